"""Crops: CURL's random crop (render larger, cut the training size) and its deterministic center crop."""

from __future__ import annotations

from collections.abc import Sequence

from tensordict.utils import NestedKey
from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params, check_parameter


def _pair(owner: str, size: int | Sequence[int]) -> tuple[int, int]:
    if isinstance(size, (str, bytes)) or not isinstance(size, (int, Sequence)) or isinstance(size, bool):
        raise TypeError(f"{owner}: size must be an int or a (height, width) pair of ints, got {type(size).__name__} {size!r}.")
    pair = (size, size) if isinstance(size, int) else tuple(size)
    if len(pair) != 2:
        raise ValueError(f"{owner}: size must be an int or a (height, width) pair of ints, got {size!r}.")
    for name, value in zip(("size[0] (height)", "size[1] (width)"), pair):
        check_parameter(owner, name, value, low=1, integer=True)
    return int(pair[0]), int(pair[1])


class _Crop(ImageAugmentation):
    needs_scale = False  # a window of input values: any float range

    def __init__(
        self,
        size: int | Sequence[int] = 84,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        *,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        self.height, self.width = _pair(type(self).__name__, size)
        super().__init__(in_keys, out_keys, max_value=max_value, seed=seed)

    def output_size(self, height: int, width: int) -> tuple[int, int]:
        if height < self.height or width < self.width:
            raise ValueError(
                f"{type(self).__name__} cuts {self.height}x{self.width} windows but the images are "
                f"{height}x{width}: render larger (e.g. make_env(..., image_size=100) as CURL does)."
            )
        return self.height, self.width

    def extra_repr(self) -> str:
        return f"size=({self.height}, {self.width})"


class RandomCrop(_Crop):
    """Cut a window at a random position, the same for all stacked frames of a sample (CURL).

    CURL renders 100×100 frames and trains on random 84×84 crops. Positions are uniform over all
    windows that fit; the output is ``[..., C, size, size]`` for any channel count and any float
    range (``needs_scale = False``), and the observation spec of an env with this transform is
    resized to match.

    Paper: CURL, https://arxiv.org/abs/2004.04136.

    Args:
        size: output ``(height, width)``, or one int for a square (positive ints).
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomCrop
        >>> RandomCrop(84, seed=0)(pixels=torch.zeros(8, 9, 100, 100, dtype=torch.uint8)).shape
        torch.Size([8, 9, 84, 84])
    """

    def make_params(self, images: Tensor) -> Params:
        height, width = self.output_size(*images.shape[-2:])
        n = images.shape[0]
        return {
            "top": self.randint(images.shape[-2] - height + 1, n, like=images),
            "left": self.randint(images.shape[-1] - width + 1, n, like=images),
        }

    def apply(self, images: Tensor, params: Params) -> Tensor:
        return functional.crop(images, params["top"], params["left"], self.height, self.width)


class CenterCrop(_Crop):
    """Cut the central window: the evaluation-time counterpart of :class:`RandomCrop` (CURL).

    Any channel count and any float range (``needs_scale = False``).

    Paper: CURL, https://arxiv.org/abs/2004.04136.

    Args:
        size: output ``(height, width)``, or one int for a square (positive ints).
        in_keys, out_keys, max_value: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import CenterCrop
        >>> CenterCrop(84)(pixels=torch.zeros(9, 100, 100)).shape
        torch.Size([9, 84, 84])
    """

    def make_params(self, images: Tensor) -> Params:
        self.output_size(*images.shape[-2:])
        return {}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        return functional.center_crop(images, self.height, self.width)

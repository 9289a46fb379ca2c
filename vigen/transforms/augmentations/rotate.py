"""DMC-GB2's random rotation: turn each sample by an angle drawn uniformly in [-degrees, degrees]."""

from __future__ import annotations

from collections.abc import Sequence

from tensordict.utils import NestedKey
from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params, check_parameter


class RandomRotate(ImageAugmentation):
    """Turn each sample about its centre by an angle drawn uniformly in ``[-degrees, degrees]`` (DMC-GB2).

    All frames of a stack turn together; pixels are sampled bilinearly and the corners the turned
    image leaves empty take the nearest edge pixel (:func:`~vigen.transforms.augmentations.functional.rotate`).
    DMC-GB2's ``random_rotate`` (its strong augmentation ``rotate``, 180°) edge-pads by 17 pixels,
    turns with torchvision's ``RandomRotation`` and centre-crops back: the same picture, except
    that torchvision draws **one angle per call** (every selected sample of a batch turns alike)
    where this draws one per sample; ``per_sample=False`` draws one angle per call as DMC-GB2 does.
    Every output pixel is a weighted mean of input pixels, so float pixels on any range work
    (``needs_scale = False``); float outputs stay within each sample's range (and ``[0, max_value]``).

    Paper: DMC-GB2 / SADA, https://arxiv.org/abs/2405.17416.

    Args:
        degrees: the largest angle, in degrees, in [0, 180] (DMC-GB2: 180).
        per_sample: one angle per sample (default) or one per call (DMC-GB2).
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomRotate
        >>> rotate = RandomRotate(180, seed=0)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> rotate(pixels=pixels).dtype
        torch.uint8
        >>> quarter = {"degrees": torch.full((4,), 90.0)}  # replay a chosen draw
        >>> torch.equal(rotate.apply(pixels, quarter), torch.rot90(pixels, 1, dims=(-2, -1)))
        True
    """

    needs_scale = False  # bilinear means of input values: any float range

    def __init__(
        self,
        degrees: float = 180.0,
        *,
        per_sample: bool = True,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        check_parameter(type(self).__name__, "degrees", degrees, low=0, high=180)
        if not isinstance(per_sample, bool):
            raise TypeError(f"{type(self).__name__}: per_sample must be True or False, got {per_sample!r}.")
        super().__init__(in_keys, out_keys, max_value=max_value, seed=seed)
        self.degrees = float(degrees)
        self.per_sample = per_sample

    def make_params(self, images: Tensor) -> Params:
        draws = self.rand(images.shape[0] if self.per_sample else 1, like=images)
        degrees = (2 * draws - 1) * self.degrees
        return {"degrees": degrees.expand(images.shape[0])}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        return functional.rotate(images, params["degrees"], self.white(images))

    def extra_repr(self) -> str:
        return f"degrees={self.degrees:g}" + ("" if self.per_sample else ", per_sample=False")

"""DrQ's random shift: replicate-pad, then translate each sample by a random integer offset."""

from __future__ import annotations

from collections.abc import Sequence

from tensordict.utils import NestedKey
from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params, check_parameter


class RandomShift(ImageAugmentation):
    """Random integer translation inside a replicate-padded border (DrQ, DrQ-v2).

    Each sample is replicate-padded by ``pad`` pixels and a window of the original size is cut
    at an offset drawn uniformly from ``{0, ..., 2·pad}²``, the same for all channels (so all
    stacked frames) of the sample. Any channel count works, e.g. TorchRL's ``GrayScale()`` then
    ``CatFrames`` (Atari-style DrQ). This is exactly what DrQ-v2's ``RandomShiftsAug`` computes with ``grid_sample``
    for its integer shifts, done as a gather (no float round trip for uint8 frames). The output
    only moves input values, so float pixels on any range work (``needs_scale = False``).

    Papers: DrQ, https://arxiv.org/abs/2004.13649; DrQ-v2, https://arxiv.org/abs/2107.09645.

    Args:
        pad: border width in pixels, an int >= 0 (DrQ-v2: 4 at 84×84).
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomShift
        >>> shift = RandomShift(pad=4, seed=0)
        >>> pixels = torch.randint(0, 256, (32, 9, 84, 84), dtype=torch.uint8)
        >>> shift(pixels=pixels).shape
        torch.Size([32, 9, 84, 84])
        >>> params = shift.make_params(pixels)  # replay a draw
        >>> torch.equal(shift.apply(pixels, params), shift.apply(pixels, params))
        True
    """

    needs_scale = False  # a gather of input values: any float range

    def __init__(
        self,
        pad: int = 4,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        *,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        check_parameter(type(self).__name__, "pad", pad, low=0, integer=True)
        super().__init__(in_keys, out_keys, max_value=max_value, seed=seed)
        self.pad = int(pad)

    def make_params(self, images: Tensor) -> Params:
        return {"offsets": self.randint(2 * self.pad + 1, images.shape[0], 2, like=images)}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        return functional.shift(images, params["offsets"], self.pad)

    def extra_repr(self) -> str:
        return f"pad={self.pad}"

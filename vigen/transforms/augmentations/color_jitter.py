"""Photometric jitter per sample: brightness, contrast, saturation and hue."""

from __future__ import annotations

from collections.abc import Sequence

from tensordict.utils import NestedKey
from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params, check_parameter


class RandomColorJitter(ImageAugmentation):
    """Random brightness, contrast, saturation and hue, drawn per sample and shared by its stacked frames.

    Factors are uniform in ``[max(0, 1 - b), 1 + b]`` for brightness, contrast and saturation,
    and the hue shift is uniform in ``[-h, h]`` turns; they are applied in that order (see
    :func:`vigen.transforms.augmentations.functional.color_jitter`). The defaults are those of RL-ViGen's
    ``RandomJitterAug`` (0.4, 0.4, 0.4, 0.5), which RL-ViGen defines but never runs. Unlike
    torchvision's ``ColorJitter`` every sample gets its own factors (one draw per call is wrong
    for RL batches); the order is fixed rather than shuffled. Saturation and hue need a pixel's
    R, G and B, so inputs are stacks of RGB frames, ``C = 3·k``; every step works on
    ``x / max_value`` clipped to [0, 1], so float pixels must be on ``[0, max_value]`` (``needs_scale``).

    Paper: RL-ViGen, https://arxiv.org/abs/2307.10224 (augmentation suite of its SVEA agent).

    Args:
        brightness, contrast, saturation: jitter strength ``b`` >= 0 (0 disables that step).
        hue: maximum hue shift in turns, in [0, 0.5].
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomColorJitter
        >>> jitter = RandomColorJitter(seed=0)
        >>> jitter(pixels=torch.rand(4, 9, 84, 84)).shape
        torch.Size([4, 9, 84, 84])
    """

    def __init__(
        self,
        brightness: float = 0.4,
        contrast: float = 0.4,
        saturation: float = 0.4,
        hue: float = 0.5,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        *,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        for name, value in (("brightness", brightness), ("contrast", contrast), ("saturation", saturation)):
            check_parameter(type(self).__name__, name, value, low=0)
        check_parameter(type(self).__name__, "hue", hue, low=0, high=0.5, hint=" Hue shifts are in turns.")
        super().__init__(in_keys, out_keys, max_value=max_value, seed=seed)
        self.brightness, self.contrast, self.saturation, self.hue = brightness, contrast, saturation, hue

    needs_rgb = True  # saturation and hue mix a pixel's R, G and B
    needs_scale = True  # every step works on x / max_value in [0, 1] and clips there

    def _factors(self, strength: float, images: Tensor) -> Tensor:
        low = max(0.0, 1.0 - strength)
        return low + (1.0 + strength - low) * self.rand(images.shape[0], like=images)

    def make_params(self, images: Tensor) -> Params:
        return {
            "brightness": self._factors(self.brightness, images),
            "contrast": self._factors(self.contrast, images),
            "saturation": self._factors(self.saturation, images),
            "hue": (2 * self.rand(images.shape[0], like=images) - 1) * self.hue,
        }

    def apply(self, images: Tensor, params: Params) -> Tensor:
        return functional.color_jitter(
            images, params["brightness"], params["contrast"], params["saturation"], params["hue"], self.white(images)
        )

    def extra_repr(self) -> str:
        return f"brightness={self.brightness}, contrast={self.contrast}, saturation={self.saturation}, hue={self.hue}"

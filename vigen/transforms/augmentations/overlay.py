"""SVEA's random overlay: blend each observation with a natural image."""

from __future__ import annotations

import os
from collections.abc import Sequence

import torch
from tensordict.utils import NestedKey
from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params, check_parameter
from vigen.assets.image_bank import ImageBank, check_image_folder


def check_overlay(name: str, alpha: float, images: ImageBank | str | os.PathLike | None) -> None:
    """Check an overlay's blend weight ``alpha`` (in [0, 1]) and its ``images`` (a bank, a folder or ``None``), naming ``name``.

    Examples:
        >>> check_overlay("RandomOverlay", 0.5, None)
        >>> check_overlay("RandomOverlay", "/data/places", None)
        Traceback (most recent call last):
        ...
        TypeError: RandomOverlay: alpha is the blend weight, got str '/data/places'; pass images='/data/places' for the overlay images.
    """
    if isinstance(alpha, (str, bytes, os.PathLike, ImageBank)):
        raise TypeError(f"{name}: alpha is the blend weight, got {type(alpha).__name__} {alpha!r}; "
                        f"pass images={alpha!r} for the overlay images.")
    check_parameter(name, "alpha", alpha, low=0, high=1)
    if images is not None and not isinstance(images, (ImageBank, str, os.PathLike)):
        raise TypeError(f"{name}: images must be an ImageBank, a folder path or None, got {type(images).__name__}.")
    if isinstance(images, (str, os.PathLike)):
        check_image_folder(images, owner=name)


class RandomOverlay(ImageAugmentation):
    """Blend every sample with a random image from a bank: ``(1 - α)·x + α·I`` (SVEA).

    Each sample gets its own image ``I``, the same over all of its stacked frames, as in DMC-GB's
    and RL-ViGen's ``random_overlay`` (α = 0.5). The bank is loaded once, on first use, and
    resized once per image size. By default it is :meth:`ImageBank.builtin` (no download); pass a
    folder (Places365 in ``ImageFolder`` layout, or any folder of images) for the papers' setting.
    Unlike DMC-GB, images are not re-cropped (``RandomResizedCrop``) at every draw. The images
    are RGB, blended into each RGB frame of a stack, so inputs have ``C = 3·k`` channels, and
    scaled to the frames' white level, so float inputs must be on ``[0, max_value]`` (``needs_scale``).

    Paper: SVEA, https://arxiv.org/abs/2107.00644.

    Args:
        alpha: weight of the overlaid image, in [0, 1].
        images: an :class:`ImageBank`, a folder of images, or ``None`` for the built-in bank.
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    All arguments but ``alpha`` are keyword-only: a folder goes in ``images=``.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomOverlay
        >>> overlay = RandomOverlay(alpha=0.5, seed=0)
        >>> overlay(pixels=torch.zeros(4, 9, 84, 84, dtype=torch.uint8)).float().mean() > 0
        tensor(True)
    """

    def __init__(
        self,
        alpha: float = 0.5,
        *,
        images: ImageBank | str | os.PathLike | None = None,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        check_overlay(type(self).__name__, alpha, images)
        super().__init__(in_keys, out_keys, max_value=max_value, seed=seed)
        self.alpha = alpha
        self._images = images

    needs_rgb = True  # RGB images blended into RGB frames
    needs_scale = True  # the images are brought to the frames' white level before the blend

    @property
    def bank(self) -> ImageBank:
        """The image bank, loaded on first access."""
        self._images = ImageBank.load(self._images)
        return self._images

    def prepare(self, shape: torch.Size, device: torch.device) -> None:
        self.bank.resized(*shape[-2:], device=device)

    def make_params(self, images: Tensor) -> Params:
        return {"index": self.randint(len(self.bank), images.shape[0], like=images)}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        white = self.white(images)
        backgrounds = self.bank.resized(*images.shape[-2:], device=images.device)[params["index"]]
        return functional.overlay(images, self.at_white(backgrounds, images.dtype, white), self.alpha, white)

    @staticmethod
    def at_white(backgrounds: Tensor, dtype: torch.dtype, white: float) -> Tensor:
        """The bank's uint8 ``backgrounds`` on the frames' scale: as they are for uint8 frames, else floats ``× white / 255``."""
        return backgrounds if backgrounds.dtype == dtype and white == 255 else backgrounds.float() * (white / 255)

    def image_source(self) -> str:
        """Where the images come from, for ``repr``: the bank, the folder, or ``builtin``."""
        return str(self._images if isinstance(self._images, ImageBank) else (self._images or "builtin"))

    def extra_repr(self) -> str:
        return f"alpha={self.alpha}, images={self.image_source()}"

"""The one pixel contract of vigen's transforms, networks and losses, and its cheap check.

A pixel tensor is ``[..., C, H, W]`` (channels first, any leading batch dims) and either

* ``uint8`` on ``[0, 255]``, or
* floating point on ``[0, max_value]``, with ``max_value = 1.0`` unless the caller says otherwise
  (TorchRL's ``ToTensorImage()`` scale). Float pixels on the 0–255 scale are declared with
  ``max_value=255`` on the transform, the encoder or the loss that reads them.

:func:`check_pixels` enforces this before any work starts. It costs one ``amax`` over a float
batch (nothing for uint8) and raises with the fix instead of letting wrongly scaled or
channels-last images turn into white frames or silently wrong features.
"""

from __future__ import annotations

import torch
from torch import Tensor

PIXEL_DTYPES = (torch.uint8, torch.float16, torch.bfloat16, torch.float32, torch.float64)
RGB_CHANNELS = 3
# how far above max_value a float pixel may be before the scale is judged wrong (rounding slack)
SCALE_TOLERANCE = 1e-3


def white_value(images: Tensor, max_value: float | None = None) -> float:
    """The value of a white pixel: ``max_value`` if given, else 255 for uint8 and 1.0 for floats.

    Examples:
        >>> import torch
        >>> white_value(torch.zeros(3, 2, 2, dtype=torch.uint8)), white_value(torch.zeros(3, 2, 2))
        (255.0, 1.0)
        >>> white_value(torch.zeros(3, 2, 2), max_value=255)
        255.0
    """
    if max_value is not None:
        return float(max_value)
    return 1.0 if images.dtype.is_floating_point else float(torch.iinfo(images.dtype).max)


def looks_channels_last(shape: torch.Size | tuple[int, ...]) -> bool:
    """Whether ``[..., A, B, C]`` looks like ``[..., H, W, C]``: a small last dim beside a much larger first one.

    Channels-first stacks have ``C`` at most a few dozen and ``W`` rarely below ``C / 4``; HWC
    frames (``84 × 84 × 3·k``) have a last dim far below their height.

    Examples:
        >>> looks_channels_last((84, 84, 9)), looks_channels_last((9, 84, 84)), looks_channels_last((9, 8, 8))
        (True, False, False)
    """
    return len(shape) >= 3 and shape[-1] <= 16 and shape[-3] >= 4 * shape[-1]


def check_pixels(
    images: Tensor,
    *,
    name: str,
    max_value: float | None = None,
    rgb: bool = False,
) -> None:
    """Raise a ``TypeError``/``ValueError`` naming the fix if ``images`` breaks the pixel contract.

    Args:
        images: ``[..., C, H, W]`` pixels.
        name: who checks (a class name), put at the start of the message.
        max_value: the declared white of float pixels (``None``: 1.0); uint8 is always 0–255.
        rgb: the caller needs RGB frame stacks, ``C = 3·k``.

    Examples:
        >>> import torch
        >>> check_pixels(torch.rand(2, 9, 8, 8), name="Demo")
        >>> check_pixels(torch.full((2, 9, 8, 8), 200.0), name="Demo")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        ValueError: Demo: float pixels reach 200, above max_value 1; these look like 0–255 pixels: pass max_value=255, ...
    """
    if images.dtype not in PIXEL_DTYPES:
        raise TypeError(f"{name} takes uint8 or floating-point pixels, got {images.dtype}; "
                        "convert them with .to(torch.uint8) (0–255) or .float() / 255 (0–1).")
    if images.ndim < 3:
        raise ValueError(f"{name} takes channels-first pixels [..., C, H, W], got shape {tuple(images.shape)}.")
    if looks_channels_last(images.shape):
        raise ValueError(
            f"{name} takes channels-first pixels [..., C, H, W], got shape {tuple(images.shape)}, which looks "
            "channels-last [..., H, W, C]: put TorchRL's ToTensorImage() (or PermuteTransform) before it, "
            "or call .movedim(-1, -3)."
        )
    if rgb and images.shape[-3] % RGB_CHANNELS:
        raise ValueError(
            f"{name} works on RGB colours, so it needs stacks of RGB frames with 3·k channels, got "
            f"{images.shape[-3]} channels (shape {tuple(images.shape)}). Apply it before GrayScale(), or use an "
            "augmentation that works on any channel count (RandomShift, RandomCrop, RandomFrequencyMask, noise, blur)."
        )
    if images.dtype.is_floating_point and images.numel():
        white = white_value(images, max_value)
        peak = float(images.amax())
        if peak > white * (1 + SCALE_TOLERANCE):
            hint = ("these look like 0–255 pixels: pass max_value=255, or divide them by 255 "
                    "(TorchRL's ToTensorImage() gives 0–1)") if white == 1.0 else "clamp them or declare the right max_value"
            raise ValueError(f"{name}: float pixels reach {peak:g}, above max_value {white:g}; {hint}.")

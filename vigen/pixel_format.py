"""The one pixel contract of vigen's transforms, networks and losses, and its cheap check.

A pixel tensor is ``[..., C, H, W]`` (channels first, any leading batch dims) and either

* ``uint8`` on ``[0, 255]``, or
* floating point.

The value scale of float pixels matters only to a reader whose math assumes a white level:
a blend with an image, a convolution squashed back to the range, a colour change, noise of a
given strength, an encoder's normalization. Such a reader (``needs_scale=True``, the default)
takes float pixels on ``[0, max_value]``, with ``max_value = 1.0`` unless the caller says
otherwise (TorchRL's ``ToTensorImage()`` scale); float pixels on the 0–255 scale are declared with
``max_value=255`` on the transform, the encoder or the loss that reads them. A reader whose
output only moves, interpolates or zeroes the input's values (a shift, a crop, a rotation, a
zero-filled frequency mask) does not depend on the scale (``needs_scale=False``): it takes float
pixels on any range, such as normalized observations or TorchRL's mock envs' ``randn`` frames.

:func:`check_pixels` enforces this before any work starts. It costs one ``amax`` over a float
batch (nothing for uint8) and raises with the fix instead of letting wrongly scaled or
channels-last images turn into white frames or silently wrong features. A NaN or +inf maximum
is refused on every scale.
"""

from __future__ import annotations

import math
import numbers

import torch
from torch import Tensor

from vigen.devices import host_reads_are_free

PIXEL_DTYPES = (torch.uint8, torch.float16, torch.bfloat16, torch.float32, torch.float64)
RGB_CHANNELS = 3
# how far above max_value a float pixel may be before the scale is judged wrong (rounding slack)
SCALE_TOLERANCE = 1e-3
# the largest last dim still taken for a channel count when judging a layout
MAX_CHANNELS_LAST = 16


def check_max_value(owner: str, max_value: object) -> float | None:
    """``max_value`` (the white of float pixels) as a float, after checking it; ``None`` stays ``None`` (1.0).

    Every transform, encoder and loss that takes ``max_value`` checks it here, before any work.

    Examples:
        >>> check_max_value("Demo", 255), check_max_value("Demo", None)
        (255.0, None)
        >>> check_max_value("Demo", 0)
        Traceback (most recent call last):
        ...
        ValueError: Demo: max_value is the white of float pixels and must be a positive number (or None for 1.0), got 0; use 255 for float pixels on the 0–255 scale.
    """
    if max_value is None:
        return None
    if isinstance(max_value, bool) or not isinstance(max_value, numbers.Real) or not (math.isfinite(max_value) and max_value > 0):
        raise ValueError(f"{owner}: max_value is the white of float pixels and must be a positive number (or None for 1.0), "
                         f"got {max_value!r}; use 255 for float pixels on the 0–255 scale.")
    return float(max_value)


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
    """Whether ``[..., A, B, C]`` looks like ``[..., H, W, C]`` rather than ``[..., C, H, W]``.

    Square channels-first frames (``B == C``) are channels first. Otherwise the shape is judged
    channels-last when its last dim is a plausible channel count (at most 16) below both others,
    as in ``84 × 84 × 3·k`` or ``16 × 16 × 9``; a channels-first stack never has fewer columns
    than channels unless its frames are narrower than they are few.

    Examples:
        >>> looks_channels_last((84, 84, 9)), looks_channels_last((16, 16, 9)), looks_channels_last((64, 96, 3))
        (True, True, True)
        >>> looks_channels_last((9, 84, 84)), looks_channels_last((9, 8, 8)), looks_channels_last((3, 64, 96))
        (False, False, False)
    """
    if len(shape) < 3:
        return False
    first, middle, last = (int(d) for d in shape[-3:])
    if middle == last:
        return False
    return last <= MAX_CHANNELS_LAST and last < first and last < middle


def check_pixel_layout(
    shape: torch.Size | tuple[int, ...],
    dtype: torch.dtype,
    *,
    name: str,
    max_value: float | None = None,
    rgb: bool = False,
) -> None:
    """Everything :func:`check_pixels` checks without reading a value: dtype, layout, channels, declared scale.

    Use it on a spec (``spec.shape``, ``spec.dtype``) to fail when an env is built rather than at
    its first step.

    Args:
        shape: ``[..., C, H, W]``.
        dtype: the pixels' dtype.
        name: who checks (a class name), put at the start of the message.
        max_value: the declared white of float pixels (``None``: 1.0); uint8 pixels are 0–255,
            so only ``None`` or 255 fit them.
        rgb: the caller needs RGB frame stacks, ``C = 3·k``.

    Examples:
        >>> import torch
        >>> check_pixel_layout((9, 84, 84), torch.uint8, name="Demo", rgb=True)
        >>> check_pixel_layout((84, 84, 9), torch.uint8, name="Demo")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        ValueError: Demo takes channels-first pixels [..., C, H, W], got shape (84, 84, 9), which looks channels-last ...
    """
    shape = tuple(shape)
    if dtype not in PIXEL_DTYPES:
        raise TypeError(f"{name} takes uint8 or floating-point pixels, got {dtype}; "
                        "convert them with .to(torch.uint8) (0–255) or .float() / 255 (0–1).")
    if len(shape) < 3:
        raise ValueError(f"{name} takes channels-first pixels [..., C, H, W], got shape {shape}.")
    if looks_channels_last(shape):
        raise ValueError(
            f"{name} takes channels-first pixels [..., C, H, W], got shape {shape}, which looks "
            "channels-last [..., H, W, C]: put TorchRL's ToTensorImage() (or PermuteTransform) before it, "
            "or call .movedim(-1, -3)."
        )
    if rgb and shape[-3] % RGB_CHANNELS:
        raise ValueError(
            f"{name} works on RGB colours, so it needs stacks of RGB frames with 3·k channels, got "
            f"{shape[-3]} channels (shape {shape}). Apply it before GrayScale(), or use an "
            "augmentation that works on any channel count (RandomShift, RandomCrop, RandomFrequencyMask, noise, blur)."
        )
    if not dtype.is_floating_point and max_value is not None and float(max_value) != float(torch.iinfo(dtype).max):
        raise ValueError(
            f"{name}: uint8 pixels are always on 0–255, but max_value={max_value} was declared; max_value "
            "describes float pixels only: leave it None (or 255) for uint8 input."
        )


def check_pixels(
    images: Tensor,
    *,
    name: str,
    max_value: float | None = None,
    rgb: bool = False,
    scan: bool | None = None,
    needs_scale: bool = True,
) -> None:
    """Raise a ``TypeError``/``ValueError`` naming the fix if ``images`` breaks the pixel contract.

    Checks what :func:`check_pixel_layout` checks, then, for float pixels only, their maximum
    (one ``amax``): it must be finite (no NaN, no +inf) and, if the caller ``needs_scale``, not
    above ``max_value``. Values below 0 are not looked for.

    The value scan reads a number back from the tensor's device: on an accelerator that is a host
    synchronization, and ``torch.compile`` cannot trace it. So it never runs while compiling, and
    by default (``scan=None``) only where reading values back is free
    (:func:`~vigen.devices.host_reads_are_free`: CPU tensors); ``scan=True`` scans on any device
    outside ``torch.compile`` (a loss scans its first float batch so), ``scan=False`` checks the
    layout only.

    Args:
        images: ``[..., C, H, W]`` pixels.
        name: who checks (a class name), put at the start of the message.
        max_value: the declared white of float pixels (``None``: 1.0); uint8 is always 0–255.
        rgb: the caller needs RGB frame stacks, ``C = 3·k``.
        scan: look at the float values (``None``: where host reads are free; never while compiling).
        needs_scale: the caller's math assumes that ``max_value`` is white, so float values above
            it are refused; ``False`` (shifts, crops, rotations, zero fills) takes any float range.

    Examples:
        >>> import torch
        >>> check_pixels(torch.rand(2, 9, 8, 8), name="Demo")
        >>> check_pixels(torch.rand(2, 9, 8, 8) * 255, name="Demo")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        ValueError: Demo: float pixels reach 2..., above max_value 1.0, and its math assumes pixels on [0, max_value]; for 0–255 pixels pass max_value=255, ...
        >>> check_pixels(torch.randn(2, 9, 8, 8) * 255, name="Demo", needs_scale=False)  # a shift takes any range
    """
    if not isinstance(images, Tensor):
        raise TypeError(f"{name} takes pixels as a torch.Tensor, got {type(images).__name__}.")
    check_pixel_layout(images.shape, images.dtype, name=name, max_value=max_value, rgb=rgb)
    if scan is None:
        scan = host_reads_are_free(images)
    if scan and images.dtype.is_floating_point and images.numel() and not torch.compiler.is_compiling():
        white = white_value(images, max_value)
        peak = float(images.detach().amax())
        if not math.isfinite(peak):
            raise ValueError(f"{name}: float pixels hold NaN or inf values; check the env or buffer that made them.")
        if needs_scale and peak > white * (1 + SCALE_TOLERANCE):
            hint = ("for 0–255 pixels pass max_value=255, or divide them by 255 (TorchRL's ToTensorImage() gives 0–1); "
                    "bring normalized pixels back to [0, 1] first") if white == 1.0 else "clamp them or declare the right max_value"
            raise ValueError(f"{name}: float pixels reach {peak:g}, above max_value {white}, and its math assumes "
                             f"pixels on [0, max_value]; {hint}.")

"""The checks the networks share: layer counts and widths at construction, the frame stack at the input.

Examples:
    >>> import torch
    >>> check_sizes("Demo", ("channels", 32, 1), ("blocks", 0, 0))
    >>> check_sizes("Demo", ("channels", 2.5, 1))
    Traceback (most recent call last):
    ...
    ValueError: Demo: channels must be an int >= 1, got 2.5.
    >>> check_stack("Demo", torch.zeros(2, 6, 8, 8, dtype=torch.uint8), in_channels=9, max_value=None)
    Traceback (most recent call last):
    ...
    ValueError: Demo was built for stacks of 9 channels, got shape (2, 6, 8, 8); build it with in_channels=6.
"""

from __future__ import annotations

import numbers

from torch import Tensor

from vigen.pixel_format import check_pixels


def check_sizes(owner: str, *sizes: tuple[str, object, int]) -> None:
    """Raise a ValueError naming ``owner`` and the argument unless each ``(argument, value, least)`` is an int >= least."""
    for argument, value, least in sizes:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < least:
            raise ValueError(f"{owner}: {argument} must be an int >= {least}, got {value!r}.")


def check_stack(owner: str, pixels: Tensor, in_channels: int, max_value: float | None) -> None:
    """Raise unless ``pixels`` keep vigen's pixel contract at ``max_value`` and stack the ``in_channels`` ``owner`` was built for."""
    check_pixels(pixels.detach(), name=owner, max_value=max_value)
    if pixels.shape[-3] != in_channels:
        raise ValueError(f"{owner} was built for stacks of {in_channels} channels, got shape {tuple(pixels.shape)}; "
                         f"build it with in_channels={pixels.shape[-3]}.")

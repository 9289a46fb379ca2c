"""The constructor check every network shares: layer counts and widths are ints at or above their least value.

Examples:
    >>> check_sizes("Demo", ("channels", 32, 1), ("blocks", 0, 0))
    >>> check_sizes("Demo", ("channels", 2.5, 1))
    Traceback (most recent call last):
    ...
    ValueError: Demo: channels must be an int >= 1, got 2.5.
"""

from __future__ import annotations

import numbers


def check_sizes(owner: str, *sizes: tuple[str, object, int]) -> None:
    """Raise a ValueError naming ``owner`` and the argument unless each ``(argument, value, least)`` is an int >= least."""
    for argument, value, least in sizes:
        if isinstance(value, bool) or not isinstance(value, numbers.Integral) or value < least:
            raise ValueError(f"{owner}: {argument} must be an int >= {least}, got {value!r}.")

"""Intensity sweeps: one factor of variation at several intensities, as the Distracting Control Suite reports them.

A sweep is a list of generalization dicts, one per intensity, that :func:`~vigen.evaluation.evaluate`
takes as levels (``levels=["train", *sweep("camera_rotation", [0.1, 0.3])]``) and
:func:`~vigen.evaluation.plot_intensity` draws as a robustness curve (return against intensity).
The Distracting Control Suite (Stone et al. 2021, https://arxiv.org/abs/2101.02722) evaluates at
the intensities 0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4 and 0.5 (:data:`DCS_INTENSITIES`).
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Mapping, Sequence
from typing import Any

from vigen.envs import level_label

DCS_INTENSITIES: tuple[float, ...] = (0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5)
"""The Distracting Control Suite's difficulty scale ``s`` (its benchmark uses 0.1 / 0.2 / 0.3 as easy / medium / hard)."""


class SweepPoint(dict):
    """One level of a sweep: a generalization dict that also remembers which factor was swept.

    It is a plain ``dict`` for :func:`vigen.envs.make_env`; :func:`~vigen.evaluation.evaluate`
    reads :attr:`factor` so that rows of a sweep with ``fixed`` factors still carry the swept
    factor and its intensity.

    Examples:
        >>> from vigen.evaluation.sweep import SweepPoint
        >>> point = SweepPoint("camera_rotation", {"camera_rotation": 0.3, "object_color": 0.5})
        >>> point.factor, point.intensity, point.fixed, dict(point) == {"camera_rotation": 0.3, "object_color": 0.5}
        ('camera_rotation', 0.3, {'object_color': 0.5}, True)
    """

    def __init__(self, factor: str, generalization: Mapping[str, float]) -> None:
        if factor not in generalization:
            raise ValueError(f"SweepPoint: the swept factor {factor!r} is not in the generalization dict {dict(generalization)}.")
        super().__init__(generalization)
        self.factor = factor

    @property
    def intensity(self) -> float:
        """The swept factor's intensity."""
        return float(self[self.factor])

    @property
    def fixed(self) -> dict[str, float]:
        """The factors held fixed along the sweep."""
        return {name: value for name, value in self.items() if name != self.factor}

    def __reduce__(self) -> tuple[Any, ...]:
        return SweepPoint, (self.factor, dict(self))

    def __repr__(self) -> str:
        return f"SweepPoint({self.factor!r}, {dict(self)!r})"


def check_factor_intensity(name: str, value: Any, *, argument: str) -> float:
    """``value`` as a float in [0, 1], or an error naming ``argument`` and the factor.

    Examples:
        >>> from vigen.evaluation.sweep import check_factor_intensity
        >>> check_factor_intensity("camera_rotation", 1, argument="intensities")
        1.0
    """
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise TypeError(f"{argument}: the intensity of {name!r} must be a number in [0, 1], got {value!r} "
                        f"({type(value).__name__}).")
    if math.isnan(value) or not 0.0 <= float(value) <= 1.0:
        raise ValueError(f"{argument}: the intensity of {name!r} must be in [0, 1] (0: the factor off, 1: its strongest "
                         f"setting), got {value}.")
    return float(value)


def _check_name(name: Any, argument: str) -> str:
    if not isinstance(name, str) or not name:
        raise TypeError(f"{argument} must be a factor name such as 'camera_rotation' (see vigen.envs.factors(suite)), "
                        f"got {name!r}.")
    if "=" in name or "+" in name:
        raise ValueError(f"{argument} {name!r} is a level label, not a factor name; give the name alone, e.g. "
                         f"'camera_rotation', and the intensities separately.")
    return name


def sweep(factor: str, intensities: Sequence[float], *, fixed: Mapping[str, float] | None = None) -> list[dict[str, float]]:
    """One generalization dict per intensity of ``factor``, each with the ``fixed`` factors added.

    Intensity 0 leaves the factor off (the point is kept, so the curve starts at the clean scene).
    Factor names are checked against the suite by :func:`~vigen.evaluation.evaluate` (or
    :func:`vigen.envs.make_env`), which knows which suite the levels are for.

    Args:
        factor: the factor to sweep, e.g. ``"camera_rotation"`` (``vigen.envs.factors(suite)`` lists them).
        intensities: distinct intensities in [0, 1], e.g. :data:`DCS_INTENSITIES`.
        fixed: other factors held at one intensity along the whole sweep.

    Returns:
        A list of :class:`SweepPoint` (plain dicts that also remember the swept factor).

    Examples:
        >>> from vigen.evaluation import sweep
        >>> [dict(level) for level in sweep("camera_rotation", [0, 0.1, 0.3])]
        [{'camera_rotation': 0.0}, {'camera_rotation': 0.1}, {'camera_rotation': 0.3}]
        >>> [dict(level) for level in sweep("camera_rotation", [0.1], fixed={"object_color": 0.5})]
        [{'camera_rotation': 0.1, 'object_color': 0.5}]
        >>> sweep("camera_rotation", [0.1, 1.5])
        Traceback (most recent call last):
        ...
        ValueError: intensities: the intensity of 'camera_rotation' must be in [0, 1] (0: the factor off, 1: its strongest setting), got 1.5.
    """
    factor = _check_name(factor, "factor")
    if isinstance(intensities, (str, bytes)) or not isinstance(intensities, Sequence):
        raise TypeError(f"intensities must be a list of numbers in [0, 1], e.g. [0, 0.1, 0.3], got {intensities!r}.")
    if not intensities:
        raise ValueError(f"intensities is empty: give at least one intensity of {factor!r} in [0, 1], e.g. [0, 0.1, 0.3].")
    values = [check_factor_intensity(factor, value, argument="intensities") for value in intensities]
    repeated = sorted({value for value in values if values.count(value) > 1})
    if repeated:
        raise ValueError(f"intensities repeat {repeated}: each intensity would give the same level twice; list each once.")
    if fixed is not None and not isinstance(fixed, Mapping):
        raise TypeError(f"fixed must be a dict of factor -> intensity, e.g. {{'object_color': 0.5}}, got {fixed!r}.")
    held = {_check_name(name, "fixed"): check_factor_intensity(name, value, argument="fixed")
            for name, value in (fixed or {}).items()}
    if factor in held:
        raise ValueError(f"fixed holds {factor!r}, the factor being swept; drop it from fixed.")
    return [SweepPoint(factor, {factor: value, **held}) for value in values]


def level_columns(level: str | Mapping[str, float]) -> dict[str, Any]:
    """The columns an evaluation row of ``level`` carries besides its label: none for a named level;
    ``factor`` and ``intensity`` for a generalization dict.

    ``factor`` is the swept factor (a :class:`SweepPoint`) or the dict's one factor, with its
    ``intensity``; a plain dict of several factors gets their names joined by ``+`` and a blank
    intensity. A sweep with fixed factors also gets ``fixed``, their label.

    Examples:
        >>> from vigen.evaluation.sweep import level_columns, sweep
        >>> level_columns("color_hard"), level_columns({"camera_rotation": 0.3})
        ({}, {'factor': 'camera_rotation', 'intensity': 0.3})
        >>> level_columns({"object_color": 0.5, "camera_rotation": 0.3})
        {'factor': 'camera_rotation+object_color', 'intensity': ''}
        >>> level_columns(sweep("camera_rotation", [0.3], fixed={"object_color": 0.5})[0])
        {'factor': 'camera_rotation', 'intensity': 0.3, 'fixed': 'object_color=0.5'}
    """
    if isinstance(level, str):
        return {}
    if isinstance(level, SweepPoint):
        columns: dict[str, Any] = {"factor": level.factor, "intensity": level.intensity}
        return {**columns, "fixed": level_label(level.fixed)} if level.fixed else columns
    if len(level) == 1:
        (name, value), = level.items()
        return {"factor": name, "intensity": float(value)}
    return {"factor": "+".join(sorted(level)), "intensity": ""}

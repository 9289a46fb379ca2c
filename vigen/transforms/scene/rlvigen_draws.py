"""RL-ViGen's per-episode draws on its DMC and locomotion tasks: one ``RandomState(seed)``, drawn in ``ColorWrapper.reset``'s order.

RL-ViGen's ``ColorWrapper`` (``envs/DMCVGB/dmcvgb/wrappers.py``) holds one ``np.random.RandomState(seed)``
per env, seeded with the env seed (line 20), and at every reset draws from it, in this order, for
the knobs its config sets (``envs/DMCVGB/cfg/config.yaml``):

1. ``background`` colour: ``randint(100)``, one of DMC-GB's ``color_{difficulty}`` presets (lines 45-52);
2. ``objects_color``: ``randint(100)``, one of ``color_{objects_color}``'s presets (lines 53-56);
3. ``table_texture`` (Unitree ground, Franka table): ``randint(10)`` (``reload_physics``, lines 127-138);
4. ``light_position``: ``randint(3, 5)`` or ``randint(9, 11)`` per light and coordinate (lines 80-83);
5. ``light_color``: ``uniform(-0.2, 0.2)`` or ``uniform(-10, 10)`` per light and channel (lines 84-88).

A knob left at ``original`` draws nothing. One knob alone is therefore DMC-GB's draw, one
``randint(100)`` per reset. With several knobs, the draws interleave, so a transform that shows
one knob replays the whole sequence (:meth:`RLViGenDraws.episode`) and keeps its own part: every
transform of a level holds its own ``RandomState`` and they all agree without sharing one.

Examples:
    >>> import numpy as np
    >>> draws = RLViGenDraws(background=True, objects=True, texture=True, light_position=(3, 4), light_color=0.2)
    >>> first = draws.episode(np.random.RandomState(0), nlight=2)
    >>> first["background"], first["objects"], first["texture"]
    (44, 47, 5)
    >>> first["light_position"].shape, first["light_color"].shape
    ((2, 3), (2, 3))
    >>> RLViGenDraws(objects=True).episode(np.random.RandomState(0), nlight=2)  # one knob: DMC-GB's draw
    {'objects': 44}
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

NUM_PRESETS = 100
"""The presets of DMC-GB's ``color_easy.pt`` / ``color_hard.pt``, which RL-ViGen loads (``wrappers.py:105-108``)."""

NUM_TEXTURES = 10
"""RL-ViGen's textures per level (``table_easy0`` ... ``table_easy9``, ``table_hard0`` ... ``table_hard9``)."""

KNOBS = ("background", "objects", "texture", "light_position", "light_color")
"""RL-ViGen's knobs that draw at reset, in the order ``ColorWrapper.reset`` draws them."""


@dataclass(frozen=True)
class RLViGenDraws:
    """Which of RL-ViGen's knobs draw at each reset, i.e. its config: the draws of one episode, in its order.

    Args:
        background: the ``background`` colour is on (``type: color``).
        objects: ``objects_color`` is on.
        texture: ``table_texture`` is on (the Unitree's ground, the Franka's table).
        light_position: vigen's inclusive offset range, ``(3, 4)`` (easy) or ``(9, 10)`` (hard), or ``None``.
        light_color: the half-width of the diffuse offset, 0.2 (easy) or 10 (hard), or ``None``.
    """

    background: bool = False
    objects: bool = False
    texture: bool = False
    light_position: tuple[int, int] | None = None
    light_color: float | None = None

    def __post_init__(self) -> None:
        if self.light_position is not None:
            object.__setattr__(self, "light_position", tuple(int(value) for value in self.light_position))

    def knobs(self) -> tuple[str, ...]:
        """The knobs that draw, in RL-ViGen's order."""
        on = {"background": self.background, "objects": self.objects, "texture": self.texture,
              "light_position": self.light_position is not None, "light_color": self.light_color is not None}
        return tuple(knob for knob in KNOBS if on[knob])

    def episode(self, state: np.random.RandomState, nlight: int) -> dict[str, Any]:
        """One reset's draws from ``state``, as ``ColorWrapper.reset`` makes them (``nlight``: the scene's lights)."""
        draws: dict[str, Any] = {}
        if self.background:
            draws["background"] = int(state.randint(NUM_PRESETS))
        if self.objects:
            draws["objects"] = int(state.randint(NUM_PRESETS))
        if self.texture:
            draws["texture"] = int(state.randint(NUM_TEXTURES))
        if self.light_position is not None:
            low, high = self.light_position
            draws["light_position"] = state.randint(low, high + 1, size=(nlight, 3))
        if self.light_color is not None:
            draws["light_color"] = state.uniform(-self.light_color, self.light_color, size=(nlight, 3))
        return draws


def check_draws(draws: Any, knob: str, owner: str) -> RLViGenDraws | None:
    """``draws`` if it is ``None`` or an :class:`RLViGenDraws` with ``knob`` on; a clear error otherwise."""
    if draws is None:
        return None
    if not isinstance(draws, RLViGenDraws):
        raise TypeError(f"{owner}: rlvigen_draws is an RLViGenDraws (the knobs RL-ViGen's config sets) or None, got {draws!r}.")
    if knob not in draws.knobs():
        raise ValueError(f"{owner}: rlvigen_draws={draws!r} does not draw {knob!r}, the knob this transform shows; "
                         f"turn it on (RLViGenDraws({knob}=...)).")
    return draws

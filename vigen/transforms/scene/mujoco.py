"""MuJoCo helpers the scene perturbations share: names to ids, texture pixels, geom and material names."""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np


def named_id(model: Any, kind: mujoco.mjtObj, name: str) -> int:
    """The id of the model's ``kind`` object called ``name``; a clear error if there is none.

    Examples:
        >>> import mujoco
        >>> model = mujoco.MjModel.from_xml_string('<mujoco><worldbody><geom name="floor" type="plane" size="1 1 1"/></worldbody></mujoco>')
        >>> named_id(model, mujoco.mjtObj.mjOBJ_GEOM, "floor")
        0
    """
    index = mujoco.mj_name2id(model, kind, name)
    if index < 0:
        raise ValueError(f"The scene has no {kind.name[6:].lower()} named {name!r}; this perturbation needs one.")
    return index


def texture_pixels(model: Any, texture: int) -> np.ndarray:
    """A writable view of one texture's pixels in ``model.tex_data``."""
    start = model.tex_adr[texture]
    size = model.tex_width[texture] * model.tex_height[texture] * model.tex_nchannel[texture]
    return model.tex_data[start : start + size]

"""DMC-GB2's video screen: a lit, textured box behind the agent that shows the video inside the scene.

DMC-GB2 (aalmuzairee/dmcgb2, ``envs/dmcgb/dmcgb_photometric.py``) does not composite its videos into the
frame: ``_reformat_xml`` adds a ``projector`` texture and material and a box site ``video_screen`` to the
domain's XML and recompiles it; each step it writes the current video frame (resized to 256 × 256) into
that texture, re-uploads it (``_apply_video``), and for walker and cheetah moves the box to follow the
torso's centre of mass (``_move_backcube``, lines 98-104). The box is lit and shaded like any object,
is seen from the side by a turned camera, and leaves the sky around it.

:class:`VideoScreen` does the same to a dm_control physics. The box moves after the physics step, so
the frame must be rendered again after the move (the env rendered its own before): the screen costs
one extra render per step (see ``DMCGB2VideoBackground(screen=True)``).
"""

from __future__ import annotations

import xml.etree.ElementTree as ElementTree
from types import MappingProxyType
from typing import Any

import mujoco
import numpy as np

from vigen.transforms.scene.mujoco import named_id, texture_pixels

SCREEN = "video_screen"
PROJECTOR = "projector"
TEXTURE_SIZE = 256
"""The side of the square video texture (``ColorVideoWrapper(video_render_size=256)``, ``dmcgb_wrapper.py:31``)."""

SCREEN_BOXES = MappingProxyType({
    # domain: (half sizes, position, euler in degrees), as _reformat_xml's site_dicts place the box
    "walker": ((1.86, 0.1, 1.86), (0.0, 1.96, -0.7), (-30.0, 0.0, 0.0)),
    "cheetah": ((1.86, 0.1, 1.86), (0.0, 1.6, -0.7), (0.0, 0.0, 0.0)),
    "cartpole": ((1.86, 0.1, 1.86), (0.0, 0.5, 1.0), (0.0, 0.0, 0.0)),
    "ball_in_cup": ((0.66, 0.1, 0.66), (0.0, 0.5, 0.05), (-27.0, 0.0, 0.0)),
    "finger": ((0.66, 0.1, 0.66), (0.0, 0.5, 0.05), (-27.0, 0.0, 0.0)),
})
"""DMC-GB2's screen box per domain."""

FOLLOW_TORSO = MappingProxyType({"walker": (0.0, -1.07), "cheetah": (-0.05, 0.15)})
"""Domains whose screen follows the torso's subtree centre of mass: (x offset, z offset) (lines 47-50)."""


def check_screen_domain(domain: Any, owner: str) -> str:
    """``domain`` if DMC-GB2 has a screen for it (``"cup"`` means ``"ball_in_cup"``), else a clear error."""
    name = {"cup": "ball_in_cup"}.get(domain, domain)
    if name not in SCREEN_BOXES:
        raise ValueError(f"{owner}: DMC-GB2's video screen exists for the domains {tuple(SCREEN_BOXES)}, got domain={domain!r}.")
    return name


def xml_with_screen(xml: str, domain: str) -> str:
    """The domain's MJCF with DMC-GB2's projector texture, its material and the ``video_screen`` box site added."""
    root = ElementTree.fromstring(xml)
    asset = root.find("asset")
    if asset is None:
        asset = ElementTree.SubElement(root, "asset")
    ElementTree.SubElement(asset, "texture", name=PROJECTOR, type="skybox", builtin="flat", width="512", height="512",
                           mark="none")
    ElementTree.SubElement(asset, "material", name=PROJECTOR, texture=PROJECTOR, texuniform="false", specular="0",
                           shininess="0", reflectance="0", emission="0")
    size, pos, euler = SCREEN_BOXES[domain]
    ElementTree.SubElement(root.find("worldbody"), "site", name=SCREEN, type="box", material=PROJECTOR,
                           size=" ".join(map(str, size)), pos=" ".join(map(str, pos)), euler=" ".join(map(str, euler)))
    return ElementTree.tostring(root, encoding="unicode")


class VideoScreen:
    """DMC-GB2's video screen in a dm_control ``Physics``: install it once, then show a frame and follow the torso.

    Args:
        domain: one of :data:`SCREEN_BOXES` (``"cup"`` means ``"ball_in_cup"``).
        remove_floor: make the ``grid`` material transparent (DMC-GB2's ``video_hard``, line 111).
    """

    def __init__(self, domain: str, remove_floor: bool = False) -> None:
        self.domain = check_screen_domain(domain, "VideoScreen")
        self.remove_floor = remove_floor

    def install(self, physics: Any) -> bool:
        """Reload ``physics`` from the domain's XML with the screen added, unless it has one; True if it reloaded.

        The reload resets the physics state (the env's reset follows) and keeps the model's
        offscreen-buffer, shadow and multisample settings.
        """
        model = physics.model.ptr
        if mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, SCREEN) >= 0:
            return False
        from dm_control.suite import common  # the domain XMLs DMC-GB2 edits (dm_control.suite.common.read_model)

        kept = {("quality", name): getattr(model.vis.quality, name) for name in ("shadowsize", "offsamples")}
        kept.update({("global_", name): getattr(model.vis.global_, name) for name in ("offwidth", "offheight")})
        counts = (model.nq, model.nbody, model.ngeom)
        physics.reload_from_xml_string(xml_with_screen(common.read_model(f"{self.domain}.xml"), self.domain), common.ASSETS)
        model = physics.model.ptr
        if (model.nq, model.nbody, model.ngeom) != counts:
            raise ValueError(f"VideoScreen: the env's model is not dm_control's {self.domain}.xml (DMC-GB2 rebuilds that file); "
                             "the screen exists for the suite's own domain models only.")
        for (group, name), value in kept.items():
            setattr(getattr(model.vis, group), name, value)
        if self.remove_floor:
            model.mat_rgba[named_id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "grid"), 3] = 0.0
        return True

    def show(self, model: Any, data: Any, frame: np.ndarray) -> int:
        """Write one ``[256, 256, 3]`` uint8 frame into the screen texture (one image for every face); returns its id."""
        texture = named_id(model, mujoco.mjtObj.mjOBJ_TEXTURE, PROJECTOR)
        model.tex_width[texture] = model.tex_height[texture] = frame.shape[0]
        texture_pixels(model, texture)[:] = np.ascontiguousarray(frame).reshape(-1)
        return texture

    def follow(self, model: Any, data: Any) -> None:
        """Move the screen to the torso's subtree centre of mass plus the domain's offset in x and z (walker, cheetah)."""
        if self.domain not in FOLLOW_TORSO:
            return
        torso = named_id(model, mujoco.mjtObj.mjOBJ_BODY, "torso")
        site = named_id(model, mujoco.mjtObj.mjOBJ_SITE, SCREEN)
        dx, dz = FOLLOW_TORSO[self.domain]
        data.site_xpos[site, 0] = data.subtree_com[torso, 0] + dx
        data.site_xpos[site, 2] = data.subtree_com[torso, 2] + dz

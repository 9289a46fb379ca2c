"""MuJoCo offscreen rendering: the GL backend choice and render-quality settings.

MuJoCo picks its OpenGL backend from the ``MUJOCO_GL`` environment variable when ``mujoco`` (or
``dm_control``) is first imported. vigen renders offscreen, so it selects ``egl`` unless the user
already chose a backend. On a machine without a GPU, EGL runs on Mesa's software rasterizer
(llvmpipe); if EGL is not available at all, set ``MUJOCO_GL=osmesa`` (Debian/Ubuntu package
``libosmesa6``) before importing vigen.

On software rasterizers the render settings dominate the cost of a pixel env. dm_control's
defaults (2048² shadow map, 4× multisampling, a 640×480 offscreen buffer) cost 18–20 ms per
84×84 walker frame on a 2-core CPU; :meth:`RenderSettings.fast` (256² shadow map, no
multisampling, a buffer the size of the image) costs 4–6 ms. The fast settings change pixels
slightly (softer shadow edges, aliased silhouettes), so keep the defaults for numbers you compare
with published results, and use the fast ones for smoke tests, debugging and CPU-only runs.
"""

from __future__ import annotations

import os
import sys
import warnings
from dataclasses import dataclass
from typing import Any

DEFAULT_GL_BACKEND = "egl"


def configure_mujoco_gl(backend: str = DEFAULT_GL_BACKEND) -> str:
    """Select MuJoCo's OpenGL backend unless the user already chose one.

    Sets ``MUJOCO_GL`` to ``backend`` when it is unset and returns the backend in force.
    dm_control reads the variable once, when ``dm_control._render`` is first imported (which
    ``from dm_control import suite`` does); if that happened before with no backend chosen, a warning says so,
    because dm_control then keeps the backend it picked. (TorchRL imports ``mujoco`` itself,
    which fixes ``mujoco.GLContext`` early; vigen does not render through that class.)

    Args:
        backend: ``"egl"`` (default, offscreen on GPU or Mesa), ``"osmesa"`` (pure software
            fallback) or ``"glfw"`` (needs a display).

    Examples:
        >>> from vigen.rendering import configure_mujoco_gl
        >>> configure_mujoco_gl()  # doctest: +SKIP
        'egl'
    """
    if "MUJOCO_GL" in os.environ:
        return os.environ["MUJOCO_GL"]
    if "dm_control._render" in sys.modules:
        warnings.warn(
            "dm_control's renderer was imported before vigen with MUJOCO_GL unset, so it keeps the "
            f"backend it chose. Import vigen first, or set MUJOCO_GL={backend} in the environment.",
            stacklevel=2,
        )
    os.environ["MUJOCO_GL"] = backend
    return backend


@dataclass(frozen=True)
class RenderSettings:
    """Offscreen render-quality settings applied to a MuJoCo model before its first render.

    ``None`` keeps the model's own value. The defaults keep everything as the model declares it
    (dm_control's suite: 2048² shadow map, 4 multisamples, 640×480 buffer), which is what
    published pixel-based results were rendered with. :meth:`fast` is the CPU-friendly preset.

    Args:
        shadow_size: side of the square shadow map in texels (``model.vis.quality.shadowsize``).
        multisamples: offscreen multisampling (``model.vis.quality.offsamples``); 0 disables it.
        buffer_to_image: size the offscreen buffer (``model.vis.global_.offwidth/offheight``) to
            the rendered image instead of the model's default.

    Examples:
        >>> from vigen.rendering import RenderSettings
        >>> RenderSettings.fast()
        RenderSettings(shadow_size=256, multisamples=0, buffer_to_image=True)
    """

    shadow_size: int | None = None
    multisamples: int | None = None
    buffer_to_image: bool = False

    @classmethod
    def fast(cls) -> RenderSettings:
        """The CPU-friendly preset: 256² shadow map, no multisampling, buffer sized to the image."""
        return cls(shadow_size=256, multisamples=0, buffer_to_image=True)

    @property
    def is_default(self) -> bool:
        return self == RenderSettings()

    def apply(self, model: Any, height: int, width: int) -> None:
        """Write the settings into ``model`` (a ``mujoco.MjModel`` or dm_control wrapper).

        Must run before the model's first render: MuJoCo sizes the offscreen buffer, shadow map
        and multisample buffers when it creates the render context. The offscreen buffer is
        never made smaller than the image, since MuJoCo cannot render past it.
        """
        quality, global_ = model.vis.quality, model.vis.global_
        if self.shadow_size is not None:
            quality.shadowsize = self.shadow_size
        if self.multisamples is not None:
            quality.offsamples = self.multisamples
        if self.buffer_to_image:
            global_.offwidth, global_.offheight = width, height
        else:
            global_.offwidth = max(global_.offwidth, width)
            global_.offheight = max(global_.offheight, height)

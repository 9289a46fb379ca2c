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


EGL_EXTENSIONS = 0x3055
EGL_CUDA_DEVICE_NV = 0x323A  # EGL_NV_device_cuda: the CUDA device ordinal of an EGL device


def egl_devices() -> list[dict[str, Any]]:
    """The EGL devices this process can render on, in the order ``MUJOCO_EGL_DEVICE_ID`` indexes them.

    Each is ``{"index": i, "extensions": [...], "cuda": ordinal or None}``: NVIDIA's devices name
    their CUDA device (``EGL_NV_device_cuda``); Mesa's software device (``EGL_MESA_device_software``)
    has none. Empty where EGL or its device enumeration is missing.

    Examples:
        >>> from vigen.rendering import egl_devices
        >>> all(device["index"] == i for i, device in enumerate(egl_devices()))
        True
    """
    if os.environ.setdefault("PYOPENGL_PLATFORM", "egl") != "egl":
        return []
    import ctypes

    try:  # NVIDIA's EGL wants libOpenGL loaded globally before PyOpenGL (as dm_control's EGL backend loads it)
        ctypes.CDLL("libOpenGL.so.0", mode=ctypes.RTLD_GLOBAL)
    except OSError:
        pass
    try:
        from OpenGL import EGL

        query_devices = ctypes.CFUNCTYPE(EGL.EGLBoolean, EGL.EGLint, ctypes.POINTER(EGL.EGLDeviceEXT), ctypes.POINTER(EGL.EGLint))(
            EGL.eglGetProcAddress("eglQueryDevicesEXT"))
        query_string = ctypes.CFUNCTYPE(ctypes.c_char_p, EGL.EGLDeviceEXT, EGL.EGLint)(EGL.eglGetProcAddress("eglQueryDeviceStringEXT"))
        query_attribute = ctypes.CFUNCTYPE(EGL.EGLBoolean, EGL.EGLDeviceEXT, EGL.EGLint, ctypes.POINTER(ctypes.c_ssize_t))(
            EGL.eglGetProcAddress("eglQueryDeviceAttribEXT"))
        handles = (EGL.EGLDeviceEXT * 16)()
        count = EGL.EGLint()
        if not query_devices(16, handles, ctypes.byref(count)):
            return []
    except Exception:  # noqa: BLE001 - no EGL, or an EGL without device enumeration: nothing to choose from
        return []
    devices = []
    for index in range(count.value):
        extensions = (query_string(handles[index], EGL_EXTENSIONS) or b"").decode().split()
        cuda = None
        if "EGL_NV_device_cuda" in extensions:
            value = ctypes.c_ssize_t(-1)
            if query_attribute(handles[index], EGL_CUDA_DEVICE_NV, ctypes.byref(value)) and value.value >= 0:
                cuda = int(value.value)
        devices.append({"index": index, "extensions": extensions, "cuda": cuda})
    return devices


def render_on_cuda_device(cuda_index: int) -> int | None:
    """Make MuJoCo render on the EGL device of CUDA device ``cuda_index``, here and in every process started later.

    Sets ``MUJOCO_EGL_DEVICE_ID`` (which MuJoCo's and dm_control's EGL backends read when they
    are first imported) to the EGL device whose ``EGL_NV_device_cuda`` ordinal is ``cuda_index``;
    env workers (a ``MultiSyncCollector``'s processes, ``ParallelEnv``'s) inherit it. Returns the
    EGL device chosen, or ``None`` and changes nothing where ``MUJOCO_GL`` is not ``egl``, where the
    user set ``MUJOCO_EGL_DEVICE_ID`` already (returned as it is), or where no EGL device names that
    CUDA device (a machine without NVIDIA's EGL: MuJoCo keeps its own choice, e.g. Mesa's software
    rasterizer). dm_control picks its device once per process: in a process that rendered before
    the call, only the processes started afterwards follow it.

    Examples:
        >>> from vigen.rendering import render_on_cuda_device
        >>> render_on_cuda_device(0) is None or isinstance(render_on_cuda_device(0), int)  # None without NVIDIA's EGL
        True
    """
    if "MUJOCO_EGL_DEVICE_ID" in os.environ:
        return int(os.environ["MUJOCO_EGL_DEVICE_ID"])
    if os.environ.get("MUJOCO_GL") != "egl":
        return None
    chosen = next((device["index"] for device in egl_devices() if device["cuda"] == cuda_index), None)
    if chosen is not None:
        os.environ["MUJOCO_EGL_DEVICE_ID"] = str(chosen)
    return chosen


def gl_renderer(physics: Any) -> str:
    """The OpenGL renderer a dm_control ``Physics`` draws with: the GPU's name, or e.g. ``llvmpipe`` for Mesa's software one.

    Examples:
        >>> from dm_control import suite
        >>> from vigen.rendering import gl_renderer
        >>> isinstance(gl_renderer(suite.load("cartpole", "balance").physics), str)
        True
    """
    from OpenGL import GL

    with physics.contexts.gl.make_current() as context:
        return context.call(GL.glGetString, GL.GL_RENDERER).decode()


def renderer_name(env: Any) -> str:
    """Which OpenGL renderer a vigen env (or its base env) draws with, for a report: :func:`gl_renderer` of its physics, or
    ``unknown (...)`` where it cannot be read (not a dm_control env, no GL context).

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.rendering import renderer_name
        >>> isinstance(renderer_name(make_env("dmc/cartpole-balance", image_size=16)), str)
        True
    """
    physics = getattr(getattr(env, "base_env", env), "physics", None)
    try:
        return gl_renderer(physics) if physics is not None else "unknown (not a dm_control env)"
    except Exception as error:  # noqa: BLE001 - only a report
        return f"unknown ({type(error).__name__})"

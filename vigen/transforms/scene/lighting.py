"""RL-ViGen's lighting shifts: light position and colour offsets, and lights that move every step."""

from __future__ import annotations

import mujoco
import numpy as np
from tensordict import TensorDictBase

from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation

# MuJoCo reads a light's position from a different field per mode (fixed, track, trackcom...).
POSITION_FIELDS = ("light_pos", "light_pos0", "light_poscom0")

MOVING_PATHS = ("bounce", "drift")
"""How a moving light travels: vigen's bounce within a range, or RL-ViGen's drift that never turns."""

HEIGHT_AXIS = 2


class RandomLighting(ScenePerturbation):
    """Shift every light's position and diffuse colour per episode, and optionally move it every step (RL-ViGen).

    With RL-ViGen's DMC ranges (``wrappers``/``DMCVGB`` light settings):

    ========  ======================  ====================  =============================
    level     position offset          diffuse offset        moving light (step / range)
    ========  ======================  ====================  =============================
    easy      integer in {3, 4}        U(-0.2, 0.2)          0.01 / ±5
    hard      integer in {9, 10}       U(-10, 10)            0.05 / ±10
    ========  ======================  ====================  =============================

    Offsets are drawn per light and per coordinate (RL-ViGen adds ``randint(3, 5)``, which is
    always positive). Diffuse colours are not clipped, as in RL-ViGen: values above 1 over-expose,
    negative ones darken.

    A moving light takes one of two paths (``moving_path``):

    * ``"bounce"`` (vigen's default): ``moving_step`` is added to every coordinate of
      ``moving_axes`` after each env step, and a coordinate turns back when it leaves its episode
      start ± ``moving_range``; the height turns back at its episode start instead of going below
      it (its range is start … start + ``moving_range``), so a light that starts above the floor
      stays above it. RL-ViGen sets such a range (``wrappers.py:35-40``) but its check never fires
      (below); the bounce is vigen's reading of what the range was for, not RL-ViGen's behaviour.
    * ``"drift"`` (RL-ViGen's, exactly): ``moving_step`` is added to every coordinate of
      ``moving_axes`` before each env step renders, and the light never turns. RL-ViGen's
      ``ColorWrapper.step`` (``envs/DMCVGB/dmcvgb/wrappers.py:92-98``) adds ``step_pos`` (0.01 easy,
      0.05 hard, lines 35-40) to every coordinate of every light before ``env.step``, then compares
      booleans (``light_pos[:, 0].all() > range[1].all()`` or ``... < range[0].all()``, line 96),
      which are all True while no light's x is exactly 0 (its Unitree and Franka lights start at
      x = -1 and 0 and step off 0 at once), so ``step_pos`` never changes sign: at hard
      (0.05 per agent step) its lights have drifted +25 on every axis by step 500, the end of a
      1000-step episode at action repeat 2. The drift restarts from the episode's start at reset,
      as RL-ViGen's reloaded model does.

    Paper: RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        position_offset: inclusive integer range of the position offset, or ``None``.
        diffuse_offset: half-width of the uniform diffuse offset, or ``None``.
        moving_step: per-step displacement of a moving light, or ``None`` for static lights.
        moving_range: how far a bouncing light travels from its episode start before turning.
        moving_path: ``"bounce"`` (vigen's, within ``moving_range``, never below the start height) or
            ``"drift"`` (RL-ViGen's: ``moving_step`` more on every moving axis at every step, never turning).
        position_jitter: per-axis half-widths ``(x, y, z)`` of a uniform position offset, added to
            ``position_offset`` (RL-ViGen's Adroit ``light_*``: (0.5, 0.5, 0.2) easy, (1, 1, 0.5) hard).
        moving_axes: the axes a moving light moves along (RL-ViGen's Adroit moves it along y only).
        height: a height to put every light at before the offsets (RL-ViGen's robosuite moving
            light starts at z = 4), or ``None`` to keep the model's.
        directional: make every light directional (``True``) or a spot light (``False``), or keep
            each light's type (``None``). A directional light's position does not change the
            image, so a moving light must not be directional (RL-ViGen's robosuite: ``False``).
        cast_shadow: turn shadows on or off for every light, or keep them (``None``).
        seed: see :class:`~vigen.transforms.scene.ScenePerturbation`.

    Examples:
        >>> from vigen.envs import make_env
        >>> from vigen.transforms import RandomLighting
        >>> env = make_env("dmc/walker-walk").append_transform(RandomLighting.rlvigen("easy", seed=0))
        >>> env.rollout(3)["pixels"].shape
        torch.Size([3, 9, 84, 84])

    RL-ViGen's drift at hard: +0.05 per agent step on every axis (+25 by step 500), the step's frame included:

        >>> drift = RandomLighting(None, None, moving_step=0.05, moving_path="drift", seed=0)
        >>> env = make_env("dmc/walker-walk", image_size=16, frame_stack=1).append_transform(drift)
        >>> start = env.base_env.scene.model.light_poscom0.copy()
        >>> _ = env.rollout(4)
        >>> (env.base_env.scene.model.light_poscom0 - start).round(6).tolist()
        [[0.2, 0.2, 0.2]]
    """

    LEVELS = {
        "easy": {"position_offset": (3, 4), "diffuse_offset": 0.2, "moving_step": 0.01, "moving_range": 5.0},
        "hard": {"position_offset": (9, 10), "diffuse_offset": 10.0, "moving_step": 0.05, "moving_range": 10.0},
    }

    def __init__(
        self,
        position_offset: tuple[int, int] | None = (3, 4),
        diffuse_offset: float | None = 0.2,
        moving_step: float | None = None,
        moving_range: float = 5.0,
        moving_path: str = "bounce",
        position_jitter: tuple[float, float, float] | None = None,
        moving_axes: tuple[int, ...] = (0, 1, 2),
        height: float | None = None,
        directional: bool | None = None,
        cast_shadow: bool | None = None,
        seed: int | None = None,
    ) -> None:
        if moving_path not in MOVING_PATHS:
            raise ValueError(f"RandomLighting: moving_path must be 'bounce' (vigen's, within moving_range, never below the "
                             f"start height) or 'drift' (RL-ViGen's: never turning), got {moving_path!r}.")
        super().__init__(seed=seed)
        self.moving_path = moving_path
        self.position_offset = tuple(position_offset) if position_offset is not None else None
        self.diffuse_offset = diffuse_offset
        self.moving_step = moving_step
        self.moving_range = moving_range
        self.position_jitter = tuple(position_jitter) if position_jitter is not None else None
        self.moving_axes = tuple(moving_axes)
        self.height = height
        self.directional = directional
        self.cast_shadow = cast_shadow

    @classmethod
    def rlvigen(cls, level: str, seed: int | None = None) -> RandomLighting:
        """RL-ViGen's ``light_position`` + ``light_color`` + ``moving_light`` at ``"easy"`` or ``"hard"``."""
        if level not in cls.LEVELS:
            raise ValueError(f"Unknown RL-ViGen lighting level {level!r}; choose from {sorted(cls.LEVELS)}.")
        return cls(**cls.LEVELS[level], seed=seed)

    def read_defaults(self, scene: SceneHandle) -> Defaults:
        model = scene.model
        if model.nlight == 0:
            raise ValueError("RandomLighting needs a scene with at least one light.")
        defaults = {name: getattr(model, name).copy() for name in POSITION_FIELDS}
        defaults["light_diffuse"] = model.light_diffuse.copy()
        defaults["light_type"] = model.light_type.copy()
        defaults["light_castshadow"] = model.light_castshadow.copy()
        return defaults

    def sample(self, rng: np.random.Generator, defaults: Defaults) -> SceneParams:
        shape = defaults["light_pos"].shape
        position = np.zeros(shape)
        if self.position_offset is not None:
            low, high = self.position_offset
            position = rng.integers(low, high + 1, size=shape).astype(np.float64)
        if self.position_jitter is not None:
            half_widths = np.asarray(self.position_jitter)
            position = position + rng.uniform(-half_widths, half_widths, size=shape)
        diffuse = np.zeros(shape)
        if self.diffuse_offset is not None:
            diffuse = rng.uniform(-self.diffuse_offset, self.diffuse_offset, size=shape)
        return {"position": position, "diffuse": diffuse, "motion": np.zeros(shape), "direction": np.ones(shape), "restyle": True}

    def identity_params(self, defaults: Defaults) -> SceneParams:
        zeros = np.zeros_like(defaults["light_pos"])
        return {"position": zeros, "diffuse": zeros, "motion": zeros, "direction": np.ones_like(zeros), "restyle": False}

    def apply(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        model = scene.model
        self._place(scene, defaults, params)
        model.light_diffuse[:] = defaults["light_diffuse"] + params["diffuse"]
        model.light_type[:] = defaults["light_type"]
        model.light_castshadow[:] = defaults["light_castshadow"]
        if params["restyle"] and self.directional is not None:
            kind = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL if self.directional else mujoco.mjtLightType.mjLIGHT_SPOT
            model.light_type[:] = int(kind)
        if params["restyle"] and self.cast_shadow is not None:
            model.light_castshadow[:] = self.cast_shadow

    def advance(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        """The bounce's move after an env step: turn at start ± ``moving_range`` (the height: at start and start + range)."""
        if self.moving_step is None or self.moving_path != "bounce":
            return
        low, high = np.full(3, -float(self.moving_range)), np.full(3, float(self.moving_range))
        low[HEIGHT_AXIS] = 0.0
        motion = params["motion"] + params["direction"] * self.moving_step * self._axes()
        outside = (motion > high) | (motion < low)
        params["direction"] = np.where(outside, -params["direction"], params["direction"])
        params["motion"] = np.clip(motion, low, high)
        self._place(scene, defaults, params)

    def _inv_call(self, tensordict: TensorDictBase) -> TensorDictBase:
        # the drift's move runs before the base env steps and renders, as RL-ViGen moves its lights before env.step
        if self.moving_step is not None and self.moving_path == "drift" and self.params is not None:
            scene = self.scene
            self.params["motion"] = self.params["motion"] + self.moving_step * self._axes()
            self._place(scene, self.defaults(scene), self.params)
        return tensordict

    def _axes(self) -> np.ndarray:
        axes = np.zeros(3)
        axes[list(self.moving_axes)] = 1.0
        return axes

    def _place(self, scene: SceneHandle, defaults: Defaults, params: SceneParams) -> None:
        """Write default position (at ``height`` when restyled) + episode offset + motion into every position field."""
        offset = params["position"] + params["motion"]
        for name in POSITION_FIELDS:
            start = defaults[name].copy()
            if params["restyle"] and self.height is not None:
                start[:, 2] = self.height
            getattr(scene.model, name)[:] = start + offset

    def extra_repr(self) -> str:
        return (
            f"position_offset={self.position_offset}, diffuse_offset={self.diffuse_offset}, "
            f"moving_step={self.moving_step}, moving_range={self.moving_range}"
            + ("" if self.moving_path == "bounce" else f", moving_path={self.moving_path!r}")
            + ("" if self.position_jitter is None else f", position_jitter={self.position_jitter}")
            + ("" if self.moving_axes == (0, 1, 2) else f", moving_axes={self.moving_axes}")
            + ("" if self.height is None else f", height={self.height}")
            + ("" if self.directional is None else f", directional={self.directional}")
            + ("" if self.cast_shadow is None else f", cast_shadow={self.cast_shadow}")
        )

"""RL-ViGen's lighting shifts: light position and colour offsets, and lights that move every step."""

from __future__ import annotations

import mujoco
import numpy as np

from vigen.transforms.scene.base import Defaults, SceneHandle, SceneParams, ScenePerturbation

# MuJoCo reads a light's position from a different field per mode (fixed, track, trackcom...).
POSITION_FIELDS = ("light_pos", "light_pos0", "light_poscom0")


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
    always positive). A moving light adds ``step`` to every coordinate after each env step and
    reverses when it leaves its episode start ± ``moving_range`` (RL-ViGen's check compares the
    wrong booleans; this is the intended bounce). Diffuse colours are not clipped, as in RL-ViGen:
    values above 1 over-expose, negative ones darken.

    Paper: RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        position_offset: inclusive integer range of the position offset, or ``None``.
        diffuse_offset: half-width of the uniform diffuse offset, or ``None``.
        moving_step: per-step displacement of a moving light, or ``None`` for static lights.
        moving_range: how far a moving light travels from its episode start before turning.
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
        position_jitter: tuple[float, float, float] | None = None,
        moving_axes: tuple[int, ...] = (0, 1, 2),
        height: float | None = None,
        directional: bool | None = None,
        cast_shadow: bool | None = None,
        seed: int | None = None,
    ) -> None:
        super().__init__(seed=seed)
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
        if self.moving_step is None:
            return
        axes = np.zeros(3)
        axes[list(self.moving_axes)] = 1.0
        motion = params["motion"] + params["direction"] * self.moving_step * axes
        outside = np.abs(motion) > self.moving_range
        params["direction"] = np.where(outside, -params["direction"], params["direction"])
        params["motion"] = np.clip(motion, -self.moving_range, self.moving_range)
        self._place(scene, defaults, params)

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
            + ("" if self.position_jitter is None else f", position_jitter={self.position_jitter}")
            + ("" if self.moving_axes == (0, 1, 2) else f", moving_axes={self.moving_axes}")
            + ("" if self.height is None else f", height={self.height}")
            + ("" if self.directional is None else f", directional={self.directional}")
            + ("" if self.cast_shadow is None else f", cast_shadow={self.cast_shadow}")
        )

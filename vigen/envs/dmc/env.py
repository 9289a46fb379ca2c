"""dm_control suite tasks as TorchRL base envs, set up as in DrQ-v2 and RL-ViGen (the simulator side of the ``dmc`` suite).

Each env renders 84×84 RGB frames from the task's camera and repeats every action twice without
rendering the skipped frames; episodes run 1000 simulator (control) steps. The chain, innermost
first:

* ``suite.load(domain, task)``: the dm_control task, with its own time limit lifted;
* :class:`ActionRepeat`: repeats the action and ends the episode at ``episode_length`` control
  steps as a time-limit truncation (``discount == 1``);
* ``dm_control.suite.wrappers.pixels.Wrapper``: renders once per agent step, pixels only;
* :class:`DMCPixelEnv` (a TorchRL ``DMControlWrapper``): specs, seeding, ``terminated`` /
  ``truncated`` from the discount, and the live ``physics``.

:mod:`vigen.envs.dmc.suite` (the suite record) adds the levels, channel-first frames and the frame stack.
"""

from __future__ import annotations

import math
import time
from typing import Any

import dm_env
import mujoco
import numpy as np
import torch
from dm_control import suite
from dm_control.mujoco.engine import Camera
from dm_control.suite.wrappers import pixels
from tensordict import TensorDictBase
from torchrl.envs.libs.dm_control import DMControlWrapper

from vigen.envs.pixels import check_env_arguments
from vigen.rendering import RenderSettings

DOMAIN_ALIASES = {"cup": "ball_in_cup"}
"""Short domain names used by DrQ-v2's task names (``cup_catch``)."""

DEFAULT_CAMERAS = {"quadruped": 2}
"""Camera per domain where DrQ-v2 does not use camera 0 (the quadruped's camera 2 follows it)."""


def task_names() -> list[str]:
    """All dm_control suite tasks as ``"<domain>-<task>"``, plus DrQ-v2's ``cup`` alias.

    Examples:
        >>> "walker-walk" in task_names(), "cup-catch" in task_names()
        (True, True)
    """
    names = [f"{domain}-{task}" for domain, task in suite.ALL_TASKS]
    aliases = {full: short for short, full in DOMAIN_ALIASES.items()}
    return names + [f"{aliases[d]}-{t}" for d, t in suite.ALL_TASKS if d in aliases]


class ActionRepeat(dm_env.Environment):
    """Repeats each action ``repeat`` times and cuts episodes at ``episode_length`` control steps.

    Rewards are summed and discounts multiplied over the repeated steps, as in DrQ-v2's
    ``ActionRepeatWrapper``. Reaching ``episode_length`` returns a ``LAST`` step with the
    discount of the last transition (1 unless the task terminated), which TorchRL reads as a
    truncation. The wrapped env's own time limit should be lifted so that this is the only one.

    Args:
        env: a dm_control ``control.Environment``.
        repeat: control steps per agent step.
        episode_length: control steps per episode.

    Examples:
        >>> from dm_control import suite
        >>> env = ActionRepeat(suite.load("cartpole", "balance", task_kwargs={"time_limit": float("inf")}), 2, 10)
        >>> first = env.reset()
        >>> steps = [env.step([0.0]) for _ in range(5)]  # 5 agent steps = 10 control steps
        >>> [step.last() for step in steps], steps[-1].discount
        ([False, False, False, False, True], 1.0)
    """

    def __init__(self, env: Any, repeat: int, episode_length: int) -> None:
        if repeat < 1:
            raise ValueError(f"action_repeat must be at least 1, got {repeat}.")
        if episode_length < 1:
            raise ValueError(f"episode_length must be at least 1 control step, got {episode_length}.")
        self._env = env
        self._repeat = repeat
        self._episode_length = episode_length
        self._elapsed = 0
        self._needs_reset = True
        self.physics_seconds = 0.0
        """Wall seconds spent in the simulator's steps so far (resets excluded), read by :class:`DMCPixelEnv`'s timing."""

    @property
    def physics(self) -> Any:
        return self._env.physics

    @property
    def task(self) -> Any:
        return self._env.task

    def reset(self) -> dm_env.TimeStep:
        self._elapsed = 0
        self._needs_reset = False
        return self._env.reset()

    def step(self, action: Any) -> dm_env.TimeStep:
        if self._needs_reset:
            return self.reset()
        started = time.perf_counter()
        try:
            return self._repeat_step(action)
        finally:
            self.physics_seconds += time.perf_counter() - started

    def _repeat_step(self, action: Any) -> dm_env.TimeStep:
        reward, discount = 0.0, 1.0
        for _ in range(self._repeat):
            time_step = self._env.step(action)
            self._elapsed += 1
            reward += time_step.reward or 0.0
            discount *= time_step.discount
            if time_step.last() or self._elapsed >= self._episode_length:
                self._needs_reset = True
                return dm_env.TimeStep(dm_env.StepType.LAST, reward, discount, time_step.observation)
        return time_step._replace(reward=reward, discount=discount)

    def observation_spec(self) -> Any:
        return self._env.observation_spec()

    def action_spec(self) -> Any:
        return self._env.action_spec()

    def reward_spec(self) -> Any:
        return self._env.reward_spec()

    def discount_spec(self) -> Any:
        return self._env.discount_spec()

    def close(self) -> None:
        self._env.close()


class DMCScene:
    """The :class:`~vigen.transforms.scene.SceneHandle` of a dm_control physics.

    Examples:
        >>> scene = DMCPixelEnv("walker", "walk", image_size=64).scene
        >>> scene.model.ntex, scene.data.time
        (2, 0.0)
        >>> scene.segmentation().shape
        (64, 64, 2)
    """

    def __init__(self, physics: Any, segmentation_camera: Any) -> None:
        self._physics = physics
        self._segmentation_camera = segmentation_camera

    @property
    def model(self) -> mujoco.MjModel:
        return self._physics.model.ptr

    @property
    def data(self) -> mujoco.MjData:
        return self._physics.data.ptr

    def segmentation(self) -> np.ndarray:
        """``[H, W, 2]`` int32 (object id, object type) of the env's camera view; ``-1`` where nothing is hit."""
        return self._segmentation_camera().render(segmentation=True)

    def upload_texture(self, texture_id: int) -> None:
        contexts = self._physics._contexts  # None until the first render, which uploads everything
        if contexts is not None:
            with contexts.gl.make_current() as ctx:
                ctx.call(mujoco.mjr_uploadTexture, self.model, contexts.mujoco.ptr, texture_id)


class DMCPixelEnv(DMControlWrapper):
    """A dm_control suite task rendered to uint8 HWC frames, with the action repeat under the renderer.

    The TorchRL base env of the ``dmc/`` suite (:func:`vigen.envs.make_env` adds channel-first frames, frame stacking
    and float32 actions and rewards). It follows TorchRL's ``DMControlWrapper`` for specs, seeding
    and flags: an episode that ends with discount 1 (the time limit) is ``truncated``, one that
    ends with discount 0 is ``terminated``. :attr:`physics` is the live MuJoCo model, data and
    render contexts, for scene perturbations.

    Args:
        domain: suite domain, e.g. ``"walker"`` (``"cup"`` is accepted for ``"ball_in_cup"``).
        task: suite task, e.g. ``"walk"``.
        action_repeat: control steps per agent step; only the last one is rendered.
        image_size: height and width of the rendered frame.
        camera_id: camera to render; ``None`` uses 2 for quadruped and 0 elsewhere (DrQ-v2).
        episode_length: control steps per episode.
        render_settings: MuJoCo render quality; ``None`` keeps dm_control's defaults.
        seed: seed of the task's random state (initial poses and targets); ``None`` draws one.
        device: device of the returned tensors.

    Reference: DrQ-v2, https://arxiv.org/abs/2107.09645 (its ``dmc.py`` sets up the same env).

    Examples:
        >>> from vigen.envs.dmc.env import DMCPixelEnv
        >>> env = DMCPixelEnv("walker", "walk", seed=0)
        >>> env
        DMCPixelEnv(walker-walk, camera_id=0, image_size=84, action_repeat=2, episode_length=1000)
        >>> env.reset()["pixels"].shape, env.physics.model.ncam
        (torch.Size([84, 84, 3]), 2)
    """

    def __init__(
        self,
        domain: str,
        task: str,
        *,
        action_repeat: int = 2,
        image_size: int = 84,
        camera_id: int | None = None,
        episode_length: int = 1000,
        render_settings: RenderSettings | None = None,
        seed: int | None = None,
        device: torch.device | str = "cpu",
    ) -> None:
        check_env_arguments(
            action_repeat=action_repeat, image_size=image_size, camera_id=camera_id, episode_length=episode_length, seed=seed
        )
        domain = DOMAIN_ALIASES.get(domain, domain)
        if (domain, task) not in suite.ALL_TASKS:
            raise ValueError(f"Unknown dm_control task {domain}-{task}. Valid names: {', '.join('dmc/' + name for name in task_names())}.")
        camera_id = DEFAULT_CAMERAS.get(domain, 0) if camera_id is None else camera_id

        control_env = suite.load(domain, task, task_kwargs={"random": seed, "time_limit": math.inf})
        self._wrap(control_env, f"{domain}-{task}", action_repeat=action_repeat, image_size=image_size, camera_id=camera_id,
                   episode_length=episode_length, render_settings=render_settings, device=device)
        self.domain_name, self.task_name = domain, task

    def _wrap(self, control_env: Any, name: str, *, action_repeat: int, image_size: int, camera_id: int, episode_length: int,
              render_settings: RenderSettings | None, device: torch.device | str) -> None:
        """Put the action repeat, the renderer and TorchRL's wrapper around a dm_control ``control.Environment``."""
        model = control_env.physics.model
        if not 0 <= camera_id < model.ncam:
            raise ValueError(f"camera_id={camera_id} does not exist: {name} has cameras 0..{model.ncam - 1}.")
        (render_settings or RenderSettings()).apply(model, image_size, image_size)
        rendered = pixels.Wrapper(
            ActionRepeat(control_env, action_repeat, episode_length),
            pixels_only=True,
            render_kwargs={"height": image_size, "width": image_size, "camera_id": camera_id},
        )
        self._step_seconds = 0.0
        DMControlWrapper.__init__(self, rendered, device=device)
        self.camera_id = camera_id
        self.image_size, self.action_repeat, self.episode_length = image_size, action_repeat, episode_length

    def _set_seed(self, seed: int | None) -> None:
        """Seed the task as ``seed=`` does at build time: the next reset starts the seed's first episode.

        TorchRL's ``DMControlWrapper`` seeds and then resets, which uses up that first episode.
        """
        super()._set_seed(seed)
        if seed is not None:
            self._env._env.task._random = np.random.RandomState(seed)

    @property
    def physics(self) -> Any:
        """The live dm_control ``Physics``: MuJoCo model and data, and the render contexts."""
        return self._env.physics

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        started = time.perf_counter()
        try:
            return super()._step(tensordict)
        finally:
            self._step_seconds += time.perf_counter() - started

    @property
    def simulator_seconds(self) -> dict[str, float]:
        """Wall seconds spent so far in the steps' physics and rendering (resets excluded), summed since the env was built.

        ``physics`` is the simulator's steps (all of an action repeat); ``render`` is the rest of
        the base env's step: rendering the frame once, and handing it to TorchRL as a tensor.
        :class:`vigen.envs.SimulatorTimes` turns them into per-step figures.

        Examples:
            >>> from vigen.envs.dmc.env import DMCPixelEnv
            >>> env = DMCPixelEnv("cartpole", "balance", image_size=16, seed=0)
            >>> _ = env.rollout(3)
            >>> {name: seconds > 0 for name, seconds in env.simulator_seconds.items()}
            {'physics': True, 'render': True}
        """
        physics = self._env._env.physics_seconds
        return {"physics": physics, "render": max(self._step_seconds - physics, 0.0)}

    def render_frame(self) -> np.ndarray:
        """The current view as uint8 ``[H, W, 3]``, rendered as the env renders its observations."""
        return self.physics.render(self.image_size, self.image_size, camera_id=self.camera_id)

    @property
    def scene(self) -> DMCScene:
        """The handle that scene perturbations (``vigen.transforms``) edit."""
        return DMCScene(self._env.physics, self._segmentation_camera)

    def _segmentation_camera(self) -> Camera:
        """A camera kept for segmentation renders, without the shadow, reflection and sky passes they do not need."""
        if getattr(self, "_segmentation_camera_cache", None) is None:
            camera = Camera(self.physics, self.image_size, self.image_size, self.camera_id)
            for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION, mujoco.mjtRndFlag.mjRND_SKYBOX):
                camera.scene.flags[flag] = 0
            self._segmentation_camera_cache = camera
        return self._segmentation_camera_cache

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({self.domain_name}-{self.task_name}, camera_id={self.camera_id}, "
            f"image_size={self.image_size}, action_repeat={self.action_repeat}, episode_length={self.episode_length})"
        )

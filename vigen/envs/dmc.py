"""dm_control suite tasks as TorchRL pixel envs, set up as in DrQ-v2 and RL-ViGen.

Each env renders 84×84 RGB frames from the task's camera, repeats every action twice without
rendering the skipped frames, runs 1000 simulator (control) steps per episode, stacks the last
three frames along the channel axis and returns them as uint8 ``[3·k, 84, 84]`` under ``"pixels"``.

The chain, innermost first:

* ``suite.load(domain, task)``: the dm_control task, with its own time limit lifted;
* :class:`ActionRepeat`: repeats the action and ends the episode at ``episode_length`` control
  steps as a time-limit truncation (``discount == 1``);
* ``dm_control.suite.wrappers.pixels.Wrapper``: renders once per agent step, pixels only;
* TorchRL's ``DMControlWrapper``: specs, seeding, ``terminated``/``truncated`` from the discount;
* ``ToTensorImage`` (HWC → CHW, uint8 kept), ``CatFrames`` and ``DoubleToFloat``.
"""

from __future__ import annotations

import math
from typing import Any

import dm_env
import torch
from dm_control import suite
from dm_control.suite.wrappers import pixels
from torchrl.envs import CatFrames, Compose, DoubleToFloat, EnvBase, ToTensorImage, TransformedEnv
from torchrl.envs.libs.dm_control import DMControlWrapper

from vigen.rendering import RenderSettings

DOMAIN_ALIASES = {"cup": "ball_in_cup"}
"""Short domain names used by DrQ-v2's task names (``cup_catch``)."""

DEFAULT_CAMERAS = {"quadruped": 2}
"""Camera per domain where DrQ-v2 does not use camera 0 (the quadruped's camera 2 follows it)."""


def env_names() -> list[str]:
    """All dm_control suite tasks as vigen env names, ``"dmc/<domain>-<task>"``, plus DrQ-v2's ``cup`` alias.

    Examples:
        >>> from vigen.envs.dmc import env_names
        >>> "dmc/walker-walk" in env_names()
        True
    """
    names = [f"dmc/{domain}-{task}" for domain, task in suite.ALL_TASKS]
    aliases = {full: short for short, full in DOMAIN_ALIASES.items()}
    return names + [f"dmc/{aliases[d]}-{t}" for d, t in suite.ALL_TASKS if d in aliases]


def make_named(env: str, **kwargs: Any) -> TransformedEnv:
    """Build ``"dmc/<domain>-<task>"`` from its ``"<domain>-<task>"`` part; see :func:`make_dmc_env`."""
    domain, _, task = env.partition("-")
    return make_dmc_env(domain, task, **kwargs)


class ActionRepeat(dm_env.Environment):
    """Repeats each action ``repeat`` times and cuts episodes at ``episode_length`` control steps.

    Rewards are summed and discounts multiplied over the repeated steps, as in DrQ-v2's
    ``ActionRepeatWrapper``. Reaching ``episode_length`` returns a ``LAST`` step with the
    discount of the last transition (1 unless the task terminated), which TorchRL reads as a
    truncation. The wrapped env's own time limit should be lifted so that this is the only one.

    Args:
        env: a dm_control ``control.Environment``.
        repeat: simulator steps per agent step.
        episode_length: simulator steps per episode.

    Examples:
        >>> from dm_control import suite
        >>> env = ActionRepeat(suite.load("cartpole", "balance", task_kwargs={"time_limit": float("inf")}), 2, 10)
        >>> steps = [env.step([0.0]) for _ in range(5)]
        >>> steps[-1].last(), steps[-1].discount
        (True, 1.0)
    """

    def __init__(self, env: Any, repeat: int, episode_length: int) -> None:
        if repeat < 1:
            raise ValueError(f"action_repeat must be at least 1, got {repeat}.")
        if episode_length < 1:
            raise ValueError(f"episode_length must be at least 1 simulator step, got {episode_length}.")
        self._env = env
        self._repeat = repeat
        self._episode_length = episode_length
        self._elapsed = 0
        self._needs_reset = True

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


def dmc_physics(env: EnvBase) -> Any:
    """The live dm_control ``Physics`` (MuJoCo model, data, render contexts) of a dm_control env.

    Accepts the env :func:`make_dmc_env` returns, its base env, or a ``TransformedEnv`` around
    either. Batched envs keep one physics per worker, so they are refused.

    Examples:
        >>> from vigen.envs.dmc import dmc_physics, make_dmc_env
        >>> dmc_physics(make_dmc_env("walker", "walk")).model.ncam
        2
    """
    base = env.base_env if isinstance(env, TransformedEnv) else env
    if not isinstance(base, DMControlWrapper):
        raise TypeError(
            f"Expected a dm_control env built by vigen.envs.make_env('dmc/...'), got {type(base).__name__}. "
            "Batched envs (SerialEnv, ParallelEnv) hold one physics per worker: reach it inside the worker."
        )
    return base._env.physics


def make_dmc_env(
    domain: str,
    task: str,
    *,
    frame_stack: int = 3,
    action_repeat: int = 2,
    image_size: int = 84,
    camera_id: int | None = None,
    episode_length: int = 1000,
    render_settings: RenderSettings | None = None,
    seed: int | None = None,
    device: torch.device | str = "cpu",
) -> TransformedEnv:
    """Build a dm_control suite task as a TorchRL pixel env (DrQ-v2's setup by default).

    Args:
        domain: suite domain, e.g. ``"walker"`` (``"cup"`` is accepted for ``"ball_in_cup"``).
        task: suite task, e.g. ``"walk"``.
        frame_stack: frames stacked along channels (``"pixels"`` is ``[3·frame_stack, H, W]``).
            Use 1 to store single frames and stack at replay-buffer sampling time
            (``CatFrames.make_rb_transform_and_sampler``), which takes a third of the memory.
        action_repeat: simulator steps per agent step; only the last one is rendered.
        image_size: height and width of the rendered frame.
        camera_id: camera to render; ``None`` uses 2 for quadruped and 0 elsewhere (DrQ-v2).
        episode_length: simulator steps per episode; the end is a truncation, never a termination.
        render_settings: MuJoCo render quality; ``None`` keeps dm_control's defaults, and
            :meth:`RenderSettings.fast` is 3–4× faster on CPU-only machines.
        seed: seeds the task's random state (initial poses and targets) when given.
        device: device of the returned tensors.

    Returns:
        A ``TransformedEnv`` with uint8 ``"pixels"``, float32 ``"action"`` in [-1, 1] (task
        bounds) and ``"reward"``, and ``"done"``/``"terminated"``/``"truncated"`` flags.

    Examples:
        >>> from vigen.envs.dmc import make_dmc_env
        >>> env = make_dmc_env("walker", "walk", seed=0)
        >>> env.rollout(5)["pixels"].shape
        torch.Size([5, 9, 84, 84])
    """
    domain = DOMAIN_ALIASES.get(domain, domain)
    if (domain, task) not in suite.ALL_TASKS:
        raise ValueError(f"Unknown dm_control task {domain}-{task}. Valid tasks: {', '.join(env_names())}.")
    if frame_stack < 1:
        raise ValueError(f"frame_stack must be at least 1, got {frame_stack}.")
    camera_id = DEFAULT_CAMERAS.get(domain, 0) if camera_id is None else camera_id

    control_env = suite.load(domain, task, task_kwargs={"random": seed, "time_limit": math.inf})
    physics = control_env.physics
    if not 0 <= camera_id < physics.model.ncam:
        raise ValueError(f"camera_id={camera_id} does not exist: {domain} has cameras 0..{physics.model.ncam - 1}.")
    (render_settings or RenderSettings()).apply(physics.model, image_size, image_size)

    repeated = ActionRepeat(control_env, action_repeat, episode_length)
    rendered = pixels.Wrapper(
        repeated, pixels_only=True, render_kwargs={"height": image_size, "width": image_size, "camera_id": camera_id}
    )
    env = DMControlWrapper(rendered, device=device)
    transforms = [ToTensorImage(in_keys=["pixels"], from_int=False, dtype=torch.uint8)]
    if frame_stack > 1:
        transforms.append(CatFrames(N=frame_stack, dim=-3, in_keys=["pixels"]))
    transforms.append(DoubleToFloat())
    env = TransformedEnv(env, Compose(*transforms))
    if seed is not None:
        env.set_seed(seed)
    return env

"""Adroit dexterous-hand tasks (gymnasium-robotics) as TorchRL base envs (the simulator side of the ``adroit`` suite).

gymnasium-robotics is imported when the first env is built. :mod:`vigen.envs.adroit.suite` (the suite
record) adds the levels, channel-first frames and the frame stack.
"""

from __future__ import annotations

import importlib
from typing import Any

import mujoco
import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs.common import _EnvWrapper

from vigen.envs.pixels import check_env_arguments, set_task_specs
from vigen.rendering import RenderSettings


TASKS = {"door": "AdroitHandDoorEnv", "hammer": "AdroitHandHammerEnv", "pen": "AdroitHandPenEnv"}
"""vigen name -> gymnasium-robotics env class (module ``adroit_<name>``)."""

EPISODE_LENGTHS = {"door": 200, "hammer": 200, "pen": 100}
"""Control steps per episode (DAPG / mj_envs ``max_episode_steps``, as in RL-ViGen)."""

SUCCESS_STEPS = {"door": 25, "hammer": 25, "pen": 20}
"""An episode succeeds once the goal holds on more than this many control steps (DAPG's ``evaluate_success``)."""


class AdroitScene:
    """The :class:`~vigen.transforms.scene.SceneHandle` of an Adroit env and its renderer."""

    def __init__(self, env: AdroitPixelEnv) -> None:
        self._env = env

    @property
    def model(self) -> mujoco.MjModel:
        return self._env._env.model

    @property
    def data(self) -> mujoco.MjData:
        return self._env._env.data

    def upload_texture(self, texture_id: int) -> None:
        renderer = self._env.renderer
        renderer._gl_context.make_current()
        mujoco.mjr_uploadTexture(self.model, renderer._mjr_context, texture_id)

    def segmentation(self) -> np.ndarray:
        """``[H, W, 2]`` int32 (object id, object type) of the env's camera; ``-1`` where nothing is hit."""
        renderer = self._env.renderer
        renderer.enable_segmentation_rendering()
        try:
            renderer.update_scene(self.data, camera=self._env.camera)
            return renderer.render()
        finally:
            renderer.disable_segmentation_rendering()


class AdroitPixelEnv(_EnvWrapper):
    """An Adroit hand task rendered to uint8 HWC frames, with the action repeat under the renderer.

    The TorchRL base env of the ``adroit/`` suite (:func:`vigen.envs.make_env` adds the levels and the
    frame stack). The action is the hand's (and arm's) joint
    targets in [-1, 1]; rewards (DAPG's dense reward) are summed over repeated steps; an episode
    ends at ``episode_length`` control steps as a truncation (the tasks do not terminate).
    ``"success"`` follows DAPG's criterion, which RL-ViGen reports: it turns true once the goal
    has held on more than :data:`SUCCESS_STEPS` control steps of the episode (25; 20 for pen),
    so an episode succeeded if its last step says so.

    gymnasium-robotics 1.2.1–1.4.2 flipped the sign of the reach term of the door and hammer
    rewards in its ``v1`` envs (``+0.1·‖palm − handle‖``, pushing the hand away); vigen restores
    DAPG's ``-0.1·‖palm − handle‖``.

    Args:
        task: ``"door"``, ``"hammer"`` or ``"pen"``.
        action_repeat: control steps per agent step; only the last is rendered.
        image_size: height and width of the rendered frame.
        camera: camera name (``"vil_camera"``, or ``"fixed"`` for a closer view).
        episode_length: control steps per episode; ``None``: :data:`EPISODE_LENGTHS` (200, pen 100).
        render_settings: MuJoCo render quality; ``None`` keeps the model's.
        seed: seeds the first reset (initial door, hammer or pen target); ``None`` draws one.
        device: device of the returned tensors.

    Reference: RL-ViGen, https://arxiv.org/abs/2307.10224; Adroit (DAPG), https://arxiv.org/abs/1709.10087.

    Examples:
        >>> from vigen.envs.adroit.env import AdroitPixelEnv
        >>> env = AdroitPixelEnv("door", seed=0)  # doctest: +SKIP
        >>> env.rollout(3)["next", "pixels"].shape  # doctest: +SKIP
        torch.Size([3, 84, 84, 3])
    """

    git_url = "https://github.com/Farama-Foundation/Gymnasium-Robotics"
    libname = "gymnasium_robotics"

    def __init__(
        self,
        task: str,
        *,
        action_repeat: int = 2,
        image_size: int = 84,
        camera: str = "vil_camera",
        episode_length: int | None = None,
        render_settings: RenderSettings | None = None,
        seed: int | None = None,
        device: torch.device | str = "cpu",
    ) -> None:
        check_env_arguments(action_repeat=action_repeat, image_size=image_size, camera=camera, episode_length=episode_length, seed=seed)
        self._next_seed = seed
        episode_length = EPISODE_LENGTHS.get(task, 1) if episode_length is None else episode_length
        super().__init__(
            task=task, action_repeat=action_repeat, image_size=image_size, camera=camera,
            episode_length=episode_length, render_settings=render_settings, device=device,
        )

    def _check_kwargs(self, kwargs: dict) -> None:
        if kwargs["task"] not in TASKS:
            raise ValueError(f"Unknown Adroit task {kwargs['task']!r}. Valid names: {', '.join(TASKS)}.")

    def _build_env(self, task, action_repeat, image_size, camera, episode_length, render_settings) -> Any:
        try:
            module = importlib.import_module(f"gymnasium_robotics.envs.adroit_hand.adroit_{task}")
        except ImportError as error:
            raise ImportError(f"adroit/ envs need gymnasium-robotics: pip install -e \".[adroit]\" ({error}).") from error
        env = getattr(module, TASKS[task])(reward_type="dense")
        cameras = [env.model.camera(i).name for i in range(env.model.ncam)]
        if camera not in cameras:
            raise ValueError(f"No camera {camera!r} in adroit/{task}; cameras: {', '.join(cameras)}.")
        (render_settings or RenderSettings()).apply(env.model, image_size, image_size)
        self.renderer = mujoco.Renderer(env.model, image_size, image_size)
        self.task, self.camera, self.image_size = task, camera, image_size
        self.action_repeat, self.episode_length = action_repeat, episode_length
        self._elapsed = self._goal_steps = 0
        return env

    def _make_specs(self, env: Any) -> None:
        set_task_specs(self, env.action_space.low, env.action_space.high, self.image_size)

    def _init_env(self) -> None:
        pass

    def _set_seed(self, seed: int | None) -> None:
        self._next_seed = seed

    @property
    def scene(self) -> AdroitScene:
        """The handle that scene perturbations (``vigen.transforms``) edit."""
        return AdroitScene(self)

    def render_frame(self) -> np.ndarray:
        """The current view as uint8 ``[H, W, 3]``, top row first."""
        self.renderer.update_scene(self._env.data, camera=self.camera)
        return self.renderer.render()

    def _observation(self, terminated: bool, truncated: bool) -> TensorDict:
        frame = torch.from_numpy(self.render_frame()).to(self.device)
        success = self._goal_steps > SUCCESS_STEPS[self.task]

        def flag(value: bool) -> torch.Tensor:
            return torch.tensor([value], device=self.device)

        return TensorDict(pixels=frame, success=flag(success), done=flag(terminated or truncated),
                          terminated=flag(terminated), truncated=flag(truncated and not terminated))

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        self._env.reset(seed=self._next_seed)
        self._next_seed, self._elapsed, self._goal_steps = None, 0, 0
        return self._observation(False, False)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = tensordict.get("action").detach().cpu().numpy().astype(np.float64)
        reward, terminated = 0.0, False
        for _ in range(self.action_repeat):
            _, step_reward, terminated, _, info = self._env.step(action)
            reward += float(step_reward) + self._reach_sign_fix()
            self._goal_steps += bool(info.get("success", False))
            self._elapsed += 1
            if terminated or self._elapsed >= self.episode_length:
                break
        result = self._observation(bool(terminated), self._elapsed >= self.episode_length)
        result.set("reward", torch.tensor([reward], dtype=torch.float32, device=self.device))
        return result

    def _reach_sign_fix(self) -> float:
        """``-0.2·‖palm − target‖``: turns gymnasium-robotics' ``+0.1·d`` reach term back into DAPG's ``-0.1·d``."""
        env, data = self._env, self._env.data
        if self.task == "door":
            distance = np.linalg.norm(data.site_xpos[env.grasp_site_id] - data.site_xpos[env.handle_site_id])
        elif self.task == "hammer":
            distance = np.linalg.norm(data.site_xpos[env.S_grasp_site_id] - data.xpos[env.obj_body_id])
        else:
            return 0.0
        return -0.2 * float(distance)

    def close(self, *, raise_if_closed: bool = True) -> None:
        renderer = self.__dict__.get("renderer")
        if renderer is not None:
            renderer.close()
            self.renderer = None
        super().close(raise_if_closed=raise_if_closed)

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({self.task}, camera={self.camera}, image_size={self.image_size}, "
            f"action_repeat={self.action_repeat}, episode_length={self.episode_length})"
        )

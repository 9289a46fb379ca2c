"""Adroit dexterous-hand tasks (gymnasium-robotics) as TorchRL pixel envs, with RL-ViGen's Adroit levels.

RL-ViGen's Adroit setting: 84×84 frames from a fixed camera, a stack of 3, success reported per
episode. vigen builds the gymnasium-robotics models (``AdroitHandDoor/Hammer/Pen``, mujoco 3),
repeats each action twice (VRL3's setting) and renders with its own ``mujoco.Renderer`` at the
target size, so :class:`~vigen.rendering.RenderSettings` apply (gymnasium's renderer keeps a
640×480 buffer with multisampling).

Differences from RL-ViGen's ``mj_envs`` models, which need mujoco-py: the gymnasium-robotics models
have no ``top`` camera (RL-ViGen's door and hammer view) and no skybox, so every task renders from
``vil_camera`` (RL-ViGen's pen view) and the colour levels recolour the floor, table and objects
(the background stays black) while the video levels key the background and floor by segmentation.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs import Transform, TransformedEnv
from torchrl.envs.common import _EnvWrapper

from vigen.envs.pixels import PixelEnv, check_env_arguments, perturbations, seed_in_order, set_task_specs, stacked_pixel_env
from vigen.rendering import RenderSettings
from vigen.transforms import ImageBank, RandomCamera, RandomLighting, RandomMaterialColors, RandomTextures, VideoBackground

TASKS = {"door": "AdroitHandDoorEnv", "hammer": "AdroitHandHammerEnv", "pen": "AdroitHandPenEnv"}
"""vigen name -> gymnasium-robotics env class (module ``adroit_<name>``)."""

HAND_PARTS = ("C_", "V_", "MatColl", "MatViz", "forearm", "Adroit", "ARM", "arm")
"""Name prefixes of the hand's and arm's geoms and materials, which the colour levels leave alone."""

EPISODE_LENGTHS = {"door": 200, "hammer": 200, "pen": 100}
"""Simulator steps per episode (DAPG / mj_envs ``max_episode_steps``, as in RL-ViGen)."""

SUCCESS_STEPS = {"door": 25, "hammer": 25, "pen": 20}
"""An episode succeeds once the goal holds on more than this many simulator steps (DAPG's ``evaluate_success``)."""

TABLE_TEXTURES = ("marble2d", "marblecube")
"""The table top's textures, which the colour and video levels replace (RL-ViGen: one of 10 per level)."""

# name -> (what it shows, where it comes from)
LEVELS: dict[str, tuple[str, str]] = {
    "train": ("gymnasium-robotics' default scene", "RL-ViGen train"),
    "color_easy": ("table texture (10 per level), floor and object colours 0.5·default + 0.5·U(0, 1)",
                   "RL-ViGen color-easy (its parts; vigen's colour ranges)"),
    "color_hard": ("table texture (10 per level), floor and object colours U(0, 1)",
                   "RL-ViGen color-hard (its parts; vigen's colour ranges)"),
    "video_easy": ("background and floor replaced by a video; easy colours; light moving 0.04/step within ± 1.2 along y",
                   "RL-ViGen video-easy"),
    "video_hard": ("background and floor replaced by a video; hard colours; light moving 0.12/step within ± 3 along y",
                   "RL-ViGen video-hard"),
    "camera_easy": ("camera moved ± 0.03, turned ± 3.4°, field of view −4° … +5°", "RL-ViGen camera easy (setting.yaml)"),
    "camera_hard": ("camera moved ± 0.07, turned ± 9.2°, field of view ± 10°", "RL-ViGen camera hard (setting.yaml)"),
    "light_easy": ("light moved ± (0.5, 0.5, 0.2)", "RL-ViGen light easy (setting.yaml)"),
    "light_hard": ("light moved ± (1, 1, 0.5)", "RL-ViGen light hard (setting.yaml)"),
}

GROUPS: dict[str, list[str]] = {
    "rlvigen": ["color_easy", "color_hard", "video_easy", "video_hard"],
    "camera": ["camera_easy", "camera_hard"],
    "light": ["light_easy", "light_hard"],
    "all": list(LEVELS),
}

COLOR_MIX = {"easy": 0.5, "hard": 1.0}
MOVING_LIGHT = {"easy": (0.04, 1.2), "hard": (0.12, 3.0)}
CAMERA = {"camera_easy": (0.03, 0.03, (-4.0, 5.0)), "camera_hard": (0.07, 0.08, (-10.0, 10.0))}
"""Position (per axis), quaternion-component noise (RL-ViGen adds it unnormalised; vigen turns by 2·asin of it per axis), FOV."""
LIGHT = {"light_easy": (0.5, 0.5, 0.2), "light_hard": (1.0, 1.0, 0.5)}


def env_names() -> list[str]:
    """The Adroit tasks as vigen env names.

    Examples:
        >>> from vigen.envs.adroit import env_names
        >>> env_names()
        ['adroit/door', 'adroit/hammer', 'adroit/pen']
    """
    return [f"adroit/{task}" for task in TASKS]


def make_named(env: str, **kwargs: Any) -> TransformedEnv:
    """Build ``"adroit/<task>"`` from its ``"<task>"`` part; see :func:`make_adroit_env`."""
    return make_adroit_env(env, **kwargs)


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

    The TorchRL base env of :func:`make_adroit_env`. The action is the hand's (and arm's) joint
    targets in [-1, 1]; rewards (DAPG's dense reward) are summed over repeated steps; an episode
    ends at ``episode_length`` simulator steps as a truncation (the tasks do not terminate).
    ``"success"`` follows DAPG's criterion, which RL-ViGen reports: it turns true once the goal
    has held on more than :data:`SUCCESS_STEPS` simulator steps of the episode (25; 20 for pen),
    so an episode succeeded if its last step says so.

    gymnasium-robotics 1.2.1–1.4.2 flipped the sign of the reach term of the door and hammer
    rewards in its ``v1`` envs (``+0.1·‖palm − handle‖``, pushing the hand away); vigen restores
    DAPG's ``-0.1·‖palm − handle‖``.

    Args:
        task: ``"door"``, ``"hammer"`` or ``"pen"``.
        action_repeat: simulator steps per agent step; only the last is rendered.
        image_size: height and width of the rendered frame.
        camera: camera name (``"vil_camera"``, or ``"fixed"`` for a closer view).
        episode_length: simulator steps per episode; ``None``: :data:`EPISODE_LENGTHS` (200, pen 100).
        render_settings: MuJoCo render quality; ``None`` keeps the model's.
        seed: seeds the first reset (initial door, hammer or pen target); ``None`` draws one.
        device: device of the returned tensors.

    Reference: RL-ViGen, https://arxiv.org/abs/2307.10224; Adroit (DAPG), https://arxiv.org/abs/1709.10087.

    Examples:
        >>> from vigen.envs.adroit import AdroitPixelEnv
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


def level_transforms(level: str, seed: int | None = None, videos: Any = None) -> list[Transform]:
    """The scene transforms of an Adroit ``level``, the ``i``-th seeded with :func:`~vigen.envs.pixels.derive_seed` ``(seed, i)``."""
    if level not in LEVELS:
        raise ValueError(f"Unknown Adroit level {level!r}. Levels: {', '.join(LEVELS)}. Groups: {', '.join(GROUPS)}.")
    return seed_in_order(_level_transforms(level, videos), seed)


def _level_transforms(level: str, videos: Any) -> list[Transform]:
    kind, _, difficulty = level.partition("_")
    if kind in ("color", "video"):
        tables = ImageBank.procedural(10, size=256, seed=100 + ("easy", "hard").index(difficulty))
        built: list[Transform] = [
            RandomTextures(TABLE_TEXTURES, images=tables),
            RandomMaterialColors(mix=COLOR_MIX[difficulty], exclude=HAND_PARTS),
        ]
        if kind == "video":
            step, moving_range = MOVING_LIGHT[difficulty]
            built += [
                RandomLighting(position_offset=None, diffuse_offset=None, moving_step=step, moving_range=moving_range,
                               moving_axes=(1,)),
                VideoBackground(videos, floor=True),
            ]
        return built
    if kind == "camera":
        position, quaternion, fov = CAMERA[level]
        return [RandomCamera(position=position, rotation_deg=math.degrees(2 * math.asin(quaternion)), fov_deg=fov)]
    if kind == "light":
        return [RandomLighting(position_offset=None, diffuse_offset=None, position_jitter=LIGHT[level])]
    return []


def make_adroit_env(
    task: str,
    *,
    frame_stack: int = 3,
    generalization: str | Sequence[Transform] | None = None,
    seed: int | None = None,
    level_options: dict[str, Any] | None = None,
    **env_options: Any,
) -> PixelEnv:
    """Build an Adroit task as a TorchRL pixel env (RL-ViGen's frames: 84×84, a stack of 3).

    Args:
        task: ``"door"``, ``"hammer"`` or ``"pen"``.
        frame_stack: frames stacked along channels (``"pixels"`` is ``[3·frame_stack, H, W]``).
        generalization: a level name (:data:`LEVELS`) or a list of vigen transforms.
        seed: seeds the task's first reset and every perturbation of the env, the ``i``-th with
            ``derive_seed(seed, i)``, as ``env.set_seed(seed)`` does later.
        level_options: ``{"videos": folder}`` for the video levels (default: procedural videos).
        **env_options: options of :class:`AdroitPixelEnv` (``action_repeat``, ``image_size``,
            ``camera``, ``episode_length`` (200; pen 100), ``render_settings``, ``device``).

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("adroit/door", generalization="video_hard", seed=0)  # doctest: +SKIP
        >>> env.rollout(2)["pixels"].shape  # doctest: +SKIP
        torch.Size([2, 9, 84, 84])
    """
    checked = {name: env_options[name] for name in ("action_repeat", "image_size", "camera", "episode_length") if name in env_options}
    check_env_arguments(frame_stack=frame_stack, seed=seed, **checked)
    transforms = perturbations(generalization, lambda level: level_transforms(level, seed, **(level_options or {})))
    return stacked_pixel_env(AdroitPixelEnv(task, seed=seed, **env_options), transforms, frame_stack, seed=seed)

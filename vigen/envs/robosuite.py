"""robosuite manipulation tasks as TorchRL pixel envs, set up as in RL-ViGen, with its generalization levels.

RL-ViGen's robosuite setting: a Panda arm under the ``OSC_POSE`` controller, the ``agentview``
camera at 84×84, shaped rewards, 20 Hz control, 500-step episodes (a time-limit truncation),
action repeat 1 and a stack of 3 frames. TorchRL has no robosuite wrapper; :class:`RobosuitePixelEnv`
is one, following TorchRL's wrapper conventions (specs, seeding, ``_reset``/``_step``).

The levels (RL-ViGen's ``eval-easy``/``medium``/``hard`` scene presets from SECANT, its camera
ranges and its cross-embodiment robots) are made of vigen's scene transforms, the same classes
as for dm_control, acting on the live model through :class:`RobosuiteScene`. robosuite's own
modders are not used: on mujoco 3 they write to renamed texture fields, do not re-upload textures
to an existing render context, and save their defaults against a stale sim after a hard reset.
"""

from __future__ import annotations

import functools
import math
import numbers
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import mujoco
import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs import Transform, TransformedEnv
from torchrl.envs.common import _EnvWrapper

from vigen.envs.pixels import PixelEnv, check_env_arguments, perturbations, seed_in_order, set_task_specs, stacked_pixel_env
from vigen.rendering import RenderSettings
from vigen.transforms import (
    ImageBank,
    RandomCamera,
    RandomLighting,
    RandomMaterialColors,
    RandomTextures,
    VideoBackground,
)

TASKS = {"door": "Door", "lift": "Lift", "two-arm-peg-in-hole": "TwoArmPegInHole"}
"""vigen name -> robosuite environment class."""

ROBOTS = ("Panda", "IIWA", "Kinova3", "Sawyer", "Jaco", "UR5e")
"""Single-arm robots installed with robosuite 1.5.2 whose OSC_POSE + gripper action has 7 dimensions."""

ROBOT_PARTS = ("robot", "gripper", "fixed_mount")
"""Name prefixes of the robot's materials and geoms (arm, gripper, mount)."""

TEXTURES = {
    "door": ("texplane", "tex-light-gray-plaster", "tex-ceramic", "tex-steel-brushed", "Door_dark-wood", "Door_light-wood", "Door_metal"),
    "lift": ("texplane", "tex-light-gray-plaster", "tex-ceramic", "tex-steel-brushed", "cube_redwood"),
    "two-arm-peg-in-hole": ("texplane", "tex-light-gray-plaster", "hole_red-wood", "peg_greenwood"),
}
"""Textures the scene presets replace: floor, walls, table top and legs, and the task's objects (RL-ViGen's aliases)."""

BACKGROUND_TEXTURES = ("texplane", "tex-light-gray-plaster")
"""The floor and wall textures, which the ``hard`` level covers with a video instead."""

SCENES = 10
"""Scene presets per level (RL-ViGen's ``scene_id`` 0..9)."""

SCENE_LEVELS = ("easy", "medium", "hard")
"""The levels whose textures (and ``hard``'s video) depend on the scene id."""

ROBOSUITE_TEXTURES = {
    "easy": ("green-wood", "red-wood", "blue-wood", "gray-woodgrain", "gray-felt", "dirt"),
    "medium": ("wood-varnished-panels", "white-bricks"),
    "hard": (),
}
"""robosuite's own texture files in each level's texture set (RL-ViGen: WoodGreen ... Dirt; WoodPanels, BricksWhite)."""

GENERATED_TEXTURES = {"easy": 5, "medium": 20, "hard": 15}
"""Generated stand-ins for SECANT's Custom01–05, Custom06–25 and Custom26–40 textures, which robosuite 1.5 does not ship."""

CAMERA_RANGES = {"camera_easy": (0.12, 0.12, 10.0), "camera_hard": (0.16, 0.16, 20.0)}
"""RL-ViGen ``robo_setting.yaml``: position (m, per axis), rotation (rad), field of view (±degrees)."""

# name -> (what it shows, where it comes from)
LEVELS: dict[str, tuple[str, str]] = {
    "train": ("robosuite's default scene", "RL-ViGen train"),
    "easy": (
        "new floor, wall, table and object textures per scene; non-robot colours 0.8·default + 0.2·U(0, 1)",
        "RL-ViGen eval-easy (SECANT presets)",
    ),
    "medium": (
        "easy's colours, the medium texture set, the robot in one random colour, a moving spot light with shadows from z = 4",
        "RL-ViGen eval-medium (SECANT presets)",
    ),
    "hard": (
        "the hard texture set, the scene's video behind the robot (floor and walls), a moving light",
        "RL-ViGen eval-hard (SECANT presets, DMC-GB videos)",
    ),
    "camera_easy": ("camera moved ± 0.12 m, turned up to 0.12 rad about each of its axes, field of view ± 10°; easy's colours",
                    "RL-ViGen cam-easy (one random axis there)"),
    "camera_hard": ("camera moved ± 0.16 m, turned up to 0.16 rad about each of its axes, field of view ± 20°; easy's colours",
                    "RL-ViGen cam-hard (one random axis there)"),
    **{
        f"robot_{robot.lower()}": (f"the {robot} arm instead of the Panda, same controller", "RL-ViGen cross-embodiment")
        for robot in ROBOTS[1:]
    },
}

GROUPS: dict[str, list[str]] = {
    "rlvigen": ["easy", "medium", "hard"],
    "camera": ["camera_easy", "camera_hard"],
    "embodiment": [f"robot_{robot.lower()}" for robot in ROBOTS[1:]],
    "all": list(LEVELS),
}


def env_names() -> list[str]:
    """The robosuite tasks as vigen env names.

    Examples:
        >>> from vigen.envs.robosuite import env_names
        >>> env_names()
        ['robosuite/door', 'robosuite/lift', 'robosuite/two-arm-peg-in-hole']
    """
    return [f"robosuite/{task}" for task in TASKS]


def make_named(env: str, **kwargs: Any) -> TransformedEnv:
    """Build ``"robosuite/<task>"`` from its ``"<task>"`` part; see :func:`make_robosuite_env`."""
    return make_robosuite_env(env, **kwargs)


class RobosuiteScene:
    """The :class:`~vigen.transforms.scene.SceneHandle` of a robosuite env's ``MjSim``.

    Examples:
        >>> from vigen.envs.robosuite import RobosuitePixelEnv
        >>> scene = RobosuitePixelEnv("lift", image_size=32).scene  # doctest: +SKIP
        >>> scene.segmentation().shape  # doctest: +SKIP
        (32, 32, 2)
    """

    def __init__(self, env: Any, camera: str, image_size: int) -> None:
        self._env, self._camera, self._image_size = env, camera, image_size

    @property
    def model(self) -> mujoco.MjModel:
        return self._env.sim.model._model

    @property
    def data(self) -> mujoco.MjData:
        return self._env.sim.data._data

    def upload_texture(self, texture_id: int) -> None:
        context = self._env.sim._render_context_offscreen
        if context is not None:
            context.upload_texture(texture_id)

    def segmentation(self) -> np.ndarray:
        """``[H, W, 2]`` int32 (object id, object type) of the agent camera, top row first; ``-1`` where nothing is hit."""
        sim, size = self._env.sim, self._image_size
        camera_id = sim.model.camera_name2id(self._camera)
        sim._render_context_offscreen.gl_ctx.make_current()  # each env has its own GL context
        sim._render_context_offscreen.render(size, size, camera_id=camera_id, segmentation=True)
        types_ids = sim._render_context_offscreen.read_pixels(size, size, segmentation=True)
        return np.ascontiguousarray(types_ids[::-1, :, ::-1])


class RobosuitePixelEnv(_EnvWrapper):
    """A robosuite task rendered from one camera to uint8 HWC frames (top row first), with success flags.

    The TorchRL base env of :func:`make_robosuite_env`. The action is robosuite's (``OSC_POSE``
    deltas and the gripper, in [-1, 1]); the reward is robosuite's shaped reward; an episode ends
    at ``episode_length`` steps as a truncation (robosuite tasks do not terminate). ``"success"`` reports
    the task's success check after every step. Seeding sets robosuite's random generator (robot
    initial joint noise and object placement).

    Args:
        task: ``"door"``, ``"lift"`` or ``"two-arm-peg-in-hole"``.
        robot: the arm (``"Panda"`` in RL-ViGen's training; see :data:`ROBOTS`); two-arm tasks use two.
        image_size: height and width of the rendered frame.
        camera: robosuite camera name.
        episode_length: control steps per episode (robosuite's ``horizon``), the same as agent
            steps since the action repeat is 1.
        control_freq: control steps per simulated second.
        reward_shaping: robosuite's dense reward (RL-ViGen: on).
        render_settings: MuJoCo render quality; ``None`` keeps robosuite's (4096² shadows, 4×
            multisampling, a 640×480 buffer). :meth:`RenderSettings.fast` is much faster on CPU.
        seed: seed of robosuite's random generator; ``None`` draws one.
        device: device of the returned tensors.

    Reference: RL-ViGen, https://arxiv.org/abs/2307.10224; robosuite, https://robosuite.ai.

    Examples:
        >>> from vigen.envs.robosuite import RobosuitePixelEnv
        >>> env = RobosuitePixelEnv("lift", seed=0)  # doctest: +SKIP
        >>> env.rollout(3)["next", "pixels"].shape  # doctest: +SKIP
        torch.Size([3, 84, 84, 3])
    """

    git_url = "https://github.com/ARISE-Initiative/robosuite"
    libname = "robosuite"

    def __init__(
        self,
        task: str,
        *,
        robot: str = "Panda",
        image_size: int = 84,
        camera: str = "agentview",
        episode_length: int = 500,
        control_freq: int = 20,
        reward_shaping: bool = True,
        render_settings: RenderSettings | None = None,
        seed: int | None = None,
        device: torch.device | str = "cpu",
    ) -> None:
        super().__init__(
            task=task, robot=robot, image_size=image_size, camera=camera, episode_length=episode_length,
            control_freq=control_freq, reward_shaping=reward_shaping, render_settings=render_settings,
            seed=seed, device=device,
        )

    def _check_kwargs(self, kwargs: dict) -> None:
        if kwargs["task"] not in TASKS:
            raise ValueError(f"Unknown robosuite task {kwargs['task']!r}. Valid names: {', '.join(TASKS)}.")
        if kwargs["robot"] not in ROBOTS:
            raise ValueError(f"Unknown robot {kwargs['robot']!r}. Robots with the Panda's action space: {', '.join(ROBOTS)}.")
        check_env_arguments(**{name: kwargs[name] for name in ("image_size", "camera", "episode_length", "control_freq", "seed")})

    def _build_env(self, task, robot, image_size, camera, episode_length, control_freq, reward_shaping, render_settings, seed) -> Any:
        try:
            import robosuite
            from robosuite.controllers import load_composite_controller_config
        except ImportError as error:
            raise ImportError(f"robosuite/ envs need robosuite: pip install -e \".[robosuite]\" ({error}).") from error

        robots = [robot, robot] if TASKS[task].startswith("TwoArm") else robot
        env = robosuite.make(
            TASKS[task], robots=robots, controller_configs=load_composite_controller_config(robot=robot),
            has_renderer=False, has_offscreen_renderer=True, use_camera_obs=False, use_object_obs=False,
            reward_shaping=reward_shaping, control_freq=control_freq, horizon=episode_length, hard_reset=False,
            ignore_done=False, seed=seed,
        )
        if camera not in env.sim.model.camera_names:
            raise ValueError(f"No camera {camera!r} in robosuite/{task}; cameras: {', '.join(env.sim.model.camera_names)}.")
        context = env.sim._render_context_offscreen
        context.__class__ = _render_context_class(type(context))
        (render_settings or RenderSettings()).apply(env.sim.model._model, image_size, image_size)
        context.gl_ctx.make_current()
        context.con.free()  # rebuild the render context with the new shadow map, multisampling and buffer
        context._set_mujoco_context_and_buffers()
        self.task, self.robot, self.camera, self.image_size, self.episode_length = task, robot, camera, image_size, episode_length
        self.action_repeat = 1
        self._camera_id = env.sim.model.camera_name2id(camera)
        self._build_seed = seed
        return env

    def _make_specs(self, env: Any) -> None:
        set_task_specs(self, *env.action_spec, self.image_size)

    def _init_env(self) -> None:
        self._env.reset()
        if self._build_seed is not None:  # the first episode is the seed's first draw, as after set_seed(seed)
            self._set_seed(self._build_seed)

    def _set_seed(self, seed: int | None) -> None:
        rng = np.random.default_rng(seed)
        self._env.rng = rng
        samplers = [getattr(self._env, "placement_initializer", None)]
        while samplers:
            sampler = samplers.pop()
            if sampler is not None:
                sampler.rng = rng
                samplers += list(getattr(sampler, "samplers", {}).values())

    @property
    def scene(self) -> RobosuiteScene:
        """The handle that scene perturbations (``vigen.transforms``) edit."""
        return RobosuiteScene(self._env, self.camera, self.image_size)

    def render_frame(self) -> np.ndarray:
        """The current view as uint8 ``[H, W, 3]``, top row first."""
        context, size = self._env.sim._render_context_offscreen, self.image_size
        context.gl_ctx.make_current()  # each env has its own GL context; robosuite's render assumes one
        context.render(size, size, camera_id=self._camera_id)
        return np.ascontiguousarray(context.read_pixels(size, size)[::-1])  # OpenGL rows run bottom-up

    def _observation(self, success: bool, **flags: bool) -> TensorDict:
        values = {name: torch.tensor([value], device=self.device) for name, value in flags.items()}
        return TensorDict(pixels=torch.from_numpy(self.render_frame()).to(self.device), success=torch.tensor([success], device=self.device), **values)

    def _reset(self, tensordict: TensorDictBase | None = None, **kwargs: Any) -> TensorDictBase:
        self._env.reset()
        return self._observation(False, done=False, terminated=False, truncated=False)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        action = tensordict.get("action").detach().cpu().numpy().astype(np.float64)
        _, reward, done, _ = self._env.step(action)
        result = self._observation(bool(self._env._check_success()), done=bool(done), terminated=False, truncated=bool(done))
        result.set("reward", torch.tensor([reward], dtype=torch.float32, device=self.device))
        return result

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({self.task}, robot={self.robot}, camera={self.camera}, "
            f"image_size={self.image_size}, episode_length={self.episode_length})"
        )


class RobosuiteEnv(PixelEnv):
    """The env of :func:`make_robosuite_env`: a :class:`~vigen.envs.pixels.PixelEnv` whose level shows one of 10 scenes.

    ``scene_id`` is the scene the level's textures (and the ``hard`` level's video) show. Built
    without an explicit ``scene_id``, the scene follows the seed: ``set_seed(s)`` moves it to
    ``s % 10``, the scene ``make_robosuite_env(..., seed=s)`` builds, so the two give the same
    episodes. A ``scene_id`` given at build stays through ``set_seed``; :meth:`set_scene`
    changes it either way. Levels without scenes (``train``, camera, robot) and user transforms
    are not touched.

    Args:
        base_env: the :class:`RobosuitePixelEnv`.
        transform: its transform chain.
        level: the level name, or ``None`` for user transforms.
        level_transforms: the level's transforms (in ``transform``) that :func:`select_scene` sets.
        scene_id: the scene they show now.
        scene_follows_seed: whether ``set_seed(s)`` moves them to scene ``s % 10``.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("robosuite/lift", generalization="easy", image_size=32)  # doctest: +SKIP
        >>> _ = env.set_seed(13)  # doctest: +SKIP
        >>> env.scene_id  # doctest: +SKIP
        3
    """

    def __init__(
        self,
        base_env: RobosuitePixelEnv,
        transform: Transform,
        *,
        level: str | None = None,
        level_transforms: Sequence[Transform] = (),
        scene_id: int = 0,
        scene_follows_seed: bool = True,
    ) -> None:
        _check_scene_id(scene_id)
        super().__init__(base_env, transform)
        self.level, self.scene_id, self.scene_follows_seed = level, int(scene_id), scene_follows_seed
        self._scene_transforms = list(level_transforms)

    def set_seed(self, seed: int | None = None, static_seed: bool = False) -> int | None:
        """Seed the env as :meth:`PixelEnv.set_seed` does and, if the scene follows the seed, move the level to scene ``seed % 10``."""
        check_env_arguments(seed=seed)
        if seed is not None and self.scene_follows_seed:
            self.set_scene(seed % SCENES)
        return super().set_seed(seed, static_seed=static_seed)

    def set_scene(self, scene_id: int) -> None:
        """Show the level's scene ``scene_id`` (0..9) from the next reset on."""
        _check_scene_id(scene_id)
        if self.level is not None:
            select_scene(self._scene_transforms, self.level, scene_id)
        self.scene_id = int(scene_id)


@functools.cache
def _render_context_class(base: type) -> type:
    """robosuite's render context, freed in its own GL context.

    robosuite frees a render context's GL objects in whichever context is current, so the
    garbage collection of one env deletes the framebuffers of another env in the same process.
    """

    class RenderContext(base):
        def __del__(self) -> None:
            try:
                self.gl_ctx.make_current()
            except Exception:  # the GL context is already gone at interpreter exit
                return
            super().__del__()

    return RenderContext


def level_transforms(task: str, level: str, scene_id: int = 0, seed: int | None = None, videos: Any = None) -> list[Transform]:
    """The scene transforms of a robosuite ``level`` for ``task`` and one of its 10 scenes.

    Textures come from the level's set (robosuite's texture files and generated stand-ins for
    SECANT's), one image per textured material, fixed by ``scene_id``, as is the ``hard`` level's
    video; colours, lights and cameras are drawn per episode from ``seed``, the ``i``-th transform
    with :func:`~vigen.envs.pixels.derive_seed` ``(seed, i)``. :func:`select_scene` moves them to
    another scene.
    """
    if level not in LEVELS:
        raise ValueError(f"Unknown robosuite level {level!r}. Levels: {', '.join(LEVELS)}. Groups: {', '.join(GROUPS)}.")
    _check_scene_id(scene_id)
    return seed_in_order(select_scene(_level_transforms(task, level, videos), level, scene_id), seed)


def select_scene(transforms: Sequence[Transform], level: str, scene_id: int) -> list[Transform]:
    """Set ``level``'s transforms to its scene ``scene_id`` (0..9): the texture draw and the ``hard`` video; returns them.

    The change takes effect at the next reset; other transforms are left as they are.

    Examples:
        >>> from vigen.envs.robosuite import select_scene
        >>> from vigen.transforms import RandomTextures, VideoBackground
        >>> textures, video = select_scene([RandomTextures(), VideoBackground()], "hard", 4)
        >>> textures.scene_id, video.video
        (24, 4)
    """
    _check_scene_id(scene_id)
    if level not in SCENE_LEVELS:
        return list(transforms)
    for transform in transforms:
        if isinstance(transform, RandomTextures):
            transform.scene_id = SCENES * SCENE_LEVELS.index(level) + int(scene_id)
        elif isinstance(transform, VideoBackground):
            transform.video = int(scene_id)
    return list(transforms)


def _check_scene_id(scene_id: int) -> None:
    if isinstance(scene_id, bool) or not isinstance(scene_id, numbers.Integral):
        raise TypeError(
            f"scene_id must be an int in 0..{SCENES - 1} (or None: seed % {SCENES}), got {scene_id!r} ({type(scene_id).__name__})."
        )
    if not 0 <= scene_id < SCENES:
        raise ValueError(f"scene_id selects one of RL-ViGen's {SCENES} scenes per level: 0..{SCENES - 1}, got {scene_id}.")


def _level_transforms(task: str, level: str, videos: Any) -> list[Transform]:
    local_colors = RandomMaterialColors(mix=0.2, exclude=ROBOT_PARTS)
    moving_light = RandomLighting(position_offset=None, diffuse_offset=None, moving_step=0.03, moving_range=3.0,
                                  height=4.0, directional=False, cast_shadow=True)
    if level in SCENE_LEVELS:
        textures = [name for name in TEXTURES[task] if level != "hard" or name not in BACKGROUND_TEXTURES]
        built = [RandomTextures(textures, images=functools.partial(texture_bank, level))]
        if level == "easy":
            return built + [local_colors]
        if level == "medium":
            robot = RandomMaterialColors(mix=1.0, include=ROBOT_PARTS[:2], shared=True)
            return built + [local_colors, robot, moving_light]
        return built + [local_colors, moving_light, VideoBackground(videos, floor=True, background=("wall",))]
    if level in CAMERA_RANGES:
        position, rotation, fov = CAMERA_RANGES[level]
        camera = RandomCamera(position=position, rotation_deg=math.degrees(rotation), fov_deg=(-fov, fov))
        return [local_colors, camera]
    return []


def texture_bank(level: str) -> ImageBank:
    """The level's texture set: robosuite's texture files, then generated stand-ins for SECANT's custom textures."""
    import robosuite

    folder = Path(robosuite.__file__).parent / "models" / "assets" / "textures"
    generated = ImageBank.procedural(GENERATED_TEXTURES[level], size=256, seed=SCENE_LEVELS.index(level))
    files = ROBOSUITE_TEXTURES[level]
    if not files:
        return generated
    return ImageBank.from_files([folder / f"{name}.png" for name in files], size=256) + generated


def make_robosuite_env(
    task: str,
    *,
    frame_stack: int = 3,
    generalization: str | Sequence[Transform] | None = None,
    scene_id: int | None = None,
    seed: int | None = None,
    level_options: dict[str, Any] | None = None,
    robot: str | None = None,
    **env_options: Any,
) -> RobosuiteEnv:
    """Build a robosuite task as a TorchRL pixel env (RL-ViGen's setup by default).

    Args:
        task: ``"door"``, ``"lift"`` or ``"two-arm-peg-in-hole"``.
        frame_stack: frames stacked along channels (``"pixels"`` is ``[3·frame_stack, H, W]``).
        generalization: a level name (:data:`LEVELS`: ``train``, ``easy``, ``medium``, ``hard``,
            ``camera_easy``, ``camera_hard``, ``robot_iiwa``, ...) or a list of vigen transforms.
        scene_id: which of the level's 10 scenes (RL-ViGen's ``scene_id``), fixed for the env's
            life, through ``set_seed`` too. ``None``: the scene follows the seed, ``seed % 10`` (0
            without a seed) here and after every ``env.set_seed(seed)``, so ``seeds=range(10)`` in
            :func:`vigen.evaluation.evaluate` is RL-ViGen's 10 scenes.
        seed: seeds robosuite (initial joints and object placement) and every perturbation of the
            env, the ``i``-th with ``derive_seed(seed, i)``, and picks the scene (see ``scene_id``):
            ``env.set_seed(seed)`` later does all of it, so the two give the same episodes.
        level_options: ``{"videos": folder}`` for the ``hard`` level's video background
            (default: procedural videos).
        robot: the arm; a ``robot_*`` level sets it. Default ``"Panda"``.
        **env_options: options of :class:`RobosuitePixelEnv` (``image_size``, ``camera``,
            ``episode_length``, ``control_freq``, ``reward_shaping``, ``render_settings``, ``device``).

    Returns:
        A :class:`RobosuiteEnv` with uint8 ``"pixels"`` ``[3·frame_stack, H, W]``, float32
        ``"action"`` and ``"reward"``, ``"success"`` and the done flags.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("robosuite/lift", generalization="easy", scene_id=3, seed=0)  # doctest: +SKIP
        >>> env.rollout(2)["pixels"].shape  # doctest: +SKIP
        torch.Size([2, 9, 84, 84])
    """
    checked = {name: env_options[name] for name in ("image_size", "camera", "episode_length", "control_freq") if name in env_options}
    check_env_arguments(frame_stack=frame_stack, seed=seed, **checked)
    if scene_id is not None:
        _check_scene_id(scene_id)
    scene = (0 if seed is None else seed % SCENES) if scene_id is None else scene_id
    if isinstance(generalization, str) and generalization.startswith("robot_") and generalization in LEVELS:
        level_robot = next(r for r in ROBOTS if r.lower() == generalization[len("robot_"):])
        if robot is not None and robot != level_robot:
            raise ValueError(f"Level {generalization!r} uses the {level_robot} arm, but robot={robot!r} was given.")
        robot = level_robot
    transforms = perturbations(generalization, lambda level: level_transforms(task, level, scene, seed, **(level_options or {})))
    return stacked_pixel_env(RobosuitePixelEnv(task, robot=robot or "Panda", seed=seed, **env_options), transforms,
                             frame_stack, seed=seed, env_class=RobosuiteEnv,
                             level=generalization if isinstance(generalization, str) else None,
                             level_transforms=transforms, scene_id=scene, scene_follows_seed=scene_id is None)

"""robosuite tasks as TorchRL base envs, set up as in RL-ViGen (the simulator side of the ``robosuite`` suite).

RL-ViGen's robosuite setting: a Panda arm under the ``OSC_POSE`` controller, the ``agentview``
camera at 84×84, shaped rewards, 20 Hz control, 500-step episodes (a time-limit truncation),
action repeat 1. TorchRL has no robosuite wrapper; :class:`RobosuitePixelEnv` is one, following
TorchRL's wrapper conventions (specs, seeding, ``_reset``/``_step``). robosuite itself is imported
when the first env is built. :mod:`vigen.envs.robosuite.suite` (the suite record) adds the levels,
channel-first frames and the frame stack.
"""

from __future__ import annotations

import functools
from typing import Any

import mujoco
import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torchrl.envs.common import _EnvWrapper

from vigen.envs.pixels import check_env_arguments, set_task_specs
from vigen.rendering import RenderSettings


TASKS = {"door": "Door", "lift": "Lift", "two-arm-peg-in-hole": "TwoArmPegInHole"}
"""vigen name -> robosuite environment class."""

ROBOTS = ("Panda", "IIWA", "Kinova3", "Sawyer", "Jaco", "UR5e")
"""Single-arm robots installed with robosuite 1.5.2 whose OSC_POSE + gripper action has 7 dimensions."""


class RobosuiteScene:
    """The :class:`~vigen.transforms.scene.SceneHandle` of a robosuite env's ``MjSim``.

    Examples:
        >>> from vigen.envs.robosuite.env import RobosuitePixelEnv
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

    The TorchRL base env of the ``robosuite/`` suite (:func:`vigen.envs.make_env` adds the levels and the
    frame stack). The action is robosuite's (``OSC_POSE``
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
        >>> from vigen.envs.robosuite.env import RobosuitePixelEnv
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

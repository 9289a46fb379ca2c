"""The ``loco`` suite's tasks as TorchRL base envs: the scene, RL-ViGen's task, and the dm_control pixel chain of ``dmc/``.

A :class:`LocoPixelEnv` is a :class:`~vigen.envs.dmc.env.DMCPixelEnv` whose dm_control
environment comes from :func:`~vigen.envs.loco.scene.build_scene` and
:func:`~vigen.envs.loco.tasks.make_control_env` instead of ``suite.load``: the same action
repeat (2), 84×84 frames, episodes of 1000 control steps (10 s) ending as truncations, seeding,
and :class:`~vigen.envs.dmc.env.DMCScene` handle for the scene perturbations.

Where RL-ViGen's training differs from that, an option reproduces it: ``action_mapping="rlvigen_train"``
(raw actions, clipped by the simulator), ``time_limit_as="terminated"`` (its ``Gym2DMC`` gives discount 0
at the time limit, ``loco_wrapper.py:37–39``) and ``start_clearance="rlvigen"`` (its starts: the ``stand``
robot sunk 2 cm into the floor, ``-0.02``; the ``walk`` robot 1 cm above it, vigen's rule too).
"""

from __future__ import annotations

import os
from typing import Any

import dm_env
import torch

from vigen.envs.dmc.env import ActionRepeat, DMCPixelEnv
from vigen.envs.loco.scene import MAX_MESH_FACES, build_scene
from vigen.envs.loco.tasks import ACTION_MAPPINGS, make_control_env, pinned_camera_positions
from vigen.envs.pixels import check_env_arguments
from vigen.rendering import RenderSettings

TIME_LIMITS = ("truncated", "terminated")
"""How an episode that reaches ``episode_length`` ends: a truncation (discount 1, vigen) or RL-ViGen's termination (discount 0)."""


class TerminalTimeLimit(ActionRepeat):
    """Ends episodes at ``episode_length`` control steps with discount 0, as RL-ViGen's training wrapper does.

    RL-ViGen's ``Gym2DMC`` (``wrappers/loco_wrapper.py:37–39``) turns every ``done``, the 10 s time
    limit included, into discount 0, so its agents never bootstrap past the last step. TorchRL reads
    discount 0 as ``terminated``. (An :class:`~vigen.envs.dmc.env.ActionRepeat` of one step whose last
    step has discount 0.)

    Examples:
        >>> from vigen.envs.loco.scene import build_scene
        >>> env = TerminalTimeLimit(make_control_env(build_scene("franka-reach"), seed=0), episode_length=2)
        >>> _ = env.reset()
        >>> [(step.last(), step.discount) for step in (env.step([0.0] * 8), env.step([0.0] * 8))]
        [(False, 1.0), (True, 0.0)]
    """

    def __init__(self, env: Any, episode_length: int) -> None:
        super().__init__(env, 1, episode_length)

    def step(self, action: Any) -> dm_env.TimeStep:
        time_step = super().step(action)
        return time_step._replace(discount=0.0) if time_step.last() else time_step


class LocoPixelEnv(DMCPixelEnv):
    """An RL-ViGen locomotion task (Unitree stand / walk, Franka reach / push) rendered to uint8 HWC frames.

    Args:
        task: ``"unitree-stand"``, ``"unitree-walk"``, ``"franka-reach"`` or ``"franka-push"``.
        robot: ``"go1"`` (default for the Unitree tasks), ``"go2"``, ``"aliengo"``, ``"a1"`` (needs
            ``model_dir``), or ``"panda"`` (the Franka tasks).
        model_dir: a MuJoCo Menagerie checkout to read the robot from (then ``robot`` defaults to ``"a1"``
            for the Unitree tasks, RL-ViGen's robot).
        max_mesh_faces: meshes with more faces are simplified to this many (the source Go1 draws 700k
            triangles per frame, 30× slower than the walker); ``None`` renders the source meshes.
        action_repeat: control steps (0.01 s) per agent step; only the last one is rendered.
        image_size: height and width of the rendered frame.
        camera_id: 0 (RL-ViGen's default: the Unitree's ``back_above``, the Franka's ``side_table``), or
            another camera of the scene (Unitree: 1 ``side``, 2 ``side_low``; Franka: 1 ``above_table``).
        episode_length: control steps (0.01 s) per episode.
        render_settings: MuJoCo render quality; ``None`` keeps dm_control's defaults.
        action_mapping: ``"scaled"`` ([-1, 1] mapped onto the servo ranges, RL-ViGen's evaluator) or
            ``"rlvigen_train"`` (RL-ViGen's training: raw actions, clipped to the ranges); see
            :func:`~vigen.envs.loco.tasks.source_command`.
        time_limit_as: ``"truncated"`` (discount 1 at ``episode_length``: agents bootstrap) or ``"terminated"``
            (RL-ViGen's training: discount 0).
        camera_offset: RL-ViGen's ``cam_pos`` level, 0 (off), 0.08 (easy) or 0.15 (hard): every camera's world
            position pinned at its start plus U(±offset) per axis, drawn once per seed
            (:func:`~vigen.envs.loco.tasks.pinned_camera_positions`).
        start_clearance: quadrupeds: metres from the lowest collision geom to the floor at the start;
            ``None``: 5 mm (stand) or 1 cm (walk); ``-0.02`` is RL-ViGen's sunk ``stand`` start; ``"rlvigen"`` is
            RL-ViGen's start of each task (stand −2 cm, walk 1 cm; the Franka tasks ignore it).
        seed: seed of the task's random state (targets and object placement).
        device: device of the returned tensors.

    Examples:
        >>> env = LocoPixelEnv("unitree-stand", seed=0, image_size=32)
        >>> env
        LocoPixelEnv(unitree-stand, robot=go1, camera_id=0, image_size=32, action_repeat=2, episode_length=1000)
        >>> env.reset()["pixels"].shape, env.action_spec.shape
        (torch.Size([32, 32, 3]), torch.Size([12]))
    """

    def __init__(
        self,
        task: str,
        *,
        robot: str | None = None,
        model_dir: str | os.PathLike | None = None,
        max_mesh_faces: int | None = MAX_MESH_FACES,
        action_repeat: int = 2,
        image_size: int = 84,
        camera_id: int = 0,
        episode_length: int = 1000,
        render_settings: RenderSettings | None = None,
        action_mapping: str = "scaled",
        time_limit_as: str = "truncated",
        camera_offset: float = 0.0,
        start_clearance: float | str | None = None,
        seed: int | None = None,
        device: torch.device | str = "cpu",
    ) -> None:
        check_env_arguments(action_repeat=action_repeat, image_size=image_size, camera_id=camera_id, episode_length=episode_length,
                            seed=seed)
        if robot is not None and not isinstance(robot, str):
            raise TypeError(f"robot must be a robot name (str) or None, got {robot!r} ({type(robot).__name__}).")
        if model_dir is not None and not isinstance(model_dir, (str, os.PathLike)):
            raise TypeError(f"model_dir must be a folder path (str or os.PathLike) or None, got {type(model_dir).__name__}.")
        if max_mesh_faces is not None:
            check_env_arguments(max_mesh_faces=max_mesh_faces)
        if action_mapping not in ACTION_MAPPINGS:
            raise ValueError(f"action_mapping must be one of {', '.join(map(repr, ACTION_MAPPINGS))}, got {action_mapping!r}.")
        if time_limit_as not in TIME_LIMITS:
            raise ValueError(f"time_limit_as must be one of {', '.join(map(repr, TIME_LIMITS))}, got {time_limit_as!r}.")
        if isinstance(camera_offset, bool) or not isinstance(camera_offset, (int, float)) or not camera_offset >= 0:
            raise ValueError(f"camera_offset must be metres >= 0 (RL-ViGen's cam_pos: 0.08 easy, 0.15 hard), got {camera_offset!r}.")
        scene = build_scene(task, robot, model_dir, max_mesh_faces, start_clearance)
        control_env = make_control_env(scene, seed, action_mapping)
        if time_limit_as == "terminated":
            control_env = TerminalTimeLimit(control_env, episode_length)
        self._wrap(control_env, f"loco/{task}", action_repeat=action_repeat, image_size=image_size,
                   camera_id=camera_id, episode_length=episode_length, render_settings=render_settings, device=device)
        self.domain_name, self.task_name = task.partition("-")[0], task.partition("-")[2]
        self.robot, self.model_dir, self.scene_spec = scene.robot, model_dir, scene
        self.action_mapping, self.time_limit_as, self.camera_offset = action_mapping, time_limit_as, float(camera_offset)
        self._pin_cameras(seed)

    def _pin_cameras(self, seed: int | None) -> None:
        if getattr(self, "camera_offset", 0.0) > 0:
            self._env._env.task.camera_positions = pinned_camera_positions(self.scene_spec, self.camera_offset, seed)

    def _set_seed(self, seed: int | None) -> None:
        """Seed the task, and redraw RL-ViGen's once-per-env camera offset from the same seed."""
        super()._set_seed(seed)
        if seed is not None:
            self._pin_cameras(seed)

    def __repr__(self) -> str:
        source = {"action_mapping": (self.action_mapping, "scaled"), "time_limit_as": (self.time_limit_as, "truncated"),
                  "camera_offset": (self.camera_offset, 0.0)}
        changed = "".join(f", {name}={value!r}" for name, (value, default) in source.items() if value != default)
        return (
            f"{type(self).__name__}({self.domain_name}-{self.task_name}, robot={self.robot}, camera_id={self.camera_id}, "
            f"image_size={self.image_size}, action_repeat={self.action_repeat}, episode_length={self.episode_length}{changed})"
        )

"""The ``loco`` suite's tasks as TorchRL base envs: the scene, RL-ViGen's task, and the dm_control pixel chain of ``dmc/``.

A :class:`LocoPixelEnv` is a :class:`~vigen.envs.dmc_env.DMCPixelEnv` whose dm_control
environment comes from :func:`~vigen.envs.loco_scene.build_scene` and
:func:`~vigen.envs.loco_tasks.make_control_env` instead of ``suite.load``: the same action
repeat (2), 84×84 frames, episodes of 1000 control steps (10 s) ending as truncations, seeding,
and :class:`~vigen.envs.dmc_env.DMCScene` handle for the scene perturbations.
"""

from __future__ import annotations

import os

import torch

from vigen.envs.dmc_env import DMCPixelEnv
from vigen.envs.loco_scene import MAX_MESH_FACES, build_scene
from vigen.envs.loco_tasks import make_control_env
from vigen.envs.pixels import check_env_arguments
from vigen.rendering import RenderSettings


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
        action_repeat: simulator steps per agent step; only the last one is rendered.
        image_size: height and width of the rendered frame.
        camera_id: 0 (RL-ViGen's default: the Unitree's ``back_above``, the Franka's ``side_table``), or
            another camera of the scene (Unitree: 1 ``side``, 2 ``side_low``; Franka: 1 ``above_table``).
        episode_length: control steps (0.01 s) per episode.
        render_settings: MuJoCo render quality; ``None`` keeps dm_control's defaults.
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
        scene = build_scene(task, robot, model_dir, max_mesh_faces)
        self._wrap(make_control_env(scene, seed), f"loco/{task}", action_repeat=action_repeat, image_size=image_size,
                   camera_id=camera_id, episode_length=episode_length, render_settings=render_settings, device=device)
        self.domain_name, self.task_name = task.partition("-")[0], task.partition("-")[2]
        self.robot, self.model_dir = scene.robot, model_dir

    def __repr__(self) -> str:
        return (
            f"{type(self).__name__}({self.domain_name}-{self.task_name}, robot={self.robot}, camera_id={self.camera_id}, "
            f"image_size={self.image_size}, action_repeat={self.action_repeat}, episode_length={self.episode_length})"
        )

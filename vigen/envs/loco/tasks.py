"""The ``loco`` suite's tasks and rewards, as RL-ViGen wrote them (``envs/DMCVGB/dm_control/dm_control/suite/{unitree,franka}.py``).

The rewards are pure functions of named physical readings, so each term can be checked by hand;
:class:`QuadrupedTask` and :class:`FrankaTask` (dm_control ``base.Task`` subclasses) read those
values from the physics and call them.

Actions lie in [-1, 1]. RL-ViGen treats them two ways (:data:`ACTION_MAPPINGS`):

* ``"scaled"`` (vigen's default): mapped linearly onto the actuators' control ranges, as RL-ViGen's
  standalone evaluator does (``locoeval.py:113`` wraps the env in dm_control's ``action_scale``);
* ``"rlvigen_train"``: RL-ViGen's training path, which sends the action unscaled (``_convert_action``
  is commented out at ``dmc2gym/wrappers.py:177``; ``loco_wrapper.py:127``'s ``action_scale`` maps
  [-1, 1] onto the [-1, 1] spec it is given, a no-op), so MuJoCo clips it to each control range: an
  A1 knee (−2.697 … −0.916 rad) can only reach −1 … −0.916, the gripper (0 … 255) opens at most
  1/255 of its 4 cm, and the action penalty reads the raw action as a position in the control
  range (the stand reward of an idle A1 loses 0.119). This is a bug of the source that shaped its
  published numbers; it is offered by name to reproduce them.

RL-ViGen's ``current_action`` (what its rewards read) is the mapped control under ``"scaled"`` and
the raw action under ``"rlvigen_train"``, in RL-ViGen's control units (the gripper's 0 … 255).

Read differently from RL-ViGen, with the same result on its robot: RL-ViGen's orientation terms
use the ``framexaxis`` / ``framezaxis`` sensors of the trunk *body*, which MuJoCo reports in the
body's inertial frame. On the A1 that frame's x axis is the trunk's up axis and its z axis the
forward axis (its largest inertia is about the vertical), so ``|x − (0, 0, 1)|²`` penalises tilt and
``|z − (1, 0, 0)|²`` turning away from world x. vigen reads the trunk's up and forward axes from
its body frame, so the terms mean the same on every robot whatever its inertia. Kept as written:
``walk`` pulls the commanded joint angles towards a "stable" pose whose knee angle (0) lies outside
the knee's range, so that term never reaches 0.

Changed from RL-ViGen, because its code does not do what it says:

* ``franka_push`` writes the box's ``body_pos``, which a free joint ignores, so its box always
  starts at (0.44, 0); vigen places the box through its joint, at the same U(0.43, 0.58) × U(−0.1, 0.1);
* ``franka_reach`` draws its targets from NumPy's global random state; vigen draws them from the
  task's seeded one.

Paper: RL-ViGen, https://arxiv.org/abs/2307.10224.
"""

from __future__ import annotations

import collections
from typing import Any

import mujoco
import numpy as np
from dm_control.mujoco import Physics, wrapper
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import rewards
from dm_env import specs

from vigen.envs.loco.scene import LEGS, LEG_JOINTS, LocoScene

ACTION_MAPPINGS = ("scaled", "rlvigen_train")
"""How an action in [-1, 1] becomes the servo targets: scaled onto the control ranges, or RL-ViGen's training path (raw, clipped)."""

CONTROL_TIMESTEP = 0.01
"""Seconds per control step (RL-ViGen's unitree and franka: 0.01 s; 1000 steps = 10 s)."""

WALK_SPEED = 1.0
"""RL-ViGen's walk target speed, m/s along world x."""

WALK_STABLE_POSE = {"front": (0.05, 0.22, -0.8), "rear": (0.1, 0.68, 0.0)}
"""RL-ViGen's "stable" joint targets of ``unitree_walk`` (hip, thigh, calf), which its action penalty pulls towards."""

REACH_TARGET = ((0.4, 0.6), (-0.1, 0.1), (0.65, 0.85))
PUSH_GOAL = ((0.7, 0.85), (-0.1, 0.1))
PUSH_BOX = ((0.43, 0.58), (-0.1, 0.1))
"""RL-ViGen's uniform ranges per axis: the reach target, the push goal and the push box start."""


# -- rewards -------------------------------------------------------------------------------------
def standing(height: float, stand_height: float) -> float:
    """1 at or above ``stand_height``, falling to 0.1 at half of it (dm_control's Gaussian ``tolerance``)."""
    return float(rewards.tolerance(height, bounds=(stand_height, float("inf")), margin=stand_height / 2))


def axis_penalties(up_axis: np.ndarray, forward_axis: np.ndarray) -> tuple[float, float]:
    """RL-ViGen's orientation terms: ``|up − (0, 0, 1)|²`` (tilt) and ``|forward − (1, 0, 0)|²`` (heading), base axes in world coordinates."""
    tilt = float(np.sum(np.square(up_axis - np.array([0.0, 0.0, 1.0]))))
    return tilt, float(np.sum(np.square(forward_axis - np.array([1.0, 0.0, 0.0]))))


def stand_reward(height: float, upright: float, up_axis: np.ndarray, forward_axis: np.ndarray, action: np.ndarray,
                 stand_height: float) -> float:
    """``unitree_stand``: ``(2·standing + upright)/3 − 0.08·mean(a²) − 0.1·tilt − 0.05·heading`` with ``a`` in [-1, 1].

    Examples:
        >>> up, forward = np.array([0, 0, 1.0]), np.array([1.0, 0, 0])
        >>> round(stand_reward(0.36, 1.0, up, forward, np.zeros(12), stand_height=0.36), 6)  # upright, idle, facing +x
        1.0
    """
    x_penalty, z_penalty = axis_penalties(up_axis, forward_axis)
    action_penalty = float(np.mean(np.square(action)))
    return (2 * standing(height, stand_height) + upright) / 3 - 0.08 * action_penalty - 0.1 * x_penalty - 0.05 * z_penalty


def walk_reward(height: float, upright: float, forward: float, up_axis: np.ndarray, forward_axis: np.ndarray, vertical_velocity: float,
                angular_velocity: np.ndarray, forward_velocity: float, control: np.ndarray, stable_control: np.ndarray,
                stand_height: float, speed: float = WALK_SPEED) -> float:
    """``unitree_walk``: ``(s + m + s·m)/3`` with ``s`` the posture score and ``m`` the speed score.

    ``s = (3·standing + upright + forward)/5 − 0.05·mean((ctrl − stable)²) − 0.05·v_z² − 0.005·|ω_xy|² − 0.1·tilt − 0.05·heading``;
    ``m`` is dm_control's linear ``tolerance`` of the velocity along world x: 1 from ``speed`` on, 0.1 at rest,
    ``1 − 0.9·(1 − v/speed)`` in between, 0 from ``speed/9`` backwards.
    """
    x_penalty, z_penalty = axis_penalties(up_axis, forward_axis)
    action_penalty = float(np.sum(np.square(control - stable_control)) / len(control))
    posture = ((3 * standing(height, stand_height) + upright + forward) / 5 - 0.05 * action_penalty - 0.05 * vertical_velocity ** 2
               - 0.005 * float(np.sum(np.square(angular_velocity[:2]))) - 0.1 * x_penalty - 0.05 * z_penalty)
    move = float(rewards.tolerance(forward_velocity, bounds=(speed, float("inf")), margin=speed, sigmoid="linear"))
    return (posture + move + posture * move) / 3


def reach_reward(distance: float, action: np.ndarray) -> float:
    """``franka_reach``: ``tolerance(d, (0, 0.01), margin 0.035) − 0.01·mean(a²)``, ``d`` from the fingers' midpoint to the target."""
    return float(rewards.tolerance(distance, bounds=(0.0, 0.01), margin=0.035)) - 0.01 * float(np.mean(np.square(action)))


def push_reward(left_to_box: float, right_to_box: float, box_to_goal: float, action: np.ndarray) -> float:
    """``franka_push``: ``(t(left) + t(right) + 2·t(box→goal))/4 − 0.01·mean(a²)`` with Gaussian tolerances of margin 0.2."""
    left = rewards.tolerance(left_to_box, bounds=(0.0, 0.001), margin=0.2)
    right = rewards.tolerance(right_to_box, bounds=(0.0, 0.001), margin=0.2)
    goal = rewards.tolerance(box_to_goal, bounds=(0.0, 0.01), margin=0.2)
    return float((left + right + 2 * goal) / 4) - 0.01 * float(np.mean(np.square(action)))


def source_command(action: np.ndarray, source_ctrlrange: np.ndarray, mapping: str = "scaled") -> tuple[np.ndarray, np.ndarray]:
    """RL-ViGen's ``current_action`` for ``action`` in [-1, 1], and the servo targets it sets, both in RL-ViGen's control units.

    ``"scaled"`` maps [-1, 1] linearly onto ``source_ctrlrange`` (``[n, 2]``); ``"rlvigen_train"`` keeps the
    raw action, which the simulator clips to the range.

    Examples:
        >>> knee = np.array([[-2.69653, -0.916298]])  # RL-ViGen's A1 knee
        >>> [np.round(source_command(np.array([a]), knee, "rlvigen_train")[1], 3).item() for a in (-1.0, 0.0, 1.0)]
        [-1.0, -0.916, -0.916]
        >>> np.round(source_command(np.array([0.0]), knee)[1], 3).item()  # scaled: the middle of the range
        -1.806
    """
    action = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
    low, high = np.asarray(source_ctrlrange, dtype=np.float64).T
    if mapping == "rlvigen_train":
        return action, np.clip(action, low, high)
    current = low + (action + 1.0) / 2.0 * (high - low)
    return current, current


def normalized_action(current_action: np.ndarray, source_ctrlrange: np.ndarray) -> np.ndarray:
    """The action RL-ViGen's stand, reach and push penalties square: ``current_action`` mapped from the control range onto [-1, 1].

    ``unitree.py`` and ``franka.py``: ``-1 + 2·(current_action − min) / (max − min)``. Under ``"scaled"``
    that is the agent's action; under ``"rlvigen_train"`` a raw 0 on the A1's knee reads as 2.03.

    Examples:
        >>> np.round(normalized_action(np.zeros(3), np.array([[-0.802851, 0.802851], [-1.0472, 4.18879], [-2.69653, -0.916298]])), 3)
        array([ 0.   , -0.6  ,  2.029])
    """
    low, high = np.asarray(source_ctrlrange, dtype=np.float64).T
    return -1.0 + 2.0 * (np.asarray(current_action, dtype=np.float64) - low) / (high - low)


def pinned_camera_positions(scene: LocoScene, offset: float, seed: int | None) -> np.ndarray:
    """RL-ViGen's ``cam_pos`` level: ``[ncam, 3]`` world camera positions, the start state's plus U(±``offset``) each.

    As ``dmc2gym/wrappers.py:98–106``: the offsets are drawn once, by a ``RandomState(seed)`` of their own,
    and added to ``cam_xpos`` as the env is made (its bodies in the start pose).

    Examples:
        >>> from vigen.envs.loco.scene import build_scene
        >>> scene = build_scene("franka-reach")
        >>> start = pinned_camera_positions(scene, 0.0, seed=0)
        >>> moved = pinned_camera_positions(scene, 0.08, seed=0)
        >>> bool(np.abs(moved - start).max() <= 0.08), np.array_equal(moved, pinned_camera_positions(scene, 0.08, seed=0))
        (True, True)
    """
    data = mujoco.MjData(scene.model)
    data.qpos[:] = scene.start_qpos
    mujoco.mj_forward(scene.model, data)
    return data.cam_xpos + np.random.RandomState(seed).uniform(-offset, offset, size=data.cam_xpos.shape)


# -- tasks ---------------------------------------------------------------------------------------
class ScaledActionTask(base.Task):
    """A task whose actions lie in [-1, 1], turned into servo targets by ``action_mapping`` (:func:`source_command`).

    :attr:`camera_positions` (``[ncam, 3]``, or ``None``) is RL-ViGen's ``cam_pos`` level
    (``dmc2gym/wrappers.py:203–204``): written into the world ``cam_xpos`` before every frame, so a camera on
    the trunk stays where it was while its orientation follows the trunk (:func:`pinned_camera_positions`).

    Subclasses place their objects (:meth:`place_objects`) and define the reward.
    """

    def __init__(self, scene: LocoScene, random: Any = None, action_mapping: str = "scaled") -> None:
        if action_mapping not in ACTION_MAPPINGS:
            raise ValueError(f"action_mapping must be one of {', '.join(map(repr, ACTION_MAPPINGS))}, got {action_mapping!r}.")
        super().__init__(random=random)
        self.scene, self.action_mapping = scene, action_mapping
        self.source_ctrlrange = scene.source_ctrlrange
        self.camera_positions: np.ndarray | None = None
        self._command(np.zeros(scene.model.nu))

    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        return specs.BoundedArray((physics.model.nu,), np.float64, -1.0, 1.0, name="action")

    def _command(self, action: np.ndarray) -> None:
        """Keep what RL-ViGen's rewards read: ``action`` (the normalized action), ``control`` (its ``current_action``), and the targets."""
        self.control, targets = source_command(action, self.source_ctrlrange, self.action_mapping)
        self.targets = targets * self.scene.source_ctrl_scale
        if self.action_mapping == "scaled":
            self.action = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        else:
            self.action = normalized_action(self.control, self.source_ctrlrange)

    def before_step(self, action: np.ndarray, physics: Physics) -> None:
        self._command(action)
        physics.set_control(self.targets)

    def initialize_episode(self, physics: Physics) -> None:
        physics.reset()
        with physics.reset_context():
            physics.data.qpos[:] = self.scene.start_qpos
            self.place_objects(physics)
        self._command(np.zeros(physics.model.nu))
        super().initialize_episode(physics)

    def place_objects(self, physics: Physics) -> None:
        """Draw the episode's targets and objects (none by default)."""

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        # the last call after every reset and step, before the frame is rendered: where RL-ViGen's render() pins the cameras
        if self.camera_positions is not None:
            physics.data.cam_xpos[:] = self.camera_positions
        return collections.OrderedDict(position=physics.data.qpos.copy(), velocity=physics.data.qvel.copy())


class QuadrupedTask(ScaledActionTask):
    """RL-ViGen's ``unitree_stand`` (``walk=False``: rise from a folded pose) and ``unitree_walk`` (1 m/s along x).

    Examples:
        >>> from vigen.envs.loco.scene import build_scene
        >>> env = make_control_env(build_scene("unitree-stand"), seed=0)
        >>> time_step = env.reset()
        >>> round(env.task.readings(env.physics)["height"], 3), env.action_spec().shape
        (0.129, (12,))
    """

    def __init__(self, scene: LocoScene, walk: bool, random: Any = None, **options: Any) -> None:
        super().__init__(scene, random=random, **options)
        self.walk = walk
        self.stable_control = np.array([WALK_STABLE_POSE["front" if leg[0] == "F" else "rear"][i]
                                        for leg in LEGS for i, _ in enumerate(LEG_JOINTS)])

    def readings(self, physics: Physics) -> dict[str, Any]:
        """The physical values the rewards read (RL-ViGen's ``Physics`` methods): the base body's pose and its sensors."""
        data, body = physics.named.data, self.scene.base_body
        return {
            "height": float(data.xpos[body][2]),
            "upright": float(data.xmat[body][8]),
            "forward": float(data.xmat[body][0]),
            "up_axis": data.xmat[body].reshape(3, 3)[:, 2].copy(),
            "forward_axis": data.xmat[body].reshape(3, 3)[:, 0].copy(),
            "vertical_velocity": float(data.sensordata["base_subtreelinvel"][2]),
            "forward_velocity": float(data.sensordata["base_subtreelinvel"][0]),
            "angular_velocity": data.sensordata["base_angvel"].copy(),
        }

    def get_reward(self, physics: Physics) -> float:
        r = self.readings(physics)
        if not self.walk:
            return stand_reward(r["height"], r["upright"], r["up_axis"], r["forward_axis"], self.action, self.scene.stand_height)
        return walk_reward(r["height"], r["upright"], r["forward"], r["up_axis"], r["forward_axis"], r["vertical_velocity"],
                           r["angular_velocity"], r["forward_velocity"], self.control, self.stable_control, self.scene.stand_height)


class FrankaTask(ScaledActionTask):
    """RL-ViGen's ``franka_reach`` (fingers to a target ball) and ``franka_push`` (a box onto a goal square).

    Examples:
        >>> from vigen.envs.loco.scene import build_scene
        >>> env = make_control_env(build_scene("franka-push"), seed=0)
        >>> time_step = env.reset()
        >>> sorted(env.task.readings(env.physics)), env.action_spec().shape
        (['box_to_goal', 'fingers_to_target', 'left_to_box', 'right_to_box'], (7,))
    """

    def __init__(self, scene: LocoScene, push: bool, random: Any = None, **options: Any) -> None:
        super().__init__(scene, random=random, **options)
        self.push = push

    def place_objects(self, physics: Physics) -> None:
        model = physics.named.model
        if not self.push:
            model.site_pos["target_ball"] = [self.random.uniform(*bounds) for bounds in REACH_TARGET]
            return
        model.site_pos["target_box"][:2] = [self.random.uniform(*bounds) for bounds in PUSH_GOAL]
        physics.named.data.qpos["object_box"][:2] = [self.random.uniform(*bounds) for bounds in PUSH_BOX]

    def readings(self, physics: Physics) -> dict[str, float]:
        data = physics.named.data
        left, right = self.scene.finger_bodies
        target = data.site_xpos["target_ball"]
        readings = {"fingers_to_target": float(np.linalg.norm(target - (data.xpos[left] + data.xpos[right]) / 2))}
        if self.push:
            readings.update(left_to_box=float(np.linalg.norm(target - data.site_xpos["left_finger"])),
                            right_to_box=float(np.linalg.norm(target - data.site_xpos["right_finger"])),
                            box_to_goal=float(np.linalg.norm(target - data.site_xpos["target_box"])))
        return readings

    def get_reward(self, physics: Physics) -> float:
        r = self.readings(physics)
        if not self.push:
            return reach_reward(r["fingers_to_target"], self.action)
        return push_reward(r["left_to_box"], r["right_to_box"], r["box_to_goal"], self.action)


def make_control_env(scene: LocoScene, seed: int | None = None, action_mapping: str = "scaled") -> control.Environment:
    """The dm_control environment of a built scene: its task, 0.01 s control steps, no time limit (the env wrapper cuts episodes).

    ``action_mapping``: see :func:`source_command`.
    """
    physics = Physics.from_model(wrapper.MjModel(scene.model))
    options = {"random": seed, "action_mapping": action_mapping}
    if scene.task.startswith("unitree"):
        task: base.Task = QuadrupedTask(scene, walk=scene.task == "unitree-walk", **options)
    else:
        task = FrankaTask(scene, push=scene.task == "franka-push", **options)
    return control.Environment(physics, task, time_limit=float("inf"), control_timestep=CONTROL_TIMESTEP)

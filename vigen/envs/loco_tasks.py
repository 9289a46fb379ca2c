"""The ``loco`` suite's tasks and rewards, as RL-ViGen wrote them (``envs/DMCVGB/dm_control/dm_control/suite/{unitree,franka}.py``).

The rewards are pure functions of named physical readings, so each term can be checked by hand;
:class:`QuadrupedTask` and :class:`FrankaTask` (dm_control ``base.Task`` subclasses) read those
values from the physics and call them. Both tasks take actions in [-1, 1] and map them linearly
onto the actuators' control ranges, as RL-ViGen's ``action_scale`` wrapper does; RL-ViGen's
``current_action`` (in control units) is that mapped action.

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

import numpy as np
from dm_control.mujoco import Physics, wrapper
from dm_control.rl import control
from dm_control.suite import base
from dm_control.utils import rewards
from dm_env import specs

from vigen.envs.loco_scene import LEGS, LEG_JOINTS, LocoScene

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


# -- tasks ---------------------------------------------------------------------------------------
class ScaledActionTask(base.Task):
    """A task whose actions lie in [-1, 1] and are mapped linearly onto the actuators' control ranges (RL-ViGen's ``action_scale``).

    Subclasses place their objects (:meth:`place_objects`) and define the reward.
    """

    def __init__(self, scene: LocoScene, random: Any = None) -> None:
        super().__init__(random=random)
        self.scene = scene
        self._command(np.zeros(scene.model.nu), scene.model.actuator_ctrlrange)

    def action_spec(self, physics: Physics) -> specs.BoundedArray:
        return specs.BoundedArray((physics.model.nu,), np.float64, -1.0, 1.0, name="action")

    def _command(self, action: np.ndarray, ctrlrange: np.ndarray) -> None:
        """Keep ``action`` (clipped to [-1, 1]) and the control it maps to: RL-ViGen's rewards read one or the other."""
        self.action = np.clip(np.asarray(action, dtype=np.float64), -1.0, 1.0)
        low, high = ctrlrange.T
        self.control = low + (self.action + 1.0) / 2.0 * (high - low)

    def before_step(self, action: np.ndarray, physics: Physics) -> None:
        self._command(action, physics.model.actuator_ctrlrange)
        physics.set_control(self.control)

    def initialize_episode(self, physics: Physics) -> None:
        physics.reset()
        with physics.reset_context():
            physics.data.qpos[:] = self.scene.start_qpos
            self.place_objects(physics)
        self._command(np.zeros(physics.model.nu), physics.model.actuator_ctrlrange)
        super().initialize_episode(physics)

    def place_objects(self, physics: Physics) -> None:
        """Draw the episode's targets and objects (none by default)."""

    def get_observation(self, physics: Physics) -> collections.OrderedDict:
        return collections.OrderedDict(position=physics.data.qpos.copy(), velocity=physics.data.qvel.copy())


class QuadrupedTask(ScaledActionTask):
    """RL-ViGen's ``unitree_stand`` (``walk=False``: rise from a folded pose) and ``unitree_walk`` (1 m/s along x).

    Examples:
        >>> from vigen.envs.loco_scene import build_scene
        >>> env = make_control_env(build_scene("unitree-stand"), seed=0)
        >>> time_step = env.reset()
        >>> round(env.task.readings(env.physics)["height"], 3), env.action_spec().shape
        (0.129, (12,))
    """

    def __init__(self, scene: LocoScene, walk: bool, random: Any = None) -> None:
        super().__init__(scene, random=random)
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
        >>> from vigen.envs.loco_scene import build_scene
        >>> env = make_control_env(build_scene("franka-push"), seed=0)
        >>> time_step = env.reset()
        >>> sorted(env.task.readings(env.physics)), env.action_spec().shape
        (['box_to_goal', 'fingers_to_target', 'left_to_box', 'right_to_box'], (7,))
    """

    def __init__(self, scene: LocoScene, push: bool, random: Any = None) -> None:
        super().__init__(scene, random=random)
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


def make_control_env(scene: LocoScene, seed: int | None = None) -> control.Environment:
    """The dm_control environment of a built scene: its task, 0.01 s control steps, no time limit (the env wrapper cuts episodes)."""
    physics = Physics.from_model(wrapper.MjModel(scene.model))
    if scene.task.startswith("unitree"):
        task: base.Task = QuadrupedTask(scene, walk=scene.task == "unitree-walk", random=seed)
    else:
        task = FrankaTask(scene, push=scene.task == "franka-push", random=seed)
    return control.Environment(physics, task, time_limit=float("inf"), control_timestep=CONTROL_TIMESTEP)

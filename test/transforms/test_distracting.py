"""The Distracting Control Suite's camera and colour distractions against the source's definitions.

Numbers and formulas come from google-research/google-research ``distracting_control/camera.py``,
``color.py`` and ``suite_utils.py`` (commit 0c1bbe5f) and DMC-GB's copy
(nicklashansen/dmcontrol-generalization-benchmark ``src/env/distracting_control/``, commit ff9c0aa8);
see also ../shared/reference/ANCHORS.md §3.4.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from vigen.envs import make_env
from vigen.rendering import RenderSettings
from vigen.transforms import DistractingCamera, DistractingColors
from vigen.transforms.scene.distracting import DCS_NUM_VIDEOS, DCS_SCALES, dcs_ground_plane_alpha

pytestmark = pytest.mark.render

FAST = RenderSettings.fast()
CAMERA_FIELDS = ["cam_pos", "cam_quat", "cam_pos0", "cam_poscom0", "cam_mat0"]


def build(task: str = "walker-walk", transforms=(), seed: int = 0):
    return make_env(f"dmc/{task}", generalization=list(transforms), seed=seed, frame_stack=1, image_size=32,
                    render_settings=FAST)


def rollout(env, steps: int) -> torch.Tensor:
    state = env.reset()
    frames = [state["pixels"]]
    for _ in range(steps):
        state = env.step(state.set("action", torch.zeros(env.action_spec.shape)))["next"]
        frames.append(state["pixels"])
    return torch.stack(frames)


def sphere2cart(radius, h_angle, v_angle):  # camera.py: sphere2cart
    return radius * np.array([math.sin(v_angle) * math.cos(h_angle), math.sin(v_angle) * math.sin(h_angle), math.cos(v_angle)])


def cart2sphere(p):  # camera.py: cart2sphere
    return np.array([np.linalg.norm(p), math.atan2(p[1], p[0]), math.atan2(np.linalg.norm(p[:2]), p[2])])


@pytest.fixture(scope="module")
def walker_scene():
    env = build()
    env.reset()
    return env.base_env.scene


def test_source_tables():
    # DMC-GB suite_utils.py DIFFICULTY_NUM_VIDEOS and src/arguments.py intensities
    assert DCS_SCALES == (0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5)
    assert dict(DCS_NUM_VIDEOS) == {0.025: 2, 0.05: 2, 0.1: 4, 0.15: 6, 0.2: 8, 0.3: None, 0.4: None, 0.5: None}
    # suite_utils.get_background_kwargs: reacher 0, walker / cheetah 1, others 0.3
    assert [dcs_ground_plane_alpha(d) for d in ("reacher", "walker", "cheetah", "finger", "ball_in_cup")] == [0, 1, 1, .3, .3]


@pytest.mark.parametrize("scale", [0.3, 1.0])
def test_camera_draws_fill_the_source_ranges(walker_scene, scale):
    camera = DistractingCamera(scale)
    defaults = camera.read_defaults(walker_scene)
    # walker's camera 0 is trackcom: DCS centres it on the root subtree's CoM, start = cam_poscom0
    r0, h0, v0 = cart2sphere(walker_scene.model.cam_poscom0[0])
    half = math.pi / 2 * scale
    bounds = {  # setup_camera, with limit_to_upper_quadrant (every domain but reacher)
        "radius": (r0 * (1 - 0.5 * scale), r0 * (1 + 1.5 * scale)),
        "azimuth": (max(h0 - half, -math.pi), min(h0 + half, 0.0)),
        "polar": (max(v0 - half, 0.0), min(v0 + half, math.pi / 2)),
        "roll": (-half, half),
    }
    rng = np.random.default_rng(0)
    draws = [camera.sample(rng, defaults) for _ in range(200)]
    values = {"radius": [d["sphere"][0] for d in draws], "azimuth": [d["sphere"][1] for d in draws],
              "polar": [d["sphere"][2] for d in draws], "roll": [d["roll"] for d in draws]}
    for name, (low, high) in bounds.items():
        v = np.array(values[name])
        assert low - 1e-9 <= v.min() and v.max() <= high + 1e-9, name
        assert v.min() < low + 0.05 * (high - low) and v.max() > high - 0.05 * (high - low), f"{name} fills its range"
    assert all(np.abs(d["velocity"]).max() < 1e-12 and d["roll_velocity"] == 0 for d in draws), "static: no drift"


def reference_walk(rng, state, s, k, low, high):
    """camera.py DistractingCameraEnv._apply, step by step, with get_camera_kwargs(scale=s, dynamic=True)."""
    vel_std, max_vel, roll_std, max_roll_vel, roll_delta = .1 * s, .4 * s, math.pi / 300 * s, math.pi / 50 * s, math.pi / 2 * s
    vel = state["vel"] + rng.standard_normal(3) * vel_std * k
    roll_vel = state["roll_vel"] + rng.standard_normal() * roll_std
    norm = np.sqrt(np.sum(vel ** 2))
    if norm > max_vel * k:
        vel = vel * (max_vel * k) / norm
    roll_vel = np.clip(roll_vel, -max_roll_vel, max_roll_vel)
    cart = sphere2cart(*state["sphere"])
    sphere2 = cart2sphere(cart + vel)
    sphere2 = np.array([np.clip(sphere2[i], low[i], high[i]) for i in range(3)])
    roll2 = np.clip(state["roll"] + roll_vel, -roll_delta, roll_delta)
    return {"sphere": sphere2, "vel": sphere2cart(*sphere2) - cart, "roll": roll2, "roll_vel": roll2 - state["roll"]}


def test_dynamic_camera_walk_follows_the_source_step_by_step(walker_scene):
    s = 0.4
    camera = DistractingCamera(s, dynamic=True)
    defaults = camera.read_defaults(walker_scene)
    k = np.linalg.norm(walker_scene.model.cam_poscom0[0]) / 4  # vel_scaling = start radius / 4
    low, high = defaults["low"], defaults["high"]
    rng, ref_rng = np.random.default_rng(5), np.random.default_rng(5)
    params = camera.sample(rng, defaults)
    # setup_camera's draws, in its order: h, v, r, roll, unit velocity * U(0, max_vel), roll velocity; then one _apply
    h, v, r, roll = (ref_rng.uniform(low[1], high[1]), ref_rng.uniform(low[2], high[2]), ref_rng.uniform(low[0], high[0]),
                     ref_rng.uniform(-math.pi / 2 * s, math.pi / 2 * s))
    vel = ref_rng.standard_normal(3)
    vel = vel / np.linalg.norm(vel) * ref_rng.uniform(0, .4 * s)
    state = {"sphere": np.array([r, h, v]), "vel": vel, "roll": roll, "roll_vel": ref_rng.uniform(-math.pi / 50 * s, math.pi / 50 * s)}
    speeds = []
    for _ in range(300):
        state = reference_walk(ref_rng, state, s, k, low, high)
        np.testing.assert_allclose(params["sphere"], state["sphere"], rtol=0, atol=1e-9)
        np.testing.assert_allclose(params["velocity"], state["vel"], rtol=0, atol=1e-9)
        assert params["roll"] == pytest.approx(state["roll"], abs=1e-12)
        speeds.append(np.linalg.norm(params["velocity"]))
        camera.walk(rng, defaults, params)
    assert max(speeds) <= .4 * s * k + 1e-9 and max(speeds) > 0


def camera_pose(scene, camera: int = 0):
    return scene.data.cam_xpos[camera].copy(), scene.data.cam_xmat[camera].reshape(3, 3).copy()


def test_trackcom_camera_sits_at_the_drawn_sphere_point_and_looks_at_the_target():
    camera = DistractingCamera(0.3, seed=1)
    env = build(transforms=[camera])
    clean = build()
    clean.reset()
    env.reset()
    scene = env.base_env.scene
    position, xmat = camera_pose(scene)
    com = scene.data.subtree_com[1]
    radius, h_angle, v_angle = camera.params["sphere"]
    np.testing.assert_allclose(position - com, sphere2cart(radius, h_angle, v_angle), atol=1e-9)
    # get_lookat_point: the default camera's view axis, at the camera's distance to the CoM
    default_position, default_xmat = camera_pose(clean.base_env.scene)
    default_com = clean.base_env.scene.data.subtree_com[1]
    offset = default_position - default_com
    target = com + offset + default_xmat @ np.array([0, 0, -np.linalg.norm(offset)])
    view = -xmat[:, 2]
    np.testing.assert_allclose(view, (target - position) / np.linalg.norm(target - position), atol=1e-9)
    # get_lookat_xmat_no_roll then the roll about the view axis: undoing the roll leaves a level x axis
    level = xmat @ np.array([[math.cos(-camera.params["roll"]), -math.sin(-camera.params["roll"]), 0],
                             [math.sin(-camera.params["roll"]), math.cos(-camera.params["roll"]), 0], [0, 0, 1]])
    assert abs(level[2, 0]) < 1e-9
    assert abs(camera.params["roll"]) > 0.01


def test_fixed_camera_orbits_the_world_origin():
    camera = DistractingCamera(0.2, seed=3)
    env = build("cartpole-swingup", [camera])
    env.reset()
    scene = env.base_env.scene
    position, xmat = camera_pose(scene)
    np.testing.assert_allclose(position, sphere2cart(*camera.params["sphere"]), atol=1e-9)
    start = np.array([0.0, -4.0, 1.0])  # cartpole.xml: <camera name="fixed" pos="0 -4 1" zaxis="0 -1 0"/>
    assert np.linalg.norm(position - start) > 0.05
    assert np.allclose(scene.model.cam_mode[0], 0)
    view = -xmat[:, 2]
    target = camera.defaults(scene)["target"]  # world frame: the camera sits on the world body
    np.testing.assert_allclose(view, (target - position) / np.linalg.norm(target - position), atol=1e-9)


def test_scale_zero_gives_the_clean_frames_and_restore_is_exact():
    clean = rollout(build(), 3)
    transforms = [DistractingCamera(0.0, dynamic=True, seed=0), DistractingColors(0.0, dynamic=True, seed=0)]
    assert torch.equal(rollout(build(transforms=transforms), 3), clean)

    camera, colors = DistractingCamera(0.5, dynamic=True, seed=0), DistractingColors(0.5, dynamic=True, seed=0)
    env = build(transforms=[camera, colors])
    model = env.base_env.scene.model
    before = {name: getattr(model, name).copy() for name in CAMERA_FIELDS + ["mat_rgba", "tex_data"]}
    rollout(env, 2)
    assert not np.array_equal(model.cam_poscom0, before["cam_poscom0"]) and not np.array_equal(model.mat_rgba, before["mat_rgba"])
    camera.restore()
    colors.restore()
    for name, value in before.items():
        assert np.array_equal(getattr(model, name), value), name


def test_dynamic_variants_move_every_step_and_replay_from_the_seed():
    def run(seed):
        camera, colors = DistractingCamera(0.3, dynamic=True, seed=seed), DistractingColors(0.3, dynamic=True, seed=seed)
        env = build(transforms=[camera, colors], seed=seed)  # make_env derives the transforms' seeds from its own
        model = env.base_env.scene.model
        state = env.reset()
        poses, rgbs, frames = [], [], [state["pixels"]]
        for _ in range(3):
            state = env.step(state.set("action", torch.zeros(6)))["next"]
            poses.append(model.cam_poscom0[0].copy())
            rgbs.append(model.mat_rgba[:, :3].copy())
            frames.append(state["pixels"])
        return np.stack(poses), np.stack(rgbs), torch.stack(frames)

    poses, rgbs, frames = run(4)
    assert (np.linalg.norm(np.diff(poses, axis=0), axis=1) > 0).all(), "the camera moves at every step"
    assert (np.abs(np.diff(rgbs, axis=0)).max(axis=(1, 2)) > 0).all(), "the colours walk at every step"
    again = run(4)
    assert np.array_equal(again[0], poses) and np.array_equal(again[1], rgbs) and torch.equal(again[2], frames)
    assert not np.array_equal(run(5)[0], poses)


def test_static_camera_holds_its_pose_for_the_episode():
    camera = DistractingCamera(0.3, seed=0)
    env = build(transforms=[camera])
    model = env.base_env.scene.model
    state = env.reset()
    pose = model.cam_poscom0[0].copy()
    for _ in range(2):
        state = env.step(state.set("action", torch.zeros(6)))["next"]
    assert np.array_equal(model.cam_poscom0[0], pose)
    env.reset()
    assert not np.array_equal(model.cam_poscom0[0], pose), "a new viewpoint per episode"


def test_colors_draw_every_material_in_its_box(walker_scene):
    s = 0.3
    colors = DistractingColors(s)
    defaults = colors.read_defaults(walker_scene)
    original = walker_scene.model.mat_rgba[:, :3].copy()
    assert len(defaults["materials"]) == walker_scene.model.nmat, "DCS edits mat_rgba[:, :3] of every material"
    low, high = np.clip(original - s, 0, 1), np.clip(original + s, 0, 1)  # color.py _reset_color
    rng = np.random.default_rng(0)
    draws = np.stack([colors.sample(rng, defaults)["rgb"] for _ in range(200)])
    assert (draws >= low - 1e-12).all() and (draws <= high + 1e-12).all()
    width = high - low
    assert (draws.min(axis=0) < low + 0.05 * width).all() and (draws.max(axis=0) > high - 0.05 * width).all()
    assert set(np.unique(np.stack(defaults["materials"]))) == set(range(walker_scene.model.nmat))


def test_dynamic_colors_walk_with_the_source_std_inside_the_box(walker_scene):
    s = 0.5
    colors = DistractingColors(s, dynamic=True, seed=0)

    class Scene:  # the model only: advance writes colours, it renders nothing
        model = walker_scene.model

    scene = Scene()
    before = walker_scene.model.mat_rgba.copy()
    defaults = colors.read_defaults(walker_scene)
    colors.params = colors.sample(colors.generator(), defaults)
    steps = []
    for _ in range(300):
        start = colors.params["rgb"].copy()
        colors.advance(scene, defaults, colors.params)
        steps.append(colors.params["rgb"] - start)
        assert (colors.params["rgb"] >= defaults["low"]).all() and (colors.params["rgb"] <= defaults["high"]).all()
    free = np.concatenate(steps).ravel()
    free = free[(free != 0)]
    assert np.std(free[np.abs(free) < 0.05]) == pytest.approx(0.03 * s, rel=0.15)  # step_std = 0.03 * scale
    assert np.array_equal(walker_scene.model.mat_rgba[:, 3], before[:, 3]), "alpha untouched"
    walker_scene.model.mat_rgba[:] = before


def test_parts_select_materials_by_prefix(walker_scene):
    colors = DistractingColors(0.3, parts=("self",))
    defaults = colors.read_defaults(walker_scene)
    names = [walker_scene.model.material(int(i)).name for i in defaults["materials"]]
    assert names and all(n.startswith("self") for n in names)
    with pytest.raises(ValueError, match="selects no material"):
        DistractingColors(parts=("nothing",)).read_defaults(walker_scene)


@pytest.mark.parametrize("bad", [
    lambda: DistractingCamera(1.5), lambda: DistractingCamera(-0.1), lambda: DistractingColors(2),
    lambda: DistractingCamera(walk_steps=0), lambda: DistractingColors(0.1, walk_steps=1.5),
])
def test_bad_arguments_are_refused_up_front(bad):
    with pytest.raises(ValueError, match="scale|walk_steps"):
        bad()


def test_target_body_cameras_are_refused():
    with pytest.raises(ValueError, match="mjCAMLIGHT_TARGETBODY"):
        build("cartpole-swingup", [DistractingCamera(0.1, camera=1)]).reset()  # cartpole's camera 1 targets the cart
    assert repr(DistractingCamera(0.2, dynamic=True, seed=1)) == "DistractingCamera(scale=0.2, dynamic=True, camera=0, seed=1)"


def test_reacher_shortest_rotation_keeps_the_camera_on_the_target():
    camera = DistractingCamera(0.5, limit_to_upper_quadrant=False, seed=0)
    env = build("reacher-easy", [camera])
    for _ in range(3):
        env.reset()
        position, xmat = camera_pose(env.base_env.scene)
        target = camera.defaults(env.base_env.scene)["target"]
        view = -xmat[:, 2]
        np.testing.assert_allclose(view, (target - position) / np.linalg.norm(target - position), atol=1e-9)
        np.testing.assert_allclose(xmat.T @ xmat, np.eye(3), atol=1e-9)

"""DMC-GB2's camera shifts against its source: aalmuzairee/dmcgb2 ``envs/dmcgb/dmcgb_geometric.py`` (commit 5fd8fd7a).

See also ../shared/reference/ANCHORS.md §3.5.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from vigen.envs import make_env
from vigen.rendering import RenderSettings
from vigen.transforms import DMCGB2Camera
from vigen.transforms.scene.dmcgb2_camera import CAM_EDGES, NUM_PRESETS, preset_order, rotate_presets, shift_presets

pytestmark = pytest.mark.render

FAST = RenderSettings.fast()


# The source's matrices, written as in dmcgb_geometric.py (R_yaw, R_pitch, R_roll)
def r_yaw(a):
    return np.array([[math.cos(a), -math.sin(a), 0], [math.sin(a), math.cos(a), 0], [0, 0, 1]])


def r_pitch(a):
    return np.array([[math.cos(a), 0, math.sin(a)], [0, 1, 0], [-math.sin(a), 0, math.cos(a)]])


def r_roll(a):
    return np.array([[1, 0, 0], [0, math.cos(a), -math.sin(a)], [0, math.sin(a), math.cos(a)]])


def build(task="walker-walk", transforms=()):
    return make_env(f"dmc/{task}", generalization=list(transforms), frame_stack=1, image_size=32, render_settings=FAST)


def test_cam_edges_equal_the_source_table():
    # ShiftWrapper._get_corner_coordinates: cam_edges (Right, Left, Down, Up / Left, Right, Up, Down), degrees
    assert dict(CAM_EDGES) == {
        "walker": (10, -10, 10, -10), "cheetah": (10, -10, 10, -10), "cartpole": (8, -8, 10, -10),
        "finger": (6, -6, 12, -6), "ball_in_cup": (6, -6, 12, -6),
    }


@pytest.mark.parametrize("difficulty, low, high", [("hard", -180.0, 180.0), ("easy", -90.0, 90.0)])
def test_rotate_presets_are_evenly_spaced_over_the_source_bounds(difficulty, low, high):
    presets = rotate_presets(difficulty)
    assert len(presets) == NUM_PRESETS == 100
    np.testing.assert_allclose(presets, low + np.arange(100) * (high - low) / 100)  # _get_rotation_angles
    assert presets[0] == low and presets[-1] < high


@pytest.mark.parametrize("domain", sorted(CAM_EDGES))
@pytest.mark.parametrize("difficulty", ["easy", "hard"])
def test_shift_presets_walk_the_four_corners(domain, difficulty):
    max_roll, min_roll, max_pitch, min_pitch = np.array(CAM_EDGES[domain]) / (1.5 if difficulty == "easy" else 1.0)
    presets = shift_presets(domain, difficulty)
    corners = [(min_roll, min_pitch), (max_roll, min_pitch), (max_roll, max_pitch), (min_roll, max_pitch)]
    assert presets.shape == (100, 2)
    for i, corner in enumerate(corners):  # _sample_cam_positions: 25 points per edge, from each corner to the next
        np.testing.assert_allclose(presets[25 * i], corner)
        following = np.array(corners[(i + 1) % 4])
        np.testing.assert_allclose(presets[25 * i + 24], corner + 24 * (following - corner) / 25)
    assert presets[:, 0].min() == min_roll and presets[:, 0].max() == max_roll
    assert presets[:, 1].min() == min_pitch and presets[:, 1].max() == max_pitch


def test_rotations_compose_as_the_wrappers_do():
    # RotateWrapper(ShiftWrapper(env)): cam_xmat <- cam_xmat @ shift, then @ rot; each preset unpacked (yaw, pitch, roll)
    mats = DMCGB2Camera("rotate_shift", "hard", domain="cartpole").rotations()
    for i in (0, 13, 37, 99):
        pitch, roll = np.radians(shift_presets("cartpole", "hard")[i])
        shift = r_yaw(0.0) @ (r_pitch(pitch) @ r_roll(roll))
        np.testing.assert_allclose(mats[i], shift @ r_yaw(math.radians(rotate_presets("hard")[i])), atol=1e-12)


def test_presets_cycle_one_per_reset_in_the_source_order():
    # each wrapper shuffles its list with np.random.RandomState(seed).shuffle and takes the next one at each reset
    for seed in (0, 7):
        shuffled = list(range(100))
        np.random.RandomState(seed).shuffle(shuffled)
        assert preset_order(seed).tolist() == shuffled
        camera = DMCGB2Camera("rotate", "easy", source_seed=seed)
        drawn = []
        for _ in range(102):
            camera.params = camera.sample(camera.generator(), {})
            drawn.append(camera.params["preset"])
        assert drawn == shuffled + shuffled[:2]


def test_the_camera_turns_by_the_preset_in_place():
    for mode, episodes in (("rotate", 1), ("shift", 1), ("rotate_shift", 2)):
        camera = DMCGB2Camera(mode, "hard", domain="walker", source_seed=3)
        env = build(transforms=[camera])
        model = env.base_env.scene.model  # before the first reset: unedited; walker's camera 0 is trackcom
        start_position, start = model.cam_poscom0[0].copy(), model.cam_mat0[0].reshape(3, 3).copy()
        for episode in range(episodes):
            env.reset()
            data = env.base_env.scene.data
            preset = camera.params["preset"]
            assert preset == preset_order(3)[episode]
            xmat = data.cam_xmat[0].reshape(3, 3)
            np.testing.assert_allclose(xmat, start @ camera.rotations()[preset], atol=1e-9)
            np.testing.assert_allclose(data.cam_xpos[0] - data.subtree_com[1], start_position, atol=1e-9)  # kept
        if mode == "rotate":  # the view axis is kept: the image turns by the preset's angle
            np.testing.assert_allclose(xmat[:, 2], start[:, 2], atol=1e-9)
            angle = math.degrees(math.atan2(start[:, 1] @ xmat[:, 0], start[:, 0] @ xmat[:, 0]))
            assert angle == pytest.approx(rotate_presets("hard")[preset_order(3)[0]], abs=1e-6)


def test_fixed_camera_and_restore():
    camera = DMCGB2Camera("rotate_shift", "easy", domain="cup", seed=0)
    env = build("ball_in_cup-catch", [camera])
    model = env.base_env.scene.model
    before = {name: getattr(model, name).copy() for name in ("cam_pos", "cam_quat", "cam_pos0", "cam_poscom0", "cam_mat0")}
    start = env.base_env.scene.data.cam_xmat[0].reshape(3, 3).copy()
    env.reset()
    np.testing.assert_allclose(env.base_env.scene.data.cam_xmat[0].reshape(3, 3),
                               start @ camera.rotations()[camera.params["preset"]], atol=1e-9)
    state = env.step(env.reset().set("action", torch.zeros(env.action_spec.shape)))
    assert state is not None
    camera.restore()
    for name, value in before.items():
        assert np.array_equal(getattr(model, name), value), name


@pytest.mark.parametrize("kwargs, match", [
    (dict(mode="orbit"), "mode must be one of"), (dict(difficulty="medium"), "difficulty must be one of"),
    (dict(mode="shift"), "shift limits exist for"), (dict(mode="shift", domain="humanoid"), "shift limits exist for"),
])
def test_bad_arguments_name_the_valid_values(kwargs, match):
    with pytest.raises(ValueError, match=match):
        DMCGB2Camera(**kwargs)
    assert repr(DMCGB2Camera("shift", "easy", domain="finger", seed=2)) == \
        "DMCGB2Camera(mode='shift', difficulty='easy', domain='finger', seed=2)"

"""Adroit envs: TorchRL contract, seeding, episode length, RL-ViGen's Adroit levels through vigen's scene transforms."""

from __future__ import annotations

import numpy as np
import pytest
import torch
from torchrl.envs.utils import check_env_specs

import vigen.transforms
from vigen.envs import make_env
from vigen.envs.adroit import env as adroit_env
from vigen.envs.adroit import suite as adroit
from vigen.envs.levels import resolve_levels
from vigen.rendering import RenderSettings
from vigen.transforms.scene import ScenePerturbation

pytest.importorskip("gymnasium_robotics", reason="the adroit extra is not installed: pip install -e '.[adroit]'")

pytestmark = pytest.mark.render
FAST = RenderSettings.fast()
SIZE = 48
MODEL_FIELDS = ["mat_rgba", "geom_rgba", "tex_data", "light_pos", "cam_pos", "cam_quat", "cam_fovy"]


def door(level=None, seed: int = 0, **kwargs):
    return make_env("adroit/door", generalization=level, seed=seed, image_size=SIZE, render_settings=FAST, **kwargs)


def first_frame(env) -> torch.Tensor:
    return env.reset()["pixels"][-3:].float()


@pytest.mark.parametrize("task, action_dim", [("door", 28), ("hammer", 26), ("pen", 24)])
def test_check_env_specs(task, action_dim):
    env = make_env(f"adroit/{task}", seed=0, image_size=SIZE, render_settings=FAST)
    check_env_specs(env)
    state = env.reset()
    assert state["pixels"].shape == (9, SIZE, SIZE) and state["pixels"].dtype == torch.uint8
    assert env.action_spec.shape == (action_dim,)
    assert state["pixels"].float().std() > 10
    env.close()


def test_frames_match_mujocos_renderer_top_row_first():
    env = door(frame_stack=1)
    pixels = env.reset()["pixels"].permute(1, 2, 0).numpy()
    segmentation = env.base_env.scene.segmentation()
    model = env.base_env.scene.model
    background_rows = np.nonzero((segmentation[..., 0] < 0).any(axis=1))[0]
    assert background_rows.min() == 0, "the black background is at the top of the view"
    assert (pixels[segmentation[..., 0] < 0] == 0).all(), "and it is black where nothing is hit"
    assert model.geom("ground").id in np.unique(segmentation[SIZE - 1, :, 0]), "the floor reaches the bottom row"


def test_same_seed_same_episode_other_seed_other_start():
    actions = torch.rand(4, 28, generator=torch.Generator().manual_seed(0)) * 2 - 1

    def play(seed):
        env = door(seed=seed)
        state = env.reset()
        frames = [state["pixels"]]
        for action in actions:
            state = env.step(state.set("action", action))["next"]
            frames.append(state["pixels"])
        return torch.stack(frames)

    assert torch.equal(play(3), play(3))
    assert not torch.equal(play(3)[0], play(4)[0]), "the door starts elsewhere"


def test_dense_reward_is_dapgs():
    """DAPG's door reward: -0.1·‖palm − handle‖ - 0.1·(q - 1.57)² - 1e-5·Σ qvel² + bonuses (gymnasium-robotics 1.4.2 flips the first sign)."""
    env = door(action_repeat=1)
    state = env.reset()
    action = torch.rand(28, generator=torch.Generator().manual_seed(1)) * 2 - 1
    reward = env.step(state.set("action", action))["next", "reward"].item()
    task, data = env.base_env._env, env.base_env._env.data
    distance = np.linalg.norm(data.site_xpos[task.grasp_site_id] - data.site_xpos[task.handle_site_id])
    hinge = float(data.qpos[task.door_hinge_addrs])
    expected = -0.1 * distance - 0.1 * (hinge - 1.57) ** 2 - 1e-5 * np.sum(data.qvel**2)
    expected += 2 * (hinge > 0.2) + 8 * (hinge > 1.0) + 10 * (hinge > 1.35)
    assert reward == pytest.approx(expected, rel=1e-5, abs=1e-6)


def test_success_after_more_than_25_goal_steps(monkeypatch):
    """DAPG's criterion (RL-ViGen reports it): the goal must hold on more than 25 control steps of the episode."""
    env = door()
    task = env.base_env._env
    state = env.reset()
    monkeypatch.setattr(task, "step", lambda action: (None, 0.0, False, False, {"success": True}))
    flags = []
    for _ in range(15):
        state = env.step(state.set("action", torch.zeros(28)))["next"]
        flags.append(bool(state["success"]))
    assert flags.index(True) == 12 and all(flags[12:]), "2 control steps per agent step: 26 > 25 at the 13th"
    assert adroit_env.SUCCESS_STEPS == {"door": 25, "hammer": 25, "pen": 20}


def test_pen_episodes_are_100_simulator_steps():
    pen = make_env("adroit/pen", seed=0, image_size=SIZE, render_settings=FAST)
    assert pen.base_env.episode_length == 100 and door().base_env.episode_length == 200
    assert pen.rollout(60, break_when_any_done=True).shape == (50,)


def test_truncated_after_episode_length_simulator_steps():
    env = door(episode_length=6)
    rollout = env.rollout(10, break_when_any_done=True)
    assert rollout.shape == (3,), "6 control steps at action repeat 2"
    assert rollout["next", "truncated"].squeeze(-1).tolist() == [False, False, True]
    assert not rollout["next", "terminated"].any()


@pytest.mark.parametrize("level", [level for level in adroit.LEVELS if level != "train"])
def test_each_level_changes_the_first_frame(level):
    assert (first_frame(door(level)) - first_frame(door("train"))).abs().mean() > 1.0


def test_train_is_the_untouched_scene():
    assert torch.equal(first_frame(door("train")), first_frame(door(None)))


@pytest.mark.parametrize("level", ["color_hard", "video_hard", "camera_hard", "light_hard"])
def test_twenty_resets_do_not_drift(level):
    env = door(level)
    model = env.base_env.scene.model
    original = {name: getattr(model, name).copy() for name in MODEL_FIELDS}
    for _ in range(20):
        env.reset()
    for perturbation in (t for t in env.transform if isinstance(t, ScenePerturbation)):
        perturbation.restore()
    for name, value in original.items():
        assert np.array_equal(getattr(model, name), value), f"{name} drifted"


def test_video_light_moves_along_y_only():
    env = door("video_hard")
    model = env.base_env.scene.model
    state = env.reset()
    start = model.light_pos.copy()
    env.step(state.set("action", torch.zeros(28)))
    np.testing.assert_allclose(model.light_pos - start, [[0.0, 0.12, 0.0]], atol=1e-12)


def test_hand_keeps_its_colours():
    env = door("color_hard")
    model = env.base_env.scene.model
    hand = [i for i in range(model.ngeom) if model.geom(i).name.startswith("V_")]
    before = model.geom_rgba[hand].copy(), model.mat_rgba.copy()
    env.reset()
    assert np.array_equal(model.geom_rgba[hand], before[0])
    assert not np.array_equal(model.mat_rgba, before[1]), "the scene's materials changed"


def test_levels_use_vigen_transform_classes():
    for level in adroit.LEVELS:
        for transform in adroit.ADROIT.level_transforms("door", level):
            assert type(transform) in vars(vigen.transforms).values(), f"{level}: {type(transform)}"


def test_bad_names_say_what_is_valid():
    with pytest.raises(ValueError, match="Did you mean adroit/door"):
        make_env("adroit/dor")
    with pytest.raises(ValueError, match="Unknown generalization level 'extreme' for adroit/ envs"):
        make_env("adroit/door", generalization="extreme")
    with pytest.raises(ValueError, match="No camera 'top'"):
        make_env("adroit/door", camera="top")
    assert resolve_levels(["rlvigen"], suite="adroit") == ["color_easy", "color_hard", "video_easy", "video_hard"]


# set_seed(s) and make_env(..., seed=s) give the same episodes (Adroit levels have no scene id).
ONE_LEVEL_PER_GROUP = ["train", "video_hard", "camera_hard", "light_hard"]  # all, rlvigen (textures, colours, video), camera, light


def small_door(level=None, **kwargs):
    return make_env("adroit/door", generalization=level, image_size=24, frame_stack=1, render_settings=FAST,
                    episode_length=10, **kwargs)


def episode(env, steps: int = 2) -> tuple[torch.Tensor, torch.Tensor]:
    """The pixels of a reset and of ``steps`` fixed actions, and the rewards."""
    dim = env.action_spec.shape[-1]
    actions = iter(torch.linspace(-1, 1, steps * dim).reshape(steps, dim))
    data = env.rollout(steps, lambda td: td.set("action", next(actions)), break_when_any_done=False)
    return torch.cat([data["pixels"], data["next", "pixels"][-1:]]), data["next", "reward"]


def check_set_seed_equals_seed_at_build(level):
    expected = episode(small_door(level, seed=13))
    later = small_door(level)
    episode(later)  # used first: set_seed must start over
    later.set_seed(13)
    got = episode(later)
    assert torch.equal(got[0], expected[0]) and torch.equal(got[1], expected[1])


@pytest.mark.parametrize("level", ONE_LEVEL_PER_GROUP)
def test_set_seed_equals_seed_at_build(level):
    check_set_seed_equals_seed_at_build(level)


@pytest.mark.slow
@pytest.mark.matrix
@pytest.mark.parametrize("level", [level for level in adroit.LEVELS if level not in ONE_LEVEL_PER_GROUP])
def test_set_seed_equals_seed_at_build_every_level(level):
    check_set_seed_equals_seed_at_build(level)

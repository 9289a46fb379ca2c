"""robosuite envs: TorchRL contract, seeding, horizon, RL-ViGen's levels through vigen's own scene transforms."""

from __future__ import annotations

import mujoco
import numpy as np
import pytest
import torch
from torchrl.envs.utils import check_env_specs

import vigen.transforms
from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC
from vigen.envs.levels import resolve_levels
from vigen.envs.robosuite import suite
from vigen.rendering import RenderSettings
from vigen.transforms.scene import ScenePerturbation

pytest.importorskip("robosuite", reason="the robosuite extra is not installed: pip install -e '.[robosuite]'")

pytestmark = pytest.mark.render
FAST = RenderSettings.fast()
SIZE = 40
PERTURBED_LEVELS = ["easy", "medium", "hard", "camera_easy", "camera_hard", "robot_iiwa"]
MODEL_FIELDS = ["mat_rgba", "geom_rgba", "tex_data", "light_pos", "light_type", "light_castshadow", "cam_pos", "cam_quat",
                "cam_fovy"]


def lift(level=None, seed: int = 0, **kwargs):
    return make_env("robosuite/lift", generalization=level, seed=seed, image_size=SIZE, render_settings=FAST, **kwargs)


def first_frame(env) -> torch.Tensor:
    return env.reset()["pixels"][-3:].float()


@pytest.mark.parametrize("task", ["door", "lift", "two-arm-peg-in-hole"])
def test_check_env_specs(task):
    env = make_env(f"robosuite/{task}", seed=0, image_size=SIZE, render_settings=FAST)
    check_env_specs(env)
    state = env.reset()
    assert state["pixels"].shape == (9, SIZE, SIZE) and state["pixels"].dtype == torch.uint8
    assert env.action_spec.shape == ((12,) if task.startswith("two-arm") else (7,))
    assert state["pixels"].float().std() > 10, "a rendered scene, not a blank frame"


def test_frames_and_segmentation_are_upright():
    """robosuite's OpenGL frames run bottom-up; the env flips them, and its segmentation the same way."""
    env = make_env("robosuite/lift", seed=0, image_size=SIZE, render_settings=FAST, frame_stack=1)
    pixels = env.reset()["pixels"].permute(1, 2, 0).numpy()
    sim = env.base_env._env.sim
    sim._render_context_offscreen.gl_ctx.make_current()
    assert np.array_equal(pixels, sim.render(width=SIZE, height=SIZE, camera_name="agentview")[::-1])
    segmentation = env.base_env.scene.segmentation()
    model = env.base_env.scene.model

    def mean_row(geom: str) -> float:
        return np.nonzero(segmentation[..., 0] == model.geom(geom).id)[0].mean()

    assert mean_row("wall_rear_visual") < mean_row("table_visual"), "the wall is above the table"


def test_same_seed_same_episode_other_seed_other_start():
    actions = torch.rand(6, 7, generator=torch.Generator().manual_seed(0)) * 2 - 1

    def play(seed):
        env = lift(seed=seed)
        state = env.reset()
        frames = [state["pixels"]]
        for action in actions:
            state = env.step(state.set("action", action))["next"]
            frames.append(state["pixels"])
        return torch.stack(frames)

    assert torch.equal(play(3), play(3))
    assert not torch.equal(play(3)[0], play(4)[0]), "the cube starts elsewhere"


def test_truncated_at_the_horizon_never_terminated():
    env = lift(episode_length=4)
    rollout = env.rollout(10, break_when_any_done=True)
    assert rollout.shape == (4,)
    assert rollout["next", "truncated"].squeeze(-1).tolist() == [False, False, False, True]
    assert not rollout["next", "terminated"].any()
    assert rollout["next", "success"].dtype == torch.bool


@pytest.mark.parametrize("level", PERTURBED_LEVELS)
def test_each_level_changes_the_first_frame(level):
    assert (first_frame(lift(level)) - first_frame(lift("train"))).abs().mean() > 2.0


def test_train_is_the_untouched_scene():
    assert torch.equal(first_frame(lift("train")), first_frame(lift(None)))
    assert suite.ROBOSUITE.level_transforms("lift", "train") == []


def test_scene_ids_reproduce_their_scene():
    def textures(scene_id, seed):
        env = lift("easy", seed=seed, scene_id=scene_id)
        env.reset()
        return env.base_env.scene.model.tex_data.copy()

    assert np.array_equal(textures(3, seed=0), textures(3, seed=5)), "the scene's textures do not depend on the seed"
    assert not np.array_equal(textures(3, seed=0), textures(4, seed=0))
    env = lift("easy", seed=7)
    assert env.transform[0].scene_id == suite.SCENES * 0 + 7, "scene_id defaults to seed % 10"


@pytest.mark.parametrize("level", ["medium", "hard", "camera_hard"])
def test_twenty_resets_do_not_drift(level):
    env = lift(level)
    model = env.base_env.scene.model
    original = {name: getattr(model, name).copy() for name in MODEL_FIELDS}
    perturbations = [t for t in env.transform if isinstance(t, ScenePerturbation)]
    for _ in range(20):
        env.reset()
    for perturbation in perturbations:
        perturbation.restore()
    for name, value in original.items():
        assert np.array_equal(getattr(model, name), value), f"{name} drifted"


def test_moving_light_is_a_shadow_casting_spot_from_height_four_that_moves():
    """RL-ViGen's medium/hard light: z = 4, shadows on, not directional (a directional light's position changes nothing)."""
    env = lift("medium", frame_stack=1)
    model = env.base_env.scene.model
    assert model.light_type[0] == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL and not model.light_castshadow[0]
    state = env.reset()
    assert np.allclose(model.light_pos[:, 2], 4.0)
    assert model.light_type[0] == mujoco.mjtLightType.mjLIGHT_SPOT and model.light_castshadow[0]
    start, first = model.light_pos.copy(), state["pixels"].float()
    for _ in range(10):
        state = env.step(state.set("action", torch.zeros(7)))["next"]
    assert np.allclose(model.light_pos - start, 0.3)
    light = next(t for t in env.transform if isinstance(t, vigen.transforms.RandomLighting))
    scene = env.base_env.scene
    mujoco.mj_camlight(scene.model, scene.data)  # light positions reach the renderer through data.light_xpos
    moved = env.base_env.render_frame()
    model.light_pos[:] = start
    mujoco.mj_camlight(scene.model, scene.data)
    assert np.abs(moved.astype(float) - env.base_env.render_frame()).mean() > 0.5, "the image depends on the light's position"
    light.restore()
    assert model.light_type[0] == mujoco.mjtLightType.mjLIGHT_DIRECTIONAL and not model.light_castshadow[0]


def test_hard_level_replaces_floor_and_walls_with_video():
    env = lift("hard", frame_stack=1)
    pixels = env.reset()["pixels"]
    video = next(t for t in env.transform if isinstance(t, vigen.transforms.VideoBackground))
    mask = torch.from_numpy(video.background_mask(env.base_env.scene))
    assert 0.1 < mask.float().mean() < 0.9, "floor and walls are part of the view, the robot and table are not"
    expected = video.videos.frames(video.params["video"], SIZE, SIZE)[0].permute(2, 0, 1)
    assert torch.equal(pixels[:, mask], expected[:, mask])
    videos = [t.video for scene in (3, 4) for t in suite.ROBOSUITE.level_transforms("lift", "hard", scene)
              if isinstance(t, vigen.transforms.VideoBackground)]
    assert videos == [3, 4], "each scene plays its own video in every episode"


@pytest.mark.parametrize("robot", ["IIWA", "Kinova3"])
def test_cross_embodiment_keeps_the_panda_action_spec(robot):
    panda = lift()
    other = lift(f"robot_{robot.lower()}")
    assert other.base_env.robot == robot
    assert other.action_spec == panda.action_spec
    assert any(name.startswith("robot0_") for name in other.base_env.scene.model.names.decode().split("\x00"))


@pytest.mark.slow
@pytest.mark.matrix
@pytest.mark.parametrize("robot", suite.ROBOTS)
def test_every_listed_robot_keeps_the_panda_action_spec(robot):
    assert make_env("robosuite/door", robot=robot, image_size=16, render_settings=FAST).action_spec == lift().action_spec


def test_levels_use_the_same_transform_classes_as_dm_control():
    dmc_classes = {type(t) for level in DMC.levels for t in DMC.level_transforms("walker-walk", level)}
    for level in suite.LEVELS:
        for transform in suite.ROBOSUITE.level_transforms("door", level):
            assert type(transform) in vars(vigen.transforms).values(), f"{level}: {type(transform)} is not a vigen transform"
    used = {type(t) for level in suite.LEVELS for t in suite.ROBOSUITE.level_transforms("door", level)}
    assert used & dmc_classes >= {vigen.transforms.RandomTextures, vigen.transforms.RandomCamera,
                                  vigen.transforms.RandomLighting, vigen.transforms.VideoBackground}


def test_bad_names_say_what_is_valid():
    with pytest.raises(ValueError, match="Did you mean robosuite/door"):
        make_env("robosuite/dor")
    with pytest.raises(ValueError, match="Unknown generalization level .extreme. for robosuite/ envs.*easy"):
        make_env("robosuite/door", generalization="extreme")
    with pytest.raises(ValueError, match="scene_id selects one of the level's 10 scenes"):
        make_env("robosuite/door", generalization="easy", scene_id=10)
    with pytest.raises(ValueError, match="Unknown robot 'Baxter'"):
        make_env("robosuite/door", robot="Baxter")
    with pytest.raises(ValueError, match="Level 'robot_iiwa' sets robot='IIWA', but robot='Sawyer' was given"):
        make_env("robosuite/door", generalization="robot_iiwa", robot="Sawyer")
    assert resolve_levels(["train", "rlvigen"], suite="robosuite") == ["train", "easy", "medium", "hard"]


# set_seed(s) and make_env(..., seed=s) give the same episodes, the scene (seed % 10) included.
SEED = 13  # scene 3: not the scene 0 an env without a seed is built with, and seed % 10 != seed
ONE_LEVEL_PER_GROUP = ["train", "hard", "camera_hard", "robot_iiwa"]  # train, rlvigen (textures and video), camera, embodiment
OTHER_LEVELS = [level for level in suite.LEVELS if level not in ONE_LEVEL_PER_GROUP]


def door(level=None, **kwargs):
    return make_env("robosuite/door", generalization=level, image_size=24, frame_stack=1, render_settings=FAST,
                    episode_length=10, **kwargs)


def episode(env, steps: int = 2) -> tuple[torch.Tensor, torch.Tensor]:
    """The pixels of a reset and of ``steps`` fixed actions, and the rewards."""
    actions = iter(torch.linspace(-1, 1, steps * 7).reshape(steps, 7))
    data = env.rollout(steps, lambda td: td.set("action", next(actions)), break_when_any_done=False)
    return torch.cat([data["pixels"], data["next", "pixels"][-1:]]), data["next", "reward"]


def scene_parameters(env) -> list[tuple[str, int]]:
    """What fixes the scene: the texture draw's scene id and the video played."""
    return [(type(t).__name__, t.scene_id if isinstance(t, vigen.transforms.RandomTextures) else t.video)
            for t in env.transform if isinstance(t, (vigen.transforms.RandomTextures, vigen.transforms.VideoBackground))]


def check_set_seed_equals_seed_at_build(level):
    seeded = door(level, seed=SEED)
    later = door(level)
    episode(later)  # used first: set_seed must start over, scene included
    later.set_seed(SEED)
    expected, got = episode(seeded), episode(later)
    assert torch.equal(got[0], expected[0]) and torch.equal(got[1], expected[1])
    assert scene_parameters(later) == scene_parameters(seeded)
    if level in suite.SCENE_LEVELS:
        assert scene_parameters(later) == [("RandomTextures", suite.SCENES * suite.SCENE_LEVELS.index(level) + 3)] + (
            [("VideoBackground", 3)] if level == "hard" else [])
    assert later.scene_id == seeded.scene_id == SEED % suite.SCENES


@pytest.mark.parametrize("level", ONE_LEVEL_PER_GROUP)
def test_set_seed_equals_seed_at_build_scene_included(level):
    check_set_seed_equals_seed_at_build(level)


@pytest.mark.slow
@pytest.mark.matrix
@pytest.mark.parametrize("level", OTHER_LEVELS)
def test_set_seed_equals_seed_at_build_every_level(level):
    check_set_seed_equals_seed_at_build(level)


def test_set_seed_moves_the_level_to_the_seeds_scene():
    """Seeds 13 and 14 show scenes 3 and 4, whose textures differ even with the same task episode and colours."""
    three, four = door("easy"), door("easy")
    three.set_seed(SEED)
    four.set_seed(SEED + 1)
    assert scene_parameters(three) == [("RandomTextures", 3)] and scene_parameters(four) == [("RandomTextures", 4)]
    four.set_seed(SEED)
    four.set_scene(4)  # seed 13's episode and draws, scene 4's textures
    assert four.scene_id == 4 and scene_parameters(four) == [("RandomTextures", 4)]
    assert not torch.equal(episode(three)[0][0], episode(four)[0][0])


def test_an_explicit_scene_id_stays_through_set_seed():
    fixed = door("hard", scene_id=5)
    fixed.set_seed(SEED)
    assert fixed.scene_id == 5 and scene_parameters(fixed) == [("RandomTextures", 25), ("VideoBackground", 5)]
    expected = episode(door("hard", scene_id=5, seed=SEED))
    got = episode(fixed)
    assert torch.equal(got[0], expected[0]) and torch.equal(got[1], expected[1])


def test_bad_scene_ids_are_refused_before_building():
    with pytest.raises(TypeError, match=r"^scene_id must be an int in 0..9"):
        make_env("robosuite/door", generalization="easy", scene_id=3.0)
    with pytest.raises(TypeError, match=r"^scene_id must be an int in 0..9"):
        make_env("robosuite/door", generalization="easy", scene_id=True)
    with pytest.raises(ValueError, match="scene_id selects one of the level's 10 scenes"):
        make_env("robosuite/door", generalization="easy", image_size=32).set_scene(-1)

"""Seeds mean what the README says: make_env(..., seed=s) and make_env(...).set_seed(s) give the same episodes."""

from __future__ import annotations

from functools import partial

import pytest
import torch
from torchrl.envs import Compose, ParallelEnv

from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC, GROUPS, LEVELS


def level_transforms(level, seed=None, **options):
    return DMC.level_transforms("walker-walk", level, seed=seed, **options)
from vigen.envs.pixels import derive_seed
from vigen.rendering import RenderSettings
from vigen.transforms import RandomShift, VideoBackground

pytestmark = pytest.mark.render

FAST = RenderSettings.fast()
NAME = "dmc/walker-walk"
# all, dmcgb, rlvigen, corruptions, dmcgb2, dcs, dcs_static
ONE_PER_GROUP = ["train", "video_hard", "camera_hard", "gaussian_noise_3", "rotate_shift_hard", "dcs_0.2", "dcs_static_0.1"]
SLOW_LEVELS = [level for level in LEVELS if level not in ONE_PER_GROUP]
assert {"dmcgb", "rlvigen", "corruptions", "dmcgb2", "dcs", "dcs_static", "all"} == set(GROUPS)


def build(level=None, **kwargs):
    return make_env(NAME, generalization=level, image_size=24, frame_stack=1, render_settings=FAST,
                    episode_length=20, **kwargs)


def episode(env, steps: int = 3) -> tuple[torch.Tensor, torch.Tensor]:
    """Pixels of a reset and ``steps`` fixed actions, and the rewards (batched envs: one row per worker)."""
    actions = torch.linspace(-1, 1, steps * 6).reshape(steps, 6).expand(*env.batch_size, steps, 6).movedim(-2, 0)
    step = iter(actions)
    data = env.rollout(steps, lambda td: td.set("action", next(step)), break_when_any_done=False)
    return torch.cat([data["pixels"], data["next", "pixels"][..., -1:, :, :, :]], dim=-4), data["next", "reward"]


def assert_same(a, b):
    assert torch.equal(a[0], b[0]) and torch.equal(a[1], b[1])


def check_set_seed_equals_seed_at_build(level):
    seeded = episode(build(level, seed=5))
    later = build(level)
    episode(later)  # the env has been used: set_seed must start over, not continue
    later.set_seed(5)
    assert_same(episode(later), seeded)
    again = build(level)
    again.set_seed(5)
    assert_same(episode(again), seeded)
    assert_same(episode(build(level, seed=5)), seeded)


@pytest.mark.parametrize("level", ONE_PER_GROUP)
def test_set_seed_equals_seed_at_build(level):
    check_set_seed_equals_seed_at_build(level)


@pytest.mark.slow
@pytest.mark.matrix
@pytest.mark.parametrize("level", SLOW_LEVELS)
def test_set_seed_equals_seed_at_build_every_level(level):
    check_set_seed_equals_seed_at_build(level)


@pytest.mark.parametrize("level", ["dcs_static_0.1", "camera_hard", "gaussian_noise_3", "rotate_hard", "dcs_0.2"])
def test_seeds_change_the_perturbation(level):
    """Two seeds differ in the perturbation itself, not only in the task's initial pose.

    Not DMC-GB's video_easy / video_hard: DMC-GB plays the same videos in the same order for every
    seed (test/envs/test_dmcgb_video_fidelity.py).
    """
    a, b = build(level), build(level)
    a.set_seed(5)
    b.set_seed(6)
    b.base_env.set_seed(5)  # same task episode, different perturbation seeds
    assert not torch.equal(episode(a)[0], episode(b)[0])


def test_set_seed_seeds_every_transform_as_the_level_does():
    env = build("color_hard")
    env.set_seed(7)
    scene = [t for t in env.transform if type(t).__name__ == "RandomSceneColors"]
    assert [t.seed for t in scene] == [t.seed for t in level_transforms("color_hard", seed=7)] == [derive_seed(7, 0)]
    assert derive_seed(7, 0) == 7 * 1_000_003 and derive_seed(7, 2, 1) == (7 * 1_000_003 + 2) * 1_000_003 + 1


def test_user_transforms_in_compose_are_seeded_like_a_level():
    seeded = episode(build([Compose(VideoBackground())], seed=3))
    later = build([Compose(VideoBackground())])
    episode(later)
    later.set_seed(3)
    assert_same(episode(later), seeded)


def test_appended_augmentations_are_reseeded():
    def with_shift():
        return build("video_easy").append_transform(RandomShift(pad=4))

    used, fresh = with_shift(), with_shift()
    episode(used)
    used.set_seed(3)
    fresh.set_seed(3)
    assert_same(episode(used), episode(fresh))
    shift = [t for t in used.transform if isinstance(t, RandomShift)]
    assert [t.seed for t in shift] == [derive_seed(3, 1)], "the second seeded transform of the chain gets index 1"


def test_set_seed_refuses_a_bad_seed():
    with pytest.raises(ValueError, match=r"^seed must be an int in \[0, 4294967295\]"):
        build().set_seed(-3)


@pytest.mark.slow
@pytest.mark.timeout(300)
@pytest.mark.parametrize("level", ["video_hard", "camera_hard"])
def test_parallel_env_set_seed_reproduces_and_workers_differ(level):
    make = partial(build, level)
    runs = []
    for _ in range(2):
        env = ParallelEnv(2, make)
        try:
            env.set_seed(0)
            runs.append(episode(env))
        finally:
            env.close()
    assert_same(runs[0], runs[1])
    pixels = runs[0][0]
    assert not torch.equal(pixels[0], pixels[1]), "workers must get different seeds"
    single = build(level)
    second_seed = single.set_seed(0)  # ParallelEnv gives worker 1 the seed that follows 0
    assert_same(episode(build(level, seed=0)), (pixels[0], runs[0][1][0]))
    assert_same(episode(build(level, seed=second_seed)), (pixels[1], runs[0][1][1]))

"""dm_control pixel envs: DrQ-v2's setup (84×84 uint8, frame stack 3, action repeat 2, 1000 steps)."""

from __future__ import annotations

import pickle
from functools import partial

import dm_env
import numpy as np
import pytest
import torch
from dm_env import specs
from torchrl.collectors import MultiSyncCollector
from torchrl.envs import CatFrames, ParallelEnv, SerialEnv
from torchrl.envs.utils import check_env_specs

from vigen.envs import make_env
from vigen.envs.dmc.env import ActionRepeat, DMCPixelEnv
from vigen.rendering import RenderSettings

FAST = RenderSettings.fast()


def fixed_actions(env, steps: int, seed: int = 0) -> torch.Tensor:
    """A reproducible action sequence inside the env's action bounds."""
    spec = env.action_spec
    generator = torch.Generator().manual_seed(seed)
    unit = torch.rand((steps, *spec.shape), generator=generator)
    return spec.space.low + unit * (spec.space.high - spec.space.low)


def rollout_with(env, actions: torch.Tensor, tensordict=None):
    """Roll ``env`` out with a fixed action sequence (no global RNG involved), from a reset unless given a state."""
    step = iter(actions)
    return env.rollout(
        len(actions),
        policy=lambda td: td.set("action", next(step)),
        break_when_any_done=False,
        auto_reset=tensordict is None,
        tensordict=tensordict,
    )


class ScriptedEnv(dm_env.Environment):
    """A dm_env whose step ``i`` (1-based) pays reward ``i`` and terminates (discount 0) at ``terminate_at``."""

    def __init__(self, terminate_at: int | None = None) -> None:
        self.terminate_at = terminate_at
        self.count = 0

    def reset(self):
        self.count = 0
        return dm_env.restart(np.zeros(1))

    def step(self, action):
        self.count += 1
        if self.count == self.terminate_at:
            return dm_env.termination(float(self.count), np.zeros(1))
        return dm_env.transition(float(self.count), np.zeros(1), discount=1.0)

    def observation_spec(self):
        return specs.Array((1,), np.float64)

    def action_spec(self):
        return specs.BoundedArray((1,), np.float64, -1.0, 1.0)


class TestActionRepeat:
    def test_rewards_summed_over_repeats(self):
        env = ActionRepeat(ScriptedEnv(), repeat=2, episode_length=100)
        env.reset()
        assert [env.step(0.0).reward for _ in range(3)] == [1 + 2, 3 + 4, 5 + 6]

    def test_time_limit_is_a_truncation(self):
        env = ActionRepeat(ScriptedEnv(), repeat=2, episode_length=6)
        env.reset()
        steps = [env.step(0.0) for _ in range(3)]
        assert [s.last() for s in steps] == [False, False, True]
        assert steps[-1].discount == 1.0

    def test_odd_episode_length_cuts_the_last_repeat(self):
        env = ActionRepeat(ScriptedEnv(), repeat=2, episode_length=5)
        env.reset()
        steps = [env.step(0.0) for _ in range(3)]
        assert steps[-1].last() and steps[-1].reward == 5.0

    def test_termination_inside_a_repeat(self):
        env = ActionRepeat(ScriptedEnv(terminate_at=3), repeat=2, episode_length=100)
        env.reset()
        first, second = env.step(0.0), env.step(0.0)
        assert not first.last()
        assert second.last() and second.discount == 0.0 and second.reward == 3.0

    def test_step_after_last_resets(self):
        env = ActionRepeat(ScriptedEnv(), repeat=1, episode_length=1)
        env.reset()
        assert env.step(0.0).last()
        assert env.step(0.0).first()

    @pytest.mark.parametrize("kwargs", [{"repeat": 0, "episode_length": 10}, {"repeat": 2, "episode_length": 0}])
    def test_bad_arguments(self, kwargs):
        with pytest.raises(ValueError, match="at least 1"):
            ActionRepeat(ScriptedEnv(), **kwargs)


@pytest.mark.render
class TestMakeDMCEnv:
    def test_walker_rollout_pixels(self):
        env = make_env("dmc/walker-walk", seed=0, render_settings=FAST)
        pixels = env.rollout(100)["pixels"]
        assert pixels.shape == (100, 9, 84, 84) and pixels.dtype == torch.uint8
        changed = (pixels[1:] != pixels[:-1]).flatten(1).any(1)
        assert changed.all(), "every step should show a new frame"

    def test_defaults_match_drqv2(self):
        env = make_env("dmc/cheetah-run", seed=0, render_settings=FAST)
        assert env.observation_spec["pixels"].shape == (9, 84, 84)
        assert env.observation_spec["pixels"].dtype == torch.uint8
        assert set(env.observation_spec.keys()) == {"pixels"}
        assert env.action_spec.dtype == torch.float32 and env.reward_spec.dtype == torch.float32
        assert torch.equal(env.action_spec.space.low, -torch.ones(6))

    @pytest.mark.parametrize(
        "name", ["dmc/walker-walk", "dmc/cartpole-swingup", "dmc/quadruped-walk", "dmc/cup-catch", "dmc/finger-spin"]
    )
    def test_check_env_specs(self, name):
        check_env_specs(make_env(name, seed=0, render_settings=FAST))

    def test_action_repeat_renders_once_per_agent_step(self, monkeypatch):
        env = make_env("dmc/walker-walk", seed=0, render_settings=FAST)
        physics = env.base_env.physics
        renders = []
        render = physics.render
        monkeypatch.setattr(physics, "render", lambda *a, **k: renders.append(1) or render(*a, **k))
        state = env.reset()
        assert len(renders) == 1
        start = physics.data.time
        rollout_with(env, fixed_actions(env, 10), tensordict=state)
        assert len(renders) == 1 + 10
        walker_control_timestep = 0.025
        assert physics.data.time - start == pytest.approx(10 * 2 * walker_control_timestep)

    @pytest.mark.slow
    def test_episode_is_1000_simulator_steps_and_truncated(self):
        env = make_env("dmc/cartpole-balance", seed=0, render_settings=FAST, image_size=16)
        data = env.rollout(600, break_when_any_done=False)
        assert data["next", "truncated"].squeeze(-1).nonzero().squeeze(-1).tolist() == [499]
        assert not data["next", "terminated"].any()
        assert torch.equal(data["next", "done"], data["next", "truncated"])

    def test_same_seed_same_rollout(self):
        first = make_env("dmc/walker-walk", seed=3, render_settings=FAST)
        second = make_env("dmc/walker-walk", seed=3, render_settings=FAST)
        actions = fixed_actions(first, 20)
        a, b = rollout_with(first, actions), rollout_with(second, actions)
        assert torch.equal(a["pixels"], b["pixels"])
        assert torch.equal(a["next", "reward"], b["next", "reward"])

    def test_set_seed_resets_to_the_same_episode(self):
        env = make_env("dmc/walker-walk", render_settings=FAST)
        actions = fixed_actions(env, 10)
        env.set_seed(7)
        a = rollout_with(env, actions)
        env.set_seed(7)
        b = rollout_with(env, actions)
        assert torch.equal(a["pixels"], b["pixels"])

    def test_different_seeds_differ(self):
        a = make_env("dmc/walker-walk", seed=0, render_settings=FAST).reset()["pixels"]
        b = make_env("dmc/walker-walk", seed=1, render_settings=FAST).reset()["pixels"]
        assert not torch.equal(a, b)

    def test_frame_stack_shifts_by_one_frame(self):
        env = make_env("dmc/walker-walk", seed=0, render_settings=FAST)
        data = rollout_with(env, fixed_actions(env, 5))
        first = data["pixels"][0]
        assert torch.equal(first[0:3], first[3:6]) and torch.equal(first[3:6], first[6:9])
        assert torch.equal(data["pixels"][1:, 0:6], data["pixels"][:-1, 3:9])
        assert torch.equal(data["next", "pixels"][:-1], data["pixels"][1:])

    def test_single_frames_stacked_at_sampling_time_match_env_stacking(self):
        """frame_stack=1 + CatFrames in the replay buffer gives the env-side stack (a third of the memory)."""
        stacked_env = make_env("dmc/walker-walk", seed=0, render_settings=FAST, image_size=32)
        single_env = make_env("dmc/walker-walk", seed=0, render_settings=FAST, image_size=32, frame_stack=1)
        actions = fixed_actions(stacked_env, 6)
        stacked, single = rollout_with(stacked_env, actions), rollout_with(single_env, actions)
        assert single["pixels"].shape == (6, 3, 32, 32)
        cat = CatFrames(N=3, dim=-3, in_keys=["pixels", ("next", "pixels")], padding="same")
        restacked = cat(single.unsqueeze(0)).squeeze(0)
        assert torch.equal(restacked["pixels"], stacked["pixels"])
        assert torch.equal(restacked["next", "pixels"], stacked["next", "pixels"])

    def test_camera_ids(self):
        default = make_env("dmc/quadruped-walk", seed=0, render_settings=FAST, frame_stack=1).reset()["pixels"]
        camera_2 = make_env("dmc/quadruped-walk", seed=0, camera_id=2, render_settings=FAST, frame_stack=1)
        camera_0 = make_env("dmc/quadruped-walk", seed=0, camera_id=0, render_settings=FAST, frame_stack=1)
        assert torch.equal(default, camera_2.reset()["pixels"])
        assert not torch.equal(default, camera_0.reset()["pixels"])

    def test_fast_render_keeps_the_picture(self):
        exact = make_env("dmc/walker-walk", seed=0, frame_stack=1).reset()["pixels"].float()
        fast = make_env("dmc/walker-walk", seed=0, frame_stack=1, render_settings=FAST).reset()["pixels"].float()
        assert (exact - fast).abs().mean() < 4.0, "fast rendering should only soften shadows and edges"

    def test_base_env_exposes_physics_and_settings(self):
        env = make_env("dmc/quadruped-run", render_settings=FAST)
        assert isinstance(env.base_env, DMCPixelEnv)
        assert repr(env.base_env) == (
            "DMCPixelEnv(quadruped-run, camera_id=2, image_size=84, action_repeat=2, episode_length=1000)"
        )
        model = env.base_env.physics.model
        assert (model.vis.quality.shadowsize, model.vis.global_.offwidth) == (256, 84)

    def test_bad_arguments(self):
        with pytest.raises(ValueError, match="cameras 0..1"):
            make_env("dmc/walker-walk", camera_id=5)
        with pytest.raises(ValueError, match="frame_stack"):
            make_env("dmc/walker-walk", frame_stack=0)


@pytest.mark.render
class TestBatchedDMCEnv:
    def test_factory_pickles(self):
        factory = pickle.loads(pickle.dumps(partial(make_env, "dmc/walker-walk", seed=0, render_settings=FAST)))
        assert factory().reset()["pixels"].shape == (9, 84, 84)

    def test_serial_env_check(self):
        env = SerialEnv(2, partial(make_env, "dmc/walker-walk", render_settings=FAST, image_size=32))
        try:
            check_env_specs(env, seed=0)
        finally:
            env.close()

    def test_parallel_env_check_and_seeding(self):
        make = partial(make_env, "dmc/walker-walk", render_settings=FAST, image_size=32)
        env = ParallelEnv(2, make)
        try:
            check_env_specs(env, seed=0)
            actions = fixed_actions(env, 5)
            env.set_seed(11)
            a = rollout_with(env, actions)
            env.set_seed(11)
            b = rollout_with(env, actions)
            assert a["pixels"].shape == (2, 5, 9, 32, 32)
            assert torch.equal(a["pixels"], b["pixels"])
            assert not torch.equal(a["pixels"][0], a["pixels"][1]), "workers must get different seeds"
        finally:
            env.close()

    @pytest.mark.slow
    def test_multiprocess_collector(self):
        make = partial(make_env, "dmc/cartpole-swingup", render_settings=FAST, image_size=32)
        collector = MultiSyncCollector([make, make], policy=None, frames_per_batch=20, total_frames=40)
        try:
            batches = list(collector)
        finally:
            collector.shutdown()
        assert len(batches) == 2
        assert batches[0]["pixels"].dtype == torch.uint8
        assert batches[0]["pixels"].shape[-3:] == (9, 32, 32)
        assert batches[0].numel() == 20

"""build_agent: the config's networks, its std schedule, the env's action bounds, the pretrained-weights option."""

from __future__ import annotations

from dataclasses import replace

import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Bounded
from torchrl.envs.utils import ExplorationType, set_exploration_type

from vigen.losses import ALGOS
from vigen.run import TrainConfig, build_agent

SMALL = TrainConfig(hidden_dim=16, feature_dim=8, observation_shape=(9, 32, 32), action_dim=2)


def _actions(agent, count: int = 64) -> torch.Tensor:
    pixels = torch.randint(0, 256, (count, 9, 32, 32), dtype=torch.uint8)
    with set_exploration_type(ExplorationType.RANDOM):
        return agent.policy(TensorDict({"pixels": pixels}, batch_size=[count]))["action"]


def test_the_policy_acts_within_the_envs_action_bounds():
    """DrQ-v2 clamps actor output plus σ = 1 noise to the spec: the spec's bounds, not [-1, 1], limit the actions."""
    torch.manual_seed(0)
    wide = _actions(build_agent(SMALL, Bounded(-3.0, 3.0, shape=(2,))))
    assert wide.abs().max() > 1.0 and wide.abs().max() <= 3.0
    narrow = _actions(build_agent(SMALL, Bounded(-0.5, 0.5, shape=(2,))))
    assert narrow.abs().max() <= 0.5


def test_the_exploration_noise_follows_the_configs_std_schedule():
    """Linear from std_init to std_final over std_duration agent steps (DrQ-v2's linear(1.0, 0.1, 100000) in small)."""
    config = replace(SMALL, std_init=0.5, std_final=0.1, std_duration=8)
    noise = build_agent(config, Bounded(-1.0, 1.0, shape=(2,))).exploration_noise
    assert noise.sigma.item() == pytest.approx(0.5)
    noise.step(4)
    assert noise.sigma.item() == pytest.approx(0.3)
    noise.step(100)
    assert noise.sigma.item() == pytest.approx(0.1)


def test_a_sac_agent_samples_instead_of_adding_noise():
    agent = build_agent(replace(SMALL, algo="drq", std_init=0.3), Bounded(-1.0, 1.0, shape=(2,)))
    assert agent.exploration_noise is None, "DrQ takes no std (it would refuse one)"
    build_agent(SMALL, Bounded(-1.0, 1.0, shape=(2,)))
    noisy = {algo for algo in ("drqv2", "svea", "srm", "sgqn", "curl", "drq", "sada", "vrl3", "madi", "simgrl", "pieg", "scpl")
             if ALGOS[algo].takes_std}
    assert noisy == {"drqv2", "svea", "srm", "sgqn", "curl", "vrl3", "pieg"}, "DDPG's; the rest are SAC (DrQ, DMC-GB, DMC-GB2)"


def test_bad_shapes_are_named():
    with pytest.raises(ValueError, match="no observation_shape"):
        build_agent(TrainConfig(), Bounded(-1.0, 1.0, shape=(2,)))
    with pytest.raises(ValueError, match="the action spec has 3 dimensions, the config's action_dim is 2"):
        build_agent(SMALL, Bounded(-1.0, 1.0, shape=(3,)))


def test_pretrained_weights_are_read_only_when_asked(tmp_path):
    """A checkpoint's weights replace the pretrained ones: evaluation does not need the weights file."""
    config = replace(SMALL, algo="vrl3", encoder_weights=str(tmp_path / "moved.pth"))
    with pytest.raises(FileNotFoundError):
        build_agent(config, Bounded(-1.0, 1.0, shape=(2,)))
    with pytest.warns(UserWarning, match="random weights"):
        build_agent(config, Bounded(-1.0, 1.0, shape=(2,)), pretrained=False)

"""vigen.pretrained: export a run's acting policy, load it back acting exactly as the stored weights do, refuse bad files."""

from __future__ import annotations

import json

import pytest
import torch
from torchrl.data import Bounded
from torchrl.envs.utils import ExplorationType, set_exploration_type

from vigen.run.checkpoint import CheckpointError
from vigen.pretrained import available, export_policy, info, load_agent, load_config, load_policy
from vigen.run import TrainConfig, build_agent

SHAPE = (9, 32, 32)


def exported(tmp_path, algo="drqv2", name="agent", low=-1.0, high=1.0, dtype=torch.float16):
    spec = Bounded(low, high, shape=(2,))
    config = TrainConfig(algo=algo, hidden_dim=16, feature_dim=8, observation_shape=SHAPE, action_dim=2, seed=0)
    agent = build_agent(config, spec)
    for parameter in agent.loss.parameters():  # a "trained" agent: weights far from their initialisation
        parameter.data.add_(0.05 * torch.randn_like(parameter))
    export_policy(config, agent.loss, spec, tmp_path, name, {"env": "dmc/cartpole-balance", "seed": 0}, dtype=dtype)
    return agent


def pixels(batch=5):
    return torch.randint(0, 256, (batch, *SHAPE), dtype=torch.uint8, generator=torch.Generator().manual_seed(1))


def test_the_loaded_policy_acts_as_the_stored_weights_do(tmp_path):
    agent = exported(tmp_path)
    for part in (agent.loss.encoder, agent.loss.actor):  # what float16 storage keeps of each weight
        for tensor in part.state_dict().values():
            if tensor.is_floating_point():
                tensor.copy_(tensor.half().float())
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        expected = agent.policy(pixels=pixels())
    assert torch.equal(load_policy("agent", root=tmp_path)(pixels=pixels()), expected)


def test_float32_storage_is_exact(tmp_path):
    agent = exported(tmp_path, dtype=torch.float32)
    with set_exploration_type(ExplorationType.DETERMINISTIC):
        expected = agent.policy(pixels=pixels())
    assert torch.equal(load_policy("agent", root=tmp_path)(pixels=pixels()), expected)


@pytest.mark.parametrize("algo", ["drqv2", "drq"])
def test_the_policy_is_deterministic_and_within_the_bounds(tmp_path, algo):
    exported(tmp_path, algo=algo, low=-0.5, high=0.25)
    policy = load_policy("agent", root=tmp_path)
    first, second = policy(pixels=pixels()), policy(pixels=pixels())
    assert torch.equal(first, second), "no exploration noise outside a RANDOM exploration context"
    assert first.min() >= -0.5 and first.max() <= 0.25


def test_provenance_records_the_network_sizes_and_the_checksum(tmp_path):
    exported(tmp_path)
    record = info("agent", root=tmp_path)
    assert record["algo"] == "drqv2" and record["observation_shape"] == list(SHAPE) and record["hidden_dim"] == 16
    assert record["env"] == "dmc/cartpole-balance" and len(record["sha256"]) == 64 and record["dtype"] == "float16"
    assert load_config("agent", root=tmp_path).hidden_dim == 16


def test_an_altered_weights_file_is_refused(tmp_path):
    exported(tmp_path)
    weights = tmp_path / "agent.pt"
    weights.write_bytes(weights.read_bytes()[:-10])
    with pytest.raises(CheckpointError, match="does not match the checksum"):
        load_policy("agent", root=tmp_path)


def test_an_agent_loads_by_its_weights_file_too(tmp_path, monkeypatch):
    exported(tmp_path, name="mine")
    by_file = load_policy(str(tmp_path / "mine.pt"))
    assert torch.equal(by_file(pixels=pixels()), load_policy("mine", root=tmp_path)(pixels=pixels()))
    assert info(str(tmp_path / "mine.pt"))["sha256"] == info("mine", root=tmp_path)["sha256"]
    with pytest.raises(KeyError, match="with its .json beside it"):
        info(str(tmp_path / "other.pt"))
    monkeypatch.chdir(tmp_path)
    assert info("mine.pt")["sha256"] == info("mine", root=tmp_path)["sha256"], "a relative file is read from the working directory"


def test_unknown_names_list_the_available_agents(tmp_path):
    exported(tmp_path, name="known")
    with pytest.raises(KeyError, match="available: known"):
        load_policy("unknown", root=tmp_path)


def test_an_agent_is_not_overwritten_by_default(tmp_path):
    exported(tmp_path)
    before = (tmp_path / "agent.json").read_text()
    with pytest.raises(FileExistsError, match="overwrite=True"):
        exported(tmp_path)
    assert (tmp_path / "agent.json").read_text() == before


SHIPPED = ["drqv2-cartpole-balance", "svea-cartpole-balance"]


def test_the_shipped_agents_are_the_expected_ones():
    assert available() == SHIPPED


@pytest.mark.parametrize("name", SHIPPED)
def test_each_shipped_agent_loads_and_acts_within_its_bounds(name):
    record = info(name)
    assert {"commit", "command", "frames", "seed", "env", "evaluation"} <= set(record), f"{name}: provenance incomplete"
    policy = load_policy(name)
    shape = tuple(record["observation_shape"])
    observations = torch.randint(0, 256, (8, *shape), dtype=torch.uint8, generator=torch.Generator().manual_seed(0))
    action = policy(pixels=observations)
    weights = torch.load(f"{policy_file(name)}", weights_only=True)
    assert action.shape == (8, record["action_dim"])
    assert (action >= weights["action_low"]).all() and (action <= weights["action_high"]).all()
    assert action.std(0).max() > 0, f"{name} acts the same on every observation"
    evaluated = {row["level"] for row in record["evaluation"]}
    assert {"train", "color_hard", "video_hard"} <= evaluated and all(len(row["returns"]) == 10 for row in record["evaluation"])


@pytest.mark.parametrize("name", SHIPPED)
def test_each_shipped_agent_is_its_runs_agent_with_the_files_weights_bit_for_bit(name):
    stored = torch.load(policy_file(name), weights_only=True)["parts"]
    assert not any(key.startswith("policy.") for key in stored["actor"]), "re-exported with today's names (issue 47)"
    shipped = load_agent(name)
    assert shipped.config == TrainConfig.from_json(info(name)["config"]) and shipped.frames == info(name)["frames"]
    assert type(shipped.agent.loss).__name__ == {"drqv2": "DrQv2Loss", "svea": "SVEALoss"}[shipped.config.algo]
    assert shipped.agent.exploration_noise.sigma == 0, "built with the run's config, acting without noise"
    for part, tensors in stored.items():
        state = getattr(shipped.agent.loss, part).state_dict()
        assert set(state) == set(tensors), f"{part}: the file holds the module's keys, no more, no fewer"
        for key, value in tensors.items():
            assert state[key].dtype == torch.float32 and torch.equal(state[key], value.float()), f"{part}.{key}"


def policy_file(name):
    from vigen.pretrained import AGENTS

    return AGENTS / f"{name}.pt"


def test_shipped_files_come_in_pairs():
    from vigen.pretrained import AGENTS

    weights = {path.stem for path in AGENTS.glob("*.pt")}
    records = {path.stem for path in AGENTS.glob("*.json")}
    assert weights == records, f"weights without provenance or the reverse: {sorted(weights ^ records)}"
    for name in records:
        json.loads((AGENTS / f"{name}.json").read_text())

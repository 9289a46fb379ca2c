"""Checkpoints written before one name per coefficient (SVEA's alpha/beta, svea_alpha/svea_beta, SAC's log_alpha) and
before the sampler was ``loss.sampler`` (SAC's ``policy.log_alpha``) still load."""

from __future__ import annotations

import pytest
import torch

from loss_helpers import make_loss

LEGACY = {
    "svea": {"weak_weight": "alpha", "strong_weight": "beta"},
    "madi": {"weak_weight": "svea_alpha", "strong_weight": "svea_beta", "sampler.log_alpha": "log_alpha"},
    "drq": {"sampler.log_alpha": "log_alpha"},
    "drq/policy": {"sampler.log_alpha": "policy.log_alpha"},  # the sampler's name before issue 42
    "scpl/policy": {"sampler.log_alpha": "policy.log_alpha"},
}


@pytest.mark.parametrize("case", sorted(LEGACY))
def test_a_state_dict_with_the_old_names_loads_strictly(case):
    name = case.split("/")[0]
    saved = make_loss(name)
    with torch.no_grad():
        for key in LEGACY[case]:
            saved.get_buffer(key).fill_(0.125) if "weight" in key else saved.get_parameter(key).fill_(-1.5)
    renamed = {LEGACY[case].get(key, key): value for key, value in saved.state_dict().items()}
    assert set(LEGACY[case].values()) <= set(renamed), "the old names are what 0.x checkpoints hold"
    loaded = make_loss(name)
    loaded.load_state_dict(renamed)  # strict: every key found under its new name
    for key, value in saved.state_dict().items():
        assert torch.equal(loaded.state_dict()[key], value), key


def _old_actor_names(state: dict, prefix: str) -> dict:
    """``state`` as vigen wrote it before issue 42, when the actors' MLP after the trunk was named ``policy``."""
    return {key.replace(f"{prefix}action_head.", f"{prefix}policy."): value for key, value in state.items()}


@pytest.mark.parametrize("name", ["drqv2", "vrl3", "drq", "sada"])  # vigen's Actor, and GaussianActor without and with a trunk
def test_a_loss_state_dict_with_the_actors_old_mlp_name_loads_bit_for_bit(name):
    saved = make_loss(name)
    with torch.no_grad():
        for parameter in saved.parameters():
            parameter.add_(torch.randn_like(parameter))
    old = _old_actor_names(saved.state_dict(), "actor_params.")
    assert any(key.startswith("actor_params.policy.") for key in old) and not any("action_head" in key for key in old)
    loaded = make_loss(name)
    loaded.load_state_dict(old)  # strict
    for key, value in saved.state_dict().items():
        assert torch.equal(loaded.state_dict()[key], value), key


@pytest.mark.parametrize("name", ["drqv2", "drq"])
def test_an_acting_policy_and_an_actor_load_their_old_state_dicts(name):
    from torchrl.data import Bounded

    spec = Bounded(-1.0, 1.0, shape=(2,))
    saved, loaded = make_loss(name), make_loss(name)
    with torch.no_grad():
        for parameter in saved.parameters():
            parameter.add_(torch.randn_like(parameter))
    policy = loaded.make_policy(spec)
    state = saved.make_policy(spec).state_dict()
    old = {key.replace(".action_head.", ".policy."): value for key, value in state.items()}
    assert set(old) != set(state)
    policy.load_state_dict(old)  # a run's checkpoint["policy"], as examples/train.py --resume loads it
    assert all(torch.equal(policy.state_dict()[key], value) for key, value in state.items())
    fresh = make_loss(name).actor
    fresh.load_state_dict(_old_actor_names(saved.actor.state_dict(), ""))  # a shipped agent's "actor" part
    assert all(torch.equal(fresh.state_dict()[key], value) for key, value in saved.actor.state_dict().items())


def test_a_key_under_its_new_name_wins_over_an_old_one():
    from vigen.models import rename_actor_keys

    state = {"policy.0.weight": 1, "action_head.0.weight": 2, "trunk.policy.0": 3}
    rename_actor_keys(state)
    assert state == {"policy.0.weight": 1, "action_head.0.weight": 2, "trunk.policy.0": 3}

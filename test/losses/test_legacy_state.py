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

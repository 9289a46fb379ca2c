"""Checkpoints written before one name per coefficient (SVEA's alpha/beta, svea_alpha/svea_beta, SAC's log_alpha) still load."""

from __future__ import annotations

import pytest
import torch

from loss_helpers import make_loss

LEGACY = {
    "svea": {"weak_weight": "alpha", "strong_weight": "beta"},
    "madi": {"weak_weight": "svea_alpha", "strong_weight": "svea_beta", "policy.log_alpha": "log_alpha"},
    "drq": {"policy.log_alpha": "log_alpha"},
}


@pytest.mark.parametrize("name", sorted(LEGACY))
def test_a_state_dict_with_the_old_names_loads_strictly(name):
    saved = make_loss(name)
    with torch.no_grad():
        for key in LEGACY[name]:
            saved.get_buffer(key).fill_(0.125) if "weight" in key else saved.get_parameter(key).fill_(-1.5)
    renamed = {LEGACY[name].get(key, key): value for key, value in saved.state_dict().items()}
    assert set(LEGACY[name].values()) <= set(renamed), "the old names are what 0.x checkpoints hold"
    loaded = make_loss(name)
    loaded.load_state_dict(renamed)  # strict: every key found under its new name
    for key, value in saved.state_dict().items():
        assert torch.equal(loaded.state_dict()[key], value), key

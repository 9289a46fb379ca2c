"""SplitSoftUpdate: each part of the target networks moves at its own rate, the rest at tau (DMC-GB's critic / encoder taus)."""

from __future__ import annotations

import pytest
import torch

from vigen.losses import SplitSoftUpdate, make_loss


def loss_of(name: str = "madi"):
    torch.manual_seed(0)
    return make_loss(name, (9, 64, 64), 2, hidden_dim=8, feature_dim=4)


def perturb(loss) -> None:
    """Move the online parameters away from their targets (an updater copies them into the targets when it is made)."""
    torch.manual_seed(1)
    with torch.no_grad():
        for parameter in loss.parameters():
            parameter.add_(torch.randn_like(parameter))


def test_each_part_moves_at_its_rate_and_the_rest_at_tau():
    """θ' ← (1 − τ)·θ' + τ·θ with τ = 0.05 for the encoder and the critic's trunk (DMC-GB's critic encoder), 0.01 else."""
    loss = loss_of()
    update = SplitSoftUpdate(loss, tau=0.01, taus={"encoder": 0.05, "critic.trunk": 0.05})
    perturb(loss)
    before = {name: {key: value.detach().clone() for key, value in getattr(loss, f"target_{name}_params").items(True, True)}
              for name in ("encoder", "critic")}
    update.step()
    for name in ("encoder", "critic"):
        online, target = getattr(loss, f"{name}_params"), getattr(loss, f"target_{name}_params")
        for key, value in target.items(True, True):
            tau = 0.05 if name == "encoder" or key[0] == "trunk" else 0.01
            expected = before[name][key] + tau * (online.get(key).detach() - before[name][key])
            torch.testing.assert_close(value.data, expected.data, msg=lambda m: f"{name} {key}: {m}")


def test_without_taus_it_is_torchrls_soft_update():
    from torchrl.objectives import SoftUpdate

    split, plain = loss_of(), loss_of()
    updates = SplitSoftUpdate(split, tau=0.01, taus={}), SoftUpdate(plain, tau=0.01)
    for loss, update in zip((split, plain), updates):
        perturb(loss)
        update.step()
    for (key, value), (_, expected) in zip(split.state_dict().items(), plain.state_dict().items()):
        assert torch.equal(value, expected), key


def test_a_part_with_no_target_parameters_or_a_bad_rate_is_refused():
    loss = loss_of("drqv2")  # DrQ-v2 has no target encoder
    with pytest.raises(ValueError, match="no target parameters under 'encoder'; the parts are critic, critic.q1"):
        SplitSoftUpdate(loss, tau=0.01, taus={"encoder": 0.05})
    with pytest.raises(ValueError, match="the rate of 'critic.trunk' must be in \\(0, 1\\]"):
        SplitSoftUpdate(loss, tau=0.01, taus={"critic.trunk": 1.5})

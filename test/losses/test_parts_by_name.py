"""make_loss with an algorithm's parts swapped by name: SVEA on DMC-GB's SAC parts, a SAC actor's log-std bounds."""

from __future__ import annotations

import pytest
import torch

from vigen.losses import SquashedGaussian, example_batch, make_loss
from vigen.models import GaussianActor, SharedCNN

DMCGB_PARTS = dict(encoder_type="shared_cnn_01", actor_type="gaussian_projected", sampler_type="squashed_gaussian",
                   squash_epsilon=1e-6, target_encoder=True, augment_next=False)


def test_svea_on_dmcgbs_sac_parts_is_madi_without_its_masker():
    """MaDi is SVEA on DMC-GB's SAC with a masker: the same parts without it give the same losses on the same weights."""
    torch.manual_seed(0)
    svea = make_loss("svea", (9, 64, 64), 2, hidden_dim=8, feature_dim=4, seed=1, **DMCGB_PARTS)
    torch.manual_seed(0)
    madi = make_loss("madi", (9, 64, 64), 2, hidden_dim=8, feature_dim=4, seed=1, input_mask=torch.nn.Identity())
    assert isinstance(svea.encoder, SharedCNN) and not svea.encoder.centered and isinstance(svea.actor, GaussianActor)
    assert isinstance(svea.sampler, SquashedGaussian) and svea.sampler.squash_epsilon == 1e-6
    madi.load_state_dict(svea.state_dict(), strict=False)
    batch = example_batch(4, (9, 64, 64))
    torch.manual_seed(3)
    mine = svea(batch.clone())
    torch.manual_seed(3)
    theirs = madi(batch.clone())
    for key in ("loss_critic", "loss_actor", "loss_alpha"):
        torch.testing.assert_close(mine[key], theirs[key], msg=lambda m: f"{key}: {m}")


def test_log_std_bounds_shape_the_sac_actor_and_bad_parts_are_refused():
    loss = make_loss("drq", (9, 32, 32), 2, hidden_dim=8, log_std_bounds=(-5, 1))
    _, log_std = loss.actor(torch.randn(64, loss.critic.trunk[0].in_features) * 100)
    assert loss.actor.log_std_bounds == (-5.0, 1.0) and -5 <= float(log_std.min()) and float(log_std.max()) <= 1
    with pytest.raises(ValueError, match="log_std_bounds shape a SAC actor's log σ; Actor has none"):
        make_loss("drqv2", (9, 32, 32), 2, hidden_dim=8, log_std_bounds=(-5, 1))
    with pytest.raises(ValueError, match="encoder_type='nope' is not one of vigen's"):
        make_loss("svea", (9, 64, 64), 2, hidden_dim=8, encoder_type="nope")
    with pytest.raises(ValueError, match="SquashedGaussian draws from a SAC actor, but the actor is Actor"):
        make_loss("svea", (9, 64, 64), 2, hidden_dim=8, sampler_type="squashed_gaussian")
    with pytest.raises(TypeError, match="samples with NoisyDeterministic and takes no 'init_temperature'"):
        make_loss("svea", (9, 64, 64), 2, hidden_dim=8, init_temperature=0.1)


def test_a_param_group_names_a_module_with_parameters():
    with pytest.raises(ValueError, match="param_groups names 'masker', which is not one of its modules \\(encoder, actor, "
                                         "critic, sampler\\)"):
        make_loss("drq", (9, 32, 32), 2, hidden_dim=8, param_groups={"masker": {"lr": 1e-3}}).optimizer_groups(1e-4)
    with pytest.raises(ValueError, match="param_groups names 'sampler', which has no parameters"):
        make_loss("drqv2", (9, 32, 32), 2, hidden_dim=8, param_groups={"sampler": {"every": 2}}).optimizer_groups(1e-4)
    with pytest.raises(ValueError, match="\['every'\] is a number of updates, an integer >= 1, got 0"):
        make_loss("drq", (9, 32, 32), 2, hidden_dim=8, param_groups={"actor": {"every": 0}})

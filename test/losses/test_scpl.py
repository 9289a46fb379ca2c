"""SCPL (AAMAS 2025, https://github.com/bofusun/SCPL): the dynamics model, the policy KL and the loss, by hand."""

from __future__ import annotations

import math

import pytest
import torch
import torch.nn.functional as F
from torch import nn

from loss_helpers import ACTIONS, dmcgb_squashed_sample, make_batch, make_loss
from vigen.losses import (ALGOS, GuidedBackprop, NoisyDeterministic, SCPLLoss, SquashedGaussian, attribution_mask, build_loss,
                          diagonal_gaussian_kl, squashed_normal_sample)
from vigen.losses import make_loss as make_paper_loss
from vigen.models import Actor, Critic, DrQv2Encoder, GaussianActor, LatentDynamics, SharedCNN
from vigen.transforms import ImageAugmentation, RandomOverlay

pytestmark = pytest.mark.filterwarnings("ignore:No target network updater")
GAMMA = 0.9  # what loss_helpers gives the value estimator
ALPHA = 0.1  # the initial temperature


class Invert(ImageAugmentation):
    """A deterministic strong view, so that the hand computation sees the same pixels."""

    def make_params(self, images):
        return {}

    def apply(self, images, params):
        return (self.white(images) - images).to(images.dtype)



# -- the pieces ------------------------------------------------------------------------------------
def test_diagonal_gaussian_kl_is_torchs_kl():
    torch.manual_seed(0)
    mean_p, mean_q, log_var_p, log_var_q = (torch.randn(5, 3) for _ in range(4))
    expected = torch.distributions.kl_divergence(
        torch.distributions.MultivariateNormal(mean_p, torch.diag_embed(log_var_p.exp())),
        torch.distributions.MultivariateNormal(mean_q, torch.diag_embed(log_var_q.exp())),
    )
    assert torch.allclose(diagonal_gaussian_kl(mean_p, log_var_p, mean_q, log_var_q), expected, atol=1e-5)
    assert torch.allclose(diagonal_gaussian_kl(mean_p, log_var_p, mean_p, log_var_p), torch.zeros(5))


def test_squashed_normal_sample_with_dmcgbs_epsilon():
    generator = torch.Generator().manual_seed(0)
    mean, log_std = torch.randn(6, 3, generator=generator) * 0.5, torch.randn(6, 3, generator=generator) * 0.3
    torch.manual_seed(1)
    action, log_prob = squashed_normal_sample(mean, log_std, epsilon=1e-6)
    torch.manual_seed(1)
    expected_action, expected = dmcgb_squashed_sample(mean, log_std)
    assert torch.equal(action, expected_action)
    assert torch.allclose(log_prob, expected, atol=1e-5)
    torch.manual_seed(1)
    _, stable = squashed_normal_sample(mean, log_std)
    assert not torch.equal(stable, log_prob) and torch.allclose(stable, log_prob, atol=1e-3), "ε = 1e-6 moves log π a little"
    # the two forms part where tanh saturates: log(1 − a²) → −∞, log(relu(1 − a²) + ε) ≥ log ε
    _, far_stable = squashed_normal_sample(torch.full((1, 1), 20.0), torch.full((1, 1), -10.0))
    _, far = squashed_normal_sample(torch.full((1, 1), 20.0), torch.full((1, 1), -10.0), epsilon=1e-6)
    assert far_stable > far + 10


def test_latent_dynamics_by_hand():
    torch.manual_seed(0)
    model = LatentDynamics(embedding_dim=5, action_dim=2, hidden_dim=7)
    embedding, action = torch.randn(3, 5), torch.randn(3, 2)
    hidden = torch.relu(F.layer_norm(torch.cat([embedding, action], 1) @ model.hidden.weight.T + model.hidden.bias, (7,),
                                     model.norm.weight, model.norm.bias))
    next_embedding, reward = model(embedding, action)
    assert torch.allclose(next_embedding, hidden @ model.next_embedding.weight.T + model.next_embedding.bias, atol=1e-6)
    assert torch.allclose(reward, hidden @ model.reward.weight.T + model.reward.bias, atol=1e-6)
    assert sum(p.numel() for p in LatentDynamics(100, 6).parameters()) == 106 * 512 + 512 + 2 * 512 + 512 * 101 + 101
    with pytest.raises(ValueError, match="hidden_dim must be a positive int"):
        LatentDynamics(5, 2, hidden_dim=0)


def test_shared_cnn_on_dmcgbs_pixel_scale():
    """``centered=False``: the convolutions read x / 255 (DMC-GB's NormalizeImg), not x / 255 − 0.5."""
    torch.manual_seed(0)
    pixels = torch.randint(0, 256, (2, 9, 16, 16), dtype=torch.uint8)
    encoder = SharedCNN(9, num_layers=3, centered=False)
    assert torch.allclose(encoder(pixels), encoder.convnet(pixels.float() / 255).flatten(1), atol=1e-6)
    centered = SharedCNN(9, num_layers=3)
    centered.load_state_dict(encoder.state_dict())
    assert torch.allclose(centered(pixels), encoder.convnet(pixels.float() / 255 - 0.5).flatten(1), atol=1e-6)


# -- the loss --------------------------------------------------------------------------------------
def _scpl(**kwargs) -> SCPLLoss:
    loss = make_loss("scpl", augmentation=None, strong_augmentation=Invert(), **kwargs)
    assert isinstance(loss, SCPLLoss)
    return loss


def test_scpl_equals_its_update_rule():
    """SCPL's ``update``: SVEA critic + 0.5·masked-Q consistency, SAC actor + KL, α loss, dynamics model."""
    loss = _scpl()
    with torch.no_grad():  # a target encoder apart from the online one, to see which one each term reads
        for value in loss.target_encoder_params.values(True, True):
            value.mul_(0.9)
    batch = make_batch()
    torch.manual_seed(5)
    out = loss(batch)

    encoder, actor, critic, dynamics = loss.encoder, loss.actor, loss.critic, loss.dynamics
    target_encoder = DrQv2Encoder(9)
    target_encoder.load_state_dict(encoder.state_dict())
    with torch.no_grad():
        for (name, param), value in zip(target_encoder.named_parameters(), loss.target_encoder_params.values(True, True)):
            param.copy_(value)
    target_critic = Critic(32, ACTIONS, 8, 16)
    with torch.no_grad():
        for param, value in zip(target_critic.parameters(), loss.target_critic_params.values(True, True)):
            param.copy_(value)
    action, reward = batch["action"], batch["next", "reward"]
    obs, next_obs = batch["pixels"].float() / 255, batch["next", "pixels"].float() / 255
    strong, strong_next = 1 - obs, 1 - next_obs

    torch.manual_seed(5)
    with torch.no_grad():  # y = r + γ·(min Q'(target h', a') − α·log π(a'|online h'))
        next_action, next_log_prob = dmcgb_squashed_sample(*actor(encoder(next_obs)))
        target = reward + GAMMA * (torch.min(*target_critic(target_encoder(next_obs), next_action)) - ALPHA * next_log_prob)
    views = torch.cat([obs, strong]).requires_grad_(True)
    actions = torch.cat([action, action])
    guided = GuidedBackprop(encoder, critic)
    with guided.recording():
        q1_probe, _ = critic(encoder(views), actions)
    mask = attribution_mask(guided.saliency(q1_probe, views), 0.9)
    views = views.detach()
    fill = views.min() + (views.max() - views.min()) * torch.rand(())
    masked = views * mask + fill * ~mask
    q1, q2 = critic(encoder(views), actions)
    m1, m2 = critic(encoder(masked), actions)
    targets = torch.cat([target, target])
    critic_loss = F.mse_loss(q1, targets) + F.mse_loss(q2, targets) + 0.5 * (F.mse_loss(q1, m1) + F.mse_loss(q2, m2))
    assert torch.allclose(out["loss_critic"], critic_loss, atol=1e-5)
    assert torch.allclose(out["mask_fraction"], mask.float().mean())
    assert 0.1 <= out["mask_fraction"] < 0.2, "the top 10 % of each frame (ties included)"
    assert torch.allclose(out["q_strong_mean"], q1[6:].mean(), atol=1e-6)

    with torch.no_grad():
        hidden, hidden_strong = encoder(obs), encoder(strong)
        mean, log_std = actor(hidden)
        mean_strong, log_std_strong = actor(hidden_strong)
        pi, log_prob = dmcgb_squashed_sample(mean, log_std)
        actor_q = torch.min(*critic(hidden, pi))
        kl = torch.distributions.kl_divergence(  # SCPL: MultivariateNormal(tanh μ, diag(σ))
            torch.distributions.MultivariateNormal(torch.tanh(mean), torch.diag_embed(log_std.exp())),
            torch.distributions.MultivariateNormal(torch.tanh(mean_strong), torch.diag_embed(log_std_strong.exp())),
        )
    assert torch.allclose(out["loss_actor"], (ALPHA * log_prob - actor_q).mean() + kl.mean(), atol=1e-5)
    assert torch.allclose(out["policy_kl"], kl.mean(), atol=1e-5)
    assert torch.allclose(out["loss_alpha"], (ALPHA * (-log_prob + ACTIONS)).mean(), atol=1e-5), "target entropy −|A|"

    with torch.no_grad():  # ½·mean((ê' − e')²) + MSE(r̂, r) over both views, e = the critic trunk's embedding
        embedding = critic.trunk(encoder(torch.cat([obs, strong])))
        next_embedding = critic.trunk(encoder(torch.cat([next_obs, strong_next])))
        predicted, predicted_reward = dynamics(embedding, actions)
        transition = torch.mean(0.5 * (predicted - next_embedding) ** 2)
        reward_error = F.mse_loss(predicted_reward, torch.cat([reward, reward]))
    assert torch.allclose(out["loss_dynamics"], transition + reward_error, atol=1e-5)
    assert torch.allclose(out["reward_error"], reward_error, atol=1e-5)


def test_without_target_encoder_the_target_reads_the_online_encoder():
    loss = _scpl(target_encoder=False)
    batch = make_batch()
    torch.manual_seed(2)
    out = loss(batch)
    torch.manual_seed(2)
    with torch.no_grad():
        hidden = loss.encoder(batch["next", "pixels"])
        next_action, next_log_prob = dmcgb_squashed_sample(*loss.actor(hidden))
        with loss.target_critic_params.to_module(loss.critic):
            value = torch.min(*loss.critic(hidden, next_action)) - ALPHA * next_log_prob
    assert torch.allclose(out["target_mean"], (batch["next", "reward"] + GAMMA * value).mean(), atol=1e-5)


def test_strong_views_of_obs_and_next_obs_share_one_draw():
    """SCPL overlays obs and next obs stacked along the channels: the same image for both."""
    loss = make_loss("scpl", augmentation=None, strong_augmentation=RandomOverlay(alpha=1.0, seed=0))
    seen, augmentation = [], loss.strong_augmentation[0]
    draw = augmentation.augment
    augmentation.augment = lambda images: seen.append(draw(images)) or seen[-1]  # record the one strong draw
    loss(make_batch())
    (pair,) = seen
    strong_obs, strong_next_obs = pair.chunk(2, dim=1)  # obs and next obs stacked along the channels, one draw
    assert torch.equal(strong_obs, strong_next_obs), "alpha = 1: both are the sample's image"
    assert not torch.equal(strong_obs[0], strong_obs[1]), "each sample its own image"


def test_dynamics_term_trains_the_model_the_critic_trunk_and_the_encoder():
    loss = make_loss("scpl")
    loss(make_batch())["loss_dynamics"].backward()

    def reached(params) -> set[str]:
        return {key[0] for key, value in params.items(True, True) if value.grad is not None and value.grad.abs().sum() > 0}

    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in loss.dynamics.parameters())
    assert reached(loss.critic_params) == {"trunk"}, "not the Q heads"
    assert reached(loss.encoder_params) and not reached(loss.actor_params) and loss.sampler.log_alpha.grad is None


def test_kl_weight_and_covariance():
    batch = make_batch()
    outs = {}
    for options in ({}, {"kl_weight": 0.0}, {"kl_covariance": "variance"}):
        torch.manual_seed(0)
        loss = make_loss("scpl", augmentation=None, strong_augmentation=Invert(), **options)
        torch.manual_seed(3)
        outs[str(options)] = loss(batch)
    default, off, variance = outs.values()
    assert torch.allclose(default["loss_actor"] - off["loss_actor"], default["policy_kl"], atol=1e-5)
    assert not torch.allclose(default["policy_kl"], variance["policy_kl"]), "diag(σ) and diag(σ²) are other Gaussians"


def test_make_loss_builds_scpls_networks():
    assert ALGOS["scpl"].loss is SCPLLoss
    loss = make_paper_loss("scpl", (9, 84, 84), action_dim=6, hidden_dim=64, feature_dim=100, seed=0)
    assert isinstance(loss.encoder, SharedCNN) and not loss.encoder.centered, "DMC-GB's x / 255"
    assert isinstance(loss.actor, GaussianActor) and isinstance(loss.actor.trunk, nn.Sequential), "its own projection"
    assert isinstance(loss.dynamics, LatentDynamics) and loss.dynamics.hidden.in_features == 106
    assert loss.sampler.squash_epsilon == 1e-6 and loss.scores_on_target_encoder
    groups = loss.optimizer_groups(1e-4)
    assert [g["lr"] for g in groups] == [1e-4, 3e-4]
    assert {id(p) for p in groups[1]["params"]} == {id(p) for p in loss.dynamics.parameters()}
    assert sum(len(g["params"]) for g in groups) == len(list(loss.parameters()))


def test_bad_arguments_are_explained():
    encoder = DrQv2Encoder(9)
    actor, critic, dynamics = GaussianActor(32, 2, 16, feature_dim=8), Critic(32, 2, 8, 16), LatentDynamics(8, 2, 16)

    class NoEmbed(nn.Module):
        def forward(self, hidden, action):
            return critic(hidden, action)

    with pytest.raises(TypeError, match="embed"):
        build_loss("scpl", encoder, actor, NoEmbed(), dynamics)
    with pytest.raises(TypeError, match="LatentDynamics"):
        build_loss("scpl", encoder, actor, critic, "model")
    with pytest.raises(ValueError, match="quantile"):
        build_loss("scpl", encoder, actor, critic, dynamics, quantile=1.5)
    with pytest.raises(ValueError, match="kl_covariance"):
        build_loss("scpl", encoder, actor, critic, dynamics, kl_covariance="cov")
    with pytest.raises(ValueError, match="'lr'"):
        build_loss("scpl", encoder, actor, critic, dynamics, param_groups={"dynamics": {"lr": -1.0}})
    with pytest.raises(TypeError, match="NoisyDeterministic"):  # refused by SCPL itself, with a deterministic actor too
        build_loss("scpl", encoder, Actor(32, 2, feature_dim=8, hidden_dim=16), critic, dynamics, sampler=NoisyDeterministic())
    with pytest.raises(TypeError, match="std"):
        build_loss("scpl", encoder, actor, critic, dynamics, std_schedule=0.1)
    with pytest.raises(TypeError, match="missing .*weak_weight"):  # the class has no defaults: the record gives them
        SCPLLoss(encoder, actor, critic, dynamics, sampler=SquashedGaussian(), augmentation=None, target_encoder=True)
    assert math.isclose(build_loss("scpl", encoder, actor, critic, dynamics).quantile, 0.9)

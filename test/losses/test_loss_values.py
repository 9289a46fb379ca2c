"""Each loss against a hand computation of its paper's formula, on tiny networks and fixed views."""

from __future__ import annotations

import copy
import math

import pytest
import torch
import torch.nn.functional as F
from torch import nn
from torchrl.data import LazyTensorStorage, ReplayBuffer
from torchrl.envs.transforms import MultiStepTransform
from torchrl.objectives import SoftUpdate

from loss_helpers import SIZE, make_batch, make_loss
from vigen.losses import (
    DrQv2Loss,
    NoisyDeterministic,
    GuidedBackprop,
    LinearSchedule,
    attribution_mask,
    clipped_normal_sample,
    squashed_normal_sample,
)
from vigen.transforms import ImageAugmentation

pytestmark = pytest.mark.filterwarnings("ignore:No target network updater")
GAMMA = 0.9  # what make_loss gives the value estimator


class Flip(ImageAugmentation):
    """A deterministic 'weak augmentation': every view is the left-right mirror of its pixels."""

    def make_params(self, images):
        return {}

    def apply(self, images, params):
        return images.flip(-1)


class Invert(ImageAugmentation):
    """A deterministic 'strong augmentation' for exact checks."""

    def make_params(self, images):
        return {}

    def apply(self, images, params):
        return (self.white(images) - images).to(images.dtype)


def _mse_pair(q1, q2, target):
    return F.mse_loss(q1, target) + F.mse_loss(q2, target)


def _next_value(loss, next_pixels):
    """min(Q1', Q2') at the noiseless target action (std 0), from the target critic."""
    hidden = loss.encoder(next_pixels)
    action = loss.actor(hidden).clamp(-1 + 1e-6, 1 - 1e-6)
    with loss.target_critic_params.to_module(loss.critic):
        return torch.min(*loss.critic(hidden, action))


# -- DrQ-v2 ------------------------------------------------------------------------------------
def test_drqv2_equals_its_update_rule():
    loss = make_loss("drqv2", augmentation=None, std_schedule=0.0)
    batch = make_batch()
    out = loss(batch)
    with torch.no_grad():
        target = batch["next", "reward"] + GAMMA * _next_value(loss, batch["next", "pixels"])
        hidden = loss.encoder(batch["pixels"])
        q1, q2 = loss.critic(hidden, batch["action"])
        actor_q = torch.min(*loss.critic(hidden, loss.actor(hidden).clamp(-1 + 1e-6, 1 - 1e-6)))
    assert torch.allclose(out["loss_critic"], _mse_pair(q1, q2, target), atol=1e-6)
    assert torch.allclose(out["loss_actor"], -actor_q.mean(), atol=1e-6)
    assert torch.allclose(out["target_mean"], target.mean(), atol=1e-6)


def test_target_comes_from_the_target_critic():
    loss = make_loss("drqv2", augmentation=None, std_schedule=0.0)
    batch = make_batch()
    before = loss(batch)["target_mean"]
    with torch.no_grad():
        loss.target_critic_params["q1", "4", "bias"].add_(1.0)
        loss.target_critic_params["q2", "4", "bias"].add_(1.0)
    assert torch.allclose(loss(batch)["target_mean"], before + GAMMA, atol=1e-5)


def test_n_step_terminated_and_truncated_targets():
    """γⁿ from steps_to_next_obs; terminations cut the bootstrap, truncations keep it."""
    loss = make_loss("drqv2", augmentation=None, std_schedule=0.0, reduction="none")
    batch = make_batch(
        batch=3,
        done=torch.tensor([[False], [True], [True]]),
        terminated=torch.tensor([[False], [True], [False]]),  # the third is a time-limit truncation
    )
    batch["steps_to_next_obs"] = torch.tensor([3, 2, 1])
    out = loss(batch)
    with torch.no_grad():
        value = _next_value(loss, batch["next", "pixels"]).squeeze(-1)
        reward = batch["next", "reward"].squeeze(-1)
        target = reward + torch.stack([GAMMA**3 * value[0], torch.zeros(()), GAMMA * value[2]])
        q1, q2 = loss.critic(loss.encoder(batch["pixels"]), batch["action"])
    expected = (q1.squeeze(-1) - target) ** 2 + (q2.squeeze(-1) - target) ** 2
    assert torch.allclose(out["loss_critic"], expected, atol=1e-5)


def test_n_step_batch_from_torchrl_multistep_transform():
    """A buffer with MultiStepTransform(3) gives r + γr' + γ²r'' + γ³·V(s₃), shorter at an episode end."""
    steps = 6
    frames = torch.randint(0, 256, (steps + 1, 9, 16, 16), dtype=torch.uint8)
    done = torch.zeros(steps, 1, dtype=torch.bool)
    done[-1] = True  # time limit
    trajectory = make_batch(batch=steps, done=done, terminated=torch.zeros(steps, 1, dtype=torch.bool))
    trajectory["pixels"], trajectory["next", "pixels"] = frames[:-1], frames[1:]
    trajectory["next", "reward"] = torch.arange(1.0, steps + 1).unsqueeze(-1)
    buffer = ReplayBuffer(storage=LazyTensorStorage(16), transform=MultiStepTransform(3, GAMMA))
    buffer.extend(trajectory)
    buffer.extend(trajectory.clone())  # the transform holds back the last n steps until the next extend
    sample = buffer[:steps]
    loss = make_loss("drqv2", augmentation=None, std_schedule=0.0, reduction="none")
    loss(sample)
    with torch.no_grad():
        value = _next_value(loss, frames[[3, 4, 5, 6, 6, 6]]).squeeze(-1)
    rewards = trajectory["next", "reward"].squeeze(-1)
    n = torch.tensor([3, 3, 3, 3, 2, 1])
    expected = torch.stack([
        sum(GAMMA**k * rewards[t + k] for k in range(int(n[t]))) + GAMMA ** n[t] * value[t] for t in range(steps)
    ])
    assert torch.equal(sample["steps_to_next_obs"], n)
    target = loss.value_estimator.value_estimate(sample, next_value=value.unsqueeze(-1)).squeeze(-1)
    assert torch.allclose(target, expected, atol=1e-5)


def test_clipped_noise_and_schedule():
    mean = torch.zeros(20_000, 2, requires_grad=True)
    sample = clipped_normal_sample(mean, std=1.0, clip=0.3)
    assert sample.abs().max() <= 0.3 + 1e-6
    sample.sum().backward()
    assert torch.equal(mean.grad, torch.ones_like(mean)), "straight-through gradient"
    wide = clipped_normal_sample(torch.zeros(20_000), std=0.2, clip=None)
    assert abs(wide.std().item() - 0.2) < 0.01
    near_edge = clipped_normal_sample(torch.full((100,), 0.99), std=1.0, clip=None)
    assert near_edge.max() < 1 and near_edge.min() > -1
    loss = make_loss("drqv2", std_schedule=LinearSchedule(1.0, 0.1, 1000))
    assert loss.sampler.std(loss.schedule_step).item() == 1.0
    loss.set_step(500)
    assert math.isclose(loss(make_batch())["std"].item(), 0.55, rel_tol=1e-6)
    assert loss.sampler.std_schedule(500) == 0.55 and loss.sampler.std(loss.schedule_step).item() == pytest.approx(0.55)


# -- SVEA / SRM --------------------------------------------------------------------------------
def test_svea_weights_the_weak_and_strong_views():
    loss = make_loss("svea", augmentation=None, std_schedule=0.0, strong_augmentation=Invert(), weak_weight=0.3, strong_weight=0.7)
    batch = make_batch()
    out = loss(batch)
    with torch.no_grad():
        target = batch["next", "reward"] + GAMMA * _next_value(loss, batch["next", "pixels"])
        weak = _mse_pair(*loss.critic(loss.encoder(batch["pixels"]), batch["action"]), target)
        strong = _mse_pair(*loss.critic(loss.encoder(255 - batch["pixels"]), batch["action"]), target)
    assert torch.allclose(out["loss_critic"], 0.3 * weak + 0.7 * strong, atol=1e-5)
    loss.weak_weight, loss.strong_weight = 1.0, 0.0  # schedulable coefficients
    assert torch.allclose(loss(batch)["loss_critic"], weak, atol=1e-5)


def test_srm_strong_view_is_frequency_masked_overlay():
    loss = make_loss("srm")
    assert [type(t).__name__ for t in loss.strong_augmentation] == ["RandomOverlay", "RandomFrequencyMask"]
    mask = loss.strong_augmentation[1]
    assert (mask.p, mask.max_low, mask.max_width, mask.per_sample, mask.fill) == (0.5, 0.5, 0.05, False, "zero")


# -- SGQN --------------------------------------------------------------------------------------
def test_guided_backprop_matches_the_analytic_rule():
    """y = v·relu(W₂·relu(W₁x)): guided gradient zeroes negative gradients at both ReLUs."""
    torch.manual_seed(0)
    net = nn.Sequential(nn.Linear(5, 7), nn.ReLU(), nn.Linear(7, 6), nn.ReLU(), nn.Linear(6, 1))
    x = torch.randn(4, 5, requires_grad=True)
    guided = GuidedBackprop(net)
    with guided.recording():
        y = net(x)
    saliency = guided.saliency(y, x, retain_graph=True)
    w1, w2, v = net[0].weight, net[2].weight, net[4].weight
    z1 = x @ w1.T + net[0].bias
    z2 = torch.relu(z1) @ w2.T + net[2].bias
    g2 = (z2 > 0) * v.clamp(min=0)  # gradient into the second ReLU's input, guided
    g1 = (z1 > 0) * (g2 @ w2).clamp(min=0)
    assert torch.allclose(saliency, g1 @ w1, atol=1e-6)
    (plain,) = torch.autograd.grad(y.sum(), x)
    assert torch.allclose(plain, (((z2 > 0) * v) @ w2 * (z1 > 0)) @ w1, atol=1e-6), "other backward passes are plain"
    assert not torch.allclose(plain, saliency)


@pytest.mark.parametrize("dtype", [torch.float32, torch.float64])
def test_last_dim_quantile_is_torch_quantile_bit_for_bit(dtype):
    from vigen.losses.saliency import last_dim_quantile

    values = torch.rand(5, 3, 7056, dtype=dtype, generator=torch.Generator().manual_seed(0))
    values[0, 0, :100] = 0.5  # ties
    for q in (0.0, 0.5, 0.9, 0.93, 0.95, 0.98, 1.0):
        assert torch.equal(last_dim_quantile(values, q), torch.quantile(values, q, dim=-1, keepdim=True)), q
    assert torch.equal(last_dim_quantile(values[..., :1], 0.9), values[..., :1])


def test_guided_backprop_needs_relu_modules():
    with pytest.raises(ValueError, match="nn.ReLU"):
        GuidedBackprop(nn.Sequential(nn.Linear(2, 2), nn.Tanh()))


def test_attribution_mask_keeps_the_top_quantile_per_frame():
    saliency = torch.zeros(1, 6, 4, 5)
    saliency[0, 1, 0, :3] = torch.tensor([3.0, -5.0, 1.0])  # frame 0: max over RGB of |saliency|
    saliency[0, 4] = -torch.arange(20.0).reshape(4, 5)  # frame 1
    mask = attribution_mask(saliency, quantile=0.9)
    frame0 = torch.zeros(4, 5, dtype=torch.bool)
    frame0[0, :2] = True  # the top 10 % of 20 pixels: |−5| and 3
    assert torch.equal(mask[0, 0], frame0) and torch.equal(mask[0, 2], frame0)
    frame1 = torch.zeros(4, 5, dtype=torch.bool)
    frame1[3, 3:] = True  # |−18| and |−19|
    assert all(torch.equal(mask[0, c], frame1) for c in (3, 4, 5))
    assert attribution_mask(torch.zeros(1, 3, 4, 5), 0.9).all(), "ties at the threshold are kept, as in SGQN"


def test_sgqn_without_masking_is_td_plus_attribution_bce():
    """quantile 0 keeps every pixel: the consistency term vanishes and the head learns an all-ones mask."""
    loss = make_loss("sgqn", augmentation=None, std_schedule=0.0, quantile=0.0, attribution_augmentation=[])
    batch = make_batch()
    out = loss(batch)
    with torch.no_grad():
        target = batch["next", "reward"] + GAMMA * _next_value(loss, batch["next", "pixels"])
        embedding = loss.encoder(batch["pixels"])
        td = _mse_pair(*loss.critic(embedding, batch["action"]), target)
        logits = loss.decoder(embedding, batch["action"])
    assert out["consistency"] == 0 and out["mask_fraction"] == 1
    assert torch.allclose(out["loss_critic"], td, atol=1e-5)
    assert torch.allclose(out["loss_attribution"], F.binary_cross_entropy_with_logits(logits, torch.ones_like(logits)), atol=1e-5)


def test_sgqn_consistency_term_and_saliency():
    loss = make_loss("sgqn", augmentation=None, std_schedule=0.0, quantile=0.9, consistency_weight=0.5)
    batch = make_batch()
    out = loss(batch)
    with torch.no_grad():
        target = batch["next", "reward"] + GAMMA * _next_value(loss, batch["next", "pixels"])
        td = _mse_pair(*loss.critic(loss.encoder(batch["pixels"]), batch["action"]), target)
    assert out["consistency"] > 0
    assert torch.allclose(out["loss_critic"], td + 0.5 * out["consistency"], atol=1e-5)

    pixels = (batch["pixels"].float() / 255).requires_grad_()  # the loss's float pixels: the encoder's 0–1 scale
    guided = GuidedBackprop(loss.encoder, loss.critic)
    with guided.recording():
        q1, _ = loss.critic(loss.encoder(pixels), batch["action"])
    mask = attribution_mask(guided.saliency(q1, pixels), 0.9)
    assert mask.float().mean() == out["mask_fraction"], "the loss masks with the guided saliency of Q1"
    # Each frame keeps at least its top 10 %; more only where saliency ties at the threshold
    # (a randomly initialised tiny net can have dead units that zero a whole frame's saliency).
    per_frame = mask[:, ::3].float().mean(dim=(-2, -1))
    assert (per_frame >= 0.1).all()
    assert per_frame.median() < 0.1 + 2 / SIZE**2


def test_sgqn_critic_gradients_are_the_plain_ones():
    """The guided switch only changes the saliency pass, never the loss's own backward."""
    sgqn = make_loss("sgqn", augmentation=None, std_schedule=0.0, consistency_weight=0.0)
    drqv2 = DrQv2Loss(sgqn.encoder, sgqn.actor, sgqn.critic, augmentation=None, sampler=NoisyDeterministic(std_schedule=0.0),
                      target_encoder=False)
    drqv2.make_value_estimator(gamma=GAMMA)
    drqv2.target_critic_params.data.update_(sgqn.target_critic_params.data)
    batch = make_batch()
    grads = []
    for loss in (sgqn, drqv2):
        loss.zero_grad(set_to_none=True)
        loss(batch.clone())["loss_critic"].backward()
        grads.append(torch.cat([p.grad.flatten() for p in loss.critic_params.values(True, True)]))
    assert torch.allclose(grads[0], grads[1], atol=1e-6)


# -- CURL --------------------------------------------------------------------------------------
def test_curl_is_infonce_with_a_bilinear_head():
    loss = make_loss("curl", augmentation=None, std_schedule=0.0, contrastive_augmentation=[])
    batch = make_batch()
    out = loss(batch)
    with torch.no_grad():
        z = loss.encoder(batch["pixels"])
        scores = z @ loss.head.W @ z.T
        logits = scores - scores.max(dim=1, keepdim=True).values
        expected = F.cross_entropy(logits, torch.arange(len(z)))
    assert torch.allclose(out["loss_curl"], expected, atol=1e-5)
    assert out["curl_accuracy"] == (logits.argmax(1) == torch.arange(len(z))).float().mean()


def test_curl_key_encoder_is_a_soft_updated_copy():
    loss = make_loss("curl", augmentation=None, std_schedule=0.0, contrastive_augmentation=[], key_encoder=True)
    updater = SoftUpdate(loss, tau=0.5)
    batch = make_batch()
    before = loss(batch)
    with torch.no_grad():
        for value in loss.target_encoder_params.values(True, True):
            value.mul_(0.5)
    after = loss(batch)
    assert not torch.allclose(before["loss_curl"], after["loss_curl"]), "positives come from the key encoder"
    assert torch.allclose(before["loss_critic"], after["loss_critic"]), "the critic uses the online encoder"
    keys = loss.target_encoder_params.clone()
    updater.step()
    online = loss.encoder_params.detach()
    expected = keys.apply(lambda k, o: 0.5 * k + 0.5 * o, online)
    assert all(torch.allclose(a, b) for a, b in zip(loss.target_encoder_params.values(True, True), expected.values(True, True)))


# -- DrQ ---------------------------------------------------------------------------------------
def test_squashed_normal_log_prob():
    mean, log_std = torch.randn(5, 3), torch.randn(5, 3) * 0.3
    torch.manual_seed(0)
    action, log_prob = squashed_normal_sample(mean, log_std)
    reference = torch.distributions.TransformedDistribution(
        torch.distributions.Normal(mean, log_std.exp()), [torch.distributions.TanhTransform()]
    )
    assert torch.allclose(log_prob.squeeze(-1), reference.log_prob(action).sum(-1), atol=1e-4)


def test_drq_equals_its_update_rule():
    loss = make_loss("drq", augmentation=None)
    batch = make_batch()
    torch.manual_seed(3)
    out = loss(batch)
    alpha = 0.1
    torch.manual_seed(3)
    with torch.no_grad():
        next_hidden = loss.encoder(torch.cat([batch["next", "pixels"]] * 2))
        next_action, next_log_prob = squashed_normal_sample(*loss.actor(next_hidden))
        value = torch.min(*loss.critic(next_hidden, next_action)) - alpha * next_log_prob
        targets = batch["next", "reward"] + GAMMA * value.reshape(2, -1, 1)
        target = targets.mean(0)
        hidden = loss.encoder(batch["pixels"])
        q1, q2 = loss.critic(hidden, batch["action"])
        action, log_prob = squashed_normal_sample(*loss.actor(hidden))
        actor_q = torch.min(*loss.critic(hidden, action))
    assert torch.allclose(out["loss_critic"], 2 * _mse_pair(q1, q2, target), atol=1e-5), "two identical views, summed"
    assert torch.allclose(out["loss_actor"], (alpha * log_prob - actor_q).mean(), atol=1e-5)
    assert torch.allclose(out["loss_alpha"], (alpha * (-log_prob + 2)).mean(), atol=1e-5), "target entropy −|A| = −2"
    assert torch.allclose(out["alpha"], torch.tensor(alpha))


def test_original_drq_samples_on_the_online_encoder_and_scores_on_the_target_one():
    """DrQ (K = M = 2, target encoder): a' ~ π(online h'ₖ), y = mean_k r + γ·[min Q'(target h'ₖ, a'ₖ) − α·log π]."""
    loss = make_loss("drq", augmentation=Flip(), clean_view=False, target_encoder=True)
    with torch.no_grad():  # a target encoder apart from the online one
        for value in loss.target_encoder_params.values(True, True):
            value.mul_(0.8)
    batch = make_batch()
    torch.manual_seed(4)
    out = loss(batch)
    target_encoder = copy.deepcopy(loss.encoder)
    with torch.no_grad():
        for param, value in zip(target_encoder.parameters(), loss.target_encoder_params.values(True, True)):
            param.copy_(value)
    alpha, flipped = 0.1, batch["next", "pixels"].flip(-1)
    torch.manual_seed(4)
    with torch.no_grad():
        views = torch.cat([flipped, flipped])
        next_action, next_log_prob = squashed_normal_sample(*loss.actor(loss.encoder(views)))
        with loss.target_critic_params.to_module(loss.critic):
            value = torch.min(*loss.critic(target_encoder(views), next_action)) - alpha * next_log_prob
        target = (batch["next", "reward"] + GAMMA * value.reshape(2, -1, 1)).mean(0)
    assert torch.allclose(out["target_mean"], target.mean(), atol=1e-5)


def test_drq_temperature_gradient_goes_to_log_alpha_only():
    loss = make_loss("drq")
    out = loss(make_batch())
    out["loss_alpha"].backward()
    assert loss.sampler.log_alpha.grad is not None and loss.sampler.log_alpha.grad != 0
    assert all(p.grad is None for p in loss.actor_params.values(True, True))


# -- SADA --------------------------------------------------------------------------------------
def test_sada_equals_dmcgb2_update_rule():
    """DMC-GB2 ``algos/sada.py``: critic 0.5·[MSE(cat(Q1, Q2), y) + MSE(cat(Q̃1, Q̃2), y)]; actor on
    ``[h, h̃]`` scored by the critic on ``[h, h]``; α-loss over the same 2B samples."""
    loss = make_loss("sada", augmentation=None, strong_augmentation=Invert())
    batch = make_batch()
    torch.manual_seed(5)
    out = loss(batch)
    alpha = 0.1
    torch.manual_seed(5)
    with torch.no_grad():
        next_hidden = loss.encoder(batch["next", "pixels"])
        next_action, next_log_prob = squashed_normal_sample(*loss.actor(next_hidden))
        target = batch["next", "reward"] + GAMMA * (torch.min(*loss.critic(next_hidden, next_action)) - alpha * next_log_prob)
        pixels = batch["pixels"]
        hidden, strong = loss.encoder(pixels), loss.encoder(255 - pixels)
        q1, q2 = loss.critic(hidden, batch["action"])
        s1, s2 = loss.critic(strong, batch["action"])
        critic = 0.5 * (F.mse_loss(torch.cat([q1, q2]), torch.cat([target, target]))
                        + F.mse_loss(torch.cat([s1, s2]), torch.cat([target, target])))
        action, log_prob = squashed_normal_sample(*loss.actor(torch.cat([hidden, strong])))
        actor_q = torch.min(*loss.critic(torch.cat([hidden, hidden]), action))
    assert torch.allclose(out["loss_critic"], critic, atol=1e-5)
    assert torch.allclose(out["loss_actor"], (alpha * log_prob - actor_q).mean(), atol=1e-5)
    assert torch.allclose(out["loss_alpha"], (alpha * (-log_prob + 2)).mean(), atol=1e-5)
    assert torch.allclose(out["q_strong_mean"], s1.mean(), atol=1e-5)


def test_sada_actor_gradient_reaches_only_the_actor():
    loss = make_loss("sada")
    loss(make_batch())["loss_actor"].backward()
    assert all(p.grad is None for p in loss.encoder_params.values(True, True))
    assert all(p.grad is None for p in loss.critic_params.values(True, True))
    assert any(p.grad is not None and p.grad.abs().sum() > 0 for p in loss.actor_params.values(True, True))

"""Time per update of vigen's losses against straightforward implementations of the same math.

Each algorithm's update (loss, backward, optimizer steps, target update) on uint8 batches
``[B, 9, 84, 84]`` with 6-dim actions, at the papers' network sizes (hidden 1024, feature 50), is
timed against a reference written the way RL-ViGen's agents (``algos/*.py``) do it: DrQ-v2's
``grid_sample`` shift, one encoder call per view in NCHW layout, the float overlay and 3-D FFT
mask, separate critic / actor / auxiliary steps with their own backward passes, and for SGQN a
captum-style guided backprop (a fresh forward pass with gradient hooks on the ReLUs, run twice:
before the critic step and again before the attribution step). The newer methods follow the same
pattern: SADA as DMC-GB2's update (one encoder call per view; separate critic, actor and
temperature steps), MaDi and SimGRL as DMC-GB's SAC SVEA (target encoder; MaDi's masker multiplied
into the 0–255 views, with its own Adam; SimGRL's shifted overlay written as a per-frame loop), VRL3
with its safe-Q target and
pre-tanh penalty written inline, PIE-G as SVEA on its frozen ResNet-18 (one encoder call per view,
BatchNorm statistics moving), and SCPL as its SAC update (DMC-GB's target encoder, a captum-style
saliency forward, the masked view, then the dynamics model on a fresh encoder pass with its own
encoder and model Adam steps; SCPL's code also re-encodes the observation for the actor and computes
two saliency maps it never uses, which the reference leaves out).

vigen's update is ``loss(batch)``, one backward of the summed ``loss_*`` entries, one Adam step
(``fused=True``, as ``examples/train.py`` steps: the same update, about 10× faster on a CPU than
the default for-loop Adam the reference uses), ``SoftUpdate.step()``. What it does differently at equal math: views of one update share an
encoder pass, the convolutions run channels-last in chunks of 64 samples (vigen's encoders do
this; the reference's encoders are the same models with ``chunk_size=None``), the shift is a gather,
the overlay and frequency mask run on uint8, the actor's backward pass does not compute critic
weight gradients, and SGQN's saliency reuses the critic's forward pass (one input-only backward)
and serves both the consistency and the attribution term (RL-ViGen recomputes it after the critic
step, which is why the reference also does more FLOPs for SGQN).

Also printed: FLOPs per update (matmuls and convolutions, counted with
``torch.utils.flop_counter``), and the FLOP/s achieved as a fraction of this CPU's peak, measured
in the same run (the best of a 2048² fp32 matmul and the encoder's 32→32 3×3 convolution).

Each figure is the median of ``--repeats`` updates, vigen and reference timed in alternation.

``--profile`` prints, per algorithm and batch, where vigen's update spends its time: the phases
(loss forward, backward, Adam, ``SoftUpdate``; wall clock, medians) and the operators (self CPU
time from ``torch.profiler``, grouped: convolutions forward and backward, matmuls, the rest).
Only the convolution and matmul groups can run near the CPU's peak; the rest bounds the
fraction of the peak an update can reach.

``--device cuda`` runs both sides on the GPU: every timed update ends with
``torch.cuda.synchronize()``. Every table measures the device's time one way
(``vigen.run.timing``'s union of the intervals during which the device ran anything, from
``torch.profiler``): "GPU ms" is that union per update, "GPU busy" the union over the updates'
wall time, each column named for the update it measures (reference, eager, compiled, captured).
``--compile`` also times vigen's update compiled whole (``vigen.losses.UpdateStep(compile=True)``:
inductor, and on CUDA a CUDA graph, :class:`vigen.cuda_graph.CudaGraphCall`) beside the eager one,
after three warm-up calls, and prints its compile time; on CUDA it is also launched back to back
(no wait between updates, as a training loop launches it: "back-to-back ms") with CUDA events
around each ``graph.replay()`` ("event ms"). ``--captured`` adds the update with its sampling
inside (:class:`vigen.run.SampledUpdate` over a :class:`vigen.run.FrameReplay` on the device: the
slots drawn there, the frames stacked, augmented and updated in one graph). The GPU learner's
options, each switchable: ``--tf32 on|off`` (matmuls and convolutions, both sides),
``--precision bf16`` (vigen's updates under bf16 autocast, with the largest relative loss
difference of one update against fp32, checked against a 2 % tolerance), ``--channels-last on|off``
(vigen's convolutions). ``--jobs N`` compiles the algorithms in N processes at once (sharing
inductor's cache, ``--cache-dir``) and then times them one at a time with nothing else running;
``--save-cache`` / ``--load-cache`` write and read ``torch.compiler``'s cache artifacts. Every run
prints the command that reproduces it.

Reproduce (about 15 minutes on 2 CPU cores at both batch sizes; run nothing else meanwhile):

    python benchmarks/losses.py                      # batch 64 and 256
    python benchmarks/losses.py --batch 64 --algos drqv2 sgqn --repeats 5
    python benchmarks/losses.py --batch 256 --algos svea --profile   # where the time goes
    python benchmarks/losses.py --batch 64 256 --algos drqv2 svea sada curl --compile   # compiled vs eager
    python benchmarks/losses.py --device cuda --batch 256 --compile --repeats 10        # on a GPU
    python benchmarks/losses.py --device cuda --batch 256 --compile --captured --algos drqv2 --tf32 on --precision bf16
    python benchmarks/losses.py --device cuda --batch 256 --compile --repeats 10 --jobs 12 --deadline 420  # all twelve
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import os
import random
import shlex
import signal
import statistics
import subprocess
import sys
import threading
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import torch
import torch.nn.functional as F
from tensordict import TensorDict
from torch import Tensor, nn
from torch.utils.flop_counter import FlopCounterMode
from torchrl.objectives import SoftUpdate

from augmentations import drqv2_shift, float_overlay, rlvigen_random_mask_freq_v2, seconds
from vigen.devices import resolve_device
from vigen.run import FrameReplay, SampledUpdate
from vigen.run.timing import busy_seconds, device_intervals
from vigen.losses import ALGOS as VIGEN_ALGOS
from vigen.losses import ActorCriticLoss, UpdateStep, attribution_mask, build_loss, make_networks
from vigen.transforms import ImageBank, RandomFrequencyMask, RandomOverlay, RandomShiftedOverlay

ACTIONS, GAMMA, STD, CLIP, TAU, LR = 6, 0.99, 0.2, 0.3, 0.01, 1e-4
ALGOS = ["drqv2", "svea", "srm", "sgqn", "curl", "drq", "sada", "madi", "simgrl", "vrl3", "pieg", "scpl"]
TIMING_S = 12  # --jobs keeps this much of its deadline per compiled process, to time it (about 10 s on an H200)
BF16_TOLERANCE = 0.02  # bf16 autocast is kept where one update's losses stay within 2 % of fp32's
RLVIGEN_MS_AT_64 = {"drqv2": 280, "svea": 640, "srm": 1050, "curl": 760, "sgqn": 2540}  # RL-ViGen's own agents at batch 64, timed on a machine like this one (issue 5)


# -- networks ----------------------------------------------------------------------------------
def networks(algo: str) -> dict[str, nn.Module]:
    """The algorithm's networks as ``make_loss`` builds them (84×84×9 pixels, 6 actions)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # VRL3 / PIE-G without weight files: random initialisation, the same FLOPs
        return make_networks(algo, (9, 84, 84), ACTIONS)


# -- the reference: RL-ViGen's agents, written plainly ------------------------------------------
def noisy(mu: Tensor) -> Tensor:
    action = mu + (torch.randn_like(mu) * STD).clamp(-CLIP, CLIP)
    clamped = action.clamp(-1 + 1e-6, 1 - 1e-6)
    return action - action.detach() + clamped.detach()


def squashed(mean: Tensor, log_std: Tensor) -> tuple[Tensor, Tensor]:
    dist = torch.distributions.TransformedDistribution(
        torch.distributions.Normal(mean, log_std.exp()), [torch.distributions.TanhTransform(cache_size=1)]
    )
    action = dist.rsample()
    return action, dist.log_prob(action).sum(-1, keepdim=True)


def float_shifted_overlay(x: Tensor, images: Tensor, max_shift: int = 6) -> Tensor:
    """SimGRL's overlay written plainly: per sample an image at (H + 2p)² and a shift; frame f blends the window at p + f·shift."""
    n, c, h, w = x.shape
    frames, pad = c // 3, (c // 3) * max_shift
    big = F.interpolate(images[torch.randint(len(images), (n,), device=images.device)].float(), size=(h + 2 * pad, w + 2 * pad), mode="bilinear")
    shift = torch.randint(-max_shift, max_shift + 1, (n, 2)).tolist()  # Python ints index the windows
    out = []
    for f in range(frames):
        windows = torch.stack([big[i, :, pad + f * shift[i][0] : pad + f * shift[i][0] + h, pad + f * shift[i][1] : pad + f * shift[i][1] + w]
                               for i in range(n)])
        out.append(0.5 * x[:, 3 * f : 3 * f + 3].float() + 0.5 * windows)
    return torch.cat(out, 1)


def guided_backprop(encoder: nn.Module, critic: nn.Module, obs: Tensor, action: Tensor) -> Tensor:
    """captum's GuidedBackprop of Q1: a new forward pass whose ReLU outputs clamp negative gradients."""
    def clamp_gradient(module: nn.Module, inputs: tuple[Tensor, ...], output: Tensor) -> None:
        output.register_hook(lambda grad: grad.clamp(min=0))

    relus = [m for net in (encoder, critic) for m in net.modules() if isinstance(m, nn.ReLU)]
    hooks = [relu.register_forward_hook(clamp_gradient) for relu in relus]
    obs = obs.detach().requires_grad_()
    q1 = critic(encoder(obs), action)[0]
    (grad,) = torch.autograd.grad(q1.sum(), obs)
    for hook in hooks:
        hook.remove()
    return grad


class RLViGenEncoder(nn.Module):
    """A vigen encoder's layers called as RL-ViGen calls its encoder: ``obs / 255 − 0.5`` on float 0–255
    views, unchecked (RL-ViGen's float views, e.g. its frequency mask, overshoot 255). Encoders
    without a single ``convnet`` (per-frame, ResNet) are called as they are, on ``max_value=255``
    floats; MaDi's masker, when given, masks the 0–255 view first (as MaDi's ``x · mask``)."""

    def __init__(self, encoder: nn.Module, masker: nn.Module | None = None) -> None:
        super().__init__()
        self.encoder, self.masker = encoder, masker
        if not hasattr(encoder, "convnet"):
            encoder.max_value = 255.0

    def forward(self, obs: Tensor) -> Tensor:
        obs = obs.float()
        if self.masker is not None:
            obs = obs * self.masker.masks(obs).repeat_interleave(3, dim=-3).flatten(-4, -3)
        if not hasattr(self.encoder, "convnet"):
            return self.encoder(obs.clamp(0, 255) if getattr(self.encoder, "centered", True) else obs)
        offset = 0.5 if getattr(self.encoder, "centered", True) else 0.0  # SCPL: DMC-GB's x / 255
        return self.encoder.project(self.encoder.convnet(obs / 255.0 - offset).flatten(1))


class Reference:
    """One RL-ViGen-style agent: three Adam optimizers, sequential critic → actor → aux steps."""

    def __init__(self, algo: str, nets: dict[str, nn.Module], overlay_images: Tensor) -> None:
        self.algo = algo
        masker = nets.get("input_mask")
        if masker is not None:
            masker.max_value = 255.0
        self.encoder, self.actor, self.critic = RLViGenEncoder(nets["encoder"], masker), nets["actor"], nets["critic"]
        self.critic_target = copy.deepcopy(self.critic)
        self.images = overlay_images
        self.encoder_opt = torch.optim.Adam(self.encoder.encoder.parameters(), lr=LR)
        if masker is not None:  # MaDi: the masker steps with the critic, at its own lr and betas
            self.masker_opt = torch.optim.Adam(masker.parameters(), lr=1e-3, betas=(0.9, 0.999))
        self.actor_opt = torch.optim.Adam(self.actor.parameters(), lr=LR)
        self.critic_opt = torch.optim.Adam(self.critic.parameters(), lr=LR)
        if algo in ("drq", "sada", "scpl", "madi", "simgrl"):
            self.log_alpha = torch.tensor(0.1, device=overlay_images.device).log().requires_grad_()
            self.alpha_opt = torch.optim.Adam([self.log_alpha], lr=LR)
        if algo == "sgqn":
            self.decoder = nets["decoder"]
            aux = list(self.encoder.parameters()) + list(self.decoder.parameters())
            self.aux_opt = torch.optim.Adam(aux, lr=LR, betas=(0.99, 0.999))
        if algo == "curl":
            self.W = nets["head"].W
            self.curl_opt = torch.optim.Adam([self.W], lr=LR, betas=(0.99, 0.999))
        if algo in ("scpl", "madi", "simgrl"):  # DMC-GB's target critic holds its own encoder
            self.encoder_target = copy.deepcopy(self.encoder)
        if algo == "scpl":  # the model and the encoder get their own Adam
            self.dynamics = nets["dynamics"]
            self.dynamics_opt = torch.optim.Adam(self.dynamics.parameters(), lr=3e-4)

    def overlay(self, x: Tensor) -> Tensor:
        if self.algo == "simgrl":
            return float_shifted_overlay(x, self.images)
        return float_overlay(x, self.images)

    def update(self, batch: TensorDict) -> None:
        obs, action = batch["pixels"], batch["action"]
        next_obs, reward = batch["next", "pixels"], batch["next", "reward"]
        if self.algo == "drq":
            return self.update_drq(obs, action, reward, next_obs)
        if self.algo == "sada":
            return self.update_sada(obs, action, reward, next_obs)
        if self.algo == "scpl":
            return self.update_scpl(obs, action, reward, next_obs)
        if self.algo in ("madi", "simgrl"):
            return self.update_svea_sac(obs, action, reward, next_obs)
        if self.algo == "curl":
            anchor, positive = drqv2_shift(obs), drqv2_shift(obs)
        obs, next_obs = drqv2_shift(obs), drqv2_shift(next_obs)
        with torch.no_grad():
            next_h = self.encoder(next_obs)
            next_action = noisy(self.actor(next_h))
            target = reward + GAMMA * torch.min(*self.critic_target(next_h, next_action))
            if self.algo == "vrl3":
                target = torch.where(target > 201, 200 + (target - 200).clamp(min=0).sqrt(), target)

        if self.algo == "sgqn":
            mask = attribution_mask(guided_backprop(self.encoder, self.critic, obs, action), 0.93)
            masked = obs * mask
            masked[~mask] = random.uniform(obs.min().item(), obs.max().item())
        h = self.encoder(obs)
        q1, q2 = self.critic(h, action)
        critic_loss = F.mse_loss(q1, target) + F.mse_loss(q2, target)
        if self.algo in ("svea", "srm", "pieg"):
            strong = self.overlay(obs)
            if self.algo == "srm" and random.random() < 0.5:
                strong = rlvigen_random_mask_freq_v2(strong)
            sq1, sq2 = self.critic(self.encoder(strong), action)
            critic_loss = 0.5 * critic_loss + 0.5 * (F.mse_loss(sq1, target) + F.mse_loss(sq2, target))
        if self.algo == "sgqn":
            mq1, mq2 = self.critic(self.encoder(masked), action)
            critic_loss = critic_loss + 0.9 * (F.mse_loss(q1, mq1) + F.mse_loss(q2, mq2))
        self.encoder_opt.zero_grad(set_to_none=True)
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_opt.step()
        self.encoder_opt.step()

        h = h.detach()
        if self.algo == "vrl3":
            pre_tanh = self.actor.action_head(self.actor.trunk(h))
            actor_q = torch.min(*self.critic(h, noisy(torch.tanh(pre_tanh))))
            penalty = 0.001 * (pre_tanh.abs() - 5).clamp(min=0).pow(2).mean()
            actor_loss = -actor_q.mean() + penalty
        else:
            actor_loss = -torch.min(*self.critic(h, noisy(self.actor(h)))).mean()
        self.actor_opt.zero_grad(set_to_none=True)
        actor_loss.backward()
        self.actor_opt.step()

        if self.algo == "curl":
            z_anchor = self.encoder(anchor)
            with torch.no_grad():
                z_positive = self.encoder(positive)
            logits = z_anchor @ self.W @ z_positive.T
            logits = logits - logits.max(1, keepdim=True).values
            curl_loss = F.cross_entropy(logits, torch.arange(len(logits), device=logits.device))
            self.encoder_opt.zero_grad(set_to_none=True)
            self.curl_opt.zero_grad(set_to_none=True)
            curl_loss.backward()
            self.encoder_opt.step()
            self.curl_opt.step()
        self.soft_update()
        if self.algo == "sgqn":
            mask = attribution_mask(guided_backprop(self.encoder, self.critic, obs, action), 0.93)
            logits = self.decoder(self.encoder(self.overlay(obs).detach()), action)
            aux_loss = F.binary_cross_entropy_with_logits(logits, mask.float())
            self.aux_opt.zero_grad(set_to_none=True)
            aux_loss.backward()
            self.aux_opt.step()

    def update_drq(self, obs: Tensor, action: Tensor, reward: Tensor, next_obs: Tensor) -> None:
        obs, obs_aug = obs.float(), drqv2_shift(obs)
        next_obs, next_aug = next_obs.float(), drqv2_shift(next_obs)
        alpha = self.log_alpha.exp()
        with torch.no_grad():
            targets = []
            for view in (next_obs, next_aug):
                h = self.encoder(view)
                next_action, log_prob = squashed(*self.actor(h))
                value = torch.min(*self.critic_target(h, next_action)) - alpha.detach() * log_prob
                targets.append(reward + GAMMA * value)
            target = (targets[0] + targets[1]) / 2
        h = self.encoder(obs)
        q1, q2 = self.critic(h, action)
        aq1, aq2 = self.critic(self.encoder(obs_aug), action)
        critic_loss = sum(F.mse_loss(q, target) for q in (q1, q2, aq1, aq2))
        self.encoder_opt.zero_grad(set_to_none=True)
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_opt.step()
        self.encoder_opt.step()

        self.sac_actor_steps(self.actor(h.detach()), h.detach(), alpha)

    def update_sada(self, obs: Tensor, action: Tensor, reward: Tensor, next_obs: Tensor) -> None:
        """DMC-GB2's SADA: one encoder call per view, separate critic / actor / temperature steps."""
        obs, next_obs = drqv2_shift(obs), drqv2_shift(next_obs)
        strong = self.overlay(obs)
        alpha = self.log_alpha.exp()
        with torch.no_grad():
            h = self.encoder(next_obs)
            next_action, log_prob = squashed(*self.actor(h))
            target = reward + GAMMA * (torch.min(*self.critic_target(h, next_action)) - alpha * log_prob)
        h, h_strong = self.encoder(obs), self.encoder(strong)
        q1, q2 = self.critic(h, action)
        sq1, sq2 = self.critic(h_strong, action)
        critic_loss = 0.5 * (F.mse_loss(torch.cat([q1, q2]), torch.cat([target, target]))
                             + F.mse_loss(torch.cat([sq1, sq2]), torch.cat([target, target])))
        self.encoder_opt.zero_grad(set_to_none=True)
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_opt.step()
        self.encoder_opt.step()

        h, h_strong = h.detach(), h_strong.detach()
        self.sac_actor_steps(self.actor(torch.cat([h, h_strong])), torch.cat([h, h]), alpha)

    def update_svea_sac(self, obs: Tensor, action: Tensor, reward: Tensor, next_obs: Tensor) -> None:
        """DMC-GB's SAC SVEA as MaDi (next obs unshifted, masker stepped with the critic) and SimGRL run it."""
        obs = drqv2_shift(obs)
        next_obs = drqv2_shift(next_obs) if self.algo == "simgrl" else next_obs.float()
        strong = self.overlay(obs)
        alpha = self.log_alpha.exp()
        with torch.no_grad():
            next_action, log_prob = squashed(*self.actor(self.encoder(next_obs)))
            value = torch.min(*self.critic_target(self.encoder_target(next_obs), next_action)) - alpha * log_prob
            target = reward + GAMMA * value
        h, h_strong = self.encoder(obs), self.encoder(strong)
        q1, q2 = self.critic(h, action)
        sq1, sq2 = self.critic(h_strong, action)
        critic_loss = 0.5 * (F.mse_loss(q1, target) + F.mse_loss(q2, target) + F.mse_loss(sq1, target) + F.mse_loss(sq2, target))
        self.encoder_opt.zero_grad(set_to_none=True)
        self.critic_opt.zero_grad(set_to_none=True)
        if self.algo == "madi":
            self.masker_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_opt.step()
        self.encoder_opt.step()
        if self.algo == "madi":
            self.masker_opt.step()

        self.sac_actor_steps(self.actor(h.detach()), h.detach(), alpha)

    def update_scpl(self, obs: Tensor, action: Tensor, reward: Tensor, next_obs: Tensor) -> None:
        """SCPL's SAC update: critic (+ masked-Q consistency), actor (+ KL), temperature, then the dynamics model."""
        obs, next_obs = drqv2_shift(obs), drqv2_shift(next_obs)
        strong, strong_next = float_overlay(torch.cat([obs, next_obs], 1), self.images).chunk(2, dim=1)
        alpha = self.log_alpha.exp()
        with torch.no_grad():
            next_action, log_prob = squashed(*self.actor(self.encoder(next_obs)))
            value = torch.min(*self.critic_target(self.encoder_target(next_obs), next_action)) - alpha * log_prob
            target = torch.cat([reward + GAMMA * value] * 2)
        views, actions = torch.cat([obs, strong]), torch.cat([action, action])
        mask = attribution_mask(guided_backprop(self.encoder, self.critic, views, actions), 0.9)
        masked = views * mask
        masked[~mask] = random.uniform(views.min().item(), views.max().item())
        h = self.encoder(views)
        q1, q2 = self.critic(h, actions)
        mq1, mq2 = self.critic(self.encoder(masked), actions)
        critic_loss = (F.mse_loss(q1, target) + F.mse_loss(q2, target)
                       + 0.5 * (F.mse_loss(q1, mq1) + F.mse_loss(q2, mq2)))
        self.encoder_opt.zero_grad(set_to_none=True)
        self.critic_opt.zero_grad(set_to_none=True)
        critic_loss.backward()
        self.critic_opt.step()
        self.encoder_opt.step()

        h_clean, h_strong = h.detach().chunk(2)
        mean, log_std = self.actor(h_clean)
        mean_strong, log_std_strong = self.actor(h_strong)
        kl = torch.distributions.kl_divergence(
            torch.distributions.MultivariateNormal(torch.tanh(mean), torch.diag_embed(log_std.exp()).detach()),
            torch.distributions.MultivariateNormal(torch.tanh(mean_strong), torch.diag_embed(log_std_strong.exp())),
        )
        self.sac_actor_steps((mean, log_std), h_clean, alpha, extra=kl.mean())

        embedding = self.critic.embed(self.encoder(views))
        with torch.no_grad():
            next_embedding = self.critic.embed(self.encoder(torch.cat([next_obs, strong_next])))
        predicted, predicted_reward = self.dynamics(embedding, actions)
        model_loss = (0.5 * (predicted - next_embedding).pow(2)).mean() + F.mse_loss(predicted_reward, torch.cat([reward] * 2))
        self.encoder_opt.zero_grad(set_to_none=True)
        self.critic_opt.zero_grad(set_to_none=True)
        self.dynamics_opt.zero_grad(set_to_none=True)
        model_loss.backward()
        self.encoder_opt.step()
        self.critic_opt.step()  # only the trunk (DMC-GB's critic projection) has gradients here
        self.dynamics_opt.step()

    def sac_actor_steps(self, policy: tuple[Tensor, Tensor], critic_features: Tensor, alpha: Tensor,
                        extra: Tensor | None = None) -> None:
        """SAC's actor step (α·log π − min Q on ``critic_features``, plus ``extra``), temperature step, target update."""
        new_action, log_prob = squashed(*policy)
        actor_loss = (alpha.detach() * log_prob - torch.min(*self.critic(critic_features, new_action))).mean()
        if extra is not None:
            actor_loss = actor_loss + extra
        self.actor_opt.zero_grad(set_to_none=True)
        actor_loss.backward()
        self.actor_opt.step()
        alpha_loss = (alpha * (-log_prob - -ACTIONS).detach()).mean()
        self.alpha_opt.zero_grad(set_to_none=True)
        alpha_loss.backward()
        self.alpha_opt.step()
        self.soft_update()

    def soft_update(self) -> None:
        with torch.no_grad():
            for p, tp in zip(self.critic.parameters(), self.critic_target.parameters()):
                tp.lerp_(p, TAU)
            if self.algo in ("scpl", "madi", "simgrl"):
                for p, tp in zip(self.encoder.parameters(), self.encoder_target.parameters()):
                    tp.lerp_(p, TAU)


# -- vigen ---------------------------------------------------------------------------------------
class Vigen:
    """The same algorithm from vigen.losses: one loss call, one backward, one optimizer, SoftUpdate.

    ``channels_last`` puts the convolutions' weights and inputs in channels-last layout (as ``make_loss`` and
    ``examples/train.py`` do); ``precision="bf16"`` runs every update under ``torch.autocast(bfloat16)`` (parameters,
    gradients and Adam stay fp32); ``cudagraph`` is UpdateStep's (``None``: on CUDA when compiled; ``False`` for a
    :class:`vigen.run.SampledUpdate`, which captures the sampling with it).
    """

    def __init__(self, algo: str, nets: dict[str, nn.Module], bank: ImageBank, *, device: torch.device = torch.device("cpu"),
                 compile: bool = False, channels_last: bool = True, precision: str = "fp32", cudagraph: bool | None = None) -> None:
        def overlay() -> RandomOverlay:
            return RandomOverlay(images=bank)

        views = {"svea": {"strong_augmentation": overlay()}, "sgqn": {"attribution_augmentation": overlay()},
                 "srm": {"strong_augmentation": [overlay(), RandomFrequencyMask()]}, "sada": {"strong_augmentation": overlay()},
                 "madi": {"strong_augmentation": overlay()}, "simgrl": {"strong_augmentation": RandomShiftedOverlay(images=bank)},
                 "pieg": {"strong_augmentation": overlay()}, "scpl": {"strong_augmentation": overlay()}}
        nets = dict(nets)
        if channels_last:  # as make_loss: the convolutions' weights (the encoder's, SGQN's decoder's) channels-last too
            for name in ("encoder", "decoder"):
                if name in nets:
                    nets[name].to(memory_format=torch.channels_last)
        sampler = {"std_schedule": STD} if VIGEN_ALGOS[algo].takes_std else {}
        self.loss: ActorCriticLoss = build_loss(algo, *nets.values(), **sampler, **views.get(algo, {}), channels_last=channels_last)
        self.loss.to(device)
        self.loss.make_value_estimator(gamma=GAMMA)
        self.device, self.precision = device, precision
        captured = compile or cudagraph  # captured later with its sampling (SampledUpdate) or now (UpdateStep's CUDA graph)
        # as examples/train.py: eager steps a fused Adam, a compiled update fuses the step itself (capturable for a CUDA graph)
        self.optimizer = torch.optim.Adam(self.loss.optimizer_groups(LR), fused=not compile,
                                          capturable=bool(captured or cudagraph is False) and device.type == "cuda")
        self.updater = SoftUpdate(self.loss, tau=TAU)
        self.step = UpdateStep(self.loss, self.optimizer, self.updater, compile=compile, cudagraph=cudagraph)

    def autocast(self) -> contextlib.AbstractContextManager:
        """bf16 autocast (without its weight cache, which a CUDA graph cannot hold) or nothing."""
        if self.precision == "bf16":
            return torch.autocast(self.device.type, dtype=torch.bfloat16, cache_enabled=False)
        return contextlib.nullcontext()

    def update(self, batch: TensorDict) -> TensorDict:
        with self.autocast():
            return self.step(batch)

    def phases(self, batch: TensorDict) -> dict[str, float]:
        """Seconds of each phase of one update."""
        times, start = {}, time.perf_counter()
        out = self.loss(batch)
        times["loss forward"], start = time.perf_counter() - start, time.perf_counter()
        self.optimizer.zero_grad(set_to_none=True)
        sum(value for key, value in out.items() if key.startswith("loss_")).backward()
        times["backward"], start = time.perf_counter() - start, time.perf_counter()
        self.optimizer.step()
        times["Adam step"], start = time.perf_counter() - start, time.perf_counter()
        self.updater.step()
        times["SoftUpdate"] = time.perf_counter() - start
        return times


# -- measuring -----------------------------------------------------------------------------------
def make_batch(batch: int, device: torch.device = torch.device("cpu")) -> TensorDict:
    pixels = lambda: torch.randint(0, 256, (batch, 9, 84, 84), dtype=torch.uint8)  # noqa: E731
    return TensorDict(
        {
            "pixels": pixels(),
            "action": torch.rand(batch, ACTIONS) * 2 - 1,
            "next": {
                "pixels": pixels(),
                "reward": torch.rand(batch, 1),
                "done": torch.zeros(batch, 1, dtype=torch.bool),
                "terminated": torch.zeros(batch, 1, dtype=torch.bool),
            },
        },
        batch_size=[batch],
    ).to(device)


def synchronized(fn: Callable[[], object], device: torch.device) -> Callable[[], object]:
    """``fn`` followed by a wait for the device's queued work, so that a timer measures it (no-op on the CPU)."""
    if device.type != "cuda":
        return fn

    def run() -> object:
        out = fn()
        torch.cuda.synchronize(device)
        return out
    return run


def device_time(update: Callable[[], object], repeats: int, device: torch.device) -> tuple[float, float]:
    """(device seconds per update, busy share) of ``repeats`` synchronized updates, by one definition for every table:
    the union of the device's activity intervals (kernels, copies, memsets; ``vigen.run.timing``) that torch.profiler
    records, over the number of updates and over the updates' wall time. The union counts a kernel once, however many
    operators or streams it is listed under."""
    activity = torch.profiler.ProfilerActivity.CUDA if device.type == "cuda" else torch.profiler.ProfilerActivity.CPU
    synchronize(device)
    with torch.profiler.profile(activities=[activity]) as prof:
        start = time.perf_counter()
        for _ in range(repeats):
            update()
        synchronize(device)
        wall = time.perf_counter() - start
    busy = busy_seconds(device_intervals(prof, device.type))
    return busy / repeats, min(busy / wall, 1.0)


def synchronize(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def back_to_back(update: Callable[[], object], repeats: int, device: torch.device) -> tuple[float, float | None]:
    """(wall seconds per update, device ms per update by CUDA events) of ``repeats`` updates launched back to back.

    One synchronization at the end, none between: the host queues the next update while the device runs the last, as a
    training loop does; the wall time per update is the loop's rate. On CUDA an event pair around each call times what
    the device spent from the call's first queued work to its last (for a CUDA graph: ``graph.replay()``); their median.
    """
    events = ([(torch.cuda.Event(enable_timing=True), torch.cuda.Event(enable_timing=True)) for _ in range(repeats)]
              if device.type == "cuda" else [])
    synchronize(device)
    start = time.perf_counter()
    for index in range(repeats):
        if events:
            events[index][0].record()
        update()
        if events:
            events[index][1].record()
    synchronize(device)
    wall = (time.perf_counter() - start) / repeats
    return wall, statistics.median(begin.elapsed_time(end) for begin, end in events) if events else None


def synthetic_steps(length: int, start: int, pool: Tensor, episode: int = 500) -> TensorDict:
    """``length`` steps of one worker from step ``start`` on: frames cycled from ``pool``, stacked as CatFrames stacks them
    (3 frames, the reset frame repeated), episodes of ``episode`` steps (time limits: truncated), random actions and rewards."""
    frames = len(pool)
    time_in_episode = (torch.arange(start, start + length) % episode)
    frame_id = torch.arange(start, start + length + 1) % frames
    first = torch.arange(start, start + length) - time_in_episode
    def stack(at: Tensor, since: Tensor) -> Tensor:
        ids = torch.stack([torch.maximum(at - back, since) for back in (2, 1, 0)], 1) % frames
        return pool[ids].flatten(1, 2)
    steps = torch.arange(start, start + length)
    del frame_id
    end = time_in_episode == episode - 1
    return TensorDict({
        "pixels": stack(steps, first), "action": torch.rand(length, ACTIONS) * 2 - 1,
        "next": {"pixels": stack(steps + 1, first), "reward": torch.rand(length, 1), "done": end[:, None].clone(),
                 "terminated": torch.zeros(length, 1, dtype=torch.bool), "truncated": end[:, None].clone()},
    }, batch_size=[length])


def synthetic_replay(batch_size: int, capacity: int, device: torch.device, chunk: int = 2000) -> FrameReplay:
    """A :class:`vigen.run.FrameReplay` on ``device`` holding ``capacity`` transitions of 84×84 frames (a pool of 64 random
    frames, cycled: the content does not change the cost), 3-step returns, episodes of 500 steps."""
    pool = torch.randint(0, 256, (64, 3, 84, 84), dtype=torch.uint8, generator=torch.Generator().manual_seed(0))
    replay = FrameReplay(capacity, batch_size, n_step=3, gamma=GAMMA, device=device, check=False)
    done = 0
    while len(replay) < capacity:
        length = min(chunk, capacity - len(replay) + 3)
        replay.extend(synthetic_steps(length, done, pool))
        done += length
    return replay


def bf16_check(algo: str, nets: dict[str, nn.Module], bank: ImageBank, device: torch.device, batch: TensorDict,
               channels_last: bool) -> float:
    """The largest relative difference between the ``loss_*`` values of one bf16-autocast update and one fp32 update from
    the same networks, batch and random state (the same augmentations and noise)."""
    values = []
    for precision in ("fp32", "bf16"):
        vigen = Vigen(algo, copy.deepcopy(nets), bank, device=device, precision=precision, channels_last=channels_last)
        torch.manual_seed(1)
        out = vigen.update(batch.clone())
        values.append({key: float(value) for key, value in out.items() if key.startswith("loss_")})
    fp32, bf16 = values
    return max(abs(bf16[key] - fp32[key]) / max(abs(fp32[key]), 1e-3) for key in fp32)


class _NoModuleTracking:
    """Stands in for FlopCounterMode's module tracker, which cannot hash TensorDictParams."""

    parents = {"Global"}

    def __enter__(self) -> None:
        return None

    def __exit__(self, *args: object) -> None:
        return None


def flops(update: Callable[[], None]) -> int:
    counter = FlopCounterMode(display=False)
    counter.mod_tracker = _NoModuleTracking()
    with counter:
        update()
    return counter.get_total_flops()


def peak_flops(repeats: int = 5) -> tuple[float, float]:
    """FLOP/s of a large fp32 matmul and of the encoders' 32→32 3×3 convolution (channels-last, forward)."""
    a, b = torch.randn(2048, 2048), torch.randn(2048, 2048)
    matmul = 2 * 2048**3 / seconds(lambda: a @ b, repeats=repeats)[0]
    conv = nn.Conv2d(32, 32, 3).to(memory_format=torch.channels_last)
    x = torch.randn(64, 32, 37, 37).contiguous(memory_format=torch.channels_last)
    with torch.no_grad():
        conv_time = seconds(lambda: conv(x), repeats=repeats)[0]
    conv_flops = 2 * 64 * 32 * 35 * 35 * 32 * 9
    return matmul, conv_flops / conv_time


OPERATOR_GROUPS = (  # (group, test on the operator's name); the first match wins
    ("convolutions, backward", lambda name: "convolution_backward" in name),
    ("convolutions, forward", lambda name: "conv" in name and "backward" not in name),
    ("matmuls (forward and backward)", lambda name: name in ("aten::addmm", "aten::mm", "aten::bmm", "aten::matmul", "aten::linear")),
)


def profile(vigen: Vigen, batch: TensorDict, repeats: int, update_flops: int, peak: float) -> str:
    """A markdown table of where one vigen update spends its time: phases, then operator groups.

    Its last line is the rate of the convolution and matmul operators alone (the update's FLOPs
    over their time): the fraction of the peak the update would reach if nothing else took time.
    """
    samples = [vigen.phases(batch.clone()) for _ in range(repeats + 1)][1:]
    phases = {name: statistics.median(sample[name] for sample in samples) for name in samples[0]}
    total = sum(phases.values())
    with torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CPU]) as prof:
        vigen.update(batch.clone())
    groups: dict[str, float] = {name: 0.0 for name, _ in OPERATOR_GROUPS}
    rest: dict[str, float] = {}
    for event in prof.key_averages():
        seconds_ = event.self_cpu_time_total / 1e6
        group = next((name for name, match in OPERATOR_GROUPS if match(event.key)), None)
        if group is None:
            rest[event.key] = rest.get(event.key, 0.0) + seconds_
        else:
            groups[group] += seconds_
    profiled = sum(groups.values()) + sum(rest.values())
    top = sorted(rest.items(), key=lambda item: -item[1])[:6]
    groups["everything else"] = sum(rest.values())
    lines = ["| part of the update | ms | share |", "|---|---|---|"]
    lines += [f"| phase: {name} | {value * 1e3:.0f} | {100 * value / total:.0f} % |" for name, value in phases.items()]
    lines += [f"| operators: {name} | {value * 1e3:.0f} | {100 * value / profiled:.0f} % |" for name, value in groups.items()]
    lines.append("| largest of the rest | " + ", ".join(f"{name.removeprefix('aten::')} {100 * value / profiled:.0f} %" for name, value in top) + " | |")
    kernels = sum(value for name, value in groups.items() if name != "everything else") * total / profiled
    lines.append(f"| convolutions and matmuls alone | {update_flops / kernels / 1e9:.0f} GFLOP/s | {100 * update_flops / kernels / peak:.0f} % of peak |")
    return "\n".join(lines)


def set_tf32(mode: str) -> str:
    """TF32 for float32 matmuls and convolutions: ``on``, ``off``, or torch's ``default`` (matmuls full fp32, cuDNN
    convolutions TF32); returns what is in force."""
    if mode == "on":
        torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32 = True, True
    elif mode == "off":
        torch.backends.cuda.matmul.allow_tf32, torch.backends.cudnn.allow_tf32 = False, False
    return (f"TF32 {mode}: matmuls {'TF32' if torch.backends.cuda.matmul.allow_tf32 else 'fp32'}, "
            f"convolutions {'TF32' if torch.backends.cudnn.allow_tf32 else 'fp32'}")


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--batch", type=int, nargs="+", default=[64, 256])
    parser.add_argument("--algos", nargs="+", default=ALGOS, choices=ALGOS)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--profile", action="store_true", help="also print where vigen's update spends its time, per algorithm")
    parser.add_argument("--device", default="cpu", help="cpu (default), cuda or cuda:N: where both updates run")
    parser.add_argument("--compile", action="store_true",
                        help="vigen's update compiled whole (vigen.losses.UpdateStep(compile=True); on CUDA also a CUDA graph); "
                             "the eager update is timed beside it")
    parser.add_argument("--captured", action="store_true",
                        help="also vigen's update with its sampling inside (vigen.run.SampledUpdate over a FrameReplay on the "
                             "device; compiled with --compile), launched back to back")
    parser.add_argument("--replay-capacity", type=int, default=None,
                        help="--captured's FrameReplay transitions (default 20000 on CUDA, 500 on the CPU)")
    parser.add_argument("--tf32", choices=["default", "on", "off"], default="default",
                        help="TF32 matmuls and convolutions on CUDA, for both sides (default: torch's, convolutions only)")
    parser.add_argument("--precision", choices=["fp32", "bf16"], default="fp32",
                        help="bf16: vigen's updates under torch.autocast(bfloat16) (the reference stays fp32); the bf16 column "
                             f"is the largest relative loss difference of one update against fp32, checked against {BF16_TOLERANCE:.0%}")
    parser.add_argument("--channels-last", choices=["on", "off"], default="on",
                        help="vigen's convolutions in channels-last layout, weights and inputs (on: as make_loss and train.py)")
    parser.add_argument("--jobs", type=int, default=1,
                        help="compile the algorithms in this many processes at once, then time them one at a time (--compile)")
    parser.add_argument("--deadline", type=float, default=None,
                        help="with --jobs: seconds for everything; what has not compiled by then is stopped and named")
    parser.add_argument("--cache-dir", type=Path, default=None,
                        help="inductor's cache folder, shared by the --jobs processes (TORCHINDUCTOR_CACHE_DIR)")
    parser.add_argument("--save-cache", type=Path, default=None,
                        help="after compiling, write torch.compiler.save_cache_artifacts() there (per algorithm: PATH.ALGO)")
    parser.add_argument("--load-cache", type=Path, default=None,
                        help="before compiling, torch.compiler.load_cache_artifacts() from there (per algorithm: PATH.ALGO)")
    parser.add_argument("--also", nargs="+", default=[], metavar="'ALGO FLAGS'",
                        help="with --jobs: more processes, each an algorithm with its own flags over the others', e.g. "
                             "'drqv2 --tf32 on --precision bf16' (an option's effect); timed first, in the order given")
    parser.add_argument("--hold", action="store_true", help=argparse.SUPPRESS)  # a --jobs child: compile, say READY, wait
    args = parser.parse_args(argv)
    if args.jobs < 1:
        parser.error("--jobs must be >= 1")
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    given = sys.argv[1:] if argv is None else argv
    if args.cache_dir is not None:
        os.environ["TORCHINDUCTOR_CACHE_DIR"] = str(args.cache_dir.resolve())
    if args.jobs > 1 and (len(args.algos) > 1 or args.also) and not args.hold:
        return run_in_parallel(args, given)
    device = resolve_device(args.device)
    print("reproduce: python benchmarks/losses.py " + " ".join(given), flush=True)
    torch.manual_seed(0)
    random.seed(0)
    bank = ImageBank.builtin()
    images = bank.resized(84, 84, device=device)
    if device.type == "cpu":
        matmul_peak, conv_peak = peak_flops()
        peak = max(matmul_peak, conv_peak)
        print(f"torch {torch.__version__}, {torch.get_num_threads()} threads; peak {peak / 1e9:.0f} GFLOP/s (fp32): "
              f"2048² matmul {matmul_peak / 1e9:.0f}, 32→32 3×3 convolution {conv_peak / 1e9:.0f}")
    else:
        peak = float("nan")
        print(f"torch {torch.__version__} on {torch.cuda.get_device_name(device)}; {set_tf32(args.tf32)}; "
              f"channels-last {args.channels_last}; vigen in {args.precision}. 'ms': median of {args.repeats} updates, each "
              "followed by torch.cuda.synchronize(); 'GPU ms': the union of the device's activity per update (torch.profiler); "
              "'GPU busy': that union over the updates' wall time; 'back-to-back ms': updates queued without a wait; "
              "'event ms': CUDA events around each (graph.replay()).", flush=True)
    prepared = [prepare(algo, batch_size, args, device, bank, images) for batch_size in args.batch for algo in args.algos]
    if args.hold:  # a --jobs child: everything is compiled; the parent says when this process may time (nothing else runs)
        print("@@READY", flush=True)
        sys.stdin.readline()
    columns, profiles = None, []
    for item in prepared:
        row, text = measure(item, args, device, peak)
        if list(row) != columns:  # a header whenever the columns change (a loss that did not compile has fewer)
            columns = list(row)
            print("| " + " | ".join(row) + " |\n|" + "---|" * len(row), flush=True)
        print("| " + " | ".join(row.values()) + " |", flush=True)
        if text:
            profiles.append(text)
    for table in profiles:
        print(table)
    return 0


def prepare(algo: str, batch_size: int, args: argparse.Namespace, device: torch.device, bank: ImageBank, images: Tensor) -> dict:
    """Everything one row times, built (and compiled: the first calls of a compiled update) before any timing.

    With ``--captured`` every update of the row takes a batch of the captured update's replay (the same entries, so that
    the compiled update's graph is the captured one's, and inductor's cache serves the second compile)."""
    replay = None
    if args.captured:
        replay = synthetic_replay(batch_size, args.replay_capacity or (20_000 if device.type == "cuda" else 500), device)
        batch = replay.gather(torch.arange(batch_size, device=device)).clone()
    else:
        batch = make_batch(batch_size, device)
    torch.manual_seed(0)
    vigen_nets = networks(algo)
    reference_nets = copy.deepcopy(vigen_nets)
    reference_nets["encoder"].chunk_size = None
    for net in reference_nets.values():
        net.to(device)
    options = dict(device=device, channels_last=args.channels_last == "on", precision=args.precision)
    item = {"algo": algo, "batch_size": batch_size, "batch": batch, "reference": Reference(algo, reference_nets, images),
            "vigen": Vigen(algo, copy.deepcopy(vigen_nets), bank, **options)}
    if args.precision == "bf16":
        item["bf16"] = bf16_check(algo, vigen_nets, bank, device, batch, args.channels_last == "on")
    if args.load_cache is not None:
        cache = args.load_cache.with_name(f"{args.load_cache.name}.{algo}")
        item["cache_loaded"] = load_cache(cache)
    if args.compile:
        started = time.perf_counter()
        try:
            compiled = Vigen(algo, copy.deepcopy(vigen_nets), bank, compile=True, **options)
            for _ in range(3):  # compile, then (CUDA graphs) warm up and capture
                compiled.update(batch.clone())
            synchronize(device)
            item["compiled"], item["compile_s"] = compiled, time.perf_counter() - started
        except Exception as error:  # noqa: BLE001 - a loss that does not compile here still gets its eager row
            item["failed"] = f"compile failed: {type(error).__name__}: {str(error).splitlines()[0][:150]}"
            print(f"{algo}: {item['failed']}", flush=True)
    if replay is not None and "failed" not in item:
        started = time.perf_counter()
        try:
            captured = Vigen(algo, copy.deepcopy(vigen_nets), bank, compile=args.compile, cudagraph=False, **options)
            sampled = SampledUpdate(captured.step, replay)
            for _ in range(3):
                with captured.autocast():
                    sampled()
            synchronize(device)
            item.update(captured_vigen=captured, sampled=sampled, replay_bytes=replay.bytes_on_device(),
                        captured_compile_s=time.perf_counter() - started)
        except Exception as error:  # noqa: BLE001 - as above
            item["failed"] = f"captured failed: {type(error).__name__}: {str(error).splitlines()[0][:150]}"
            print(f"{algo}: {item['failed']}", flush=True)
    if args.save_cache is not None and args.compile:
        save_cache(args.save_cache.with_name(f"{args.save_cache.name}.{algo}"))
    return item


def measure(item: dict, args: argparse.Namespace, device: torch.device, peak: float) -> tuple[dict[str, str], str | None]:
    """One row of the table (column -> cell), and on the CPU with ``--profile`` the profile's table."""
    algo, batch_size, batch, reference, vigen = (item[key] for key in ("algo", "batch_size", "batch", "reference", "vigen"))
    ref_update = synchronized(lambda: reference.update(batch.clone()), device)
    vigen_update = synchronized(lambda: vigen.update(batch.clone()), device)
    ref_flops, vigen_flops = flops(ref_update), flops(vigen_update)
    timed = [ref_update, vigen_update]
    compiled = item.get("compiled")
    if compiled is not None:
        compiled_call = lambda: compiled.update(batch.clone())  # noqa: E731
        timed.append(synchronized(compiled_call, device))
    ref_s, vigen_s, *compiled_s = seconds(*timed, repeats=args.repeats)
    cuda = device.type == "cuda"
    row = {"algo": algo, "batch": str(batch_size)}
    if cuda or (args.tf32, args.precision, args.channels_last) != ("default", "fp32", "on"):
        row["options"] = (f"TF32 {args.tf32}, {args.precision}, channels-last {args.channels_last}"
                          + (", captured" if args.captured else ""))
    row.update({"reference ms": f"{ref_s * 1e3:.1f}", ("eager ms" if cuda else "vigen ms"): f"{vigen_s * 1e3:.1f}"})
    if compiled_s:
        row["compiled ms"] = f"{compiled_s[0] * 1e3:.1f}"
    fast = compiled_s[0] if compiled_s else vigen_s
    row["reference / compiled" if compiled_s and cuda else "speed-up"] = f"{ref_s / fast:.2f}×"
    if compiled_s:
        row["compiled / eager"] = f"{vigen_s / compiled_s[0]:.2f}×"
        row["compile s"] = f"{item['compile_s']:.0f}"
    if cuda:
        ref_gpu, _ = device_time(ref_update, args.repeats, device)
        eager_gpu, eager_busy = device_time(vigen_update, args.repeats, device)
        row["reference GPU ms"], row["eager GPU ms"], row["eager GPU busy"] = (
            f"{ref_gpu * 1e3:.2f}", f"{eager_gpu * 1e3:.2f}", f"{100 * eager_busy:.0f} %")
        if compiled is not None:
            compiled_gpu, compiled_busy = device_time(synchronized(compiled_call, device), args.repeats, device)
            wall, event_ms = back_to_back(compiled_call, args.repeats, device)
            row.update({"compiled GPU ms": f"{compiled_gpu * 1e3:.2f}", "compiled GPU busy": f"{100 * compiled_busy:.0f} %",
                        "compiled back-to-back ms": f"{wall * 1e3:.2f}", "compiled event ms": f"{event_ms:.2f}"})
    sampled = item.get("sampled")
    if sampled is not None:
        captured = item["captured_vigen"]

        def sampled_call() -> None:
            with captured.autocast():
                sampled()
        wall, event_ms = back_to_back(sampled_call, args.repeats, device)
        row["captured ms"] = f"{wall * 1e3:.2f}"
        if cuda:
            captured_gpu, _ = device_time(synchronized(sampled_call, device), args.repeats, device)
            row.update({"captured event ms": f"{event_ms:.2f}", "captured GPU ms": f"{captured_gpu * 1e3:.2f}",
                        "replay GB": f"{item['replay_bytes'] / 1e9:.2f}"})
    if "bf16" in item:
        row["bf16 loss diff"] = f"{100 * item['bf16']:.2f} % ({'ok' if item['bf16'] <= BF16_TOLERANCE else 'over'} {BF16_TOLERANCE:.0%})"
    if "cache_loaded" in item:
        row["cache"] = item["cache_loaded"]
    if "failed" in item:
        row["failed"] = item["failed"].replace("|", "/")
    row["ref GFLOP"], row["vigen GFLOP"] = f"{ref_flops / 1e9:.1f}", f"{vigen_flops / 1e9:.1f}"
    if not cuda:
        row["vigen % of peak"] = f"{100 * vigen_flops / vigen_s / peak:.0f} %"
        row["RL-ViGen ms @64"] = str(RLVIGEN_MS_AT_64.get(algo, "—") if batch_size == 64 else "—")
    text = None
    if args.profile and not cuda:
        text = (f"\n### {algo}, batch {batch_size}: {vigen_s * 1e3:.0f} ms per update, "
                f"{100 * vigen_flops / vigen_s / peak:.0f} % of peak\n\n{profile(vigen, batch, args.repeats, vigen_flops, peak)}")
    return row, text


def load_cache(path: Path) -> str:
    """``torch.compiler.load_cache_artifacts`` from ``path``: what it says (loaded, or the error), for the table."""
    if not path.is_file():
        return f"no {path.name}"
    try:
        info = torch.compiler.load_cache_artifacts(path.read_bytes())
    except Exception as error:  # noqa: BLE001 - the finding is the error itself
        return f"load failed: {type(error).__name__}: {error}"[:200]
    return f"loaded {path.stat().st_size} bytes: {info}"[:200] if info is not None else f"loaded nothing from {path.name}"


def save_cache(path: Path) -> None:
    artifacts = torch.compiler.save_cache_artifacts()
    if artifacts is None:
        print(f"save_cache_artifacts: nothing to save for {path.name}", flush=True)
        return
    data, info = artifacts
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(data)
    print(f"save_cache_artifacts: {len(data)} bytes to {path} ({info})", flush=True)


def run_in_parallel(args: argparse.Namespace, given: list[str]) -> int:
    """``--jobs N``: one child per algorithm, N compiling at once; when all are compiled (or the deadline nears), each
    times its updates in turn while the others wait, so that no timing shares the machine. Their output, in order."""
    started = time.perf_counter()
    deadline = started + (args.deadline if args.deadline is not None else 1e9)
    base = strip_flags(given, {"--jobs": 1, "--algos": len(args.algos), "--deadline": 1, "--also": len(args.also)})
    cores = os.cpu_count() or 1
    env = {**os.environ, "TORCHINDUCTOR_COMPILE_THREADS": str(max(1, cores // args.jobs)), "PYTHONUNBUFFERED": "1"}
    jobs = [(extra.split()[0], extra.split()[1:]) for extra in args.also] + [(algo, []) for algo in args.algos]
    labels = [" ".join([algo, *flags]) for algo, flags in jobs]
    print("reproduce: python benchmarks/losses.py " + " ".join(shlex.quote(arg) for arg in given), flush=True)
    print(f"--jobs {args.jobs}: {len(jobs)} processes, {args.jobs} compiling at once "
          f"({env['TORCHINDUCTOR_COMPILE_THREADS']} inductor compile threads each), then timed one at a time", flush=True)
    children: dict[str, Child] = {}
    waiting = list(zip(labels, jobs))
    while waiting or any(child.compiling() for child in children.values()):
        while waiting and sum(child.compiling() for child in children.values()) < args.jobs:
            label, (algo, flags) = waiting.pop(0)
            children[label] = Child([sys.executable, str(Path(__file__).resolve()), *base, *flags, "--algos", algo, "--hold"], env)
        if time.perf_counter() > deadline - TIMING_S * (1 + sum(child.ready.is_set() for child in children.values())):
            break  # leave time to time the compiled ones
        time.sleep(0.5)
    compile_s = time.perf_counter() - started
    results = {}
    for algo in labels:
        child = children.get(algo)
        if child is None:
            results[algo] = "not started: no time left"
        elif not child.ready.is_set():
            child.stop()
            results[algo] = "failed" if child.process.poll() not in (None, -15, -9) else "not compiled before the deadline"
        else:
            left = deadline - time.perf_counter()
            if left < 10:
                child.stop()
                results[algo] = "compiled, not timed: no time left"
                continue
            child.go()
            code = child.wait(left)
            results[algo] = "timed" if code == 0 else f"exit {code}"
    for algo in labels:
        child = children.get(algo)
        print(f"\n## {algo}: {results[algo]}", flush=True)
        if child is not None:
            print("".join(child.lines), flush=True)
    print(f"\n--jobs {args.jobs}: compiled in {compile_s:.0f} s, all done in {time.perf_counter() - started:.0f} s; "
          + ", ".join(f"{algo} {result}" for algo, result in results.items()), flush=True)
    return 0 if all(result == "timed" for result in results.values()) else 1


def strip_flags(argv: list[str], flags: dict[str, int]) -> list[str]:
    """``argv`` without the given flags and the values that follow them (``--algos`` takes as many as it had)."""
    out, skip = [], 0
    for arg in argv:
        if skip:
            skip -= 1
            if not arg.startswith("--"):
                continue
            skip = 0
        name = arg.split("=", 1)[0]
        if name in flags:
            skip = 0 if "=" in arg else flags[name]
            continue
        out.append(arg)
    return out


class Child:
    """One ``--hold`` process: its output lines (read in a thread), whether it said READY, and its exit."""

    def __init__(self, command: list[str], env: dict[str, str]) -> None:
        self.process = subprocess.Popen(command, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                        text=True, env=env, start_new_session=True)
        self.lines: list[str] = []
        self.ready = threading.Event()
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:
            if line.startswith("@@READY"):
                self.ready.set()
            else:
                self.lines.append(line)

    def compiling(self) -> bool:
        return self.process.poll() is None and not self.ready.is_set()

    def go(self) -> None:
        self.process.stdin.write("go\n")
        self.process.stdin.flush()

    def wait(self, timeout: float) -> int | None:
        try:
            return self.process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            self.stop()
            self.lines.append(f"[losses.py --jobs] stopped: timing ran past the deadline\n")
            return None

    def stop(self) -> None:
        for sig, wait in ((signal.SIGTERM, 5), (signal.SIGKILL, 5)):
            try:
                os.killpg(self.process.pid, sig)
            except ProcessLookupError:
                return
            try:
                self.process.wait(timeout=wait)
                return
            except subprocess.TimeoutExpired:
                continue


if __name__ == "__main__":
    sys.exit(main())

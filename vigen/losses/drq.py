"""DrQ: SAC with a clean and a shifted view, averaged targets and a learned temperature."""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import Tensor, nn

from vigen.losses.base import ActorCriticLoss, weighted_td_errors


class DrQLoss(ActorCriticLoss):
    """DrQ as in RL-ViGen: SAC on a clean and a randomly shifted view of every observation.

    With ``h₀ = encoder(obs)``, ``h₁ = encoder(shift(obs))`` and the same two views of the next
    observation (``h'₀``, ``h'₁``, no gradient):

    * targets ``yᵢ = r + γⁿ·(1 − terminated)·[min(Q1', Q2')(h'ᵢ, a'ᵢ) − α·log π(a'ᵢ|h'ᵢ)]`` with
      ``a'ᵢ ~ π(h'ᵢ)``, averaged: ``y = (y₀ + y₁) / 2``;
    * ``loss_critic`` = Σ over both views of MSE(Q1(hᵢ, a), y) + MSE(Q2(hᵢ, a), y) (summed, not
      averaged), which trains the encoder;
    * ``loss_actor = α·log π(ã|h₀) − min(Q1, Q2)(h₀, ã)`` on detached clean features, through a
      frozen critic;
    * ``loss_alpha = α·(−log π(ã|h₀) − H̄)`` with target entropy ``H̄ = −|A|``; α = exp(``log_alpha``),
      initialised at 0.1 (RL-ViGen's, the record ``ALGOS["drq"]``).

    RL-ViGen replaces one of the original DrQ's two shifted views by the raw observation
    (``clean_view=True``, ``make_loss("drq")``). The original DrQ (K = M = 2 independently shifted views, and a target
    encoder in the target critic) is ``clean_view=False, target_encoder=True``: the views are
    then ``shift₁(obs)`` and ``shift₂(obs)`` (and of next obs), the actor reads the first, the
    next action is sampled on the online encoder's features and scored on the target encoder's,
    and ``SoftUpdate`` moves the target encoder with the target critic. The actor is
    :class:`~vigen.models.GaussianActor` (mean, log σ of a tanh-squashed Gaussian), the critic
    DrQ-v2's.

    Paper: DrQ, https://arxiv.org/abs/2004.13649.

    Args:
        encoder, critic: as in :class:`DrQv2Loss`.
        actor: features → (mean, log σ).
        clean_view: pair the raw observation with one shifted view (RL-ViGen); ``False`` draws
            two shifted views (the original DrQ's K = M = 2).
        **options: ``sampler`` (SAC's :class:`~vigen.losses.SquashedGaussian`; a
            :class:`~vigen.losses.NoisyDeterministic` makes it DDPG on both views), ``augmentation``
            (the shift), ``target_encoder`` (encode the next views with a target copy of the encoder,
            as the original DrQ; RL-ViGen uses the online encoder), ``input_mask``, ``param_groups``,
            ``channels_last``, ``reduction``, ``check_finite`` (see :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import build_loss, example_batch
        >>> from vigen.models import Critic, DrQv2Encoder, GaussianActor
        >>> encoder = DrQv2Encoder(9)
        >>> features = encoder.output_dim(9, 84, 84)
        >>> actor, critic = GaussianActor(features, 2, hidden_dim=32), Critic(features, 2, hidden_dim=32)
        >>> loss = build_loss("drq", encoder, actor, critic)  # RL-ViGen's DrQ: its record, ALGOS["drq"]
        >>> loss.clean_view, loss.sampler
        (True, SquashedGaussian(init_temperature=0.1, target_entropy='auto', squash_epsilon=None))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_")), round(out["alpha"].item(), 3)
        (['loss_actor', 'loss_alpha', 'loss_critic'], 0.1)
    """

    def __init__(self, encoder: nn.Module, actor: nn.Module, critic: nn.Module, *, clean_view: bool, **options: Any) -> None:
        super().__init__(encoder, actor, critic, **options)
        self.clean_view = bool(clean_view)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        obs, next_obs = self.augment(batch.pixels), self.augment(batch.next_pixels)
        with torch.no_grad():  # the mean of both next views' targets
            first, second = self.next_value(torch.cat(self.two_views(batch.next_pixels, next_obs))).chunk(2)
            target = 0.5 * (self.bootstrap(tensordict, first) + self.bootstrap(tensordict, second))
        features = self.encode_views(self.two_views(batch.pixels, obs))
        q1, q2 = self.q_values(torch.cat(features), batch.action.repeat(2, 1))
        loss_critic = weighted_td_errors(q1, q2, target, [1.0, 1.0])  # summed over the views, not averaged
        # the actor and SAC's temperature: on the first view's detached features
        loss_actor, log_prob = self.actor_loss(features[0].detach())
        return self.output(tensordict, target, q1[:batch.size], q2[:batch.size],
                           {"loss_critic": loss_critic, "loss_actor": loss_actor,
                            **self.sampler.temperature_losses(log_prob, batch.action_dim, views=1)},
                           self.sampler.metrics(self.schedule_step, log_prob))

    def two_views(self, pixels: Tensor, shifted: Tensor) -> tuple[Tensor, Tensor]:
        """(raw or a second shift, the first shift): RL-ViGen's pair, or the original DrQ's (a fresh draw)."""
        return (pixels, shifted) if self.clean_view else (shifted, self.augment(pixels))

"""SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view."""

from __future__ import annotations

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch

from vigen.losses.base import per_sample_mean
from vigen.losses.svea import TwoViewLoss, svea_critic


class SADALoss(TwoViewLoss):
    """SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view.

    Its critic is :class:`~vigen.losses.SVEALoss`'s (:func:`~vigen.losses.svea.svea_critic`) on SAC with
    DMC-GB2's settings (the next observation shifted, no target encoder, DrQ's log π); its actor step
    is its own.

    With the weak view ``s = shift(obs)``, the strong view ``s̃ = strong(s)`` and their features
    ``h = encoder(s)``, ``h̃ = encoder(s̃)`` (one pass):

    * ``loss_critic = w·TD(h) + w̃·TD(h̃)`` against the SAC target of ``shift(next obs)``, with
      ``TD = (Q1 − y)² + (Q2 − y)²``; DMC-GB2 writes it as ``0.5·[MSE(Q(h), y) + MSE(Q(h̃), y)]``
      over the stacked (Q1, Q2), which is w = w̃ = 0.25 here (its record, ``ALGOS["sada"]``);
    * ``loss_actor`` = SAC's actor loss on the batch ``[h, h̃]`` for the policy, scored by the critic
      on ``[h, h]``: the actor learns to act on the augmented view as it would on the clean one,
      and the critic never judges augmented features in the actor step;
    * ``loss_alpha`` over the same ``2B`` samples (per sample, the mean over the two views, as for
      ``loss_actor``).

    DMC-GB2 draws its strong augmentation among rotate, shift, rotate+shift, conv, overlay and
    conv+overlay (its ``all``); ``make_loss("sada")`` uses the overlay: pass
    ``strong_augmentation=dmcgb2_strong_augmentation("all")`` (:mod:`vigen.transforms`) for its setting. Its networks are DrQ-v2's encoder
    and twin critic with DrQ's SAC actor (:class:`~vigen.models.GaussianActor` on a trunk);
    ``make_loss("sada", ...)`` builds them.

    Paper: SADA / DMC-GB2, https://arxiv.org/abs/2405.17416.

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.SVEALoss`; the actor returns (mean, log σ).
        strong_augmentation, weak_weight, strong_weight, augment_next: the two views (see
            :class:`~vigen.losses.svea.TwoViewLoss`); DMC-GB2: w = w̃ = 0.25 (its 0.5 of the stacked
            MSEs), the next observation shifted.
        **options: ``sampler`` (DMC-GB2: SAC's :class:`~vigen.losses.SquashedGaussian`, α₀ = 0.1, DrQ's
            log π; a :class:`~vigen.losses.NoisyDeterministic` makes it DDPG), ``augmentation`` (the weak
            view), ``target_encoder`` (DMC-GB2: none), ``input_mask``, ``param_groups``,
            ``channels_last``, ``reduction``, ``check_finite`` (see :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import example_batch, make_loss
        >>> loss = make_loss("sada", (9, 84, 84), action_dim=2, hidden_dim=32, seed=0)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> sorted(key for key in loss(batch).keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_alpha', 'loss_critic']
    """

    own_out_keys = ("q_strong_mean",)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        # the critic: SVEA's, w·TD(h) + w̃·TD(h̃) against one target, both views in one encoder pass
        critic = svea_critic(self, tensordict, batch, augment_next=self.augment_next)
        # the actor: the policy reads [h, h̃], the critic scores its actions on [h, h]; per sample, the views' mean
        clean, augmented = critic.features.detach(), critic.strong_features.detach()
        loss_actor, log_prob = self.actor_loss(torch.cat([clean, augmented]), torch.cat([clean, clean]))
        return self.output(tensordict, critic.target, *critic.weak_view_q,
                           {"loss_critic": critic.loss, "loss_actor": per_sample_mean(loss_actor, views=2),
                            **self.sampler.temperature_losses(log_prob, batch.action_dim, views=2)},
                           {**self.sampler.metrics(self.schedule_step, log_prob), "q_strong_mean": critic.q_strong_mean})

"""SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view."""

from __future__ import annotations

from typing import Any, Literal

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import nn

from vigen.losses.base import ActorCriticLoss, Augmentations, default_shift, per_sample_mean, weighted_td_errors
from vigen.losses.samplers import Sampler, SquashedGaussian


class SADALoss(ActorCriticLoss):
    """SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view.

    Its critic is :class:`~vigen.losses.SVEALoss`'s on SAC with DMC-GB2's settings (the next
    observation shifted, no target encoder, DrQ's log π); its actor step is its own.

    With the weak view ``s = shift(obs)``, the strong view ``s̃ = strong(s)`` and their features
    ``h = encoder(s)``, ``h̃ = encoder(s̃)`` (one pass):

    * ``loss_critic = w·TD(h) + w̃·TD(h̃)`` against the SAC target of ``shift(next obs)``, with
      ``TD = (Q1 − y)² + (Q2 − y)²``; DMC-GB2 writes it as ``0.5·[MSE(Q(h), y) + MSE(Q(h̃), y)]``
      over the stacked (Q1, Q2), which is w = w̃ = 0.25 here (the default);
    * ``loss_actor`` = SAC's actor loss on the batch ``[h, h̃]`` for the policy, scored by the critic
      on ``[h, h]``: the actor learns to act on the augmented view as it would on the clean one,
      and the critic never judges augmented features in the actor step;
    * ``loss_alpha`` over the same ``2B`` samples (per sample, the mean over the two views, as for
      ``loss_actor``).

    DMC-GB2 draws its strong augmentation among rotate, shift, rotate+shift, conv, overlay and
    conv+overlay (its ``all``); the default here is the overlay: pass
    ``strong_augmentation=dmcgb2_strong_augmentation("all")`` (:mod:`vigen.transforms`) for its setting. Its networks are DrQ-v2's encoder
    and twin critic with DrQ's SAC actor (:class:`~vigen.models.GaussianActor` on a trunk);
    ``make_loss("sada", ...)`` builds them.

    Paper: SADA / DMC-GB2, https://arxiv.org/abs/2405.17416.

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.SVEALoss`; the actor returns (mean, log σ).
        augmentation: the weak view; ``"default"`` is ``RandomShift(pad=4)``.
        strong_augmentation: the strong view, applied on top of the weak one; ``None`` for
            ``RandomOverlay(alpha=0.5)``.
        sampler: SAC's :class:`~vigen.losses.SquashedGaussian`; default DMC-GB2's (α₀ = 0.1, DrQ's log π);
            a :class:`~vigen.losses.NoisyDeterministic` makes it DDPG.
        weak_weight, strong_weight: weights of the two views' TD errors (0.25 each: DMC-GB2's 0.5
            of the stacked MSEs).
        augment_next: shift the next observation too (DMC-GB2: yes).
        target_encoder: score the next action on a target copy of the encoder (DMC-GB2: no).
        **kwargs: ``input_mask``, ``param_groups``, ``channels_last``, ``reduction``,
            ``check_finite`` (see :class:`~vigen.losses.ActorCriticLoss`).

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
    _schedulable_buffers = frozenset({"weak_weight", "strong_weight"})

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        sampler: Sampler | None = None,
        augmentation: Augmentations | Literal["default"] = "default",
        strong_augmentation: Augmentations = None,
        weak_weight: float = 0.25,
        strong_weight: float = 0.25,
        augment_next: bool = True,
        target_encoder: bool = False,
        **kwargs: Any,
    ) -> None:
        super().__init__(encoder, actor, critic, sampler=SquashedGaussian() if sampler is None else sampler,
                         augmentation=default_shift(augmentation), target_encoder=target_encoder, **kwargs)
        self.add_strong_view(strong_augmentation, weak_weight, strong_weight)
        self.augment_next = bool(augment_next)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        obs = self.augment(batch.pixels)
        next_obs = self.augment(batch.next_pixels) if self.augment_next else batch.next_pixels
        target = self.critic_target(tensordict, next_obs)
        strong = self.augment(obs, self.strong_augmentation)  # the strong view is built on the weak one
        # the critic: w·TD(h) + w̃·TD(h̃) against one target, both views in one encoder pass
        features, strong_features = self.encode_views([obs, strong])
        q1, q2 = self.q_values(torch.cat([features, strong_features]), batch.action.repeat(2, 1))
        loss_critic = weighted_td_errors(q1, q2, target, [self.weak_weight, self.strong_weight])
        # the actor: the policy reads [h, h̃], the critic scores its actions on [h, h]; per sample, the views' mean
        clean, augmented = features.detach(), strong_features.detach()
        loss_actor, log_prob = self.actor_loss(torch.cat([clean, augmented]), torch.cat([clean, clean]))
        return self.output(tensordict, target, q1[:batch.size], q2[:batch.size],
                           {"loss_critic": loss_critic, "loss_actor": per_sample_mean(loss_actor, views=2)},
                           {"q_strong_mean": q1[batch.size:].detach().mean()}, log_prob=log_prob)

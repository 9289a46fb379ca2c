"""SVEA: a second, strongly augmented view in the critic loss, on DrQ-v2's DDPG or on DMC-GB's SAC."""

from __future__ import annotations

from typing import Any, Literal

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import nn

from vigen.losses.base import ActorCriticLoss, Augmentations, default_shift, weighted_td_errors
from vigen.losses.samplers import NoisyDeterministic, Sampler


class SVEALoss(ActorCriticLoss):
    """SVEA: ``w·TD(weak view) + w̃·TD(strong view)`` against one target, the actor on the weak view.

    The weak view is ``s = shift(obs)``; the strong view ``s̃ = strong(s)`` is built on top of it.
    Both are scored against the same target ``y`` of the next observation:

        ``loss_critic = w·[(Q1(s) − y)² + (Q2(s) − y)²] + w̃·[(Q1(s̃) − y)² + (Q2(s̃) − y)²]``

    per sample, with w = w̃ = 0.5 (``weak_weight``, ``strong_weight``). Both views go through the
    encoder with gradient, batched into one pass (as DMC-GB concatenates them). The actor sees the
    weak view only; ``q_strong_mean`` logs the strong view's mean Q1.

    The defaults are RL-ViGen's SVEA, on DrQ-v2's DDPG (``sampler=NoisyDeterministic()``, the next
    observation shifted, the online encoder in the target) with the random overlay as strong
    augmentation: the blend ``0.5·x + 0.5·image`` of uint8 frames is rounded back to uint8 (the
    originals blend floats, a difference of at most half a grey level). The SVEA paper's own code is
    DMC-GB's SAC agent:

        SVEALoss(encoder, actor, critic, sampler=SquashedGaussian(squash_epsilon=DMCGB_SQUASH_EPSILON),
                 strong_augmentation=RandomConv(), augment_next=True, target_encoder=True)

    on DMC-GB's networks (``SharedCNN(centered=False)``, :class:`~vigen.models.GaussianActor` and
    :class:`~vigen.models.Critic` with ``feature_dim`` projections); at DMC-GB @ ff9c0aa its
    ``sample_svea`` is ``sample_drq`` (the next observation is shifted too; MaDi's and SimGRL's forks
    leave it as stored) and its target critic scores on a target encoder. ``examples/train.py
    --recipe svea-dmcgb`` trains it with DMC-GB's settings (:data:`vigen.run.RECIPES`). SRM, MaDi and
    SimGRL are this loss with other defaults (registered presets of :func:`~vigen.losses.make_loss`).
    Departure from DMC-GB: DMC-GB steps the critic, then the actor and temperature on the stepped
    critic, each with its own Adam; here every term comes from the batch's parameters and one
    optimizer step takes them all. Its actor, temperature and targets every second update, and its
    two target rates (0.01 for the Q heads, 0.05 for the encoder and the critic's projection), are the
    update's: :class:`~vigen.losses.UpdateStep`'s schedule and :class:`~vigen.losses.SplitSoftUpdate`.

    Paper: SVEA, https://arxiv.org/abs/2107.00644 (code: DMC-GB,
    https://github.com/nicklashansen/dmcontrol-generalization-benchmark; RL-ViGen,
    https://arxiv.org/abs/2307.10224).

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.DrQv2Loss` (a SAC actor returns mean and log σ).
        sampler: :class:`~vigen.losses.NoisyDeterministic` (default, DrQ-v2's) or
            :class:`~vigen.losses.SquashedGaussian` (DMC-GB's SAC).
        augmentation: the weak view; ``"default"`` is ``RandomShift(pad=4)``.
        strong_augmentation: applied on top of the weak view; default ``RandomOverlay(alpha=0.5)``
            with vigen's built-in image bank (pass ``RandomOverlay(images=<Places365 folder>)``
            for the papers' images).
        weak_weight, strong_weight: w and w̃.
        augment_next: shift the next observation too (RL-ViGen, SimGRL); ``False`` leaves it as
            stored (DMC-GB's ``sample_svea``).
        target_encoder: score the next action on a target copy of the encoder (DMC-GB's SAC).
        **kwargs: ``input_mask``, ``param_groups``, ``channels_last``, ``reduction``,
            ``check_finite`` (see :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import example_batch
        >>> from vigen.models import Actor, Critic, SharedCNN
        >>> encoder = SharedCNN(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = SVEALoss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> out["loss_critic"].requires_grad, out["q_strong_mean"].requires_grad
        (True, False)
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
        weak_weight: float = 0.5,
        strong_weight: float = 0.5,
        augment_next: bool = True,
        target_encoder: bool = False,
        **kwargs: Any,
    ) -> None:
        super().__init__(encoder, actor, critic, sampler=NoisyDeterministic() if sampler is None else sampler,
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
        # the critic: w·TD(s) + w̃·TD(s̃) against one target, both views in one encoder pass
        features, strong_features = self.encode_views([obs, strong])
        q1, q2 = self.q_values(torch.cat([features, strong_features]), batch.action.repeat(2, 1))
        loss_critic = weighted_td_errors(q1, q2, target, [self.weak_weight, self.strong_weight])
        # the actor: on the weak view's detached features
        loss_actor, log_prob = self.actor_loss(features.detach())
        return self.output(tensordict, target, q1[:batch.size], q2[:batch.size],
                           {"loss_critic": loss_critic, "loss_actor": loss_actor},
                           {"q_strong_mean": q1[batch.size:].detach().mean()}, log_prob=log_prob)

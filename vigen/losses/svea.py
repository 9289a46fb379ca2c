"""SVEA: a second, strongly augmented view in the critic loss, on DrQ-v2's DDPG or on DMC-GB's SAC."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import Tensor, nn

from vigen.losses.base import ActorCriticLoss, Augmentations, Batch, weighted_td_errors


@dataclass(frozen=True)
class TwoViewCritic:
    """SVEA's critic step on one batch: the target, both views' features and Q values, and the critic loss."""

    target: Tensor
    """``y`` of the next observation, ``[B, 1]``, without gradient."""
    features: Tensor
    """``h``, the weak view's features ``[B, D]``."""
    strong_features: Tensor
    """``h̃``, the strong view's features ``[B, D]``."""
    q1: Tensor
    """Q1 of both views, view-major ``[2·B, 1]``: the weak view's first."""
    q2: Tensor
    loss: Tensor
    """``w·TD(h) + w̃·TD(h̃)`` per sample, ``[B]``."""

    @property
    def weak_view_q(self) -> tuple[Tensor, Tensor]:
        """(Q1, Q2) of the weak view, ``[B, 1]`` each (what the output's ``q_mean`` and priority read)."""
        size = self.features.shape[0]
        return self.q1[:size], self.q2[:size]

    @property
    def q_strong_mean(self) -> Tensor:
        """The strong view's mean Q1, detached (a metric)."""
        return self.q1[self.features.shape[0]:].detach().mean()


class TwoViewLoss(ActorCriticLoss):
    """What a loss with SVEA's critic (:func:`svea_critic`) is built with: its strong view and whether the next view is shifted.

    It holds the options only; each loss on it writes its own ``forward`` (:class:`SVEALoss`,
    :class:`~vigen.losses.SADALoss`, :class:`~vigen.losses.PIEGLoss`).

    Args:
        encoder, actor, critic: the networks (see :class:`~vigen.losses.ActorCriticLoss`).
        strong_augmentation: applied on top of the weak view (SVEA: ``RandomOverlay(alpha=0.5)``);
            ``None`` makes the strong view the weak one.
        weak_weight, strong_weight: w and w̃, the weights of the two views' TD errors (buffers,
            schedulable: ``loss.strong_weight = 0.3``).
        augment_next: shift the next observation too (RL-ViGen, SimGRL); ``False`` leaves it as
            stored (MaDi's fork of DMC-GB).
        **options: ``sampler``, ``augmentation`` (the weak view) and the rest of
            :class:`~vigen.losses.ActorCriticLoss`'s.
    """

    def __init__(self, encoder: nn.Module, actor: nn.Module, critic: nn.Module, *, strong_augmentation: Augmentations,
                 weak_weight: float, strong_weight: float, augment_next: bool, **options: Any) -> None:
        super().__init__(encoder, actor, critic, **options)
        self.add_strong_view(strong_augmentation, weak_weight, strong_weight)
        self.augment_next = bool(augment_next)


def svea_critic(loss: TwoViewLoss, tensordict: TensorDictBase, batch: Batch, *, augment_next: bool = True,
                one_encoder_pass: bool = True) -> TwoViewCritic:
    """SVEA's critic: the weak view ``s = shift(obs)``, the strong view ``s̃ = strong(s)``, both scored against one target.

    ``loss_critic = w·[(Q1(s) − y)² + (Q2(s) − y)²] + w̃·[(Q1(s̃) − y)² + (Q2(s̃) − y)²]`` per sample,
    with ``y`` the critic target of ``shift(next obs)`` (of the next obs as stored without
    ``augment_next``), ``w``, ``w̃`` the loss's ``weak_weight`` and ``strong_weight`` and its
    ``strong_augmentation`` (:meth:`~vigen.losses.ActorCriticLoss.add_strong_view`). Both views go
    through the encoder with gradient, in one pass (as DMC-GB concatenates them), or each in its own
    (``one_encoder_pass=False``: its own BatchNorm statistics, as PIE-G). The draws come in this
    order: the weak view, the next view, the target's action, the strong view.

    Paper: SVEA, https://arxiv.org/abs/2107.00644. SADA and PIE-G train this critic too.

    Examples:
        >>> from vigen.losses import example_batch, make_loss
        >>> loss = make_loss("svea", (9, 84, 84), action_dim=2, hidden_dim=32, seed=0).make_value_estimator(gamma=0.99)
        >>> batch = example_batch(4)
        >>> critic = svea_critic(loss, batch, loss.read_batch(batch))
        >>> critic.q1.shape, critic.loss.shape
        (torch.Size([8, 1]), torch.Size([4]))
    """
    obs = loss.augment(batch.pixels)
    next_obs = loss.augment(batch.next_pixels) if augment_next else batch.next_pixels
    target = loss.critic_target(tensordict, next_obs)
    strong = loss.augment(obs, loss.strong_augmentation)  # the strong view is built on the weak one
    if one_encoder_pass:
        features, strong_features = loss.encode_views([obs, strong])
    else:
        features, strong_features = loss.encode(obs), loss.encode(strong)
    q1, q2 = loss.q_values(torch.cat([features, strong_features]), batch.action.repeat(2, 1))
    td = weighted_td_errors(q1, q2, target, [loss.weak_weight, loss.strong_weight])
    return TwoViewCritic(target, features, strong_features, q1, q2, td)


class SVEALoss(TwoViewLoss):
    """SVEA: ``w·TD(weak view) + w̃·TD(strong view)`` against one target, the actor on the weak view.

    The weak view is ``s = shift(obs)``; the strong view ``s̃ = strong(s)`` is built on top of it.
    Both are scored against the same target ``y`` of the next observation (:func:`svea_critic`):

        ``loss_critic = w·[(Q1(s) − y)² + (Q2(s) − y)²] + w̃·[(Q1(s̃) − y)² + (Q2(s̃) − y)²]``

    per sample (``weak_weight``, ``strong_weight``), both views in one encoder pass. The actor sees
    the weak view only; with SAC's sampler its temperature loss ``loss_alpha`` comes from the same
    actions. ``q_strong_mean`` logs the strong view's mean Q1.

    ``make_loss("svea")`` is RL-ViGen's SVEA, on DrQ-v2's DDPG (the next observation shifted, the
    online encoder in the target) with the random overlay as strong augmentation (w = w̃ = 0.5; the
    record ``ALGOS["svea"]``): the blend ``0.5·x + 0.5·image`` of uint8 frames is rounded back to
    uint8 (the originals blend floats, a difference of at most half a grey level). The SVEA paper's
    own code is DMC-GB's SAC agent: ``sampler=SquashedGaussian(squash_epsilon=DMCGB_SQUASH_EPSILON),
    strong_augmentation=RandomConv(), augment_next=True, target_encoder=True`` on DMC-GB's networks
    (``SharedCNN(centered=False)``, :class:`~vigen.models.GaussianActor` and :class:`~vigen.models.Critic`
    with ``feature_dim`` projections); at DMC-GB @ ff9c0aa its ``sample_svea`` is ``sample_drq`` (the
    next observation is shifted too; MaDi's and SimGRL's forks leave it as stored) and its target
    critic scores on a target encoder. ``examples/train.py --recipe svea-dmcgb`` trains it with
    DMC-GB's settings (:data:`vigen.run.RECIPES`). SRM, MaDi and SimGRL are this loss with other
    options (their records in :data:`~vigen.losses.ALGOS`). Departure from DMC-GB: DMC-GB steps the
    critic, then the actor and temperature on the stepped critic, each with its own Adam; here every
    term comes from the batch's parameters and one optimizer step takes them all. Its actor,
    temperature and targets every second update, and its two target rates (0.01 for the Q heads,
    0.05 for the encoder and the critic's projection), are the update's:
    :class:`~vigen.losses.UpdateStep`'s schedule and :class:`~vigen.losses.SplitSoftUpdate`.

    Paper: SVEA, https://arxiv.org/abs/2107.00644 (code: DMC-GB,
    https://github.com/nicklashansen/dmcontrol-generalization-benchmark; RL-ViGen,
    https://arxiv.org/abs/2307.10224).

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.DrQv2Loss` (a SAC actor returns mean and log σ).
        strong_augmentation, weak_weight, strong_weight, augment_next: the two views (see
            :class:`TwoViewLoss`); RL-ViGen's strong view is ``RandomOverlay(alpha=0.5)``, here with
            vigen's built-in image bank (pass ``RandomOverlay(images=<Places365 folder>)`` for the
            papers' images).
        **options: ``sampler``, ``augmentation`` (the weak view), ``target_encoder``, ``input_mask``,
            ``param_groups``, ``channels_last``, ``reduction``, ``check_finite`` (see
            :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import NoisyDeterministic, example_batch
        >>> from vigen.models import Actor, Critic, SharedCNN
        >>> from vigen.transforms import RandomOverlay, RandomShift
        >>> encoder = SharedCNN(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = SVEALoss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32),
        ...                 strong_augmentation=RandomOverlay(alpha=0.5), weak_weight=0.5, strong_weight=0.5,
        ...                 augment_next=True, target_encoder=False, sampler=NoisyDeterministic(),
        ...                 augmentation=RandomShift(pad=4))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> out["loss_critic"].requires_grad, out["q_strong_mean"].requires_grad
        (True, False)
    """

    own_out_keys = ("q_strong_mean",)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        # the critic: w·TD(s) + w̃·TD(s̃) against one target, both views in one encoder pass
        critic = svea_critic(self, tensordict, batch, augment_next=self.augment_next)
        # the actor: on the weak view's detached features; SAC's temperature on the same actions
        loss_actor, log_prob = self.actor_loss(critic.features.detach())
        return self.output(tensordict, critic.target, *critic.weak_view_q,
                           {"loss_critic": critic.loss, "loss_actor": loss_actor,
                            **self.sampler.temperature_losses(log_prob, batch.action_dim, views=1)},
                           {**self.sampler.metrics(self.schedule_step, log_prob), "q_strong_mean": critic.q_strong_mean})

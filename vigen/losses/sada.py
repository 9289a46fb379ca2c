"""SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view."""

from __future__ import annotations

from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import nn

from vigen.losses.base import per_sample_mean
from vigen.losses.policies import SquashedGaussian
from vigen.losses.svea import SVEALoss


class SADALoss(SVEALoss):
    """SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view.

    It is :class:`~vigen.losses.SVEALoss` on SAC with DMC-GB2's settings (the next observation shifted,
    no target encoder, DrQ's log π), with its own actor step.

    With the weak view ``s = shift(obs)``, the strong view ``s̃ = strong(s)`` and their features
    ``h = encoder(s)``, ``h̃ = encoder(s̃)`` (one pass):

    * ``loss_critic = w·TD(h) + w̃·TD(h̃)`` against the SAC target of ``shift(next obs)``, with
      ``TD = (Q1 − y)² + (Q2 − y)²``; DMC-GB2 writes it as ``0.5·[MSE(Q(h), y) + MSE(Q(h̃), y)]``
      over the stacked (Q1, Q2), which is w = w̃ = 0.25 here (the default);
    * ``loss_actor`` = SAC's actor loss on the batch ``[h, h̃]`` for the policy, scored by the critic
      on ``[h, h]``: the actor learns to act on the augmented view as it would on the clean one,
      and the critic never judges augmented features in the actor step;
    * ``loss_alpha`` over the same ``2B`` samples.

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
        policy: SAC's :class:`~vigen.losses.SquashedGaussian`; default DMC-GB2's (α₀ = 0.1, DrQ's log π).
        weak_weight, strong_weight: weights of the two views' TD errors (0.25 each: DMC-GB2's 0.5
            of the stacked MSEs).
        **kwargs: the options of :class:`~vigen.losses.SVEALoss` (``augment_next``, ``target_encoder``,
            ``input_mask``, ...), with DMC-GB2's defaults (``True``, ``False``).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import make_loss
        >>> loss = make_loss("sada", (9, 84, 84), action_dim=2, hidden_dim=32, seed=0)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> batch = TensorDict({
        ...     "pixels": pixels, "action": torch.zeros(4, 2),
        ...     "next": {"pixels": pixels, "reward": torch.ones(4, 1),
        ...              "done": torch.zeros(4, 1, dtype=torch.bool),
        ...              "terminated": torch.zeros(4, 1, dtype=torch.bool)},
        ... }, batch_size=[4])
        >>> sorted(key for key in loss(batch).keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_alpha', 'loss_critic']
    """

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        policy: SquashedGaussian | None = None,
        weak_weight: float = 0.25,
        strong_weight: float = 0.25,
        **kwargs: Any,
    ) -> None:
        super().__init__(encoder, actor, critic, policy=SquashedGaussian() if policy is None else policy,
                         weak_weight=weak_weight, strong_weight=strong_weight, **kwargs)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        critic = self.two_view_critic(tensordict, batch)
        clean, augmented = critic.weak_features.detach(), critic.strong_features.detach()
        # the policy reads [h, h̃]; the critic scores its actions on [h, h]
        loss_actor, log_prob = self.actor_loss(torch.cat([clean, augmented]), torch.cat([clean, clean]))
        losses = {"loss_actor": loss_actor, **self.policy.losses(log_prob, batch.action.shape[-1])}
        return self.output(tensordict, critic.target, critic.q1[:batch.size], critic.q2[:batch.size],
                           {"loss_critic": critic.loss, **{name: per_sample_mean(value, views=2) for name, value in losses.items()}},
                           {"q_strong_mean": critic.q1[batch.size:].detach().mean(), **self.policy_metrics(log_prob)})

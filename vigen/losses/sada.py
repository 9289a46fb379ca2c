"""SADA: SVEA's critic, and an actor trained on clean and augmented views against the clean Q."""

from __future__ import annotations

from typing import Any

import torch
from torch import Tensor, nn

from vigen.losses.base import Augmentations, CriticResult, Observations
from vigen.losses.svea_sac import SACSVEALoss
from vigen.transforms import RandomOverlay


class SADALoss(SACSVEALoss):
    """SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view.

    It is :class:`~vigen.losses.SACSVEALoss` with DMC-GB2's settings (the next observation shifted,
    no target encoder, DrQ's log π) and one hook changed, :meth:`actor_features`.

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

    Paper: SADA / DMC-GB2, https://arxiv.org/abs/2405.03451.

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.SVEALoss`; the actor returns (mean, log σ).
        augmentation: the weak view; ``"default"`` is ``RandomShift(pad=4)``.
        strong_augmentation: the strong view, applied on top of the weak one; ``None`` for
            ``RandomOverlay(alpha=0.5)``.
        weak_weight, strong_weight: weights of the two views' TD errors (0.25 each: DMC-GB2's 0.5
            of the stacked MSEs); the loss's ``svea_alpha`` and ``svea_beta``.
        **kwargs: the options of :class:`~vigen.losses.SACSVEALoss` (``init_temperature``,
            ``input_mask``, ...); ``augment_next``, ``target_encoder`` and ``squash_epsilon`` default
            to DMC-GB2's ``True``, ``False`` and ``None``.

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
        weak_weight: float = 0.25,
        strong_weight: float = 0.25,
        **kwargs: Any,
    ) -> None:
        for option, dmcgb2 in (("augment_next", True), ("target_encoder", False), ("squash_epsilon", None)):
            kwargs.setdefault(option, dmcgb2)
        super().__init__(encoder, actor, critic, alpha=weak_weight, beta=strong_weight, **kwargs)

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return RandomOverlay(alpha=0.5)

    def actor_features(self, batch: Observations, critic: CriticResult) -> tuple[Tensor, Tensor]:
        """The policy reads ``[h, h̃]``; the critic scores its actions on ``[h, h]``."""
        clean, strong = (features.detach() for features in critic.view_features)
        return torch.cat([clean, strong]), torch.cat([clean, clean])

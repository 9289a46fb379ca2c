"""SADA: SVEA's critic, and an actor trained on clean and augmented views against the clean Q."""

from __future__ import annotations

from typing import Any, Literal

import torch
from torch import Tensor, nn

from vigen.losses.base import ActorCriticLoss, Augmentations, CriticResult, Observations, View, default_shift
from vigen.losses.sac import SoftActorCritic
from vigen.transforms import RandomOverlay


class SADALoss(SoftActorCritic, ActorCriticLoss):
    """SADA (DMC-GB2): SAC with SVEA's two-view critic and an actor that also reads the strong view.

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
            of the stacked MSEs).
        init_temperature, target_entropy: see :class:`~vigen.losses.SoftActorCritic`.
        **kwargs: ``input_mask``, ``channels_last``, ``reduction``, ``check_finite``.

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

    out_keys = ActorCriticLoss.out_keys + ["loss_alpha", "alpha", "entropy", "q_strong_mean"]

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        augmentation: Augmentations | Literal["default"] = "default",
        strong_augmentation: Augmentations = None,
        weak_weight: float = 0.25,
        strong_weight: float = 0.25,
        **kwargs: Any,
    ) -> None:
        augmentation = default_shift(augmentation)
        super().__init__(encoder, actor, critic, augmentation=augmentation, **kwargs)
        self.strong_augmentation = self._augmentations(
            RandomOverlay(alpha=0.5) if strong_augmentation is None else strong_augmentation
        )
        self.register_coeff_buffer("weak_weight", weak_weight)
        self.register_coeff_buffer("strong_weight", strong_weight)

    _schedulable_buffers = frozenset({"weak_weight", "strong_weight"})

    def critic_views(self, batch: Observations) -> list[View]:
        """The weak view and its strongly augmented copy."""
        strong = self._augment(self.strong_augmentation, batch.obs)
        return [View(batch.obs, self.weak_weight), View(strong, self.strong_weight, name="strong")]

    def actor_features(self, batch: Observations, critic: CriticResult) -> tuple[Tensor, Tensor]:
        """The policy reads ``[h, h̃]``; the critic scores its actions on ``[h, h]``."""
        clean, strong = (features.detach() for features in critic.view_features)
        return torch.cat([clean, strong]), torch.cat([clean, clean])

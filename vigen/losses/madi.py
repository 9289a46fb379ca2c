"""MaDi: SVEA with a small masker in front of the encoder, trained by the critic's loss only."""

from __future__ import annotations

import math
from typing import Any

from torch import nn

from vigen.losses.svea import SVEALoss
from vigen.models.masker import MaDiMasker


class MaDiLoss(SVEALoss):
    """MaDi on vigen's SVEA: every view goes through a learned soft mask before the encoder.

    The masker ``M`` (default :class:`~vigen.models.MaDiMasker`) gives each frame of a stack a
    soft mask and multiplies it in. It is the loss's ``input_mask``: it runs in front of the
    encoder for every view (weak, strong and next), and in front of the acting policy
    (:meth:`make_policy`). With ``h = encoder(M(s))`` the update is SVEA's:

    * ``loss_critic = α·TD(M(s)) + β·TD(M(s̃))`` with ``s = shift(obs)``, ``s̃ = overlay(s)`` and the
      target ``y`` computed, without gradient, on ``M(shift(next obs))``; α = β = 0.5 and MaDi's
      strong augmentation is the random overlay (SVEA's default here);
    * ``loss_actor`` reads the detached features of ``M(s)``.

    So the masker learns from the critic's TD error alone: the actor's features are detached
    and the target carries no gradient, as in MaDi, where the masker's optimizer steps with
    the critic's. It gets its own Adam learning rate and betas, MaDi's ``masker_lr`` = 1e-3 and
    ``masker_beta`` = 0.9: :meth:`optimizer_groups` returns its parameters as a group of
    their own.

    Departures from the original: MaDi is written on DMC-GB's SVEA, a SAC agent with its own
    target encoder and separate optimizers for critic (with masker), actor and temperature;
    here it runs on vigen's SVEA, DrQ-v2's DDPG update (RL-ViGen's SVEA), whose target is
    computed by the online encoder and whose actor reads the features of the critic step
    (before, not after, this step's masker update). The masker and the encoder scale pixels
    as vigen does (see :class:`~vigen.models.MaDiMasker`).

    Paper: MaDi, https://arxiv.org/abs/2312.15339.

    Args:
        encoder, actor, critic: as in :class:`SVEALoss`; ``make_loss("madi", ...)`` uses SVEA's
            11-layer :class:`~vigen.models.SharedCNN`.
        masker: pixels → masked float pixels on the encoder's scale; ``None`` builds
            ``MaDiMasker(max_value=encoder.max_value)``. A :class:`~vigen.models.MaDiMasker`
            without ``max_value`` is given the encoder's.
        masker_lr: the masker's learning rate (MaDi: 1e-3).
        masker_beta: the masker's Adam β1 (MaDi: 0.9; β2 is 0.999).
        **kwargs: the options of :class:`SVEALoss` (strong_augmentation, alpha, beta,
            augmentation, std, ...), except ``input_mask``, which is the masker.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.models import Actor, Critic, SharedCNN
        >>> encoder = SharedCNN(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = MaDiLoss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32))
        >>> type(loss.masker).__name__
        'MaDiMasker'
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> batch = TensorDict({
        ...     "pixels": pixels, "action": torch.zeros(4, 2),
        ...     "next": {"pixels": pixels, "reward": torch.ones(4, 1),
        ...              "done": torch.zeros(4, 1, dtype=torch.bool),
        ...              "terminated": torch.zeros(4, 1, dtype=torch.bool)},
        ... }, batch_size=[4])
        >>> out = loss(batch)
        >>> optimizer = torch.optim.Adam(loss.optimizer_groups(lr=1e-4))
        >>> [group["lr"] for group in optimizer.param_groups]  # everything else, then the masker
        [0.0001, 0.001]
    """

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        masker: nn.Module | None = None,
        *,
        masker_lr: float = 1e-3,
        masker_beta: float = 0.9,
        **kwargs: Any,
    ) -> None:
        name = type(self).__name__
        if "input_mask" in kwargs:
            raise TypeError(f"{name}: the input mask of MaDi is its masker; pass masker=... instead of input_mask=....")
        if not (isinstance(masker_lr, (int, float)) and math.isfinite(masker_lr) and masker_lr > 0):
            raise ValueError(f"{name}: masker_lr must be a positive number, got {masker_lr!r}.")
        if not (isinstance(masker_beta, (int, float)) and 0 <= masker_beta < 1):
            raise ValueError(f"{name}: masker_beta is Adam's β1 of the masker, a number in [0, 1), got {masker_beta!r}.")
        encoder_max = getattr(encoder, "max_value", None)
        if masker is None:
            masker = MaDiMasker(max_value=encoder_max)
        elif not isinstance(masker, nn.Module):
            raise TypeError(f"{name}: masker must be an nn.Module (e.g. vigen.models.MaDiMasker()), got {type(masker).__name__}.")
        elif isinstance(masker, MaDiMasker):
            if masker.max_value is None:
                masker.max_value = encoder_max
            elif masker.max_value != encoder_max:
                raise ValueError(
                    f"{name}: the masker has max_value={masker.max_value} but the encoder's is {encoder_max}; the "
                    "masker hands the encoder float pixels on its scale, so they must agree. Leave the masker's "
                    "max_value unset (the loss gives it the encoder's)."
                )
        super().__init__(encoder, actor, critic, input_mask=masker, **kwargs)
        self.masker_lr = float(masker_lr)
        self.masker_beta = float(masker_beta)

    @property
    def masker(self) -> nn.Module:
        """The masker (the loss's ``input_mask``)."""
        return self.input_mask

    def optimizer_groups(self, lr: float) -> list[dict[str, Any]]:
        """Everything but the masker at ``lr``; the masker at ``masker_lr`` with betas ``(masker_beta, 0.999)``."""
        masker = list(self.masker.parameters())
        own = {id(parameter) for parameter in masker}
        rest = [parameter for parameter in self.parameters() if id(parameter) not in own]
        return [
            {"params": rest, "lr": lr},
            {"params": masker, "lr": self.masker_lr, "betas": (self.masker_beta, 0.999)},
        ]

"""MaDi: SVEA (DMC-GB's SAC) with a small masker in front of the encoder, trained by the critic's loss only."""

from __future__ import annotations

import math
from typing import Any

from torch import nn

from vigen.losses.base import Augmentations
from vigen.losses.svea_sac import SACSVEALoss
from vigen.models.masker import MaDiMasker
from vigen.transforms import RandomOverlay


class MaDiLoss(SACSVEALoss):
    """MaDi: SVEA on DMC-GB's SAC with a small masker in front of the encoder, trained by the critic's loss only.

    The masker ``M`` (default :class:`~vigen.models.MaDiMasker`) gives each frame of a stack a
    soft mask and multiplies it in. It is the loss's ``input_mask``: it runs in front of the
    encoder for every view (weak, strong and next, the online and the target encoder's passes)
    and in front of the acting policy (:meth:`make_policy`). With ``h = encoder(M(s))`` the
    update is :class:`~vigen.losses.SACSVEALoss`'s, as MaDi's code (DMC-GB's SVEA) has it:

    * ``loss_critic = 0.5·TD(M(s)) + 0.5·TD(M(s̃))`` with ``s = shift(obs)``, ``s̃ = overlay(s)``
      and the SAC target of ``M(next obs)`` (not shifted: DMC-GB's ``sample_svea``), the next
      action sampled on the online encoder and scored on the target encoder;
    * ``loss_actor = α·log π(ã|h) − min(Q1, Q2)(h, ã)`` and ``loss_alpha`` on the detached
      features of ``M(s)``.

    So the masker learns from the critic's TD error alone: the actor's features are detached
    and the target carries no gradient, as in MaDi, where the masker's optimizer steps with
    the critic's. It gets its own Adam learning rate and betas, MaDi's ``masker_lr`` = 1e-3 and
    ``masker_beta`` = 0.9: :meth:`optimizer_groups` returns its parameters as a group of
    their own. MaDi's strong augmentation for its results is the random overlay (the default here).

    Departures from MaDi's code (measured in ``benchmarks/parity.py``): those of
    :class:`~vigen.losses.SACSVEALoss` (one optimizer step for all terms, one τ); MaDi's optional
    binary ("hard") masks are not offered (its default and its results are the soft masks here).

    Paper: MaDi, https://arxiv.org/abs/2312.15339 (code: https://github.com/bramgrooten/mask-distractions).

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.SACSVEALoss`; ``make_loss("madi", ...)``
            uses DMC-GB's networks (SVEA's 11-layer :class:`~vigen.models.SharedCNN` on ``x / 255``,
            the SAC actor and the critic with their projections).
        masker: pixels → masked float pixels on the encoder's scale; ``None`` builds
            ``MaDiMasker(max_value=encoder.max_value)``. A :class:`~vigen.models.MaDiMasker`
            without ``max_value`` is given the encoder's.
        masker_lr: the masker's learning rate (MaDi: 1e-3).
        masker_beta: the masker's Adam β1 (MaDi: 0.9; β2 is 0.999).
        **kwargs: the options of :class:`~vigen.losses.SACSVEALoss` (strong_augmentation, alpha,
            beta, augmentation, augment_next, ...), except ``input_mask``, which is the masker.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import make_loss
        >>> loss = make_loss("madi", (9, 84, 84), action_dim=2, hidden_dim=32, seed=0)
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

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return RandomOverlay(alpha=0.5)

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

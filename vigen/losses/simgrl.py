"""SimGRL: SVEA (DMC-GB's SAC) with a shifted random overlay as its strong view, on a per-frame encoder."""

from __future__ import annotations

from typing import Any

from vigen.losses.base import Augmentations
from vigen.losses.svea_sac import SACSVEALoss
from vigen.transforms import RandomShiftedOverlay


class SimGRLLoss(SACSVEALoss):
    """SimGRL: SVEA on DMC-GB's SAC with a shifted random overlay as strong view, on a per-frame encoder.

    SimGRL changes two things in SVEA, both outside the update's formula:

    * the strong view is :class:`~vigen.transforms.RandomShiftedOverlay` (α = 0.5, shifts up to 6
      pixels per frame), the default here: each frame of a stack gets its own shifted crop of
      the sample's image, so the overlaid background moves across the stack;
    * the encoder stacks frames at feature level, :class:`~vigen.models.PerFrameEncoder`
      (``make_loss("simgrl", ...)`` builds it, on ``x / 255`` as SimGRL); any encoder can be passed.

    The update is :class:`~vigen.losses.SACSVEALoss`'s as SimGRL's code has it: with
    ``s = shift(obs)`` and ``s' = shift(next obs)`` (its ``sample_drq``: both shifted, the
    default ``augment_next=True`` here), ``loss_critic = 0.5·[MSE(Q1(s̃), y) + MSE(Q2(s̃), y) +
    MSE(Q1(s), y) + MSE(Q2(s), y)]`` against the SAC target ``y`` of ``s'`` (sampled on the online
    encoder, scored on the target encoder), ``loss_actor`` and ``loss_alpha`` on the detached
    features of ``s``. SimGRL's ablations are the same loss with other parts: ``SharedCNN`` as
    encoder (its "SimGRL-S") or ``strong_augmentation=RandomOverlay()`` (its "SimGRL-F").

    Departures from SimGRL's code (measured in ``benchmarks/parity.py``): those of
    :class:`~vigen.losses.SACSVEALoss` (one optimizer step for all terms, one τ).

    Paper: SimGRL (NeurIPS 2024; no arXiv version), https://openreview.net/forum?id=0AumdfLzpK
    (code: https://github.com/W-Song11/SimGRL-Code).

    Args:
        encoder, actor, critic: as in :class:`~vigen.losses.SACSVEALoss`.
        strong_augmentation: the strong view; ``None`` for ``RandomShiftedOverlay(alpha=0.5, max_shift=6)``
            with vigen's built-in image bank (pass ``RandomShiftedOverlay(images=<Places365 folder>)``
            for the paper's images).
        augment_next: shift the next observation (SimGRL: yes).
        **kwargs: the options of :class:`~vigen.losses.SACSVEALoss` (alpha, beta, augmentation, ...).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import make_loss
        >>> loss = make_loss("simgrl", (9, 84, 84), action_dim=2, hidden_dim=32, seed=0)
        >>> loss.strong_augmentation[0]
        RandomShiftedOverlay(alpha=0.5, max_shift=6, images=builtin, in_keys=['pixels'], seed=1)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> batch = TensorDict({
        ...     "pixels": pixels, "action": torch.zeros(4, 2),
        ...     "next": {"pixels": pixels, "reward": torch.ones(4, 1),
        ...              "done": torch.zeros(4, 1, dtype=torch.bool),
        ...              "terminated": torch.zeros(4, 1, dtype=torch.bool)},
        ... }, batch_size=[4])
        >>> out = loss(batch)
        >>> out["loss_critic"].requires_grad, out["q_strong_mean"].requires_grad
        (True, False)
    """

    def __init__(self, *args: Any, augment_next: bool = True, **kwargs: Any) -> None:
        super().__init__(*args, augment_next=augment_next, **kwargs)

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return RandomShiftedOverlay(alpha=0.5, max_shift=6)

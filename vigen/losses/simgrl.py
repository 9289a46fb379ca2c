"""SimGRL: SVEA with a shifted random overlay as its strong view, on a per-frame encoder."""

from __future__ import annotations

from vigen.losses.base import Augmentations
from vigen.losses.svea import SVEALoss
from vigen.transforms import RandomShiftedOverlay


class SimGRLLoss(SVEALoss):
    """SimGRL on vigen's SVEA: ``0.5·TD(s) + 0.5·TD(shifted_overlay(s))`` with ``s = shift(obs)``.

    SimGRL changes two things in SVEA, both outside the update's formula:

    * the strong view is :class:`~vigen.transforms.RandomShiftedOverlay` (α = 0.5, shifts up to 6
      pixels per frame), the default here: each frame of a stack gets its own shifted crop of
      the sample's image, so the overlaid background moves across the stack;
    * the encoder stacks frames at feature level, :class:`~vigen.models.PerFrameEncoder`
      (``make_loss("simgrl", ...)`` builds it); any encoder can be passed.

    The critic loss is SimGRL's ``0.5·[MSE(Q1(s̃), y) + MSE(Q2(s̃), y) + MSE(Q1(s), y) + MSE(Q2(s), y)]``,
    which is SVEA's ``α·TD(s) + β·TD(s̃)`` with α = β = 0.5 (the defaults), against the target
    ``y`` of ``shift(next obs)``. The actor reads the clean view ``s``. SimGRL's ablations are
    the same loss with other parts: ``SharedCNN`` as encoder (its "SimGRL-S") or
    ``strong_augmentation=RandomOverlay()`` (its "SimGRL-F").

    Departure from the original: SimGRL is written on DMC-GB's SVEA, a SAC agent with a target
    encoder and its own optimizers; here it runs on vigen's SVEA, DrQ-v2's DDPG update
    (RL-ViGen's SVEA), whose target is computed by the online encoder, with DrQ-v2's actor and
    critic heads.

    Paper: SimGRL (NeurIPS 2024; no arXiv version), https://openreview.net/forum?id=0AumdfLzpK.

    Args:
        encoder, actor, critic: as in :class:`SVEALoss`.
        strong_augmentation: the strong view; ``None`` for ``RandomShiftedOverlay(alpha=0.5, max_shift=6)``
            with vigen's built-in image bank (pass ``RandomShiftedOverlay(images=<Places365 folder>)``
            for the paper's images).
        alpha, beta: weights of the clean and strong views' TD losses (0.5 each).
        **kwargs: the options of :class:`~vigen.losses.DrQv2Loss` (augmentation, std, ...).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.models import Actor, Critic, PerFrameEncoder
        >>> encoder = PerFrameEncoder(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = SimGRLLoss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32))
        >>> loss.strong_augmentation[0]
        RandomShiftedOverlay(alpha=0.5, max_shift=6, images=builtin, in_keys=['pixels'])
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

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return RandomShiftedOverlay(alpha=0.5, max_shift=6)

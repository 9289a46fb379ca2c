"""SRM: SVEA whose strong view also loses a random ring of spatial frequencies."""

from __future__ import annotations

from vigen.losses.drqv2 import Augmentations
from vigen.losses.svea import SVEALoss
from vigen.transforms import RandomFrequencyMask, RandomOverlay


class SRMLoss(SVEALoss):
    """SRM as in RL-ViGen: SVEA with the strong view ``SRM(overlay(shift(obs)))``.

    The frequency mask is RL-ViGen's ``random_mask_freq_v2``: with probability 0.5 per batch, one
    square ring of spatial frequencies (inner edge ≤ 0.5, width ≤ 0.05 cycles/pixel) is zeroed
    in every image of the batch. The SRM paper's own agents apply the mask without the overlay:
    pass ``strong_augmentation=RandomFrequencyMask()`` (and ``per_sample=True, fill="noise"`` for
    its per-image rings filled with noise). Everything else is :class:`SVEALoss` (α = β = 0.5).

    Papers: SRM (Huang et al., NeurIPS 2022),
    https://proceedings.neurips.cc/paper_files/paper/2022/hash/802a4350ca4fced76b13b8b320af1543-Abstract-Conference.html;
    RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        encoder, actor, critic, strong_augmentation, alpha, beta, **kwargs: as in :class:`SVEALoss`;
            the default ``strong_augmentation`` is ``[RandomOverlay(), RandomFrequencyMask()]``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.models import Actor, Critic, SharedCNN
        >>> encoder = SharedCNN(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = SRMLoss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> [type(t).__name__ for t in loss.strong_augmentation]
        ['RandomOverlay', 'RandomFrequencyMask']
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> batch = TensorDict({
        ...     "pixels": pixels, "action": torch.zeros(4, 2),
        ...     "next": {"pixels": pixels, "reward": torch.ones(4, 1),
        ...              "done": torch.zeros(4, 1, dtype=torch.bool),
        ...              "terminated": torch.zeros(4, 1, dtype=torch.bool)},
        ... }, batch_size=[4])
        >>> loss(batch)["loss_critic"].shape
        torch.Size([])
    """

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return [RandomOverlay(alpha=0.5), RandomFrequencyMask()]

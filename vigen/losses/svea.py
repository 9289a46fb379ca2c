"""SVEA: DrQ-v2's update with a second, strongly augmented view in the critic loss."""

from __future__ import annotations

from typing import Any

from torch import nn

from vigen.losses.base import Augmentations, Observations, View
from vigen.losses.drqv2 import DrQv2Loss
from vigen.transforms import RandomOverlay


class SVEALoss(DrQv2Loss):
    """SVEA on DrQ-v2 (RL-ViGen's variant): ``α·TD(weak view) + β·TD(strong view)``.

    The weak view is ``s = shift(obs)``; the strong view ``s̃ = strong(s)`` is built on top of it.
    Both are scored against the same target ``y`` from the weak view of the next observation:

        ``loss_critic = α·[MSE(Q1(s), y) + MSE(Q2(s), y)] + β·[MSE(Q1(s̃), y) + MSE(Q2(s̃), y)]``

    with α = β = 0.5. Both views go through the encoder with gradient, batched into one pass
    (as DMC-GB concatenates them). The actor sees the weak view only.

    RL-ViGen's SVEA uses the random overlay as strong augmentation (the default here): the blend
    ``0.5·x + 0.5·image`` of uint8 frames is rounded back to uint8 (the originals blend floats, a
    difference of at most half a grey level). DMC-GB's
    original uses random convolution: pass ``strong_augmentation=RandomConv()``. Either way the
    encoder in the papers is the 11-layer :class:`~vigen.models.SharedCNN`.

    Paper: SVEA, https://arxiv.org/abs/2107.00644.

    Args:
        encoder, actor, critic: as in :class:`DrQv2Loss`.
        strong_augmentation: applied on top of the weak view; default ``RandomOverlay(alpha=0.5)``
            with vigen's built-in image bank (pass ``RandomOverlay(images=<Places365 folder>)``
            for the papers' images).
        alpha: weight of the weak view's TD loss.
        beta: weight of the strong view's TD loss.
        **kwargs: the options of :class:`DrQv2Loss` (augmentation, std, ...).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.models import Actor, Critic, SharedCNN
        >>> encoder = SharedCNN(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = SVEALoss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32))
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

    out_keys = DrQv2Loss.out_keys + ["q_strong_mean"]

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        strong_augmentation: Augmentations = None,
        alpha: float = 0.5,
        beta: float = 0.5,
        **kwargs: Any,
    ) -> None:
        super().__init__(encoder, actor, critic, **kwargs)
        if strong_augmentation is None:
            strong_augmentation = self._default_strong_augmentation()
        self.strong_augmentation = self._augmentations(strong_augmentation)
        self.register_coeff_buffer("alpha", alpha)
        self.register_coeff_buffer("beta", beta)

    _schedulable_buffers = frozenset({"alpha", "beta"})

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return RandomOverlay(alpha=0.5)

    def critic_views(self, batch: Observations) -> list[View]:
        """The weak view with weight α and its strongly augmented copy with weight β."""
        strong = self._augment(self.strong_augmentation, batch.obs)
        return [View(batch.obs, self.alpha), View(strong, self.beta, name="strong")]

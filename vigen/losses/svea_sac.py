"""SVEA as its paper's code runs it: DMC-GB's SAC agent with a strongly augmented view in the critic loss."""

from __future__ import annotations

from typing import Any, Literal

from tensordict import TensorDictBase
from torch import Tensor, nn

from vigen.losses.base import ActorCriticLoss, Augmentations, Observations, View, default_shift
from vigen.losses.sac import SoftActorCritic
from vigen.transforms import RandomConv


class SACSVEALoss(SoftActorCritic, ActorCriticLoss):
    """SVEA on DMC-GB's SAC (the SVEA paper's code; MaDi and SimGRL are written on it).

    With the weak view ``s = shift(obs)``, the strong view ``s̃ = strong(s)`` and the SAC target
    ``y = r + γⁿ·(1 − terminated)·[min(Q1', Q2')(h'_T, a') − α·log π(a'|h')]`` of the next
    observation (``a'`` sampled on the online encoder's ``h'``, scored on the target encoder's
    ``h'_T``: DMC-GB's target critic holds its own encoder):

    * ``loss_critic = α_SVEA·TD(s) + β_SVEA·TD(s̃)`` with ``TD = (Q1 − y)² + (Q2 − y)²``, both
      views in one encoder pass (DMC-GB concatenates them when α = β);
    * ``loss_actor = α·log π(ã|h) − min(Q1, Q2)(h, ã)`` on the detached features of ``s``;
    * ``loss_alpha = α·(−log π(ã|h) − H̄)``.

    DMC-GB's details are the defaults: the next observation is not shifted (its
    ``sample_svea``; ``augment_next=True`` shifts it, as ``sample_drq`` does for SimGRL), the
    strong view is the random convolution, log π uses ``log(relu(1 − tanh²) + 1e-6)``. Build it
    on DMC-GB's networks (SVEA's 11-layer CNN on ``x / 255``: ``SharedCNN(centered=False)``; the
    critic's and the actor's own Linear → LayerNorm → Tanh projections: :class:`~vigen.models.Critic`
    and :class:`~vigen.models.GaussianActor` with ``feature_dim``). :class:`~vigen.losses.SVEALoss`
    is RL-ViGen's SVEA, on DrQ-v2's DDPG.

    Departures from DMC-GB (measured through MaDi's and SimGRL's rows of ``benchmarks/parity.py``):
    DMC-GB steps the critic, then the actor and temperature, each with its own Adam and the
    actor every second update; here every term comes from the batch's parameters and one
    optimizer step takes them all. ``SoftUpdate`` has one τ (DMC-GB: 0.01 for the Q heads,
    0.05 for the encoder and the critic's projection).

    Paper: SVEA, https://arxiv.org/abs/2107.00644 (code: DMC-GB,
    https://github.com/nicklashansen/dmcontrol-generalization-benchmark).

    Args:
        encoder: pixels → features.
        actor: features → (mean, log σ), e.g. :class:`~vigen.models.GaussianActor`.
        critic: (features, action) → (Q1, Q2).
        augmentation: the weak view; ``"default"`` is ``RandomShift(pad=4)``.
        strong_augmentation: the strong view; ``None`` for ``RandomConv()`` (DMC-GB's SVEA).
        alpha, beta: weights of the weak and strong views' TD errors (0.5 each).
        augment_next: shift the next observation too (``False``: DMC-GB's SVEA).
        target_encoder, squash_epsilon, init_temperature, target_entropy: see
            :class:`~vigen.losses.SoftActorCritic` (here: ``True``, ``1e-6``, 0.1, ``"auto"``).
        **kwargs: ``input_mask``, ``channels_last``, ``reduction``, ``check_finite``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.models import Critic, GaussianActor, SharedCNN
        >>> encoder = SharedCNN(9, centered=False)
        >>> features = encoder.output_dim(9, 84, 84)
        >>> loss = SACSVEALoss(encoder, GaussianActor(features, 2, hidden_dim=32, feature_dim=50),
        ...                    Critic(features, 2, hidden_dim=32))
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
        alpha: float = 0.5,
        beta: float = 0.5,
        augment_next: bool = False,
        target_encoder: bool = True,
        squash_epsilon: float | None = 1e-6,
        **kwargs: Any,
    ) -> None:
        augmentation = default_shift(augmentation)
        super().__init__(encoder, actor, critic, augmentation=augmentation, target_encoder=target_encoder,
                         squash_epsilon=squash_epsilon, **kwargs)
        if strong_augmentation is None:
            strong_augmentation = self._default_strong_augmentation()
        self.strong_augmentation = self._augmentations(strong_augmentation)
        self.augment_next = bool(augment_next)
        self.register_coeff_buffer("svea_alpha", alpha)
        self.register_coeff_buffer("svea_beta", beta)

    _schedulable_buffers = frozenset({"svea_alpha", "svea_beta"})

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return RandomConv()

    def observations(self, tensordict: TensorDictBase) -> Observations:
        """The weak view of obs; of next obs too only with ``augment_next`` (DMC-GB's SVEA leaves it as stored)."""
        keys = self.tensor_keys
        pixels, next_pixels = tensordict.get(keys.pixels), tensordict.get(("next", keys.pixels))
        obs = self.augment(pixels)
        next_obs = self.augment(next_pixels) if self.augment_next else next_pixels
        return Observations(pixels, next_pixels, tensordict.get(keys.action), obs, next_obs)

    def critic_views(self, batch: Observations) -> list[View]:
        """The weak view (weight α) and its strong view (weight β)."""
        return [View(batch.obs, self.svea_alpha), View(self.strong_view(batch), self.svea_beta, name="strong")]

    def strong_view(self, batch: Observations) -> Tensor:
        """``strong(s)``, a fresh draw on the weak view (SCPL draws it in step 1, with the next observation's)."""
        return self._augment(self.strong_augmentation, batch.obs)

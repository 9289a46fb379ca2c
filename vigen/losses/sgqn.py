"""SGQN: saliency-guided Q-networks, on DrQ-v2's update."""

from __future__ import annotations

from typing import Any, Literal

import torch.nn.functional as F
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import nn

from vigen.losses.base import ActorCriticLoss, Augmentations, default_shift, squared_td_errors
from vigen.losses.samplers import NoisyDeterministic, Sampler
from vigen.losses.saliency import GuidedBackprop, GuidedForward, salient_q_consistency
from vigen.transforms import RandomOverlay


class SGQNLoss(ActorCriticLoss):
    """SGQN on DrQ-v2 (RL-ViGen's variant): a saliency-consistency term and an attribution head.

    With ``s = shift(obs)``:

    1. the guided-backprop saliency of Q1(s, a) with respect to the pixels of ``s`` gives, per
       sample and frame, a mask ``M`` of the pixels at or above the ``quantile`` of
       max-over-RGB ``|saliency|`` (:func:`~vigen.losses.attribution_mask`);
    2. ``s_M = s·M + u·(1 − M)``, with one ``u ~ U(min s, max s)`` for the batch;
    3. ``loss_critic = TD(s) + λ·[MSE(Q1(s), Q1(s_M)) + MSE(Q2(s), Q2(s_M))]``, gradients on both
       sides of the consistency term;
    4. ``loss_attribution = BCE(decoder(encoder(overlay(s)), a), M)``: the attribution head
       learns to predict the mask from an overlaid view; its gradient reaches the shared encoder.

    The saliency reuses the critic's own forward pass (one input-only backward pass on top). In
    RL-ViGen the attribution step comes after the critic step: it recomputes the mask with the
    updated critic and steps the encoder a second time, with its own Adam (``aux_lr`` 1e-4, betas
    (0.99, 0.999)). Here both terms use the mask of the same parameters and one ``backward()``,
    as everything in one call of a TorchRL loss does.

    Defaults follow RL-ViGen: ``quantile=0.93``, ``consistency_weight=0.9``. The original SGQN
    uses ``quantile=0.9`` (0.98 for cartpole) and ``consistency_weight=0.5``; RL-ViGen's Adroit
    branch also uses 0.5. The encoder in both is :class:`~vigen.models.ProjectedEncoder` (512-d),
    the head :class:`~vigen.models.AttributionDecoder`. Guided backprop runs through the
    ``nn.ReLU`` modules of the encoder and critic.

    Paper: SGQN, https://arxiv.org/abs/2209.09203.

    Args:
        encoder, actor, critic: as in :class:`DrQv2Loss`.
        decoder: the attribution head, ``(embedding, action) → mask logits [B, 3·k, H, W]``.
        quantile: saliency quantile of the mask, per frame.
        consistency_weight: λ.
        attribution_augmentation: the view the head predicts from; default ``RandomOverlay()``.
        sampler: DrQ-v2's :class:`~vigen.losses.NoisyDeterministic` (its default) or
            :class:`~vigen.losses.SquashedGaussian`.
        augmentation: the weak view; ``"default"`` is ``RandomShift(pad=4)``.
        **kwargs: ``input_mask``, ``channels_last``, ``reduction``, ``check_finite`` (see
            :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import example_batch
        >>> from vigen.models import Actor, AttributionDecoder, Critic, ProjectedEncoder
        >>> encoder = ProjectedEncoder(9, image_size=84)
        >>> loss = SGQNLoss(encoder, Actor(512, 2, hidden_dim=32), Critic(512, 2, hidden_dim=32),
        ...                 AttributionDecoder(action_dim=2))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> round(out["mask_fraction"].item(), 2)  # the top 7 % of each frame
        0.07
    """

    own_out_keys = ("loss_attribution", "mask_fraction", "consistency")
    _schedulable_buffers = frozenset({"consistency_weight"})

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        decoder: nn.Module,
        *,
        sampler: Sampler | None = None,
        augmentation: Augmentations | Literal["default"] = "default",
        quantile: float = 0.93,
        consistency_weight: float = 0.9,
        attribution_augmentation: Augmentations = None,
        **kwargs: Any,
    ) -> None:
        if not 0.0 <= quantile <= 1.0:
            raise ValueError(f"quantile must be in [0, 1], got {quantile}.")
        super().__init__(encoder, actor, critic, sampler=NoisyDeterministic() if sampler is None else sampler,
                         augmentation=default_shift(augmentation), **kwargs)
        GuidedBackprop(encoder, critic)  # fails early, with advice, when there is no nn.ReLU to guide
        self.decoder = decoder
        self.quantile = quantile
        self.register_coeff_buffer("consistency_weight", consistency_weight)
        self.attribution_augmentation = self._augmentations(
            RandomOverlay(alpha=0.5) if attribution_augmentation is None else attribution_augmentation)
        self.guided_forward: GuidedForward | None = None

    def prepare_compile(self) -> None:
        """Install the guided pass a compiled update takes its saliency from (:class:`~vigen.losses.GuidedForward`)."""
        if self.guided_forward is None:
            self.guided_forward = GuidedForward(self.encoder, self.critic)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        obs, next_obs = self.augment(batch.pixels), self.augment(batch.next_pixels)
        target = self.critic_target(tensordict, next_obs)
        # the critic: TD loss of s plus λ· the consistency of Q on s and on its salient pixels s_M (mask M)
        salient = salient_q_consistency(self, obs, batch.action, self.quantile, self.guided_forward)
        loss_critic = squared_td_errors(salient.q1, salient.q2, target) + self.consistency_weight * salient.consistency
        loss_actor, log_prob = self.actor_loss(salient.features.detach())
        # the attribution head learns to predict M from an overlaid view of s (its gradient reaches the encoder)
        overlaid = self.augment(obs, self.attribution_augmentation)
        logits = self.decoder(self.encode(overlaid), batch.action)
        attribution = F.binary_cross_entropy_with_logits(logits, salient.mask.to(logits.dtype), reduction="none")
        return self.output(tensordict, target, salient.q1, salient.q2,
                           {"loss_critic": loss_critic, "loss_actor": loss_actor,
                            "loss_attribution": attribution.flatten(1).mean(1)},
                           {"mask_fraction": salient.mask.float().mean(), "consistency": salient.consistency.mean()},
                           log_prob=log_prob)

"""SGQN: saliency-guided Q-networks, on DrQ-v2's update."""

from __future__ import annotations

from typing import Any

import torch.nn.functional as F
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import nn

from vigen.losses.base import Augmentations, squared_td_errors
from vigen.losses.saliency import SalientQLoss


class SGQNLoss(SalientQLoss):
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

    ``make_loss("sgqn")`` follows RL-ViGen: ``quantile=0.93``, ``consistency_weight=0.9``. The original SGQN
    uses ``quantile=0.9`` (0.98 for cartpole) and ``consistency_weight=0.5``; RL-ViGen's Adroit
    branch also uses 0.5. The encoder in both is :class:`~vigen.models.ProjectedEncoder` (512-d),
    the head :class:`~vigen.models.AttributionDecoder`. Guided backprop runs through the
    ``nn.ReLU`` modules of the encoder and critic.

    Paper: SGQN, https://arxiv.org/abs/2209.09203.

    Args:
        encoder, actor, critic: as in :class:`DrQv2Loss`.
        decoder: the attribution head, ``(embedding, action) → mask logits [B, 3·k, H, W]``.
        quantile: saliency quantile of the mask, per frame (:class:`~vigen.losses.saliency.SalientQLoss`).
        consistency_weight: λ.
        attribution_augmentation: the view the head predicts from (RL-ViGen: ``RandomOverlay(alpha=0.5)``).
        **options: ``sampler`` (RL-ViGen: DrQ-v2's :class:`~vigen.losses.NoisyDeterministic`),
            ``augmentation`` (the weak view), ``target_encoder`` (RL-ViGen: none), ``input_mask``,
            ``param_groups``, ``channels_last``, ``reduction``, ``check_finite`` (see
            :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import build_loss, example_batch
        >>> from vigen.models import Actor, AttributionDecoder, Critic, ProjectedEncoder
        >>> encoder = ProjectedEncoder(9, image_size=84)
        >>> loss = build_loss("sgqn", encoder, Actor(512, 2, hidden_dim=32), Critic(512, 2, hidden_dim=32),
        ...                   AttributionDecoder(action_dim=2))  # RL-ViGen's options
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> round(out["mask_fraction"].item(), 2)  # the top 7 % of each frame
        0.07
    """

    own_out_keys = ("loss_attribution", "mask_fraction", "consistency")

    def __init__(self, encoder: nn.Module, actor: nn.Module, critic: nn.Module, decoder: nn.Module, *,
                 attribution_augmentation: Augmentations, **options: Any) -> None:
        super().__init__(encoder, actor, critic, **options)
        self.decoder = decoder
        self.attribution_augmentation = self._augmentations(attribution_augmentation)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        obs, next_obs = self.augment(batch.pixels), self.augment(batch.next_pixels)
        target = self.critic_target(tensordict, next_obs)
        # the critic: TD loss of s plus λ· the consistency of Q on s and on its salient pixels s_M (mask M)
        salient = self.salient_q(obs, batch.action)
        loss_critic = squared_td_errors(salient.q1, salient.q2, target) + self.consistency_weight * salient.consistency
        loss_actor, log_prob = self.actor_loss(salient.features.detach())
        # the attribution head learns to predict M from an overlaid view of s (its gradient reaches the encoder)
        overlaid = self.augment(obs, self.attribution_augmentation)
        logits = self.decoder(self.encode(overlaid), batch.action)
        attribution = F.binary_cross_entropy_with_logits(logits, salient.mask.to(logits.dtype), reduction="none")
        return self.output(tensordict, target, salient.q1, salient.q2,
                           {"loss_critic": loss_critic, "loss_actor": loss_actor,
                            "loss_attribution": attribution.flatten(1).mean(1),
                            **self.sampler.temperature_losses(log_prob, batch.action_dim, views=1)},
                           {**self.sampler.metrics(self.schedule_step, log_prob),
                            "mask_fraction": salient.mask.float().mean(), "consistency": salient.consistency.mean()})

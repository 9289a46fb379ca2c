"""CURL: a contrastive auxiliary loss on the encoder, on DrQ-v2's update."""

from __future__ import annotations

from typing import Any

import torch
import torch.nn.functional as F
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import nn

from vigen.losses.base import ActorCriticLoss, Augmentations, squared_td_errors
from vigen.models import CURLHead


class CURLLoss(ActorCriticLoss):
    """CURL on DrQ-v2 (RL-ViGen's variant): InfoNCE with a bilinear similarity over the batch.

    Two more views of each observation are drawn with ``contrastive_augmentation``: the anchor
    ``z_a = encoder(aug₁(obs))`` (with gradient) and the positive ``z_p = encoder(aug₂(obs))``
    (without). With the logits ``z_a·W·z_pᵀ`` (``[B, B]``, minus each row's maximum),

        ``loss_curl = CrossEntropy(logits, labels=arange(B))``:

    each anchor must pick its own positive among the batch. The critic gets its own shifted view,
    encoded in the same pass as the anchors.

    RL-ViGen's agent takes this step after the critic step: it encodes the anchor with the
    encoder the critic step has just moved and steps the encoder a second time, with its own
    Adam (``aux_lr`` 1e-4, betas (0.99, 0.999)). Here both losses come from one set of
    parameters and one ``backward()``, as a TorchRL loss does; ``examples/train.py`` steps one
    Adam over all parameters. ``curl_accuracy`` is the fraction of anchors
    whose highest logit is their positive.

    RL-ViGen encodes the positives with the online encoder (``key_encoder=False``, ``make_loss("curl")``).
    The original CURL uses a momentum key encoder: ``key_encoder=True`` keeps one in
    ``target_encoder_params``, moved by the same ``SoftUpdate`` as the target critic (one τ for
    both; the original uses 0.05 for the key encoder and 0.01 for the critic). The original's
    views are random 84×84 crops of 100×100 renders: pass ``contrastive_augmentation=RandomCrop(84)``
    and ``augmentation=RandomCrop(84)`` on such a buffer. The encoder in both is
    :class:`~vigen.models.ProjectedEncoder` (512-d).

    Paper: CURL, https://arxiv.org/abs/2004.04136.

    Args:
        encoder, actor, critic: as in :class:`DrQv2Loss`.
        head: the bilinear head (:class:`~vigen.models.CURLHead`) of the encoder's output size.
        contrastive_augmentation: draws the anchor and positive views (RL-ViGen: ``RandomShift(pad=4)``).
        key_encoder: encode positives with a momentum copy of the encoder.
        **options: ``sampler`` (RL-ViGen: DrQ-v2's :class:`~vigen.losses.NoisyDeterministic`),
            ``augmentation`` (the critic's view), ``input_mask``, ``param_groups``, ``channels_last``,
            ``reduction``, ``check_finite`` (see :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import build_loss, example_batch
        >>> from vigen.models import Actor, CURLHead, Critic, ProjectedEncoder
        >>> encoder = ProjectedEncoder(9, image_size=84)
        >>> loss = build_loss("curl", encoder, Actor(512, 2, hidden_dim=32), Critic(512, 2, hidden_dim=32), CURLHead(512))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> sorted(key for key in loss(batch).keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_critic', 'loss_curl']
    """

    own_out_keys = ("loss_curl", "curl_accuracy")

    def __init__(self, encoder: nn.Module, actor: nn.Module, critic: nn.Module, head: CURLHead, *,
                 contrastive_augmentation: Augmentations, key_encoder: bool, **options: Any) -> None:
        super().__init__(encoder, actor, critic, target_encoder="keys" if key_encoder else False, **options)
        self.head = head
        self.contrastive_augmentation = self._augmentations(contrastive_augmentation)
        self.key_encoder = key_encoder

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        obs, next_obs = self.augment(batch.pixels), self.augment(batch.next_pixels)
        target = self.critic_target(tensordict, next_obs)
        anchor_view = self.augment(batch.pixels, self.contrastive_augmentation)
        features, anchor = self.encode_views([obs, anchor_view])  # one encoder pass
        q1, q2 = self.q_values(features, batch.action)
        loss_actor, log_prob = self.actor_loss(features.detach())
        with torch.no_grad():  # the positives: a second draw, on the key encoder if there is one
            keys = self.target_encoder_params if self.key_encoder else None
            positive = self.encode(self.augment(batch.pixels, self.contrastive_augmentation), params=keys)
        logits = self.head.logits(anchor, positive)
        labels = torch.arange(batch.size, device=logits.device)
        return self.output(tensordict, target, q1, q2,
                           {"loss_critic": squared_td_errors(q1, q2, target), "loss_actor": loss_actor,
                            "loss_curl": F.cross_entropy(logits, labels, reduction="none"),
                            **self.sampler.temperature_losses(log_prob, batch.action_dim, views=1)},
                           {**self.sampler.metrics(self.schedule_step, log_prob),
                            "curl_accuracy": (logits.argmax(dim=1) == labels).float().mean()})

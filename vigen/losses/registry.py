"""Build any of vigen's losses with the networks its paper uses, by name."""

from __future__ import annotations

from typing import Any

import torch

from torch import nn

from vigen.losses.base import ActorCriticLoss
from vigen.losses.curl import CURLLoss
from vigen.losses.drq import DrQLoss
from vigen.losses.drqv2 import DrQv2Loss
from vigen.losses.madi import MaDiLoss
from vigen.losses.pieg import PIEGLoss
from vigen.losses.sada import SADALoss
from vigen.losses.scpl import SCPLLoss
from vigen.losses.sgqn import SGQNLoss
from vigen.losses.simgrl import SimGRLLoss
from vigen.losses.srm import SRMLoss
from vigen.losses.svea import SVEALoss
from vigen.losses.vrl3 import VRL3Loss
from vigen.models import (
    Actor,
    AttributionDecoder,
    Critic,
    CURLHead,
    DrQv2Encoder,
    GaussianActor,
    LatentDynamics,
    PerFrameEncoder,
    PIEGEncoder,
    ProjectedEncoder,
    SharedCNN,
    VRL3Encoder,
)

ALGOS: dict[str, type[ActorCriticLoss]] = {
    "drqv2": DrQv2Loss,
    "svea": SVEALoss,
    "srm": SRMLoss,
    "sgqn": SGQNLoss,
    "curl": CURLLoss,
    "drq": DrQLoss,
    "sada": SADALoss,
    "vrl3": VRL3Loss,
    "madi": MaDiLoss,
    "simgrl": SimGRLLoss,
    "pieg": PIEGLoss,
    "scpl": SCPLLoss,
}
"""Algorithm name -> loss class."""


def make_loss(
    algo: str,
    observation_shape: tuple[int, int, int],
    action_dim: int,
    *,
    feature_dim: int = 50,
    hidden_dim: int = 1024,
    max_value: float | None = None,
    seed: int | None = None,
    device: torch.device | str | None = None,
    **loss_options: Any,
) -> ActorCriticLoss:
    """The loss of ``algo`` on fresh networks shaped as in RL-ViGen.

    Encoders: DrQ-v2's 4-layer CNN for ``drqv2`` and ``drq``; SVEA's 11-layer shared CNN for
    ``svea`` and ``srm``; the 4-layer CNN with a linear projection to 512 (an embedding for the
    attribution decoder and the contrastive head) for ``sgqn`` and ``curl``. Heads: the actor and
    twin critic with a ``feature_dim`` trunk and ``hidden_dim`` MLPs (DrQ's SAC actor has no
    trunk; SADA's, DMC-GB2's, has one); SGQN's attribution decoder; CURL's bilinear head.
    ``vrl3`` uses VRL3's small ResNet (:class:`~vigen.models.VRL3Encoder`; ``stage1_weights=path`` loads its
    stage-1 checkpoint, without it the encoder starts from random weights as in RL-ViGen).
    ``madi`` puts MaDi's masker in front of SVEA's CNN; ``simgrl`` uses SimGRL's per-frame encoder; both
    on DMC-GB's pixel scale ``x / 255`` with the SAC actor's own ``feature_dim`` trunk, as their code.
    ``pieg`` uses PIE-G's frozen ResNet-18 encoder (:class:`~vigen.models.PIEGEncoder`, output 1024);
    ``encoder_weights=path`` loads torchvision's ImageNet ResNet-18 state dict into it, which PIE-G's
    results need (without it the ResNet starts from random weights, with a warning).
    ``scpl`` uses SVEA's CNN on DMC-GB's pixel scale ``x / 255`` (``centered=False``), the SAC
    actor with its own ``feature_dim`` trunk (DMC-GB's actor projection; SCPL's is 100) and
    SCPL's :class:`~vigen.models.LatentDynamics` (512 hidden units) on the critic trunk's embedding.

    Args:
        algo: one of :data:`ALGOS`.
        observation_shape: ``(3·frames, height, width)`` of the pixels.
        action_dim: size of the action.
        feature_dim: the trunk's output size (50).
        hidden_dim: the MLPs' width (1024).
        max_value: the white of float pixels, given to the encoder and through it to the loss and
            its augmentations: ``None`` for uint8 pixels or TorchRL's ``ToTensorImage()`` floats on
            0–1, 255 for float pixels on the 0–255 scale (see :mod:`vigen.pixel_format`).
        seed: seeds every augmentation the loss owns (each its own stream, see
            :meth:`~vigen.losses.ActorCriticLoss.seed_augmentations`), so its views do not depend
            on the global RNG; ``None`` leaves them on torch's global RNG.
        device: where the networks live (default: the CPU); batches must come on it, and the
            policies of :meth:`~vigen.losses.ActorCriticLoss.make_policy` act there.
        **loss_options: keyword arguments of the loss class (e.g. ``std``, ``strong_augmentation``).

    Examples:
        >>> from vigen.losses import make_loss
        >>> loss = make_loss("svea", (9, 84, 84), action_dim=6, hidden_dim=64)
        >>> type(loss).__name__, type(loss.encoder).__name__
        ('SVEALoss', 'SharedCNN')
    """
    if algo not in ALGOS:
        raise ValueError(f"Unknown algorithm {algo!r}; choose one of {', '.join(ALGOS)}.")
    channels, height, width = observation_shape
    if height != width:
        raise ValueError(f"vigen's encoders take square images, got {height}×{width}; render at a square size.")
    encoder: nn.Module
    if algo in ("svea", "srm"):
        encoder = SharedCNN(channels, max_value=max_value)
    elif algo == "scpl":  # DMC-GB's SharedCNN scales pixels to x / 255
        encoder = SharedCNN(channels, max_value=max_value, centered=False)
    elif algo == "madi":  # DMC-GB's SharedCNN on x / 255; MaDiLoss builds its masker on the encoder's max_value
        encoder = SharedCNN(channels, max_value=max_value, centered=False)
    elif algo == "simgrl":  # SimGRL's per-frame encoder on x / 255
        encoder = PerFrameEncoder(channels, max_value=max_value, centered=False)
    elif algo == "vrl3":
        encoder = VRL3Encoder(channels, max_value=max_value, stage1_weights=loss_options.pop("stage1_weights", None))
    elif algo == "pieg":
        weights = loss_options.pop("encoder_weights", None)
        encoder = PIEGEncoder(channels, image_size=height, max_value=max_value, weights=weights)
    elif algo in ("sgqn", "curl"):
        encoder = ProjectedEncoder(channels, image_size=height, max_value=max_value)
    else:
        encoder = DrQv2Encoder(channels, max_value=max_value)
    features = encoder.output_dim(channels, height, width)
    critic = Critic(features, action_dim, feature_dim=feature_dim, hidden_dim=hidden_dim)
    loss: ActorCriticLoss
    if algo == "drq":
        actor = GaussianActor(features, action_dim, hidden_dim=hidden_dim)
        loss = DrQLoss(encoder, actor, critic, **loss_options)
    elif algo in ("sada", "scpl", "madi", "simgrl"):  # SAC actors with their own projection (DMC-GB, DMC-GB2)
        actor = GaussianActor(features, action_dim, hidden_dim=hidden_dim, feature_dim=feature_dim)
        if algo == "scpl":
            loss = SCPLLoss(encoder, actor, critic, LatentDynamics(feature_dim, action_dim), **loss_options)
        else:
            loss = ALGOS[algo](encoder, actor, critic, **loss_options)
    else:
        actor = Actor(features, action_dim, feature_dim=feature_dim, hidden_dim=hidden_dim)
        if algo == "sgqn":
            decoder = AttributionDecoder(action_dim, embedding_dim=features, out_channels=channels, image_size=height)
            loss = SGQNLoss(encoder, actor, critic, decoder, **loss_options)
        elif algo == "curl":
            loss = CURLLoss(encoder, actor, critic, CURLHead(features), **loss_options)
        else:
            loss = ALGOS[algo](encoder, actor, critic, **loss_options)
    if device is not None:
        loss.to(device)
    if seed is not None:
        loss.seed_augmentations(seed)
    return loss

"""Tiny networks and batches for the loss tests (16×16 frame stacks, two action dims)."""

from __future__ import annotations

import warnings
from typing import Any

import torch
from tensordict import TensorDict

from vigen.losses import ActorCriticLoss, build_loss
from vigen.models import (
    Actor,
    AttributionDecoder,
    Critic,
    CURLHead,
    DrQv2Encoder,
    GaussianActor,
    LatentDynamics,
    MaDiMasker,
    PerFrameEncoder,
    PIEGEncoder,
    ProjectedEncoder,
    VRL3Encoder,
)
from vigen.transforms import RandomShift

SIZE, ACTIONS, EMBEDDING = 16, 2, 16
LOSSES = ["drqv2", "svea", "srm", "sgqn", "curl", "drq", "sada", "madi", "simgrl", "vrl3", "pieg", "scpl"]
SAC_LOSSES = ("drq", "sada", "scpl", "madi", "simgrl")  # sample from their policy: no std


def make_loss(name: str, max_value: float | None = None, *, gaussian: bool | None = None, **kwargs: Any) -> ActorCriticLoss:
    """A loss of each kind on networks small enough for unit tests (``max_value`` goes to the encoder).

    The loss is :func:`~vigen.losses.build_loss`'s: the algorithm's record, with a 1-pixel shift
    (16×16 frames) and ``kwargs`` over it. ``gaussian``: a SAC actor (mean, log σ) rather than a
    deterministic one; default: the algorithm's.
    """
    kwargs.setdefault("augmentation", RandomShift(pad=1))
    scale = {} if max_value is None else {"max_value": max_value}
    if name in ("sgqn", "curl"):
        encoder = ProjectedEncoder(9, image_size=SIZE, out_dim=EMBEDDING, **scale)
    elif name == "simgrl":  # per-frame convs 3→4→4, stacked 12→8: 8×3×3 features
        encoder = PerFrameEncoder(9, num_layers=3, frame_layers=2, frame_filters=4, channels=8, **scale)
    elif name == "vrl3":  # stem 9→4, stages 4, 8, 16, 32: 32 pooled features
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # random weights (no stage-1 checkpoint), as in RL-ViGen
            encoder = VRL3Encoder(9, channels=4, **scale)
    elif name == "pieg":  # ResNet-18 to layer2 on 16×16 frames: 128×2×2 maps, 4 of them, Linear to 16
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # random ResNet weights (no ImageNet file in tests)
            encoder = PIEGEncoder(9, image_size=SIZE, out_dim=EMBEDDING, **scale)
    else:
        encoder = DrQv2Encoder(9, **scale)
    features = encoder.output_dim(9, SIZE, SIZE)
    critic = Critic(features, ACTIONS, feature_dim=8, hidden_dim=16)
    if name in SAC_LOSSES if gaussian is None else gaussian:  # DrQ's and DMC-GB2's SAC actors have no trunk
        actor = GaussianActor(features, ACTIONS, hidden_dim=16, **({} if name in ("drq", "sada") else {"feature_dim": 8}))
    else:
        actor = Actor(features, ACTIONS, feature_dim=8, hidden_dim=16)
    extra = {
        "sgqn": lambda: {"decoder": AttributionDecoder(ACTIONS, embedding_dim=EMBEDDING, image_size=SIZE)},
        "curl": lambda: {"head": CURLHead(EMBEDDING)},
        "madi": lambda: {"input_mask": MaDiMasker(num_filters=4, max_value=max_value)},
        "scpl": lambda: {"dynamics": LatentDynamics(8, ACTIONS, hidden_dim=16)},
    }.get(name, dict)()
    loss = build_loss(name, encoder, actor, critic, **extra, **kwargs)  # the algorithm's record for what is not given
    loss.make_value_estimator(gamma=0.9)
    return loss


def make_batch(batch: int = 6, seed: int = 0, **next_entries: torch.Tensor) -> TensorDict:
    """A replay-buffer-like batch: uint8 pixels, actions in [-1, 1], rewards and flags."""
    generator = torch.Generator().manual_seed(seed)
    pixels = torch.randint(0, 256, (batch, 9, SIZE, SIZE), dtype=torch.uint8, generator=generator)
    next_pixels = torch.randint(0, 256, (batch, 9, SIZE, SIZE), dtype=torch.uint8, generator=generator)
    nxt = {
        "pixels": next_pixels,
        "reward": torch.rand(batch, 1, generator=generator),
        "done": torch.zeros(batch, 1, dtype=torch.bool),
        "terminated": torch.zeros(batch, 1, dtype=torch.bool),
    }
    nxt.update(next_entries)
    action = torch.rand(batch, ACTIONS, generator=generator) * 2 - 1
    return TensorDict({"pixels": pixels, "action": action, "next": nxt}, batch_size=[batch])



def dmcgb_squashed_sample(mean: torch.Tensor, log_std: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """DMC-GB's actor, written out: u = μ + σ·ε, a = tanh(u), log π = log N(u; μ, σ) − Σ log(relu(1 − a²) + 1e-6)."""
    u = mean + log_std.exp() * torch.randn_like(mean)
    action = torch.tanh(u)
    log_prob = torch.distributions.Normal(mean, log_std.exp()).log_prob(u) - torch.log(torch.relu(1 - action**2) + 1e-6)
    return action, log_prob.sum(-1, keepdim=True)

"""Every algorithm of vigen by name: its loss, its paper's networks and the defaults that make it that paper's.

SRM, MaDi and SimGRL are SVEA with other parts, so they are presets of :class:`~vigen.losses.SVEALoss`
here, not classes:

* **SRM** (RL-ViGen's): SVEA whose strong view also loses a random ring of spatial frequencies,
  ``SRM(overlay(shift(obs)))`` (RL-ViGen's ``random_mask_freq_v2``: with probability 0.5 per
  batch one square ring, inner edge ≤ 0.5, width ≤ 0.05 cycles/pixel, zeroed in every image).
  The SRM paper's own agents apply the mask without the overlay (pass
  ``strong_augmentation=RandomFrequencyMask()``, and ``per_sample=True, fill="noise"`` for its
  per-image rings filled with noise). Paper: Huang et al., NeurIPS 2022,
  https://proceedings.neurips.cc/paper_files/paper/2022/hash/802a4350ca4fced76b13b8b320af1543-Abstract-Conference.html.
* **MaDi**: SVEA on DMC-GB's SAC with :class:`~vigen.models.MaDiMasker` in front of the encoder
  (the loss's ``input_mask``: every view, the target encoder's passes and the acting policy). The
  masker learns from the critic's TD error alone (the actor's features are detached, the target
  carries no gradient), with its own Adam group: ``masker_lr`` 1e-3, ``masker_beta`` (β1) 0.9.
  The next observation is not shifted (DMC-GB's ``sample_svea``); the strong view is the random
  overlay; binary ("hard") masks are not offered. Paper: https://arxiv.org/abs/2312.15339 (code:
  https://github.com/bramgrooten/mask-distractions).
* **SimGRL**: SVEA on DMC-GB's SAC whose strong view is :class:`~vigen.transforms.RandomShiftedOverlay`
  (α = 0.5, shifts up to 6 pixels per frame: the overlaid background moves across the stack), on
  :class:`~vigen.models.PerFrameEncoder` (frames stacked at feature level), both observations
  shifted (its ``sample_drq``). Its ablations are the same loss with other parts: ``SharedCNN``
  (its "SimGRL-S") or ``strong_augmentation=RandomOverlay()`` (its "SimGRL-F"). Paper: NeurIPS
  2024, https://openreview.net/forum?id=0AumdfLzpK (code: https://github.com/W-Song11/SimGRL-Code).

DMC-GB's SAC (MaDi, SimGRL, SCPL) uses SVEA's 11-layer CNN on ``x / 255``, a target encoder in
the target critic, ``log(relu(1 − tanh²) + 1e-6)`` and the actor's own ``feature_dim``
projection; the departures of all SAC presets from their code (one optimizer step for all terms,
one τ) are measured in ``benchmarks/parity``.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any, Literal

import torch
from torch import nn

from vigen.losses.base import ActorCriticLoss
from vigen.losses.curl import CURLLoss
from vigen.losses.drq import DrQLoss
from vigen.losses.drqv2 import DrQv2Loss
from vigen.losses.pieg import PIEGLoss
from vigen.losses.policies import ActingPolicy, NoisyDeterministic, SquashedGaussian
from vigen.losses.sada import SADALoss
from vigen.losses.scpl import SCPLLoss
from vigen.losses.sgqn import SGQNLoss
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
    MaDiMasker,
    PerFrameEncoder,
    PIEGEncoder,
    ProjectedEncoder,
    SharedCNN,
    VRL3Encoder,
)
from vigen.transforms import RandomFrequencyMask, RandomOverlay, RandomShiftedOverlay

EncoderName = Literal["drqv2", "shared_cnn", "shared_cnn_01", "per_frame", "projected", "vrl3", "pieg"]
ActorName = Literal["deterministic", "gaussian", "gaussian_projected"]
PolicyName = Literal["noisy", "sac"]

NOISY_OPTIONS = ("std", "std_clip")
SAC_OPTIONS = ("init_temperature", "target_entropy", "squash_epsilon")


@dataclass(frozen=True)
class Algorithm:
    """One algorithm: the loss class, the networks of its paper, its acting policy and its preset options.

    Attributes:
        loss: the loss class.
        encoder: the encoder, by name (see :func:`make_encoder`).
        actor: ``"deterministic"`` (:class:`~vigen.models.Actor`), ``"gaussian"`` (DrQ's SAC actor,
            no trunk) or ``"gaussian_projected"`` (the SAC actor with its own ``feature_dim`` trunk).
        policy: ``"noisy"`` (:class:`~vigen.losses.NoisyDeterministic`) or ``"sac"``
            (:class:`~vigen.losses.SquashedGaussian`).
        policy_defaults: the policy's options in the paper (VRL3: std 0.01; DMC-GB: ``squash_epsilon`` 1e-6).
        presets: loss options that make the loss this paper's, as factories (a fresh augmentation per loss).
        summary: one line for listings.
    """

    loss: type[ActorCriticLoss]
    encoder: EncoderName
    actor: ActorName
    policy: PolicyName
    summary: str
    policy_defaults: Mapping[str, Any] = field(default_factory=dict)
    presets: Mapping[str, Callable[[], Any]] = field(default_factory=dict)

    @property
    def takes_std(self) -> bool:
        """Whether the acting noise has a std schedule (DrQ-v2's DDPG) rather than SAC's temperature."""
        return self.policy == "noisy"


DMCGB_SAC = dict(squash_epsilon=1e-6)

ALGOS: dict[str, Algorithm] = {
    "drqv2": Algorithm(DrQv2Loss, "drqv2", "deterministic", "noisy", "DrQ-v2: DDPG with random shifts"),
    "svea": Algorithm(SVEALoss, "shared_cnn", "deterministic", "noisy", "SVEA on DrQ-v2 (RL-ViGen): an overlaid view in the critic"),
    "srm": Algorithm(SVEALoss, "shared_cnn", "deterministic", "noisy", "SRM (RL-ViGen): SVEA with a frequency-masked strong view",
                     presets={"strong_augmentation": lambda: [RandomOverlay(alpha=0.5), RandomFrequencyMask()]}),
    "sgqn": Algorithm(SGQNLoss, "projected", "deterministic", "noisy", "SGQN on DrQ-v2: saliency consistency and an attribution head"),
    "curl": Algorithm(CURLLoss, "projected", "deterministic", "noisy", "CURL on DrQ-v2: a contrastive encoder loss"),
    "drq": Algorithm(DrQLoss, "drqv2", "gaussian", "sac", "DrQ (RL-ViGen): SAC on a clean and a shifted view"),
    "sada": Algorithm(SADALoss, "drqv2", "gaussian_projected", "sac", "SADA (DMC-GB2): SAC, the actor also on the strong view"),
    "vrl3": Algorithm(VRL3Loss, "vrl3", "deterministic", "noisy", "VRL3 stage 3 (RL-ViGen Adroit): safe Q and a pre-tanh penalty",
                      policy_defaults={"std": 0.01}),
    "madi": Algorithm(SVEALoss, "shared_cnn_01", "gaussian_projected", "sac", "MaDi: SVEA (DMC-GB SAC) with a learned input masker",
                      policy_defaults=DMCGB_SAC,
                      presets={"augment_next": lambda: False, "target_encoder": lambda: True,
                               "strong_augmentation": lambda: RandomOverlay(alpha=0.5)}),
    "simgrl": Algorithm(SVEALoss, "per_frame", "gaussian_projected", "sac", "SimGRL: SVEA (DMC-GB SAC) with shifted overlays, per-frame encoder",
                        policy_defaults=DMCGB_SAC,
                        presets={"augment_next": lambda: True, "target_encoder": lambda: True,
                                 "strong_augmentation": lambda: RandomShiftedOverlay(alpha=0.5, max_shift=6)}),
    "pieg": Algorithm(PIEGLoss, "pieg", "deterministic", "noisy", "PIE-G: SVEA on a frozen ImageNet ResNet-18"),
    "scpl": Algorithm(SCPLLoss, "shared_cnn_01", "gaussian_projected", "sac",
                      "SCPL: SVEA (SAC) with saliency consistency, a policy KL and a dynamics model", policy_defaults=DMCGB_SAC),
}
"""Algorithm name -> :class:`Algorithm`."""


def make_encoder(name: EncoderName, channels: int, image_size: int, max_value: float | None,
                 options: dict[str, Any]) -> nn.Module:
    """The encoder ``name`` for ``channels``-deep square images; pops its own options (weights files) from ``options``."""
    if name == "shared_cnn":
        return SharedCNN(channels, max_value=max_value)
    if name == "shared_cnn_01":  # DMC-GB's SharedCNN scales pixels to x / 255
        return SharedCNN(channels, max_value=max_value, centered=False)
    if name == "per_frame":  # SimGRL's per-frame encoder on x / 255
        return PerFrameEncoder(channels, max_value=max_value, centered=False)
    if name == "vrl3":
        return VRL3Encoder(channels, max_value=max_value, stage1_weights=options.pop("stage1_weights", None))
    if name == "pieg":
        return PIEGEncoder(channels, image_size=image_size, max_value=max_value, weights=options.pop("encoder_weights", None))
    if name == "projected":
        return ProjectedEncoder(channels, image_size=image_size, max_value=max_value)
    return DrQv2Encoder(channels, max_value=max_value)


def make_policy_head(algo: str, options: dict[str, Any]) -> ActingPolicy:
    """The acting policy of ``algo`` with the paper's defaults; pops the policy's options (``std``, ``init_temperature``, ...)."""
    algorithm = ALGOS[algo]
    own, other = (NOISY_OPTIONS, SAC_OPTIONS) if algorithm.takes_std else (SAC_OPTIONS, NOISY_OPTIONS)
    wrong = [name for name in other if name in options]
    if wrong:
        kind = "DrQ-v2's noisy deterministic actor" if algorithm.takes_std else "its SAC policy"
        raise TypeError(f"{algorithm.loss.__name__} ({algo}) acts with {kind} and takes no {', '.join(map(repr, wrong))}; "
                        f"its policy options are {', '.join(own)}.")
    values = {**algorithm.policy_defaults, **{name: options.pop(name) for name in own if name in options}}
    if algorithm.takes_std:
        return NoisyDeterministic(**{"clip" if name == "std_clip" else name: value for name, value in values.items()})
    return SquashedGaussian(**values)


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
    """The loss of ``algo`` on fresh networks shaped as in its paper (RL-ViGen's, DMC-GB's, DMC-GB2's).

    Encoders: DrQ-v2's 4-layer CNN for ``drqv2``, ``drq`` and ``sada``; SVEA's 11-layer shared CNN
    for ``svea`` and ``srm``, and on DMC-GB's pixel scale ``x / 255`` for ``madi`` and ``scpl``;
    the 4-layer CNN with a linear projection to 512 for ``sgqn`` and ``curl``; SimGRL's per-frame
    encoder for ``simgrl``; VRL3's small ResNet for ``vrl3`` (``stage1_weights=path`` loads its
    stage-1 checkpoint; without it the encoder starts from random weights as in RL-ViGen); PIE-G's
    frozen ResNet-18 for ``pieg`` (``encoder_weights=path`` loads torchvision's ImageNet ResNet-18
    state dict, which PIE-G's results need; without it, random weights and a warning). Heads: the
    actor and twin critic with a ``feature_dim`` trunk and ``hidden_dim`` MLPs (DrQ's SAC actor
    has no trunk; the DMC-GB and DMC-GB2 SAC actors have their own); SGQN's attribution decoder;
    CURL's bilinear head; SCPL's :class:`~vigen.models.LatentDynamics` (512 hidden units); MaDi's
    masker. The networks are put in channels-last layout (unless ``channels_last=False``).

    The acting policy takes its options here: ``std``, ``std_clip`` for the DDPG algorithms
    (:class:`~vigen.losses.NoisyDeterministic`), ``init_temperature``, ``target_entropy``,
    ``squash_epsilon`` for the SAC ones (:class:`~vigen.losses.SquashedGaussian`); or pass
    ``policy=`` whole. MaDi takes ``masker_lr`` (1e-3) and ``masker_beta`` (0.9).

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
        **loss_options: the policy's options (above) and keyword arguments of the loss class
            (e.g. ``strong_augmentation``, ``weak_weight``); they override the preset's.

    Examples:
        >>> from vigen.losses import make_loss
        >>> loss = make_loss("svea", (9, 84, 84), action_dim=6, hidden_dim=64)
        >>> type(loss).__name__, type(loss.encoder).__name__
        ('SVEALoss', 'SharedCNN')
        >>> srm = make_loss("srm", (9, 84, 84), action_dim=6, hidden_dim=64)
        >>> type(srm).__name__, [type(t).__name__ for t in srm.strong_augmentation]
        ('SVEALoss', ['RandomOverlay', 'RandomFrequencyMask'])
    """
    options = dict(loss_options)
    networks = make_networks(algo, observation_shape, action_dim, feature_dim=feature_dim, hidden_dim=hidden_dim,
                             max_value=max_value, options=options)
    if options.get("channels_last", True):  # the convolutions: the encoder's, SGQN's decoder's
        for name in ("encoder", "decoder"):
            if name in networks:
                networks[name].to(memory_format=torch.channels_last)
    masker = networks.pop("masker", None)
    if masker is not None:
        options.setdefault("masker", masker)
    loss = build_loss(algo, *networks.values(), **options)
    if device is not None:
        loss.to(device)
    if seed is not None:
        loss.seed_augmentations(seed)
    return loss


def make_networks(
    algo: str,
    observation_shape: tuple[int, int, int],
    action_dim: int,
    *,
    feature_dim: int = 50,
    hidden_dim: int = 1024,
    max_value: float | None = None,
    options: dict[str, Any] | None = None,
) -> dict[str, nn.Module]:
    """The networks of ``algo``'s paper, by role: ``encoder``, ``actor``, ``critic`` and its extra module if any.

    The extra modules are SGQN's ``decoder``, CURL's ``head``, SCPL's ``dynamics`` and MaDi's
    ``masker``, built in this order (the order the original agents draw their initial weights in).
    ``options`` gives the encoder's files (``stage1_weights``, ``encoder_weights``), which are popped
    from it. :func:`make_loss` puts them in a loss.

    Examples:
        >>> sorted(make_networks("curl", (9, 84, 84), action_dim=2, hidden_dim=32))
        ['actor', 'critic', 'encoder', 'head']
    """
    if algo not in ALGOS:
        raise ValueError(f"Unknown algorithm {algo!r}; choose one of {', '.join(ALGOS)}.")
    algorithm = ALGOS[algo]
    channels, height, width = observation_shape
    if height != width:
        raise ValueError(f"vigen's encoders take square images, got {height}×{width}; render at a square size.")
    encoder = make_encoder(algorithm.encoder, channels, height, max_value, {} if options is None else options)
    features = encoder.output_dim(channels, height, width)
    critic = Critic(features, action_dim, feature_dim=feature_dim, hidden_dim=hidden_dim)
    if algorithm.actor == "gaussian":
        actor: nn.Module = GaussianActor(features, action_dim, hidden_dim=hidden_dim)
    elif algorithm.actor == "gaussian_projected":
        actor = GaussianActor(features, action_dim, hidden_dim=hidden_dim, feature_dim=feature_dim)
    else:
        actor = Actor(features, action_dim, feature_dim=feature_dim, hidden_dim=hidden_dim)
    networks: dict[str, nn.Module] = {"encoder": encoder, "actor": actor, "critic": critic}
    if algo == "sgqn":
        networks["decoder"] = AttributionDecoder(action_dim, embedding_dim=features, out_channels=channels, image_size=height)
    elif algo == "curl":
        networks["head"] = CURLHead(features)
    elif algo == "scpl":
        networks["dynamics"] = LatentDynamics(feature_dim, action_dim)
    elif algo == "madi" and "masker" not in (options or {}):
        networks["masker"] = MaDiMasker(max_value=max_value)
    return networks


def build_loss(algo: str, *networks: nn.Module, **options: Any) -> ActorCriticLoss:
    """The loss of ``algo`` on the given networks (encoder, actor, critic, and its extra module), with the preset's options.

    What :func:`make_loss` does after it builds the paper's networks: the policy from its options
    (``std``, ``init_temperature``, ...; or ``policy=``), MaDi's masker (``masker``, ``masker_lr``,
    ``masker_beta``; built on the encoder's ``max_value``), and the preset's defaults for options
    not given. Use it to run a preset (SRM, MaDi, SimGRL) on networks of your own.

    Examples:
        >>> from vigen.models import Actor, Critic, SharedCNN
        >>> encoder = SharedCNN(9)
        >>> features = encoder.output_dim(9, 84, 84)
        >>> loss = build_loss("srm", encoder, Actor(features, 2, hidden_dim=32), Critic(features, 2, hidden_dim=32))
        >>> [type(t).__name__ for t in loss.strong_augmentation]
        ['RandomOverlay', 'RandomFrequencyMask']
    """
    if algo not in ALGOS:
        raise ValueError(f"Unknown algorithm {algo!r}; choose one of {', '.join(ALGOS)}.")
    algorithm = ALGOS[algo]
    if "policy" not in options:
        options["policy"] = make_policy_head(algo, options)
    if algo == "madi":  # built after the networks, as MaDi's agent builds it
        options.update(_madi_masker(options, getattr(networks[0], "max_value", None)))
    for name, factory in algorithm.presets.items():
        options.setdefault(name, factory())
    return algorithm.loss(*networks, **options)


def _madi_masker(options: dict[str, Any], max_value: float | None) -> dict[str, Any]:
    """MaDi's masker as the loss's input mask, with its own Adam group; pops ``masker``, ``masker_lr``, ``masker_beta``."""
    masker = options.pop("masker", None)
    masker_lr, masker_beta = options.pop("masker_lr", 1e-3), options.pop("masker_beta", 0.9)
    if "input_mask" in options:
        raise TypeError("madi: the input mask of MaDi is its masker; pass masker=... instead of input_mask=....")
    if not (isinstance(masker_lr, (int, float)) and math.isfinite(masker_lr) and masker_lr > 0):
        raise ValueError(f"madi: masker_lr must be a positive number, got {masker_lr!r}.")
    if not (isinstance(masker_beta, (int, float)) and 0 <= masker_beta < 1):
        raise ValueError(f"madi: masker_beta is Adam's β1 of the masker, a number in [0, 1), got {masker_beta!r}.")
    if masker is None:
        masker = MaDiMasker(max_value=max_value)
    elif not isinstance(masker, nn.Module):
        raise TypeError(f"madi: masker must be an nn.Module (e.g. vigen.models.MaDiMasker()), got {type(masker).__name__}.")
    groups = {"input_mask": {"lr": float(masker_lr), "betas": (float(masker_beta), 0.999)}}
    return {"input_mask": masker, "param_groups": groups}

"""Every algorithm of vigen by name: its loss, its paper's networks and the defaults that make it that paper's.

SRM, MaDi and SimGRL are SVEA with other parts, so they are records of :class:`~vigen.losses.SVEALoss`
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
  carries no gradient), with its own Adam group: lr 1e-3, betas (0.9, 0.999)
  (``param_groups={"input_mask": {...}}``, in its record).
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
the target critic, ``log(relu(1 − tanh²) + ε)`` (:data:`~vigen.losses.samplers.DMCGB_SQUASH_EPSILON`) and the actor's own ``feature_dim``
projection; the departure of all SAC records from their code (one optimizer step for all terms) is
measured in ``benchmarks/parity``; their actor and targets every second update and their two target
rates are the update's (:class:`~vigen.losses.UpdateStep`, :class:`~vigen.losses.SplitSoftUpdate`; the
recipes of :data:`vigen.run.RECIPES`).

Everything that makes an algorithm its paper's is a field of its :class:`Algorithm` record, and
nowhere else: the loss class, the encoder, the actor, the sampler and its options, the loss's
augmentations and options (its coefficients and switches), the extra networks, the per-module
optimizer groups, the option that loads pretrained encoder weights, and the rewards' scale of its
runs. The loss classes have no defaults of their own: they take all of it as arguments, and
:func:`build_loss` gives them the record's. The functions below read the record; none of them
names an algorithm. :mod:`vigen.losses.paper_defaults` writes the records out for help texts and
``docs/losses.md``.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal

import torch
from torch import nn

from vigen.losses.base import ActorCriticLoss, Augmentations
from vigen.losses.curl import CURLLoss
from vigen.losses.drq import DrQLoss
from vigen.losses.drqv2 import DrQv2Loss
from vigen.losses.pieg import PIEGLoss
from vigen.losses.sada import SADALoss
from vigen.losses.samplers import DMCGB_SQUASH_EPSILON, NoisyDeterministic, Sampler, SquashedGaussian
from vigen.losses.schedule import LinearSchedule
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
from vigen.transforms import RandomFrequencyMask, RandomOverlay, RandomShift, RandomShiftedOverlay

EncoderName = Literal["drqv2", "shared_cnn", "shared_cnn_01", "per_frame", "projected", "vrl3", "pieg"]
ActorName = Literal["deterministic", "gaussian", "gaussian_projected"]


@dataclass(frozen=True)
class Shapes:
    """The sizes a network of an algorithm is built for (:func:`make_networks`)."""

    channels: int
    image_size: int
    features: int
    """The encoder's output size."""
    action_dim: int
    feature_dim: int
    hidden_dim: int
    max_value: float | None


ENCODERS: Mapping[str, Callable[[int, int, float | None, str | None], nn.Module]] = MappingProxyType({
    "drqv2": lambda channels, size, max_value, weights: DrQv2Encoder(channels, max_value=max_value),
    "shared_cnn": lambda channels, size, max_value, weights: SharedCNN(channels, max_value=max_value),
    # DMC-GB's SharedCNN and SimGRL's per-frame encoder scale pixels to x / 255
    "shared_cnn_01": lambda channels, size, max_value, weights: SharedCNN(channels, max_value=max_value, centered=False),
    "per_frame": lambda channels, size, max_value, weights: PerFrameEncoder(channels, max_value=max_value, centered=False),
    "projected": lambda channels, size, max_value, weights: ProjectedEncoder(channels, image_size=size, max_value=max_value),
    "vrl3": lambda channels, size, max_value, weights: VRL3Encoder(channels, max_value=max_value, stage1_weights=weights),
    "pieg": lambda channels, size, max_value, weights: PIEGEncoder(channels, image_size=size, max_value=max_value,
                                                                    weights=weights),
})
"""Encoder name → ``(channels, image size, max_value, weights file or None) → encoder``."""

ACTORS: Mapping[str, Callable[[Shapes], nn.Module]] = MappingProxyType({
    "deterministic": lambda s: Actor(s.features, s.action_dim, feature_dim=s.feature_dim, hidden_dim=s.hidden_dim),
    "gaussian": lambda s: GaussianActor(s.features, s.action_dim, hidden_dim=s.hidden_dim),  # DrQ's: no trunk
    "gaussian_projected": lambda s: GaussianActor(s.features, s.action_dim, hidden_dim=s.hidden_dim, feature_dim=s.feature_dim),
})
"""Actor name → ``shapes → actor``."""

@dataclass(frozen=True)
class Algorithm:
    """One algorithm: its loss class, the networks of its paper, its sampler and every default that makes it that paper's.

    Attributes:
        loss: the loss class.
        encoder: the encoder, by name (:data:`ENCODERS`).
        actor: the actor, by name (:data:`ACTORS`): ``"deterministic"`` (:class:`~vigen.models.Actor`),
            ``"gaussian"`` (DrQ's SAC actor, no trunk) or ``"gaussian_projected"`` (the SAC actor with its
            own ``feature_dim`` trunk).
        sampler: :class:`~vigen.losses.NoisyDeterministic` or :class:`~vigen.losses.SquashedGaussian`.
        sampler_options: the sampler's options in the paper where they are not the sampler's own
            defaults (DrQ-v2's noise, SAC's α₀ = 0.1): VRL3's ``std_schedule``, DMC-GB's ``squash_epsilon``.
        augmentations: the loss's augmentations in the paper, by keyword (``augmentation``, the weak
            view, and ``strong_augmentation``, ...), as factories: a fresh one for every loss.
        options: the loss's other options in the paper, by keyword: its coefficients (``weak_weight``,
            ``quantile``, ...) and switches (``augment_next``, ``target_encoder``, ...).
        networks: the loss's extra networks by its keyword (SGQN's ``decoder``, CURL's ``head``, SCPL's
            ``dynamics``, MaDi's ``input_mask``), each built from the :class:`Shapes`, in this order.
        param_groups: per-module optimizer groups of the paper (MaDi's masker, SCPL's dynamics model),
            under what is given.
        encoder_weights: the :func:`make_loss` option that loads a pretrained encoder (``None``: none).
        reward_scales: the factor the paper's runs put on an env's rewards, by env name (VRL3 on
            Adroit); 1 for the others (:meth:`reward_scale`).
    """

    loss: type[ActorCriticLoss]
    encoder: EncoderName
    actor: ActorName
    sampler: type[NoisyDeterministic] | type[SquashedGaussian]
    sampler_options: Mapping[str, Any] = field(default_factory=dict)
    augmentations: Mapping[str, Callable[[], Augmentations]] = field(default_factory=dict)
    options: Mapping[str, Any] = field(default_factory=dict)
    networks: Mapping[str, Callable[[Shapes], nn.Module]] = field(default_factory=dict)
    param_groups: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    encoder_weights: str | None = None
    reward_scales: Mapping[str, float] = field(default_factory=dict)

    def __post_init__(self) -> None:
        for name in ("sampler_options", "augmentations", "options", "networks", "reward_scales"):  # read-only records
            object.__setattr__(self, name, MappingProxyType(dict(getattr(self, name))))
        object.__setattr__(self, "param_groups", MappingProxyType(
            {module: MappingProxyType(dict(group)) for module, group in self.param_groups.items()}))

    @property
    def takes_std(self) -> bool:
        """Whether the sampler is DrQ-v2's noisy deterministic actor (a std schedule) rather than SAC's."""
        return self.sampler is NoisyDeterministic

    @property
    def std_schedule(self) -> LinearSchedule:
        """The paper's schedule of the noise std (a fixed std is a flat one), for a std-taking algorithm.

        Examples:
            >>> ALGOS["drqv2"].std_schedule, ALGOS["vrl3"].std_schedule.init
            (LinearSchedule(init=1.0, final=0.1, duration=100000), 0.01)
        """
        if not self.takes_std:
            raise AttributeError(f"{self.loss.__name__} samples from SAC's squashed Gaussian; it has no noise std.")
        return self.sampler(**self.sampler_options).std_schedule

    def reward_scale(self, env: str) -> float:
        """The factor the paper's runs put on the rewards of ``env`` (``<suite>/<task>``): its ``reward_scales``, else 1.

        Examples:
            >>> ALGOS["vrl3"].reward_scale("adroit/door"), ALGOS["vrl3"].reward_scale("dmc/walker-walk")
            (0.05, 1.0)
        """
        return float(self.reward_scales.get(env, 1.0))


SHIFT = MappingProxyType({"augmentation": lambda: RandomShift(pad=4)})
"""DrQ-v2's weak view, a random shift by up to 4 pixels: every algorithm's (RL-ViGen's and DMC-GB's code)."""


def overlay() -> RandomOverlay:
    """SVEA's strong view as RL-ViGen and DMC-GB draw it: the random overlay, α = 0.5 (vigen's built-in images)."""
    return RandomOverlay(alpha=0.5)


ONLINE_TARGET = MappingProxyType({"target_encoder": False})
"""DrQ-v2's critic target (RL-ViGen's, DMC-GB2's): the next action scored on the online encoder's features."""
SVEA_VIEWS = MappingProxyType({"weak_weight": 0.5, "strong_weight": 0.5, "augment_next": True})
"""SVEA's two views: each TD error weighed 0.5 (RL-ViGen's ``svea_alpha``, ``svea_beta``), the next observation shifted."""
DMCGB_SAC = MappingProxyType({"squash_epsilon": DMCGB_SQUASH_EPSILON})
"""DMC-GB's SAC sampler (SAC-AE's ``log(relu(1 − tanh²) + ε)``), MaDi's, SimGRL's and SCPL's."""

ALGOS: Mapping[str, Algorithm] = MappingProxyType({
    "drqv2": Algorithm(DrQv2Loss, "drqv2", "deterministic", NoisyDeterministic, augmentations=SHIFT, options=ONLINE_TARGET),
    "svea": Algorithm(SVEALoss, "shared_cnn", "deterministic", NoisyDeterministic,
                      augmentations={**SHIFT, "strong_augmentation": overlay}, options={**SVEA_VIEWS, **ONLINE_TARGET}),
    "srm": Algorithm(SVEALoss, "shared_cnn", "deterministic", NoisyDeterministic, options={**SVEA_VIEWS, **ONLINE_TARGET},
                     augmentations={**SHIFT, "strong_augmentation": lambda: [overlay(), RandomFrequencyMask()]}),
    "sgqn": Algorithm(SGQNLoss, "projected", "deterministic", NoisyDeterministic,
                      augmentations={**SHIFT, "attribution_augmentation": overlay},
                      # RL-ViGen's (the SGQN paper: 0.9, 0.5)
                      options={"quantile": 0.93, "consistency_weight": 0.9, **ONLINE_TARGET},
                      networks={"decoder": lambda s: AttributionDecoder(s.action_dim, embedding_dim=s.features,
                                                                        out_channels=s.channels, image_size=s.image_size)}),
    "curl": Algorithm(CURLLoss, "projected", "deterministic", NoisyDeterministic,
                      augmentations={**SHIFT, "contrastive_augmentation": lambda: RandomShift(pad=4)},
                      options={"key_encoder": False}, networks={"head": lambda s: CURLHead(s.features)}),
    "drq": Algorithm(DrQLoss, "drqv2", "gaussian", SquashedGaussian, augmentations=SHIFT,
                     options={"clean_view": True, **ONLINE_TARGET}),  # RL-ViGen's DrQ (the original: False, True)
    "sada": Algorithm(SADALoss, "drqv2", "gaussian_projected", SquashedGaussian,
                      augmentations={**SHIFT, "strong_augmentation": overlay},
                      options={"weak_weight": 0.25, "strong_weight": 0.25, "augment_next": True, **ONLINE_TARGET}),
    "vrl3": Algorithm(VRL3Loss, "vrl3", "deterministic", NoisyDeterministic,
                      sampler_options={"std_schedule": LinearSchedule(0.01, 0.01, 500_000)}, augmentations=SHIFT,
                      options={"safe_q_threshold": 200.0, "safe_q_factor": 0.5, "pretanh_threshold": 5.0,
                               "pretanh_weight": 1e-3, **ONLINE_TARGET},
                      encoder_weights="stage1_weights",
                      # RL-ViGen's (and VRL3's) reward_rescale, the rewards its safe-Q threshold of 200 is meant for
                      reward_scales={"adroit/door": 1 / 20, "adroit/hammer": 1 / 100, "adroit/pen": 1 / 50,
                                     "adroit/relocate": 1 / 30}),
    "madi": Algorithm(SVEALoss, "shared_cnn_01", "gaussian_projected", SquashedGaussian, sampler_options=DMCGB_SAC,
                      augmentations={**SHIFT, "strong_augmentation": overlay},
                      options={**SVEA_VIEWS, "augment_next": False, "target_encoder": True},
                      networks={"input_mask": lambda s: MaDiMasker(max_value=s.max_value)},  # after the others, as MaDi
                      param_groups={"input_mask": {"lr": 1e-3, "betas": (0.9, 0.999)}}),  # its masker_lr, masker_beta
    "simgrl": Algorithm(SVEALoss, "per_frame", "gaussian_projected", SquashedGaussian, sampler_options=DMCGB_SAC,
                        augmentations={**SHIFT, "strong_augmentation": lambda: RandomShiftedOverlay(alpha=0.5, max_shift=6)},
                        options={**SVEA_VIEWS, "target_encoder": True}),
    "pieg": Algorithm(PIEGLoss, "pieg", "deterministic", NoisyDeterministic,
                      augmentations={**SHIFT, "strong_augmentation": overlay},
                      options={**SVEA_VIEWS, "acting_batchnorm": "running", **ONLINE_TARGET}, encoder_weights="encoder_weights"),
    "scpl": Algorithm(SCPLLoss, "shared_cnn_01", "gaussian_projected", SquashedGaussian, sampler_options=DMCGB_SAC,
                      augmentations={**SHIFT, "strong_augmentation": overlay},
                      options={"weak_weight": 0.5, "strong_weight": 0.5, "quantile": 0.9, "consistency_weight": 0.5,
                               "kl_weight": 1.0, "kl_covariance": "std", "dynamics_weight": 1.0, "target_encoder": True},
                      networks={"dynamics": lambda s: LatentDynamics(s.feature_dim, s.action_dim)},
                      param_groups={"dynamics": {"lr": 3e-4}}),  # its own Adam for the model
})
"""Algorithm name -> :class:`Algorithm`."""

SAMPLER_OPTIONS: Mapping[type, tuple[str, ...]] = MappingProxyType({
    NoisyDeterministic: ("std_schedule", "clip"),
    SquashedGaussian: ("init_temperature", "target_entropy", "squash_epsilon"),
})
"""The options of each sampler that :func:`make_loss` takes as keywords."""

SAMPLERS: Mapping[str, type[NoisyDeterministic] | type[SquashedGaussian]] = MappingProxyType({
    "noisy_deterministic": NoisyDeterministic, "squashed_gaussian": SquashedGaussian})
"""Sampler name → class: what ``sampler_type=`` of :func:`make_loss` picks instead of the algorithm's sampler."""


def algorithm(algo: str) -> Algorithm:
    """The record of ``algo``, or a ``ValueError`` listing the names.

    Examples:
        >>> algorithm("drqv2").loss.__name__
        'DrQv2Loss'
    """
    if algo not in ALGOS:
        raise ValueError(f"Unknown algorithm {algo!r}; choose one of {', '.join(ALGOS)}.")
    return ALGOS[algo]


def make_sampler(algo: str, options: dict[str, Any]) -> Sampler:
    """The sampler of ``algo`` with the paper's options; pops the sampler's options (``std``, ``init_temperature``, ...).

    ``options["sampler_type"]`` (popped) picks another sampler by name (:data:`SAMPLERS`), e.g. SAC's for SVEA as
    DMC-GB trains it; the record's sampler options then do not apply.

    Examples:
        >>> make_sampler("vrl3", {})
        NoisyDeterministic(std_schedule=LinearSchedule(init=0.01, final=0.01, duration=500000), clip=0.3)
        >>> make_sampler("svea", {"sampler_type": "squashed_gaussian", "squash_epsilon": 1e-6})
        SquashedGaussian(init_temperature=0.1, target_entropy='auto', squash_epsilon=1e-06)
    """
    record = algorithm(algo)
    kind = options.pop("sampler_type", None)
    if kind is not None and kind not in SAMPLERS:
        raise ValueError(f"{algo}: sampler_type={kind!r} is no sampler; choose one of {', '.join(SAMPLERS)}.")
    sampler = record.sampler if kind is None else SAMPLERS[kind]
    own = SAMPLER_OPTIONS[sampler]
    wrong = [name for other, names in SAMPLER_OPTIONS.items() if other is not sampler for name in names
             if name in options and name not in own]
    if wrong:
        raise TypeError(f"{record.loss.__name__} ({algo}) samples with {sampler.__name__} and takes no "
                        f"{', '.join(map(repr, wrong))}; its sampler's options are {', '.join(own)}.")
    paper = record.sampler_options if sampler is record.sampler else {}  # the record's options are for its own sampler
    return sampler(**{**paper, **{name: options.pop(name) for name in own if name in options}})


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

    The sampler takes its options here: ``std_schedule``, ``clip`` for the DDPG algorithms
    (:class:`~vigen.losses.NoisyDeterministic`), ``init_temperature``, ``target_entropy``,
    ``squash_epsilon`` for the SAC ones (:class:`~vigen.losses.SquashedGaussian`); or pass
    ``sampler=`` whole. Per-module optimizer options are ``param_groups`` (MaDi's masker:
    ``param_groups={"input_mask": {"lr": 5e-4}}``), merged over the paper's. An algorithm's parts can be
    swapped by name (an original's parts on vigen's loss): ``encoder_type`` (:data:`ENCODERS`), ``actor_type``
    (:data:`ACTORS`), ``sampler_type`` (:data:`SAMPLERS`), and a SAC actor's ``log_std_bounds``; SVEA as
    DMC-GB trains it is ``make_loss("svea", ..., encoder_type="shared_cnn_01", actor_type="gaussian_projected",
    sampler_type="squashed_gaussian", squash_epsilon=1e-6, ...)`` (:data:`vigen.run.RECIPES` holds such sets).

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
        **loss_options: the sampler's options (above), the pretrained encoder's file (the
            record's ``encoder_weights``) and keyword arguments of the loss class (e.g.
            ``strong_augmentation``, ``weak_weight``); they override the record's.

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
    """The networks of ``algo``'s paper, by role: ``encoder``, ``actor``, ``critic`` and the record's extra networks.

    The extra networks (:attr:`Algorithm.networks`: SGQN's ``decoder``, CURL's ``head``, SCPL's
    ``dynamics``, MaDi's masker as ``input_mask``) come after the others; the critic is built
    before the actor (the order the original agents draw their initial weights in). ``options``
    gives the encoder's weights file (the record's ``encoder_weights`` option), popped from it.
    :func:`make_loss` puts them in a loss; an extra network already in ``options`` is not built.

    Examples:
        >>> sorted(make_networks("curl", (9, 84, 84), action_dim=2, hidden_dim=32))
        ['actor', 'critic', 'encoder', 'head']
    """
    record = algorithm(algo)
    options = {} if options is None else options
    channels, height, width = observation_shape
    if height != width:
        raise ValueError(f"vigen's encoders take square images, got {height}×{width}; render at a square size.")
    encoder_type, actor_type = options.pop("encoder_type", record.encoder), options.pop("actor_type", record.actor)
    for part, name, table in (("encoder_type", encoder_type, ENCODERS), ("actor_type", actor_type, ACTORS)):
        if name not in table:
            raise ValueError(f"{algo}: {part}={name!r} is not one of vigen's; choose one of {', '.join(table)}.")
    weights = options.pop(record.encoder_weights, None) if record.encoder_weights else None
    encoder = ENCODERS[encoder_type](channels, height, max_value, weights)
    shapes = Shapes(channels, height, encoder.output_dim(channels, height, width), action_dim, feature_dim, hidden_dim,
                    max_value)
    critic = Critic(shapes.features, action_dim, feature_dim=feature_dim, hidden_dim=hidden_dim)
    actor = ACTORS[actor_type](shapes)
    bounds = options.pop("log_std_bounds", None)
    if bounds is not None:
        if not isinstance(actor, GaussianActor):
            raise ValueError(f"{algo}: log_std_bounds shape a SAC actor's log σ; {type(actor).__name__} has none "
                             f"(pick actor_type='gaussian' or 'gaussian_projected').")
        low, high = (float(bound) for bound in bounds)
        if not low < high:
            raise ValueError(f"{algo}: log_std_bounds must be (low, high) with low < high, got {tuple(bounds)}.")
        actor.log_std_bounds = (low, high)
    networks: dict[str, nn.Module] = {"encoder": encoder, "actor": actor, "critic": critic}
    for name, factory in record.networks.items():
        if name not in options:
            networks[name] = factory(shapes)
    return networks


def build_loss(algo: str, encoder: nn.Module, actor: nn.Module, critic: nn.Module, *extra: nn.Module,
               **options: Any) -> ActorCriticLoss:
    """The loss of ``algo`` on the given networks, with the record's options for those not given.

    ``extra`` are the record's extra networks in its order (:attr:`Algorithm.networks`, as
    :func:`make_networks` returns them), or pass them by keyword (``decoder=``, ``head=``,
    ``dynamics=``, ``input_mask=``). What :func:`make_loss` does after it builds the paper's
    networks: the sampler from its options (``std_schedule``, ``init_temperature``, ...; or ``sampler=``),
    the paper's per-module optimizer groups under the given ``param_groups``, and the record's
    augmentations and options for those not given. Use it to run an algorithm (SRM, MaDi, SimGRL
    included) on networks of your own.

    Examples:
        >>> from vigen.models import Actor, Critic, SharedCNN
        >>> encoder = SharedCNN(9)
        >>> features = encoder.output_dim(9, 84, 84)
        >>> loss = build_loss("srm", encoder, Actor(features, 2, hidden_dim=32), Critic(features, 2, hidden_dim=32))
        >>> [type(t).__name__ for t in loss.strong_augmentation]
        ['RandomOverlay', 'RandomFrequencyMask']
    """
    record = algorithm(algo)
    names = list(record.networks)
    if len(extra) > len(names):
        raise TypeError(f"{algo}: {len(extra)} extra networks given, but it takes {len(names)} ({', '.join(names) or 'none'}).")
    for name, network in zip(names, extra):
        if name in options:
            raise TypeError(f"{algo}: its {name!r} network was given twice (as an argument and as {name}=).")
        options[name] = network
    missing = [name for name in names if name not in options]
    if missing:
        raise TypeError(f"{algo}: the loss needs its {', '.join(missing)} network; pass it (make_networks({algo!r}, ...) "
                        "builds the paper's).")
    if "sampler" not in options:
        options["sampler"] = make_sampler(algo, options)
    sampler = options["sampler"]
    if isinstance(actor, (Actor, GaussianActor)) and isinstance(sampler, SquashedGaussian) != isinstance(actor, GaussianActor):
        sac = isinstance(sampler, SquashedGaussian)
        raise ValueError(f"{algo}: {type(sampler).__name__} draws from {'a SAC actor' if sac else 'a deterministic actor'}, "
                         f"but the actor is {type(actor).__name__}; pick the matching actor_type "
                         f"({'gaussian or gaussian_projected' if sac else 'deterministic'}).")
    if record.param_groups:
        given = options.get("param_groups") or {}
        options["param_groups"] = {module: {**record.param_groups.get(module, {}), **given.get(module, {})}
                                   for module in {**record.param_groups, **given}}
    for name, factory in record.augmentations.items():
        if name not in options:
            options[name] = factory()
    return record.loss(encoder, actor, critic, **{**record.options, **options})

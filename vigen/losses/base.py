"""What every vigen loss shares: TorchRL's plumbing and the pieces of the update, each written once.

:class:`ActorCriticLoss` owns the plumbing: the batch keys (``set_keys``), the TD(0) value
estimator (n-step returns through ``steps_to_next_obs``), the batch checks, the output with its
``td_error`` priority, prioritized-replay weights, ``reduction`` and the finite-loss check. Its
building blocks are the update's pieces, written once:

* :meth:`~ActorCriticLoss.next_value` and :meth:`~ActorCriticLoss.bootstrap`: the critic target
  ``y = r + γⁿ·(1 − terminated)·V(h')`` (optionally scored on a target encoder);
* :func:`squared_td_errors` and :func:`weighted_td_errors`: the critic's TD loss over one or more views;
* :meth:`~ActorCriticLoss.actor_loss`: the actor's objective through a frozen critic;
* ``loss.sampler``: how actions are drawn in the update and how the acting policy explores, a
  :class:`~vigen.losses.NoisyDeterministic` (DrQ-v2) or a :class:`~vigen.losses.SquashedGaussian`
  (SAC), with the temperature loss of SAC (``loss.sampler.temperature_losses``) and the sampler's
  metrics (``loss.sampler.metrics``);
* :meth:`~ActorCriticLoss.output`: the ``loss_*`` terms a ``forward`` hands it, reduced, and the metrics.

Each algorithm's ``forward`` strings these together in the order of its paper's update, top to
bottom, as DrQ-v2's ``update`` reads (see :class:`~vigen.losses.DrQv2Loss`), and names every term of
its summed loss, SAC's temperature loss included; :meth:`~ActorCriticLoss.output` adds none. Nothing
on the update's path is a hook a subclass overrides. A loss's defaults in its paper are not here
nor in its class: they are its record in :data:`vigen.losses.ALGOS`, which :func:`~vigen.losses.build_loss`
and :func:`~vigen.losses.make_loss` apply.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, Literal

import torch
from tensordict import TensorDict, TensorDictBase, TensorDictParams
from tensordict.nn import TensorDictModuleBase
from tensordict.utils import NestedKey, unravel_key
from torch import Tensor, nn
from torchrl.data import TensorSpec
from torchrl.objectives import LossModule
from torchrl.objectives.utils import ValueEstimators, dispatch_value_estimator

from vigen.devices import host_reads_are_free
from vigen.losses.samplers import ActorOutput, Sampler, SquashedGaussian
from vigen.models import weight_init
from vigen.pixel_format import check_pixels
from vigen.seeding import derive_seed
from vigen.transforms import ImageAugmentation

Augmentations = ImageAugmentation | Sequence[ImageAugmentation] | None

PARAM_GROUP_OPTIONS = frozenset({"lr", "lr_scale", "betas", "eps", "weight_decay", "every"})
"""The options a per-module optimizer group (``param_groups``) may set; ``lr_scale`` is a multiple of the base lr;
``every`` steps the group on every N-th update only (:class:`~vigen.losses.UpdateStep`: DMC-GB's actor every second)."""

BATCH_NORMS = (nn.BatchNorm1d, nn.BatchNorm2d, nn.BatchNorm3d, nn.SyncBatchNorm)
"""The BatchNorm module types whose statistics a loss's acting policy or views must manage (VRL3, PIE-G)."""


@dataclass(frozen=True)
class Batch:
    """What an update reads from its batch: the stored frame stacks ``[B, 3·k, H, W]`` and the actions ``[B, A]``."""

    pixels: Tensor
    next_pixels: Tensor
    action: Tensor

    @property
    def size(self) -> int:
        """B, the number of samples."""
        return self.pixels.shape[0]

    @property
    def action_dim(self) -> int:
        """The size of an action (SAC's default target entropy is ``−action_dim``)."""
        return self.action.shape[-1]


def example_batch(
    batch_size: int = 4,
    observation_shape: tuple[int, int, int] = (9, 84, 84),
    action_dim: int = 2,
    *,
    seed: int = 0,
) -> TensorDict:
    """A replay-buffer batch of random uint8 frame stacks, as a TorchRL env writes it, for examples and quick checks.

    ``pixels`` and ``("next", "pixels")`` ``[B, 3·k, H, W]`` (the same frames), actions in ``[-1, 1)``,
    a reward of 1 and no episode end (``done`` and ``terminated`` all ``False``).

    Examples:
        >>> batch = example_batch(4)
        >>> batch["pixels"].shape, batch["pixels"].dtype, batch["next", "terminated"].any().item()
        (torch.Size([4, 9, 84, 84]), torch.uint8, False)
    """
    generator = torch.Generator().manual_seed(seed)
    pixels = torch.randint(0, 256, (batch_size, *observation_shape), dtype=torch.uint8, generator=generator)
    flags = torch.zeros(batch_size, 1, dtype=torch.bool)
    return TensorDict({
        "pixels": pixels, "action": torch.rand(batch_size, action_dim, generator=generator) * 2 - 1,
        "next": {"pixels": pixels, "reward": torch.ones(batch_size, 1), "done": flags, "terminated": flags.clone()},
    }, batch_size=[batch_size])


def squared_td_errors(q1: Tensor, q2: Tensor, target: Tensor) -> Tensor:
    """Per-sample squared TD errors of both critics, ``(Q1 − y)² + (Q2 − y)²``, shape ``[B]``.

    The sum of DrQ-v2's two critic MSEs, before the batch mean. (TorchRL's ``"td_error"`` priority
    that the losses write is another quantity, ``max(|Q1 − y|, |Q2 − y|)``.)

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Examples:
        >>> import torch
        >>> squared_td_errors(torch.tensor([[1.0]]), torch.tensor([[3.0]]), torch.tensor([[2.0]]))
        tensor([2.])
    """
    return ((q1 - target).pow(2) + (q2 - target).pow(2)).squeeze(-1)


def weighted_td_errors(q1: Tensor, q2: Tensor, target: Tensor, weights: Sequence[float | Tensor]) -> Tensor:
    """``Σ_v w_v·[(Q1_v − y)² + (Q2_v − y)²]`` per sample, for the Q values of ``len(weights)`` views stacked view-major.

    ``q1`` and ``q2`` are ``[V·B, 1]`` (the views of one batch concatenated), ``target`` is ``[B, 1]``:
    every view is scored against the same target, as SVEA's critic loss does.

    Paper: SVEA, https://arxiv.org/abs/2107.00644.

    Examples:
        >>> import torch
        >>> q = torch.tensor([[1.0], [3.0]])  # one sample, two views
        >>> weighted_td_errors(q, q, torch.tensor([[2.0]]), weights=[0.5, 0.5])
        tensor([2.])
    """
    errors = squared_td_errors(q1, q2, target.repeat(len(weights), 1)).split(target.shape[0])
    loss = weights[0] * errors[0]
    for weight, error in zip(weights[1:], errors[1:]):
        loss = loss + weight * error
    return loss


def per_sample_mean(loss: Tensor, views: int) -> Tensor:
    """A per-sample loss over ``views`` views of each sample (``[V·B]``, view-major) as its mean over the views, ``[B]``.

    Examples:
        >>> import torch
        >>> per_sample_mean(torch.tensor([1.0, 2.0, 3.0, 4.0]), views=2)
        tensor([2., 3.])
    """
    if loss.shape[0] % views:
        raise ValueError(f"per_sample_mean: {loss.shape[0]} values are not {views} views of one batch.")
    return loss.reshape(views, -1).mean(0)


class ActorCriticLoss(LossModule):
    """TorchRL's plumbing for vigen's actor-critic losses, and the update's pieces, each written once.

    A loss subclasses it with its ``__init__`` (its own options, if any) and its ``forward``: the
    update in its paper's order, built from :meth:`read_batch`, :meth:`augment`, :meth:`next_value`,
    :meth:`bootstrap`, :meth:`encode`, :meth:`q_values`, :func:`weighted_td_errors`,
    :meth:`actor_loss`, the sampler's ``temperature_losses`` and ``metrics``, and :meth:`output`.
    How actions are drawn is the ``sampler``'s. The class takes every option of the paper as an
    argument; :func:`~vigen.losses.build_loss` gives them from the algorithm's record.

    The batch (checked before any work, naming every missing key and the fix):

    * ``pixels`` and ``("next", "pixels")``: frame stacks ``[B, 3·k, H, W]`` as
      :mod:`vigen.pixel_format` defines them, uint8 on 0–255 or float on ``[0, max_value]``. The
      loss's ``max_value`` is its encoder's (vigen's encoders take ``max_value=``), so it is set
      once, on the encoder; every augmentation of the loss whose ``max_value`` is ``None`` gets it
      (the loss keeps private copies: what the caller passed is never changed).
    * ``action``, ``("next", "reward")`` and ``("next", "terminated")``. ``terminated`` tells true
      terminations from time limits; a batch without it is refused rather than bootstrapping
      from ``done``. If every ``done`` of your data is a true termination, say so with
      ``loss.set_keys(terminated="done")``.
    * optional: ``steps_to_next_obs`` (n-step), ``priority_weight`` (prioritized replay).

    With ``check_finite`` (the default) a non-finite ``loss_*`` is caught. Where reading a value
    back to the host is free (CPU tensors, eager; :func:`~vigen.devices.host_reads_are_free`) the
    call raises at once, before any optimizer step: a ``ValueError`` naming the batch entries that
    hold NaN or inf, or a ``FloatingPointError`` naming the non-finite parameters when the batch
    is finite. Elsewhere (a GPU, ``torch.compile``) that read would synchronize with the host, so
    the loss counts the call on the device (``nonfinite_calls``, a 0-d tensor) and
    :meth:`raise_if_nonfinite` raises, one read at a script's logging interval;
    :class:`~vigen.losses.UpdateStep` also zeros such an update's gradients there.

    Paper: DrQ-v2 (the update the pieces follow), https://arxiv.org/abs/2107.09645.

    Args:
        encoder: pixels ``[B, 3·k, H, W]`` → features ``[B, D]``.
        actor: features → the sampler's parameters (an action for ``NoisyDeterministic``, mean and
            log σ for ``SquashedGaussian``).
        critic: (features, action) → (Q1, Q2); it gets target parameters (``target_critic_params``)
            for ``torchrl.objectives.SoftUpdate``.
        sampler: how actions are drawn, :class:`~vigen.losses.NoisyDeterministic` or
            :class:`~vigen.losses.SquashedGaussian`.
        augmentation: the weak augmentation (DrQ-v2: ``RandomShift(pad=4)``), drawn afresh for each
            view it makes; ``None`` if the replay buffer already augments (augment in one place only,
            or every view is shifted twice).
        target_encoder: keep a target copy of the encoder (``target_encoder_params``, moved by
            ``SoftUpdate`` with the target critic) and score the next action on its features
            (DMC-GB's SAC, the original DrQ); ``False``: the target critic scores the online
            encoder's features (DrQ-v2, RL-ViGen). ``"keys"`` keeps the copy without scoring on it
            (CURL's momentum key encoder).
        input_mask: a module applied to the pixels before the encoder, in every view and in the
            acting policy (MaDi's masker); ``None`` for none.
        param_groups: per-module optimizer options, ``{attribute: {"lr": ..., ...}}`` for
            :meth:`optimizer_groups`, the one spelling of every per-module setting: MaDi's masker
            (``{"input_mask": {"lr": 1e-3, "betas": (0.9, 0.999)}}``), SCPL's dynamics model
            (``{"dynamics": {"lr": 3e-4}}``), VRL3's encoder (``{"encoder": {"lr_scale": 0.01}}``:
            ``"lr_scale"`` sets the group's lr as a multiple of the base one). The options are
            :data:`PARAM_GROUP_OPTIONS`.
        channels_last: feed the convolutions channels-last pixels (:func:`~vigen.losses.make_loss`
            also puts vigen's networks in that layout; a loss never changes the caller's modules).
        reduction: ``"mean"``, ``"sum"`` or ``"none"`` (per-sample losses).
        check_finite: catch a NaN or inf loss (raised in the call on the CPU, counted on the device
            elsewhere; see above); ``False`` skips the check.

    Examples:
        >>> from vigen.losses import DrQv2Loss
        >>> issubclass(DrQv2Loss, ActorCriticLoss)
        True
    """

    @dataclass
    class _AcceptedKeys:
        """Keys of the batch the loss reads (and ``priority``, which it writes).

        Attributes:
            pixels: the frame stack; the next one is read at ``("next", pixels)``.
            action: the action taken.
            reward: the (n-step) reward, read at ``("next", reward)``.
            done: end of episode, read at ``("next", done)``.
            terminated: true termination (no bootstrap), read at ``("next", terminated)``.
            steps_to_next_obs: n of the n-step return (``γⁿ``); optional.
            priority: where ``max(|Q1 − y|, |Q2 − y|)`` is written for prioritized replay.
            priority_weight: importance weights of a prioritized sampler; optional.
        """

        pixels: NestedKey = "pixels"
        action: NestedKey = "action"
        reward: NestedKey = "reward"
        done: NestedKey = "done"
        terminated: NestedKey = "terminated"
        steps_to_next_obs: NestedKey = "steps_to_next_obs"
        priority: NestedKey = "td_error"
        priority_weight: NestedKey = "priority_weight"

    default_keys = _AcceptedKeys
    tensor_keys: _AcceptedKeys
    default_value_estimator = ValueEstimators.TD0
    SUPPORTED_VALUE_ESTIMATORS = (ValueEstimators.TD0,)
    own_out_keys: tuple[str, ...] = ()
    """The losses and metrics an algorithm adds to the output."""
    _schedulable_buffers = frozenset({"weak_weight", "strong_weight"})  # TorchRL's: loss.weak_weight = 0.3 sets the buffer

    sampler: Sampler
    encoder: nn.Module
    encoder_params: TensorDictParams
    target_encoder_params: TensorDictParams
    actor: nn.Module
    actor_params: TensorDictParams
    target_actor_params: TensorDictParams  # never made: TorchRL's convert_to_functional warns unless it is declared
    critic: nn.Module
    critic_params: TensorDictParams
    target_critic_params: TensorDictParams

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        sampler: Sampler,
        augmentation: Augmentations,
        target_encoder: bool | Literal["keys"],
        input_mask: nn.Module | None = None,
        param_groups: Mapping[str, Mapping[str, Any]] | None = None,
        channels_last: bool = True,
        reduction: str = "mean",
        check_finite: bool = True,
    ) -> None:
        super().__init__()
        if reduction not in ("mean", "sum", "none"):
            raise ValueError(f"reduction must be 'mean', 'sum' or 'none', got {reduction!r}.")
        if target_encoder not in (True, False, "keys"):
            raise ValueError(f"target_encoder must be True, False or 'keys' (a key encoder only), got {target_encoder!r}.")
        self._in_keys = None
        self.reduction = reduction
        self.check_finite = check_finite
        self.max_value: float | None = getattr(encoder, "max_value", None)
        self.channels_last = channels_last
        mask_max = getattr(input_mask, "max_value", None)
        if input_mask is not None and hasattr(input_mask, "max_value") and mask_max != self.max_value:
            raise ValueError(
                f"{type(self).__name__}: the input mask has max_value={mask_max} but the encoder's is {self.max_value}; "
                "the mask hands the encoder float pixels on its scale, so they must agree. Build it with "
                f"max_value={self.max_value} (make_loss does)."
            )
        self.sampler = sampler
        self.input_mask = input_mask
        self.convert_to_functional(encoder, "encoder", create_target_params=bool(target_encoder))
        self.convert_to_functional(actor, "actor")
        self.convert_to_functional(critic, "critic", create_target_params=True)
        self.scores_on_target_encoder = target_encoder is True
        self.augmentation = self._augmentations(augmentation)
        self.register_buffer("schedule_step", torch.zeros((), dtype=torch.long))
        self.register_buffer("nonfinite_calls", torch.zeros((), dtype=torch.long), persistent=False)
        self._scanned_pixels = False  # whether a batch's float pixels were scanned once (check_batch)
        self.param_groups = self._checked_param_groups(param_groups or {})

    @property
    def out_keys(self) -> list[str]:
        """Every entry of the output: the shared ones, the sampler's (``std``, or ``loss_alpha``, ``alpha``, ``entropy``), the algorithm's."""
        return ["loss_critic", "loss_actor", "q_mean", "target_mean", "target_std", *self.sampler.out_keys, *self.own_out_keys]

    def add_strong_view(self, strong_augmentation: Augmentations, weak_weight: float, strong_weight: float) -> None:
        """SVEA's second view for the losses that score it (SVEA, SADA, PIE-G, SCPL): its augmentation and both views' weights.

        ``strong_augmentation`` is applied on top of the weak view (SVEA: ``RandomOverlay(alpha=0.5)``;
        ``None`` makes the strong view the weak one); ``weak_weight`` and ``strong_weight`` weigh the two
        views' TD errors (buffers, schedulable: ``loss.strong_weight = 0.3``).
        """
        self.strong_augmentation = self._augmentations(strong_augmentation)
        self.register_coeff_buffer("weak_weight", weak_weight)
        self.register_coeff_buffer("strong_weight", strong_weight)

    def set_step(self, step: int) -> None:
        """Evaluate the loss's schedules at ``step`` from now on (DrQ-v2: agent steps = frames / action repeat)."""
        self.schedule_step.fill_(int(step))

    # -- the update's pieces -------------------------------------------------------------------
    def read_batch(self, tensordict: TensorDictBase) -> Batch:
        """Check the batch (see the class docstring) and read its pixels, next pixels and actions."""
        self.check_batch(tensordict)
        keys = self.tensor_keys
        return Batch(tensordict.get(keys.pixels), tensordict.get(("next", keys.pixels)), tensordict.get(keys.action))

    def augment(self, pixels: Tensor, augmentations: nn.ModuleList | None = None) -> Tensor:
        """``pixels`` through ``augmentations`` in turn (default: the weak augmentation), a fresh draw per call."""
        for augmentation in self.augmentation if augmentations is None else augmentations:
            augmented = augmentation.augment(pixels)
            if augmented.dtype != pixels.dtype:
                raise TypeError(
                    f"{type(augmentation).__name__} turned {pixels.dtype} pixels into {augmented.dtype}; the loss "
                    "cannot tell their scale. Augmentations keep the dtype: end apply() with .to(images.dtype)."
                )
            pixels = augmented
        return pixels

    def next_value(self, next_obs: Tensor) -> Tensor:
        """``V(h') = min(Q1', Q2')(h'_Q, a')`` (minus ``α·log π(a'|h')`` for SAC) with ``a'`` drawn by the sampler at ``h'``.

        ``h' = encoder(next_obs)`` is the *online* encoder's (DrQ-v2 has no target encoder); with
        ``target_encoder=True`` the target critic scores on the target encoder's ``h'_Q`` (DMC-GB's SAC).
        Call it without gradient.
        """
        features = self.encode(next_obs)
        scored = self.encode(next_obs, params=self.target_encoder_params) if self.scores_on_target_encoder else features
        action, log_prob = self.sampler.sample(self.actor_output(features), self.schedule_step)
        return self.sampler.value(torch.min(*self.target_q_values(scored, action)), log_prob)

    def critic_target(self, tensordict: TensorDictBase, next_obs: Tensor) -> Tensor:
        """The critic target ``y = r + γⁿ·(1 − terminated)·V(h')`` of the next view ``next_obs``, without gradient, ``[B, 1]``."""
        with torch.no_grad():
            return self.bootstrap(tensordict, self.next_value(next_obs))

    def bootstrap(self, tensordict: TensorDictBase, next_value: Tensor) -> Tensor:
        """The critic target ``y = r + γⁿ·(1 − terminated)·V``, ``[B, 1]``, from TorchRL's TD(0) estimator."""
        return self.value_estimator.value_estimate(tensordict, next_value=next_value)

    def actor_loss(
        self,
        features: Tensor,
        critic_features: Tensor | None = None,
        *,
        actor_output: ActorOutput | None = None,
    ) -> tuple[Tensor, Tensor | None]:
        """The actor's per-sample objective at detached ``features``, and the log-probability of its actions.

        ``ã`` is drawn by the sampler from ``actor(features)`` (or the given ``actor_output``) and
        scored by the critic, frozen (its parameters detached, so this trains the actor only), on
        ``critic_features`` (default ``features``): ``−min(Q1, Q2)(h, ã)``, or
        ``α·log π(ã|h) − min(Q1, Q2)(h, ã)`` for SAC.
        """
        output = self.actor_output(features) if actor_output is None else actor_output
        action, log_prob = self.sampler.sample(output, self.schedule_step)
        q = torch.min(*self.q_values(features if critic_features is None else critic_features, action, frozen=True))
        return self.sampler.objective(q, log_prob).squeeze(-1), log_prob

    def output(
        self,
        tensordict: TensorDictBase,
        target: Tensor,
        q1: Tensor,
        q2: Tensor,
        losses: Mapping[str, Tensor],
        metrics: Mapping[str, Tensor] | None = None,
    ) -> TensorDict:
        """The loss's TensorDict: the per-sample ``losses`` the ``forward`` names, reduced, and its metrics, detached.

        It adds no loss: every ``loss_*`` entry is one of ``losses``, each per sample (``[B]``; an
        actor step over several views gives each sample the mean over its views, as the forward
        says), reduced by ``reduction`` (``loss_critic`` weighted by ``priority_weight``). ``q1``,
        ``q2`` are the critic's values of the batch's first view ``[B, 1]`` and ``target`` its
        target ``y``: ``q_mean``, ``target_mean``, ``target_std`` and the ``td_error`` priority
        ``max(|Q1 − y|, |Q2 − y|)`` (written into ``tensordict``) come from them.
        """
        keys = self.tensor_keys
        size = q1.shape[0]
        for name, value in losses.items():
            if not name.startswith("loss_") or value.shape != (size,):
                raise ValueError(f"{type(self).__name__}: the loss term {name!r} has shape {tuple(value.shape)}; a loss term "
                                 f"is named loss_* and holds one value per sample, [{size}] (average an actor step over "
                                 "several views per sample: per_sample_mean, temperature_losses(..., views=V)).")
        priority = torch.maximum((q1 - target).abs(), (q2 - target).abs()).detach().squeeze(-1)
        tensordict.set(keys.priority, priority)
        weights = self._maybe_get_priority_weight(tensordict)
        out = {name: self._reduce_loss(value, tensordict, weights=weights if name == "loss_critic" else None)
               for name, value in losses.items()}
        out.update(q_mean=q1.detach().mean(), target_mean=target.mean(), target_std=target.std())
        out.update({name: value.detach() for name, value in (metrics or {}).items()})
        if self.check_finite:
            if host_reads_are_free(q1):
                self._check_finite(out, tensordict)
            else:  # raising would read the value back (a host synchronization): count on the device
                self.nonfinite_calls.add_(self._nonfinite(out).long())
        return TensorDict(out, batch_size=[])

    # -- building blocks ---------------------------------------------------------------------
    def encode(self, pixels: Tensor, params: TensorDictBase | None = None) -> Tensor:
        """Encoder features of ``[B, 3·k, H, W]`` pixels, after the input mask (default: online parameters)."""
        if self.input_mask is not None:
            pixels = self.input_mask(pixels)
        if self.channels_last and pixels.ndim == 4:
            pixels = pixels.contiguous(memory_format=torch.channels_last)
        with (self.encoder_params if params is None else params).to_module(self.encoder, preserve_module_state=False):
            return self.encoder(pixels)

    def encode_views(self, views: Sequence[Tensor]) -> list[Tensor]:
        """Features of each view; views of one shape share a single encoder pass."""
        if len(views) == 1:
            return [self.encode(views[0])]
        if all(view.shape == views[0].shape and view.dtype == views[0].dtype for view in views):
            return list(self.encode(torch.cat(list(views))).split(views[0].shape[0]))
        return [self.encode(view) for view in views]

    def actor_output(self, features: Tensor) -> ActorOutput:
        """The actor's output at ``features`` (an action, or the mean and log σ of SAC's Gaussian)."""
        with self.actor_params.to_module(self.actor, preserve_module_state=False):
            return self.actor(features)

    def q_values(self, features: Tensor, action: Tensor, *, frozen: bool = False) -> tuple[Tensor, Tensor]:
        """(Q1, Q2) of the online critic; ``frozen`` detaches its parameters (the actor step)."""
        params = self.critic_params.detach() if frozen else self.critic_params
        with params.to_module(self.critic, preserve_module_state=False):
            return self.critic(features, action)

    def target_q_values(self, features: Tensor, action: Tensor) -> tuple[Tensor, Tensor]:
        """(Q1', Q2') of the target critic."""
        with self.target_critic_params.to_module(self.critic, preserve_module_state=False):
            return self.critic(features, action)

    @property
    def alpha(self) -> Tensor:
        """The temperature α of a ``SquashedGaussian`` sampler."""
        if not isinstance(self.sampler, SquashedGaussian):
            raise AttributeError(f"{type(self).__name__} acts with DrQ-v2's noisy deterministic actor; it has no temperature.")
        return self.sampler.alpha

    @property
    def has_value_estimator(self) -> bool:
        """Whether :meth:`make_value_estimator` was called (its ``gamma`` set); TorchRL would otherwise make a default one."""
        return self._value_estimator is not None

    def prepare_compile(self) -> None:
        """Set up what a compiled update needs before it is traced (:class:`~vigen.losses.UpdateStep` calls it; nothing here)."""

    def make_policy(self, action_spec: TensorSpec, *, pixels_key: NestedKey = "pixels") -> TensorDictModuleBase:
        """The acting policy (a TorchRL module, pixels → ``"action"``) on this loss's live networks.

        The module is the one name vigen gives "policy". With
        :class:`~vigen.losses.NoisyDeterministic`: ``actor(encoder(pixels))`` and TorchRL's
        ``AdditiveGaussianModule`` whose σ follows the loss's std schedule (call
        ``policy[-1].step(frames)`` as frames are collected); the noise is added when the
        exploration type is ``RANDOM`` (collectors' default) and left out under ``DETERMINISTIC``
        (evaluation), unclipped, the action clamped to the spec, as in DrQ-v2's acting. With
        :class:`~vigen.losses.SquashedGaussian`: a ``ProbabilisticActor`` sampling the
        tanh-squashed Gaussian (its mean under ``DETERMINISTIC``).
        """
        return self.sampler.acting_module(PixelsToAction(self), action_spec, pixels_key, self.device)

    def optimizer_groups(self, lr: float) -> list[dict[str, Any]]:
        """Parameter groups for one optimizer over the whole loss: ``torch.optim.Adam(loss.optimizer_groups(lr))``.

        One group at ``lr``, then one per entry of ``param_groups`` (a module: ``"actor"``, ``"sampler"`` (SAC's
        temperature), ``"input_mask"``, ...; or ``"encoder"`` for the encoder's parameters) with its own options
        (MaDi's masker: lr 1e-3, betas (0.9, 0.999)). A group's ``every`` stays in it for
        :class:`~vigen.losses.UpdateStep`, which steps the group on every N-th update only.

        Examples:
            >>> from vigen.losses import make_loss
            >>> loss = make_loss("drq", (9, 32, 32), 2, hidden_dim=8, param_groups={"actor": {"lr": 1e-3, "every": 2}})
            >>> [(group["lr"], group.get("every", 1)) for group in loss.optimizer_groups(1e-4)]
            [(0.0001, 1), (0.001, 2)]
        """
        groups, own = [], set()
        for name, options in self.param_groups.items():
            module = self.encoder_params if name == "encoder" else getattr(self, name, None)
            if not isinstance(module, nn.Module):
                own = ["encoder", "actor", "critic", *(child for child, value in self.named_children()
                                                       if not child.endswith("_params") and any(True for _ in value.parameters()))]
                raise ValueError(f"{type(self).__name__}: param_groups names {name!r}, which is not one of its modules "
                                 f"({', '.join(dict.fromkeys(own))}).")
            params = list(module.parameters())
            if not params:
                raise ValueError(f"{type(self).__name__}: param_groups names {name!r}, which has no parameters "
                                 f"(a DDPG sampler has no temperature).")
            own.update(id(parameter) for parameter in params)
            resolved = {key: value for key, value in options.items() if key != "lr_scale"}
            if "lr_scale" in options:  # a multiple of the base learning rate (VRL3's encoder)
                resolved["lr"] = lr * options["lr_scale"]
            groups.append({"params": params, **resolved})
        rest = [parameter for parameter in self.parameters() if id(parameter) not in own]
        return [{"params": rest, "lr": lr}, *groups]

    def seed_augmentations(self, seed: int | None) -> None:
        """Seed every augmentation this loss owns, each with its own stream below ``seed``.

        The streams follow the augmentations' order in the module tree, so a loss built the same
        way draws the same views. ``None`` returns them to torch's global RNG.
        """
        augmentations = [module for module in self.modules() if isinstance(module, ImageAugmentation)]
        for index, augmentation in enumerate(augmentations):
            augmentation.set_seed(derive_seed(seed, index))

    # -- TorchRL plumbing ----------------------------------------------------------------------
    @property
    def device(self) -> torch.device:
        """The device of the networks (of the first parameter): batches come on it and policies act there."""
        return next(self.parameters()).device

    @property
    def in_keys(self) -> list[NestedKey]:
        keys = self.tensor_keys
        return [
            keys.pixels, keys.action, ("next", keys.pixels),
            ("next", keys.reward), ("next", keys.done), ("next", keys.terminated),
        ]

    @in_keys.setter
    def in_keys(self, value: Any) -> None:
        self._in_keys = value

    def make_value_estimator(self, value_type: ValueEstimators | None = None, **hyperparams: Any) -> ActorCriticLoss:
        """Build the TD(0) estimator (``gamma`` here: ``loss.make_value_estimator(gamma=0.99)``), on the loss's device."""
        value_type, hyperparams = self._prepare_value_estimator_kwargs(value_type, **hyperparams)
        if value_type is None:
            return self
        hyperparams.setdefault("device", self.device)  # its gamma buffer lives with the networks
        dispatch_value_estimator(
            self,
            value_type,
            supported=self.SUPPORTED_VALUE_ESTIMATORS,
            tensor_keys=self._value_keys(),
            value_network=None,
            **hyperparams,
        )
        return self

    def _forward_value_estimator_keys(self, **kwargs: Any) -> None:
        if self._value_estimator is not None:
            self._value_estimator.set_keys(**self._value_keys())

    def _value_keys(self) -> dict[str, NestedKey]:
        keys = self.tensor_keys
        return {
            "reward": keys.reward, "done": keys.done, "terminated": keys.terminated,
            "steps_to_next_obs": keys.steps_to_next_obs,
        }

    def reset_parameters_recursive(self) -> None:
        """Re-initialise every network (DrQ-v2's init) and copy each online network into its target."""
        for name in ("encoder", "actor", "critic"):
            with getattr(self, f"{name}_params").to_module(getattr(self, name)):
                getattr(self, name).apply(_reinitialise)
        for module in self.children():
            if not isinstance(module, TensorDictParams) and any(True for _ in module.parameters()):
                module.apply(_reinitialise)
        for name in ("encoder", "actor", "critic"):
            target = getattr(self, f"target_{name}_params", None)
            if target is not None:
                target.data.update_(getattr(self, f"{name}_params").data)

    # -- what the batch must hold ------------------------------------------------------------
    def _required_keys(self) -> dict[NestedKey, str]:
        """Batch key → its ``set_keys`` name, for every entry the update cannot do without."""
        keys = self.tensor_keys
        return {
            unravel_key(keys.pixels): "pixels", unravel_key(keys.action): "action",
            unravel_key(("next", keys.pixels)): "pixels", unravel_key(("next", keys.reward)): "reward",
            unravel_key(("next", keys.terminated)): "terminated",
        }

    def check_batch(self, tensordict: TensorDictBase) -> None:
        """Raise, before any work, on missing entries and on pixels that break the pixel contract (every call does).

        Float pixels are also scanned for their range (NaN, inf, above ``max_value``: one ``amax``).
        Where reading that value back is free (CPU tensors, eager) every batch is scanned; on an
        accelerator the scan is a host synchronization, so only the first batch the loss sees outside
        ``torch.compile`` is (a wrong scale is a property of the data pipeline, not of one batch; a
        NaN later shows as a non-finite loss, see ``check_finite``). :class:`~vigen.losses.UpdateStep`
        checks its first batch so, before it compiles.
        """
        name = type(self).__name__
        required = self._required_keys()
        missing = [key for key in required if tensordict.get(key, None) is None]
        if missing:
            names = sorted({required[key] for key in missing})
            fix = ", ".join(f"{n}=..." for n in names)
            message = (
                f"{name}: the batch has no {', '.join(map(repr, missing))}. Store "
                f"{'it' if len(missing) == 1 else 'them'} in the replay buffer, or point the loss at your keys "
                f"with loss.set_keys({fix})."
            )
            if "terminated" in names:
                message += (
                    " ('next', 'terminated') marks true terminations (no bootstrap) apart from time limits, which "
                    "bootstrap; TorchRL envs write it. If every done of your data is a true termination, use "
                    "loss.set_keys(terminated='done')."
                )
            present = ", ".join(sorted(map(repr, tensordict.keys(True, True))))
            raise KeyError(f"{message} The batch has: {present}.")
        keys = self.tensor_keys
        action = tensordict.get(keys.action)
        action_dim = getattr(self.critic, "action_dim", None)
        if action_dim is not None and action.shape[-1:] != (action_dim,):
            raise ValueError(f"{name}: the batch's {unravel_key(keys.action)!r} has shape {tuple(action.shape)}, but the critic "
                             f"was built for actions of size {action_dim}; build the loss with the env's action size "
                             f"(make_loss(..., action_dim={action.shape[-1] if action.ndim else 1})) or store the full action.")
        for flag in (("next", keys.terminated), ("next", keys.done)):
            value = tensordict.get(flag, None)
            if value is not None and value.dtype != torch.bool:
                raise TypeError(f"{name}: the batch's {unravel_key(flag)!r} is {value.dtype}, but done and terminated flags "
                                "are booleans (TorchRL envs write torch.bool); convert them with .bool() before storing.")
        scan = None if self._scanned_pixels else True  # None: where host reads are free (check_pixels)
        for key in (keys.pixels, ("next", keys.pixels)):
            try:
                check_pixels(tensordict.get(key), name=f"{name} (batch entry {unravel_key(key)!r})", max_value=self.max_value,
                             scan=scan)
            except ValueError as error:
                if "max_value" not in str(error):
                    raise
                raise ValueError(f"{error} The loss takes max_value from its encoder: build the encoder with "
                                 "max_value=... (or make_loss(..., max_value=...)).") from None
        if not torch.compiler.is_compiling():  # check_pixels scans nothing while compiling
            self._scanned_pixels = True

    @staticmethod
    def _nonfinite(out: Mapping[str, Tensor]) -> Tensor:
        """Whether any ``loss_*`` value of ``out`` is NaN or inf, a 0-d boolean tensor (tensor ops only)."""
        losses = [value.detach().reshape(-1) for key, value in out.items() if key.startswith("loss_")]
        return ~torch.isfinite(torch.cat(losses)).all()

    def raise_if_nonfinite(self) -> None:
        """Raise ``FloatingPointError`` if a call off the CPU gave a NaN or inf loss (reads one number: call it when logging).

        Where reading a value back to the host is not free (an accelerator, ``torch.compile``), a loss
        with ``check_finite`` counts such calls in ``nonfinite_calls`` instead of raising inside the call.
        """
        count = int(self.nonfinite_calls)
        if count:
            raise FloatingPointError(
                f"{type(self).__name__}: {count} call(s) on {self.nonfinite_calls.device} gave a NaN or inf loss_* (counted "
                "on the device: raising inside the call would synchronize with the host). Check the replay buffer for NaN "
                "or inf entries, and if the batches are finite lower the learning rate, clip gradients or scale the rewards; "
                "one call of the loss on the CPU raises at once and names the batch entries or parameters to blame.")

    def _check_finite(self, out: dict[str, Tensor], tensordict: TensorDictBase) -> None:
        """Raise if a ``loss_*`` value is NaN or inf, naming the batch entries (or parameters) to blame."""
        losses = {key: value for key, value in out.items() if key.startswith("loss_")}
        if not self._nonfinite(losses):
            return
        name = type(self).__name__
        bad = [key for key, value in losses.items() if not torch.isfinite(value.detach()).all()]
        bad_losses, verb = ", ".join(bad), ("is" if len(bad) == 1 else "are")
        keys = self.tensor_keys
        inputs = [*self._required_keys(), unravel_key(keys.steps_to_next_obs), unravel_key(keys.priority_weight)]
        bad_inputs = []
        for key in inputs:
            value = tensordict.get(key, None)
            if value is not None and value.is_floating_point() and not torch.isfinite(value).all():
                bad_inputs.append(key)
        if bad_inputs:
            raise ValueError(
                f"{name}: {bad_losses} {verb} NaN or inf because the batch entries {', '.join(map(repr, bad_inputs))} hold "
                "NaN or inf values; drop or repair those transitions before they reach the replay buffer (a backward "
                "and an optimizer step would turn every parameter into NaN). Pass check_finite=False to skip this check."
            )
        bad_params = [key for key, value in self.named_parameters() if not torch.isfinite(value).all()]
        where = (f"these parameters are non-finite: {', '.join(bad_params[:8])}" + (" ..." if len(bad_params) > 8 else "")
                 if bad_params else "the parameters are finite, so the computation overflowed")
        raise FloatingPointError(
            f"{name}: {bad_losses} {verb} NaN or inf although the batch is finite; {where}. Training has diverged: "
            "lower the learning rate, clip gradients or scale the rewards. Pass check_finite=False to skip this check."
        )

    def float_pixels(self, pixels: Tensor) -> Tensor:
        """``pixels`` as floats on the encoder's float scale ``[0, max_value or 1]`` (the same features).

        Examples:
            >>> import torch
            >>> from vigen.losses import make_loss
            >>> make_loss("drqv2", (9, 16, 16), 2, hidden_dim=8).float_pixels(torch.tensor([255], dtype=torch.uint8))
            tensor([1.])
        """
        if pixels.is_floating_point():
            return pixels
        return pixels.float() / (255.0 / (1.0 if self.max_value is None else self.max_value))

    def _checked_param_groups(self, param_groups: Mapping[str, Mapping[str, Any]]) -> dict[str, dict[str, Any]]:
        """``param_groups`` checked: known options (:data:`PARAM_GROUP_OPTIONS`), a positive finite lr or lr scale."""
        name = type(self).__name__
        checked = {}
        for module, options in param_groups.items():
            unknown = sorted(set(options) - PARAM_GROUP_OPTIONS)
            if unknown:
                raise ValueError(f"{name}: param_groups[{module!r}] has unknown options {unknown}; "
                                 f"the options are {sorted(PARAM_GROUP_OPTIONS)}.")
            for key in ("lr", "lr_scale"):
                value = options.get(key, 1.0)
                if isinstance(value, bool) or not isinstance(value, (int, float)) or not (math.isfinite(value) and value > 0):
                    raise ValueError(f"{name}: param_groups[{module!r}][{key!r}] must be a positive number, got {value!r}.")
            betas = options.get("betas", (0.9, 0.999))
            if not (len(betas) == 2 and all(isinstance(beta, (int, float)) and 0 <= beta < 1 for beta in betas)):
                raise ValueError(f"{name}: param_groups[{module!r}]['betas'] are Adam's (β1, β2), each in [0, 1), got {betas!r}.")
            every = options.get("every", 1)
            if isinstance(every, bool) or not isinstance(every, int) or every < 1:
                raise ValueError(f"{name}: param_groups[{module!r}]['every'] is a number of updates, an integer >= 1, got {every!r}.")
            checked[module] = {key: (tuple(float(beta) for beta in value) if key == "betas" else
                                     int(value) if key == "every" else float(value))
                               for key, value in options.items()}
        return checked

    def _augmentations(self, augmentations: Augmentations) -> nn.ModuleList:
        """Private copies of ``augmentations``; those without a ``max_value`` get the loss's (its encoder's)."""
        if augmentations is None:
            return nn.ModuleList()
        if not isinstance(augmentations, Sequence):
            augmentations = [augmentations]
        copies = []
        for augmentation in augmentations:
            if not isinstance(augmentation, ImageAugmentation):
                raise TypeError(
                    f"Augmentations must be vigen ImageAugmentations (e.g. RandomShift()), got {type(augmentation).__name__}."
                )
            if None not in (augmentation.max_value, self.max_value) and augmentation.max_value != self.max_value:
                raise ValueError(
                    f"{type(augmentation).__name__} has max_value={augmentation.max_value} but the encoder's is "
                    f"{self.max_value}: float pixels have one scale. Leave the augmentation's max_value unset "
                    "(the loss gives it the encoder's)."
                )
            copy = augmentation.clone()
            if copy.max_value is None:
                copy.max_value = self.max_value
            copies.append(copy)
        return nn.ModuleList(copies)


class PixelsToAction(nn.Module):
    """A loss's acting network, ``actor(encoder(input_mask(pixels)))``, sharing the loss's modules."""

    def __init__(self, loss: ActorCriticLoss) -> None:
        super().__init__()
        self.input_mask = loss.input_mask
        self.encoder = loss.encoder
        self.head = loss.actor

    def forward(self, pixels: Tensor) -> ActorOutput:
        if self.input_mask is not None:
            pixels = self.input_mask(pixels)
        return self.head(self.encoder(pixels))


class RunningStatistics(nn.Module):
    """Runs ``module`` with every BatchNorm in it on its running statistics, then puts them back in their mode.

    VRL3 acts (and evaluates) with its agent in eval mode while its updates run in training mode;
    a policy sharing the loss's encoder does the same through this wrapper, without touching the
    rest of the module's mode.

    Examples:
        >>> import torch
        >>> from torch import nn
        >>> net = RunningStatistics(nn.Sequential(nn.Conv2d(3, 4, 3), nn.BatchNorm2d(4)))
        >>> out = net(torch.rand(1, 3, 8, 8))
        >>> net.module[1].training, int(net.module[1].num_batches_tracked)  # still training, stats untouched
        (True, 0)
    """

    def __init__(self, module: nn.Module) -> None:
        super().__init__()
        self.module = module

    def forward(self, *args: Any) -> Any:
        norms = [m for m in self.module.modules() if isinstance(m, BATCH_NORMS) and m.training]
        for norm in norms:
            norm.train(False)
        try:
            return self.module(*args)
        finally:
            for norm in norms:
                norm.train(True)


def _reinitialise(module: nn.Module) -> None:
    if isinstance(module, (nn.Linear, nn.Conv2d, nn.ConvTranspose2d)):
        weight_init(module)
    elif hasattr(module, "reset_parameters"):
        module.reset_parameters()

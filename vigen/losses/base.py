"""The actor-critic update every vigen loss shares, written in the order of DrQ-v2's ``update``.

:class:`ActorCriticLoss` runs, on one replay-buffer batch:

1. **augment**: the weak views ``obs = aug(pixels)``, ``next_obs = aug(next pixels)``;
2. **critic target** (no gradient): ``y = r + γⁿ·(1 − terminated)·V(next_obs)``;
3. **critic loss**: the TD error of every critic view, weighted, from one encoder pass;
4. **actor loss**: on detached features, through a frozen critic;
5. **auxiliary losses**: what a method adds (contrastive, attribution, temperature, ...).

Each step is a method that returns a small typed result (:class:`Observations`,
:class:`CriticResult`, :class:`ActorResult`, :class:`AuxiliaryResult`), and a method changes
what it needs through named hooks:

* :meth:`~ActorCriticLoss.critic_views`: the views the TD loss is taken on and their weights
  (SVEA's strong view, DrQ's clean view);
* :meth:`~ActorCriticLoss.auxiliary_views`: more views to encode, with gradient, in the same
  encoder pass (CURL's anchor);
* :meth:`~ActorCriticLoss.actor_features`: what the actor reads and what the critic scores its
  actions on (SADA trains the actor on clean and augmented views against the clean Q);
* ``input_mask``: a module in front of the encoder for every view and for the acting policy
  (MaDi's masker);
* the encoder itself: any module from pixels to features (SimGRL encodes each frame apart and
  stacks features; PIE-G's is a frozen ResNet);
* :meth:`~ActorCriticLoss.auxiliary_losses`: extra ``loss_*`` terms (CURL, SGQN, SCPL);
* :meth:`~ActorCriticLoss.sample_action` and :meth:`~ActorCriticLoss.next_value`: the policy's
  sampling and the bootstrapped value (DDPG's clipped noise, SAC's entropy term);
* :meth:`~ActorCriticLoss.make_policy`: the acting policy, from the same networks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any, Literal

import torch
from tensordict import TensorDict, TensorDictBase, TensorDictParams
from tensordict.nn import TensorDictModuleBase, dispatch
from tensordict.utils import NestedKey, unravel_key
from torch import Tensor, nn
from torchrl.data import TensorSpec
from torchrl.objectives import LossModule
from torchrl.objectives.utils import ValueEstimators, dispatch_value_estimator

from vigen.models import weight_init
from vigen.pixel_format import check_pixels
from vigen.seeding import derive_seed
from vigen.transforms import ImageAugmentation, RandomShift

Augmentations = ImageAugmentation | Sequence[ImageAugmentation] | None


@dataclass(frozen=True)
class Observations:
    """What one update reads from its batch, and the weak views it draws (step 1).

    Attributes:
        pixels: the stored frame stacks ``[B, 3·k, H, W]``.
        next_pixels: the stored next frame stacks.
        action: the actions taken, ``[B, A]``.
        obs: the weak view of ``pixels`` (``pixels`` itself without augmentation).
        next_obs: the weak view of ``next_pixels``, drawn independently.
    """

    pixels: Tensor
    next_pixels: Tensor
    action: Tensor
    obs: Tensor
    next_obs: Tensor

    @property
    def batch_size(self) -> int:
        return self.pixels.shape[0]


@dataclass(frozen=True)
class View:
    """One view the critic's TD loss is taken on, with its weight in ``loss_critic``.

    A view with a ``name`` logs the mean Q1 of its samples as ``q_<name>_mean``.
    """

    pixels: Tensor
    weight: float | Tensor = 1.0
    name: str | None = None


@dataclass
class CriticResult:
    """The critic step's per-sample loss and what later steps read from it (step 3).

    Attributes:
        loss: per-sample critic loss ``[B]``, gradient to the critic and the encoder.
        q1, q2: both Q values of the first view ``[B, 1]`` (the TD error and ``q_mean`` use them).
        view_features: encoder features of every critic view, in the order of
            :meth:`ActorCriticLoss.critic_views`, with gradient.
        auxiliary_features: encoder features of :meth:`ActorCriticLoss.auxiliary_views`.
        metrics: detached values to log.
    """

    loss: Tensor
    q1: Tensor
    q2: Tensor
    view_features: tuple[Tensor, ...]
    auxiliary_features: tuple[Tensor, ...] = ()
    metrics: dict[str, Tensor] = field(default_factory=dict)

    @property
    def features(self) -> Tensor:
        """Features of the first view: what the actor reads (detached) by default."""
        return self.view_features[0]


@dataclass
class ActorResult:
    """The actor step's per-sample loss (step 4).

    Attributes:
        loss: per-sample actor loss ``[B']`` (``B'`` is ``B`` unless the actor reads more views).
        log_prob: log-probability of the sampled actions, for losses with a learned temperature.
        metrics: detached values to log.
    """

    loss: Tensor
    log_prob: Tensor | None = None
    metrics: dict[str, Tensor] = field(default_factory=dict)


@dataclass
class AuxiliaryResult:
    """The extra per-sample ``loss_*`` terms of a method, and their metrics (step 5)."""

    losses: dict[str, Tensor] = field(default_factory=dict)
    metrics: dict[str, Tensor] = field(default_factory=dict)


def default_shift(augmentation: Augmentations | Literal["default"]) -> Augmentations:
    """A loss's weak augmentation argument: ``"default"`` is DrQ-v2's ``RandomShift(pad=4)``, a new one each call.

    The losses take ``augmentation="default"`` rather than a module instance as default argument
    (one instance would be shared by every loss built with the default).

    Examples:
        >>> default_shift("default")
        RandomShift(pad=4, in_keys=['pixels'])
        >>> default_shift(None) is None
        True
    """
    if isinstance(augmentation, str):
        if augmentation != "default":
            raise ValueError(f"augmentation must be an ImageAugmentation, a list of them, None or 'default', got {augmentation!r}.")
        return RandomShift(pad=4)
    return augmentation


def td_error(q1: Tensor, q2: Tensor, target: Tensor) -> Tensor:
    """Per-sample squared TD error of both critics, ``(Q1 − y)² + (Q2 − y)²``, shape ``[B]``.

    The sum of two MSEs of DrQ-v2's critic loss, before the batch mean.

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Examples:
        >>> import torch
        >>> td_error(torch.tensor([[1.0]]), torch.tensor([[3.0]]), torch.tensor([[2.0]]))
        tensor([2.])
    """
    return ((q1 - target).pow(2) + (q2 - target).pow(2)).squeeze(-1)


class ActorCriticLoss(LossModule):
    """The skeleton of vigen's augmentation-based actor-critic losses (see the module docstring).

    Subclasses choose the policy (:meth:`sample_action`, :meth:`next_value`, :meth:`make_policy`)
    and what their method adds through the hooks. The skeleton owns the TorchRL plumbing: keys
    (``set_keys``), the TD(0) value estimator (``make_value_estimator(gamma=...)``; n-step returns
    through ``steps_to_next_obs``), the batch checks, prioritized-replay weights and the
    ``td_error`` priority, ``reduction`` and the finite-loss check.

    The batch (checked before any work, naming every missing key and the fix):

    * ``pixels`` and ``("next", "pixels")``: frame stacks ``[B, 3·k, H, W]`` as
      :mod:`vigen.pixel_format` defines them, uint8 on 0–255 or float on ``[0, max_value]``. The
      loss's ``max_value`` is its encoder's (vigen's encoders take ``max_value=``), so it is set
      once, on the encoder; every augmentation of the loss whose ``max_value`` is ``None`` gets it.
    * ``action``, ``("next", "reward")`` and ``("next", "terminated")``. ``terminated`` tells true
      terminations from time limits; a batch without it is refused rather than bootstrapping
      from ``done``. If every ``done`` of your data is a true termination, say so with
      ``loss.set_keys(terminated="done")``.
    * optional: ``steps_to_next_obs`` (n-step), ``priority_weight`` (prioritized replay).

    With ``check_finite`` (the default) a non-finite ``loss_*`` raises inside the call, before
    any optimizer step: a ``ValueError`` naming the batch entries that hold NaN or inf, or a
    ``FloatingPointError`` naming the non-finite parameters when the batch is finite.

    Paper: DrQ-v2 (the update this skeleton follows), https://arxiv.org/abs/2107.09645.

    Args:
        encoder: pixels ``[B, 3·k, H, W]`` → features ``[B, D]``.
        actor: features → the policy's parameters.
        critic: (features, action) → (Q1, Q2); it gets target parameters (``target_critic_params``)
            for ``torchrl.objectives.SoftUpdate``.
        augmentation: the weak augmentation, drawn independently for obs and next obs (``None``
            if the replay buffer already augments).
        input_mask: a module applied to the pixels before the encoder, in every view and in the
            acting policy (MaDi's masker); ``None`` for none.
        channels_last: run the convolutions in channels-last memory layout.
        reduction: ``"mean"``, ``"sum"`` or ``"none"`` (per-sample losses).
        check_finite: raise when a loss is NaN or inf; ``False`` skips the check.

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
            priority: where the TD error is written for prioritized replay.
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
    out_keys = ["loss_critic", "loss_actor", "q_mean", "target_mean", "target_std"]
    compiles_whole = True
    """Whether ``torch.compile(fullgraph=True)`` traces the whole update (:class:`~vigen.losses.UpdateStep`)."""

    encoder: nn.Module
    encoder_params: TensorDictParams
    target_encoder_params: TensorDictParams
    actor: nn.Module
    actor_params: TensorDictParams
    target_actor_params: TensorDictParams
    critic: nn.Module
    critic_params: TensorDictParams
    target_critic_params: TensorDictParams

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        augmentation: Augmentations = None,
        input_mask: nn.Module | None = None,
        channels_last: bool = True,
        reduction: str = "mean",
        check_finite: bool = True,
    ) -> None:
        super().__init__()
        if reduction not in ("mean", "sum", "none"):
            raise ValueError(f"reduction must be 'mean', 'sum' or 'none', got {reduction!r}.")
        self._in_keys = None
        self.reduction = reduction
        self.check_finite = check_finite
        self.max_value: float | None = getattr(encoder, "max_value", None)
        self.channels_last = channels_last
        if channels_last:
            encoder.to(memory_format=torch.channels_last)
        self.input_mask = input_mask
        self.convert_to_functional(encoder, "encoder")
        self.convert_to_functional(actor, "actor")
        self.convert_to_functional(critic, "critic", create_target_params=True)
        self.augmentation = self._augmentations(augmentation)
        self.register_buffer("schedule_step", torch.zeros((), dtype=torch.long))

    def set_step(self, step: int) -> None:
        """Evaluate the loss's schedules at ``step`` from now on (DrQ-v2: agent steps = frames / action repeat)."""
        self.schedule_step.fill_(int(step))

    # -- the update, in DrQ-v2's order -------------------------------------------------------
    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        self._check_batch(tensordict)
        batch = self.observations(tensordict)                   # 1. augment
        with torch.no_grad():
            target = self.critic_target(batch, tensordict)      # 2. critic target
        critic = self.critic_loss(batch, target)                # 3. critic loss (trains the encoder)
        actor = self.actor_loss(batch, critic)                  # 4. actor loss (detached features)
        auxiliary = self.auxiliary_losses(batch, critic, actor)  # 5. what the method adds
        return self._output(tensordict, target, critic, actor, auxiliary)

    def observations(self, tensordict: TensorDictBase) -> Observations:
        """Step 1: read the batch and draw the weak views of obs and next obs."""
        keys = self.tensor_keys
        pixels, next_pixels = tensordict.get(keys.pixels), tensordict.get(("next", keys.pixels))
        return Observations(
            pixels=pixels, next_pixels=next_pixels, action=tensordict.get(keys.action),
            obs=self.augment(pixels), next_obs=self.augment(next_pixels),
        )

    def critic_target(self, batch: Observations, tensordict: TensorDictBase) -> Tensor:
        """Step 2: ``y = r + γⁿ·(1 − terminated)·V(h')`` with ``h' = encoder(next_obs)``, ``[B, 1]``.

        The online encoder encodes the next view (DrQ-v2 has no target encoder); :meth:`next_value`
        gives ``V``.
        """
        next_value = self.next_value(self.encode(batch.next_obs))
        return self.value_estimator.value_estimate(tensordict, next_value=next_value)

    def critic_loss(self, batch: Observations, target: Tensor) -> CriticResult:
        """Step 3: ``Σ_views weight·[(Q1(h, a) − y)² + (Q2(h, a) − y)²]`` per sample.

        The critic views and the auxiliary views share one encoder pass when their shapes agree.
        """
        views = self.critic_views(batch)
        extra = self.auxiliary_views(batch)
        features = self.encode_views([view.pixels for view in views] + list(extra))
        view_features, auxiliary_features = features[: len(views)], features[len(views):]
        count = len(views)
        q1, q2 = self.q_values(torch.cat(view_features) if count > 1 else view_features[0], batch.action.repeat(count, 1))
        errors = td_error(q1, q2, target.repeat(count, 1)).split(batch.batch_size)
        loss = views[0].weight * errors[0]
        for view, error in zip(views[1:], errors[1:]):
            loss = loss + view.weight * error
        size = batch.batch_size
        metrics = {f"q_{view.name}_mean": q.detach().mean() for view, q in zip(views, q1.split(size)) if view.name}
        return CriticResult(loss, q1[:size], q2[:size], tuple(view_features), tuple(auxiliary_features), metrics)

    def actor_loss(self, batch: Observations, critic: CriticResult) -> ActorResult:
        """Step 4: ``−min(Q1, Q2)(h, ã)`` with ``ã`` sampled from the policy on detached features.

        The critic is frozen here (its parameters detached): the actor loss trains the actor only.
        """
        policy_features, critic_features = self.actor_features(batch, critic)
        action, log_prob = self.sample_action(policy_features)
        q1, q2 = self.q_values(critic_features, action, frozen=True)
        return ActorResult(-torch.min(q1, q2).squeeze(-1), log_prob)

    def auxiliary_losses(self, batch: Observations, critic: CriticResult, actor: ActorResult) -> AuxiliaryResult:
        """Step 5: the method's extra per-sample ``loss_*`` terms (none here)."""
        return AuxiliaryResult()

    # -- hooks ----------------------------------------------------------------------------------
    def augment(self, pixels: Tensor) -> Tensor:
        """The weak augmentation (a fresh draw per call)."""
        return self._augment(self.augmentation, pixels)

    def critic_views(self, batch: Observations) -> list[View]:
        """The views the TD loss is taken on; the first one's features feed the actor."""
        return [View(batch.obs)]

    def auxiliary_views(self, batch: Observations) -> list[Tensor]:
        """Views encoded with gradient in the critic's encoder pass, for :meth:`auxiliary_losses`."""
        return []

    def actor_features(self, batch: Observations, critic: CriticResult) -> tuple[Tensor, Tensor]:
        """(what the policy reads, what the critic scores its actions on), both detached."""
        features = critic.features.detach()
        return features, features

    def sample_action(self, features: Tensor) -> tuple[Tensor, Tensor | None]:
        """A differentiable action sample from the policy at ``features``, and its log-probability."""
        raise NotImplementedError

    def next_value(self, next_features: Tensor) -> Tensor:
        """The bootstrapped value at the next features, through the target critic, ``[B, 1]``."""
        raise NotImplementedError

    def make_policy(self, action_spec: TensorSpec, *, pixels_key: NestedKey = "pixels") -> TensorDictModuleBase:
        """The acting policy (a TorchRL module, pixels → ``"action"``) on this loss's live networks."""
        raise NotImplementedError

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

    def policy(self, features: Tensor) -> Tensor | tuple[Tensor, ...]:
        """The actor's output at ``features``."""
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

    def metrics(self) -> dict[str, Tensor]:
        """Loss-wide values logged with every update (e.g. the noise std)."""
        return {}

    def prepare_compile(self) -> None:
        """Set up what a compiled update needs before it is traced (:class:`~vigen.losses.UpdateStep` calls it; nothing here)."""

    def optimizer_groups(self, lr: float) -> list[dict[str, Any]]:
        """Parameter groups for one optimizer over the whole loss: ``torch.optim.Adam(loss.optimizer_groups(lr))``.

        One group at ``lr`` here; a method whose paper gives a module its own learning rate or
        betas (MaDi's masker) returns that module's parameters as a group of their own.
        """
        return [{"params": list(self.parameters()), "lr": lr}]

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

    def _output(
        self,
        tensordict: TensorDictBase,
        target: Tensor,
        critic: CriticResult,
        actor: ActorResult,
        auxiliary: AuxiliaryResult,
    ) -> TensorDict:
        keys = self.tensor_keys
        priority = torch.maximum((critic.q1 - target).abs(), (critic.q2 - target).abs()).detach().squeeze(-1)
        tensordict.set(keys.priority, priority)
        size = priority.shape[0]
        out = {
            "loss_critic": self._reduce_loss(critic.loss, tensordict, weights=self._maybe_get_priority_weight(tensordict)),
            "loss_actor": self._reduce_loss(_per_sample(actor.loss, size), tensordict),
        }
        for name, value in auxiliary.losses.items():
            out[name] = self._reduce_loss(_per_sample(value, size), tensordict)
        out.update(q_mean=critic.q1.detach().mean(), target_mean=target.mean(), target_std=target.std(), **self.metrics())
        for metrics in (critic.metrics, actor.metrics, auxiliary.metrics):
            out.update({name: value.detach() for name, value in metrics.items()})
        if self.check_finite and not torch.compiler.is_compiling():  # a compiled update guards with tensor ops (UpdateStep)
            self._check_finite(out, tensordict)
        return TensorDict(out, batch_size=[])

    # -- what the batch must hold ------------------------------------------------------------
    def _required_keys(self) -> dict[NestedKey, str]:
        """Batch key → its ``set_keys`` name, for every entry the update cannot do without."""
        keys = self.tensor_keys
        return {
            unravel_key(keys.pixels): "pixels", unravel_key(keys.action): "action",
            unravel_key(("next", keys.pixels)): "pixels", unravel_key(("next", keys.reward)): "reward",
            unravel_key(("next", keys.terminated)): "terminated",
        }

    def _check_batch(self, tensordict: TensorDictBase) -> None:
        """Raise, before any work, on missing entries and on pixels that break the pixel contract."""
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
        for key in (keys.pixels, ("next", keys.pixels)):
            try:
                check_pixels(tensordict.get(key), name=f"{name} (batch entry {unravel_key(key)!r})", max_value=self.max_value,
                             scan=True)
            except ValueError as error:
                if "max_value" not in str(error):
                    raise
                raise ValueError(f"{error} The loss takes max_value from its encoder: build the encoder with "
                                 "max_value=... (or make_loss(..., max_value=...)).") from None

    def _check_finite(self, out: dict[str, Tensor], tensordict: TensorDictBase) -> None:
        """Raise if a ``loss_*`` value is NaN or inf, naming the batch entries (or parameters) to blame."""
        losses = {key: value for key, value in out.items() if key.startswith("loss_")}
        if torch.isfinite(torch.cat([value.detach().reshape(-1) for value in losses.values()])).all():
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

    def _to_float(self, pixels: Tensor) -> Tensor:
        """``pixels`` as floats on the encoder's float scale ``[0, max_value or 1]`` (the same features)."""
        if pixels.is_floating_point():
            return pixels
        return pixels.float() / (255.0 / (1.0 if self.max_value is None else self.max_value))

    @staticmethod
    def _augment(augmentations: nn.ModuleList, pixels: Tensor) -> Tensor:
        for augmentation in augmentations:
            augmented = augmentation.augment(pixels)
            if augmented.dtype != pixels.dtype:
                raise TypeError(
                    f"{type(augmentation).__name__} turned {pixels.dtype} pixels into {augmented.dtype}; the loss "
                    "cannot tell their scale. Augmentations keep the dtype: end apply() with .to(images.dtype)."
                )
            pixels = augmented
        return pixels

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


def _per_sample(loss: Tensor, batch_size: int) -> Tensor:
    """A loss over ``k`` views of each sample (``[k·B]``, view-major) as the per-sample mean over its views, ``[B]``."""
    if loss.ndim == 1 and loss.shape[0] != batch_size and loss.shape[0] % batch_size == 0:
        return loss.reshape(-1, batch_size).mean(0)
    return loss


def _reinitialise(module: nn.Module) -> None:
    if isinstance(module, (nn.Linear, nn.Conv2d, nn.ConvTranspose2d)):
        weight_init(module)
    elif hasattr(module, "reset_parameters"):
        module.reset_parameters()

"""DrQ-v2's actor-critic update as a TorchRL LossModule, and the skeleton SVEA, SRM, SGQN and CURL extend."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import torch
from tensordict import TensorDict, TensorDictBase, TensorDictParams
from tensordict.nn import dispatch
from tensordict.utils import NestedKey, unravel_key
from torch import Tensor, nn
from torchrl.objectives import LossModule
from torchrl.objectives.utils import ValueEstimators, dispatch_value_estimator

from vigen.losses.sampling import clipped_normal_sample
from vigen.losses.schedule import LinearSchedule
from vigen.models import weight_init
from vigen.pixel_format import check_pixels
from vigen.transforms import ImageAugmentation, RandomShift

Augmentations = ImageAugmentation | Sequence[ImageAugmentation] | None


class DrQv2Loss(LossModule):
    """DrQ-v2's update: DDPG with a clipped double-Q target, n-step returns and random shifts.

    One call computes, on a replay-buffer batch:

    * ``loss_critic`` = MSE(Q1(h, a), y) + MSE(Q2(h, a), y) with ``h = encoder(shift(obs))`` and
      ``y = r + γⁿ·(1 − terminated)·min(Q1', Q2')(h', a')``, where ``h' = encoder(shift(next obs))``
      is computed without gradient by the *online* encoder, ``Q'`` is the target critic and
      ``a' = actor(h')`` plus clipped Gaussian noise (std from the schedule, clip 0.3). Time-limit
      truncations bootstrap, terminations do not; ``γⁿ`` uses ``steps_to_next_obs`` when the
      batch has it (TorchRL's ``MultiStepTransform``).
    * ``loss_actor`` = −min(Q1, Q2)(h.detach(), actor(h.detach()) + noise), through a detached
      critic: it trains the actor only.

    The encoder learns from the critic loss only; only the critic has target parameters
    (``target_critic_params``), moved by ``SoftUpdate(loss, tau=0.01)``. Since the gradients do
    not cross, one ``backward()`` of the sum of the ``loss_*`` entries and a step of every
    optimizer equals DrQ-v2's separate updates, except that the actor sees the critic before
    (not after) this step's update, as in TorchRL's DDPG/TD3.

    Views that go through the encoder with gradient share one encoder pass, in channels-last
    layout (vigen's encoders also convolve large batches in cache-sized chunks). The std of both noises
    follows ``std`` evaluated at the step given to :meth:`set_step` (DrQ-v2: agent steps).

    Subclasses change :meth:`_critic_terms` (the views and the extra loss terms), and may add
    auxiliary losses there.

    The batch (checked before any work, naming every missing key and the fix):

    * ``pixels`` and ``("next", "pixels")``: frame stacks ``[B, 3·k, H, W]`` as
      :mod:`vigen.pixel_format` defines them, uint8 on 0–255 or float on ``[0, max_value]``. The
      loss's ``max_value`` is its encoder's (vigen's encoders take ``max_value=``: ``None`` means
      1.0 for floats, TorchRL's ``ToTensorImage()`` scale; float pixels on 0–255 need
      ``max_value=255``), so it is set once, on the encoder; a custom encoder without that
      attribute counts as ``None``. Every augmentation of the loss, default or given, whose
      ``max_value`` is ``None`` gets the encoder's.
    * ``action``, ``("next", "reward")`` and ``("next", "terminated")``. ``terminated`` (TorchRL
      envs write it) tells true terminations from time limits; a batch without it is refused
      rather than bootstrapping from ``done``. If every ``done`` of your data is a true
      termination, say so with ``loss.set_keys(terminated="done")``.
    * optional: ``steps_to_next_obs`` (n-step), ``priority_weight`` (prioritized replay).

    With ``check_finite`` (the default) a non-finite ``loss_*`` raises inside the call, before
    any optimizer step: a ``ValueError`` naming the batch entries that hold NaN or inf, or a
    ``FloatingPointError`` naming the non-finite parameters when the batch is finite. The check
    costs one ``isfinite`` over the few loss values; the batch is only scanned when it fails.

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Args:
        encoder: pixels ``[B, 3·k, H, W]`` → features ``[B, D]``, e.g. :class:`~vigen.models.DrQv2Encoder`.
        actor: features → action mean in [-1, 1], e.g. :class:`~vigen.models.Actor`.
        critic: (features, action) → (Q1, Q2), e.g. :class:`~vigen.models.Critic`.
        augmentation: the weak augmentation, drawn independently for obs and next obs;
            default ``RandomShift(pad=4)``. ``None`` if the replay buffer already augments.
        std: the noise std, a float or a :class:`LinearSchedule` (default ``linear(1.0, 0.1, 100000)``).
        std_clip: clip of the noise (0.3).
        channels_last: run the convolutions in channels-last memory layout.
        reduction: ``"mean"`` (DrQ-v2), ``"sum"`` or ``"none"`` (per-sample losses).
        check_finite: raise when a loss is NaN or inf (see above); ``False`` skips the check.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.models import Actor, Critic, DrQv2Encoder
        >>> encoder = DrQv2Encoder(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = DrQv2Loss(encoder, Actor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32))
        >>> loss.make_value_estimator(gamma=0.99)
        DrQv2Loss(...)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> batch = TensorDict({
        ...     "pixels": pixels, "action": torch.rand(4, 2) * 2 - 1,
        ...     "next": {"pixels": pixels, "reward": torch.ones(4, 1),
        ...              "done": torch.zeros(4, 1, dtype=torch.bool),
        ...              "terminated": torch.zeros(4, 1, dtype=torch.bool)},
        ... }, batch_size=[4])
        >>> out = loss(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_critic']
        >>> sum(out[key] for key in ("loss_actor", "loss_critic")).backward()
        >>> loss(batch.exclude(("next", "terminated")))
        Traceback (most recent call last):
        ...
        KeyError: "DrQv2Loss: the batch has no ('next', 'terminated')...
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
    out_keys = ["loss_critic", "loss_actor", "q_mean", "target_mean", "target_std", "std"]

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
        augmentation: Augmentations = RandomShift(pad=4),
        std: float | LinearSchedule = LinearSchedule(1.0, 0.1, 100_000),
        std_clip: float | None = 0.3,
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
        self.convert_to_functional(encoder, "encoder")
        self.convert_to_functional(actor, "actor")
        self.convert_to_functional(critic, "critic", create_target_params=True)
        self.augmentation = self._augmentations(augmentation)
        self.std_schedule = std
        self.std_clip = std_clip
        self.register_buffer("schedule_step", torch.zeros((), dtype=torch.long))

    # -- schedule --------------------------------------------------------------------------
    def set_step(self, step: int) -> None:
        """Evaluate the std schedule at ``step`` from now on (DrQ-v2: agent steps = frames / action repeat)."""
        self.schedule_step.fill_(int(step))

    @property
    def stddev(self) -> float:
        """The current noise std."""
        if callable(self.std_schedule):
            return float(self.std_schedule(int(self.schedule_step)))
        return float(self.std_schedule)

    # -- TorchRL plumbing ------------------------------------------------------------------
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

    def make_value_estimator(self, value_type: ValueEstimators | None = None, **hyperparams: Any) -> DrQv2Loss:
        """Build the TD(0) estimator (``gamma`` here: ``loss.make_value_estimator(gamma=0.99)``)."""
        value_type, hyperparams = self._prepare_value_estimator_kwargs(value_type, **hyperparams)
        if value_type is None:
            return self
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
        """Re-initialise every network (DrQ-v2's init) and copy the critic into its target."""
        for name in ("encoder", "actor", "critic"):
            with getattr(self, f"{name}_params").to_module(getattr(self, name)):
                getattr(self, name).apply(_reinitialise)
        for module in self.children():
            if not isinstance(module, TensorDictParams) and any(True for _ in module.parameters()):
                module.apply(_reinitialise)
        self.target_critic_params.data.update_(self.critic_params.data)

    # -- the update ------------------------------------------------------------------------
    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        keys = self.tensor_keys
        self._check_batch(tensordict)
        pixels, action = tensordict.get(keys.pixels), tensordict.get(keys.action)
        with torch.no_grad():
            target = self._target(tensordict.get(("next", keys.pixels)), tensordict)
        terms = self._critic_terms(pixels, action, target)
        q1, q2, critic, hidden = (terms.pop(name) for name in ("q1", "q2", "critic", "hidden"))
        actor = self._actor_terms(hidden.detach(), terms)
        td_error = torch.maximum((q1 - target).abs(), (q2 - target).abs()).detach().squeeze(-1)
        tensordict.set(keys.priority, td_error)
        out = {
            "loss_critic": self._reduce_loss(critic, tensordict, weights=self._maybe_get_priority_weight(tensordict)),
            "loss_actor": self._reduce_loss(actor, tensordict),
        }
        for name in [name for name in terms if name.startswith("loss_")]:
            out[name] = self._reduce_loss(terms.pop(name), tensordict)
        out.update(q_mean=q1.detach().mean(), target_mean=target.mean(), target_std=target.std(), **self._metrics())
        out.update({name: value.detach() for name, value in terms.items()})
        if self.check_finite:
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
        for key in (keys.pixels, ("next", keys.pixels)):
            try:
                check_pixels(tensordict.get(key), name=f"{name} (batch entry {unravel_key(key)!r})", max_value=self.max_value)
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

    def _target(self, next_pixels: Tensor, tensordict: TensorDictBase) -> Tensor:
        """``y = r + γⁿ·(1 − terminated)·min(Q1', Q2')(h', a')``, shape ``[B, 1]`` (no gradient)."""
        hidden = self._encode(self._augment(self.augmentation, next_pixels))
        action = clipped_normal_sample(self._policy(hidden), self.stddev, self.std_clip)
        with self.target_critic_params.to_module(self.critic):
            next_value = torch.min(*self.critic(hidden, action))
        return self.value_estimator.value_estimate(tensordict, next_value=next_value)

    def _critic_terms(self, pixels: Tensor, action: Tensor, target: Tensor) -> dict[str, Tensor]:
        """Per-sample critic loss, Q values and the features the actor uses (plus any extra ``loss_*``)."""
        obs = self._augment(self.augmentation, pixels)
        hidden = self._encode(obs)
        q1, q2 = self._q(hidden, action)
        critic = (q1 - target).pow(2) + (q2 - target).pow(2)
        return {"critic": critic.squeeze(-1), "hidden": hidden, "q1": q1, "q2": q2}

    def _actor_terms(self, hidden: Tensor, terms: dict[str, Tensor]) -> Tensor:
        """Per-sample ``−min(Q1, Q2)`` of a noisy policy action, through a frozen critic.

        Subclasses may add more ``loss_*`` entries or metrics to ``terms``.
        """
        action = clipped_normal_sample(self._policy(hidden), self.stddev, self.std_clip)
        with self.critic_params.detach().to_module(self.critic):
            q1, q2 = self.critic(hidden, action)
        return -torch.min(q1, q2).squeeze(-1)

    def _metrics(self) -> dict[str, Tensor]:
        return {"std": torch.tensor(self.stddev)}

    # -- helpers for subclasses ----------------------------------------------------------
    def _encode(self, pixels: Tensor, params: TensorDictBase | None = None) -> Tensor:
        """Encoder features of ``[B, 3·k, H, W]`` pixels (with ``params``, default the online ones)."""
        if self.channels_last and pixels.ndim == 4:
            pixels = pixels.contiguous(memory_format=torch.channels_last)
        with (self.encoder_params if params is None else params).to_module(self.encoder):
            return self.encoder(pixels)

    def _policy(self, hidden: Tensor) -> Tensor:
        with self.actor_params.to_module(self.actor):
            return self.actor(hidden)

    def _q(self, hidden: Tensor, action: Tensor) -> tuple[Tensor, Tensor]:
        with self.critic_params.to_module(self.critic):
            return self.critic(hidden, action)

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


def _reinitialise(module: nn.Module) -> None:
    if isinstance(module, (nn.Linear, nn.Conv2d, nn.ConvTranspose2d)):
        weight_init(module)
    elif hasattr(module, "reset_parameters"):
        module.reset_parameters()

"""DrQ-v2's actor-critic update as a TorchRL LossModule, and the skeleton SVEA, SRM, SGQN and CURL extend."""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import torch
from tensordict import TensorDict, TensorDictBase, TensorDictParams
from tensordict.nn import dispatch
from tensordict.utils import NestedKey
from torch import Tensor, nn
from torchrl.objectives import LossModule
from torchrl.objectives.utils import ValueEstimators, dispatch_value_estimator

from vigen.losses.sampling import clipped_normal_sample
from vigen.losses.schedule import LinearSchedule
from vigen.models import weight_init
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
    ) -> None:
        super().__init__()
        if reduction not in ("mean", "sum", "none"):
            raise ValueError(f"reduction must be 'mean', 'sum' or 'none', got {reduction!r}.")
        self._in_keys = None
        self.reduction = reduction
        self.channels_last = channels_last
        if channels_last:
            encoder.to(memory_format=torch.channels_last)
        self.convert_to_functional(encoder, "encoder")
        self.convert_to_functional(actor, "actor")
        self.convert_to_functional(critic, "critic", create_target_params=True)
        self.augmentation = _module_list(augmentation)
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
        pixels = _read(tensordict, keys.pixels, "pixels")
        action = _read(tensordict, keys.action, "action")
        with torch.no_grad():
            target = self._target(_read(tensordict, ("next", keys.pixels), "pixels"), tensordict)
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
        return TensorDict(out, batch_size=[])

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

    @staticmethod
    def _augment(augmentations: nn.ModuleList, pixels: Tensor) -> Tensor:
        for augmentation in augmentations:
            pixels = augmentation.augment(pixels)
        return pixels


def _module_list(augmentations: Augmentations) -> nn.ModuleList:
    if augmentations is None:
        return nn.ModuleList()
    if not isinstance(augmentations, Sequence):
        augmentations = [augmentations]
    for augmentation in augmentations:
        if not isinstance(augmentation, ImageAugmentation):
            raise TypeError(
                f"Augmentations must be vigen ImageAugmentations (e.g. RandomShift()), got {type(augmentation).__name__}."
            )
    return nn.ModuleList([augmentation.clone() for augmentation in augmentations])


def _read(tensordict: TensorDictBase, key: NestedKey, name: str) -> Tensor:
    value = tensordict.get(key, None)
    if value is None:
        raise KeyError(
            f"The batch has no {key!r} entry. Store it in the replay buffer, or point the loss "
            f"at yours with loss.set_keys({name}=...). The batch has: {sorted(map(str, tensordict.keys(True, True)))}."
        )
    return value


def _reinitialise(module: nn.Module) -> None:
    if isinstance(module, (nn.Linear, nn.Conv2d, nn.ConvTranspose2d)):
        weight_init(module)
    elif hasattr(module, "reset_parameters"):
        module.reset_parameters()

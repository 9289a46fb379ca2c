"""DrQ-v2's update: DDPG with a clipped double-Q target, n-step returns and random shifts."""

from __future__ import annotations

from typing import Literal

import torch
from tensordict.nn import TensorDictModule, TensorDictModuleBase, TensorDictSequential
from tensordict.utils import NestedKey
from torch import Tensor, nn
from torchrl.data import TensorSpec
from torchrl.modules import AdditiveGaussianModule

from vigen.losses.base import ActorCriticLoss, Augmentations, default_shift
from vigen.losses.sampling import clipped_normal_sample
from vigen.losses.schedule import LinearSchedule


class DrQv2Loss(ActorCriticLoss):
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

    The update runs the steps of :class:`~vigen.losses.ActorCriticLoss` (augment, critic
    target, critic loss, actor loss, auxiliary losses); SVEA, SRM, SGQN, CURL, SADA, MaDi,
    SimGRL, SCPL and PIE-G change its hooks. Its acting policy is :meth:`make_policy`.

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
            ``"default"`` is ``RandomShift(pad=4)``. ``None`` if the replay buffer already augments
            (augment in one place only, or every view is shifted twice).
        std: the noise std, a float or a :class:`LinearSchedule` (default ``linear(1.0, 0.1, 100000)``).
        std_clip: clip of the noise (0.3).
        channels_last: run the convolutions in channels-last memory layout.
        reduction: ``"mean"`` (DrQ-v2), ``"sum"`` or ``"none"`` (per-sample losses).
        check_finite: raise when a loss is NaN or inf (see above); ``False`` skips the check.
        input_mask: a module in front of the encoder (MaDi's masker); ``None`` for none.

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

    out_keys = ActorCriticLoss.out_keys + ["std"]

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        augmentation: Augmentations | Literal["default"] = "default",
        std: float | LinearSchedule = LinearSchedule(1.0, 0.1, 100_000),
        std_clip: float | None = 0.3,
        input_mask: nn.Module | None = None,
        channels_last: bool = True,
        reduction: str = "mean",
        check_finite: bool = True,
    ) -> None:
        augmentation = default_shift(augmentation)
        super().__init__(
            encoder, actor, critic, augmentation=augmentation, input_mask=input_mask,
            channels_last=channels_last, reduction=reduction, check_finite=check_finite,
        )
        self.std_schedule = std
        self.std_clip = std_clip

    @property
    def stddev(self) -> float:
        """The current noise std, at the step given to :meth:`set_step` (a Python float: reading it synchronizes)."""
        if isinstance(self.std_schedule, LinearSchedule):
            return float(self.std_schedule.at(self.schedule_step))
        return float(self.std_schedule(int(self.schedule_step)) if callable(self.std_schedule) else self.std_schedule)

    def std(self) -> Tensor:
        """The current noise std, a 0-d float32 tensor on the loss's device: the update reads it without a host synchronization."""
        if isinstance(self.std_schedule, LinearSchedule):
            return self.std_schedule.at(self.schedule_step).float()
        return self.schedule_step.new_full((), self.stddev, dtype=torch.float32)

    def sample_action(self, features: Tensor) -> tuple[Tensor, None]:
        """``μ(h)`` plus Gaussian noise of the scheduled std, clipped (DrQ-v2's ``TruncatedNormal``)."""
        return clipped_normal_sample(self.policy(features), self.std(), self.std_clip), None

    def next_value(self, next_features: Tensor) -> Tensor:
        """``min(Q1', Q2')(h', a')`` with ``a'`` sampled as in :meth:`sample_action`."""
        action, _ = self.sample_action(next_features)
        return torch.min(*self.target_q_values(next_features, action))

    def metrics(self) -> dict[str, Tensor]:
        return {"std": self.std()}

    def make_policy(self, action_spec: TensorSpec, *, pixels_key: NestedKey = "pixels") -> TensorDictModuleBase:
        """``actor(encoder(pixels))`` plus exploration noise, on this loss's live parameters.

        The noise is TorchRL's ``AdditiveGaussianModule`` whose σ follows the loss's std schedule
        (call ``policy[-1].step(frames)`` as frames are collected); it is added when the
        exploration type is ``RANDOM`` (collectors' default) and left out under
        ``DETERMINISTIC`` (evaluation). The noise is unclipped and the action clamped to the
        spec, as in DrQ-v2's acting.
        """
        actor = TensorDictModule(PixelsToAction(self), in_keys=[pixels_key], out_keys=["action"])
        schedule = self.std_schedule
        if isinstance(schedule, LinearSchedule):
            sigma = dict(sigma_init=schedule.init, sigma_end=schedule.final, annealing_num_steps=schedule.duration)
        else:
            sigma = dict(sigma_init=float(schedule), sigma_end=float(schedule), annealing_num_steps=1)
        return TensorDictSequential(actor, AdditiveGaussianModule(action_spec.to(self.device), **sigma, device=self.device))


class PixelsToAction(nn.Module):
    """A loss's acting network, ``head(encoder(input_mask(pixels)))``, sharing the loss's modules.

    ``head`` is the loss's actor unless given (DrQ wraps it to give TorchRL's ``TanhNormal`` its
    parameters).
    """

    def __init__(self, loss: ActorCriticLoss, head: nn.Module | None = None) -> None:
        super().__init__()
        self.input_mask = loss.input_mask
        self.encoder = loss.encoder
        self.head = loss.actor if head is None else head

    def forward(self, pixels: Tensor) -> Tensor | tuple[Tensor, ...]:
        if self.input_mask is not None:
            pixels = self.input_mask(pixels)
        return self.head(self.encoder(pixels))

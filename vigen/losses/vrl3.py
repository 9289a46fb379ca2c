"""VRL3's stage-3 update: DrQ-v2's DDPG with a safe Q target, a pre-tanh penalty and a small fixed std."""

from __future__ import annotations

import math
import numbers
from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModuleBase, dispatch
from tensordict.utils import NestedKey
from torch import Tensor, nn
from torchrl.data import TensorSpec

from vigen.losses.base import ActorCriticLoss, PixelsToAction, RunningStatistics, squared_td_errors
from vigen.losses.samplers import NoisyDeterministic


def safe_q_target(target: Tensor, threshold: float = 200.0, factor: float = 0.5) -> Tensor:
    """VRL3's safe Q target: targets above ``threshold + 1`` grow only as ``(y − threshold)^factor``.

    ``y ↦ y`` where ``y ≤ threshold + 1``, else ``threshold + (y − threshold)^factor``; the two
    pieces meet at ``threshold + 1``. ``factor`` 0 caps the target at ``threshold + 1``; ``factor``
    1 (or more) leaves it alone, as in VRL3's code.

    Paper: VRL3, https://arxiv.org/abs/2202.10324.

    Examples:
        >>> import torch
        >>> safe_q_target(torch.tensor([100.0, 201.0, 209.0, 300.0]))
        tensor([100., 201., 203., 210.])
        >>> safe_q_target(torch.tensor([100.0, 300.0]), factor=0.0)
        tensor([100., 201.])
    """
    if factor >= 1:
        return target
    compressed = threshold + (target - threshold).clamp(min=1.0).pow(factor)
    return torch.where(target > threshold + 1, compressed, target)


def pretanh_penalty(pre_tanh: Tensor, threshold: float = 5.0) -> Tensor:
    """VRL3's penalty on the actor's pre-tanh output: ``mean_j max(|u_j| − threshold, 0)²`` per sample, ``[B]``.

    It keeps the actor's mean out of tanh's flat tails, where its gradient vanishes; VRL3 weighs it
    by 0.001 and takes the batch mean.

    Paper: VRL3, https://arxiv.org/abs/2202.10324.

    Examples:
        >>> import torch
        >>> pretanh_penalty(torch.tensor([[7.0, -1.0], [-8.0, 5.5]]))
        tensor([2.0000, 4.6250])
    """
    return (pre_tanh.abs() - threshold).clamp(min=0.0).pow(2).mean(-1)


class VRL3Loss(ActorCriticLoss):
    """VRL3's stage-3 (online) update, as RL-ViGen runs it on Adroit: DrQ-v2 with a safe Q target and a pre-tanh penalty.

    One call computes, on a replay-buffer batch (``h = encoder(shift(obs))``,
    ``h' = encoder(shift(next obs))`` without gradient, ``Q'`` the target critic):

    * ``loss_critic`` = MSE(Q1(h, a), ỹ) + MSE(Q2(h, a), ỹ) with the safe target
      ``ỹ = y`` if ``y ≤ c + 1`` else ``c + (y − c)^ρ`` (:func:`safe_q_target`; ``c`` =
      ``safe_q_threshold`` = 200, ``ρ`` = ``safe_q_factor`` = 0.5), where
      ``y = r + γⁿ·(1 − terminated)·min(Q1', Q2')(h', a')`` and ``a' = tanh(u(h')) + ε``,
      ``ε ~ N(0, σ²)`` clipped to ±0.3;
    * ``loss_actor`` = −min(Q1, Q2)(h̄, tanh(u) + ε) + λ·mean_j max(|u_j| − t, 0)², with
      ``h̄ = h.detach()``, ``u`` the actor's output before its tanh at ``h̄``
      (:func:`pretanh_penalty`; ``t`` = ``pretanh_threshold`` = 5, ``λ`` = ``pretanh_weight`` =
      0.001), through a frozen critic.

    The noise std σ is fixed at 0.01 (VRL3's ``linear(0.01, 0.01, 500000)``, the sampler of its record
    ``ALGOS["vrl3"]``), for the target, the actor step and acting; VRL3 is DDPG, so a SAC sampler is refused. The encoder
    (VRL3's small ResNet, :class:`~vigen.models.VRL3Encoder`) learns from the critic loss only, at
    ``lr`` (VRL3: its ``encoder_lr_scale`` 1; 0.01 for relocate is
    ``param_groups={"encoder": {"lr_scale": 0.01}}``, :meth:`optimizer_groups`). The acting policy (:meth:`make_policy`) runs the encoder's
    BatchNorms on their running statistics, as VRL3 acts in eval mode; the update uses the
    statistics of each batch.

    The safe-Q threshold is in the units of the rewards the loss sees: VRL3 and RL-ViGen scale
    Adroit's rewards (door by 1/20, hammer 1/100, pen 1/50: the record's ``reward_scales``), so
    scale them before the loss (``examples/train.py --algo vrl3`` does).

    What is left out of VRL3 (stage 3 as RL-ViGen runs it: ``stage1_use_pretrain=False``,
    ``stage2_n_update=0``): stage 1 (ImageNet pretraining; load a checkpoint with
    ``VRL3Encoder(stage1_weights=...)``), stage 2 (conservative Q-learning on demonstrations) and
    the behaviour-cloning terms (weight 0 in both). RL-ViGen also fills the replay buffer with 25
    demonstrations before stage 3 and feeds the actor and critic the hand's 24 joint positions
    next to the image features; vigen trains from pixels alone, without demonstrations (they are
    VRL3's data, not downloadable here). As in :class:`DrQv2Loss`, one ``backward()`` of the sum
    of the ``loss_*`` entries replaces VRL3's separate critic and actor steps (the actor sees the
    critic before this step's update), and the next observation is encoded before the current
    one, so the BatchNorms' running statistics see the two batches in the other order.

    Paper: VRL3, https://arxiv.org/abs/2202.10324; RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        encoder: pixels → features, e.g. :class:`~vigen.models.VRL3Encoder` (``make_loss("vrl3")``).
        actor: features → action mean ``tanh(u)``; for the penalty the loss reads ``u`` as
            ``actor.action_head(actor.trunk(h))``, the shape of vigen's :class:`~vigen.models.Actor`.
        critic: (features, action) → (Q1, Q2), e.g. :class:`~vigen.models.Critic`.
        sampler: DrQ-v2's :class:`~vigen.losses.NoisyDeterministic` (VRL3: std 0.01, clip 0.3).
        safe_q_threshold: ``c`` of the safe target (VRL3: 200).
        safe_q_factor: ``ρ`` in [0, 1] (VRL3: 0.5); 1 turns the safe target off, 0 is a hard cap at ``c + 1``.
        pretanh_threshold: ``t`` of the penalty (VRL3: 5).
        pretanh_weight: ``λ`` (VRL3: 0.001); 0 turns the penalty off (and any actor works).
        **options: ``augmentation`` (the weak view), ``target_encoder`` (VRL3: none), ``input_mask``,
            ``param_groups``, ``channels_last``, ``reduction``, ``check_finite`` (see
            :class:`~vigen.losses.ActorCriticLoss`).

    Examples:
        >>> import torch, warnings
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import build_loss, example_batch
        >>> from vigen.models import Actor, Critic, VRL3Encoder
        >>> with warnings.catch_warnings():
        ...     warnings.simplefilter("ignore")  # no stage-1 weights: random initialisation, as RL-ViGen
        ...     encoder = VRL3Encoder(9)
        >>> features = encoder.output_dim(9, 84, 84)
        >>> loss = build_loss("vrl3", encoder, Actor(features, 2, hidden_dim=32), Critic(features, 2, hidden_dim=32))
        >>> loss.make_value_estimator(gamma=0.99)
        VRL3Loss(...)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_")), round(out["std"].item(), 6)
        (['loss_actor', 'loss_critic'], 0.01)
        >>> optimizer = torch.optim.Adam(loss.optimizer_groups(lr=1e-4))
        >>> sum(out[key] for key in ("loss_actor", "loss_critic")).backward()
        >>> optimizer.step()
    """

    own_out_keys = ("actor_pretanh_penalty", "abs_pretanh", "max_abs_pretanh")

    def __init__(self, encoder: nn.Module, actor: nn.Module, critic: nn.Module, *, sampler: NoisyDeterministic,
                 safe_q_threshold: float, safe_q_factor: float, pretanh_threshold: float, pretanh_weight: float,
                 **options: Any) -> None:
        name = type(self).__name__
        if not isinstance(sampler, NoisyDeterministic):
            raise TypeError(f"{name} is DDPG (VRL3 acts with a fixed-std noisy deterministic actor, its penalty reads the "
                            f"actor's pre-tanh action); it takes a NoisyDeterministic sampler, not {type(sampler).__name__}.")
        for arg, value in (("safe_q_threshold", safe_q_threshold), ("pretanh_threshold", pretanh_threshold),
                           ("pretanh_weight", pretanh_weight)):
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ValueError(f"{name}: {arg} must be a finite number, got {value!r}.")
        if not (isinstance(safe_q_factor, numbers.Real) and 0 <= safe_q_factor <= 1):
            raise ValueError(f"{name}: safe_q_factor must be in [0, 1] (1 turns the safe Q target off, 0 caps it at "
                             f"safe_q_threshold + 1), got {safe_q_factor!r}.")
        for arg, value in (("pretanh_threshold", pretanh_threshold), ("pretanh_weight", pretanh_weight)):
            if value < 0:
                raise ValueError(f"{name}: {arg} must be >= 0, got {value!r}.")
        readable = all(isinstance(getattr(actor, part, None), nn.Module) for part in ("trunk", "action_head"))
        if pretanh_weight > 0 and not readable:
            raise TypeError(
                f"{name} penalises the actor's output before its tanh, which it reads as actor.action_head(actor.trunk(h)) "
                f"(vigen.models.Actor); {type(actor).__name__} has no trunk and action_head. Use vigen.models.Actor, "
                "or pass pretanh_weight=0."
            )
        super().__init__(encoder, actor, critic, sampler=sampler, **options)
        self.safe_q_threshold = float(safe_q_threshold)
        self.safe_q_factor = float(safe_q_factor)
        self.pretanh_threshold = float(pretanh_threshold)
        self.pretanh_weight = float(pretanh_weight)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        obs, next_obs = self.augment(batch.pixels), self.augment(batch.next_pixels)
        target = safe_q_target(self.critic_target(tensordict, next_obs), self.safe_q_threshold, self.safe_q_factor)
        features = self.encode(obs)
        q1, q2 = self.q_values(features, batch.action)
        # the actor: −min(Q1, Q2)(h̄, tanh(u) + ε) plus λ times the pre-tanh penalty of u
        detached, metrics = features.detach(), {}
        if self.pretanh_weight > 0:
            with self.actor_params.to_module(self.actor, preserve_module_state=False):
                pre_tanh = self.actor.action_head(self.actor.trunk(detached))  # u, the action before vigen's Actor's tanh
            loss_actor, _ = self.actor_loss(detached, actor_output=torch.tanh(pre_tanh))
            penalty = self.pretanh_weight * pretanh_penalty(pre_tanh, self.pretanh_threshold)
            loss_actor = loss_actor + penalty
            size = pre_tanh.detach().abs()
            metrics.update(actor_pretanh_penalty=penalty.mean(), abs_pretanh=size.mean(), max_abs_pretanh=size.max())
        else:
            loss_actor, _ = self.actor_loss(detached)
        # VRL3 is DDPG (a NoisyDeterministic sampler): no temperature loss
        return self.output(tensordict, target, q1, q2,
                           {"loss_critic": squared_td_errors(q1, q2, target), "loss_actor": loss_actor},
                           {**self.sampler.metrics(self.schedule_step, None), **metrics})

    def make_policy(self, action_spec: TensorSpec, *, pixels_key: NestedKey = "pixels") -> TensorDictModuleBase:
        """DrQ-v2's acting policy (σ = the loss's std), the encoder's BatchNorms on their running statistics."""
        return self.sampler.acting_module(RunningStatistics(PixelsToAction(self)), action_spec, pixels_key, self.device)

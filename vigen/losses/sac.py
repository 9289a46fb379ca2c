"""Soft actor-critic as a policy for any vigen loss: a tanh-squashed Gaussian and a learned temperature."""

from __future__ import annotations

import math
from typing import Any, Literal

import torch
from tensordict import TensorDictBase
from tensordict.nn import TensorDictModule, TensorDictModuleBase
from tensordict.utils import NestedKey
from torch import Tensor, nn
from torchrl.data import TensorSpec
from torchrl.modules import ProbabilisticActor, TanhNormal

from vigen.losses.base import ActorCriticLoss, ActorResult, AuxiliaryResult, CriticResult, Observations
from vigen.losses.drqv2 import PixelsToAction
from vigen.losses.sampling import squashed_normal_sample


class SoftActorCritic(ActorCriticLoss):
    """SAC's policy steps for a vigen loss; put it first among the bases (``class L(SoftActorCritic, SVEALoss)``).

    With ``(ã, log π) ~ π(h)`` a reparameterised tanh-squashed Gaussian sample (the actor returns
    its mean and log σ, e.g. :class:`~vigen.models.GaussianActor`):

    * bootstrapped value ``V(h') = min(Q1', Q2')(h', a') − α·log π(a'|h')``;
    * ``loss_actor = α·log π(ã|h) − min(Q1, Q2)(h_Q, ã)`` on the detached features of
      :meth:`~ActorCriticLoss.actor_features` (``h`` for the policy, ``h_Q`` for the critic),
      through a frozen critic, with α detached;
    * ``loss_alpha = α·(−log π(ã|h) − H̄)`` with target entropy ``H̄ = −|A|`` by default; α =
      exp(``log_alpha``), initialised at ``init_temperature``.

    The acting policy samples the squashed Gaussian, its mean under ``DETERMINISTIC``.

    Paper: SAC, https://arxiv.org/abs/1801.01290 (with DrQ's settings, https://arxiv.org/abs/2004.13649).

    Args:
        *args: the networks and hook options of the loss it is mixed into.
        init_temperature: initial α (DrQ, DMC-GB2: 0.1).
        target_entropy: ``"auto"`` for ``−action_dim``, or a number.
        squash_epsilon: ``None`` for DrQ's stable ``log(1 − tanh(u)²)``; a number ε for the
            SAC-AE / DMC-GB form ``log(relu(1 − tanh(u)²) + ε)`` (1e-6 there), see
            :func:`~vigen.losses.squashed_normal_sample`.
        target_encoder: give the target critic a target copy of the encoder (DMC-GB's SAC, whose
            target critic holds its own encoder; the original DrQ): the next action is sampled on
            the online encoder's features and scored on the target encoder's. ``SoftUpdate``
            moves it with the target critic. ``False``: both read the online encoder (DrQ-v2,
            RL-ViGen, DMC-GB2).
        **kwargs: the options of the loss it is mixed into (not ``std``/``std_clip``: SAC
            samples from its policy).

    Examples:
        >>> from vigen.losses import DrQLoss, SADALoss
        >>> issubclass(DrQLoss, SoftActorCritic), issubclass(SADALoss, SoftActorCritic)
        (True, True)
    """

    def __init__(
        self,
        *args: Any,
        init_temperature: float = 0.1,
        target_entropy: float | Literal["auto"] = "auto",
        squash_epsilon: float | None = None,
        target_encoder: bool = False,
        **kwargs: Any,
    ) -> None:
        name = type(self).__name__
        for option in ("std", "std_clip"):
            if option in kwargs:
                raise TypeError(f"{name} samples from its SAC policy and takes no {option!r} (DrQ-v2's noise).")
        if not init_temperature > 0:
            raise ValueError(f"{name}: init_temperature must be positive, got {init_temperature}.")
        if squash_epsilon is not None and not (isinstance(squash_epsilon, (int, float)) and squash_epsilon > 0):
            raise ValueError(f"{name}: squash_epsilon must be None or a positive number (DMC-GB: 1e-6), got {squash_epsilon!r}.")
        super().__init__(*args, **kwargs)
        self.squash_epsilon = None if squash_epsilon is None else float(squash_epsilon)
        self.target_encoder = bool(target_encoder)
        if self.target_encoder:
            self.convert_to_functional(self.encoder, "encoder", create_target_params=True)
        self.log_alpha = nn.Parameter(torch.tensor(math.log(init_temperature)))
        self.target_entropy = target_entropy

    @property
    def alpha(self) -> Tensor:
        """The temperature α = exp(log_alpha)."""
        return self.log_alpha.exp()

    def sample_action(self, features: Tensor) -> tuple[Tensor, Tensor]:
        """A reparameterised sample of the tanh-squashed Gaussian, and its log-probability."""
        return squashed_normal_sample(*self.policy(features), epsilon=self.squash_epsilon)

    def critic_target(self, batch: Observations, tensordict: TensorDictBase) -> Tensor:
        """``y = r + γⁿ·(1 − terminated)·V(s')``, with the target encoder's features for the target critic if there is one."""
        online = self.encode(batch.next_obs)
        scored = self.encode(batch.next_obs, params=self.target_encoder_params) if self.target_encoder else None
        return self.value_estimator.value_estimate(tensordict, next_value=self.next_value(online, scored))

    def next_value(self, next_features: Tensor, critic_features: Tensor | None = None) -> Tensor:
        """``min(Q1', Q2')(h'_Q, a') − α·log π(a'|h')`` with ``a' ~ π(h')``.

        ``critic_features`` are what the target critic reads (``h'_Q``; default ``h'``): with a
        target encoder, the policy samples on the online encoder's features and the target
        critic scores them on the target encoder's, as DMC-GB's SAC does.
        """
        action, log_prob = self.sample_action(next_features)
        critic_features = next_features if critic_features is None else critic_features
        return torch.min(*self.target_q_values(critic_features, action)) - self.alpha * log_prob

    def actor_loss(self, batch: Observations, critic: CriticResult) -> ActorResult:
        """``α·log π(ã|h) − min(Q1, Q2)(h_Q, ã)`` (α detached, critic frozen)."""
        policy_features, critic_features = self.actor_features(batch, critic)
        action, log_prob = self.sample_action(policy_features)
        q = torch.min(*self.q_values(critic_features, action, frozen=True))
        return ActorResult((self.alpha.detach() * log_prob - q).squeeze(-1), log_prob,
                           {"entropy": -log_prob.detach().mean()})

    def auxiliary_losses(self, batch: Observations, critic: CriticResult, actor: ActorResult) -> AuxiliaryResult:
        """The method's own terms, plus the temperature loss ``α·(−log π − H̄)`` (log π detached)."""
        result = super().auxiliary_losses(batch, critic, actor)
        if actor.log_prob is None:
            raise RuntimeError(f"{type(self).__name__}: the actor step must return the log-probability of its actions.")
        target_entropy = -batch.action.shape[-1] if self.target_entropy == "auto" else float(self.target_entropy)
        result.losses["loss_alpha"] = (self.alpha * (-actor.log_prob - target_entropy).detach()).squeeze(-1)
        return result

    def metrics(self) -> dict[str, Tensor]:
        return {"alpha": self.alpha.detach()}

    def make_policy(self, action_spec: TensorSpec, *, pixels_key: NestedKey = "pixels") -> TensorDictModuleBase:
        """A ``ProbabilisticActor`` sampling the tanh-squashed Gaussian (its mean under ``DETERMINISTIC``)."""
        network = PixelsToAction(self, head=_LocScale(self.actor))
        features = TensorDictModule(network, in_keys=[pixels_key], out_keys=["loc", "scale"])
        action_spec = action_spec.to(self.device)
        return ProbabilisticActor(
            features,
            in_keys=["loc", "scale"],
            spec=action_spec,
            distribution_class=TanhNormal,
            distribution_kwargs={"low": action_spec.space.low, "high": action_spec.space.high},
        )


class _LocScale(nn.Module):
    """``GaussianActor``'s (mean, log σ) → (loc, σ), the parameters TorchRL's ``TanhNormal`` takes."""

    def __init__(self, actor: nn.Module) -> None:
        super().__init__()
        self.actor = actor

    def forward(self, features: Tensor) -> tuple[Tensor, Tensor]:
        mean, log_std = self.actor(features)
        return mean, log_std.exp()

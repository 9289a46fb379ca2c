"""DrQ: SAC with a clean and a shifted view, averaged targets and a learned temperature."""

from __future__ import annotations

import math
from typing import Any, Literal

import torch
from tensordict import TensorDictBase
from torch import Tensor, nn

from vigen.losses.drqv2 import DrQv2Loss
from vigen.losses.sampling import squashed_normal_sample


class DrQLoss(DrQv2Loss):
    """DrQ as in RL-ViGen: SAC on a clean and a randomly shifted view of every observation.

    With ``h₀ = encoder(obs)``, ``h₁ = encoder(shift(obs))`` and the same two views of the next
    observation (``h'₀``, ``h'₁``, no gradient):

    * targets ``yᵢ = r + γⁿ·(1 − terminated)·[min(Q1', Q2')(h'ᵢ, a'ᵢ) − α·log π(a'ᵢ|h'ᵢ)]`` with
      ``a'ᵢ ~ π(h'ᵢ)``, averaged: ``y = (y₀ + y₁) / 2``;
    * ``loss_critic`` = Σ over both views of MSE(Q1(hᵢ, a), y) + MSE(Q2(hᵢ, a), y) (summed, not
      averaged), which trains the encoder;
    * ``loss_actor = α·log π(ã|h₀) − min(Q1, Q2)(h₀, ã)`` on detached clean features, through a
      frozen critic;
    * ``loss_alpha = α·(−log π(ã|h₀) − H̄)`` with target entropy ``H̄ = −|A|``; α = exp(``log_alpha``),
      initialised at 0.1.

    The original DrQ averages K = M = 2 *shifted* views instead; RL-ViGen replaces one of them by
    the raw observation, which is what this loss does (``augmentation=None`` makes both views
    clean). The actor is :class:`~vigen.models.GaussianActor` (mean, log σ of a tanh-squashed
    Gaussian), the critic DrQ-v2's.

    Paper: DrQ, https://arxiv.org/abs/2004.13649.

    Args:
        encoder, critic: as in :class:`DrQv2Loss`.
        actor: features → (mean, log σ).
        init_temperature: initial α.
        target_entropy: ``"auto"`` for ``−action_dim``, or a number.
        **kwargs: ``augmentation``, ``channels_last``, ``reduction``, ``check_finite``
            (see :class:`DrQv2Loss`).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.models import Critic, DrQv2Encoder, GaussianActor
        >>> encoder = DrQv2Encoder(9)
        >>> repr_dim = encoder.output_dim(9, 84, 84)
        >>> loss = DrQLoss(encoder, GaussianActor(repr_dim, 2, hidden_dim=32), Critic(repr_dim, 2, hidden_dim=32))
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> batch = TensorDict({
        ...     "pixels": pixels, "action": torch.zeros(4, 2),
        ...     "next": {"pixels": pixels, "reward": torch.ones(4, 1),
        ...              "done": torch.zeros(4, 1, dtype=torch.bool),
        ...              "terminated": torch.zeros(4, 1, dtype=torch.bool)},
        ... }, batch_size=[4])
        >>> out = loss(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_")), round(out["alpha"].item(), 3)
        (['loss_actor', 'loss_alpha', 'loss_critic'], 0.1)
    """

    out_keys = ["loss_critic", "loss_actor", "loss_alpha", "q_mean", "target_mean", "target_std", "alpha", "entropy"]

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        *,
        init_temperature: float = 0.1,
        target_entropy: float | Literal["auto"] = "auto",
        **kwargs: Any,
    ) -> None:
        for name in ("std", "std_clip"):
            if name in kwargs:
                raise TypeError(f"DrQLoss samples from its SAC policy and takes no {name!r} (DrQ-v2's noise).")
        if init_temperature <= 0:
            raise ValueError(f"init_temperature must be positive, got {init_temperature}.")
        super().__init__(encoder, actor, critic, std=0.0, std_clip=None, **kwargs)
        self.log_alpha = nn.Parameter(torch.tensor(math.log(init_temperature)))
        self.target_entropy = target_entropy

    @property
    def alpha(self) -> Tensor:
        """The temperature α = exp(log_alpha)."""
        return self.log_alpha.exp()

    def _target(self, next_pixels: Tensor, tensordict: TensorDictBase) -> Tensor:
        views = self._views(next_pixels)
        hidden = self._encode(views)
        action, log_prob = squashed_normal_sample(*self._policy(hidden))
        with self.target_critic_params.to_module(self.critic):
            next_value = torch.min(*self.critic(hidden, action)) - self.alpha * log_prob
        clean, shifted = next_value.chunk(2)
        estimate = self.value_estimator.value_estimate
        return 0.5 * (estimate(tensordict, next_value=clean) + estimate(tensordict, next_value=shifted))

    def _critic_terms(self, pixels: Tensor, action: Tensor, target: Tensor) -> dict[str, Tensor]:
        batch = pixels.shape[0]
        hidden = self._encode(self._views(pixels))
        q1, q2 = self._q(hidden, action.repeat(2, 1))
        errors = ((q1 - target.repeat(2, 1)).pow(2) + (q2 - target.repeat(2, 1)).pow(2)).squeeze(-1)
        return {
            "critic": errors[:batch] + errors[batch:], "hidden": hidden[:batch],
            "q1": q1[:batch], "q2": q2[:batch],
        }

    def _actor_terms(self, hidden: Tensor, terms: dict[str, Tensor]) -> Tensor:
        action, log_prob = squashed_normal_sample(*self._policy(hidden))
        with self.critic_params.detach().to_module(self.critic):
            q = torch.min(*self.critic(hidden, action))
        target_entropy = -action.shape[-1] if self.target_entropy == "auto" else float(self.target_entropy)
        terms["loss_alpha"] = (self.alpha * (-log_prob - target_entropy).detach()).squeeze(-1)
        terms["entropy"] = -log_prob.detach().mean()
        return (self.alpha.detach() * log_prob - q).squeeze(-1)

    def _metrics(self) -> dict[str, Tensor]:
        return {"alpha": self.alpha.detach()}

    def _views(self, pixels: Tensor) -> Tensor:
        return torch.cat([pixels, self._augment(self.augmentation, pixels)])

"""The two samplers of vigen's losses: DrQ-v2's noisy deterministic actor and SAC's squashed Gaussian.

A loss holds one of them as ``loss.sampler``: how an action is drawn from the actor's output
inside the update, what that draw adds to the bootstrapped value and to the actor's objective,
which extra losses and metrics it brings (SAC's temperature, added by
:meth:`~vigen.losses.ActorCriticLoss.output` for every loss), and the exploration of the acting
policy (:meth:`~vigen.losses.ActorCriticLoss.make_policy`, a TorchRL module: in vigen "policy" is
always that acting module). The update itself (one critic target, one TD loss, one actor loss) is
written once, in :class:`~vigen.losses.ActorCriticLoss`.
"""

from __future__ import annotations

import math
from typing import Literal

import torch
from tensordict.nn import TensorDictModule, TensorDictModuleBase, TensorDictSequential
from tensordict.utils import NestedKey
from torch import Tensor, nn
from torchrl.data import TensorSpec
from torchrl.modules import AdditiveGaussianModule, ProbabilisticActor, TanhNormal

from vigen.losses.sampling import clipped_normal_sample, squashed_normal_sample
from vigen.losses.schedule import LinearSchedule

ActorOutput = Tensor | tuple[Tensor, ...]

DRQV2_STD = LinearSchedule(1.0, 0.1, 100_000)
"""DrQ-v2's exploration and target-noise std, ``linear(1.0, 0.1, 100000)`` of agent steps (its easy tasks)."""
DRQV2_CLIP = 0.3
"""DrQ-v2's clip of the target and actor-step noise (``stddev_clip``)."""
DMCGB_SQUASH_EPSILON = 1e-6
"""The ε of SAC-AE / DMC-GB's ``log(relu(1 − tanh(u)²) + ε)`` (SVEA's, MaDi's, SimGRL's and SCPL's code)."""


class NoisyDeterministic(nn.Module):
    """DrQ-v2's sampler: the actor's action ``μ(h)`` plus clipped Gaussian noise of a scheduled std (DDPG).

    * inside the update, ``a = μ(h) + clip(ε·σ, −c, c)`` with the straight-through clamp of
      :func:`~vigen.losses.clipped_normal_sample`, ``σ`` the schedule at the loss's step;
    * the bootstrapped value is ``min(Q1', Q2')(h', a')`` and the actor's objective ``−min(Q1, Q2)(h, ã)``;
    * it acts with TorchRL's ``AdditiveGaussianModule`` (σ annealed like the schedule as frames are
      collected), unclipped noise and the action clamped to the spec, as DrQ-v2 acts; without noise under
      ``ExplorationType.DETERMINISTIC``.

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Args:
        std: a float or a :class:`~vigen.losses.LinearSchedule` of agent steps (DrQ-v2:
            ``linear(1.0, 0.1, 100000)``, the default).
        clip: the noise clip ``c`` (0.3); ``None`` for none.

    Examples:
        >>> import torch
        >>> sampler = NoisyDeterministic(std=0.2)
        >>> action, log_prob = sampler.sample(torch.zeros(1000, 2), step=torch.tensor(0))
        >>> round(float(action.abs().max()), 4), log_prob  # the noise is clipped at 0.3
        (0.3, None)
    """

    out_keys = ("std",)
    """The metrics it adds to a loss's output."""

    def __init__(self, std: float | LinearSchedule = DRQV2_STD, clip: float | None = DRQV2_CLIP) -> None:
        super().__init__()
        if not isinstance(std, LinearSchedule) and not (isinstance(std, (int, float)) and std >= 0):
            raise ValueError(f"std must be a number >= 0 or a LinearSchedule, got {std!r}.")
        self.schedule = std
        self.clip = clip

    def std(self, step: Tensor) -> Tensor:
        """The noise std at ``step``, a 0-d float32 tensor on the step's device (no host synchronization)."""
        if isinstance(self.schedule, LinearSchedule):
            return self.schedule.at(step).float()
        return step.new_full((), float(self.schedule), dtype=torch.float32)

    def stddev(self, step: Tensor) -> float:
        """The noise std at ``step`` as a Python float (reading it synchronizes with the step's device)."""
        if isinstance(self.schedule, LinearSchedule):
            return float(self.schedule.at(step))
        return float(self.schedule)

    def sample(self, actor_output: ActorOutput, step: Tensor) -> tuple[Tensor, None]:
        """``μ(h)`` plus the clipped noise (DrQ-v2's ``TruncatedNormal``), and no log-probability."""
        return clipped_normal_sample(actor_output, self.std(step), self.clip), None

    def value(self, q: Tensor, log_prob: Tensor | None) -> Tensor:
        """The bootstrapped value of a sampled next action: ``min(Q1', Q2')`` itself."""
        return q

    def objective(self, q: Tensor, log_prob: Tensor | None) -> Tensor:
        """The actor's per-sample objective: ``−min(Q1, Q2)``."""
        return -q

    def losses(self, log_prob: Tensor | None, action_dim: int) -> dict[str, Tensor]:
        """Extra ``loss_*`` terms of the sampler: none."""
        return {}

    def metrics(self, step: Tensor, log_prob: Tensor | None) -> dict[str, Tensor]:
        """The noise std at ``step``."""
        return {"std": self.std(step)}

    def acting_module(self, network: nn.Module, action_spec: TensorSpec, pixels_key: NestedKey,
                      device: torch.device) -> TensorDictModuleBase:
        """``network`` (pixels → action) and TorchRL's ``AdditiveGaussianModule`` with σ annealed like ``std``."""
        actor = TensorDictModule(network, in_keys=[pixels_key], out_keys=["action"])
        if isinstance(self.schedule, LinearSchedule):
            sigma = dict(sigma_init=self.schedule.init, sigma_end=self.schedule.final,
                         annealing_num_steps=self.schedule.duration)
        else:
            sigma = dict(sigma_init=float(self.schedule), sigma_end=float(self.schedule), annealing_num_steps=1)
        return TensorDictSequential(actor, AdditiveGaussianModule(action_spec.to(device), **sigma, device=device))

    def extra_repr(self) -> str:
        return f"std={self.schedule}, clip={self.clip}"


class SquashedGaussian(nn.Module):
    """SAC's sampler: a tanh-squashed Gaussian with a learned temperature α.

    With ``(ã, log π) ~ π(h)`` a reparameterised sample (the actor returns the mean and log σ, e.g.
    :class:`~vigen.models.GaussianActor`):

    * the bootstrapped value is ``min(Q1', Q2')(h', a') − α·log π(a'|h')``;
    * the actor's objective is ``α·log π(ã|h) − min(Q1, Q2)(h, ã)``, α detached;
    * ``loss_alpha = α·(−log π(ã|h) − H̄)``, log π detached, with target entropy ``H̄ = −|A|`` by
      default; α = exp(``log_alpha``), initialised at ``init_temperature``;
    * it acts with a TorchRL ``ProbabilisticActor`` over ``TanhNormal`` (its mean under
      ``ExplorationType.DETERMINISTIC``).

    Paper: SAC, https://arxiv.org/abs/1801.01290 (with DrQ's settings, https://arxiv.org/abs/2004.13649).

    Args:
        init_temperature: initial α (DrQ, DMC-GB2: 0.1).
        target_entropy: ``"auto"`` for ``−action_dim``, or a number.
        squash_epsilon: ``None`` for DrQ's stable ``log(1 − tanh(u)²)``; a number ε for the SAC-AE /
            DMC-GB form ``log(relu(1 − tanh(u)²) + ε)`` (:data:`DMCGB_SQUASH_EPSILON` there), see
            :func:`~vigen.losses.squashed_normal_sample`.

    Examples:
        >>> import torch
        >>> sampler = SquashedGaussian(init_temperature=0.1)
        >>> action, log_prob = sampler.sample((torch.zeros(4, 2), torch.zeros(4, 2)), step=torch.tensor(0))
        >>> round(float(sampler.alpha.detach()), 3), sorted(sampler.losses(log_prob, action_dim=2))
        (0.1, ['loss_alpha'])
    """

    out_keys = ("loss_alpha", "alpha", "entropy")
    """The loss and metrics it adds to a loss's output."""

    def __init__(
        self,
        init_temperature: float = 0.1,
        target_entropy: float | Literal["auto"] = "auto",
        squash_epsilon: float | None = None,
    ) -> None:
        super().__init__()
        if not (isinstance(init_temperature, (int, float)) and init_temperature > 0):
            raise ValueError(f"init_temperature must be positive, got {init_temperature!r}.")
        if not (target_entropy == "auto" or isinstance(target_entropy, (int, float))):
            raise ValueError(f"target_entropy must be 'auto' (−action_dim) or a number, got {target_entropy!r}.")
        if squash_epsilon is not None and not (isinstance(squash_epsilon, (int, float)) and squash_epsilon > 0):
            raise ValueError(f"squash_epsilon must be None or a positive number (DMC-GB: {DMCGB_SQUASH_EPSILON}), "
                             f"got {squash_epsilon!r}.")
        self.log_alpha = nn.Parameter(torch.tensor(math.log(init_temperature)))
        self.target_entropy = target_entropy
        self.squash_epsilon = None if squash_epsilon is None else float(squash_epsilon)

    @property
    def alpha(self) -> Tensor:
        """The temperature α = exp(log_alpha)."""
        return self.log_alpha.exp()

    def sample(self, actor_output: ActorOutput, step: Tensor) -> tuple[Tensor, Tensor]:
        """A reparameterised sample of the tanh-squashed Gaussian ``(mean, log σ)``, and its log-probability."""
        mean, log_std = actor_output
        return squashed_normal_sample(mean, log_std, epsilon=self.squash_epsilon)

    def value(self, q: Tensor, log_prob: Tensor | None) -> Tensor:
        """The soft value of a sampled next action: ``min(Q1', Q2') − α·log π``."""
        return q - self.alpha * log_prob

    def objective(self, q: Tensor, log_prob: Tensor | None) -> Tensor:
        """The actor's per-sample objective: ``α·log π − min(Q1, Q2)``, α detached."""
        return self.alpha.detach() * log_prob - q

    def losses(self, log_prob: Tensor | None, action_dim: int) -> dict[str, Tensor]:
        """The temperature loss ``α·(−log π − H̄)``, per sample, log π detached."""
        if log_prob is None:
            raise RuntimeError("SquashedGaussian: the actor step must give the log-probability of its actions.")
        target_entropy = -action_dim if self.target_entropy == "auto" else float(self.target_entropy)
        return {"loss_alpha": (self.alpha * (-log_prob - target_entropy).detach()).squeeze(-1)}

    def metrics(self, step: Tensor, log_prob: Tensor | None) -> dict[str, Tensor]:
        """α, and the entropy estimate ``−mean log π`` of the actor's samples."""
        metrics = {"alpha": self.alpha.detach()}
        if log_prob is not None:
            metrics["entropy"] = -log_prob.detach().mean()
        return metrics

    def acting_module(self, network: nn.Module, action_spec: TensorSpec, pixels_key: NestedKey,
                      device: torch.device) -> TensorDictModuleBase:
        """A ``ProbabilisticActor`` sampling ``TanhNormal`` from ``network``'s (mean, log σ) (its mean when deterministic)."""
        features = TensorDictModule(_LocScale(network), in_keys=[pixels_key], out_keys=["loc", "scale"])
        action_spec = action_spec.to(device)
        return ProbabilisticActor(
            features, in_keys=["loc", "scale"], spec=action_spec, distribution_class=TanhNormal,
            distribution_kwargs={"low": action_spec.space.low, "high": action_spec.space.high},
        )

    def extra_repr(self) -> str:
        return f"target_entropy={self.target_entropy!r}, squash_epsilon={self.squash_epsilon}"


Sampler = NoisyDeterministic | SquashedGaussian
"""How a loss draws actions: :class:`NoisyDeterministic` (DDPG) or :class:`SquashedGaussian` (SAC)."""


class _LocScale(nn.Module):
    """(mean, log σ) → (loc, σ), the parameters TorchRL's ``TanhNormal`` takes."""

    def __init__(self, network: nn.Module) -> None:
        super().__init__()
        self.network = network

    def forward(self, pixels: Tensor) -> tuple[Tensor, Tensor]:
        mean, log_std = self.network(pixels)
        return mean, log_std.exp()

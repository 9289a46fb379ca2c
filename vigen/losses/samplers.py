"""The two samplers of vigen's losses, DrQ-v2's noisy deterministic actor and SAC's squashed Gaussian, and their draws.

A loss holds one of them as ``loss.sampler``: how an action is drawn from the actor's output
inside the update (:func:`clipped_normal_sample`, :func:`squashed_normal_sample`: TorchRL runs
losses in deterministic exploration mode, so the losses draw explicitly), what that draw adds to
the bootstrapped value and to the actor's objective, the temperature loss of a SAC update
(``loss_alpha``, which every loss's ``forward`` adds by calling :meth:`~SquashedGaussian.temperature_losses`
by name, with the number of views its actor step scored) and the metrics, and the exploration of
the acting policy (:meth:`~vigen.losses.ActorCriticLoss.make_policy`, a TorchRL module: in vigen
"policy" is always that acting module).

Names: ``std`` is the noise's standard deviation at a step (a value: the ``std`` metric,
:meth:`NoisyDeterministic.std`); ``std_schedule`` is how it moves over the agent steps (a
:class:`~vigen.losses.LinearSchedule`).
"""

from __future__ import annotations

import math
from typing import Literal

import torch
import torch.nn.functional as F
from tensordict.nn import TensorDictModule, TensorDictModuleBase, TensorDictSequential
from tensordict.utils import NestedKey
from torch import Tensor, nn
from torchrl.data import TensorSpec
from torchrl.modules import AdditiveGaussianModule, ProbabilisticActor, TanhNormal

from vigen.losses.schedule import LinearSchedule

ActorOutput = Tensor | tuple[Tensor, ...]

DRQV2_STD_SCHEDULE = LinearSchedule(1.0, 0.1, 100_000)
"""DrQ-v2's schedule of the exploration and target-noise std, ``linear(1.0, 0.1, 100000)`` of agent steps (its easy tasks)."""
DRQV2_CLIP = 0.3
"""DrQ-v2's clip of the target and actor-step noise (``stddev_clip``)."""
DMCGB_SQUASH_EPSILON = 1e-6
"""The ε of SAC-AE / DMC-GB's ``log(relu(1 − tanh(u)²) + ε)`` (SVEA's, MaDi's, SimGRL's and SCPL's code)."""


def clipped_normal_sample(mean: Tensor, std: float | Tensor, clip: float | None, eps: float = 1e-6) -> Tensor:
    """DrQ-v2's ``TruncatedNormal(mean, std).sample(clip)``, with its straight-through clamp.

    The noise ``ε·std`` is clamped to ``[-clip, clip]``, the action to ``[-1 + eps, 1 - eps]``; the
    gradient flows to ``mean`` as if neither clamp were there.

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Examples:
        >>> import torch
        >>> action = clipped_normal_sample(torch.zeros(1000, 2), std=1.0, clip=0.3)
        >>> torch.allclose(action.abs().max(), torch.tensor(0.3))  # the noise is clipped at 0.3
        True
    """
    noise = torch.randn_like(mean) * std
    if clip is not None:
        noise = noise.clamp(-clip, clip)
    action = mean + noise
    clamped = action.clamp(-1.0 + eps, 1.0 - eps)
    return action - action.detach() + clamped.detach()


def squashed_normal_sample(mean: Tensor, log_std: Tensor, *, epsilon: float | None = None) -> tuple[Tensor, Tensor]:
    """A reparameterised sample of ``tanh(N(mean, exp(log_std)))`` and its log-probability.

    The log-probability is summed over the action dims. ``log(1 - tanh(u)²)`` is computed stably
    as ``2·(log 2 − u − softplus(−2u))``, as in DrQ's ``SquashedNormal``; with ``epsilon`` it is
    ``log(relu(1 − tanh(u)²) + epsilon)`` instead, the SAC-AE / DMC-GB form (``epsilon=1e-6``)
    that SVEA, SGQN, MaDi, SimGRL and SCPL inherit.

    Paper: DrQ, https://arxiv.org/abs/2004.13649 (SAC: https://arxiv.org/abs/1801.01290).

    Examples:
        >>> import torch
        >>> action, log_prob = squashed_normal_sample(torch.zeros(3, 2), torch.zeros(3, 2))
        >>> action.shape, log_prob.shape
        (torch.Size([3, 2]), torch.Size([3, 1]))
    """
    std = log_std.exp()
    pre_tanh = mean + std * torch.randn_like(mean)
    gaussian = -0.5 * ((pre_tanh - mean) / std) ** 2 - log_std - 0.5 * math.log(2 * math.pi)
    action = torch.tanh(pre_tanh)
    if epsilon is None:
        log_det = 2.0 * (math.log(2.0) - pre_tanh - F.softplus(-2.0 * pre_tanh))
    else:
        log_det = torch.log(F.relu(1.0 - action.pow(2)) + epsilon)
    return action, (gaussian - log_det).sum(-1, keepdim=True)


class NoisyDeterministic(nn.Module):
    """DrQ-v2's sampler: the actor's action ``μ(h)`` plus clipped Gaussian noise of a scheduled std (DDPG).

    * inside the update, ``a = μ(h) + clip(ε·σ, −c, c)`` with the straight-through clamp of
      :func:`clipped_normal_sample`, ``σ`` the std at the loss's step;
    * the bootstrapped value is ``min(Q1', Q2')(h', a')`` and the actor's objective ``−min(Q1, Q2)(h, ã)``;
      it has no temperature (:meth:`temperature_losses` gives none);
    * it acts with TorchRL's ``AdditiveGaussianModule`` (σ annealed like the schedule as frames are
      collected), unclipped noise and the action clamped to the spec, as DrQ-v2 acts; without noise under
      ``ExplorationType.DETERMINISTIC``.

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Args:
        std_schedule: the std over agent steps, a :class:`~vigen.losses.LinearSchedule` (DrQ-v2:
            ``linear(1.0, 0.1, 100000)``, the default) or a number for a constant std.
        clip: the noise clip ``c`` (0.3); ``None`` for none.

    Examples:
        >>> import torch
        >>> sampler = NoisyDeterministic(std_schedule=0.2)
        >>> action, log_prob = sampler.sample(torch.zeros(1000, 2), step=torch.tensor(0))
        >>> round(float(action.abs().max()), 4), log_prob  # the noise is clipped at 0.3
        (0.3, None)
        >>> sampler.std(torch.tensor(0))
        tensor(0.2000)
    """

    out_keys = ("std",)
    """The metrics it adds to a loss's output."""

    def __init__(self, std_schedule: LinearSchedule | float = DRQV2_STD_SCHEDULE, clip: float | None = DRQV2_CLIP) -> None:
        super().__init__()
        if not isinstance(std_schedule, LinearSchedule):
            if isinstance(std_schedule, bool) or not (isinstance(std_schedule, (int, float)) and std_schedule >= 0):
                raise ValueError(f"std_schedule must be a LinearSchedule or a number >= 0 (a constant std), got {std_schedule!r}.")
            std_schedule = LinearSchedule.constant(float(std_schedule))
        self.std_schedule = std_schedule
        self.clip = clip

    def std(self, step: Tensor) -> Tensor:
        """The noise std at ``step``, a 0-d float32 tensor on the step's device (no host synchronization)."""
        return self.std_schedule.at(step).float()

    def sample(self, actor_output: ActorOutput, step: Tensor) -> tuple[Tensor, None]:
        """``μ(h)`` plus the clipped noise (DrQ-v2's ``TruncatedNormal``), and no log-probability."""
        return clipped_normal_sample(actor_output, self.std(step), self.clip), None

    def value(self, q: Tensor, log_prob: Tensor | None) -> Tensor:
        """The bootstrapped value of a sampled next action: ``min(Q1', Q2')`` itself."""
        return q

    def objective(self, q: Tensor, log_prob: Tensor | None) -> Tensor:
        """The actor's per-sample objective: ``−min(Q1, Q2)``."""
        return -q

    def temperature_losses(self, log_prob: Tensor | None, action_dim: int, *, views: int) -> dict[str, Tensor]:
        """DDPG has no temperature: no loss."""
        return {}

    def metrics(self, step: Tensor, log_prob: Tensor | None) -> dict[str, Tensor]:
        """The noise std at ``step``."""
        return {"std": self.std(step)}

    def acting_module(self, network: nn.Module, action_spec: TensorSpec, pixels_key: NestedKey,
                      device: torch.device) -> TensorDictModuleBase:
        """``network`` (pixels → action) and TorchRL's ``AdditiveGaussianModule`` with σ annealed as the std schedule."""
        actor = TensorDictModule(network, in_keys=[pixels_key], out_keys=["action"])
        schedule = self.std_schedule
        return TensorDictSequential(actor, AdditiveGaussianModule(
            action_spec.to(device), sigma_init=schedule.init, sigma_end=schedule.final,
            annealing_num_steps=schedule.duration, device=device))

    def extra_repr(self) -> str:
        return f"std_schedule={self.std_schedule}, clip={self.clip}"


class SquashedGaussian(nn.Module):
    """SAC's sampler: a tanh-squashed Gaussian with a learned temperature α.

    With ``(ã, log π) ~ π(h)`` a reparameterised sample (the actor returns the mean and log σ, e.g.
    :class:`~vigen.models.GaussianActor`):

    * the bootstrapped value is ``min(Q1', Q2')(h', a') − α·log π(a'|h')``;
    * the actor's objective is ``α·log π(ã|h) − min(Q1, Q2)(h, ã)``, α detached;
    * ``loss_alpha = α·(−log π(ã|h) − H̄)``, log π detached, with target entropy ``H̄ = −|A|`` by
      default; α = exp(``log_alpha``), initialised at ``init_temperature``
      (:meth:`temperature_losses`, which a loss's ``forward`` calls);
    * it acts with a TorchRL ``ProbabilisticActor`` over ``TanhNormal`` (its mean under
      ``ExplorationType.DETERMINISTIC``).

    Paper: SAC, https://arxiv.org/abs/1801.01290 (with DrQ's settings, https://arxiv.org/abs/2004.13649).

    Args:
        init_temperature: initial α (DrQ, DMC-GB2: 0.1).
        target_entropy: ``"auto"`` for ``−action_dim``, or a number.
        squash_epsilon: ``None`` for DrQ's stable ``log(1 − tanh(u)²)``; a number ε for the SAC-AE /
            DMC-GB form ``log(relu(1 − tanh(u)²) + ε)`` (:data:`DMCGB_SQUASH_EPSILON` there), see
            :func:`squashed_normal_sample`.

    Examples:
        >>> import torch
        >>> sampler = SquashedGaussian(init_temperature=0.1)
        >>> action, log_prob = sampler.sample((torch.zeros(4, 2), torch.zeros(4, 2)), step=torch.tensor(0))
        >>> round(float(sampler.alpha.detach()), 3), sampler.temperature_losses(log_prob, action_dim=2, views=2)["loss_alpha"].shape
        (0.1, torch.Size([2]))
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
        self.init_temperature = float(init_temperature)
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

    def temperature_losses(self, log_prob: Tensor | None, action_dim: int, *, views: int) -> dict[str, Tensor]:
        """``loss_alpha = α·(−log π − H̄)`` per sample, log π detached, from the actor step's ``log_prob``.

        ``log_prob`` holds the actions of ``views`` views of the batch, view-major (``[V·B, 1]``);
        each sample's loss is the mean over its views (``[B]``).
        """
        if log_prob is None:
            raise RuntimeError("SquashedGaussian: the actor step must give the log-probability of its actions.")
        if isinstance(views, bool) or not isinstance(views, int) or views < 1 or log_prob.shape[0] % views:
            raise ValueError(f"SquashedGaussian: {log_prob.shape[0]} log-probabilities are not {views!r} views of one batch.")
        target_entropy = -action_dim if self.target_entropy == "auto" else float(self.target_entropy)
        loss = (self.alpha * (-log_prob - target_entropy).detach()).squeeze(-1)
        return {"loss_alpha": loss.reshape(views, -1).mean(0)}

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
        return f"init_temperature={self.init_temperature}, target_entropy={self.target_entropy!r}, squash_epsilon={self.squash_epsilon}"


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

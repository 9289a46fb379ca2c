"""SCPL: SVEA's critic with a saliency-masked Q consistency, a policy KL and a latent dynamics model."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Literal

import torch
from tensordict import TensorDictBase
from torch import Tensor, nn

from vigen.losses.base import ActorResult, Augmentations, AuxiliaryResult, CriticResult, Observations, td_error
from vigen.losses.saliency import GuidedBackprop, install_guided_forward, salient_q_consistency
from vigen.losses.sampling import squashed_normal_sample
from vigen.losses.svea_sac import SACSVEALoss
from vigen.transforms import RandomOverlay


def diagonal_gaussian_kl(mean_p: Tensor, log_var_p: Tensor, mean_q: Tensor, log_var_q: Tensor) -> Tensor:
    """``KL(N(μ_p, diag(v_p)) ‖ N(μ_q, diag(v_q)))`` per sample, summed over the last dim.

    ``½·Σ_j [v_p/v_q + (μ_q − μ_p)²/v_q − 1 + log v_q − log v_p]``, from the log-variances.

    Examples:
        >>> import torch
        >>> zero = torch.zeros(1, 2)
        >>> diagonal_gaussian_kl(zero, zero, zero, zero)
        tensor([0.])
        >>> diagonal_gaussian_kl(torch.ones(1, 2), zero, zero, zero)  # ½·Σ μ² for unit variances
        tensor([1.])
    """
    ratio = (log_var_p - log_var_q).exp()
    return 0.5 * (ratio + (mean_q - mean_p).pow(2) / log_var_q.exp() - 1.0 - (log_var_p - log_var_q)).sum(-1)


@dataclass(frozen=True)
class PairedObservations(Observations):
    """SCPL's step 1: the weak views, their strong views (one draw per (obs, next obs) pair) and the reward.

    Attributes:
        strong_obs: ``strong(obs)``.
        strong_next_obs: ``strong(next_obs)`` with the same draw as ``strong_obs`` (e.g. the same
            overlay image), as SCPL augments obs and next obs stacked along the channels.
        reward: the batch's (n-step) reward ``[B, 1]``.
    """

    strong_obs: Tensor
    strong_next_obs: Tensor
    reward: Tensor


class SCPLLoss(SACSVEALoss):
    """SCPL: SAC with SVEA's two-view critic, a saliency-masked Q consistency, a policy KL and a dynamics model.

    With the weak views ``s = shift(obs)``, ``s' = shift(next obs)`` (drawn independently), the
    strong views ``s̃ = strong(s)``, ``s̃' = strong(s')`` (one draw for the pair: SCPL overlays
    obs and next obs stacked along the channels), ``h = encoder(s)``, ``h̃ = encoder(s̃)``:

    * **critic**: ``loss_critic = w·TD(s) + w̃·TD(s̃) + λ_c·½·[C(s) + C(s̃)]``, where ``TD`` is
      ``(Q1 − y)² + (Q2 − y)²`` against the SAC target ``y`` of ``s'``, ``M`` the guided-backprop
      mask of Q1 at the ``quantile`` per sample and frame (:func:`~vigen.losses.attribution_mask`),
      ``x_M = x·M + u·(1 − M)`` with one ``u ~ U(min, max)`` over both views, and
      ``C(x) = (Q1(x) − Q1(x_M))² + (Q2(x) − Q2(x_M))²`` with gradient on both sides. SCPL's
      ``MSE(Q, y)`` over the stacked views and its ``0.5·MSE(Q, Q_M)`` are w = w̃ = 0.5 and
      λ_c = 0.5 here (the defaults);
    * **actor**: ``loss_actor = α·log π(ã|h) − min(Q1, Q2)(h, ã) + λ_KL·KL(π(·|h) ‖ π(·|h̃))`` on
      detached encoder features. As in SCPL's code, the KL is between the Gaussians
      ``N(tanh μ, diag(σ))`` and ``N(tanh μ̃, diag(σ̃))`` built from the policy's mean and σ at
      ``h`` and ``h̃`` (``kl_covariance="std"``, the default; ``"variance"`` uses ``diag(σ²)``),
      with the covariance of the first detached and its mean not;
    * **temperature**: ``loss_alpha = α·(−log π(ã|h) − H̄)``;
    * **dynamics**: with ``e = critic.embed(h)`` (the critic trunk's embedding, DMC-GB's critic
      projection) for both views and ``e' = critic.embed(encoder(s'))``, ``ẽ'`` likewise for
      ``s̃'`` (online networks, no gradient), the model ``(ê', r̂) = dynamics(e, a)`` gives
      ``loss_dynamics = ½·mean_j (ê' − e')² + (r̂ − r)²``, averaged over the two views; it trains
      the model, the critic trunk and the encoder.

    The next observation's target uses a target encoder by default (``target_encoder=True``,
    DMC-GB's SAC, whose target critic holds its own encoder): the next action is sampled on the
    online encoder's features and scored by the target critic on the target encoder's.
    ``SoftUpdate`` moves the target encoder with the target critic.

    Departures from SCPL's code (measured in ``benchmarks/parity.py``): SCPL steps the critic,
    then the actor and temperature, then (every second update) the encoder and the model with
    their own Adam (lr 3e-4), each after the previous step; here every term comes from the same
    parameters and one optimizer step takes them all, every update. The actor, the target and
    the dynamics model are updated on every call (SCPL: every second update of the critic), and
    ``SoftUpdate`` has one τ (SCPL: 0.01 for the Q heads, 0.05 for the encoder and the critic's
    projection). With n-step returns the reward model predicts the n-step reward of the batch
    (SCPL: one step).

    It is :class:`~vigen.losses.SACSVEALoss` (with the next observation shifted, SCPL's
    ``sample_drq``) with its steps 1 and 3 to 5 extended.

    Paper: SCPL, "Salience-Invariant Consistent Policy Learning for Generalization in Visual
    Reinforcement Learning" (AAMAS 2025), code https://github.com/bofusun/SCPL.

    Args:
        encoder: pixels → features; ``make_loss("scpl", ...)`` uses SVEA's 11-layer
            :class:`~vigen.models.SharedCNN` on DMC-GB's ``x / 255`` as SCPL does.
        actor: features → (mean, log σ), e.g. :class:`~vigen.models.GaussianActor` with a
            ``feature_dim`` trunk (DMC-GB's actor projection).
        critic: (features, action) → (Q1, Q2), with ``embed(features)``, the embedding both heads
            read (:class:`~vigen.models.Critic`).
        dynamics: (embedding, action) → (next embedding, reward), e.g.
            :class:`~vigen.models.LatentDynamics`.
        augmentation: the weak view; ``"default"`` is ``RandomShift(pad=4)``.
        strong_augmentation: the strong view; ``None`` for ``RandomOverlay(alpha=0.5)`` (SCPL's
            ``scpl``; pass ``RandomConv()`` for its ``scplr``).
        weak_weight, strong_weight: w and w̃ (0.5 each); the loss's ``svea_alpha`` and ``svea_beta``.
        quantile: the saliency quantile of the mask (0.9).
        consistency_weight: λ_c (0.5).
        kl_weight: λ_KL (1).
        kl_covariance: ``"std"`` (SCPL's code: ``diag(σ)``) or ``"variance"`` (``diag(σ²)``).
        dynamics_weight: weight of ``loss_dynamics`` (1).
        dynamics_lr: the model's learning rate in :meth:`optimizer_groups` (SCPL: 3e-4).
        target_encoder: encode the next view for the target critic with a target encoder.
        init_temperature, target_entropy: see :class:`~vigen.losses.SoftActorCritic`.
        squash_epsilon: SCPL's (DMC-GB's) ``log(relu(1 − tanh²) + 1e-6)``; ``None`` for DrQ's form.
        **kwargs: ``input_mask``, ``channels_last``, ``reduction``, ``check_finite``, ``init_temperature``, ...

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import make_loss
        >>> loss = make_loss("scpl", (9, 84, 84), action_dim=2, hidden_dim=32, seed=0)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> batch = TensorDict({
        ...     "pixels": pixels, "action": torch.zeros(4, 2),
        ...     "next": {"pixels": pixels, "reward": torch.ones(4, 1),
        ...              "done": torch.zeros(4, 1, dtype=torch.bool),
        ...              "terminated": torch.zeros(4, 1, dtype=torch.bool)},
        ... }, batch_size=[4])
        >>> out = loss(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_alpha', 'loss_critic', 'loss_dynamics']
        >>> optimizer = torch.optim.Adam(loss.optimizer_groups(lr=1e-4))
        >>> [group["lr"] for group in optimizer.param_groups]  # everything else, then the dynamics model
        [0.0001, 0.0003]
    """

    out_keys = SACSVEALoss.out_keys + [
        "mask_fraction", "consistency", "policy_kl", "loss_dynamics", "transition_error", "reward_error",
    ]

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        dynamics: nn.Module,
        *,
        augmentation: Augmentations | Literal["default"] = "default",
        strong_augmentation: Augmentations = None,
        weak_weight: float = 0.5,
        strong_weight: float = 0.5,
        quantile: float = 0.9,
        consistency_weight: float = 0.5,
        kl_weight: float = 1.0,
        kl_covariance: Literal["std", "variance"] = "std",
        dynamics_weight: float = 1.0,
        dynamics_lr: float = 3e-4,
        target_encoder: bool = True,
        squash_epsilon: float | None = 1e-6,
        **kwargs: Any,
    ) -> None:
        name = type(self).__name__
        if not callable(getattr(critic, "embed", None)):
            raise TypeError(f"{name}: the critic needs an embed(features) method giving the embedding its Q heads read "
                            "(the dynamics model's input), as vigen.models.Critic has.")
        if not isinstance(dynamics, nn.Module):
            raise TypeError(f"{name}: dynamics must be an nn.Module (e.g. vigen.models.LatentDynamics), got {type(dynamics).__name__}.")
        if not 0.0 <= quantile <= 1.0:
            raise ValueError(f"{name}: quantile must be in [0, 1], got {quantile}.")
        if kl_covariance not in ("std", "variance"):
            raise ValueError(f"{name}: kl_covariance must be 'std' (SCPL's code) or 'variance', got {kl_covariance!r}.")
        if not (isinstance(dynamics_lr, (int, float)) and math.isfinite(dynamics_lr) and dynamics_lr > 0):
            raise ValueError(f"{name}: dynamics_lr must be a positive number, got {dynamics_lr!r}.")
        super().__init__(encoder, actor, critic, augmentation=augmentation, strong_augmentation=strong_augmentation,
                         alpha=weak_weight, beta=strong_weight, augment_next=True, target_encoder=target_encoder,
                         squash_epsilon=squash_epsilon, **kwargs)
        GuidedBackprop(encoder, critic)  # fails early, with advice, when there is no nn.ReLU to guide
        self.dynamics = dynamics
        self.quantile = quantile
        self.kl_covariance = kl_covariance
        self.dynamics_lr = float(dynamics_lr)
        for coefficient, value in (("consistency_weight", consistency_weight), ("kl_weight", kl_weight),
                                   ("dynamics_weight", dynamics_weight)):
            self.register_coeff_buffer(coefficient, value)

    _schedulable_buffers = frozenset({"consistency_weight", "kl_weight", "dynamics_weight"})

    prepare_compile = install_guided_forward  # a compiled update's guided pass

    @staticmethod
    def _default_strong_augmentation() -> Augmentations:
        return RandomOverlay(alpha=0.5)

    # -- the steps --------------------------------------------------------------------------------
    def observations(self, tensordict: TensorDictBase) -> PairedObservations:
        """The weak views, the strong views of obs and next obs (one draw per pair) and the reward."""
        weak = super().observations(tensordict)
        pair = self._augment(self.strong_augmentation, torch.cat([weak.obs, weak.next_obs], dim=1))
        strong_obs, strong_next_obs = pair.chunk(2, dim=1)
        reward = tensordict.get(("next", self.tensor_keys.reward))
        return PairedObservations(weak.pixels, weak.next_pixels, weak.action, weak.obs, weak.next_obs,
                                  strong_obs, strong_next_obs, reward)

    def strong_view(self, batch: Observations) -> Tensor:
        """The strong view drawn in step 1, with the next observation's."""
        assert isinstance(batch, PairedObservations)
        return batch.strong_obs

    def critic_loss(self, batch: Observations, target: Tensor) -> CriticResult:
        """TD loss of both views plus ``λ_c·`` the mean over the views of the Q consistency with their salient pixels."""
        views = self.critic_views(batch)
        size, count = batch.batch_size, len(views)
        pixels = torch.cat([view.pixels for view in views])
        salient = salient_q_consistency(self, pixels, batch.action.repeat(count, 1), self.quantile)
        q1, q2, mask = salient.q1, salient.q2, salient.mask
        consistency = salient.consistency.reshape(count, size).mean(0)
        errors = td_error(q1, q2, target.repeat(count, 1)).split(size)
        loss = self.consistency_weight * consistency
        for view, error in zip(views, errors):
            loss = loss + view.weight * error
        metrics = {"q_strong_mean": q1[size:].detach().mean(), "mask_fraction": mask.float().mean(),
                   "consistency": consistency.detach().mean()}
        return CriticResult(loss, q1[:size], q2[:size], tuple(salient.features.split(size)), metrics=metrics)

    def actor_loss(self, batch: Observations, critic: CriticResult) -> ActorResult:
        """SAC's actor loss on ``h`` plus ``λ_KL·KL(π(·|h) ‖ π(·|h̃))`` (detached features, frozen critic)."""
        clean, strong = (features.detach() for features in critic.view_features)
        mean, log_std = self.policy(torch.cat([clean, strong]))
        (mean_clean, mean_strong), (log_std_clean, log_std_strong) = mean.chunk(2), log_std.chunk(2)
        action, log_prob = squashed_normal_sample(mean_clean, log_std_clean, epsilon=self.squash_epsilon)
        q = torch.min(*self.q_values(clean, action, frozen=True))
        per_unit = 1.0 if self.kl_covariance == "std" else 2.0  # log of the covariance's diagonal: log σ or 2·log σ
        kl = diagonal_gaussian_kl(torch.tanh(mean_clean), per_unit * log_std_clean.detach(),
                                  torch.tanh(mean_strong), per_unit * log_std_strong)
        loss = (self.alpha.detach() * log_prob - q).squeeze(-1) + self.kl_weight * kl
        return ActorResult(loss, log_prob, {"entropy": -log_prob.detach().mean(), "policy_kl": kl.detach().mean()})

    def auxiliary_losses(self, batch: Observations, critic: CriticResult, actor: ActorResult) -> AuxiliaryResult:
        """The temperature loss and the dynamics model's next-embedding and reward errors on both views."""
        assert isinstance(batch, PairedObservations)
        result = super().auxiliary_losses(batch, critic, actor)
        count = len(critic.view_features)
        embedding = self.embed(torch.cat(critic.view_features))
        with torch.no_grad():
            next_embedding = self.embed(self.encode(torch.cat([batch.next_obs, batch.strong_next_obs])))
        predicted_next, predicted_reward = self.dynamics(embedding, batch.action.repeat(count, 1))
        transition = 0.5 * (predicted_next - next_embedding).pow(2).mean(-1)
        reward = (predicted_reward - batch.reward.repeat(count, 1)).pow(2).squeeze(-1)
        result.losses["loss_dynamics"] = self.dynamics_weight * (transition + reward)  # [views·B]: averaged per sample
        result.metrics.update(transition_error=transition.detach().mean(), reward_error=reward.detach().mean())
        return result

    # -- building blocks ------------------------------------------------------------------------
    def embed(self, features: Tensor) -> Tensor:
        """The online critic's embedding of encoder features (its trunk), with gradient."""
        with self.critic_params.to_module(self.critic, preserve_module_state=False):
            return self.critic.embed(features)

    def optimizer_groups(self, lr: float) -> list[dict[str, Any]]:
        """Everything but the dynamics model at ``lr``; the model at ``dynamics_lr`` (SCPL: 3e-4)."""
        model = list(self.dynamics.parameters())
        own = {id(parameter) for parameter in model}
        rest = [parameter for parameter in self.parameters() if id(parameter) not in own]
        return [{"params": rest, "lr": lr}, {"params": model, "lr": self.dynamics_lr}]

"""SCPL: SVEA's critic with a saliency-masked Q consistency, a policy KL and a latent dynamics model."""

from __future__ import annotations

from typing import Any, Literal

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from torch import Tensor, nn

from vigen.losses.base import Augmentations, per_sample_mean, squared_td_errors
from vigen.losses.samplers import SquashedGaussian
from vigen.losses.saliency import SalientQLoss


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


class SCPLLoss(SalientQLoss):
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
      λ_c = 0.5 here (its record, ``ALGOS["scpl"]``);
    * **actor**: ``loss_actor = α·log π(ã|h) − min(Q1, Q2)(h, ã) + λ_KL·KL(π(·|h) ‖ π(·|h̃))`` on
      detached encoder features. As in SCPL's code, the KL is between the Gaussians
      ``N(tanh μ, diag(σ))`` and ``N(tanh μ̃, diag(σ̃))`` built from the policy's mean and σ at
      ``h`` and ``h̃`` (``kl_covariance="std"``; ``"variance"`` uses ``diag(σ²)``),
      with the covariance of the first detached and its mean not;
    * **temperature**: ``loss_alpha = α·(−log π(ã|h) − H̄)``;
    * **dynamics**: with ``e = critic.embed(h)`` (the critic trunk's embedding, DMC-GB's critic
      projection) for both views and ``e' = critic.embed(encoder(s'))``, ``ẽ'`` likewise for
      ``s̃'`` (online networks, no gradient), the model ``(ê', r̂) = dynamics(e, a)`` gives
      ``loss_dynamics = ½·mean_j (ê' − e')² + (r̂ − r)²``, averaged over the two views; it trains
      the model, the critic trunk and the encoder.

    The next observation's target uses a target encoder (``target_encoder=True`` in its record,
    DMC-GB's SAC, whose target critic holds its own encoder): the next action is sampled on the
    online encoder's features and scored by the target critic on the target encoder's.
    ``SoftUpdate`` moves the target encoder with the target critic.

    Departures from SCPL's code (measured in ``benchmarks/parity``): SCPL steps the critic,
    then the actor and temperature, then (every second update) the encoder and the model with
    their own Adam (lr 3e-4), each after the previous step; here every term comes from the same
    parameters and one optimizer step takes them all. The loss computes the actor's and the model's
    terms on every call; SCPL's stepping of the actor, the target and the model every second update,
    and its two target rates (0.01 for the Q heads, 0.05 for the encoder and the critic's projection),
    are the update's (:class:`~vigen.losses.UpdateStep`'s schedule, :class:`~vigen.losses.SplitSoftUpdate`;
    ``examples/train.py --recipe scpl-dmcgb``). With n-step returns the reward model predicts the n-step
    reward of the batch (SCPL: one step).

    Its critic is :class:`~vigen.losses.SVEALoss`'s on SAC (with the next observation shifted, SCPL's
    ``sample_drq``) plus the consistency term; the rest of the update is its own.

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
        sampler: SAC's :class:`~vigen.losses.SquashedGaussian` (the policy KL needs its mean and
            σ: a ``NoisyDeterministic`` is refused); SCPL's (DMC-GB's) is α₀ = 0.1 and
            ``log(relu(1 − tanh²) + ε)`` (``squash_epsilon=DMCGB_SQUASH_EPSILON``).
        strong_augmentation: the strong view (SCPL's ``scpl``: ``RandomOverlay(alpha=0.5)``; its
            ``scplr``: ``RandomConv()``).
        weak_weight, strong_weight: w and w̃ (SCPL: 0.5 each).
        quantile: the saliency quantile of the mask (SCPL: 0.9; :class:`~vigen.losses.saliency.SalientQLoss`).
        consistency_weight: λ_c (SCPL: 0.5).
        kl_weight: λ_KL (SCPL: 1).
        kl_covariance: ``"std"`` (SCPL's code: ``diag(σ)``) or ``"variance"`` (``diag(σ²)``).
        dynamics_weight: weight of ``loss_dynamics`` (SCPL: 1).
        **options: ``augmentation`` (the weak view), ``target_encoder`` (SCPL: DMC-GB's target encoder),
            ``param_groups`` (SCPL's dynamics model has its own Adam, lr 3e-4: ``{"dynamics": {"lr": 3e-4}}``,
            :meth:`optimizer_groups`), ``input_mask``, ``channels_last``, ``reduction``, ``check_finite``.

    Examples:
        >>> import torch
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import example_batch, make_loss
        >>> loss = make_loss("scpl", (9, 84, 84), action_dim=2, hidden_dim=32, seed=0)
        >>> updater = SoftUpdate(loss, tau=0.01)
        >>> batch = example_batch(4)  # uint8 frame stacks [4, 9, 84, 84], actions of size 2
        >>> out = loss(batch)
        >>> sorted(key for key in out.keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_alpha', 'loss_critic', 'loss_dynamics']
        >>> optimizer = torch.optim.Adam(loss.optimizer_groups(lr=1e-4))
        >>> [group["lr"] for group in optimizer.param_groups]  # everything else, then the dynamics model
        [0.0001, 0.0003]
    """

    own_out_keys = ("q_strong_mean", "loss_dynamics", "mask_fraction", "consistency", "policy_kl",
                    "transition_error", "reward_error")
    _schedulable_buffers = frozenset({"kl_weight", "dynamics_weight"})

    def __init__(
        self,
        encoder: nn.Module,
        actor: nn.Module,
        critic: nn.Module,
        dynamics: nn.Module,
        *,
        sampler: SquashedGaussian,
        strong_augmentation: Augmentations,
        weak_weight: float,
        strong_weight: float,
        kl_weight: float,
        kl_covariance: Literal["std", "variance"],
        dynamics_weight: float,
        **options: Any,
    ) -> None:
        name = type(self).__name__
        if not isinstance(sampler, SquashedGaussian):
            raise TypeError(f"{name} is SAC: its policy KL compares the squashed Gaussians of two views; it takes a "
                            f"SquashedGaussian sampler, not {type(sampler).__name__}.")
        if not callable(getattr(critic, "embed", None)):
            raise TypeError(f"{name}: the critic needs an embed(features) method giving the embedding its Q heads read "
                            "(the dynamics model's input), as vigen.models.Critic has.")
        if not isinstance(dynamics, nn.Module):
            raise TypeError(f"{name}: dynamics must be an nn.Module (e.g. vigen.models.LatentDynamics), got {type(dynamics).__name__}.")
        if kl_covariance not in ("std", "variance"):
            raise ValueError(f"{name}: kl_covariance must be 'std' (SCPL's code) or 'variance', got {kl_covariance!r}.")
        super().__init__(encoder, actor, critic, sampler=sampler, **options)
        self.add_strong_view(strong_augmentation, weak_weight, strong_weight)
        self.dynamics = dynamics
        self.kl_covariance = kl_covariance
        self.register_coeff_buffer("kl_weight", kl_weight)
        self.register_coeff_buffer("dynamics_weight", dynamics_weight)

    @dispatch
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        batch = self.read_batch(tensordict)
        size, action = batch.size, batch.action
        obs, next_obs = self.augment(batch.pixels), self.augment(batch.next_pixels)
        # one strong draw for each (obs, next obs) pair: SCPL augments them stacked along the channels
        pair = self.augment(torch.cat([obs, next_obs], dim=1), self.strong_augmentation)
        strong_obs, strong_next_obs = pair.chunk(2, dim=1)
        target = self.critic_target(tensordict, next_obs)
        # the critic: the TD loss of both views plus λ_c· their mean Q consistency with their salient pixels
        salient = self.salient_q(torch.cat([obs, strong_obs]), action.repeat(2, 1))
        q1, q2 = salient.q1, salient.q2
        consistency = salient.consistency.reshape(2, size).mean(0)
        errors = squared_td_errors(q1, q2, target.repeat(2, 1)).split(size)
        loss_critic = self.consistency_weight * consistency + self.weak_weight * errors[0] + self.strong_weight * errors[1]
        # the actor: SAC's loss on h plus λ_KL·KL(π(·|h) ‖ π(·|h̃)), on detached features
        clean, strong = (features.detach() for features in salient.features.split(size))
        mean, log_std = self.actor_output(torch.cat([clean, strong]))
        (mean_clean, mean_strong), (log_std_clean, log_std_strong) = mean.chunk(2), log_std.chunk(2)
        loss_actor, log_prob = self.actor_loss(clean, actor_output=(mean_clean, log_std_clean))
        per_unit = 1.0 if self.kl_covariance == "std" else 2.0  # log of the covariance's diagonal: log σ or 2·log σ
        kl = diagonal_gaussian_kl(torch.tanh(mean_clean), per_unit * log_std_clean.detach(),
                                  torch.tanh(mean_strong), per_unit * log_std_strong)
        loss_actor = loss_actor + self.kl_weight * kl
        # the dynamics model: the next embedding and the reward from (embedding, action), on both views
        embedding = self.embed(salient.features)
        with torch.no_grad():
            next_embedding = self.embed(self.encode(torch.cat([next_obs, strong_next_obs])))
        predicted_next, predicted_reward = self.dynamics(embedding, action.repeat(2, 1))
        transition = 0.5 * (predicted_next - next_embedding).pow(2).mean(-1)
        rewards = tensordict.get(("next", self.tensor_keys.reward)).repeat(2, 1)
        reward = (predicted_reward - rewards).pow(2).squeeze(-1)
        losses = {"loss_critic": loss_critic, "loss_actor": loss_actor,
                  "loss_dynamics": per_sample_mean(self.dynamics_weight * (transition + reward), views=2),
                  # SAC's temperature, on the actor step's actions (the clean view's)
                  "loss_alpha": self.sampler.temperature_losses(log_prob, batch.action_dim, views=1)["loss_alpha"]}
        metrics = {**self.sampler.metrics(self.schedule_step, log_prob), "q_strong_mean": q1[size:].detach().mean(),
                   "mask_fraction": salient.mask.float().mean(), "consistency": consistency.detach().mean(),
                   "policy_kl": kl.detach().mean(), "transition_error": transition.detach().mean(),
                   "reward_error": reward.detach().mean()}
        return self.output(tensordict, target, q1[:size], q2[:size], losses, metrics)

    def embed(self, features: Tensor) -> Tensor:
        """The online critic's embedding of encoder features (its trunk), with gradient."""
        with self.critic_params.to_module(self.critic, preserve_module_state=False):
            return self.critic.embed(features)

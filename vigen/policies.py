"""Acting policies for vigen's losses: the networks a loss trains, as a TorchRL policy over pixels.

The policy shares the loss's live parameters (no copy), so it acts with whatever the optimizer
last wrote. Exploration follows TorchRL's convention: noise is added when the exploration type is
``RANDOM`` (collectors' default) and left out under ``DETERMINISTIC`` (evaluation).
"""

from __future__ import annotations

from tensordict.nn import TensorDictModule, TensorDictModuleBase, TensorDictSequential
from torch import Tensor, nn
from torchrl.data import TensorSpec
from torchrl.modules import AdditiveGaussianModule, ProbabilisticActor, TanhNormal

from vigen.losses import DrQLoss, DrQv2Loss, LinearSchedule


class _PixelsToFeatures(nn.Module):
    def __init__(self, encoder: nn.Module, head: nn.Module) -> None:
        super().__init__()
        self.encoder = encoder
        self.head = head

    def forward(self, pixels: Tensor) -> Tensor | tuple[Tensor, Tensor]:
        return self.head(self.encoder(pixels))


class _LocScale(nn.Module):
    """``GaussianActor``'s (mean, log σ) → (loc, σ), the parameters TorchRL's ``TanhNormal`` takes."""

    def __init__(self, actor: nn.Module) -> None:
        super().__init__()
        self.actor = actor

    def forward(self, hidden: Tensor) -> tuple[Tensor, Tensor]:
        mean, log_std = self.actor(hidden)
        return mean, log_std.exp()


def make_policy(
    loss: DrQv2Loss,
    action_spec: TensorSpec,
    *,
    pixels_key: str = "pixels",
) -> TensorDictModuleBase:
    """The acting policy of ``loss``: pixels → ``"action"``, with the algorithm's exploration.

    * DDPG-style losses (DrQ-v2, SVEA, SRM, SGQN, CURL): ``actor(encoder(pixels))`` plus
      Gaussian noise from TorchRL's ``AdditiveGaussianModule`` whose σ follows the loss's std
      schedule (linear 1.0 → 0.1) when the loss has one; call ``policy[-1].step(frames)`` as
      steps are collected. The noise is unclipped and the action clamped to the spec, as in
      DrQ-v2's acting.
    * DrQ (SAC): a ``ProbabilisticActor`` sampling a tanh-squashed Gaussian, its mean under
      ``DETERMINISTIC``.

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645 (exploration schedule).

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import Bounded
        >>> from vigen.losses import DrQv2Loss
        >>> from vigen.models import Actor, Critic, DrQv2Encoder
        >>> from vigen.policies import make_policy
        >>> encoder = DrQv2Encoder(9)
        >>> features = encoder.output_dim(9, 84, 84)
        >>> loss = DrQv2Loss(encoder, Actor(features, 2, hidden_dim=32), Critic(features, 2, hidden_dim=32))
        >>> policy = make_policy(loss, Bounded(-1, 1, shape=(2,)))
        >>> pixels = torch.randint(0, 256, (9, 84, 84), dtype=torch.uint8)
        >>> policy(TensorDict({"pixels": pixels}))["action"].shape
        torch.Size([2])
    """
    if isinstance(loss, DrQLoss):
        features = TensorDictModule(
            _PixelsToFeatures(loss.encoder, _LocScale(loss.actor)), in_keys=[pixels_key], out_keys=["loc", "scale"]
        )
        return ProbabilisticActor(
            features,
            in_keys=["loc", "scale"],
            spec=action_spec,
            distribution_class=TanhNormal,
            distribution_kwargs={"low": action_spec.space.low, "high": action_spec.space.high},
        )
    if not isinstance(loss, DrQv2Loss):
        raise TypeError(f"make_policy takes a vigen loss (DrQv2Loss or a subclass), got {type(loss).__name__}.")
    actor = TensorDictModule(_PixelsToFeatures(loss.encoder, loss.actor), in_keys=[pixels_key], out_keys=["action"])
    schedule = loss.std_schedule
    if isinstance(schedule, LinearSchedule):
        sigma = dict(sigma_init=schedule.init, sigma_end=schedule.final, annealing_num_steps=schedule.duration)
    else:
        sigma = dict(sigma_init=float(schedule), sigma_end=float(schedule), annealing_num_steps=1)
    return TensorDictSequential(actor, AdditiveGaussianModule(action_spec, **sigma))

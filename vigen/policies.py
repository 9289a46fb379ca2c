"""Acting policies for vigen's losses: ``make_policy(loss, spec)`` is ``loss.make_policy(spec)``.

Each loss builds its own acting policy from the networks it trains (see
:meth:`vigen.losses.ActorCriticLoss.make_policy`); the policy shares the loss's live parameters (no
copy), so it acts with whatever the optimizer last wrote. Exploration follows TorchRL's
convention: noise is added when the exploration type is ``RANDOM`` (collectors' default) and left
out under ``DETERMINISTIC`` (evaluation).
"""

from __future__ import annotations

from tensordict.nn import TensorDictModuleBase
from tensordict.utils import NestedKey
from torchrl.data import TensorSpec

from vigen.losses import ActorCriticLoss


def make_policy(
    loss: ActorCriticLoss,
    action_spec: TensorSpec,
    *,
    pixels_key: NestedKey = "pixels",
) -> TensorDictModuleBase:
    """The acting policy of ``loss``: pixels → ``"action"``, with the algorithm's exploration.

    * DDPG-style losses (DrQ-v2, SVEA, SRM, SGQN, CURL, ...): ``actor(encoder(pixels))`` plus
      Gaussian noise from TorchRL's ``AdditiveGaussianModule`` whose σ follows the loss's std
      schedule (linear 1.0 → 0.1) when the loss has one; call ``policy[-1].step(frames)`` as
      steps are collected. The noise is unclipped and the action clamped to the spec, as in
      DrQ-v2's acting.
    * DrQ (SAC): a ``ProbabilisticActor`` sampling a tanh-squashed Gaussian, its mean under
      ``DETERMINISTIC``.

    A loss with an input mask (MaDi) applies it in front of the encoder here too.

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
    if not isinstance(loss, ActorCriticLoss):
        raise TypeError(f"make_policy takes a vigen loss (an ActorCriticLoss), got {type(loss).__name__}.")
    return loss.make_policy(action_spec, pixels_key=pixels_key)

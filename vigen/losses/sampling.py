"""How DrQ-v2 and DrQ sample actions inside their updates.

DrQ-v2 adds clipped Gaussian noise to a deterministic action (its ``TruncatedNormal``); DrQ
samples a tanh-squashed Gaussian. TorchRL runs losses in deterministic exploration mode, so the
losses call these explicitly.
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor


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

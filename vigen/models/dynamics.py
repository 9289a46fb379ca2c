"""SCPL's latent dynamics model: the next state embedding and the reward from (embedding, action)."""

from __future__ import annotations

import torch
from torch import Tensor, nn


class LatentDynamics(nn.Module):
    """A deterministic transition and reward model on a state embedding, as in SCPL.

    ``z = relu(LayerNorm(Linear([h, a])))`` with ``hidden_dim`` units, then two linear heads:
    the predicted next embedding ``ĥ' = Linear(z)`` (same size as ``h``) and the predicted
    reward ``r̂ = Linear(z)``. SCPL trains it, and through ``h`` the encoder, with
    ``½·mean((ĥ' − sg(h'))²) + (r̂ − r)²`` (see :class:`~vigen.losses.SCPLLoss`). The layers keep
    PyTorch's default initialisation, as SCPL's model does.

    Paper: SCPL (AAMAS 2025), https://github.com/bofusun/SCPL.

    Args:
        embedding_dim: size of the state embedding ``h`` (the critic trunk's ``feature_dim``).
        action_dim: size of the action.
        hidden_dim: width of the hidden layer (SCPL: 512).

    Examples:
        >>> import torch
        >>> model = LatentDynamics(embedding_dim=50, action_dim=6)
        >>> next_embedding, reward = model(torch.zeros(4, 50), torch.zeros(4, 6))
        >>> next_embedding.shape, reward.shape
        (torch.Size([4, 50]), torch.Size([4, 1]))
    """

    def __init__(self, embedding_dim: int, action_dim: int, hidden_dim: int = 512) -> None:
        super().__init__()
        for name, value in (("embedding_dim", embedding_dim), ("action_dim", action_dim), ("hidden_dim", hidden_dim)):
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"LatentDynamics: {name} must be a positive int, got {value!r}.")
        self.hidden = nn.Linear(embedding_dim + action_dim, hidden_dim)
        self.norm = nn.LayerNorm(hidden_dim)
        self.next_embedding = nn.Linear(hidden_dim, embedding_dim)
        self.reward = nn.Linear(hidden_dim, 1)

    def forward(self, embedding: Tensor, action: Tensor) -> tuple[Tensor, Tensor]:
        """(predicted next embedding ``[..., embedding_dim]``, predicted reward ``[..., 1]``)."""
        hidden = torch.relu(self.norm(self.hidden(torch.cat([embedding, action], dim=-1))))
        return self.next_embedding(hidden), self.reward(hidden)

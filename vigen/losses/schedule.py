"""DrQ-v2's linear schedule, of the exploration and target-policy noise std (a sampler's ``std_schedule``)."""

from __future__ import annotations

from dataclasses import dataclass

import torch
from torch import Tensor


@dataclass(frozen=True)
class LinearSchedule:
    """``init`` → ``final`` linearly over ``duration`` steps, then ``final`` (DrQ-v2's ``linear(a, b, n)``).

    DrQ-v2 evaluates it at the *agent* step (frames / action repeat); RL-ViGen's presets are
    ``linear(1.0, 0.1, 100000)`` (easy), ``500000`` (medium) and ``2000000`` (hard).

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Examples:
        >>> schedule = LinearSchedule(1.0, 0.1, 100_000)
        >>> schedule(0), schedule(50_000), schedule(10**6)
        (1.0, 0.55, 0.1)
    """

    init: float = 1.0
    final: float = 0.1
    duration: int = 100_000

    def __post_init__(self) -> None:
        if self.duration <= 0:
            raise ValueError(f"LinearSchedule duration must be positive, got {self.duration}.")

    @classmethod
    def constant(cls, value: float) -> LinearSchedule:
        """The schedule that stays at ``value`` from the first step.

        Examples:
            >>> LinearSchedule.constant(0.2)(10**6)
            0.2
        """
        return cls(value, value, 1)

    def __call__(self, step: int | float) -> float:
        mix = min(max(float(step) / self.duration, 0.0), 1.0)
        return (1.0 - mix) * self.init + mix * self.final

    def at(self, step: Tensor) -> Tensor:
        """The schedule at a step held in a tensor, as a float64 tensor on its device: no host synchronization.

        Computed in float64 with the same operations as :meth:`__call__`, so it holds the same value.

        Examples:
            >>> import torch
            >>> LinearSchedule(1.0, 0.1, 100_000).at(torch.tensor(50_000)).item() == LinearSchedule(1.0, 0.1, 100_000)(50_000)
            True
        """
        mix = (step.to(torch.float64) / self.duration).clamp(0.0, 1.0)
        return (1.0 - mix) * self.init + mix * self.final

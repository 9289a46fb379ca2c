"""Every loss learns a tiny pixel task on CPU: point the first action at a dot seen in the image.

One-step episodes (terminated, so the target is the reward): the frame stack shows a bright
square at a column given by ``x ∈ [-1, 1]``, the reward is ``−(a₀ − x)² − a₁²``, and actions in the
data are uniform. A critic that reads the dot from the pixels and an actor that climbs it end
with ``a₀ ≈ x``; an untrained actor is off by about 0.5 on average, the trained ones by about 0.1 (the ±1 px
shift alone blurs x by ±0.17).
"""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict
from torchrl.objectives import SoftUpdate

from loss_helpers import LOSSES, SAC_LOSSES, SIZE, make_loss
from vigen.transforms import RandomShift

pytestmark = pytest.mark.slow


def dot_images(x: torch.Tensor) -> torch.Tensor:
    """``[B, 9, 16, 16]`` uint8 stacks of three identical frames with a 4×4 square at column ``x``."""
    images = torch.zeros(len(x), 9, SIZE, SIZE, dtype=torch.uint8)
    columns = ((x + 1) / 2 * (SIZE - 4)).round().long()
    for index, column in enumerate(columns.tolist()):
        images[index, :, 6:10, column : column + 4] = 255
    return images


def dot_batch(batch: int, generator: torch.Generator) -> TensorDict:
    x = torch.rand(batch, generator=generator) * 2 - 1
    action = torch.rand(batch, 2, generator=generator) * 2 - 1
    reward = -(action[:, :1] - x[:, None]) ** 2 - action[:, 1:] ** 2
    pixels = dot_images(x)
    ones = torch.ones(batch, 1, dtype=torch.bool)
    return TensorDict(
        {"pixels": pixels, "action": action, "next": {"pixels": pixels, "reward": reward, "done": ones, "terminated": ones}},
        batch_size=[batch],
    )


def policy_error(loss, x: torch.Tensor) -> float:
    with torch.no_grad():
        mean = loss.actor_output(loss.encode(dot_images(x)))  # through the input mask, if the loss has one
        action = torch.tanh(mean[0]) if isinstance(mean, tuple) else mean
    return (action[:, 0] - x).abs().mean().item()


CI_SAMPLE = {"drqv2", "svea", "curl", "drq", "sada", "simgrl", "vrl3"}  # the rest (the slowest) run with -m matrix


@pytest.mark.parametrize("name", [name if name in CI_SAMPLE else pytest.param(name, marks=pytest.mark.matrix) for name in LOSSES])
def test_loss_learns_the_dot_task(name):
    torch.manual_seed(0)
    options = {} if name in SAC_LOSSES else {"std_schedule": 0.2}
    loss = make_loss(name, augmentation=RandomShift(pad=1, seed=0), **options)
    updater = SoftUpdate(loss, tau=0.05)
    optimizer = torch.optim.Adam(loss.parameters(), lr=1e-3)
    generator = torch.Generator().manual_seed(0)
    x_eval = torch.linspace(-0.9, 0.9, 64)
    before = policy_error(loss, x_eval)
    for _ in range(1000):
        out = loss(dot_batch(64, generator))
        optimizer.zero_grad()
        sum(value for key, value in out.items() if key.startswith("loss_")).backward()
        optimizer.step()
        updater.step()
    after = policy_error(loss, x_eval)
    assert before > 0.3 and after < 0.2, f"{name}: |a - x| went from {before:.3f} to {after:.3f}"

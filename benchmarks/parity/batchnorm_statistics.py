"""BatchNorm running statistics: what an update leaves behind (PIE-G's and VRL3's measure, not compared)."""

from __future__ import annotations

import copy
from typing import Any

import torch
from torch import Tensor, nn

from benchmarks.parity.harness import TINY, canonical, relative

_STATISTICS = ("running_mean", "running_var", "num_batches_tracked")


def batchnorm_statistics(agent: Any, attribute: str, prefix: str, loss: Any) -> tuple[dict[str, Tensor], dict[str, Tensor]]:
    """The BatchNorm buffers of vigen's ``loss`` and of the original's module ``attribute`` (under vigen's name ``prefix``).

    Both as ``{canonical name: copy}``: running means, variances and batch counts; every one of
    vigen's must have its counterpart in the original.
    """
    module = agent
    for part in attribute.split("."):
        module = getattr(module, part)
    ours = {canonical(n): b.detach().clone() for n, b in loss.named_buffers() if n.rsplit(".", 1)[-1] in _STATISTICS}
    theirs = {f"{prefix}.{n}": b.detach().clone() for n, b in module.named_buffers() if f"{prefix}.{n}" in ours}
    if set(ours) != set(theirs):
        raise RuntimeError(f"BatchNorm buffers of vigen without a counterpart in the original: {sorted(set(ours) - set(theirs))[:4]}")
    return theirs, ours


class StatisticsGap:
    """How far vigen's BatchNorm running statistics are from the original's, at build and after the update.

    The running statistics are an exponential average (momentum m): after p passes, ``(1 − m)^p``
    of a gap at build is left; the rest of the gap after the update comes from the order in which
    the passes saw their batches. Every gap is relative to the original's statistics after the
    update (those it acts with), per tensor, then the max over tensors. What the gap changes when
    acting: the original's deterministic actions (``agent.act(obs, step, eval_mode=True)`` in eval
    mode) on the observations ``pixels`` with its own statistics and with vigen's. Called as a
    :data:`~benchmarks.parity.harness.Measure`.
    """

    def __init__(self, agent: Any, attribute: str, prefix: str, loss: Any, pixels: Tensor, step: int) -> None:
        self.attribute, self.prefix, self.pixels, self.step = attribute, prefix, pixels, step
        self.original, self.vigen = batchnorm_statistics(agent, attribute, prefix, loss)
        module = agent
        for part in attribute.split("."):
            module = getattr(module, part)
        momenta = {m.momentum for m in module.modules() if isinstance(m, nn.modules.batchnorm._BatchNorm)}
        if len(momenta) != 1 or None in momenta:
            raise RuntimeError(f"StatisticsGap needs one BatchNorm momentum, found {momenta}.")
        self.momentum = float(momenta.pop())

    def __call__(self, agent: Any, loss: Any) -> str:
        original, vigen = batchnorm_statistics(agent, self.attribute, self.prefix, loss)
        count = next(k for k in vigen if k.endswith("num_batches_tracked"))
        passes = int(original[count] - self.original[count]), int(vigen[count] - self.vigen[count])
        decay = (1 - self.momentum) ** passes[0]
        built, after, order = 0.0, 0.0, 0.0
        running = [k for k in vigen if not k.endswith("num_batches_tracked")]
        for key in running:
            scale = max(original[key].abs().max().item(), TINY)
            start = self.vigen[key] - self.original[key]
            built = max(built, start.abs().max().item() / scale)
            after = max(after, (vigen[key] - original[key]).abs().max().item() / scale)
            order = max(order, (vigen[key] - original[key] - decay * start).abs().max().item() / scale)
        swapped = copy.deepcopy(agent)
        module = swapped
        for part in self.attribute.split("."):
            module = getattr(module, part)
        with torch.no_grad():
            for name, buffer in module.named_buffers():
                if f"{self.prefix}.{name}" in vigen:
                    buffer.copy_(vigen[f"{self.prefix}.{name}"])
        acting = relative(self._actions(swapped), self._actions(agent))
        return (f"BatchNorm running statistics ({len(running)} tensors; {passes[1]} encoder passes in vigen, {passes[0]} in the "
                f"original), max rel. diff vigen vs original (to the original's after the update): {built:.1e} at build, "
                f"{after:.1e} after the update, of which {decay * built:.1e} is what is left of the build-time gap "
                f"((1 − {self.momentum:g})^{passes[0]} of it) and {order:.1e} comes from the order of the passes. Acting "
                f"(eval mode, running statistics) on the batch's {len(self.pixels)} observations, the original's "
                f"deterministic actions with vigen's statistics instead of its own: max rel. diff {acting:.1e}")

    def _actions(self, agent: Any) -> Tensor:
        agent.train(False)
        try:
            with torch.no_grad():
                return torch.stack([torch.as_tensor(agent.act(obs, self.step, eval_mode=True)) for obs in self.pixels])
        finally:
            agent.train(True)

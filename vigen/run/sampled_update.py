"""One gradient update on a batch sampled on the device, the sampling and the update captured together as one CUDA graph.

A training loop whose replay buffer lives on the GPU (:class:`vigen.run.FrameReplay`) needs
nothing from the host per update: the slots are drawn on the device, the batch gathered there,
the loss, backward, Adam and the target update run there. :class:`SampledUpdate` captures all
of it once (:class:`vigen.cuda_graph.CudaGraphCall`) and then launches one graph per update: the
loop's host time per update is one ``graph.replay()``, and the host never waits for the GPU
until it reads a metric.
"""

from __future__ import annotations

from typing import Protocol

import torch
from tensordict import TensorDictBase

from vigen.cuda_graph import CudaGraphCall, indexed
from vigen.losses import UpdateStep
from vigen.transforms import ImageAugmentation


class DeviceSampler(Protocol):
    """A replay buffer that samples on the device from its own generator (:class:`vigen.run.FrameReplay`)."""

    generator: torch.Generator

    def sample(self) -> TensorDictBase: ...


class SampledUpdate:
    """``update(replay.sample())`` as one call: on CUDA captured as one CUDA graph, replayed at every update.

    The first ``warmup`` calls run eagerly (the first compiles a compiled update); the next one
    captures and replays; every call makes exactly one update, drawing its batch from the
    replay's generator (and the augmentations from theirs) as the eager loop would, so the
    captured updates equal the eager ones. The returned losses and metrics are the graph's own
    tensors, overwritten by the next call: read them (``vigen.losses.update_metrics``) or clone
    them before it. Extending the replay between calls is what it is for: its memory is fixed.

    Off CUDA (or ``cudagraph=False``) it runs the same calls eagerly through the wrapper's
    static-buffer path, which is how a CPU test checks the capture logic
    (``vigen.devices.accelerator_paths``).

    Args:
        update: the update, built with ``cudagraph=False`` (this captures it together with the
            sampling); compiled or eager. Captured, its optimizer must be ``capturable``.
        replay: samples on the update's device from its own ``generator``.
        cudagraph: capture (default: on CUDA).
        warmup: eager calls before the capture.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.objectives import SoftUpdate
        >>> from vigen.losses import UpdateStep, make_loss
        >>> from vigen.run import FrameReplay, SampledUpdate
        >>> loss = make_loss("drqv2", (9, 16, 16), 2, hidden_dim=16, feature_dim=8).make_value_estimator(gamma=0.99)
        >>> replay = FrameReplay(100, batch_size=4, n_step=1, gamma=0.99, device="cpu")
        >>> frame = torch.randint(0, 256, (3, 16, 16), dtype=torch.uint8)
        >>> steps = TensorDict({"pixels": frame.repeat(3, 1, 1).expand(8, 9, 16, 16), "action": torch.zeros(8, 2), "next": {
        ...     "pixels": frame.repeat(3, 1, 1).expand(8, 9, 16, 16), "reward": torch.ones(8, 1),
        ...     "done": torch.zeros(8, 1, dtype=torch.bool), "terminated": torch.zeros(8, 1, dtype=torch.bool)}}, batch_size=[8])
        >>> replay.extend(steps)
        >>> update = SampledUpdate(UpdateStep(loss, torch.optim.Adam(loss.parameters()), SoftUpdate(loss, tau=0.01)), replay)
        >>> sorted(key for key in update().keys() if key.startswith("loss_"))
        ['loss_actor', 'loss_critic']
    """

    def __init__(self, update: UpdateStep, replay: DeviceSampler, *, cudagraph: bool | None = None, warmup: int = 2) -> None:
        if update.cudagraph:
            raise ValueError("SampledUpdate captures the sampling and the update as one CUDA graph; give it an UpdateStep built "
                             "with cudagraph=False.")
        device = update.device
        cudagraph = device.type == "cuda" if cudagraph is None else cudagraph
        if cudagraph and device.type != "cuda":
            raise ValueError(f"SampledUpdate: cudagraph=True needs the update on CUDA; it is on {device}.")
        if indexed(replay.generator.device) != indexed(device):
            raise ValueError(f"SampledUpdate: the replay samples on {replay.generator.device}, the update runs on {device}; "
                             "build the replay with the update's device.")
        if cudagraph and not all(group.get("capturable", False) for group in update.optimizer.param_groups):
            raise ValueError("SampledUpdate: a captured update needs a capturable optimizer, e.g. "
                             "torch.optim.Adam(loss.optimizer_groups(lr), capturable=True).")
        seeded = [module.generator(device) for module in update.loss.modules()
                  if isinstance(module, ImageAugmentation) and module.seed is not None]
        self.update, self.replay, self.cudagraph = update, replay, cudagraph
        self._call = CudaGraphCall(self._sample_and_update, warmup=warmup, device=device,
                                   generators=[replay.generator, *seeded], enabled=cudagraph)

    def _sample_and_update(self) -> TensorDictBase:
        return self.update(self.replay.sample())

    def __call__(self) -> TensorDictBase:
        """One update on a fresh sample; its losses and metrics (the graph's tensors once captured)."""
        return self._call()

    @property
    def captured(self) -> bool:
        """Whether the graph is captured (on CUDA, after ``warmup`` calls)."""
        return self._call.captured

"""A training run's replay buffer: memory-mapped in the run folder, optionally sampled from a copy in the device's memory.

:class:`RunReplay` is what ``examples/train.py`` stores transitions in and samples batches from. Its
:meth:`RunReplay.store` turns the collector's batches into n-step transitions (TorchRL's
``MultiStepTransform``), scales their rewards, and saves in the journal the slots they overwrite.
The buffer of record is always ``disk``: a ``LazyMemmapStorage`` in the run folder, which
checkpoints count (:func:`vigen.run.checkpoint.replay_state`) and a :class:`vigen.run.checkpoint.ReplayJournal`
protects, so that ``--resume`` puts it back exactly. With a ``device`` (``--replay-on-device``),
a second buffer of the same capacity, a ``LazyTensorStorage`` in the device's memory, receives
every transition in the same slot (both write round-robin from the same cursor) and serves the
samples: a batch is gathered on the GPU instead of from the memory map and copied over.
On ``--resume``, :meth:`RunReplay.reload` fills it from the restored memory map.

On a CPU, ``device="cpu"`` keeps the copy in RAM and draws the same indices from the same
generator as the memory-mapped buffer, so a run samples exactly the same batches either way (the
test of the mirror). On CUDA the indices are drawn on the GPU, from its own generator (which
checkpoints save too): the batches differ from a memory-mapped run's, reproducibly.

Without a device copy, batches bound for a CUDA device are gathered into pinned host memory and
copied without blocking.
"""

from __future__ import annotations

import math
from pathlib import Path

import torch
from tensordict import TensorDictBase
from torchrl.data import LazyMemmapStorage, LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs.transforms import MultiStepTransform

from vigen.run.checkpoint import ReplayJournal


def to_device(data: TensorDictBase, device: torch.device) -> TensorDictBase:
    """``data`` on ``device``; to CUDA from pinned memory without blocking (the copy is ordered on the current stream)."""
    if device.type == "cuda" and data.device is not None and data.device.type == "cpu":
        if not data.is_locked and not _is_pinned(data):
            data = data.pin_memory()
        return data.to(device, non_blocking=True)
    return data.to(device)


def _is_pinned(data: TensorDictBase) -> bool:
    return all(tensor.is_pinned() for tensor in data.values(include_nested=True, leaves_only=True))


def transition_bytes(observation_shape: tuple[int, ...]) -> int:
    """About how many bytes one stored transition takes: two uint8 observations (``pixels`` and the next), plus 1 KiB.

    Examples:
        >>> transition_bytes((9, 84, 84))
        128032
    """
    return 2 * math.prod(observation_shape) + 1024


def check_device_fits(capacity: int, observation_shape: tuple[int, ...], device: torch.device) -> None:
    """Raise a ``ValueError`` when a device copy of ``capacity`` transitions would not fit in the GPU's free memory."""
    needed = capacity * transition_bytes(observation_shape)
    free, total = torch.cuda.mem_get_info(device)
    if needed > 0.9 * free:
        raise ValueError(f"--replay-on-device: a copy of the replay buffer needs about {needed / 2**30:.1f} GiB, and {device} "
                         f"has {free / 2**30:.1f} of {total / 2**30:.1f} GiB free; lower --buffer-size or drop the flag.")


class RunReplay:
    """The run's memory-mapped replay buffer (``disk``), and optionally its copy in ``device``'s memory for sampling.

    Args:
        capacity: transitions either buffer holds.
        batch_size: transitions per sampled batch.
        storage_dir: the memory map's folder in the run folder.
        device: where sampled batches go (the updates' device).
        on_device: keep the copy in ``device``'s memory and sample from it.
        n_step: turns collector batches into n-step transitions in :meth:`store` (it holds back each
            batch's last steps until the next one).
        reward_scale: factor on the stored rewards (:meth:`store`).
        journal: the folder of the undo journal (:meth:`store` protects the slots it overwrites).

    Examples:
        >>> import tempfile, torch
        >>> from tensordict import TensorDict
        >>> from vigen.run.replay import RunReplay
        >>> data = TensorDict({"pixels": torch.arange(12, dtype=torch.uint8).reshape(6, 2)}, batch_size=[6])
        >>> replays = [RunReplay(4, 3, Path(tempfile.mkdtemp()), torch.device("cpu"), on_device=flag) for flag in (False, True)]
        >>> samples = []
        >>> for replay in replays:
        ...     replay.extend(data)
        ...     _ = torch.manual_seed(0)
        ...     samples.append(replay.sample()["pixels"])
        >>> torch.equal(*samples), replays[1].memory.storage[:]["pixels"].tolist() == replays[1].disk.storage[:]["pixels"].tolist()
        (True, True)
    """

    def __init__(self, capacity: int, batch_size: int, storage_dir: Path, device: torch.device, *, on_device: bool = False,
                 n_step: MultiStepTransform | None = None, reward_scale: float = 1.0, journal: Path | None = None) -> None:
        self.device, self.storage_dir = torch.device(device), Path(storage_dir)
        self.n_step, self.reward_scale = n_step, reward_scale
        self.disk = TensorDictReplayBuffer(storage=LazyMemmapStorage(capacity, scratch_dir=storage_dir), batch_size=batch_size,
                                           pin_memory=self.device.type == "cuda" and not on_device)
        self.memory = (TensorDictReplayBuffer(storage=LazyTensorStorage(capacity, device=self.device), batch_size=batch_size)
                       if on_device else None)
        self.journal = ReplayJournal(journal, self.disk) if journal is not None else None

    def store(self, batch: TensorDictBase) -> None:
        """A collector batch (``[time]`` or ``[workers, time]``) as n-step transitions, rewards scaled, journaled, stored.

        The last ``n`` steps of each trajectory wait in the n-step transform for the next batch,
        unless the batch ends their episode.
        """
        if self.n_step is None:
            raise RuntimeError("RunReplay.store makes n-step transitions: build the replay with n_step=MultiStepTransform(...).")
        transitions = self.n_step.inv(batch)  # with n-step rewards and next pixels
        if transitions is None:
            return
        if self.reward_scale != 1:
            transitions.set(("next", "reward"), transitions["next", "reward"] * self.reward_scale)
        if self.journal is not None:
            self.journal.protect(transitions.numel())
        self.extend(transitions.reshape(-1))

    def extend(self, transitions: TensorDictBase) -> None:
        """Store ``transitions`` (flat ``[N]``) in the memory map and, in the same slots, in the device copy."""
        self.disk.extend(transitions)
        if self.memory is not None:
            self.memory.extend(to_device(transitions, self.device))
            self._check_in_step()

    def sample(self) -> TensorDictBase:
        """One batch on the device: gathered there from the device copy, or from the memory map and copied over."""
        if self.memory is not None:
            return self.memory.sample()
        return to_device(self.disk.sample(), self.device)

    def reload(self, chunk: int = 4096) -> None:
        """Fill the device copy from the memory map, slot for slot, and take its cursor (after ``--resume`` restored it)."""
        if self.memory is None:
            return
        if len(self.memory.storage):
            raise RuntimeError("RunReplay.reload fills a new device copy; this one holds transitions already.")
        length = len(self.disk.storage)
        for start in range(0, length, chunk):
            slots = torch.arange(start, min(start + chunk, length))
            self.memory.storage.set(slots, to_device(self.disk.storage.get(slots), self.device))
        self.memory.writer.load_state_dict(self.disk.writer.state_dict())
        self._check_in_step()

    def _check_in_step(self) -> None:
        disk, memory = self.disk.writer.state_dict(), self.memory.writer.state_dict()
        if (len(self.disk.storage), int(disk["_cursor"])) != (len(self.memory.storage), int(memory["_cursor"])):
            raise RuntimeError(f"RunReplay: the device copy ({len(self.memory.storage)} transitions, next slot "
                               f"{memory['_cursor']}) no longer matches the memory map ({len(self.disk.storage)}, next slot "
                               f"{disk['_cursor']}); this is a bug, please report it.")

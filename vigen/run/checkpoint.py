"""Crash-safe run folders: checkpoints that load without running code, an undo journal for the replay buffer, logs rewound.

A run of ``examples/train.py`` keeps three kinds of state on disk, and this module keeps them
consistent with each other whatever moment the run is killed at:

* **checkpoints** (:func:`save_checkpoint`, :func:`load_checkpoint`, :func:`newest_checkpoint`):
  written atomically (:func:`vigen.io.atomic_write`), holding only tensors, numbers, strings and
  plain containers, and loaded with ``torch.load(weights_only=True)``, so a file from elsewhere
  can never run code. Resuming takes the newest checkpoint that loads and says which were skipped.
* **the replay storage**, a live memory map that keeps changing after a checkpoint. The
  checkpoint records its cursor and length (:func:`replay_state`); a :class:`ReplayJournal` saves
  the old contents of every slot the checkpoint counts as valid before an ``extend`` overwrites it,
  so :meth:`ReplayJournal.rollback` can put the storage back exactly as the checkpoint saw it.
* **CSV logs**, appended row by row: :func:`truncate_csv_logs` drops the rows a killed segment
  wrote after the checkpoint, so the resumed run does not log them a second time.

Random states (:func:`random_states`), seeded augmentation generators (:func:`generator_states`)
and the n-step window of TorchRL's ``MultiStepTransform`` (:func:`multistep_state`) are saved as
plain tensors and lists too.

Examples:
    A run folder as a killed run leaves it: a good checkpoint, a newer one cut short, the temporary
    file of a write that never finished, and a log that went on after the last good checkpoint.
    Resuming takes the newest checkpoint that loads, removes the temporary files and rewinds the
    logs to the checkpoint's step:

    >>> import tempfile
    >>> from pathlib import Path
    >>> from vigen.run.checkpoint import (checkpoint_files, checkpoint_path, newest_checkpoint,
    ...                                   remove_temporary_files, save_checkpoint, truncate_csv_logs)
    >>> run = Path(tempfile.mkdtemp())
    >>> checkpoints, logs = run / "checkpoints", run / "logs"
    >>> checkpoints.mkdir(), logs.mkdir()
    (None, None)
    >>> _ = save_checkpoint(checkpoint_path(checkpoints, 10), {"frames": 10})
    >>> _ = checkpoint_path(checkpoints, 20).write_bytes(b"PK\\x03\\x04 cut short")
    >>> _ = (checkpoints / ".frames_00000030.pt.tmp-7").write_bytes(b"half")
    >>> _ = (logs / "loss.csv").write_text("5,0.5\\n10,0.4\\n20,0.3\\n")
    >>> [path.name for path in checkpoint_files(checkpoints)]  # newest first; temporary files are not checkpoints
    ['frames_00000020.pt', 'frames_00000010.pt']
    >>> path, state, skipped = newest_checkpoint(checkpoints)  # the newest that loads, and why the newer ones did not
    >>> path.name, state["frames"], [(skip.name, "truncated" in why) for skip, why in skipped]
    ('frames_00000010.pt', 10, [('frames_00000020.pt', True)])
    >>> [path.name for path in remove_temporary_files(checkpoints)], sorted(path.name for path in checkpoints.iterdir())
    (['.frames_00000030.pt.tmp-7'], ['frames_00000010.pt', 'frames_00000020.pt'])
    >>> truncate_csv_logs(logs, state["frames"]), (logs / "loss.csv").read_text()
    (['loss.csv: dropped 1 rows logged after step 10'], '5,0.5\\n10,0.4\\n')
"""

from __future__ import annotations

import csv
import io
import json
import pickle
import random
import re
from pathlib import Path
from typing import Any

import numpy as np
import torch
from tensordict import TensorDict, TensorDictBase
from torch import Tensor, nn
from torchrl.data import ReplayBuffer
from torchrl.envs.transforms import MultiStepTransform

from vigen.io import atomic_write, fsync_path
from vigen.transforms import ImageAugmentation

CHECKPOINT_NAME = re.compile(r"^frames_(\d+)\.pt$")
PLAIN_LEAVES = (Tensor, int, float, bool, str, type(None), torch.Size, torch.dtype)


class CheckpointError(ValueError):
    """A checkpoint that cannot be used: unreadable, truncated, or holding objects that could run code."""


def checkpoint_path(folder: str | Path, frames: int) -> Path:
    """Where the checkpoint at ``frames`` environment frames lives in a ``checkpoints`` folder.

    Examples:
        >>> from vigen.run.checkpoint import checkpoint_path
        >>> checkpoint_path("runs/a/checkpoints", 400).name
        'frames_00000400.pt'
    """
    if not isinstance(frames, int) or frames < 0:
        raise ValueError(f"checkpoint_path: frames must be an integer >= 0, got {frames!r}.")
    return Path(folder) / f"frames_{frames:08d}.pt"


def check_plain(state: Any, where: str = "state") -> None:
    """Raise ``TypeError`` naming the entry of ``state`` that ``torch.load(weights_only=True)`` would refuse.

    Allowed: tensors, numbers, strings, booleans, ``None``, ``torch.Size``, dtypes, and dicts
    (string or integer keys), lists and tuples of those.

    Examples:
        >>> import torch
        >>> from vigen.run.checkpoint import check_plain
        >>> check_plain({"steps": 3, "rng": torch.zeros(2), "levels": ["train"]})
        >>> check_plain({"rng": torch.Generator()})
        Traceback (most recent call last):
        ...
        TypeError: state['rng'] is a Generator; a checkpoint holds only tensors, numbers, strings and plain containers (save generator.get_state(), a tensor, instead).
    """
    if isinstance(state, PLAIN_LEAVES):
        return
    if isinstance(state, dict):
        for key, value in state.items():
            if not isinstance(key, (str, int)):
                raise TypeError(f"{where} has a key of type {type(key).__name__}; checkpoint dict keys are strings or integers.")
            check_plain(value, f"{where}[{key!r}]")
        return
    if isinstance(state, (list, tuple)):
        for index, value in enumerate(state):
            check_plain(value, f"{where}[{index}]")
        return
    hint = " (save generator.get_state(), a tensor, instead)" if isinstance(state, torch.Generator) else ""
    raise TypeError(
        f"{where} is a {type(state).__name__}; a checkpoint holds only tensors, numbers, strings and plain containers{hint}."
    )


def save_checkpoint(path: str | Path, state: dict[str, Any]) -> Path:
    """Write ``state`` to ``path`` atomically, after checking it holds only plain data (see :func:`check_plain`).

    Examples:
        >>> import tempfile, torch
        >>> from pathlib import Path
        >>> from vigen.run.checkpoint import load_checkpoint, save_checkpoint
        >>> path = save_checkpoint(Path(tempfile.mkdtemp()) / "frames_00000010.pt", {"frames": 10, "w": torch.ones(2)})
        >>> load_checkpoint(path)["frames"]
        10
    """
    if not isinstance(state, dict):
        raise TypeError(f"save_checkpoint: state must be a dict, got {type(state).__name__}.")
    check_plain(state)
    return atomic_write(path, lambda file: torch.save(state, file))


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    """Load a checkpoint without running code (``weights_only=True``), on the CPU.

    Raises:
        CheckpointError: the file is missing, truncated or corrupt, is not a dict, or holds objects
            other than tensors and plain containers (a pickle that would import or call something).

    Examples:
        >>> import pickle, tempfile
        >>> from pathlib import Path
        >>> from vigen.run.checkpoint import CheckpointError, load_checkpoint
        >>> path = Path(tempfile.mkdtemp()) / "frames_00000010.pt"
        >>> _ = path.write_bytes(pickle.dumps(Path("x"), protocol=2))  # a pickle that would import pathlib
        >>> try:
        ...     load_checkpoint(path)
        ... except CheckpointError as error:
        ...     print(str(error).replace(str(path), "<path>")[:72])
        refused <path>: it holds objects other than tensors and plain containers
    """
    path = Path(path)
    if not path.is_file():
        raise CheckpointError(f"{path} does not exist or is not a file.")
    try:
        state = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as error:
        lines = [line.strip() for line in str(error).splitlines() if line.strip()]
        reason = next((line for line in lines if line.startswith(("Unsupported", "WeightsUnpickler"))), "a non-plain object")
        raise CheckpointError(
            f"refused {path}: it holds objects other than tensors and plain containers, and loading it could "
            f"run code ({reason}). Only load checkpoints written by vigen's save_checkpoint."
        ) from None
    except (RuntimeError, EOFError, OSError, ValueError) as error:
        reason = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise CheckpointError(f"{path} is truncated or corrupt ({reason}).") from None
    if not isinstance(state, dict):
        raise CheckpointError(f"{path} holds a {type(state).__name__}, not a checkpoint dict.")
    return state


def checkpoint_files(folder: str | Path) -> list[Path]:
    """The ``frames_*.pt`` files of ``folder``, newest (most frames) first; temporary files are not listed.

    Example: the module's.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    found = [(int(match.group(1)), path) for path in folder.iterdir() if (match := CHECKPOINT_NAME.match(path.name))]
    return [path for _, path in sorted(found, reverse=True)]


def newest_checkpoint(folder: str | Path) -> tuple[Path, dict[str, Any], list[tuple[Path, str]]]:
    """The newest checkpoint of ``folder`` that loads, its state, and the newer ones skipped with the reason.

    Raises:
        CheckpointError: no checkpoint in ``folder`` loads (the message lists why for each).

    Example: the module's.
    """
    skipped: list[tuple[Path, str]] = []
    for path in checkpoint_files(folder):
        try:
            return path, load_checkpoint(path), skipped
        except CheckpointError as error:
            skipped.append((path, str(error)))
    if not skipped:
        raise CheckpointError(f"{folder} has no checkpoints (frames_*.pt).")
    reasons = "\n".join(f"  {path.name}: {why}" for path, why in skipped)
    raise CheckpointError(f"no checkpoint in {folder} loads:\n{reasons}")


def remove_temporary_files(folder: str | Path) -> list[Path]:
    """Delete the temporary files a killed :func:`vigen.io.atomic_write` left in ``folder``; return them.

    Example: the module's.
    """
    folder = Path(folder)
    if not folder.is_dir():
        return []
    removed = sorted(path for path in folder.iterdir() if path.name.startswith(".") and ".tmp-" in path.name)
    for path in removed:
        path.unlink()
    return removed


# -- random states ---------------------------------------------------------------------------------


def random_states() -> dict[str, Any]:
    """torch's (CPU and, once CUDA is in use, every CUDA device's), NumPy's and Python's global random states (see :func:`set_random_states`).

    Examples:
        >>> import torch
        >>> from vigen.run.checkpoint import random_states, set_random_states
        >>> states = random_states()
        >>> first = torch.rand(3)
        >>> set_random_states(states)
        >>> torch.equal(torch.rand(3), first)
        True
    """
    name, keys, position, has_gauss, cached = np.random.get_state()
    version, internal, gauss = random.getstate()
    cuda = {"cuda": torch.cuda.get_rng_state_all()} if torch.cuda.is_available() and torch.cuda.is_initialized() else {}
    return {
        **cuda,
        "torch": torch.get_rng_state(),
        "numpy": {"name": name, "keys": torch.from_numpy(keys.astype(np.int64)), "position": int(position),
                  "has_gauss": int(has_gauss), "cached_gaussian": float(cached)},
        "python": {"version": version, "internal": torch.tensor(internal, dtype=torch.int64), "gauss": gauss},
    }


def set_random_states(states: dict[str, Any]) -> None:
    """Restore what :func:`random_states` returned."""
    missing = {"torch", "numpy", "python"} - set(states)
    if missing:
        raise KeyError(f"set_random_states: the states lack {sorted(missing)}; pass what random_states() returned.")
    torch.set_rng_state(states["torch"])
    if "cuda" in states and torch.cuda.is_available():  # a GPU run resumes exactly; elsewhere the CUDA states are not needed
        cuda = [state for state in states["cuda"]][: torch.cuda.device_count()]
        for index, state in enumerate(cuda):
            torch.cuda.set_rng_state(state, index)
    numpy = states["numpy"]
    np.random.set_state((numpy["name"], numpy["keys"].numpy().astype(np.uint32), numpy["position"],
                         numpy["has_gauss"], numpy["cached_gaussian"]))
    python = states["python"]
    random.setstate((python["version"], tuple(int(x) for x in python["internal"].tolist()), python["gauss"]))


def generator_states(module: nn.Module) -> dict[str, Tensor]:
    """The generator states of every seeded vigen augmentation in ``module`` (a loss), by module name.

    The CPU generator's state is under the module's name; a generator on another device (a GPU
    run's) is under ``"<name>@<device>"``, e.g. ``"augmentation.0@cuda:0"``.

    Augmentations without a seed draw from torch's global RNG, which :func:`random_states` covers.

    Examples:
        >>> import torch
        >>> from torch import nn
        >>> from vigen.run.checkpoint import generator_states, set_generator_states
        >>> from vigen.transforms import RandomShift
        >>> model = nn.Sequential(RandomShift(seed=0))
        >>> states = generator_states(model)
        >>> first = model[0].augment(torch.zeros(2, 3, 8, 8, dtype=torch.uint8) + torch.arange(8, dtype=torch.uint8))
        >>> set_generator_states(model, states)
        >>> torch.equal(model[0].augment(torch.zeros(2, 3, 8, 8, dtype=torch.uint8) + torch.arange(8, dtype=torch.uint8)), first)
        True
    """
    states = {}
    for name, augmentation in module.named_modules():
        if isinstance(augmentation, ImageAugmentation) and augmentation.seed is not None:
            states[name] = augmentation.generator(torch.device("cpu")).get_state()
            for device in augmentation.generator_devices():
                if device.type != "cpu":  # a GPU run's augmentations draw on the GPU
                    states[f"{name}@{device}"] = augmentation.generator(device).get_state()
    return states


def set_generator_states(module: nn.Module, states: dict[str, Tensor]) -> None:
    """Restore what :func:`generator_states` returned for the same module."""
    augmentations = dict(module.named_modules())
    for key, state in states.items():
        name, _, device = key.partition("@")
        augmentation = augmentations.get(name)
        if not isinstance(augmentation, ImageAugmentation) or augmentation.seed is None:
            raise KeyError(f"set_generator_states: {name!r} is not a seeded augmentation of this module; "
                           "was the checkpoint written for another algorithm?")
        if not device:
            augmentation.generator(torch.device("cpu")).set_state(state)
        elif torch.device(device).type == "cuda" and torch.cuda.is_available() and torch.device(device).index < torch.cuda.device_count():
            augmentation.generator(torch.device(device)).set_state(state)


RUN_FLAGS = ("capturable", "fused", "foreach", "differentiable")
"""An optimizer group's options that belong to the run (its device, and whether its update is compiled or captured as
a CUDA graph), not to the training state: :func:`load_optimizer_state` keeps the current run's."""


def load_optimizer_state(optimizer: torch.optim.Optimizer, state: dict[str, Any]) -> None:
    """Load a saved ``optimizer.state_dict()`` into ``optimizer``, keeping this run's :data:`RUN_FLAGS`.

    ``Optimizer.load_state_dict`` takes every group option from the file, so a run resumed on
    another device or with another ``--compile`` choice would get the flags of the run that saved
    it: a compiled CPU run resumed on CUDA would bring back a non-capturable Adam for a CUDA graph
    (``capturable=False``), an eager CPU run resumed compiled a fused one that ``torch.compile``
    cannot trace. Here the moments and the hyper-parameters (lr, betas, eps, weight decay, ...)
    come from the file and the flags stay the ones ``optimizer`` was built with; each step count
    moves where those flags keep it (on the parameter's device for a capturable or fused Adam, on
    the CPU otherwise).

    Examples:
        >>> import torch
        >>> from vigen.run.checkpoint import load_optimizer_state
        >>> weight = torch.nn.Parameter(torch.ones(2))
        >>> saved = torch.optim.Adam([weight], lr=0.1, fused=True)
        >>> weight.grad = torch.ones(2)
        >>> saved.step()
        >>> resumed = torch.optim.Adam([weight], lr=0.5, fused=False)
        >>> load_optimizer_state(resumed, saved.state_dict())
        >>> resumed.param_groups[0]["lr"], resumed.param_groups[0]["fused"], resumed.state[weight]["step"]
        (0.1, False, tensor(1.))
    """
    flags = [{key: group[key] for key in RUN_FLAGS if key in group} for group in optimizer.param_groups]
    optimizer.load_state_dict(state)
    for group, own in zip(optimizer.param_groups, flags):
        group.update(own)
        on_device = bool(group.get("capturable")) or bool(group.get("fused"))
        for parameter in group["params"]:
            step = optimizer.state.get(parameter, {}).get("step")
            if isinstance(step, Tensor):
                optimizer.state[parameter]["step"] = step.to(device=parameter.device if on_device else "cpu",
                                                             dtype=torch.float32)


# -- tensordicts as plain data ---------------------------------------------------------------------


def tensordict_to_plain(data: TensorDictBase) -> dict[str, Any]:
    """A TensorDict as a dict of lists of keys and tensors, loadable with ``weights_only=True``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from vigen.run.checkpoint import tensordict_from_plain, tensordict_to_plain
        >>> data = TensorDict({"a": torch.ones(2), ("next", "a"): torch.zeros(2)}, batch_size=[2])
        >>> (tensordict_from_plain(tensordict_to_plain(data)) == data).all()
        True
    """
    keys = sorted(data.keys(include_nested=True, leaves_only=True), key=str)
    return {"batch_size": list(data.batch_size),
            "keys": [[key] if isinstance(key, str) else list(key) for key in keys],
            "values": [data.get(key).clone() for key in keys]}


def tensordict_from_plain(plain: dict[str, Any]) -> TensorDict:
    """The TensorDict :func:`tensordict_to_plain` described."""
    out = TensorDict({}, batch_size=plain["batch_size"])
    for key, value in zip(plain["keys"], plain["values"]):
        out.set(tuple(key), value)
    return out


def multistep_state(transform: MultiStepTransform) -> dict[str, Any] | None:
    """The steps a ``MultiStepTransform`` holds back for its n-step window (``None`` before any data).

    TorchRL keeps them in the transform's ``_buffer`` (torchrl 0.14) and emits them with the next
    ``extend``; saving them with a checkpoint keeps those transitions across a resume.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.envs.transforms import MultiStepTransform
        >>> from vigen.run.checkpoint import multistep_state, set_multistep_state
        >>> n_step = MultiStepTransform(2, 0.9)
        >>> steps = TensorDict({"obs": torch.arange(5.0), ("next", "obs"): torch.arange(1.0, 6.0),
        ...     ("next", "reward"): torch.ones(5, 1), ("next", "done"): torch.zeros(5, 1, dtype=torch.bool),
        ...     ("next", "terminated"): torch.zeros(5, 1, dtype=torch.bool),
        ...     ("next", "truncated"): torch.zeros(5, 1, dtype=torch.bool)}, batch_size=[5])
        >>> n_step.inv(steps)["obs"].tolist()
        [0.0, 1.0, 2.0]
        >>> resumed = MultiStepTransform(2, 0.9)
        >>> set_multistep_state(resumed, multistep_state(n_step))
        >>> resumed.inv(steps)["obs"].tolist()  # the two held-back steps come first
        [3.0, 4.0, 0.0, 1.0, 2.0]
    """
    held = transform._buffer
    return None if held is None else tensordict_to_plain(held)


def set_multistep_state(transform: MultiStepTransform, state: dict[str, Any] | None) -> None:
    """Restore what :func:`multistep_state` returned."""
    transform._buffer = None if state is None else tensordict_from_plain(state)


# -- replay buffer ---------------------------------------------------------------------------------


def replay_state(buffer: ReplayBuffer) -> dict[str, int]:
    """The write cursor, write count and length of a round-robin replay buffer, its storage files made durable.

    Stored in a checkpoint, this is the buffer as the checkpoint counts it: slots ``[0, len)``
    are valid, the next write goes to ``cursor``.

    Examples:
        >>> import torch
        >>> from tensordict import TensorDict
        >>> from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
        >>> from vigen.run.checkpoint import replay_state
        >>> buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(4))
        >>> _ = buffer.extend(TensorDict({"x": torch.arange(6)}, batch_size=[6]))
        >>> replay_state(buffer)
        {'cursor': 2, 'write_count': 6, 'len': 4}
    """
    writer = buffer.writer.state_dict()
    scratch = getattr(buffer.storage, "scratch_dir", None)
    if scratch is not None and Path(scratch).is_dir():
        for path in sorted(Path(scratch).rglob("*")):
            if path.is_file():
                fsync_path(path)
    return {"cursor": int(writer["_cursor"]), "write_count": int(writer["_write_count"]), "len": len(buffer.storage)}


def restore_replay(buffer: ReplayBuffer, state: dict[str, int], storage_dir: str | Path) -> None:
    """Open the memory-mapped storage of ``storage_dir`` in ``buffer`` (a new ``LazyMemmapStorage`` buffer) at ``state``.

    ``state`` is what :func:`replay_state` recorded; run :meth:`ReplayJournal.rollback` first so the
    slots hold what they held then.
    """
    missing = {"cursor", "write_count", "len"} - set(state)
    if missing:
        raise KeyError(f"restore_replay: the replay state lacks {sorted(missing)}; pass what replay_state() returned.")
    storage_dir = Path(storage_dir)
    if state["len"] > 0:
        if not (storage_dir / "meta.json").exists():
            raise CheckpointError(f"the checkpoint counts {state['len']} transitions but {storage_dir} holds no "
                                  "replay storage; was the run folder copied without replay_buffer/?")
        metadata = {"metadata": {}, "is_pytree": False, "len": int(state["len"])}
        atomic_write(storage_dir / "storage_metadata.json", json.dumps(metadata))
        buffer.storage.loads(storage_dir)
    buffer.writer.load_state_dict({"_cursor": int(state["cursor"]), "_write_count": int(state["write_count"])})


class ReplayJournal:
    """Undo journal of a replay storage that lives on disk and keeps changing after each checkpoint.

    Before an ``extend`` overwrites slots the last checkpoint counts as valid, :meth:`protect`
    saves their contents (pre-images) to ``folder`` (one atomically written, fsynced file per
    extend). :meth:`rollback` restores them newest first, which puts back the storage the
    checkpoint saw however many extends ran since; :meth:`commit` drops the journal once a newer
    checkpoint is written. Records carry the write count of the checkpoint they protect, so a
    stale journal is never applied to another checkpoint.

    Examples:
        >>> import tempfile, torch
        >>> from pathlib import Path
        >>> from tensordict import TensorDict
        >>> from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
        >>> from vigen.run.checkpoint import ReplayJournal, replay_state
        >>> buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(4))
        >>> journal = ReplayJournal(Path(tempfile.mkdtemp()), buffer)
        >>> _ = buffer.extend(TensorDict({"x": torch.arange(4)}, batch_size=[4]))
        >>> saved = replay_state(buffer)
        >>> journal.commit(saved)  # a checkpoint was written
        >>> journal.protect(3)
        >>> _ = buffer.extend(TensorDict({"x": torch.arange(10, 13)}, batch_size=[3]))  # overwrites slots 0-2
        >>> journal.rollback(saved)
        []
        >>> buffer.storage[:]["x"].tolist()
        [0, 1, 2, 3]
    """

    def __init__(self, folder: str | Path, buffer: ReplayBuffer) -> None:
        self.folder = Path(folder)
        self.buffer = buffer
        self.base: dict[str, int] | None = None
        self.folder.mkdir(parents=True, exist_ok=True)
        records = self.records()
        self.next_record = int(records[-1].stem) + 1 if records else 0

    def records(self) -> list[Path]:
        """The journal's record files, oldest first."""
        return sorted(path for path in self.folder.glob("*.pt") if path.stem.isdigit())

    def commit(self, state: dict[str, int]) -> None:
        """A checkpoint holding replay ``state`` is on disk: forget older pre-images, protect this state from now on."""
        for path in self.records():
            path.unlink()
        fsync_path(self.folder)
        self.base = dict(state)

    def protect(self, count: int) -> None:
        """Save the slots the next ``extend`` of ``count`` transitions will overwrite that the checkpoint counts valid."""
        if not isinstance(count, int) or count < 0:
            raise ValueError(f"ReplayJournal.protect: count must be an integer >= 0, got {count!r}.")
        if self.base is None or self.base["len"] == 0 or count == 0:
            return
        storage = self.buffer.storage
        cursor = int(self.buffer.writer.state_dict()["_cursor"])
        slots = (cursor + torch.arange(count)) % storage.max_size
        slots = slots[slots < self.base["len"]]
        if slots.numel() == 0:
            return
        record = {"base": self.base["write_count"], "slots": slots, "data": tensordict_to_plain(storage.get(slots))}
        atomic_write(self.folder / f"{self.next_record:08d}.pt", lambda file: torch.save(record, file))
        self.next_record += 1

    def rollback(self, state: dict[str, int]) -> list[str]:
        """Restore the pre-images saved since the checkpoint of replay ``state``, newest first; return notes.

        Call after :func:`restore_replay` opened the storage. Records of another checkpoint are left
        alone; a newer checkpoint's are reported (the storage was overwritten after a checkpoint that
        could not be loaded: those slots keep their newer transitions).
        """
        notes = []
        ours = []
        for path in self.records():
            try:
                record = torch.load(path, map_location="cpu", weights_only=True)
            except (pickle.UnpicklingError, RuntimeError, EOFError, OSError) as error:
                notes.append(f"replay journal: skipped unreadable {path.name} ({str(error).splitlines()[0]})")
                continue
            if record["base"] == state["write_count"]:
                ours.append(record)
            elif record["base"] > state["write_count"]:
                notes.append(f"replay journal: {path.name} protects a later checkpoint (write count {record['base']}); "
                             f"{len(record['slots'])} slots overwritten after it keep their newer transitions")
        if ours and not self.buffer.storage.initialized:
            raise CheckpointError("ReplayJournal.rollback: open the storage (restore_replay) before rolling it back.")
        for record in reversed(ours):
            self.buffer.storage.set(record["slots"], tensordict_from_plain(record["data"]), set_cursor=False)
        self.base = dict(state)
        return notes


# -- logs ------------------------------------------------------------------------------------------


def truncate_csv_logs(folder: str | Path, step: int) -> list[str]:
    """Drop the rows logged after ``step`` from every ``step,value`` CSV under ``folder``; return what was dropped.

    TorchRL's ``CSVLogger`` appends one ``step,value`` row per call. A run killed after a
    checkpoint has logged rows the resumed run logs again: rewinding the files to the checkpoint's
    step first keeps each step once. Each file is rewritten atomically, and only if it changes.

    Example: the module's.
    """
    if not isinstance(step, int):
        raise TypeError(f"truncate_csv_logs: step must be an integer, got {type(step).__name__}.")
    folder = Path(folder)
    notes = []
    for path in sorted(folder.rglob("*.csv")) if folder.is_dir() else []:
        text = path.read_text()
        rows = list(csv.reader(io.StringIO(text)))
        kept = [row for row in rows if row and _step_of(row) is not None and _step_of(row) <= step]
        if len(kept) == len(rows):
            continue
        out = io.StringIO()
        csv.writer(out, lineterminator="\n").writerows(kept)
        atomic_write(path, out.getvalue())
        notes.append(f"{path.relative_to(folder)}: dropped {len(rows) - len(kept)} rows logged after step {step}")
    return notes


def _step_of(row: list[str]) -> float | None:
    try:
        return float(row[0])
    except ValueError:
        return None

"""A training run's folder: made once every check has passed, its ``config.json``, and the one process that writes it.

A run folder of ``examples/train.py`` holds ``config.json`` (:meth:`vigen.run.TrainConfig.to_json`),
``checkpoints/``, ``logs/`` and ``replay_buffer/``. One process writes it at a time
(:class:`vigen.io.RunFolderLock`, which the OS drops when that process ends): a second ``--resume``,
or an evaluation writing its report inside the folder, stops at once, naming the holder.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any

from vigen.io import RunFolderLock, atomic_write, unused_path
from vigen.run.config import TrainConfig, resumed_config

CONFIG = "config.json"


def new_run_folder(config: TrainConfig, out: Path | None = None) -> Path:
    """Make the folder of a new run (``out``, default ``runs/<algo>-<task>-s<seed>``; a new name if it exists) and write
    its ``config.json`` (atomically).

    Examples:
        >>> import tempfile
        >>> from vigen.run import TrainConfig
        >>> folder = new_run_folder(TrainConfig(algo="svea"), Path(tempfile.mkdtemp()) / "run")
        >>> sorted(path.name for path in folder.iterdir()), new_run_folder(TrainConfig(), folder).name
        (['config.json'], 'run-1')
    """
    folder = unused_path(out or Path("runs") / f"{config.algo}-{config.env.split('/', 1)[-1]}-s{config.seed}")
    folder.mkdir(parents=True)
    atomic_write(folder / CONFIG, json.dumps(config.to_json(), indent=2))
    return folder


def resumed_run_config(folder: Path, flags: Mapping[str, Any]) -> TrainConfig:
    """The config of the run in ``folder``, which ``flags`` (those typed) may not contradict but for ``frames``.

    Raises:
        ValueError: ``--resume FOLDER: ...``, no ``config.json`` there, or the flags that contradict it.
    """
    if not (folder / CONFIG).is_file():
        raise ValueError(f"--resume {folder}: no config.json there; pass a run folder of examples/train.py.")
    try:
        return resumed_config(json.loads((folder / CONFIG).read_text()), flags)
    except ValueError as error:
        raise ValueError(f"--resume {folder}: {error}") from None


def enclosing_run_folder(path: Path) -> Path | None:
    """The run folder ``path`` lies in (a folder above it holding ``config.json`` and ``checkpoints/`` or a writer lock),
    or ``None``.

    Examples:
        >>> enclosing_run_folder(Path("/nonexistent/reports/evaluation")) is None
        True
    """
    return next((parent for parent in path.absolute().parents if (parent / CONFIG).is_file()
                 and ((parent / "checkpoints").is_dir() or (parent / RunFolderLock.LOCK).exists())), None)

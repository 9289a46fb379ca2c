"""File helpers shared by the example scripts: never overwrite what a user saved, never leave half a file."""

from __future__ import annotations

import os
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO


def unused_path(path: str | Path) -> Path:
    """``path`` if it is free, else ``stem-1.suffix``, ``stem-2.suffix``, ...: the first that does not exist.

    Examples:
        >>> from vigen.io import unused_path
        >>> unused_path("/nonexistent/run.png")
        PosixPath('/nonexistent/run.png')
    """
    path = Path(path)
    candidate, index = path, 0
    while candidate.exists():
        index += 1
        candidate = path.with_name(f"{path.stem}-{index}{path.suffix}")
    return candidate


def temporary_path(path: str | Path) -> Path:
    """The temporary name :func:`atomic_write` uses for ``path``: hidden, in the same folder, per process.

    Examples:
        >>> from vigen.io import temporary_path
        >>> temporary_path("/runs/a/frames_00000400.pt").name.startswith(".frames_00000400.pt.tmp-")
        True
    """
    path = Path(path)
    return path.with_name(f".{path.name}.tmp-{os.getpid()}")


def fsync_path(path: str | Path) -> None:
    """Make a file's data, or a folder's entries (new, renamed or removed files), durable.

    Examples:
        >>> import tempfile
        >>> from vigen.io import fsync_path
        >>> fsync_path(tempfile.gettempdir())
    """
    descriptor = os.open(path, os.O_RDONLY)
    try:
        os.fsync(descriptor)
    finally:
        os.close(descriptor)


def atomic_write(path: str | Path, write: bytes | str | Callable[[BinaryIO], object]) -> Path:
    """Write ``path`` all at once: readers (and a run killed at any moment) see the old file or the new one.

    The data goes to a temporary file in the same folder, is flushed and fsynced, replaces
    ``path`` with ``os.replace`` and the folder is fsynced. A failed write removes the temporary
    file and leaves ``path`` as it was.

    Args:
        path: the file to write; its folder must exist.
        write: the bytes or text to write, or a function that writes into the open binary file
            (e.g. ``lambda f: torch.save(state, f)``).

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.io import atomic_write
        >>> folder = Path(tempfile.mkdtemp())
        >>> atomic_write(folder / "config.json", '{"seed": 0}').read_text()
        '{"seed": 0}'
        >>> sorted(p.name for p in folder.iterdir())  # no temporary file left behind
        ['config.json']
    """
    path = Path(path)
    if not path.parent.is_dir():
        raise FileNotFoundError(f"atomic_write: the folder of {path} does not exist; create it first.")
    if not (isinstance(write, (bytes, str)) or callable(write)):
        raise TypeError(f"atomic_write: write must be bytes, str or a function of a binary file, got {type(write).__name__}.")
    temporary = temporary_path(path)
    try:
        with open(temporary, "wb") as file:
            if isinstance(write, str):
                file.write(write.encode())
            elif isinstance(write, bytes):
                file.write(write)
            else:
                write(file)
            file.flush()
            os.fsync(file.fileno())
        os.replace(temporary, path)
    except BaseException:
        temporary.unlink(missing_ok=True)
        raise
    fsync_path(path.parent)
    return path

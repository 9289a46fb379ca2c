"""File helpers shared by the example scripts: never overwrite what a user saved, never leave half a file,
never let two processes write one run folder."""

from __future__ import annotations

import datetime
import fcntl
import json
import os
import socket
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
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


class FolderInUse(RuntimeError):
    """Another live process holds the run folder (:class:`RunFolderLock`); the message names it."""


class RunFolderLock:
    """One writer per run folder: an exclusive ``fcntl.flock`` on ``<folder>/.writer.lock``, held while writing.

    :meth:`acquire` takes the lock at once or raises :class:`FolderInUse` naming the holder's
    process (pid, host, start time, from ``.writer.json``, which the holder writes atomically when it
    takes the lock). The operating system drops a ``flock`` when its process ends, however it ends:
    a lock left by a killed run does not block the next one. (``flock`` locks are advisory, and on
    some network file systems local to one host: two hosts writing one NFS folder are not seen.)

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> folder = Path(tempfile.mkdtemp())
        >>> with RunFolderLock(folder) as lock:
        ...     RunFolderLock(folder).acquire()  # a second writer, even in the same process
        Traceback (most recent call last):
        ...
        vigen.io.FolderInUse: ... is in use by process ...
        >>> RunFolderLock(folder).acquire().release()  # free again once released
    """

    LOCK = ".writer.lock"
    HOLDER = ".writer.json"

    def __init__(self, folder: str | Path) -> None:
        self.folder = Path(folder)
        self._descriptor: int | None = None

    def acquire(self) -> RunFolderLock:
        """Take the lock now, or raise :class:`FolderInUse` naming its holder; returns ``self``."""
        if not self.folder.is_dir():
            raise FileNotFoundError(f"RunFolderLock: {self.folder} is no folder.")
        descriptor = os.open(self.folder / self.LOCK, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(descriptor, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(descriptor)
            raise FolderInUse(f"{self.folder} is in use by {self.holder_text()}: one process writes a run folder at a "
                              "time (its checkpoints, replay buffer and logs). Wait for it to end, or stop it.") from None
        self._descriptor = descriptor
        started = datetime.datetime.now().astimezone().isoformat(timespec="seconds")
        atomic_write(self.folder / self.HOLDER, json.dumps({"pid": os.getpid(), "host": socket.gethostname(),
                                                            "started": started}))
        return self

    def holder(self) -> dict[str, object] | None:
        """The holder's ``{"pid", "host", "started"}`` as it recorded them; ``None`` if none is recorded."""
        try:
            return json.loads((self.folder / self.HOLDER).read_text())
        except (FileNotFoundError, ValueError):
            return None

    def holder_text(self) -> str:
        """``process <pid> on <host>, started <time>``, or what is known of a holder that has not recorded itself yet."""
        holder = self.holder()
        if holder is None:
            return "another process (it has not recorded its pid yet)"
        return f"process {holder.get('pid')} on {holder.get('host')}, started {holder.get('started')}"

    def release(self) -> None:
        """Drop the lock (also dropped by the OS when the process ends)."""
        if self._descriptor is None:
            return
        (self.folder / self.HOLDER).unlink(missing_ok=True)
        fcntl.flock(self._descriptor, fcntl.LOCK_UN)
        os.close(self._descriptor)
        self._descriptor = None

    def __enter__(self) -> RunFolderLock:
        return self.acquire() if self._descriptor is None else self

    def __exit__(self, kind: type[BaseException] | None, error: BaseException | None, trace: TracebackType | None) -> None:
        self.release()

"""A failure written to a report file: how a ``ParallelEnv`` worker tells its parent what killed it.

A worker of ``torchrl.envs.ParallelEnv`` that raises dies, and its exception stays in its own
stderr. vigen's :class:`~vigen.envs.pixels.PixelEnv` runs its steps, resets and seeds under
:func:`failures_recorded`, and :class:`~vigen.envs.parallel.ParallelEnv` reads the file back and
raises a :class:`~vigen.envs.parallel.WorkerError` quoting it.
"""

from __future__ import annotations

import traceback
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from vigen.io import atomic_write


def record_failure(report: str | Path | None) -> None:
    """Inside an ``except`` block: write the traceback being handled to ``report`` (``None``: do nothing).

    The file is replaced atomically, so a reader sees a whole traceback or none. A report that
    cannot be written is given up: the exception being handled matters more. Re-raise after it.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> report = Path(tempfile.mkdtemp()) / "worker-0.txt"
        >>> try:
        ...     raise ValueError("boom")
        ... except ValueError:
        ...     record_failure(report)
        >>> report.read_text().splitlines()[-1]
        'ValueError: boom'
    """
    if report is not None:
        with suppress(OSError):
            atomic_write(report, traceback.format_exc())


@contextmanager
def failures_recorded(report: str | Path | None) -> Iterator[None]:
    """Run the block; if it raises, :func:`record_failure` to ``report`` and let the exception propagate unchanged.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> report = Path(tempfile.mkdtemp()) / "worker-0.txt"
        >>> try:
        ...     with failures_recorded(report):
        ...         raise KeyError("pixels")
        ... except KeyError:
        ...     pass
        >>> report.read_text().splitlines()[-1]
        "KeyError: 'pixels'"
    """
    try:
        yield
    except Exception:
        record_failure(report)
        raise

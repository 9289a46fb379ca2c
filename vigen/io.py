"""File helpers shared by the example scripts: never overwrite what a user saved."""

from __future__ import annotations

from pathlib import Path


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

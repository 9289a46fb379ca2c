"""Progress of a fetch, reported as events to an optional callback (the library itself never prints)."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

STAGES = ("present", "download", "resume", "restart", "done", "failed", "extract", "record")
"""What a :class:`Progress` event says about its file.

* ``present``: already in the cache and checked; not downloaded again.
* ``download`` / ``resume``: bytes are arriving (``resume``: continuing a ``.part`` file from ``done`` bytes).
* ``restart``: the server ignored the Range request (or the ``.part`` was unusable); starting over.
* ``done``: downloaded, checked and moved into place.
* ``failed``: this file could not be fetched (``message`` says why); the fetch goes on with the others.
* ``extract`` / ``record``: an archive is being extracted / its files' checksums are being recorded.
"""


@dataclass(frozen=True)
class Progress:
    """One progress event of a fetch.

    Attributes:
        dataset: the data set's name.
        file: the file's path relative to the data set folder (or the archive's name).
        stage: one of :data:`STAGES`.
        index: this file's number (1-based) among the ``count`` files of the fetch.
        count: how many files the fetch handles.
        done: bytes written so far (for ``download``/``resume``), else the file's size where known.
        total: the file's size in bytes where known.
        message: a short explanation (for ``failed``, ``restart``).

    Examples:
        >>> from vigen.data.progress import Progress
        >>> event = Progress("dmcgb-videos", "video_hard/video0.mp4", "download", 1, 100, done=512, total=1024)
        >>> f"{event.index}/{event.count} {event.file} {event.done * 100 // event.total}%"
        '1/100 video_hard/video0.mp4 50%'
    """

    dataset: str
    file: str
    stage: str
    index: int
    count: int
    done: int = 0
    total: int | None = None
    message: str = ""

    def __post_init__(self) -> None:
        if self.stage not in STAGES:
            raise ValueError(f"Progress stage {self.stage!r} is not one of {', '.join(STAGES)}.")


ProgressCallback = Callable[[Progress], None]
"""The type of the ``progress=`` argument of :func:`vigen.data.fetch`."""

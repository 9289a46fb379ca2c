"""One file's transfer into ``<target>.part``: resumed with an HTTP ``Range`` request, moved into place only when checked.

:func:`download_part` brings the whole of an address into the ``.part`` file beside the target
(continuing a ``.part`` left by an interrupted run, starting over when the server ignores the
Range request), and :func:`install` moves a checked ``.part`` over the target with ``os.replace``.
A finished file's name therefore only ever holds a complete, checked file.
"""

from __future__ import annotations

import http.client
import os
import re
import urllib.error
import urllib.parse
import urllib.request
from collections.abc import Callable
from pathlib import Path
from typing import BinaryIO

from vigen import __version__
from vigen.data.checksums import CHUNK
from vigen.data.errors import CorruptFileError, DownloadError, IncompleteDownloadError, MissingFileError, SourceUnreachableError
from vigen.io import fsync_path

Report = Callable[[str, int, "int | None", str], None]
"""``report(stage, done_bytes, total_bytes, message)``; stages as in :data:`vigen.data.progress.STAGES`."""

TIMEOUT_S = 30.0
"""Seconds a connection may stay silent before the transfer counts as failed."""

_CONTENT_RANGE = re.compile(r"bytes (\d+)-(\d+)/(\d+|\*)")


def part_path(target: str | os.PathLike) -> Path:
    """The ``.part`` file beside ``target`` that a transfer writes into.

    Examples:
        >>> from vigen.data.transfer import part_path
        >>> part_path("/cache/dmcgb-videos/video_hard/video0.mp4").name
        'video0.mp4.part'
    """
    target = Path(target)
    return target.with_name(target.name + ".part")


def download_part(
    url: str,
    target: str | os.PathLike,
    *,
    expected_size: int | None = None,
    label: str | None = None,
    fix: str = "re-run the fetch",
    report: Report | None = None,
    timeout: float = TIMEOUT_S,
) -> Path:
    """Bring the whole content at ``url`` (http, https or file) into ``target``'s ``.part`` file and return that file.

    An existing ``.part`` is continued with a ``Range: bytes=<its size>-`` request; a server that
    answers with the whole file (200) or a wrong range restarts it cleanly. The content is not
    checked against any id here, only its length: a server announcing another size than
    ``expected_size``, or sending more, raises :class:`~vigen.data.errors.CorruptFileError` and
    removes the ``.part``. A connection that ends early raises
    :class:`~vigen.data.errors.IncompleteDownloadError` and keeps the ``.part`` to resume from.

    Args:
        url: where to read.
        target: the file the content is meant for (its folder must exist); it is not written.
        expected_size: the size the content must have, where known.
        label: how errors name the file (default: ``target``).
        fix: the command that retries, quoted in errors.
        report: called as ``report(stage, done, total, message)`` while bytes arrive.
        timeout: seconds a silent connection is waited for.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data.transfer import download_part, install
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "source.bin").write_bytes(b"0123456789")
        >>> _ = (folder / "copy.bin.part").write_bytes(b"0123")  # left by an interrupted run
        >>> part = download_part((folder / "source.bin").as_uri(), folder / "copy.bin", expected_size=10)
        >>> install(part, folder / "copy.bin").read_bytes()
        b'0123456789'
    """
    target = Path(target)
    label = label or str(target)
    part = part_path(target)
    report = report or (lambda stage, done, total, message: None)
    offset = part.stat().st_size if part.exists() else 0
    if expected_size is not None and offset > expected_size:
        part.unlink()
        report("restart", 0, expected_size, f"{part.name} was longer than the file; starting over")
        offset = 0
    if expected_size is not None and offset == expected_size and offset > 0:
        return part
    stream, start, total = _open(url, offset, target, label, fix, timeout)
    try:
        if offset and start != offset:
            report("restart", 0, total, f"the server ignored the request to resume at byte {offset}; starting over")
        if expected_size is not None and total is not None and total != expected_size:
            part.unlink(missing_ok=True)
            raise CorruptFileError(
                f"{label}: {url} serves {total} bytes, expected {expected_size}. Nothing was kept. Fix: the source or "
                f"mirror holds another file under this name; check it, then {fix}; or copy the right file to {target}.",
                path=target, expected=f"{expected_size} bytes", got=f"{total} bytes",
            )
        limit = expected_size if expected_size is not None else total
        done = _stream_into(stream, part, start, limit, total, url, target, label, fix, report)
    finally:
        stream.close()
    if total is not None and done < total:
        raise IncompleteDownloadError(
            f"the download of {label} from {url} stopped at {done} of {total} bytes; they are kept in {part}. "
            f"Fix: {fix} to resume.",
            url=url, target=target,
        )
    return part


def install(part: str | os.PathLike, target: str | os.PathLike) -> Path:
    """Move a checked ``.part`` file over ``target`` in one step (``os.replace``) and make it durable.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data.transfer import install
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "a.bin.part").write_bytes(b"a")
        >>> install(folder / "a.bin.part", folder / "a.bin").name, sorted(p.name for p in folder.iterdir())
        ('a.bin', ['a.bin'])
    """
    target = Path(target)
    os.replace(part, target)
    fsync_path(target.parent)
    return target


def _stream_into(stream: BinaryIO, part: Path, start: int, limit: int | None, total: int | None, url: str, target: Path,
                 label: str, fix: str, report: Report) -> int:
    """Append (or, from byte 0, write) the stream into ``part``; return how many bytes ``part`` holds."""
    done = start
    stage = "resume" if start else "download"
    with open(part, "ab" if start else "wb") as file:
        report(stage, done, total, f"resuming at byte {start}" if start else "")
        while True:
            try:
                chunk = stream.read(CHUNK)
            except (OSError, http.client.HTTPException) as error:
                file.flush()
                os.fsync(file.fileno())
                raise IncompleteDownloadError(
                    f"the download of {label} from {url} broke off at {done}"
                    f"{f' of {total}' if total is not None else ''} bytes ({type(error).__name__}: {error}); they are kept "
                    f"in {part}. Fix: {fix} to resume.",
                    url=url, target=target,
                ) from error
            if not chunk:
                break
            if limit is not None and done + len(chunk) > limit:
                file.close()
                part.unlink(missing_ok=True)
                raise CorruptFileError(
                    f"{label}: {url} sent more than the {limit} bytes expected. Nothing was kept. Fix: check the source or "
                    f"mirror, then {fix}; or copy the right file to {target}.",
                    path=target, expected=f"{limit} bytes", got=f"more than {limit} bytes",
                )
            file.write(chunk)
            done += len(chunk)
            report(stage, done, total, "")
        file.flush()
        os.fsync(file.fileno())
    return done


def _open(url: str, offset: int, target: Path, label: str, fix: str, timeout: float) -> tuple[BinaryIO, int, int | None]:
    """Open ``url`` from byte ``offset`` where the source allows it: (stream, the byte it starts at, total size or None)."""
    scheme = urllib.parse.urlsplit(url).scheme.lower()
    if scheme == "file":
        path = Path(urllib.request.url2pathname(urllib.parse.urlsplit(url).path))
        if not path.is_file():
            raise MissingFileError(
                f"{label} is not in the mirror: {path} does not exist. Fix: put the file there (a mirror holds "
                f"<mirror>/<data set>/<file>, see docs/data.md), then {fix}; or copy the file to {target}.",
                url=url, target=target,
            )
        stream = open(path, "rb")
        total = os.fstat(stream.fileno()).st_size
        start = offset if offset <= total else 0
        stream.seek(start)
        return stream, start, total
    if scheme not in ("http", "https"):
        raise DownloadError(f"{label}: cannot read {url}: only http(s) and file URLs are supported.", url=url, target=target)
    response = _request(url, offset, target, label, fix, timeout)
    if response.status == 206:
        match = _CONTENT_RANGE.fullmatch(response.headers.get("Content-Range", "").strip())
        if match and int(match.group(1)) == offset:
            return response, offset, None if match.group(3) == "*" else int(match.group(3))
        response.close()
        response = _request(url, 0, target, label, fix, timeout)
    length = response.headers.get("Content-Length")
    return response, 0, int(length) if length and length.isdigit() else None


def _request(url: str, offset: int, target: Path, label: str, fix: str, timeout: float) -> http.client.HTTPResponse:
    """GET ``url`` (with a Range header from a non-zero ``offset``), turning failures into vigen.data errors."""
    headers = {"User-Agent": f"vigen-data/{__version__}", "Accept-Encoding": "identity"}
    if offset:
        headers["Range"] = f"bytes={offset}-"
    try:
        return urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=timeout)
    except urllib.error.HTTPError as error:
        error.close()
        if error.code == 416 and offset:
            return _request(url, 0, target, label, fix, timeout)
        if error.code in (404, 410):
            raise MissingFileError(
                f"{label} is not at {url} (HTTP {error.code}). Fix: check the source or mirror (a mirror holds "
                f"<mirror>/<data set>/<file>, see docs/data.md), then {fix}; or copy the file to {target}.",
                url=url, target=target,
            ) from None
        raise DownloadError(
            f"{label}: {url} answered HTTP {error.code} {error.reason}. Fix: check the source or mirror, then {fix}; "
            f"or copy the file to {target}.",
            url=url, target=target,
        ) from None
    except (urllib.error.URLError, OSError, http.client.HTTPException) as error:
        reason = getattr(error, "reason", error)
        raise SourceUnreachableError(
            f"cannot reach {url} to fetch {label} ({type(reason).__name__}: {reason}). Fix: check the network, or use a "
            f"mirror (--mirror / $VIGEN_DATA_MIRROR, see docs/data.md), then {fix}; or copy the file to {target}.",
            url=url, target=target,
        ) from None

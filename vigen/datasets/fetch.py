"""Fetching a named data set into the cache: one fetch of a data set at a time, every file checked before it takes its name.

The transfer is pooch's (:func:`pooch.retrieve`: a temporary file beside the target, its sha256
checked, then moved into place; :class:`pooch.Unzip` for archives). vigen adds what pooch lacks:

* a download that stopped resumes from its ``<file>.part`` with an HTTP ``Range`` request
  (:class:`ResumingDownloader`, pooch's downloader interface), and a ``file://`` or folder mirror;
* files pinned by their git blob id (DMC-GB's videos), checked before pooch moves them into place;
* a lock per data set (:mod:`filelock`): a second fetch of the same data set waits for the first,
  and says which process it waits for;
* a file already in the cache that is not the pinned one is reported and left as it is (pooch
  would download it again over it), and every failure ends in one :class:`~vigen.datasets.DataError`
  naming the fix.

Mirror layout (an http(s) URL, a ``file://`` URL or a local folder): ``<mirror>/<data set>/<file's
path in the data set>``, e.g. ``<mirror>/dmcgb-videos/video_hard/video0.mp4``, and
``<mirror>/<data set>/<archive>`` for an archive: a mirror is laid out like the cache, with
archives in place of their extracted folders.
"""

from __future__ import annotations

import contextlib
import errno
import http.client
import importlib
import logging
import os
import re
import shlex
import shutil
import socket
import time
import urllib.error
import urllib.parse
import urllib.request
import zipfile
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType
from typing import BinaryIO

from vigen import __version__
from vigen.datasets.records import DataError, DataSet, PinnedFile, dataset_folder, get_dataset
from vigen.datasets.verify import (CHUNK, MANIFEST_NAME, archive_origin, layout_missing, manifest_size_mismatches,
                                   pinned_mismatch, read_manifest, record_manifest, sha256_file)
from vigen.io import atomic_write, fsync_path

STAGES = ("wait", "present", "download", "resume", "restart", "done", "failed", "extract", "record")
"""What a :class:`Progress` event says about its file.

* ``wait``: another process is fetching this data set (``message`` names it); this one waits for it.
* ``present``: already in the cache and checked; not downloaded again.
* ``download`` / ``resume``: bytes are arriving (``resume``: continuing a ``.part`` file from ``done`` bytes).
* ``restart``: the server ignored the Range request, or a resumed file failed its check; starting over.
* ``done``: downloaded, checked and moved into place.
* ``failed``: this file could not be fetched (``message`` says why); the fetch goes on with the others.
* ``extract`` / ``record``: an archive is being extracted / its files' checksums are being recorded.
"""

TIMEOUT_S = 30.0
"""Seconds a connection may stay silent before the transfer counts as failed."""

LOCK_NAME = ".fetch.lock"
"""The lock file in a data set's folder; ``.fetch.holder`` beside it names the process holding it."""

_CONTENT_RANGE = re.compile(r"bytes (\d+)-(\d+)/(\d+|\*)")


@dataclass(frozen=True)
class Progress:
    """One progress event of a fetch (the library never prints; the command does).

    Attributes:
        dataset: the data set's name.
        file: the file's path relative to the data set folder (or the archive's name; '' for ``wait``).
        stage: one of :data:`STAGES`.
        index: this file's number (1-based) among the ``count`` files of the fetch (0 for ``wait``).
        count: how many files the fetch handles.
        done: bytes written so far (for ``download``/``resume``), else the file's size where known.
        total: the file's size in bytes where known.
        message: a short explanation (for ``wait``, ``failed``, ``restart``, ``done``).

    Examples:
        >>> from vigen.datasets import Progress
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
"""The type of the ``progress=`` argument of :func:`fetch`."""

Report = Callable[..., None]
"""``report(stage, done=0, total=None, message="")``: one file's :class:`Progress` events."""


class DownloadError(DataError, ConnectionError):
    """A transfer failed on the way; ``reason`` says how.

    * ``"unreachable"``: the source or mirror cannot be reached at all (offline, refused): the fetch stops.
    * ``"missing"``: the source or mirror does not have the file (HTTP 404, or absent from a mirror folder).
    * ``"incomplete"``: the connection ended before the whole file came; its ``.part`` is kept for the next fetch.
    * ``"refused"``: another HTTP error, or an address vigen cannot read.

    Examples:
        >>> from vigen.datasets import DownloadError
        >>> error = DownloadError("cut", url="http://host/a", target="/tmp/a", reason="incomplete")
        >>> error.url, error.reason, isinstance(error, ConnectionError)
        ('http://host/a', 'incomplete', True)
    """

    REASONS = ("unreachable", "missing", "incomplete", "refused")

    def __init__(self, message: str, *, url: str, target: object, reason: str) -> None:
        if reason not in self.REASONS:
            raise ValueError(f"DownloadError reason must be one of {self.REASONS}, got {reason!r}.")
        super().__init__(message)
        self.url = url
        self.target = target
        self.reason = reason


class CorruptFileError(DataError, ValueError):
    """A file or archive is not the pinned one (size, git blob id, sha256, or an archive's layout); nothing took its place.

    Attributes:
        path: the file (downloaded, or already in the cache).
        expected: what the record pins, e.g. ``"git blob 395d... (1164499 bytes)"``.
        got: what the file holds.

    Examples:
        >>> from vigen.datasets import CorruptFileError
        >>> CorruptFileError("bad", path="/c/a", expected="sha256 00", got="sha256 11").got
        'sha256 11'
    """

    def __init__(self, message: str, *, path: object, expected: str, got: str) -> None:
        super().__init__(message)
        self.path = path
        self.expected = expected
        self.got = got


class FetchError(DataError):
    """Some files of a fetch failed (each listed, with its own error in ``failures``); the files that passed were kept.

    Examples:
        >>> from vigen.datasets import DownloadError, FetchError
        >>> missing = DownloadError("a.mp4 is not at http://m/a.mp4", url="http://m/a.mp4", target="/c/a.mp4", reason="missing")
        >>> len(FetchError("1 file failed", [missing]).failures)
        1
    """

    def __init__(self, message: str, failures: Sequence[DataError]) -> None:
        super().__init__(message)
        self.failures = list(failures)


def fetch(
    name: str | DataSet,
    part: str | None = None,
    root: str | os.PathLike | None = None,
    mirror: str | os.PathLike | None = None,
    progress: ProgressCallback | None = None,
    wait: float | None = None,
) -> Path:
    """Fetch a data set (or one part of it) into the cache and return its folder (the part's folder for a part).

    Pinned files already present and matching their pin are kept; the others are downloaded
    into ``<file>.part`` (resuming one left by an interrupted run), checked against their size and
    git blob id or sha256, then moved into place. A resumed file that fails its check is
    downloaded once more from its first byte before it counts as corrupt. A file that fails does
    not stop the others: at the end, :class:`FetchError` lists every failure (the checked files
    stay). An unreachable source raises :class:`DownloadError` (``reason="unreachable"``) at once.

    An archive data set (``davis2017``) is downloaded the same way, checked against its pinned
    size and sha256, extracted into a temporary folder, checked against its layout, and moved
    into place with a manifest of its files' sizes and sha256 (the archive is removed again if
    this call downloaded it).

    Only one fetch of a data set runs at a time (a lock file in its folder): another waits for it
    (``wait`` seconds; None: as long as it takes), and its ``wait`` event names the holder.

    Args:
        name: a data set name (see :data:`vigen.datasets.DATASETS`) or a :class:`~vigen.datasets.DataSet`.
        part: one part (e.g. ``"video_hard"``); None fetches all.
        root: the cache folder (default :func:`vigen.datasets.cache_root`).
        mirror: an http(s) URL, ``file://`` URL or folder laid out as ``<mirror>/<name>/<file>``
            (default ``$VIGEN_DATA_MIRROR``, else the original sources).
        progress: called with a :class:`Progress` event as the fetch goes.
        wait: seconds to wait for another fetch of this data set; None waits until it ends.

    Raises:
        DataError: any failure (its subclasses say which), with a message that ends with the fix.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets import DataSet, PinnedFile, fetch, git_blob_id, locate
        >>> mirror, root = Path(tempfile.mkdtemp()), Path(tempfile.mkdtemp())
        >>> (mirror / "toy/clips").mkdir(parents=True)
        >>> _ = (mirror / "toy/clips/a.bin").write_bytes(b"frames")
        >>> toy = DataSet("toy", "one clip", license="CC0", source="made here", url_template="https://example.org/{path}",
        ...               files=(PinnedFile("clips/a.bin", git_blob_id(mirror / "toy/clips/a.bin"), 6),))
        >>> fetch(toy, root=root, mirror=mirror) == root / "toy"
        True
        >>> (root / "toy/clips/a.bin").read_bytes(), locate(toy, "clips", root=root) == root / "toy/clips"
        (b'frames', True)
    """
    dataset = get_dataset(name)
    dataset.check_part(part)
    if wait is not None and not wait >= 0:
        raise DataError(f"wait is seconds to wait for another fetch of {dataset.name} (>= 0, or None: until it ends), got {wait!r}.")
    resolved = resolve_mirror(mirror)
    folder = dataset_folder(dataset, root)
    command = fetch_command(dataset.name, part, mirror, root)
    emit = progress or (lambda event: None)
    try:
        with _fetch_lock(dataset, folder, emit, wait, command):
            if dataset.archive is not None:
                return _fetch_archive(dataset, folder, resolved, emit, command)
            return _fetch_pinned(dataset, part, folder, resolved, emit, command)
    except DataError:
        raise
    except OSError as error:  # the cache folder cannot be made or written (permissions, a file in the way, a full disk)
        raise DataError(_cache_error(dataset, folder, error, command)) from None


def fetch_command(name: str, part: str | None = None, mirror: str | os.PathLike | None = None,
                  root: str | os.PathLike | None = None) -> str:
    """The command line that fetches ``name`` (and ``part``), as errors and warnings quote it.

    Examples:
        >>> from vigen.datasets import fetch_command
        >>> fetch_command("dmcgb-videos", "video_hard")
        'python -m vigen.datasets fetch dmcgb-videos --part video_hard'
    """
    words = ["python", "-m", "vigen.datasets", "fetch", name]
    if part is not None:
        words += ["--part", part]
    if mirror is not None:
        words += ["--mirror", os.fspath(mirror)]
    if root is not None:
        words += ["--root", os.fspath(root)]
    return shlex.join(words)


def resolve_mirror(mirror: str | os.PathLike | None = None) -> str | None:
    """The mirror to read from: ``mirror`` if given, else ``$VIGEN_DATA_MIRROR``, else None (the original sources).

    An http(s) URL is returned without its trailing '/'; a local folder or ``file://`` URL is
    returned as an absolute ``file://`` URL and must exist. Anything else raises
    :class:`~vigen.datasets.DataError` before any work starts.

    Examples:
        >>> import tempfile
        >>> from vigen.datasets.fetch import resolve_mirror
        >>> resolve_mirror("http://127.0.0.1:8000/vigen/")
        'http://127.0.0.1:8000/vigen'
        >>> resolve_mirror(tempfile.gettempdir()).startswith("file:///")
        True
    """
    origin = "the mirror argument"
    if mirror is None:
        mirror = os.environ.get("VIGEN_DATA_MIRROR") or None
        origin = "$VIGEN_DATA_MIRROR"
        if mirror is None:
            return None
    text = os.fspath(mirror)
    scheme = urllib.parse.urlsplit(text).scheme.lower() if "://" in text else ""
    if scheme in ("http", "https"):
        return text.rstrip("/")
    if scheme == "file":
        folder = Path(urllib.request.url2pathname(urllib.parse.urlsplit(text).path))
    elif scheme:
        raise DataError(f"mirror {text!r} ({origin}): use an http(s):// URL, a file:// URL or a local folder, not {scheme}://.")
    else:
        folder = Path(text).expanduser()
    if not folder.is_dir():
        raise DataError(f"mirror folder {folder} ({origin}) does not exist or is not a folder. Fix: give the folder that "
                        "holds <mirror>/<data set>/<file> (see docs/data.md), or an http(s):// URL.")
    return folder.resolve().as_uri()


def source_url(dataset: DataSet, relative: str, mirror: str | None, original: str) -> str:
    """The address to read one file of ``dataset`` from: under the mirror if there is one, else ``original``.

    Examples:
        >>> from vigen.datasets import get_dataset
        >>> from vigen.datasets.fetch import source_url
        >>> source_url(get_dataset("dmcgb-videos"), "video_hard/video0.mp4", "http://127.0.0.1:8000", "unused")
        'http://127.0.0.1:8000/dmcgb-videos/video_hard/video0.mp4'
    """
    if mirror is None:
        return original
    return f"{mirror}/{urllib.parse.quote(dataset.name)}/{urllib.parse.quote(relative)}"


class ResumingDownloader:
    """A pooch downloader that continues ``<target>.part`` with an HTTP ``Range`` request, and reads ``file://`` mirrors.

    Called by :func:`pooch.retrieve` as ``downloader(url, output_file, pooch)``: it brings the
    whole content into the ``.part`` beside ``target`` (continuing what an interrupted run left;
    starting over when the server ignores the Range request), checks its length against ``size``
    and, where given, runs ``check`` (the git blob id: pooch only knows hashlib's hashes), and then
    moves it to pooch's ``output_file``, which pooch checks against a sha256 pin and moves into
    place. A connection that ends early raises :class:`DownloadError` (``reason="incomplete"``)
    and keeps the ``.part``; a wrong length or check raises :class:`CorruptFileError` and removes it.

    Args:
        target: the file the content is meant for (its folder must exist).
        size: the size the content must have, where known.
        check: ``check(path)`` is None when the file holds the pinned content, else what it holds.
        expected: how errors name the pinned content (default: the size).
        label: how errors name the file.
        fix: the command that retries, quoted in errors.
        report: called as ``report(stage, done, total, message)`` while bytes arrive.
        resume: False starts from byte 0 even where a ``.part`` exists.

    Attributes:
        resumed_at: the byte the transfer continued from (0: it started at the first byte).

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets.fetch import ResumingDownloader
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "source.bin").write_bytes(b"0123456789")
        >>> _ = (folder / "copy.bin.part").write_bytes(b"0123")  # left by an interrupted run
        >>> download = ResumingDownloader(folder / "copy.bin", size=10)
        >>> download((folder / "source.bin").as_uri(), str(folder / "handed-to-pooch"), None)
        >>> (folder / "handed-to-pooch").read_bytes(), download.resumed_at
        (b'0123456789', 4)
    """

    def __init__(self, target: str | os.PathLike, *, size: int | None = None, check: Callable[[Path], str | None] | None = None,
                 expected: str | None = None, label: str | None = None, fix: str = "re-run the fetch", report: Report | None = None, resume: bool = True,
                 timeout: float = TIMEOUT_S) -> None:
        self.target = Path(target)
        self.part = self.target.with_name(self.target.name + ".part")
        self.size = size
        self.check = check
        self.expected = expected or f"{size} bytes"
        self.label = label or str(self.target)
        self.fix = fix
        self.report = report or (lambda stage, done=0, total=None, message="": None)
        self.resume = resume
        self.timeout = timeout
        self.resumed_at = 0

    def __call__(self, url: str, output_file: str | os.PathLike, pooch: object, check_only: bool = False) -> None:
        if check_only:
            return None
        if not self.resume:
            self.part.unlink(missing_ok=True)
        offset = self.part.stat().st_size if self.part.exists() else 0
        if self.size is not None and offset > self.size:
            self.part.unlink()
            self.report("restart", 0, self.size, f"{self.part.name} was longer than the file; starting over")
            offset = 0
        self.resumed_at = offset
        if not (self.size is not None and offset == self.size and offset > 0):  # else the .part is whole: only check it
            self._transfer(url, offset)
        if self.check is not None and (got := self.check(self.part)) is not None:
            self.part.unlink()
            raise CorruptFileError(self.corrupt(url, got), path=self.target, expected=self.expected, got=got)
        os.replace(self.part, output_file)
        return None

    def corrupt(self, url: str, got: str) -> str:
        """The message for content from ``url`` that is not the pinned one."""
        return (f"{self.label} from {url} is not the pinned file: expected {self.expected}, got {got}. Nothing was kept. "
                f"Fix: the source or mirror holds another file under this name; check {url}, then {self.fix}; or copy "
                f"the right file to {self.target}.")

    def _transfer(self, url: str, offset: int) -> None:
        stream, start, total = self._open(url, offset)
        try:
            if offset and start != offset:
                self.report("restart", 0, total, f"the server ignored the request to resume at byte {offset}; starting over")
                self.resumed_at = 0
            if self.size is not None and total is not None and total != self.size:
                self.part.unlink(missing_ok=True)
                raise CorruptFileError(
                    f"{self.label}: {url} serves {total} bytes, expected {self.expected}. Nothing was kept. Fix: the source or "
                    f"mirror holds another file under this name; check it, then {self.fix}; or copy the right file to "
                    f"{self.target}.",
                    path=self.target, expected=f"{self.size} bytes", got=f"{total} bytes",
                )
            done = self._stream_into(stream, url, start, self.size if self.size is not None else total, total)
        finally:
            stream.close()
        if total is not None and done < total:
            raise DownloadError(f"the download of {self.label} from {url} stopped at {done} of {total} bytes; they are kept "
                                f"in {self.part}. Fix: {self.fix} to resume.", url=url, target=self.target, reason="incomplete")

    def _stream_into(self, stream: BinaryIO, url: str, start: int, limit: int | None, total: int | None) -> int:
        """Append (or, from byte 0, write) the stream into the ``.part``; return how many bytes it holds."""
        done = start
        stage = "resume" if start else "download"
        with open(self.part, "ab" if start else "wb") as file:
            self.report(stage, done, total, f"resuming at byte {start}" if start else "")
            while True:
                try:
                    chunk = stream.read(CHUNK)
                except (OSError, http.client.HTTPException) as error:
                    file.flush()
                    os.fsync(file.fileno())
                    raise DownloadError(
                        f"the download of {self.label} from {url} broke off at {done}"
                        f"{f' of {total}' if total is not None else ''} bytes ({type(error).__name__}: {error}); they are "
                        f"kept in {self.part}. Fix: {self.fix} to resume.",
                        url=url, target=self.target, reason="incomplete",
                    ) from None
                if not chunk:
                    break
                if limit is not None and done + len(chunk) > limit:
                    file.close()
                    self.part.unlink(missing_ok=True)
                    raise CorruptFileError(
                        f"{self.label}: {url} sent more than the {limit} bytes expected. Nothing was kept. Fix: check the "
                        f"source or mirror, then {self.fix}; or copy the right file to {self.target}.",
                        path=self.target, expected=f"{limit} bytes", got=f"more than {limit} bytes",
                    )
                file.write(chunk)
                done += len(chunk)
                self.report(stage, done, total, "")
            file.flush()
            os.fsync(file.fileno())
        return done

    def _open(self, url: str, offset: int) -> tuple[BinaryIO, int, int | None]:
        """Open ``url`` from byte ``offset`` where the source allows it: (stream, the byte it starts at, total size or None)."""
        scheme = urllib.parse.urlsplit(url).scheme.lower()
        if scheme == "file":
            path = Path(urllib.request.url2pathname(urllib.parse.urlsplit(url).path))
            if not path.is_file():
                raise DownloadError(f"{self.label} is not in the mirror: {path} does not exist. Fix: put the file there (a "
                                    f"mirror holds <mirror>/<data set>/<file>, see docs/data.md), then {self.fix}; or copy "
                                    f"the file to {self.target}.", url=url, target=self.target, reason="missing")
            try:
                stream = open(path, "rb")
            except OSError as error:
                raise DownloadError(f"{self.label}: cannot read {path} in the mirror ({error.strerror}). Fix: make it "
                                    f"readable, then {self.fix}.", url=url, target=self.target, reason="refused") from None
            total = os.fstat(stream.fileno()).st_size
            start = offset if offset <= total else 0
            stream.seek(start)
            return stream, start, total
        if scheme not in ("http", "https"):
            raise DownloadError(f"{self.label}: cannot read {url}: only http(s) and file URLs are supported. Fix: give "
                                "an http(s):// or file:// mirror.", url=url, target=self.target, reason="refused")
        response = self._request(url, offset)
        if response.status == 206:
            match = _CONTENT_RANGE.fullmatch(response.headers.get("Content-Range", "").strip())
            if match and int(match.group(1)) == offset:
                return response, offset, None if match.group(3) == "*" else int(match.group(3))
            response.close()
            response = self._request(url, 0)
        length = response.headers.get("Content-Length")
        return response, 0, int(length) if length and length.isdigit() else None

    def _request(self, url: str, offset: int) -> http.client.HTTPResponse:
        """GET ``url`` (with a Range header from a non-zero ``offset``), turning failures into :class:`DownloadError`."""
        headers = {"User-Agent": f"vigen-datasets/{__version__}", "Accept-Encoding": "identity"}
        if offset:
            headers["Range"] = f"bytes={offset}-"
        try:
            return urllib.request.urlopen(urllib.request.Request(url, headers=headers), timeout=self.timeout)
        except urllib.error.HTTPError as error:
            error.close()
            if error.code == 416 and offset:
                return self._request(url, 0)
            if error.code in (404, 410):
                raise DownloadError(f"{self.label} is not at {url} (HTTP {error.code}). Fix: check the source or mirror (a "
                                    f"mirror holds <mirror>/<data set>/<file>, see docs/data.md), then {self.fix}; or copy "
                                    f"the file to {self.target}.", url=url, target=self.target, reason="missing") from None
            raise DownloadError(f"{self.label}: {url} answered HTTP {error.code} {error.reason}. Fix: check the source or "
                                f"mirror, then {self.fix}; or copy the file to {self.target}.",
                                url=url, target=self.target, reason="refused") from None
        except (urllib.error.URLError, OSError, http.client.HTTPException) as error:
            reason = getattr(error, "reason", error)
            raise DownloadError(f"cannot reach {url} to fetch {self.label} ({type(reason).__name__}: {reason}). Fix: check "
                                f"the network, or use a mirror (--mirror / $VIGEN_DATA_MIRROR, see docs/data.md), then "
                                f"{self.fix}; or copy the file to {self.target}.",
                                url=url, target=self.target, reason="unreachable") from None


def _download(url: str, target: Path, *, size: int | None, sha256: str | None, check: Callable[[Path], str | None] | None,
              expected: str, label: str, command: str, report: Report) -> None:
    """``url`` into ``target`` through :func:`pooch.retrieve` and a :class:`ResumingDownloader`, checked against its pin.

    A file that fails its check after resuming a ``.part`` is downloaded once more from byte 0:
    the ``.part`` may have been left by another source or an older run, and the source itself is
    only blamed for a whole download.
    """
    pooch = _installed("pooch")
    for resume in (True, False):
        downloader = ResumingDownloader(target, size=size, check=check, expected=expected, label=label,
                                        fix=f"re-run `{command}`", report=report, resume=resume)
        try:
            with _pooch_quiet(pooch):
                pooch.retrieve(url, known_hash=f"sha256:{sha256}" if sha256 else None, fname=target.name,
                               path=target.parent, downloader=downloader, progressbar=False)
            return
        except CorruptFileError:
            if not (resume and downloader.resumed_at):
                raise
        except ValueError as error:  # pooch's sha256 check; pooch removed the file
            if not (resume and downloader.resumed_at):
                found = re.search(r"but got ([0-9a-f]{64})", str(error))
                got = f"sha256 {found.group(1)}" if found else "another sha256"
                raise CorruptFileError(downloader.corrupt(url, got), path=target, expected=expected, got=got) from None
        report("restart", 0, size, f"the file resumed at byte {downloader.resumed_at} failed its check; downloading it whole")


def _installed(module: str) -> ModuleType:
    """``module`` (pooch, filelock: imported when a fetch starts, not with the package), or a DataError naming the fix."""
    try:
        return importlib.import_module(module)
    except ImportError:
        raise DataError(f"fetching needs {module}, which is not installed here. Fix: pip install '{module}' (vigen's setup.py "
                        "lists it), then re-run the fetch.") from None


@contextlib.contextmanager
def _pooch_quiet(pooch) -> Iterator[None]:
    """pooch logs each download to stderr; a library call of vigen reports through ``progress`` only."""
    logger = pooch.get_logger()
    level = logger.level
    logger.setLevel(logging.WARNING)
    try:
        yield
    finally:
        logger.setLevel(level)


@contextlib.contextmanager
def _fetch_lock(dataset: DataSet, folder: Path, emit: ProgressCallback, wait: float | None, command: str) -> Iterator[None]:
    """Hold the data set's lock (``<folder>/.fetch.lock``) while fetching; while another process holds it, wait, naming it."""
    filelock = _installed("filelock")
    FileLock, Timeout = filelock.FileLock, filelock.Timeout
    folder.mkdir(parents=True, exist_ok=True)
    lock = FileLock(str(folder / LOCK_NAME))
    holder = folder / ".fetch.holder"
    try:
        lock.acquire(timeout=0)
    except Timeout:
        who = _read_holder(holder)
        emit(Progress(dataset.name, "", "wait", 0, 0, message=f"waiting for {who}, which is fetching {dataset.name} into {folder}"))
        try:
            lock.acquire(timeout=-1 if wait is None else wait, poll_interval=0.05)
        except Timeout:
            raise DataError(f"{dataset.name} is being fetched into {folder} by {_read_holder(holder)}; this fetch waited "
                            f"{wait:g} s for it. Fix: let that fetch finish (or stop it), then re-run `{command}`; or wait "
                            "longer (--wait SECONDS, or no --wait to wait until it ends).") from None
    try:
        atomic_write(holder, f"pid {os.getpid()} on {socket.gethostname()} since {time.strftime('%Y-%m-%d %H:%M:%S')}\n")
        yield
    finally:
        holder.unlink(missing_ok=True)
        lock.release()


def _read_holder(path: Path) -> str:
    try:
        return path.read_text(encoding="utf-8").strip() or "another process"
    except OSError:
        return "another process (which has not written its pid yet)"


def _cache_error(dataset: DataSet, folder: Path, error: OSError, command: str) -> str:
    """The message for an error of the file system under the cache folder: what failed where, and what to do."""
    where = f" ({error.filename})" if error.filename else ""
    what = f"{error.strerror or error}{where}"
    if error.errno in (errno.ENOSPC, errno.EDQUOT):
        fix = f"free space there, or fetch into another folder (--root DIR or $VIGEN_DATA), then re-run `{command}`"
    else:
        fix = f"fetch into a folder you can write (--root DIR or $VIGEN_DATA), then re-run `{command}`"
    return f"cannot fetch {dataset.name} into {folder}: {what}. Fix: {fix}."


def _fetch_pinned(dataset: DataSet, part: str | None, folder: Path, mirror: str | None, emit: ProgressCallback,
                  command: str) -> Path:
    files = dataset.files_of(part)
    failures: list[tuple[PinnedFile, DataError]] = []
    for index, pinned in enumerate(files, start=1):
        def report(stage: str, done: int = 0, total: int | None = None, message: str = "", pinned: PinnedFile = pinned,
                   index: int = index) -> None:
            emit(Progress(dataset.name, pinned.path, stage, index, len(files), done, total, message))

        url = source_url(dataset, pinned.path, mirror, dataset.url_of(pinned))
        try:
            _fetch_pinned_file(dataset, pinned, folder / pinned.path, url, report, command)
        except DownloadError as error:
            if error.reason == "unreachable":
                raise
            failures.append((pinned, error))
            report("failed", message=str(error))
        except CorruptFileError as error:
            failures.append((pinned, error))
            report("failed", message=str(error))
    if failures:
        raise FetchError(_failure_summary(dataset, part, files, failures, folder, command), [error for _, error in failures])
    return folder / part if part is not None else folder


def _fetch_pinned_file(dataset: DataSet, pinned: PinnedFile, target: Path, url: str, report: Report, command: str) -> None:
    label = f"{dataset.name}/{pinned.path}"
    if target.exists():
        got = pinned_mismatch(target, pinned)
        if got is None:
            report("present", target.stat().st_size, target.stat().st_size)
            return
        raise CorruptFileError(
            f"{target} is already in the cache but is not {label}: expected {pinned.expected}, got {got}. It was "
            f"left as it is. Fix: move it aside or delete it, then re-run `{command}`.",
            path=target, expected=pinned.expected, got=got,
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    # pooch checks hashlib's hashes only: the downloader checks a git blob id before pooch moves the file into place
    check = (lambda path: pinned_mismatch(path, pinned)) if pinned.git_blob is not None else None
    _download(url, target, size=pinned.size, sha256=pinned.sha256, check=check, expected=pinned.expected, label=label,
              command=command, report=report)
    report("done", target.stat().st_size, target.stat().st_size)


def _failure_summary(dataset: DataSet, part: str | None, files: tuple[PinnedFile, ...],
                     failures: list[tuple[PinnedFile, DataError]], folder: Path, command: str) -> str:
    scope = f"{dataset.name} part {part}" if part is not None else dataset.name
    lines = [f"{len(failures)} of the {len(files)} files of {scope} could not be fetched "
             f"(the other {len(files) - len(failures)} are in {folder}, checked):"]
    fixes: list[str] = []
    for pinned, error in failures:
        text, _, fix = str(error).partition(" Fix: ")
        lines.append(f"  - {pinned.path}: {text}")
        fix = fix.replace(str(folder / pinned.path), f"{folder}/<file>")  # one fix line for all files that share it
        if fix and fix not in fixes:
            fixes.append(fix)
    lines += [f"Fix: {fix}" for fix in fixes]
    lines.append(f"(the cache folder: {folder}; the other files stay, so re-running `{command}` only fetches these)")
    return "\n".join(lines)


def _fetch_archive(dataset: DataSet, folder: Path, mirror: str | None, emit: ProgressCallback, command: str) -> Path:
    archive = dataset.archive
    assert archive is not None
    layout = archive.layout
    url = source_url(dataset, archive.file_name, mirror, archive.url)

    def report(stage: str, done: int = 0, total: int | None = None, message: str = "") -> None:
        emit(Progress(dataset.name, archive.file_name, stage, 1, 1, done, total, message))

    top = folder / layout.top
    manifest = read_manifest(folder)
    if manifest is not None and top.exists():
        changed = manifest_size_mismatches(folder, manifest)
        origin = archive_origin(dataset, manifest)
        if changed:
            raise CorruptFileError(
                f"{top} does not match its manifest {folder / MANIFEST_NAME}: {len(changed)} files missing or of another "
                f"size (e.g. {changed[0]}). It was left as it is. Fix: `python -m vigen.datasets verify {dataset.name}` "
                f"names them; move {top} and the manifest aside, then re-run `{command}`.",
                path=top, expected="the files of the manifest", got=f"{len(changed)} files missing or changed",
            )
        if origin == "other":
            recorded = manifest["archive"]
            raise CorruptFileError(
                f"{top} was extracted by an earlier fetch from an archive with sha256 {recorded.get('sha256')}, not the "
                f"pinned {archive.file_name} ({archive.expected}). It was left as it is. Fix: move {top} and "
                f"{folder / MANIFEST_NAME} aside, then re-run `{command}`.",
                path=top, expected=f"the files of {archive.expected}", got=f"the files of sha256 {recorded.get('sha256')}",
            )
        report("present", message="in place, from the pinned archive" if origin == "pinned" else
               "in place, recorded from a folder found there (not the pinned archive)")
        return folder
    if top.exists():  # no manifest: copied there by hand, or a fetch stopped between its two renames
        missing = layout_missing(folder, layout)
        if missing:
            raise CorruptFileError(
                f"{top} does not have {dataset.name}'s layout: missing {_shown(missing)}. It was left as it is. Fix: move "
                f"it aside, then re-run `{command}`.", path=top, expected=f"{dataset.name}'s layout", got=f"missing {_shown(missing)}")
        report("record", message=f"{top} is already in place; recording its files")
        record_manifest(folder, dataset.name, layout.top, None)
        report("done", message="already in place: its layout checked and its files recorded; not the pinned archive, so "
                               "evaluation rows name it `not verified`")
        return folder
    path = folder / archive.file_name
    downloaded = not path.exists()
    label = f"{dataset.name}/{archive.file_name}"
    if downloaded:
        _download(url, path, size=archive.size, sha256=archive.sha256, check=None,
                  expected=f"{archive.expected}, as {archive.pinned_by} records it", label=label, command=command, report=report)
    else:
        got = f"sha256 {sha256_file(path)} ({path.stat().st_size} bytes)"
        if got != archive.expected:
            raise CorruptFileError(
                f"{path} is already in the cache but is not the pinned {archive.file_name}: expected {archive.expected} "
                f"({archive.pinned_by}), got {got}. It was left as it is. Fix: move it aside or delete it, then re-run "
                f"`{command}`.", path=path, expected=archive.expected, got=got)
        report("present", path.stat().st_size, path.stat().st_size, f"using the pinned archive already at {path}")
    try:
        _extract_into_place(dataset, folder, path, url, downloaded, report, command)
    finally:
        if downloaded:
            path.unlink(missing_ok=True)
    return folder


def _extract_into_place(dataset: DataSet, folder: Path, path: Path, url: str, downloaded: bool, report: Report,
                        command: str) -> None:
    """Extract the archive into ``folder/.extract-<pid>`` (pooch's Unzip), check its layout, record its manifest, and
    move both into place."""
    pooch = _installed("pooch")
    archive = dataset.archive
    assert archive is not None
    for leftover in folder.glob(".extract-*"):  # from a fetch that was killed: under the lock none is live
        shutil.rmtree(leftover, ignore_errors=True)
    staging = folder / f".extract-{os.getpid()}"
    kept = "It was removed." if downloaded else f"{path} was left as it is."
    fix = (f"Fix: check that the source or mirror serves {dataset.name}'s {archive.file_name}, then re-run `{command}`"
           + ("" if downloaded else f" after moving {path} aside") + ".")
    try:
        report("extract", message=f"extracting {path.name}")
        try:
            with zipfile.ZipFile(path) as opened:
                outside = [m.filename for m in opened.infolist() if m.filename.startswith(("/", "\\"))
                           or ".." in m.filename.replace("\\", "/").split("/") or ":" in m.filename.split("/")[0]]
            if outside:
                raise CorruptFileError(f"{path.name} (from {url}) holds a member named {outside[0]!r} that would land outside "
                                       f"its folder; refused. {kept} {fix}", path=path, expected="members inside the folder",
                                       got=f"member {outside[0]!r}")
            with _pooch_quiet(pooch):
                pooch.Unzip(extract_dir=str(staging))(str(path), "download", None)
        except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError) as error:
            raise CorruptFileError(f"{path.name} (from {url}) is not a readable zip archive ({error}). {kept} {fix}",
                                   path=path, expected="a zip archive", got=f"{type(error).__name__}: {error}") from None
        missing = layout_missing(staging, archive.layout)
        if missing:
            raise CorruptFileError(f"{archive.file_name} (from {url}) does not have {dataset.name}'s layout: missing "
                                   f"{_shown(missing)}. {kept} {fix}", path=path, expected=f"{dataset.name}'s layout",
                                   got=f"missing {_shown(missing)}")
        report("record", message="recording the extracted files' sizes and sha256")
        manifest = record_manifest(staging, dataset.name, archive.layout.top,
                                   {"file": archive.file_name, "url": url, "sha256": archive.sha256, "size": archive.size})
        os.replace(staging / archive.layout.top, folder / archive.layout.top)
        os.replace(staging / MANIFEST_NAME, folder / MANIFEST_NAME)
        fsync_path(folder)
        report("done", message=f"extracted from the pinned archive ({archive.expected}); {len(manifest['files'])} files")
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _shown(missing: list[str]) -> str:
    return ", ".join(missing[:10]) + (f" and {len(missing) - 10} more" if len(missing) > 10 else "")

"""Fetching a named data set into the cache: every file checked before it takes its final name."""

from __future__ import annotations

import os
import shlex
import shutil
from pathlib import Path

from vigen.data.archive import (MANIFEST_NAME, check_layout, extract_zip, manifest_size_mismatches, read_manifest,
                                record_manifest)
from vigen.data.cache import dataset_folder
from vigen.data.catalog import get_dataset
from vigen.data.checksums import sha256_file
from vigen.data.errors import (CorruptFileError, DataError, DownloadError, FetchError, LayoutError, MissingFileError,
                               SourceUnreachableError)
from vigen.data.mirror import resolve_mirror, source_url
from vigen.data.progress import Progress, ProgressCallback
from vigen.data.records import DataSet, PinnedFile
from vigen.data.transfer import download_part, install
from vigen.io import fsync_path


def fetch(
    name: str | DataSet,
    part: str | None = None,
    root: str | os.PathLike | None = None,
    mirror: str | os.PathLike | None = None,
    progress: ProgressCallback | None = None,
    sha256: str | None = None,
) -> Path:
    """Fetch a data set (or one part of it) into the cache and return its folder (the part's folder for a part).

    Pinned files already present and matching their git blob id are kept; the others are
    downloaded into ``<file>.part`` (resuming one left by an interrupted run), checked against
    their size and git blob id (or sha256), then renamed into place. A file that fails does not stop the
    others: at the end, :class:`~vigen.data.errors.FetchError` lists every failure (the checked
    files stay). An unreachable source raises :class:`~vigen.data.errors.SourceUnreachableError`
    at once.

    An archive data set (``davis2017``) is downloaded the same way, checked against ``sha256`` (or
    the sha256 its record or an earlier fetch recorded) when one is known, extracted into a
    temporary folder, checked against its layout, and renamed into place with a manifest of its
    files' sizes and sha256 (the archive is removed again if this call downloaded it).

    Args:
        name: a data set name (see :data:`vigen.data.DATASETS`) or a :class:`~vigen.data.records.DataSet`.
        part: one part (e.g. ``"video_hard"``); None fetches all.
        root: the cache folder (default :func:`vigen.data.cache_root`).
        mirror: an http(s) URL, ``file://`` URL or folder laid out as ``<mirror>/<name>/<file>``
            (default ``$VIGEN_DATA_MIRROR``, else the original sources).
        progress: called with a :class:`~vigen.data.progress.Progress` event as the fetch goes.
        sha256: the expected sha256 of an archive data set's archive, checked before extraction.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data import fetch, git_blob_id, locate
        >>> from vigen.data.records import DataSet, PinnedFile
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
    if sha256 is not None and dataset.archive is None:
        raise DataError(f"--sha256 is for archive data sets; {dataset.name}'s files are each pinned by a git blob id.")
    if sha256 is not None:
        sha256 = sha256.strip().lower()
        if len(sha256) != 64 or any(c not in "0123456789abcdef" for c in sha256):
            raise DataError(f"sha256 must be 64 hex digits, got {sha256!r}.")
    resolved = resolve_mirror(mirror)
    folder = dataset_folder(dataset, root)
    command = fetch_command(dataset.name, part, mirror, root)
    emit = progress or (lambda event: None)
    folder.mkdir(parents=True, exist_ok=True)
    if dataset.archive is not None:
        return _fetch_archive(dataset, folder, resolved, emit, command, sha256)
    return _fetch_pinned(dataset, part, folder, resolved, emit, command)


def fetch_command(name: str, part: str | None = None, mirror: str | os.PathLike | None = None,
                  root: str | os.PathLike | None = None) -> str:
    """The command line that fetches ``name`` (and ``part``), as errors and warnings quote it.

    Examples:
        >>> from vigen.data.fetch import fetch_command
        >>> fetch_command("dmcgb-videos", "video_hard")
        'python -m vigen.data fetch dmcgb-videos --part video_hard'
    """
    words = ["python", "-m", "vigen.data", "fetch", name]
    if part is not None:
        words += ["--part", part]
    if mirror is not None:
        words += ["--mirror", os.fspath(mirror)]
    if root is not None:
        words += ["--root", os.fspath(root)]
    return shlex.join(words)


def _fetch_pinned(dataset: DataSet, part: str | None, folder: Path, mirror: str | None, emit: ProgressCallback,
                  command: str) -> Path:
    files = dataset.files_of(part)
    failures: list[tuple[PinnedFile, DataError]] = []
    for index, pinned in enumerate(files, start=1):
        def report(stage: str, done: int = 0, total: int | None = None, message: str = "", pinned: PinnedFile = pinned,
                   index: int = index) -> None:
            emit(Progress(dataset.name, pinned.path, stage, index, len(files), done, total, message))

        try:
            _fetch_pinned_file(dataset, pinned, folder / pinned.path, source_url(dataset, pinned.path, mirror, dataset.url_of(pinned)),
                               report, command)
        except SourceUnreachableError:
            raise
        except (MissingFileError, CorruptFileError, DownloadError) as error:
            failures.append((pinned, error))
            report("failed", message=str(error))
    if failures:
        raise FetchError(_failure_summary(dataset, part, files, failures, folder, command), [error for _, error in failures])
    return folder / part if part is not None else folder


def _fetch_pinned_file(dataset: DataSet, pinned: PinnedFile, target: Path, url: str, report, command: str) -> None:
    label = f"{dataset.name}/{pinned.path}"
    if target.exists():
        got = _pinned_mismatch(target, pinned)
        if got is None:
            report("present", target.stat().st_size, target.stat().st_size)
            return
        raise CorruptFileError(
            f"{target} is already in the cache but is not {label}: expected {pinned.expected}, got {got}. It was "
            f"left as it is. Fix: move it aside or delete it, then re-run `{command}`.",
            path=target, expected=pinned.expected, got=got,
        )
    target.parent.mkdir(parents=True, exist_ok=True)
    part = download_part(url, target, expected_size=pinned.size, label=label, fix=f"re-run `{command}`", report=report)
    got = _pinned_mismatch(part, pinned)
    if got is not None:
        part.unlink()
        raise CorruptFileError(
            f"{label} from {url} is corrupt: expected {pinned.expected}, got {got}. Nothing was kept. Fix: re-run "
            f"`{command}`; if it fails again the source or mirror holds a wrong copy: check {url}, or copy the right file "
            f"to {target}.",
            path=target, expected=pinned.expected, got=got,
        )
    install(part, target)
    report("done", target.stat().st_size, target.stat().st_size)


def _pinned_mismatch(path: Path, pinned: PinnedFile) -> str | None:
    """None when ``path`` holds the pinned content, else what it holds (``git blob <id> (<size> bytes)``, or its sha256)."""
    size = path.stat().st_size
    if pinned.size is not None and size != pinned.size:
        return f"{size} bytes"
    return None if pinned.matches(path) else f"{pinned.content_id(path)} ({size} bytes)"


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


def _fetch_archive(dataset: DataSet, folder: Path, mirror: str | None, emit: ProgressCallback, command: str,
                   sha256: str | None) -> Path:
    archive = dataset.archive
    assert archive is not None
    layout = archive.layout
    url = source_url(dataset, archive.file_name, mirror, archive.url)

    def report(stage: str, done: int = 0, total: int | None = None, message: str = "") -> None:
        emit(Progress(dataset.name, archive.file_name, stage, 1, 1, done, total, message))

    top = folder / layout.top
    manifest = read_manifest(folder)
    recorded = None
    if manifest is not None:
        changed = manifest_size_mismatches(folder, manifest)
        if top.is_dir() and not changed:
            report("present")
            return folder
        if top.exists():
            raise CorruptFileError(
                f"{top} does not match its manifest {folder / MANIFEST_NAME}: {len(changed)} files missing or of another "
                f"size (e.g. {changed[0]}). It was left as it is. Fix: `python -m vigen.data verify {dataset.name}` names "
                f"them; move {top} and the manifest aside, then re-run `{command}`.",
                path=top, expected="the files of the manifest", got=f"{len(changed)} files missing or changed",
            )
        recorded = (manifest.get("archive") or {}).get("sha256")
    elif top.exists():
        # in place without a manifest: copied there by hand, or a fetch stopped between its two renames
        try:
            check_layout(folder, layout, where=str(top))
        except LayoutError as error:
            raise LayoutError(f"{error} It was left as it is. Fix: move it aside, then re-run `{command}`.",
                              missing=error.missing) from None
        report("record", message=f"{top} is already in place; recording its files")
        record_manifest(folder, dataset.name, layout.top, None)
        return folder
    expected = sha256 or archive.sha256 or recorded
    path = folder / archive.file_name
    downloaded = not path.exists()
    if downloaded:
        part = download_part(url, path, expected_size=archive.size, label=f"{dataset.name}/{archive.file_name}",
                             fix=f"re-run `{command}`", report=report)
        got = sha256_file(part)
        if expected is not None and got != expected:
            part.unlink()
            raise CorruptFileError(
                f"{dataset.name}/{archive.file_name} from {url} is corrupt: expected sha256 {expected}, got sha256 {got}. "
                f"Nothing was kept. Fix: re-run `{command}`; if it fails again the source or mirror holds another archive: "
                f"check {url}, or copy the right archive to {path}.",
                path=path, expected=f"sha256 {expected}", got=f"sha256 {got}",
            )
        install(part, path)
    else:
        got = sha256_file(path)
        if expected is not None and got != expected:
            raise CorruptFileError(
                f"{path} is already in the cache but its sha256 is {got}, expected {expected}. It was left as it is. "
                f"Fix: move it aside or delete it, then re-run `{command}`.",
                path=path, expected=f"sha256 {expected}", got=f"sha256 {got}",
            )
        report("present", path.stat().st_size, path.stat().st_size, f"using the archive already at {path}")
    _extract_into_place(dataset, folder, path, url, got, downloaded, report, command)
    if downloaded:
        path.unlink()
    return folder


def _extract_into_place(dataset: DataSet, folder: Path, path: Path, url: str, sha256: str, downloaded: bool, report,
                        command: str) -> None:
    """Extract the archive into ``folder/.extract-<pid>``, check its layout, record its manifest, rename both into place."""
    archive = dataset.archive
    assert archive is not None
    staging = folder / f".extract-{os.getpid()}"
    shutil.rmtree(staging, ignore_errors=True)
    try:
        report("extract", message=f"extracting {path.name}")
        try:
            extract_zip(path, staging)
            check_layout(staging, archive.layout, where=f"{archive.file_name} (from {url})")
        except DataError as error:
            kept = "It was removed." if downloaded else f"{path} was left as it is."
            if downloaded:
                path.unlink()
            fix = (f"Fix: check that the source or mirror serves {dataset.name}'s {archive.file_name}, then re-run `{command}`"
                   + ("" if downloaded else f" after moving {path} aside") + ".")
            message = f"{str(error).partition(' Fix: ')[0]} {kept} {fix}"
            if isinstance(error, LayoutError):
                raise LayoutError(message, missing=error.missing) from None
            if isinstance(error, CorruptFileError):
                raise CorruptFileError(message, path=path, expected=error.expected, got=error.got) from None
            raise DataError(message) from None
        report("record", message="recording the extracted files' sizes and sha256")
        record_manifest(staging, dataset.name, archive.layout.top,
                        {"file": archive.file_name, "url": url, "sha256": sha256, "size": path.stat().st_size})
        os.replace(staging / archive.layout.top, folder / archive.layout.top)
        os.replace(staging / MANIFEST_NAME, folder / MANIFEST_NAME)
        fsync_path(folder)
        report("done")
    finally:
        shutil.rmtree(staging, ignore_errors=True)


"""Checking what the cache holds: :func:`locate` and :func:`status` (cheap: names and sizes), :func:`verify` (every file
hashed against its pin), and the content ids, archive layouts and manifests they read.

:func:`locate` and :func:`status` are what vigen's levels call at every env build, so they only
look at file names and sizes. :func:`verify` hashes: a pinned file against its git blob id or
sha256, an archive data set's files against the manifest its fetch recorded, and that manifest's
archive against the record's pin. This module imports the standard library only.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from vigen.datasets.records import ArchiveLayout, DataError, DataSet, PinnedFile, dataset_folder, get_dataset
from vigen.io import atomic_write

CHUNK = 1 << 20
"""Bytes read at a time when hashing and copying."""

MANIFEST_NAME = "manifest.json"
"""An archive data set's manifest, in its folder beside the extracted top folder."""


def git_blob_id(path: str | os.PathLike) -> str:
    """The file's git blob id, as ``git hash-object`` gives it: ``sha1(b"blob <size>\\0" + content)``.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets import git_blob_id
        >>> empty = Path(tempfile.mkdtemp()) / "empty"
        >>> _ = empty.write_bytes(b"")
        >>> git_blob_id(empty)
        'e69de29bb2d1d6434b8b29ae775ad8c2e48c5391'
    """
    with open(path, "rb") as file:
        digest = hashlib.sha1(b"blob %d\0" % os.fstat(file.fileno()).st_size)
        for chunk in iter(lambda: file.read(CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def sha256_file(path: str | os.PathLike) -> str:
    """The sha256 of a file's content, hex.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets.verify import sha256_file
        >>> path = Path(tempfile.mkdtemp()) / "abc"
        >>> _ = path.write_bytes(b"abc")
        >>> sha256_file(path)[:16]
        'ba7816bf8f01cfea'
    """
    digest = hashlib.sha256()
    with open(path, "rb") as file:
        for chunk in iter(lambda: file.read(CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def pinned_mismatch(path: str | os.PathLike, pinned: PinnedFile) -> str | None:
    """None when the file at ``path`` holds the pinned content, else what it holds (``<id> (<size> bytes)`` or its size).

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets import PinnedFile
        >>> from vigen.datasets.verify import pinned_mismatch
        >>> path = Path(tempfile.mkdtemp()) / "a.bin"
        >>> _ = path.write_bytes(b"hello\\n")
        >>> pinned_mismatch(path, PinnedFile("a.bin", "ce013625030ba8dba906f756967f9e9ca394464a", 6)) is None
        True
        >>> pinned_mismatch(path, PinnedFile("a.bin", "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391", 0))
        '6 bytes'
    """
    size = Path(path).stat().st_size
    if pinned.size is not None and size != pinned.size:
        return f"{size} bytes"
    got = f"git blob {git_blob_id(path)}" if pinned.git_blob is not None else f"sha256 {sha256_file(path)}"
    return None if got == pinned.pin else f"{got} ({size} bytes)"


def layout_missing(folder: str | os.PathLike, layout: ArchiveLayout) -> list[str]:
    """What ``folder`` lacks of ``layout``: required files, listings, and listed items without a file matching ``item_glob``.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets import ArchiveLayout
        >>> from vigen.datasets.verify import layout_missing
        >>> layout = ArchiveLayout("TOY", listings=("TOY/sets.txt",), item_glob="TOY/frames/{item}/*.jpg")
        >>> folder = Path(tempfile.mkdtemp())
        >>> (folder / "TOY/frames/bear").mkdir(parents=True)
        >>> _ = (folder / "TOY/sets.txt").write_text("bear\\ncat\\n")
        >>> _ = (folder / "TOY/frames/bear/00000.jpg").write_bytes(b"jpg")
        >>> layout_missing(folder, layout)
        ['TOY/frames/cat/*.jpg']
    """
    folder = Path(folder)
    missing = [path for path in layout.required if not (folder / path).is_file()]
    for listing in layout.listings:
        if not (folder / listing).is_file():
            if listing not in missing:
                missing.append(listing)
            continue
        items = [line.strip() for line in (folder / listing).read_text(encoding="utf-8", errors="replace").splitlines()]
        items = [item for item in items if item]
        if not items:
            missing.append(f"{listing} (lists no item)")
        for item in items:
            pattern = layout.item_glob.format(item=item)  # type: ignore[union-attr]
            if "/" in item or item in (".", "..") or next(folder.glob(pattern), None) is None:
                missing.append(pattern)
    return missing


def record_manifest(folder: str | os.PathLike, dataset: str, top: str, archive: dict[str, Any] | None) -> dict[str, Any]:
    """Hash every file under ``folder/top`` and write ``folder/manifest.json`` atomically; return the manifest.

    Args:
        folder: the data set's folder (or the staging folder an archive was extracted into).
        dataset: the data set's name.
        top: the extracted top folder inside ``folder``.
        archive: ``{"file", "url", "sha256", "size"}`` of the archive the files came from, or None for files
            found already in place.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets.verify import read_manifest, record_manifest
        >>> folder = Path(tempfile.mkdtemp())
        >>> (folder / "TOY").mkdir()
        >>> _ = (folder / "TOY/a.txt").write_text("abc")
        >>> manifest = record_manifest(folder, "toy", "TOY", None)
        >>> read_manifest(folder)["files"]["TOY/a.txt"]["size"]
        3
    """
    folder = Path(folder)
    files = {path.relative_to(folder).as_posix(): {"size": path.stat().st_size, "sha256": sha256_file(path)}
             for path in sorted((folder / top).rglob("*")) if path.is_file()}
    manifest = {"dataset": dataset, "archive": archive, "recorded": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
                "files": files}
    atomic_write(folder / MANIFEST_NAME, json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def read_manifest(folder: str | os.PathLike) -> dict[str, Any] | None:
    """The manifest in a data set's folder, or None when there is none yet.

    Examples:
        >>> import tempfile
        >>> from vigen.datasets.verify import read_manifest
        >>> read_manifest(tempfile.mkdtemp()) is None
        True
    """
    path = Path(folder) / MANIFEST_NAME
    if not path.is_file():
        return None
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise DataError(f"{path} cannot be read ({error}). Fix: move it aside and re-run the fetch to record it again.") from None
    if not isinstance(manifest, dict) or not isinstance(manifest.get("files"), dict):
        raise DataError(f"{path} is not a vigen.datasets manifest. Fix: move it aside and re-run the fetch to record it again.")
    return manifest


def manifest_size_mismatches(folder: str | os.PathLike, manifest: dict[str, Any]) -> list[str]:
    """The manifest's files that are missing from ``folder`` or have another size (no hashing: cheap).

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets.verify import manifest_size_mismatches
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "a.txt").write_text("abc")
        >>> manifest_size_mismatches(folder, {"files": {"a.txt": {"size": 3}, "b.txt": {"size": 1}}})
        ['b.txt']
    """
    folder = Path(folder)
    changed = []
    for relative, entry in manifest["files"].items():
        try:
            if (folder / relative).stat().st_size != entry["size"]:
                changed.append(relative)
        except OSError:
            changed.append(relative)
    return changed


def archive_origin(dataset: DataSet, manifest: dict[str, Any]) -> str:
    """Where an archive data set's recorded files came from: ``"pinned"`` (the archive matched the record's pin),
    ``"in place"`` (a folder found in the cache, from no archive) or ``"other"`` (an archive with another sha256).

    Examples:
        >>> from vigen.datasets import get_dataset
        >>> from vigen.datasets.verify import archive_origin
        >>> davis = get_dataset("davis2017")
        >>> archive_origin(davis, {"archive": {"sha256": davis.archive.sha256}}), archive_origin(davis, {"archive": None})
        ('pinned', 'in place')
    """
    assert dataset.archive is not None
    recorded = manifest.get("archive") or {}
    if not recorded:
        return "in place"
    return "pinned" if recorded.get("sha256") == dataset.archive.sha256 else "other"


@dataclass(frozen=True)
class PartStatus:
    """How many of a part's expected files are in the cache with their expected size.

    Attributes:
        dataset: the data set's name.
        part: the part, or None for a data set fetched whole (an archive).
        present: files present with the expected size.
        expected: files expected, or None where that is only known once fetched (an archive's manifest).
        folder: where the part's files are (or would be).

    Examples:
        >>> from pathlib import Path
        >>> from vigen.datasets import PartStatus
        >>> PartStatus("dmcgb-videos", "video_easy", 6, 10, Path("/c/dmcgb-videos/video_easy")).complete
        False
    """

    dataset: str
    part: str | None
    present: int
    expected: int | None
    folder: Path

    @property
    def complete(self) -> bool:
        """Every expected file is present (False while the expected files are unknown)."""
        return self.expected is not None and self.expected > 0 and self.present == self.expected


def status(name: str | DataSet, root: str | os.PathLike | None = None) -> tuple[PartStatus, ...]:
    """For each part of a data set (one entry for a data set fetched whole), how many expected files are present.

    Examples:
        >>> import tempfile
        >>> from vigen.datasets import status
        >>> [(s.part, s.present, s.expected) for s in status("dmcgb-videos", root=tempfile.mkdtemp())]
        [('video_easy', 0, 10), ('video_hard', 0, 100)]
        >>> [(s.part, s.present, s.expected) for s in status("davis2017", root=tempfile.mkdtemp())]
        [(None, 0, None)]
    """
    dataset = get_dataset(name)
    folder = dataset_folder(dataset, root)
    if dataset.archive is not None:
        manifest = read_manifest(folder)
        if manifest is None:
            return (PartStatus(dataset.name, None, 0, None, folder),)
        expected = len(manifest["files"])
        return (PartStatus(dataset.name, None, expected - len(manifest_size_mismatches(folder, manifest)), expected, folder),)
    return tuple(PartStatus(dataset.name, part, sum(_present(folder / pinned.path, pinned) for pinned in dataset.files_of(part)),
                            len(dataset.files_of(part)), folder / part if part else folder)
                 for part in dataset.parts or (None,))


def locate(name: str | DataSet, part: str | None = None, root: str | os.PathLike | None = None) -> Path | None:
    """The folder of a fetched data set (or part) when every one of its files is present with its size, else None.

    Cheap (no hashing): :func:`verify` checks contents. An unknown name or part raises
    :class:`~vigen.datasets.UnknownDataSetError`, listing the known ones.

    Examples:
        >>> import tempfile
        >>> from vigen.datasets import locate
        >>> locate("dmcgb-videos", "video_hard", root=tempfile.mkdtemp()) is None
        True
    """
    dataset = get_dataset(name)
    dataset.check_part(part)
    folder = dataset_folder(dataset, root)
    if dataset.archive is not None:
        manifest = read_manifest(folder)
        complete = (manifest is not None and (folder / dataset.archive.layout.top).is_dir()
                    and not manifest_size_mismatches(folder, manifest))
        return folder if complete else None
    if all(_present(folder / pinned.path, pinned) for pinned in dataset.files_of(part)):
        return folder / part if part is not None else folder
    return None


def _present(path: Path, pinned: PinnedFile) -> bool:
    try:
        return path.is_file() and (pinned.size is None or path.stat().st_size == pinned.size)
    except OSError:
        return False


@dataclass(frozen=True)
class Mismatch:
    """A file whose content is not the expected one.

    Examples:
        >>> from vigen.datasets import Mismatch
        >>> str(Mismatch("video_hard/video0.mp4", "git blob 0a (10 bytes)", "9 bytes"))
        'video_hard/video0.mp4: expected git blob 0a (10 bytes), got 9 bytes'
    """

    path: str
    expected: str
    got: str

    def __str__(self) -> str:
        return f"{self.path}: expected {self.expected}, got {self.got}"


@dataclass(frozen=True)
class VerifyReport:
    """What :func:`verify` found for one data set.

    Attributes:
        dataset: the data set's name.
        folder: its folder in the cache.
        checked: files present and matching.
        mismatched: files present with other content, files of an extracted archive that went missing, and an
            archive that was not the pinned one.
        absent: pinned files not fetched (not an error: parts can be fetched alone).
        notes: what else the reader should know (leftover ``.part`` files, where an archive's files came from).
        ok: no mismatch.

    Examples:
        >>> import tempfile
        >>> from vigen.datasets import verify
        >>> report = verify("dmcgb-videos", root=tempfile.mkdtemp())
        >>> report.ok, len(report.checked), len(report.absent)
        (True, 0, 110)
    """

    dataset: str
    folder: Path
    checked: tuple[str, ...] = ()
    mismatched: tuple[Mismatch, ...] = ()
    absent: tuple[str, ...] = ()
    notes: tuple[str, ...] = field(default=())

    @property
    def ok(self) -> bool:
        return not self.mismatched

    def __str__(self) -> str:
        head = (f"{self.dataset}: {len(self.checked)} files checked, {len(self.mismatched)} mismatched, "
                f"{len(self.absent)} not fetched ({self.folder})")
        return "\n".join([head, *(f"  MISMATCH {mismatch}" for mismatch in self.mismatched), *(f"  {note}" for note in self.notes)])


def verify(name: str | DataSet, root: str | os.PathLike | None = None) -> VerifyReport:
    """Hash every fetched file of a data set and compare it with its pinned git blob id / sha256.

    Pinned files not fetched are listed as ``absent`` (parts may be fetched alone). An archive
    data set's files are checked against the manifest its fetch recorded (one that went missing
    counts as a mismatch), and the manifest's archive against the record's pin.

    Examples:
        >>> from vigen.datasets import verify
        >>> print(verify("davis2017", root="/nonexistent/vigen"))
        davis2017: 0 files checked, 0 mismatched, 0 not fetched (/nonexistent/vigen/davis2017)
          not fetched (no manifest.json)
    """
    dataset = get_dataset(name)
    folder = dataset_folder(dataset, root)
    if dataset.archive is not None:
        return _verify_archive(dataset, folder)
    checked: list[str] = []
    mismatched: list[Mismatch] = []
    absent: list[str] = []
    for pinned in dataset.files:
        path = folder / pinned.path
        if not path.is_file():
            absent.append(pinned.path)
        elif (got := pinned_mismatch(path, pinned)) is not None:
            mismatched.append(Mismatch(pinned.path, pinned.expected, got))
        else:
            checked.append(pinned.path)
    leftovers = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.part")) if folder.is_dir() else []
    notes = tuple(f"incomplete download {relative} (the next fetch resumes it)" for relative in leftovers)
    return VerifyReport(dataset.name, folder, tuple(checked), tuple(mismatched), tuple(absent), notes)


def _verify_archive(dataset: DataSet, folder: Path) -> VerifyReport:
    archive = dataset.archive
    assert archive is not None
    manifest = read_manifest(folder)
    if manifest is None:
        return VerifyReport(dataset.name, folder, notes=(f"not fetched (no {MANIFEST_NAME})",))
    checked: list[str] = []
    mismatched: list[Mismatch] = []
    for relative, entry in sorted(manifest["files"].items()):
        expected = f"sha256 {entry['sha256']} ({entry['size']} bytes)"
        path = folder / relative
        if not path.is_file():
            mismatched.append(Mismatch(relative, expected, "no file"))
        elif (got := f"sha256 {sha256_file(path)} ({path.stat().st_size} bytes)") != expected:
            mismatched.append(Mismatch(relative, expected, got))
        else:
            checked.append(relative)
    origin = archive_origin(dataset, manifest)
    if origin == "pinned":
        note = f"extracted from the pinned archive {archive.file_name} ({archive.expected}, as {archive.pinned_by} records it)"
    elif origin == "in place":
        note = (f"files recorded in place, not from the pinned archive: checked against what was recorded then "
                f"(evaluation rows name them `not verified`)")
    else:
        recorded = manifest["archive"]
        mismatched.insert(0, Mismatch(archive.file_name, archive.expected,
                                      f"sha256 {recorded.get('sha256')} ({recorded.get('size')} bytes), recorded by an "
                                      "earlier fetch that did not check the pin"))
        note = (f"Fix: move {folder} aside and fetch {dataset.name} again; rows name these files `not verified` "
                "until then")
    return VerifyReport(dataset.name, folder, tuple(checked), tuple(mismatched), (), (note,))

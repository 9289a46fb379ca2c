"""Checking a fetched data set's contents: every file hashed against its pinned id or its recorded sha256."""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

from vigen.data.archive import read_manifest
from vigen.data.cache import dataset_folder
from vigen.data.catalog import get_dataset
from vigen.data.checksums import sha256_file
from vigen.data.records import DataSet


@dataclass(frozen=True)
class Mismatch:
    """A file whose content is not the expected one.

    Examples:
        >>> from vigen.data.verify import Mismatch
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
        mismatched: files present with other content, and files of an extracted archive that went missing.
        absent: pinned files not fetched (not an error: parts can be fetched alone).
        ok: no mismatch.

    Examples:
        >>> import tempfile
        >>> from vigen.data import verify
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
    """Hash every fetched file of a data set and compare it with its pinned git blob id / recorded sha256.

    Pinned files not fetched are listed as ``absent`` (parts may be fetched alone); an archive
    data set's files are checked against the manifest its first fetch recorded, and one that went
    missing counts as a mismatch.

    Examples:
        >>> import tempfile
        >>> from vigen.data import verify
        >>> print(verify("davis2017", root="/nonexistent/vigen"))
        davis2017: 0 files checked, 0 mismatched, 0 not fetched (/nonexistent/vigen/davis2017)
          not fetched (no manifest.json)
    """
    dataset = get_dataset(name)
    folder = dataset_folder(dataset, root)
    checked: list[str] = []
    mismatched: list[Mismatch] = []
    absent: list[str] = []
    if dataset.archive is not None:
        manifest = read_manifest(folder)
        if manifest is None:
            return VerifyReport(dataset.name, folder, notes=("not fetched (no manifest.json)",))
        for relative, entry in sorted(manifest["files"].items()):
            expected = f"sha256 {entry['sha256']} ({entry['size']} bytes)"
            path = folder / relative
            if not path.is_file():
                mismatched.append(Mismatch(relative, expected, "no file"))
            elif path.stat().st_size != entry["size"] or sha256_file(path) != entry["sha256"]:
                mismatched.append(Mismatch(relative, expected, f"sha256 {sha256_file(path)} ({path.stat().st_size} bytes)"))
            else:
                checked.append(relative)
        archive = manifest.get("archive") or {}
        note = f"archive sha256 at first fetch: {archive['sha256']}" if archive.get("sha256") else "files recorded in place (no archive)"
        return VerifyReport(dataset.name, folder, tuple(checked), tuple(mismatched), (), (note,))
    for pinned in dataset.files:
        path = folder / pinned.path
        if not path.is_file():
            absent.append(pinned.path)
            continue
        if not pinned.matches(path):
            mismatched.append(Mismatch(pinned.path, pinned.expected, f"{pinned.content_id(path)} ({path.stat().st_size} bytes)"))
        else:
            checked.append(pinned.path)
    leftovers = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*.part")) if folder.is_dir() else []
    notes = tuple(f"incomplete download {relative} (the next fetch resumes it)" for relative in leftovers)
    return VerifyReport(dataset.name, folder, tuple(checked), tuple(mismatched), tuple(absent), notes)

"""Finding fetched data without hashing: :func:`locate` (is it all there?) and :func:`status` (how much is there?).

These are what vigen's levels call to use the benchmarks' data when it has been fetched (and
fall back to stand-ins otherwise); both only look at file names and sizes, so they are cheap
enough to call at every env build.
"""

from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

from vigen.data.archive import manifest_size_mismatches, read_manifest
from vigen.data.cache import dataset_folder
from vigen.data.catalog import get_dataset
from vigen.data.records import DataSet, PinnedFile


@dataclass(frozen=True)
class PartStatus:
    """How many of a part's expected files are in the cache with their expected size.

    Attributes:
        dataset: the data set's name.
        part: the part, or None for a data set fetched whole (an archive).
        present: files present with the expected size.
        expected: files expected, or None where that is only known after the first fetch (an archive).
        folder: where the part's files are (or would be).

    Examples:
        >>> from pathlib import Path
        >>> from vigen.data.locate import PartStatus
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
        >>> from vigen.data import status
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
    result = []
    for part in dataset.parts or (None,):
        files = dataset.files_of(part)
        present = sum(_present(folder / pinned.path, pinned) for pinned in files)
        result.append(PartStatus(dataset.name, part, present, len(files), folder / part if part else folder))
    return tuple(result)


def locate(name: str | DataSet, part: str | None = None, root: str | os.PathLike | None = None) -> Path | None:
    """The folder of a fetched data set (or part) when every one of its files is present with its size, else None.

    Cheap (no hashing): run :func:`vigen.data.verify` to check contents. An unknown name or part
    raises :class:`~vigen.data.errors.UnknownDataSetError`, listing the known ones.

    Examples:
        >>> import tempfile
        >>> from vigen.data import locate
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

"""What data a level showed, by identity: the data set, its part, how many of its files, and how they were checked.

An evaluation row's ``data`` column names the data its level showed without a machine's path:

* ``dmcgb-videos/video_easy: 10 of 10, verified``: every file shown is a pinned file of the data
  set's part (its git blob id and its name checked), and 10 of the part's 10 files were there;
* ``dmcgb-colors/color_hard: 100 of 100, shipped``: values that ship inside vigen;
* ``davis2017/train: 60 of 60, verified``: an archive data set's split in the cache, extracted by
  ``python -m vigen.datasets fetch`` from the archive whose sha256 matched the record's pin; every
  file shown is one of the files that fetch recorded (name and size checked when the level is
  built; ``python -m vigen.datasets verify`` hashes them);
* ``davis2017/train: 60 of 60, not verified``: the same split recorded from a folder found in the
  cache (not the pinned archive), or holding files the fetch did not record;
* ``dmcgb-videos/video_easy: 6 of 10, not verified``: rows made before vigen checked files (a
  folder of copies that no level hashed);
* ``davis2017/train: 60 of 60, fetched``: rows made before vigen pinned DAVIS's archive (then the
  first fetch recorded whatever archive it got);
* ``user folder: 7 videos``: anything else a user gave (a folder whose files are not all pinned
  files of one part, or a file of their own).

A label may end with ``, <note>`` (``..., shipped, cycled as DMC-GB2 does``). Only
:attr:`DataIdentity.full` data (``verified`` or ``shipped``, every file of the part) is the
published data set in full; :func:`vigen.results.compare` refuses other rows unless asked.

Examples:
    >>> from vigen.datasets.identity import DataIdentity, parse_identity
    >>> label = str(DataIdentity("dmcgb-videos", "video_easy", 6, 10, "verified"))
    >>> label
    'dmcgb-videos/video_easy: 6 of 10, verified'
    >>> parse_identity(label).full, parse_identity("dmcgb-videos/video_hard: 100 of 100, verified").full
    (False, True)
    >>> str(DataIdentity(None, None, 7, None, "user")), parse_identity("user folder: 7 videos").full
    ('user folder: 7 videos', False)
"""

from __future__ import annotations

import os
import re
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from vigen.datasets.records import DataSet, PinnedFile
from vigen.datasets.verify import archive_origin, git_blob_id, locate, read_manifest

CHECKS = ("verified", "shipped", "fetched", "not verified", "user")
"""How the files shown were checked: against the pinned ids (``verified``), values shipped in vigen (``shipped``),
fetched before the archive was pinned (``fetched``: older rows), not checked against a pin (``not verified``), a
user's own (``user``)."""
FULL_CHECKS = ("verified", "shipped")
"""The checks under which a data set shown in full counts as the published one."""
DEFINED_BY_LEVEL = ("random colours",)
"""Labels of draws a level defines by itself (vigen's colour factors: default + N(0, σ²)): no data set to show in full."""

_LABEL = re.compile(r"(?P<dataset>[a-z0-9][a-z0-9._-]*)/(?P<part>[A-Za-z0-9._-]+): (?P<shown>\d+) of (?P<expected>\d+), "
                    r"(?P<check>verified|shipped|fetched|not verified)(?:, (?P<note>.+))?")
_USER = re.compile(r"user (?P<what>folder|file|files): (?P<shown>\d+) (?P<kind>[a-z]+)(?:, (?P<note>.+))?")


@dataclass(frozen=True)
class DataIdentity:
    """The data a transform showed: ``dataset``/``part`` (``None`` for a user's own), files shown of those expected, the check.

    Args:
        dataset: the data set's name (``"dmcgb-videos"``, ``"dmcgb-colors"``), or ``None`` for a user's own data.
        part: the part (``"video_easy"``, ``"color_hard"``, DAVIS's split).
        shown: how many files (or presets) were there to be shown.
        expected: how many the part holds (``None`` for a user's own data).
        check: one of :data:`CHECKS`.
        kind: what the files are, for a user's data (``"videos"``, ``"presets"``, ``"images"``).
        where: for a user's data, ``"folder"``, ``"file"`` or ``"files"``.
        note: a few words more (``"cycled as DMC-GB2 does"``), after a comma.

    Examples:
        >>> from vigen.datasets.identity import DataIdentity
        >>> DataIdentity("dmcgb-colors", "color_hard", 100, 100, "shipped").full
        True
        >>> str(DataIdentity(None, None, 1, None, "user", kind="presets", where="file"))
        'user file: 1 preset'
    """

    dataset: str | None
    part: str | None
    shown: int
    expected: int | None
    check: str
    kind: str = "videos"
    where: str = "folder"
    note: str = ""

    def __post_init__(self) -> None:
        if self.check not in CHECKS:
            raise ValueError(f"DataIdentity: check must be one of {CHECKS}, got {self.check!r}.")
        if (self.dataset is None) != (self.check == "user"):
            raise ValueError("DataIdentity: a user's own data has no data set (dataset=None, check='user'), and a named "
                             f"data set is not the user's; got dataset={self.dataset!r}, check={self.check!r}.")

    @property
    def full(self) -> bool:
        """Every file of the data set's part was shown and checked (``verified``) or ships with vigen (``shipped``)."""
        return (self.dataset is not None and self.check in FULL_CHECKS and self.expected is not None
                and self.shown == self.expected)

    def __str__(self) -> str:
        note = f", {self.note}" if self.note else ""
        if self.dataset is None:
            kind = self.kind[:-1] if self.shown == 1 and self.kind.endswith("s") else self.kind
            return f"user {self.where}: {self.shown} {kind}{note}"
        return f"{self.dataset}/{self.part}: {self.shown} of {self.expected}, {self.check}{note}"


def parse_identity(label: str) -> DataIdentity | None:
    """The :class:`DataIdentity` a ``data`` label names, or ``None`` where the label names none (stand-ins, old path labels).

    Examples:
        >>> from vigen.datasets.identity import parse_identity
        >>> parse_identity("dmcgb-colors/color_easy: 100 of 100, shipped, cycled as DMC-GB2 does").note
        'cycled as DMC-GB2 does'
        >>> parse_identity("procedural stand-in videos (10)") is None
        True
    """
    match = _LABEL.fullmatch(label.strip())
    if match:
        return DataIdentity(match["dataset"], match["part"], int(match["shown"]), int(match["expected"]), match["check"],
                            note=match["note"] or "")
    match = _USER.fullmatch(label.strip())
    if match:
        return DataIdentity(None, None, int(match["shown"]), None, "user", kind=match["kind"], where=match["what"],
                            note=match["note"] or "")
    return None


def label_parts(label: str) -> list[str]:
    """A row's ``data`` label split into its transforms' labels: at each ``;`` outside parentheses.

    Examples:
        >>> label_parts("dmcgb-colors/color_easy: 100 of 100, shipped; procedural stand-in videos (10; an older note)")
        ['dmcgb-colors/color_easy: 100 of 100, shipped', ' procedural stand-in videos (10; an older note)']
    """
    parts, depth, start = [], 0, 0
    for index, character in enumerate(label):
        depth += {"(": 1, ")": -1}.get(character, 0)
        if character == ";" and depth == 0:
            parts.append(label[start:index])
            start = index + 1
    return parts + [label[start:]] if label else []


def not_in_full(label: object) -> list[str]:
    """The parts of a row's ``data`` label (``"; "``-joined) that are not a data set shown in full; stand-ins left out.

    A part is in full where it parses as a :class:`DataIdentity` that is :attr:`~DataIdentity.full`.
    A user's folder or file, fewer files than the part holds, files not verified, and a label that
    names no data set (a machine path, as rows held before vigen named data by identity) are not.
    Stand-ins (labels saying ``stand-in``) are the ``stand_in`` column's business, and draws a level
    defines by itself (:data:`DEFINED_BY_LEVEL`) show no data set.

    Examples:
        >>> from vigen.datasets.identity import not_in_full
        >>> not_in_full("dmcgb-colors/color_easy: 100 of 100, shipped; dmcgb-videos/video_easy: 6 of 10, verified")
        ['dmcgb-videos/video_easy: 6 of 10, verified']
        >>> not_in_full("user folder: 7 videos"), not_in_full(""), not_in_full("procedural stand-in videos (10)")
        (['user folder: 7 videos'], [], [])
        >>> not_in_full("random colours: default + N(0, 0.2²) per channel")
        []
    """
    parts = [part.strip() for part in label_parts(str(label or "")) if part.strip()]
    return [part for part in parts if "stand-in" not in part and not part.startswith(DEFINED_BY_LEVEL)
            and not ((identity := parse_identity(part)) is not None and identity.full)]


def identify_files(paths: Sequence[str | os.PathLike], datasets: Iterable[DataSet], *, kind: str = "videos",
                   where: str = "folder") -> DataIdentity:
    """Which data set part ``paths`` are: every path a pinned file of one part (name and git blob id), or the user's own.

    Only files whose size is a pinned size (or a pinned file of unknown size) are hashed, so a
    folder of other videos costs a ``stat`` per file. A frame folder is never a pinned file. Files
    that are all pinned files of one part give ``<data set>/<part>: <found> of <part's files>,
    verified``; anything else is ``user folder: <n> videos``, with a note saying how many of them
    are a part's files where some are.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.datasets.identity import identify_files
        >>> from vigen.datasets.records import DataSet, PinnedFile
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "a.bin").write_bytes(b"")
        >>> toy = DataSet("toy", "toy", "CC0", "here", files=(PinnedFile("part/a.bin", "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391", 0),
        ...               PinnedFile("part/b.bin", "ce013625030ba8dba906f756967f9e9ca394464a", 6)), url_template="x/{path}")
        >>> str(identify_files([folder / "a.bin"], [toy]))
        'toy/part: 1 of 2, verified'
        >>> _ = (folder / "c.bin").write_bytes(b"other")
        >>> str(identify_files([folder / "a.bin", folder / "c.bin"], [toy]))
        'user folder: 2 videos, 1 of them toy/part files'
    """
    datasets = [dataset for dataset in datasets if dataset.files]
    pinned_by_size: dict[int | None, list[tuple[DataSet, PinnedFile]]] = {}
    for dataset in datasets:
        for pinned in dataset.files:
            pinned_by_size.setdefault(pinned.size, []).append((dataset, pinned))
    matches: list[tuple[str, str, str] | None] = []
    for path in map(Path, paths):
        matches.append(_pinned_match(path, pinned_by_size))
    parts = {(dataset, part) for dataset, part, _ in filter(None, matches)}
    names = {name for _, _, name in filter(None, matches)}
    if matches and None not in matches and len(parts) == 1 and len(names) == len(matches):
        (dataset_name, part), = parts
        expected = next(len(dataset.files_of(part)) for dataset in datasets if dataset.name == dataset_name)
        return DataIdentity(dataset_name, part, len(matches), expected, "verified")
    found = [match for match in matches if match is not None]
    note = ""
    if found:
        counts = {f"{dataset}/{part}": sum(1 for match in found if match[:2] == (dataset, part)) for dataset, part in sorted(parts)}
        note = ", ".join(f"{count} of them {name} files" for name, count in counts.items())
    return DataIdentity(None, None, len(matches), None, "user", kind=kind, where=where, note=note)


def _pinned_match(path: Path, pinned_by_size: dict[int | None, list[tuple[DataSet, PinnedFile]]]
                  ) -> tuple[str, str, str] | None:
    """(data set, part, path in the data set) of the pinned file ``path`` is (same name and git blob id), or ``None``."""
    if not path.is_file():
        return None
    size = path.stat().st_size
    candidates = [(dataset, pinned) for dataset, pinned in pinned_by_size.get(size, []) + pinned_by_size.get(None, [])
                  if pinned.name == path.name]
    if not candidates:
        return None
    blob = git_blob_id(path)
    return next(((dataset.name, pinned.part, pinned.path) for dataset, pinned in candidates if pinned.git_blob == blob), None)


def identify_fetched_split(paths: Sequence[str | os.PathLike], dataset: DataSet, split: str,
                           root: str | os.PathLike | None = None) -> DataIdentity | None:
    """An archive data set's split as the cache holds it (``davis2017/train: 60 of 60, verified``), or ``None``.

    ``paths`` are the split's folders (e.g. DAVIS's ``JPEGImages/480p/<video>``, one per video the
    split lists). They are the fetched data set when it is in the cache (:func:`~vigen.datasets.locate`:
    every recorded file there with its size) and every path lies inside it; ``None`` otherwise (a
    user's own folder). The check is ``verified`` when the files were extracted from the archive
    whose sha256 matched the record's pin and every file under ``paths`` is one the fetch recorded,
    else ``not verified``.

    Examples:
        >>> import tempfile
        >>> from vigen.datasets import get_dataset
        >>> from vigen.datasets.identity import identify_fetched_split
        >>> identify_fetched_split(["/elsewhere/DAVIS/JPEGImages/480p/bear"], get_dataset("davis2017"), "train",
        ...                        root=tempfile.mkdtemp()) is None  # not fetched there
        True
    """
    folder = locate(dataset, root=root)
    if folder is None:
        return None
    folder = folder.resolve()
    shown = [Path(path).resolve() for path in paths]
    if not shown or not all(path.is_relative_to(folder) for path in shown):
        return None
    manifest = read_manifest(folder) or {"files": {}}
    recorded = manifest["files"]
    files = [file for path in shown for file in (path.rglob("*") if path.is_dir() else [path]) if file.is_file()]
    from_fetch = all(file.relative_to(folder).as_posix() in recorded for file in files)
    check = "verified" if archive_origin(dataset, manifest) == "pinned" and from_fetch else "not verified"
    return DataIdentity(dataset.name, split, len(shown), len(shown), check)

"""What a named data set is, as plain records: its pinned files or its archive, its source, license and layout.

A data set is either a list of :class:`PinnedFile` (each fetched on its own from ``url_template`` and
checked against its git blob id), grouped into parts by their first folder, or one :class:`Archive`
(fetched, checked against a sha256 when one is known, extracted and checked against its
:class:`ArchiveLayout`). Adding a data set means adding a record to :data:`vigen.data.DATASETS`,
not code.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from pathlib import Path

from vigen.data.checksums import git_blob_id, sha256_file
from vigen.data.errors import UnknownDataSetError

_HEX40 = re.compile(r"[0-9a-f]{40}")
_HEX64 = re.compile(r"[0-9a-f]{64}")
_NAME = re.compile(r"[a-z0-9][a-z0-9._-]*")


@dataclass(frozen=True)
class PinnedFile:
    """One file of a data set, pinned by its git blob id (``git hash-object``) or its sha256, and, where known, its size.

    A file of a git repository is pinned by its blob id; a file served elsewhere (torchvision's
    weights on download.pytorch.org) by its sha256.

    Attributes:
        path: '/'-separated, relative to the data set's folder; its first folder is its part
            (``video_hard/video0.mp4`` is in part ``video_hard``).
        git_blob: 40 hex digits, ``sha1(b"blob <size>\\0" + content)``; None for a file pinned by ``sha256``.
        size: bytes, or None where the source listing does not record it (the blob id still pins the content).
        sha256: 64 hex digits, for a file that is not pinned by a git blob id.

    Examples:
        >>> from vigen.data.records import PinnedFile
        >>> pinned = PinnedFile("video_hard/video0.mp4", "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391", 0)
        >>> pinned.part, pinned.name, pinned.expected
        ('video_hard', 'video0.mp4', 'git blob e69de29bb2d1d6434b8b29ae775ad8c2e48c5391 (0 bytes)')
        >>> PinnedFile("empty.bin", None, 0, sha256="e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855").expected
        'sha256 e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855 (0 bytes)'
    """

    path: str
    git_blob: str | None
    size: int | None = None
    sha256: str | None = None

    def __post_init__(self) -> None:
        parts = self.path.split("/")
        if self.path.startswith("/") or any(piece in ("", ".", "..") for piece in parts):
            raise ValueError(f"PinnedFile path {self.path!r} must be relative, '/'-separated, without '.', '..' or empty pieces.")
        if (self.git_blob is None) == (self.sha256 is None):
            raise ValueError(f"PinnedFile {self.path}: pin it by a git blob id or by a sha256, one of them.")
        if self.git_blob is not None and not _HEX40.fullmatch(self.git_blob):
            raise ValueError(f"PinnedFile {self.path}: git_blob must be 40 lowercase hex digits, got {self.git_blob!r}.")
        if self.sha256 is not None and not _HEX64.fullmatch(self.sha256):
            raise ValueError(f"PinnedFile {self.path}: sha256 must be 64 lowercase hex digits, got {self.sha256!r}.")
        if self.size is not None and self.size < 0:
            raise ValueError(f"PinnedFile {self.path}: size must be >= 0 or None, got {self.size}.")

    @property
    def part(self) -> str:
        """The first folder of :attr:`path` ('' for a file at the top of the data set)."""
        return self.path.split("/")[0] if "/" in self.path else ""

    @property
    def name(self) -> str:
        """The file name, without folders."""
        return self.path.rsplit("/", 1)[-1]

    @property
    def expected(self) -> str:
        """How messages name the pinned content: ``git blob <id> (<size> bytes)`` or ``sha256 <hex> (<size> bytes)``."""
        pin = f"git blob {self.git_blob}" if self.git_blob is not None else f"sha256 {self.sha256}"
        return pin + (f" ({self.size} bytes)" if self.size is not None else "")

    def content_id(self, path: str | Path) -> str:
        """What the file at ``path`` holds, in this pin's terms: ``git blob <id>`` or ``sha256 <hex>``."""
        return f"git blob {git_blob_id(path)}" if self.git_blob is not None else f"sha256 {sha256_file(path)}"

    def matches(self, path: str | Path) -> bool:
        """Whether the file at ``path`` has the pinned size (where known) and content."""
        if self.size is not None and Path(path).stat().st_size != self.size:
            return False
        return self.content_id(path) == (f"git blob {self.git_blob}" if self.git_blob is not None else f"sha256 {self.sha256}")


@dataclass(frozen=True)
class ArchiveLayout:
    """What an extracted archive must hold, checked before it is moved into the cache.

    Attributes:
        top: the folder the archive extracts to (kept; the rest of the archive is not).
        required: files that must exist, relative to the data set folder.
        listings: text files (relative to the data set folder) listing one item name a line.
        item_glob: a glob with ``{item}`` that must match at least one file for every listed item.

    Examples:
        >>> from vigen.data.records import ArchiveLayout
        >>> layout = ArchiveLayout("DAVIS", listings=("DAVIS/ImageSets/2017/train.txt",),
        ...                        item_glob="DAVIS/JPEGImages/480p/{item}/*.jpg")
        >>> layout.item_glob.format(item="bear")
        'DAVIS/JPEGImages/480p/bear/*.jpg'
    """

    top: str
    required: tuple[str, ...] = ()
    listings: tuple[str, ...] = ()
    item_glob: str | None = None

    def __post_init__(self) -> None:
        if not self.top or "/" in self.top or self.top in (".", ".."):
            raise ValueError(f"ArchiveLayout top must be one folder name, got {self.top!r}.")
        for path in (*self.required, *self.listings):
            if not path.startswith(self.top + "/"):
                raise ValueError(f"ArchiveLayout: {path!r} is not inside the archive's top folder {self.top!r}.")
        if self.listings and (self.item_glob is None or "{item}" not in self.item_glob):
            raise ValueError("ArchiveLayout: listings need an item_glob holding '{item}'.")


@dataclass(frozen=True)
class Archive:
    """A data set shipped as one zip archive, extracted into the cache.

    Attributes:
        file_name: the archive's name; also its name under a mirror (``<mirror>/<data set>/<file_name>``).
        url: where the original is.
        layout: what the extracted archive must hold.
        sha256: the archive's sha256 where it is known in advance, else None (recorded at first download).
        size: the archive's size in bytes where known.

    Examples:
        >>> from vigen.data.records import Archive, ArchiveLayout
        >>> Archive("toy.zip", "https://example.org/toy.zip", ArchiveLayout("TOY")).file_name
        'toy.zip'
    """

    file_name: str
    url: str
    layout: ArchiveLayout
    sha256: str | None = None
    size: int | None = None

    def __post_init__(self) -> None:
        if "/" in self.file_name or not self.file_name.endswith(".zip"):
            raise ValueError(f"Archive file_name must be a .zip file name without folders, got {self.file_name!r}.")
        if self.sha256 is not None and not _HEX64.fullmatch(self.sha256):
            raise ValueError(f"Archive {self.file_name}: sha256 must be 64 lowercase hex digits, got {self.sha256!r}.")


@dataclass(frozen=True)
class DataSet:
    """A named data set of a benchmark: what it is, where it comes from, under which license, and its files.

    Exactly one of ``files`` (with ``url_template``, holding ``{path}``) or ``archive`` is given.

    Examples:
        >>> from vigen.data.records import DataSet, PinnedFile
        >>> toy = DataSet("toy", "two tiny files", license="CC0", source="made here",
        ...               files=(PinnedFile("a/x.bin", "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391", 0),
        ...                      PinnedFile("b/y.bin", "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391", 0)),
        ...               url_template="https://example.org/toy/{path}")
        >>> toy.parts, [f.path for f in toy.files_of("b")], toy.size
        (('a', 'b'), ['b/y.bin'], 0)
    """

    name: str
    title: str
    license: str
    source: str
    files: tuple[PinnedFile, ...] = ()
    url_template: str | None = None
    archive: Archive | None = None
    notes: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        if not _NAME.fullmatch(self.name):
            raise ValueError(f"DataSet name {self.name!r} must be lowercase letters, digits, '.', '_' or '-'.")
        if bool(self.files) == (self.archive is not None):
            raise ValueError(f"DataSet {self.name}: give either pinned files or an archive, not {'both' if self.files else 'neither'}.")
        if self.files and (self.url_template is None or "{path}" not in self.url_template):
            raise ValueError(f"DataSet {self.name}: pinned files need a url_template holding '{{path}}'.")
        paths = [pinned.path for pinned in self.files]
        if len(set(paths)) != len(paths):
            raise ValueError(f"DataSet {self.name}: a path is listed twice.")

    @property
    def parts(self) -> tuple[str, ...]:
        """The parts (first folders of the pinned files) in the order they are listed; () for an archive."""
        return tuple(dict.fromkeys(pinned.part for pinned in self.files if pinned.part))

    @property
    def size(self) -> int | None:
        """Total bytes of the pinned files (None if a size is not recorded), or the archive's size where known."""
        if self.archive is not None:
            return self.archive.size
        sizes = [pinned.size for pinned in self.files]
        return None if None in sizes else sum(sizes)  # type: ignore[arg-type]

    def check_part(self, part: str | None) -> None:
        """Raise :class:`~vigen.data.errors.UnknownDataSetError` (listing the known parts) unless ``part`` is one."""
        if part is None or part in self.parts:
            return
        known = ", ".join(self.parts) if self.parts else f"none: {self.name} is fetched whole"
        raise UnknownDataSetError(f"data set {self.name} has no part {part!r}; its parts: {known}.")

    def files_of(self, part: str | None = None) -> tuple[PinnedFile, ...]:
        """The pinned files of ``part`` (all of them for None); an unknown part raises, naming the known ones."""
        self.check_part(part)
        return tuple(pinned for pinned in self.files if part is None or pinned.part == part)

    def url_of(self, pinned: PinnedFile) -> str:
        """The original address of a pinned file."""
        assert self.url_template is not None
        return self.url_template.format(path=pinned.path)


def read_pinned_files(path: str | Path) -> tuple[PinnedFile, ...]:
    """Read a pinned-file list: '#' comments, a ``blob size path`` header, then one tab-separated row per file.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data.records import read_pinned_files
        >>> listing = Path(tempfile.mkdtemp()) / "files.tsv"
        >>> _ = listing.write_text("# toy\\nblob\\tsize\\tpath\\ne69de29bb2d1d6434b8b29ae775ad8c2e48c5391\\t?\\ta/empty.bin\\n")
        >>> read_pinned_files(listing)[0]
        PinnedFile(path='a/empty.bin', git_blob='e69de29bb2d1d6434b8b29ae775ad8c2e48c5391', size=None, sha256=None)
    """
    rows = [line for line in Path(path).read_text(encoding="utf-8").splitlines() if line and not line.startswith("#")]
    if not rows or rows[0].split("\t") != ["blob", "size", "path"]:
        raise ValueError(f"{path}: a pinned-file list starts (after '#' comments) with the header 'blob<TAB>size<TAB>path'.")
    pinned = []
    for number, row in enumerate(rows[1:], start=2):
        cells = row.split("\t")
        if len(cells) != 3 or not (cells[1] == "?" or cells[1].isdigit()):
            raise ValueError(f"{path}: row {number} {row!r} is not 'blob<TAB>size-or-?<TAB>path'.")
        pinned.append(PinnedFile(cells[2], cells[0], None if cells[1] == "?" else int(cells[1])))
    return tuple(pinned)

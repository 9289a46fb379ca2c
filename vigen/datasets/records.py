"""What a named data set is, as plain records, the catalog of them (:data:`DATASETS`), where the cache keeps them, and the
errors every part of :mod:`vigen.datasets` raises.

A data set is either a list of :class:`PinnedFile` (each fetched on its own from ``url_template`` and
checked against its git blob id or sha256), grouped into parts by their first folder, or one
:class:`Archive` (fetched, checked against its pinned sha256 and size, extracted and checked against
its :class:`ArchiveLayout`). Adding a data set means adding a record to :data:`DATASETS`, not code.
"""

from __future__ import annotations

import os
import re
from dataclasses import dataclass, field
from pathlib import Path

_HEX40 = re.compile(r"[0-9a-f]{40}")
_HEX64 = re.compile(r"[0-9a-f]{64}")
_NAME = re.compile(r"[a-z0-9][a-z0-9._-]*")


class DataError(Exception):
    """Base class of every error :mod:`vigen.datasets` raises on purpose; its message ends with the fix.

    Examples:
        >>> from vigen.datasets import DataError, FetchError
        >>> issubclass(FetchError, DataError)
        True
    """


class UnknownDataSetError(DataError, LookupError):
    """A data set name or part that no record has; the message lists the known ones.

    Examples:
        >>> from vigen.datasets import UnknownDataSetError, get_dataset
        >>> try:
        ...     get_dataset("dmcgb-video")
        ... except UnknownDataSetError as error:
        ...     print(str(error).split(";")[0])
        unknown data set 'dmcgb-video'
    """


class StandInDataWarning(UserWarning):
    """A level shows vigen's stand-ins because the benchmark's data is not in the cache; the message names the fetch command.

    Python's warning filter shows each such message once per process by default; evaluation rows
    and reports still name the stand-ins on every row.

    Examples:
        >>> from vigen.datasets import StandInDataWarning
        >>> issubclass(StandInDataWarning, UserWarning)
        True
    """


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
        >>> from vigen.datasets import PinnedFile
        >>> pinned = PinnedFile("video_hard/video0.mp4", "e69de29bb2d1d6434b8b29ae775ad8c2e48c5391", 0)
        >>> pinned.part, pinned.name, pinned.expected
        ('video_hard', 'video0.mp4', 'git blob e69de29bb2d1d6434b8b29ae775ad8c2e48c5391 (0 bytes)')
        >>> PinnedFile("empty.bin", None, 0, sha256="e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855").pin
        'sha256 e3b0c44298fc1c149afbf4c8996fb92427ae41e4649b934ca495991b7852b855'
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
    def pin(self) -> str:
        """The pinned content id: ``git blob <id>`` or ``sha256 <hex>``."""
        return f"git blob {self.git_blob}" if self.git_blob is not None else f"sha256 {self.sha256}"

    @property
    def expected(self) -> str:
        """How messages name the pinned content: :attr:`pin` and the size where known."""
        return self.pin + (f" ({self.size} bytes)" if self.size is not None else "")


@dataclass(frozen=True)
class ArchiveLayout:
    """What an extracted archive must hold, checked before it is moved into the cache.

    Attributes:
        top: the folder the archive extracts to (kept; the rest of the archive is not).
        required: files that must exist, relative to the data set folder.
        listings: text files (relative to the data set folder) listing one item name a line.
        item_glob: a glob with ``{item}`` that must match at least one file for every listed item.

    Examples:
        >>> from vigen.datasets import ArchiveLayout
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
    """A data set shipped as one zip archive, pinned by its sha256 and size, and extracted into the cache.

    Attributes:
        file_name: the archive's name; also its name under a mirror (``<mirror>/<data set>/<file_name>``).
        url: where the original is.
        layout: what the extracted archive must hold.
        sha256: the archive's sha256 (64 lowercase hex digits): no other archive is extracted.
        size: the archive's size in bytes.
        pinned_by: who records that sha256 and size (a checksum list, a paper), as messages and docs quote it.

    Examples:
        >>> from vigen.datasets import Archive, ArchiveLayout
        >>> Archive("toy.zip", "https://example.org/toy.zip", ArchiveLayout("TOY"), "00" * 32, 22).expected
        'sha256 0000000000000000000000000000000000000000000000000000000000000000 (22 bytes)'
    """

    file_name: str
    url: str
    layout: ArchiveLayout
    sha256: str
    size: int
    pinned_by: str = ""

    def __post_init__(self) -> None:
        if "/" in self.file_name or not self.file_name.endswith(".zip"):
            raise ValueError(f"Archive file_name must be a .zip file name without folders, got {self.file_name!r}.")
        if not _HEX64.fullmatch(self.sha256):
            raise ValueError(f"Archive {self.file_name}: sha256 must be 64 lowercase hex digits, got {self.sha256!r}.")
        if self.size <= 0:
            raise ValueError(f"Archive {self.file_name}: size must be > 0, got {self.size}.")

    @property
    def expected(self) -> str:
        """How messages name the pinned archive: ``sha256 <hex> (<size> bytes)``."""
        return f"sha256 {self.sha256} ({self.size} bytes)"


@dataclass(frozen=True)
class DataSet:
    """A named data set of a benchmark: what it is, where it comes from, under which license, and its files.

    Exactly one of ``files`` (with ``url_template``, holding ``{path}``) or ``archive`` is given.

    Examples:
        >>> from vigen.datasets import DataSet, PinnedFile
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
        """Total bytes of the pinned files (None if a size is not recorded), or the archive's size."""
        if self.archive is not None:
            return self.archive.size
        sizes = [pinned.size for pinned in self.files]
        return None if None in sizes else sum(sizes)  # type: ignore[arg-type]

    def check_part(self, part: str | None) -> None:
        """Raise :class:`UnknownDataSetError` (listing the known parts) unless ``part`` is one."""
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
        >>> from vigen.datasets.records import read_pinned_files
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


DMCGB_COMMIT = "ff9c0aa8d47685ed972414c67f1b7225e37ff85e"
"""The DMC-GB commit whose ``src/env/data/`` the pinned video list was taken from."""

DMCGB_VIDEOS = DataSet(
    name="dmcgb-videos",
    title="DMC-GB's background videos: video_easy (10) and video_hard (100)",
    license="MIT (DMC-GB, Nicklas Hansen)",
    source=f"github.com/nicklashansen/dmcontrol-generalization-benchmark@{DMCGB_COMMIT}:src/env/data/",
    files=read_pinned_files(Path(__file__).with_name("dmcgb_videos.tsv")),
    url_template=(
        "https://raw.githubusercontent.com/nicklashansen/dmcontrol-generalization-benchmark/"
        f"{DMCGB_COMMIT}/src/env/data/{{path}}"
    ),
    notes=("DMC-GB2 (aalmuzairee/dmcgb2) holds the same blobs under envs/dmcgb/data/.",),
)

DAVIS2017 = DataSet(
    name="davis2017",
    title="DAVIS 2017 trainval, 480p JPEG frames (the RL-ViGen / DMC-GB2 video backgrounds)",
    license="DAVIS terms (davischallenge.org); cite Pont-Tuset et al. 2017 and Perazzi et al. 2016",
    source="data.vision.ee.ethz.ch (DAVIS challenge, ETH Zurich)",
    archive=Archive(
        file_name="DAVIS-2017-trainval-480p.zip",
        url="https://data.vision.ee.ethz.ch/csergi/share/davis/DAVIS-2017-trainval-480p.zip",
        layout=ArchiveLayout(
            top="DAVIS",
            required=("DAVIS/ImageSets/2017/train.txt", "DAVIS/ImageSets/2017/val.txt"),
            listings=("DAVIS/ImageSets/2017/train.txt", "DAVIS/ImageSets/2017/val.txt"),
            item_glob="DAVIS/JPEGImages/480p/{item}/*.jpg",
        ),
        sha256="e3d0b5b77c3d031b000a19e0e25e3e2cac65d183755601bc2cf066df1a2aa492",
        size=832_766_765,
        pinned_by=("TensorFlow Datasets (tensorflow/datasets@90b66237ad09c9e5b9b1bc61b646db7b1fb0713c, "
                   "tensorflow_datasets/video/davis/checksums.tsv)"),
    ),
    notes=("DAVIS publishes no checksum; the archive's sha256 and size are those TensorFlow Datasets records for it.",),
)

RESNET18_SHA256 = "f37072fd47e89c5e827621c5baffa7500819f7896bbacec160b1a16c560e07ec"
"""The sha256 of torchvision's ``resnet18-f37072fd.pth`` (its name carries the first 8 hex digits, which torchvision
checks on download); the full value as widely quoted for that file, with its size, 46,830,571 bytes."""

TORCHVISION_RESNET18 = DataSet(
    name="torchvision-resnet18",
    title="torchvision's ImageNet ResNet-18 weights (IMAGENET1K_V1), PIE-G's frozen encoder",
    license="BSD-3-Clause (torchvision); the weights were trained on ImageNet, whose terms restrict use to research",
    source="download.pytorch.org/models/ (torchvision.models.ResNet18_Weights.IMAGENET1K_V1)",
    files=(PinnedFile("resnet18-f37072fd.pth", None, 46_830_571, sha256=RESNET18_SHA256),),
    url_template="https://download.pytorch.org/models/{path}",
    notes=("A torchvision state dict: load it with vigen's PIEGEncoder(weights=...) or make_loss('pieg', ..., "
           "encoder_weights=...); examples/train.py --recipe pieg-rlvigen finds it here.",),
)

DATASETS: dict[str, DataSet] = {dataset.name: dataset for dataset in (DMCGB_VIDEOS, DAVIS2017, TORCHVISION_RESNET18)}
"""Every named data set, by name. A plain dict of :class:`DataSet` records."""


def get_dataset(name: str | DataSet) -> DataSet:
    """The record of a data set by name (a record is returned as it is); an unknown name lists the known ones.

    Examples:
        >>> from vigen.datasets import get_dataset
        >>> videos = get_dataset("dmcgb-videos")
        >>> videos.parts, len(videos.files), len(videos.files_of("video_hard"))
        (('video_easy', 'video_hard'), 110, 100)
    """
    if isinstance(name, DataSet):
        return name
    try:
        return DATASETS[name]
    except KeyError:
        raise UnknownDataSetError(f"unknown data set {name!r}; known data sets: {', '.join(DATASETS)}.") from None


def cache_root(root: str | os.PathLike | None = None) -> Path:
    """The folder that holds every fetched data set (not created here).

    ``root`` if given, else ``$VIGEN_DATA``, else ``$XDG_CACHE_HOME/vigen`` (when that is an
    absolute path), else ``~/.cache/vigen``.

    Examples:
        >>> import os
        >>> from vigen.datasets import cache_root
        >>> str(cache_root("/scratch/vigen"))
        '/scratch/vigen'
        >>> cache_root() == cache_root(os.environ["VIGEN_DATA"]) if os.environ.get("VIGEN_DATA") else True
        True
    """
    if root is not None:
        return Path(root).expanduser()
    if os.environ.get("VIGEN_DATA"):
        return Path(os.environ["VIGEN_DATA"]).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "vigen"
    return Path.home() / ".cache" / "vigen"


def dataset_folder(dataset: DataSet, root: str | os.PathLike | None = None) -> Path:
    """``<cache root>/<data set name>``: the folder a data set is fetched into.

    Examples:
        >>> from vigen.datasets import get_dataset
        >>> from vigen.datasets.records import dataset_folder
        >>> str(dataset_folder(get_dataset("dmcgb-videos"), "/scratch/vigen"))
        '/scratch/vigen/dmcgb-videos'
    """
    return cache_root(root) / dataset.name

"""The benchmarks' named data sets: records, cache, fetch, verify, and the ``python -m vigen.data`` command.

Large data the benchmarks use (DMC-GB's background videos, DAVIS 2017) is not shipped with
vigen: it is fetched into a cache folder by name, each file checked against a pinned id, and
found there by the levels::

    python -m vigen.data list
    python -m vigen.data fetch dmcgb-videos --part video_hard
    python -m vigen.data verify
    python -m vigen.data path dmcgb-videos --part video_hard

The stable API for code (the levels) is :func:`locate` / :func:`status` (cheap, no hashing),
:func:`fetch`, :func:`verify`, :func:`cache_root` and :data:`DATASETS`. This package imports only
the standard library (never torch, the envs, transforms or losses). See docs/data.md.

Examples:
    >>> import tempfile
    >>> import vigen.data
    >>> sorted(vigen.data.DATASETS)
    ['davis2017', 'dmcgb-videos', 'torchvision-resnet18']
    >>> vigen.data.locate("dmcgb-videos", part="video_hard", root=tempfile.mkdtemp()) is None  # not fetched there
    True
"""

from vigen.data.cache import cache_root
from vigen.data.catalog import DATASETS, get_dataset
from vigen.data.checksums import git_blob_id
from vigen.data.errors import (CorruptFileError, DataError, DownloadError, FetchError, IncompleteDownloadError, LayoutError,
                               MissingFileError, SourceUnreachableError, StandInDataWarning, UnknownDataSetError)
from vigen.data.fetch import fetch, fetch_command
from vigen.data.locate import PartStatus, locate, status
from vigen.data.progress import Progress
from vigen.data.records import Archive, ArchiveLayout, DataSet, PinnedFile
from vigen.data.verify import Mismatch, VerifyReport, verify

__all__ = [
    "DATASETS", "Archive", "ArchiveLayout", "CorruptFileError", "DataError", "DataSet", "DownloadError", "FetchError",
    "IncompleteDownloadError", "LayoutError", "Mismatch", "MissingFileError", "PartStatus", "PinnedFile", "Progress",
    "SourceUnreachableError", "StandInDataWarning", "UnknownDataSetError", "VerifyReport", "cache_root", "fetch", "fetch_command", "get_dataset",
    "git_blob_id", "locate", "status", "verify",
]

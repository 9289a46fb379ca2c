"""The benchmarks' named data sets: records, fetch, verify, and the ``python -m vigen.datasets`` command.

Large data the benchmarks use (DMC-GB's background videos, DAVIS 2017, torchvision's ResNet-18) is
not shipped with vigen: it is fetched into a cache folder by name, each file checked against a
pinned id, and found there by the levels::

    python -m vigen.datasets list
    python -m vigen.datasets fetch dmcgb-videos --part video_hard
    python -m vigen.datasets verify
    python -m vigen.datasets path dmcgb-videos --part video_hard

The stable API for code (the levels) is :func:`locate` / :func:`status` (cheap, no hashing),
:func:`fetch`, :func:`verify`, :func:`cache_root` and :data:`DATASETS`. Modules: ``records``
(what a data set is, the catalog, the cache folder, the errors), ``fetch`` (on pooch, with a lock
per data set and resumed downloads), ``verify`` (what the cache holds), ``identity`` (how rows
name the data a level showed) and ``__main__`` (the command). Importing this package imports the
standard library only (pooch and filelock load when a fetch starts). See docs/data.md.

Examples:
    >>> import tempfile
    >>> import vigen.datasets
    >>> sorted(vigen.datasets.DATASETS)
    ['davis2017', 'dmcgb-videos', 'torchvision-resnet18']
    >>> vigen.datasets.locate("dmcgb-videos", part="video_hard", root=tempfile.mkdtemp()) is None  # not fetched there
    True
"""

from vigen.datasets.fetch import (CorruptFileError, DownloadError, FetchError, Progress, ResumingDownloader, fetch,
                                  fetch_command)
from vigen.datasets.records import (DATASETS, Archive, ArchiveLayout, DataError, DataSet, PinnedFile, StandInDataWarning,
                                    UnknownDataSetError, cache_root, get_dataset)
from vigen.datasets.verify import Mismatch, PartStatus, VerifyReport, git_blob_id, locate, status, verify

__all__ = [
    "DATASETS", "Archive", "ArchiveLayout", "CorruptFileError", "DataError", "DataSet", "DownloadError", "FetchError",
    "Mismatch", "PartStatus", "PinnedFile", "Progress", "ResumingDownloader", "StandInDataWarning", "UnknownDataSetError",
    "VerifyReport", "cache_root", "fetch", "fetch_command", "get_dataset", "git_blob_id", "locate", "status", "verify",
]

"""The errors of :mod:`vigen.data`: each names the file, what was expected, what was got, and the fix."""

from __future__ import annotations

from collections.abc import Sequence


class DataError(Exception):
    """Base class of every error :mod:`vigen.data` raises on purpose.

    Examples:
        >>> from vigen.data.errors import DataError, MissingFileError
        >>> issubclass(MissingFileError, DataError)
        True
    """


class UnknownDataSetError(DataError, LookupError):
    """A data set name or part that no record has; the message lists the known ones.

    Examples:
        >>> from vigen.data import get_dataset
        >>> from vigen.data.errors import UnknownDataSetError
        >>> try:
        ...     get_dataset("dmcgb-video")
        ... except UnknownDataSetError as error:
        ...     print(str(error).split(";")[0])
        unknown data set 'dmcgb-video'
    """


class DownloadError(DataError, ConnectionError):
    """A transfer failed for a reason on the way (server unreachable, HTTP error, connection cut).

    Attributes:
        url: the address that was read.
        target: the file that was being written.

    Examples:
        >>> from vigen.data.errors import DownloadError
        >>> DownloadError("cut", url="http://host/a", target="/tmp/a").url
        'http://host/a'
    """

    def __init__(self, message: str, *, url: str, target: object) -> None:
        super().__init__(message)
        self.url = url
        self.target = target


class SourceUnreachableError(DownloadError):
    """The source or mirror cannot be reached at all (offline, refused, unknown host): no file can be fetched.

    Examples:
        >>> from vigen.data.errors import DownloadError, SourceUnreachableError
        >>> issubclass(SourceUnreachableError, DownloadError)
        True
    """


class IncompleteDownloadError(DownloadError):
    """The connection ended before the whole file came; the ``.part`` file is kept so the next fetch resumes.

    Examples:
        >>> from vigen.data.errors import IncompleteDownloadError
        >>> IncompleteDownloadError("cut", url="u", target="t").target
        't'
    """


class MissingFileError(DataError, FileNotFoundError):
    """The source or mirror does not have the file (HTTP 404, or absent from a mirror folder).

    Examples:
        >>> from vigen.data.errors import MissingFileError
        >>> error = MissingFileError("video3.mp4 is not at http://m/video3.mp4", url="http://m/video3.mp4", target="/c/video3.mp4")
        >>> error.url, isinstance(error, FileNotFoundError)
        ('http://m/video3.mp4', True)
    """

    def __init__(self, message: str, *, url: str, target: object) -> None:
        super().__init__(message)
        self.url = url
        self.target = target


class CorruptFileError(DataError, ValueError):
    """A file's content is not the pinned one (wrong size, git blob id or sha256); nothing was kept in its place.

    Attributes:
        path: the file (downloaded, or already in the cache).
        expected: what the record pins, e.g. ``"git blob 395d... (1164499 bytes)"``.
        got: what the file holds.

    Examples:
        >>> from vigen.data.errors import CorruptFileError
        >>> CorruptFileError("bad", path="/c/a", expected="sha256 00", got="sha256 11").got
        'sha256 11'
    """

    def __init__(self, message: str, *, path: object, expected: str, got: str) -> None:
        super().__init__(message)
        self.path = path
        self.expected = expected
        self.got = got


class LayoutError(DataError, ValueError):
    """An extracted archive lacks a part of the layout its data set needs (a listing, a folder, frames).

    Examples:
        >>> from vigen.data.errors import LayoutError
        >>> LayoutError("no DAVIS/ImageSets/2017/val.txt", missing=["DAVIS/ImageSets/2017/val.txt"]).missing
        ['DAVIS/ImageSets/2017/val.txt']
    """

    def __init__(self, message: str, *, missing: Sequence[str]) -> None:
        super().__init__(message)
        self.missing = list(missing)


class FetchError(DataError):
    """Some files of a fetch failed (listed, each with its own error); the files that passed their checks were kept.

    Attributes:
        failures: the error of each file that could not be fetched.

    Examples:
        >>> from vigen.data.errors import FetchError, MissingFileError
        >>> missing = MissingFileError("a.mp4 is not at http://m/a.mp4", url="http://m/a.mp4", target="/c/a.mp4")
        >>> len(FetchError("1 file failed", [missing]).failures)
        1
    """

    def __init__(self, message: str, failures: Sequence[DataError]) -> None:
        super().__init__(message)
        self.failures = list(failures)


class StandInDataWarning(UserWarning):
    """A level shows vigen's stand-ins because the benchmark's data is not in the cache; the message names the fetch command.

    Python's warning filter shows each such message once per process by default; evaluation rows
    and reports still name the stand-ins on every row.

    Examples:
        >>> from vigen.data.errors import StandInDataWarning
        >>> issubclass(StandInDataWarning, UserWarning)
        True
    """

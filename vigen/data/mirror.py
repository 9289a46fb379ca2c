"""Where a fetch reads from: the data set's original address, or a mirror standing in for it.

Mirror layout (an http(s) URL, a ``file://`` URL or a local folder)::

    <mirror>/<data set name>/<file's path in the data set>    pinned files, e.g. <mirror>/dmcgb-videos/video_hard/video0.mp4
    <mirror>/<data set name>/<archive file name>              archives, e.g. <mirror>/davis2017/DAVIS-2017-trainval-480p.zip

i.e. a mirror is laid out like the cache folder, with archives in place of their extracted folders.
"""

from __future__ import annotations

import os
import urllib.parse
import urllib.request
from pathlib import Path

from vigen.data.errors import DataError
from vigen.data.records import DataSet


def resolve_mirror(mirror: str | os.PathLike | None = None) -> str | None:
    """The mirror to read from: ``mirror`` if given, else ``$VIGEN_DATA_MIRROR``, else None (the original sources).

    An http(s) URL is returned without its trailing '/'; a local folder or ``file://`` URL is
    returned as an absolute ``file://`` URL and must exist. Anything else raises
    :class:`~vigen.data.errors.DataError` before any work starts.

    Examples:
        >>> import tempfile
        >>> from vigen.data.mirror import resolve_mirror
        >>> resolve_mirror("http://127.0.0.1:8000/vigen/")
        'http://127.0.0.1:8000/vigen'
        >>> resolve_mirror(tempfile.gettempdir()).startswith("file:///")
        True
    """
    origin = "the mirror argument"
    if mirror is None:
        mirror = os.environ.get("VIGEN_DATA_MIRROR") or None
        origin = "$VIGEN_DATA_MIRROR"
        if mirror is None:
            return None
    text = os.fspath(mirror)
    scheme = urllib.parse.urlsplit(text).scheme.lower() if "://" in text else ""
    if scheme in ("http", "https"):
        return text.rstrip("/")
    if scheme == "file":
        folder = Path(urllib.request.url2pathname(urllib.parse.urlsplit(text).path))
    elif scheme:
        raise DataError(f"mirror {text!r} ({origin}): use an http(s):// URL, a file:// URL or a local folder, not {scheme}://.")
    else:
        folder = Path(text).expanduser()
    if not folder.is_dir():
        raise DataError(
            f"mirror folder {folder} ({origin}) does not exist or is not a folder; a mirror holds "
            "<mirror>/<data set>/<file> (see docs/data.md)."
        )
    return folder.resolve().as_uri()


def source_url(dataset: DataSet, relative: str, mirror: str | None, original: str) -> str:
    """The address to read one file of ``dataset`` from: under the mirror if there is one, else ``original``.

    ``mirror`` is what :func:`resolve_mirror` returned; ``relative`` is the file's path in the
    data set (or the archive's file name).

    Examples:
        >>> from vigen.data import get_dataset
        >>> from vigen.data.mirror import source_url
        >>> videos = get_dataset("dmcgb-videos")
        >>> source_url(videos, "video_hard/video0.mp4", "http://127.0.0.1:8000", "unused")
        'http://127.0.0.1:8000/dmcgb-videos/video_hard/video0.mp4'
    """
    if mirror is None:
        return original
    return f"{mirror}/{urllib.parse.quote(dataset.name)}/{urllib.parse.quote(relative)}"

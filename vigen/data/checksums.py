"""The content ids files are checked against: git blob ids and sha256, read in chunks."""

from __future__ import annotations

import hashlib
import os
from pathlib import Path

CHUNK = 1 << 20


def git_blob_id(path: str | os.PathLike) -> str:
    """The file's git blob id, as ``git hash-object`` gives it: ``sha1(b"blob <size>\\0" + content)``.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data import git_blob_id
        >>> empty = Path(tempfile.mkdtemp()) / "empty"
        >>> _ = empty.write_bytes(b"")
        >>> git_blob_id(empty)
        'e69de29bb2d1d6434b8b29ae775ad8c2e48c5391'
    """
    path = Path(path)
    digest = hashlib.sha1(b"blob %d\0" % path.stat().st_size)
    with open(path, "rb") as file:
        for chunk in iter(lambda: file.read(CHUNK), b""):
            digest.update(chunk)
    return digest.hexdigest()


def git_blob_id_of_bytes(data: bytes) -> str:
    """The git blob id of ``data`` (what :func:`git_blob_id` gives for a file holding it).

    Examples:
        >>> from vigen.data.checksums import git_blob_id_of_bytes
        >>> git_blob_id_of_bytes(b"hello\\n")
        'ce013625030ba8dba906f756967f9e9ca394464a'
    """
    return hashlib.sha1(b"blob %d\0" % len(data) + data).hexdigest()


def sha256_file(path: str | os.PathLike) -> str:
    """The sha256 of a file's content, hex.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data.checksums import sha256_file
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

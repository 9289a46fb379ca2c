"""Archive data sets: safe extraction into a temporary folder, the layout check, and the checksum manifest.

The manifest (``<data set folder>/manifest.json``) is written at the first fetch: the archive's
name, address, size and sha256, and every extracted file's size and sha256. Later,
:func:`vigen.data.verify` checks the files against it and :func:`vigen.data.locate` checks that
they are all there with their sizes.
"""

from __future__ import annotations

import json
import os
import time
import zipfile
from pathlib import Path
from typing import Any

from vigen.data.checksums import sha256_file
from vigen.data.errors import CorruptFileError, DataError, LayoutError
from vigen.data.records import ArchiveLayout
from vigen.io import atomic_write

MANIFEST_NAME = "manifest.json"
"""The manifest's file name, in the data set's folder beside the extracted top folder."""


def check_layout(folder: str | os.PathLike, layout: ArchiveLayout, where: str | None = None) -> None:
    """Raise :class:`~vigen.data.errors.LayoutError` naming every missing piece unless ``folder`` holds ``layout``.

    Every required file must exist, every listing must list at least one item, and every listed
    item must match ``item_glob`` at least once.

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data.archive import check_layout
        >>> from vigen.data.records import ArchiveLayout
        >>> layout = ArchiveLayout("TOY", listings=("TOY/sets.txt",), item_glob="TOY/frames/{item}/*.jpg")
        >>> folder = Path(tempfile.mkdtemp())
        >>> (folder / "TOY/frames/bear").mkdir(parents=True)
        >>> _ = (folder / "TOY/sets.txt").write_text("bear\\ncat\\n")
        >>> _ = (folder / "TOY/frames/bear/00000.jpg").write_bytes(b"jpg")
        >>> try:
        ...     check_layout(folder, layout, "toy")
        ... except Exception as error:
        ...     print(error.missing)
        ['TOY/frames/cat/*.jpg']
    """
    folder = Path(folder)
    missing = [path for path in layout.required if not (folder / path).is_file()]
    for listing in layout.listings:
        if not (folder / listing).is_file():
            if listing not in missing:
                missing.append(listing)
            continue
        items = [line.strip() for line in (folder / listing).read_text(encoding="utf-8", errors="replace").splitlines()]
        items = [item for item in items if item]
        if not items:
            missing.append(f"{listing} (lists no item)")
        for item in items:
            pattern = layout.item_glob.format(item=item)  # type: ignore[union-attr]
            if "/" in item or item in (".", "..") or next(folder.glob(pattern), None) is None:
                missing.append(pattern)
    if missing:
        shown = ", ".join(missing[:10]) + (f" and {len(missing) - 10} more" if len(missing) > 10 else "")
        raise LayoutError(f"{where or folder} does not have the expected layout: missing {shown}.", missing=missing)


def extract_zip(archive: str | os.PathLike, into: str | os.PathLike) -> None:
    """Extract a zip archive into the folder ``into``, refusing members that would land outside it.

    A damaged archive raises :class:`~vigen.data.errors.CorruptFileError`; an absolute or ``..``
    member name raises :class:`~vigen.data.errors.DataError` before anything is written.

    Examples:
        >>> import tempfile, zipfile
        >>> from pathlib import Path
        >>> from vigen.data.archive import extract_zip
        >>> folder = Path(tempfile.mkdtemp())
        >>> with zipfile.ZipFile(folder / "a.zip", "w") as archive:
        ...     archive.writestr("TOY/a.txt", "a")
        >>> extract_zip(folder / "a.zip", folder / "out")
        >>> (folder / "out/TOY/a.txt").read_text()
        'a'
    """
    archive = Path(archive)
    try:
        with zipfile.ZipFile(archive) as opened:
            for member in opened.infolist():
                pieces = member.filename.replace("\\", "/").split("/")
                if member.filename.startswith(("/", "\\")) or ".." in pieces or ":" in pieces[0]:
                    raise DataError(f"{archive} holds a member named {member.filename!r} that would land outside the folder; refused.")
            opened.extractall(into)
    except (zipfile.BadZipFile, zipfile.LargeZipFile, EOFError) as error:
        raise CorruptFileError(
            f"{archive} is not a readable zip archive ({error}). Fix: delete it and re-run the fetch.",
            path=archive, expected="a zip archive", got=f"{type(error).__name__}: {error}",
        ) from error


def record_manifest(folder: str | os.PathLike, dataset: str, top: str, archive: dict[str, Any] | None) -> dict[str, Any]:
    """Hash every file under ``folder/top`` and write ``folder/manifest.json`` atomically; return the manifest.

    Args:
        folder: the data set's folder.
        dataset: the data set's name.
        top: the extracted top folder inside ``folder``.
        archive: ``{"file", "url", "sha256", "size"}`` of the archive the files came from, or None
            (files found already in place).

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data.archive import read_manifest, record_manifest
        >>> folder = Path(tempfile.mkdtemp())
        >>> (folder / "TOY").mkdir()
        >>> _ = (folder / "TOY/a.txt").write_text("abc")
        >>> manifest = record_manifest(folder, "toy", "TOY", None)
        >>> read_manifest(folder)["files"]["TOY/a.txt"]["size"]
        3
    """
    folder = Path(folder)
    files = {}
    for path in sorted((folder / top).rglob("*")):
        if path.is_file():
            files[path.relative_to(folder).as_posix()] = {"size": path.stat().st_size, "sha256": sha256_file(path)}
    manifest = {
        "dataset": dataset,
        "archive": archive,
        "recorded": time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
        "files": files,
    }
    atomic_write(folder / MANIFEST_NAME, json.dumps(manifest, indent=1, sort_keys=True) + "\n")
    return manifest


def read_manifest(folder: str | os.PathLike) -> dict[str, Any] | None:
    """The manifest in a data set's folder, or None when there is none yet.

    Examples:
        >>> import tempfile
        >>> from vigen.data.archive import read_manifest
        >>> read_manifest(tempfile.mkdtemp()) is None
        True
    """
    path = Path(folder) / MANIFEST_NAME
    if not path.is_file():
        return None
    try:
        manifest = json.loads(path.read_text(encoding="utf-8"))
    except (OSError, ValueError) as error:
        raise DataError(f"{path} cannot be read ({error}). Fix: move it aside and re-run the fetch to record it again.") from error
    if not isinstance(manifest, dict) or not isinstance(manifest.get("files"), dict):
        raise DataError(f"{path} is not a vigen.data manifest. Fix: move it aside and re-run the fetch to record it again.")
    return manifest


def manifest_size_mismatches(folder: str | os.PathLike, manifest: dict[str, Any]) -> list[str]:
    """The manifest's files that are missing from ``folder`` or have another size (no hashing: cheap).

    Examples:
        >>> import tempfile
        >>> from pathlib import Path
        >>> from vigen.data.archive import manifest_size_mismatches
        >>> folder = Path(tempfile.mkdtemp())
        >>> _ = (folder / "a.txt").write_text("abc")
        >>> manifest_size_mismatches(folder, {"files": {"a.txt": {"size": 3}, "b.txt": {"size": 1}}})
        ['b.txt']
    """
    folder = Path(folder)
    changed = []
    for relative, entry in manifest["files"].items():
        try:
            if (folder / relative).stat().st_size != entry["size"]:
                changed.append(relative)
        except OSError:
            changed.append(relative)
    return changed

"""davis2017 through a mirror serving a small synthetic zip in DAVIS's layout: record at first fetch, verify after."""

from __future__ import annotations

import hashlib
import json
import shutil
import zipfile
from pathlib import Path

import pytest

from vigen.data import CorruptFileError, DataError, LayoutError, fetch, locate, status, verify

ZIP = "DAVIS-2017-trainval-480p.zip"
LAYOUT = {
    "DAVIS/ImageSets/2017/train.txt": b"bear\ncamel\n",
    "DAVIS/ImageSets/2017/val.txt": b"dog\n",
    "DAVIS/JPEGImages/480p/bear/00000.jpg": b"\xff\xd8bear0",
    "DAVIS/JPEGImages/480p/bear/00001.jpg": b"\xff\xd8bear1",
    "DAVIS/JPEGImages/480p/camel/00000.jpg": b"\xff\xd8camel0",
    "DAVIS/JPEGImages/480p/dog/00000.jpg": b"\xff\xd8dog0",
    "DAVIS/Annotations/480p/dog/00000.png": b"\x89PNGdog0",
    "DAVIS/README.md": b"synthetic DAVIS for tests\n",
}


def _serve_zip(server, members: dict[str, bytes]) -> bytes:
    path = server.folder / "davis2017" / ZIP
    path.parent.mkdir(parents=True, exist_ok=True)
    with zipfile.ZipFile(path, "w") as archive:
        for name, data in members.items():
            archive.writestr(name, data)
    return path.read_bytes()


def _cache_files(folder: Path) -> list[str]:
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")) if folder.exists() else []


def test_first_fetch_records_the_checksums_and_later_fetches_reuse_them(server, isolated_cache):
    archive = _serve_zip(server, LAYOUT)
    stages = []
    folder = fetch("davis2017", mirror=server.url, progress=lambda event: stages.append(event.stage))
    assert folder == isolated_cache / "davis2017" == locate("davis2017")
    assert server.requests == [(f"/davis2017/{ZIP}", None)]
    for name, data in LAYOUT.items():
        assert (folder / name).read_bytes() == data
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["archive"] == {"file": ZIP, "url": f"{server.url}/davis2017/{ZIP}",
                                   "sha256": hashlib.sha256(archive).hexdigest(), "size": len(archive)}
    assert manifest["files"] == {name: {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}
                                 for name, data in LAYOUT.items()}
    assert not (folder / ZIP).exists() and not list(folder.glob(".extract-*"))  # archive removed, no staging left
    assert stages[-3:] == ["extract", "record", "done"]
    assert [(s.part, s.present, s.expected) for s in status("davis2017")] == [(None, len(LAYOUT), len(LAYOUT))]
    assert verify("davis2017").ok and len(verify("davis2017").checked) == len(LAYOUT)

    fetch("davis2017", mirror=server.url)  # present: nothing requested
    assert len(server.requests) == 1

    changed = folder / "DAVIS/JPEGImages/480p/bear/00001.jpg"
    changed.write_bytes(b"\xff\xd8BEAR1")  # same size: only verify (hashing) sees it
    report = verify("davis2017")
    assert not report.ok and [m.path for m in report.mismatched] == ["DAVIS/JPEGImages/480p/bear/00001.jpg"]
    assert locate("davis2017") == folder

    # the extracted folder removed, the manifest kept: a re-fetch is checked against the recorded sha256
    shutil.rmtree(folder / "DAVIS")
    _serve_zip(server, {**LAYOUT, "DAVIS/README.md": b"another archive\n"})
    with pytest.raises(CorruptFileError) as caught:
        fetch("davis2017", mirror=server.url)
    assert f"expected sha256 {hashlib.sha256(archive).hexdigest()}" in str(caught.value) and "Nothing was kept" in str(caught.value)
    assert _cache_files(folder) == ["manifest.json"]


@pytest.mark.parametrize("drop, missing", [
    ("DAVIS/ImageSets/2017/val.txt", ["DAVIS/ImageSets/2017/val.txt"]),
    ("DAVIS/JPEGImages/480p/dog/00000.jpg", ["DAVIS/JPEGImages/480p/dog/*.jpg"]),
])
def test_a_bad_layout_is_refused_naming_the_missing_part_and_nothing_is_kept(server, isolated_cache, drop, missing):
    _serve_zip(server, {name: data for name, data in LAYOUT.items() if name != drop})
    with pytest.raises(LayoutError) as caught:
        fetch("davis2017", mirror=server.url)
    assert caught.value.missing == missing and missing[0] in str(caught.value) and "It was removed" in str(caught.value)
    assert _cache_files(isolated_cache / "davis2017") == []
    assert locate("davis2017") is None


def test_an_expected_sha256_is_checked_before_extraction(server, isolated_cache):
    archive = _serve_zip(server, LAYOUT)
    with pytest.raises(CorruptFileError) as caught:
        fetch("davis2017", mirror=server.url, sha256="ab" * 32)
    assert caught.value.expected == f"sha256 {'ab' * 32}" and caught.value.got == f"sha256 {hashlib.sha256(archive).hexdigest()}"
    assert _cache_files(isolated_cache / "davis2017") == []
    assert fetch("davis2017", mirror=server.url, sha256=hashlib.sha256(archive).hexdigest().upper()) == locate("davis2017")


def test_an_extracted_folder_already_in_place_is_recorded_without_downloading(server, isolated_cache):
    for name, data in LAYOUT.items():
        (isolated_cache / "davis2017" / name).parent.mkdir(parents=True, exist_ok=True)
        (isolated_cache / "davis2017" / name).write_bytes(data)
    assert fetch("davis2017", mirror=server.url) == locate("davis2017") and server.requests == []
    manifest = json.loads((isolated_cache / "davis2017/manifest.json").read_text())
    assert manifest["archive"] is None and len(manifest["files"]) == len(LAYOUT)
    assert "files recorded in place" in str(verify("davis2017"))


def test_an_archive_with_a_member_outside_its_folder_is_refused(server, isolated_cache):
    _serve_zip(server, {**LAYOUT, "../escape.txt": b"x"})
    with pytest.raises(DataError, match="'../escape.txt' that would land outside"):
        fetch("davis2017", mirror=server.url)
    assert not (isolated_cache / "escape.txt").exists() and not list((isolated_cache / "davis2017").glob("DAVIS"))

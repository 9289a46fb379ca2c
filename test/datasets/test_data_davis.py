"""davis2017 through a mirror serving a small made-up zip in DAVIS's layout: refused under the real pin (TensorFlow
Datasets' sha256 and size), fetched under a pin the test injects for its own archive, and checked after."""

from __future__ import annotations

import hashlib
import json
import shutil

import pytest

from vigen.datasets import DATASETS, CorruptFileError, fetch, locate, status, verify
from vigen.datasets.__main__ import main

ZIP = "DAVIS-2017-trainval-480p.zip"
TFDS_SHA256 = "e3d0b5b77c3d031b000a19e0e25e3e2cac65d183755601bc2cf066df1a2aa492"


def _cache_files(folder):
    """The files a fetch left in ``folder`` (the lock file aside)."""
    return sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*")
                  if p.is_file() and p.name != ".fetch.lock") if folder.exists() else []


def test_davis_is_pinned_to_the_archive_tensorflow_datasets_records():
    """tensorflow/datasets, tensorflow_datasets/video/davis/checksums.tsv: URL, 832766765 bytes, that sha256."""
    archive = DATASETS["davis2017"].archive
    assert (archive.file_name, archive.size, archive.sha256) == (ZIP, 832_766_765, TFDS_SHA256)
    assert archive.url == f"https://data.vision.ee.ethz.ch/csergi/share/davis/{ZIP}"
    assert "tensorflow_datasets/video/davis/checksums.tsv" in archive.pinned_by


def test_a_made_up_zip_from_a_mirror_is_refused_under_the_real_pin(server, served_davis, isolated_cache, capsys):
    """The issue's case: a mirror serving another zip under DAVIS's name. It must not be accepted, nor become a reference."""
    served_davis(pin=False)
    assert main(["fetch", "davis2017", "--mirror", server.url]) == 1
    err = capsys.readouterr().err
    error = [line for line in err.splitlines() if line.startswith("error: ")]
    assert len(error) == 1 and "Traceback" not in err
    assert f"serves {len((server.folder / 'davis2017' / ZIP).read_bytes())} bytes, expected sha256 {TFDS_SHA256} " \
           "(832766765 bytes), as TensorFlow Datasets" in error[0]
    assert "Nothing was kept" in error[0] and "Fix: the source or mirror holds another file under this name" in error[0]
    assert "in place" not in err and "checked" not in err
    assert _cache_files(isolated_cache / "davis2017") == [] and locate("davis2017") is None


def test_a_zip_of_the_pinned_size_with_other_bytes_is_refused_by_its_sha256(server, served_davis, isolated_cache,
                                                                             monkeypatch):
    archive = served_davis()
    other = bytearray(archive)
    other[-30] ^= 0xFF  # same size, one byte changed
    (server.folder / "davis2017" / ZIP).write_bytes(bytes(other))
    with pytest.raises(CorruptFileError) as caught:
        fetch("davis2017", mirror=server.url)
    pin = DATASETS["davis2017"].archive
    assert caught.value.got == f"sha256 {hashlib.sha256(other).hexdigest()}"
    assert f"expected sha256 {pin.sha256} ({pin.size} bytes), as this test records it" in str(caught.value)
    assert _cache_files(isolated_cache / "davis2017") == [] and locate("davis2017") is None


def test_the_pinned_archive_is_extracted_recorded_and_checked(server, served_davis, isolated_cache, davis_layout):
    archive = served_davis()
    stages = []
    folder = fetch("davis2017", mirror=server.url, progress=lambda event: stages.append((event.stage, event.message)))
    assert folder == isolated_cache / "davis2017" == locate("davis2017")
    assert server.requests == [(f"/davis2017/{ZIP}", None)]
    for name, data in davis_layout.items():
        assert (folder / name).read_bytes() == data
    manifest = json.loads((folder / "manifest.json").read_text())
    assert manifest["archive"] == {"file": ZIP, "url": f"{server.url}/davis2017/{ZIP}",
                                   "sha256": hashlib.sha256(archive).hexdigest(), "size": len(archive)}
    assert manifest["files"] == {name: {"size": len(data), "sha256": hashlib.sha256(data).hexdigest()}
                                 for name, data in davis_layout.items()}
    assert _cache_files(folder) == sorted(["manifest.json", *davis_layout])  # the archive removed, no staging folder left
    assert [stage for stage, _ in stages[-3:]] == ["extract", "record", "done"]
    assert stages[-1][1].startswith("extracted from the pinned archive")
    assert [(s.part, s.present, s.expected) for s in status("davis2017")] == [(None, len(davis_layout), len(davis_layout))]
    report = verify("davis2017")
    assert report.ok and len(report.checked) == len(davis_layout) and "extracted from the pinned archive" in report.notes[0]

    stages.clear()
    fetch("davis2017", mirror=server.url, progress=lambda event: stages.append((event.stage, event.message)))
    assert len(server.requests) == 1 and stages == [("present", "in place, from the pinned archive")]

    changed = folder / "DAVIS/JPEGImages/480p/bear/00001.jpg"
    changed.write_bytes(b"\xff\xd8BEAR1")  # same size: only verify (hashing) sees it
    report = verify("davis2017")
    assert not report.ok and [m.path for m in report.mismatched] == ["DAVIS/JPEGImages/480p/bear/00001.jpg"]
    assert locate("davis2017") == folder

    # the extracted folder removed, the manifest kept: a re-fetch is checked against the pin again
    shutil.rmtree(folder / "DAVIS")
    (server.folder / "davis2017" / ZIP).write_bytes(archive[::-1])  # same size, other bytes
    with pytest.raises(CorruptFileError, match="Nothing was kept"):
        fetch("davis2017", mirror=server.url)
    assert _cache_files(folder) == ["manifest.json"]


def test_a_manifest_recorded_from_another_archive_is_a_mismatch_and_not_taken_as_present(server, served_davis,
                                                                                          isolated_cache, capsys):
    """What an earlier vigen left when it recorded whatever archive its first fetch got."""
    served_davis()
    folder = fetch("davis2017", mirror=server.url)
    manifest = json.loads((folder / "manifest.json").read_text())
    manifest["archive"]["sha256"] = "ab" * 32
    (folder / "manifest.json").write_text(json.dumps(manifest))
    report = verify("davis2017")
    assert not report.ok and report.mismatched[0].path == ZIP and "did not check the pin" in report.mismatched[0].got
    with pytest.raises(CorruptFileError, match=f"from an archive with sha256 {'ab' * 32}, not the pinned"):
        fetch("davis2017", mirror=server.url)
    assert main(["verify", "davis2017"]) == 1
    assert "error: davis2017: files that are not the pinned ones" in capsys.readouterr().err


@pytest.mark.parametrize("drop, missing", [
    ("DAVIS/ImageSets/2017/val.txt", "DAVIS/ImageSets/2017/val.txt"),
    ("DAVIS/JPEGImages/480p/dog/00000.jpg", "DAVIS/JPEGImages/480p/dog/*.jpg"),
])
def test_a_pinned_archive_without_the_layout_is_refused_naming_the_missing_part(server, served_davis, isolated_cache, drop,
                                                                                 missing, davis_layout):
    served_davis({name: data for name, data in davis_layout.items() if name != drop})
    with pytest.raises(CorruptFileError) as caught:
        fetch("davis2017", mirror=server.url)
    assert caught.value.got == f"missing {missing}" and "It was removed" in str(caught.value)
    assert _cache_files(isolated_cache / "davis2017") == [] and locate("davis2017") is None


def test_an_extracted_folder_already_in_place_is_recorded_as_not_the_pinned_archive(server, isolated_cache, capsys, davis_layout):
    for name, data in davis_layout.items():
        (isolated_cache / "davis2017" / name).parent.mkdir(parents=True, exist_ok=True)
        (isolated_cache / "davis2017" / name).write_bytes(data)
    assert main(["fetch", "davis2017", "--mirror", server.url]) == 0 and server.requests == []
    err = capsys.readouterr().err
    assert "not the pinned archive, so evaluation rows name it `not verified`" in err and ": in place, checked" not in err
    manifest = json.loads((isolated_cache / "davis2017/manifest.json").read_text())
    assert manifest["archive"] is None and len(manifest["files"]) == len(davis_layout) and locate("davis2017")
    report = verify("davis2017")
    assert report.ok and "files recorded in place, not from the pinned archive" in report.notes[0]


def test_the_pinned_archive_placed_in_the_cache_by_hand_is_used_and_kept(server, served_davis, isolated_cache):
    archive = served_davis()
    (isolated_cache / "davis2017").mkdir(parents=True)
    (isolated_cache / "davis2017" / ZIP).write_bytes(archive)
    assert fetch("davis2017", mirror=server.url) == locate("davis2017") and server.requests == []
    assert (isolated_cache / "davis2017" / ZIP).read_bytes() == archive
    (isolated_cache / "davis2017" / ZIP).write_bytes(archive[::-1])
    shutil.rmtree(isolated_cache / "davis2017" / "DAVIS")
    with pytest.raises(CorruptFileError, match="is already in the cache but is not the pinned"):
        fetch("davis2017", mirror=server.url)
    assert (isolated_cache / "davis2017" / ZIP).read_bytes() == archive[::-1], "left as it is"


def test_an_archive_with_a_member_outside_its_folder_is_refused(server, served_davis, isolated_cache, davis_layout):
    served_davis({**davis_layout, "../escape.txt": b"x"})
    with pytest.raises(CorruptFileError, match="'../escape.txt' that would land outside"):
        fetch("davis2017", mirror=server.url)
    assert not (isolated_cache / "escape.txt").exists() and not list((isolated_cache / "davis2017").glob("DAVIS"))

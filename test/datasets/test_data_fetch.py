"""Fetching pinned files over HTTP: checks, resume, restart, stale partial files, faults, offline, and what is left on disk."""

from __future__ import annotations

import socket
from pathlib import Path

import pytest

from vigen.datasets import (CorruptFileError, DataError, DownloadError, FetchError, UnknownDataSetError, fetch, locate, status,
                            verify)

CLIP = bytes(range(256)) * 40  # 10240 bytes
OTHER = b"other clip " * 300


def _files(root: Path) -> list[str]:
    """The files under ``root`` (each data set's lock file aside)."""
    return sorted(p.relative_to(root).as_posix() for p in root.rglob("*") if p.is_file() and p.name != ".fetch.lock")


def test_fetch_checks_each_file_and_does_not_download_present_ones_again(server, isolated_cache, make_toy):
    toy = make_toy(server.folder, {"easy/a.bin": CLIP, "hard/b.bin": OTHER, "hard/c.bin": b"c"})
    events = []
    assert fetch(toy, part="hard", mirror=server.url, progress=events.append) == isolated_cache / "toy/hard"
    assert _files(isolated_cache) == ["toy/hard/b.bin", "toy/hard/c.bin"]
    assert (isolated_cache / "toy/hard/b.bin").read_bytes() == OTHER
    assert [(e.file, e.index, e.count) for e in events if e.stage == "done"] == [("hard/b.bin", 1, 2), ("hard/c.bin", 2, 2)]
    assert locate(toy, "hard") == isolated_cache / "toy/hard" and locate(toy) is None and locate(toy, "easy") is None
    assert [(s.part, s.present, s.expected, s.complete) for s in status(toy)] == [("easy", 0, 1, False), ("hard", 2, 2, True)]

    server.requests.clear()
    events.clear()
    fetch(toy, mirror=server.url, progress=events.append)
    assert server.requests == [("/toy/easy/a.bin", None)]  # only the missing file was requested
    assert [e.file for e in events if e.stage == "present"] == ["hard/b.bin", "hard/c.bin"]
    assert locate(toy) == isolated_cache / "toy" and verify(toy).ok and len(verify(toy).checked) == 3


def test_a_cut_connection_keeps_the_part_and_the_next_fetch_resumes_with_the_right_range(server, isolated_cache, make_toy):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP})
    server.faults["/toy/hard/a.bin"] = "cut_once"
    with pytest.raises(FetchError) as caught:
        fetch(toy, mirror=server.url)
    (error,) = caught.value.failures
    assert isinstance(error, DownloadError) and error.reason == "incomplete"
    assert "5120 of 10240 bytes" in str(error) and "hard/a.bin" in str(error) and "resume" in str(error)
    target = isolated_cache / "toy/hard/a.bin"
    assert not target.exists() and Path(str(target) + ".part").read_bytes() == CLIP[:5120]

    events = []
    fetch(toy, mirror=server.url, progress=events.append)
    assert server.requests[-1] == ("/toy/hard/a.bin", "bytes=5120-")
    assert target.read_bytes() == CLIP and not Path(str(target) + ".part").exists()
    assert any(e.stage == "resume" and e.message == "resuming at byte 5120" for e in events)


def test_a_server_ignoring_range_restarts_the_file_cleanly(server, isolated_cache, make_toy):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP})
    server.faults["/toy/hard/a.bin"] = "cut_once"
    with pytest.raises(FetchError):
        fetch(toy, mirror=server.url)
    server.faults["/toy/hard/a.bin"] = "ignore_range"
    events = []
    fetch(toy, mirror=server.url, progress=events.append)
    assert server.requests[-1] == ("/toy/hard/a.bin", "bytes=5120-")  # asked to resume, got the whole file
    assert (isolated_cache / "toy/hard/a.bin").read_bytes() == CLIP  # not the first half twice
    assert [e.stage for e in events if e.stage in ("restart", "done")] == ["restart", "done"]


def test_wrong_bytes_raise_a_corrupt_error_and_leave_no_file(server, isolated_cache, make_toy, git_blob):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP, "hard/b.bin": OTHER})
    server.faults["/toy/hard/a.bin"] = "wrong"
    with pytest.raises(FetchError) as caught:
        fetch(toy, mirror=server.url)
    (error,) = caught.value.failures
    assert isinstance(error, CorruptFileError)
    got = git_blob(bytes(byte ^ 0xFF for byte in CLIP))
    assert error.expected == f"git blob {git_blob(CLIP)} (10240 bytes)" and error.got == f"git blob {got} (10240 bytes)"
    for text in ("toy/hard/a.bin", git_blob(CLIP), got, f"{server.url}/toy/hard/a.bin", "Nothing was kept",
                 f"Fix: the source or mirror holds another file under this name; check {server.url}/toy/hard/a.bin, then re-run "
                 "`python -m vigen.datasets fetch toy"):
        assert text in str(caught.value)
    assert _files(isolated_cache) == ["toy/hard/b.bin"]  # the good file stays, no .part of the bad one


def test_a_missing_file_is_named_with_its_url_and_the_others_are_kept(server, isolated_cache, make_toy):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP, "hard/b.bin": OTHER})
    (server.folder / "toy/hard/b.bin").unlink()
    with pytest.raises(FetchError) as caught:
        fetch(toy, "hard", mirror=server.url)
    (error,) = caught.value.failures
    assert isinstance(error, DownloadError) and error.reason == "missing" and error.url == f"{server.url}/toy/hard/b.bin"
    message = str(caught.value)
    assert "1 of the 2 files of toy part hard could not be fetched" in message
    assert f"hard/b.bin: toy/hard/b.bin is not at {server.url}/toy/hard/b.bin (HTTP 404)" in message
    assert f"copy the file to {isolated_cache / 'toy'}/<file>" in message
    assert _files(isolated_cache) == ["toy/hard/a.bin"] and locate(toy, "hard") is None


def test_a_wrong_size_announced_by_the_server_is_refused_before_downloading(server, isolated_cache, make_toy):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP})
    (server.folder / "toy/hard/a.bin").write_bytes(CLIP + b"extra")
    with pytest.raises(FetchError) as caught:
        fetch(toy, mirror=server.url)
    assert f"serves 10245 bytes, expected git blob {toy.files[0].git_blob} (10240 bytes)" in str(caught.value)
    assert _files(isolated_cache) == []


def test_offline_names_the_url_and_the_fix(isolated_cache, make_toy):
    with socket.socket() as probe:  # a port nothing listens on
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    toy = make_toy(isolated_cache.parent / "unused", {"hard/a.bin": CLIP, "hard/b.bin": OTHER})
    with pytest.raises(DownloadError) as caught:
        fetch(toy, mirror=f"http://127.0.0.1:{port}")
    assert caught.value.reason == "unreachable"
    message = str(caught.value)
    assert f"cannot reach http://127.0.0.1:{port}/toy/hard/a.bin" in message
    assert "--mirror / $VIGEN_DATA_MIRROR" in message and f"copy the file to {isolated_cache / 'toy/hard/a.bin'}" in message
    assert _files(isolated_cache) == []  # stopped at the first file: nothing half-written


def test_a_wrong_file_already_in_the_cache_is_not_overwritten(server, isolated_cache, make_toy):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP})
    mine = isolated_cache / "toy/hard/a.bin"
    mine.parent.mkdir(parents=True)
    mine.write_bytes(b"my own file")
    with pytest.raises(FetchError) as caught:
        fetch(toy, mirror=server.url)
    assert "already in the cache but is not toy/hard/a.bin" in str(caught.value) and "left as it is" in str(caught.value)
    assert mine.read_bytes() == b"my own file" and server.requests == []


def test_a_local_folder_mirror_from_the_environment(tmp_path, monkeypatch, isolated_cache, make_toy):
    toy = make_toy(tmp_path / "mirror", {"hard/a.bin": CLIP})
    monkeypatch.setenv("VIGEN_DATA_MIRROR", (tmp_path / "mirror").as_uri())
    assert fetch(toy, "hard") == isolated_cache / "toy/hard"
    assert (isolated_cache / "toy/hard/a.bin").read_bytes() == CLIP
    (tmp_path / "mirror/toy/hard/a.bin").unlink()
    (isolated_cache / "toy/hard/a.bin").unlink()
    with pytest.raises(FetchError) as caught:
        fetch(toy, "hard", root=tmp_path / "other")
    assert f"{tmp_path / 'mirror/toy/hard/a.bin'} does not exist" in str(caught.value)


def test_clear_errors_before_any_work(tmp_path, isolated_cache, make_toy):
    toy = make_toy(tmp_path / "mirror", {"hard/a.bin": CLIP})
    with pytest.raises(UnknownDataSetError, match="has no part 'medium'; its parts: hard"):
        fetch(toy, "medium", mirror=tmp_path / "mirror")
    with pytest.raises(UnknownDataSetError, match="known data sets: dmcgb-videos, davis2017"):
        fetch("dmcgb")
    with pytest.raises(Exception, match="mirror folder .*nowhere .the mirror argument. does not exist"):
        fetch(toy, mirror=tmp_path / "nowhere")
    with pytest.raises(Exception, match="not ftp://"):
        fetch(toy, mirror="ftp://example.org/data")
    with pytest.raises(DataError, match="wait is seconds to wait"):
        fetch(toy, mirror=tmp_path / "mirror", wait=-1)
    assert not isolated_cache.exists()


def test_verify_names_a_changed_file(server, isolated_cache, make_toy, git_blob):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP, "easy/b.bin": OTHER})
    fetch(toy, "hard", mirror=server.url)
    (isolated_cache / "toy/hard/a.bin").write_bytes(CLIP[::-1])
    report = verify(toy)
    assert not report.ok and report.absent == ("easy/b.bin",) and report.checked == ()
    assert str(report.mismatched[0]) == (f"hard/a.bin: expected git blob {git_blob(CLIP)} (10240 bytes), "
                                         f"got git blob {git_blob(CLIP[::-1])} (10240 bytes)")
    assert locate(toy, "hard") == isolated_cache / "toy/hard"  # locate is cheap: sizes only


@pytest.mark.parametrize("stale", ["whole", "half"])
def test_a_stale_part_with_other_bytes_does_not_make_a_good_mirror_file_corrupt(server, isolated_cache, make_toy, stale):
    """A ``.part`` left by another source or an older run (here: other bytes) is resumed, fails its check, and the file is
    then downloaded whole, once, from byte 0: the mirror's good file is not called corrupt."""
    toy = make_toy(server.folder, {"hard/a.bin": CLIP})
    part = isolated_cache / "toy/hard/a.bin.part"
    part.parent.mkdir(parents=True)
    stale_bytes = CLIP[::-1] if stale == "whole" else CLIP[::-1][:len(CLIP) // 2]
    part.write_bytes(stale_bytes)
    events = []
    assert fetch(toy, mirror=server.url, progress=events.append) == isolated_cache / "toy"
    assert (isolated_cache / "toy/hard/a.bin").read_bytes() == CLIP and not part.exists()
    ranges = [header for path, header in server.requests]
    assert ranges == ([None] if stale == "whole" else [f"bytes={len(CLIP) // 2}-", None])  # a whole .part is only checked
    (restart,) = [event for event in events if event.stage == "restart"]
    assert restart.message == f"the file resumed at byte {len(stale_bytes)} failed its check; downloading it whole"
    assert [event.stage for event in events][-1] == "done" and not [event for event in events if event.stage == "failed"]


def test_a_file_that_fails_again_when_downloaded_whole_is_corrupt(server, isolated_cache, make_toy, git_blob):
    toy = make_toy(server.folder, {"hard/a.bin": CLIP})
    part = isolated_cache / "toy/hard/a.bin.part"
    part.parent.mkdir(parents=True)
    part.write_bytes(CLIP[:100])
    server.faults["/toy/hard/a.bin"] = "wrong"
    with pytest.raises(FetchError) as caught:
        fetch(toy, mirror=server.url)
    (error,) = caught.value.failures
    assert isinstance(error, CorruptFileError) and [h for _, h in server.requests] == ["bytes=100-", None]
    assert not part.exists() and _files(isolated_cache) == []

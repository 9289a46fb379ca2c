"""Every failure of ``python -m vigen.datasets`` ends in one ``error:`` message that names the fix, with its exit status, and
never in a traceback: impossible and unwritable cache folders, a full disk, mirrors, the network, corrupt and changed files,
another fetch holding the data set, an unreadable manifest, an interrupt, and usage errors."""

from __future__ import annotations

import errno
import os
import socket
import subprocess
import sys
from pathlib import Path

import pytest

import vigen.datasets
from vigen.datasets.__main__ import main
from vigen.datasets.fetch import ResumingDownloader

CLIP = b"clip bytes " * 100
ROOT = Path(__file__).parents[2]


@pytest.fixture
def toy(server, make_toy, monkeypatch):
    """A test-made data set registered under the name 'toy', served by the test server."""
    record = make_toy(server.folder, {"hard/a.bin": CLIP, "hard/b.bin": CLIP[::-1]})
    monkeypatch.setitem(vigen.datasets.DATASETS, "toy", record)
    return record


def one_error(capsys, fix: str | None = "Fix: ") -> str:
    """The command's stderr holds exactly one ``error:`` message (it may span lines), naming the fix; returned."""
    err = capsys.readouterr().err
    assert err.count("error: ") == 1 and "Traceback" not in err, err
    message = err[err.index("error: "):]
    if fix is not None:
        assert fix in message, message
    return message


def test_a_root_that_is_a_file(toy, server, tmp_path, capsys):
    (tmp_path / "a-file").write_text("not a folder")
    assert main(["fetch", "toy", "--mirror", server.url, "--root", str(tmp_path / "a-file")]) == 1
    message = one_error(capsys, "Fix: fetch into a folder you can write (--root DIR or $VIGEN_DATA), then re-run")
    assert f"cannot fetch toy into {tmp_path / 'a-file' / 'toy'}: " in message


def test_a_root_that_cannot_be_made(toy, server, capsys):
    assert main(["fetch", "toy", "--mirror", server.url, "--root", "/proc/vigen-cache"]) == 1
    assert "cannot fetch toy into /proc/vigen-cache/toy: " in one_error(capsys, "Fix: fetch into a folder you can write")


def test_an_unwritable_root(toy, server, tmp_path, capsys, monkeypatch):
    """The issue's raw PermissionError (``fetch.py:82``), raised where the cache folder is made (the tests may run as
    root, who may write anywhere, so the error is raised for them)."""
    def refuse(self, *args, **kwargs):
        raise PermissionError(errno.EACCES, "Permission denied", str(self))

    monkeypatch.setattr(Path, "mkdir", refuse)
    assert main(["fetch", "toy", "--mirror", server.url, "--root", str(tmp_path / "locked")]) == 1
    message = one_error(capsys, "Fix: fetch into a folder you can write (--root DIR or $VIGEN_DATA)")
    assert f"Permission denied ({tmp_path / 'locked' / 'toy'})" in message


@pytest.mark.skipif(os.geteuid() == 0, reason="root may write into a read-only folder")
def test_a_read_only_root(toy, server, tmp_path, capsys):
    (tmp_path / "read-only").mkdir(mode=0o500)
    assert main(["fetch", "toy", "--mirror", server.url, "--root", str(tmp_path / "read-only")]) == 1
    assert "Permission denied" in one_error(capsys, "Fix: fetch into a folder you can write")


def test_a_full_disk(toy, server, capsys, monkeypatch):
    def full(self, *args, **kwargs):
        raise OSError(errno.ENOSPC, "No space left on device", str(self.part))

    monkeypatch.setattr(ResumingDownloader, "_stream_into", full)
    assert main(["fetch", "toy", "--mirror", server.url]) == 1
    assert "No space left on device" in one_error(capsys, "Fix: free space there, or fetch into another folder")


def test_a_root_given_in_the_environment_that_is_a_file(toy, server, tmp_path, capsys, monkeypatch):
    (tmp_path / "a-file").write_text("")
    monkeypatch.setenv("VIGEN_DATA", str(tmp_path / "a-file"))
    assert main(["fetch", "toy", "--mirror", server.url]) == 1
    one_error(capsys, "(--root DIR or $VIGEN_DATA)")


def test_a_mirror_folder_that_does_not_exist(toy, tmp_path, capsys):
    assert main(["fetch", "toy", "--mirror", str(tmp_path / "nowhere")]) == 1
    assert "does not exist or is not a folder" in one_error(capsys, "Fix: give the folder that holds")


def test_a_mirror_nothing_answers(toy, capsys):
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        port = probe.getsockname()[1]
    assert main(["fetch", "toy", "--mirror", f"http://127.0.0.1:{port}"]) == 1
    assert f"cannot reach http://127.0.0.1:{port}/toy/hard/a.bin" in one_error(capsys, "Fix: check the network, or use a mirror")


def test_corrupt_files(toy, server, capsys):
    server.faults["/toy/hard/a.bin"] = "wrong"
    assert main(["fetch", "toy", "--mirror", server.url]) == 1
    message = one_error(capsys, "Fix: the source or mirror holds another file under this name")
    assert "1 of the 2 files of toy could not be fetched" in message and "is not the pinned file" in message


def test_a_wrong_file_already_in_the_cache_and_verify(toy, server, isolated_cache, capsys):
    (isolated_cache / "toy/hard").mkdir(parents=True)
    (isolated_cache / "toy/hard/a.bin").write_bytes(b"mine")
    assert main(["fetch", "toy", "--mirror", server.url]) == 1
    assert "already in the cache but is not toy/hard/a.bin" in one_error(capsys, "Fix: move it aside or delete it")
    assert main(["verify", "toy"]) == 1
    assert "error: toy: files that are not the pinned ones" in one_error(capsys, "Fix: move them aside, then re-run")


def test_another_fetch_holds_the_data_set(toy, server, isolated_cache, capsys):
    from filelock import FileLock

    (isolated_cache / "toy").mkdir(parents=True)
    (isolated_cache / "toy/.fetch.holder").write_text("pid 4242 on node7 since 2026-01-01 10:00:00\n")
    with FileLock(str(isolated_cache / "toy/.fetch.lock")):
        holder = subprocess.run([sys.executable, "-c", (
            "import sys, vigen.datasets as d; from vigen.datasets import PinnedFile; from vigen.datasets.__main__ import main; "
            f"d.DATASETS['toy'] = d.DataSet('toy', 't', 'CC0', 's', files=({toy.files[0]!r},), url_template='x/{{path}}'); "
            f"sys.exit(main(['fetch', 'toy', '--mirror', {server.url!r}, '--root', {str(isolated_cache)!r}, '--wait', '0.3']))")],
            capture_output=True, text=True, timeout=60, cwd=ROOT, env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert holder.returncode == 1 and "Traceback" not in holder.stderr, holder.stderr
    assert "toy: waiting for pid 4242 on node7 since 2026-01-01 10:00:00, which is fetching toy" in holder.stderr
    assert holder.stderr.count("error: ") == 1 and "error: toy is being fetched into" in holder.stderr
    assert "by pid 4242 on node7" in holder.stderr and "Fix: let that fetch finish (or stop it), then re-run" in holder.stderr


def test_an_unreadable_manifest(isolated_cache, capsys):
    (isolated_cache / "davis2017").mkdir(parents=True)
    (isolated_cache / "davis2017/manifest.json").write_text("{not json")
    assert main(["verify", "davis2017"]) == 1
    assert "manifest.json cannot be read" in one_error(capsys, "Fix: move it aside and re-run the fetch")
    assert main(["path", "davis2017"]) == 1
    one_error(capsys, "Fix: move it aside")


def test_an_interrupted_fetch(toy, server, capsys, monkeypatch):
    def interrupt(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(ResumingDownloader, "_transfer", interrupt)
    assert main(["fetch", "toy", "--mirror", server.url]) == 130
    one_error(capsys, "Fix: re-run the same command; a fetch resumes")


def test_data_that_is_not_fetched(capsys):
    assert main(["path", "dmcgb-videos", "--part", "video_hard"]) == 1
    err = capsys.readouterr().err
    assert "Fetch it with: python -m vigen.datasets fetch dmcgb-videos --part video_hard" in err and "Traceback" not in err


def test_usage_errors_exit_2(capsys):
    assert main(["fetch", "davis"]) == 2
    assert "unknown data set 'davis'; known data sets:" in one_error(capsys, fix=None)
    assert main(["fetch", "dmcgb-videos", "--part", "hard"]) == 2
    assert "its parts: video_easy, video_hard" in one_error(capsys, fix=None)
    for argv in (["download", "davis2017"], ["fetch", "davis2017", "--wait", "soon"], []):
        with pytest.raises(SystemExit) as caught:
            main(argv)
        assert caught.value.code == 2
        assert "Traceback" not in capsys.readouterr().err


def test_a_real_process_prints_no_traceback(tmp_path):
    (tmp_path / "a-file").write_text("")
    result = subprocess.run([sys.executable, "-m", "vigen.datasets", "fetch", "davis2017", "--root", str(tmp_path / "a-file")],
                            capture_output=True, text=True, timeout=60, cwd=ROOT,
                            env={**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)})
    assert result.returncode == 1 and result.stdout == "" and "Traceback" not in result.stderr
    assert result.stderr.startswith("error: cannot fetch davis2017 into ") and result.stderr.count("\n") == 1

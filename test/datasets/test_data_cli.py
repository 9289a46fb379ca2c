"""``python -m vigen.datasets`` through its ``main(argv)``, the cache folder's rules, and the old name's one line."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

import vigen.datasets
from vigen.datasets import cache_root
from vigen.datasets.__main__ import main

CLIP = b"clip bytes " * 100


@pytest.fixture
def toy(server, make_toy, monkeypatch):
    """A test-made data set registered under the name 'toy', served by the test server."""
    record = make_toy(server.folder, {"easy/a.bin": CLIP, "hard/b.bin": CLIP[::-1], "hard/c.bin": b"c"})
    monkeypatch.setitem(vigen.datasets.DATASETS, "toy", record)
    return record


def test_fetch_path_list_verify(server, toy, isolated_cache, capsys):
    assert main(["path", "toy", "--part", "hard"]) == 1
    err = capsys.readouterr().err
    assert "toy part hard is not (fully) fetched" in err and "hard 0/2 files present" in err
    assert "Fetch it with: python -m vigen.datasets fetch toy --part hard" in err

    assert main(["fetch", "toy", "--part", "hard", "--mirror", server.url]) == 0
    out, err = capsys.readouterr()
    assert out.strip() == str(isolated_cache / "toy/hard")
    assert "[1/2] toy/hard/b.bin: downloaded and checked" in err and "[2/2] toy/hard/c.bin: downloaded and checked" in err
    assert "(2 downloaded, 0 already present)" in err

    assert main(["path", "toy", "--part", "hard"]) == 0 and capsys.readouterr().out.strip() == str(isolated_cache / "toy/hard")
    assert main(["path", "toy"]) == 1 and "toy is not (fully) fetched" in capsys.readouterr().err

    assert main(["list"]) == 0
    out = capsys.readouterr().out
    assert "toy  3 files, 0.0 MB  license: CC0" in out
    assert f"hard: fetched, 2/2 files in {isolated_cache / 'toy/hard'}" in out and "easy: not fetched, 0/1" in out
    assert "dmcgb-videos  110 files" in out and "davis2017" in out

    assert main(["verify", "toy"]) == 0 and "toy: 2 files checked, 0 mismatched, 1 not fetched" in capsys.readouterr().out
    (isolated_cache / "toy/hard/c.bin").write_bytes(b"C")
    assert main(["verify"]) == 1
    out = capsys.readouterr().out
    assert "MISMATCH hard/c.bin: expected git blob" in out and "davis2017: 0 files checked" in out


def test_a_failed_fetch_exits_1_naming_the_missing_file(server, toy, capsys):
    (server.folder / "toy/hard/c.bin").unlink()
    assert main(["fetch", "toy", "--mirror", server.url]) == 1
    err = capsys.readouterr().err
    assert "[3/3] toy/hard/c.bin: FAILED" in err and "error: 1 of the 3 files of toy could not be fetched" in err
    assert f"{server.url}/toy/hard/c.bin (HTTP 404)" in err


def test_unknown_names_and_parts_list_the_known_ones(capsys):
    assert main(["fetch", "davis"]) == 2
    assert "unknown data set 'davis'; known data sets: dmcgb-videos, davis2017" in capsys.readouterr().err
    assert main(["path", "dmcgb-videos", "--part", "hard"]) == 2
    assert "its parts: video_easy, video_hard" in capsys.readouterr().err
    assert main(["path", "davis2017", "--part", "train"]) == 2
    assert "davis2017 is fetched whole" in capsys.readouterr().err
    with pytest.raises(SystemExit):
        main(["download", "davis2017"])


def test_cache_root_order(tmp_path, monkeypatch):
    monkeypatch.setenv("VIGEN_DATA", str(tmp_path / "env"))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    assert cache_root(tmp_path / "arg") == tmp_path / "arg" and cache_root() == tmp_path / "env"
    monkeypatch.delenv("VIGEN_DATA")
    assert cache_root() == tmp_path / "xdg/vigen"
    monkeypatch.setenv("XDG_CACHE_HOME", "relative/path")  # ignored, as the XDG spec says
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    assert cache_root() == tmp_path / "home/.cache/vigen"


def test_importing_vigen_datasets_imports_no_torch_nor_pooch_and_ships_its_pinned_list():
    code = ("import sys, vigen.datasets; bad = [m for m in ('torch', 'pooch', 'filelock', 'requests') if m in sys.modules]; "
            "bad += [m for m in sys.modules if m.startswith(('vigen.envs', 'vigen.transforms', 'vigen.losses'))]; "
            "assert not bad, bad; print(len(vigen.datasets.DATASETS['dmcgb-videos'].files))")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60,
                            cwd=Path(__file__).parents[2])
    assert result.returncode == 0, result.stderr
    assert result.stdout.strip() == "110"
    setup = (Path(__file__).parents[2] / "setup.py").read_text()
    assert '"vigen.datasets": ["*.tsv"]' in setup  # the pinned list is package data, so wheels carry it
    assert '"pooch>=' in setup and '"filelock>=' in setup


def test_the_old_name_exits_2_with_one_line_naming_the_new_command():
    result = subprocess.run([sys.executable, "-m", "vigen.data", "fetch", "dmcgb-videos", "--part", "video_hard"],
                            capture_output=True, text=True, timeout=60, cwd=Path(__file__).parents[2])
    assert result.returncode == 2 and result.stdout == ""
    assert result.stderr == ("error: vigen.data is now vigen.datasets: run "
                             "`python -m vigen.datasets fetch dmcgb-videos --part video_hard`.\n")

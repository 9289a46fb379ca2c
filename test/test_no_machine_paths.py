"""Committed results and package data name data sets, never a machine's paths: no absolute path in any of them.

Rows, reports and shipped files are read on other machines; a path such as ``/work/vigen-data/...`` says nothing
there and leaks the machine that made them. Checked: every file under ``docs/results/``, the data files of
``vigen/**/data/`` and ``vigen/datasets/`` (not its code), everything under ``vigen/pretrained/`` but its code, and
every csv / json / md / txt / tsv file under ``docs/``.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TEXT_SUFFIXES = (".csv", ".json", ".md", ".txt", ".tsv")
ABSOLUTE_PATH = re.compile(rb"(?<![\w.~/$<>:-])(?:/(?:work|root|home|tmp|Users|mnt|scratch)/|[A-Za-z]:\\)")
"""A POSIX home, work or temporary folder, or a Windows drive, not inside a URL or a longer path."""


def checked_files() -> list[Path]:
    docs = ROOT / "docs"
    files = {path for path in (docs / "results").rglob("*") if path.is_file()}
    files |= {path for path in docs.rglob("*") if path.suffix in TEXT_SUFFIXES}
    files |= {path for path in (ROOT / "vigen" / "pretrained").rglob("*") if path.suffix != ".py"}
    files |= {path for folder in [*(ROOT / "vigen").rglob("data"), ROOT / "vigen" / "datasets"] if folder.is_dir()
              for path in folder.rglob("*") if path.suffix != ".py"}
    return sorted(path for path in files if path.is_file() and "__pycache__" not in path.parts)


def test_the_checked_files_include_the_results_and_the_shipped_agents():
    names = {path.relative_to(ROOT).as_posix() for path in checked_files()}
    assert {"docs/results/cartpole-balance-benchmark-data/episodes.csv", "vigen/pretrained/agents/svea-cartpole-balance.json",
            "vigen/datasets/dmcgb_videos.tsv", "vigen/results/data/madi.csv", "docs/testing.md"} <= names


@pytest.mark.parametrize("path", checked_files(), ids=lambda path: path.relative_to(ROOT).as_posix())
def test_no_committed_result_or_package_file_holds_an_absolute_path(path):
    content = path.read_bytes()
    found = [(content[:match.start()].count(b"\n") + 1, content[max(0, match.start() - 30):match.end() + 30])
             for match in ABSOLUTE_PATH.finditer(content)]
    assert not found, f"{path.relative_to(ROOT)} holds machine paths (line, context): {found}; name the data set instead"


@pytest.mark.parametrize("text, found", [("data,/work/vigen-data/video_easy: 6 videos", True), (r"C:\Users\me", True),
                                         ("VIGEN_DATA=/home/me/cache", True), ("https://example.org/home/x", False),
                                         ("dmcgb-videos/video_easy: 10 of 10, verified", False), ("~/tmp/x", False)])
def test_the_pattern_finds_paths_and_not_urls_or_relative_names(text, found):
    assert bool(ABSOLUTE_PATH.search(text.encode())) == found

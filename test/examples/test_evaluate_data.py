"""examples/evaluate.py evaluates each video level on its own videos in one run, and its rows and report say what each
level showed (the benchmark's data or vigen's stand-ins)."""

from __future__ import annotations

import csv
import os
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[2]


def write_videos(folder: Path, count: int, shade: int) -> Path:
    folder.mkdir(parents=True)
    for i in range(count):
        writer = cv2.VideoWriter(str(folder / f"video{i}.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 25, (32, 32))
        for _ in range(4):
            writer.write(np.full((32, 32, 3), shade + 20 * i, np.uint8))
        writer.release()
    return folder


@pytest.mark.slow
@pytest.mark.render
def test_each_video_level_plays_its_own_folder_and_the_rows_say_so(tmp_path):
    easy, hard = write_videos(tmp_path / "easy", 2, 30), write_videos(tmp_path / "hard", 12, 120)
    out = tmp_path / "report"
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "evaluate.py"), "--pretrained", "svea-cartpole-balance",
         "--levels", "train", "color_hard", "video_easy", "video_hard", "--episodes", "2", "--episode-length", "20",
         "--videos", f"video_easy={easy}", f"video_hard={hard}", "--out", str(out)],
        capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    with open(out / "episodes.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    by_level = {level: [row for row in rows if row["level"] == level] for level in ("train", "color_hard", "video_easy", "video_hard")}
    assert {row["data"] for row in by_level["train"]} == {""}
    assert {row["data"] for row in by_level["color_hard"]} == {"DMC-GB color_hard presets (shipped, 100)"}
    assert {(row["data"], row["stand_in"]) for row in by_level["video_easy"]} == {(f"{easy}: 2 videos", "False")}
    assert {(row["data"], row["stand_in"]) for row in by_level["video_hard"]} == {(f"{hard}: 12 videos", "False")}
    assert [row["level_options"] for row in by_level["video_hard"]] == [f'{{"videos": "{hard}"}}'] * 2
    # DMC-GB's order: episode k plays video (k + 1) mod n, named by file
    assert [row["shown"] for row in by_level["video_easy"]] == ["video=video1.mp4", "video=video0.mp4"]
    assert [row["shown"] for row in by_level["video_hard"]] == ["video=video1.mp4", "video=video2.mp4"]
    assert all(row["shown"].startswith("preset=") for row in by_level["color_hard"])


def test_videos_are_given_per_level_pattern():
    import importlib.util

    spec = importlib.util.spec_from_file_location("evaluate_script", ROOT / "examples" / "evaluate.py")
    script = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = script  # its dataclasses look their module up
    spec.loader.exec_module(script)
    pairs = [("video_easy", Path("/e")), ("dcs_*", Path("/davis")), ("*", Path("/any"))]
    assert script.videos_for("dmc/walker-walk", "video_easy", pairs) == {"videos": "/e"}
    assert script.videos_for("dmc/walker-walk", "dcs_0.2", pairs) == {"videos": "/davis"}
    assert script.videos_for("dmc/walker-walk", "video_hard", pairs) == {"videos": "/any"}
    assert script.videos_for("dmc/walker-walk", "color_hard", pairs) == {}, "a level without videos gets no folder"
    runs = script.in_runs(["train", "video_easy", "video_hard", "dcs_0.1", "dcs_0.2"],
                          lambda level: script.videos_for("dmc/walker-walk", level, pairs[:2]))
    assert runs == [(["train"], {}), (["video_easy"], {"videos": "/e"}), (["video_hard"], {}),
                    (["dcs_0.1", "dcs_0.2"], {"videos": "/davis"})]
    with pytest.raises(SystemExit, match="is not a folder"):
        script.parse_videos(["video_easy=/no/such/folder"])


@pytest.mark.slow
@pytest.mark.render
def test_stand_in_levels_are_labelled_in_the_report_and_warned_about(tmp_path):
    out = tmp_path / "report"
    env = {**os.environ, "VIGEN_DATA": str(tmp_path / "empty-cache")}
    result = subprocess.run(
        [sys.executable, str(ROOT / "examples" / "evaluate.py"), "--pretrained", "svea-cartpole-balance", "--levels", "train",
         "video_hard", "--episodes", "1", "--episode-length", "10", "--out", str(out)],
        capture_output=True, text=True, cwd=ROOT, timeout=600, env=env)
    assert result.returncode == 0, result.stderr[-2000:]
    assert "StandInDataWarning" in result.stderr and "python -m vigen.data fetch dmcgb-videos --part video_hard" in result.stderr
    report = (out / "report.md").read_text()
    assert "| video_hard (stand-in) |" in report and "| train |" in report
    assert "- video_hard: DMC-GB video_hard" in report and "showed procedural stand-in videos (10) (vigen's stand-ins" in report

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
         "--videos", f"video_easy={easy}", f"video_hard={hard}", "--allow-partial-data", "--out", str(out)],
        capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stderr[-2000:]
    with open(out / "episodes.csv", newline="") as file:
        rows = list(csv.DictReader(file))
    by_level = {level: [row for row in rows if row["level"] == level] for level in ("train", "color_hard", "video_easy", "video_hard")}
    assert {row["data"] for row in by_level["train"]} == {""}
    assert {row["data"] for row in by_level["color_hard"]} == {"dmcgb-colors/color_hard: 100 of 100, shipped"}
    assert {(row["data"], row["stand_in"]) for row in by_level["video_easy"]} == {("user folder: 2 videos", "False")}
    assert {(row["data"], row["stand_in"]) for row in by_level["video_hard"]} == {("user folder: 12 videos", "False")}
    assert [row["level_options"] for row in by_level["video_hard"]] == ['{"videos": "folder hard"}'] * 2, "a name, not a path"
    assert str(tmp_path) not in (out / "episodes.csv").read_text() + (out / "report.md").read_text()
    # DMC-GB's order: episode k plays video (k + 1) mod n, named by file
    assert [row["shown"] for row in by_level["video_easy"]] == ["video=video1.mp4", "video=video0.mp4"]
    assert [row["shown"] for row in by_level["video_hard"]] == ["video=video1.mp4", "video=video2.mp4"]
    assert all(row["shown"].startswith("preset=") for row in by_level["color_hard"])


def test_videos_are_given_per_level_pattern(evaluate_script):
    script = evaluate_script
    pairs = [("video_easy", Path("/e")), ("dcs_*", Path("/davis")), ("*", Path("/any"))]
    assert script.videos_for("dmc/walker-walk", "video_easy", pairs) == {"videos": "/e"}
    assert script.videos_for("dmc/walker-walk", "dcs_0.2", pairs) == {"videos": "/davis"}
    assert script.videos_for("dmc/walker-walk", "video_hard", pairs) == {"videos": "/any"}
    assert script.videos_for("dmc/walker-walk", "color_hard", pairs) == {}, "a level without videos gets no folder"
    runs = script.in_runs(["train", "video_easy", "video_hard", "dcs_0.1", "dcs_0.2"],
                          lambda level: script.videos_for("dmc/walker-walk", level, pairs[:2]))
    assert runs == [(["train"], {}), (["video_easy"], {"videos": "/e"}), (["video_hard"], {}),
                    (["dcs_0.1", "dcs_0.2"], {"videos": "/davis"})]
    from vigen.evaluation.level_data import video_folders

    with pytest.raises(ValueError, match="is not a folder"):
        video_folders(["video_easy=/no/such/folder"])


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
    assert "StandInDataWarning" in result.stderr and "python -m vigen.datasets fetch dmcgb-videos --part video_hard" in result.stderr
    report = (out / "report.md").read_text()
    assert "| video_hard (stand-in) |" in report and "| train |" in report
    assert "- video_hard: DMC-GB video_hard" in report and "showed procedural stand-in videos (10) (vigen's stand-ins" in report


def test_a_videos_folder_is_checked_against_its_levels_data_set_before_any_work(tmp_path):
    from vigen.evaluation.level_data import check_video_counts, video_folders

    six = tmp_path / "video_easy"
    six.mkdir()
    for i in (0, 1, 2, 6, 8, 9):  # the 6 of DMC-GB's 10 video_easy files the committed results had
        (six / f"video{i}.mp4").write_bytes(b"")  # counted, not opened
    levels = {"dmc/cartpole-balance": ["train", "video_easy", "color_video_easy", "dcs_0.1"]}
    videos = video_folders([str(six)])  # one folder for every video level
    with pytest.raises(ValueError) as stopped:
        check_video_counts(levels, videos, allow_partial_data=False)
    message = str(stopped.value)
    assert f"video_easy={six}: 6 videos; video_easy plays dmcgb-videos/video_easy, 10 videos" in message
    assert f"color_video_easy={six}: 6 videos" in message and "dcs_0.1" not in message, "DAVIS pins no count"
    assert "python -m vigen.datasets fetch dmcgb-videos --part video_easy" in message and "--allow-partial-data" in message
    check_video_counts(levels, videos, allow_partial_data=True)  # asked for: no stop
    for i in (3, 4, 5, 7):
        (six / f"video{i}.mp4").write_bytes(b"")
    check_video_counts(levels, videos, allow_partial_data=False)  # all 10
    with pytest.raises(ValueError, match="video_hard=.*10 videos; video_hard plays dmcgb-videos/video_hard, 100 videos"):
        check_video_counts({"dmc/walker-walk": ["video_hard"]}, videos, allow_partial_data=False)


def test_under_dmcgb_the_env_seeds_are_seed_plus_42(evaluate_script):
    script = evaluate_script
    from vigen.protocols import PROTOCOLS

    assert script.env_seeds((0, 1), PROTOCOLS["dmcgb"]) == [42, 43], "DMC-GB src/eval.py:53: make_env(seed=args.seed + 42)"
    assert script.env_seeds((0, 1), PROTOCOLS["drqv2"]) == [0, 1] and script.env_seeds((0, 1), None) == [0, 1]
    comparison = script.Comparison("madi", "dmcgb", ["madi"], False, False)
    assert script.evaluation_protocol([], comparison).name == "dmcgb"

"""benchmarks/losses.py's GPU options cannot rot on a CPU: the captured update's synthetic replay holds CatFrames' stacks, the
busy measure is the union of device intervals, --jobs passes on every other flag, and a tiny run prints every column; and
benchmarks/update_gap.py (the eager update inside train.py against losses.py, one condition at a time) runs end to end."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest
import torch

from vigen.run import FrameReplay

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def losses():
    spec = importlib.util.spec_from_file_location("benchmark_losses", ROOT / "benchmarks" / "losses.py")
    module = importlib.util.module_from_spec(spec)
    sys.path.insert(0, str(ROOT / "benchmarks"))  # as when run as a script: augmentations.py beside it
    try:
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return module


def test_the_synthetic_trajectories_are_stacks_the_frame_replay_rebuilds_across_chunks_and_episode_ends(losses):
    pool = torch.randint(0, 256, (5, 3, 84, 84), dtype=torch.uint8)
    replay = FrameReplay(100, 4, n_step=3, gamma=0.99, device="cpu", check=True)  # raises on any stack CatFrames would not show
    for start in range(0, 24, 8):
        replay.extend(losses.synthetic_steps(8, start, pool, episode=10))
    assert len(replay) == 21 and replay.frames_stored == 24 + 3  # one frame per step, one reset frame per episode


def test_the_busy_measure_is_the_union_of_device_intervals_counted_once(losses):
    """On the CPU the profiler's host operators stand in for kernels: nested operators overlap, and the union counts them once."""
    x = torch.ones(128, 128)
    per_update, share = losses.device_time(lambda: (x @ x).relu_(), 3, torch.device("cpu"))
    assert 0 < share <= 1 and per_update > 0


def test_jobs_children_get_every_other_flag(losses):
    argv = ["--device", "cuda", "--algos", "drqv2", "svea", "--jobs", "4", "--batch", "256", "--deadline=300", "--compile"]
    assert losses.strip_flags(argv, {"--jobs": 1, "--algos": 2, "--deadline": 1}) == [
        "--device", "cuda", "--batch", "256", "--compile"]


@pytest.mark.slow
def test_a_tiny_cpu_run_with_the_captured_update_and_bf16_prints_every_column(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "losses.py"), "--batch", "2", "--repeats", "1", "--algos",
                             "drqv2", "--captured", "--precision", "bf16", "--channels-last", "off"], cwd=tmp_path, env=env,
                            capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    header, _, row = [line for line in result.stdout.splitlines() if line.startswith("|")][:3]
    columns = [cell.strip() for cell in header.strip("|").split("|")]
    assert {"reference ms", "vigen ms", "captured ms", "bf16 loss diff"} <= set(columns)
    cells = dict(zip(columns, (cell.strip() for cell in row.strip("|").split("|"))))
    assert float(cells["captured ms"]) > 0
    assert cells["bf16 loss diff"].endswith(("(ok 2%)", "(over 2%)")), "the difference, checked against the stated tolerance"


@pytest.mark.slow
def test_the_update_gap_runs_every_condition_at_tiny_sizes(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "update_gap.py"), "--quick", "--json", str(tmp_path / "gap.json")],
                            cwd=tmp_path, env=env, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
    rows = json.loads((tmp_path / "gap.json").read_text())["rows"]
    assert [row["row"][0] for row in rows] == ["A", "B", "C", "D", "E"]
    assert all(row["update_ms"] > 0 for row in rows) and all(row["sample_ms"] > 0 for row in rows[3:])

"""A run killed while it writes a checkpoint resumes exactly: counters, weights, replay buffer and logs as if never killed."""

from __future__ import annotations

import csv
import os
import pickle
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from tensordict import TensorDict

ROOT = Path(__file__).resolve().parents[2]
# 100-frame collector batches (50 agent steps, --update-every 1), a checkpoint after each; 15-step
# episodes, so checkpoints cut episodes; an 80-slot buffer, so it wraps in the second segment
TINY = ["--env", "dmc/cartpole-balance", "--episode-length", "30", "--seed-frames", "40", "--eval-every", "100",
        "--eval-episodes", "1", "--batch-size", "4", "--buffer-size", "80", "--hidden-dim", "16", "--feature-dim", "8",
        "--update-every", "1", "--threads", "1"]
FRAMES = "300"
# runs train.py as __main__ with torch.save cut short (half the bytes, then SIGKILL) on the k-th checkpoint
KILLER = """
import io, os, runpy, signal, sys, torch
kill_at, calls, real_save = int(sys.argv[1]), [0], torch.save
def save(obj, f, *args, **kwargs):
    if isinstance(obj, dict) and "loss" in obj:
        calls[0] += 1
        if calls[0] == kill_at:
            data = io.BytesIO()
            real_save(obj, data, *args, **kwargs)
            half = data.getvalue()[: len(data.getvalue()) // 2]
            if isinstance(f, (str, os.PathLike)):
                with open(f, "wb") as file:
                    file.write(half)
            else:
                f.write(half)
                f.flush()
            os.kill(os.getpid(), signal.SIGKILL)
    return real_save(obj, f, *args, **kwargs)
torch.save = save
sys.argv = [sys.argv[2], *sys.argv[3:]]
runpy.run_path(sys.argv[0], run_name="__main__")
"""


def train(*args: str | Path, kill_at: int | None = None) -> subprocess.CompletedProcess:
    script = str(ROOT / "examples" / "train.py")
    cmd = [sys.executable, script] if kill_at is None else [sys.executable, "-c", KILLER, str(kill_at), script]
    env = dict(os.environ, OMP_NUM_THREADS="1")
    return subprocess.run([*cmd, *map(str, args)], capture_output=True, text=True, cwd=ROOT, env=env)


def csv_rows(run_dir: Path) -> dict[str, list[list[str]]]:
    out = {}
    for path in sorted((run_dir / "logs" / "scalars").rglob("*.csv")):
        rows = list(csv.reader(path.open()))
        if path.stem == "seconds_per_update":  # wall time: only its steps can match
            rows = [row[:1] for row in rows]
        out[str(path.relative_to(run_dir))] = rows
    return out


def assert_same_tensors(a: dict, b: dict, where: str) -> None:
    assert a.keys() == b.keys(), where
    for key in a:
        if isinstance(a[key], dict):
            assert_same_tensors(a[key], b[key], f"{where}.{key}")
        elif isinstance(a[key], torch.Tensor):
            assert torch.equal(a[key], b[key]), f"{where}.{key} differs"
        else:
            assert a[key] == b[key], f"{where}.{key}: {a[key]} != {b[key]}"


@pytest.fixture(scope="module")
def uninterrupted(tmp_path_factory) -> Path:
    run_dir = tmp_path_factory.mktemp("runs") / "whole"
    result = train("--frames", FRAMES, "--out", run_dir, *TINY)
    assert result.returncode == 0, result.stderr[-3000:]
    return run_dir


@pytest.mark.slow
@pytest.mark.render
def test_killed_while_checkpointing_resumes_exactly(uninterrupted, tmp_path):
    run_dir = tmp_path / "killed"
    killed = train("--frames", FRAMES, "--out", run_dir, *TINY, kill_at=2)
    assert killed.returncode == -9, killed.stderr[-3000:]
    resumed = train("--resume", run_dir, "--frames", FRAMES)
    assert resumed.returncode == 0, resumed.stderr[-3000:]

    final = "checkpoints/frames_00000300.pt"
    whole = torch.load(uninterrupted / final, weights_only=True)
    again = torch.load(run_dir / final, weights_only=True)
    assert (again["steps"], again["updates"]) == (whole["steps"], whole["updates"]) == (150, 130)
    assert_same_tensors(whole["loss"], again["loss"], "loss")
    assert_same_tensors(whole["optimizer"]["state"], again["optimizer"]["state"], "optimizer")
    assert again["replay"] == whole["replay"] and whole["replay"]["write_count"] > 80, "the buffer wrapped, same cursor"
    stored = TensorDict.load_memmap(uninterrupted / "replay_buffer" / "storage")
    restored = TensorDict.load_memmap(run_dir / "replay_buffer" / "storage")
    assert (stored == restored).all(), "every slot of the replay storage holds the same transition"
    assert csv_rows(run_dir) == csv_rows(uninterrupted), "the logs hold each step once, as in the run never killed"


@pytest.mark.render
def test_resume_skips_a_truncated_checkpoint_and_says_so(uninterrupted, tmp_path):
    run_dir = tmp_path / "truncated"
    subprocess.run(["cp", "-r", str(uninterrupted), str(run_dir)], check=True)
    newest = run_dir / "checkpoints" / "frames_00000300.pt"
    newest.write_bytes(newest.read_bytes()[:1000])
    result = train("--resume", run_dir, "--frames", FRAMES)
    assert result.returncode == 0, result.stderr[-3000:]
    assert "skipped checkpoint frames_00000300.pt" in result.stderr and "truncated" in result.stderr
    assert "resuming from frames_00000200.pt" in result.stdout
    assert torch.load(newest, weights_only=True)["steps"] == 150, "the run went on from 200 frames and wrote 300 again"


class _Marker:
    def __init__(self, path: Path) -> None:
        self.path = path

    def __reduce__(self):
        return (os.system, (f"touch {self.path}",))


def _plant(checkpoint: Path, marker: Path) -> None:
    checkpoint.parent.mkdir(parents=True, exist_ok=True)
    checkpoint.write_bytes(pickle.dumps({"loss": {}, "frames": 10, "steps": 5, "updates": 0, "x": _Marker(marker)}, protocol=2))


@pytest.mark.render
def test_malicious_checkpoints_are_refused_by_both_scripts(uninterrupted, tmp_path):
    run_dir = tmp_path / "evil"
    run_dir.mkdir()
    (run_dir / "config.json").write_text((uninterrupted / "config.json").read_text())
    marker = tmp_path / "marker"
    _plant(run_dir / "checkpoints" / "frames_00000010.pt", marker)
    resumed = train("--resume", run_dir, "--frames", FRAMES)
    assert resumed.returncode != 0 and "refused" in resumed.stderr and "frames_00000010.pt" in resumed.stderr
    evaluated = subprocess.run([sys.executable, str(ROOT / "examples" / "evaluate.py"), str(run_dir), "--episodes", "1",
                                "--levels", "train", "--out", tmp_path / "report"], capture_output=True, text=True, cwd=ROOT)
    assert evaluated.returncode != 0 and "refused" in evaluated.stderr
    assert not marker.exists(), "loading a checkpoint ran code"
    assert not (tmp_path / "report").exists()


# --overlap: a worker process, 100-frame batches, two per segment, so each segment collects its second batch in the
# background while it updates on the first; 400 frames are two segments, and the 80-slot buffer wraps in the second
OVERLAP = ["--overlap", "--eval-every", "200"]


@pytest.mark.slow
@pytest.mark.render
def test_an_overlapped_run_killed_while_checkpointing_resumes_exactly_with_its_replay_on_the_device(tmp_path):
    """--overlap collects the next batch while updating, but the weights each batch acts with are fixed by the sequence and
    nothing is in flight at a checkpoint: killed and resumed (with the replay's device copy, the CPU standing in), the run
    ends as the one never killed, bit for bit, and with the serial run's update ratio."""
    whole, killed = tmp_path / "whole", tmp_path / "killed"
    result = train("--frames", "400", "--out", whole, *TINY, *OVERLAP, "--time-stages")
    assert result.returncode == 0, result.stderr[-3000:]
    result = train("--frames", "400", "--out", killed, *TINY, *OVERLAP, "--replay-on-device", kill_at=2)
    assert result.returncode == -9, result.stderr[-3000:]
    result = train("--resume", killed, "--frames", "400", "--replay-on-device")
    assert result.returncode == 0, result.stderr[-3000:]
    assert "resuming from frames_00000200.pt" in result.stdout

    final = "checkpoints/frames_00000400.pt"
    a, b = (torch.load(run / final, weights_only=True) for run in (whole, killed))
    assert (a["steps"], a["updates"]) == (b["steps"], b["updates"]) == (200, 180), "one update per agent step after 20 seed steps"
    assert_same_tensors(a["loss"], b["loss"], "loss")
    assert_same_tensors(a["optimizer"]["state"], b["optimizer"]["state"], "optimizer")
    assert a["replay"] == b["replay"] and a["replay"]["write_count"] > 80
    stored, restored = (TensorDict.load_memmap(run / "replay_buffer" / "storage") for run in (whole, killed))
    assert (stored == restored).all()
    timing = [path for path in csv_rows(whole) if "/time/" in path]
    assert timing, "--time-stages logged the stages"
    assert {k: v for k, v in csv_rows(whole).items() if k not in timing} == csv_rows(killed)
    waits = [float(value) for _, value in csv.reader((whole / "logs/scalars/time/wait_s.csv").open())]
    collects = [float(value) for _, value in csv.reader((whole / "logs/scalars/time/collect_s.csv").open())]
    assert min(w / c for w, c in zip(waits[1::2], collects[1::2])) < 0.5, "each segment's second batch was collected while updating"

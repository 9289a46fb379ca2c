"""benchmarks/train_throughput.py (run by the device check's tier 5) cannot rot: its figures from a run's stage rows, its
quick mode end to end on the CPU through ``gpu_check.sh --dry --tiers 5``, and the learning comparison's verdict."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def load(name: str):
    spec = importlib.util.spec_from_file_location(f"benchmark_{name}", ROOT / "benchmarks" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    sys.path.insert(0, str(ROOT / "benchmarks"))  # as when run as a script: the scripts beside it import
    try:
        spec.loader.exec_module(module)
    finally:
        sys.path.remove(str(ROOT / "benchmarks"))
    return module


def rows(*batches: tuple[float, int, int, float, float]) -> list[dict[str, float]]:
    """Rows as train.py --time-stages logs them: (wall s, agent steps, updates, collect s, wait s) per batch of 100 steps."""
    out, frames = [], 0
    for wall, steps, updates, collect, wait in batches:
        frames += 2 * steps  # action repeat 2
        out.append({"frames": frames, "wall_s": wall, "steps": steps, "updates": updates, "collect_s": collect, "wait_s": wait,
                    "store_s": 0.01, "sample_s": 0.1 * updates / 50, "update_s": 0.5 * updates / 50, "sync_s": 0.0,
                    "env_step_ms": 4.0, "env_render_ms": 3.0})
    return out


def test_the_figures_come_from_the_measured_batches_only():
    summarize = load("train_throughput").summarize
    logged = rows((10.0, 100, 0, 1.0, 1.0),  # start-up, then seeding
                  (11.0, 100, 0, 1.0, 1.0),
                  (12.0, 100, 0, 1.0, 1.0),
                  (15.0, 100, 50, 1.0, 1.0),  # warm-up: the first updates (a compiled update compiles here)
                  (16.0, 100, 50, 1.0, 0.25),  # measured: 2 batches, 400 frames in 2 s, collection mostly hidden
                  (17.0, 100, 50, 1.0, 0.25),
                  (30.0, 100, 50, 1.0, 0.25))  # after the window
    figures = summarize(logged, warmup=1, batches=2)
    assert figures["frames_per_s"] == 200 and figures["updates_per_s"] == 50 and figures["measured_batches"] == 2
    assert figures["collect_frames_per_s"] == 200 and figures["hidden"] == 0.75 and figures["wait_share"] == 0.25
    assert figures["seed_frames_per_s"] == 200, "seeding rows after the first (start-up)"
    assert round(figures["update_ms_per_update"], 6) == 10 and figures["env_render_ms"] == 3.0
    assert "error" in summarize(logged[:4], warmup=1, batches=2)


def test_the_learning_comparison_calls_a_difference_noise_only_within_two_standard_errors():
    compare = load("overlap_learning").compare
    serial = {1: {10: 100.0, 20: 200.0}, 2: {10: 120.0, 20: 240.0}}
    assert compare({"serial": serial, "overlap": {1: {10: 105.0, 20: 210.0}, 2: {10: 115.0, 20: 230.0}}})[
        "verdicts"]["overlap"]["within_noise"]
    assert not compare({"serial": serial, "overlap": {1: {10: 300.0, 20: 500.0}, 2: {10: 310.0, 20: 520.0}}})[
        "verdicts"]["overlap"]["within_noise"]


@pytest.mark.slow
@pytest.mark.render
@pytest.mark.device_prep
def test_the_device_checks_throughput_tier_runs_the_quick_benchmark_on_the_cpu(tmp_path):
    env = {**os.environ, "PYTHON": sys.executable, "OMP_NUM_THREADS": "1"}
    env.pop("GPU_CHECK_T0", None)
    result = subprocess.run(["bash", str(ROOT / "benchmarks" / "gpu_check.sh"), "--dry", "--carry", "none", "--tiers", "5",
                             "--out", str(tmp_path)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=280)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "figures.json").read_text())
    (tier,) = report["tiers"]
    assert (tier["tier"], tier["name"], tier["status"]) == (5, "training throughput", "passed")
    results = {result["name"]: result for result in tier["figures"]["results"]}
    assert set(results) == {"1w-serial-eager-memmap", "2w-overlap-eager-device"}
    for result in results.values():
        figures = result["figures"]
        assert result["status"] == "passed" and figures["frames_per_s"] > 0 and figures["updates_per_s"] > 0
        assert figures["env_step_ms"] >= figures["env_render_ms"] > 0 and figures["env_physics_ms"] > 0, "measured in the workers"
        assert figures["update_ms_per_update"] > 0 and figures["store_ms_per_step"] > 0
    assert results["1w-serial-eager-memmap"]["figures"]["hidden"] == 0, "serial: the loop waits for every frame"
    assert "| 2w-overlap-eager-device |" in tier["figures"]["table"]
    log = (tmp_path / "logs" / "tier5.log").read_text()
    assert "env worker 1 renders with" in log and "examples/train.py" in log, "each run's whole output is kept"
    assert sorted(path.name for path in tmp_path.rglob("*") if path.is_file()) == ["figures.json", "install.log", "tier5.log"]


@pytest.mark.slow
@pytest.mark.render
def test_several_runs_share_the_machine_and_their_aggregate_is_reported_beside_each_run_s(tmp_path):
    """--runs 2: two train.py processes at once (seeds 0 and 1), both measured while both train; aggregate_frames_per_s is the
    sum of their frames/s, and each run's figures are kept."""
    env = {**os.environ, "PYTHONPATH": str(ROOT), "OMP_NUM_THREADS": "1"}
    result = subprocess.run([sys.executable, str(ROOT / "benchmarks" / "train_throughput.py"), "--quick", "--configs", "1",
                             "--runs", "2", "--out", str(tmp_path)], cwd=ROOT, env=env, capture_output=True, text=True, timeout=400)
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "train_throughput.json").read_text())
    (group,) = report["results"]
    assert (group["name"], group["runs"], group["status"]) == ("1w-serial-eager-memmap x2", 2, "passed")
    runs = group["results"]
    assert [run["seed"] for run in runs] == [0, 1] and all(run["status"] == "passed" for run in runs)
    assert all("--seed" in run["command"] and "--threads 1" in run["command"] for run in runs)
    each = [run["figures"]["frames_per_s"] for run in runs]
    assert all(value > 0 for value in each) and group["figures"]["frames_per_s_each"] == each
    assert group["figures"]["aggregate_frames_per_s"] == pytest.approx(sum(each))
    assert "| 1w-serial-eager-memmap x2 | 2 |" in report["table"]

"""examples/sweep.py (the API) and examples/evaluate.py --sweep: rows per intensity, the robustness curve, clear errors."""

from __future__ import annotations

import csv
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PNG = b"\x89PNG\r\n\x1a\n"


def run(script: str, *args: str | Path, ok: bool = True) -> subprocess.CompletedProcess:
    result = subprocess.run([sys.executable, str(ROOT / "examples" / script), *map(str, args)],
                            capture_output=True, text=True, cwd=ROOT)
    assert (result.returncode == 0) == ok, result.stderr[-3000:]
    return result


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="") as file:
        return list(csv.DictReader(file))


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    run_dir = tmp_path_factory.mktemp("runs") / "drqv2"
    run("train.py", "--algo", "drqv2", "--env", "dmc/cartpole-balance", "--frames", "200", "--seed-frames", "100",
        "--eval-every", "200", "--eval-episodes", "1", "--batch-size", "8", "--hidden-dim", "32",
        "--buffer-size", "1000", "--episode-length", "100", "--out", run_dir)
    return run_dir


@pytest.mark.render
@pytest.mark.slow
def test_sweep_example_writes_table_and_curve(tmp_path):
    """examples/sweep.py, the API's robustness curve: a random policy on walker-walk at four camera_rotation intensities."""
    out = tmp_path / "sweep"
    result = run("sweep.py", out)
    assert "| camera_rotation=0 | " in result.stdout and "| camera_rotation=0.5 | " in result.stdout
    assert {p.name for p in out.iterdir()} == {"episodes.csv", "intensity_camera_rotation.png"}
    rows = _rows(out / "episodes.csv")
    assert [(r["env"], r["level"], r["factor"], r["intensity"], r["seed"]) for r in rows] == [
        ("dmc/walker-walk", f"camera_rotation={x}", "camera_rotation", f"{float(x)}", s)
        for x in ("0", "0.1", "0.3", "0.5") for s in ("0", "1")]
    assert all(r["method"] == "random" and r["length"] == "50" for r in rows), "100 control steps = 50 agent steps"
    assert (out / "intensity_camera_rotation.png").read_bytes()[:8] == PNG


@pytest.mark.render
@pytest.mark.slow
def test_evaluate_example_with_sweeps(trained, tmp_path):
    out = tmp_path / "report"
    result = run("evaluate.py", trained, "--levels", "train", "--sweep", "camera_rotation", "0.1", "0.3",
                 "--sweep", "object_color", "0.5", "--episodes", "1", "--episode-length", "6", "--out", out)
    assert {p.name for p in out.iterdir()} == {"episodes.csv", "summary.csv", "report.md", "levels.png", "gaps.csv", "profile.png",
                                               "intensity_camera_rotation.png", "intensity_object_color.png"}
    gaps = {r["level"]: r for r in _rows(out / "gaps.csv")}
    assert set(gaps) == {"camera_rotation=0.1", "camera_rotation=0.3", "object_color=0.5"}
    assert gaps["camera_rotation=0.3"]["factor"] == "camera_rotation" and float(gaps["camera_rotation=0.3"]["gap"]) > 0
    assert "intensity_object_color.png" in result.stdout
    rows = _rows(out / "episodes.csv")
    assert [(r["level"], r["factor"], r["intensity"]) for r in rows] == [
        ("train", "", ""), ("camera_rotation=0.1", "camera_rotation", "0.1"),
        ("camera_rotation=0.3", "camera_rotation", "0.3"), ("object_color=0.5", "object_color", "0.5")]
    summary = {r["level"]: r for r in _rows(out / "summary.csv")}
    assert summary["camera_rotation=0.3"]["intensity"] == "0.3" and summary["train"]["factor"] == ""
    report = (out / "report.md").read_text()
    assert "| camera_rotation=0.1 |" in report and "![intensity_camera_rotation.png]" in report


@pytest.mark.render
@pytest.mark.slow
def test_evaluate_example_refuses_a_bad_sweep(trained, tmp_path, evaluate_script, stopped):
    for args, message in ((["--sweep", "camera_rotation"], "give the intensities after the factor"),
                          (["--sweep", "camera_rotation", "0.1", "1.2"], "[0, 1]"),
                          (["--sweep", "camera_rotaton", "0.1"], "not a factor of dmc/cartpole-balance")):
        said = stopped(evaluate_script.main, [trained, *args, "--out", tmp_path / "report"])
        assert message in said, said
    assert not (tmp_path / "report").exists()

"""The device check (``benchmarks/gpu_check.sh``) runs on the CPU in its dry mode, so that it cannot rot between the
sessions that have a GPU: its figures' structure, the tiers' order, its deadline, and a missing dependency named fast.

The whole dry runs (about a minute each) are marked ``device_prep``: ``bash scripts/test.sh -m device_prep`` runs them
before a device session; the default run keeps the failure paths, the budgets and the calls' order."""

from __future__ import annotations

import importlib.util
import json
import os
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
SCRIPT = ROOT / "benchmarks" / "gpu_check.sh"


def gpu_check(*args: str, timeout: float = 280) -> tuple[subprocess.CompletedProcess, float]:
    env = {**os.environ, "PYTHON": sys.executable, "OMP_NUM_THREADS": "1"}
    env.pop("GPU_CHECK_T0", None)
    started = time.perf_counter()
    result = subprocess.run(["bash", str(SCRIPT), "--dry", *args], cwd=ROOT, env=env, capture_output=True, text=True,
                            timeout=timeout)
    return result, time.perf_counter() - started


def load_module():
    spec = importlib.util.spec_from_file_location("gpu_check", ROOT / "benchmarks" / "gpu_check.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
@pytest.mark.device_prep
def test_the_dry_check_runs_every_tier_in_order_and_writes_its_figures(tmp_path):
    result, seconds = gpu_check("--carry", "none", "--out", str(tmp_path))
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "figures.json").read_text())
    assert report["dry"] is True and report["status"] == "passed" and report["device"] == "cpu"
    assert report["torch"] and report["python"] and report["git"]["commit"]
    assert report["seconds"] < report["deadline_s"] and seconds < report["deadline_s"] + 10
    assert report["install"]["status"] == "passed"
    tiers = report["tiers"]
    assert [tier["tier"] for tier in tiers] == [1, 2, 3, 4]
    assert [tier["name"] for tier in tiers] == ["device tests", "drqv2 and svea against the reference",
                                                "end-to-end training", "the other losses"]
    for tier in tiers:
        assert tier["status"] == "passed", tier
        assert 0 < tier["seconds"] <= tier["timeout_s"] + 10
        log = (tmp_path / tier["log"]).read_text()
        assert "$ " in log and len(log.splitlines()) > 5, "the tier's whole output is kept"
    device_tests, pair, training, others = (tier["figures"] for tier in tiers)
    assert device_tests["passed"] >= 1 and device_tests["failed"] == device_tests["errors"] == 0
    assert "test session starts" in (tmp_path / tiers[0]["log"]).read_text(), "pytest's full log, not its last lines"
    assert [row["algo"] for row in pair["rows"]] == ["drqv2"] and pair["rows"][0]["reference ms"] > 0
    assert pair["rows"][0]["vigen ms"] > 0 and not pair["not_reached"]
    assert training["frames_per_s"] > 0 and training["updates_per_s"] > 0 and training["logged_batches"] >= 3
    assert len(others["rows"]) == 1 and others["rows"][0]["algo"] not in ("drqv2", "svea")
    back = [path for path in tmp_path.rglob("*") if path.is_file()]
    assert len(back) <= 8, "the device tool brings back at most 8 files from $OUT"
    assert all(len(path.relative_to(tmp_path).parts) <= 3 for path in back)


def write_carry(folder: Path, wheels: list[str], modules: list[str]) -> None:
    folder.mkdir()
    with zipfile.ZipFile(folder / "dm_control-0-trimmed.zip", "w") as archive:
        archive.writestr("dm_control_stub_dist/README", "empty")
    import hashlib
    digest = hashlib.sha256((folder / "dm_control-0-trimmed.zip").read_bytes()).hexdigest()
    manifest = {"wheels": [{"file": f"wheels/{name}", "bytes": 1, "sha256": "0"} for name in wheels],
                "dm_control": {"file": "dm_control-0-trimmed.zip", "bytes": 1, "sha256": digest}, "gl": [],
                "modules": modules, "commit": "0" * 40}
    (folder / "MANIFEST.json").write_text(json.dumps(manifest))


def test_a_wheel_missing_from_the_carry_folder_stops_the_check_at_once_naming_it(tmp_path):
    write_carry(tmp_path / "carry", ["tensordict-0.14.3-cp312-cp312-manylinux_2_28_x86_64.whl"], ["tensordict"])
    result, seconds = gpu_check("--carry", str(tmp_path / "carry"), "--out", str(tmp_path / "out"), timeout=60)
    assert result.returncode == 2 and seconds < 30
    assert "tensordict-0.14.3-cp312-cp312-manylinux_2_28_x86_64.whl" in result.stderr
    assert "python scripts/gpu_carry.py" in result.stderr, "the error says how to rebuild the folder"
    report = json.loads((tmp_path / "out" / "figures.json").read_text())
    assert report["status"] == "failed" and report["install"]["status"] == "failed"
    assert "tensordict-0.14.3" in report["install"]["error"]
    assert [(tier["tier"], tier["status"]) for tier in report["tiers"]] == [(1, "skipped"), (2, "skipped"), (3, "skipped"),
                                                                             (4, "skipped")]


def test_a_module_that_does_not_import_stops_the_check_within_a_minute_naming_it(tmp_path):
    write_carry(tmp_path / "carry", [], ["vigen_gpu_check_absent_module", "tensordict"])
    result, seconds = gpu_check("--carry", str(tmp_path / "carry"), "--out", str(tmp_path / "out"), timeout=90)
    assert result.returncode == 2 and seconds < 60
    assert "cannot import vigen_gpu_check_absent_module (ModuleNotFoundError" in result.stderr
    assert "tensordict (" not in result.stderr, "only what failed is named"
    report = json.loads((tmp_path / "out" / "figures.json").read_text())
    assert report["install"]["status"] == "failed" and report["install"]["seconds"] < 60
    assert "vigen_gpu_check_absent_module" in (tmp_path / "out" / "logs" / "install.log").read_text()


def test_no_carry_folder_names_the_command_that_builds_it(tmp_path):
    result, seconds = gpu_check("--carry", str(tmp_path / "absent"), "--out", str(tmp_path / "out"), timeout=60)
    assert result.returncode == 2 and seconds < 30
    assert "no carry folder" in result.stderr and "python scripts/gpu_carry.py" in result.stderr


def test_a_command_past_its_budget_is_stopped_with_its_children_and_its_output_kept(tmp_path):
    gpu_check_module = load_module()
    log = tmp_path / "log"
    started = time.perf_counter()
    code, seconds = gpu_check_module.run_logged(
        ["bash", "-c", f"echo started; sleep 60 & echo $! > {tmp_path / 'child'}; wait"], log, dict(os.environ), 1.5)
    assert code is None and 1.4 < seconds < 10 and time.perf_counter() - started < 10
    text = log.read_text()
    assert "started" in text and "the time budget ran out" in text
    child = int((tmp_path / "child").read_text())
    time.sleep(0.2)
    assert not Path(f"/proc/{child}").exists() or "Z" in Path(f"/proc/{child}/stat").read_text().split()[2], \
        "the command's children end with it"


def test_the_table_reader_takes_the_rows_benchmarks_losses_prints(tmp_path):
    log = tmp_path / "log"
    log.write_text("reproduce: python benchmarks/losses.py\ntorch 2.11.0 on NVIDIA H100\n"
                   "| algo | batch | reference ms | vigen ms | speed-up | compiled ms | compiled / eager | compile s | ref GFLOP |"
                   " vigen GFLOP | GPU busy (vigen) | RL-ViGen ms @64 |\n|---|---|---|---|---|---|---|---|---|---|---|---|\n"
                   "| drqv2 | 256 | 20.0 | 31.0 | 2.50× | 8.0 | 3.88× | 41 | 103.6 | 103.6 | 64 % | — |\n"
                   "W1128 a warning line\n| svea | 256 | 34.4 | 59.1 | 0.58× | 59.0 | 1.00× | 50 | 337 | 337 | 14 % | — |\n")
    rows = load_module().table_rows(log)
    assert [row["algo"] for row in rows] == ["drqv2", "svea"], "torch's warnings between the rows are skipped"
    assert rows[0]["compiled ms"] == 8.0 and rows[0]["speed-up"] == 2.5 and rows[0]["GPU busy (vigen)"] == 64.0


@pytest.mark.slow
@pytest.mark.device_prep
def test_the_learner_call_runs_the_device_tests_the_gap_and_every_loss_in_parallel(tmp_path):
    """issue 48's second call (--call learner) on the CPU: tiers 1, 7, 6 in that order; tier 6 compiles in parallel processes
    (here two at once, no compile), times each alone, the named variants first, and names their options."""
    result, _ = gpu_check("--carry", "none", "--call", "learner", "--out", str(tmp_path))
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "figures.json").read_text())
    assert [tier["tier"] for tier in report["tiers"]] == [1, 7, 6] and report["status"] == "passed"
    _, gap, losses = (tier["figures"] for tier in report["tiers"])
    assert [row["row"][0] for row in gap["rows"]] == ["A", "B", "C", "D", "E"]
    assert [row["algo"] for row in losses["rows"]] == ["drqv2", "drqv2", "drq"] and not losses["not_reached"]
    assert losses["rows"][0]["options"] == "TF32 default, fp32, channels-last off, captured", "the variants are timed first"
    assert losses["rows"][0]["captured ms"] > 0, "the update with its sampling inside"
    assert any(line.startswith("--jobs 2: compiled in") for line in losses["summary"])


@pytest.mark.slow
@pytest.mark.device_prep
@pytest.mark.render
def test_the_end_to_end_call_runs_the_throughput_tier_with_several_runs(tmp_path):
    """issue 48's first call (--call e2e) on the CPU: tier 5 alone, a multi-worker configuration, then two runs at once."""
    result, _ = gpu_check("--carry", "none", "--call", "e2e", "--out", str(tmp_path))
    assert result.returncode == 0, result.stdout + result.stderr
    report = json.loads((tmp_path / "figures.json").read_text())
    (tier,) = report["tiers"]
    results = {result["name"]: result for result in tier["figures"]["results"]}
    assert list(results) == ["2w-overlap-eager-device", "1w-overlap-eager-memmap x2"]
    group = results["1w-overlap-eager-memmap x2"]
    assert group["runs"] == 2 and len(group["each_run"]) == 2 and group["status"] == "passed"
    assert group["figures"]["aggregate_frames_per_s"] == pytest.approx(sum(group["figures"]["frames_per_s_each"]))


def test_the_calls_fit_the_device_tool_and_come_in_order():
    """Each call stops itself before the device tool's 600 s and 64 MiB; the end-to-end call comes first, its compiled
    8-worker configuration given at least 170 s; the learner call's budgets add up within its deadline."""
    module = load_module()
    e2e, learner = module.CALLS["e2e"], module.CALLS["learner"]
    assert list(module.CALLS) == ["e2e", "learner"]
    assert e2e[1] < 600 and learner[1] < 600
    specs = e2e[2].split("--configs ", 1)[1].split()
    assert specs[0] == "8/overlap/compiled/device@180" and float(specs[0].split("@")[1]) >= 170
    assert sum(float(spec.split("@")[1]) for spec in specs) + module.INSTALL_S <= e2e[1]
    assert sum(module.BUDGET_S["gpu"][tier] or 0 for tier in learner[0]) + module.INSTALL_S < learner[1] - 200, \
        "the losses tier (no budget of its own) keeps at least 200 s"

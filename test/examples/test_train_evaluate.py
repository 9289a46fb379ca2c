"""Smoke runs of the training, evaluation and composition examples with tiny budgets, and resuming."""

from __future__ import annotations

import csv
import json
import subprocess
import sys
from pathlib import Path

import pytest
import torch
from in_process import run

ROOT = Path(__file__).resolve().parents[2]
# config.json as examples/train.py wrote it before vigen.run.TrainConfig, for `--algo drqv2 *TINY`
EARLIER_CONFIG = Path(__file__).with_name("data") / "config_2026-11.json"
TINY = ["--env", "dmc/cartpole-balance", "--seed-frames", "200", "--eval-every", "400", "--eval-episodes", "1",
        "--batch-size", "8", "--hidden-dim", "32", "--buffer-size", "2000", "--episode-length", "100"]


def run_process(script: str, *args: str | Path) -> subprocess.CompletedProcess:
    """``python examples/<script> args`` in a process of its own, which must exit 0: for scripts with no ``main(argv)``,
    and for runs whose worker processes import the script's functions by its module name (``in_process.run`` runs the
    others in this process)."""
    result = subprocess.run([sys.executable, str(ROOT / "examples" / script), *map(str, args)], capture_output=True,
                            text=True, cwd=ROOT)
    assert result.returncode == 0, result.stderr[-3000:]
    return result


def _eval_log(run_dir: Path) -> list[list[str]]:
    return list(csv.reader((run_dir / "logs" / "scalars" / "eval" / "train_return.csv").open()))


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Path:
    run_dir = tmp_path_factory.mktemp("runs") / "drqv2"
    run("train.py", "--algo", "drqv2", "--frames", "400", "--out", run_dir, *TINY)
    return run_dir


@pytest.mark.render
def test_train_writes_config_logs_and_checkpoints(trained):
    config = json.loads((trained / "config.json").read_text())
    assert config["algo"] == "drqv2" and config["batch_size"] == 8 and config["observation_shape"] == [9, 84, 84]
    earlier = json.loads(EARLIER_CONFIG.read_text())
    assert list(config) == list(earlier), "the keys and order of earlier runs"
    # since issue 42 the std schedule and the rewards' scale default to the algorithm's (null), which the earlier values are
    unset = {"std_duration": 100_000, "std_init": 1.0, "std_final": 0.1, "reward_scale": 1.0}
    assert {key: value for key, value in config.items() if key not in unset} == \
        {key: value for key, value in earlier.items() if key not in unset}
    assert all(config[key] is None and earlier[key] == value for key, value in unset.items())
    checkpoint = torch.load(trained / "checkpoints" / "frames_00000400.pt", weights_only=True)
    # 400 frames = 200 agent steps; updates every 2 steps after the 100 seed steps
    assert (checkpoint["steps"], checkpoint["updates"]) == (200, 50)
    assert int(checkpoint["loss"]["schedule_step"]) == 200
    assert [row[0] for row in _eval_log(trained)] == ["400"]
    assert (trained / "logs" / "scalars" / "train" / "loss_critic.csv").exists()


@pytest.mark.render
def test_resume_continues_the_counters_and_keeps_earlier_files(trained, tmp_path):
    run_dir = tmp_path / "resumed"
    subprocess.run(["cp", "-r", str(trained), str(run_dir)], check=True)
    (run_dir / "config.json").write_text(EARLIER_CONFIG.read_text())  # a run started before TrainConfig resumes too
    first = (run_dir / "checkpoints" / "frames_00000400.pt").read_bytes()
    run("train.py", "--resume", run_dir, "--frames", "800")
    checkpoint = torch.load(run_dir / "checkpoints" / "frames_00000800.pt", weights_only=True)
    assert (checkpoint["steps"], checkpoint["updates"]) == (400, 150), "counters continue from the saved ones"
    assert checkpoint["optimizer"]["state"], "the optimizer state came back"
    assert (run_dir / "checkpoints" / "frames_00000400.pt").read_bytes() == first
    assert [row[0] for row in _eval_log(run_dir)] == ["400", "800"], "logs are appended, not rewritten"
    assert checkpoint["replay"]["len"] >= 390, "the replay buffer holds the transitions of both parts"


@pytest.mark.render
def test_new_runs_never_reuse_a_folder(trained):
    config = (trained / "config.json").read_text()
    run("train.py", "--frames", "200", "--out", trained, *TINY)
    assert (trained.parent / "drqv2-1" / "config.json").exists()
    assert (trained / "config.json").read_text() == config


@pytest.mark.render
def test_evaluate_writes_the_report(trained, tmp_path):
    out = tmp_path / "report"
    result = run("evaluate.py", trained, "--levels", "train", "color_hard", "--episodes", "1", "--random", "--out", out)
    assert "| level | drqv2 | random |" in result.stdout
    assert {p.name for p in out.iterdir()} == {"episodes.csv", "summary.csv", "report.md", "levels.png", "gaps.csv",
                                               "improvements.csv", "profile.png"}
    report = (out / "report.md").read_text()
    assert "## Generalization gap" in report and "## Probability of improvement" in report
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert [(r["method"], r["level"]) for r in rows] == [
        ("drqv2", "train"), ("drqv2", "color_hard"), ("random", "train"), ("random", "color_hard")]
    assert all(int(r["length"]) == 50 for r in rows), "--episode-length 100 control steps = 50 agent steps"
    run("evaluate.py", trained, "--levels", "train", "--episodes", "1", "--out", out)
    assert (tmp_path / "report-1" / "report.md").exists() and len((out / "episodes.csv").read_text().splitlines()) == 5


@pytest.mark.render
@pytest.mark.render
def test_an_exported_agent_evaluates_as_its_run_does(trained, tmp_path):
    import torch

    from vigen.pretrained import export_policy
    from vigen.run import env_action_spec, load_agent

    loaded = load_agent(trained)
    export_policy(loaded.config, loaded.agent.loss, env_action_spec(loaded.config), tmp_path, "exported",
                  {"frames": loaded.frames}, dtype=torch.float32)
    episodes = {}
    for name, source in (("run", [trained]), ("exported", ["--pretrained", tmp_path / "exported.pt"])):
        run("evaluate.py", *source, "--levels", "color_hard", "--episodes", "1", "--out", tmp_path / name)
        episodes[name] = [(r["method"], r["level"], r["frames"], r["return"]) for r in csv.DictReader((tmp_path / name / "episodes.csv").open())]
    assert episodes["exported"] == episodes["run"], "float32 export: the same actions, so the same episodes"


def test_evaluate_names_a_missing_checkpoint(tmp_path, evaluate_script, stopped):
    assert "has no checkpoints" in stopped(evaluate_script.main, [tmp_path])


@pytest.mark.render
def test_evaluate_names_a_checkpoint_moved_out_of_its_run_folder(trained, tmp_path, evaluate_script, stopped):
    moved = tmp_path / "frames_00000400.pt"
    moved.write_bytes((trained / "checkpoints" / "frames_00000400.pt").read_bytes())
    said = stopped(evaluate_script.main, [moved])
    assert "no config.json at" in said and "keep the checkpoint in its run folder" in said


@pytest.mark.slow
@pytest.mark.parametrize("algo", ["svea", "sgqn", *(pytest.param(algo, marks=pytest.mark.matrix)
                                                    for algo in ("srm", "curl", "drq", "sada", "pieg", "madi", "simgrl", "vrl3", "scpl"))])
def test_train_every_algorithm(algo, tmp_path):
    run("train.py", "--algo", algo, "--frames", "400", "--out", tmp_path / algo, *TINY)
    assert (tmp_path / algo / "checkpoints" / "frames_00000400.pt").exists()


@pytest.mark.render
@pytest.mark.slow
@pytest.mark.matrix  # inductor compiles the update for about a minute on 2 cores
def test_train_with_a_compiled_update_logs_its_compile_time(tmp_path):
    result = run("train.py", "--compile", "--device", "cpu", "--frames", "400", "--out", tmp_path / "run", *TINY)
    assert "compiled the update in" in result.stdout
    assert json.loads((tmp_path / "run" / "config.json").read_text())["compile"] is True
    assert (tmp_path / "run" / "logs" / "scalars" / "train" / "compile_seconds.csv").exists()


@pytest.mark.render
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA")
def test_a_gpu_run_resumes_on_the_gpu_and_evaluates_on_the_cpu(tmp_path):
    run_dir = tmp_path / "gpu"
    run("train.py", "--device", "cuda", "--frames", "400", "--out", run_dir, *TINY)
    checkpoint = torch.load(run_dir / "checkpoints" / "frames_00000400.pt", weights_only=True, map_location="cpu")
    assert len(checkpoint["random"]["cuda"]) == torch.cuda.device_count()
    run("train.py", "--resume", run_dir, "--frames", "800", "--device", "cuda")
    run("evaluate.py", run_dir, "--device", "cpu", "--levels", "train", "--episodes", "1", "--episode-length", "10",
        "--out", tmp_path / "report")


@pytest.mark.render
def test_compose_example_trains_and_tests(tmp_path):
    result = run_process("compose_torchrl.py", "--frames", "300", "--batch-size", "8", "--eval-steps", "30")
    assert "loss_critic" in result.stdout
    assert "| level | svea |" in result.stdout and "| gaussian_noise |" in result.stdout


@pytest.mark.slow
@pytest.mark.render
def test_train_with_worker_processes(tmp_path):
    """--workers 2: a MultiSyncCollector; n-step returns per worker, every transition stored once."""
    run_process("train.py", "--workers", "2", "--frames", "800", "--out", tmp_path / "run", *TINY)
    checkpoint = torch.load(tmp_path / "run" / "checkpoints" / "frames_00000800.pt", weights_only=True)
    assert (checkpoint["steps"], checkpoint["updates"]) == (400, 150)
    assert checkpoint["replay"]["len"] == 400 - 2 * 3, "each worker's last 3 steps wait for their n-step window"


@pytest.mark.render
def test_robosuite_train_then_evaluate_reports_success(tmp_path):
    """RL-ViGen's robosuite protocol in small: scenes picked by seed, a success-rate table next to the returns."""
    pytest.importorskip("robosuite", reason="the robosuite extra is not installed: pip install -e '.[robosuite]'")
    run_dir = tmp_path / "lift"
    run("train.py", "--algo", "drqv2", "--env", "robosuite/lift", "--frames", "100", "--seed-frames", "50", "--eval-every",
        "100", "--eval-episodes", "1", "--batch-size", "8", "--hidden-dim", "32", "--buffer-size", "2000",
        "--episode-length", "50", "--out", run_dir)
    config = json.loads((run_dir / "config.json").read_text())
    assert config["env"] == "robosuite/lift" and config["action_dim"] == 7
    out = tmp_path / "report"
    result = run("evaluate.py", run_dir, "--levels", "easy", "robot_iiwa", "--seeds", "0", "1", "--episodes", "1",
                 "--episode-length", "10", "--out", out)
    assert "| level | drqv2 |" in result.stdout
    rows = list(csv.DictReader((out / "episodes.csv").open()))
    assert [(r["level"], r["seed"]) for r in rows] == [("easy", "0"), ("easy", "1"), ("robot_iiwa", "0"), ("robot_iiwa", "1")]
    assert all(int(r["length"]) == 10 and r["success"] in ("True", "False") for r in rows)
    assert "## Success rate (%)" in (out / "report.md").read_text() and (out / "summary_success.csv").exists()


@pytest.mark.render
@pytest.mark.parametrize("flags, message", [
    (["--eval-levels", "colour_hard"], "--eval-levels"),
    (["--eval-every", "1"], "--eval-every 1 is below one agent step"),
    (["--frames", "-2"], "--frames"),
    (["--seed-frames", "-1"], "--seed-frames"),
    (["--buffer-size", "4"], "--buffer-size 4 is below --batch-size 8"),
    (["--workers", "0"], "--workers must be an integer >= 1"),
    (["--env", "dmc/cartpole-balanse"], "Unknown env"),
    (["--encoder-weights", "resnet18.pth"], "drqv2 has no pretrained encoder"),
    (["--algo", "pieg", "--encoder-weights", "no-such-file.pth"], "no such file"),
    (["--device", "cuda:7"], "--device: device 'cuda:7': this machine has"),
    (["--device", "gpu"], "'gpu' is not a device name"),
])
def test_bad_arguments_stop_the_run_before_it_starts(flags, message, tmp_path, train_script, stopped):
    """Each setting is checked before the first frame; the failed start leaves no run folder."""
    said = stopped(train_script.main, ["--frames", "400", "--out", tmp_path / "run", *TINY, *flags])
    assert message in said
    assert not (tmp_path / "run").exists()


@pytest.mark.render
def test_resume_refuses_flags_that_contradict_the_run(trained, tmp_path, train_script, stopped):
    run_dir = tmp_path / "resumed"
    subprocess.run(["cp", "-r", str(trained), str(run_dir)], check=True)
    said = stopped(train_script.main, ["--resume", run_dir, "--frames", "800", "--algo", "svea", "--batch-size", "16"])
    assert "--algo svea (the run has drqv2)" in said and "--batch-size 16 (the run has 8)" in said
    assert not (run_dir / "checkpoints" / "frames_00000800.pt").exists()


@pytest.mark.render
def test_the_run_folder_used_is_printed(trained):
    result = run("train.py", "--frames", "0", "--out", trained, *TINY)
    printed = Path(next(line for line in result.stdout.splitlines() if line.startswith("run folder: "))[12:])
    assert printed != trained and printed.parent == trained.parent and (printed / "config.json").exists()


@pytest.mark.render
def test_protocol_sets_the_papers_settings_and_records_overrides(tmp_path):
    run_dir = tmp_path / "dmcgb"
    result = run("train.py", "--protocol", "dmcgb", "--frames", "800", "--out", run_dir, *TINY)
    assert "budget: 500,000 agent steps (4,000,000 frames at action repeat 8)" in result.stdout
    assert "overridden by a flag: frames = 800 (protocol: 4000000)" in result.stdout
    config = json.loads((run_dir / "config.json").read_text())
    assert (config["protocol"], config["action_repeat"], config["frame_stack"], config["image_size"]) == ("dmcgb", 8, 3, 84)
    assert config["protocol_settings"]["frames"] == 4_000_000 and config["protocol_settings"]["eval_episodes"] == 30
    assert config["protocol_overrides"]["eval_every"] == {"protocol": 80_000, "flag": 400}
    checkpoint = torch.load(run_dir / "checkpoints" / "frames_00000800.pt", weights_only=True)
    assert checkpoint["steps"] == 100, "800 frames at cartpole's action repeat 8"


@pytest.mark.render
def test_compare_refuses_another_protocol_before_evaluating(trained, tmp_path, evaluate_script, stopped):
    said = stopped(evaluate_script.main, [trained, "--compare", "dmcgb", "--out", tmp_path / "report"])
    assert "dmc/cartpole-balance: action repeat 2 in the run, 8 in protocol dmcgb" in said
    assert not (tmp_path / "report").exists(), "the check comes before any episode"


@pytest.mark.render
def test_compare_puts_the_run_beside_the_published_curve(trained, tmp_path, evaluate_script, stopped):
    out = tmp_path / "report"

    def refused(*flags: str) -> str:
        said = stopped(evaluate_script.main, [trained, "--compare", "drqv2", *flags, "--out", out])
        assert not out.exists(), "refused before any episode"
        return said

    assert "episode length 100 in the run, 1000 in protocol drqv2" in refused(), "the run's 100-step episodes"
    # DrQ-v2 publishes its curve at 0 and 20,000 frames: compare() sets the 400-frame run beside the mean interpolated
    # between them (never beside a point at another budget), and says so; no --allow-budget-mismatch is needed
    # the run names no recipe (--algo drqv2 with vigen's cpu preset): compare() refuses DrQ-v2's own curve (recipe drqv2)
    # unless asked, and then names every setting that differs
    assert "the run was trained by no recipe (vigen's algorithm defaults), drqv2's drqv2 row by recipe drqv2" in \
        refused("--episode-length", "1000")
    result = run("evaluate.py", trained, "--compare", "drqv2", "--episode-length", "1000", "--episodes", "1",
                 "--allow-recipe-mismatch", "--out", out)
    assert "| dmc/cartpole-balance | train | drqv2 | return |" in result.stdout and "drqv2: drqv2" in result.stdout
    lines = list(csv.DictReader((out / "published.csv").open()))
    assert [(line["source"], line["published_frames"], line["budget_matches"]) for line in lines] == [("drqv2", "400", "False")]
    assert lines[0]["notes"].startswith("published mean interpolated linearly between 0 frames (")
    assert "and 20,000 frames (" in lines[0]["notes"] and "the source publishes no point at 400" in lines[0]["notes"]
    assert "batch_size: not set in the run" not in lines[0]["notes"], "a run of no recipe is named as such"
    assert "the run was trained by no recipe (vigen's algorithm defaults), the published row by recipe drqv2" in lines[0]["notes"]
    assert (out / "published.png").exists() and "## Published" in (out / "report.md").read_text()

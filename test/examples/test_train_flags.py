"""examples/train.py's flags come from TrainConfig and its Launch (parsed by tyro): recipes, resumes, the checks before
any work, one writer per run folder (every flag's name, meaning and default: test_script_flags.py)."""

from __future__ import annotations

import json
import os
import socket
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from vigen.run import PRESETS, RunSchedule

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def train(train_script):
    return train_script  # examples/train.py, loaded once (test/examples/conftest.py)


def test_recipe_list_prints_every_recipe_and_stops(train, capsys):
    with pytest.raises(SystemExit) as stopped:
        train.parse_args(["--recipe", "list"])
    assert stopped.value.code == 0
    printed = capsys.readouterr().out
    assert "recipe svea-dmcgb: SVEA as DMC-GB trains it" in printed and "departs (one-step)" in printed


def test_a_recipe_sets_the_run_and_a_flag_over_it_is_recorded(train):
    config, _ = train.parse_args(["--recipe", "svea-dmcgb", "--env", "dmc/cartpole-swingup", "--seed-steps", "10",
                                  "--no-seed-catch-up"])
    assert (config.algo, config.batch_size, config.protocol, config.actor_update_every, config.seed_catch_up) == \
        ("svea", 128, "dmcgb", 2, False)
    assert config.recipe_overrides == {"seed_steps": {"recipe": 1000, "flag": 10},
                                       "seed_catch_up": {"recipe": True, "flag": False}}
    with pytest.raises(SystemExit, match="--algo drqv2 and --recipe svea-dmcgb"):
        train.parse_args(["--recipe", "svea-dmcgb", "--algo", "drqv2"])


def test_flags_build_the_same_config_as_the_preset_with_overrides(train, tmp_path):
    config, launch = train.parse_args(["--algo", "svea", "--preset", "paper", "--batch-size", "32", "--compile", "--eval-levels",
                                       "train", "color_hard", "--threads", "1", "--device", "cpu", "--out", str(tmp_path)])
    assert config == replace(PRESETS["paper"], algo="svea", batch_size=32, compile=True, eval_levels=("train", "color_hard"))
    assert (launch.threads, launch.device, launch.out, launch.resume) == (1, "cpu", tmp_path, None)


@pytest.mark.parametrize("flags, message", [
    (["--threads", "0"], "--threads must be >= 1, got 0"),
    (["--ray-address", "10.0.0.1:6379"], "--ray-address names the Ray cluster of --collector ray"),
    (["--lr", "-1"], "--lr must be > 0"),
    (["--protocol", "dmcgb", "--env", "robosuite/lift"], "--protocol dmcgb: protocol 'dmcgb' covers the dmc suite"),
    (["--overlap", "--collector", "ray"], "--overlap collects in this machine's worker processes"),
    (["--ray", "--collector", "local"], "--ray is --collector ray with its cluster"),
    (["--ray", "10.0.0.1:6379", "--ray-address", "10.0.0.2:6379"], "--ray is --collector ray with its cluster"),
])
def test_bad_flags_stop_before_any_work(train, flags, message):
    with pytest.raises(SystemExit) as stop:
        train.parse_args(flags)
    assert message in str(stop.value.code)


def test_overlap_is_a_setting_of_the_run_and_the_replay_copy_and_timers_are_how_it_runs(train, tmp_path):
    """--overlap changes what is learned (one batch of policy lag), so config.json keeps it and a resume may not change it;
    --replay-on-device and --time-stages change only where batches are sampled and what is logged."""
    config, launch = train.parse_args(["--overlap", "--workers", "4", "--replay-on-device", "--time-stages", "--out", str(tmp_path)])
    assert (config.overlap, config.workers, launch.replay_on_device, launch.time_stages) == (True, 4, True, True)
    assert config.to_json()["overlap"] is True
    run = tmp_path / "run"
    run.mkdir()
    (run / "config.json").write_text(json.dumps(replace(config, observation_shape=(9, 84, 84), action_dim=1).to_json()))
    config, launch = train.parse_args(["--resume", str(run), "--replay-on-device"])
    assert config.overlap and launch.replay_on_device and not launch.time_stages
    (run / "config.json").write_text(json.dumps({**config.to_json(), "overlap": False}))
    with pytest.raises(SystemExit) as stop:
        train.parse_args(["--resume", str(run), "--overlap"])
    assert "--overlap true (the run has false)" in str(stop.value.code).lower()


def test_resume_needs_a_run_folder_and_no_out(train, tmp_path):
    with pytest.raises(SystemExit, match="no config.json there; pass a run folder of examples/train.py"):
        train.parse_args(["--resume", str(tmp_path)])
    with pytest.raises(SystemExit, match="--out and --resume: a resumed run stays in its folder"):
        train.parse_args(["--resume", str(tmp_path), "--out", str(tmp_path / "elsewhere")])


HOLDER = """
import sys, time
from vigen.io import RunFolderLock
RunFolderLock(sys.argv[1]).acquire()
print("holding", flush=True)
time.sleep(600)
"""


def test_a_second_writer_is_refused_at_once_naming_the_holder_and_a_killed_holders_lock_does_not_block(train, tmp_path):
    run = tmp_path / "run"
    run.mkdir()
    config = replace(PRESETS["cpu"], observation_shape=(9, 84, 84), action_dim=1)
    (run / "config.json").write_text(json.dumps(config.to_json()))
    env = dict(os.environ, OMP_NUM_THREADS="1")
    holder = subprocess.Popen([sys.executable, "-c", HOLDER, str(run)], stdout=subprocess.PIPE, text=True, cwd=ROOT, env=env)
    try:
        assert holder.stdout.readline().strip() == "holding"
        second = subprocess.run([sys.executable, str(ROOT / "examples" / "train.py"), "--resume", str(run), "--threads", "1"],
                                capture_output=True, text=True, cwd=ROOT, env=env, timeout=300)
        assert second.returncode != 0
        assert f"is in use by process {holder.pid} on {socket.gethostname()}, started " in second.stderr, second.stderr
        assert "run folder:" not in second.stdout, "refused before any work (no env, no checkpoint read)"
        with pytest.raises(SystemExit, match=f"in use by process {holder.pid}"):
            train.hold(run)
    finally:
        holder.kill()  # SIGKILL: the holder cleans nothing up; the OS drops its flock
        holder.wait()
    assert json.loads((run / ".writer.json").read_text())["pid"] == holder.pid, "the killed holder's record is left behind"
    lock = train.hold(run)  # ... and does not block
    assert json.loads((run / ".writer.json").read_text())["pid"] == os.getpid()
    lock.release()


def test_ray_is_the_collector_and_its_cluster_as_in_evaluate(train):
    """One spelling of "use Ray" in both scripts: --ray [ADDRESS]; train.py's --collector ray and --ray-address say the same."""
    config, launch = train.parse_args(["--ray"])
    assert (config.collector, launch.ray_address) == ("ray", None)
    config, launch = train.parse_args(["--ray", "10.0.0.1:6379", "--workers", "2"])
    assert (config.collector, config.workers, launch.ray_address) == ("ray", 2, "10.0.0.1:6379")
    assert train.parse_args(["--collector", "ray", "--ray-address", "10.0.0.1:6379"])[0] == config.__class__(collector="ray")


def schedule(frames: int, steps_between_checkpoints: int) -> RunSchedule:
    return RunSchedule(action_repeat=2, frames=frames, seed_steps=0, eval_every=steps_between_checkpoints, worker_batch_steps=100)


def test_the_run_says_before_it_starts_how_many_frames_it_trains():
    """Collector batches of 100 agent steps (--update-every 2) at action repeat 2: the run trains 200 frames at a time."""
    note = schedule(300, 2500).frames_note()
    assert note.startswith("--frames 300: training 400 frames, not 300: the collector gathers whole batches of 100 agent "
                           "steps (200 frames at action repeat 2)")
    assert schedule(400, 2500).frames_note() is None, "a whole number of batches: no note"
    assert "301 frames are 150 whole agent steps" in schedule(301, 2500).frames_note()
    # a checkpoint every 150 agent steps ends a segment at the first batch past it: 200 steps, then 300
    assert "training 600 frames, not 500" in schedule(500, 150).frames_note()
    assert schedule(600, 150).frames_note(steps=200) is None, "resumed at 200 steps"

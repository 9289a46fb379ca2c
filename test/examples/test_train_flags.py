"""examples/train.py's flags come from TrainConfig: every flag of the script before TrainConfig keeps its name and meaning."""

from __future__ import annotations

import importlib.util
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from vigen.run import PRESETS

ROOT = Path(__file__).resolve().parents[2]
# train.py's flags before TrainConfig (README, docs/, scripts/ and benchmarks/ use them)
FLAGS = ["--algo", "--env", "--preset", "--protocol", "--frames", "--action-repeat", "--frame-stack", "--image-size", "--seed",
         "--out", "--resume", "--workers", "--collector", "--ray-address", "--eval-levels", "--logger", "--episode-length",
         "--threads", "--device", "--compile", "--encoder-weights", "--batch-size", "--buffer-size", "--lr", "--hidden-dim",
         "--feature-dim", "--n-step", "--gamma", "--tau", "--seed-frames", "--update-every", "--std-duration", "--eval-every",
         "--eval-episodes", "--std-init", "--std-final", "--reward-scale"]


@pytest.fixture(scope="module")
def train():
    spec = importlib.util.spec_from_file_location("train_example", ROOT / "examples" / "train.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # dataclasses look their module up there
    spec.loader.exec_module(module)
    yield module
    del sys.modules[spec.name]


def test_every_earlier_flag_is_still_there(train):
    options = {option for action in train.make_parser()._actions for option in action.option_strings}
    assert set(FLAGS) <= options


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
])
def test_bad_flags_stop_before_any_work(train, flags, message):
    with pytest.raises(SystemExit) as stop:
        train.parse_args(flags)
    assert message in str(stop.value.code)


def test_resume_needs_a_run_folder_and_no_out(train, tmp_path):
    with pytest.raises(SystemExit, match="no config.json there; pass a run folder of examples/train.py"):
        train.parse_args(["--resume", str(tmp_path)])
    with pytest.raises(SystemExit, match="--out and --resume: a resumed run stays in its folder"):
        train.parse_args(["--resume", str(tmp_path), "--out", str(tmp_path / "elsewhere")])

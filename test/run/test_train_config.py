"""TrainConfig: presets against the papers, the layers of a new run, protocols, config.json old and new, checks, flags."""

from __future__ import annotations

import json
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import pytest

from vigen.losses import ALGOS, LinearSchedule
from vigen.run import (DEFAULT_FRAMES, PRESETS, TrainConfig, check_runnable, exploration_std_schedule, new_config, parse_flags,
                       resumed_config, with_protocol)

DATA = Path(__file__).resolve().parents[1] / "examples" / "data"
# the flags that wrote DATA / "config_2026-11.json" with examples/train.py as it was before TrainConfig
TINY = dict(algo="drqv2", env="dmc/cartpole-balance", seed_frames=200, eval_every=400, eval_episodes=1, batch_size=8,
            hidden_dim=32, buffer_size=2000, episode_length=100)


def test_paper_preset_is_drqv2s_hyperparameters():
    """DrQ-v2 (Yarats et al. 2021, https://arxiv.org/abs/2107.09645), Table 1, as RL-ViGen runs it."""
    paper = PRESETS["paper"]
    assert (paper.batch_size, paper.buffer_size, paper.lr, paper.feature_dim, paper.hidden_dim) == (256, 10**6, 1e-4, 50, 1024)
    assert (paper.n_step, paper.gamma, paper.tau, paper.seed_frames, paper.update_every) == (3, 0.99, 0.01, 4000, 2)
    assert exploration_std_schedule(paper) == LinearSchedule(1.0, 0.1, 100_000), "linear(1.0, 0.1, 100000), the algorithm's"
    cpu = PRESETS["cpu"]
    assert replace(cpu, preset="paper", batch_size=256, buffer_size=10**6, eval_episodes=10) == paper, \
        "cpu is the same agent with a smaller batch, buffer and evaluation"
    assert cpu == TrainConfig(), "the defaults are the cpu preset"


def test_flags_override_the_algorithms_defaults_which_the_run_takes_where_a_setting_is_unset():
    """VRL3 (RL-ViGen's Adroit setup): a fixed std of 0.01, door's rewards ×1/20; its record holds them, once."""
    vrl3 = new_config({"algo": "vrl3", "env": "adroit/door", "preset": "paper"})
    assert (vrl3.batch_size, vrl3.std_init, vrl3.std_final, vrl3.reward_scale) == (256, None, None, None), "unset"
    assert (exploration_std_schedule(vrl3).init, exploration_std_schedule(vrl3).final) == (0.01, 0.01)
    assert ALGOS["vrl3"].reward_scale("adroit/door") == 1 / 20 and ALGOS["vrl3"].reward_scale("dmc/walker-walk") == 1.0
    flagged = new_config({"algo": "vrl3", "env": "adroit/door", "std_init": 0.2})
    assert (flagged.std_init, exploration_std_schedule(flagged).init, exploration_std_schedule(flagged).final) == (0.2, 0.2, 0.01)
    assert new_config({"algo": "svea"}) == replace(TrainConfig(), algo="svea")


def test_the_config_module_imports_no_simulator_loss_torch_or_ray():
    """vigen.run.config reads, checks and writes a config where none of them is installed (checks needing them run later)."""
    code = ("import sys, vigen.run.config as c; c.TrainConfig(algo='svea').check(); c.new_config({'algo': 'vrl3'}); "
            "heavy = sorted(m for m in sys.modules if m.split('.')[0] in {'torch', 'torchrl', 'tensordict', 'mujoco', "
            "'dm_control', 'robosuite', 'ray', 'numpy'} or m.startswith(('vigen.losses', 'vigen.envs', 'vigen.run.agent'))); "
            "print(heavy)")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True,
                            cwd=Path(__file__).resolve().parents[2])
    assert result.stdout.strip() == "[]", result.stdout


def test_a_protocol_sets_its_settings_and_records_the_flags_that_override_it():
    """DMC-GB: 500k agent steps at cartpole's action repeat 8 = 4M frames; 30 episodes on train and color_hard."""
    config = new_config({"protocol": "dmcgb", "env": "dmc/cartpole-balance", "frames": 800, "eval_every": 400,
                         "frame_stack": 3, "eval_levels": ("train",)})
    assert (config.action_repeat, config.frame_stack, config.image_size, config.eval_episodes) == (8, 3, 84, 30)
    assert (config.frames, config.eval_every, config.eval_levels) == (800, 400, ("train",))
    assert config.protocol_overrides == {"frames": {"protocol": 4_000_000, "flag": 800},
                                         "eval_every": {"protocol": 80_000, "flag": 400},
                                         "eval_levels": {"protocol": ["train", "color_hard"], "flag": ["train"]}}, \
        "a flag equal to the protocol's value (frame_stack 3) is no override"
    assert new_config({"protocol": "dmcgb"}).eval_levels == ("train", "color_hard")
    assert config.protocol_settings["frames"] == 4_000_000
    assert with_protocol(replace(config, protocol_overrides=None), explicit=()).frames == 4_000_000
    with pytest.raises(ValueError, match="--protocol dmcgb: "):
        new_config({"protocol": "dmcgb", "env": "robosuite/door"})


UNSET_SINCE_42 = ("std_duration", "std_init", "std_final", "reward_scale")
"""Settings whose default became "the algorithm's" (``None``), resolved when the run is built (issue 42)."""


def test_config_json_keeps_the_format_of_earlier_runs():
    """A file written by train.py before TrainConfig existed: the same flags write the same keys, in order, and values.

    But for the settings that now default to their algorithm's (written ``null``): an old file holds the values that
    default resolves to, so old and new files build the same run.
    """
    saved = json.loads((DATA / "config_2026-11.json").read_text())
    config = replace(new_config(TINY), observation_shape=(9, 84, 84), action_dim=1)
    written = config.to_json()
    assert list(written) == list(saved), "the same keys in the same order"
    assert {key: value for key, value in written.items() if key not in UNSET_SINCE_42} == \
        {key: value for key, value in saved.items() if key not in UNSET_SINCE_42}
    assert all(written[key] is None for key in UNSET_SINCE_42)
    old = TrainConfig.from_json(saved)
    assert old == replace(config, frames=DEFAULT_FRAMES, std_duration=100_000, std_init=1.0, std_final=0.1, reward_scale=1.0)
    assert exploration_std_schedule(old) == exploration_std_schedule(config) == LinearSchedule(1.0, 0.1, 100_000), "the same run"
    assert TrainConfig.from_json(json.loads(json.dumps(config.to_json()))) == replace(config, frames=DEFAULT_FRAMES)


def test_a_config_older_than_a_setting_gets_its_default():
    """The oldest config.json train.py wrote had no collector, protocol, compile, env options or std settings."""
    saved = json.loads((DATA / "config_2026-11.json").read_text())
    for newer in ("collector", "encoder_weights", "protocol", "action_repeat", "frame_stack", "image_size", "compile",
                  "std_init", "std_final", "reward_scale"):
        del saved[newer]
    config = resumed_config(saved, {})
    assert (config.collector, config.protocol, config.compile, config.std_init, config.std_final) == ("local", None, False, None, None)
    assert (config.batch_size, config.frames) == (8, DEFAULT_FRAMES)


def test_resume_refuses_contradicting_flags_and_takes_its_budget():
    saved = replace(new_config(TINY), observation_shape=(9, 84, 84), action_dim=1).to_json()
    with pytest.raises(ValueError) as error:
        resumed_config(saved, {"algo": "svea", "batch_size": 8, "eval_levels": ("color_hard",)})
    assert "--algo svea (the run has drqv2)" in str(error.value) and "--eval-levels color_hard (the run has train)" in str(error.value)
    assert "--batch-size" not in str(error.value), "a flag equal to the saved value agrees"
    assert resumed_config(saved, {"frames": 800, "algo": "drqv2"}).frames == 800
    protocol = replace(new_config({**TINY, "protocol": "dmcgb"}), observation_shape=(9, 84, 84), action_dim=1).to_json()
    assert resumed_config(protocol, {}).frames == 4_000_000, "the protocol's budget"
    overridden = replace(new_config({**TINY, "protocol": "dmcgb", "frames": 800}), observation_shape=(9, 84, 84), action_dim=1)
    assert resumed_config(overridden.to_json(), {}).frames == 800, "the flag that overrode the protocol's budget"


@pytest.mark.parametrize("change, message", [
    (dict(batch_size=0), "--batch-size must be an integer >= 1, got 0"),
    (dict(workers=1.5), "--workers must be an integer >= 1"),
    (dict(frame_stack=0), "--frame-stack must be an integer >= 1"),
    (dict(frames=-1), "--frames and --seed-frames must be >= 0"),
    (dict(buffer_size=4, batch_size=8), "--buffer-size 4 is below --batch-size 8"),
    (dict(gamma=1.5), "--gamma, --tau in (0, 1]"),
    (dict(lr=0.0), "--lr must be > 0"),
    (dict(std_final=-0.1), "--std-init and --std-final must be >= 0"),
    (dict(actor_update_every=0), "--actor-update-every must be an integer >= 1, got 0"),
    (dict(target_update_every=1.5), "--target-update-every must be an integer >= 1"),
    (dict(seed_steps=-1), "--seed-steps must be >= 0"),
    (dict(encoder_tau=0.0), "--encoder-tau must be in (0, 1]"),
    (dict(reward_scale=float("inf")), "--reward-scale positive"),
    (dict(episode_length=0), "--episode-length must be >= 1"),
    (dict(std_duration=0), "--std-duration must be an integer >= 1"),
])
def test_check_names_the_bad_setting(change, message):
    with pytest.raises(ValueError) as error:
        replace(TrainConfig(), **change).check()
    assert message in str(error.value)


@pytest.mark.parametrize("change, message", [
    (dict(encoder_weights="resnet18.pth"), "drqv2 has no pretrained encoder; it applies to vrl3, pieg"),
    (dict(algo="pieg", encoder_weights="no-such-file.pth"), "no such file"),
    (dict(env="dmc/cartpole-balanse"), "Unknown env"),
    (dict(eval_levels=("colour_hard",)), "--eval-levels"),
    (dict(algo="sac"), "--algo sac: no such algorithm"),
])
def test_check_runnable_names_what_needs_the_simulators_losses_or_ray(change, message):
    config = replace(TrainConfig(), **change)
    config.check()  # fine on its own
    with pytest.raises(ValueError) as error:
        check_runnable(config)
    assert message in str(error.value)


def test_flags_hold_only_what_was_typed(capsys):
    flags = parse_flags({"config": TrainConfig}, ["--batch-size", "8", "--eval-levels", "train", "color_hard", "--compile",
                                                  "--lr", "3e-4"])
    assert flags.given("config") == {"batch_size": 8, "eval_levels": ("train", "color_hard"), "compile": True, "lr": 3e-4}
    assert parse_flags({"config": TrainConfig}, []).given("config") == {}
    for bad in (["--algo", "sac"], ["--collector", "slurm"], ["--batch-size", "8.5"], ["--protocol", "dmcgb3"]):
        with pytest.raises(SystemExit):
            parse_flags({"config": TrainConfig}, bad)
    recorded = {"protocol_settings", "protocol_overrides", "recipe_settings", "recipe_overrides", "observation_shape", "action_dim"}
    for name in recorded:  # the run records these itself: no flag
        with pytest.raises(SystemExit):
            parse_flags({"config": TrainConfig}, [f"--{name.replace('_', '-')}", "1"])
    capsys.readouterr()

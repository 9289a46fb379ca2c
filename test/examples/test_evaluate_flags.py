"""examples/evaluate.py's flags come from its EvaluationConfig and Launch (parsed by tyro; every flag's name, meaning and
default: test_script_flags.py), and the command's checks stop with the flag and the fix before any agent loads."""

from __future__ import annotations

from pathlib import Path

import pytest
import torch

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def evaluate(evaluate_script):
    return evaluate_script  # examples/evaluate.py, loaded once (test/examples/conftest.py)


def test_the_flags_keep_their_meanings(evaluate):
    config, launch = evaluate.parse_args(["runs/a", "runs/b", "--pretrained", "svea-cartpole-balance", "--levels", "train",
                                          "color_hard", "--sweep", "camera_rotation", "0", "0.1", "--sweep", "light_color",
                                          "0.5", "--episodes", "3", "--seeds", "0", "1", "--random", "--videos", "/v",
                                          "--episode-length", "20", "--compare", "dmcgb", "--allow-budget-mismatch",
                                          "--allow-stand-ins", "--allow-recipe-mismatch", "--ray", "--workers", "2",
                                          "--device", "cpu", "--out", "r"])
    assert config == evaluate.EvaluationConfig(
        runs=(Path("runs/a"), Path("runs/b")), pretrained=("svea-cartpole-balance",), levels=("train", "color_hard"),
        sweep=(("camera_rotation", "0", "0.1"), ("light_color", "0.5")), episodes=3, seeds=(0, 1), random=True,
        videos=("/v",), episode_length=20, compare="dmcgb", allow_budget_mismatch=True, allow_stand_ins=True,
        allow_recipe_mismatch=True)
    assert launch == evaluate.Launch(ray="local", workers=2, device="cpu", out=Path("r"))
    assert evaluate.parse_args(["--ray", "10.0.0.1:6379"])[1].ray == "10.0.0.1:6379"


def test_the_defaults_are_the_earlier_ones(evaluate):
    config, launch = evaluate.parse_args(["runs/a"])
    assert (config.levels, config.sweep, config.episodes, config.seeds, config.random, config.videos) == (None, (), 10, (0,),
                                                                                                         False, ())
    assert (config.pretrained, config.episode_length, config.compare) == ((), None, None)
    assert launch == evaluate.Launch(ray=None, workers=None, device="auto", out=Path("reports/evaluation"))


@pytest.mark.parametrize("argv, message", [
    (["runs/a", "--device", "tpu"], "--device: device 'tpu' is not a device name"),
    (["runs/a", "--workers", "2"], "--workers 2: it sets the Ray jobs in flight (>= 1) and needs --ray."),
    ([], "give run folders of examples/train.py, or --pretrained NAME (shipped: drqv2-cartpole-balance"),
    (["--pretrained", "nope"], "--pretrained nope: no pretrained agent 'nope'"),
])
def test_the_command_checks_name_the_flag(evaluate, argv, message):
    config, launch = evaluate.parse_args(argv)
    with pytest.raises(SystemExit) as stop:
        evaluate.acting_device(launch)
        evaluate.check_agents_named(config)
    assert message in str(stop.value)


def test_ray_acts_on_the_cpu(evaluate):
    assert evaluate.acting_device(evaluate.Launch(ray="local")) == torch.device("cpu"), "Ray's tasks act on their own CPU"
    with pytest.raises(SystemExit, match="needs --ray"):
        evaluate.acting_device(evaluate.Launch(workers=0, ray=None))


def test_a_sweep_without_intensities_names_the_fix(evaluate):
    with pytest.raises(SystemExit, match="give the intensities after the factor, e.g. --sweep camera_rotation 0 0.1 0.3"):
        evaluate.parse_sweep(("camera_rotation",))


def test_a_report_inside_a_run_folder_in_use_stops_naming_its_writer(evaluate, tmp_path):
    from vigen.io import FolderInUse, RunFolderLock

    run = tmp_path / "runs" / "drqv2-s0"
    (run / "checkpoints").mkdir(parents=True)
    (run / "config.json").write_text("{}")
    with RunFolderLock(run):  # the run trains
        with pytest.raises(SystemExit, match=r"--out .*/reports/eval: .* is in use by process \d+ .*outside the run folder"):
            evaluate.hold_run_folder(run / "reports" / "eval")
    with evaluate.hold_run_folder(run / "reports" / "eval"):  # the run has ended: the report holds the folder meanwhile
        with pytest.raises(FolderInUse, match="is in use by process"):
            RunFolderLock(run).acquire()
    RunFolderLock(run).acquire().release()
    with evaluate.hold_run_folder(tmp_path / "reports" / "eval") as held:
        assert held is None, "outside a run folder: no lock"


def test_runs_play_the_levels_of_their_protocol(evaluate, monkeypatch):
    """Runs trained under one protocol, and the random policy beside them, play that protocol's version of each level
    (evaluate(..., protocol=)); --compare's protocol wins; runs of several protocols or none play vigen's levels as named."""
    from types import SimpleNamespace

    seen = []

    def fake_evaluate(policy, env, levels, **kwargs):
        seen.append((kwargs["tags"]["method"], kwargs["protocol"]))
        return []

    monkeypatch.setattr(evaluate, "evaluate", fake_evaluate)
    config, launch = evaluate.parse_args(["runs/a", "--levels", "color_hard"])
    levels = {"dmc/walker-walk": ["color_hard"]}

    def played(protocols, compared=None):
        agents = [SimpleNamespace(config=SimpleNamespace(protocol=protocol)) for protocol in protocols]
        chosen = evaluate.evaluation_protocol(agents, None if compared is None else SimpleNamespace(protocol=compared))
        runs = [evaluate.Evaluated(None, "dmc/walker-walk", {}, {"method": f"m{i}", "protocol": protocol})
                for i, protocol in enumerate(protocols)]
        seen.clear()
        evaluate.play(runs + evaluate.random_evaluated(runs), levels, [], config, launch, torch.device("cpu"), [0],
                      chosen.name if chosen else None)
        return seen[:]

    assert played(["dmcgb2", "dmcgb2"]) == [("m0", "dmcgb2"), ("m1", "dmcgb2"), ("random", "dmcgb2")]
    assert played(["dmcgb2", ""]) == [("m0", None), ("m1", None), ("random", None)]
    assert played(["dmcgb2", None]) == [("m0", None), ("m1", None), ("random", None)]
    assert played(["dmcgb2"], "dmcgb") == [("m0", "dmcgb"), ("random", "dmcgb")]


def test_a_runs_evaluation_env_takes_its_protocols_test_env_options():
    """RL-ViGen's loco rows come from locoeval.py (scaled actions, the time limit a truncation), not from the training
    path: a run trained under rlvigen_loco is evaluated with the protocol's test_env_options, and trained with its
    train_env_options (TrainConfig.training_env_options, which train.py builds its envs with)."""
    from vigen.evaluation.runs import run_env_options
    from vigen.run import new_config

    config = new_config({"protocol": "rlvigen_loco", "env": "loco/unitree-walk"})
    options = run_env_options(config, None)
    assert options["action_mapping"] == "scaled" and options["time_limit_as"] == "truncated"
    assert options["start_clearance"] == "rlvigen"
    assert config.training_env_options()["action_mapping"] == "rlvigen_train"
    assert config.training_env_options()["time_limit_as"] == "terminated"
    assert "action_mapping" not in run_env_options(new_config({"env": "loco/unitree-walk"}), None)

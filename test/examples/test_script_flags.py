"""Every flag of examples/train.py and examples/evaluate.py keeps its name, meaning and default.

``MAIN`` was recorded from the two scripts of main at ba48bea (argparse, flags made by the hand-written vigen.run.cli)
by enumerating their parsers' actions and parsing an empty command line: each flag's field, kind, value type and the
value it has when not typed. The scripts now parse with tyro; each test below checks one of these against them.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from vigen.run import parse_flags

ROOT = Path(__file__).resolve().parents[2]
ALGOS = ("drqv2", "svea", "srm", "sgqn", "curl", "drq", "sada", "vrl3", "madi", "simgrl", "pieg", "scpl")
PROTOCOLS = ("dmcgb", "dmcgb2", "rlvigen", "rlvigen_loco", "drqv2", "planet")

# flag: (settings, kind, type, default, choices). Kinds: "value" (one), "value +" (one or more), "switch" (--x and --no-x),
# "repeatable +" (each time one or more), "optional value (bare: local)", "positional *" (any number).
MAIN = {
    "train": {
        "--algo": ("TrainConfig", "value", "str", "drqv2", ALGOS),
        "--env": ("TrainConfig", "value", "str", "dmc/cartpole-balance", None),
        "--preset": ("TrainConfig", "value", "str", "cpu", ("paper", "cpu")),
        "--seed": ("TrainConfig", "value", "int", 0, None),
        "--workers": ("TrainConfig", "value", "int", 1, None),
        "--collector": ("TrainConfig", "value", "str", "local", ("local", "ray")),
        "--overlap": ("TrainConfig", "switch", "bool", False, None),
        "--eval-levels": ("TrainConfig", "value +", "str", ("train",), None),
        "--logger": ("TrainConfig", "value", "str", "csv", ("csv", "wandb")),
        "--episode-length": ("TrainConfig", "value", "int", None, None),
        "--encoder-weights": ("TrainConfig", "value", "str", None, None),
        "--protocol": ("TrainConfig", "value", "str", None, PROTOCOLS),
        "--action-repeat": ("TrainConfig", "value", "int", None, None),
        "--frame-stack": ("TrainConfig", "value", "int", None, None),
        "--image-size": ("TrainConfig", "value", "int", None, None),
        "--compile": ("TrainConfig", "switch", "bool", False, None),
        "--batch-size": ("TrainConfig", "value", "int", 64, None),
        "--buffer-size": ("TrainConfig", "value", "int", 100000, None),
        "--lr": ("TrainConfig", "value", "float", 0.0001, None),
        "--hidden-dim": ("TrainConfig", "value", "int", 1024, None),
        "--feature-dim": ("TrainConfig", "value", "int", 50, None),
        "--n-step": ("TrainConfig", "value", "int", 3, None),
        "--gamma": ("TrainConfig", "value", "float", 0.99, None),
        "--tau": ("TrainConfig", "value", "float", 0.01, None),
        "--seed-frames": ("TrainConfig", "value", "int", 4000, None),
        "--update-every": ("TrainConfig", "value", "int", 2, None),
        "--std-duration": ("TrainConfig", "value", "int", None, None),
        "--eval-every": ("TrainConfig", "value", "int", 10000, None),
        "--eval-episodes": ("TrainConfig", "value", "int", 5, None),
        "--std-init": ("TrainConfig", "value", "float", None, None),
        "--std-final": ("TrainConfig", "value", "float", None, None),
        "--reward-scale": ("TrainConfig", "value", "float", None, None),
        "--frames": ("TrainConfig", "value", "int", 100000, None),
        "--recipe": ("TrainConfig", "value", "str", None, None),
        "--seed-steps": ("TrainConfig", "value", "int", None, None),
        "--seed-catch-up": ("TrainConfig", "switch", "bool", False, None),
        "--actor-update-every": ("TrainConfig", "value", "int", 1, None),
        "--target-update-every": ("TrainConfig", "value", "int", 1, None),
        "--encoder-tau": ("TrainConfig", "value", "float", None, None),
        "--out": ("Launch", "value", "Path", None, None),
        "--resume": ("Launch", "value", "Path", None, None),
        "--threads": ("Launch", "value", "int", None, None),
        "--device": ("Launch", "value", "str", "auto", None),
        "--ray-address": ("Launch", "value", "str", None, None),
        "--replay-on-device": ("Launch", "switch", "bool", False, None),
        "--time-stages": ("Launch", "switch", "bool", False, None),
    },
    "evaluate": {
        "runs": ("EvaluationConfig", "positional *", "Path", (), None),
        "--pretrained": ("EvaluationConfig", "value +", "str", (), None),
        "--levels": ("EvaluationConfig", "value +", "str", None, None),
        "--sweep": ("EvaluationConfig", "repeatable +", "str", (), None),
        "--episodes": ("EvaluationConfig", "value", "int", 10, None),
        "--seeds": ("EvaluationConfig", "value +", "int", (0,), None),
        "--random": ("EvaluationConfig", "switch", "bool", False, None),
        "--videos": ("EvaluationConfig", "value +", "str", (), None),
        "--episode-length": ("EvaluationConfig", "value", "int", None, None),
        "--compare": ("EvaluationConfig", "value", "str", None,
                      ("curl", "dmcgb", "dmcgb2", "drqv2", "madi", "planet", "rlvigen", "rlvigen_loco", "sgqn", "simgrl")),
        "--allow-budget-mismatch": ("EvaluationConfig", "switch", "bool", False, None),
        "--allow-stand-ins": ("EvaluationConfig", "switch", "bool", False, None),
        "--allow-partial-data": ("EvaluationConfig", "switch", "bool", False, None),
        "--allow-recipe-mismatch": ("EvaluationConfig", "switch", "bool", False, None),
        "--ray": ("Launch", "optional value (bare: local)", "str", None, None),
        "--workers": ("Launch", "value", "int", None, None),
        "--device": ("Launch", "value", "str", "auto", None),
        "--out": ("Launch", "value", "Path", "reports/evaluation", None),
    },
}
ADDED = {"train": {"--ray": ("Launch", "optional value (bare: local)", "str", None, None)}}
"""Flags added since: train.py's --ray [ADDRESS], the spelling of "use Ray" evaluate.py has (--collector ray [--ray-address])."""
SAMPLES = {"int": ("7", 7), "float": ("0.5", 0.5), "str": ("x", "x"), "Path": ("some/folder", Path("some/folder"))}


@pytest.fixture(scope="module")
def scripts(train_script, evaluate_script):
    return {"train": train_script, "evaluate": evaluate_script}  # loaded once (test/examples/conftest.py)


def settings_of(script) -> dict[str, type]:
    if hasattr(script, "EvaluationConfig"):
        return {"EvaluationConfig": script.EvaluationConfig, "Launch": script.Launch}
    return {"TrainConfig": script.TrainConfig, "Launch": script.Launch}


def typed(script, argv: list[str]) -> dict[str, object]:
    """The fields the command line sets, with their values (parsed as the script parses it, before its own checks)."""
    parsed = parse_flags(settings_of(script), argv)
    return {name: value for kind in parsed.settings for name, value in parsed.given(kind).items()}


def field(flag: str) -> str:
    return flag.removeprefix("--").replace("-", "_")


@pytest.mark.parametrize("name", MAIN)
def test_help_lists_every_flag_of_main_and_no_other(scripts, name, capsys):
    with pytest.raises(SystemExit):
        scripts[name].parse_args(["--help"])
    listed = set()
    for line in capsys.readouterr().out.splitlines():
        text = line.strip("│ ")
        if text.startswith("--"):
            listed |= {flag for flag in re.findall(r"--[a-z][a-z-]*", text.split("  ")[0]) if not flag.startswith("--no-")}
    assert listed - {"--help"} == {flag for flag in {**MAIN[name], **ADDED.get(name, {})} if flag.startswith("--")}


@pytest.mark.parametrize("name", MAIN)
def test_every_flag_keeps_its_default(scripts, name):
    values = {type(part).__name__: part for part in scripts[name].parse_args([])}
    for flag, (owner, _, kind, default, _) in {**MAIN[name], **ADDED.get(name, {})}.items():
        value = getattr(values[owner], field(flag))
        assert value == (Path(default) if isinstance(default, str) and kind == "Path" else default), flag


@pytest.mark.parametrize("name", MAIN)
def test_every_flag_keeps_its_meaning(scripts, name, capsys):
    """Each flag sets its field, with a value of its type, in each of its forms; a tuple flag takes one value or more."""
    script = scripts[name]
    for flag, (owner, kind, value_type, default, choices) in {**MAIN[name], **ADDED.get(name, {})}.items():
        text, value = (choices[0], choices[0]) if choices else SAMPLES.get(value_type, (None, None))
        if kind == "value":
            assert typed(script, [flag, text]) == {field(flag): value}, flag
        elif kind == "value +":
            assert typed(script, [flag, text, text]) == {field(flag): (value, value)}, flag
            with pytest.raises(SystemExit):
                typed(script, [flag])
        elif kind == "switch":
            assert typed(script, [flag]) == {field(flag): True} and typed(script, [flag.replace("--", "--no-")]) == {
                field(flag): False}, flag
        elif kind == "repeatable +":
            assert typed(script, [flag, "a", "1", flag, "b"]) == {field(flag): (("a", "1"), ("b",))}, flag
        elif kind == "optional value (bare: local)":
            assert typed(script, [flag]) == {field(flag): "local"} and typed(script, [flag, "10.0.0.1:6379"]) == {
                field(flag): "10.0.0.1:6379"}, flag
        elif kind == "positional *":
            parsed = parse_flags(settings_of(script), ["a", "b"]).settings[owner]
            assert getattr(parsed, flag) == (Path("a"), Path("b")) and getattr(parse_flags(settings_of(script), []).settings[
                owner], flag) == default
        if choices:
            with pytest.raises(SystemExit):
                typed(script, [flag, "no-such-choice"])
    capsys.readouterr()

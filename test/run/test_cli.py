"""vigen.run.cli: a command's flags from its settings dataclasses, parsed by tyro, with what vigen adds to it (the flags
typed, a flag whose value may be left out, one value or more), as examples/train.py and examples/evaluate.py parse theirs."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Annotated

import pytest
from tyro.conf import Positional, UseAppendAction, arg

from vigen.run import BareValue, flag_value, parse_flags, unset_means


@dataclass(frozen=True)
class Command:
    runs: Positional[tuple[Path, ...]] = ()
    """run folders"""
    names: Annotated[tuple[str, ...], arg(metavar="NAME")] = ()
    """shipped agents"""
    sweep: Annotated[tuple[tuple[str, ...], ...], UseAppendAction] = ()
    """a factor and its intensities; repeatable"""
    seeds: tuple[int, ...] = (0,)
    """seeds"""
    ray: Annotated[str | None, BareValue("local"), unset_means("no Ray")] = None
    """a local Ray cluster, or the one at ADDRESS"""
    random: bool = False
    """a random policy too"""
    out: Path = Path("reports")
    """the report folder"""


def parsed(*argv: str) -> Command:
    return parse_flags({"command": Command}, list(argv)).settings["command"]


def test_nothing_typed_gives_the_dataclass_defaults_and_no_flag_typed():
    result = parse_flags({"command": Command}, [])
    assert result.settings["command"] == Command() and result.typed == frozenset() and result.given("command") == {}


def test_each_kind_of_field_reads_its_values_typed():
    command = parsed("runs/a", "runs/b", "--names", "x", "y", "--sweep", "camera_fov", "0.1", "--sweep", "brightness", "1",
                     "--seeds", "3", "4", "--random", "--out", "elsewhere")
    assert command == Command(runs=(Path("runs/a"), Path("runs/b")), names=("x", "y"),
                              sweep=(("camera_fov", "0.1"), ("brightness", "1")), seeds=(3, 4), random=True,
                              out=Path("elsewhere"))


def test_the_flags_typed_are_recorded_whatever_their_value():
    """A layer under the flags (a recipe, a preset, a resumed run) gives way to a flag typed with its own default value, and
    to ``--no-`` switches; a switch neither typed stays unset."""
    result = parse_flags({"command": Command}, ["--seeds", "0", "--no-random", "--out=reports"])
    assert result.given("command") == {"seeds": (0,), "random": False, "out": Path("reports")}
    assert parse_flags({"command": Command}, ["--random"]).given("command") == {"random": True}


def test_a_flag_with_a_bare_value_takes_it_alone_or_a_value_after_it():
    assert parsed().ray is None
    assert parsed("--ray").ray == "local"
    assert parsed("--ray", "10.0.0.1:6379").ray == "10.0.0.1:6379"
    assert parsed("--ray", "--random") == Command(ray="local", random=True)


@pytest.mark.parametrize("argv", [["--seeds"], ["--names", "--random"], ["--sweep", "a", "1", "--sweep"]])
def test_a_tuple_flag_needs_one_value_or_more(argv, capsys):
    with pytest.raises(SystemExit) as stop:
        parsed(*argv)
    assert stop.value.code == 2 and "give one value or more after it" in capsys.readouterr().err


@pytest.mark.parametrize("argv, message", [(["--seeds", "x"], "--seeds"), (["--nope"], "--nope"), (["--random=3"], "--random")])
def test_a_malformed_command_line_stops_with_status_2_naming_the_flag(argv, message, capsys):
    with pytest.raises(SystemExit) as stop:
        parsed(*argv)
    assert stop.value.code == 2 and message in capsys.readouterr().err


def test_the_help_names_the_values_and_the_defaults(capsys):
    with pytest.raises(SystemExit):
        parsed("--help")
    text = " ".join(capsys.readouterr().out.replace("│", " ").split())
    assert "--names NAME" in text and "--ray STR" in text and "--sweep" in text
    assert "a local Ray cluster, or the one at ADDRESS (default: no Ray)" in text
    assert "seeds (default: 0)" in text and "--random, --no-random" in text


def test_values_print_as_they_are_typed():
    assert flag_value(("train", "color_hard")) == "train color_hard"
    assert flag_value(()) == flag_value(None) == "none"
    assert flag_value(0.5) == "0.5"

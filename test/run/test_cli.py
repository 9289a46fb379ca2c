"""vigen.run.cli: flags generated from a dataclass's fields, as examples/train.py and examples/evaluate.py build theirs."""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import pytest

from vigen.run import add_flags, flag_value, given_flags, setting


@dataclass(frozen=True)
class Command:
    runs: tuple[Path, ...] = setting((), "run folders", positional=True)
    names: tuple[str, ...] = setting((), "shipped agents", metavar="NAME")
    sweep: tuple[tuple[str, ...], ...] = setting((), "a factor and its intensities; repeatable", metavar="FACTOR I1")
    seeds: tuple[int, ...] = setting((0,), "seeds")
    ray: str | None = setting(None, "a local Ray cluster, or the one at ADDRESS", unset="no Ray", bare="local",
                              metavar="ADDRESS")
    random: bool = setting(False, "a random policy too")
    out: Path = setting(Path("reports"), "the report folder")


def parsed(*argv: str, given_only: bool = True) -> Command:
    parser = argparse.ArgumentParser()
    add_flags(parser, Command, given_only=given_only)
    return Command(**given_flags(parser.parse_args(list(argv)), Command))


@pytest.mark.parametrize("given_only", [True, False])
def test_nothing_typed_gives_the_dataclass_defaults(given_only):
    assert parsed(given_only=given_only) == Command()


def test_each_kind_of_field_reads_its_values_typed():
    command = parsed("runs/a", "runs/b", "--names", "x", "y", "--sweep", "camera_fov", "0.1", "--sweep", "brightness", "1",
                     "--seeds", "3", "4", "--random", "--out", "elsewhere")
    assert command == Command(runs=(Path("runs/a"), Path("runs/b")), names=("x", "y"),
                              sweep=(("camera_fov", "0.1"), ("brightness", "1")), seeds=(3, 4), random=True,
                              out=Path("elsewhere"))


def test_a_switch_turns_on_and_off():
    """``--no-random`` turns off what a layer under the flags (a recipe, a preset) turned on; neither typed: unset."""
    assert parsed("--random").random is True and parsed("--no-random").random is False
    parser = argparse.ArgumentParser()
    add_flags(parser, Command, given_only=True)
    assert given_flags(parser.parse_args(["--no-random"]), Command)["random"] is False
    assert "random" not in given_flags(parser.parse_args([]), Command)


def test_a_flag_with_a_bare_value_takes_it_alone_or_a_value_after_it():
    assert parsed().ray is None
    assert parsed("--ray").ray == "local"
    assert parsed("--ray", "10.0.0.1:6379").ray == "10.0.0.1:6379"
    assert parsed("--ray", "--random") == Command(ray="local", random=True)


def test_the_help_names_the_values_and_the_defaults():
    parser = argparse.ArgumentParser()
    add_flags(parser, Command)
    text = " ".join(parser.format_help().split())
    assert "--names NAME [NAME ...]" in text and "--ray [ADDRESS]" in text and "--sweep FACTOR I1 [FACTOR I1 ...]" in text
    assert "a local Ray cluster, or the one at ADDRESS (default: no Ray)" in text
    assert "seeds (default: 0)" in text and "shipped agents (default: none)" in text


def test_values_print_as_they_are_typed():
    assert flag_value(("train", "color_hard")) == "train color_hard"
    assert flag_value(()) == flag_value(None) == "none"
    assert flag_value(0.5) == "0.5"

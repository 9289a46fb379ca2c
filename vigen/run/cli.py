"""Command-line flags generated from a dataclass: one ``--flag-name`` per documented field, typed by its annotation."""

from __future__ import annotations

import argparse
import dataclasses
import types
import typing
from collections.abc import Callable, Iterable
from typing import Any, Literal


def setting(
    default: Any,
    help: str,
    *,
    choices: Callable[[], Iterable[str]] | None = None,
    unset: str | None = None,
    metavar: str | None = None,
    bare: Any = None,
    positional: bool = False,
) -> Any:
    """A dataclass field that is also a flag: its default, what it means (the flag's help) and, optionally, its choices.

    ``choices`` is a function, called when the parser is built, so that a field may list names
    defined after the class (a registry, the presets). ``unset`` says what a ``None`` default
    means (``"the suite's"``), for the help. ``metavar`` names the flag's values in the help.
    ``bare`` is the value of the flag given without one (``--ray`` alone: ``"local"``; ``--ray
    ADDRESS`` gives the address). ``positional`` makes the field the command's positional
    arguments (``tuple[X, ...]``: any number of them) instead of a ``--flag``. Fields made with
    plain ``dataclasses.field`` (or none) get no flag.

    Examples:
        >>> from dataclasses import dataclass, fields
        >>> @dataclass
        ... class Settings:
        ...     batch_size: int = setting(64, "transitions per update")
        >>> fields(Settings)[0].metadata["help"]
        'transitions per update'
    """
    return dataclasses.field(default=default, metadata={"help": help, "choices": choices, "unset": unset,
                                                        "metavar": metavar, "bare": bare, "positional": positional})


def add_flags(parser: argparse.ArgumentParser, settings: type, *, given_only: bool = False) -> None:
    """Add one flag per :func:`setting` field of the dataclass ``settings`` to ``parser``.

    ``batch_size: int`` becomes ``--batch-size`` of type ``int``; ``X | None`` takes an ``X``;
    ``bool`` is a switch (``--compile``, and ``--no-compile``); ``tuple[str, ...]`` takes one value or more;
    ``tuple[tuple[str, ...], ...]`` is a repeatable flag of one value or more each time
    (``--sweep camera_rotation 0 0.1 --sweep light_color 0.5``); a ``Literal`` or the field's
    ``choices`` restricts the values. The help ends with the default (a switch's is off). Read the
    parsed flags back with :func:`given_flags`.

    Args:
        parser: where the flags go.
        settings: a dataclass whose fields were made with :func:`setting`.
        given_only: every flag defaults to ``None``, so that :func:`given_flags` tells the flags
            typed on the command line from the defaults (the dataclass then fills in the rest).
            A repeatable flag defaults to ``None`` either way.

    Examples:
        >>> import argparse
        >>> from dataclasses import dataclass
        >>> @dataclass
        ... class Settings:
        ...     batch_size: int = setting(64, "transitions per update")
        ...     levels: tuple[str, ...] = setting(("train",), "levels to evaluate")
        ...     sweep: tuple[tuple[str, ...], ...] = setting((), "a factor and its intensities; repeatable")
        >>> parser = argparse.ArgumentParser()
        >>> add_flags(parser, Settings, given_only=True)
        >>> given_flags(parser.parse_args(["--levels", "train", "color_hard"]), Settings)
        {'levels': ('train', 'color_hard')}
        >>> Settings(**given_flags(parser.parse_args(["--sweep", "camera_fov", "0.1", "--sweep", "brightness", "1"]), Settings))
        Settings(batch_size=64, levels=('train',), sweep=(('camera_fov', '0.1'), ('brightness', '1')))
    """
    hints = typing.get_type_hints(settings)
    for field in dataclasses.fields(settings):
        if "help" not in field.metadata:
            continue
        kind = _without_none(hints[field.name])
        shown = field.metadata["unset"] if field.default is None and field.metadata["unset"] else flag_value(field.default)
        options: dict[str, Any] = {"default": None if given_only else field.default,
                                   "help": f"{field.metadata['help']} (default: {shown})"}
        if kind is bool:  # --compile, and --no-compile to turn off what a recipe (or a preset) turns on
            options.update(action=argparse.BooleanOptionalAction, help=field.metadata["help"])
        else:
            if typing.get_origin(kind) is tuple and typing.get_origin(typing.get_args(kind)[0]) is tuple:
                options.update(action="append", default=None)  # argparse appends to a copy of its default
                kind = typing.get_args(kind)[0]
            if typing.get_origin(kind) is tuple:
                options["nargs"] = "*" if field.metadata.get("positional") else "+"
                kind = typing.get_args(kind)[0]
            elif field.metadata.get("bare") is not None:
                options.update(nargs="?", const=field.metadata["bare"])
            if typing.get_origin(kind) is Literal:
                options["choices"] = list(typing.get_args(kind))
                kind = str
            options["type"] = kind
        if field.metadata.get("choices") is not None:
            options["choices"] = list(field.metadata["choices"]())
        if field.metadata.get("metavar") is not None:
            options["metavar"] = field.metadata["metavar"]
        if field.metadata.get("positional"):
            parser.add_argument(field.name, **options)
        else:
            parser.add_argument(flag_name(field.name), **options)


def given_flags(namespace: argparse.Namespace, settings: type) -> dict[str, Any]:
    """The :func:`setting` fields of ``settings`` that ``namespace`` holds a value for, lists as tuples.

    Parsed with ``given_only=True``: the flags typed on the command line; ``settings(**given_flags(...))``
    is then the dataclass with the defaults filled in.
    """
    given = {}
    for field in dataclasses.fields(settings):
        value = getattr(namespace, field.name, None)
        if "help" in field.metadata and value is not None:
            given[field.name] = _tupled(value)
    return given


def flag_name(name: str) -> str:
    """``"batch_size"`` -> ``"--batch-size"``: a field's flag, for messages."""
    return f"--{name.replace('_', '-')}"


def _tupled(value: Any) -> Any:
    """argparse's lists as the tuples a frozen dataclass holds: ``[["a", "b"]]`` -> ``(("a", "b"),)``."""
    return tuple(_tupled(item) for item in value) if isinstance(value, list) else value


def _without_none(kind: Any) -> Any:
    """``int | None`` -> ``int``."""
    if typing.get_origin(kind) in (typing.Union, types.UnionType):
        (kind,) = [arg for arg in typing.get_args(kind) if arg is not type(None)]
    return kind


def flag_value(value: Any) -> str:
    """A value as it is typed after its flag, for messages: ``("train", "color_hard")`` -> ``"train color_hard"``."""
    if isinstance(value, tuple) and value:
        return " ".join(map(str, value))
    return "none" if value is None or value == () else str(value)

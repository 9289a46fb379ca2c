"""Command lines from settings dataclasses, parsed by `tyro <https://brentyi.github.io/tyro/>`_, and what vigen adds to it.

Each field of a settings dataclass is a flag, documented by the docstring below it (a long one as
string literals in parentheses, which Python joins into one, so that tyro does not break its lines): ``batch_size``
is ``--batch-size``; a ``bool`` is a switch (``--compile``, and ``--no-compile`` to turn off what a
layer under the flags turned on); ``tuple[X, ...]`` takes one value or more; a field marked
``tyro.conf.UseAppendAction`` is repeatable, ``tyro.conf.Positional`` holds the positional
arguments; a ``Literal`` (or ``tyro.conf.arg(constructor_factory=...)`` returning one, for names
known only when the command runs) restricts the values. :func:`parse_flags` hands the command's
dataclasses to ``tyro.cli`` in one flat namespace and adds three things tyro does not do:

* **which flags were typed** (:attr:`Parsed.typed`): the layers under the flags (a preset, a
  recipe, a protocol, a resumed run's ``config.json``) give way to the flags on the command line,
  whatever their value, and only to them;
* **a flag whose value may be left out** (:class:`BareValue`, argparse's ``nargs="?"``): ``--ray``
  alone is ``--ray local``, ``--ray ADDRESS`` names a cluster;
* **one value or more** for tuple flags (tyro also takes none): an empty ``--levels`` is refused;
  and a switch typed with a value (``--random=False``, which tyro would read as ``--random``) too.

:func:`flag_name` and :func:`flag_value` spell a field and a value as they are typed, for messages.
"""

from __future__ import annotations

import dataclasses
import inspect
import sys
import types
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Annotated, Any

import tyro


@dataclass(frozen=True)
class BareValue:
    """Marks a flag whose value may be left out: ``Annotated[str | None, BareValue("local")]``.

    Typed alone (at the end of the command line, or before another ``-`` option), the flag takes
    ``value``; otherwise the token after it is its value.
    """

    value: str


RayAddress = Annotated[str | None, BareValue("local"), tyro.conf.arg(metavar="[ADDRESS]")]
"""The type of both scripts' ``--ray`` flag, one spelling of "use Ray": alone, a local cluster (``"local"``); with an
address, the cluster there."""


@dataclass(frozen=True)
class Parsed:
    """A parsed command line: one settings instance per name, and the fields whose flag was typed."""

    settings: Mapping[str, Any]
    typed: frozenset[str]
    """The fields whose flag is on the command line (a switch's ``--no-`` spelling too), whatever the value typed."""

    def given(self, name: str) -> dict[str, Any]:
        """The typed fields of ``settings[name]`` and their values: what the layers under the flags give way to."""
        values = self.settings[name]
        return {field.name: getattr(values, field.name) for field in dataclasses.fields(values) if field.name in self.typed}


def parse_flags(settings: Mapping[str, type], argv: Sequence[str] | None = None, *, description: str | None = None) -> Parsed:
    """Parse ``argv`` (default: ``sys.argv[1:]``) into one instance of each settings dataclass, with tyro.

    ``settings`` names the dataclasses (the names head their groups in ``--help``); their fields
    share one namespace of flags (no ``--config.`` prefixes). A malformed command line (an unknown
    flag, a value of the wrong type, a choice not offered) stops with tyro's message, which shows
    the flag's help, and exit status 2.

    Examples:
        >>> @dataclass(frozen=True)
        ... class Settings:
        ...     batch_size: int = 64
        ...     '''transitions per update'''
        ...     levels: tuple[str, ...] = ("train",)
        ...     '''levels to evaluate'''
        ...     ray: RayAddress = None
        ...     '''a local Ray cluster, or the one at ADDRESS'''
        >>> parsed = parse_flags({"settings": Settings}, ["--levels", "train", "color_hard", "--ray"])
        >>> parsed.settings["settings"]
        Settings(batch_size=64, levels=('train', 'color_hard'), ray='local')
        >>> sorted(parsed.typed), parse_flags({"settings": Settings}, ["--batch-size", "64"]).given("settings")
        (['levels', 'ray'], {'batch_size': 64})
    """
    argv = list(sys.argv[1:] if argv is None else argv)
    hints = {field.name: typing.get_type_hints(kind, include_extras=True)[field.name]
             for kind in settings.values() for field in dataclasses.fields(kind)}
    bare = {flag_name(name): marker.value for name, hint in hints.items() for marker in _metadata(hint) if isinstance(marker, BareValue)}
    argv = _with_bare_values(argv, bare)
    switches = {flag: name for name, hint in hints.items() if _bare_type(hint) is bool
                for flag in (flag_name(name), flag_name(f"no_{name}"))}
    spellings = {**{flag_name(name): name for name in hints}, **switches}
    for token in argv:
        if token.split("=", 1)[0] in switches and "=" in token:  # tyro would ignore the value: --random=False is on
            _stop(f"{token}: {token.split('=', 1)[0]} is a switch and takes no value; type it alone (or its --no- form).")
    typed = frozenset(spellings[flag] for flag in (token.split("=", 1)[0] for token in argv) if flag in spellings)

    def command(**parts: Any) -> dict[str, Any]:
        return parts

    parameters = [inspect.Parameter(name, inspect.Parameter.KEYWORD_ONLY, annotation=kind) for name, kind in settings.items()]
    command.__signature__ = inspect.Signature(parameters)  # type: ignore[attr-defined]
    command.__annotations__ = {name: kind for name, kind in settings.items()}
    parts = tyro.cli(command, args=argv, description=description, config=(tyro.conf.OmitArgPrefixes, tyro.conf.DisallowNone))
    for name in sorted(typed):
        value = next(getattr(part, name) for part in parts.values() if hasattr(part, name))
        if typing.get_origin(_bare_type(hints[name])) is tuple and tyro.conf.Positional not in _metadata(hints[name]) \
                and (value == () or any(item == () for item in value if isinstance(item, tuple))):
            _stop(f"{flag_name(name)}: give one value or more after it.")
    return Parsed(parts, typed)


def unset_means(meaning: str) -> Any:
    """``Annotated[int | None, unset_means("the suite's")]``: the help says what the field left unset (``None``) means."""
    return tyro.conf.arg(help_behavior_hint=f"(default: {meaning})")


def flag_name(name: str) -> str:
    """``"batch_size"`` -> ``"--batch-size"``: a field's flag, for messages."""
    return f"--{name.replace('_', '-')}"


def flag_value(value: Any) -> str:
    """A value as it is typed after its flag, for messages: ``("train", "color_hard")`` -> ``"train color_hard"``."""
    if isinstance(value, tuple) and value:
        return " ".join(map(str, value))
    return "none" if value is None or value == () else str(value)


def _stop(message: str) -> None:
    """Stop as a malformed command line does (as tyro and argparse do): the message on stderr, exit status 2."""
    sys.stderr.write(f"{message}\n")
    raise SystemExit(2)


def _with_bare_values(argv: list[str], bare: Mapping[str, str]) -> list[str]:
    """``argv`` with each bare-value flag typed alone given its value (``--ray`` -> ``--ray local``)."""
    out = []
    for index, token in enumerate(argv):
        out.append(token)
        if token in bare and (index + 1 == len(argv) or argv[index + 1].startswith("-")):
            out.append(bare[token])
    return out


def _metadata(hint: Any) -> tuple[Any, ...]:
    """The ``Annotated`` metadata of a field's type (tyro's markers, :class:`BareValue`; nested ``Annotated`` are flat)."""
    return getattr(hint, "__metadata__", ())


def _bare_type(hint: Any) -> Any:
    """A field's type without ``Annotated`` and ``| None``: ``Annotated[int | None, ...]`` -> ``int``."""
    hint = typing.get_args(hint)[0] if _metadata(hint) else hint
    arguments = [argument for argument in typing.get_args(hint) if argument is not type(None)]
    return arguments[0] if typing.get_origin(hint) in (typing.Union, types.UnionType) and len(arguments) == 1 else hint

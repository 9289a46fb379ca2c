"""The algorithms' records written out for people: help texts and the table of ``docs/losses.md``.

Each value comes from the record (:data:`vigen.losses.ALGOS`), where every paper default has its
one home, and from the samplers' own defaults where the record leaves them: nothing here holds a
number. ``python -m vigen.losses`` prints the table that ``docs/losses.md`` holds (a test keeps
them equal).
"""

from __future__ import annotations

from collections.abc import Callable
from fractions import Fraction
from typing import Any

from vigen.losses.registry import ALGOS, Algorithm, make_sampler

RUN_SETTINGS: dict[str, Callable[[Algorithm], Any]] = {
    "std_init": lambda record: record.std_schedule.init,
    "std_final": lambda record: record.std_schedule.final,
    "std_duration": lambda record: record.std_schedule.duration,
}
"""The run settings (:class:`vigen.run.TrainConfig` fields) whose default is the algorithm's, and how a record gives it
(``reward_scale`` is :func:`defaults_help`'s too, per env)."""


def defaults_help(setting: str) -> str:
    """What a run setting left unset takes from the algorithm's record, as a help text says it.

    ``setting`` is one of :data:`RUN_SETTINGS` (the DDPG algorithms' noise-std schedule) or
    ``"reward_scale"`` (the factor on an env's rewards).

    Examples:
        >>> defaults_help("std_init")
        "the algorithm's: 1.0 (drqv2, svea, srm, sgqn, curl, pieg), 0.01 (vrl3)"
        >>> defaults_help("reward_scale")
        "the algorithm's: 1; vrl3 on adroit/door 1/20, adroit/hammer 1/100, adroit/pen 1/50, adroit/relocate 1/30"
    """
    if setting == "reward_scale":
        scaled = "; ".join(f"{name} on " + ", ".join(f"{env} {_fraction(scale)}" for env, scale in record.reward_scales.items())
                           for name, record in ALGOS.items() if record.reward_scales)
        return "the algorithm's: 1" + (f"; {scaled}" if scaled else "")
    if setting not in RUN_SETTINGS:
        raise ValueError(f"defaults_help: {setting!r} is not a setting with an algorithm's default; "
                         f"choose one of {', '.join([*RUN_SETTINGS, 'reward_scale'])}.")
    values: dict[Any, list[str]] = {}
    for name, record in ALGOS.items():
        if record.takes_std:
            values.setdefault(RUN_SETTINGS[setting](record), []).append(name)
    return "the algorithm's: " + ", ".join(f"{value} ({', '.join(names)})" for value, names in values.items())


def defaults_markdown() -> str:
    """The table of every algorithm's record: its loss, networks, sampler, augmentations, options and optimizer groups."""
    lines = ["| algorithm | loss | encoder, actor | sampler | augmentations | options | optimizer groups, reward scales |",
             "|---|---|---|---|---|---|---|"]
    for name, record in ALGOS.items():
        augmentations = "<br>".join(f"`{key}`: `{_augmentation(factory())}`" for key, factory in record.augmentations.items())
        options = ", ".join(f"`{key}={value!r}`" for key, value in record.options.items()) or "—"
        groups = [f"`{module}`: {', '.join(f'{key} {value}' for key, value in group.items())}"
                  for module, group in record.param_groups.items()]
        groups += [f"{env} ×{_fraction(scale)}" for env, scale in record.reward_scales.items()]
        networks = ", ".join(f"`{network}`" for network in record.networks)
        lines.append(f"| `{name}` | `{record.loss.__name__}`{f' + {networks}' if networks else ''} | "
                     f"`{record.encoder}`, `{record.actor}` | `{make_sampler(name, {})!r}` | {augmentations or '—'} | "
                     f"{options} | {'<br>'.join(groups) or '—'} |")
    return "\n".join(lines) + "\n"


def _augmentation(augmentation: Any) -> str:
    """An augmentation's repr without the keys it reads (every loss's read ``pixels``); a list's items each so."""
    if isinstance(augmentation, list):
        return "[" + ", ".join(_augmentation(item) for item in augmentation) + "]"
    return repr(augmentation).replace(", in_keys=['pixels']", "")


def _fraction(value: float) -> str:
    fraction = Fraction(value).limit_denominator(1000)
    return str(fraction) if abs(float(fraction) - value) < 1e-12 else f"{value:g}"

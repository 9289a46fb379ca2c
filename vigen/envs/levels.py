"""Levels across the suites: group names resolved for a suite, and ``docs/levels.md`` rendered from every suite's tables.

The types level tables are written in (:class:`Level`, :class:`Factor`, :class:`Step`, the
:class:`Derived` rules, ...) are defined in :mod:`vigen.envs.level_types`, which imports no suite,
and are importable from here too. This module sits above the registry: ``docs/levels.md`` is
generated from the suites' tables (``python -m vigen.envs.levels > docs/levels.md``) and a test
keeps the two equal.

Examples:
    >>> from vigen.envs.levels import Level, resolve_levels
    >>> resolve_levels(["train", "dmcgb"], suite="dmc")
    ['train', 'color_easy', 'color_hard', 'video_easy', 'video_hard']
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

from vigen.envs.factors import FACTORS
from vigen.envs.level_types import (
    ByTask,
    Choice,
    Derived,
    Factor,
    FetchedData,
    Level,
    LevelContext,
    Scaled,
    SceneIndex,
    Severity,
    Span,
    StandInImages,
    Step,
    accepted_options,
    check_intensity,
    evaluate_value,
    level_label,
)
from vigen.envs.registry import SUITES, get_suite

__all__ = [
    "ByTask", "Choice", "Derived", "Factor", "FetchedData", "Level", "LevelContext", "Scaled", "SceneIndex", "Severity", "Span",
    "StandInImages", "Step", "accepted_options", "check_intensity", "evaluate_value", "level_label", "levels_markdown",
    "resolve_levels",
]


def resolve_levels(names: str | Sequence[str], suite: str = "dmc") -> list[str]:
    """Expand group names (e.g. ``dmcgb``, ``rlvigen``, ``all``) into level names of ``suite``, in order.

    Examples:
        >>> resolve_levels(["train", "dmcgb"])
        ['train', 'color_easy', 'color_hard', 'video_easy', 'video_hard']
    """
    return get_suite(suite).resolve_levels(names)


def levels_markdown() -> str:
    """The tables of every suite's levels, groups and factors (the content of ``docs/levels.md``)."""
    def cell(text: Any) -> str:
        return str(text).replace("|", "\\|")

    def steps(steps: Sequence[Step], env_options: Mapping[str, Any]) -> str:
        shown = [f"`{cell(repr(step))}`" for step in steps] + [f"env: `{cell(f'{k}={v!r}')}`" for k, v in env_options.items()]
        return "; ".join(shown) or "—"

    lines = [
        "# Generalization levels",
        "",
        "Generated from the suites' level tables by `python -m vigen.envs.levels > docs/levels.md`; a test keeps them equal.",
        "Use a level with `make_env(name, generalization=level, seed=...)`, factors with",
        "`make_env(name, generalization={\"camera_rotation\": 0.3, ...}, seed=...)` (intensity `x` in [0, 1]; 0 is off).",
        "`x` in a parameter is the factor's intensity; `scene_id` is the scene a level shows (robosuite: 0..9, `seed % 10` by default).",
        "",
        "## Factors",
        "",
        "| factor | what changes | suites |",
        "|---|---|---|",
    ]
    for name, what in FACTORS.items():
        where = [suite_name for suite_name, suite in SUITES.items() if name in suite.factors]
        lines.append(f"| `{name}` | {cell(what)} | {', '.join(where) or '—'} |")
    for suite_name, suite in SUITES.items():
        lines += ["", f"## {suite_name}/ — {cell(suite.about)}", "",
                  f"Example: `make_env(\"{suite_name}/{suite.example_task}\", generalization=\"{next(iter(suite.levels))}\", seed=0)`.",
                  "", "| level | what changes | transforms and exact parameters | source |", "|---|---|---|---|"]
        for level_name, level in suite.levels.items():
            only = f" (only {', '.join(level.tasks)})" if level.tasks is not None else ""
            lines.append(f"| `{level_name}` | {cell(level.what + only)} | {steps(level.steps, level.env_options)} | {cell(level.source)} |")
        lines += ["", "| group | levels |", "|---|---|"]
        lines += [f"| `{group}` | {', '.join(f'`{name}`' for name in names)} |" for group, names in suite.groups.items()]
        lines += ["", "| factor | transforms at intensity x | named levels on it |", "|---|---|---|"]
        for factor_name, factor in suite.factors.items():
            points = ", ".join(f"`{level}` = {x:g}" for level, x in factor.points.items()) or "—"
            lines.append(f"| `{factor_name}` | {steps(factor.steps, factor.env_options)} | {points} |")
    return "\n".join(lines) + "\n"


if __name__ == "__main__":
    print(levels_markdown(), end="")

"""Published numbers as typed rows: the schema of ``vigen/results/data/*.csv``, loading, checking and filtering.

Every row is one number a paper or its repository published, keyed by what makes two numbers
comparable: (method, variant, source, protocol, suite, task, level, statistic, unit, budget,
budget unit, seeds). ``where`` says where in the source it was read.
"""

from __future__ import annotations

import csv
import math
from collections import Counter
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import asdict, dataclass, fields
from functools import lru_cache
from pathlib import Path
from types import MappingProxyType
from typing import Any

from vigen.protocols import BUDGET_UNITS, PROTOCOLS
from vigen.results.sources import SOURCES

DATA = Path(__file__).parent / "data"
STATISTICS = ("mean", "median", "seed")
"""``mean``/``median``: over seeds of each seed's score; ``seed``: one seed's score (``seed`` names it)."""
UNITS = ("return", "success_percent")
"""``return``: episode return; ``success_percent``: episodes that succeeded, in %."""
SPREAD_KINDS = ("std", "")
"""``std``: standard deviation over seeds; empty: no spread published."""
OTHER_SUITES: Mapping[str, tuple[str, ...]] = MappingProxyType({"habitat": ("test",), "carla": ("easy", "medium", "hard")})
"""Suites RL-ViGen publishes that vigen does not build (yet), with their levels; the others' levels are vigen's."""


@dataclass(frozen=True)
class PublishedScore:
    """One published number and what it is a number of.

    Examples:
        >>> from vigen.results import published
        >>> row = published(source="madi", method="madi", task="walker-walk")[0]
        >>> row.env, row.level, row.value, row.spread, row.budget_text
        ('dmc/walker-walk', 'video_hard', 858.0, 37.0, '500,000 agent_steps')
    """

    method: str
    variant: str
    source: str
    protocol: str
    suite: str
    task: str
    level: str
    statistic: str
    unit: str
    budget: int | None
    budget_unit: str
    seeds: int
    seed: int | None
    value: float
    spread: float | None
    spread_kind: str
    where: str

    @property
    def env(self) -> str:
        """The vigen env name, ``"<suite>/<task>"``."""
        return f"{self.suite}/{self.task}"

    @property
    def verified(self) -> bool:
        """Whether this row was checked against its source's original table or file (:attr:`Source.unverified`)."""
        return SOURCES[self.source].verified

    @property
    def recipe(self) -> str | None:
        """The vigen recipe that trains this row's method as the code behind it did (:meth:`Source.recipe_of`); ``None``
        where vigen has none (:meth:`Source.why_no_recipe` says why).

        Examples:
            >>> from vigen.results import published
            >>> {row.recipe for row in published(source="dmcgb", method="svea", variant="conv")}
            {'svea-dmcgb'}
        """
        return SOURCES[self.source].recipe_of(self.method, self.variant, self.suite)

    @property
    def label(self) -> str:
        """The method as a table names it, e.g. ``"svea (overlay)"``."""
        return f"{self.method} ({self.variant})" if self.variant else self.method

    @property
    def budget_text(self) -> str:
        """The budget as the source counts it, e.g. ``'500,000 agent_steps'``."""
        return "not published" if self.budget is None else f"{self.budget:,} {self.budget_unit}"

    def frames(self, action_repeat: int) -> int | None:
        """The budget in frames, given the action repeat the protocol uses on this task."""
        if self.budget is None:
            return None
        return self.budget * action_repeat if self.budget_unit == "agent_steps" else self.budget


COLUMNS = tuple(field.name for field in fields(PublishedScore))


def _optional(text: str, kind: type) -> Any:
    return None if text == "" else kind(text)


def parse_row(raw: dict[str, str], where: str = "") -> PublishedScore:
    """A CSV row as a :class:`PublishedScore`, checked against the schema; a bad row raises naming the column.

    Examples:
        >>> from vigen.results.published import COLUMNS, parse_row
        >>> raw = dict(zip(COLUMNS, ["svea", "", "sgqn", "dmcgb", "dmc", "walker-walk", "video_hard", "mean", "return", "500000",
        ...                          "agent_steps", "5", "", "385", "63", "std", "SGQN Table 2"]))
        >>> parse_row(raw).spread
        63.0
    """
    if tuple(raw) != COLUMNS:
        raise ValueError(f"{where}: columns {list(raw)} are not the schema's {list(COLUMNS)}.")
    try:
        row = PublishedScore(
            **{key: raw[key] for key in ("method", "variant", "source", "protocol", "suite", "task", "level", "statistic",
                                         "unit", "budget_unit", "spread_kind", "where")},
            budget=_optional(raw["budget"], int), seeds=int(raw["seeds"]), seed=_optional(raw["seed"], int),
            value=float(raw["value"]), spread=_optional(raw["spread"], float),
        )
    except ValueError as error:
        raise ValueError(f"{where}: {error} in {raw}") from None
    check_row(row, where)
    return row


def _levels(suite: str) -> tuple[str, ...] | None:
    """The level names a published row of ``suite`` may use; ``None`` for an unknown suite."""
    if suite in OTHER_SUITES:
        return OTHER_SUITES[suite]
    from vigen.envs.registry import SUITES  # the simulators themselves load only when an env is built

    return tuple(SUITES[suite].levels) if suite in SUITES else None


def check_row(row: PublishedScore, where: str = "") -> None:
    """Raise ``ValueError`` naming what is wrong if ``row`` breaks the schema (vocabularies, units, seeds, spreads).

    Examples:
        >>> import dataclasses
        >>> from vigen.results import published
        >>> from vigen.results.published import check_row
        >>> check_row(dataclasses.replace(published(source="sgqn")[0], level="vidoe_hard"), "sgqn.csv")
        Traceback (most recent call last):
        ...
        ValueError: sgqn.csv: level 'vidoe_hard' is not a level of suite dmc (e.g. train, color_easy, color_hard).
    """
    problems = []
    levels = _levels(row.suite)
    if levels is None:
        problems.append(f"suite {row.suite!r} is neither a vigen suite nor one of {list(OTHER_SUITES)}")
    elif row.level not in levels:
        problems.append(f"level {row.level!r} is not a level of suite {row.suite} (e.g. {', '.join(levels[:3])})")
    if row.source not in SOURCES:
        problems.append(f"source {row.source!r} is not one of {list(SOURCES)}")
    if row.protocol not in PROTOCOLS:
        problems.append(f"protocol {row.protocol!r} is not one of {list(PROTOCOLS)}")
    if row.statistic not in STATISTICS:
        problems.append(f"statistic {row.statistic!r} is not one of {STATISTICS}")
    if row.unit not in UNITS:
        problems.append(f"unit {row.unit!r} is not one of {UNITS}")
    if row.spread_kind not in SPREAD_KINDS or (row.spread is None) != (row.spread_kind == ""):
        problems.append(f"spread {row.spread} and spread_kind {row.spread_kind!r} must both be given (kind in {SPREAD_KINDS}) or both empty")
    if row.budget is None and row.budget_unit != "" or row.budget is not None and row.budget_unit not in BUDGET_UNITS:
        problems.append(f"budget {row.budget} needs a budget_unit in {BUDGET_UNITS} (both empty when the source does not state it)")
    if row.budget is not None and row.budget <= 0 and not (row.budget == 0 and row.budget_unit == "frames"):
        problems.append(f"budget {row.budget} must be positive")
    if row.protocol in PROTOCOLS and row.budget is not None and row.budget_unit != PROTOCOLS[row.protocol].budget_unit:
        problems.append(f"budget_unit {row.budget_unit!r} is not protocol {row.protocol}'s {PROTOCOLS[row.protocol].budget_unit!r}")
    if row.seeds < 1:
        problems.append(f"seeds {row.seeds} must be >= 1")
    if (row.statistic == "seed") != (row.seed is not None) or row.seed is not None and not 1 <= row.seed <= row.seeds:
        problems.append(f"seed {row.seed} must be set (1..seeds) exactly when statistic is 'seed'")
    if not math.isfinite(row.value) or row.spread is not None and not (math.isfinite(row.spread) and row.spread >= 0):
        problems.append(f"value {row.value} and spread {row.spread} must be finite (spread >= 0)")
    if row.unit == "success_percent" and not 0 <= row.value <= 100:
        problems.append(f"a success rate in % must lie in [0, 100], got {row.value}")
    if not (row.method and row.suite and row.task and row.level and row.where):
        problems.append("method, suite, task, level and where must not be empty")
    if row.method != row.method.lower() or "/" in row.task:
        problems.append("method must be lower case and task must not contain '/' (the env is suite/task)")
    if problems:
        raise ValueError(f"{where}: " + "; ".join(problems) + ".")


@lru_cache(maxsize=None)
def load(source: str) -> tuple[PublishedScore, ...]:
    """Every row of one source's file, checked (``vigen/results/data/<source>.csv``).

    Examples:
        >>> from vigen.results import load
        >>> len(load("sgqn")), {row.level for row in load("sgqn")} == {"video_easy", "video_hard"}
        (50, True)
    """
    if source not in SOURCES:
        raise ValueError(f"Unknown source {source!r}; the sources are {', '.join(SOURCES)}.")
    path = DATA / f"{source}.csv"
    with path.open(newline="") as file:
        rows = tuple(parse_row(raw, f"{path.name}, line {line}") for line, raw in enumerate(csv.DictReader(file), start=2))
    stray = {row.source for row in rows} - {source}
    if stray:
        raise ValueError(f"{path.name} holds rows of source(s) {sorted(stray)}; each file holds its own source only.")
    counts = Counter((r.method, r.variant, r.suite, r.task, r.level, r.statistic, r.unit, r.budget, r.seed) for r in rows)
    twice = sorted((key for key, count in counts.items() if count > 1), key=str)
    if twice:
        raise ValueError(f"{path.name}: the cell(s) {twice[:3]} appear more than once; one row per published number.")
    return rows


def published(*, source: str | Sequence[str] | None = None, **filters: Any) -> list[PublishedScore]:
    """The published rows that match every filter (a column name and a value, or a list of accepted values).

    Examples:
        >>> from vigen.results import published
        >>> [(row.source, row.protocol, row.value) for row in published(method="svea", task="walker-stand", level="video_hard")]
        [('sgqn', 'dmcgb', 747.0), ('madi', 'dmcgb', 847.0), ('simgrl', 'dmcgb', 834.0), ('dmcgb2', 'dmcgb2', 429.0)]
    """
    unknown = set(filters) - set(COLUMNS)
    if unknown:
        raise ValueError(f"Unknown column(s) {sorted(unknown)}; filter by {', '.join(COLUMNS)}.")
    names = list(SOURCES) if source is None else [source] if isinstance(source, str) else list(source)
    accepted = {key: {value} if isinstance(value, (str, int, float)) or value is None else set(value)
                for key, value in filters.items()}
    return [row for name in names for row in load(name)
            if all(getattr(row, key) in values for key, values in accepted.items())]


def as_dicts(rows: Iterable[PublishedScore]) -> list[dict[str, Any]]:
    """Rows as plain dicts (for CSV writers and pandas).

    Examples:
        >>> from vigen.results import as_dicts, published
        >>> as_dicts(published(source="madi", method="madi", task="finger-spin"))[0]["value"]
        566.0
    """
    return [asdict(row) for row in rows]

"""Put a vigen evaluation beside the published numbers of the same method, task and level, under the same protocol.

A published number is only comparable to a run trained and evaluated the way the paper did: the
same budget counted in the same unit (DMC-GB's 500k *agent steps* are 2M frames at action repeat
4), action repeat, frame stack, image size and episode length. :func:`compare` checks all of them
and raises :class:`ProtocolMismatch`, naming every difference, instead of printing unlike numbers
side by side. What it cannot check it states on each line (``notes``): a published number from
another implementation of the method than vigen's, a level vigen only approximates, a budget the
source does not state.
"""

from __future__ import annotations

import json
from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from types import MappingProxyType
from typing import Any, ClassVar

import numpy as np

from vigen.datasets.identity import not_in_full
from vigen.protocols import Protocol, get_protocol
from vigen.results.published import PublishedScore, published
from vigen.results.sources import SOURCES
from vigen.run.recipes import RECIPES, differences

VALUE_UNITS: Mapping[str, str] = MappingProxyType({"return": "return", "success": "success_percent"})
"""Evaluation column -> the published unit it is compared with (``success`` rows are 0/1, shown in %)."""
SETTINGS = ("action_repeat", "frame_stack", "image_size", "episode_length")
"""The row columns that must match the protocol (``examples/evaluate.py`` tags every row with them)."""
CLIPPED_AT_ZERO: Mapping[str, tuple[str, ...]] = MappingProxyType({"rlvigen": ("loco/",)})
"""Source -> env prefixes whose published scores average episode returns clipped below at 0 (RL-ViGen's
``locoeval.py:96`` sets a negative episode return to 0 before the mean); the run's returns are clipped the same way."""
CLIP_NOTE = "episode returns below 0 counted as 0 before averaging, as the source's evaluator does"
LOCO_PROTOCOL: Mapping[str, str] = MappingProxyType({"rlvigen": "rlvigen_loco"})
"""Source -> the protocol its ``loco/`` rows follow (:data:`vigen.protocols.PROTOCOLS`), named on every ``loco/`` line."""


def refusal(reason: str, items: Iterable[str], fix: str = "") -> str:
    """The message of a refused comparison: ``reason``, one ``  - item`` line per item, then ``fix``.

    Examples:
        >>> print(refusal("cannot compare", ["a differs", "b differs"], "Fix a and b."))
        cannot compare:
          - a differs
          - b differs
        Fix a and b.
    """
    return "\n".join([f"{reason}:", *(f"  - {item}" for item in items), *([fix] if fix else [])])


class ProtocolMismatch(ValueError):
    """The run and the published numbers were not produced under the same protocol; ``differences`` lists how.

    Examples:
        >>> from vigen.results import ProtocolMismatch
        >>> error = ProtocolMismatch(["dmc/walker-walk: action repeat 2 in the run, 4 in protocol dmcgb"])
        >>> error.differences
        ['dmc/walker-walk: action repeat 2 in the run, 4 in protocol dmcgb']
    """

    def __init__(self, differences: Sequence[str], hint: str = "") -> None:
        self.differences = list(differences)
        super().__init__(refusal("cannot compare with the published numbers; what differs", self.differences, hint))


class LevelsRefused(ValueError):
    """Rows refused beside the published numbers for what their levels showed; ``levels`` lists (level, data shown).

    Each subclass says why (``reason``) and how to go on (``fix``).
    """

    reason: ClassVar[str]
    fix: ClassVar[str]

    def __init__(self, levels: Sequence[tuple[str, str]]) -> None:
        self.levels = list(levels)
        super().__init__(refusal(self.reason, (f"{level}: {data}" for level, data in self.levels), self.fix))


class StandInRows(LevelsRefused):
    """Rows that showed vigen's stand-ins where the source showed its own data; ``levels`` lists (level, data shown).

    Examples:
        >>> from vigen.results.compare import StandInRows
        >>> print(StandInRows([("video_hard", "procedural stand-in videos (10)")]))  # doctest: +ELLIPSIS
        cannot set these rows beside published numbers: they showed vigen's stand-ins, not the benchmark's data:
          - video_hard: procedural stand-in videos (10)
        Fetch the data (python -m vigen.datasets fetch ...) and evaluate again, or pass allow_stand_ins=True ...
    """

    reason = "cannot set these rows beside published numbers: they showed vigen's stand-ins, not the benchmark's data"
    fix = ("Fetch the data (python -m vigen.datasets fetch ...) and evaluate again, or pass allow_stand_ins=True "
           "(--allow-stand-ins) to show them anyway, each line saying so.")


class PartialData(LevelsRefused):
    """Rows whose level did not show the published data set in full; ``levels`` lists (level, data shown).

    Examples:
        >>> from vigen.results.compare import PartialData
        >>> print(PartialData([("video_easy", "dmcgb-videos/video_easy: 6 of 10, verified")]))  # doctest: +ELLIPSIS
        cannot set these rows beside published numbers: their level did not show the published data set in full:
          - video_easy: dmcgb-videos/video_easy: 6 of 10, verified
        Evaluate on the whole data set (python -m vigen.datasets fetch ..., without --videos), or pass allow_partial_data=True ...
    """

    reason = "cannot set these rows beside published numbers: their level did not show the published data set in full"
    fix = ("Evaluate on the whole data set (python -m vigen.datasets fetch ..., without --videos), or pass "
           "allow_partial_data=True (--allow-partial-data) to show them anyway, each line saying what was shown.")


def partial_data(label: Any) -> list[str]:
    """The parts of a row's ``data`` label that are not a data set shown in full (:func:`vigen.datasets.identity.not_in_full`).

    A part is in full where it names a data set part, every one of its files, ``verified`` against
    the pinned ids or ``shipped`` with vigen (:class:`vigen.datasets.identity.DataIdentity`). A user's
    folder or file, fewer files than the part holds, unverified files, and a label that names no
    data set (e.g. a machine path, as rows had before vigen named data by identity) are not;
    stand-ins are left to the ``stand_in`` column.

    Examples:
        >>> from vigen.results.compare import partial_data
        >>> partial_data("dmcgb-colors/color_easy: 100 of 100, shipped; dmcgb-videos/video_easy: 6 of 10, verified")
        ['dmcgb-videos/video_easy: 6 of 10, verified']
    """
    return not_in_full(label)


def _options_not_played(rows: Sequence[Mapping[str, Any]], wanted: Mapping[str, Any]) -> dict[str, Any]:
    """The protocol's ``level_options`` some of ``rows`` were not played with (their ``level_options`` column, JSON)."""
    played = [json.loads(str(row.get("level_options") or "{}")) for row in rows]
    return {key: value for key, value in wanted.items() if any(options.get(key) != value for options in played)}


class RecipeMismatch(ValueError):
    """The run was trained by another recipe than the code behind the published numbers; ``differences`` lists how.

    Examples:
        >>> from vigen.results.compare import RecipeMismatch
        >>> RecipeMismatch(["svea on dmc/walker-walk: the run was trained by no recipe, dmcgb's svea (conv) row by recipe "
        ...                 "svea-dmcgb"]).differences[0][:40]
        'svea on dmc/walker-walk: the run was tra'
    """

    def __init__(self, differences: Sequence[str]) -> None:
        self.differences = list(differences)
        super().__init__(refusal(
            "cannot set the run beside these published numbers: it was not trained by the recipe behind them",
            self.differences,
            "Train with the published row's recipe (examples/train.py --recipe NAME; --recipe list), or pass "
            "allow_recipe_mismatch=True (--allow-recipe-mismatch) to show it anyway, each line saying what differs."))


def run_recipe(rows: Sequence[Mapping[str, Any]]) -> tuple[str | None, dict[str, Any]]:
    """The recipe the rows' run was trained by (their ``recipe`` column; ``None``: none or no column) and its overrides.

    ``recipe_overrides`` is ``{setting: {"recipe": value, "flag": value}}``, a dict or its JSON text (as a CSV holds it).

    Examples:
        >>> run_recipe([{"recipe": "svea-dmcgb", "recipe_overrides": '{"seed_steps": {"recipe": 1000, "flag": 10}}'}])
        ('svea-dmcgb', {'seed_steps': {'recipe': 1000, 'flag': 10}})
        >>> run_recipe([{"method": "svea"}])
        (None, {})
    """
    names = {str(row.get("recipe") or "") for row in rows} - {"", "nan", "None"}
    if len(names) > 1:
        raise ValueError(f"the rows mix runs of the recipes {sorted(names)}; compare one recipe at a time.")
    overrides: dict[str, Any] = {}
    for row in rows:
        given = row.get("recipe_overrides") or {}
        overrides.update(json.loads(given) if isinstance(given, str) else dict(given))
    return (next(iter(names)) if names else None), overrides


def _recipe_lines(name: str | None, overrides: Mapping[str, Any], row: PublishedScore, env: str) -> tuple[str, str]:
    """Whether the run's recipe is the published row's, as (the mismatch, or ``""``; the note for the line)."""
    published_recipe = row.recipe
    if name is not None and name == published_recipe:
        recipe = RECIPES.get(name)
        changed = "; ".join(f"{key} {values['flag']} (recipe {values['recipe']})" for key, values in overrides.items())
        departs = ", ".join(recipe.departures) if recipe is not None else ""
        return "", (f"recipe {name}, the published row's" + (f"; overridden in the run: {changed}" if changed else "")
                    + (f"; vigen departs from its code: {departs} (docs/recipes.md)" if departs else ""))
    source = SOURCES[row.source]
    theirs = (f"recipe {published_recipe}" if published_recipe else
              f"code vigen has no recipe for ({source.why_no_recipe(row.method, row.variant, row.suite)})")
    mine = f"recipe {name}" if name else "no recipe (vigen's algorithm defaults)"
    mismatch = f"{row.method} on {env}: the run was trained by {mine}, {row.source}'s {row.label} row by {theirs}"
    lines = [f"the run was trained by {mine}, the published row by {theirs}"]
    if name in RECIPES and published_recipe in RECIPES:
        try:
            settings = {**RECIPES[name].settings(env), **{key: value["flag"] for key, value in overrides.items()}}
            lines += differences(settings, RECIPES[published_recipe].settings(env), run_name="the run",
                                 published_name=published_recipe)
        except ValueError as error:  # a recipe that does not cover the env
            lines.append(str(error))
    return mismatch, "; ".join(lines)


def _published_batch(row: PublishedScore, env: str, protocol: Protocol) -> tuple[int | None, str]:
    """The training batch of the code behind a published row: its recipe's where it has one, else the protocol's code's."""
    if row.recipe in RECIPES:
        try:
            return RECIPES[row.recipe].settings(env).get("batch_size"), f"recipe {row.recipe}'s"
        except ValueError:  # a task the recipe's code has no config for
            pass
    return protocol.batch_size, f"{protocol.name}'s code"


def _is_true(value: Any) -> bool:
    """A row's boolean cell, as evaluate() writes it (True / False) or as a CSV reads it back ("True" / "False")."""
    return value is True or (isinstance(value, str) and value.strip().lower() == "true")


def check_protocol(rows: Sequence[Mapping[str, Any]], protocol: str | Protocol) -> list[str]:
    """How the rows' settings differ from ``protocol``: one sentence per difference, empty when they follow it.

    Each row must carry the settings the protocol fixes for its env (``action_repeat`` where the
    suite has one, ``frame_stack``, ``image_size``, ``episode_length`` where the protocol fixes
    it); a missing column is a difference too, since nothing then shows the run followed the
    protocol. A ``protocol`` column naming another protocol is one as well.

    Examples:
        >>> from vigen.results import check_protocol
        >>> row = {"env": "dmc/walker-walk", "action_repeat": 2, "frame_stack": 3, "image_size": 84, "episode_length": 1000}
        >>> check_protocol([row], "dmcgb")
        ['dmc/walker-walk: action repeat 2 in the run, 4 in protocol dmcgb']
        >>> check_protocol([dict(row, action_repeat=4)], "dmcgb")
        []
    """
    protocol = get_protocol(protocol)
    differences = []
    for env in dict.fromkeys(row["env"] for row in rows):
        of_env = [row for row in rows if row["env"] == env]
        named = {row.get("protocol") for row in of_env} - {None, ""}
        if named and named != {protocol.name}:
            differences.append(f"{env}: the run was trained under protocol {', '.join(sorted(map(str, named)))}, "
                               f"the published numbers under {protocol.name}")
        try:
            expected = {"action_repeat": protocol.action_repeat_option(env), "frame_stack": protocol.frame_stack,
                        "image_size": protocol.image_size, "episode_length": protocol.episode_length_for(env)}
        except ValueError as error:
            differences.append(str(error))
            continue
        for name in SETTINGS:
            if expected[name] is None:
                continue
            found = {row.get(name) for row in of_env}
            if None in found or "" in found:
                differences.append(f"{env}: rows without a {name!r} column; tag them with the run's settings "
                                   f"(examples/evaluate.py does) so that the protocol can be checked")
            elif found != {expected[name]}:
                differences.append(f"{env}: {name.replace('_', ' ')} {', '.join(map(str, sorted(found)))} in the run, "
                                   f"{expected[name]} in protocol {protocol.name}")
    return differences


def _published_mean(members: Sequence[PublishedScore]) -> tuple[float, float | None, int]:
    """Mean, spread and seeds of a published cell: its ``mean`` row, or the mean ± sample std of its ``seed`` rows."""
    statistics = {row.statistic for row in members}
    if statistics == {"seed"}:
        values = np.array([row.value for row in members])
        return float(values.mean()), float(values.std(ddof=1)) if values.size > 1 else None, int(values.size)
    if statistics != {"mean"} or len(members) != 1:
        raise ValueError(f"a published cell must be one 'mean' row or per-seed rows, got {sorted(statistics)} x {len(members)}.")
    return members[0].value, members[0].spread, members[0].seeds


def _run_scores(rows: Sequence[Mapping[str, Any]], value: str, clip_at_zero: bool = False) -> list[float]:
    """One score per run (its mean over episodes and seeds), in %, for ``success``; ``clip_at_zero``: each episode's ``max(0, ·)``.

    Examples:
        >>> _run_scores([{"run": 0, "return": -100.0}, {"run": 0, "return": 300.0}], "return", clip_at_zero=True)
        [150.0]
    """
    per_run: dict[Any, list[float]] = defaultdict(list)
    for row in rows:
        score = float(row[value]) * (100.0 if value == "success" else 1.0)
        per_run[row.get("run", 0)].append(max(score, 0.0) if clip_at_zero else score)
    return [float(np.mean(scores)) for scores in per_run.values()]


@dataclass(frozen=True)
class PublishedPoint:
    """The published side of a comparison at the run's budget: its mean, spread, seeds and how it was found."""

    mean: float
    spread: float | None
    seeds: int | None
    frames: int | None
    note: str = ""
    where: str = ""
    """Where the point is in the source; an interpolated point names both ends (``"interpolated between ... and ..."``)."""


def _at_budget(budgets: Mapping[int | None, list[PublishedScore]], run_frames: int | None, repeat: int
               ) -> tuple[PublishedPoint | None, str]:
    """The published point at the run's budget, or why there is none.

    The cell published at the run's frames (or the only one, when the source states no budget); else
    the published means linearly interpolated between the two budgets around the run's; else
    ``None`` and the budgets that exist. A point at another budget is never returned.
    """
    if list(budgets) == [None]:
        return PublishedPoint(*_published_mean(budgets[None]), frames=None, where=budgets[None][0].where), ""
    at_frames = {cell[0].frames(repeat): cell for budget, cell in budgets.items() if budget is not None}
    if run_frames in at_frames:
        return PublishedPoint(*_published_mean(at_frames[run_frames]), frames=run_frames, where=at_frames[run_frames][0].where), ""
    below = [frames for frames in at_frames if run_frames is not None and frames < run_frames]
    above = [frames for frames in at_frames if run_frames is not None and frames > run_frames]
    if below and above:
        low, high = max(below), min(above)
        (low_mean, _, low_seeds), (high_mean, _, high_seeds) = (_published_mean(at_frames[low]), _published_mean(at_frames[high]))
        weight = (run_frames - low) / (high - low)
        seeds = None if low_seeds is None or high_seeds is None else min(low_seeds, high_seeds)
        return PublishedPoint(low_mean + weight * (high_mean - low_mean), None, seeds, run_frames,
                              f"published mean interpolated linearly between {low:,} frames ({low_mean:.1f}) and "
                              f"{high:,} frames ({high_mean:.1f}); the source publishes no point at {run_frames:,}",
                              f"interpolated between {at_frames[low][0].where} and {at_frames[high][0].where}"), ""
    shown = ", ".join(f"{frames:,}" for frames in sorted(at_frames)[:6]) + (" ..." if len(at_frames) > 6 else "")
    some = next(iter(at_frames.values()))[0]
    return None, f"{shown} frames ({some.budget_text} at action repeat {repeat}), none at or around the run's"


def compare(
    rows: Iterable[Mapping[str, Any]],
    *,
    source: str | Sequence[str],
    protocol: str | Protocol,
    value: str = "return",
    allow_budget_mismatch: bool = False,
    allow_stand_ins: bool = False,
    allow_partial_data: bool = False,
    allow_recipe_mismatch: bool = False,
) -> list[dict[str, Any]]:
    """A vigen evaluation beside the published numbers of the same method, env and level, one line per pair.

    Args:
        rows: :func:`vigen.evaluation.evaluate` rows (one per episode) with ``method``, ``env``,
            ``level``, ``run``, ``frames`` (the checkpoint's frames) and the settings of
            :func:`check_protocol` (``examples/evaluate.py`` tags all of them).
        source: the source(s) to compare with (:data:`vigen.results.SOURCES`).
        protocol: the protocol the rows were produced under; it must be the source's.
        value: ``"return"`` or ``"success"`` (compared with published success rates in %).
        allow_budget_mismatch: show a run whose budget has no published point at it or around
            it (e.g. a run still in progress) instead of raising: its line has no published number
            (``published`` is NaN) and ``notes`` says which budgets the source publishes. A run is
            never set beside a number published at another budget: between two published budgets
            the published mean is interpolated linearly, and ``notes`` says so.
        allow_stand_ins: set rows that showed vigen's stand-ins (``stand_in`` true: procedural
            videos, statistics-matched colours) beside the published numbers anyway; each such line
            says in ``notes`` that the source showed its own data. Without it such rows raise
            :class:`StandInRows`. Rows without a ``stand_in`` column (evaluations older than the
            column, or rows made by hand) are taken as showing the benchmark's data.
        allow_partial_data: set rows beside the published numbers whose level did not show the
            published data set in full (:func:`partial_data`: fewer files than the data set's part,
            a user's folder, files not verified against the pinned ids, a ``data`` label naming no
            data set); each such line says in ``notes`` what was shown. Without it such rows raise
            :class:`PartialData`. Rows without a ``data`` column are taken as showing it in full.
        allow_recipe_mismatch: set a run beside published numbers whose code trained the method by
            another recipe than the run's (the rows' ``recipe`` column, :data:`vigen.run.RECIPES`;
            rows without one name none) instead of leaving them out; each such line says in ``notes``
            what differs, setting by setting where both recipes are known. Without it, a published
            row of another recipe is left out (a line of the same method that is shown says so), and
            :class:`RecipeMismatch` is raised where no row of a method, env and level is left. A run of
            the row's recipe gets a note naming it, the settings a flag overrode and vigen's departures
            from the code.

    Returns:
        Lines with the vigen side (``runs``, ``mean``, ``std`` over runs of each run's mean, as
        the papers compute theirs), the published side (``published``, ``published_spread``,
        ``published_seeds``, ``published_method`` with its variant, ``source``, ``where``), both
        budgets in frames (``budget_matches`` is ``None`` where the source does not state its
        budget), ``difference`` (vigen − published) and ``notes``: what the reader must know
        (a different budget, a budget not published, a training batch other than the source's where the rows
        carry ``batch_size``, another implementation, a level vigen approximates, an unverified source, returns
        clipped at 0). Where the source clips each episode's return at 0 before
        averaging (:data:`CLIPPED_AT_ZERO`: RL-ViGen's ``loco`` scores, or a protocol with ``clip_returns_at=0``), the
        run's returns are clipped the same way and the line's ``notes`` say so. A ``loco/`` line of RL-ViGen names the
        protocol its rows follow (:data:`LOCO_PROTOCOL`: ``rlvigen_loco``, which ``protocol`` may be, since its rows are
        published as ``rlvigen``'s), and the evaluator the sheet's rows are assumed to come from, and why.

    Raises:
        ProtocolMismatch: the protocols, a setting, the budget or the unit differ (each difference listed).
        StandInRows: rows showed vigen's stand-ins (without ``allow_stand_ins``).
        PartialData: rows showed less than the published data set, or not the benchmark's files (without
            ``allow_partial_data``).
        RecipeMismatch: the run's recipe is not that of any published row of its method, env and level.
        ValueError: the source publishes nothing for the rows' methods, envs and levels.

    Examples:
        >>> from vigen.results import compare
        >>> rows = [{"method": "sada", "env": "dmc/walker-walk", "level": "rotate_hard", "run": run, "frames": 1_000_000,
        ...          "action_repeat": 2, "frame_stack": 3, "image_size": 84, "episode_length": 1000, "return": value,
        ...          "recipe": "sada-dmcgb2"} for run, value in enumerate([700.0, 800.0])]
        >>> [(line["source"], line["published"], line["mean"]) for line in compare(rows, source="dmcgb2", protocol="dmcgb2")]
        [('dmcgb2', 799.0, 750.0)]
        >>> compare(rows, source="dmcgb2", protocol="dmcgb2")[0]["notes"]  # doctest: +ELLIPSIS
        "recipe sada-dmcgb2, the published row's; vigen departs from its code: one-step (docs/recipes.md)"
        >>> compare([dict(row, action_repeat=4) for row in rows], source="dmcgb2", protocol="dmcgb2")
        Traceback (most recent call last):
        ...
        vigen.results.compare.ProtocolMismatch: cannot compare with the published numbers; what differs:
          - dmc/walker-walk: action repeat 4 in the run, 2 in protocol dmcgb2
        Train with the settings of protocol dmcgb2 (examples/train.py --protocol dmcgb2).
    """
    rows = list(rows)
    if not rows:
        raise ValueError("no rows to compare; pass the rows of an evaluation.")
    if value not in VALUE_UNITS:
        raise ValueError(f"value must be one of {list(VALUE_UNITS)}, got {value!r}.")
    missing = [key for key in ("method", "env", "level", value) if any(key not in row for row in rows)]
    if missing:
        raise KeyError(f"rows lack the column(s) {missing}; pass the rows of vigen.evaluation.evaluate with method tags.")
    protocol = get_protocol(protocol)
    sources = [source] if isinstance(source, str) else list(source)
    candidates = published(source=sources, unit=VALUE_UNITS[value], statistic=["mean", "seed"])
    if not candidates:
        raise ProtocolMismatch([f"{', '.join(sources)} publish(es) no {value} ({VALUE_UNITS[value]}) numbers"])
    same = {protocol.name, *protocol.published_as}
    others = {name: sorted({row.protocol for row in candidates if row.source == name} - same) for name in sources}
    differences = [f"source {name} publishes under protocol {', '.join(found)}, the run follows {protocol.name}"
                   for name, found in others.items() if found]
    differences += check_protocol(rows, protocol)
    if differences:
        hint = (f"Drop {', '.join(name for name, found in others.items() if found)} or compare under its protocol."
                if any(others.values()) else
                f"Train with the settings of protocol {protocol.name} (examples/train.py --protocol {protocol.name}).")
        raise ProtocolMismatch(differences, hint)
    stand_ins = {(str(row["level"]), str(row.get("data", ""))) for row in rows if _is_true(row.get("stand_in"))}
    if stand_ins and not allow_stand_ins:  # after the protocol: a run under another protocol is refused for that first
        raise StandInRows(sorted(stand_ins))
    partial = {(str(row["level"]), "; ".join(partial_data(row.get("data")))) for row in rows if partial_data(row.get("data"))}
    if partial and not allow_partial_data:
        raise PartialData(sorted(partial))

    cells: dict[tuple, list[PublishedScore]] = defaultdict(list)
    for row in candidates:
        cells[row.method, row.env, row.level, row.source, row.variant, row.budget].append(row)
    groups: dict[tuple, list[Mapping[str, Any]]] = defaultdict(list)
    for row in rows:
        groups[str(row["method"]), str(row["env"]), str(row["level"])].append(row)

    lines: list[dict[str, Any]] = []
    budget_problems: dict[tuple, tuple[dict, dict]] = {}  # (method, env, frames, published budget) -> (sources, levels)
    recipe_problems: list[str] = []
    for (method, env, level), members in groups.items():
        matches = [key for key in cells if key[:3] == (method, env, level)]
        if not matches:
            continue
        frames = {row.get("frames") for row in members} - {None, ""}
        if len(frames) > 1:
            raise ValueError(f"{method} on {env} ({level}) mixes checkpoints of {sorted(frames)} frames; compare one budget at a time.")
        run_frames = int(next(iter(frames))) if frames else None
        repeat = protocol.action_repeat_for(env)
        recipe_name, overrides = run_recipe(members)
        shown_from, left_out = len(lines), []
        for source_name, variant in dict.fromkeys(key[3:5] for key in matches):
            budgets = {key[5]: cells[key] for key in matches if key[3:5] == (source_name, variant)}
            mismatch, recipe_note = _recipe_lines(recipe_name, overrides, next(iter(budgets.values()))[0], env)
            if mismatch and not allow_recipe_mismatch:  # before the budget: a row of another recipe is not compared at all
                left_out.append(mismatch)
                continue
            point, problem = _at_budget(budgets, run_frames, repeat)
            if point is None and not allow_budget_mismatch:
                key = (method, env, run_frames, problem)
                budget_problems.setdefault(key, ({}, {}))[0][source_name] = None
                budget_problems[key][1][level] = None
                continue
            cell = next(iter(budgets.values()))
            if point is None:  # shown, with no published number beside it
                values = "; ".join(f"{mean:.0f}" + (f" ± {spread:.0f}" if spread is not None else "") + f" at {cell_rows[0].budget_text}"
                                   for cell_rows in budgets.values() for mean, spread, _ in [_published_mean(cell_rows)])
                point = PublishedPoint(float("nan"), None, None, None,
                                       f"no published point at the run's {run_frames or 0:,} frames: the source publishes {problem}"
                                       f" ({cell[0].label}: {values}; not set beside the run's number)")
            clip = value == "return" and (env.startswith(CLIPPED_AT_ZERO.get(source_name, ())) or protocol.clip_returns_at == 0)
            scores = _run_scores(members, value, clip_at_zero=clip)
            mean, spread, seeds, published_frames = point.mean, point.spread, point.seeds, point.frames
            notes = [CLIP_NOTE] if clip else []
            if env.startswith("loco/") and source_name in LOCO_PROTOCOL:
                loco = get_protocol(LOCO_PROTOCOL[source_name])
                notes.append(f"published under protocol {loco.name} (trained with {dict(loco.train_env_options)}, evaluated "
                             f"with {dict(loco.test_env_options)}); evaluator: {loco.evaluator}")
            if point.note:
                notes.append(point.note)
            elif published_frames is None:
                notes.append("budget not published")
            batches = {row.get("batch_size") for row in members} - {None, ""}
            code_batch, whose = _published_batch(cell[0], env, protocol)
            if code_batch is not None and batches and batches != {code_batch}:
                notes.append(f"batch: run {', '.join(map(str, sorted(batches)))}, {whose} {code_batch}")
            if recipe_note:
                notes.append(recipe_note)
            if mismatch and SOURCES[source_name].reproduced_by.get(cell[0].method) != method:
                notes.append(f"published from another implementation of {cell[0].label} than vigen's {method}")
            if not SOURCES[source_name].verified:
                notes.append(f"{source_name}'s rows are unverified: {SOURCES[source_name].unverified}")
            if level in protocol.level_differences:
                notes.append(f"{level} differs: {protocol.level_differences[level]}")
            unplayed = _options_not_played(members, protocol.level_options.get(level, {}))
            if unplayed:
                notes.append(f"played without {protocol.name}'s level_options {unplayed} (evaluate(..., protocol="
                             f"{protocol.name!r}) sets them): vigen's default {level}, not {protocol.name}'s")
            shown = {str(row.get("data", "")) for row in members if _is_true(row.get("stand_in"))}
            if shown:
                notes.append(f"vigen showed stand-ins ({'; '.join(sorted(shown))}) where the source showed its own data: "
                             "not the benchmark's number")
            partly = sorted({part for row in members for part in partial_data(row.get("data"))})
            if partly:
                notes.append(f"vigen showed {'; '.join(partly)}, not the published data set in full")
            lines.append({
                "method": method, "env": env, "level": level, "runs": len(scores), "frames": run_frames,
                "mean": float(np.mean(scores)), "std": float(np.std(scores, ddof=1)) if len(scores) > 1 else float("nan"),
                "published_method": cell[0].label, "source": source_name, "published": mean,
                "published_spread": spread, "published_seeds": seeds, "published_statistic": cell[0].statistic,
                "published_frames": published_frames,
                "budget_matches": None if published_frames is None else not point.note,
                "difference": float(np.mean(scores)) - mean, "unit": cell[0].unit, "notes": "; ".join(notes),
                "where": point.where, "published_recipe": cell[0].recipe or "",
            })
        if left_out and len(lines) == shown_from and not any(key[:2] == (method, env) for key in budget_problems):
            recipe_problems += [f"{text} ({level})" for text in left_out]
        for line in lines[shown_from:]:
            line["notes"] = "; ".join(filter(None, [line["notes"], *(f"left out, another recipe: {text}" for text in left_out)]))
    if recipe_problems:
        raise RecipeMismatch(list(dict.fromkeys(recipe_problems)))
    if budget_problems:
        raise ProtocolMismatch([
            f"{method} on {env}: the run's checkpoint is at {'an unknown number of' if frames is None else f'{frames:,}'} frames; "
            f"{', '.join(names)} publish(es) {', '.join(levels)} at {budget}"
            for (method, env, frames, budget), (names, levels) in budget_problems.items()],
            "Evaluate a checkpoint at a published budget (or between two), or pass allow_budget_mismatch=True "
            "(--allow-budget-mismatch) to show the run with no published number beside it, labelled.")
    if not lines:
        have = sorted({(row.method, row.env, row.level) for row in candidates})
        raise ValueError(f"{', '.join(sources)} publish(es) nothing for the rows' (method, env, level) "
                         f"{sorted(groups)[:6]}; it has e.g. {have[:6]}.")
    return lines

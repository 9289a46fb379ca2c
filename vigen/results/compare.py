"""Put a vigen evaluation beside the published numbers of the same method, task and level, under the same protocol.

A published number is only comparable to a run trained and evaluated the way the paper did: the
same budget counted in the same unit (DMC-GB's 500k *agent steps* are 2M frames at action repeat
4), action repeat, frame stack and image size. :func:`compare` checks all of them and raises
:class:`ProtocolMismatch`, naming every difference, instead of printing unlike numbers side by side.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from vigen.protocols import Protocol, get_protocol
from vigen.results.published import PublishedScore, published

VALUE_UNITS = {"return": "return", "success": "success_percent"}
"""Evaluation column -> the published unit it is compared with (``success`` rows are 0/1, shown in %)."""
SETTINGS = ("action_repeat", "frame_stack", "image_size")


class ProtocolMismatch(ValueError):
    """The run and the published numbers were not produced under the same protocol; ``differences`` lists how."""

    def __init__(self, differences: Sequence[str], hint: str = "") -> None:
        self.differences = list(differences)
        super().__init__("cannot compare with the published numbers; what differs:\n" +
                         "\n".join(f"  - {difference}" for difference in self.differences) + (f"\n{hint}" if hint else ""))


def _published_mean(members: Sequence[PublishedScore]) -> tuple[float, float | None, int]:
    """Mean, spread and seeds of a published cell: its ``mean`` row, or the mean ± sample std of its ``seed`` rows."""
    if members[0].statistic == "seed":
        values = np.array([row.value for row in members])
        return float(values.mean()), float(values.std(ddof=1)) if values.size > 1 else None, int(values.size)
    return members[0].value, members[0].spread, members[0].seeds


def _run_scores(rows: Sequence[Mapping[str, Any]], value: str) -> list[float]:
    """One score per run (its mean over episodes and seeds), in %, for ``success``."""
    per_run: dict[Any, list[float]] = defaultdict(list)
    for row in rows:
        per_run[row.get("run", 0)].append(float(row[value]) * (100.0 if value == "success" else 1.0))
    return [float(np.mean(scores)) for scores in per_run.values()]


def check_protocol(rows: Sequence[Mapping[str, Any]], protocol: Protocol) -> list[str]:
    """How the rows' own settings (``protocol``, ``action_repeat``, ``frame_stack``, ``image_size`` columns) differ from ``protocol``."""
    differences = []
    for env in dict.fromkeys(row["env"] for row in rows):
        of_env = [row for row in rows if row["env"] == env]
        named = {row.get("protocol") for row in of_env} - {None, ""}
        if named and named != {protocol.name}:
            differences.append(f"{env}: the run was trained under protocol {', '.join(sorted(map(str, named)))}, "
                               f"the published numbers under {protocol.name}")
        try:
            expected = {"action_repeat": protocol.action_repeat_for(env), "frame_stack": protocol.frame_stack,
                        "image_size": protocol.image_size}
        except ValueError as error:
            differences.append(str(error))
            continue
        for name in SETTINGS:
            found = {row[name] for row in of_env if row.get(name) not in (None, "")}
            if found and found != {expected[name]}:
                differences.append(f"{env}: {name.replace('_', ' ')} {', '.join(map(str, sorted(found)))} in the run, "
                                   f"{expected[name]} in protocol {protocol.name}")
    return differences


def compare(
    rows: Iterable[Mapping[str, Any]],
    *,
    source: str | Sequence[str],
    protocol: str | Protocol,
    value: str = "return",
    allow_budget_mismatch: bool = False,
) -> list[dict[str, Any]]:
    """A vigen evaluation beside the published numbers of the same method, env and level, one line per pair.

    Args:
        rows: :func:`vigen.evaluation.evaluate` rows (one per episode) with ``method``, ``env``,
            ``level``, ``run`` and ``frames`` (the checkpoint's frames) columns; ``examples/evaluate.py``
            also tags the run's ``protocol``, ``action_repeat``, ``frame_stack`` and ``image_size``,
            which are checked when present.
        source: the source(s) to compare with (:data:`vigen.results.SOURCES`).
        protocol: the protocol the rows were produced under; it must be the source's.
        value: ``"return"`` or ``"success"`` (compared with published success rates in %).
        allow_budget_mismatch: put a run beside published numbers measured after a different
            training length (e.g. a run still in progress); each line states both budgets.

    Returns:
        Lines with the vigen side (``runs``, ``mean``, ``std`` over runs of each run's mean, as
        the papers compute theirs), the published side (``published``, ``published_spread``,
        ``published_seeds``, ``published_method`` with its variant, ``source``, ``where``), both
        budgets in frames, and ``difference`` (vigen − published).

    Raises:
        ProtocolMismatch: the protocols, a setting, the budget or the unit differ (each difference listed).
        ValueError: the source publishes nothing for the rows' methods, envs and levels.

    Examples:
        >>> from vigen.results import compare
        >>> rows = [{"method": "svea", "env": "dmc/walker-stand", "level": "video_hard", "run": run, "frames": 2_000_000,
        ...          "action_repeat": 4, "return": value} for run, value in enumerate([800.0, 900.0])]
        >>> [(line["source"], line["published"], line["mean"]) for line in compare(rows, source="sgqn", protocol="dmcgb")]
        [('sgqn', 747.0, 850.0)]
        >>> compare([dict(row, action_repeat=2) for row in rows], source="sgqn", protocol="dmcgb")
        Traceback (most recent call last):
        ...
        vigen.results.compare.ProtocolMismatch: cannot compare with the published numbers; what differs:
          - dmc/walker-stand: action repeat 2 in the run, 4 in protocol dmcgb
        Train with the published protocol's settings (examples/train.py --protocol dmcgb) or compare with a source published under the run's.
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
    candidates = published(source=sources, unit=VALUE_UNITS[value])
    if not candidates:
        raise ProtocolMismatch([f"{', '.join(sources)} publish(es) no {value} ({VALUE_UNITS[value]}) numbers"])
    differences = [f"source {name} publishes under protocol {', '.join(sorted({row.protocol for row in candidates if row.source == name}))}, "
                   f"the run follows {protocol.name}" for name in sources
                   if {row.protocol for row in candidates if row.source == name} - {protocol.name}]
    differences += check_protocol(rows, protocol)
    if differences:
        raise ProtocolMismatch(differences, f"Train with the published protocol's settings (examples/train.py --protocol "
                                            f"{candidates[0].protocol}) or compare with a source published under the run's.")

    cells: dict[tuple, list[PublishedScore]] = defaultdict(list)
    for row in candidates:
        cells[row.method, row.env, row.level, row.source, row.variant, row.budget].append(row)
    groups: dict[tuple, list[Mapping[str, Any]]] = defaultdict(list)
    for row in rows:
        groups[str(row["method"]), str(row["env"]), str(row["level"])].append(row)

    lines: list[dict[str, Any]] = []
    budget_problems: dict[tuple, tuple[dict, dict]] = {}  # (method, env, frames, published budget) -> (sources, levels)
    for (method, env, level), members in groups.items():
        matches = [key for key in cells if key[:3] == (method, env, level)]
        if not matches:
            continue
        frames = {row.get("frames") for row in members} - {None, ""}
        if len(frames) > 1:
            raise ValueError(f"{method} on {env} ({level}) mixes checkpoints of {sorted(frames)} frames; compare one budget at a time.")
        run_frames = int(next(iter(frames))) if frames else None
        repeat = protocol.action_repeat_for(env)
        for source_name, variant in dict.fromkeys(key[3:5] for key in matches):
            budgets = {key[5]: cells[key] for key in matches if key[3:5] == (source_name, variant)}
            cell, problem = _at_budget(budgets, run_frames, repeat, allow_budget_mismatch)
            if cell is None:
                key = (method, env, run_frames, problem)
                budget_problems.setdefault(key, ({}, {}))[0][source_name] = None
                budget_problems[key][1][level] = None
                continue
            mean, spread, seeds = _published_mean(cell)
            scores = _run_scores(members, value)
            lines.append({
                "method": method, "env": env, "level": level, "runs": len(scores), "frames": run_frames,
                "mean": float(np.mean(scores)), "std": float(np.std(scores, ddof=1)) if len(scores) > 1 else float("nan"),
                "published_method": cell[0].label, "source": source_name, "published": mean,
                "published_spread": spread, "published_seeds": seeds, "published_frames": cell[0].frames(repeat),
                "budget_matches": cell[0].frames(repeat) in (run_frames, None),
                "difference": float(np.mean(scores)) - mean, "unit": cell[0].unit, "where": cell[0].where,
            })
    if budget_problems:
        raise ProtocolMismatch([
            f"{method} on {env}: the run's checkpoint is at {'an unknown number of' if frames is None else f'{frames:,}'} frames; "
            f"{', '.join(names)} publish(es) {', '.join(levels)} at {budget}"
            for (method, env, frames, budget), (names, levels) in budget_problems.items()], "Evaluate a checkpoint at the published budget, or pass "
                                                "allow_budget_mismatch=True (--allow-budget-mismatch) to show them anyway, labelled.")
    if not lines:
        have = sorted({(row.method, row.env, row.level) for row in candidates})
        raise ValueError(f"{', '.join(sources)} publish(es) nothing for the rows' (method, env, level) "
                         f"{sorted(groups)[:6]}; it has e.g. {have[:6]}.")
    return lines


def _at_budget(budgets: Mapping[int | None, list[PublishedScore]], run_frames: int | None, repeat: int, allow_mismatch: bool
               ) -> tuple[list[PublishedScore] | None, str]:
    """The published cell at the run's frames (or at an unstated budget); else the nearest one if allowed, else why not."""
    at_frames = {cell[0].frames(repeat): cell for cell in budgets.values()}
    if run_frames in at_frames or None in at_frames:
        return at_frames.get(run_frames, at_frames.get(None)), ""
    nearest = at_frames[min(at_frames, key=lambda frames: abs(frames - (run_frames or 0)))]
    if allow_mismatch:
        return nearest, ""
    shown = ", ".join(f"{frames:,}" for frames in sorted(at_frames)[:6]) + (" ..." if len(at_frames) > 6 else "")
    return None, f"{shown} frames ({nearest[0].budget_text} at action repeat {repeat})"

"""From per-episode rows to summary lines: per method and level, generalization gaps, probabilities of improvement."""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np

from vigen.evaluation.aggregate import iqm, rlvigen_mean_std, stratified_bootstrap_ci
from vigen.evaluation.statistics import (generalization_gap, generalization_gap_ci, improvement_p_value, probability_of_improvement,
                                         probability_of_improvement_ci)


def score_matrix(rows: Iterable[Mapping[str, Any]], *, run: str = "run", task: str = "env", value: str = "return") -> np.ndarray:
    """The ``[runs, tasks]`` matrix of mean ``value`` per run and task (the mean over its episodes).

    Every run must have been evaluated on every task; a gap raises, since averaging over
    different task sets would compare unlike things.

    Examples:
        >>> from vigen.evaluation import score_matrix
        >>> rows = [{"run": r, "env": t, "return": float(r + 10 * t + e)} for r in (0, 1) for t in (0, 1) for e in (0, 1)]
        >>> score_matrix(rows)
        array([[ 0.5, 10.5],
               [ 1.5, 11.5]])
    """
    cells: dict[tuple[Any, Any], list[float]] = defaultdict(list)
    for row in rows:
        for key in (run, task, value):
            if key not in row:
                raise KeyError(f"row {dict(row)} has no {key!r} column; pass run=, task= or value= to name the columns.")
        cells[row[run], row[task]].append(float(row[value]))
    runs = sorted({r for r, _ in cells}, key=str)
    tasks = sorted({t for _, t in cells}, key=str)
    missing = [(r, t) for r in runs for t in tasks if (r, t) not in cells]
    if missing:
        raise ValueError(f"runs and tasks do not form a full grid; missing (run, task) pairs: {missing[:5]}.")
    return np.array([[np.mean(cells[r, t]) for t in tasks] for r in runs])


def summarize(
    rows: Sequence[Mapping[str, Any]],
    by: Sequence[str] = ("method", "level"),
    *,
    value: str = "return",
    run: str | None = None,
    task: str = "env",
    reps: int = 2000,
    carry: Sequence[str] = ("factor", "intensity", "fixed"),
) -> list[dict[str, Any]]:
    """One line per group (default: method × level) with every convention the papers use.

    Columns: the ``by`` keys; ``runs``, ``tasks``, ``episodes``; ``mean`` and ``iqm`` of the
    ``[runs, tasks]`` score matrix with rliable's 95 % stratified-bootstrap interval of the IQM
    (``iqm_low``, ``iqm_high``) and of the mean (``mean_low``, ``mean_high``); RL-ViGen's
    per-seed ``rlvigen_mean`` ± ``rlvigen_std``. ``run`` names the column that identifies a run:
    ``"run"`` when rows have it (one trained agent each), else ``"seed"``. ``by`` keys missing
    from the rows are skipped. The ``carry`` columns (a sweep's ``factor`` and ``intensity``) are
    copied into a line when all its rows have the same value, so that curves can be drawn from
    the lines.

    Examples:
        >>> from vigen.evaluation import summarize
        >>> rows = [{"level": "train", "seed": s, "env": "dmc/a", "return": r} for s, r in enumerate([10.0, 20.0, 30.0])]
        >>> line = summarize(rows, reps=200)[0]
        >>> line["level"], line["runs"], line["mean"], line["rlvigen_std"]
        ('train', 3, 20.0, 10.0)
        >>> swept = [{"level": "camera_rotation=0.3", "factor": "camera_rotation", "intensity": 0.3, "seed": s,
        ...           "env": "dmc/a", "return": 1.0} for s in range(2)]
        >>> {key: summarize(swept, reps=10)[0][key] for key in ("level", "factor", "intensity")}
        {'level': 'camera_rotation=0.3', 'factor': 'camera_rotation', 'intensity': 0.3}
    """
    if not rows:
        raise ValueError("no rows to summarize; did the evaluation run any episode?")
    keys = [key for key in by if key in rows[0]]
    run = run or ("run" if "run" in rows[0] else "seed")
    groups: dict[tuple, list[Mapping[str, Any]]] = defaultdict(list)
    for row in rows:
        groups[tuple(row[key] for key in keys)].append(row)
    lines = []
    for group, members in groups.items():
        scores = score_matrix(members, run=run, task=task, value=value)
        rlvigen = rlvigen_mean_std(scores)
        iqm_low, iqm_high = stratified_bootstrap_ci(scores, iqm, reps=reps)
        mean_low, mean_high = stratified_bootstrap_ci(scores, np.mean, reps=reps)
        carried = {}
        for column in carry:
            values = {str(member.get(column)) for member in members}
            if column not in keys and column in members[0] and len(values) == 1:
                carried[column] = members[0][column]
        lines.append({
            **dict(zip(keys, group)), **carried,
            "runs": scores.shape[0], "tasks": scores.shape[1], "episodes": len(members),
            "mean": float(scores.mean()), "mean_low": mean_low, "mean_high": mean_high,
            "iqm": iqm(scores), "iqm_low": iqm_low, "iqm_high": iqm_high,
            "rlvigen_mean": rlvigen.mean, "rlvigen_std": rlvigen.std,
        })
    return lines


def _run_column(rows: Sequence[Mapping[str, Any]]) -> str:
    return "run" if "run" in rows[0] else "seed"


def generalization_gaps(
    rows: Sequence[Mapping[str, Any]], *, train_level: str = "train", value: str = "return", reps: int = 2000,
) -> list[dict[str, Any]]:
    """Per method and test level, the generalization gap: mean test return over the same runs' mean ``train_level`` return.

    Columns: ``method``, ``level``, ``gap`` with its 95 % bootstrap interval (``gap_low``,
    ``gap_high``; runs resampled jointly for both levels; degenerate for one run), ``runs``, and the
    sweep columns ``factor`` and ``intensity`` when the level has them. Methods without a ``train_level`` row are skipped.

    Examples:
        >>> from vigen.evaluation import generalization_gaps
        >>> rows = [{"method": "svea", "level": level, "run": run, "env": "dmc/a", "return": r * (run + 1)}
        ...         for level, r in [("train", 800.0), ("video_hard", 200.0)] for run in range(3)]
        >>> [(line["level"], line["gap"]) for line in generalization_gaps(rows, reps=100)]
        [('video_hard', 0.25)]
    """
    if not rows:
        raise ValueError("no rows; pass the rows of an evaluation that includes the training level.")
    run = _run_column(rows)
    lines = []
    for method in dict.fromkeys(row.get("method", "agent") for row in rows):
        mine = [row for row in rows if row.get("method", "agent") == method]
        train = [row for row in mine if row["level"] == train_level]
        if not train:
            continue
        reference = score_matrix(train, run=run, value=value)
        for level in dict.fromkeys(row["level"] for row in mine if row["level"] != train_level):
            members = [row for row in mine if row["level"] == level]
            test = score_matrix(members, run=run, value=value)
            if test.shape != reference.shape:
                raise ValueError(f"{method}: level {level!r} has {test.shape} runs x tasks, {train_level!r} {reference.shape}; "
                                 "the gap pairs each run with itself, so evaluate the same runs and tasks on both.")
            if reference.mean() <= 0:
                continue  # a ratio to a non-positive training return means nothing
            low, high = generalization_gap_ci(test, reference, reps=reps)
            extra = {key: members[0][key] for key in ("factor", "intensity") if key in members[0]}
            lines.append({"method": method, "level": level, **extra, "gap": generalization_gap(test, reference),
                          "gap_low": low, "gap_high": high, "runs": test.shape[0]})
    return lines


def improvements(rows: Sequence[Mapping[str, Any]], *, value: str = "return", reps: int = 2000) -> list[dict[str, Any]]:
    """Per level, the probability of improvement P(X > Y) of every method X over every other method Y, with its 95 % interval.

    Each pair is compared on the envs (tasks) both methods were evaluated on (``tasks`` says how
    many); a pair without a shared env is left out. ``p_value`` is the one-sided Mann–Whitney U
    test that X's runs score above Y's (:func:`~vigen.evaluation.statistics.improvement_p_value`);
    with 3 runs each it cannot go below 0.05.

    Examples:
        >>> from vigen.evaluation import improvements
        >>> rows = [{"method": m, "level": "train", "run": run, "env": "dmc/a", "return": r + run}
        ...         for m, r in [("svea", 900.0), ("drqv2", 100.0)] for run in range(3)]
        >>> [(line["method"], line["over"], line["probability"]) for line in improvements(rows, reps=100)]
        [('svea', 'drqv2', 1.0), ('drqv2', 'svea', 0.0)]
    """
    if not rows:
        raise ValueError("no rows; pass the rows of an evaluation of two methods or more.")
    run = _run_column(rows)
    lines = []
    for level in dict.fromkeys(row["level"] for row in rows):
        at_level = [row for row in rows if row["level"] == level]
        methods = list(dict.fromkeys(row.get("method", "agent") for row in at_level))
        envs = {method: {row["env"] for row in at_level if row.get("method", "agent") == method} for method in methods}
        for x in methods:
            for y in methods:
                shared = envs[x] & envs[y]  # the tasks both were evaluated on; columns pair by task
                if x == y or not shared:
                    continue
                x_scores, y_scores = (score_matrix([row for row in at_level if row.get("method", "agent") == method
                                                    and row["env"] in shared], run=run, value=value) for method in (x, y))
                low, high = probability_of_improvement_ci(x_scores, y_scores, reps=reps)
                lines.append({"level": level, "method": x, "over": y, "tasks": len(shared),
                              "probability": probability_of_improvement(x_scores, y_scores), "low": low, "high": high,
                              "p_value": improvement_p_value(x_scores, y_scores), "runs": x_scores.shape[0],
                              "over_runs": y_scores.shape[0]})
    return lines

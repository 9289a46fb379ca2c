"""Rebuild a committed results folder's summary, statistics, plots and report from its per-episode rows.

A results folder (``docs/results/<task>/``) holds what was measured: ``episodes.csv`` (one row per
zero-shot episode, as ``examples/evaluate.py`` writes them) and ``training.csv`` (each run's
evaluation return during training, from its ``logs/scalars/eval/train_return.csv``). Everything
else in it is derived here, deterministically (the bootstrap draws are seeded), so that a test can
recompute it and find the same numbers:

- ``summary.csv``: per method and level, the IQM and mean over runs with 95 % stratified-bootstrap
  intervals (rliable's), and RL-ViGen's mean ± std over runs;
- ``gaps.csv``: per method and test level, the generalization gap (test / train return of the same
  runs) with its 95 % interval;
- ``improvements.csv``: per level, P(X > Y) for every pair of methods with its 95 % interval;
- ``published.csv``: the train-level rows beside the published numbers (``vigen.results.compare``);
- ``levels.png`` (IQM per level) and ``robustness.png`` (the gap per level);
- ``report.md``: the tables above and, per test level, whether the second method's advantage over
  the first is resolved: only where a stated test holds (:data:`RESOLVED_RULE`), with the closest
  pair of runs the ordering rests on beside it; and, where the rows say it, the data each level showed.

    python scripts/results_report.py docs/results/cartpole-balance --compare drqv2 --methods drqv2 svea

Existing derived files are replaced only with ``--overwrite`` (the rows never are).
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from vigen.assets.video_source import natural_key
from vigen.evaluation import generalization_gaps, improvements, markdown_table, plot_levels, summarize, write_csv
from vigen.evaluation.aggregate import percentile_interval, stratified_picks
from vigen.evaluation.report import interval_cell, label_stand_ins
from vigen.evaluation.statistics import gap_resamples, generalization_gap, improvement_p_value, smallest_p_value
from vigen.evaluation.summary import score_matrix
from vigen.io import atomic_write
from vigen.protocols import get_protocol
from vigen.results import compare, published

ALPHA = 0.05
RESOLVED_RULE = (f"resolved where the one-sided Mann–Whitney U test on the runs' mean returns gives p ≤ {ALPHA} in one "
                 "direction and the closest pair of runs across the two methods differs by at least twice the standard "
                 "error of that difference, √(SE₁² + SE₂²) (for the gap difference: the test on each run's own test / train "
                 "ratio, and the 95 % interval excludes 0)")
"""When the report calls a level resolved. With 3 runs per method the smallest p-value is 1 / C(6, 3) = 0.05."""
INTEGER_COLUMNS = ("run", "seed", "episode", "length", "frames", "batch_size", "action_repeat", "frame_stack", "image_size", "episode_length")
FLOAT_COLUMNS = ("return",)
BOOLEAN_COLUMNS = ("stand_in",)
DERIVED = ("summary.csv", "gaps.csv", "gap_differences.csv", "improvements.csv", "published.csv", "levels.png", "robustness.png", "report.md")


def read_rows(path: str | Path) -> list[dict[str, Any]]:
    """The rows of an ``episodes.csv`` with numbers as numbers (empty cells stay ``""``, as the random baseline's are)."""
    rows = []
    with open(path, newline="") as file:
        for row in csv.DictReader(file):
            for column in INTEGER_COLUMNS:
                if row.get(column, "") != "":
                    row[column] = int(row[column])
            for column in FLOAT_COLUMNS:
                row[column] = float(row[column])
            for column in BOOLEAN_COLUMNS:
                if column in row:
                    row[column] = {"True": True, "False": False}[row[column]]
            rows.append(row)
    if not rows:
        raise ValueError(f"{path}: no rows.")
    return rows


def derive(rows: Sequence[Mapping[str, Any]], *, compare_with: str | None = None, methods: Sequence[str] | None = None) -> dict[str, list[dict[str, Any]]]:
    """Every derived table of a results folder, from its per-episode rows (``methods``: the baseline and the method compared)."""
    trained = [row for row in rows if row["method"] != "random"]
    tables = {"summary": summarize(rows), "gaps": generalization_gaps(trained), "improvements": improvements(rows)}
    if methods is not None:
        tables["gap_differences"] = gap_differences(trained, methods[1], methods[0])
    if compare_with is not None:
        at_train = [row for row in trained if row["level"] == "train"]
        # the committed runs name no recipe (vigen's algorithm defaults): shown beside the published curve anyway, each
        # line saying so (docs/recipes.md)
        tables["published"] = compare(at_train, source=compare_with, protocol=compare_with, allow_budget_mismatch=True,
                                      allow_recipe_mismatch=True)
    return tables


def gap_differences(rows: Sequence[Mapping[str, Any]], method: str, over: str, *, reps: int = 2000, seed: int = 0
                    ) -> list[dict[str, Any]]:
    """Per test level, gap(method) − gap(over) with a 95 % interval: each method's runs resampled apart, each run paired with itself.

    A positive difference means ``method`` keeps more of its own training return under the shift.
    """
    rng = np.random.default_rng(seed)
    lines = []
    levels = [level for level in dict.fromkeys(row["level"] for row in rows) if level != "train"]
    for level in levels:
        draws, point = [], []
        for name in (method, over):
            mine = [row for row in rows if row["method"] == name]
            train = score_matrix([row for row in mine if row["level"] == "train"])
            test = score_matrix([row for row in mine if row["level"] == level])
            draws.append(gap_resamples(test, train, stratified_picks(rng, reps, *train.shape)))
            point.append(generalization_gap(test, train))
        differences = draws[0] - draws[1]
        low, high = percentile_interval(differences[np.isfinite(differences)], 0.95)
        lines.append({"level": level, "method": method, "over": over, "difference": float(point[0] - point[1]),
                      "low": float(low), "high": float(high),
                      "p_value": improvement_p_value(*(run_ratios(rows, name, level) for name in (method, over)))})
    return lines


def run_ratios(rows: Sequence[Mapping[str, Any]], method: str, level: str) -> np.ndarray:
    """Each run's own test / train ratio ``[runs, tasks]`` (the statistic the gap difference's test ranks)."""
    mine = [row for row in rows if row["method"] == method]
    return score_matrix([row for row in mine if row["level"] == level]) / score_matrix([row for row in mine if row["level"] == "train"])


def closest_pair(rows: Sequence[Mapping[str, Any]], method: str, over: str, level: str) -> dict[str, float]:
    """The pair of runs (one of ``method``, one of ``over``) whose mean returns at ``level`` lie closest: their margin and its error.

    ``error`` is the standard error of the difference of the two run means, √(SE₁² + SE₂²), each
    run's SE the spread of its episodes over the square root of their count. An ordering of runs
    that rests on a margin under twice that error would likely flip with more episodes.
    """
    runs: dict[str, dict[Any, list[float]]] = {method: {}, over: {}}
    for row in rows:
        if row["level"] == level and row["method"] in runs:
            runs[row["method"]].setdefault(row["run"], []).append(float(row["return"]))

    def mean_and_error(values: list[float]) -> tuple[float, float]:
        spread = float(np.std(values, ddof=1)) if len(values) > 1 else float("nan")
        return float(np.mean(values)), spread / math.sqrt(len(values))

    pairs = [(mean_and_error(mine), mean_and_error(theirs)) for mine in runs[method].values() for theirs in runs[over].values()]
    (mine, mine_error), (theirs, theirs_error) = min(pairs, key=lambda pair: abs(pair[0][0] - pair[1][0]))
    return {"margin": abs(mine - theirs), "error": math.hypot(mine_error, theirs_error)}


def resolved(p_above: float, p_below: float, above: str, below: str) -> str:
    """``above`` where the one-sided test that way gives p ≤ :data:`ALPHA`, ``below`` where the other way does, else "not resolved"."""
    return above if p_above <= ALPHA else below if p_below <= ALPHA else "not resolved"


def direction(lines: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]], method: str, over: str) -> list[dict[str, Any]]:
    """Per level, P(method > over) with its interval, the Mann–Whitney p-values both ways, the closest pair and the verdict.

    The verdict follows :data:`RESOLVED_RULE`: a test that holds on an ordering of runs whose closest
    pair differs by less than twice the standard error of that difference is reported as "not resolved (fragile)".
    """
    reverse = {line["level"]: line["p_value"] for line in lines if line["method"] == over and line["over"] == method}
    verdicts = []
    for line in lines:
        if line["method"] != method or line["over"] != over:
            continue
        pair = closest_pair(rows, method, over, line["level"])
        fragile = pair["margin"] < 2 * pair["error"]
        verdict = resolved(line["p_value"], reverse[line["level"]], f"{method} better", f"{over} better")
        if fragile and verdict != "not resolved":
            verdict = f"not resolved (fragile: {verdict} by the test alone)"
        verdicts.append({"level": line["level"], "probability": line["probability"], "low": line["low"],
                         "high": line["high"], "p_value": line["p_value"], "p_reverse": reverse[line["level"]],
                         "margin": pair["margin"], "error": pair["error"], "fragile": fragile, "verdict": verdict})
    return verdicts


def data_shown(rows: Sequence[Mapping[str, Any]]) -> list[str]:
    """The report's table of what each level showed: its data, whether vigen's stand-ins, its options, what the episodes saw."""
    if not any("data" in row for row in rows):
        return []
    table = ["## What each level showed", "",
             "From the rows' `data`, `stand_in`, `level_options` and `shown` columns (examples/evaluate.py writes them).", "",
             "| level | data | stand-in | level options | seen by the episodes |", "|---|---|---|---|---|"]
    for level in dict.fromkeys(row["level"] for row in rows):
        mine = [row for row in rows if row["level"] == level]
        data = "; ".join(dict.fromkeys(str(row.get("data", "")) for row in mine if row.get("data"))) or "—"
        stand_in = "yes" if any(row.get("stand_in") is True for row in mine) else "no"
        options = ", ".join(f"`{value}`" for value in dict.fromkeys(str(row.get("level_options", "")) for row in mine) if value) or "—"
        shown = sorted({str(row["shown"]) for row in mine if row.get("shown")}, key=natural_key)
        named = [value if ";" in value else value.split("=", 1)[-1] for value in shown]  # "video=video3.mp4" -> "video3.mp4"
        seen = "—" if not shown else f"{len(shown)} distinct: " + ", ".join(named[:6]) + (" ..." if len(shown) > 6 else "")
        table.append(f"| {level} | {data} | {stand_in} | {options} | {seen} |")
    return table + [""]


def write(folder: Path, rows: Sequence[Mapping[str, Any]], tables: Mapping[str, list[dict[str, Any]]],
          methods: Sequence[str]) -> list[Path]:
    """Write the derived files of ``folder`` (the caller checked they may be replaced)."""
    written = [write_csv(tables[name], folder / f"{name}.csv") for name in ("summary", "gaps", "gap_differences", "improvements",
                                                                           "published") if name in tables]
    task = ", ".join(dict.fromkeys(row["env"] for row in rows))
    written.append(plot_levels(tables["summary"], folder / "levels.png", title=f"{task}: zero-shot IQM per level (95 % CI)"))
    as_bars = [{"method": line["method"], "level": line["level"], "iqm": line["gap"], "iqm_low": line["gap_low"],
                "iqm_high": line["gap_high"], "runs": line["runs"]} for line in tables["gaps"]]
    written.append(plot_levels(as_bars, folder / "robustness.png", ylabel="test / train return (same runs)",
                               title=f"{task}: return kept under each shift (95 % CI)"))
    report = [f"# Zero-shot evaluation: {task}", "",
              "Derived by `scripts/results_report.py` from `episodes.csv`; see README.md for how the rows were made.", "",
              *data_shown(rows),
              "## Episode return", "", markdown_table(label_stand_ins(tables["summary"], rows)), "",
              "## Generalization gap (test / train return of the same runs, 95 % CI)", "",
              markdown_table(tables["gaps"], cell=lambda line: interval_cell(line["gap"], line["gap_low"], line["gap_high"], line["runs"])),
              "", "![robustness.png](robustness.png)", ""]
    if len(methods) == 2:
        first, second = methods
        verdicts = direction(tables["improvements"], rows, second, first)
        runs = {name: len({row["run"] for row in rows if row["method"] == name}) for name in methods}
        floor = smallest_p_value(runs[second], runs[first])
        report += [f"## P({second} > {first}) per level (95 % CI), with the one-sided Mann–Whitney test", "",
                   f"A level is {RESOLVED_RULE}. With {runs[second]} runs of {second} and {runs[first]} of {first}, the "
                   f"smallest p-value any result can give is {floor:.3g}: "
                   + ("no level can be resolved at this sample size. " if floor > ALPHA else
                      f"p = {floor:.3g} means every pair of runs agrees, the most this design can show, not certainty. ")
                   + "The closest pair is the pair of runs, one of each method, whose mean returns lie closest, with the "
                     "standard error of their difference, √(SE₁² + SE₂²), each run's SE its episodes' spread over "
                     "√episodes; an ordering that rests on a margin under twice that error is fragile: more episodes could "
                     "flip it.", "",
                   f"| level | P | 95 % CI | p ({second} > {first}) | p ({first} > {second}) | closest pair: margin | resolved |",
                   "|---|---|---|---|---|---|---|"]
        single = runs[second] == 1 and runs[first] == 1  # a bootstrap over one run each has no interval

        def ci(low: float, high: float, spec: str = ".2f") -> str:
            return "1 run each: no interval" if single else f"[{low:{spec}}, {high:{spec}}]"

        report += [f"| {line['level']} | {line['probability']:.2f} | {ci(line['low'], line['high'])} | "
                   f"{line['p_value']:.3f} | {line['p_reverse']:.3f} | {line['margin']:.1f} (SE {line['error']:.1f}) | "
                   f"{line['verdict']} |" for line in verdicts]
        report += ["", f"## Return kept under shift: gap({second}) − gap({first}) per level (95 % CI)", "",
                   f"A method's gap at a level is its runs' mean test return divided by their mean training return (a "
                   f"ratio of means over the runs, not the mean of each run's own ratio). Positive: {second} keeps more of "
                   f"its training return than {first} does. The p-value is the one-sided Mann–Whitney test on each run's own "
                   f"test / train ratio.", "",
                   "| level | difference | 95 % CI | p | resolved |", "|---|---|---|---|---|"]
        for line in tables["gap_differences"]:
            reverse = improvement_p_value(*(run_ratios(rows, name, line["level"]) for name in (first, second)))
            word = (resolved(line["p_value"], reverse, f"{second} keeps more", f"{first} keeps more")
                    if line["low"] > 0 or line["high"] < 0 else "not resolved")
            report.append(f"| {line['level']} | {line['difference']:+.2f} | {ci(line['low'], line['high'], '+.2f')} | "
                          f"{line['p_value']:.3f} | {word} |")
        report += [""]
    if "published" in tables:
        report += ["## Beside the published numbers (train level)", "",
                   "| method | frames | vigen mean ± std over runs | published | published frames | notes |", "|---|---|---|---|---|---|"]
        for line in tables["published"]:
            spread = "" if math.isnan(line["std"]) else f" ± {line['std']:.1f}"
            theirs = ("none at this budget" if math.isnan(line["published"]) else
                      f"{line['published']:.1f} ({line['published_seeds']} seeds)")
            at = "" if line["published_frames"] is None else f"{line['published_frames']:,}"
            report.append(f"| {line['method']} | {line['frames']:,} | {line['mean']:.1f}{spread} "
                          f"({line['runs']} run{'s' * (line['runs'] != 1)}) | "
                          f"{theirs} | {at} | {line['notes']} |")
        for line in tables["published"]:
            others = published(source=line["source"], method=line["method"],
                               suite=line["env"].split("/")[0], task=line["env"].split("/", 1)[1], level=line["level"],
                               statistic="mean", unit="return")
            budgets = [(row.frames(get_protocol(row.protocol).action_repeat_for(line["env"])), row.value) for row in others]
            around = sorted((frames, value) for frames, value in budgets
                            if frames is not None and abs(frames - line["frames"]) <= 20_000)
            if len(around) > 1:
                report.append("")
                report.append(f"{line['source']} publishes {line['method']} on {line['env']} at "
                              + ", ".join(f"{value:.1f} ({frames:,} frames)" for frames, value in around) + ".")
        report += [""]
    report += ["## Probability of improvement P(row beats column), per level (95 % CI)", ""]
    for level in dict.fromkeys(line["level"] for line in tables["improvements"]):
        report += [f"{level}:", "", markdown_table([line for line in tables["improvements"] if line["level"] == level],
                                                   rows="method", columns="over",
                                                   cell=lambda line: interval_cell(line["probability"], line["low"], line["high"],
                                                                                max(line["runs"], line["over_runs"]))), ""]
    report += ["![levels.png](levels.png)", ""]
    atomic_write(folder / "report.md", "\n".join(report))
    return [*written, folder / "report.md"]


def main(argv: Sequence[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("folder", type=Path, help="the results folder (holding episodes.csv)")
    parser.add_argument("--compare", default=None, help="a source of vigen.results to put the train level beside")
    parser.add_argument("--methods", nargs=2, default=None, metavar=("BASELINE", "METHOD"),
                        help="the pair whose P(METHOD > BASELINE) the report resolves per level")
    parser.add_argument("--overwrite", action="store_true", help="replace derived files that exist")
    args = parser.parse_args(argv)
    episodes = args.folder / "episodes.csv"
    if not episodes.is_file():
        raise SystemExit(f"{episodes}: not found; pass a results folder holding the rows of examples/evaluate.py.")
    existing = [name for name in DERIVED if (args.folder / name).exists()]
    if existing and not args.overwrite:
        raise SystemExit(f"{args.folder} already holds {', '.join(existing)}; pass --overwrite to rebuild them.")
    rows = read_rows(episodes)
    methods = args.methods or []
    missing = [method for method in methods if method not in {row["method"] for row in rows}]
    if missing:
        raise SystemExit(f"--methods {' '.join(missing)}: not in the rows' methods.")
    tables = derive(rows, compare_with=args.compare, methods=args.methods)
    # written beside, then moved over the old files one by one (vigen's writers never replace a file)
    staging = Path(tempfile.mkdtemp(prefix=".rebuild-", dir=args.folder))
    try:
        written = write(staging, rows, tables, methods)
        for path in written:
            os.replace(path, args.folder / path.name)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    print("wrote " + ", ".join(path.name for path in written))


if __name__ == "__main__":
    main()

"""An evaluation's report: the report folder of ``examples/evaluate.py`` (:func:`write_report`), and the writers it is made
of: raw rows as CSV, the summary as a markdown table, bar plots and robustness curves as PNG.

None of them overwrites a file: an existing path raises ``FileExistsError`` (pick a new folder,
e.g. with :func:`vigen.io.unused_path`).
"""

from __future__ import annotations

import csv
import io
import math
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from vigen.datasets.identity import not_in_full
from vigen.envs import get_suite
from vigen.evaluation.statistics import performance_profile, performance_profile_ci
from vigen.evaluation.summary import generalization_gaps, improvements, score_matrix, summarize
from vigen.io import atomic_write
from vigen.protocols import PROTOCOLS

if TYPE_CHECKING:
    from vigen.evaluation.comparison import Comparison


def _new_file(path: str | Path) -> Path:
    path = Path(path)
    if path.exists():
        raise FileExistsError(f"{path} exists and would be overwritten; choose another path or folder.")
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


@contextmanager
def _figure(path: Path, size: tuple[float, float]) -> Iterator[Any]:
    """One figure's axes to draw on; when drawing succeeds it is saved to ``path`` (PNG, written atomically); always closed."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    figure, axes = plt.subplots(figsize=size)
    try:
        yield axes
        axes.spines[["top", "right"]].set_visible(False)
        figure.tight_layout()
        atomic_write(path, lambda file: figure.savefig(file, format="png", dpi=120))
    finally:
        plt.close(figure)


def write_csv(rows: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """Write rows (dicts) as CSV with the union of their keys as columns, in first-seen order, atomically (all rows or no file).

    Examples:
        >>> import tempfile, pathlib
        >>> from vigen.evaluation import write_csv
        >>> path = write_csv([{"level": "train", "return": 1.0}], pathlib.Path(tempfile.mkdtemp()) / "rows.csv")
        >>> path.read_text().splitlines()
        ['level,return', 'train,1.0']
    """
    path = _new_file(path)
    columns = list(dict.fromkeys(key for row in rows for key in row))
    text = io.StringIO()
    writer = csv.DictWriter(text, fieldnames=columns)
    writer.writeheader()
    writer.writerows(rows)
    return atomic_write(path, text.getvalue())


IQM_LEGEND = "Cells: IQM [95 % stratified-bootstrap CI] · RL-ViGen mean ± std over runs."


def _iqm_cell(line: Mapping[str, Any]) -> str:
    if line.get("runs") == 1:  # a bootstrap over one run has no spread to show
        return f"{line['iqm']:.1f} (1 run: no interval)"
    std = "" if math.isnan(line["rlvigen_std"]) else f" ± {line['rlvigen_std']:.1f}"
    return f"{line['iqm']:.1f} [{line['iqm_low']:.1f}, {line['iqm_high']:.1f}] · {line['rlvigen_mean']:.1f}{std}"


def interval_cell(value: float, low: float, high: float, runs: int | None, spec: str = ".2f") -> str:
    """``value [low, high]``, or ``value (1 run: no interval)`` where the interval is a bootstrap over a single run.

    Examples:
        >>> from vigen.evaluation.report import interval_cell
        >>> interval_cell(0.81, 0.7, 0.9, 3), interval_cell(0.81, 0.81, 0.81, 1)
        ('0.81 [0.70, 0.90]', '0.81 (1 run: no interval)')
    """
    if runs == 1:
        return f"{value:{spec}} (1 run: no interval)"
    return f"{value:{spec}} [{low:{spec}}, {high:{spec}}]"


def label_stand_ins(lines: Sequence[Mapping[str, Any]], rows: Sequence[Mapping[str, Any]]) -> list[dict[str, Any]]:
    """``lines`` with " (stand-in)" after each level whose rows showed vigen's stand-ins (``stand_in`` true), and
    " (partial data)" after each level whose rows showed less than a data set in full (a user's folder, fewer files
    than the part holds, files not verified: :func:`vigen.datasets.identity.not_in_full`), for tables.

    Examples:
        >>> from vigen.evaluation.report import label_stand_ins
        >>> rows = [{"level": "train", "stand_in": False}, {"level": "video_hard", "stand_in": True},
        ...         {"level": "video_easy", "stand_in": False, "data": "dmcgb-videos/video_easy: 6 of 10, verified"}]
        >>> [line["level"] for line in label_stand_ins([{"level": "train"}, {"level": "video_hard"}, {"level": "video_easy"}], rows)]
        ['train', 'video_hard (stand-in)', 'video_easy (partial data)']
    """
    stand_ins = {row["level"] for row in rows if row.get("stand_in") is True or str(row.get("stand_in")) == "True"}
    partial = {row["level"] for row in rows if not_in_full(row.get("data"))}

    def label(level: str) -> str:
        return level + (" (stand-in)" if level in stand_ins else "") + (" (partial data)" if level in partial else "")

    return [dict(line, level=label(line["level"])) for line in lines]


def markdown_table(
    lines: Sequence[Mapping[str, Any]],
    *,
    rows: str = "level",
    columns: str = "method",
    cell: Callable[[Mapping[str, Any]], str] | None = None,
    legend: str | None = None,
) -> str:
    """A ``rows`` × ``columns`` markdown table; by default levels × methods of ``IQM [95 % CI]`` and RL-ViGen's ``mean ± std``.

    ``cell`` formats one line as its cell (default: the IQM cell, with its legend below the table;
    a method evaluated as one run shows its score and "1 run: no interval", since a bootstrap over
    runs has nothing to resample); a missing cell shows "—". ``legend`` is a line printed below the table.

    Examples:
        >>> from vigen.evaluation import markdown_table
        >>> line = {"method": "svea", "level": "train", "iqm": 800.0, "iqm_low": 780.0, "iqm_high": 820.0,
        ...         "rlvigen_mean": 801.0, "rlvigen_std": 12.0, "runs": 3}
        >>> print(markdown_table([line]))
        | level | svea |
        |---|---|
        | train | 800.0 [780.0, 820.0] · 801.0 ± 12.0 |
        <BLANKLINE>
        Cells: IQM [95 % stratified-bootstrap CI] · RL-ViGen mean ± std over runs.
        >>> print(markdown_table([dict(line, method="random", runs=1)]).splitlines()[2])
        | train | 800.0 (1 run: no interval) |
        >>> print(markdown_table([{"level": "video_hard", "method": "svea", "gap": 0.4}], cell=lambda line: f"{line['gap']:.2f}"))
        | level | svea |
        |---|---|
        | video_hard | 0.40 |
    """
    if cell is None:
        cell, legend = _iqm_cell, IQM_LEGEND if legend is None else legend
    row_names = list(dict.fromkeys(str(line.get(rows, "")) for line in lines))
    column_names = list(dict.fromkeys(str(line.get(columns, "agent")) for line in lines))
    cells = {(str(line.get(rows, "")), str(line.get(columns, "agent"))): line for line in lines}
    table = [f"| {rows} | " + " | ".join(column_names) + " |", "|" + "---|" * (len(column_names) + 1)]
    for name in row_names:
        table.append(f"| {name} | " + " | ".join("—" if (name, column) not in cells else cell(cells[name, column])
                                                for column in column_names) + " |")
    if legend:
        table += ["", legend]
    return "\n".join(table)


def plot_levels(
    lines: Sequence[Mapping[str, Any]],
    path: str | Path,
    *,
    statistic: str = "iqm",
    title: str | None = None,
    ylabel: str = "episode return",
) -> Path:
    """Bar plot, levels along x and one bar per method, heights ``statistic`` with its 95 % CI as error bars.

    A method evaluated as one run (a line with ``runs`` 1) gets a hatched bar and no error bar, and
    the title says so: a bootstrap over one run has no interval to show.

    ``statistic`` is ``"iqm"`` or ``"mean"`` (both with their bootstrap intervals) or
    ``"rlvigen_mean"`` (error bars ± the sample std over runs), as in RL-ViGen's figures.

    Examples:
        >>> import tempfile, pathlib
        >>> from vigen.evaluation import plot_levels
        >>> lines = [{"method": "drqv2", "level": level, "iqm": r, "iqm_low": r - 5, "iqm_high": r + 5}
        ...          for level, r in [("train", 900.0), ("color_hard", 400.0)]]
        >>> plot_levels(lines, pathlib.Path(tempfile.mkdtemp()) / "levels.png").suffix
        '.png'
    """
    path = _new_file(path)
    levels = list(dict.fromkeys(str(line["level"]) for line in lines))
    methods = list(dict.fromkeys(str(line.get("method", "agent")) for line in lines))
    by_cell = {(str(line["level"]), str(line.get("method", "agent"))): line for line in lines}
    width = 0.8 / len(methods)
    with _figure(path, (max(4.0, 1.1 * len(levels) * max(1, len(methods)) ** 0.5 + 1.5), 3.2)) as axes:
        single = False
        for index, method in enumerate(methods):
            xs, heights, bands, hatches = [], [], [], []
            for position, level in enumerate(levels):
                line = by_cell.get((level, method))
                if line is None:
                    continue
                one_run = line.get("runs") == 1  # a bootstrap over one run has no spread: no interval is drawn
                single |= one_run
                xs.append(position - 0.4 + width * (index + 0.5))
                heights.append(float(line[statistic]))
                if one_run:
                    bands.append(None)
                elif statistic == "rlvigen_mean":
                    bands.append(_band(line, statistic))
                else:  # a line of several runs must carry its interval
                    bands.append((float(line[f"{statistic}_low"]), float(line[f"{statistic}_high"])))
                hatches.append("//" if one_run else None)
            bars = axes.bar(xs, heights, width=width * 0.92, label=method)
            for bar, hatch in zip(bars, hatches):
                bar.set_hatch(hatch)
            drawn = [(x, height, band) for x, height, band in zip(xs, heights, bands) if band is not None]
            if drawn:
                axes.errorbar([x for x, _, _ in drawn], [height for _, height, _ in drawn], fmt="none", ecolor="black",
                              capsize=3, yerr=[[height - band[0] for _, height, band in drawn],
                                               [band[1] - height for _, height, band in drawn]])
        crowded = len(levels) > 4
        axes.set_xticks(range(len(levels)), levels, rotation=30 if crowded else 0, ha="right" if crowded else "center")
        axes.set_ylabel(ylabel)
        interval = "± std over runs" if statistic == "rlvigen_mean" else "95 % CI"
        caption = title or f"zero-shot {statistic.replace('_', ' ')} per level ({interval})"
        axes.set_title(caption + ("\nhatched: one run, no interval" if single else ""), fontsize="medium")
        if len(methods) > 1:
            axes.legend(frameon=False, fontsize="small")
    return path


def _band(line: Mapping[str, Any], statistic: str) -> tuple[float, float] | None:
    """The interval drawn around ``statistic``: its bootstrap CI, or ± the std over runs for ``rlvigen_mean``."""
    if statistic == "rlvigen_mean":
        spread = _number(line.get("rlvigen_std"))
        centre = _number(line[statistic])
        return None if spread is None or centre is None else (centre - spread, centre + spread)
    low, high = _number(line.get(f"{statistic}_low")), _number(line.get(f"{statistic}_high"))
    return None if low is None or high is None else (low, high)


def _number(value: Any) -> float | None:
    """``value`` as a finite float; ``None`` for blanks (e.g. a CSV's empty cell), missing values and NaN."""
    if value is None or value == "":
        return None
    number = float(value)
    return number if math.isfinite(number) else None


def plot_intensity(
    lines: Sequence[Mapping[str, Any]],
    path: str | Path,
    *,
    factor: str,
    statistic: str = "iqm",
    title: str | None = None,
    ylabel: str = "episode return",
) -> Path:
    """Robustness curve: ``statistic`` against the intensity of ``factor``, one line per method, with its 95 % CI band.

    This is the Distracting Control Suite's figure (Stone et al. 2021, https://arxiv.org/abs/2101.02722):
    return as a distraction grows. ``lines`` are :func:`~vigen.evaluation.summarize` lines or the
    rows of :func:`~vigen.evaluation.evaluate` (summarized here), either read back from CSV or not;
    the points are the lines whose ``factor`` column is ``factor`` (the levels of
    :func:`~vigen.evaluation.sweep`). A sweep with ``fixed`` factors is its own curve, labelled
    with them. ``statistic`` is ``"iqm"`` or ``"mean"`` (band: the stratified-bootstrap CI) or
    ``"rlvigen_mean"`` (band: ± the std over runs); the band is left out where it is unknown.

    Examples:
        >>> import tempfile, pathlib
        >>> from vigen.evaluation import plot_intensity
        >>> lines = [{"method": "drqv2", "level": f"camera_rotation={x:g}", "factor": "camera_rotation", "intensity": x,
        ...           "iqm": r, "iqm_low": r - 30, "iqm_high": r + 30} for x, r in [(0.0, 900.0), (0.1, 600.0), (0.3, 250.0)]]
        >>> plot_intensity(lines, pathlib.Path(tempfile.mkdtemp()) / "camera_rotation.png", factor="camera_rotation").suffix
        '.png'
    """
    if statistic not in ("iqm", "mean", "rlvigen_mean"):
        raise ValueError(f"statistic must be 'iqm', 'mean' or 'rlvigen_mean', got {statistic!r}.")
    if not lines:
        raise ValueError("lines is empty: pass the summary lines (or rows) of an evaluation that ran a sweep.")
    if statistic not in lines[0] and "return" in lines[0]:
        lines = summarize(lines)
    swept = [line for line in lines if line.get("factor") == factor and _number(line.get("intensity")) is not None]
    if not swept:
        found = sorted({str(line["factor"]) for line in lines if _number(line.get("intensity")) is not None})
        raise ValueError(f"no line sweeps factor {factor!r}; the swept factors are {found or 'none'}. Evaluate "
                         f"levels=sweep({factor!r}, [...]) first, or pass factor= one of those.")
    missing = [line.get("level") for line in swept if statistic not in line]
    if missing:
        raise ValueError(f"lines of levels {missing} have no {statistic!r} column; pass summarize() lines or statistic=.")

    path = _new_file(path)
    curves: dict[str, list[Mapping[str, Any]]] = {}
    for line in swept:
        method, fixed = str(line.get("method", "agent")), str(line.get("fixed") or "")
        curves.setdefault(f"{method} ({fixed})" if fixed else method, []).append(line)
    with _figure(path, (5.0, 3.4)) as axes:
        for label, members in curves.items():
            members = sorted(members, key=lambda line: float(line["intensity"]))
            xs = [float(line["intensity"]) for line in members]
            (drawn,) = axes.plot(xs, [float(line[statistic]) for line in members], marker="o", label=label)
            bands = [_band(line, statistic) for line in members]
            if all(band is not None for band in bands):
                axes.fill_between(xs, [band[0] for band in bands], [band[1] for band in bands], color=drawn.get_color(),
                                  alpha=0.2, linewidth=0)
        axes.set_xlabel(f"{factor} intensity")
        axes.set_ylabel(ylabel)
        band = "± std over runs" if statistic == "rlvigen_mean" else "95 % CI"
        axes.set_title(title or f"robustness to {factor}: {statistic.replace('_', ' ')} ({band})", fontsize="medium")
        axes.legend(frameon=False, fontsize="small")
    return path


def comparison_table(lines: Sequence[Mapping[str, Any]]) -> str:
    """A markdown table of :func:`vigen.results.compare` lines: the vigen run beside each published number, with its notes.

    Examples:
        >>> from vigen.evaluation import comparison_table
        >>> line = {"method": "svea", "env": "dmc/walker-stand", "level": "video_hard", "runs": 2, "mean": 850.0, "std": 70.7,
        ...         "published_method": "svea", "source": "sgqn", "published": 747.0, "published_spread": 43.0,
        ...         "published_seeds": 5, "difference": 103.0, "unit": "return", "notes": ""}
        >>> print(comparison_table([line]).splitlines()[2])
        | dmc/walker-stand | video_hard | svea | return | 850.0 ± 70.7 (2 runs) | 747.0 ± 43.0 (5 seeds) | sgqn: svea | +103.0 |  |
    """
    table = ["| env | level | method | unit | vigen | published | source: method | vigen − published | notes |",
             "|---|---|---|---|---|---|---|---|---|"]
    for line in lines:
        std = "" if _number(line.get("std")) is None else f" ± {line['std']:.1f}"
        spread = "" if _number(line.get("published_spread")) is None else f" ± {line['published_spread']:.1f}"
        runs = f"{line['runs']} run{'s' * (line['runs'] != 1)}"
        if _number(line["published"]) is None:  # no published point at the run's budget (see notes)
            theirs, difference = "none at this budget", ""
        else:
            theirs = f"{line['published']:.1f}{spread} ({line['published_seeds']} seeds)"
            difference = f"{line['difference']:+.1f}"
        table.append(f"| {line['env']} | {line['level']} | {line['method']} | {line.get('unit', 'return')} | "
                     f"{line['mean']:.1f}{std} ({runs}) | {theirs} | "
                     f"{line['source']}: {line['published_method']} | {difference} | {line.get('notes', '')} |")
    seeded = sorted({line["source"] for line in lines if line.get("published_statistic") == "seed"})
    table += ["", "vigen: mean ± sample std over runs of each run's mean. Published: mean ± std over seeds"
              + (f" (for {', '.join(seeded)} computed here from its per-seed values)." if seeded else ", as the source prints it.")]
    return "\n".join(table)


def plot_comparison(lines: Sequence[Mapping[str, Any]], path: str | Path, *, title: str | None = None,
                    ylabel: str = "episode return") -> Path:
    """Bars of the vigen runs (mean ± std over runs) with the published ranges (value ± spread) of each source beside them.

    Examples:
        >>> import tempfile, pathlib
        >>> from vigen.evaluation import plot_comparison
        >>> line = {"method": "svea", "env": "dmc/walker-stand", "level": "video_hard", "mean": 850.0, "std": 70.7,
        ...         "published_method": "svea", "source": "sgqn", "published": 747.0, "published_spread": 43.0}
        >>> plot_comparison([line], pathlib.Path(tempfile.mkdtemp()) / "published.png").suffix
        '.png'
    """
    if not lines:
        raise ValueError("no comparison lines to plot; pass the lines of vigen.results.compare.")
    units = {line.get("unit", "return") for line in lines}
    if len(units) > 1:
        raise ValueError(f"lines of several units {sorted(units)} share no axis; plot each unit on its own.")
    path = _new_file(path)
    groups = list(dict.fromkeys((line["method"], line["env"], line["level"]) for line in lines))
    with _figure(path, (max(4.5, 1.6 * len(groups) + 1.5), 3.6)) as axes:
        sources = list(dict.fromkeys(f"{line['source']}: {line['published_method']}" for line in lines))
        markers = "osD^v<>p*h"
        for position, group in enumerate(groups):
            members = [line for line in lines if (line["method"], line["env"], line["level"]) == group]
            first = members[0]
            std = _number(first.get("std"))
            axes.bar(position, first["mean"], width=0.5, yerr=None if std is None else [[std], [std]], capsize=4,
                     color="tab:blue", alpha=0.8, label="vigen (mean ± std over runs)" if position == 0 else None)
            for offset, line in enumerate(members):
                label = f"{line['source']}: {line['published_method']}"
                index = sources.index(label)
                spread = _number(line.get("published_spread")) or 0.0
                shown = axes.get_legend_handles_labels()[1]
                axes.errorbar(position + 0.32 + 0.08 * offset, line["published"], yerr=spread, fmt=markers[index % len(markers)],
                              color=f"C{1 + index}", capsize=3, label=None if label in shown else label)
        axes.set_xticks(range(len(groups)), [f"{method}\n{env.split('/', 1)[-1]}\n{level}" for method, env, level in groups],
                        fontsize="small")
        axes.set_ylabel(ylabel)
        axes.set_title(title or "vigen beside the published numbers (published: mean ± std over seeds)", fontsize="medium")
        axes.legend(frameon=False, fontsize="x-small")
    return path


def plot_performance_profile(
    rows: Sequence[Mapping[str, Any]],
    path: str | Path,
    *,
    levels: Sequence[str] | None = None,
    value: str = "return",
    taus: Sequence[float] | None = None,
    reps: int = 2000,
    title: str | None = None,
) -> Path:
    """rliable's performance profile: the fraction of runs × (task, level) scores above τ, one line per method, 95 % band.

    ``levels`` picks the levels pooled (default: every level but ``train``); each (env, level)
    pair is one task of the score matrix. ``taus`` default to 101 points from 0 to the highest score.

    Examples:
        >>> import tempfile, pathlib
        >>> from vigen.evaluation import plot_performance_profile
        >>> rows = [{"method": m, "level": "color_hard", "env": "dmc/a", "run": run, "return": r + 50.0 * run}
        ...         for m, r in [("svea", 700.0), ("drqv2", 300.0)] for run in range(3)]
        >>> plot_performance_profile(rows, pathlib.Path(tempfile.mkdtemp()) / "profile.png", reps=100).suffix
        '.png'
    """
    chosen = [row for row in rows if (row["level"] in levels if levels is not None else row["level"] != "train")]
    if not chosen:
        raise ValueError(f"no rows at levels {levels or 'other than train'}; evaluate a test level or pass levels=.")
    run = "run" if "run" in chosen[0] else "seed"
    pooled = [dict(row, task=f"{row['env']}|{row['level']}") for row in chosen]
    methods = list(dict.fromkeys(str(row.get("method", "agent")) for row in pooled))
    scores = {method: score_matrix([row for row in pooled if str(row.get("method", "agent")) == method], run=run, task="task",
                                   value=value) for method in methods}
    top = max(float(matrix.max()) for matrix in scores.values())
    taus = np.linspace(0.0, top if top > 0 else 1.0, 101) if taus is None else np.asarray(taus, dtype=np.float64)

    path = _new_file(path)
    with _figure(path, (5.0, 3.4)) as axes:
        for method, matrix in scores.items():
            (drawn,) = axes.plot(taus, performance_profile(matrix, taus), label=method)
            low, high = performance_profile_ci(matrix, taus, reps=reps)
            axes.fill_between(taus, low, high, color=drawn.get_color(), alpha=0.2, linewidth=0)
        axes.set_xlabel(f"{value} threshold τ")
        axes.set_ylabel("fraction of runs with score > τ")
        pooled_levels = ", ".join(dict.fromkeys(row["level"] for row in chosen))
        axes.set_title(title or f"performance profile over {pooled_levels} (95 % CI)", fontsize="small")
        axes.legend(frameon=False, fontsize="small")
    return path


@dataclass
class Report:
    """A report folder as :func:`write_report` wrote it: ``report.md``'s text and the files beside it, in the order they are
    listed."""

    folder: Path
    rows: list[dict]
    """The episodes (episodes.csv)."""
    lines: list[dict]
    """The summary lines (summary.csv): per method and level."""
    text: str = ""
    tables: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    curves: list[Path] = field(default_factory=list)
    comparison: Comparison | None = None
    published_table: str = ""
    """With a comparison: the runs beside the published numbers, as printed."""

    def summary(self) -> str:
        """What ``examples/evaluate.py`` prints: the return table, the published numbers (with a comparison), the files."""
        text = markdown_table(label_stand_ins(self.lines, self.rows))
        if self.comparison is not None:
            text += (f"\n\nPublished numbers, protocol {self.comparison.protocol}:\n\n{self.published_table}\n\n"
                     f"{level_notes(self.rows)}")
        names = [path.name for path in [*self.tables, self.folder / "report.md", *self.figures, *self.curves]]
        return text + f"\n\nwrote {self.folder}/: {', '.join(names)}"


def write_report(rows: list[dict], folder: str | Path, *, swept: Sequence[str] = (), comparison: Comparison | None = None,
                 played: int | None = None) -> Report:
    """Write the report folder of an evaluation's rows: each section by its own step, then ``report.md``.

    The folder (new: an existing one raises ``FileExistsError``) gets ``episodes.csv`` (one row per episode),
    ``summary.csv`` and, in ``report.md``, the return per level and method (IQM with its 95 % stratified-bootstrap CI, and
    RL-ViGen's mean ± std over runs), what each level showed and the success rate where the task has one; ``gaps.csv``
    (test / train return of the same runs), ``improvements.csv`` (P(X > Y), with two methods or more); ``levels.png``,
    ``profile.png`` over the test levels and an ``intensity_FACTOR.png`` robustness curve per ``swept`` factor; with a
    ``comparison`` (:class:`vigen.evaluation.comparison.Comparison`), ``published.csv`` and ``published*.png``, the runs
    beside the published numbers (``played``: the episodes per level and run, said when fewer than the protocol's).

    Examples:
        >>> import tempfile, pathlib
        >>> rows = [{"env": "dmc/cartpole-balance", "method": "drqv2", "run": run, "level": level, "seed": 0, "return": r + run,
        ...          "stand_in": False} for level, r in [("train", 120.0), ("color_hard", 80.0)] for run in (0, 1)]
        >>> report = write_report(rows, pathlib.Path(tempfile.mkdtemp()) / "report")
        >>> report.summary().splitlines()[-1]
        'wrote .../report/: episodes.csv, summary.csv, gaps.csv, report.md, levels.png, profile.png'
    """
    folder = Path(folder)
    folder.mkdir(parents=True)
    report = Report(folder, rows, summarize(rows), comparison=comparison)
    _add_returns(report)
    _add_gaps(report)
    _add_improvements(report)
    _add_figures(report, swept)
    if comparison is not None:
        _add_published(report, comparison, played)
    atomic_write(folder / "report.md", report.text)
    return report


def _task_names(rows: list[dict]) -> str:
    """The envs of the rows, in order: the report's title."""
    return ", ".join(dict.fromkeys(row["env"] for row in rows))


def _add_returns(report: Report) -> None:
    """episodes.csv and summary.csv; the return per level and method, what each level showed, the success rate."""
    rows = report.rows
    report.tables += [write_csv(rows, report.folder / "episodes.csv"), write_csv(report.lines, report.folder / "summary.csv")]
    report.text += (f"# Zero-shot evaluation: {_task_names(rows)}\n\n## Episode return\n\n"
                    f"{markdown_table(label_stand_ins(report.lines, rows))}\n")
    if any(row["stand_in"] for row in rows):
        report.text += ("\nLevels marked (stand-in) showed vigen's stand-ins (procedural videos, statistics-matched colours), "
                        "not the benchmark's own data; `python -m vigen.datasets fetch ...` gets the data (docs/data.md).\n")
    if any(not_in_full(row.get("data")) for row in rows):
        report.text += ("\nLevels marked (partial data) showed less than their data set in full (fewer files than its part, "
                        "a user's folder, or files not verified against the pinned ids): their `data` column says what.\n")
    report.text += f"\n## What each level showed\n\n{level_notes(rows, heading=False)}"
    if all("success" in row for row in rows):  # tasks with a success check: the success rate in %
        success = summarize([dict(row, success=100.0 * row["success"]) for row in rows], value="success")
        report.tables.append(write_csv(success, report.folder / "summary_success.csv"))
        report.text += f"\n## Success rate (%)\n\n{markdown_table(success)}\n"


def _add_gaps(report: Report) -> None:
    """gaps.csv: each method's test / train return per level, with its 95 % CI (the random policy has no gap)."""
    gaps = generalization_gaps([row for row in report.rows if row["method"] != "random"])
    if gaps:
        report.tables.append(write_csv(gaps, report.folder / "gaps.csv"))
        report.text += "\n## Generalization gap (test / train return of the same runs, 95 % CI)\n\n" + markdown_table(
            gaps, cell=lambda line: interval_cell(line["gap"], line["gap_low"], line["gap_high"], line["runs"])) + "\n"


def _add_improvements(report: Report) -> None:
    """improvements.csv, with two methods or more: P(row beats column) per level, with its 95 % CI."""
    if len({row["method"] for row in report.rows}) <= 1:
        return
    better = improvements(report.rows)
    report.tables.append(write_csv(better, report.folder / "improvements.csv"))
    report.text += "\n## Probability of improvement P(row beats column), per level (95 % CI)\n\n" + "\n\n".join(
        f"{level}:\n\n" + markdown_table([line for line in better if line["level"] == level], rows="method", columns="over",
                                          cell=lambda line: interval_cell(line["probability"], line["low"], line["high"],
                                                                            max(line["runs"], line["over_runs"])))
        for level in dict.fromkeys(line["level"] for line in better)) + "\n"


def _add_figures(report: Report, swept: Sequence[str]) -> None:
    """levels.png; profile.png over the test levels; one intensity_FACTOR.png robustness curve per swept factor."""
    task, folder, lines = _task_names(report.rows), report.folder, report.lines
    report.figures.append(plot_levels(lines, folder / "levels.png", title=f"{task}: zero-shot IQM per level (95 % CI)"))
    if any(row["level"] != "train" for row in report.rows):
        report.figures.append(plot_performance_profile(report.rows, folder / "profile.png"))
        report.text += "\n## Performance profile over the test levels\n\n![profile.png](profile.png)\n"
    report.curves += [plot_intensity(lines, folder / f"intensity_{factor}.png", factor=factor,
                                     title=f"{task}: IQM against {factor} (95 % CI)") for factor in dict.fromkeys(swept)]
    if report.curves:
        report.text += "\n## Robustness curves\n\n" + "".join(f"![{curve.name}]({curve.name})\n" for curve in report.curves)


def _add_published(report: Report, comparison: Comparison, played: int | None) -> None:
    """published.csv and published*.png: the runs beside the published numbers, with what each level showed."""
    protocol = PROTOCOLS[comparison.protocol]
    compared = comparison.lines([row for row in report.rows if row["method"] != "random"])
    report.tables.append(write_csv(compared, report.folder / "published.csv"))
    for unit in dict.fromkeys(line["unit"] for line in compared):
        name = "published.png" if unit == "return" else f"published_{unit}.png"
        report.figures.append(plot_comparison([line for line in compared if line["unit"] == unit], report.folder / name,
                                              ylabel="episode return" if unit == "return" else "success rate (%)"))
    wanted = protocol.test.episodes
    report.published_table = comparison_table(compared) + ("" if played is None or played >= wanted else
        f"\nThis evaluation played {played} episodes per level and run; protocol {comparison.protocol} plays {wanted} "
        f"(--episodes {wanted}): fewer episodes, a noisier mean.")
    report.text += (f"\n## Published ({protocol.title}; sources: {', '.join(comparison.sources)})\n\n"
                    f"{report.published_table}\n\n{level_notes(report.rows)}\n"
                    + "".join(f"![{figure.name}]({figure.name})\n" for figure in report.figures
                              if figure.name.startswith("published")))


def level_notes(rows: Sequence[Mapping[str, Any]], heading: bool = True) -> str:
    """What vigen's levels are and the data each showed, so a reader sees where they approximate the source's.

    Examples:
        >>> print(level_notes([{"env": "dmc/walker-walk", "level": "color_hard", "data": "dmcgb-colors/color_hard: 100 of "
        ...                     "100, shipped", "stand_in": False}]).splitlines()[-1][:38])
        - color_hard: DMC-GB color_hard (its 1
    """
    notes = []
    for env, level in dict.fromkeys((row["env"], row["level"]) for row in rows):
        if level == "train":
            continue
        source = get_suite(env).levels[level].source if level in get_suite(env).levels else level
        mine = [row for row in rows if (row["env"], row["level"]) == (env, level)]
        shown = [data for data in dict.fromkeys(row.get("data", "") for row in mine) if data]
        stand_in = any(row.get("stand_in") is True for row in mine)
        notes.append(f"- {level}: {source}" + (f"; showed {', '.join(shown)}" if shown else "")
                     + (" (vigen's stand-ins, not the benchmark's data)" if stand_in else ""))
    if not notes:
        return ""
    return ("vigen's levels, for reading the comparison:\n\n" if heading else "") + "\n".join(dict.fromkeys(notes)) + "\n"

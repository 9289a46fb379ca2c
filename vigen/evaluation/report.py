"""Writers for an evaluation: raw rows as CSV, the summary as a markdown table, bar plots as PNG.

None of them overwrites a file: an existing path raises ``FileExistsError`` (pick a new folder,
e.g. with :func:`vigen.io.unused_path`).
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any


def _new_file(path: str | Path) -> Path:
    path = Path(path)
    if path.exists():
        raise FileExistsError(f"{path} exists and would be overwritten; choose another path or folder.")
    path.parent.mkdir(parents=True, exist_ok=True)
    return path


def write_csv(rows: Sequence[Mapping[str, Any]], path: str | Path) -> Path:
    """Write rows (dicts) as CSV with the union of their keys as columns, in first-seen order.

    Examples:
        >>> import tempfile, pathlib
        >>> from vigen.evaluation import write_csv
        >>> path = write_csv([{"level": "train", "return": 1.0}], pathlib.Path(tempfile.mkdtemp()) / "rows.csv")
        >>> path.read_text().splitlines()
        ['level,return', 'train,1.0']
    """
    path = _new_file(path)
    columns = list(dict.fromkeys(key for row in rows for key in row))
    with path.open("w", newline="") as file:
        writer = csv.DictWriter(file, fieldnames=columns)
        writer.writeheader()
        writer.writerows(rows)
    return path


def markdown_table(lines: Sequence[Mapping[str, Any]], *, rows: str = "level", columns: str = "method") -> str:
    """A levels × methods markdown table of ``IQM [95 % CI]`` and RL-ViGen's ``mean ± std`` per cell.

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
    """
    row_names = list(dict.fromkeys(str(line.get(rows, "")) for line in lines))
    column_names = list(dict.fromkeys(str(line.get(columns, "agent")) for line in lines))
    cells = {(str(line.get(rows, "")), str(line.get(columns, "agent"))): line for line in lines}

    def cell(line: Mapping[str, Any] | None) -> str:
        if line is None:
            return "—"
        std = "" if math.isnan(line["rlvigen_std"]) else f" ± {line['rlvigen_std']:.1f}"
        return f"{line['iqm']:.1f} [{line['iqm_low']:.1f}, {line['iqm_high']:.1f}] · {line['rlvigen_mean']:.1f}{std}"

    table = [f"| {rows} | " + " | ".join(column_names) + " |", "|" + "---|" * (len(column_names) + 1)]
    for name in row_names:
        table.append(f"| {name} | " + " | ".join(cell(cells.get((name, column))) for column in column_names) + " |")
    table += ["", "Cells: IQM [95 % stratified-bootstrap CI] · RL-ViGen mean ± std over runs."]
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
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = _new_file(path)
    levels = list(dict.fromkeys(str(line["level"]) for line in lines))
    methods = list(dict.fromkeys(str(line.get("method", "agent")) for line in lines))
    by_cell = {(str(line["level"]), str(line.get("method", "agent"))): line for line in lines}
    width = 0.8 / len(methods)
    figure, axes = plt.subplots(figsize=(max(4.0, 1.1 * len(levels) * max(1, len(methods)) ** 0.5 + 1.5), 3.2))
    for index, method in enumerate(methods):
        xs, heights, below, above = [], [], [], []
        for position, level in enumerate(levels):
            line = by_cell.get((level, method))
            if line is None:
                continue
            height = float(line[statistic])
            if statistic == "rlvigen_mean":
                spread = 0.0 if math.isnan(line["rlvigen_std"]) else float(line["rlvigen_std"])
                low, high = height - spread, height + spread
            else:
                low, high = float(line[f"{statistic}_low"]), float(line[f"{statistic}_high"])
            xs.append(position - 0.4 + width * (index + 0.5))
            heights.append(height)
            below.append(height - low)
            above.append(high - height)
        axes.bar(xs, heights, width=width * 0.92, yerr=[below, above], capsize=3, label=method)
    axes.set_xticks(range(len(levels)), levels, rotation=30 if len(levels) > 4 else 0, ha="right" if len(levels) > 4 else "center")
    axes.set_ylabel(ylabel)
    axes.set_title(title or f"zero-shot {statistic.replace('_', ' ')} per level (95 % CI)")
    axes.spines[["top", "right"]].set_visible(False)
    if len(methods) > 1:
        axes.legend(frameon=False, fontsize="small")
    figure.tight_layout()
    figure.savefig(path, dpi=120)
    plt.close(figure)
    return path

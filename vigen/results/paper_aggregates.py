"""The aggregates papers print, recomputed from their published rows.

* :func:`seed_aggregates`: RL-ViGen's convention, from per-seed rows: per seed, the mean over a
  category's tasks; then the mean ± sample standard deviation (``ddof=1``) over seeds.
* :func:`task_means`: the "average" row of DMC-GB-style tables (SGQN, MaDi, DMC-GB2): the mean over
  tasks (and, for DMC-GB2's geometric / photometric means, over levels) of each task's mean.
"""

from __future__ import annotations

from collections import defaultdict
from collections.abc import Iterable, Sequence
from typing import Any

import numpy as np

from vigen.evaluation.aggregate import rlvigen_mean_std
from vigen.results.published import PublishedScore


def seed_aggregates(rows: Iterable[PublishedScore], by: Sequence[str] = ("source", "method", "variant", "suite", "level")
                    ) -> list[dict[str, Any]]:
    """Mean ± sample std over seeds of each seed's mean over tasks, per group of ``by`` columns (``statistic="seed"`` rows).

    Every seed of a group must have a score on every task of the group (else the per-seed means
    would average different tasks).

    Examples:
        >>> from vigen.results import published, seed_aggregates
        >>> line = seed_aggregates(published(source="rlvigen", method="pieg", suite="robosuite", level="easy"))[0]
        >>> line["tasks"], line["seeds"], round(line["mean"])
        (3, 5, 305)
    """
    groups: dict[tuple, list[PublishedScore]] = defaultdict(list)
    for row in rows:
        if row.statistic != "seed":
            raise ValueError(f"seed_aggregates needs per-seed rows (statistic 'seed'), got {row.statistic!r} from {row.source}.")
        groups[tuple(getattr(row, key) for key in by)].append(row)
    lines = []
    for key, members in groups.items():
        tasks = sorted({row.task for row in members})
        seeds = sorted({row.seed for row in members})
        cells = {(row.seed, row.task): row.value for row in members}
        missing = [(seed, task) for seed in seeds for task in tasks if (seed, task) not in cells]
        if missing or len(cells) != len(members):
            raise ValueError(f"{dict(zip(by, key))}: seeds and tasks do not form a full grid (missing {missing[:4]}) "
                             "or a cell appears twice.")
        summary = rlvigen_mean_std(np.array([[cells[seed, task] for task in tasks] for seed in seeds]))
        lines.append({**dict(zip(by, key)), "tasks": len(tasks), "seeds": summary.seeds, "mean": summary.mean,
                      "std": summary.std, "mean_std": str(summary)})
    return lines


def task_means(rows: Iterable[PublishedScore], by: Sequence[str] = ("source", "method", "variant", "level")
               ) -> dict[tuple, float]:
    """The mean of the ``mean`` rows per group of ``by`` columns (e.g. a table's "average" row per method and level).

    Examples:
        >>> from vigen.results import published, task_means
        >>> task_means(published(source="madi", level="video_hard", method="madi"))
        {('madi', 'madi', '', 'video_hard'): 751.0}
    """
    groups: dict[tuple, list[float]] = defaultdict(list)
    for row in rows:
        if row.statistic != "mean":
            raise ValueError(f"task_means averages 'mean' rows, got {row.statistic!r} from {row.source}.")
        groups[tuple(getattr(row, key) for key in by)].append(row.value)
    return {key: float(np.mean(values)) for key, values in groups.items()}

"""Aggregate evaluation returns as the field reports them: rliable's IQM and bootstrap CIs, RL-ViGen's mean ± std.

Scores are arrays of shape ``[runs, tasks]``: one row per seed (run), one column per task, each
entry a run's mean return on that task (over its evaluation episodes). The conventions:

* **rliable** (Agarwal et al. 2021, https://arxiv.org/abs/2108.13264): the interquartile mean
  (IQM) is the mean of the middle 50 % of all ``runs × tasks`` scores; 95 % confidence intervals
  come from a *stratified* bootstrap, which resamples runs with replacement within each task, and
  take the 2.5 and 97.5 percentiles of the statistic over the resamples.
* **RL-ViGen** (https://arxiv.org/abs/2307.10224): average the tasks within each seed, then report
  the mean ± sample standard deviation (``ddof=1``) of those per-seed averages.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy import stats

Statistic = Callable[[np.ndarray], float]


def as_scores(scores: np.ndarray | list) -> np.ndarray:
    """``scores`` as a checked float64 ``[runs, tasks]`` array (one task's ``[runs]`` becomes a column); bad input raises.

    Examples:
        >>> from vigen.evaluation import as_scores
        >>> as_scores([1, 2, 3]).shape
        (3, 1)
    """
    array = np.asarray(scores, dtype=np.float64)
    if array.ndim == 1:
        array = array[:, None]
    if array.ndim != 2 or array.size == 0:
        raise ValueError(f"scores must be a non-empty [runs, tasks] array (or one task's [runs]), got shape {array.shape}.")
    if not np.isfinite(array).all():
        raise ValueError("scores contain NaN or infinite values; drop or fix the failed runs first.")
    return array


def mean(scores: np.ndarray | list) -> float:
    """The mean of all ``runs × tasks`` scores.

    Examples:
        >>> from vigen.evaluation import mean
        >>> mean([[1.0, 2.0], [3.0, 6.0]])
        3.0
    """
    return float(as_scores(scores).mean())


def iqm(scores: np.ndarray | list) -> float:
    """Interquartile mean: the mean of the middle 50 % of all scores (rliable's ``IQM``).

    The lowest and highest 25 % are cut as in ``scipy.stats.trim_mean(x, 0.25)``, which rliable
    uses.

    Examples:
        >>> from vigen.evaluation import iqm
        >>> iqm([1.0, 2.0, 3.0, 100.0])  # the middle half: 2 and 3
        2.5
    """
    return float(stats.trim_mean(as_scores(scores).reshape(-1), proportiontocut=0.25))


def stratified_bootstrap_ci(
    scores: np.ndarray | list,
    statistic: Statistic = iqm,
    *,
    confidence: float = 0.95,
    reps: int = 2000,
    seed: int = 0,
) -> tuple[float, float]:
    """Percentile confidence interval of ``statistic`` under rliable's stratified bootstrap.

    Each resample draws, for every task independently, ``runs`` runs with replacement; the
    interval is the ``(1 − confidence)/2`` and ``(1 + confidence)/2`` percentiles of the statistic
    over ``reps`` resamples (rliable uses 50 000; 2 000 keeps a report fast and the percentiles
    stable to about a percent of the spread). ``seed`` makes it reproducible.

    Examples:
        >>> from vigen.evaluation import stratified_bootstrap_ci
        >>> low, high = stratified_bootstrap_ci([[1.0], [2.0], [3.0], [4.0]], reps=500)
        >>> 1.0 <= low < 2.5 < high <= 4.0
        True
    """
    array = as_scores(scores)
    check_confidence(confidence)
    resamples = resample_runs(array, stratified_picks(np.random.default_rng(seed), reps, *array.shape))
    low, high = percentile_interval(statistic_of_each(statistic, resamples), confidence)
    return float(low), float(high)


def statistic_of_each(statistic: Statistic, resamples: np.ndarray) -> np.ndarray:
    """``statistic`` of each ``[runs, tasks]`` resample of ``resamples`` (``[reps, runs, tasks]``), as a ``[reps]`` array.

    The IQM and the mean are taken over all resamples in one numpy call, with the same values as
    one call per resample (the same sort and sum on each row); other statistics are called per resample.

    Examples:
        >>> import numpy as np
        >>> from vigen.evaluation.aggregate import iqm, statistic_of_each
        >>> resamples = np.random.default_rng(0).normal(size=(50, 5, 3))
        >>> bool((statistic_of_each(iqm, resamples) == [iqm(resample) for resample in resamples]).all())
        True
    """
    rows = resamples.reshape(len(resamples), -1)
    if statistic is iqm:
        return stats.trim_mean(rows, proportiontocut=0.25, axis=1)
    if statistic is mean or statistic is np.mean:
        return rows.mean(axis=1)
    return np.array([statistic(resample) for resample in resamples])


def check_confidence(confidence: float) -> None:
    """Raise naming the fix unless ``confidence`` lies in (0, 1)."""
    if not 0 < confidence < 1:
        raise ValueError(f"confidence must be in (0, 1), got {confidence}.")


def stratified_picks(rng: np.random.Generator, reps: int, runs: int, tasks: int) -> np.ndarray:
    """Run indices ``[reps, runs, tasks]`` of a stratified bootstrap: for every task, ``runs`` runs drawn with replacement.

    Examples:
        >>> import numpy as np
        >>> from vigen.evaluation.aggregate import stratified_picks
        >>> stratified_picks(np.random.default_rng(0), 100, 3, 2).shape
        (100, 3, 2)
    """
    return rng.integers(0, runs, size=(reps, runs, tasks))


def resample_runs(scores: np.ndarray, picks: np.ndarray) -> np.ndarray:
    """The ``[reps, runs, tasks]`` resamples of ``scores`` at :func:`stratified_picks` (the same picks pair two levels' runs).

    Examples:
        >>> import numpy as np
        >>> from vigen.evaluation.aggregate import resample_runs
        >>> resample_runs(np.array([[1.0, 10.0], [2.0, 20.0]]), np.array([[[1, 0], [1, 1]]])).tolist()
        [[[2.0, 10.0], [2.0, 20.0]]]
    """
    return np.take_along_axis(np.broadcast_to(scores, (picks.shape[0], *scores.shape)), picks, axis=1)


def percentile_interval(values: np.ndarray, confidence: float) -> tuple[np.ndarray, np.ndarray]:
    """The ``(1 − confidence)/2`` and ``(1 + confidence)/2`` percentiles of bootstrap ``values`` along their first axis.

    Examples:
        >>> import numpy as np
        >>> from vigen.evaluation.aggregate import percentile_interval
        >>> [round(float(bound), 6) for bound in percentile_interval(np.arange(101.0), 0.9)]
        [5.0, 95.0]
    """
    tail = 100 * (1 - confidence) / 2
    low, high = np.percentile(values, [tail, 100 - tail], axis=0)
    return low, high


@dataclass(frozen=True)
class MeanStd:
    """A mean ± sample standard deviation over seeds, as RL-ViGen's tables print it."""

    mean: float
    std: float
    seeds: int

    def __str__(self) -> str:
        return f"{self.mean:.1f} ± {self.std:.1f}"


def rlvigen_mean_std(scores: np.ndarray | list) -> MeanStd:
    """RL-ViGen's convention: average the tasks within each seed, then mean ± sample std over seeds.

    Examples:
        >>> from vigen.evaluation import rlvigen_mean_std
        >>> summary = rlvigen_mean_std([242.5, 228, 290.5, 141.5, 279])  # one task, five seeds
        >>> round(summary.mean, 1), round(summary.std, 2)
        (236.3, 58.85)
    """
    per_seed = as_scores(scores).mean(axis=1)
    std = float(per_seed.std(ddof=1)) if per_seed.size > 1 else float("nan")
    return MeanStd(float(per_seed.mean()), std, int(per_seed.size))

"""Statistics that compare methods and levels: generalization gap, probability of improvement, performance profiles.

Scores are ``[runs, tasks]`` arrays, as in :mod:`vigen.evaluation.aggregate`. The first two follow
rliable (Agarwal et al. 2021, "Deep RL at the Edge of the Statistical Precipice",
https://arxiv.org/abs/2108.13264; ``benchmarks/rliable_parity.py`` checks them against its code):

* **probability of improvement** P(X > Y): for each task, the probability that a run of X scores
  above a run of Y (the Mann–Whitney U statistic over ``n·m``, ties counting ½), averaged over tasks;
  its interval comes from a stratified bootstrap that resamples X's and Y's runs independently within
  each task;
* **performance profile**: the fraction of all ``runs × tasks`` scores above each threshold τ (rliable's
  run-score distribution), with a stratified-bootstrap band;
* **the one-sided Mann–Whitney U test** of "a run of X scores above a run of Y": the p-value
  beside P(X > Y), the test that says whether a level is resolved. Its smallest possible p-value is
  fixed by the number of runs: ``1 / C(n + m, n)``, which is 0.05 for 3 runs against 3, so 3 runs
  per method can never show more than p = 0.05, however far apart they score;
* **generalization gap** as a ratio: mean test score over mean training score of the same runs
  (1 = nothing lost; 1 − gap is the fraction lost), the form visual-RL papers quote ("test
  performance at 14 % of training", CNSN 2024); the difference train − test (Cobbe et al. 2019) is
  ``train.mean() * (1 − gap)``. Its interval resamples runs jointly for both levels (each run is paired with itself).
"""

from __future__ import annotations

from collections.abc import Sequence

import math

import numpy as np
from scipy import stats

from vigen.evaluation.aggregate import as_scores, check_confidence, percentile_interval, resample_runs, stratified_picks


def _resample(scores: np.ndarray, rng: np.random.Generator, reps: int) -> np.ndarray:
    """``reps`` stratified resamples ``[reps, runs, tasks]``: runs drawn with replacement within each task."""
    return resample_runs(scores, stratified_picks(rng, reps, *scores.shape))


def _same_tasks(x: np.ndarray | list, y: np.ndarray | list) -> tuple[np.ndarray, np.ndarray]:
    """Two methods' checked scores ``[runs_x, tasks]`` and ``[runs_y, tasks]``; a different number of tasks raises."""
    x, y = as_scores(x), as_scores(y)
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"x and y must cover the same tasks, got {x.shape[1]} and {y.shape[1]} task columns.")
    return x, y


def _improvement(x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """P(X > Y) per leading batch: x ``[..., n, tasks]``, y ``[..., m, tasks]`` -> ``[...]``."""
    above = (x[..., :, None, :] > y[..., None, :, :]).mean(axis=(-3, -2))
    ties = (x[..., :, None, :] == y[..., None, :, :]).mean(axis=(-3, -2))
    return (above + 0.5 * ties).mean(axis=-1)


def probability_of_improvement(x: np.ndarray | list, y: np.ndarray | list) -> float:
    """P(X > Y): the chance that a run of method X beats a run of Y on a task, averaged over tasks.

    ``x`` is ``[runs_x, tasks]`` and ``y`` is ``[runs_y, tasks]`` over the same tasks (runs may differ).

    Examples:
        >>> from vigen.evaluation import probability_of_improvement
        >>> probability_of_improvement([[3.0], [4.0]], [[1.0], [2.0]])  # every run of X beats every run of Y
        1.0
        >>> probability_of_improvement([[1.0], [3.0]], [[1.0], [2.0]])  # (tie ½ + 0 + 1 + 1) / 4
        0.625
    """
    x, y = _same_tasks(x, y)
    return float(_improvement(x, y))


def probability_of_improvement_ci(
    x: np.ndarray | list, y: np.ndarray | list, *, confidence: float = 0.95, reps: int = 2000, seed: int = 0,
) -> tuple[float, float]:
    """Percentile interval of P(X > Y) under rliable's stratified independent bootstrap (X's and Y's runs apart).

    Examples:
        >>> from vigen.evaluation import probability_of_improvement_ci
        >>> low, high = probability_of_improvement_ci([[3.0], [4.0], [0.0]], [[1.0], [2.0], [2.5]], reps=500)
        >>> 0.0 <= low < 2 / 3 < high <= 1.0
        True
    """
    x, y = _same_tasks(x, y)
    check_confidence(confidence)
    rng = np.random.default_rng(seed)
    values = np.concatenate([_improvement(_resample(x, rng, chunk), _resample(y, rng, chunk))
                             for chunk in _chunks(reps, x.shape[0] * y.shape[0] * x.shape[1])])
    low, high = percentile_interval(values, confidence)
    return float(low), float(high)


def improvement_p_value(x: np.ndarray | list, y: np.ndarray | list) -> float:
    """One-sided Mann–Whitney U test that runs of X score above runs of Y: its p-value.

    ``x`` is ``[runs_x, tasks]`` and ``y`` ``[runs_y, tasks]``; each run is scored by its mean over
    the tasks, and the test compares those run scores (scipy's ``mannwhitneyu``, ``alternative=
    "greater"``: exact when no scores tie, the normal approximation with tie correction otherwise).
    It answers the question P(X > Y) estimates: the p-value is small only when X's runs score above
    Y's more often than a random ordering would. The smallest p-value a design can give is
    :func:`smallest_p_value`; 0.05 for 3 runs against 3.

    Examples:
        >>> from vigen.evaluation.statistics import improvement_p_value
        >>> round(improvement_p_value([[3.0], [4.0], [5.0]], [[0.0], [1.0], [2.0]]), 4)  # every run of X above: 1 / C(6, 3)
        0.05
        >>> round(improvement_p_value([[0.0], [4.0], [5.0]], [[3.0], [1.0], [2.0]]), 4)  # 6 of 9 pairs: 7 of 20 orders do as well
        0.35
    """
    x, y = _same_tasks(x, y)
    x_runs, y_runs = x.mean(axis=1), y.mean(axis=1)
    method = "asymptotic" if len(np.intersect1d(x_runs, y_runs)) or len(set(x_runs)) < len(x_runs) \
        or len(set(y_runs)) < len(y_runs) else "exact"
    return float(stats.mannwhitneyu(x_runs, y_runs, alternative="greater", method=method).pvalue)


def smallest_p_value(runs_x: int, runs_y: int) -> float:
    """The smallest one-sided Mann–Whitney p-value ``runs_x`` runs against ``runs_y`` runs can give: ``1 / C(n + m, n)``.

    Examples:
        >>> from vigen.evaluation.statistics import smallest_p_value
        >>> smallest_p_value(3, 3), round(smallest_p_value(5, 5), 4)
        (0.05, 0.004)
    """
    if runs_x < 1 or runs_y < 1:
        raise ValueError(f"both methods need at least one run, got {runs_x} and {runs_y}.")
    return 1 / math.comb(runs_x + runs_y, runs_x)


def _chunks(reps: int, cost: int, budget: int = 4_000_000) -> list[int]:
    """Split ``reps`` so that one chunk's pairwise comparisons stay below ``budget`` elements."""
    size = max(1, budget // max(1, cost))
    return [min(size, reps - start) for start in range(0, reps, size)]


def performance_profile(scores: np.ndarray | list, taus: Sequence[float] | np.ndarray) -> np.ndarray:
    """The fraction of all ``runs × tasks`` scores strictly above each threshold in ``taus`` (rliable's run-score distribution).

    Examples:
        >>> from vigen.evaluation import performance_profile
        >>> performance_profile([[100.0, 900.0], [500.0, 700.0]], [0, 500, 1000]).tolist()
        [1.0, 0.5, 0.0]
    """
    scores = as_scores(scores)
    taus = np.asarray(taus, dtype=np.float64)
    return (scores.reshape(-1)[None, :] > taus[:, None]).mean(axis=1)


def performance_profile_ci(
    scores: np.ndarray | list, taus: Sequence[float] | np.ndarray, *, confidence: float = 0.95, reps: int = 2000, seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    """Pointwise percentile band of :func:`performance_profile` under the stratified bootstrap (rliable: 2 000 reps).

    Examples:
        >>> from vigen.evaluation import performance_profile_ci
        >>> low, high = performance_profile_ci([[100.0], [500.0], [900.0]], [400.0], reps=500)
        >>> bool(0.0 <= low[0] <= 2 / 3 <= high[0] <= 1.0)
        True
    """
    scores = as_scores(scores)
    check_confidence(confidence)
    taus = np.asarray(taus, dtype=np.float64)
    resamples = _resample(scores, np.random.default_rng(seed), reps).reshape(reps, -1)
    values = (resamples[:, None, :] > taus[None, :, None]).mean(axis=2)
    return percentile_interval(values, confidence)


def generalization_gap(test: np.ndarray | list, train: np.ndarray | list) -> float:
    """Mean test score over mean training score of the same ``[runs, tasks]`` (1: no loss, 0.4: 60 % lost).

    Examples:
        >>> from vigen.evaluation import generalization_gap
        >>> generalization_gap([[400.0], [200.0]], [[800.0], [400.0]])
        0.5
    """
    test, train = as_scores(test), as_scores(train)
    if test.shape != train.shape:
        raise ValueError(f"test and train must hold the same runs and tasks, got shapes {test.shape} and {train.shape}.")
    reference = train.mean()
    if reference <= 0:
        raise ValueError(f"the mean training score is {reference:g}; a test / train ratio needs a positive training score.")
    return float(test.mean() / reference)


def gap_resamples(test: np.ndarray, train: np.ndarray, picks: np.ndarray) -> np.ndarray:
    """The generalization gap of each bootstrap resample ``picks`` (:func:`~vigen.evaluation.aggregate.stratified_picks`).

    The same picks resample both levels, so each run stays paired with itself; a resample whose
    training mean is not positive gives NaN.

    Examples:
        >>> import numpy as np
        >>> from vigen.evaluation.statistics import gap_resamples
        >>> picks = np.array([[[0], [0]], [[1], [1]]])  # two resamples of 2 runs x 1 task: run 0 twice, run 1 twice
        >>> gap_resamples(np.array([[400.0], [300.0]]), np.array([[800.0], [600.0]]), picks).tolist()
        [0.5, 0.5]
    """
    train_means = resample_runs(train, picks).mean(axis=(1, 2))
    return resample_runs(test, picks).mean(axis=(1, 2)) / np.where(train_means > 0, train_means, np.nan)


def generalization_gap_ci(
    test: np.ndarray | list, train: np.ndarray | list, *, confidence: float = 0.95, reps: int = 2000, seed: int = 0,
) -> tuple[float, float]:
    """Percentile interval of :func:`generalization_gap`, resampling runs within each task, the same draw for both levels.

    Examples:
        >>> from vigen.evaluation import generalization_gap_ci
        >>> low, high = generalization_gap_ci([[400.0], [300.0], [500.0]], [[800.0], [800.0], [800.0]], reps=500)
        >>> 0.3 < low < 0.5 < high < 0.65
        True
    """
    test, train = as_scores(test), as_scores(train)
    generalization_gap(test, train)  # checks shapes and the training score
    check_confidence(confidence)
    ratios = gap_resamples(test, train, stratified_picks(np.random.default_rng(seed), reps, *test.shape))
    low, high = percentile_interval(ratios[np.isfinite(ratios)], confidence)
    return float(low), float(high)

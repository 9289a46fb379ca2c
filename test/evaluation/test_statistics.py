"""Generalization gap, probability of improvement and performance profiles against their definitions (rliable)."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from vigen.evaluation import (generalization_gap, generalization_gap_ci, generalization_gaps, improvements, performance_profile,
                              performance_profile_ci, probability_of_improvement, probability_of_improvement_ci)
from vigen.evaluation.statistics import improvement_p_value, smallest_p_value


def brute_force_improvement(x: np.ndarray, y: np.ndarray) -> float:
    """P(X > Y) by counting every pair of runs on every task, a tie counting one half."""
    per_task = []
    for task in range(x.shape[1]):
        pairs = list(itertools.product(x[:, task], y[:, task]))
        per_task.append(sum(1.0 if a > b else 0.5 if a == b else 0.0 for a, b in pairs) / len(pairs))
    return float(np.mean(per_task))


def test_probability_of_improvement_is_the_mann_whitney_average_over_tasks():
    rng = np.random.default_rng(0)
    x, y = rng.integers(0, 5, size=(4, 3)).astype(float), rng.integers(0, 5, size=(6, 3)).astype(float)  # ties included
    assert probability_of_improvement(x, y) == pytest.approx(brute_force_improvement(x, y))
    assert probability_of_improvement(x, y) + probability_of_improvement(y, x) == pytest.approx(1.0)
    low, high = probability_of_improvement_ci(x, y, reps=300)
    assert 0.0 <= low <= probability_of_improvement(x, y) <= high <= 1.0
    for statistic in (probability_of_improvement, probability_of_improvement_ci, improvement_p_value):
        with pytest.raises(ValueError, match="same tasks"):
            statistic(x, y[:, :2])


def test_performance_profile_is_the_fraction_of_scores_above_tau():
    scores = np.array([[100.0, 900.0], [500.0, 700.0], [300.0, 300.0]])
    taus = [0.0, 299.0, 300.0, 600.0, 900.0]
    expected = [np.mean(scores > tau) for tau in taus]
    assert performance_profile(scores, taus).tolist() == pytest.approx(expected)
    low, high = performance_profile_ci(scores, taus, reps=300)
    assert np.all(low <= np.asarray(expected) + 1e-12) and np.all(np.asarray(expected) <= high + 1e-12)
    assert np.all(np.diff(performance_profile(scores, np.linspace(0, 1000, 50))) <= 0), "a profile never rises"


def test_generalization_gap_is_test_over_train_of_the_same_runs():
    train = np.array([[800.0, 600.0], [900.0, 500.0]])
    test = np.array([[400.0, 300.0], [450.0, 250.0]])
    assert generalization_gap(test, train) == pytest.approx(0.5)
    assert generalization_gap_ci(test, train, reps=200) == pytest.approx((0.5, 0.5)), "each run keeps half: no spread"
    with pytest.raises(ValueError, match="same runs and tasks"):
        generalization_gap(test[:1], train)
    with pytest.raises(ValueError, match="positive training score"):
        generalization_gap(test, -train)


def test_rows_give_gaps_and_improvements_per_level():
    rows = [{"method": method, "level": level, "run": run, "env": "dmc/a", "return": base * factor + run}
            for method, base in [("svea", 800.0), ("drqv2", 600.0)] for level, factor in [("train", 1.0), ("video_hard", 0.5)]
            for run in range(3)]
    gaps = {(line["method"], line["level"]): line["gap"] for line in generalization_gaps(rows, reps=100)}
    assert gaps[("svea", "video_hard")] == pytest.approx(401.0 / 801.0)
    assert set(gaps) == {("svea", "video_hard"), ("drqv2", "video_hard")}
    better = {(line["level"], line["method"], line["over"]): line["probability"] for line in improvements(rows, reps=100)}
    assert better[("video_hard", "svea", "drqv2")] == 1.0 and better[("train", "drqv2", "svea")] == 0.0


def test_improvements_pair_methods_on_the_envs_both_ran():
    rows = [{"method": method, "level": "train", "run": run, "env": env, "return": value + run}
            for method, env, value in [("svea", "dmc/walker-walk", 900.0), ("svea", "dmc/cheetah-run", 100.0),
                                       ("drqv2", "dmc/cheetah-run", 500.0)] for run in range(3)]
    lines = improvements(rows, reps=50)
    assert [(line["method"], line["over"], line["tasks"], line["probability"]) for line in lines] == [
        ("svea", "drqv2", 1, 0.0), ("drqv2", "svea", 1, 1.0)], "svea's walker runs are not set against drqv2's cheetah runs"


def permutation_p_value(x: list[float], y: list[float]) -> float:
    """The exact one-sided p-value by its definition: the share of all splits of the pooled runs whose U is at least x's."""
    pooled = x + y

    def u(a, b):
        return sum(1.0 if i > j else 0.5 if i == j else 0.0 for i in a for j in b)

    observed = u(x, y)
    splits = list(itertools.combinations(range(len(pooled)), len(x)))
    at_least = sum(u([pooled[i] for i in chosen], [pooled[i] for i in range(len(pooled)) if i not in chosen]) >= observed
                   for chosen in splits)
    return at_least / len(splits)


@pytest.mark.parametrize("x, y", [([3.0, 4.0, 5.0], [0.0, 1.0, 2.0]), ([0.0, 4.0, 5.0], [3.0, 1.0, 2.0]),
                                  ([10.0, 20.0, 30.0, 40.0], [15.0, 5.0, 1.0]), ([1.0, 2.0, 3.0], [4.0, 5.0, 6.0])])
def test_improvement_p_value_is_the_exact_mann_whitney_test(x, y):
    p = improvement_p_value([[v] for v in x], [[v] for v in y])
    assert p == pytest.approx(permutation_p_value(x, y), abs=1e-12)


def test_three_runs_each_cannot_go_below_p_005():
    assert smallest_p_value(3, 3) == pytest.approx(0.05)
    far_apart = improvement_p_value([[1000.0], [1001.0], [1002.0]], [[0.0], [1.0], [2.0]])
    assert far_apart == pytest.approx(0.05)  # however far apart the runs score


def test_improvements_carry_the_p_value_of_each_pair():
    rows = [{"method": m, "level": "train", "run": run, "env": "dmc/a", "return": r + run}
            for m, r in [("svea", 900.0), ("drqv2", 100.0)] for run in range(3)]
    lines = {(line["method"], line["over"]): line["p_value"] for line in improvements(rows, reps=50)}
    assert lines[("svea", "drqv2")] == pytest.approx(0.05) and lines[("drqv2", "svea")] == pytest.approx(1.0)

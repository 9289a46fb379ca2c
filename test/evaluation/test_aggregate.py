"""The aggregation helpers against hand computations and the papers' definitions."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vigen.evaluation import (
    iqm,
    markdown_table,
    mean,
    plot_levels,
    rlvigen_mean_std,
    score_matrix,
    stratified_bootstrap_ci,
    summarize,
    write_csv,
)


def test_rlvigen_published_example():
    """RL-ViGen's convention on its own per-seed numbers: 236.3 ± 58.85."""
    summary = rlvigen_mean_std([242.5, 228, 290.5, 141.5, 279])
    assert summary.mean == pytest.approx(236.3)
    assert summary.std == pytest.approx(58.85, abs=0.005)
    assert str(summary) == "236.3 ± 58.9" and summary.seeds == 5


def test_rlvigen_averages_tasks_within_each_seed_first():
    scores = np.array([[100.0, 300.0], [200.0, 600.0]])  # seeds × tasks
    summary = rlvigen_mean_std(scores)
    assert summary.mean == pytest.approx(300.0)  # per-seed means 200 and 400
    assert summary.std == pytest.approx(math.sqrt(2) * 100)  # sample std of (200, 400)


def test_iqm_is_the_mean_of_the_middle_half():
    assert iqm(np.arange(1.0, 9.0)) == pytest.approx(4.5)  # 3, 4, 5, 6
    assert iqm([[1.0, 2.0], [3.0, 4.0], [5.0, 6.0], [7.0, 8.0]]) == pytest.approx(4.5)  # over runs × tasks
    assert iqm([1.0, 2.0, 3.0, 4.0, 1000.0]) == pytest.approx(3.0)  # cuts int(0.25·5) = 1 at each end
    assert mean([[1.0, 2.0], [3.0, 4.0]]) == 2.5


def test_bootstrap_is_stratified_by_task():
    """Resampling runs within each task keeps one score per task: the mean of a task-constant matrix never moves."""
    scores = np.array([[0.0, 100.0], [0.0, 100.0], [0.0, 100.0]])
    assert stratified_bootstrap_ci(scores, np.mean, reps=300) == (50.0, 50.0)


def test_bootstrap_percentiles_match_the_exact_distribution():
    """Two runs [0, 1]: resampled means are 0, .5, 1 with probabilities ¼, ½, ¼, so the 95 % interval is [0, 1]."""
    assert stratified_bootstrap_ci([0.0, 1.0], np.mean, reps=4000) == (0.0, 1.0)
    low, high = stratified_bootstrap_ci([0.0, 1.0], np.mean, confidence=0.4, reps=4000)
    assert low == high == 0.5  # the middle 40 % all land on 0.5


def test_bootstrap_is_reproducible_and_checks_input():
    scores = np.random.default_rng(0).normal(size=(5, 3))
    assert stratified_bootstrap_ci(scores, reps=200, seed=1) == stratified_bootstrap_ci(scores, reps=200, seed=1)
    with pytest.raises(ValueError, match="NaN"):
        iqm([1.0, float("nan")])
    with pytest.raises(ValueError, match="confidence"):
        stratified_bootstrap_ci(scores, confidence=95)


def test_score_matrix_averages_episodes_and_requires_a_full_grid():
    rows = [{"run": r, "env": t, "return": float(10 * r + "ab".index(t) + 1 + e)}
            for r in (0, 1) for t in ("a", "b") for e in (0, 2)]
    np.testing.assert_allclose(score_matrix(rows), [[2.0, 3.0], [12.0, 13.0]])  # episodes +0 and +2 average to +1
    with pytest.raises(ValueError, match="missing"):
        score_matrix(rows[:-2])
    with pytest.raises(KeyError, match="'return'"):
        score_matrix([{"run": 0, "env": "a"}])


def _rows():
    rows = []
    for method, base in (("drqv2", 800.0), ("svea", 700.0)):
        for level, drop in (("train", 0.0), ("color_hard", 300.0)):
            for run in range(3):
                rows += [{"method": method, "level": level, "run": run, "env": "dmc/a", "episode": e,
                          "return": base - drop + 10 * run + e} for e in range(2)]
    return rows


def test_summarize_one_line_per_method_and_level():
    lines = summarize(_rows(), reps=300)
    assert [(line["method"], line["level"]) for line in lines] == [
        ("drqv2", "train"), ("drqv2", "color_hard"), ("svea", "train"), ("svea", "color_hard")]
    first = lines[0]
    assert (first["runs"], first["tasks"], first["episodes"]) == (3, 1, 6)
    assert first["mean"] == pytest.approx(810.5)  # runs 800.5, 810.5, 820.5
    assert first["rlvigen_mean"] == pytest.approx(810.5) and first["rlvigen_std"] == pytest.approx(10.0)
    assert first["iqm_low"] <= first["iqm"] <= first["iqm_high"]
    assert 800.5 <= first["mean_low"] <= first["mean_high"] <= 820.5


def test_markdown_table_and_csv(tmp_path):
    lines = summarize(_rows(), reps=100)
    table = markdown_table(lines)
    assert table.splitlines()[0] == "| level | drqv2 | svea |"
    assert "| color_hard | 510.5 [" in table
    path = write_csv(_rows(), tmp_path / "episodes.csv")
    assert path.read_text().splitlines()[0] == "method,level,run,env,episode,return"
    with pytest.raises(FileExistsError, match="overwritten"):
        write_csv(_rows(), path)


def test_write_csv_leaves_no_partial_file(tmp_path):
    class Unprintable:
        def __str__(self) -> str:
            raise RuntimeError("cannot be written")

    path = tmp_path / "episodes.csv"
    with pytest.raises(RuntimeError, match="cannot be written"):
        write_csv([{"level": "train", "return": 1.0}, {"level": "easy", "return": Unprintable()}], path)
    assert list(tmp_path.iterdir()) == []  # neither the first row nor a temporary file


def test_plot_levels_writes_a_png(tmp_path):
    pytest.importorskip("matplotlib")
    path = plot_levels(summarize(_rows(), reps=100), tmp_path / "levels.png")
    assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    with pytest.raises(FileExistsError):
        plot_levels(summarize(_rows(), reps=100), path)


def test_a_plot_that_fails_while_drawing_leaves_no_file(tmp_path):
    pytest.importorskip("matplotlib")
    import matplotlib.pyplot as plt

    lines = [{key: value for key, value in line.items() if key != "iqm_high"} for line in summarize(_rows(), reps=100)]
    with pytest.raises(KeyError, match="iqm_high"):
        plot_levels(lines, tmp_path / "levels.png")
    assert list(tmp_path.iterdir()) == [] and plt.get_fignums() == [], "nothing half-written, the figure closed"


def test_plot_levels_draws_no_interval_for_a_method_of_one_run(tmp_path, monkeypatch):
    from matplotlib.axes import Axes

    drawn, titles = [], []
    errorbar, set_title = Axes.errorbar, Axes.set_title
    monkeypatch.setattr(Axes, "errorbar", lambda self, x, y, **kw: (drawn.append((list(x), kw["yerr"])), errorbar(self, x, y, **kw))[1])
    monkeypatch.setattr(Axes, "set_title", lambda self, text, **kw: (titles.append(text), set_title(self, text, **kw))[1])
    lines = [{"method": "svea", "level": "train", "runs": 3, "iqm": 900.0, "iqm_low": 880.0, "iqm_high": 950.0},
             {"method": "random", "level": "train", "runs": 1, "iqm": 300.0, "iqm_low": 300.0, "iqm_high": 300.0}]
    plot_levels(lines, tmp_path / "levels.png")
    assert len(drawn) == 1 and len(drawn[0][0]) == 1, "one error bar: the 3-run method's"
    assert drawn[0][1] == [[20.0], [50.0]]
    assert "one run, no interval" in titles[0]
    drawn.clear(), titles.clear()
    plot_levels(lines[:1], tmp_path / "three.png")
    assert len(drawn) == 1 and "one run" not in titles[0]

"""Zero-shot generalization evaluation: run policies on unseen levels, aggregate, report.

* :func:`evaluate`: one row per episode for each level and seed (:class:`EvaluationError` keeps them if a level fails);
* :func:`sweep`: one factor at several intensities, as levels for :func:`evaluate`;
* :func:`summarize`, :func:`score_matrix` and the statistics :func:`mean`, :func:`iqm`,
  :func:`stratified_bootstrap_ci` (rliable's conventions) and :func:`rlvigen_mean_std`;
* :func:`generalization_gaps`, :func:`improvements` (rows -> lines) and the statistics behind them,
  :func:`generalization_gap`, :func:`probability_of_improvement`, :func:`performance_profile` (rliable's definitions);
* :func:`write_csv`, :func:`markdown_table`, :func:`plot_levels`, :func:`plot_intensity`,
  :func:`plot_performance_profile`, :func:`plot_comparison`: the report files.

Examples:
    >>> from vigen.evaluation import evaluate, summarize, markdown_table
    >>> rows = evaluate(None, "dmc/cartpole-balance", ["train", "color_hard"], episodes=1, seeds=[0, 1], max_steps=5,
    ...                 tags={"method": "random"})
    >>> print(markdown_table(summarize(rows, reps=100)).splitlines()[0])
    | level | random |
"""

from vigen.evaluation.aggregate import MeanStd, as_scores, iqm, mean, rlvigen_mean_std, stratified_bootstrap_ci
from vigen.evaluation.report import (comparison_table, markdown_table, plot_comparison, plot_intensity, plot_levels,
                                     plot_performance_profile, write_csv)
from vigen.evaluation.jobs import EvaluationError
from vigen.evaluation.rollout import evaluate
from vigen.evaluation.statistics import (generalization_gap, generalization_gap_ci, performance_profile,
                                         performance_profile_ci, probability_of_improvement, probability_of_improvement_ci)
from vigen.evaluation.summary import generalization_gaps, improvements, score_matrix, summarize
from vigen.evaluation.sweep import DCS_INTENSITIES, SweepPoint, sweep

__all__ = [
    "DCS_INTENSITIES",
    "EvaluationError",
    "MeanStd",
    "SweepPoint",
    "as_scores",
    "comparison_table",
    "evaluate",
    "generalization_gap",
    "generalization_gap_ci",
    "generalization_gaps",
    "improvements",
    "iqm",
    "markdown_table",
    "mean",
    "performance_profile",
    "performance_profile_ci",
    "plot_comparison",
    "plot_intensity",
    "plot_levels",
    "plot_performance_profile",
    "probability_of_improvement",
    "probability_of_improvement_ci",
    "rlvigen_mean_std",
    "score_matrix",
    "stratified_bootstrap_ci",
    "summarize",
    "sweep",
    "write_csv",
]

"""Published results, with provenance, and a vigen evaluation beside them under the same protocol.

* :func:`published` / :func:`load`: the numbers papers and their repositories published, one CSV per
  source in ``vigen/results/data/`` (:data:`SOURCES` says where each was read), each row keyed by
  method, source, protocol, suite, task, level, statistic, unit, budget and seeds;
* :func:`compare`: a vigen evaluation next to the published numbers of the same method, task and
  level; it raises :class:`ProtocolMismatch` when the protocol, a setting, the budget or the unit differ, and
  :class:`RecipeMismatch` when the run was not trained by the recipe behind the published row (:data:`vigen.run.RECIPES`);
* :func:`seed_aggregates` and :func:`task_means`: the aggregates the papers print, recomputed from the rows.

Examples:
    >>> from vigen.results import published, seed_aggregates
    >>> [(row.source, row.value) for row in published(method="sgqn", task="walker-walk", level="video_hard")]
    [('sgqn', 739.0), ('madi', 718.0), ('simgrl', 739.0)]
    >>> easy = seed_aggregates(published(source="rlvigen", method="drqv2", suite="loco", level="easy"))
    >>> print(easy[0]["mean_std"])
    236.3 ± 58.9
"""

from vigen.results.paper_aggregates import seed_aggregates, task_means
from vigen.results.compare import PartialData, ProtocolMismatch, RecipeMismatch, StandInRows, check_protocol, compare
from vigen.results.published import COLUMNS, PublishedScore, as_dicts, load, published
from vigen.results.sources import SOURCES, Source

__all__ = [
    "COLUMNS",
    "PartialData",
    "ProtocolMismatch",
    "PublishedScore",
    "RecipeMismatch",
    "SOURCES",
    "Source",
    "StandInRows",
    "as_dicts",
    "check_protocol",
    "compare",
    "load",
    "published",
    "seed_aggregates",
    "task_means",
]

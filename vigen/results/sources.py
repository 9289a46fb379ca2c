"""Where each file of published numbers comes from: the paper, the repository and commit, the license."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from types import MappingProxyType


@dataclass(frozen=True)
class Source:
    """One source of published numbers, stored as ``vigen/results/data/<name>.csv``.

    Args:
        name: the file's name and the ``source`` column of its rows.
        title: the paper.
        url: the paper.
        repository: the repository the numbers were read in, with the commit.
        license: the repository's license.
        read_from: the file(s) in that repository (or the paper's table) the numbers were read from, and how.
        reproduced_by: published method -> the vigen algorithm (``vigen.losses.ALGOS``) that runs the same update as
            the code behind these numbers (checked by ``python -m benchmarks.parity``); a method not listed was published
            from another implementation than vigen's algorithm of that name (e.g. DMC-GB's SAC-based SVEA, where
            vigen's ``svea`` is RL-ViGen's DrQ-v2-based one).
        unverified: empty when every row was checked against the original table or file; otherwise why the rows
            could not be traced to one. Such rows stay in the data, and :func:`vigen.results.compare` says so on
            every line that uses them.

    Examples:
        >>> from vigen.results import SOURCES
        >>> SOURCES["rlvigen"].reproduced_by["svea"], "svea" in SOURCES["sgqn"].reproduced_by
        ('svea', False)
        >>> SOURCES["sgqn"].verified, SOURCES["simgrl"].verified
        (True, False)
    """

    name: str
    title: str
    url: str
    repository: str
    license: str
    read_from: str
    reproduced_by: Mapping[str, str] = field(default_factory=dict)
    unverified: str = ""

    @property
    def verified(self) -> bool:
        """Whether every row was checked against the original table or file."""
        return not self.unverified

    def __post_init__(self) -> None:
        object.__setattr__(self, "reproduced_by", MappingProxyType(dict(self.reproduced_by)))


SOURCES: Mapping[str, Source] = MappingProxyType({source.name: source for source in (
    Source("dmcgb", "Hansen & Wang 2021, Generalization in RL by Soft Data Augmentation (SODA), ICRA: the DMControl "
           "Generalization Benchmark's results table (its SVEA rows: Hansen et al. 2021, https://arxiv.org/abs/2107.00644)",
           "https://arxiv.org/abs/2011.13389",
           "nicklashansen/dmcontrol-generalization-benchmark@ff9c0aa (the table last changed at 6861d3e; also in bofusun/SCPL@e77b623)",
           "MIT", "figures/results_table.png, transcribed by hand: random colors = color_hard, natural videos = video_easy"),
    Source("sgqn", "Bertoin et al. 2022, Look where you look! Saliency-guided Q-networks (SGQN), NeurIPS",
           "https://arxiv.org/abs/2209.09203", "SuReLI/SGQN@f383fc0", "MIT (DMC/LICENSE)",
           "Table 2 as DMC/figures/sgqn_perf.png, transcribed by hand"),
    Source("madi", "Grooten et al. 2024, MaDi: Learning to Mask Distractions for Generalization in Visual Deep RL, AAMAS",
           "https://arxiv.org/abs/2312.15339", "bramgrooten/mask-distractions@70982ce", "MIT",
           "figures/results_video_hard.png, transcribed by hand (MaDi's own re-runs of every method)", {"madi": "madi"}),
    Source("simgrl", "Song et al. 2024, A Simple Framework for Generalization in Visual RL under Dynamic Scene Perturbations, NeurIPS",
           "https://w-song11.github.io/SimGRL", "W-Song11/SimGRL-Code@08722a8", "MIT",
           "the paper's DMC-GB video_hard table as first transcribed (SimGRL with std; the baselines' means as SimGRL "
           "prints them)", {"simgrl": "simgrl"},
           unverified="no table could be found to check these rows against: the cited repository holds no numbers and "
                      "the paper's table was not at hand when they were checked; the baselines' rows are not SGQN's "
                      "Table 2 either (SVEA finger-spin 335 here, 174 there), so they are not a copy of it"),
    Source("dmcgb2", "Almuzairee et al. 2024, A Recipe for Unbounded Data Augmentation in Visual RL (SADA, DMC-GB2), RLC",
           "https://arxiv.org/abs/2405.17416", "aalmuzairee/SADA@bee2fba (linked from aalmuzairee/dmcgb2's README)", "MIT",
           "Fig. 6, static/images/repo/overall_results.png, transcribed by hand; checked against the paper's 6-task means",
           {"sada": "sada"}),
    Source("rlvigen", "Yuan et al. 2023, RL-ViGen: A Reinforcement Learning Benchmark for Visual Generalization, NeurIPS D&B",
           "https://arxiv.org/abs/2307.10224", "gemcollector/RL-ViGen@90d8b8c", "MIT",
           "results/evaluation_score.xlsx, every literal per-seed cell, by scripts/extract_published.py",
           {name: name for name in ("drqv2", "drq", "curl", "svea", "srm", "sgqn", "pieg", "vrl3")}),
    Source("drqv2", "Yarats et al. 2021, Mastering Visual Continuous Control: Improved Data-Augmented RL (DrQ-v2)",
           "https://arxiv.org/abs/2107.09645", "facebookresearch/drqv2@c0c650b (archived; curves/ last changed at 061a0e5)", "MIT",
           "curves/dmc_<task>.csv: mean, sample std and median over seeds at each evaluated frame count, by scripts/extract_published.py",
           {"drqv2": "drqv2"}),
    Source("curl", "Srinivas et al. 2020, CURL: Contrastive Unsupervised Representations for RL, ICML",
           "https://arxiv.org/abs/2004.04136", "MishaLaskin/curl@8416d6e (its code; the numbers are the paper's)", "MIT",
           "Table 1 of the paper, transcribed by hand"),
)})
"""Source name -> :class:`Source`; each has ``vigen/results/data/<name>.csv``."""

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
        recipes: a published method (or ``"method (variant)"``) → the vigen recipe (:data:`vigen.run.RECIPES`) that
            trains it as the code behind these numbers did; a row's recipe is :attr:`PublishedScore.recipe`.
        no_recipe: why the rows of the other methods name no recipe (the implementations vigen has no recipe for).

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
    recipes: Mapping[str, str] = field(default_factory=dict)
    no_recipe: str = ""

    @property
    def verified(self) -> bool:
        """Whether every row was checked against the original table or file."""
        return not self.unverified

    def __post_init__(self) -> None:
        object.__setattr__(self, "reproduced_by", MappingProxyType(dict(self.reproduced_by)))
        object.__setattr__(self, "recipes", MappingProxyType(dict(self.recipes)))

    def recipe_of(self, method: str, variant: str = "", suite: str | None = None) -> str | None:
        """The recipe behind a row of ``method`` (and ``variant``) on ``suite``; ``None`` where vigen has none (:attr:`no_recipe`).

        A recipe that does not cover the row's suite (RL-ViGen's Adroit rows of methods other than VRL3 come from
        another branch's configs) is none for that row.

        Examples:
            >>> from vigen.results import SOURCES
            >>> SOURCES["dmcgb"].recipe_of("svea", "conv"), SOURCES["dmcgb"].recipe_of("svea", "overlay")
            ('svea-dmcgb', None)
            >>> SOURCES["rlvigen"].recipe_of("svea", suite="dmc"), SOURCES["rlvigen"].recipe_of("svea", suite="adroit")
            ('svea-rlvigen', None)
        """
        name = self.recipes.get(f"{method} ({variant})" if variant else method, self.recipes.get(method))
        if name is None or suite is None:
            return name
        from vigen.run.recipes import RECIPES  # torch-free: the recipes are data

        return name if suite in RECIPES[name].suites else None

    def why_no_recipe(self, method: str, variant: str = "", suite: str | None = None) -> str:
        """Why a row names no recipe, for notes."""
        name = self.recipes.get(f"{method} ({variant})" if variant else method, self.recipes.get(method))
        if name is not None and suite is not None:
            return f"{name} does not cover the {suite} suite (its code's configs for it are not read)"
        return self.no_recipe or "vigen has no recipe for the code behind this row"


SOURCES: Mapping[str, Source] = MappingProxyType({source.name: source for source in (
    Source("dmcgb", "Hansen & Wang 2021, Generalization in RL by Soft Data Augmentation (SODA), ICRA: the DMControl "
           "Generalization Benchmark's results table (its SVEA rows: Hansen et al. 2021, https://arxiv.org/abs/2107.00644)",
           "https://arxiv.org/abs/2011.13389",
           "nicklashansen/dmcontrol-generalization-benchmark@ff9c0aa (the table last changed at 6861d3e; also in bofusun/SCPL@e77b623)",
           "MIT", "figures/results_table.png, transcribed by hand: random colors = color_hard, natural videos = video_easy",
           recipes={"svea (conv)": "svea-dmcgb"},
           no_recipe="vigen has no recipe for DMC-GB's CURL, RAD, PAD, SODA and DrQ (vigen's curl and drq are RL-ViGen's), "
                     "nor for SVEA with the overlay (DMC-GB's svea.py at ff9c0aa draws random convolutions only)"),
    Source("sgqn", "Bertoin et al. 2022, Look where you look! Saliency-guided Q-networks (SGQN), NeurIPS",
           "https://arxiv.org/abs/2209.09203", "SuReLI/SGQN@f383fc0", "MIT (DMC/LICENSE)",
           "Table 2 as DMC/figures/sgqn_perf.png, transcribed by hand",
           no_recipe="SGQN's table comes from its own fork of DMC-GB, whose settings vigen has not read (vigen's sgqn is "
                     "RL-ViGen's)"),
    Source("madi", "Grooten et al. 2024, MaDi: Learning to Mask Distractions for Generalization in Visual Deep RL, AAMAS",
           "https://arxiv.org/abs/2312.15339", "bramgrooten/mask-distractions@70982ce", "MIT",
           "figures/results_video_hard.png, transcribed by hand (MaDi's own re-runs of every method)", {"madi": "madi"},
           recipes={"madi": "madi-dmcgb"},
           no_recipe="MaDi re-ran the other methods in its own code with their settings, which vigen has no recipe for"),
    Source("simgrl", "Song et al. 2024, A Simple Framework for Generalization in Visual RL under Dynamic Scene Perturbations, NeurIPS",
           "https://w-song11.github.io/SimGRL", "W-Song11/SimGRL-Code@08722a8", "MIT",
           "the paper's DMC-GB video_hard table as first transcribed (SimGRL with std; the baselines' means as SimGRL "
           "prints them)", {"simgrl": "simgrl"},
           unverified="no table could be found to check these rows against: the cited repository holds no numbers and "
                      "the paper's table was not at hand when they were checked; the baselines' rows are not SGQN's "
                      "Table 2 either (SVEA finger-spin 335 here, 174 there), so they are not a copy of it",
           recipes={"simgrl": "simgrl-dmcgb"},
           no_recipe="SimGRL's table re-ran the other methods in its own code, which vigen has no recipe for"),
    Source("dmcgb2", "Almuzairee et al. 2024, A Recipe for Unbounded Data Augmentation in Visual RL (SADA, DMC-GB2), RLC",
           "https://arxiv.org/abs/2405.17416", "aalmuzairee/SADA@bee2fba (linked from aalmuzairee/dmcgb2's README)", "MIT",
           "Fig. 6, static/images/repo/overall_results.png, transcribed by hand; checked against the paper's 6-task means",
           {"sada": "sada"}, recipes={"sada": "sada-dmcgb2"},
           no_recipe="DMC-GB2's SVEA and DrQ rows come from its algos/svea.py and drq.py, which vigen has no recipe for"),
    Source("rlvigen", "Yuan et al. 2023, RL-ViGen: A Reinforcement Learning Benchmark for Visual Generalization, NeurIPS D&B",
           "https://arxiv.org/abs/2307.10224", "gemcollector/RL-ViGen@90d8b8c", "MIT",
           "results/evaluation_score.xlsx, every literal per-seed cell, by scripts/extract_published.py",
           {name: name for name in ("drqv2", "drq", "curl", "svea", "srm", "sgqn", "pieg", "vrl3")},
           recipes={name: f"{name}-rlvigen" for name in ("drqv2", "drq", "curl", "svea", "srm", "sgqn", "pieg", "vrl3")}),
    Source("drqv2", "Yarats et al. 2021, Mastering Visual Continuous Control: Improved Data-Augmented RL (DrQ-v2)",
           "https://arxiv.org/abs/2107.09645", "facebookresearch/drqv2@c0c650b (archived; curves/ last changed at 061a0e5)", "MIT",
           "curves/dmc_<task>.csv: mean, sample std and median over seeds at each evaluated frame count, by scripts/extract_published.py",
           {"drqv2": "drqv2"}, recipes={"drqv2": "drqv2"}),
    Source("curl", "Srinivas et al. 2020, CURL: Contrastive Unsupervised Representations for RL, ICML",
           "https://arxiv.org/abs/2004.04136", "MishaLaskin/curl@8416d6e (its code; the numbers are the paper's)", "MIT",
           "Table 1 of the paper, transcribed by hand",
           no_recipe="vigen has no recipe for CURL's own SAC code (vigen's curl is RL-ViGen's DDPG variant)"),
)})
"""Source name -> :class:`Source`; each has ``vigen/results/data/<name>.csv``."""

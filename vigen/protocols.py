"""The training and evaluation protocols of the papers vigen's users compare against, as data.

A protocol is what a paper fixes and a reader cannot see in its tables: how long agents train
and in which unit (DMC-GB counts *agent steps*, DrQ-v2 and RL-ViGen count *frames*, i.e.
control steps: agent steps × action repeat), the action repeat per task, the frame stack and image
size, how the agent is evaluated while it trains and at the end (episodes and levels), how many
seeds, and which statistic the tables print. Two published numbers, or a run and a published
number, are only comparable under the same protocol (``vigen.results.compare`` checks it).

``examples/train.py --protocol dmcgb`` and the same from Python:

Examples:
    >>> from vigen.protocols import get_protocol
    >>> dmcgb = get_protocol("dmcgb")
    >>> dmcgb.env_options("dmc/cartpole-swingup")
    {'action_repeat': 8, 'frame_stack': 3, 'image_size': 84}
    >>> dmcgb.frames("dmc/cartpole-swingup"), dmcgb.budget_text("dmc/cartpole-swingup")
    (4000000, '500,000 agent steps (4,000,000 frames at action repeat 8)')
    >>> get_protocol("drqv2").frames("dmc/cheetah-run")
    3000000

Sources: DMC-GB (Hansen & Wang 2021, https://arxiv.org/abs/2011.13389, and SVEA,
https://arxiv.org/abs/2107.00644); DMC-GB2 (Almuzairee et al. 2024, https://arxiv.org/abs/2405.17416);
RL-ViGen (Yuan et al. 2023, https://arxiv.org/abs/2307.10224); DrQ-v2 (Yarats et al. 2021,
https://arxiv.org/abs/2107.09645); the PlaNet benchmark as CURL reports it (Srinivas et al. 2020,
https://arxiv.org/abs/2004.04136).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from types import MappingProxyType
from typing import Any, Literal

BudgetUnit = Literal["agent_steps", "frames"]
BUDGET_UNITS: tuple[str, ...] = ("agent_steps", "frames")


def _frozen(mapping: Mapping[str, Any]) -> Mapping[str, Any]:
    return MappingProxyType(dict(mapping))


@dataclass(frozen=True)
class Evaluation:
    """How a protocol evaluates: ``episodes`` per level (and seed), on ``levels``, while training every ``every`` (the budget's unit).

    Examples:
        >>> from vigen.protocols import Evaluation
        >>> Evaluation(episodes=10, levels=("train",), every=20_000).levels
        ('train',)
    """

    episodes: int
    levels: tuple[str, ...]
    every: int | None = None


@dataclass(frozen=True)
class Protocol:
    """What one paper fixes for training and evaluation; per-task values are looked up by env name.

    Args:
        name: the preset's name (``--protocol NAME``).
        title: the paper or benchmark, for reports.
        url: where the protocol is defined.
        suites: the env suites it covers (``"dmc"``, ...).
        budget: training length in ``budget_unit``; ``budget_by_task`` overrides it per task
            (``"cheetah-run"``) or per domain (``"cheetah"``).
        budget_unit: ``"agent_steps"`` (DMC-GB's ``train_steps``) or ``"frames"`` (agent steps × action repeat).
        action_repeat: control steps per agent step; ``action_repeat_by_task`` overrides it per task, domain or
            suite (``None``: the suite has no action repeat, its control rate is fixed, e.g. robosuite's 20 Hz).
        frame_stack: frames stacked in an observation.
        image_size: pixels per side.
        train_eval: the evaluation while training (``every`` in ``budget_unit``).
        test: the final zero-shot evaluation the tables report; ``test_levels_by_suite`` replaces its
            levels on other suites than the first.
        episode_length: control steps per episode, per suite (the returns' scale depends on it).
        level_differences: levels whose vigen version is not the paper's, and how it differs.
        seeds: seeds per method in the papers' tables.
        statistic: what the tables print, in words.
        notes: what else a reader must know (caveats, known deviations between the papers that use it).
        batch_size: the training batch of the source's code (its default config), so that a run trained with
            another one is marked beside the published numbers; ``None`` where the source does not fix one.
        train_env_options: env options of the training envs beyond :meth:`env_options` (e.g. RL-ViGen's loco
            training path: ``action_mapping="rlvigen_train"``, ``time_limit_as="terminated"``).
        test_env_options: env options of the evaluation envs beyond :meth:`env_options`.
        level_options: ``level_options`` per level name that make a level the protocol's version of it (DMC-GB2:
            ``{"color_hard": {"draw": "dmcgb2"}, ...}``); :func:`vigen.evaluation.evaluate` (``protocol=``) passes
            each level its own.
        clip_returns_at: each episode's return is raised to this floor before averaging (RL-ViGen's
            ``locoeval.py``: 0); ``None``: no clip.
        evaluator: the source's evaluation script the published numbers are assumed to come from, and why.
        published_as: the protocol names the published rows of this protocol carry (:mod:`vigen.results`),
            besides its own name.
        eval_seed_offset: what the source adds to a run's seed to seed its evaluation env (DMC-GB: 42,
            ``src/eval.py:53``, ``src/train.py:55``); evaluation under the protocol plays env seeds
            ``seed + eval_seed_offset`` (:meth:`evaluation_seeds`), so its episodes are the source's.

    Examples:
        >>> from vigen.protocols import PROTOCOLS
        >>> PROTOCOLS["dmcgb"].action_repeat_for("dmc/finger-spin"), PROTOCOLS["dmcgb"].action_repeat_for("dmc/walker-walk")
        (2, 4)
    """

    name: str
    title: str
    url: str
    suites: tuple[str, ...]
    budget: int
    budget_unit: BudgetUnit
    action_repeat: int
    frame_stack: int
    image_size: int
    train_eval: Evaluation
    test: Evaluation
    seeds: int
    statistic: str
    action_repeat_by_task: Mapping[str, int | None] = field(default_factory=dict)
    budget_by_task: Mapping[str, int] = field(default_factory=dict)
    test_levels_by_suite: Mapping[str, tuple[str, ...]] = field(default_factory=dict)
    episode_length: Mapping[str, int] = field(default_factory=lambda: {"dmc": 1000})
    level_differences: Mapping[str, str] = field(default_factory=dict)
    notes: str = ""
    batch_size: int | None = None
    train_env_options: Mapping[str, Any] = field(default_factory=dict)
    test_env_options: Mapping[str, Any] = field(default_factory=dict)
    level_options: Mapping[str, Mapping[str, Any]] = field(default_factory=dict)
    clip_returns_at: float | None = None
    evaluator: str = ""
    published_as: tuple[str, ...] = ()
    eval_seed_offset: int = 0

    def __post_init__(self) -> None:
        if self.budget_unit not in BUDGET_UNITS:
            raise ValueError(f"budget_unit must be one of {BUDGET_UNITS}, got {self.budget_unit!r}.")
        if self.clip_returns_at is not None and (isinstance(self.clip_returns_at, bool)
                                                 or not isinstance(self.clip_returns_at, (int, float))):
            raise ValueError(f"clip_returns_at is a return floor (a number) or None, got {self.clip_returns_at!r}.")
        object.__setattr__(self, "train_env_options", _frozen(self.train_env_options))
        object.__setattr__(self, "test_env_options", _frozen(self.test_env_options))
        object.__setattr__(self, "level_options", _frozen({level: _frozen(options) for level, options in self.level_options.items()}))
        object.__setattr__(self, "action_repeat_by_task", _frozen(self.action_repeat_by_task))
        object.__setattr__(self, "budget_by_task", _frozen(self.budget_by_task))
        object.__setattr__(self, "test_levels_by_suite", _frozen(self.test_levels_by_suite))
        object.__setattr__(self, "episode_length", _frozen(self.episode_length))
        object.__setattr__(self, "level_differences", _frozen(self.level_differences))

    def _task(self, env: str) -> tuple[str, str]:
        suite, _, task = env.partition("/")
        if not task:
            raise ValueError(f"{env!r} is not an env name; pass '<suite>/<task>', e.g. 'dmc/walker-walk'.")
        if suite not in self.suites:
            raise ValueError(f"protocol {self.name!r} covers the {', '.join(self.suites)} suite(s), not {suite!r} ({env}); "
                             f"pick a protocol of that suite or none.")
        return task, task.split("-", 1)[0]

    def _lookup(self, table: Mapping[str, Any], env: str, default: Any) -> Any:
        task, domain = self._task(env)
        return table.get(task, table.get(domain, table.get(env.split("/", 1)[0], default)))

    def action_repeat_for(self, env: str) -> int:
        """The action repeat the protocol uses on ``env`` (e.g. ``"dmc/cartpole-swingup"``); 1 where the suite has none."""
        return self._lookup(self.action_repeat_by_task, env, self.action_repeat) or 1

    def budget_for(self, env: str) -> int:
        """The training length on ``env`` in the protocol's own unit (:attr:`budget_unit`)."""
        return self._lookup(self.budget_by_task, env, self.budget)

    def frames(self, env: str) -> int:
        """The training length on ``env`` in frames (control steps), whatever unit the protocol counts in."""
        budget = self.budget_for(env)
        return budget * self.action_repeat_for(env) if self.budget_unit == "agent_steps" else budget

    def budget_text(self, env: str) -> str:
        """The budget as the paper states it and in frames, e.g. ``'500,000 agent steps (2,000,000 frames at action repeat 4)'``."""
        repeat = self.action_repeat_for(env)
        if self.budget_unit == "agent_steps":
            return f"{self.budget_for(env):,} agent steps ({self.frames(env):,} frames at action repeat {repeat})"
        return f"{self.frames(env):,} frames ({self.frames(env) // repeat:,} agent steps at action repeat {repeat})"

    def eval_every_frames(self, env: str) -> int | None:
        """How often the protocol evaluates while training on ``env``, in frames."""
        every = self.train_eval.every
        return every * self.action_repeat_for(env) if every is not None and self.budget_unit == "agent_steps" else every

    def action_repeat_option(self, env: str) -> int | None:
        """The ``action_repeat`` option of ``env`` under this protocol; ``None`` where the suite has no such option."""
        return self._lookup(self.action_repeat_by_task, env, self.action_repeat)

    def episode_length_for(self, env: str) -> int | None:
        """Control steps per episode on ``env``'s suite; ``None`` where the protocol leaves it to the suite."""
        self._task(env)
        return self.episode_length.get(env.split("/", 1)[0])

    def test_levels(self, env: str) -> tuple[str, ...]:
        """The levels of the final zero-shot evaluation on ``env``'s suite."""
        self._task(env)
        return self.test_levels_by_suite.get(env.split("/", 1)[0], self.test.levels)

    def level_options_for(self, env: str, level: Any) -> dict[str, Any]:
        """The ``level_options`` that make ``level`` (a name) on ``env`` the protocol's version of it; ``{}`` for the others.

        Examples:
            >>> from vigen.protocols import get_protocol
            >>> get_protocol("dmcgb2").level_options_for("dmc/walker-walk", "video_hard")
            {'draw': 'dmcgb2', 'screen': True}
            >>> get_protocol("dmcgb").level_options_for("dmc/walker-walk", "video_hard")
            {}
        """
        self._task(env)
        return dict(self.level_options.get(level, {})) if isinstance(level, str) else {}

    def env_options(self, env: str) -> dict[str, int]:
        """The :func:`vigen.envs.make_env` options the protocol fixes on ``env``."""
        repeat = self.action_repeat_option(env)
        return {**({} if repeat is None else {"action_repeat": repeat}), "frame_stack": self.frame_stack,
                "image_size": self.image_size}

    def settings(self, env: str) -> dict[str, Any]:
        """Every value the protocol fixes on ``env``, flat, in frames (what ``examples/train.py`` records in ``config.json``).

        Examples:
            >>> from vigen.protocols import get_protocol
            >>> settings = get_protocol("rlvigen").settings("dmc/walker-walk")
            >>> settings["frames"], settings["action_repeat"], settings["test_episodes"]
            (1100000, 2, 100)
            >>> get_protocol("rlvigen").settings("robosuite/door")["action_repeat"] is None  # robosuite: fixed 20 Hz control
            True
        """
        return {
            "frames": self.frames(env), "action_repeat": self.action_repeat_option(env), "frame_stack": self.frame_stack,
            "image_size": self.image_size, "episode_length": self.episode_length_for(env),
            "eval_every": self.eval_every_frames(env), "eval_episodes": self.train_eval.episodes,
            "eval_levels": list(self.train_eval.levels), "test_episodes": self.test.episodes,
            "test_levels": list(self.test_levels(env)), "seeds": self.seeds,
            **({"train_env_options": dict(self.train_env_options)} if self.train_env_options else {}),
            **({"test_env_options": dict(self.test_env_options)} if self.test_env_options else {}),
            **({"level_options": {level: dict(options) for level, options in self.level_options.items()}}
               if self.level_options else {}),
            **({"clip_returns_at": self.clip_returns_at} if self.clip_returns_at is not None else {}),
            **({"eval_seed_offset": self.eval_seed_offset} if self.eval_seed_offset else {}),
        }

    def evaluation_seeds(self, seeds: Sequence[int]) -> list[int]:
        """The env seeds an evaluation under this protocol plays for runs or ``--seeds`` ``seeds``: each plus :attr:`eval_seed_offset`.

        Examples:
            >>> from vigen.protocols import get_protocol
            >>> get_protocol("dmcgb").evaluation_seeds([0, 1]), get_protocol("drqv2").evaluation_seeds([0, 1])
            ([42, 43], [0, 1])
        """
        return [int(seed) + self.eval_seed_offset for seed in seeds]

    def describe(self, env: str) -> list[str]:
        """The protocol on ``env`` as lines a run prints at its start."""
        return [
            f"protocol {self.name}: {self.title} ({self.url})",
            f"  budget: {self.budget_text(env)}",
            f"  frame stack {self.frame_stack}, image {self.image_size}x{self.image_size}",
            f"  while training: {self.train_eval.episodes} episodes on {', '.join(self.train_eval.levels)} every "
            f"{self.eval_every_frames(env):,} frames",
            f"  final test: {self.test.episodes} episodes per level on {', '.join(self.test_levels(env))}"
            + (f", env seed = seed + {self.eval_seed_offset}" if self.eval_seed_offset else ""),
            f"  reported: {self.statistic}, {self.seeds} seeds",
            *([f"  training envs: {dict(self.train_env_options)}"] if self.train_env_options else []),
            *([f"  test envs: {dict(self.test_env_options)}"] if self.test_env_options else []),
            *([f"  levels: {level} with {dict(options)}" for level, options in self.level_options.items()]),
            *([f"  episode returns below {self.clip_returns_at:g} count as {self.clip_returns_at:g}"]
              if self.clip_returns_at is not None else []),
            *([f"  evaluator: {self.evaluator}"] if self.evaluator else []),
            *([f"  note: {self.notes}"] if self.notes else []),
        ]


DMCGB_LEVELS = ("color_easy", "color_hard", "video_easy", "video_hard")
DMCGB2_LEVELS = tuple(f"{mode}_{difficulty}" for mode in ("rotate", "shift", "rotate_shift", "color", "video", "color_video")
                      for difficulty in ("easy", "hard"))
RLVIGEN_LEVELS = ("background_color_easy", "background_color_hard", "objects_color_easy", "objects_color_hard", "video_easy",
                  "video_hard", "light_easy", "light_hard", "camera_easy", "camera_hard")

DMCGB2_LEVEL_OPTIONS = {
    **{f"color_{difficulty}": {"draw": "dmcgb2"} for difficulty in ("easy", "hard")},
    **{f"video_{difficulty}": {"draw": "dmcgb2", "screen": True} for difficulty in ("easy", "hard")},
    **{f"color_video_{difficulty}": {"screen": True} for difficulty in ("easy", "hard")},
}
"""DMC-GB2's versions of its photometric levels: its colour cycle and video order (``draw``) and its in-scene screen."""

RLVIGEN_LOCO_EVALUATOR = (
    "locoeval.py (argparse; scripts/locoeval.sh): scaled actions (:113) and each episode's return clipped at 0 (:96). "
    "Assumed, not recorded: the sheet reports the loco tasks at Easy and Hard, two settings, and the other evaluator, "
    "locodmc_eval.py (raw actions, no clip), hard-codes type='video', difficulty='hard' (:67-69), so it cannot have "
    "given the Easy column; locoeval.py takes any --domain_name / --task_name.")
"""Which of RL-ViGen's two DMC evaluators the published loco rows are assumed to come from, and why."""

DRQV2_MEDIUM_TASKS = ("acrobot-swingup", "cheetah-run", "finger-turn_easy", "finger-turn_hard", "hopper-hop",
                      "quadruped-run", "quadruped-walk", "reacher-easy", "reacher-hard", "walker-run")
"""DrQ-v2's medium tasks (3M frames); its hard ones are humanoid's (30M); the rest are easy (1M)."""

PROTOCOLS: Mapping[str, Protocol] = _frozen({protocol.name: protocol for protocol in (
    Protocol(
        name="dmcgb",
        title="DMControl Generalization Benchmark (Hansen & Wang 2021; SVEA, SGQN, MaDi, SimGRL tables)",
        url="https://github.com/nicklashansen/dmcontrol-generalization-benchmark",
        suites=("dmc",), budget=500_000, budget_unit="agent_steps",
        action_repeat=4, action_repeat_by_task={"cartpole": 8, "finger": 2},
        frame_stack=3, image_size=84,
        train_eval=Evaluation(episodes=30, levels=("train", "color_hard"), every=10_000),
        test=Evaluation(episodes=100, levels=DMCGB_LEVELS),
        seeds=5, statistic="mean ± std over seeds of each seed's mean episode return",
        notes="train_steps counts agent steps, so its '500k' is 2M frames at action repeat 4 (RL-ViGen #11 confused "
              "the two); RAD, CURL, PAD and SODA render 100x100 and crop to 84; the test env is seeded with the run's "
              "seed + 42 (src/eval.py:53, src/train.py:55), which fixes the colour presets its episodes draw.",
        batch_size=128,  # src/arguments.py --batch_size
        eval_seed_offset=42,  # src/eval.py:53, src/train.py:55: make_env(seed=args.seed + 42)
    ),
    Protocol(
        name="dmcgb2",
        title="DMControl Generalization Benchmark 2 (Almuzairee et al. 2024, SADA)",
        url="https://github.com/aalmuzairee/dmcgb2",
        suites=("dmc",), budget=1_000_000, budget_unit="frames", action_repeat=2,
        frame_stack=3, image_size=84,
        train_eval=Evaluation(episodes=10, levels=("train", "color_hard", "rotate_hard"), every=20_000),
        test=Evaluation(episodes=100, levels=DMCGB2_LEVELS),
        seeds=5, statistic="mean ± std over seeds of each seed's mean episode return",
        level_options=DMCGB2_LEVEL_OPTIONS,
        level_differences={level: "vigen resizes the video frames with OpenCV's bilinear decoder; DMC-GB2 with PIL's "
                                  "resize (dmcgb_photometric.py:150-155)"
                           for level in ("video_easy", "video_hard", "color_video_easy", "color_video_hard")},
        notes="its levels are DMC-GB2's own (level_options, applied when vigen.evaluation.evaluate gets protocol='dmcgb2'): "
              "color_* cycle the presets from RandomState(seed).randint(100) (draw='dmcgb2', dmcgb_photometric.py:53, 58, "
              "176-179), and the video levels play from the same start and show the video on DMC-GB2's in-scene screen "
              "(screen=True, lines 62, 120, 263-284); video_hard also makes the grid material transparent, i.e. the "
              "floor (line 111; its flag is named _remove_ground_and_rails, line 47, but no rail of its domains uses "
              "grid). Without them the same level names are DMC-GB's.",
        batch_size=256,  # cfgs/config.yaml
    ),
    Protocol(
        name="rlvigen",
        title="RL-ViGen (Yuan et al. 2023)",
        url="https://github.com/gemcollector/RL-ViGen",
        suites=("dmc", "robosuite", "adroit", "loco"), budget=1_100_000, budget_unit="frames", action_repeat=2,
        action_repeat_by_task={"robosuite": None},
        budget_by_task={**dict.fromkeys(DRQV2_MEDIUM_TASKS, 3_100_000), "lift": 3_100_000, "two-arm-peg-in-hole": 3_100_000,
                        "adroit": 4_100_000, "loco": 3_100_000},
        episode_length={"dmc": 1000, "robosuite": 500, "loco": 1000},
        test_levels_by_suite={"robosuite": ("easy", "medium", "hard", "robot_iiwa", "robot_kinova3"), "loco": ("easy", "hard"),
                              "adroit": ("color_easy", "color_hard", "video_easy", "video_hard", "camera_easy", "camera_hard")},
        frame_stack=3, image_size=84,
        train_eval=Evaluation(episodes=10, levels=("train",), every=10_000),
        test=Evaluation(episodes=100, levels=RLVIGEN_LEVELS),
        seeds=5, statistic="per seed, the mean over a category's tasks; then mean ± sample std (ddof=1) over seeds",
        notes="budgets are its configs' num_train_frames (cfgs/task/easy.yaml 1.1M, medium.yaml 3.1M: robosuite Lift and "
              "TwoArmPegInHole, unitree_* and franka_reach; ViGen-adroit's task configs 4.1M); its launch scripts pass other lengths (1.0M, Habitat "
              "0.7M) and its results sheet does not say which produced the scores, so vigen.results leaves those "
              "budgets blank; robosuite runs at 20 Hz control without action repeat and evaluates 10 scenes x 10 trials per "
              "level; the paper's figures show 95 % CIs, its results sheet mean ± std.",
        batch_size=256,  # cfgs/config.yaml and every algorithm's config
    ),
    Protocol(
        name="rlvigen_loco",
        title="RL-ViGen's published locomotion rows (Yuan et al. 2023: Unitree and Franka)",
        url="https://github.com/gemcollector/RL-ViGen",
        suites=("loco",), budget=3_100_000, budget_unit="frames", action_repeat=2,
        episode_length={"loco": 1000},
        frame_stack=3, image_size=84,
        train_eval=Evaluation(episodes=10, levels=("train",), every=10_000),
        test=Evaluation(episodes=100, levels=("easy", "hard")),
        seeds=5, statistic="per seed, the mean over a category's tasks; then mean ± sample std (ddof=1) over seeds",
        train_env_options={"action_mapping": "rlvigen_train", "time_limit_as": "terminated", "start_clearance": "rlvigen"},
        test_env_options={"action_mapping": "scaled", "time_limit_as": "truncated", "start_clearance": "rlvigen"},
        clip_returns_at=0.0,
        evaluator=RLVIGEN_LOCO_EVALUATOR,
        published_as=("rlvigen",),
        notes="the published loco rows combine two paths: agents trained on raw clipped actions with discount 0 at the "
              "10 s limit (train.py through loco_wrapper.py / dmc2gym), evaluated by locoeval.py with scaled actions "
              "and returns clipped at 0; both start RL-ViGen's robots where its files do (start_clearance='rlvigen': "
              "the folded stand A1 2 cm into the floor, a1_stand.xml; the walk A1 at 0.43 m, a1_walk.xml:76); budgets as "
              "protocol rlvigen (medium.yaml: 3.1M frames for unitree_* and franka_reach).",
        batch_size=256,  # cfgs/config.yaml
    ),
    Protocol(
        name="drqv2",
        title="DrQ-v2 (Yarats et al. 2021)",
        url="https://github.com/facebookresearch/drqv2",
        suites=("dmc",), budget=1_000_000, budget_unit="frames", action_repeat=2,
        budget_by_task={**dict.fromkeys(DRQV2_MEDIUM_TASKS, 3_000_000), "humanoid": 30_000_000},
        frame_stack=3, image_size=84,
        train_eval=Evaluation(episodes=10, levels=("train",), every=20_000),
        test=Evaluation(episodes=10, levels=("train",)),
        seeds=10, statistic="mean over seeds of the evaluation return at each frame count (curves)",
        notes="its configs train 0.1M frames longer (1.1M/3.1M/30.1M, drqv2 #25); the published curves evaluate every "
              "20k frames (100k for humanoid) on the training scene only.",
        batch_size=256,  # cfgs/config.yaml
    ),
    Protocol(
        name="planet",
        title="PlaNet benchmark as CURL and DrQ report it (Srinivas et al. 2020)",
        url="https://github.com/MishaLaskin/curl",
        suites=("dmc",), budget=500_000, budget_unit="frames", action_repeat=4,
        action_repeat_by_task={"cartpole": 8, "finger": 2, "walker": 2},
        frame_stack=3, image_size=84,
        train_eval=Evaluation(episodes=10, levels=("train",), every=10_000),
        test=Evaluation(episodes=10, levels=("train",)),
        seeds=10, statistic="mean ± std over seeds at 100k and 500k environment steps (frames)",
        notes="CURL renders 100x100 and crops to 84; its '500k steps' are frames.",
    ),
)})
"""Protocol name -> :class:`Protocol`."""


def get_protocol(name: str | Protocol) -> Protocol:
    """The protocol of a name (a :class:`Protocol` passes through); an unknown name raises listing the known ones.

    Examples:
        >>> from vigen.protocols import get_protocol
        >>> get_protocol("dmcgb2").budget_unit
        'frames'
    """
    if isinstance(name, Protocol):
        return name
    if name not in PROTOCOLS:
        raise ValueError(f"Unknown protocol {name!r}; the protocols are {', '.join(PROTOCOLS)}.")
    return PROTOCOLS[name]

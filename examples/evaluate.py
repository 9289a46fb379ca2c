"""Evaluate trained agents zero-shot on generalization levels and write the report.

    python examples/evaluate.py runs/drqv2-cartpole-balance-s0 runs/svea-cartpole-balance-s0 \\
        --levels train dmcgb --episodes 10 --out reports/cartpole

``--pretrained NAME ...`` evaluates agents that ship with vigen (``vigen.pretrained.available()``)
instead of, or beside, runs:

    python examples/evaluate.py --pretrained drqv2-cartpole-balance --random --levels train color_hard

Each argument is a run folder of ``examples/train.py`` (its newest checkpoint that loads is used) or
one checkpoint file. Checkpoints load without running code (``weights_only=True``). The agent is
built from the run's ``config.json`` as ``examples/train.py`` builds it (``vigen.run.load_agent``:
the same networks, std schedule and the action bounds of the run's env). Runs of the same algorithm
with different seeds are aggregated as runs of one method. The report folder (never overwritten: a
new name is picked if it exists) holds ``episodes.csv`` (one row per episode), ``summary.csv``,
``report.md`` (levels × methods: IQM with its 95 % stratified-bootstrap CI, and RL-ViGen's mean ±
std over runs) and ``levels.png`` (bars with 95 % CIs).

``--sweep FACTOR I1 I2 ...`` (repeatable) adds one level per intensity of a factor (see
``vigen.envs.factors``) and writes its robustness curve, ``intensity_<FACTOR>.png`` (IQM against
intensity, one line per method, as the Distracting Control Suite plots them):

    python examples/evaluate.py runs/svea-walker-walk-s0 --levels train --sweep camera_rotation 0 0.1 0.2 0.3 0.5

The report also gives each method's generalization gap per level (test / train return of the same
runs, ``gaps.csv``), the probability that one method beats another per level (rliable's P(X > Y),
``improvements.csv``, with two methods or more) and a performance profile over the test levels
(``profile.png``). Tasks with a success check get the success rate (%) beside the return.

Each level shows the benchmark's own data where vigen has it: DMC-GB's colour presets ship with
vigen, and its videos and DAVIS 2017 are used once fetched (``python -m vigen.datasets fetch
dmcgb-videos``, ``... davis2017``; docs/data.md). Until then the video levels show procedural
stand-ins and warn. ``--videos`` gives folders per level instead (a level name or a shell
pattern before ``=``; one bare folder serves every video level). A folder given for a level
of a benchmark data set must hold as many videos as that data set's part (DMC-GB's
``video_easy`` 10, ``video_hard`` 100), checked before any episode; ``--allow-partial-data``
evaluates on fewer (or other) videos anyway. Every row records what its level showed, by identity
and never by path (``data``: e.g. ``dmcgb-videos/video_easy: 10 of 10, verified`` when every file
is DMC-GB's, ``user folder: 7 videos`` otherwise; ``stand_in``; ``level_options``, a folder by its
name; and ``shown``: the episode's video or preset), and the report lists it per level:

    python examples/evaluate.py --pretrained svea-cartpole-balance --levels train video_easy video_hard dcs_0.1 \\
        --videos video_easy=/data/dmcgb/video_easy video_hard=/data/dmcgb/video_hard 'dcs_*'=/data/DAVIS

``--compare NAME`` puts the runs beside the published numbers (``vigen.results``): a protocol
(``dmcgb``, ``dmcgb2``, ``rlvigen``, ``drqv2``, ``planet``: every source published under it) or one
source (``sgqn``, ``madi``, ``simgrl``, ``curl``). Before any episode runs, it checks that each run
followed that protocol (its ``config.json``: action repeat, frame stack, image size; its
checkpoint's frames against the published budget) and stops naming every difference otherwise;
``--allow-budget-mismatch`` shows a run that trained for another length anyway, marked, and
``--allow-stand-ins`` levels that showed vigen's stand-ins instead of the benchmark's data, and
``--allow-partial-data`` levels that showed less than the published data set in full (fewer videos,
a user's folder, files not verified against the pinned ids), each line saying what was shown. A published
number is set beside a run only where the run was trained by the recipe of the code behind it
(``examples/train.py --recipe``, docs/recipes.md); ``--allow-recipe-mismatch`` shows the others, each
line naming what differs. Levels
default to the protocol's test levels; the report gains a "Published" table and ``published.png``:

    python examples/evaluate.py runs/svea-walker-walk-s0 --compare dmcgb --episodes 100

Under a protocol (``--compare``'s, or the one every run was trained under) the envs are seeded as
the source seeds its test env: DMC-GB's ``seed + 42`` (``Protocol.eval_seed_offset``), so
``--seeds 0`` plays env seed 42, the colour presets DMC-GB's evaluation of a seed-0 run draws; the
rows' ``seed`` is the env seed played.

The flags are made from the fields of ``EvaluationConfig`` below (what is evaluated and reported; the
run folders are its positional arguments) and of ``Launch`` (``--ray``, ``--workers``, ``--device``,
``--out``: how this command runs, not what it measures); ``--help`` lists them with their defaults.
Runs and shipped agents alike are built by ``vigen.run.build_agent`` from the config they were
trained with (``vigen.run.load_agent``, ``vigen.pretrained.load_agent``).

The report folder may lie inside a run folder of ``examples/train.py``: the command then holds that
run's writer lock (one process writes a run folder at a time) and stops at once, naming the
process, while the run trains or resumes there.

``--ray`` spreads the (level, seed) jobs over Ray workers (``pip install -e ".[ray]"``): a local
cluster started for the evaluation (on 127.0.0.1 only), or the cluster at ``--ray ADDRESS``;
``--workers N`` caps the jobs in flight (default: the cluster's CPUs). The rows are the serial ones:

    python examples/evaluate.py runs/svea-walker-walk-s0 --levels train dmcgb --seeds 0 1 2 3 --ray --workers 2
"""

from __future__ import annotations

import argparse
import contextlib
import fnmatch
import json
import sys
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch
from tensordict.nn import TensorDictModuleBase
from tqdm import tqdm

import vigen.datasets
from vigen import pretrained
from vigen.datasets.identity import not_in_full
from vigen.assets.video_source import folder_videos
from vigen.checkpoint import CheckpointError
from vigen.devices import resolve_device
from vigen.envs import factors, level_label
from vigen.envs.level_types import FetchedData
from vigen.envs.levels import resolve_levels
from vigen.envs.registry import get_suite
from vigen.evaluation import (comparison_table, evaluate, generalization_gaps, improvements, markdown_table, plot_comparison,
                              plot_intensity, plot_levels, plot_performance_profile, summarize, sweep, write_csv)
from vigen.evaluation.report import interval_cell, label_stand_ins
from vigen.io import FolderInUse, RunFolderLock, atomic_write, unused_path
from vigen.protocols import PROTOCOLS, Protocol
from vigen.ray_cluster import ray_session
from vigen.rendering import RenderSettings
from vigen.results import (SOURCES, PartialData, ProtocolMismatch, RecipeMismatch, StandInRows, compare, load,
                           published)
from vigen.results.compare import VALUE_UNITS
from vigen.run import TrainConfig, TrainedAgent, add_flags, given_flags, load_agent, setting

DEFAULT_GROUPS = {"dmc": "dmcgb", "robosuite": "rlvigen", "adroit": "rlvigen"}
"""The test levels evaluated by default beside ``train``, per suite (others: ``all``)."""


@dataclass(frozen=True)
class EvaluationConfig:
    """What is evaluated and reported: the agents, the levels, the episodes and seeds, the data shown, the comparison."""

    runs: tuple[Path, ...] = setting((), "run folders or checkpoint files of examples/train.py", positional=True)
    pretrained: tuple[str, ...] = setting(
        (), f"agents that ship with vigen (vigen.pretrained): {', '.join(pretrained.available()) or 'none yet'}; or the "
            ".pt file of one written by vigen.pretrained.export_policy (its .json beside it)", metavar="NAME")
    levels: tuple[str, ...] | None = setting(
        None, "levels or groups of the runs' suite (dmc: dmcgb, rlvigen, corruptions; robosuite: rlvigen, camera, "
              "embodiment; adroit: rlvigen, camera, light)",
        unset="train and the suite's dmcgb (dmc) or rlvigen group; with --compare, train and the protocol's test levels")
    sweep: tuple[tuple[str, ...], ...] = setting(
        (), "a factor and its intensities in [0, 1], e.g. --sweep camera_rotation 0 0.1 0.3; repeatable; adds their levels "
            "and an intensity_FACTOR.png curve", metavar="FACTOR I1 I2")
    episodes: int = setting(10, "episodes per level and seed")
    seeds: tuple[int, ...] = setting((0,), "env and level seeds (robosuite: also the scene, seed %% 10; RL-ViGen: "
                                           "--seeds 0 1 ... 9)")
    random: bool = setting(False, "also evaluate a random policy as a baseline")
    videos: tuple[str, ...] = setting(
        (), "video folders per level: LEVEL=FOLDER, LEVEL a level or a shell pattern (video_easy=DIR video_hard=DIR "
            "'dcs_*'=DAVIS), or one FOLDER for every video level; levels without one show the data fetched with python -m "
            "vigen.datasets (docs/data.md), else procedural stand-ins", metavar="[LEVEL=]FOLDER")
    episode_length: int | None = setting(None, "control steps per episode", unset="the run's")
    compare: str | None = setting(
        None, "put the runs beside the published numbers of a protocol (all its sources) or of one source",
        choices=lambda: sorted({*PROTOCOLS, *SOURCES}))
    allow_budget_mismatch: bool = setting(
        False, "with --compare: show runs trained for another length than the published numbers, marked")
    allow_stand_ins: bool = setting(
        False, "with --compare: show levels that showed vigen's stand-ins (procedural videos, statistics-matched colours) "
               "beside the published numbers, each line saying so")
    allow_partial_data: bool = setting(
        False, "evaluate --videos folders that hold fewer (or other) videos than their level's data set and, with "
               "--compare, show such levels beside the published numbers, each line saying what was shown")
    allow_recipe_mismatch: bool = setting(
        False, "with --compare: show published numbers whose code trained the method by another recipe than the run's "
               "(examples/train.py --recipe), each line naming what differs")


@dataclass(frozen=True)
class Launch:
    """How this command runs the evaluation and where it writes the report; the rows do not depend on them."""

    ray: str | None = setting(None, "run the (level, seed) jobs on Ray: a local cluster, or the cluster at ADDRESS",
                              unset="no Ray", bare="local", metavar="ADDRESS")
    workers: int | None = setting(None, "with --ray: jobs in flight at once", unset="the cluster's CPUs")
    device: str = setting("auto", "where the policies act: auto (CUDA when present), cpu, cuda, cuda:N; envs step on the "
                                  "CPU. A checkpoint made on a GPU evaluates on a CPU-only machine (with --ray: cpu)")
    out: Path = setting(Path("reports/evaluation"), "the report folder; never overwritten: a new name is picked if it exists")


@dataclass(frozen=True)
class Comparison:
    """``--compare``: the protocol, its sources, and what may be shown beside them anyway."""

    name: str
    protocol: str
    sources: list[str]
    allow_budget_mismatch: bool
    allow_stand_ins: bool
    allow_partial_data: bool = False
    allow_recipe_mismatch: bool = False


@dataclass(frozen=True)
class Evaluated:
    """One policy to evaluate (``None``: random actions) in its env, with the env's options and the columns of its rows."""

    policy: TensorDictModuleBase | None
    env: str
    env_options: dict[str, Any]
    tags: dict[str, Any]


@dataclass
class Report:
    """The report folder as it is written: ``report.md``'s text and the files beside it, in the order they are listed."""

    folder: Path
    text: str = ""
    tables: list[Path] = field(default_factory=list)
    figures: list[Path] = field(default_factory=list)
    curves: list[Path] = field(default_factory=list)
    lines: list[dict] = field(default_factory=list)
    """The summary lines (summary.csv): per method and level."""
    published_table: str = ""
    """With --compare: the runs beside the published numbers, as printed."""


def main(argv: list[str] | None = None) -> None:
    """Check the command, load the agents, resolve their levels, play the episodes, write and print the report."""
    config, launch = parse_args(argv)
    device = acting_device(launch)
    check_agents_named(config)
    sweeps, videos = [parse_sweep(items) for items in config.sweep], parse_videos(config.videos)
    with hold_run_folder(launch.out):  # a report inside a run folder: one writer at a time, checked before any episode
        agents = [load_run(path, device) for path in config.runs] + [load_shipped(name, device) for name in config.pretrained]
        comparison = compared_with(config)
        levels = levels_per_env(agents, config, comparison, sweeps)
        check_video_counts(levels, videos, config.allow_partial_data)
        runs = [run_evaluated(trained, config.episode_length) for trained in agents]
        if comparison is not None:  # the published numbers need the same protocol and data: check before any episode runs
            check_comparable(runs, levels, videos, comparison)
        evaluations = runs + (random_evaluated(runs) if config.random else [])
        protocol = evaluation_protocol(agents, comparison)
        seeds = env_seeds(config.seeds, protocol)
        rows = play(evaluations, levels, videos, config, launch, device, seeds, protocol.name if protocol else None)
        report = write_report(rows, unused_path(launch.out), sweeps, comparison, played=config.episodes * len(config.seeds))
    print_report(report, rows, comparison)


# -- the command line ----------------------------------------------------------------------------
def make_parser() -> argparse.ArgumentParser:
    """The arguments: one per field of EvaluationConfig (the run folders first, positional) and of Launch."""
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_flags(parser, EvaluationConfig, given_only=True)
    add_flags(parser, Launch, given_only=True)
    return parser


def parse_args(argv: list[str] | None = None) -> tuple[EvaluationConfig, Launch]:
    """What to evaluate and how, from the command line (each field its default where its flag is not given)."""
    args = make_parser().parse_args(argv)
    return EvaluationConfig(**given_flags(args, EvaluationConfig)), Launch(**given_flags(args, Launch))


def acting_device(launch: Launch) -> torch.device:
    """Where the policies act: ``--device``, or the CPU under ``--ray`` (its tasks act on their own CPU); checks ``--workers``."""
    try:
        device = resolve_device(launch.device)
    except ValueError as error:
        raise SystemExit(f"--device: {error}") from None
    if launch.ray is not None and device.type != "cpu":
        device = torch.device("cpu")
    if launch.workers is not None and (launch.ray is None or launch.workers < 1):
        raise SystemExit(f"--workers {launch.workers}: it sets the Ray jobs in flight (>= 1) and needs --ray.")
    return device


def check_agents_named(config: EvaluationConfig) -> None:
    """Stop unless there is something to evaluate and every ``--pretrained`` name is a shipped agent or an exported file."""
    if not config.runs and not config.pretrained:
        raise SystemExit("give run folders of examples/train.py, or --pretrained NAME (shipped: "
                         f"{', '.join(pretrained.available()) or 'none yet'}).")
    for name in config.pretrained:
        try:
            pretrained.info(name)
        except KeyError as error:
            raise SystemExit(f"--pretrained {name}: {error.args[0]}") from None


def parse_videos(items: tuple[str, ...] | list[str]) -> list[tuple[str, Path]]:
    """``--videos`` -> (level pattern, folder) pairs, in order; a bare FOLDER applies to every level (``*``)."""
    pairs = []
    for item in items:
        pattern, _, folder = item.rpartition("=") if "=" in item else ("*", "", item)
        path = Path(folder).expanduser()
        if not pattern or not path.is_dir():
            raise SystemExit(f"--videos {item}: give LEVEL=FOLDER or FOLDER, with an existing folder "
                             f"({path} {'is not a folder' if pattern else 'has no level before ='}).")
        pairs.append((pattern, path))
    return pairs


def parse_sweep(items: tuple[str, ...] | list[str]) -> list[dict[str, float]]:
    """``("camera_rotation", "0", "0.1")`` -> the sweep's levels, or an exit naming what is wrong."""
    factor, *values = items
    try:
        return sweep(factor, [float(value) for value in values])
    except (TypeError, ValueError) as error:
        if not values:
            error = f"give the intensities after the factor, e.g. --sweep {factor} 0 0.1 0.3"
        raise SystemExit(f"--sweep {' '.join(items)}: {error}") from None


def hold_run_folder(out: Path) -> contextlib.AbstractContextManager:
    """The writer lock of the run folder of examples/train.py that the report folder lies in (nothing outside one).

    A run folder holds ``config.json`` and ``checkpoints/`` or its lock; the lock is taken now, or
    the command stops naming the process that writes the run (a training run, a ``--resume``).
    """
    folder = next((parent for parent in out.absolute().parents if (parent / "config.json").is_file()
                   and ((parent / "checkpoints").is_dir() or (parent / RunFolderLock.LOCK).exists())), None)
    if folder is None:
        return contextlib.nullcontext()
    try:
        return RunFolderLock(folder).acquire()
    except FolderInUse as error:
        raise SystemExit(f"--out {out}: {error} Or write the report outside the run folder.") from None


# -- the agents and their levels -----------------------------------------------------------------
def load_run(path: Path, device: torch.device) -> TrainedAgent:
    """The run's agent with the weights of ``path`` (or the run's newest checkpoint that loads), on ``device``."""
    try:
        trained = load_agent(path, device=device)
    except (CheckpointError, FileNotFoundError) as error:
        raise SystemExit(f"{path}: {error}") from None
    for bad, why in trained.skipped:
        print(f"skipped checkpoint {bad}: {why}", file=sys.stderr)
    return trained


def load_shipped(name: str, device: torch.device) -> TrainedAgent:
    """A shipped agent (``vigen.pretrained``), or an exported one by its file, built as its run was (``build_agent``)."""
    try:
        return pretrained.load_agent(name, device=device)
    except CheckpointError as error:
        raise SystemExit(f"--pretrained {name}: {error}") from None


def compared_with(config: EvaluationConfig) -> Comparison | None:
    """``--compare NAME`` -> the comparison: a protocol names every source published under it, a source its protocol."""
    if config.compare is None:
        return None
    if config.compare in PROTOCOLS:
        protocol, sources = config.compare, [source for source in SOURCES if any(row.protocol == config.compare
                                                                                 for row in load(source))]
    else:
        protocol, sources = load(config.compare)[0].protocol, [config.compare]
    return Comparison(config.compare, protocol, sources, config.allow_budget_mismatch, config.allow_stand_ins,
                      config.allow_partial_data, config.allow_recipe_mismatch)


def levels_per_env(agents: list[TrainedAgent], config: EvaluationConfig, comparison: Comparison | None,
                   sweeps: list[list[dict[str, float]]]) -> dict[str, list[Any]]:
    """Each env's levels: ``--levels`` (default: train and the suite's group, or the protocol's test levels), then the sweeps'."""
    levels = {}
    for env in dict.fromkeys(trained.config.env for trained in agents):
        suite = env.split("/")[0]
        try:
            default = (["train", *PROTOCOLS[comparison.protocol].test_levels(env)] if comparison
                       else ["train", DEFAULT_GROUPS.get(suite, "all")])
            levels[env] = resolve_levels(list(config.levels or default), suite=suite)
        except ValueError as error:
            raise SystemExit(f"--compare {comparison.name}: {error}" if comparison else str(error)) from None
        for swept in sweeps:
            if swept[0].factor not in factors(env):
                raise SystemExit(f"--sweep {swept[0].factor}: not a factor of {env}; its factors are {', '.join(factors(env))}.")
            levels[env] += swept
    return levels


RUN_SETTINGS = ("action_repeat", "frame_stack", "image_size")
"""The env options a run was trained with (``config.json``); its evaluation uses the same."""


def run_evaluated(trained: TrainedAgent, episode_length: int | None) -> Evaluated:
    """A run's policy in its env as it was trained (the episode length asked for), with the columns its rows carry."""
    options = run_env_options(trained.config, episode_length)
    return Evaluated(trained.agent.policy, trained.config.env, options, run_tags(trained, options))


def random_evaluated(runs: list[Evaluated]) -> list[Evaluated]:
    """``--random``: a random policy in each env, as the env's first run saw it."""
    first: dict[str, dict] = {}
    for run in runs:
        first.setdefault(run.env, run.env_options)
    return [Evaluated(None, env, env_options, {"method": "random", "run": 0}) for env, env_options in first.items()]


def run_env_options(config: TrainConfig, episode_length: int | None) -> dict:
    """The evaluation env of a run: its action repeat, frame stack and image size, the episode length asked for and its
    protocol's options of evaluation envs (``test_env_options``: RL-ViGen's loco evaluator's scaled actions, ...)."""
    length = episode_length or config.episode_length
    return {"render_settings": RenderSettings.fast(),
            **({} if length is None else {"episode_length": length}),
            **{name: getattr(config, name) for name in RUN_SETTINGS if getattr(config, name) is not None},
            **(config.protocol_settings or {}).get("test_env_options", {})}


def run_tags(trained: TrainedAgent, env_options: dict) -> dict:
    """The columns every row of a run carries: method, run, frames, its training batch, its recipe (and the settings a flag
    overrode in it) and the settings a protocol fixes (for --compare)."""
    config = trained.config
    channels, _, width = config.observation_shape  # uint8 [3 * frame stack, H, W]
    defaults = get_suite(config.env).env_options
    settings = {"action_repeat": config.action_repeat or defaults.get("action_repeat"), "frame_stack": channels // 3,
                "image_size": width, "episode_length": env_options.get("episode_length", defaults.get("episode_length"))}
    return {"method": config.algo, "run": config.seed, "frames": trained.frames, "protocol": config.protocol or "",
            "batch_size": config.batch_size, "recipe": config.recipe or "",
            "recipe_overrides": json.dumps(config.recipe_overrides) if config.recipe_overrides else "",
            **{name: value for name, value in settings.items() if value is not None}}


def check_comparable(runs: list[Evaluated], levels: dict[str, list[Any]], videos: list[tuple[str, Path]],
                     comparison: Comparison) -> None:
    """Stop, naming every difference, unless each run followed the protocol and its levels show the benchmark's data."""
    probe = [{**run.tags, "env": run.env, "level": level, "return": 0.0, "success": 0.0, **shown_data(run.env, level, videos)}
             for run in runs for level in levels[run.env] if isinstance(level, str)]
    try:
        published_lines(probe, comparison)
    except ValueError as error:  # ProtocolMismatch and StandInRows included
        raise SystemExit(f"--compare {comparison.name}: {error}") from None


# -- the episodes --------------------------------------------------------------------------------
def play(evaluations: list[Evaluated], levels: dict[str, list[Any]], videos: list[tuple[str, Path]],
         config: EvaluationConfig, launch: Launch, device: torch.device, seeds: list[int],
         protocol: str | None = None) -> list[dict]:
    """Every policy's episodes on its env's levels at env seeds ``seeds`` (one Ray cluster for all with ``--ray``), with a
    progress bar of jobs.

    The levels are ``protocol``'s versions of them (``evaluate(..., protocol=)``: DMC-GB2's colour cycle, video order and
    screen under ``dmcgb2``; :func:`evaluation_protocol` picks it), else vigen's levels as named.
    """
    backend = {} if launch.ray is None else {"backend": "ray", "workers": launch.workers}
    rows = []
    with contextlib.ExitStack() as stack:
        if launch.ray is not None:  # one cluster for every run's jobs
            stack.enter_context(ray_session(None if launch.ray == "local" else launch.ray))
        progress = stack.enter_context(tqdm(total=sum(len(levels[run.env]) for run in evaluations) * len(seeds),
                                            unit="job", desc="(level, seed) jobs", dynamic_ncols=True))
        for run in evaluations:
            for share, level_options in in_runs(levels[run.env], lambda level: videos_for(run.env, level, videos)):
                rows += evaluate(run.policy, run.env, share, episodes=config.episodes, seeds=seeds,
                                 env_options={**run.env_options, "level_options": level_options or None}, tags=run.tags,
                                 device=device, progress=lambda done, total: progress.update(1), protocol=protocol, **backend)
    return rows


def evaluation_protocol(agents: list[TrainedAgent], comparison: Comparison | None) -> Protocol | None:
    """The protocol the evaluation follows: ``--compare``'s, else the one every run was trained under, else none."""
    if comparison is not None:
        return PROTOCOLS[comparison.protocol]
    trained = {trained.config.protocol for trained in agents}
    return PROTOCOLS[trained.pop()] if len(trained) == 1 and None not in trained and "" not in trained else None


def env_seeds(seeds: tuple[int, ...] | list[int], protocol: Protocol | None) -> list[int]:
    """The env seeds played for ``--seeds``: under a protocol, as its source seeds its test env (DMC-GB: ``seed + 42``)."""
    if protocol is None or not protocol.eval_seed_offset:
        return list(seeds)
    played = protocol.evaluation_seeds(seeds)
    print(f"protocol {protocol.name}: env seeds {', '.join(map(str, played))} (seed + {protocol.eval_seed_offset}, as the "
          "source seeds its test env)", file=sys.stderr)
    return played


def level_data_set(env: str, level: Any) -> tuple[str, str, int] | None:
    """(data set, part, its files) that ``level`` plays videos from once fetched (DMC-GB's ``video_easy``: 10), or ``None``."""
    suite, _ = env.split("/", 1)
    named = get_suite(suite).levels.get(level) if isinstance(level, str) else None
    for step in named.steps if named is not None else ():
        rule = step.params.get("videos")
        if isinstance(rule, FetchedData) and rule.part is not None:
            dataset = vigen.datasets.get_dataset(rule.dataset)
            if dataset.files:
                return dataset.name, rule.part, len(dataset.files_of(rule.part))
    return None


def check_video_counts(levels: dict[str, list[Any]], videos: list[tuple[str, Path]], allow_partial_data: bool) -> None:
    """Stop before any work where a ``--videos`` folder holds another number of videos than its level's data set part."""
    problems = []
    for env, env_levels in levels.items():
        for level in env_levels:
            folder, expected = videos_for(env, level, videos).get("videos"), level_data_set(env, level)
            if folder is None or expected is None:
                continue
            dataset, part, count = expected
            found = len(folder_videos(folder))
            if found != count:
                problems.append(f"{level_label(level)}={folder}: {found} video{'s' * (found != 1)}; {level_label(level)} plays "
                                f"{dataset}/{part}, {count} videos")
    if problems and not allow_partial_data:
        parts = sorted({problem.split(" plays ")[1].split(",")[0] for problem in problems})
        fetch = "; ".join(f"python -m vigen.datasets fetch {name.split('/')[0]} --part {name.split('/')[1]}" for name in parts)
        raise SystemExit("--videos: a folder does not hold its level's data set:\n" + "\n".join(f"  - {p}" for p in problems)
                         + f"\nFetch the data set ({fetch}) and drop --videos for these levels (they find it), give a folder "
                           "holding all of it, or pass --allow-partial-data to evaluate on these videos anyway (each row "
                           "then says what it showed).")


def videos_for(env: str, level: Any, pairs: list[tuple[str, Path]]) -> dict[str, str]:
    """The ``level_options`` a level gets from ``--videos``: the first matching pattern's folder, if the level plays videos."""
    suite, task = env.split("/", 1)
    if not pairs or "videos" not in get_suite(suite).options_taken(level, task):
        return {}
    label = level_label(level)
    folder = next((folder for pattern, folder in pairs if fnmatch.fnmatchcase(label, pattern)), None)
    return {} if folder is None else {"videos": str(folder)}


def in_runs(levels: list[Any], options_of: Callable[[Any], dict[str, str]]) -> list[tuple[list[Any], dict[str, str]]]:
    """Consecutive levels that share their ``level_options``, in order (one evaluate() call each keeps Ray's parallelism)."""
    runs: list[tuple[list[Any], dict[str, str]]] = []
    for level in levels:
        options = options_of(level)
        if runs and runs[-1][1] == options:
            runs[-1][0].append(level)
        else:
            runs.append(([level], options))
    return runs


# -- the report ----------------------------------------------------------------------------------
def write_report(rows: list[dict], folder: Path, sweeps: list[list[dict[str, float]]], comparison: Comparison | None,
                 played: int) -> Report:
    """The report folder: the rows and their tables, report.md and the figures, each section written by its own step."""
    folder.mkdir(parents=True)
    report = Report(folder, lines=summarize(rows))
    add_returns(report, rows)
    add_gaps(report, rows)
    add_improvements(report, rows)
    add_figures(report, rows, sweeps)
    if comparison is not None:
        add_published(report, rows, comparison, played)
    atomic_write(folder / "report.md", report.text)
    return report


def task_names(rows: list[dict]) -> str:
    """The envs of the rows, in order: the report's title."""
    return ", ".join(dict.fromkeys(row["env"] for row in rows))


def add_returns(report: Report, rows: list[dict]) -> None:
    """episodes.csv and summary.csv; the return per level and method, what each level showed, the success rate."""
    report.tables += [write_csv(rows, report.folder / "episodes.csv"), write_csv(report.lines, report.folder / "summary.csv")]
    report.text += (f"# Zero-shot evaluation: {task_names(rows)}\n\n## Episode return\n\n"
                    f"{markdown_table(label_stand_ins(report.lines, rows))}\n")
    if any(row["stand_in"] for row in rows):
        report.text += ("\nLevels marked (stand-in) showed vigen's stand-ins (procedural videos, statistics-matched colours), "
                        "not the benchmark's own data; `python -m vigen.datasets fetch ...` gets the data (docs/data.md).\n")
    if any(not_in_full(row.get("data")) for row in rows):
        report.text += ("\nLevels marked (partial data) showed less than their data set in full (fewer files than its part, "
                        "a user's folder, or files not verified against the pinned ids): their `data` column says what.\n")
    report.text += f"\n## What each level showed\n\n{level_notes(rows, heading=False)}"
    if all("success" in row for row in rows):  # tasks with a success check: the success rate in %
        success = summarize([dict(row, success=100.0 * row["success"]) for row in rows], value="success")
        report.tables.append(write_csv(success, report.folder / "summary_success.csv"))
        report.text += f"\n## Success rate (%)\n\n{markdown_table(success)}\n"


def add_gaps(report: Report, rows: list[dict]) -> None:
    """gaps.csv: each method's test / train return per level, with its 95 % CI (the random policy has no gap)."""
    gaps = generalization_gaps([row for row in rows if row["method"] != "random"])
    if gaps:
        report.tables.append(write_csv(gaps, report.folder / "gaps.csv"))
        report.text += "\n## Generalization gap (test / train return of the same runs, 95 % CI)\n\n" + markdown_table(
            gaps, cell=lambda line: interval_cell(line["gap"], line["gap_low"], line["gap_high"], line["runs"])) + "\n"


def add_improvements(report: Report, rows: list[dict]) -> None:
    """improvements.csv, with two methods or more: P(row beats column) per level, with its 95 % CI."""
    if len({row["method"] for row in rows}) <= 1:
        return
    better = improvements(rows)
    report.tables.append(write_csv(better, report.folder / "improvements.csv"))
    report.text += "\n## Probability of improvement P(row beats column), per level (95 % CI)\n\n" + "\n\n".join(
        f"{level}:\n\n" + markdown_table([line for line in better if line["level"] == level], rows="method", columns="over",
                                          cell=lambda line: interval_cell(line["probability"], line["low"], line["high"],
                                                                            max(line["runs"], line["over_runs"])))
        for level in dict.fromkeys(line["level"] for line in better)) + "\n"


def add_figures(report: Report, rows: list[dict], sweeps: list[list[dict[str, float]]]) -> None:
    """levels.png; profile.png over the test levels; one intensity_FACTOR.png robustness curve per swept factor."""
    task, folder, lines = task_names(rows), report.folder, report.lines
    report.figures.append(plot_levels(lines, folder / "levels.png", title=f"{task}: zero-shot IQM per level (95 % CI)"))
    if any(row["level"] != "train" for row in rows):
        report.figures.append(plot_performance_profile(rows, folder / "profile.png"))
        report.text += "\n## Performance profile over the test levels\n\n![profile.png](profile.png)\n"
    swept_factors = dict.fromkeys(swept[0].factor for swept in sweeps)
    report.curves += [plot_intensity(lines, folder / f"intensity_{factor}.png", factor=factor,
                                     title=f"{task}: IQM against {factor} (95 % CI)") for factor in swept_factors]
    if report.curves:
        report.text += "\n## Robustness curves\n\n" + "".join(f"![{curve.name}]({curve.name})\n" for curve in report.curves)


def add_published(report: Report, rows: list[dict], comparison: Comparison, played: int) -> None:
    """published.csv and published*.png: the runs beside the published numbers, with what each level showed."""
    protocol = comparison.protocol
    compared = published_lines([row for row in rows if row["method"] != "random"], comparison)
    report.tables.append(write_csv(compared, report.folder / "published.csv"))
    for unit in dict.fromkeys(line["unit"] for line in compared):
        name = "published.png" if unit == "return" else f"published_{unit}.png"
        report.figures.append(plot_comparison([line for line in compared if line["unit"] == unit], report.folder / name,
                                              ylabel="episode return" if unit == "return" else "success rate (%)"))
    wanted = PROTOCOLS[protocol].test.episodes
    report.published_table = comparison_table(compared) + ("" if played >= wanted else
        f"\nThis evaluation played {played} episodes per level and run; protocol {protocol} plays {wanted} "
        f"(--episodes {wanted}): fewer episodes, a noisier mean.")
    report.text += (f"\n## Published ({PROTOCOLS[protocol].title}; sources: {', '.join(comparison.sources)})\n\n"
                    f"{report.published_table}\n\n{level_notes(rows)}\n"
                    + "".join(f"![{figure.name}]({figure.name})\n" for figure in report.figures
                              if figure.name.startswith("published")))


def print_report(report: Report, rows: list[dict], comparison: Comparison | None) -> None:
    """The return table, the published numbers (with --compare) and the files written."""
    print(markdown_table(label_stand_ins(report.lines, rows)))
    if comparison is not None:
        print(f"\nPublished numbers, protocol {comparison.protocol}:\n\n{report.published_table}\n\n{level_notes(rows)}")
    names = [path.name for path in [*report.tables, report.folder / "report.md", *report.figures, *report.curves]]
    print(f"\nwrote {report.folder}/: {', '.join(names)}")


def published_lines(rows: list[dict], comparison: Comparison) -> list[dict]:
    """compare() on the return and, where the rows and the sources have one, the success rate (Adroit publishes success only)."""
    lines, nothing = [], []
    for value in ("return", "success"):
        if all(value in row for row in rows) and published(source=comparison.sources, unit=VALUE_UNITS[value]):
            try:
                lines += compare(rows, source=comparison.sources, protocol=comparison.protocol, value=value,
                                 allow_budget_mismatch=comparison.allow_budget_mismatch,
                                 allow_stand_ins=comparison.allow_stand_ins,
                                 allow_partial_data=comparison.allow_partial_data,
                                 allow_recipe_mismatch=comparison.allow_recipe_mismatch)
            except (ProtocolMismatch, StandInRows, PartialData, RecipeMismatch):  # the run or its data, not the unit: stop
                raise
            except ValueError as error:  # nothing published in this unit for these rows
                nothing.append(str(error))
    if not lines:
        raise ValueError(" ".join(nothing) or f"{', '.join(comparison.sources)} publish nothing comparable.")
    return lines


def shown_data(env: str, level: str, videos: list[tuple[str, Path]]) -> dict[str, Any]:
    """What ``level`` will show (its transforms built, no env), as the ``data`` / ``stand_in`` columns of its rows."""
    suite, task = env.split("/", 1)
    built = [transform for transform in get_suite(suite).level_transforms(task, level, **videos_for(env, level, videos))
             if hasattr(transform, "data_source")]
    return {"data": "; ".join(t.data_source for t in built), "stand_in": any(t.uses_stand_in for t in built)}


def level_notes(rows: list[dict], heading: bool = True) -> str:
    """What vigen's levels are and the data each showed, so a reader sees where they approximate the source's."""
    notes = []
    for env, level in dict.fromkeys((row["env"], row["level"]) for row in rows):
        if level == "train":
            continue
        source = get_suite(env).levels[level].source if level in get_suite(env).levels else level
        mine = [row for row in rows if (row["env"], row["level"]) == (env, level)]
        shown = [data for data in dict.fromkeys(row.get("data", "") for row in mine) if data]
        stand_in = any(row.get("stand_in") is True for row in mine)
        notes.append(f"- {level}: {source}" + (f"; showed {', '.join(shown)}" if shown else "")
                     + (" (vigen's stand-ins, not the benchmark's data)" if stand_in else ""))
    if not notes:
        return ""
    return ("vigen's levels, for reading the comparison:\n\n" if heading else "") + "\n".join(dict.fromkeys(notes)) + "\n"


if __name__ == "__main__":
    main()

"""Evaluate trained agents zero-shot on generalization levels and write the report: the whole evaluation in ``main``.

    python examples/evaluate.py runs/drqv2-cartpole-balance-s0 runs/svea-cartpole-balance-s0 --levels train dmcgb \\
        --episodes 10 --out reports/cartpole
    python examples/evaluate.py --pretrained drqv2-cartpole-balance --random --levels train color_hard   # shipped agents
    python examples/evaluate.py runs/svea-walker-walk-s0 --levels train --sweep camera_rotation 0 0.1 0.2 0.3 0.5
    python examples/evaluate.py runs/svea-walker-walk-s0 --compare dmcgb --episodes 100   # beside the published numbers
    python examples/evaluate.py runs/svea-walker-walk-s0 --levels train dmcgb --seeds 0 1 2 3 --ray --workers 2

Each argument is a run folder of ``examples/train.py`` (its newest checkpoint that loads) or one checkpoint file. The
settings are ``EvaluationConfig`` (what is evaluated and reported) and ``Launch`` (how this command runs) below;
``--help`` lists every flag. The report folder, the data each level shows (``--videos``), ``--compare`` and its
``--allow-*`` flags, and Ray: docs/evaluation.md.
"""

from __future__ import annotations

import contextlib
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Annotated, Any, Literal

import torch
from tqdm import tqdm
from tyro.conf import Positional, UseAppendAction, arg

from vigen import pretrained
from vigen.devices import resolve_device
from vigen.evaluation import evaluate, sweep
from vigen.evaluation.comparison import Comparison
from vigen.evaluation.level_data import check_video_counts, in_runs, video_folders, videos_for
from vigen.evaluation.report import write_report
from vigen.evaluation.runs import (Evaluated, check_comparable, evaluation_protocol, levels_per_env, random_evaluated,
                                   run_evaluated)
from vigen.io import FolderInUse, RunFolderLock, unused_path
from vigen.protocols import PROTOCOLS, Protocol
from vigen.ray_cluster import ray_session
from vigen.results import SOURCES
from vigen.run import RayAddress, TrainedAgent, enclosing_run_folder, load_agent, parse_flags, unset_means
from vigen.run.checkpoint import CheckpointError


def _comparisons() -> Any:
    return Literal[tuple(sorted({*PROTOCOLS, *SOURCES}))] | None


@dataclass(frozen=True)
class EvaluationConfig:
    """What is evaluated and reported: the agents, the levels, the episodes and seeds, the data shown, the comparison."""

    runs: Positional[tuple[Path, ...]] = ()
    """run folders or checkpoint files of examples/train.py"""
    pretrained: Annotated[tuple[str, ...], arg(metavar="NAME")] = ()
    ("agents that ship with vigen (vigen.pretrained.available()), or the .pt file of one written by "
     "vigen.pretrained.export_policy (its .json beside it)")
    levels: Annotated[tuple[str, ...] | None, unset_means("train and the suite's dmcgb (dmc) or rlvigen group; with "
                                                          "--compare, train and the protocol's test levels")] = None
    ("levels or groups of the runs' suite (dmc: dmcgb, rlvigen, corruptions; robosuite: rlvigen, camera, embodiment; "
     "adroit: rlvigen, camera, light)")
    sweep: Annotated[tuple[tuple[str, ...], ...], UseAppendAction, arg(metavar="FACTOR I1 I2")] = ()
    ("a factor and its intensities in [0, 1], e.g. --sweep camera_rotation 0 0.1 0.3; repeatable; adds their levels and"
     " an intensity_FACTOR.png curve")
    episodes: int = 10
    """episodes per level and seed"""
    seeds: tuple[int, ...] = (0,)
    """env and level seeds (robosuite: also the scene, seed % 10; RL-ViGen: --seeds 0 1 ... 9)"""
    random: bool = False
    """also evaluate a random policy as a baseline"""
    videos: Annotated[tuple[str, ...], arg(metavar="[LEVEL=]FOLDER")] = ()
    ("video folders per level: LEVEL=FOLDER, LEVEL a level or a shell pattern (video_easy=DIR video_hard=DIR "
     "'dcs_*'=DAVIS), or one FOLDER for every video level; levels without one show the data fetched with python -m "
     "vigen.datasets (docs/data.md), else procedural stand-ins")
    episode_length: Annotated[int | None, unset_means("the run's")] = None
    """control steps per episode"""
    compare: Annotated[str | None, arg(constructor_factory=_comparisons), unset_means("none")] = None
    """put the runs beside the published numbers of a protocol (all its sources) or of one source"""
    allow_budget_mismatch: bool = False
    """with --compare: show runs trained for another length than the published numbers, marked"""
    allow_stand_ins: bool = False
    ("with --compare: show levels that showed vigen's stand-ins (procedural videos, statistics-matched colours) beside "
     "the published numbers, each line saying so")
    allow_partial_data: bool = False
    ("evaluate --videos folders that hold fewer (or other) videos than their level's data set and, with --compare, show"
     " such levels beside the published numbers, each line saying what was shown")
    allow_recipe_mismatch: bool = False
    ("with --compare: show published numbers whose code trained the method by another recipe than the run's "
     "(examples/train.py --recipe), each line naming what differs")


@dataclass(frozen=True)
class Launch:
    """How this command runs the evaluation and where it writes the report; the rows do not depend on them."""

    ray: Annotated[RayAddress, unset_means("no Ray")] = None
    """run the (level, seed) jobs on Ray: a local cluster on 127.0.0.1, or the cluster at ADDRESS"""
    workers: Annotated[int | None, unset_means("the cluster's CPUs")] = None
    """envs stepping in parallel, each in its own worker (with --ray: a Ray task per (level, seed) job)"""
    device: str = "auto"
    ("where the policies act: auto (CUDA when present), cpu, cuda, cuda:N; envs step on the CPU. A checkpoint made on a"
     " GPU evaluates on a CPU-only machine (with --ray: cpu)")
    out: Path = Path("reports/evaluation")
    """the report folder; never overwritten: a new name is picked if it exists"""


def parse_args(argv: list[str] | None = None) -> tuple[EvaluationConfig, Launch]:
    """What to evaluate and how, from the command line (each field its default where its flag is not given)."""
    parsed = parse_flags({"evaluation": EvaluationConfig, "launch": Launch}, argv, description=__doc__)
    return parsed.settings["evaluation"], parsed.settings["launch"]


def main(argv: list[str] | None = None) -> None:
    # the command: every flag checked before any agent loads
    config, launch = parse_args(argv)
    device = acting_device(launch)
    check_agents_named(config)
    sweeps = [parse_sweep(items) for items in config.sweep]
    videos = stop_on_error(video_folders, config.videos)
    with hold_run_folder(launch.out):  # a report inside a run folder: one writer at a time, checked before any episode
        # the agents, each in its env as it was trained, and their levels; the comparison's checks before any episode
        agents = [load_run(path, device) for path in config.runs] + [load_shipped(name, device) for name in config.pretrained]
        comparison = None if config.compare is None else Comparison.named(
            config.compare, allow_budget_mismatch=config.allow_budget_mismatch, allow_stand_ins=config.allow_stand_ins,
            allow_partial_data=config.allow_partial_data, allow_recipe_mismatch=config.allow_recipe_mismatch)
        levels = stop_on_error(levels_per_env, [trained.config.env for trained in agents], config.levels, comparison, sweeps)
        stop_on_error(check_video_counts, levels, videos, config.allow_partial_data)
        runs = [run_evaluated(trained, config.episode_length) for trained in agents]
        if comparison is not None:  # the published numbers need the same protocol and data
            stop_on_error(check_comparable, runs, levels, videos, comparison, prefix=f"--compare {comparison.name}: ")
        protocol = evaluation_protocol(agents, comparison)
        # the episodes, then the report
        rows = play(runs + (random_evaluated(runs) if config.random else []), levels, videos, config, launch, device,
                    env_seeds(config.seeds, protocol), protocol.name if protocol else None)
        report = write_report(rows, unused_path(launch.out), swept=[points[0].factor for points in sweeps],
                              comparison=comparison, played=config.episodes * len(config.seeds))
    print(report.summary())


def stop_on_error(check, *args, prefix: str = "", **kwargs):
    """``check(*args, **kwargs)``, or stop with its ``ValueError``'s message (after ``prefix``): the command's fix."""
    try:
        return check(*args, **kwargs)
    except ValueError as error:
        raise SystemExit(f"{prefix}{error}") from None


def acting_device(launch: Launch) -> torch.device:
    """Where the policies act: ``--device``, or the CPU under ``--ray`` (its tasks act on their own CPU); checks
    ``--workers``."""
    device = stop_on_error(resolve_device, launch.device, prefix="--device: ")
    if launch.ray is not None and device.type != "cpu":
        device = torch.device("cpu")
    if launch.workers is not None and (launch.ray is None or launch.workers < 1):
        raise SystemExit(f"--workers {launch.workers}: it sets the Ray jobs in flight (>= 1) and needs --ray.")
    return device


def check_agents_named(config: EvaluationConfig) -> None:
    """Stop unless there is something to evaluate and every ``--pretrained`` name is a shipped agent or an exported
    file."""
    if not config.runs and not config.pretrained:
        raise SystemExit("give run folders of examples/train.py, or --pretrained NAME (shipped: "
                         f"{', '.join(pretrained.available()) or 'none yet'}).")
    for name in config.pretrained:
        try:
            pretrained.info(name)
        except KeyError as error:
            raise SystemExit(f"--pretrained {name}: {error.args[0]}") from None


def parse_sweep(items: tuple[str, ...]) -> list[dict[str, float]]:
    """``("camera_rotation", "0", "0.1")`` -> the sweep's levels, or an exit naming what is wrong."""
    factor, *values = items
    try:
        return sweep(factor, [float(value) for value in values])
    except (TypeError, ValueError) as error:
        if not values:
            error = f"give the intensities after the factor, e.g. --sweep {factor} 0 0.1 0.3"
        raise SystemExit(f"--sweep {' '.join(items)}: {error}") from None


def hold_run_folder(out: Path) -> contextlib.AbstractContextManager:
    """The writer lock of the run folder of examples/train.py that the report folder lies in (nothing outside one): taken
    now, or stop naming the process that writes the run (a training run, a ``--resume``)."""
    folder = enclosing_run_folder(out)
    if folder is None:
        return contextlib.nullcontext()
    try:
        return RunFolderLock(folder).acquire()
    except FolderInUse as error:
        raise SystemExit(f"--out {out}: {error} Or write the report outside the run folder.") from None


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


def env_seeds(seeds: tuple[int, ...], protocol: Protocol | None) -> list[int]:
    """The env seeds played for ``--seeds``: under a protocol, as its source seeds its test env (DMC-GB: ``seed + 42``)."""
    if protocol is None or not protocol.eval_seed_offset:
        return list(seeds)
    played = protocol.evaluation_seeds(seeds)
    print(f"protocol {protocol.name}: env seeds {', '.join(map(str, played))} (seed + {protocol.eval_seed_offset}, as the "
          "source seeds its test env)", file=sys.stderr)
    return played


def play(evaluations: list[Evaluated], levels: dict[str, list[Any]], videos: list[tuple[str, Path]],
         config: EvaluationConfig, launch: Launch, device: torch.device, seeds: list[int],
         protocol: str | None = None) -> list[dict]:
    """Every policy's episodes on its env's levels at env seeds ``seeds`` (one Ray cluster for all with ``--ray``), with a
    progress bar of jobs; the levels are ``protocol``'s versions of them (DMC-GB2's colour cycle, video order and screen
    under ``dmcgb2``), else vigen's levels as named."""
    backend = {} if launch.ray is None else {"backend": "ray", "workers": launch.workers}
    rows = []
    with contextlib.ExitStack() as stack:
        if launch.ray is not None:  # one cluster for every run's jobs
            stack.enter_context(ray_session(None if launch.ray == "local" else launch.ray))
        progress = stack.enter_context(tqdm(total=sum(len(levels[run.env]) for run in evaluations) * len(seeds),
                                            unit="job", desc="(level, seed) jobs", dynamic_ncols=True))
        for run in evaluations:  # consecutive levels that share their --videos folder: one evaluate() call, in parallel on Ray
            for share, level_options in in_runs(levels[run.env], lambda level: videos_for(run.env, level, videos)):
                rows += evaluate(run.policy, run.env, share, episodes=config.episodes, seeds=seeds,
                                 env_options={**run.env_options, "level_options": level_options or None}, tags=run.tags,
                                 device=device, progress=lambda done, total: progress.update(1), protocol=protocol, **backend)
    return rows


if __name__ == "__main__":
    main()

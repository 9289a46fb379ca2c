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
vigen, and its videos and DAVIS 2017 are used once fetched (``python -m vigen.data fetch
dmcgb-videos``, ``... davis2017``; docs/data.md). Until then the video levels show procedural
stand-ins and warn. ``--videos`` gives folders per level instead (a level name or a shell
pattern before ``=``; one bare folder serves every video level). Every row records what its
level showed (``data``, ``stand_in``, ``level_options``, and ``shown``: the episode's video or
preset), and the report lists it per level:

    python examples/evaluate.py --pretrained svea-cartpole-balance --levels train video_easy video_hard dcs_0.1 \\
        --videos video_easy=/data/dmcgb/video_easy video_hard=/data/dmcgb/video_hard 'dcs_*'=/data/DAVIS

``--compare NAME`` puts the runs beside the published numbers (``vigen.results``): a protocol
(``dmcgb``, ``dmcgb2``, ``rlvigen``, ``drqv2``, ``planet``: every source published under it) or one
source (``sgqn``, ``madi``, ``simgrl``, ``curl``). Before any episode runs, it checks that each run
followed that protocol (its ``config.json``: action repeat, frame stack, image size; its
checkpoint's frames against the published budget) and stops naming every difference otherwise;
``--allow-budget-mismatch`` shows a run that trained for another length anyway, marked, and
``--allow-stand-ins`` levels that showed vigen's stand-ins instead of the benchmark's data. Levels
default to the protocol's test levels; the report gains a "Published" table and ``published.png``:

    python examples/evaluate.py runs/svea-walker-walk-s0 --compare dmcgb --episodes 100

``--ray`` spreads the (level, seed) jobs over Ray workers (``pip install -e ".[ray]"``): a local
cluster started for the evaluation (on 127.0.0.1 only), or the cluster at ``--ray ADDRESS``;
``--workers N`` caps the jobs in flight (default: the cluster's CPUs). The rows are the serial ones:

    python examples/evaluate.py runs/svea-walker-walk-s0 --levels train dmcgb --seeds 0 1 2 3 --ray --workers 2
"""

from __future__ import annotations

import argparse
import contextlib
import fnmatch
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from tqdm import tqdm

from vigen.checkpoint import CheckpointError
from vigen.devices import resolve_device
from vigen.envs import factors, level_label
from vigen.envs.levels import resolve_levels
from vigen.envs.registry import get_suite
from vigen.evaluation import (comparison_table, evaluate, generalization_gaps, improvements, markdown_table, plot_comparison,
                              plot_intensity, plot_levels, plot_performance_profile, summarize, sweep, write_csv)
from vigen.evaluation.report import interval_cell, label_stand_ins
from vigen.io import atomic_write, unused_path
from vigen.protocols import PROTOCOLS
from vigen.ray_cluster import ray_session
from vigen.rendering import RenderSettings
from vigen.results import SOURCES, ProtocolMismatch, compare, load, published
from vigen.results.compare import VALUE_UNITS
from vigen.pretrained import available, info, load_policy
from vigen.run import TrainConfig, load_agent


DEFAULT_GROUPS = {"dmc": "dmcgb", "robosuite": "rlvigen", "adroit": "rlvigen"}


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="*", type=Path, help="run folders or checkpoint files of examples/train.py")
    parser.add_argument("--pretrained", nargs="+", default=[], metavar="NAME",
                        help=f"agents that ship with vigen (vigen.pretrained): {', '.join(available()) or 'none yet'}; "
                             "or the .pt file of one written by vigen.pretrained.export_policy (its .json beside it)")
    parser.add_argument("--levels", nargs="+", default=None,
                        help="levels or groups of the runs' suite (dmc: dmcgb, rlvigen, corruptions; robosuite: rlvigen, "
                             "camera, embodiment; adroit: rlvigen, camera, light); default: train and the suite's "
                             "dmcgb (dmc) or rlvigen group")
    parser.add_argument("--sweep", nargs="+", action="append", default=[], metavar="FACTOR I1 I2",
                        help="a factor and its intensities in [0, 1], e.g. --sweep camera_rotation 0 0.1 0.3; "
                             "repeatable; adds their levels and an intensity_FACTOR.png curve")
    parser.add_argument("--episodes", type=int, default=10, help="episodes per level and seed")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0],
                        help="env and level seeds (robosuite: also the scene, seed %% 10; RL-ViGen: --seeds 0 1 ... 9)")
    parser.add_argument("--random", action="store_true", help="also evaluate a random policy as a baseline")
    parser.add_argument("--videos", nargs="+", default=[], metavar="[LEVEL=]FOLDER",
                        help="video folders per level: LEVEL=FOLDER, LEVEL a level or a shell pattern (video_easy=DIR "
                             "video_hard=DIR 'dcs_*'=DAVIS), or one FOLDER for every video level. Default: the data "
                             "fetched with python -m vigen.data (docs/data.md), else procedural stand-ins")
    parser.add_argument("--episode-length", type=int, default=None, help="simulator steps per episode (default: the run's)")
    parser.add_argument("--compare", default=None, choices=sorted({*PROTOCOLS, *SOURCES}),
                        help="put the runs beside the published numbers of a protocol (all its sources) or of one source")
    parser.add_argument("--allow-budget-mismatch", action="store_true",
                        help="with --compare: show runs trained for another length than the published numbers, marked")
    parser.add_argument("--allow-stand-ins", action="store_true",
                        help="with --compare: show levels that showed vigen's stand-ins (procedural videos, statistics-"
                             "matched colours) beside the published numbers, each line saying so")
    parser.add_argument("--ray", nargs="?", const="local", default=None, metavar="ADDRESS",
                        help="run the (level, seed) jobs on Ray: a local cluster, or the cluster at ADDRESS")
    parser.add_argument("--workers", type=int, default=None, help="with --ray: jobs in flight at once (default: the cluster's CPUs)")
    parser.add_argument("--device", default="auto",
                        help="where the policies act: auto (CUDA when present), cpu, cuda, cuda:N; envs step on the CPU. "
                             "A checkpoint made on a GPU evaluates on a CPU-only machine (with --ray: cpu)")
    parser.add_argument("--out", type=Path, default=Path("reports/evaluation"))
    args = parser.parse_args()
    try:
        args.device = resolve_device(args.device)
    except ValueError as error:
        raise SystemExit(f"--device: {error}") from None
    if args.ray is not None and args.device.type != "cpu":
        args.device = torch.device("cpu")  # Ray's evaluation tasks act on their own CPU
    if args.workers is not None and (args.ray is None or args.workers < 1):
        raise SystemExit(f"--workers {args.workers}: it sets the Ray jobs in flight (>= 1) and needs --ray.")
    if not args.runs and not args.pretrained:
        raise SystemExit("give run folders of examples/train.py, or --pretrained NAME (shipped: "
                         f"{', '.join(available()) or 'none yet'}).")
    for name in args.pretrained:
        try:
            info(name)
        except KeyError as error:
            raise SystemExit(f"--pretrained {name}: {error.args[0]}") from None
    args.sweep = [parse_sweep(items) for items in args.sweep]
    args.videos = parse_videos(args.videos)
    return args


def parse_videos(items: list[str]) -> list[tuple[str, Path]]:
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


def videos_for(env: str, level: Any, pairs: list[tuple[str, Path]]) -> dict[str, str]:
    """The ``level_options`` a level gets from ``--videos``: the first matching pattern's folder, if the level plays videos."""
    suite, task = env.split("/", 1)
    if not pairs or "videos" not in get_suite(suite).options_taken(level, task):
        return {}
    label = level_label(level)
    folder = next((folder for pattern, folder in pairs if fnmatch.fnmatchcase(label, pattern)), None)
    return {} if folder is None else {"videos": str(folder)}


def in_runs(levels: list[Any], options_of: Any) -> list[tuple[list[Any], dict[str, str]]]:
    """Consecutive levels that share their ``level_options``, in order (one evaluate() call each keeps Ray's parallelism)."""
    runs: list[tuple[list[Any], dict[str, str]]] = []
    for level in levels:
        options = options_of(level)
        if runs and runs[-1][1] == options:
            runs[-1][0].append(level)
        else:
            runs.append(([level], options))
    return runs


def parse_sweep(items: list[str]) -> list[dict[str, float]]:
    """``["camera_rotation", "0", "0.1"]`` -> the sweep's levels, or an exit naming what is wrong."""
    factor, *values = items
    try:
        return sweep(factor, [float(value) for value in values])
    except (TypeError, ValueError) as error:
        if not values:
            error = f"give the intensities after the factor, e.g. --sweep {factor} 0 0.1 0.3"
        raise SystemExit(f"--sweep {' '.join(items)}: {error}") from None


@dataclass
class Evaluated:
    """What is evaluated: an acting policy, the config it was trained with, and its training frames."""

    policy: Any
    config: TrainConfig
    frames: int


def load_run(path: Path, device: torch.device) -> Evaluated:
    """The run's config and policy with the weights of ``path`` (or the run's newest checkpoint that loads), on ``device``."""
    try:
        trained = load_agent(path, device=device)
    except (CheckpointError, FileNotFoundError) as error:
        raise SystemExit(f"{path}: {error}") from None
    for bad, why in trained.skipped:
        print(f"skipped checkpoint {bad}: {why}", file=sys.stderr)
    return Evaluated(trained.agent.policy, trained.config, trained.frames)


def load_shipped(name: str, device: torch.device) -> Evaluated:
    """A shipped agent (``vigen.pretrained``), or an exported one by its file: its deterministic policy, config and frames."""
    record = info(name)
    return Evaluated(load_policy(name, device=device), TrainConfig.from_json(record["config"]), record["frames"])


RUN_SETTINGS = ("action_repeat", "frame_stack", "image_size")
"""The env options a run was trained with (``config.json``); its evaluation uses the same."""


def run_env_options(config: TrainConfig, args: argparse.Namespace) -> dict:
    """The evaluation env of a run: its action repeat, frame stack and image size, and the episode length asked for."""
    length = args.episode_length or config.episode_length
    return {"render_settings": RenderSettings.fast(),
            **({} if length is None else {"episode_length": length}),
            **{name: getattr(config, name) for name in RUN_SETTINGS if getattr(config, name) is not None}}


def run_tags(trained: Evaluated, env_options: dict) -> dict:
    """The columns every row of a run carries: method, run, frames, its training batch and the settings a protocol fixes (for --compare)."""
    config = trained.config
    channels, _, width = config.observation_shape  # uint8 [3 * frame stack, H, W]
    defaults = get_suite(config.env).env_options
    settings = {"action_repeat": config.action_repeat or defaults.get("action_repeat"), "frame_stack": channels // 3,
                "image_size": width, "episode_length": env_options.get("episode_length", defaults.get("episode_length"))}
    return {"method": config.algo, "run": config.seed, "frames": trained.frames, "protocol": config.protocol or "",
            "batch_size": config.batch_size,
            **{name: value for name, value in settings.items() if value is not None}}


def compare_sources(name: str) -> tuple[str, list[str]]:
    """``--compare NAME`` -> (the protocol, its sources): a protocol names every source published under it."""
    if name in PROTOCOLS:
        return name, [source for source in SOURCES if any(row.protocol == name for row in load(source))]
    return load(name)[0].protocol, [name]


def main() -> None:
    args = parse_args()
    agents = [load_run(path, args.device) for path in args.runs] + [load_shipped(name, args.device) for name in args.pretrained]
    protocol, sources = compare_sources(args.compare) if args.compare else (None, [])
    levels = {}  # env name -> its levels
    for env in dict.fromkeys(trained.config.env for trained in agents):
        suite = env.split("/")[0]
        try:
            default = ["train", *PROTOCOLS[protocol].test_levels(env)] if protocol else ["train", DEFAULT_GROUPS.get(suite, "all")]
            levels[env] = resolve_levels(args.levels or default, suite=suite)
        except ValueError as error:
            raise SystemExit(f"--compare {args.compare}: {error}" if protocol else str(error)) from None
        for swept in args.sweep:
            if swept[0].factor not in factors(env):
                raise SystemExit(f"--sweep {swept[0].factor}: not a factor of {env}; its factors are {', '.join(factors(env))}.")
            levels[env] += swept
    options = [run_env_options(trained.config, args) for trained in agents]
    if protocol is not None:  # the published numbers need the same protocol and data: check before any episode runs
        probe = [{**run_tags(trained, env_options), "env": trained.config.env, "level": level, "return": 0.0, "success": 0.0,
                  **shown_data(trained.config.env, level, args.videos)}
                 for trained, env_options in zip(agents, options) for level in levels[trained.config.env] if isinstance(level, str)]
        try:
            published_lines(probe, sources, protocol, args.allow_budget_mismatch, args.allow_stand_ins)
        except ValueError as error:  # ProtocolMismatch and StandInRows included
            raise SystemExit(f"--compare {args.compare}: {error}") from None
    evaluations = [(trained.policy, trained.config.env, env_options, run_tags(trained, env_options))
                   for trained, env_options in zip(agents, options)]
    if args.random:  # in each env as its first run saw it
        first: dict[str, dict] = {}
        for trained, env_options in zip(agents, options):
            first.setdefault(trained.config.env, env_options)
        evaluations += [(None, env, env_options, {"method": "random", "run": 0}) for env, env_options in first.items()]
    backend = {} if args.ray is None else {"backend": "ray", "workers": args.workers}
    rows = []
    with contextlib.ExitStack() as stack:
        if args.ray is not None:  # one cluster for every run's jobs
            stack.enter_context(ray_session(None if args.ray == "local" else args.ray))
        progress = stack.enter_context(tqdm(total=sum(len(levels[env]) for _, env, _, _ in evaluations) * len(args.seeds),
                                            unit="job", desc="(level, seed) jobs", dynamic_ncols=True))
        for policy, env, env_options, tags in evaluations:
            for share, level_options in in_runs(levels[env], lambda level: videos_for(env, level, args.videos)):
                rows += evaluate(policy, env, share, episodes=args.episodes, seeds=args.seeds,
                                 env_options={**env_options, "level_options": level_options or None}, tags=tags,
                                 device=args.device, progress=lambda done, total: progress.update(1), **backend)

    out = unused_path(args.out)
    out.mkdir(parents=True)
    lines = summarize(rows)
    written = [write_csv(rows, out / "episodes.csv"), write_csv(lines, out / "summary.csv")]
    task = ", ".join(dict.fromkeys(row["env"] for row in rows))
    report = f"# Zero-shot evaluation: {task}\n\n## Episode return\n\n{markdown_table(label_stand_ins(lines, rows))}\n"
    if any(row["stand_in"] for row in rows):
        report += ("\nLevels marked (stand-in) showed vigen's stand-ins (procedural videos, statistics-matched colours), not "
                   "the benchmark's own data; `python -m vigen.data fetch ...` gets the data (docs/data.md).\n")
    report += f"\n## What each level showed\n\n{level_notes(rows, heading=False)}"
    if all("success" in row for row in rows):  # tasks with a success check: the success rate in %
        success = summarize([dict(row, success=100.0 * row["success"]) for row in rows], value="success")
        written.append(write_csv(success, out / "summary_success.csv"))
        report += f"\n## Success rate (%)\n\n{markdown_table(success)}\n"
    gaps = generalization_gaps([row for row in rows if row["method"] != "random"])
    if gaps:
        written.append(write_csv(gaps, out / "gaps.csv"))
        report += "\n## Generalization gap (test / train return of the same runs, 95 % CI)\n\n" + markdown_table(
            gaps, cell=lambda line: interval_cell(line["gap"], line["gap_low"], line["gap_high"], line["runs"])) + "\n"
    if len({row["method"] for row in rows}) > 1:
        better = improvements(rows)
        written.append(write_csv(better, out / "improvements.csv"))
        report += "\n## Probability of improvement P(row beats column), per level (95 % CI)\n\n" + "\n\n".join(
            f"{level}:\n\n" + markdown_table([line for line in better if line["level"] == level], rows="method", columns="over",
                                              cell=lambda line: interval_cell(line["probability"], line["low"], line["high"],
                                                                                max(line["runs"], line["over_runs"])))
            for level in dict.fromkeys(line["level"] for line in better)) + "\n"
    figures = [plot_levels(lines, out / "levels.png", title=f"{task}: zero-shot IQM per level (95 % CI)")]
    if any(row["level"] != "train" for row in rows):
        figures.append(plot_performance_profile(rows, out / "profile.png"))
        report += "\n## Performance profile over the test levels\n\n![profile.png](profile.png)\n"
    swept_factors = dict.fromkeys(swept[0].factor for swept in args.sweep)
    curves = [plot_intensity(lines, out / f"intensity_{factor}.png", factor=factor,
                             title=f"{task}: IQM against {factor} (95 % CI)") for factor in swept_factors]
    if curves:
        report += "\n## Robustness curves\n\n" + "".join(f"![{curve.name}]({curve.name})\n" for curve in curves)
    published_table = ""
    if protocol is not None:
        compared = published_lines([row for row in rows if row["method"] != "random"], sources, protocol,
                                   args.allow_budget_mismatch, args.allow_stand_ins)
        written.append(write_csv(compared, out / "published.csv"))
        for unit in dict.fromkeys(line["unit"] for line in compared):
            name = "published.png" if unit == "return" else f"published_{unit}.png"
            figures.append(plot_comparison([line for line in compared if line["unit"] == unit], out / name,
                                           ylabel="episode return" if unit == "return" else "success rate (%)"))
        played = args.episodes * len(args.seeds)
        wanted = PROTOCOLS[protocol].test.episodes
        published_table = comparison_table(compared) + ("" if played >= wanted else
            f"\nThis evaluation played {played} episodes per level and run; protocol {protocol} plays {wanted} "
            f"(--episodes {wanted}): fewer episodes, a noisier mean.")
        report += (f"\n## Published ({PROTOCOLS[protocol].title}; sources: {', '.join(sources)})\n\n{published_table}\n\n"
                   f"{level_notes(rows)}\n" + "".join(f"![{figure.name}]({figure.name})\n"
                                                                   for figure in figures if figure.name.startswith("published")))
    atomic_write(out / "report.md", report)
    print(markdown_table(label_stand_ins(lines, rows)))
    if published_table:
        print(f"\nPublished numbers, protocol {protocol}:\n\n{published_table}\n\n{level_notes(rows)}")
    names = [path.name for path in [*written, out / "report.md", *figures, *curves]]
    print(f"\nwrote {out}/: {', '.join(names)}")


def published_lines(rows: list[dict], sources: list[str], protocol: str, allow_budget_mismatch: bool,
                    allow_stand_ins: bool) -> list[dict]:
    """compare() on the return and, where the rows and the sources have one, the success rate (Adroit publishes success only)."""
    lines, nothing = [], []
    for value in ("return", "success"):
        if all(value in row for row in rows) and published(source=sources, unit=VALUE_UNITS[value]):
            try:
                lines += compare(rows, source=sources, protocol=protocol, value=value, allow_budget_mismatch=allow_budget_mismatch,
                                 allow_stand_ins=allow_stand_ins)
            except ProtocolMismatch:
                raise
            except ValueError as error:  # nothing published in this unit for these rows
                nothing.append(str(error))
    if not lines:
        raise ValueError(" ".join(nothing) or f"{', '.join(sources)} publish nothing comparable.")
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

"""Evaluate trained agents zero-shot on generalization levels and write the report.

    python examples/evaluate.py runs/drqv2-cartpole-balance-s0 runs/svea-cartpole-balance-s0 \\
        --levels train dmcgb --episodes 10 --out reports/cartpole

Each argument is a run folder of ``examples/train.py`` (its newest checkpoint that loads is used) or
one checkpoint file. Checkpoints load without running code (``weights_only=True``). Runs of the same algorithm with different seeds are aggregated as runs of one
method. The report folder (never overwritten: a new name is picked if it exists) holds
``episodes.csv`` (one row per episode), ``summary.csv``, ``report.md`` (levels × methods:
IQM with its 95 % stratified-bootstrap CI, and RL-ViGen's mean ± std over runs) and
``levels.png`` (bars with 95 % CIs).

``--sweep FACTOR I1 I2 ...`` (repeatable) adds one level per intensity of a factor (see
``vigen.envs.factors``) and writes its robustness curve, ``intensity_<FACTOR>.png`` (IQM against
intensity, one line per method, as the Distracting Control Suite plots them):

    python examples/evaluate.py runs/svea-walker-walk-s0 --levels train --sweep camera_rotation 0 0.1 0.2 0.3 0.5
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from tensordict.nn import TensorDictModuleBase
from torchrl.data import Bounded

from vigen.checkpoint import CheckpointError, load_checkpoint, newest_checkpoint
from vigen.envs import factors
from vigen.envs.levels import resolve_levels
from vigen.evaluation import evaluate, markdown_table, plot_intensity, plot_levels, summarize, sweep, write_csv
from vigen.io import unused_path
from vigen.losses import make_loss
from vigen.policies import make_policy
from vigen.rendering import RenderSettings


DEFAULT_GROUPS = {"dmc": "dmcgb", "robosuite": "rlvigen", "adroit": "rlvigen"}


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path, help="run folders or checkpoint files of examples/train.py")
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
    parser.add_argument("--videos", default=None, help="a folder of videos for the video levels (default: procedural)")
    parser.add_argument("--episode-length", type=int, default=None, help="simulator steps per episode (default: the run's)")
    parser.add_argument("--out", type=Path, default=Path("reports/evaluation"))
    args = parser.parse_args()
    args.sweep = [parse_sweep(items) for items in args.sweep]
    return args


def parse_sweep(items: list[str]) -> list[dict[str, float]]:
    """``["camera_rotation", "0", "0.1"]`` -> the sweep's levels, or an exit naming what is wrong."""
    factor, *values = items
    try:
        return sweep(factor, [float(value) for value in values])
    except (TypeError, ValueError) as error:
        if not values:
            error = f"give the intensities after the factor, e.g. --sweep {factor} 0 0.1 0.3"
        raise SystemExit(f"--sweep {' '.join(items)}: {error}") from None


def load_agent(path: Path) -> tuple[dict, TensorDictModuleBase]:
    """The run's config and its acting policy, with the weights of ``path`` (or the run's newest checkpoint that loads).

    Checkpoints load with ``weights_only=True``: one holding anything but tensors and plain data is refused.
    """
    try:
        if path.is_file():
            checkpoint_path, checkpoint = path, load_checkpoint(path)
        else:
            checkpoint_path, checkpoint, skipped = newest_checkpoint(path / "checkpoints")
            for bad, why in skipped:
                print(f"skipped checkpoint {bad}: {why}", file=sys.stderr)
    except CheckpointError as error:
        raise SystemExit(f"{path}: {error} Is it a run folder of examples/train.py?") from None
    config = json.loads((checkpoint_path.parent.parent / "config.json").read_text())
    loss = make_loss(config["algo"], tuple(config["observation_shape"]), config["action_dim"],
                     feature_dim=config["feature_dim"], hidden_dim=config["hidden_dim"])
    loss.make_value_estimator(gamma=config["gamma"])  # its gamma is part of the saved state
    loss.load_state_dict(checkpoint["loss"])
    policy = make_policy(loss, Bounded(-1.0, 1.0, shape=(config["action_dim"],)))  # dm_control's action bounds
    return dict(config, frames=checkpoint["frames"]), policy


def main() -> None:
    args = parse_args()
    level_options = {"videos": args.videos} if args.videos else None
    agents = [load_agent(path) for path in args.runs]
    levels = {}  # env name -> its levels
    for config, _ in agents:
        suite = config["env"].split("/")[0]
        try:
            levels[config["env"]] = resolve_levels(args.levels or ["train", DEFAULT_GROUPS.get(suite, "all")], suite=suite)
        except ValueError as error:
            raise SystemExit(str(error)) from None
        for swept in args.sweep:
            if swept[0].factor not in factors(config["env"]):
                raise SystemExit(f"--sweep {swept[0].factor}: not a factor of {config['env']}; its factors are "
                                 f"{', '.join(factors(config['env']))}.")
            levels[config["env"]] += swept
    rows = []
    for config, policy in agents:
        length = args.episode_length or config.get("episode_length")
        env_options = {"render_settings": RenderSettings.fast(), "level_options": level_options,
                       **({} if length is None else {"episode_length": length})}
        rows += evaluate(policy, config["env"], levels[config["env"]], episodes=args.episodes, seeds=args.seeds,
                         env_options=env_options,
                         tags={"method": config["algo"], "run": config["seed"], "frames": config["frames"]})
    if args.random:
        for env in dict.fromkeys(row["env"] for row in rows):
            rows += evaluate(None, env, levels[env], episodes=args.episodes, seeds=args.seeds,
                             env_options=env_options, tags={"method": "random", "run": 0})

    out = unused_path(args.out)
    out.mkdir(parents=True)
    lines = summarize(rows)
    write_csv(rows, out / "episodes.csv")
    write_csv(lines, out / "summary.csv")
    task = ", ".join(dict.fromkeys(row["env"] for row in rows))
    report = f"# Zero-shot evaluation: {task}\n\n## Episode return\n\n{markdown_table(lines)}\n"
    if all("success" in row for row in rows):  # tasks with a success check: the success rate in %
        success = summarize([dict(row, success=100.0 * row["success"]) for row in rows], value="success")
        write_csv(success, out / "summary_success.csv")
        report += f"\n## Success rate (%)\n\n{markdown_table(success)}\n"
    (out / "report.md").write_text(report)
    plot_levels(lines, out / "levels.png", title=f"{task}: zero-shot IQM per level (95 % CI)")
    swept_factors = dict.fromkeys(swept[0].factor for swept in args.sweep)
    curves = [plot_intensity(lines, out / f"intensity_{factor}.png", factor=factor,
                             title=f"{task}: IQM against {factor} (95 % CI)").name for factor in swept_factors]
    if curves:
        (out / "report.md").write_text(report + "\n## Robustness curves\n\n" + "".join(f"![{name}]({name})\n" for name in curves))
    print(markdown_table(lines))
    print(f"\nwrote {out}/: {', '.join(['episodes.csv', 'summary.csv', 'report.md', 'levels.png', *curves])}")


if __name__ == "__main__":
    main()

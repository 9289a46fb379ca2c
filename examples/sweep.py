"""Robustness curve of one factor: evaluate a policy zero-shot at several intensities and plot return against intensity.

    python examples/sweep.py                                        # random policy, camera_rotation 0 .. 0.5
    python examples/sweep.py --checkpoint runs/svea-walker-walk-s0  # a run folder or checkpoint of examples/train.py
    python examples/sweep.py --factor object_color --intensities 0 0.1 0.2 0.3 0.4 0.5 --episode-length 1000

Nothing is trained. The policy plays ``--episodes`` episodes per intensity and seed on
``dmc/walker-walk`` (the Distracting Control Suite sweeps intensity the same way, with 0.1 / 0.2 /
0.3 as its easy / medium / hard), with ``RenderSettings.fast()``. The report folder (a new name if
it exists) gets ``episodes.csv``, ``summary.csv``, ``report.md`` (intensities × methods: IQM with
its 95 % stratified-bootstrap CI, RL-ViGen's mean ± std over seeds) and ``intensity_<factor>.png``.

With its defaults (5 intensities × 3 seeds × 1 episode of 250 agent steps, random policy, one
torch thread) it took 77 s of wall time on this project's 2-core CPU machine (measured with
``time``, imports included, load average 3 from other jobs). With two torch threads it took 77 s
at load average 1 but 194 s at load average 2.4 (OpenMP threads competing for the two cores),
hence the default ``--threads 1``. The random policy plays the same seeded actions at every
intensity, so its curve is flat: the reference of an agent blind to pixels. A trained agent's
curve shows the factor's effect.
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

import torch
from tensordict.nn import TensorDictModuleBase

from vigen.checkpoint import CheckpointError
from vigen.envs import factors
from vigen.evaluation import evaluate, markdown_table, plot_intensity, summarize, sweep, write_csv
from vigen.io import unused_path
from vigen.rendering import RenderSettings
from vigen.run import TrainConfig, load_agent


def parse_args() -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--env", default=None, help="default: the checkpoint's env, else dmc/walker-walk")
    parser.add_argument("--factor", default="camera_rotation", help="the factor to sweep (see vigen.envs.factors)")
    parser.add_argument("--intensities", nargs="+", type=float, default=[0.0, 0.1, 0.2, 0.3, 0.5])
    parser.add_argument("--checkpoint", type=Path, default=None,
                        help="a run folder (its newest checkpoint that loads) or a checkpoint file of examples/train.py; "
                             "default: a random policy")
    parser.add_argument("--random", action="store_true", help="with --checkpoint: also evaluate a random policy")
    parser.add_argument("--episodes", type=int, default=1, help="episodes per intensity and seed")
    parser.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2], help="env and level seeds")
    parser.add_argument("--episode-length", type=int, default=500, help="control steps per episode (action repeat 2)")
    parser.add_argument("--threads", type=int, default=1,
                        help="torch threads; 1 is fastest for one env's small tensors on a busy CPU")
    parser.add_argument("--out", type=Path, default=Path("reports/sweep"))
    args = parser.parse_args()
    if args.threads < 1:
        raise SystemExit(f"--threads must be >= 1, got {args.threads}.")
    return args


def load_policy(path: Path) -> tuple[TrainConfig, TensorDictModuleBase]:
    """The run's algorithm and acting policy, from a run folder or checkpoint file (``weights_only`` loading)."""
    try:
        trained = load_agent(path)
    except (CheckpointError, FileNotFoundError) as error:
        raise SystemExit(f"--checkpoint {path}: {error}") from None
    return trained.config, trained.agent.policy


def main() -> None:
    start = time.perf_counter()
    args = parse_args()
    torch.set_num_threads(args.threads)
    agents = [] if args.checkpoint is None else [load_policy(args.checkpoint)]
    env = args.env or (agents[0][0].env if agents else "dmc/walker-walk")
    if args.factor not in factors(env):
        raise SystemExit(f"--factor {args.factor}: not a factor of {env}; its factors are {', '.join(factors(env))}.")
    try:
        levels = sweep(args.factor, args.intensities)
    except (TypeError, ValueError) as error:
        raise SystemExit(f"--intensities: {error}") from None
    policies = [(config.algo, policy) for config, policy in agents]
    if not agents or args.random:
        policies.append(("random", None))

    env_options = {"render_settings": RenderSettings.fast(), "episode_length": args.episode_length}
    rows = []
    for method, policy in policies:
        rows += evaluate(policy, env, levels, episodes=args.episodes, seeds=args.seeds, env_options=env_options,
                         tags={"method": method})
        print(f"{method}: {len(levels)} intensities x {len(args.seeds)} seeds done", flush=True)

    out = unused_path(args.out)
    out.mkdir(parents=True)
    lines = summarize(rows)
    write_csv(rows, out / "episodes.csv")
    write_csv(lines, out / "summary.csv")
    curve = plot_intensity(lines, out / f"intensity_{args.factor}.png", factor=args.factor,
                           title=f"{env}: IQM against {args.factor} (95 % CI)")
    table = markdown_table(lines)
    (out / "report.md").write_text(f"# {env}: return against {args.factor}\n\n{table}\n\n![{curve.name}]({curve.name})\n")
    print(table)
    print(f"\nwrote {out}/: episodes.csv, summary.csv, report.md, {curve.name} in {time.perf_counter() - start:.0f} s")


if __name__ == "__main__":
    main()

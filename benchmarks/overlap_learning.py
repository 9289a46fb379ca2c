"""Does an agent learn as much per frame when collection overlaps the updates? The same short runs with and without
``--overlap`` (and with more env workers), several seeds each, their evaluation returns side by side.

``--overlap`` keeps the update ratio (one update per ``--update-every`` agent steps) and acts one
collector batch of updates behind the serial run (:class:`vigen.run.CollectorBatches`); more
workers collect more steps per batch with the same weights. This compares what that does to
learning, per environment frame:

    python benchmarks/overlap_learning.py --out /tmp/overlap-learning      # cartpole-balance, cpu preset, 3 seeds, 30k frames
    python benchmarks/overlap_learning.py --variants serial overlap overlap-w8 --env dmc/walker-walk --preset paper \\
        --frames 100000 --device cuda --jobs 4 --out $OUT/overlap-learning                # on a GPU machine

Variants: ``serial`` (train.py as it is), ``overlap`` (``--overlap``), ``overlap-wN`` (``--overlap --workers
N``), ``serial-wN`` (``--workers N``). For every checkpoint (each ``--eval-every`` frames) the
table gives each variant's mean evaluation return over the seeds with its standard error, and
each variant's difference to ``serial`` with the difference's standard error. A variant is
"within noise" when the difference of its mean over all checkpoints (the area under the curve,
one number per run) to serial's is at most 2 standard errors; the largest difference at a single
checkpoint is given in standard errors too, but not used for the verdict (with a few seeds and
many checkpoints, one of them exceeds 2 standard errors by chance about half the time). The runs stay in ``<out>/runs``; running
the same command again continues them (``--resume``). Writes ``<out>/overlap_learning.md`` and
``.json``.
"""

from __future__ import annotations

import argparse
import csv
import json
import math
import os
import statistics
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

from vigen.io import atomic_write

ROOT = Path(__file__).resolve().parents[1]


def variant_flags(name: str) -> list[str]:
    """train.py's flags of a variant name: ``serial``, ``overlap``, ``overlap-w4``, ``serial-w2``.

    Examples:
        >>> variant_flags("overlap-w4"), variant_flags("serial")
        (['--overlap', '--workers', '4'], [])
    """
    mode, _, workers = name.partition("-w")
    if mode not in ("serial", "overlap") or (workers and not workers.isdigit()):
        raise SystemExit(f"variant {name!r}: write serial, overlap, serial-wN or overlap-wN")
    return [*(["--overlap"] if mode == "overlap" else []), *(["--workers", workers] if workers else [])]


def train(variant: str, seed: int, args: argparse.Namespace) -> Path:
    run_dir = args.out / "runs" / f"{variant}-s{seed}"
    if (run_dir / "config.json").is_file() and (run_dir / "checkpoints").is_dir():
        command = [sys.executable, str(ROOT / "examples" / "train.py"), "--resume", str(run_dir), "--frames", str(args.frames)]
    else:
        command = [sys.executable, str(ROOT / "examples" / "train.py"), "--algo", args.algo, "--env", args.env, "--preset", args.preset,
                   "--seed", str(seed), "--frames", str(args.frames), "--eval-every", str(args.eval_every),
                   "--eval-episodes", str(args.eval_episodes), "--out", str(run_dir), *variant_flags(variant), *args.train_flags]
    command += ["--device", args.device, *(["--threads", str(args.threads)] if args.threads else [])]
    run_dir.parent.mkdir(parents=True, exist_ok=True)
    with (args.out / "runs" / f"{variant}-s{seed}.log").open("a") as log:
        log.write(f"$ {' '.join(command)}\n")
        log.flush()
        code = subprocess.run(command, cwd=ROOT, stdout=log, stderr=subprocess.STDOUT, env={**os.environ, "PYTHONUNBUFFERED": "1"}).returncode
    if code != 0:
        raise SystemExit(f"{variant} seed {seed} failed (exit {code}); see {log.name}")
    return run_dir


def curve(run_dir: Path) -> dict[int, float]:
    with (run_dir / "logs" / "scalars" / "eval" / "train_return.csv").open() as file:
        return {int(float(frame)): float(value) for frame, value in csv.reader(file)}


def mean_se(values: list[float]) -> tuple[float, float]:
    """The mean and its standard error (0 for a single value).

    Examples:
        >>> mean_se([1.0, 3.0])
        (2.0, 1.0)
    """
    return statistics.fmean(values), (statistics.stdev(values) / math.sqrt(len(values)) if len(values) > 1 else 0.0)


def compare(curves: dict[str, dict[int, dict[int, float]]]) -> dict:
    """Per variant and checkpoint: mean, standard error and the difference to ``serial``; the verdict per variant.

    Examples:
        >>> runs = {"serial": {1: {10: 100.0, 20: 200.0}, 2: {10: 110.0, 20: 220.0}},
        ...         "overlap": {1: {10: 104.0, 20: 205.0}, 2: {10: 108.0, 20: 214.0}}}
        >>> verdict = compare(runs)["verdicts"]["overlap"]
        >>> verdict["within_noise"], round(verdict["area_difference"][0], 2)
        (True, 0.25)
    """
    frames = sorted(set.intersection(*(set(run) for runs in curves.values() for run in runs.values())))
    table = {variant: {frame: mean_se([run[frame] for run in runs.values()]) for frame in frames} for variant, runs in curves.items()}
    areas = {variant: mean_se([statistics.fmean(run[frame] for frame in frames) for run in runs.values()])
             for variant, runs in curves.items()}
    verdicts = {}
    for variant in curves:
        if variant == "serial" or "serial" not in curves:
            continue
        differences = [(table[variant][f][0] - table["serial"][f][0], math.hypot(table[variant][f][1], table["serial"][f][1]))
                       for f in frames]
        area = (areas[variant][0] - areas["serial"][0], math.hypot(areas[variant][1], areas["serial"][1]))
        verdicts[variant] = {"area_difference": area, "within_noise": abs(area[0]) <= 2 * area[1],
                             "largest_difference_in_se": max((abs(d) / se if se else math.inf if d else 0.0) for d, se in differences)}
    return {"frames": frames, "table": table, "areas": areas, "verdicts": verdicts}


def markdown(result: dict, seeds: list[int]) -> str:
    variants = list(result["table"])
    lines = [f"| frames | {' | '.join(variants)} |", "|---|" + "---|" * len(variants)]
    for frame in result["frames"]:
        cells = []
        for variant in variants:
            mean, se = result["table"][variant][frame]
            cells.append(f"{mean:.1f} ± {se:.1f}")
        lines.append(f"| {frame} | {' | '.join(cells)} |")
    lines.append(f"| mean over checkpoints | {' | '.join(f'{m:.1f} ± {se:.1f}' for m, se in result['areas'].values())} |")
    lines.append(f"\nMean evaluation return ± standard error over seeds {seeds}.")
    for variant, verdict in result["verdicts"].items():
        difference, se = verdict["area_difference"]
        lines.append(f"- {variant} − serial, mean over checkpoints: {difference:+.1f} ± {se:.1f}; largest difference at a checkpoint "
                     f"{verdict['largest_difference_in_se']:.1f} standard errors: "
                     f"{'within noise (the mean over checkpoints within 2 SE)' if verdict['within_noise'] else 'NOT within noise'}.")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--variants", nargs="+", default=["serial", "overlap", "overlap-w2"])
    parser.add_argument("--seeds", type=int, nargs="+", default=[1, 2, 3])
    parser.add_argument("--algo", default="drqv2")
    parser.add_argument("--env", default="dmc/cartpole-balance")
    parser.add_argument("--preset", default="cpu")
    parser.add_argument("--frames", type=int, default=30_000)
    parser.add_argument("--eval-every", type=int, default=5_000)
    parser.add_argument("--eval-episodes", type=int, default=5)
    parser.add_argument("--device", default="auto")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--jobs", type=int, default=1, help="runs at once")
    parser.add_argument("--out", type=Path, default=Path("overlap-learning"))
    parser.add_argument("--train-flags", nargs=argparse.REMAINDER, default=[], help="more train.py flags (last on the line)")
    args = parser.parse_args()
    for variant in args.variants:
        variant_flags(variant)
    args.out = args.out.resolve()
    print(f"reproduce: python benchmarks/overlap_learning.py {' '.join(sys.argv[1:])}", flush=True)
    jobs = [(variant, seed) for seed in args.seeds for variant in args.variants]
    with ThreadPoolExecutor(max_workers=args.jobs) as pool:
        runs = dict(zip(jobs, pool.map(lambda job: train(*job, args), jobs)))
    curves = {variant: {seed: curve(runs[variant, seed]) for seed in args.seeds} for variant in args.variants}
    result = compare(curves)
    text = markdown(result, args.seeds)
    atomic_write(args.out / "overlap_learning.md", text + "\n")
    atomic_write(args.out / "overlap_learning.json", json.dumps({"command": sys.argv, "curves": curves, **result}, indent=1))
    print(text)


if __name__ == "__main__":
    main()

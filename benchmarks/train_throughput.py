"""End-to-end training throughput of ``examples/train.py``: environment frames/s and updates/s, eager against compiled.

Each mode runs ``examples/train.py`` for ``--frames`` environment frames on ``--env`` in a new run
folder (one evaluation episode at the end), then reads the run's own logs:

* **frames/s**: environment frames over the run's wall time, evaluation included, compilation not
  (DrQ-v2's published curves count frames over wall-clock hours the same way: 70–97 frames/s on
  its GPU for walker-walk, ``../shared/data/drqv2_curves``);
* **updates/s**: one over the median ``train/seconds_per_update`` the run logged after each batch
  of updates (collection excluded);
* **compile s**: ``train/compile_seconds``, the first calls of the compiled update (tracing, code
  generation and, on CUDA, the CUDA-graph capture).

The modes run one after the other on the same machine and device, so their ratio is the figure
to read. ``--seed-frames`` is kept small so that most frames are collected while updating.

Reproduce (about 10 minutes on 2 CPU cores for both modes at the defaults):

    python benchmarks/train_throughput.py                                   # this machine's default device
    python benchmarks/train_throughput.py --device cuda --env dmc/walker-walk --frames 20000 --batch-size 256
"""

from __future__ import annotations

import argparse
import csv
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def scalar_log(run_dir: Path, name: str) -> list[float]:
    """The values of one TorchRL CSV scalar log (``logs/scalars/<name>.csv``: step, value per row)."""
    path = run_dir / "logs" / "scalars" / f"{name}.csv"
    if not path.exists():
        return []
    return [float(row[1]) for row in csv.reader(path.open()) if len(row) >= 2]


def train(mode: str, args: argparse.Namespace, out: Path) -> dict[str, float]:
    run_dir = out / mode
    command = [sys.executable, str(ROOT / "examples" / "train.py"), "--algo", args.algo, "--env", args.env,
               "--frames", str(args.frames), "--seed-frames", str(args.seed_frames), "--eval-every", str(args.frames),
               "--eval-episodes", "1", "--batch-size", str(args.batch_size), "--device", args.device, "--out", str(run_dir),
               *(["--threads", str(args.threads)] if args.threads else []), *(["--compile"] if mode == "compiled" else [])]
    started = time.perf_counter()
    result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT)
    wall = time.perf_counter() - started
    if result.returncode != 0:
        raise SystemExit(f"{mode} run failed:\n{result.stderr[-3000:]}")
    compile_seconds = sum(scalar_log(run_dir, "train/compile_seconds"))
    per_update = scalar_log(run_dir, "train/seconds_per_update")
    return {"wall": wall, "compile": compile_seconds, "frames_per_s": args.frames / (wall - compile_seconds),
            "updates_per_s": 1 / statistics.median(per_update) if per_update else float("nan")}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--algo", default="drqv2")
    parser.add_argument("--env", default="dmc/cartpole-balance")
    parser.add_argument("--frames", type=int, default=6000)
    parser.add_argument("--seed-frames", type=int, default=1000)
    parser.add_argument("--batch-size", type=int, default=64)
    parser.add_argument("--device", default="auto")
    parser.add_argument("--threads", type=int, default=None)
    parser.add_argument("--modes", nargs="+", default=["eager", "compiled"], choices=["eager", "compiled"])
    args = parser.parse_args()
    print("reproduce: python benchmarks/train_throughput.py " + " ".join(sys.argv[1:]), flush=True)
    print(f"examples/train.py --algo {args.algo} --env {args.env} --frames {args.frames} --batch-size {args.batch_size} "
          f"--device {args.device}\n")
    print("| mode | frames/s | updates/s | compile s | wall s | frames/s vs eager |\n|---|---|---|---|---|---|", flush=True)
    with tempfile.TemporaryDirectory() as folder:
        results = {}
        for mode in args.modes:
            results[mode] = figures = train(mode, args, Path(folder))
            base = results.get("eager", figures)
            print(f"| {mode} | {figures['frames_per_s']:.1f} | {figures['updates_per_s']:.1f} | {figures['compile']:.0f} "
                  f"| {figures['wall']:.0f} | {figures['frames_per_s'] / base['frames_per_s']:.2f}× |", flush=True)


if __name__ == "__main__":
    main()

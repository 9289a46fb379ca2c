"""Run a fixed set of ``examples/evaluate.py`` cases and keep everything each one wrote, to compare two versions byte for byte.

    python scripts/evaluate_cases.py runs --cases ../eval-cases                     # two tiny runs with train.py, once
    python scripts/evaluate_cases.py cases --cases ../eval-cases --into before      # every case, with this checkout
    ... change the code ...
    python scripts/evaluate_cases.py cases --cases ../eval-cases --into after
    diff -r ../eval-cases/before ../eval-cases/after                              # only help.txt may differ

``runs`` trains two tiny runs on ``dmc/cartpole-balance`` (DrQ-v2 under the ``drqv2`` protocol, SVEA under
``dmcgb``; 800 frames, ``--threads 1``) into ``<cases>/runs``, and writes a folder of two short videos
(``<cases>/videos2``) for the partial-data cases. ``cases`` runs every case of :data:`CASES` with the checkout this
script lies in (first on ``PYTHONPATH``), each from its own empty folder, and keeps the report folder (CSV, markdown,
PNG), stdout, stderr and the exit code in ``<cases>/<into>/<case>/``.

The cases cover runs, seeds, ``--random``, ``--sweep``, ``--compare`` (with the ``--allow-*`` flags), shipped agents
(``--pretrained``), ``--videos`` and the error paths: a missing run, nothing to evaluate, contradicting options,
stand-ins and partial data refused, bad flag values (vigen's checks and the parser's), and ``--help``. Each plays 1-2
episodes of 10 control steps (the
``--compare`` cases: the protocol's 1000, as the runs were trained). Outputs are made deterministic: progress bars off (``TQDM_DISABLE``), one thread, an
empty data cache (``VIGEN_DATA``: video levels show vigen's stand-ins), and paths relative to the case's folder.
"""

from __future__ import annotations

import argparse
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SHORT = ["--episodes", "1", "--episode-length", "10"]

CASES: dict[str, list[str]] = {
    "two_runs": ["{runs}/drqv2", "{runs}/svea", "--levels", "train", "color_hard", "--episodes", "2", "--episode-length", "10"],
    "seeds": ["{runs}/drqv2", "--levels", "train", "--seeds", "0", "1", *SHORT],
    "random": ["{runs}/drqv2", "--random", "--levels", "train", "color_easy", *SHORT],
    "sweep": ["{runs}/drqv2", "--levels", "train", "--sweep", "camera_rotation", "0", "0.2", "--sweep", "light_color", "0.5",
              *SHORT],
    "pretrained": ["--pretrained", "svea-cartpole-balance", "drqv2-cartpole-balance", "--levels", "train", "video_easy",
                   *SHORT],
    "partial_data_allowed": ["--pretrained", "svea-cartpole-balance", "--levels", "video_easy", "--videos",
                             "video_easy={cases}/videos2", "--allow-partial-data", *SHORT],
    "compare_drqv2": ["{runs}/drqv2", "--compare", "drqv2", "--allow-budget-mismatch", "--allow-recipe-mismatch",
                      "--episodes", "1"],
    "compare_madi_allowed": ["{runs}/svea", "--compare", "madi", "--allow-budget-mismatch", "--allow-stand-ins",
                             "--allow-recipe-mismatch", "--episodes", "1"],
    "error_stand_ins_refused": ["{runs}/svea", "--compare", "dmcgb", "--allow-budget-mismatch", "--allow-recipe-mismatch",
                                "--episodes", "1"],
    "error_protocol_mismatch": ["{runs}/drqv2", "--compare", "dmcgb", "--allow-stand-ins", "--episodes", "1"],
    "error_partial_data_refused": ["--pretrained", "svea-cartpole-balance", "--levels", "video_easy", "--videos",
                                   "video_easy={cases}/videos2", *SHORT],
    "error_missing_run": ["{runs}/no-such-run", "--levels", "train", *SHORT],
    "error_nothing_to_evaluate": ["--levels", "train"],
    "error_workers_without_ray": ["{runs}/drqv2", "--workers", "2", *SHORT],
    "error_sweep_without_intensities": ["{runs}/drqv2", "--sweep", "camera_rotation", *SHORT],
    "error_parser_bad_value": ["{runs}/drqv2", "--episodes", "two"],
    "help": ["--help"],
}
"""Each case's arguments; ``{runs}`` and ``{cases}`` are filled in. ``help`` and the parser's own errors are the cases
whose text may change with the command-line library."""

RUNS = {
    "drqv2": ["--algo", "drqv2", "--protocol", "drqv2"],
    "svea": ["--algo", "svea", "--protocol", "dmcgb"],
}
TINY = ["--env", "dmc/cartpole-balance", "--frames", "800", "--eval-every", "400", "--eval-episodes", "1", "--seed-frames", "80", "--batch-size", "4", "--buffer-size", "200", "--hidden-dim", "16",
        "--feature-dim", "8", "--update-every", "1", "--threads", "1", "--device", "cpu"]


def environment(cases: Path) -> dict[str, str]:
    empty = cases / "empty-data-cache"
    empty.mkdir(parents=True, exist_ok=True)
    python_path = os.pathsep.join(filter(None, [str(ROOT), os.environ.get("PYTHONPATH")]))
    return dict(os.environ, PYTHONPATH=python_path, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", TQDM_DISABLE="1",
                VIGEN_DATA=str(empty), MUJOCO_GL=os.environ.get("MUJOCO_GL", "egl"), PYTHONHASHSEED="0", COLUMNS="120")


def make_runs(cases: Path) -> None:
    runs = cases / "runs"
    for name, flags in RUNS.items():
        if (runs / name).exists():
            print(f"{runs / name} exists; kept")
            continue
        command = [sys.executable, str(ROOT / "examples" / "train.py"), *flags, *TINY, "--out", str(runs / name)]
        result = subprocess.run(command, env=environment(cases), capture_output=True, text=True)
        if result.returncode != 0:
            raise SystemExit(f"train.py {name} failed:\n{result.stderr[-3000:]}")
        print(f"trained {runs / name}")
    videos = cases / "videos2"
    if not videos.exists():
        import cv2
        import numpy as np

        videos.mkdir(parents=True)
        for index in range(2):
            writer = cv2.VideoWriter(str(videos / f"video{index}.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 25, (32, 32))
            for frame in range(4):
                writer.write(np.full((32, 32, 3), 40 + 60 * index + 10 * frame, np.uint8))
            writer.release()


def run_cases(cases: Path, into: Path, only: list[str] | None) -> None:
    into.mkdir(parents=True, exist_ok=True)
    for name, template in CASES.items():
        if only and name not in only:
            continue
        folder = into / name
        if folder.exists():
            shutil.rmtree(folder)
        folder.mkdir()
        argv = [arg.format(runs=cases / "runs", cases=cases) for arg in template]
        if name != "help" and "--out" not in argv:
            argv += ["--out", "report"]
        started = time.perf_counter()
        result = subprocess.run([sys.executable, str(ROOT / "examples" / "evaluate.py"), *argv], cwd=folder,
                                env=environment(cases), capture_output=True)
        (folder / "stdout.txt").write_bytes(result.stdout)
        (folder / "stderr.txt").write_bytes(result.stderr)
        (folder / "exit_code.txt").write_text(f"{result.returncode}\n")
        print(f"{name}: exit {result.returncode} in {time.perf_counter() - started:.0f} s", flush=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("what", choices=["runs", "cases"])
    parser.add_argument("--cases", type=Path, required=True, help="the folder of the runs, the videos and the results")
    parser.add_argument("--into", default="before", help="the results' subfolder of --cases (cases)")
    parser.add_argument("--only", nargs="+", help="run these cases only")
    args = parser.parse_args()
    if args.what == "runs":
        make_runs(args.cases.absolute())
    else:
        run_cases(args.cases.absolute(), args.cases.absolute() / args.into, args.only)


if __name__ == "__main__":
    main()

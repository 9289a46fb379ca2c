"""The parity tool's command line (``python -m benchmarks.parity``, from the repository root; see the package's docstring)."""

from __future__ import annotations

import argparse
import sys
import time
import warnings
from collections.abc import Sequence
from pathlib import Path

import torch

from benchmarks import parity
from benchmarks.parity.algorithms import ALGORITHMS, ORIGINALS
from benchmarks.parity.harness import Draws, Setup, compare, copy_weights, float64_mode, report, run_original, run_vigen


def parse_references(values: Sequence[str], algos: Sequence[str]) -> dict[str, Path]:
    """``PATH`` gives every algorithm its reference, ``NAME=PATH`` one algorithm (it wins over ``PATH``)."""
    default: Path | None = None
    per_algo: dict[str, Path] = {}
    for value in values:
        name, sep, path = value.partition("=")
        if sep and name in ALGORITHMS:
            per_algo[name] = Path(path)
        elif sep and name.isidentifier() and not Path(value).exists():
            raise ValueError(f"--reference {value!r}: {name!r} is not an algorithm; choose from {', '.join(ALGORITHMS)}.")
        else:
            default = Path(value)
    out = {algo: per_algo.get(algo, default) for algo in algos}
    return {algo: path for algo, path in out.items() if path is not None}


def select_algorithms(requested: Sequence[str] | None, references: dict[str, Path]) -> tuple[list[str], list[str]]:
    """The algorithms to run, and a note for each one left out.

    Every algorithm of ``requested`` needs a reference holding its original's files (else
    ``ValueError`` naming the fix). ``requested=None`` (no ``--algos``) runs every algorithm whose
    reference holds its original and notes the others (e.g. ``sada`` next to an RL-ViGen checkout).
    """
    run, skipped = [], []
    for algo in requested or list(ALGORITHMS):
        original, path = ORIGINALS[algo], references.get(algo)
        fix = f"give --reference {algo}=PATH to a checkout of {original.repository} ({original.url})"
        absent = list(original.files) if path is None else [f for f in original.files if not (path / f).is_file()]
        if not absent:
            run.append(algo)
            continue
        problem = "no --reference" if path is None else f"{path} has no {', '.join(absent)} (so it is no {original.repository} checkout)"
        if requested:
            raise ValueError(f"{algo}: {problem}; {fix}.")
        skipped.append(f"skipped {algo}: {problem}; {fix}.")
    if not run:
        raise ValueError("no algorithm has a checkout of its original: " + " ".join(skipped))
    return run, skipped


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.parity", description=parity.__doc__.split("\n\n")[0])
    parser.add_argument("--reference", action="append", required=True,
                        help="checkout of the original repository: PATH (every algorithm) or NAME=PATH (one); repeatable")
    parser.add_argument("--algos", nargs="+", choices=list(ALGORITHMS),
                        help="default: every algorithm whose --reference holds its original")
    parser.add_argument("--pythonpath", action="append", default=[], help="extra import directory for the originals' dependencies (e.g. captum)")
    parser.add_argument("--tolerance", type=float, default=1e-10, help="max relative difference counted as equal")
    parser.add_argument("--batch-size", type=int, default=Setup.batch_size)
    parser.add_argument("--seed", type=int, default=Setup.seed)
    args = parser.parse_args(argv)
    sys.path[1:1] = args.pythonpath
    try:
        references = parse_references(args.reference, args.algos or list(ALGORITHMS))
    except ValueError as error:
        parser.error(str(error))
    for algo, path in references.items():
        if not path.is_dir():
            parser.error(f"--reference for {algo}: {path} is not a directory; give a plain checkout of the original repository.")
    try:
        algos, skipped = select_algorithms(args.algos, references)
    except ValueError as error:
        parser.error(str(error))
    # the originals' deprecation notices and TorchRL's note on target parameters without an updater
    warnings.filterwarnings("ignore", category=UserWarning, message=".*(upsample|target network updater|required_grads|backward hooks on ReLU).*")
    torch.set_num_threads(1)
    setup = Setup(batch_size=args.batch_size, seed=args.seed)
    print(f"# vigen parity: one update in float64, batch {setup.batch_size}, {setup.image_size}×{setup.image_size}×"
          f"{setup.channels}, action dim {setup.action_dim}, hidden {setup.hidden_dim}, feature {setup.feature_dim}, step {setup.step}")
    print("rel. diff = max|vigen − original| / max|original| per quantity (gradients: over the tensor; the value "
          "columns show its L2 norm). The original's optimizer steps are recorded, not taken; 'steps taken' "
          "compares against its real sequential update.")
    for note in skipped:
        print(note)
    results = {}
    for name in algos:
        start = time.perf_counter()
        torch.manual_seed(setup.seed)
        with float64_mode():
            case = ALGORITHMS[name](references[name], setup)
            copy_weights(case)
            draws = Draws(setup.seed)
            fixed = run_original(case, draws, take_steps=False)
            stepped = run_original(case, draws, take_steps=True)
            ours = run_vigen(case, draws)
            measured = [measure(fixed.agent, case.loss) for measure in case.measures]
        rows = compare(case, fixed, stepped, ours)
        results[name] = report(case, rows, fixed, ours, time.perf_counter() - start, args.tolerance, measured)
    print("\n" + " ".join(f"{n}: {'OK' if ok else 'MISMATCH'}" for n, ok in results.items()))
    return 0 if all(results.values()) else 1

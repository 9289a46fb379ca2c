"""vigen's statistics against rliable's own functions on random score matrices (ties included).

    pip install --no-deps --target /tmp/rl rliable
    python benchmarks/rliable_parity.py --rliable /tmp/rl --trials 200

rliable (https://github.com/google-research/rliable, archived) imports the ``arch`` package for
its bootstrap classes; the point estimates compared here do not use them, so ``arch`` is replaced
by an empty stand-in when it is not installed. Prints the largest absolute difference per statistic.
"""

from __future__ import annotations

import argparse
import sys
import types

import numpy as np

from vigen.evaluation import iqm, performance_profile, probability_of_improvement


def import_rliable(path: str | None):
    if path:
        sys.path.insert(0, path)
    try:
        import arch.bootstrap  # noqa: F401
    except ImportError:  # only rliable's bootstrap classes need it
        bootstrap = types.ModuleType("arch.bootstrap")
        bootstrap.IIDBootstrap = bootstrap.IndependentSamplesBootstrap = object
        sys.modules["arch"], sys.modules["arch.bootstrap"] = types.ModuleType("arch"), bootstrap
    from rliable import library, metrics

    return library, metrics


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rliable", default=None, help="a folder holding the rliable package (pip install --target)")
    parser.add_argument("--trials", type=int, default=200)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    library, metrics = import_rliable(args.rliable)
    rng = np.random.default_rng(args.seed)
    worst = {"probability_of_improvement": 0.0, "iqm": 0.0, "performance_profile": 0.0}
    taus = np.linspace(0.0, 800.0, 17)
    for _ in range(args.trials):
        x = rng.integers(0, 8, size=(int(rng.integers(2, 8)), 4)).astype(float) * 100  # coarse values: many ties
        y = rng.integers(0, 8, size=(int(rng.integers(2, 8)), 4)).astype(float) * 100
        worst["probability_of_improvement"] = max(worst["probability_of_improvement"],
                                                  abs(metrics.probability_of_improvement(x, y) - probability_of_improvement(x, y)))
        worst["iqm"] = max(worst["iqm"], abs(metrics.aggregate_iqm(x) - iqm(x)))
        theirs = np.array([library.run_score_deviation(x, tau) for tau in taus])
        worst["performance_profile"] = max(worst["performance_profile"], float(np.abs(theirs - performance_profile(x, taus)).max()))
    for name, difference in worst.items():
        print(f"{name:28s} max |vigen - rliable| = {difference:.1e} over {args.trials} random score matrices")


if __name__ == "__main__":
    main()

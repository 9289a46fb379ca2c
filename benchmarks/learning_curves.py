"""Plot learning curves of examples/train.py runs next to DrQ-v2's published curves, and tabulate them.

    python benchmarks/learning_curves.py runs/drqv2-cartpole-balance-s1 runs/svea-cartpole-balance-s1 \\
        --published ../shared/data/drqv2_curves/dmc_cartpole_balance.csv --out docs/learning_check_curve

Writes ``<out>.png`` (evaluation return against environment frames; the published curve as its
seed mean with the min–max band over seeds) and ``<out>.md`` (the same numbers as a table).
Existing files are not overwritten. The published CSVs (facebookresearch/drqv2 ``curves/``) have
columns agent, task, seed, frame, episode_reward; they are optional.
"""

from __future__ import annotations

import argparse
import csv
import json
from collections import defaultdict
from pathlib import Path

import numpy as np

from vigen.io import unused_path


def run_curve(run_dir: Path) -> tuple[str, dict[int, float]]:
    config = json.loads((run_dir / "config.json").read_text())
    rows = csv.reader((run_dir / "logs" / "scalars" / "eval" / "train_return.csv").open())
    label = f"vigen {config['algo']} (batch {config['batch_size']}, seed {config['seed']})"
    return label, {int(float(frame)): float(value) for frame, value in rows}


def published_curve(path: Path, max_frame: int) -> dict[int, list[float]]:
    by_frame: dict[int, list[float]] = defaultdict(list)
    for row in csv.DictReader(path.open()):
        if int(row["frame"]) <= max_frame:
            by_frame[int(row["frame"])].append(float(row["episode_reward"]))
    return dict(sorted(by_frame.items()))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("runs", nargs="+", type=Path)
    parser.add_argument("--published", type=Path, default=None, help="a DrQ-v2 curves CSV (optional)")
    parser.add_argument("--out", type=Path, default=Path("docs/learning_check_curve"))
    args = parser.parse_args()

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    curves = dict(run_curve(run) for run in args.runs)
    max_frame = max(max(curve) for curve in curves.values())
    published = published_curve(args.published, max_frame) if args.published and args.published.exists() else {}

    figure, axes = plt.subplots(figsize=(5.5, 3.4))
    if published:
        frames = list(published)
        values = [np.array(v) for v in published.values()]
        axes.fill_between(frames, [v.min() for v in values], [v.max() for v in values], color="0.85", label="_")
        axes.plot(frames, [v.mean() for v in values], color="0.4", marker="o",
                  label=f"DrQ-v2 published (batch 256, mean of {len(values[0])} seeds, min–max)")
    for label, curve in curves.items():
        axes.plot(list(curve), list(curve.values()), marker="o", label=label)
    axes.set_xlabel("environment frames")
    axes.set_ylabel("evaluation return")
    axes.spines[["top", "right"]].set_visible(False)
    axes.legend(frameon=False, fontsize="small", loc="upper left")
    figure.tight_layout()
    png = unused_path(args.out.with_suffix(".png"))
    png.parent.mkdir(parents=True, exist_ok=True)
    figure.savefig(png, dpi=120)

    frames = sorted({frame for curve in curves.values() for frame in curve} | set(published))
    header = ["frames", *curves] + (["DrQ-v2 published mean [min, max]"] if published else [])
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for frame in frames:
        cells = [str(frame)] + [f"{curve[frame]:.0f}" if frame in curve else "" for curve in curves.values()]
        if published:
            v = np.array(published.get(frame, [np.nan]))
            cells.append(f"{v.mean():.0f} [{v.min():.0f}, {v.max():.0f}]" if frame in published else "")
        lines.append("| " + " | ".join(cells) + " |")
    table = unused_path(args.out.with_suffix(".md"))
    table.write_text("\n".join(lines) + "\n")
    print("\n".join(lines))
    print(f"\nwrote {png} and {table}")


if __name__ == "__main__":
    main()

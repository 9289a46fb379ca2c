"""Add an exported agent to the ones vigen ships, with its zero-shot evaluation table in its provenance.

The agent is a ``.pt`` written by ``vigen.pretrained.export_policy`` (its ``.json`` beside it); the
table is read from the rows of ``examples/evaluate.py`` (``episodes.csv``) that evaluated that very
file: the rows of ``--method`` and ``--run``. The weights are copied unchanged, once
``vigen.pretrained`` has loaded them (their SHA-256 checked against the provenance); the
provenance gains ``name``, ``evaluation`` (per level: the episodes' returns, their mean and
sample std, and what the level showed: the rows' ``data`` and ``stand_in``) and ``evaluation_command``.

    python scripts/ship_agent.py runs/gpu/drqv2-s0.pt docs/results/cartpole-balance/episodes.csv \\
        --method drqv2 --run 0 --name drqv2-cartpole-balance --evaluation-command "python examples/evaluate.py ..."

``--reevaluate`` replaces the table of an agent already shipped (its weights are not touched; the
file given must be that agent's ``.pt``). The table it replaces is kept, with ``--note`` saying
why, under ``earlier_evaluations``: nothing a record held is lost.

    python scripts/ship_agent.py vigen/pretrained/agents/svea-cartpole-balance.pt episodes.csv --method svea --run 0 \\
        --name svea-cartpole-balance --reevaluate --note "..." --evaluation-command "python examples/evaluate.py ..."
"""

from __future__ import annotations

import argparse
import csv
import json
import statistics
from pathlib import Path

from vigen.run.checkpoint import CheckpointError
from vigen.io import atomic_write
from vigen.pretrained import AGENTS, info, load_policy


def evaluation_table(episodes: Path, method: str, run: int) -> list[dict]:
    """Per level, in the rows' order: the returns of ``method``'s run ``run``, their mean and sample std."""
    returns: dict[str, list[float]] = {}
    shown: dict[str, dict[str, object]] = {}
    with open(episodes, newline="") as file:
        for row in csv.DictReader(file):
            if row["method"] == method and row["run"] == str(run):
                returns.setdefault(row["level"], []).append(float(row["return"]))
                if "data" in row:
                    shown[row["level"]] = {"data": row["data"], "stand_in": row["stand_in"] == "True"}
    if not returns:
        raise SystemExit(f"{episodes}: no rows of method {method!r}, run {run}.")
    return [{"level": level, "episodes": len(values), "mean": statistics.fmean(values),
             "std": statistics.stdev(values) if len(values) > 1 else 0.0, "returns": values, **shown.get(level, {})}
            for level, values in returns.items()]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("weights", type=Path, help="the exported .pt (its .json beside it)")
    parser.add_argument("episodes", type=Path, help="episodes.csv of the evaluation of that file")
    parser.add_argument("--method", required=True)
    parser.add_argument("--run", type=int, required=True)
    parser.add_argument("--name", required=True, help="the shipped agent's name")
    parser.add_argument("--evaluation-command", required=True, help="the command that wrote the rows")
    parser.add_argument("--into", type=Path, default=AGENTS, help="the agents folder (default: vigen's)")
    parser.add_argument("--reevaluate", action="store_true",
                        help="replace the evaluation table of the shipped agent --name (weights untouched; the old table "
                             "kept under earlier_evaluations)")
    parser.add_argument("--note", default="", help="with --reevaluate: why the table is replaced (kept with the old table)")
    args = parser.parse_args()
    if args.reevaluate:
        reevaluate(args)
        return
    if args.weights.suffix != ".pt":
        raise SystemExit(f"{args.weights}: not a .pt file; pass the weights that export_policy wrote.")
    try:  # vigen.pretrained's own checks: the .json beside it, the checksum, the file's format
        load_policy(str(args.weights))
        record = info(str(args.weights))
    except (KeyError, CheckpointError) as error:
        raise SystemExit(f"{args.weights}: {error.args[0]}") from None
    if record["algo"] != args.method or record["seed"] != args.run:
        raise SystemExit(f"{args.weights} is {record['algo']} seed {record['seed']}, not --method {args.method} --run {args.run}.")
    target = args.into / f"{args.name}.pt"
    if target.exists() or target.with_suffix(".json").exists():
        raise SystemExit(f"{target} (or its .json) exists; remove it first to replace agent {args.name!r}.")
    record = {"name": args.name, **record, "evaluation": evaluation_table(args.episodes, args.method, args.run),
              "evaluation_command": args.evaluation_command}
    args.into.mkdir(parents=True, exist_ok=True)
    atomic_write(target, args.weights.read_bytes())
    atomic_write(target.with_suffix(".json"), json.dumps(record, indent=2) + "\n")
    print(f"shipped {args.name}: {target} ({target.stat().st_size / 1e6:.1f} MB)")


def reevaluate(args: argparse.Namespace) -> None:
    """Replace a shipped agent's evaluation table, keeping the one it replaces under ``earlier_evaluations``."""
    target = args.into / f"{args.name}.pt"
    if not target.exists():
        raise SystemExit(f"--reevaluate: {target} is not shipped; ship it first (without --reevaluate).")
    if args.weights.resolve() != target.resolve():
        raise SystemExit(f"--reevaluate: {args.weights} is not {target}; re-evaluate the shipped file itself.")
    if not args.note:
        raise SystemExit("--reevaluate: say why the table is replaced (--note), so the old one keeps its reason.")
    try:
        load_policy(str(target))  # the checksum of the weights the rows were made with
        record = info(str(target))
    except (KeyError, CheckpointError) as error:
        raise SystemExit(f"{target}: {error.args[0]}") from None
    if record["algo"] != args.method or record["seed"] != args.run:
        raise SystemExit(f"{target} is {record['algo']} seed {record['seed']}, not --method {args.method} --run {args.run}.")
    earlier = {"evaluation": record["evaluation"], "evaluation_command": record.get("evaluation_command", ""),
               "replaced_because": args.note}
    record = {**record, "evaluation": evaluation_table(args.episodes, args.method, args.run),
              "evaluation_command": args.evaluation_command,
              "earlier_evaluations": [*record.get("earlier_evaluations", []), earlier]}
    atomic_write(target.with_suffix(".json"), json.dumps(record, indent=2) + "\n")
    print(f"re-evaluated {args.name}: {len(record['evaluation'])} levels; the earlier table kept")


if __name__ == "__main__":
    main()

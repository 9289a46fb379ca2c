#!/usr/bin/env bash
# The learning check of docs/learning_check.md: DrQ-v2 and SVEA on cartpole-balance from pixels with the
# `cpu` preset (the paper's agent, batch 64), 60k frames, seed 1; then the zero-shot report and the curves
# next to DrQ-v2's published ones. About 80 minutes for DrQ-v2 and 3.5 hours for SVEA on 2 idle cores.
#   bash benchmarks/learning_check.sh [ALGOS...]     (default: drqv2 svea; run from the repository root)
set -euo pipefail
python="${VIGEN_VENV:-.venv}/bin/python"
if [ $# -eq 0 ]; then set -- drqv2 svea; fi
runs=()
for algo in "$@"; do
  run="runs/learning-check/$algo-cartpole-balance-s1"
  if [ -d "$run" ]; then  # continue a stopped run
    "$python" examples/train.py --resume "$run" --frames 60000
  else
    "$python" examples/train.py --algo "$algo" --env dmc/cartpole-balance --preset cpu --frames 60000 --seed 1 --out "$run"
  fi
  runs+=("$run")
done
"$python" examples/evaluate.py "${runs[@]}" --random --levels train color_hard video_easy video_hard camera_easy \
  --episodes 5 --out docs/learning_check_report
"$python" benchmarks/learning_curves.py "${runs[@]}" --out docs/learning_check_curve \
  --published ../shared/data/drqv2_curves/dmc_cartpole_balance.csv

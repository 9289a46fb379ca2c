#!/usr/bin/env bash
# The main job, end to end on a CPU: set up .venv, train a small DrQ-v2 agent on cartpole-balance,
# evaluate it zero-shot (with a random-policy baseline) on unseen visual levels, and write the
# report (CSV, markdown table, PNG bar plot) under outputs/demo-<time>/report/.
#   bash scripts/demo.sh [FRAMES]     (default 6000 environment frames; about 10 minutes on 2 cores, set-up included)
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
python="${VIGEN_VENV:-.venv}/bin/python"
frames="${1:-6000}"
out="outputs/demo-$(date +%Y%m%d-%H%M%S)"

"$python" examples/train.py --algo drqv2 --env dmc/cartpole-balance --preset cpu --frames "$frames" \
  --seed-frames 2000 --eval-every "$frames" --eval-episodes 1 --out "$out/run"
"$python" examples/evaluate.py "$out/run" --random --levels train color_hard video_easy camera_easy \
  --episodes 2 --out "$out/report"

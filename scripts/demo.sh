#!/usr/bin/env bash
# The main job, end to end on a CPU: set up .venv, then evaluate the agents that ship with vigen (DrQ-v2 and SVEA,
# trained on cartpole-balance; vigen.pretrained) and a random policy zero-shot on the training level and on unseen
# visual levels, and write the report (per-episode CSV, markdown tables, plots) under outputs/demo-<time>/report/.
#   bash scripts/demo.sh                    about 3.5 minutes on 2 cores once .venv exists
#   bash scripts/demo.sh --train [FRAMES]   first trains a fresh DrQ-v2 agent here (default 6000 frames: minutes, far
#                                           too few to balance the pole; docs/results/cartpole-balance/ says what
#                                           learns, and how long it takes) and evaluates it beside the shipped ones
set -euo pipefail
cd "$(dirname "$0")/.."
train=0
frames=6000
case "${1:-}" in
  "") ;;
  --train) train=1; frames="${2:-6000}" ;;
  *) echo "usage: bash scripts/demo.sh [--train [FRAMES]]" >&2; exit 2 ;;
esac
bash scripts/setup_env.sh
python="${VIGEN_VENV:-.venv}/bin/python"
out="outputs/demo-$(date +%Y%m%d-%H%M%S)"

runs=()
if [ "$train" = 1 ]; then
  "$python" examples/train.py --algo drqv2 --env dmc/cartpole-balance --preset cpu --frames "$frames" \
    --seed-frames 2000 --eval-every "$frames" --eval-episodes 1 --out "$out/run"
  runs=("$out/run")
fi
"$python" examples/evaluate.py "${runs[@]}" --pretrained drqv2-cartpole-balance svea-cartpole-balance --random \
  --levels train color_hard video_hard --episodes 3 --out "$out/report"

#!/usr/bin/env bash
# The tests: set up .venv with every extra (so the extras are tested together), then run the whole suite (extra arguments go to pytest).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh all
exec "${VIGEN_VENV:-.venv}/bin/python" -m pytest "$@"

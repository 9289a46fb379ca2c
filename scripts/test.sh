#!/usr/bin/env bash
# The tests: set up .venv with every extra (so the extras are tested together), then run the whole suite (extra arguments
# go to pytest) on one pytest-xdist worker per core, at most 4 (VIGEN_TEST_WORKERS=0 runs them in this process).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh all
exec "${VIGEN_VENV:-.venv}/bin/python" -m pytest -n "${VIGEN_TEST_WORKERS:-auto}" --maxprocesses 4 --dist loadgroup "$@"

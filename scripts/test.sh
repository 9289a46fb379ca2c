#!/usr/bin/env bash
# The tests: set up .venv with the test extra, then run the whole suite (extra arguments go to pytest).
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh test
exec "${VIGEN_VENV:-.venv}/bin/python" -m pytest "$@"

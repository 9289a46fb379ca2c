#!/usr/bin/env bash
# Create (or reuse) the project's virtual environment and install vigen into it.
#   bash scripts/setup_env.sh [EXTRAS]      e.g. EXTRAS=test, or all
# VIGEN_VENV picks the venv folder (default .venv), PYTHON the interpreter that creates it.
set -euo pipefail
cd "$(dirname "$0")/.."
venv="${VIGEN_VENV:-.venv}"
extras="${1:-}"
if [ ! -x "$venv/bin/python" ]; then
  "${PYTHON:-python3}" -m venv "$venv"
fi
# torch first and exactly: a bare "torch" requirement would pull a multi-GB CUDA build on Linux, and CI stays on one
# version, the top of setup.py's range (2.11 to 2.13; docs/testing.md says how the lowest was tested).
# An already installed 2.13.0 build (CPU or CUDA) satisfies this and is kept.
"$venv/bin/python" -m pip install --quiet "torch==2.13.0"
"$venv/bin/python" -m pip install --quiet -e ".${extras:+[$extras]}"

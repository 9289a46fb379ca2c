#!/usr/bin/env bash
# The main job: set up .venv, then render dm_control pixel envs through vigen into outputs/render_env.png.
set -euo pipefail
cd "$(dirname "$0")/.."
bash scripts/setup_env.sh
exec "${VIGEN_VENV:-.venv}/bin/python" examples/render_env.py "$@"

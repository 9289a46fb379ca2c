"""The main job: examples/render_env.py writes a PNG grid of what the agent sees, never over a saved file."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import pytest

ROOT = Path(__file__).resolve().parents[2]


def run_example(out: Path) -> str:
    cmd = [sys.executable, str(ROOT / "examples/render_env.py"), "--tasks", "dmc/cartpole-swingup", "dmc/walker-walk",
           "--steps", "0", "3", "--fast", "--out", str(out)]
    return subprocess.run(cmd, capture_output=True, text=True, check=True).stdout


@pytest.mark.render
def test_writes_a_grid_and_never_overwrites(tmp_path):
    out = tmp_path / "grid.png"
    assert f"wrote {out}" in run_example(out)
    grid = cv2.imread(str(out))
    assert grid.shape == (2 * 84, 2 * 84, 3)
    assert grid[:84].std() > 0 and not (grid[:84] == grid[84:]).all()

    first = out.read_bytes()
    assert f"wrote {tmp_path / 'grid-1.png'}" in run_example(out)
    assert out.read_bytes() == first

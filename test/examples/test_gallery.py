"""examples/gallery.py writes one labelled grid (rows: levels, columns: seeds) without overwriting."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import cv2
import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.render
def test_gallery_grid(tmp_path):
    out = tmp_path / "grid.png"
    cmd = [sys.executable, str(ROOT / "examples/gallery.py"), "--task", "dmc/cartpole-swingup", "--levels", "train",
           "video_hard", "--seeds", "0", "1", "--fast", "--out", str(out)]
    for expected in (out, tmp_path / "grid-1.png"):
        result = subprocess.run(cmd, capture_output=True, text=True, check=True)
        assert f"wrote {expected}: 2 levels x 2 seeds" in result.stdout
    grid = cv2.imread(str(out))
    assert grid.shape == (2 * 84 * 2, 190 + 2 * 84 * 2, 3)
    train, video = grid[: 84 * 2, 190:], grid[84 * 2 :, 190:]
    assert (train.astype(int) - video.astype(int)).__abs__().mean() > 5


def test_committed_galleries_are_readable():
    for task in ("walker-walk", "cartpole-swingup"):
        image = cv2.imread(str(ROOT / "docs" / f"gallery_{task}.png"))
        assert image is not None and image.shape[0] == 16 * 84 * 2 and image.shape[1] == 190 + 5 * 84 * 2

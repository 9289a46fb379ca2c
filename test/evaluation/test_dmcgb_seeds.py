"""Under the ``dmcgb`` protocol an evaluation plays DMC-GB's test episodes: the env seeded ``seed + 42`` as DMC-GB's
``src/eval.py:53`` / ``src/train.py:55`` seed theirs, so each episode shows the colour preset and the video DMC-GB's
wrappers (``src/env/wrappers.py``) show in that episode."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from vigen.datasets import StandInDataWarning
from vigen.evaluation import evaluate
from vigen.protocols import get_protocol

pytestmark = pytest.mark.render


def dmcgb_color_presets(seed: int, episodes: int) -> list[int]:
    """DMC-GB's ColorWrapper: ``np.random.RandomState(seed)`` made once, one ``randint(len(colors))`` per reset (100 presets)."""
    state = np.random.RandomState(seed)
    return [int(state.randint(100)) for _ in range(episodes)]


def dmcgb_videos(count: int, episodes: int) -> list[int]:
    """DMC-GB's VideoWrapper: ``_index`` starts at 0 and moves on by one before each reset's video is loaded."""
    return [(k + 1) % count for k in range(episodes)]


@pytest.mark.parametrize("seed", [0, 3])
def test_evaluation_under_dmcgb_shows_dmcgb_presets_and_videos_for_the_runs_seed(seed):
    dmcgb = get_protocol("dmcgb")
    assert dmcgb.eval_seed_offset == 42 and "env seed = seed + 42" in "\n".join(dmcgb.describe("dmc/cartpole-balance"))
    options = {**dmcgb.env_options("dmc/cartpole-balance"), "image_size": 32}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", StandInDataWarning)  # the order is what is checked; stand-ins follow it too
        rows = evaluate(None, "dmc/cartpole-balance", ["color_hard", "video_easy"], episodes=4, max_steps=2,
                        seeds=dmcgb.evaluation_seeds([seed]), env_options=options)
    color = [row for row in rows if row["level"] == "color_hard"]
    assert [row["seed"] for row in color] == [seed + 42] * 4
    assert [row["shown"] for row in color] == [f"preset={preset}" for preset in dmcgb_color_presets(seed + 42, 4)]
    assert [row["shown"] for row in color] != [f"preset={preset}" for preset in dmcgb_color_presets(seed, 4)], \
        "without the offset the episodes would be another seed's"
    video = [row["shown"].split("=", 1)[1] for row in rows if row["level"] == "video_easy"]
    count = 10
    expected = dmcgb_videos(count, 4)
    assert video == [f"procedural {index}" for index in expected] or video == [f"video{index}.mp4" for index in expected]

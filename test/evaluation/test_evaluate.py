"""evaluate(): one row per episode, levels and seeds as asked, perturbations that leave the dynamics alone."""

from __future__ import annotations

import pytest
import torch
from tensordict.nn import TensorDictModule
from torch import nn

from vigen.envs import make_env
from vigen.evaluation import evaluate


class _Constant(nn.Module):
    def forward(self, pixels: torch.Tensor) -> torch.Tensor:
        return torch.full((*pixels.shape[:-3], 1), 0.3)


def _policy() -> TensorDictModule:
    return TensorDictModule(_Constant(), in_keys=["pixels"], out_keys=["action"])


def test_rows_per_level_seed_and_episode():
    rows = evaluate(_policy(), "dmc/cartpole-balance", ["train", "color_hard"], episodes=2, seeds=[0, 1],
                    max_steps=4, tags={"method": "constant", "run": 7})
    assert [(r["level"], r["seed"], r["episode"]) for r in rows] == [
        (level, seed, episode) for level in ("train", "color_hard") for seed in (0, 1) for episode in (0, 1)]
    assert all(r["method"] == "constant" and r["run"] == 7 and r["env"] == "dmc/cartpole-balance" for r in rows)
    assert all(r["length"] == 4 and r["return"] > 0 for r in rows)
    assert "success" not in rows[0], "dm_control tasks define no success"


def test_visual_levels_keep_the_dynamics():
    """A fixed open-loop policy earns the same return on a recoloured scene with the same seed."""
    train, color = (evaluate(_policy(), "dmc/cartpole-balance", level, episodes=1, seeds=[3], max_steps=20)[0]
                    for level in ("train", "color_hard"))
    assert train["return"] == pytest.approx(color["return"])


def test_factory_and_full_episode_length():
    rows = evaluate(_policy(), lambda level, seed: make_env("dmc/cartpole-balance", seed=seed, episode_length=40),
                    "train", episodes=1)
    assert rows[0]["length"] == 20, "the env's time limit (40 control steps / action repeat 2) ends the episode"


def test_bad_arguments():
    with pytest.raises(ValueError, match="Unknown generalization level"):
        evaluate(_policy(), "dmc/cartpole-balance", ["color_harder"])
    with pytest.raises(ValueError, match="episodes"):
        evaluate(_policy(), "dmc/cartpole-balance", episodes=0)

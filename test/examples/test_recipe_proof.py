"""The proof of issue 46 on this machine: a 2,000-frame run of ``--recipe svea-dmcgb`` trains and evaluates on DMC-GB's
colour presets, then compare() sets it beside DMC-GB's published SVEA row, naming both budgets and what a flag changed.

DMC-GB's 1,000 seed steps exceed 2,000 frames (250 agent steps at cartpole's action repeat 8), so the run overrides
them with ``--seed-steps 200`` and really updates: one update per agent step after them, the actor and temperature on
every second one. To stay small it also turns off DMC-GB's catch-up (which would make the 200 seed steps' updates at
once) and trains at batch 16; config.json records the three as recipe overrides, and compare() names them.
"""

from __future__ import annotations

import csv
import json

import pytest
import torch
from in_process import run

from vigen.results import RecipeMismatch, compare


@pytest.mark.slow
@pytest.mark.render
def test_a_2000_frame_svea_dmcgb_run_sits_beside_dmcgbs_published_svea_naming_both_budgets(tmp_path):
    run_dir, report = tmp_path / "svea-dmcgb", tmp_path / "report"
    trained = run("train.py", "--recipe", "svea-dmcgb", "--env", "dmc/cartpole-swingup", "--frames", "2000", "--seed-steps",
                  "200", "--no-seed-catch-up", "--batch-size", "16", "--eval-episodes", "1", "--eval-levels", "color_hard",
                  "--threads", "1", "--out", run_dir)
    assert "recipe svea-dmcgb: SVEA as DMC-GB trains it" in trained.stdout
    assert "overridden by a flag: seed_steps = 200 (recipe: 1000)" in trained.stdout
    config = json.loads((run_dir / "config.json").read_text())
    assert (config["recipe"], config["algo"], config["protocol"], config["action_repeat"]) == ("svea-dmcgb", "svea", "dmcgb", 8)
    assert config["recipe_overrides"] == {"seed_steps": {"recipe": 1000, "flag": 200}, "batch_size": {"recipe": 128, "flag": 16},
                                          "seed_catch_up": {"recipe": True, "flag": False}}
    assert config["recipe_settings"]["optimizer.sampler.betas"] == [0.5, 0.999]
    checkpoint = torch.load(run_dir / "checkpoints" / "frames_00002000.pt", weights_only=True)
    assert (checkpoint["steps"], checkpoint["updates"]) == (250, 50), "one update per agent step after the 200 seed steps"
    groups = checkpoint["optimizer"]["param_groups"]
    assert [(group["lr"], group.get("every", 1), tuple(group["betas"])) for group in groups] == \
        [(1e-3, 1, (0.9, 0.999)), (1e-3, 2, (0.9, 0.999)), (1e-4, 2, (0.5, 0.999))]
    steps = {group.get("every", 1): int(checkpoint["optimizer"]["state"][group["params"][0]]["step"]) for group in groups}
    assert steps == {1: 50, 2: 25}, "the critic's Adam every update, the actor's and the temperature's every second"

    evaluated = run("evaluate.py", run_dir, "--compare", "dmcgb", "--levels", "color_easy", "color_hard", "--episodes", "1",
                    "--allow-budget-mismatch", "--out", report)
    (line,) = list(csv.DictReader((report / "published.csv").open()))
    assert (line["level"], line["source"], line["published_method"], line["published_recipe"], line["frames"]) == \
        ("color_hard", "dmcgb", "svea (conv)", "svea-dmcgb", "2000")
    assert line["published"] == "nan", "a number published at another budget is never set beside the run's"
    notes = line["notes"]
    assert "no published point at the run's 2,000 frames: the source publishes 4,000,000 frames (500,000 agent_steps at " \
           "action repeat 8)" in notes
    assert "(svea (conv): 837 ± 23 at 500,000 agent_steps; not set beside the run's number)" in notes, "both budgets"
    assert "recipe svea-dmcgb, the published row's; overridden in the run: batch_size 16 (recipe 128); seed_steps 200 " \
           "(recipe 1000); seed_catch_up False (recipe True); vigen departs from its code: one-step" in notes
    assert "left out, another recipe: svea on dmc/cartpole-swingup: the run was trained by recipe svea-dmcgb, dmcgb's " \
           "svea (overlay) row by code vigen has no recipe for" in notes
    assert "svea (conv)" in evaluated.stdout

    numbers = ("frames", "action_repeat", "frame_stack", "image_size", "episode_length", "run")
    rows = [{key: int(value) if key in numbers else float(value) if key == "return" else value for key, value in row.items()}
            for row in csv.DictReader((report / "episodes.csv").open())]  # as evaluate.py wrote them
    assert {(row["recipe"], row["level"]) for row in rows} == {("svea-dmcgb", "color_easy"), ("svea-dmcgb", "color_hard")}
    lines = compare(rows, source="dmcgb", protocol="dmcgb", allow_budget_mismatch=True)
    assert [(line["level"], line["published_method"], line["frames"]) for line in lines] == [("color_hard", "svea (conv)", 2000)]
    plain = [dict(row, recipe="", recipe_overrides="") for row in rows]  # the same rows, had the run named no recipe
    with pytest.raises(RecipeMismatch, match="the run was trained by no recipe"):
        compare(plain, source="dmcgb", protocol="dmcgb", allow_budget_mismatch=True)

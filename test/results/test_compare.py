"""compare(): a run beside the published numbers only under the same protocol, settings, budget and unit."""

from __future__ import annotations

import math

import pytest

from vigen.results import PartialData, ProtocolMismatch, RecipeMismatch, StandInRows, compare, published
from vigen.run import RECIPES


def rows(method="svea", env="dmc/walker-stand", level="video_hard", frames=2_000_000, returns=(800.0, 900.0), **settings):
    settings = {"action_repeat": 4, "frame_stack": 3, "image_size": 84, "episode_length": 1000, **settings}
    return [{"method": method, "env": env, "level": level, "run": run, "frames": frames, "return": value, **settings}
            for run, value in enumerate(returns)]


def test_a_run_under_the_protocol_sits_beside_every_source_of_it():
    lines = compare(rows(), source=["sgqn", "madi", "simgrl"], protocol="dmcgb", allow_recipe_mismatch=True)
    assert [(line["source"], line["published"]) for line in lines] == [("sgqn", 747.0), ("madi", 847.0), ("simgrl", 834.0)]
    line = lines[0]
    assert (line["runs"], line["mean"], line["std"]) == (2, 850.0, pytest.approx(math.sqrt(5000.0)))
    assert line["difference"] == pytest.approx(103.0) and line["published_spread"] == 43.0 and line["budget_matches"]
    assert line["published_frames"] == 2_000_000, "500k agent steps at action repeat 4"
    assert line["notes"].startswith("the run was trained by no recipe (vigen's algorithm defaults), the published row by "
                                    "code vigen has no recipe for (SGQN's table comes from its own fork of DMC-GB")
    assert line["notes"].endswith("published from another implementation of svea than vigen's svea"), \
        "SGQN's SVEA is DMC-GB's SAC-based one; vigen's svea is RL-ViGen's DrQ-v2-based one"


def test_rows_of_an_unverified_source_say_so_on_every_line():
    lines = compare(rows(), source=["sgqn", "simgrl"], protocol="dmcgb", allow_recipe_mismatch=True)
    notes = {line["source"]: line["notes"] for line in lines}
    assert "unverified" not in notes["sgqn"]
    assert "simgrl's rows are unverified: no table could be found" in notes["simgrl"]
    assert all(not row.verified for row in published(source="simgrl"))
    assert all(row.verified for row in published(source=["sgqn", "madi", "dmcgb", "dmcgb2"]))


MADI_NOTE = ("recipe madi-dmcgb, the published row's; vigen departs from its code: one-step, conv-init, uint8-overlay, phase "
             "(docs/recipes.md)")


def test_a_run_trained_with_another_batch_is_marked():
    """Against the batch of the code behind the row: its recipe's (MaDi's arguments.py: 64), else the protocol's code's."""
    at_paper_batch = compare(rows(method="madi", batch_size=128, recipe="madi-dmcgb"), source="madi", protocol="dmcgb")[0]
    assert at_paper_batch["notes"] == f"batch: run 128, recipe madi-dmcgb's 64; {MADI_NOTE}"
    assert compare(rows(method="madi", batch_size=64, recipe="madi-dmcgb"), source="madi", protocol="dmcgb")[0]["notes"] == MADI_NOTE
    assert compare(rows(method="madi", recipe="madi-dmcgb"), source="madi", protocol="dmcgb")[0]["notes"] == MADI_NOTE, \
        "rows without the column"
    sgqn = compare(rows(batch_size=64), source="sgqn", protocol="dmcgb", allow_recipe_mismatch=True)[0]
    assert "batch: run 64, dmcgb's code 128" in sgqn["notes"], "no recipe behind SGQN's rows: DMC-GB's arguments.py, 128"
    drqv2 = [dict(row, level="train", frames=40_000, action_repeat=2, batch_size=512, recipe="drqv2")
             for row in rows(method="drqv2")]
    assert compare(drqv2, source="drqv2", protocol="drqv2")[0]["notes"] == \
        "recipe drqv2, the published row's; vigen departs from its code: one-step (docs/recipes.md)", \
        "DrQ-v2's cfgs/task/walker_stand.yaml trains with batch 512"
    at_256 = [dict(row, batch_size=256) for row in drqv2]
    assert compare(at_256, source="drqv2", protocol="drqv2")[0]["notes"].startswith("batch: run 256, recipe drqv2's 512")


def test_a_run_of_the_rows_recipe_is_noted_with_its_departures_and_not_as_another_implementation():
    line = compare(rows(method="madi", recipe="madi-dmcgb"), source="madi", protocol="dmcgb")[0]
    assert (line["published"], line["notes"], line["published_recipe"]) == (824.0, MADI_NOTE, "madi-dmcgb")


def test_a_run_of_another_recipe_is_refused_unless_asked_and_then_every_differing_setting_is_named():
    """vigen's svea (RL-ViGen's DrQ-v2-based SVEA) is not DMC-GB's SAC SVEA that produced DMC-GB's row."""
    run = rows(env="dmc/walker-walk", level="color_hard", recipe="svea-rlvigen")
    with pytest.raises(RecipeMismatch) as caught:
        compare(run, source="dmcgb", protocol="dmcgb")
    assert caught.value.differences == [
        "svea on dmc/walker-walk: the run was trained by recipe svea-rlvigen, dmcgb's svea (conv) row by recipe svea-dmcgb "
        "(color_hard)",
        "svea on dmc/walker-walk: the run was trained by recipe svea-rlvigen, dmcgb's svea (overlay) row by code vigen has "
        "no recipe for (vigen has no recipe for DMC-GB's CURL, RAD, PAD, SODA and DrQ (vigen's curl and drq are RL-ViGen's), "
        "nor for SVEA with the overlay (DMC-GB's svea.py at ff9c0aa draws random convolutions only)) (color_hard)"]
    assert "--recipe NAME" in str(caught.value) and "allow_recipe_mismatch=True" in str(caught.value)
    conv = compare(run, source="dmcgb", protocol="dmcgb", allow_recipe_mismatch=True)[0]
    assert conv["published_method"] == "svea (conv)" and conv["published"] == 760.0
    for setting in ("batch_size: 512 in the run, 128 in svea-dmcgb", "lr: 0.0001 in the run, 0.001 in svea-dmcgb",
                    "actor_update_every: not set in the run, 2 in svea-dmcgb",
                    "loss.sampler_type: not set in the run, squashed_gaussian in svea-dmcgb"):
        assert setting in conv["notes"], setting
    assert conv["notes"].endswith("published from another implementation of svea (conv) than vigen's svea")


def test_the_row_of_the_runs_recipe_is_shown_and_the_others_are_left_out_saying_so():
    """DMC-GB publishes SVEA with random convolution (svea-dmcgb) and with the overlay (no recipe)."""
    run = rows(env="dmc/walker-walk", level="color_hard", recipe="svea-dmcgb",
               recipe_overrides='{"seed_steps": {"recipe": 1000, "flag": 10}}')
    (line,) = compare(run, source="dmcgb", protocol="dmcgb")
    assert line["published_method"] == "svea (conv)" and line["published_recipe"] == "svea-dmcgb"
    assert line["notes"].startswith("recipe svea-dmcgb, the published row's; overridden in the run: seed_steps 10 "
                                    "(recipe 1000); vigen departs from its code: one-step, catch-up-updates, conv-init, "
                                    "not-parity-measured (docs/recipes.md)")
    assert "left out, another recipe: svea on dmc/walker-walk: the run was trained by recipe svea-dmcgb, dmcgb's svea " \
           "(overlay) row by code vigen has no recipe for" in line["notes"]
    assert set(RECIPES["svea-dmcgb"].departures) == {"one-step", "catch-up-updates", "conv-init", "not-parity-measured"}


def test_every_differing_setting_is_named():
    with pytest.raises(ProtocolMismatch) as caught:
        compare(rows(action_repeat=2, frame_stack=1, image_size=64, episode_length=500), source="sgqn", protocol="dmcgb")
    assert caught.value.differences == [
        "dmc/walker-stand: action repeat 2 in the run, 4 in protocol dmcgb",
        "dmc/walker-stand: frame stack 1 in the run, 3 in protocol dmcgb",
        "dmc/walker-stand: image size 64 in the run, 84 in protocol dmcgb",
        "dmc/walker-stand: episode length 500 in the run, 1000 in protocol dmcgb"]
    assert str(caught.value).endswith("Train with the settings of protocol dmcgb (examples/train.py --protocol dmcgb).")


def test_rows_without_their_settings_cannot_be_compared():
    bare = [{key: value for key, value in row.items() if key not in ("frame_stack", "image_size")} for row in rows()]
    with pytest.raises(ProtocolMismatch, match="rows without a 'frame_stack' column"):
        compare(bare, source="sgqn", protocol="dmcgb")


def test_another_protocols_run_or_source_is_refused():
    with pytest.raises(ProtocolMismatch, match="trained under protocol rlvigen, the published numbers under dmcgb"):
        compare(rows(protocol="rlvigen"), source="sgqn", protocol="dmcgb")
    with pytest.raises(ProtocolMismatch, match="source dmcgb2 publishes under protocol dmcgb2, the run follows dmcgb(.|\n)*"
                                               "Drop dmcgb2 or compare under its protocol"):
        compare(rows(), source=["sgqn", "dmcgb2"], protocol="dmcgb")


def test_a_level_vigen_only_approximates_is_noted():
    """DMC-GB2 shows its videos on an in-simulation cube, in its own order; vigen's video_hard does so only with the
    protocol's level_options (evaluate(..., protocol="dmcgb2")), which the rows' level_options column records."""
    run = rows(method="sada", env="dmc/walker-walk", frames=1_000_000, action_repeat=2, recipe="sada-dmcgb2")
    line = compare(run, source="dmcgb2", protocol="dmcgb2")[0]
    assert line["published"] == 270.0 and "; video_hard differs: vigen resizes the video frames" in line["notes"]
    assert "played without dmcgb2's level_options {'draw': 'dmcgb2', 'screen': True}" in line["notes"]
    played = [dict(row, level_options='{"draw": "dmcgb2", "screen": true}') for row in run]
    assert "played without" not in compare(played, source="dmcgb2", protocol="dmcgb2")[0]["notes"]
    rotated = compare([dict(row, level="rotate_hard") for row in run], source="dmcgb2", protocol="dmcgb2")[0]
    assert rotated["notes"] == "recipe sada-dmcgb2, the published row's; vigen departs from its code: one-step (docs/recipes.md)"


def test_frames_and_agent_steps_are_never_mixed():
    """A run of 500k frames at action repeat 4 has 125k agent steps: not DMC-GB's 500k agent steps."""
    with pytest.raises(ProtocolMismatch, match="checkpoint is at 500,000 frames; sgqn publish.* at 2,000,000 frames"):
        compare(rows(frames=500_000), source="sgqn", protocol="dmcgb", allow_recipe_mismatch=True)
    lines = compare(rows(frames=500_000), source="sgqn", protocol="dmcgb", allow_budget_mismatch=True,
                    allow_recipe_mismatch=True)
    assert lines[0]["frames"] == 500_000 and lines[0]["published_frames"] is None
    assert math.isnan(lines[0]["published"]) and math.isnan(lines[0]["difference"]), "no number from another budget"
    assert lines[0]["notes"].startswith("no published point at the run's 500,000 frames: the source publishes 2,000,000")
    assert "(svea: 747 ± 43 at 500,000 agent_steps; not set beside the run's number)" in lines[0]["notes"], "both budgets"


def test_drqv2_curves_are_matched_at_the_runs_frame_count():
    run = rows(method="drqv2", env="dmc/cartpole-balance", level="train", frames=40_000, action_repeat=2, recipe="drqv2")
    line = compare(run, source="drqv2", protocol="drqv2")[0]
    expected = published(source="drqv2", task="cartpole-balance", budget=40_000, statistic="mean")[0]
    assert (line["published"], line["published_frames"], line["published_seeds"]) == (expected.value, 40_000, 10)
    between = compare([dict(row, frames=30_000) for row in run], source="drqv2", protocol="drqv2")[0]
    at_20k, at_40k = (published(source="drqv2", task="cartpole-balance", budget=budget, statistic="mean")[0].value
                      for budget in (20_000, 40_000))
    assert between["published"] == pytest.approx(at_20k + (30_000 - 20_000) / (40_000 - 20_000) * (at_40k - at_20k))
    assert between["published_frames"] == 30_000 and between["budget_matches"] is False
    assert between["notes"].startswith("published mean interpolated linearly between 20,000 frames")
    assert between["where"] == ("interpolated between curves/dmc_cartpole_balance.csv, frame 20000 and "
                                "curves/dmc_cartpole_balance.csv, frame 40000"), "not the first cell's 'frame 0'"
    assert line["where"] == "curves/dmc_cartpole_balance.csv, frame 40000", "a point at the run's budget names its own"
    last = max(row.frames(2) for row in published(source="drqv2", task="cartpole-balance", statistic="mean"))
    with pytest.raises(ProtocolMismatch, match="publish.* train at 0, 20,000, 40,000.*none at or around"):
        compare([dict(row, frames=last + 10_000) for row in run], source="drqv2", protocol="drqv2")


def test_success_rates_compare_with_published_success_in_percent():
    run = [{"method": "vrl3", "env": "adroit/door", "level": "camera_easy", "run": r, "frames": 100, "success": s,
            "return": 0.0, "action_repeat": 2, "frame_stack": 3, "image_size": 84, "recipe": "vrl3-rlvigen"}
           for r, s in enumerate([1.0, 0.0])]
    line = compare(run, source="rlvigen", protocol="rlvigen", value="success")[0]
    seeds = [row.value for row in published(source="rlvigen", method="vrl3", task="door", level="camera_easy")]
    assert line["mean"] == 50.0 and line["published"] == pytest.approx(sum(seeds) / 5) and line["published_seeds"] == 5
    assert line["published_frames"] is None and line["budget_matches"] is None, "RL-ViGen's sheet does not state its budget"
    assert line["notes"].startswith("budget not published; recipe vrl3-rlvigen, the published row's")
    assert line["published_statistic"] == "seed" and line["published_recipe"] == "vrl3-rlvigen"
    pieg = [dict(row, method="pieg", recipe="pieg-rlvigen") for row in run]
    with pytest.raises(RecipeMismatch, match="pieg-rlvigen does not cover the adroit suite"):
        compare(pieg, source="rlvigen", protocol="rlvigen", value="success")  # RL-ViGen's Adroit PIE-G: another branch's configs
    with pytest.raises(ProtocolMismatch, match="sgqn publish.* no success"):
        compare([dict(row, success=1.0) for row in rows()], source="sgqn", protocol="dmcgb", value="success")


def test_nothing_published_for_the_rows_says_what_is():
    with pytest.raises(ValueError, match="publish.* nothing for the rows"):
        compare(rows(method="random"), source="sgqn", protocol="dmcgb")
    with pytest.raises(KeyError, match="lack the column"):
        compare([{"method": "svea"}], source="sgqn", protocol="dmcgb")


def test_stand_in_rows_are_refused_unless_asked_for_and_then_labelled():
    run = [dict(row, data="procedural stand-in videos (10)", stand_in=True) for row in rows()]
    with pytest.raises(StandInRows, match="video_hard: procedural stand-in videos \\(10\\)(.|\n)*allow_stand_ins=True"):
        compare(run, source="sgqn", protocol="dmcgb")
    line = compare(run, source="sgqn", protocol="dmcgb", allow_stand_ins=True, allow_recipe_mismatch=True)[0]
    assert "vigen showed stand-ins (procedural stand-in videos (10)) where the source showed its own data" in line["notes"]
    as_read = [dict(row, stand_in="True") for row in run]  # as a CSV reads the rows back
    with pytest.raises(StandInRows):
        compare(as_read, source="sgqn", protocol="dmcgb")
    real = [dict(row, data="dmcgb-videos/video_hard: 100 of 100, verified", stand_in="False") for row in rows()]
    assert "stand-ins" not in compare(real, source="sgqn", protocol="dmcgb", allow_recipe_mismatch=True)[0]["notes"]


@pytest.mark.parametrize("shown", [
    "dmcgb-videos/video_hard: 60 of 100, verified",  # part of the data set
    "user folder: 100 videos",  # a user's folder, whatever it holds
    "dmcgb-videos/video_hard: 100 of 100, not verified",  # files no level checked
    "/data/dmcgb-videos/video_hard: 100 videos",  # a path names no data set (rows from before identities)
])
def test_rows_that_did_not_show_the_data_set_in_full_are_refused_unless_asked_and_then_say_what_was_shown(shown):
    run = [dict(row, data=shown, stand_in=False) for row in rows()]
    with pytest.raises(PartialData, match=f"video_hard: {shown}(.|\n)*allow_partial_data=True"):
        compare(run, source="sgqn", protocol="dmcgb", allow_recipe_mismatch=True)
    line = compare(run, source="sgqn", protocol="dmcgb", allow_partial_data=True, allow_recipe_mismatch=True)[0]
    assert f"vigen showed {shown}, not the published data set in full" in line["notes"]
    full = [dict(row, data="dmcgb-videos/video_hard: 100 of 100, verified") for row in rows()]
    assert "data set" not in compare(full, source="sgqn", protocol="dmcgb", allow_recipe_mismatch=True)[0]["notes"]


def test_shipped_presets_are_the_data_set_in_full_and_a_user_preset_file_is_not():
    run = rows(env="dmc/walker-walk", level="color_hard")
    shipped = compare([dict(row, data="dmcgb-colors/color_hard: 100 of 100, shipped") for row in run], source="dmcgb",
                      protocol="dmcgb", allow_recipe_mismatch=True)[0]
    assert "data set" not in shipped["notes"]
    with pytest.raises(PartialData, match="color_hard: user file: 100 presets"):
        compare([dict(row, data="user file: 100 presets") for row in run], source="dmcgb", protocol="dmcgb",
                allow_recipe_mismatch=True)

"""Protocol presets: each paper's budget, unit, action repeat per task and evaluation, as the papers state them."""

from __future__ import annotations

import dataclasses

import pytest

from vigen.envs.registry import get_suite
from vigen.protocols import PROTOCOLS, get_protocol


@pytest.mark.parametrize("env, repeat", [("dmc/cartpole-swingup", 8), ("dmc/finger-spin", 2), ("dmc/walker-walk", 4),
                                         ("dmc/ball_in_cup-catch", 4), ("dmc/cheetah-run", 4)])
def test_dmcgb_counts_agent_steps_at_its_action_repeat_per_task(env, repeat):
    dmcgb = get_protocol("dmcgb")
    assert dmcgb.budget_unit == "agent_steps" and dmcgb.action_repeat_for(env) == repeat
    assert dmcgb.frames(env) == 500_000 * repeat, "DMC-GB's 500k train_steps are agent steps, not frames"
    assert dmcgb.eval_every_frames(env) == 10_000 * repeat


def test_frame_protocols_keep_their_budget_in_frames():
    assert get_protocol("drqv2").frames("dmc/walker-walk") == 1_000_000
    assert get_protocol("drqv2").frames("dmc/cheetah-run") == 3_000_000
    assert get_protocol("drqv2").frames("dmc/humanoid-walk") == 30_000_000
    assert get_protocol("dmcgb2").frames("dmc/cartpole-swingup") == 1_000_000
    assert get_protocol("rlvigen").frames("dmc/walker-walk") == 1_100_000
    assert get_protocol("planet").frames("dmc/cartpole-swingup") == 500_000
    assert get_protocol("planet").action_repeat_for("dmc/cartpole-swingup") == 8


@pytest.mark.render
def test_a_robosuite_protocol_run_builds_its_env():
    """RL-ViGen's robosuite runs have no action repeat (20 Hz control): the settings say None and make_env gets no option."""
    pytest.importorskip("robosuite", reason="the robosuite extra is not installed: pip install -e '.[robosuite]'")
    from vigen.envs import make_env

    rlvigen = get_protocol("rlvigen")
    assert rlvigen.settings("robosuite/door")["action_repeat"] is None
    assert rlvigen.frames("robosuite/lift") == 3_100_000 and rlvigen.episode_length_for("robosuite/door") == 500
    env = make_env("robosuite/door", **{**rlvigen.env_options("robosuite/door"), "image_size": 32})
    assert env.reset()["pixels"].shape == (9, 32, 32)
    env.close()


def test_level_differences_name_test_levels():
    for protocol in PROTOCOLS.values():
        assert set(protocol.level_differences) <= set(protocol.test.levels)
    assert set(get_protocol("dmcgb2").level_differences) == {"video_easy", "video_hard", "color_video_easy", "color_video_hard"}


def test_env_options_build_the_protocols_env():
    assert get_protocol("dmcgb").env_options("dmc/finger-spin") == {"action_repeat": 2, "frame_stack": 3, "image_size": 84}
    assert "action_repeat" not in get_protocol("rlvigen").env_options("robosuite/door"), "robosuite has a fixed 20 Hz control"
    assert set(get_protocol("rlvigen").env_options("robosuite/door")) <= {*get_suite("robosuite").env_options, "frame_stack"}


@pytest.mark.parametrize("name", list(PROTOCOLS))
def test_every_protocol_level_is_a_vigen_level(name):
    protocol = PROTOCOLS[name]
    for suite in protocol.suites:
        levels = get_suite(suite).levels
        env = f"{suite}/{get_suite(suite).example_task}"
        wanted = {*protocol.train_eval.levels, *protocol.test_levels(env)}
        assert wanted <= set(levels), wanted - set(levels)
    settings = protocol.settings(f"{protocol.suites[0]}/{'walker-walk' if protocol.suites[0] == 'dmc' else 'door'}")
    example = f"{protocol.suites[0]}/{get_suite(protocol.suites[0]).example_task}"
    assert settings["frames"] > 0 and settings["eval_every"] > 0 and protocol.describe(example)[0].startswith(f"protocol {name}")


def test_rlvigen_loco_protocol_trains_on_the_sources_path_and_evaluates_as_locoeval():
    """RL-ViGen's published loco rows: train.py through loco_wrapper.py (raw clipped actions, ``_convert_action`` commented
    out, dmc2gym/wrappers.py:177; discount 0 at the time limit, loco_wrapper.py:37-39), evaluated by locoeval.py (scaled
    actions, :113; each episode's return clipped at 0, :96)."""
    protocol = get_protocol("rlvigen_loco")
    assert protocol.suites == ("loco",) and protocol.test.levels == ("easy", "hard") and protocol.test.episodes == 100
    assert dict(protocol.train_env_options) == {"action_mapping": "rlvigen_train", "time_limit_as": "terminated",
                                                "start_clearance": "rlvigen"}
    assert protocol.test_env_options["action_mapping"] == "scaled" and protocol.clip_returns_at == 0
    assert "locoeval.py" in protocol.evaluator and "locodmc_eval.py" in protocol.evaluator
    assert protocol.frames("loco/unitree-walk") == get_protocol("rlvigen").frames("loco/unitree-walk")
    options = get_suite("loco").env_options
    assert set(protocol.train_env_options) <= set(options) and set(protocol.test_env_options) <= set(options)
    settings = protocol.settings("loco/unitree-stand")
    assert settings["train_env_options"]["action_mapping"] == "rlvigen_train" and settings["clip_returns_at"] == 0
    with pytest.raises(ValueError, match="clip_returns_at"):
        dataclasses.replace(protocol, clip_returns_at="zero")


def test_bad_names_say_what_exists():
    with pytest.raises(ValueError, match="Unknown protocol 'dmc-gb'; the protocols are dmcgb, dmcgb2"):
        get_protocol("dmc-gb")
    with pytest.raises(ValueError, match="covers the dmc suite"):
        get_protocol("dmcgb").frames("robosuite/door")
    with pytest.raises(ValueError, match="not an env name"):
        get_protocol("dmcgb").frames("walker-walk")


def test_dmcgb2_levels_are_dmcgb2s_own_under_its_protocol():
    """dmcgb_photometric.py:53, 58, 62, 120, 176-179, 263-284: DMC-GB2 cycles its colours from RandomState(seed).randint(100),
    plays its videos from the same start and shows them on its in-scene screen; the protocol turns those on."""
    dmcgb2, env = get_protocol("dmcgb2"), "dmc/walker-walk"
    for level in ("color_easy", "color_hard"):
        assert dmcgb2.level_options_for(env, level) == {"draw": "dmcgb2"}
    for level in ("video_easy", "video_hard"):
        assert dmcgb2.level_options_for(env, level) == {"draw": "dmcgb2", "screen": True}
    for level in ("color_video_easy", "color_video_hard"):
        assert dmcgb2.level_options_for(env, level) == {"screen": True}
    dmc = get_suite("dmc")
    for level in dmcgb2.test.levels:  # every option reaches a transform of its level: none is dropped
        assert set(dmcgb2.level_options_for(env, level)) <= dmc.options_taken(level, "walker-walk"), level
    assert dmcgb2.settings(env)["level_options"]["video_hard"] == {"draw": "dmcgb2", "screen": True}
    assert any("video_hard with {'draw': 'dmcgb2', 'screen': True}" in line for line in dmcgb2.describe(env))
    assert get_protocol("dmcgb").level_options_for(env, "color_hard") == {}, "DMC-GB's levels are vigen's default ones"
    (video,) = dmc.level_transforms("walker-walk", "video_hard", seed=0, **dmcgb2.level_options_for(env, "video_hard"))
    assert video.draw == "dmcgb2" and video.video_screen is not None and video.video_screen.remove_floor


def test_dmcgb2_note_says_what_video_hard_hides():
    """dmcgb_photometric.py:47, 110-111: ``_remove_ground_and_rails`` only sets the ``grid`` material's alpha to 0; no rail of
    its five domains uses ``grid`` (cartpole's rails are ``decoration``), so the floor alone disappears."""
    note = get_protocol("dmcgb2").notes
    assert "rails" not in note.replace("_remove_ground_and_rails", "") and "grid material transparent" in note
    assert "line 111" in note and "the floor" in note


@pytest.mark.render
def test_evaluating_under_dmcgb2_plays_its_colour_cycle():
    """dmcgb_photometric.py:53, 58, 176-179: episode k shows preset (start + k) % 100, start = RandomState(seed).randint(100)."""
    import numpy as np

    from vigen.evaluation import evaluate
    from vigen.rendering import RenderSettings

    seed = 4
    options = {"image_size": 16, "frame_stack": 1, "render_settings": RenderSettings.fast()}
    rows = evaluate(None, "dmc/cartpole-balance", ["train", "color_hard"], episodes=3, seeds=[seed], max_steps=2,
                    env_options=options, protocol="dmcgb2")
    start = np.random.RandomState(seed).randint(100)
    shown = [row["shown"] for row in rows if row["level"] == "color_hard"]
    assert shown == [f"preset={(start + k) % 100}" for k in range(3)]
    assert [row["level_options"] for row in rows if row["level"] == "color_hard"] == ['{"draw": "dmcgb2"}'] * 3
    assert all(row["level_options"] == "" for row in rows if row["level"] == "train")
    default = evaluate(None, "dmc/cartpole-balance", ["color_hard"], episodes=3, seeds=[seed], max_steps=2, env_options=options)
    state = np.random.RandomState(seed)
    assert [row["shown"] for row in default] == [f"preset={state.randint(100)}" for _ in range(3)], "DMC-GB's draw otherwise"
    with pytest.raises(ValueError, match="covers the dmc suite"):
        evaluate(None, "loco/unitree-stand", ["train"], protocol="dmcgb2")


def test_unit_words_name_control_steps():
    """An env's action repeat and episode length count control steps (one dm_control ``env.step``; frames are agent steps ×
    action repeat): the word "simulator steps" named that unit in these files."""
    from pathlib import Path

    root = Path(__file__).resolve().parents[1]
    for path in ("vigen/envs/dmc/env.py", "vigen/envs/pixels.py", "vigen/envs/loco/env.py", "vigen/run/config.py",
                 "vigen/protocols.py", "vigen/envs/adroit/env.py"):
        assert "simulator step" not in (root / path).read_text().lower(), path
    from vigen.envs.pixels import POSITIVE_ARGUMENTS

    assert POSITIVE_ARGUMENTS["episode_length"].startswith("control steps per episode")
    assert POSITIVE_ARGUMENTS["action_repeat"].startswith("control steps per agent step")

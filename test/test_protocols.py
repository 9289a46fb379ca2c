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
    assert dict(protocol.train_env_options) == {"action_mapping": "rlvigen_train", "time_limit_as": "terminated"}
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

"""Protocol presets: each paper's budget, unit, action repeat per task and evaluation, as the papers state them."""

from __future__ import annotations

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
    assert settings["frames"] > 0 and settings["eval_every"] > 0 and protocol.describe("dmc/walker-walk")[0].startswith(f"protocol {name}")


def test_bad_names_say_what_exists():
    with pytest.raises(ValueError, match="Unknown protocol 'dmc-gb'; the protocols are dmcgb, dmcgb2"):
        get_protocol("dmc-gb")
    with pytest.raises(ValueError, match="covers the dmc suite"):
        get_protocol("dmcgb").frames("robosuite/door")
    with pytest.raises(ValueError, match="not an env name"):
        get_protocol("dmcgb").frames("walker-walk")

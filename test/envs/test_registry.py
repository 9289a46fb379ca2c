"""Env names: every dm_control suite task is reachable, bad names get errors that list the valid ones."""

from __future__ import annotations

import pytest
from dm_control import suite

from vigen.envs import available_envs, make_env


def test_every_suite_task_has_a_name():
    names = set(available_envs("dmc"))
    assert {f"dmc/{domain}-{task}" for domain, task in suite.ALL_TASKS} <= names
    assert "dmc/cup-catch" in names  # DrQ-v2's short name for ball_in_cup-catch
    assert set(available_envs()) >= names


def test_unknown_env_lists_valid_names_and_suggests():
    with pytest.raises(ValueError) as error:
        make_env("dmc/walker-wlak")
    message = str(error.value)
    assert "Did you mean dmc/walker-walk" in message
    assert "dmc/cheetah-run" in message and "dmc/quadruped-walk" in message


@pytest.mark.parametrize("name", ["walker-walk", "", "dmc/", "dmc/walker"])
def test_malformed_names(name):
    with pytest.raises(ValueError, match="dmc/walker-walk"):
        make_env(name)


def test_unknown_suite_lists_suites():
    with pytest.raises(ValueError, match=r"Unknown suite 'atari'.*dmc \("):
        make_env("atari/pong")
    with pytest.raises(ValueError, match="Unknown suite"):
        available_envs("atari")


@pytest.mark.render
def test_alias_builds_the_same_task():
    from vigen.rendering import RenderSettings

    fast = RenderSettings.fast()
    alias = make_env("dmc/cup-catch", seed=0, render_settings=fast, frame_stack=1).reset()["pixels"]
    full = make_env("dmc/ball_in_cup-catch", seed=0, render_settings=fast, frame_stack=1).reset()["pixels"]
    assert (alias == full).all()

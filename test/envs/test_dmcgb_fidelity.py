"""vigen's DMC-GB colour levels against DMC-GB's own code (nicklashansen/dmcontrol-generalization-benchmark, commit ff9c0aa).

Each test re-implements the source's rule in a few lines and checks vigen against it:

* ``src/env/wrappers.py``, ``ColorWrapper``: ``self._random_state = np.random.RandomState(seed)`` with
  the env seed, and at every reset (the first included) ``self._colors[self._random_state.randint(len(self._colors))]``;
  the preset is then compiled into the model by ``reload_physics``.
* ``src/env/dm_control/dm_control/suite/common/settings.py``, ``get_model_and_assets_from_setting_kwargs``:
  sets the ``grid`` texture's ``rgb1`` / ``rgb2``, the ``self`` material's ``rgba`` (``"r g b 1"``) and
  the ``skybox`` texture's ``rgb1``, each channel written with an f-string (``str`` of a float64: the
  shortest text that reads back as the same number), and recompiles. DMC-GB's copies of
  ``walker.xml``, ``common/materials.xml``, ``common/skybox.xml`` and ``common/visual.xml`` are
  byte-identical to dm_control's, which the reference below compiles. The presets hold no
  ``grid_markrgb``, ``grid_texrepeat``, ``skybox_rgb2`` or ``skybox_markrgb``, so those stay as they are —
  the same edit DMC-GB2's ``_reformat_xml`` makes (test_dmcgb2_fidelity.py).
"""

from __future__ import annotations

import pickle
import xml.etree.ElementTree as ElementTree

import mujoco
import numpy as np
import pytest

from vigen.assets import dmcgb_presets
from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC
from vigen.rendering import RenderSettings
from vigen.transforms import RandomSceneColors

FAST = RenderSettings.fast()
EPISODES = 4


# -- the source's rules, re-implemented ------------------------------------------------------------------------------
def source_color_draws(seed: int, count: int, episodes: int) -> list[int]:
    """ColorWrapper: one RandomState(seed) per env; randint(len(colors)) at each reset, the first included."""
    random_state = np.random.RandomState(seed)
    return [random_state.randint(count) for _ in range(episodes)]


def source_model(preset: dict) -> mujoco.MjModel:
    """The walker as DMC-GB's settings.py edits its XML for one preset and reload_from_xml_string compiles it."""
    from dm_control.suite import common

    assets = dict(common.ASSETS)
    materials = ElementTree.fromstring(assets["./common/materials.xml"])
    skybox = ElementTree.fromstring(assets["./common/skybox.xml"])

    def channels(key):  # f'{c[0]} {c[1]} {c[2]}' over the preset's float64 array, as settings.py writes it
        value = preset[key]
        return f"{value[0]} {value[1]} {value[2]}"

    grid = materials.find("asset/texture")  # settings.py asserts the first texture is named 'grid'
    assert grid.get("name") == "grid"
    grid.set("rgb1", channels("grid_rgb1"))
    grid.set("rgb2", channels("grid_rgb2"))
    self_material = materials.findall("asset/material")[1]  # settings.py asserts material [1] is 'self'
    assert self_material.get("name") == "self"
    self_material.set("rgba", f"{channels('self_rgb')} 1")
    sky = skybox.find("asset/texture")
    assert sky.get("name") == "skybox"
    sky.set("rgb1", channels("skybox_rgb"))
    assets["./common/materials.xml"] = ElementTree.tostring(materials)
    assets["./common/skybox.xml"] = ElementTree.tostring(skybox)
    return mujoco.MjModel.from_xml_string(common.read_model("walker.xml"), assets)


def texture(model: mujoco.MjModel, name: str) -> np.ndarray:
    index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, name)
    start, size = model.tex_adr[index], model.tex_width[index] * model.tex_height[index] * model.tex_nchannel[index]
    return model.tex_data[start:start + size]


def build(level: str, seed: int, **level_options):
    return make_env("dmc/walker-walk", generalization=level, seed=seed, frame_stack=1, image_size=32,
                    render_settings=FAST, level_options=level_options or None)


def colors_of(env) -> RandomSceneColors:
    return next(t for t in env.transform if isinstance(t, RandomSceneColors))


def draws(colors: RandomSceneColors, episodes: int) -> list[int]:
    """The presets ``colors`` picks at its next ``episodes`` resets (no env needed: presets read no model defaults)."""
    shown = []
    for _ in range(episodes):
        colors.params = colors.sample(colors.generator(), {})
        shown.append(colors.params["preset"])
    return shown


# -- the draw ---------------------------------------------------------------------------------------------------------
@pytest.mark.parametrize("level", ["color_easy", "color_hard"])
@pytest.mark.parametrize("seed", [0, 11])
def test_presets_are_drawn_as_dmcgb_draws_them(level, seed):
    (colors,) = DMC.level_transforms("walker-walk", level, seed=seed)
    expected = source_color_draws(seed, 100, 8)
    assert draws(colors, 8) == expected
    assert len(set(expected)) > 1  # the draw is not a cycle: DMC-GB draws with replacement, in no order
    colors.set_seed(colors.seed)  # a reseed restarts DMC-GB's draws, as a new DMC-GB env with that seed
    assert draws(colors, 3) == expected[:3]


def test_the_draws_continue_after_pickling():
    # a transform pickles (TorchRL's ParallelEnv, checkpoints): its RandomState goes with it, mid-sequence
    colors = RandomSceneColors(palette="color_easy", source_seed=7)
    first = draws(colors, 2)
    copy = pickle.loads(pickle.dumps(colors))
    assert first + draws(copy, 3) == source_color_draws(7, 100, 5)


def test_source_seed_stands_for_the_dmcgb_env_seed():
    colors = RandomSceneColors(palette="color_hard", source_seed=5, seed=123)
    assert draws(colors, 4) == source_color_draws(5, 100, 4)


@pytest.mark.render
@pytest.mark.parametrize("seed", [0, 11])
def test_each_episode_shows_the_preset_dmcgb_shows(seed):
    env = build("color_hard", seed)
    model, presets = env.base_env.scene.model, dmcgb_presets("color_hard")
    self_material = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "self")
    for index in source_color_draws(seed, 100, EPISODES):
        env.reset()
        assert colors_of(env).params["preset"] == index
        assert np.array_equal(model.mat_rgba[self_material], np.float32([*presets[index]["self_rgb"], 1.0]))


# -- acceptance: byte for byte against the model DMC-GB compiles ------------------------------------------------------
@pytest.mark.render
@pytest.mark.parametrize("seed", [3, 11])
def test_colour_hard_model_equals_what_dmcgb_compiles(seed):
    env = build("color_hard", seed)
    model, presets = env.base_env.scene.model, dmcgb_presets("color_hard")
    for index in source_color_draws(seed, 100, 3):
        env.reset()
        reference = source_model(presets[index])
        for name in ("grid", "skybox"):
            assert np.array_equal(texture(model, name), texture(reference, name)), (index, name)
        # every material: 'self' changed, the others (self_default, effector, ...) left as DMC-GB leaves them
        assert model.nmat == reference.nmat
        assert np.array_equal(model.mat_rgba, reference.mat_rgba), index
        grid_material = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "grid")
        assert np.array_equal(model.mat_texrepeat[grid_material], reference.mat_texrepeat[grid_material])


# -- DMC-GB2's cycle and the stand-ins, by name ----------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 11])
def test_dmcgb2_cycle_of_the_shipped_presets_is_a_level_option(seed):
    (colors,) = DMC.level_transforms("walker-walk", "color_hard", seed=seed, draw="dmcgb2")
    start = np.random.RandomState(seed).randint(100)  # dmcgb_photometric.py:53, 58, 176-179
    assert draws(colors, 3) == [start % 100, (start + 1) % 100, (start + 2) % 100]
    assert colors.data_source == "dmcgb-colors/color_hard: 100 of 100, shipped, cycled as DMC-GB2 does" and not colors.uses_stand_in


def test_statistics_stand_ins_stay_by_name():
    (colors,) = DMC.level_transforms("walker-walk", "color_hard", seed=0, palette="statistics")
    assert colors.palette is None and colors.scale == 0.2 and colors.uses_stand_in
    assert colors.data_source == "statistics-matched stand-in colours (scale=0.2)"
    defaults = {key: np.full(3, 0.5) for key in ("grid_rgb1", "skybox_rgb", "self_rgb")} | {"grid_rgb2": np.full(3, 0.6)}
    params = colors.sample(np.random.default_rng(0), defaults)
    assert "preset" not in params and np.allclose(params["grid_rgb2"] - params["grid_rgb1"], 0.1)


def test_the_levels_name_their_data():
    for level, label in (("color_easy", "dmcgb-colors/color_easy: 100 of 100, shipped"),
                         ("color_hard", "dmcgb-colors/color_hard: 100 of 100, shipped"),
                         ("color_video_easy", "dmcgb-colors/color_easy: 100 of 100, shipped, cycled as DMC-GB2 does"),
                         ("color_video_hard", "dmcgb-colors/color_hard: 100 of 100, shipped, cycled as DMC-GB2 does")):
        colors = DMC.level_transforms("walker-walk", level, seed=0)[0]
        assert colors.data_source == label and colors.uses_stand_in is False, level
    assert "its 100 presets, shipped" in DMC.levels["color_hard"].source


def test_a_users_preset_file_still_works(tmp_path):
    entries = [{key: np.full(3, i / 200) for key in ("grid_rgb1", "grid_rgb2", "skybox_rgb", "self_rgb")} for i in range(120)]
    (tmp_path / "color_hard.pt").write_bytes(pickle.dumps(entries))
    # palette=<folder>: the level's dmcgb2_file picks color_hard.pt; drawn as DMC-GB draws, over the file's 120 entries
    (colors,) = DMC.level_transforms("walker-walk", "color_hard", seed=4, palette=str(tmp_path))
    assert draws(colors, 5) == source_color_draws(4, 120, 5)
    assert colors.params["self_rgb"][0] == colors.params["preset"] / 200
    assert colors.data_source == "user file: 120 presets" and not colors.uses_stand_in, "named, never by its path"
    # dmcgb2_colors=<file>: DMC-GB2's cycle over the user's file, in place of the shipped presets
    (cycled,) = DMC.level_transforms("walker-walk", "color_hard", seed=4, dmcgb2_colors=str(tmp_path / "color_hard.pt"))
    start = np.random.RandomState(4).randint(100)
    assert draws(cycled, 2) == [start % 120, (start + 1) % 120]
    assert cycled.data_source == "user file: 120 presets, cycled as DMC-GB2 does"


def test_bad_palette_or_draw_names_the_choices():
    with pytest.raises(ValueError, match=r"unknown palette 'colour_hard'.*'color_easy' / 'color_hard'.*'statistics'"):
        RandomSceneColors(palette="colour_hard")
    with pytest.raises(ValueError, match=r"unknown draw 'dmcgb3'; choose 'dmcgb'.*or 'dmcgb2'"):
        RandomSceneColors(palette="color_hard", draw="dmcgb3")
    with pytest.raises(ValueError, match=r"unknown draw 'cycle'"):
        build("color_hard", 0, draw="cycle")
    with pytest.raises(FileNotFoundError, match=r"does not exist.*ship with vigen"):
        RandomSceneColors(palette="/nowhere/color_hard.pt")
    with pytest.raises(ValueError, match=r"'draw' do nothing at level 'floor_texture'"):
        build("floor_texture", 0, draw="dmcgb2")  # the video levels take draw too (DMC-GB2's video order)

"""vigen's DMC-GB2 levels against DMC-GB2's own code (aalmuzairee/dmcgb2, ``envs/dmcgb/``, stored commit f8fb10b5).

Each test re-implements the source's rule in a few lines (its wrappers' RandomState use, its colour
cycle, its XML edit) and checks vigen's env against it.
"""

from __future__ import annotations

import pickle
import xml.etree.ElementTree as ElementTree
from pathlib import Path

import mujoco
import numpy as np
import pytest

from vigen.assets import dmcgb_presets
from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC
from vigen.rendering import RenderSettings
from vigen.transforms import DMCGB2Camera, RandomSceneColors, VideoBackground
from vigen.transforms.scene.dmcgb2_camera import rotate_presets
from vigen.transforms.scene.dmcgb2_video import DMCGB2VideoBackground

SOURCE_DATA = Path("/work/refs/full/aalmuzairee+dmcgb2/envs/dmcgb/data")
FAST = RenderSettings.fast()
PHOTOMETRIC = ("color_easy", "color_hard", "video_easy", "video_hard", "color_video_easy", "color_video_hard")


# -- the source's rules, re-implemented ------------------------------------------------------------------------------
def source_rotation_angles(seed: int, difficulty: str) -> list[float]:
    """RotateWrapper: 100 angles over [-180, 180) (halved for easy), shuffled by RandomState(seed) (dmcgb_geometric.py:125-130)."""
    low, high = np.array([-180.0, 180.0]) / (2.0 if difficulty == "easy" else 1.0)
    angles = list(np.arange(100) * ((high - low) / 100) + low)
    np.random.RandomState(seed).shuffle(angles)
    return angles


def source_color_indices(seed: int, count: int, episodes: int) -> list[int]:
    """ColorVideoWrapper: start = RandomState(seed).randint(100); colour index start % n, used, then + 1 (lines 53, 58, 176-179)."""
    index = np.random.RandomState(seed).randint(100) % count
    shown = []
    for _ in range(episodes):
        shown.append(index)
        index = (index + 1) % count
    return shown


def source_video_indices(seed: int, count: int, episodes: int) -> list[int]:
    """ColorVideoWrapper: video index start % n, advanced by one before each episode's video is loaded (lines 53, 62, 120)."""
    index = np.random.RandomState(seed).randint(100) % count
    shown = []
    for _ in range(episodes):
        index = (index + 1) % count
        shown.append(index)
    return shown


def source_textures(entry: dict) -> mujoco.MjModel:
    """The walker model as DMC-GB2's _reformat_xml + reload_from_xml_string build it for one colour preset."""
    from dm_control.suite import common

    assets = dict(common.ASSETS)
    materials = ElementTree.fromstring(assets["./common/materials.xml"])
    skybox = ElementTree.fromstring(assets["./common/skybox.xml"])

    def rgb(value):  # the source formats each channel with Python's str
        return f"{value[0]} {value[1]} {value[2]}"

    grid = materials.find("asset/texture[@name='grid']")
    grid.set("rgb1", rgb(entry["grid_rgb1"]))
    grid.set("rgb2", rgb(entry["grid_rgb2"]))
    materials.find("asset/material[@name='self']").set("rgba", rgb(entry["self_rgb"]) + " 1")
    skybox.find("asset/texture[@name='skybox']").set("rgb1", rgb(entry["skybox_rgb"]))
    assets["./common/materials.xml"] = ElementTree.tostring(materials)
    assets["./common/skybox.xml"] = ElementTree.tostring(skybox)
    return mujoco.MjModel.from_xml_string(common.read_model("walker.xml"), assets)


def texture(model: mujoco.MjModel, name: str) -> np.ndarray:
    index = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_TEXTURE, name)
    start, size = model.tex_adr[index], model.tex_width[index] * model.tex_height[index] * model.tex_nchannel[index]
    return model.tex_data[start:start + size].reshape(model.tex_height[index], model.tex_width[index], -1)


def presets(count: int = 100) -> list[dict]:
    """``count`` colour presets in DMC-GB2's format, each one distinct (entry i's grid_rgb1 red is i / 255)."""
    rng = np.random.default_rng(0)
    entries = []
    for i in range(count):
        grid = np.array([i / 255, *rng.uniform(0, 0.8, 2)])
        entries.append({"grid_rgb1": grid, "grid_rgb2": grid + 0.1, "skybox_rgb": rng.uniform(0, 1, 3),
                        "self_rgb": rng.uniform(0, 1, 3)})
    return entries


@pytest.fixture(scope="module")
def preset_file(tmp_path_factory) -> Path:
    """A folder laid out as DMC-GB2's envs/dmcgb/data, both files holding :func:`presets`; returns color_hard.pt."""
    folder = tmp_path_factory.mktemp("dmcgb2")
    for name in ("color_easy.pt", "color_hard.pt"):
        (folder / name).write_bytes(pickle.dumps(presets()))
    return folder / "color_hard.pt"


def build(level: str, seed: int, **level_options):
    return make_env("dmc/walker-walk", generalization=level, seed=seed, frame_stack=1, image_size=32,
                    render_settings=FAST, level_options=level_options or None)


def find(env, kind):
    return next(t for t in env.transform if isinstance(t, kind))


# -- 1. the floor --------------------------------------------------------------------------------------------------
def test_only_video_hard_removes_the_floor():
    # dmcgb_photometric.py:47: _remove_ground_and_rails = (mode == 'video_hard')
    for level in PHOTOMETRIC:
        videos = [t for t in DMC.level_transforms("walker-walk", level) if isinstance(t, VideoBackground)]
        assert all(video.floor == (level == "video_hard") for video in videos), level


# -- 2. the presets follow the env seed ----------------------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 5, 123456])
def test_camera_presets_follow_the_env_seed(seed):
    # dmcgb_wrapper.py:29-30 hands the env seed to ShiftWrapper / RotateWrapper, which shuffle with RandomState(seed)
    (camera,) = DMC.level_transforms("walker-walk", "rotate_hard", seed=seed)
    shown = []
    for _ in range(3):
        camera.params = camera.sample(camera.generator(), {})
        shown.append(rotate_presets("hard")[camera.params["preset"]])
    np.testing.assert_allclose(shown, source_rotation_angles(seed, "hard")[:3], atol=1e-12)


@pytest.mark.render
def test_camera_presets_follow_the_env_seed_in_an_env():
    env = build("rotate_easy", 7)
    camera = find(env, DMCGB2Camera)
    angles = []
    for _ in range(2):
        env.reset()
        angles.append(rotate_presets("easy")[camera.params["preset"]])
    np.testing.assert_allclose(angles, source_rotation_angles(7, "easy")[:2], atol=1e-12)
    env.set_seed(8)  # set_seed restarts the cycle of the new seed, as a DMC-GB2 env built with it
    env.reset()
    assert rotate_presets("easy")[camera.params["preset"]] == pytest.approx(source_rotation_angles(8, "easy")[0])


# -- 3. colours: DMC-GB2's presets, cycled from the seeded start ---------------------------------------------------
@pytest.mark.render
@pytest.mark.parametrize("seed", [0, 11])
def test_colour_presets_cycle_from_the_seeded_start(preset_file, seed):
    env = build("color_hard", seed, dmcgb2_colors=str(preset_file.parent))  # the folder: the level reads color_hard.pt
    model, entries = env.base_env.scene.model, presets()
    self_material = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "self")
    for index in source_color_indices(seed, len(entries), 3):
        env.reset()
        np.testing.assert_allclose(model.mat_rgba[self_material, :3], entries[index]["self_rgb"], rtol=1e-6)
        assert texture(model, "grid")[100, 10, 0] == int(255 * entries[index]["grid_rgb1"][0])


@pytest.mark.render
def test_colour_textures_equal_what_the_source_compiles(preset_file):
    # grid checker bytes (MuJoCo truncates), edge marks untouched (the source never edits markrgb), the sky gradient
    env = build("color_hard", 3, dmcgb2_colors=str(preset_file))
    env.reset()
    entry = presets()[source_color_indices(3, 100, 1)[0]]
    reference, model = source_textures(entry), env.base_env.scene.model
    for name in ("grid", "skybox"):
        assert np.array_equal(texture(model, name), texture(reference, name)), name
    material = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "self")
    assert np.array_equal(model.mat_rgba[material], reference.mat_rgba[material])


@pytest.mark.render
def test_default_colours_keep_the_grid_edge_marks():
    env = build("color_hard", 0)
    before = texture(env.base_env.scene.model, "grid").copy()
    env.reset()
    after = texture(env.base_env.scene.model, "grid")
    ring = np.zeros(before.shape[:2], dtype=bool)
    ring[[0, -1]], ring[:, [0, -1]] = True, True
    assert np.array_equal(after[ring], before[ring])  # markrgb as in dm_control's materials.xml
    assert not np.array_equal(after[~ring], before[~ring])  # the checker itself is recoloured


@pytest.mark.skipif(not SOURCE_DATA.is_dir(), reason="DMC-GB2's colour files are not on this machine")
@pytest.mark.parametrize("name", ["color_easy", "color_hard"])
def test_reads_the_source_colour_files(name):
    colors = RandomSceneColors(dmcgb2_colors=SOURCE_DATA / f"{name}.pt", source_seed=0)
    assert len(colors.palette) == 100
    colors.params = colors.sample(colors.generator(), {})
    assert colors.params["preset"] == np.random.RandomState(0).randint(100)


def test_missing_or_bad_colour_files_say_so(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist. DMC-GB's presets ship with vigen"):
        RandomSceneColors(dmcgb2_colors=tmp_path / "color_hard.pt")
    bad = tmp_path / "bad.pt"
    bad.write_bytes(pickle.dumps([{"grid_rgb1": [0.1, 0.2, 0.3]}]))
    with pytest.raises(ValueError, match="entry 0"):
        RandomSceneColors(dmcgb2_colors=bad)
    with pytest.raises(ValueError, match="is a folder"):
        RandomSceneColors(dmcgb2_colors=tmp_path)
    with pytest.raises(ValueError, match="pass one of them"):
        RandomSceneColors(palette=presets(2), dmcgb2_colors=presets(2))


@pytest.mark.parametrize("level", ["color_video_easy", "color_video_hard"])
@pytest.mark.parametrize("seed", [0, 42])
def test_colour_video_cycles_the_shipped_presets_without_a_file(level, seed):
    # DMC-GB2-only levels: its (DMC-GB's) presets, cycled from RandomState(seed).randint(100), no file to pass
    colors, _ = DMC.level_transforms("walker-walk", level, seed=seed)
    entries = dmcgb_presets(level.replace("_video", ""))
    for index in source_color_indices(seed, 100, 3):
        colors.params = colors.sample(colors.generator(), {})
        assert colors.params["preset"] == index
        assert all(np.array_equal(colors.params[key], entries[index][key]) for key in entries[index])


@pytest.mark.render
def test_colour_video_shows_the_shipped_preset_of_the_cycle():
    env = build("color_video_hard", 5)
    env.reset()
    model, entry = env.base_env.scene.model, dmcgb_presets("color_hard")[source_color_indices(5, 100, 1)[0]]
    reference = source_textures(entry)
    for name in ("grid", "skybox"):
        assert np.array_equal(texture(model, name), texture(reference, name)), name
    assert np.array_equal(model.mat_rgba, reference.mat_rgba)


# -- 5. one start index for the colours and the videos -------------------------------------------------------------
@pytest.mark.parametrize("seed", [0, 42])
def test_colour_video_share_the_start_index(preset_file, seed):
    colors, video = DMC.level_transforms("walker-walk", "color_video_easy", seed=seed, dmcgb2_colors=str(preset_file.parent))
    assert isinstance(video, DMCGB2VideoBackground)
    shown_colors, shown_videos = [], []
    for _ in range(3):
        colors.params = colors.sample(colors.generator(), {})
        video.params = video.sample(video.generator())
        shown_colors.append(colors.params["preset"])
        shown_videos.append(video.params["video"])
    assert shown_colors == source_color_indices(seed, 100, 3)
    assert shown_videos == source_video_indices(seed, len(video.videos), 3)


def dmcgb_video_indices(count: int, episodes: int) -> list[int]:
    """DMC-GB's VideoWrapper (src/env/wrappers.py): ``_current_vid_idx`` starts at 0 and moves on by one before each
    episode's video is loaded, whatever the seed: episode k plays video (k + 1) mod n."""
    index, shown = 0, []
    for _ in range(episodes):
        index = (index + 1) % count
        shown.append(index)
    return shown


@pytest.mark.parametrize("level", ["video_easy", "video_hard"])
@pytest.mark.parametrize("seed", [0, 42])
def test_video_levels_start_where_dmcgb2_starts_with_its_draw(level, seed):
    """dmcgb_photometric.py:53, 62, 120: DMC-GB2's video_* start at RandomState(seed).randint(100) and move on by one
    before each episode; the same level names follow DMC-GB's order by default."""
    (video,) = DMC.level_transforms("walker-walk", level, seed=seed, draw="dmcgb2")
    shown = []
    for _ in range(4):
        video.params = video.sample(video.generator())
        shown.append(video.params["video"])
    assert shown == source_video_indices(seed, len(video.videos), 4)
    (default,) = DMC.level_transforms("walker-walk", level, seed=seed)
    shown = []
    for _ in range(4):
        default.params = default.sample(default.generator())
        shown.append(default.params["video"])
    assert shown == dmcgb_video_indices(len(default.videos), 4)
    with pytest.raises(ValueError, match="draw"):
        DMCGB2VideoBackground(draw="random")


@pytest.mark.parametrize("level", ["video_easy", "video_hard"])
def test_video_levels_offer_dmcgb2s_screen(level):
    """dmcgb_photometric.py:45-46, 63, 263-284: every mode with 'video' in its name (video_easy and video_hard too)
    projects the video on the in-scene screen box; video_hard also removes the grid (line 47)."""
    (video,) = DMC.level_transforms("walker-walk", level, seed=0, draw="dmcgb2", screen=True)
    assert video.video_screen is not None and video.video_screen.domain == "walker"
    assert video.video_screen.remove_floor == (level == "video_hard")


# -- 4. the in-scene screen (an option) -----------------------------------------------------------------------------
@pytest.mark.render
def test_screen_shows_the_video_on_a_box_that_follows_the_torso(preset_file):
    env = build("color_video_easy", 2, dmcgb2_colors=str(preset_file), screen=True)
    video = find(env, DMCGB2VideoBackground)
    state = env.reset()
    physics = env.base_env.physics
    model, data = physics.model.ptr, physics.data.ptr
    site = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "video_screen")
    assert site >= 0 and model.site_type[site] == mujoco.mjtGeom.mjGEOM_BOX
    np.testing.assert_allclose(model.site_size[site], [1.86, 0.1, 1.86])  # _reformat_xml's walker box
    assert video.params["video"] == source_video_indices(2, len(video.videos), 1)[0]
    material = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "self")  # colours survive the reload
    np.testing.assert_allclose(model.mat_rgba[material, :3], presets()[source_color_indices(2, 100, 1)[0]]["self_rgb"], rtol=1e-6)
    frames = video.videos.frames(video.params["video"], 256, 256)
    for step in range(2):
        assert np.array_equal(texture(model, "projector")[:256].reshape(256, 256, 3), frames[step].numpy())
        torso = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_BODY, "torso")  # _move_backcube: x + 0, z - 1.07
        np.testing.assert_allclose(data.site_xpos[site, [0, 2]], data.subtree_com[torso, [0, 2]] + [0.0, -1.07])
        assert np.array_equal(state["pixels"][-3:].permute(1, 2, 0).numpy(), env.base_env.render_frame())
        state = env.step(state.set("action", env.action_spec.zero()))["next"]

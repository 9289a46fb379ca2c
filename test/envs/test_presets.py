"""The benchmark presets in the dm_control level table equal their sources' definitions.

Numbers from ../shared/reference/ANCHORS.md §3 (DMC-GB §3.1–3.2, DCS and DMC-GB's DCS variant
§3.4, DMC-GB2 §3.5, RL-ViGen §3.6); the transforms' own parity tests (against the source code)
are in test/transforms/test_distracting.py and test_dmcgb2_camera.py.
"""

from __future__ import annotations

import pytest

from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC
from vigen.rendering import RenderSettings
from vigen.transforms import DistractingCamera, DistractingColors, DMCGB2Camera, RandomSceneColors, VideoBackground
from vigen.transforms.scene.dmcgb2_camera import rotate_presets
from vigen.datasets import StandInDataWarning

FAST = {"image_size": 32, "render_settings": RenderSettings.fast()}
DCS_INTENSITIES = (0.025, 0.05, 0.1, 0.15, 0.2, 0.3, 0.4, 0.5)  # ANCHORS §3.4, DMC-GB's DCS variant
DCS_VIDEOS = (2, 2, 4, 6, 8, None, None, None)  # None: all videos


def built(level: str, task: str = "walker-walk"):
    return DMC.level_transforms(task, level, seed=0)


def test_every_preset_names_its_source():
    for name, level in DMC.levels.items():
        assert level.source, name
    for name in DMC.groups["dmcgb2"]:
        assert "DMC-GB" in DMC.levels[name].source
    for name in DMC.groups["dcs"] + DMC.groups["dcs_static"]:
        assert "Distracting Control" in DMC.levels[name].source


def test_dmcgb_colour_levels_show_its_presets_and_keep_the_statistics_by_name():
    # DMC-GB's color_easy / color_hard draw from its own 100 presets (shipped); the statistics-matched stand-ins
    # (default + N(0, scale²), 0.1 / 0.2 measured from those presets) stay available as palette="statistics"
    for level in ("color_easy", "color_hard"):
        (colors,) = built(level)
        assert isinstance(colors, RandomSceneColors) and colors.parts == ("grid", "skybox", "self")
        assert (colors.palette_name, colors.draw, len(colors.palette), colors.uses_stand_in) == (level, "dmcgb", 100, False)
    stand_ins = [DMC.level_transforms("walker-walk", level, seed=0, palette="statistics")[0]
                 for level in ("color_easy", "color_hard")]
    assert [(t.scale, t.palette, t.uses_stand_in) for t in stand_ins] == [(0.1, None, True), (0.2, None, True)]
    assert [t.floor for t in built("video_easy")] == [False] and [t.floor for t in built("video_hard")] == [True]


def test_dmcgb2_has_its_twelve_test_distributions():
    expected = {f"{kind}_{difficulty}" for kind in ("rotate", "shift", "rotate_shift", "color", "video", "color_video")
                for difficulty in ("easy", "hard")}
    assert set(DMC.groups["dmcgb2"]) == expected and len(DMC.groups["dmcgb2"]) == 12


@pytest.mark.parametrize("mode", ["rotate", "shift", "rotate_shift"])
@pytest.mark.parametrize("difficulty", ["easy", "hard"])
@pytest.mark.parametrize("task, domain", [("walker-walk", "walker"), ("cup-catch", "cup"), ("finger-spin", "finger")])
def test_dmcgb2_geometric_presets_use_the_task_domain(mode, difficulty, task, domain):
    (camera,) = built(f"{mode}_{difficulty}", task)
    assert isinstance(camera, DMCGB2Camera)
    assert (camera.mode, camera.difficulty, camera.domain) == (mode, difficulty, domain)


def test_dmcgb2_rotate_ranges_are_the_sources():
    # 100 evenly spaced in-plane angles over [-90, 90] (easy) and [-180, 180] (hard) degrees
    easy, hard = rotate_presets("easy"), rotate_presets("hard")
    assert len(easy) == len(hard) == 100
    assert easy.min() == pytest.approx(-90.0) and easy.max() <= 90.0 and hard.min() == pytest.approx(-180.0) and hard.max() <= 180.0
    assert built("rotate_hard")[0].difficulty == "hard"


def test_color_video_is_colour_and_video_together():
    for difficulty, scale in (("easy", 0.1), ("hard", 0.2)):
        colors, video = built(f"color_video_{difficulty}")
        assert isinstance(colors, RandomSceneColors) and colors.scale == scale  # the scale of palette="statistics"
        assert (colors.palette_name, colors.draw) == (f"color_{difficulty}", "dmcgb2")  # its presets, cycled by default
        assert isinstance(video, VideoBackground) and video.floor is False  # only video_hard removes it (dmcgb_photometric.py:47)


@pytest.mark.parametrize("dynamic", [True, False])
def test_dcs_levels_follow_the_intensity_scale(dynamic):
    prefix = "dcs_" if dynamic else "dcs_static_"
    assert DMC.groups["dcs" if dynamic else "dcs_static"] == [f"{prefix}{s}" for s in DCS_INTENSITIES]
    for scale, videos in zip(DCS_INTENSITIES, DCS_VIDEOS):
        camera, colors, background = built(f"{prefix}{scale}")
        assert isinstance(camera, DistractingCamera) and (camera.scale, camera.dynamic) == (scale, dynamic)
        assert isinstance(colors, DistractingColors) and (colors.scale, colors.dynamic) == (scale, dynamic)
        assert isinstance(background, VideoBackground) and background.num_videos == videos
        assert background.playback == ("bounce" if dynamic else "static")


def test_dcs_settings_follow_the_domain():
    # ground-plane alpha: reacher 0, walker and cheetah 1, others 0.3; camera 2 for quadruped; reacher unclipped
    alphas = {task: built("dcs_0.1", task)[2].ground_plane_alpha
              for task in ("reacher-easy", "walker-walk", "cheetah-run", "finger-spin")}
    assert alphas == {"reacher-easy": 0.0, "walker-walk": 1.0, "cheetah-run": 1.0, "finger-spin": 0.3}
    assert built("dcs_0.1", "quadruped-walk")[0].camera == 2 and built("dcs_0.1", "walker-walk")[0].camera == 0
    assert built("dcs_0.1", "reacher-easy")[0].limit_to_upper_quadrant is False


@pytest.mark.parametrize("level", ["rotate_shift_hard", "color_video_hard", "dcs_0.2", "dcs_static_0.3"])
def test_new_presets_build_and_play(level):
    env = make_env("dmc/walker-walk", generalization=level, seed=0, **FAST)
    assert env.rollout(3)["pixels"].shape == (3, 9, 32, 32)


def test_levels_say_what_data_they_show():
    from vigen.envs import make_env

    def level(name, **options):
        return make_env("dmc/walker-walk", generalization=name, image_size=32, level_options=options or None).level

    assert (level("color_hard").data_source, level("color_hard").uses_stand_in) == ("dmcgb-colors/color_hard: 100 of 100, shipped", False)
    stand_in = level("color_hard", palette="statistics")
    assert (stand_in.data_source, stand_in.uses_stand_in) == ("statistics-matched stand-in colours (scale=0.2)", True)
    # RL-ViGen's objects_color draws DMC-GB's presets (dmcvgb/wrappers.py:53-56); vigen's object_color factor draws random
    # colours by its own definition: no data, so no stand-in
    objects = level("objects_color_hard")
    assert (objects.data_source, objects.uses_stand_in) == (level("color_hard").data_source, False), "the same presets"
    factor = make_env("dmc/walker-walk", generalization={"object_color": 0.2}, image_size=32).level
    assert factor.data_source.startswith("random colours") and not factor.uses_stand_in
    with pytest.warns(StandInDataWarning, match="fetch dmcgb-videos --part video_hard"):
        videos = level("video_hard")  # the test session's data cache is empty (conftest)
    assert (videos.data_source, videos.uses_stand_in) == ("procedural stand-in videos (10)", True)
    assert level("train").data_source == "" and not level("train").uses_stand_in

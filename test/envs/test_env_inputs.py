"""Env arguments are checked before any simulator is built; VideoBackground's misplacement errors name the real fix."""

from __future__ import annotations

import importlib
from functools import partial

import numpy as np
import pytest
import torch
from torchrl.envs import Compose, ParallelEnv

import vigen.envs.dmc.env as dmc
from vigen.envs import make_env
from vigen.envs.pixels import check_env_arguments, check_transforms
from vigen.rendering import RenderSettings
from vigen.transforms import RandomTextures, VideoBackground

FAST = RenderSettings.fast()

BAD_ARGUMENTS = [
    ("image_size", 84.0, TypeError),
    ("image_size", "84", TypeError),
    ("image_size", 0, ValueError),
    ("image_size", True, TypeError),
    ("frame_stack", 0, ValueError),
    ("frame_stack", 3.0, TypeError),
    ("frame_stack", False, TypeError),
    ("action_repeat", -1, ValueError),
    ("action_repeat", 2.5, TypeError),
    ("episode_length", 0, ValueError),
    ("episode_length", "1000", TypeError),
    ("seed", -1, ValueError),
    ("seed", 2**32, ValueError),
    ("seed", 1.5, TypeError),
    ("seed", True, TypeError),
    ("seed", "0", TypeError),
    ("camera_id", -1, ValueError),
    ("camera_id", 0.0, TypeError),
    ("camera_id", "0", TypeError),
]


@pytest.fixture
def no_simulator(monkeypatch):
    """Fail the test if the dm_control task would be loaded: bad arguments must be refused before that."""

    def load(*args, **kwargs):
        raise AssertionError("the simulator was built before the arguments were checked")

    monkeypatch.setattr(dmc.suite, "load", load)


@pytest.mark.parametrize(("name", "value", "error"), BAD_ARGUMENTS, ids=lambda x: repr(x) if not isinstance(x, type) else "")
def test_dmc_refuses_bad_arguments_before_building(no_simulator, name, value, error):
    with pytest.raises(error) as caught:
        make_env("dmc/walker-walk", **{name: value})
    message = str(caught.value)
    assert message.startswith(f"{name} must be an int"), message
    assert repr(value) in message or str(value) in message, "the message shows the value that was passed"


@pytest.mark.parametrize(("name", "value", "error"), BAD_ARGUMENTS[:12], ids=lambda x: repr(x) if not isinstance(x, type) else "")
def test_base_env_refuses_bad_arguments_before_building(no_simulator, name, value, error):
    if name == "frame_stack":
        pytest.skip("the base env does not stack frames")
    with pytest.raises(error, match=f"^{name} must be an int"):
        dmc.DMCPixelEnv("walker", "walk", **{name: value})


def test_good_arguments_pass():
    check_env_arguments(image_size=np.int64(32), frame_stack=1, action_repeat=1, episode_length=None, seed=2**32 - 1, camera_id=None)
    check_env_arguments(seed=None, camera="agentview", control_freq=20)


def test_camera_name_must_be_a_string():
    with pytest.raises(TypeError, match="^camera must be a camera name"):
        check_env_arguments(camera=0)


@pytest.mark.parametrize(
    ("suite", "name", "value"),
    [("robosuite/lift", "image_size", 0), ("robosuite/lift", "seed", -1), ("robosuite/lift", "control_freq", 2.5),
     ("adroit/door", "action_repeat", 0), ("adroit/door", "frame_stack", True), ("adroit/door", "episode_length", 1.0)],
)
def test_other_suites_refuse_bad_arguments_before_building(monkeypatch, suite, name, value):
    module = importlib.import_module("vigen.envs." + suite.split("/")[0] + ".env")
    pixel_env = module.RobosuitePixelEnv if suite.startswith("robosuite") else module.AdroitPixelEnv

    def build(self, *args, **kwargs):
        raise AssertionError("the simulator was built before the arguments were checked")

    monkeypatch.setattr(pixel_env, "_build_env", build)
    with pytest.raises((TypeError, ValueError), match=f"^{name} must be an int"):
        make_env(suite, **{name: value})


def test_compose_in_a_generalization_list_is_flattened():
    inner = VideoBackground()
    flat = check_transforms([Compose(Compose(inner))])
    assert flat == [inner]
    assert check_transforms(inner) == [inner]


def test_missing_texture_folder_is_refused_at_build(tmp_path):
    missing = tmp_path / "no-such-folder"
    with pytest.raises(FileNotFoundError, match="images=.*no-such-folder.* is not a folder"):
        RandomTextures(images=missing)


@pytest.mark.render
class TestVideoBackgroundPlacement:
    def test_compose_of_video_background_goes_before_the_channel_first_frames(self):
        video = VideoBackground(seed=0)
        env = make_env("dmc/walker-walk", generalization=[Compose(video)], image_size=32, render_settings=FAST)
        names = [type(t).__name__ for t in env.transform]
        assert names.index("VideoBackground") < names.index("ToTensorImage")
        clean = make_env("dmc/walker-walk", seed=0, image_size=32, render_settings=FAST).reset()["pixels"]
        env.set_seed(0)
        assert not torch.equal(env.reset()["pixels"], clean), "the video replaces the background"

    @pytest.mark.parametrize("frame_stack", [1, 3])
    def test_appended_video_background_names_the_real_fix(self, frame_stack):
        env = make_env("dmc/walker-walk", frame_stack=frame_stack, image_size=32, render_settings=FAST)
        env.append_transform(VideoBackground())
        with pytest.raises(ValueError) as caught:
            env.reset()
        message = str(caught.value)
        assert "ToTensorImage" in message and "insert_transform(0" in message and "generalization=[VideoBackground" in message
        assert "frame_stack=1" not in message, "frame_stack is not the cause: the frames are channel-first at any stack"

    def test_the_advised_fix_works(self):
        env = make_env("dmc/walker-walk", frame_stack=1, image_size=32, render_settings=FAST)
        env.insert_transform(0, VideoBackground(seed=0))
        assert env.rollout(2)["pixels"].shape == (2, 3, 32, 32)


@pytest.mark.render
@pytest.mark.slow
@pytest.mark.timeout(180)
def test_worker_failure_from_a_bad_level_option_shows_its_cause(tmp_path):
    """A level option that would only fail at the first reset, inside a worker, is refused where the parent sees it."""
    missing = str(tmp_path / "no-textures-here")
    make = partial(make_env, "dmc/walker-walk", generalization="floor_texture", level_options={"images": missing},
                   image_size=32, render_settings=FAST)
    with pytest.raises(FileNotFoundError, match="no-textures-here"):
        env = ParallelEnv(2, make)
        try:
            env.reset()
        finally:
            env.close(raise_if_closed=False)


def test_a_folder_given_as_the_video_index_is_refused_at_build_with_the_fix():
    from vigen.envs import make_env

    with pytest.raises(TypeError, match=r"video is the index of the one video to play.*level_options=\{'videos': 'x'\}"):
        make_env("dmc/walker-walk", generalization="dcs_static_0.1", level_options={"video": "x"})
    with pytest.raises(ValueError, match=r"'video' do nothing at level 'video_hard'"):  # DMC-GB's order plays every video
        make_env("dmc/walker-walk", generalization="video_hard", level_options={"video": "x"})


def test_level_options_the_level_would_drop_are_refused_before_building(no_simulator):
    """A palette on a video level (or a video folder on the train level) did nothing, silently."""
    with pytest.raises(ValueError, match=r"'palette' do nothing at level 'video_easy'.*\(DMCGB2VideoBackground\).*color_easy"):
        make_env("dmc/walker-walk", generalization="video_easy", level_options={"palette": "/data/palette.npy"})
    with pytest.raises(ValueError, match=r"'videos' do nothing at level 'train'.*take no options.*video_easy"):
        make_env("dmc/walker-walk", level_options={"videos": "/data/davis"})
    with pytest.raises(ValueError, match="give those arguments to the transforms themselves"):
        make_env("dmc/walker-walk", generalization=[VideoBackground()], level_options={"videos": "/data/davis"})


def test_shared_level_options_go_to_the_levels_that_take_them():
    from vigen.envs import check_level_options_used, level_options_for

    options = {"videos": "/data/davis", "palette": "/data/palette.npy"}
    assert level_options_for("dmc/walker-walk", "video_hard", options) == {"videos": "/data/davis"}
    assert level_options_for("dmc/walker-walk", "color_hard", options) == {"palette": "/data/palette.npy"}
    assert level_options_for("dmc/walker-walk", "train", options) == {}
    check_level_options_used("dmc/walker-walk", ["train", "video_hard", "color_hard"], options)  # each is used somewhere
    with pytest.raises(ValueError, match=r"'videos' do nothing at any of the levels train, color_hard"):
        check_level_options_used("dmc/walker-walk", ["train", "color_hard"], options)

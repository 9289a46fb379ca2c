"""The levels find fetched data by themselves: ``python -m vigen.datasets fetch`` against a server on 127.0.0.1, then a level
that plays the fetched videos with no ``level_options``, in DMC-GB's order, and says so."""

from __future__ import annotations

import warnings
from pathlib import Path

import cv2
import numpy as np
import pytest

import vigen.datasets
from vigen.datasets import StandInDataWarning
from vigen.datasets.__main__ import main
from vigen.envs import make_env
from vigen.rendering import RenderSettings

pytestmark = pytest.mark.render


def clip_bytes(folder: Path, name: str, shade: int) -> bytes:
    """A short mp4 of one flat colour (each video its own), as bytes."""
    path = folder / name
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25, (32, 32))
    for _ in range(6):
        writer.write(np.full((32, 32, 3), shade, np.uint8))
    writer.release()
    return path.read_bytes()


@pytest.fixture
def fetched_videos(server, make_toy, tmp_path, monkeypatch, capsys) -> Path:
    """Three test-made videos standing in for DMC-GB's ``video_hard``, pinned under the record's name and fetched by the CLI."""
    made = tmp_path / "made"
    made.mkdir()
    files = {f"video_hard/video{i}.mp4": clip_bytes(made, f"video{i}.mp4", 40 + 80 * i) for i in range(3)}
    record = make_toy(server.folder, files, name="dmcgb-videos")
    monkeypatch.setitem(vigen.datasets.DATASETS, "dmcgb-videos", record)
    assert main(["fetch", "dmcgb-videos", "--part", "video_hard", "--mirror", server.url]) == 0
    return Path(capsys.readouterr().out.strip())


def test_video_hard_plays_the_fetched_videos_in_dmcgb_order(fetched_videos, isolated_cache):
    assert fetched_videos == isolated_cache / "dmcgb-videos" / "video_hard"
    with warnings.catch_warnings():
        warnings.simplefilter("error", StandInDataWarning)  # the data is there: no stand-in warning
        env = make_env("dmc/walker-walk", generalization="video_hard", seed=5, image_size=32, frame_stack=1,
                       render_settings=RenderSettings.fast())
    # every file is one of the record's pinned files (name and git blob id): named as the data set, never by path
    assert env.level.data_source == "dmcgb-videos/video_hard: 3 of 3, verified" and not env.level.uses_stand_in
    shown = []
    for _ in range(4):
        env.reset()
        shown.append(env.level.episode_data()["video"])
    # DMC-GB's VideoWrapper: _index starts at 0 and moves on before each episode's video is loaded
    assert shown == [f"video{(k + 1) % 3}.mp4" for k in range(4)]


def test_without_the_data_the_level_warns_and_says_it_shows_stand_ins(isolated_cache):
    with pytest.warns(StandInDataWarning, match=r"python -m vigen.datasets fetch dmcgb-videos --part video_hard"):
        env = make_env("dmc/walker-walk", generalization="video_hard", seed=5, image_size=32, frame_stack=1)
    assert env.level.uses_stand_in and env.level.data_source == "procedural stand-in videos (10)"


def test_a_folder_in_level_options_replaces_the_cache_lookup(tmp_path, isolated_cache):
    folder = tmp_path / "mine"
    folder.mkdir()
    clip_bytes(folder, "video0.mp4", 100)
    with warnings.catch_warnings():
        warnings.simplefilter("error", StandInDataWarning)  # not looked up, so no warning
        env = make_env("dmc/walker-walk", generalization="video_hard", image_size=32, frame_stack=1,
                       level_options={"videos": str(folder)})
    assert env.level.data_source == "user folder: 1 video"


@pytest.fixture
def fetched_easy_videos(server, make_toy, tmp_path, monkeypatch, capsys) -> Path:
    """Four test-made videos standing in for DMC-GB's ``video_easy``, fetched by the CLI."""
    made = tmp_path / "made_easy"
    made.mkdir()
    files = {f"video_easy/video{i}.mp4": clip_bytes(made, f"video{i}.mp4", 30 + 50 * i) for i in range(4)}
    record = make_toy(server.folder, files, name="dmcgb-videos")
    monkeypatch.setitem(vigen.datasets.DATASETS, "dmcgb-videos", record)
    assert main(["fetch", "dmcgb-videos", "--part", "video_easy", "--mirror", server.url]) == 0
    return Path(capsys.readouterr().out.strip())


@pytest.mark.parametrize("task", ["unitree-stand", "franka-push"])
def test_loco_video_levels_play_the_fetched_dmcgb_videos_in_rlvigens_order(fetched_easy_videos, task):
    """RL-ViGen's VideoWrapper (envs/DMCVGB/dmcvgb/wrappers.py:282, 291-297, 318-321) plays DMC-GB's video_{easy,hard}
    files; ``_index`` starts at 0 and moves on before each episode's video is loaded: episode k plays (k + 1) mod n."""
    from vigen.envs.loco.suite import LOCO

    with warnings.catch_warnings():
        warnings.simplefilter("error", StandInDataWarning)
        (video,) = LOCO.level_transforms(task, "video_easy", seed=3)
    assert not video.uses_stand_in and [path.name for path in video.videos.paths] == [f"video{i}.mp4" for i in range(4)]
    assert video.videos.paths[0].parent == fetched_easy_videos
    shown = []
    for _ in range(6):
        video.params = video.sample(video.generator())
        shown.append(video.videos.paths[video.params["video"]].name)
    assert shown == [f"video{(k + 1) % 4}.mp4" for k in range(6)]


def test_loco_video_levels_without_the_data_warn_and_say_they_show_stand_ins(isolated_cache):
    from vigen.envs.loco.suite import LOCO

    for level, part in (("video_easy", "video_easy"), ("video_hard", "video_hard")):
        with pytest.warns(StandInDataWarning, match=rf"loco/unitree-walk shows stand-ins: .*fetch dmcgb-videos --part {part}"):
            (video,) = LOCO.level_transforms("unitree-walk", level, seed=0)
        assert video.uses_stand_in and "stand-in" in video.data_source

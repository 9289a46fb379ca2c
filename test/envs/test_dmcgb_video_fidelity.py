"""vigen's DMC-GB ``video_easy`` / ``video_hard`` play DMC-GB's videos in DMC-GB's order.

DMC-GB's ``VideoWrapper`` (nicklashansen/dmcontrol-generalization-benchmark, ``src/env/wrappers.py``)
starts ``_index`` at 0 and, in ``reset``, moves it on by one before loading the episode's video
(``_reset_video``), then shows frame ``_current_frame % len(video)``, ``_current_frame`` being 0 at
reset and one more per ``step``. The seed plays no part. The test re-implements that rule and reads
which video and frame vigen's env shows from the background pixels.
"""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC
from vigen.rendering import RenderSettings
from vigen.transforms import VideoBackground

VIDEOS, FRAMES = 3, 4


def source_playback(episodes: int, steps: int, count: int, frames: int) -> list[list[tuple[int, int]]]:
    """DMC-GB's VideoWrapper: (video, frame) shown at reset and after each step of each episode."""
    index, shown = 0, []
    for _ in range(episodes):
        index = (index + 1) % count  # _reset_video, before the video is loaded
        current = 0  # reset
        episode = [(index, current % frames)]
        for _ in range(steps):
            current += 1  # step
            episode.append((index, current % frames))
        shown.append(episode)
    return shown


def colour(video: int, frame: int) -> tuple[int, int, int]:
    return 40 + 60 * video, 40 + 50 * frame, 200


@pytest.fixture(scope="module")
def dmcgb_folder(tmp_path_factory) -> Path:
    """video0.mp4 … video{VIDEOS-1}.mp4, each frame one flat colour that names its video and frame."""
    folder = tmp_path_factory.mktemp("video_hard")
    for video in range(VIDEOS):
        writer = cv2.VideoWriter(str(folder / f"video{video}.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 25, (32, 32))
        for frame in range(FRAMES):
            writer.write(np.full((32, 32, 3), colour(video, frame)[::-1], np.uint8))
        writer.release()
    return folder


def test_the_levels_set_dmcgb_start():
    for level in ("video_easy", "video_hard"):
        (video,) = DMC.level_transforms("walker-walk", level, seed=0)
        assert isinstance(video, VideoBackground) and video.playback == "forward" and video.first_video == 1
        assert video.draw == "dmcgb" and video.video_screen is None, "DMC-GB's order and composite by default"


@pytest.mark.parametrize("seed", [0, 7])
def test_episodes_take_the_videos_in_dmcgb_order(seed):
    for level in ("video_easy", "video_hard"):
        (video,) = DMC.level_transforms("walker-walk", level, seed=seed)
        shown = []
        for _ in range(12):
            video.params = video.sample(video.generator())
            shown.append((video.params["video"], video.params["frame"]))
        assert shown == [episode[0] for episode in source_playback(12, 0, len(video.videos), 100)]


@pytest.mark.render
@pytest.mark.parametrize("seed", [0, 7])
def test_an_env_shows_dmcgb_video_and_frame_at_every_step(dmcgb_folder, seed):
    env = make_env("dmc/walker-walk", generalization="video_hard", level_options={"videos": dmcgb_folder}, seed=seed,
                   image_size=32, frame_stack=1, render_settings=RenderSettings.fast())
    decoded = {v: env.transform[0].videos.frames(v, 32, 32) for v in range(VIDEOS)}
    nearest = {(v, f): decoded[v][f, 0, 0] for v in range(VIDEOS) for f in range(FRAMES)}
    assert len({tuple(pixel.tolist()) for pixel in nearest.values()}) == VIDEOS * FRAMES, "each (video, frame) is one colour"
    assert all((pixel.to(torch.int32) - torch.tensor(colour(*key))).abs().max() <= 8 for key, pixel in nearest.items())

    def shown(pixels: torch.Tensor) -> tuple[int, int]:
        corner = pixels[:, 0, 0]  # the sky: background in every frame
        (match,) = [key for key, pixel in nearest.items() if torch.equal(pixel, corner)]
        return match

    action = torch.zeros(env.action_spec.shape)
    seen = []
    for _ in range(5):
        state = env.reset()
        episode = [shown(state["pixels"])]
        for _ in range(6):
            state = env.step(state.set("action", action))["next"]
            episode.append(shown(state["pixels"]))
        seen.append(episode)
    env.close()
    assert seen == source_playback(5, 6, VIDEOS, FRAMES)

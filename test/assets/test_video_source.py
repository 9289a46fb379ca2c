"""User video folders: broken files are found when the source is built, named with the fix; nothing is skipped silently."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

from vigen.assets.video_source import natural_key
from vigen.transforms import VideoBackground, VideoSource

DMCGB = Path(__file__).resolve().parents[3] / "shared" / "data" / "dmcgb"


def _mp4(path: Path, frames: int = 6, size: tuple[int, int] = (24, 16)) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), 25, size)
    for i in range(frames):
        writer.write(np.full((size[1], size[0], 3), 30 * i, np.uint8))
    writer.release()
    assert path.stat().st_size > 0, "OpenCV wrote the clip"
    return path


def _avi(path: Path, frames: int = 20) -> Path:
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 25, (24, 16))
    for i in range(frames):
        writer.write(np.full((16, 24, 3), 10 * i, np.uint8))
    writer.release()
    return path


def _frames(folder: Path, count: int = 4) -> Path:
    folder.mkdir(parents=True)
    for i in range(count):
        cv2.imwrite(str(folder / f"{i:05d}.jpg"), np.full((16, 24, 3), (200, 40 * i, 0), np.uint8))
    return folder


def test_a_valid_folder_decodes_as_before(tmp_path):
    _mp4(tmp_path / "clip.mp4", frames=6)
    _frames(tmp_path / "davis" / "bear", count=4)
    source = VideoSource.from_folder(tmp_path, max_frames=5)
    assert len(source) == 2
    clip = source.frames(0, 8, 8)
    assert clip.shape == (5, 8, 8, 3) and clip[-1].float().mean() > clip[0].float().mean() + 50
    assert source.frames(1, 8, 8).shape == (4, 8, 8, 3)


@pytest.mark.parametrize("damage", ["truncated", "garbage", "empty", "text"])
def test_a_corrupt_video_is_found_at_construction(tmp_path, damage):
    good = _mp4(tmp_path / "video0.mp4")
    bad = tmp_path / "video1.mp4"
    data = good.read_bytes()
    bad.write_bytes({"truncated": data[: len(data) // 2], "garbage": bytes(range(256)) * 8, "empty": b"",
                     "text": b"<html>404 Not Found</html>"}[damage])
    with pytest.raises(ValueError) as caught:
        VideoSource.from_folder(tmp_path)
    message = str(caught.value)
    assert str(bad) in message and "1 of 2" in message and "re-encode" in message
    assert f"{good}:" not in message, "only the broken file is named"
    with pytest.raises(ValueError, match="video1.mp4"):
        VideoBackground(videos=tmp_path)  # the transform checks its folder when built, before any episode
    with pytest.raises(ValueError, match="video1.mp4"):
        VideoSource([good, bad])


def test_a_level_with_a_corrupt_video_folder_fails_when_the_env_is_built(tmp_path):
    from vigen.envs import make_env
    from vigen.rendering import RenderSettings

    _mp4(tmp_path / "video0.mp4")
    (tmp_path / "video1.mp4").write_bytes(b"\x00" * 100)
    with pytest.raises(ValueError, match="video1.mp4"):
        make_env("dmc/walker-walk", generalization="video_hard", level_options={"videos": tmp_path}, image_size=16,
                 frame_stack=1, render_settings=RenderSettings.fast())


def test_a_folder_of_only_unreadable_videos_lists_them(tmp_path):
    (tmp_path / "a.mp4").write_bytes(b"")
    (tmp_path / "b.avi").write_bytes(b"RIFF....AVI junk")
    with pytest.raises(ValueError, match="none of its 2 videos is readable") as caught:
        VideoSource.from_folder(tmp_path)
    assert str(tmp_path / "a.mp4") in str(caught.value) and str(tmp_path / "b.avi") in str(caught.value)


def test_a_folder_without_videos_lists_what_it_holds(tmp_path):
    (tmp_path / "notes.txt").write_text("videos are elsewhere")
    (tmp_path / "sub").mkdir()
    (tmp_path / "sub" / "clip.gif").write_bytes(b"GIF89a")
    with pytest.raises(FileNotFoundError, match=r"notes\.txt.*clip\.gif|clip\.gif.*notes\.txt"):
        VideoSource.from_folder(tmp_path)
    with pytest.raises(ValueError, match="empty list"):
        VideoSource([])


def test_frame_folders_are_checked_and_a_bad_frame_is_not_skipped(tmp_path):
    broken_start = _frames(tmp_path / "first" / "cows")
    (broken_start / "00000.jpg").write_bytes(b"not a jpeg")
    with pytest.raises(ValueError, match="00000.jpg does not decode"):
        VideoSource.from_folder(tmp_path / "first")
    broken_middle = _frames(tmp_path / "middle" / "bear")
    (broken_middle / "00002.jpg").write_bytes(b"not a jpeg")
    source = VideoSource.from_folder(tmp_path / "middle")  # the first frame reads: found when played
    with pytest.raises(OSError, match="00002.jpg"):
        source.frames(0, 8, 8)


def test_a_video_cut_in_the_middle_never_plays_short(tmp_path):
    """A cut AVI keeps its header (20 frames) but decodes fewer: an error naming it, not a shorter video."""
    (tmp_path / "whole").mkdir()
    whole = _avi(tmp_path / "whole" / "video0.avi")
    cut_folder = tmp_path / "cut"
    cut_folder.mkdir()
    cut = cut_folder / "video0.avi"
    cut.write_bytes(whole.read_bytes()[: int(0.9 * whole.stat().st_size)])
    assert VideoSource.from_folder(whole.parent, max_frames=50).frames(0, 8, 8).shape[0] == 20  # the uncut file is fine
    try:
        source = VideoSource.from_folder(cut_folder, max_frames=50)
    except ValueError as error:  # found at construction: as good
        assert str(cut) in str(error)
        return
    with pytest.raises(OSError, match=f"{cut}.*of its 20 frames"):
        source.frames(0, 8, 8)


@pytest.mark.skipif(not DMCGB.is_dir(), reason="the DMC-GB sample in ../shared/data/dmcgb is absent (a user's clone)")
@pytest.mark.parametrize("folder", ["video_easy", "video_hard"])
def test_real_dmcgb_videos_pass_the_checks(folder):
    source = VideoSource.from_folder(DMCGB / folder)
    assert len(source) == len(list((DMCGB / folder).glob("*.mp4")))
    assert source.frames(0, 16, 16).shape[1:] == (16, 16, 3)


def test_a_folder_plays_dmcgb_videos_in_dmcgb_order(tmp_path):
    """DMC-GB and DMC-GB2 list video{i}.mp4 for i in range(n): index i is video{i}.mp4, not the i-th name as text."""
    for i in range(100):
        _mp4(tmp_path / f"video{i}.mp4", frames=2, size=(8, 8))
    source = VideoSource.from_folder(tmp_path, max_frames=2)
    assert [path.name for path in source.paths] == [f"video{i}.mp4" for i in range(100)]
    assert source.paths[2].name == "video2.mp4" and source.paths[10].name == "video10.mp4"
    assert VideoBackground(videos=tmp_path).videos.paths == source.paths


def test_natural_order_is_deterministic_for_any_names(tmp_path):
    names = ["b10", "b9", "a", "A", "10", "9b", "video01.mp4", "video1.mp4", "video001.mp4", "x.2", "x.10"]
    expected = ["9b", "10", "A", "a", "b9", "b10", "video001.mp4", "video01.mp4", "video1.mp4", "x.2", "x.10"]
    assert sorted(names, key=natural_key) == sorted(reversed(names), key=natural_key) == expected
    (tmp_path / "nested").mkdir()
    for name in ("clip2.avi", "clip10.avi", "clip1.avi"):
        _avi(tmp_path / "nested" / name, frames=2)
    _frames(tmp_path / "frames20" / "bear", count=2)
    _frames(tmp_path / "frames3" / "bear", count=2)
    source = VideoSource.from_folder(tmp_path)
    assert [path.relative_to(tmp_path).as_posix() for path in source.paths] == [
        "frames3/bear", "frames20/bear", "nested/clip1.avi", "nested/clip2.avi", "nested/clip10.avi"]


@pytest.mark.skipif(not DMCGB.is_dir(), reason="the DMC-GB sample in ../shared/data/dmcgb is absent (a user's clone)")
def test_real_dmcgb_videos_play_in_dmcgb_order(tmp_path):
    """DMC-GB's own files under DMC-GB's names video0 … video11 (the sample's 3 videos, linked in turn): index i is video{i}."""
    sample = sorted((DMCGB / "video_hard").glob("video*.mp4"))
    for i in range(12):
        (tmp_path / f"video{i}.mp4").symlink_to(sample[i % len(sample)])
    source = VideoSource.from_folder(tmp_path, max_frames=3)
    assert [path.name for path in source.paths] == [f"video{i}.mp4" for i in range(12)]
    for i in (2, 10, 11):
        assert torch.equal(source.frames(i, 16, 16), VideoSource([sample[i % len(sample)]], max_frames=3).frames(0, 16, 16))

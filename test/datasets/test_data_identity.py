"""What a level showed, by identity: DMC-GB's own files (``../shared/data/dmcgb``) are named as its data set part and
verified by their pinned git blob ids; a renamed or foreign file makes the folder a user's; no label holds a path."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest

from vigen.assets.video_source import VideoSource
from vigen.datasets import get_dataset
from vigen.datasets.identity import DataIdentity, identify_files, parse_identity
from vigen.transforms import RandomSceneColors

SAMPLE = Path(__file__).parents[2] / ".." / "shared" / "data" / "dmcgb"
needs_sample = pytest.mark.skipif(not (SAMPLE / "video_easy").is_dir(),
                                  reason=f"DMC-GB's sample data is not at {SAMPLE} (the shared data folder beside the project)")


@needs_sample
def test_dmcgb_files_are_named_as_their_part_and_verified(tmp_path):
    easy = VideoSource.from_folder(SAMPLE / "video_easy").identity
    assert str(easy) == "dmcgb-videos/video_easy: 2 of 10, verified" and not easy.full, "2 of DMC-GB's 10 video_easy files"
    all_ten = DataIdentity("dmcgb-videos", "video_easy", 10, len(get_dataset("dmcgb-videos").files_of("video_easy")), "verified")
    assert all_ten.full and str(all_ten) == "dmcgb-videos/video_easy: 10 of 10, verified"
    folder = tmp_path / "mine"
    shutil.copytree(SAMPLE / "video_easy", folder)
    assert str(VideoSource.from_folder(folder).identity) == "dmcgb-videos/video_easy: 2 of 10, verified", "a copy is the same data"
    (folder / "video1.mp4").rename(folder / "video5.mp4")  # DMC-GB's video1 under video5's name: another episode order
    assert str(VideoSource.from_folder(folder).identity) == "user folder: 2 videos, 1 of them dmcgb-videos/video_easy files"
    shutil.copy(SAMPLE / "video_hard" / "video0.mp4", folder / "video0.mp4")  # video_hard's video0 in place of video_easy's
    assert str(VideoSource.from_folder(folder).identity) == "user folder: 2 videos, 1 of them dmcgb-videos/video_hard files"
    mixed = identify_files([SAMPLE / "video_easy" / "video0.mp4", SAMPLE / "video_hard" / "video1.mp4"],
                           [get_dataset("dmcgb-videos")])
    assert mixed.dataset is None and mixed.note == "1 of them dmcgb-videos/video_easy files, 1 of them dmcgb-videos/video_hard files"


@needs_sample
def test_dmcgb_preset_files_are_verified_and_the_shipped_presets_named_as_shipped(tmp_path):
    assert RandomSceneColors(palette=str(SAMPLE / "color_easy.pt")).data_source == "dmcgb-colors/color_easy: 100 of 100, verified"
    assert RandomSceneColors(palette="color_easy").data_source == "dmcgb-colors/color_easy: 100 of 100, shipped"
    copy = tmp_path / "color_easy.pt"
    copy.write_bytes((SAMPLE / "color_easy.pt").read_bytes() + b"\0")  # one byte more: the same presets, not DMC-GB's file
    assert RandomSceneColors(palette=str(copy)).data_source == "user file: 100 presets"


@pytest.mark.parametrize("label", ["dmcgb-videos/video_hard: 100 of 100, verified", "user folder: 7 videos",
                                   "dmcgb-colors/color_easy: 100 of 100, shipped, cycled as DMC-GB2 does",
                                   "dmcgb-videos/video_easy: 6 of 10, not verified, given as a folder",
                                   "davis2017/train: 60 of 60, fetched", "davis2017/train: 60 of 60, verified",
                                   "davis2017/train: 2 of 60, not verified", "user file: 1 preset"])
def test_labels_read_back_as_they_were_written(label):
    assert str(parse_identity(label)) == label


def test_only_a_whole_part_verified_or_shipped_is_full():
    full = {label: parse_identity(label).full for label in (
        "dmcgb-videos/video_hard: 100 of 100, verified", "dmcgb-colors/color_hard: 100 of 100, shipped",
        "dmcgb-videos/video_hard: 99 of 100, verified", "dmcgb-videos/video_hard: 100 of 100, not verified",
        "davis2017/train: 60 of 60, fetched", "user folder: 100 videos")}
    assert list(full.values()) == [True, True, False, False, False, False]
    assert parse_identity("/home/me/dmcgb-videos/video_hard: 100 videos") is None, "a path names no data set"
    with pytest.raises(ValueError, match="check must be one of"):
        DataIdentity("dmcgb-videos", "video_hard", 1, 100, "trusted")


def davis_frames(videos: dict[str, list[str]]) -> dict[str, bytes]:
    """Members of a made-up DAVIS 2017 archive whose frames decode (one black 8x8 JPEG per frame): split -> video names."""
    import cv2
    import numpy as np

    frame = cv2.imencode(".jpg", np.zeros((8, 8, 3), np.uint8))[1].tobytes()
    members = {f"DAVIS/ImageSets/2017/{split}.txt": "".join(f"{name}\n" for name in names).encode()
               for split, names in videos.items()}
    members.update({f"DAVIS/JPEGImages/480p/{name}/00000.jpg": frame for names in videos.values() for name in names})
    return members


def test_the_fetched_davis_split_is_verified_when_extracted_from_the_pinned_archive(server, served_davis, isolated_cache,
                                                                                  tmp_path):
    from vigen.datasets import fetch

    served_davis(davis_frames({"train": ["bear", "boat"], "val": ["dog"]}))  # the test's archive, and its pin
    folder = fetch("davis2017", mirror=server.url)
    davis = folder / "DAVIS"
    label = str(VideoSource.from_folder(davis, split="train").identity)
    assert label == "davis2017/train: 2 of 2, verified" and parse_identity(label).full
    assert str(VideoSource.from_folder(davis / "JPEGImages" / "480p", split="val").identity) == "davis2017/val: 1 of 1, verified"

    (davis / "JPEGImages" / "480p" / "bear" / "00001.jpg").write_bytes(b"a frame the fetch did not record")
    assert str(VideoSource.from_folder(davis, split="train").identity) == "davis2017/train: 2 of 2, not verified"

    elsewhere = tmp_path / "mine"
    shutil.copytree(davis, elsewhere / "DAVIS")
    assert str(VideoSource.from_folder(elsewhere / "DAVIS", split="train").identity) == \
        "user folder: 2 videos, DAVIS 2017 layout, train split"


def test_a_davis_folder_placed_in_the_cache_by_hand_is_not_verified(server, isolated_cache, tmp_path):
    from vigen.datasets import fetch

    for name, data in davis_frames({"train": ["bear", "boat"], "val": ["dog"]}).items():
        (isolated_cache / "davis2017" / name).parent.mkdir(parents=True, exist_ok=True)
        (isolated_cache / "davis2017" / name).write_bytes(data)
    folder = fetch("davis2017", mirror=server.url)  # records it, downloads nothing
    label = str(VideoSource.from_folder(folder / "DAVIS", split="train").identity)
    assert label == "davis2017/train: 2 of 2, not verified" and not parse_identity(label).full
    assert not parse_identity("davis2017/train: 60 of 60, fetched").full, "older rows: the archive was not pinned then"

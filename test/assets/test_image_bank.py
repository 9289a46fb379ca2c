"""The overlay image bank: built in without downloads, or read from a user folder (Places365 layout)."""

from __future__ import annotations

import pickle

import cv2
import numpy as np
import pytest
import torch

from vigen.transforms import ImageBank, RandomOverlay


def test_builtin_has_at_least_100_distinct_images_and_is_reproducible():
    bank = ImageBank.builtin(size=32)
    assert len(bank) >= 100
    distinct = {tuple(image.flatten().tolist()) for image in bank.images}
    assert len(distinct) >= 100
    assert torch.equal(bank.images, ImageBank.builtin(size=32).images)
    assert bank.images.float().std(dim=(1, 2, 3)).min() > 1, "no flat images"


def test_resized_once_per_size():
    bank = ImageBank.builtin(size=32, procedural=4)
    first = bank.resized(20, 24)
    assert first.shape == (len(bank), 3, 20, 24) and first.dtype == torch.uint8
    assert bank.resized(20, 24) is first
    assert pickle.loads(pickle.dumps(bank))._resized == {}, "caches are rebuilt, not shipped to workers"


@pytest.fixture
def places_folder(tmp_path):
    """A tiny stand-in for places365_standard/train/<class>/*.jpg."""
    root = tmp_path / "places365_standard" / "train"
    colors = {"beach": (0, 0, 255), "forest": (0, 255, 0), "sky": (255, 0, 0)}  # BGR: red, green, blue
    for name, bgr in colors.items():
        (root / name).mkdir(parents=True)
        for i in range(2):
            image = np.zeros((60, 90, 3), np.uint8)
            image[:] = bgr
            cv2.imwrite(str(root / name / f"{i}.png"), image)
    (root / "notes.txt").write_text("not an image")
    return tmp_path


def test_from_folder_reads_rgb_images_recursively(places_folder):
    bank = ImageBank.from_folder(places_folder, size=16)
    assert len(bank) == 6 and bank.images.shape == (6, 3, 16, 16)
    means = bank.images.float().mean(dim=(2, 3))
    assert {int(means[i].argmax()) for i in range(6)} == {0, 1, 2}
    assert means[0].tolist() == [255.0, 0.0, 0.0], "sorted paths: beach (red) first, decoded as RGB"


def test_from_folder_caps_the_number_of_images(places_folder):
    bank = ImageBank.from_folder(places_folder, size=8, max_images=4, seed=1)
    assert len(bank) == 4
    assert torch.equal(bank.images, ImageBank.from_folder(places_folder, size=8, max_images=4, seed=1).images)


def test_overlay_reads_a_user_folder(places_folder):
    overlay = RandomOverlay(alpha=1.0, images=places_folder, seed=0)
    out = overlay(pixels=torch.zeros(5, 6, 16, 16, dtype=torch.uint8))
    assert set(out.flatten().tolist()) <= {0, 255}
    assert torch.equal(out[:, :3], out[:, 3:]), "one image per sample, on every frame"


def test_missing_or_empty_folders(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        ImageBank.from_folder(tmp_path / "nowhere")
    with pytest.raises(FileNotFoundError, match="No images"):
        ImageBank.from_folder(tmp_path)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        RandomOverlay(images=tmp_path / "nowhere")


def test_a_file_given_as_the_overlay_folder_is_named_as_a_file(tmp_path):
    from vigen.transforms import RandomShiftedOverlay

    picture = tmp_path / "picture.png"
    picture.write_bytes(b"not a folder")
    for overlay in (RandomOverlay, RandomShiftedOverlay):
        with pytest.raises(NotADirectoryError, match="picture.png is a file, not a folder; give the folder"):
            overlay(images=picture)


def test_bad_tensor():
    with pytest.raises(ValueError, match="uint8"):
        ImageBank(torch.zeros(2, 3, 8, 8))

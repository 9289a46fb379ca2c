"""Named generalization levels through make_env, the level table, video backgrounds and floor textures."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch
from torchrl.envs import ParallelEnv
from torchrl.envs.utils import check_env_specs

from vigen.envs import make_env
from vigen.envs.levels import levels_markdown, resolve_levels
from vigen.envs.dmc.suite import DMC, GROUPS, LEVELS


def level_transforms(level, seed=None, **options):
    return DMC.level_transforms("walker-walk", level, seed=seed, **options)
from vigen.rendering import RenderSettings
from vigen.transforms import ImageBank, PixelCorruption, RandomTextures, VideoBackground, VideoSource

ROOT = Path(__file__).resolve().parents[2]
DMCGB = ROOT.parent / "shared" / "data" / "dmcgb"
FAST = RenderSettings.fast()
SCENE_LEVELS = [
    "color_easy", "color_hard", "objects_color_hard", "floor_texture", "video_easy", "video_hard",
    "light_easy", "light_hard", "camera_easy", "camera_hard",
]


def walker(level=None, seed: int = 0, **kwargs):
    return make_env("dmc/walker-walk", generalization=level, seed=seed, image_size=48, render_settings=FAST, **kwargs)


def test_docs_table_matches_the_registry():
    assert (ROOT / "docs" / "levels.md").read_text() == levels_markdown(), "run: python -m vigen.envs.levels > docs/levels.md"
    for level in LEVELS:
        assert f"| `{level}` |" in levels_markdown()


def test_every_level_builds_its_transforms():
    for level in LEVELS:
        assert len(level_transforms(level, seed=0)) == len(LEVELS[level].steps)
    assert resolve_levels("all") == list(LEVELS)
    assert set(resolve_levels(["dmcgb", "rlvigen"])) <= set(LEVELS)
    assert len(GROUPS["corruptions"]) == 25


def test_unknown_level_lists_the_valid_ones():
    with pytest.raises(ValueError, match="Levels: train, color_easy"):
        walker("colour_hard")
    with pytest.raises(ValueError, match="group of levels"):
        level_transforms("dmcgb")
    with pytest.raises(TypeError, match="list of TorchRL transforms"):
        walker(["color_hard"])


@pytest.mark.render
def test_train_is_the_clean_env():
    def rollout(env):
        actions = iter(torch.linspace(-1, 1, 30).reshape(5, 6))
        return env.rollout(5, lambda td: td.set("action", next(actions)), break_when_any_done=False)

    clean = rollout(make_env("dmc/walker-walk", seed=0, image_size=48, render_settings=FAST))
    train = rollout(walker("train"))
    assert torch.equal(clean["pixels"], train["pixels"]) and torch.equal(clean["next", "reward"], train["next", "reward"])


@pytest.mark.render
@pytest.mark.parametrize("level", SCENE_LEVELS + ["gaussian_noise_1", "gaussian_blur_1", "jpeg_compression_1", "contrast_1", "brightness_1"])
def test_each_level_changes_the_first_frame_and_passes_specs(level):
    clean = walker("train").reset()["pixels"].float()
    env = walker(level)
    perturbed = env.reset()["pixels"].float()
    threshold = 0.25 if level == "gaussian_blur_1" else 1.0  # sigma 0.375 px: mild by design
    assert (clean - perturbed).abs().mean() > threshold
    check_env_specs(env)


@pytest.mark.render
@pytest.mark.parametrize("level", ["color_hard", "video_hard", "camera_hard", "gaussian_noise_5"])
def test_levels_are_seeded(level):
    def frames(seed):
        env = walker(level, seed=seed)
        return torch.stack([env.reset()["pixels"] for _ in range(2)])

    assert torch.equal(frames(3), frames(3))
    assert not torch.equal(frames(3), frames(4))


@pytest.mark.render
def test_user_transform_list():
    env = walker([PixelCorruption("contrast", 5), RandomTextures(seed=1)])
    names = [type(t).__name__ for t in env.transform]
    assert names.index("RandomTextures") < names.index("ToTensorImage") < names.index("PixelCorruption")
    check_env_specs(env)


@pytest.mark.render
@pytest.mark.slow
def test_levels_inside_parallel_env():
    env = ParallelEnv(2, partial(walker, "video_hard"))
    try:
        check_env_specs(env)
    finally:
        env.close()


@pytest.mark.render
class TestVideoBackground:
    def test_background_changes_every_step_and_the_agent_is_kept(self):
        video = VideoBackground(floor=True, seed=0)
        env = make_env("dmc/walker-walk", generalization=[video], seed=0, image_size=48, frame_stack=1, render_settings=FAST)
        clean = make_env("dmc/walker-walk", seed=0, image_size=48, frame_stack=1, render_settings=FAST)
        actions = torch.zeros(6, 6)
        step = iter(actions)
        policy = lambda td: td.set("action", next(step))  # noqa: E731
        ours = env.rollout(6, policy, break_when_any_done=False)["next", "pixels"]
        step = iter(actions)
        theirs = clean.rollout(6, policy, break_when_any_done=False)["next", "pixels"]
        mask = torch.from_numpy(video.background_mask(env.base_env.scene))  # last frame's segmentation
        agent = ~mask
        assert agent.float().mean() > 0.02, "the walker must be in view for this test"
        assert torch.equal(ours[-1][:, agent], theirs[-1][:, agent]), "agent pixels are never replaced"
        assert not torch.equal(ours[-1][:, mask], theirs[-1][:, mask])
        background = [ours[t][:, mask] for t in range(6)]
        changes = [not torch.equal(background[t], background[t + 1]) for t in range(5)]
        assert all(changes), "the background plays a new frame every step"

    def test_easy_keeps_the_floor(self):
        video = VideoBackground(floor=False, seed=0)
        env = make_env("dmc/walker-walk", generalization=[video], seed=0, image_size=48, frame_stack=1, render_settings=FAST)
        env.reset()
        easy = video.background_mask(env.base_env.scene)
        hard = VideoBackground(floor=True)
        env.append_transform(hard)
        assert hard.background_mask(env.base_env.scene).sum() > easy.sum() > 0

    def test_videos_in_order_one_per_episode(self):
        video = VideoBackground(VideoSource.procedural(count=3, max_frames=5), seed=0)
        env = make_env("dmc/walker-walk", generalization=[video], image_size=32, render_settings=FAST)
        order = []
        for _ in range(4):
            env.reset()
            order.append(video.params["video"])
        assert [(b - a) % 3 for a, b in zip(order, order[1:])] == [1, 1, 1]

    def test_stacked_frames_are_refused(self):
        env = make_env("dmc/walker-walk", image_size=32, render_settings=FAST).append_transform(VideoBackground())
        with pytest.raises(ValueError, match=r"after ToTensorImage.*insert_transform\(0, VideoBackground"):
            env.reset()


def test_video_source_reads_videos_and_frame_folders(tmp_path):
    writer = cv2.VideoWriter(str(tmp_path / "clip.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 25, (40, 30))
    for i in range(7):
        writer.write(np.full((30, 40, 3), (0, 0, 30 * i), np.uint8))  # BGR: red ramps up
    writer.release()
    (tmp_path / "davis" / "bear").mkdir(parents=True)
    for i in range(4):
        cv2.imwrite(str(tmp_path / "davis" / "bear" / f"{i:05d}.jpg"), np.full((30, 40, 3), (200, 0, 0), np.uint8))
    source = VideoSource.from_folder(tmp_path, max_frames=5)
    assert len(source) == 2
    clip = source.frames(0, 16, 16)  # sorted: clip.mp4 before davis/bear
    assert clip.shape == (5, 16, 16, 3) and clip[-1, ..., 0].float().mean() > clip[0, ..., 0].float().mean() + 50
    frames = source.frames(1, 16, 16)
    assert frames.shape == (4, 16, 16, 3) and frames[..., 2].float().mean() > 150, "decoded as RGB"
    with pytest.raises(FileNotFoundError, match="does not exist"):
        VideoSource.from_folder(tmp_path / "nowhere")


@pytest.mark.skipif(not DMCGB.is_dir(), reason="the DMC-GB sample in ../shared/data/dmcgb is absent (a user's clone)")
def test_dmcgb_videos():
    source = VideoSource.from_folder(DMCGB / "video_hard")
    assert len(source) == 3
    frames = source.frames(0, 84, 84)
    assert frames.shape[1:] == (84, 84, 3) and frames.shape[0] == 500 and frames.float().std() > 10


def test_procedural_videos_move():
    frames = VideoSource.procedural(count=2, max_frames=10).frames(1, 32, 32).float()
    assert ((frames[1:] - frames[:-1]).abs().mean(dim=(1, 2, 3)) > 0.5).all()


@pytest.mark.render
def test_textures_with_a_scene_id_draw_the_same_images_every_episode():
    bank = ImageBank.procedural(6, size=16, seed=0)
    textures = RandomTextures(("grid", "skybox"), images=bank, scene_id=4, seed=0)
    env = walker([textures])
    model = env.base_env.scene.model
    original = model.tex_data.copy()
    env.reset()
    first = model.tex_data.copy()
    assert (first[model.tex_adr[0]:] != original[model.tex_adr[0]:]).mean() > 0.5, "both textures replaced"
    for _ in range(3):
        env.reset()
        assert np.array_equal(model.tex_data, first)
    assert textures.params["images"].tolist() == np.random.default_rng(4).integers(6, size=2).tolist(), "drawn from the scene id"
    textures.restore()
    assert np.array_equal(model.tex_data, original)
    with pytest.raises(ValueError, match="no texture named 'carpet'"):
        walker([RandomTextures("carpet", images=bank)]).reset()


@pytest.mark.render
def test_floor_texture_writes_the_image_and_restores():
    bank = ImageBank(torch.full((1, 3, 8, 8), 200, dtype=torch.uint8).index_fill_(1, torch.tensor([1]), 10))
    floor = RandomTextures(images=bank, seed=0)
    env = walker([floor])
    model = env.base_env.scene.model
    original = model.tex_data.copy()
    env.reset()
    grid = model.tex_data[model.tex_adr[1] : model.tex_adr[1] + 300 * 300 * 3].reshape(-1, 3)
    assert (grid == np.array([200, 10, 200], np.uint8)).all()
    floor.restore()
    assert np.array_equal(model.tex_data, original)

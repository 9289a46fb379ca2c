"""Scene perturbations on a real dm_control scene: visible, seeded, drift-free, restorable."""

from __future__ import annotations

from functools import partial
from pathlib import Path

import mujoco
import numpy as np
import pytest
import torch
from tensordict import TensorDict
from torchrl.envs import ParallelEnv, SerialEnv, TransformedEnv
from torchrl.envs.utils import check_env_specs

from vigen.envs import make_env
from vigen.rendering import RenderSettings
from vigen.transforms import (
    RandomCamera,
    RandomLighting,
    RandomMaterialColors,
    RandomSceneColors,
    VideoBackground,
    VideoSource,
    load_dmcgb_palette,
)

pytestmark = pytest.mark.render

DMCGB = Path(__file__).resolve().parents[3] / "shared" / "data" / "dmcgb"
FAST = RenderSettings.fast()

PERTURBATIONS = {
    "colors_easy": partial(RandomSceneColors, scale=0.1),
    "colors_hard": partial(RandomSceneColors, scale=0.2),
    "self_color": partial(RandomSceneColors, scale=0.2, parts=("self",)),
    "light_easy": partial(RandomLighting.rlvigen, "easy"),
    "light_hard": partial(RandomLighting.rlvigen, "hard"),
    "camera": partial(RandomCamera, position=0.15, rotation_deg=9, fov_deg=(-10, 10)),
    "material_colors": partial(RandomMaterialColors, mix=0.5),
}
MODEL_FIELDS = ["mat_rgba", "geom_rgba", "tex_data", "light_pos", "light_pos0", "light_poscom0", "light_diffuse", "cam_pos",
                "cam_pos0", "cam_poscom0", "cam_quat", "cam_mat0", "cam_fovy"]


def walker(perturbation=None, seed: int = 0, size: int = 48) -> TransformedEnv:
    env = make_env("dmc/walker-walk", seed=seed, frame_stack=1, image_size=size, render_settings=FAST)
    return env if perturbation is None else env.append_transform(perturbation)


def snapshot(env) -> dict[str, np.ndarray]:
    model = env.base_env.scene.model
    return {name: getattr(model, name).copy() for name in MODEL_FIELDS}


@pytest.mark.parametrize("name", PERTURBATIONS)
class TestScenePerturbation:
    def test_changes_the_first_frame(self, name):
        clean = walker().reset()["pixels"].float()
        perturbed = walker(PERTURBATIONS[name](seed=0)).reset()["pixels"].float()
        assert (clean - perturbed).abs().mean() > 1.0

    def test_same_seed_same_frames_different_seed_different(self, name):
        def frames(seed):
            env = walker(PERTURBATIONS[name](seed=seed))
            return torch.stack([env.reset()["pixels"] for _ in range(2)])

        assert torch.equal(frames(1), frames(1))
        assert not torch.equal(frames(1), frames(2))

    def test_no_drift_and_exact_restore(self, name):
        env = walker()
        original = snapshot(env)
        perturbation = PERTURBATIONS[name](seed=0)
        env = env.append_transform(perturbation)
        scene = env.base_env.scene
        expected = walker(None).base_env.scene  # a pristine model: each draw is applied to it once
        expected_defaults = perturbation.read_defaults(expected)
        for _ in range(20):
            env.reset()
            perturbation.apply(expected, expected_defaults, perturbation.params)
            for field in MODEL_FIELDS:
                assert np.array_equal(getattr(scene.model, field), getattr(expected.model, field)), field
        perturbation.restore()
        for field, value in snapshot(env).items():
            assert np.array_equal(value, original[field]), f"{field} not restored"

    def test_check_env_specs(self, name):
        check_env_specs(walker(PERTURBATIONS[name](seed=0)))

    def test_repr(self, name):
        text = repr(PERTURBATIONS[name](seed=3))
        assert text.endswith("seed=3)") and "(" in text


def test_moving_light_moves_every_step_within_its_range():
    lighting = RandomLighting(position_offset=None, diffuse_offset=None, moving_step=0.05, moving_range=0.12, seed=0)
    env = walker(lighting)
    model = env.base_env.scene.model
    env.reset()
    start = model.light_poscom0.copy()
    positions = []
    state = env.reset()
    for _ in range(8):
        state = env.step(state.set("action", torch.zeros(6)))["next"]
        positions.append(model.light_poscom0.copy())
    steps = np.diff(np.stack(positions), axis=0)
    assert (np.abs(steps) > 0).all(), "the light moves at every step"
    assert (np.abs(np.stack(positions) - start) <= 0.12 + 1e-9).all(), "and turns at its range"
    assert (steps > 0).any() and (steps < 0).any()


def test_material_colors_mix_the_default_with_a_uniform_draw():
    colors = RandomMaterialColors(mix=0.3, include=("self", "torso"), exclude=("self_default",), seed=0)
    env = walker(colors)
    model = env.base_env.scene.model
    defaults = colors.read_defaults(env.base_env.scene)
    names = [model.material(int(i)).name for i in defaults["materials"]] + [model.geom(int(i)).name for i in defaults["geoms"]]
    assert "self" in names and "self_default" not in names and all(n.startswith(("self", "torso")) for n in names)
    env.reset()
    u = colors.params["colors"]
    assert ((u >= 0) & (u <= 1)).all() and len(np.unique(u, axis=0)) == len(u), "one draw per part"
    expected = 0.7 * np.concatenate([defaults["material_rgb"], defaults["geom_rgb"]]) + 0.3 * u
    actual = np.concatenate([model.mat_rgba[defaults["materials"], :3], model.geom_rgba[defaults["geoms"], :3]])
    np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-6)

    shared = RandomMaterialColors(mix=1.0, include=("self",), shared=True, seed=0)
    env = walker(shared)
    env.reset()
    draws = shared.params["colors"]
    assert (draws == draws[0]).all()
    assert np.allclose(env.base_env.scene.model.mat_rgba[shared.defaults(env.base_env.scene)["materials"], :3], draws[0])
    with pytest.raises(ValueError, match="selects no material or geom"):
        walker(RandomMaterialColors(include=("no_such_part",))).reset()
    with pytest.raises(ValueError, match="between 0 and 1"):
        RandomMaterialColors(mix=1.5)


def test_material_colors_shift_adds_one_normal_offset_and_clips():
    shifted = RandomMaterialColors(mix=0.0, shift=0.2, include=("self", "torso"), exclude=("self_default",), shared=True, seed=0)
    env = walker(shifted)
    model = env.base_env.scene.model
    defaults = shifted.read_defaults(env.base_env.scene)
    env.reset()
    offsets = shifted.params["offsets"]
    assert (offsets == offsets[0]).all(), "shared: one offset for every part"
    expected = np.clip(np.concatenate([defaults["material_rgb"], defaults["geom_rgb"]]) + offsets, 0.0, 1.0)
    actual = np.concatenate([model.mat_rgba[defaults["materials"], :3], model.geom_rgba[defaults["geoms"], :3]])
    np.testing.assert_allclose(actual, expected, rtol=0, atol=1e-6)
    assert "offsets" not in RandomMaterialColors(mix=0.5, seed=0).sample(np.random.default_rng(0), defaults), "no shift, no draw"
    with pytest.raises(ValueError, match="shift is the standard deviation"):
        RandomMaterialColors(shift=-0.1)


def test_light_height_sets_every_light_then_restores():
    lighting = RandomLighting(position_offset=None, diffuse_offset=None, height=4.0, seed=0)
    env = walker(lighting)
    model = env.base_env.scene.model
    before = model.light_pos.copy()
    env.reset()
    assert np.allclose(model.light_pos[:, 2], 4.0) and np.array_equal(model.light_pos[:, :2], before[:, :2])
    lighting.restore()
    assert np.array_equal(model.light_pos, before)


def test_inside_parallel_env_workers():
    env = ParallelEnv(2, [partial(walker, RandomSceneColors(scale=0.2), seed=0), partial(walker, RandomCamera(0.1), seed=1)])
    try:
        check_env_specs(env)
    finally:
        env.close()


def test_outside_a_single_env_is_an_error():
    with pytest.raises(RuntimeError, match="inside a single vigen env"):
        TransformedEnv(SerialEnv(1, walker), RandomSceneColors()).reset()
    with pytest.raises(RuntimeError, match="works inside an env"):
        RandomSceneColors()(TensorDict(pixels=torch.zeros(3, 8, 8)))


@pytest.mark.skipif(not DMCGB.is_dir(), reason="the DMC-GB sample in ../shared/data/dmcgb is absent (a user's clone)")
def test_dmcgb_palette_reproduces_its_colors():
    palette = load_dmcgb_palette(DMCGB / "color_hard.pt")
    assert len(palette) == 100 and np.allclose(palette[0]["grid_rgb2"], palette[0]["grid_rgb1"] + 0.1)
    colors = RandomSceneColors(palette=palette[:1], seed=0)
    env = walker(colors)
    env.reset()
    model = env.base_env.scene.model
    entry = palette[0]
    assert np.allclose(model.mat_rgba[colors._defaults["self_material"], :3], entry["self_rgb"], atol=1e-6)
    grid = model.tex_data[model.tex_adr[1] : model.tex_adr[1] + 300 * 300 * 3].reshape(-1, 3)
    found = {tuple(c) for c in np.unique(grid, axis=0)}
    assert tuple(np.rint(entry["grid_rgb1"] * 255).astype(np.uint8)) in found
    assert tuple(np.rint(entry["grid_rgb2"] * 255).astype(np.uint8)) in found


def test_palette_loader_refuses_code(tmp_path):
    import pickle

    class Exploit:
        def __reduce__(self):
            return (print, ("this must not run",))

    bad = tmp_path / "color_bad.pt"
    bad.write_bytes(pickle.dumps([Exploit()]))
    with pytest.raises(Exception, match="(?i)weights.only|unsupported|global"):
        load_dmcgb_palette(bad)
    with pytest.raises(FileNotFoundError, match="does not exist"):
        load_dmcgb_palette(tmp_path / "missing.pt")


def test_video_background_bounce_turns_at_the_ends_as_dcs():
    # distracting_control/background.py step(): i += d; i <= 0 -> i = 0, d = +1; i >= n -> i = n - 1, d = -1
    video = VideoBackground(VideoSource.procedural(count=2, max_frames=3), playback="bounce")
    video.params = {"video": 0, "frame": None, "start": 0.5, "direction": 1}
    assert [video.frame_after(3, 0)] + [video.frame_after(3, 1) for _ in range(8)] == [1, 2, 2, 1, 0, 1, 2, 2, 1]
    video.params = {"video": 0, "frame": None, "start": 0.0, "direction": -1}
    assert [video.frame_after(3, 0)] + [video.frame_after(3, 1) for _ in range(3)] == [0, 0, 1, 2]
    video.params = {"video": 0, "frame": None, "start": 0.5, "direction": 1}
    assert [video.frame_after(3, 0), video.frame_after(3, 3), video.frame_after(3, 2)] == [1, 1, 1]  # 2, 2, 1 | 0, 1
    static = VideoBackground(VideoSource.procedural(count=2, max_frames=3), playback="static")
    static.params = {"video": 1, "frame": None, "start": 0.99, "direction": 1}
    assert [static.frame_after(3, 0)] + [static.frame_after(3, 1) for _ in range(2)] == [2, 2, 2]


def test_video_background_dcs_draws_a_random_video_of_the_first_n():
    video = VideoBackground(VideoSource.procedural(count=5, max_frames=3), playback="static", num_videos=3, seed=0)
    draws = [video.sample(video.generator()) for _ in range(300)]
    assert {d["video"] for d in draws} == {0, 1, 2}, "DCS: choice over the first num_videos videos"
    starts = np.array([d["start"] for d in draws])
    assert starts.min() >= 0 and starts.max() < 1 and starts.min() < 0.02 and starts.max() > 0.98
    assert {d["direction"] for d in draws} == {-1, 1}
    again = VideoBackground(VideoSource.procedural(count=5, max_frames=3), playback="static", num_videos=3, seed=0)
    assert [again.sample(again.generator()) for _ in range(300)] == draws
    forward = VideoBackground(VideoSource.procedural(count=5, max_frames=3), num_videos=2, seed=0)
    videos = []
    for _ in range(4):
        forward.params = forward.sample(forward.generator())
        videos.append(forward.params["video"])
    assert sorted(set(videos)) == [0, 1] and videos[1] == (videos[0] + 1) % 2, "forward: in order over the first 2"
    for kwargs, match in [(dict(playback="loop"), "playback must be one of"), (dict(alpha=1.5), "alpha"),
                          (dict(num_videos=0), "num_videos"), (dict(num_videos=6), "num_videos=6")]:
        with pytest.raises(ValueError, match=match):
            VideoBackground(VideoSource.procedural(count=5, max_frames=3), **kwargs)


def test_video_background_first_video_starts_forward_playback_there_for_every_seed():
    source = VideoSource.procedural(count=5, max_frames=3)
    for seed in (0, 1, 2):
        video = VideoBackground(source, first_video=7, num_videos=3, seed=seed)
        videos = []
        for _ in range(4):
            video.params = video.sample(video.generator())
            videos.append(video.params["video"])
        assert videos == [1, 2, 0, 1], "first_video wraps over the videos played, then one on per episode"
        video.set_seed(seed + 10)
        video.params = video.sample(video.generator())
        assert video.params["video"] == 1, "reseeding restarts the count, as a new DMC-GB env does"
    seeded = {VideoBackground(source, seed=seed).sample(np.random.default_rng(seed))["video"] for seed in range(20)}
    assert len(seeded) > 1, "without first_video the start is drawn from the seed"
    assert "first_video=1" in repr(VideoBackground(source, first_video=1))
    for kwargs, match in [(dict(first_video=-1), "first_video is the index"), (dict(first_video=True), "first_video is the index"),
                          (dict(first_video=1.0), "first_video is the index"),
                          (dict(first_video=1, playback="static"), "does not apply with playback='static'"),
                          (dict(first_video=1, video=2), "fixed video=2")]:
        with pytest.raises(ValueError, match=match):
            VideoBackground(source, **kwargs)


def test_video_backgrounds_name_their_data_source(tmp_path):
    from vigen.transforms import DMCGB2VideoBackground

    assert VideoBackground().data_source == "procedural stand-in videos (10)" and VideoBackground().uses_stand_in
    assert VideoBackground(num_videos=4).data_source == "procedural stand-in videos (4)"
    assert VideoBackground(video=12).data_source == "procedural stand-in video 2 of 10"
    assert DMCGB2VideoBackground().data_source == "procedural stand-in videos (10)" and DMCGB2VideoBackground().uses_stand_in
    import cv2

    for i in range(3):
        writer = cv2.VideoWriter(str(tmp_path / f"video{i}.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 25, (8, 8))
        writer.write(np.zeros((8, 8, 3), np.uint8))
        writer.release()
    folder = VideoBackground(tmp_path)
    # named by identity, never by path: a folder of videos that are not a benchmark's pinned files is the user's
    assert folder.data_source == "user folder: 3 videos" and not folder.uses_stand_in
    assert VideoBackground(tmp_path, num_videos=2, playback="static").data_source == "user folder: 3 videos, the first 2 played"
    assert VideoBackground(tmp_path, num_videos=1).data_source == "user folder: 3 videos, the first 1 played"
    assert VideoBackground(tmp_path, video=4).data_source == "user folder: 3 videos, only video 1 played"
    assert DMCGB2VideoBackground(tmp_path).data_source == "user folder: 3 videos"
    davis = tmp_path / "DAVIS"
    (davis / "ImageSets" / "2017").mkdir(parents=True)
    (davis / "ImageSets" / "2017" / "train.txt").write_text("bear\nboat\n")
    (davis / "ImageSets" / "2017" / "val.txt").write_text("cows\n")
    for name in ("bear", "boat", "cows"):
        (davis / "JPEGImages" / "480p" / name).mkdir(parents=True)
        cv2.imwrite(str(davis / "JPEGImages" / "480p" / name / "00000.jpg"), np.zeros((8, 8, 3), np.uint8))
    assert VideoBackground(davis, split="train").data_source == "user folder: 2 videos, DAVIS 2017 layout, train split"
    assert VideoBackground(davis, split="val").data_source == "user folder: 1 video, DAVIS 2017 layout, val split"
    assert VideoBackground(davis).data_source == "user folder: 3 videos"
    assert str(tmp_path) not in VideoBackground(davis).data_source


def test_video_background_playbacks_composite_the_expected_frames():
    source = VideoSource.procedural(count=2, max_frames=4)

    def run(**kwargs):
        video = VideoBackground(source, **kwargs)
        env = make_env("dmc/walker-walk", generalization=[video], seed=0, frame_stack=1, image_size=32, render_settings=FAST)
        clean = make_env("dmc/walker-walk", seed=0, frame_stack=1, image_size=32, render_settings=FAST)
        frames, expected = [], []
        states = env.reset(), clean.reset()
        for step in range(4):
            if step:
                states = tuple(e.step(s.set("action", torch.zeros(6)))["next"] for e, s in zip((env, clean), states))
            mask = torch.from_numpy(video.background_mask(env.base_env.scene))[..., None]
            frames.append(states[0]["pixels"].permute(1, 2, 0))
            expected.append((mask, states[1]["pixels"].permute(1, 2, 0), source.frames(video.params["video"], 32, 32)))
        return video, frames, expected

    # forward (DMC-GB, the default): frame t at step t, replacing the background
    video, frames, expected = run()
    for t, (frame, (mask, clean, clip)) in enumerate(zip(frames, expected)):
        assert torch.equal(frame, torch.where(mask, clip[t % 4], clean))
    # static (DCS): one frame for the episode; alpha blends (1 - a) * render + a * video, truncated as DCS does
    video, frames, expected = run(playback="static", alpha=0.5)
    index = video.params["frame"]
    for frame, (mask, clean, clip) in zip(frames, expected):
        blend = (0.5 * clip[index].float() + 0.5 * clean.float()).to(torch.uint8)
        assert torch.equal(frame, torch.where(mask, blend, clean))
    assert "playback='static', alpha=0.5" in repr(video)


def test_video_background_ground_plane_alpha_blends_the_floor_as_dcs():
    # suite_utils.get_background_kwargs: the grid's alpha is 0.3 outside walker / cheetah / reacher; DCS then sees
    # 0.7 of the (video) sky through the floor. vigen: floor pixels = 0.3 * render + 0.7 * video.
    source = VideoSource.procedural(count=1, max_frames=2)
    video = VideoBackground(source, playback="static", ground_plane_alpha=0.3)
    env = make_env("dmc/walker-walk", generalization=[video], seed=0, frame_stack=1, image_size=32, render_settings=FAST)
    clean = make_env("dmc/walker-walk", seed=0, frame_stack=1, image_size=32, render_settings=FAST)
    frame, reference = env.reset()["pixels"].permute(1, 2, 0), clean.reset()["pixels"].permute(1, 2, 0)
    scene = env.base_env.scene
    segmentation = scene.segmentation()
    ids, types = segmentation[..., 0], segmentation[..., 1]
    planes = scene.model.geom_type[np.maximum(ids, 0)] == mujoco.mjtGeom.mjGEOM_PLANE
    floor = torch.from_numpy((types == mujoco.mjtObj.mjOBJ_GEOM) & (ids >= 0) & planes)[..., None]
    sky = torch.from_numpy(ids < 0)[..., None]
    clip = source.frames(0, 32, 32)[video.params["frame"]]
    assert floor.any() and sky.any()
    blend = (0.7 * clip.float() + 0.3 * reference.float()).to(torch.uint8)
    expected = torch.where(sky, clip, torch.where(floor, blend, reference))
    assert torch.equal(frame, expected)
    with pytest.raises(ValueError, match="pass one of them"):
        VideoBackground(source, floor=True, ground_plane_alpha=0.3)

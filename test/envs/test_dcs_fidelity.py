"""The Distracting Control Suite presets against the sources' rules: DAVIS split, grid-only floor alpha, skybox video, stepping.

Sources: google-research/google-research ``distracting_control/`` (commit 0c1bbe5f) and DMC-GB's
copy (nicklashansen/dmcontrol-generalization-benchmark ``src/env/distracting_control/``, ff9c0aa8):

* ``suite.py:45`` plays ``background_dataset_videos="train"``; ``background.py:119-143`` turns it
  into DAVIS 2017's train list, joined to the dataset path, and keeps the first ``num_videos``;
* ``background.py:154-158`` sets the alpha of the ``grid`` material only;
* ``background.py:160-213`` writes the frame into the skybox texture (texture 0, its height set
  to its width) and ``_apply`` re-uploads it;
* DMC-GB's wrappers count simulator (control) steps from the reset and move camera
  (``camera.py:283-292``), colours (``color.py:75-89``) and video (``background.py:217-238``) on
  the even ones; the original moves on every one. The pixel wrapper renders after the last one.
"""

from __future__ import annotations

from pathlib import Path

import mujoco
import numpy as np
import pytest
import torch

from vigen.envs import make_env
from vigen.envs.dmc.suite import DMC
from vigen.rendering import RenderSettings
from vigen.transforms import DistractingCamera, DistractingColors, VideoBackground, VideoSource
from vigen.transforms.scene.mujoco import texture_pixels

FAST = RenderSettings.fast()
TRAIN = ["boat", "bear", "bmx-bumps"]  # deliberately out of order: DCS's lists are in name order
VAL = ["blackswan", "bike-packing"]


def write_davis(root: Path, train=TRAIN, val=VAL, frames: int = 3, colours: dict | None = None) -> Path:
    """A tiny DAVIS 2017 layout: ImageSets/2017/{train,val}.txt and JPEGImages/480p/<video>/00000.jpg..."""
    import cv2

    lists = root / "ImageSets" / "2017"
    lists.mkdir(parents=True)
    (lists / "train.txt").write_text("\n".join(train) + "\n")
    (lists / "val.txt").write_text("\n".join(val) + "\n")
    for index, name in enumerate(train + val):
        folder = root / "JPEGImages" / "480p" / name
        folder.mkdir(parents=True)
        for frame in range(frames):
            bgr = (colours or {}).get(name, (10 * index, 40 * frame, 200))
            cv2.imwrite(str(folder / f"{frame:05d}.jpg"), np.full((12, 16, 3), bgr, dtype=np.uint8))
    return root


# -- 1. the DAVIS train split, first N in name order -----------------------------------------------------------------

@pytest.mark.parametrize("where", ["root", "frames"])
def test_dcs_levels_play_the_first_videos_of_the_davis_train_split(tmp_path, where):
    root = write_davis(tmp_path / "DAVIS")
    folder = root if where == "root" else root / "JPEGImages" / "480p"
    *_, video = DMC.level_transforms("walker-walk", "dcs_0.05", seed=0, videos=str(folder))
    # every video sorted would be bear, bike-packing (val), blackswan (val), bmx-bumps, boat
    assert [path.name for path in video.videos.paths] == ["bear", "bmx-bumps", "boat"]
    assert video.num_videos == 2  # suite_utils.DIFFICULTY_NUM_VIDEOS['0.05']
    draws = {video.sample(video.generator())["video"] for _ in range(50)}
    assert draws == {0, 1}, "DCS: a random one of the first num_videos of the train list"


def test_davis_split_lists_are_required_and_name_the_layout(tmp_path):
    root = write_davis(tmp_path / "DAVIS")
    frames = root / "JPEGImages" / "480p"
    (root / "ImageSets" / "2017" / "train.txt").unlink()
    with pytest.raises(FileNotFoundError, match=r"ImageSets/2017/train\.txt.*JPEGImages/480p"):
        DMC.level_transforms("walker-walk", "dcs_0.05", seed=0, videos=str(frames))
    # the documented fallback: every video under the folder, in name order
    *_, video = DMC.level_transforms("walker-walk", "dcs_0.05", seed=0, videos=str(frames), split=None)
    assert [path.name for path in video.videos.paths] == sorted(TRAIN + VAL)
    # a listed video without its frames is named
    (root / "ImageSets" / "2017" / "train.txt").write_text("bear\nelephant\n")
    with pytest.raises(FileNotFoundError, match="elephant"):
        VideoBackground(str(frames), split="train")
    with pytest.raises(ValueError, match="split"):
        VideoBackground(str(frames), split="test")
    # other levels keep reading every video of a folder
    (video_easy,) = DMC.level_transforms("walker-walk", "video_easy", seed=0, videos=str(frames))
    assert len(video_easy.videos) == 5


# -- 3. only the grid material becomes transparent --------------------------------------------------------------------

@pytest.mark.render
def test_ground_plane_alpha_touches_only_the_grid_material():
    source = VideoSource.procedural(count=1, max_frames=2)
    video = VideoBackground(source, playback="static", ground_plane_alpha=0.0)  # reacher's alpha
    env = make_env("dmc/reacher-easy", generalization=[video], seed=0, frame_stack=1, image_size=16, render_settings=FAST)
    env.reset()
    model = env.base_env.scene.model
    names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g) for g in np.flatnonzero(video.ground_geoms(model))]
    planes = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g)
              for g in np.flatnonzero(model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)]
    assert names == ["ground"], "DCS sets mat_rgba['grid', 'a'] only"
    assert set(planes) > set(names), "reacher's four decoration walls are planes too, and stay opaque"


@pytest.mark.render
def test_reacher_walls_stay_opaque_and_the_ground_shows_the_video():
    source = VideoSource.procedural(count=1, max_frames=2)
    # a tilted camera (reacher's own looks straight down on the edge-on walls)
    camera = DistractingCamera(0.5, limit_to_upper_quadrant=False, seed=3)
    video = VideoBackground(source, playback="static", ground_plane_alpha=0.0)
    env = make_env("dmc/reacher-easy", generalization=[camera, video], seed=0, frame_stack=1, image_size=64,
                   render_settings=FAST)
    clean = make_env("dmc/reacher-easy", generalization=[DistractingCamera(0.5, limit_to_upper_quadrant=False, seed=3)],
                     seed=0, frame_stack=1, image_size=64, render_settings=FAST)
    frame, reference = env.reset()["pixels"].permute(1, 2, 0), clean.reset()["pixels"].permute(1, 2, 0)
    scene = env.base_env.scene
    ids, types = (torch.from_numpy(part.copy()) for part in np.moveaxis(scene.segmentation(), -1, 0))
    is_geom = (types == int(mujoco.mjtObj.mjOBJ_GEOM)) & (ids >= 0)
    material = torch.from_numpy(scene.model.geom_matid)[ids.clamp(min=0)]
    decoration = mujoco.mj_name2id(scene.model, mujoco.mjtObj.mjOBJ_MATERIAL, "decoration")
    walls = is_geom & (material == decoration) & torch.from_numpy(scene.model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE)[
        ids.clamp(min=0)]
    ground = is_geom & (material == 0)
    assert walls.any() and ground.any()
    clip = source.frames(0, 64, 64)[video.params["frame"]]
    assert torch.equal(frame[walls], reference[walls])
    assert torch.equal(frame[ground], clip[ground])


# -- 2. the video in the skybox texture ------------------------------------------------------------------------------

@pytest.mark.render
def test_skybox_mode_writes_the_frame_into_the_sky_texture_as_dcs(tmp_path):
    red = write_davis(tmp_path / "DAVIS", train=["bear"], val=[], colours={"bear": (0, 0, 255)})  # BGR red
    video = VideoBackground(str(red), split="train", playback="static", skybox=True, sky_size=16, ground_plane_alpha=0.3)
    env = make_env("dmc/walker-walk", generalization=[video], seed=0, frame_stack=1, image_size=32, render_settings=FAST)
    frame = env.reset()["pixels"].permute(1, 2, 0)
    model = env.base_env.scene.model
    sky = video.sky_texture(model)
    assert model.tex_width[sky] == model.tex_height[sky] == 16, "one square face on every side (DCS: height := width)"
    clip = video.videos.frames(0, 16, 16)[video.params["frame"]]
    assert np.array_equal(texture_pixels(model, sky), clip.numpy().reshape(-1))
    grid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_MATERIAL, "grid")
    assert model.mat_rgba[grid, 3] == pytest.approx(0.3)
    # the renderer draws the red sky; no pixel is pasted afterwards
    sky_pixels = frame[torch.from_numpy(env.base_env.scene.segmentation()[..., 0] < 0)].float()
    assert len(sky_pixels) and (sky_pixels[:, 0] - sky_pixels[:, 1:].amax(1)).min() > 100
    with pytest.raises(ValueError, match="skybox=True"):
        VideoBackground(skybox=True, floor=True)
    with pytest.raises(ValueError, match="sky_size"):
        VideoBackground(sky_size=16)


@pytest.mark.render
def test_dcs_levels_draw_the_video_in_the_sky_texture_by_default(tmp_path):
    """background.py:160-215: DCS sets texture 0's height to its width (800 for dm_control's sky) and writes the frame,
    resized to that square face, into it; the camera then sees a part of the sky cube that pans as it walks."""
    root = write_davis(tmp_path / "DAVIS", frames=2)
    env = make_env("dmc/walker-walk", generalization="dcs_static_0.05", seed=0, frame_stack=1, image_size=16,
                   render_settings=FAST, level_options={"videos": str(root)})
    model = env.base_env.scene.model
    source_sky = int(np.flatnonzero(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)[0])
    width = int(model.tex_width[source_sky])
    env.reset()
    video = env.transform[2]
    assert isinstance(video, VideoBackground) and video.skybox
    assert model.tex_width[source_sky] == model.tex_height[source_sky] == width == 800
    clip = video.videos.frames(video.params["video"], width, width)[video.params["frame"]]
    assert np.array_equal(texture_pixels(model, source_sky), clip.numpy().reshape(-1))
    composite = DMC.level_transforms("walker-walk", "dcs_0.05", seed=0, skybox=False, videos=str(root))[2]
    assert not composite.skybox, "the screen-space composite stays a named option"


# -- 4. stepping: moves per control step, counted from the reset, shown in the step's frame ---------------------------

def bounce(index: int, direction: int, length: int, moves: int) -> tuple[int, int]:
    """background.py step(): i += d; i <= 0 -> i = 0, d = +1; i >= n -> i = n - 1, d = -1."""
    for _ in range(moves):
        index += direction
        if index <= 0:
            index, direction = 0, 1
        if index >= length:
            index, direction = length - 1, -1
    return index, direction


def source_moves(step: int, action_repeat: int, update_every: int) -> int:
    """Moves after env step ``step``: control steps c = 1 .. step * action_repeat with c % update_every == 0."""
    return sum(1 for c in range(1, step * action_repeat + 1) if c % update_every == 0)


@pytest.mark.render
@pytest.mark.parametrize("update_every, action_repeat", [(2, 2), (2, 3), (2, 1), (1, 3)])
@pytest.mark.parametrize("skybox", [True, False])
def test_dynamic_distractions_move_on_the_sources_simulator_steps(update_every, action_repeat, skybox):
    s, steps = 0.3, 5
    camera = DistractingCamera(s, dynamic=True, update_every=update_every)
    colors = DistractingColors(s, dynamic=True, update_every=update_every)
    source = VideoSource.procedural(count=1, max_frames=40)
    sky = {"skybox": True, "sky_size": 8} if skybox else {}
    video = VideoBackground(source, playback="bounce", update_every=update_every, **sky)
    env = make_env("dmc/walker-walk", generalization=[camera, colors, video], seed=0, frame_stack=1, image_size=16,
                   render_settings=FAST, action_repeat=action_repeat)
    scene, physics = env.base_env.scene, env.base_env.physics
    shown = []  # what each rendered frame shows: the model's camera and colours, the sky texture
    render = physics.render

    def spy(*args, **kwargs):
        sky = texture_pixels(scene.model, video.sky_texture(scene.model)).copy() if skybox else None
        shown.append((scene.model.cam_poscom0[0].copy(), scene.model.cam_mat0[0].copy(),
                      scene.model.mat_rgba[:, :3].copy(), sky))
        return render(*args, **kwargs)

    physics.render = spy
    state = env.reset()
    start, direction = video.params["frame"], video.params["direction"]
    indices = [start]
    for _ in range(steps):
        state = env.step(state.set("action", torch.zeros(env.action_spec.shape)))["next"]
        indices.append(video.params["frame"])
    assert len(shown) == steps + 1

    # the same draws, replayed with the source's rule
    cam_rng = np.random.default_rng(camera.seed)
    cam_defaults, color_defaults = camera.defaults(scene), colors.defaults(scene)
    reference_camera = DistractingCamera(s, dynamic=True)
    cam_params = reference_camera.sample(cam_rng, cam_defaults)  # includes DCS's one walk at reset
    color_rng = np.random.default_rng(colors.seed)
    color_params = colors.sample(color_rng, color_defaults)
    walked = 0
    for t, (position, rotation, rgb, sky) in enumerate(shown):
        due = source_moves(t, action_repeat, update_every)
        for _ in range(due - walked):
            reference_camera.walk(cam_rng, cam_defaults, cam_params)
            colors.walk(color_rng, color_defaults, color_params)
        walked = due
        expected_position, expected_rotation = reference_camera.pose(cam_defaults, cam_params)
        np.testing.assert_allclose(position, expected_position, atol=1e-9, err_msg=f"camera at step {t}")
        np.testing.assert_allclose(rotation, expected_rotation.reshape(9), atol=1e-9, err_msg=f"camera at step {t}")
        np.testing.assert_allclose(rgb[color_defaults["materials"]], color_params["rgb"], atol=1e-6,  # mat_rgba is float32
                                   err_msg=f"colours at {t}")
        index, _ = bounce(start, direction, 40, due)
        assert indices[t] == index, f"video frame at step {t}"
        if skybox:
            assert np.array_equal(sky, source.frames(0, 8, 8)[index].numpy().reshape(-1)), f"sky texture at step {t}"


def test_dcs_presets_state_the_stepping_they_follow():
    dynamic = DMC.level_transforms("walker-walk", "dcs_0.2", seed=0)
    assert [t.update_every for t in dynamic] == [2, 2, 2], "DMC-GB's copy: every 2nd control step"
    assert "every 2nd control step" in DMC.levels["dcs_0.2"].what and "DMC-GB" in DMC.levels["dcs_0.2"].source
    original = DMC.level_transforms("walker-walk", "dcs_0.2", seed=0, update_every=1)
    assert [t.update_every for t in original] == [1, 1, 1]
    assert all(t.update_every is None for t in DMC.level_transforms("walker-walk", "dcs_static_0.2", seed=0))
    with pytest.raises(ValueError, match="update_every"):
        DistractingCamera(0.1, dynamic=True, update_every=0)
    with pytest.raises(ValueError, match="not both"):
        DistractingColors(0.1, dynamic=True, walk_steps=2, update_every=2)

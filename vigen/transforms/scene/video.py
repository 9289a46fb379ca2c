"""Video backgrounds: a new video frame behind the agent at every step, keyed by the scene's segmentation or in the skybox.

DMC-GB's ``video_easy`` / ``video_hard`` and the Distracting Control Suite's background videos.
"""

from __future__ import annotations

import dataclasses
import os
from collections.abc import Sequence
from typing import Any

import mujoco
import numpy as np
import torch
import torch.nn.functional as F
from tensordict import TensorDictBase
from torch import Tensor

from vigen.assets.davis import DAVIS_SPLITS
from vigen.assets.video_source import VideoSource
from vigen.transforms.scene.base import SceneHandle, SceneParams, SceneTransform
from vigen.transforms.scene.mujoco import named_id, texture_pixels
from vigen.transforms.scene.schedule import action_repeat_of, check_update_every, updates_due

PLAYBACKS = ("forward", "static", "bounce")
GROUND_MATERIAL = "grid"  # the material whose alpha DCS's ground_plane_alpha sets (background.py, _reset_background)
PROCEDURAL_SKY_SIZE = 256  # sky face of procedural stand-in videos: 800×800 ones take ~20 s and ~3 GB to generate


class VideoBackground(SceneTransform):
    """Replace the background of every frame with the current frame of a video (DMC-GB ``video_easy/hard``).

    A pixel compositor, not a model edit: the MuJoCo scene is left as it is, and each rendered
    frame is rewritten where the scene's own segmentation of the same camera view shows
    background. It draws one video per episode (at reset, from its seed) and moves one frame
    forward per step.

    ``floor=False`` (``video_easy``) replaces the sky only; ``floor=True`` (``video_hard``) also
    the floor, so only the agent (and task objects) remain; ``background`` adds geoms by name
    (robosuite's ``eval-hard``: the walls). Background pixels are found with
    the model's own segmentation of the same camera view (pixels that hit no object, plus
    ground planes with ``floor=True``), never by colour: DMC-GB keys on a green sky and
    RL-ViGen on pure black, which also replaces agent pixels of that colour.

    ``playback`` says which frames an episode shows:

    * ``"forward"`` (DMC-GB): videos taken in order, one per episode, starting from
      ``first_video`` (DMC-GB's ``video_easy`` / ``video_hard``: 1, see below) or, without it,
      from a seeded index; the first frame at reset, then one frame forward per step, wrapping;
    * ``"static"`` (Distracting Control Suite, static): a random video and one random frame of it
      for the whole episode;
    * ``"bounce"`` (Distracting Control Suite, dynamic): a random video, a random start frame and
      direction (±1), one frame per step, turning at the ends as DCS's ``background.py`` does
      (index ``i += d``; at ``i <= 0``: ``i = 0, d = +1``; at ``i >= n``: ``i = n - 1, d = -1``).

    ``first_video`` is DMC-GB's rule for the first episode's video: its ``VideoWrapper``
    (``src/env/wrappers.py``) starts its index at 0 and moves it on by one before each episode's
    video is loaded, so episode ``k`` plays video ``(k + 1) % n`` from frame 0 whatever the seed:
    ``first_video=1``, which the ``dmc`` suite's ``video_easy`` / ``video_hard`` levels set. The
    count restarts when the transform is reseeded (``set_seed``), as a new DMC-GB env does.

    ``alpha`` is DCS's ``video_alpha``: background pixels become ``(1 - α)·render + α·video``
    (truncated to the frame's integer type, as DCS does); 1 replaces them. ``num_videos`` keeps
    only the first videos of the source (DCS: the first 2 to 8 DAVIS videos at low scales, see
    ``DCS_NUM_VIDEOS``); ``split`` reads a DAVIS 2017 folder's ``train`` or ``val`` split (DCS:
    ``train``) instead of every video under the folder.

    ``ground_plane_alpha`` is DCS's: the opacity of the ``grid`` material (dm_control's floor;
    reacher 0, walker and cheetah 1, other domains 0.3). Only geoms with that material see the
    video through them, as in DCS, which sets that one material's alpha (reacher's four
    ``decoration`` walls, planes too, stay opaque). With ``skybox=False`` their pixels become
    ``(1 - w)·render + w·video`` with ``w = α·(1 - ground_plane_alpha)``.

    ``skybox`` says where the video goes:

    * ``False`` (vigen's default): into the rendered frame's background pixels, in screen space,
      the video filling the frame whatever the camera does;
    * ``True`` (the Distracting Control Suite's way, ``background.py`` ``_reset_background`` and
      ``_apply``): into the model's skybox texture, resized to one square face and shown on all
      six faces of the sky cube (the texture's height set to its width, as DCS does), re-uploaded
      to the render context whenever the frame changes; the sky then turns with the camera (a
      drifting camera sees other parts of it), and the ``grid`` material's alpha is set to
      ``ground_plane_alpha`` so the renderer shows the sky cube through the floor. Only the sky
      is replaced (no ``floor`` or ``background``). It costs a texture upload per new frame and
      decodes the video at the face's size (``sky_size``; DCS: the texture's width, 800 for
      dm_control): about 1.5× the composite's time per step at 800, about the same at 256
      (``benchmarks/dcs_skybox_cost.py``).

    ``update_every`` says how often the playback moves: ``None`` once per env step (DMC-GB's
    ``video_easy`` / ``video_hard``), an int ``k`` once per ``k`` control steps counted from the
    reset (DCS: DMC-GB's copy 2, ``background.py:225``; the original 1), so ``action_repeat / k``
    frames per env step.

    The transform composites the env's raw ``[H, W, 3]`` frames, so it must sit before
    ``ToTensorImage`` (and frame stacking): ``make_env(..., generalization="video_hard")`` or
    ``generalization=[VideoBackground(...)]`` put it there, and so does
    ``env.insert_transform(0, VideoBackground(...))`` on a built env; ``append_transform`` puts it
    after the channel-first frames and is refused at the first reset.

    Paper: DMC-GB / SODA, https://arxiv.org/abs/2011.13389.

    Args:
        videos: a :class:`VideoSource`, a folder of videos / frame folders, or ``None`` for
            procedural videos (10, as DMC-GB's ``video_easy``).
        floor: replace the floor (every ground plane) too.
        background: name prefixes of more geoms to replace, e.g. ``("wall",)``.
        video: play this video (index into ``videos``, wrapped) in every episode instead of
            taking them in turn (RL-ViGen's robosuite ``eval-hard``: the scene id).
        first_video: with ``"forward"`` playback, the video of the first episode (an index,
            wrapped), the next ones following in order (DMC-GB: 1); ``None`` draws it from the seed.
        playback: ``"forward"``, ``"static"`` or ``"bounce"`` (see above).
        alpha: weight of the video on background pixels, in [0, 1].
        num_videos: use only the first ``num_videos`` videos (``None``: all).
        ground_plane_alpha: the ``grid`` material's opacity over the video, in [0, 1] (DCS's, per
            domain: ``dcs_ground_plane_alpha``); ``None`` keeps the floor, or replaces it with ``floor=True``.
        split: ``"train"`` or ``"val"`` to play that split of a DAVIS 2017 folder ``videos`` (DCS:
            ``"train"``); ``None`` plays every video under the folder. Procedural videos and a
            :class:`VideoSource` have no split and ignore it.
        skybox: write the video into the skybox texture (DCS) instead of the frame's background pixels.
        sky_size: with ``skybox``, the side of the square sky face the frames are resized to;
            ``None`` keeps the texture's width for videos from a folder (DCS: 800 for dm_control)
            and uses 256 for procedural ones (stand-ins, slow to generate at 800). Smaller is cheaper.
        update_every: control steps per playback move (DCS: 2 in DMC-GB's copy, 1 in the
            original), or ``None`` for one move per env step.
        seed: see :class:`~vigen.transforms.scene.SceneTransform`.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", generalization="video_hard", seed=0)
        >>> env.rollout(3)["pixels"].shape
        torch.Size([3, 9, 84, 84])
        >>> dcs = VideoBackground(playback="bounce", alpha=0.5, num_videos=2, seed=0)
        >>> make_env("dmc/walker-walk", generalization=[dcs], image_size=32).rollout(3)["pixels"].shape
        torch.Size([3, 9, 32, 32])
        >>> sky = VideoBackground(playback="bounce", skybox=True, sky_size=64, update_every=2, seed=0)
        >>> make_env("dmc/walker-walk", generalization=[sky], image_size=32).rollout(2)["pixels"].shape
        torch.Size([2, 9, 32, 32])
    """

    def __init__(
        self,
        videos: VideoSource | str | os.PathLike | None = None,
        floor: bool = False,
        background: Sequence[str] = (),
        video: int | None = None,
        playback: str = "forward",
        first_video: int | None = None,
        alpha: float = 1.0,
        num_videos: int | None = None,
        ground_plane_alpha: float | None = None,
        split: str | None = None,
        skybox: bool = False,
        sky_size: int | None = None,
        update_every: int | None = None,
        seed: int | None = None,
    ) -> None:
        if playback not in PLAYBACKS:
            raise ValueError(f"VideoBackground: playback must be one of {PLAYBACKS}, got {playback!r}.")
        if isinstance(alpha, bool) or not isinstance(alpha, (int, float)) or not 0.0 <= alpha <= 1.0:
            raise ValueError(f"VideoBackground: alpha is the video's weight on background pixels, in [0, 1]; got {alpha!r}.")
        if video is not None and (isinstance(video, bool) or not isinstance(video, (int, np.integer))):
            raise TypeError(f"VideoBackground: video is the index of the one video to play (an int, wrapped), or None to "
                            f"take them in turn; got {video!r}. A folder of videos goes to videos=..., e.g. "
                            f"level_options={{'videos': {video!r}}}.")
        if first_video is not None:
            if isinstance(first_video, bool) or not isinstance(first_video, (int, np.integer)) or first_video < 0:
                raise ValueError(f"VideoBackground: first_video is the index (an int >= 0, wrapped) of the first episode's "
                                 f"video, or None to draw it from the seed; got {first_video!r}.")
            if playback != "forward" or video is not None:
                raise ValueError(f"VideoBackground: first_video sets where forward playback starts taking the videos in turn; "
                                 f"it does not apply with playback={playback!r}" + ("" if video is None else f" and a fixed video={video!r}")
                                 + ". Pass first_video=None.")
        if num_videos is not None and (isinstance(num_videos, bool) or not isinstance(num_videos, int) or num_videos < 1):
            raise ValueError(f"VideoBackground: num_videos is a count >= 1 or None (all videos), got {num_videos!r}.")
        if ground_plane_alpha is not None:
            if isinstance(ground_plane_alpha, bool) or not isinstance(ground_plane_alpha, (int, float)) or not (
                    0.0 <= ground_plane_alpha <= 1.0):
                raise ValueError("VideoBackground: ground_plane_alpha is the floor's opacity in [0, 1] or None, "
                                 f"got {ground_plane_alpha!r}.")
            if floor:
                raise ValueError("VideoBackground: floor=True replaces the floor, ground_plane_alpha blends it; pass one of them.")
        if split is not None and split not in DAVIS_SPLITS:
            raise ValueError(f"VideoBackground: split is a DAVIS 2017 split {DAVIS_SPLITS} or None (every video), got {split!r}.")
        if not isinstance(skybox, bool):
            raise TypeError(f"VideoBackground: skybox is True (video in the skybox texture) or False, got {skybox!r}.")
        if skybox and (floor or background):
            raise ValueError("VideoBackground: skybox=True puts the video in the sky texture only; floor and background "
                             "(pixel replacement by segmentation) need skybox=False.")
        if sky_size is not None and (isinstance(sky_size, bool) or not isinstance(sky_size, int) or sky_size < 2
                                     or not skybox):
            raise ValueError(f"VideoBackground: sky_size is the side of the square sky face (an int >= 2) with skybox=True, "
                             f"or None for the texture's width; got sky_size={sky_size!r} with skybox={skybox}.")
        check_update_every("VideoBackground", update_every)
        super().__init__(seed=seed, in_keys=["pixels"])
        self.ground_plane_alpha = None if ground_plane_alpha is None else float(ground_plane_alpha)
        self.videos = videos if isinstance(videos, VideoSource) else (
            VideoSource.procedural() if videos is None else VideoSource.from_folder(videos, split=split)
        )
        self.split, self.skybox, self.sky_size, self.update_every = split, skybox, sky_size, update_every
        if num_videos is not None and num_videos > len(self.videos):
            raise ValueError(f"VideoBackground: num_videos={num_videos} but the source has {len(self.videos)} videos; "
                             "pass at most that many, or None for all.")
        self.playback, self.alpha, self.num_videos = playback, float(alpha), num_videos
        self.floor = floor
        self.background = tuple(background)
        self.video = video
        self.first_video = None if first_video is None else int(first_video)

    @property
    def uses_stand_in(self) -> bool:
        """True when the videos are vigen's procedural stand-ins, not the benchmark's (or the user's) videos."""
        return self.videos.paths is None

    @property
    def data_source(self) -> str:
        """What this transform plays, by identity, never by path: e.g. ``"dmcgb-videos/video_hard: 100 of 100, verified"``.

        Videos from a folder are named by :attr:`VideoSource.identity <vigen.assets.video_source.VideoSource.identity>`
        (a data set part whose pinned files they all are, or ``user folder: <n> videos``);
        procedural ones as stand-ins with their count. ``num_videos`` (the first ones of the
        source) and a fixed ``video`` are added as a note.

        Examples:
            >>> VideoBackground().data_source, VideoBackground().uses_stand_in
            ('procedural stand-in videos (10)', True)
            >>> VideoBackground(num_videos=2).data_source, VideoBackground(video=13).data_source
            ('procedural stand-in videos (2)', 'procedural stand-in video 3 of 10')
        """
        total = len(self.videos)
        count = self.num_videos or total
        index = None if self.video is None else self.video % (total if self.playback == "forward" else count)
        if self.uses_stand_in:
            return f"procedural stand-in videos ({count})" if index is None else f"procedural stand-in video {index} of {count}"
        identity = self.videos.identity
        notes = [identity.note] if identity.note else []
        notes += [f"the first {count} played"] if count < total else []
        notes += [f"only video {index} played"] if index is not None else []
        return str(dataclasses.replace(identity, note=", ".join(notes)))

    def episode_data(self) -> dict[str, Any]:
        """The video this episode plays: its file or folder name (``"video3.mp4"``), or ``"procedural <i>"``.

        Examples:
            >>> VideoBackground().episode_data()  # before the first reset
            {}
        """
        if self.params is None:
            return {}
        index = int(self.params["video"])
        return {"video": f"procedural {index}" if self.videos.paths is None else self.videos.paths[index].name}

    def background_geoms(self, model: mujoco.MjModel) -> np.ndarray:
        """``[ngeom]`` True for the geoms that count as background: ground planes with ``floor``, and ``background`` names."""
        if getattr(self, "_geoms_model", None) is not model:
            is_background = np.zeros(model.ngeom, dtype=bool)
            if self.floor:
                is_background |= model.geom_type == mujoco.mjtGeom.mjGEOM_PLANE
            if self.background:
                names = [mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or "" for i in range(model.ngeom)]
                is_background |= np.array([name.startswith(self.background) for name in names])
            self._geoms_model, self._geoms = model, is_background
        return self._geoms

    def ground_geoms(self, model: mujoco.MjModel) -> np.ndarray:
        """``[ngeom]`` True for the geoms of the ``grid`` material, whose alpha DCS's ``ground_plane_alpha`` sets."""
        if getattr(self, "_ground_model", None) is not model:
            grid = named_id(model, mujoco.mjtObj.mjOBJ_MATERIAL, GROUND_MATERIAL)
            self._ground_model, self._ground = model, model.geom_matid == grid
        return self._ground

    def sample(self, rng: np.random.Generator) -> SceneParams:
        """The episode's video and where its playback starts.

        ``forward``: the next video in order (the first one ``first_video``, or drawn from ``rng``
        without it; or the fixed ``video``) from its first frame. ``static`` / ``bounce``: a uniformly drawn video (or the
        fixed one), a start drawn uniformly over its frames (``start`` in [0, 1), resolved once
        the frames are decoded) and, for ``bounce``, a direction ±1.
        """
        count = self.num_videos or len(self.videos)
        if self.playback != "forward":
            video = self.video % count if self.video is not None else int(rng.integers(count))
            start, direction = float(rng.random()), 2 * int(rng.integers(2)) - 1
            return {"video": video, "frame": None, "start": start, "direction": direction}
        if self.video is not None:
            return {"video": self.video % len(self.videos), "frame": 0}
        if self.params is not None:
            previous = self.params["video"]
        else:
            previous = (self.first_video if self.first_video is not None else int(rng.integers(count))) - 1
        return {"video": (previous + 1) % count, "frame": 0}

    def frame_after(self, length: int, moves: int) -> int:
        """The frame to show now, of a video of ``length`` frames, after moving the playback on ``moves`` times.

        ``forward``: one frame on per move, wrapping. ``static``: no move. ``bounce``: per move
        ``i += d``; at ``i <= 0``: ``i = 0, d = +1``; at ``i >= n``: ``i = n - 1, d = -1``.
        """
        params = self.params
        if params["frame"] is None:
            params["frame"] = min(int(params["start"] * length), length - 1)
        if self.playback == "forward":
            params["frame"] += moves
            return params["frame"] % length
        for _ in range(moves if self.playback == "bounce" else 0):
            following = params["frame"] + params["direction"]
            if following <= 0:
                following, params["direction"] = 0, 1
            if following >= length:
                following, params["direction"] = length - 1, -1
            params["frame"] = following
        return params["frame"]

    def moves_due(self) -> int:
        """Playback moves of the coming env step: one, or those of its control steps with ``update_every``."""
        if self.update_every is None:
            return 1
        return updates_due(self.params, self.update_every, action_repeat_of(self))

    def background_mask(self, scene: SceneHandle, segmentation: np.ndarray | None = None) -> np.ndarray:
        """``[H, W]`` True where the camera sees the sky (and, with ``floor``, a ground plane, or a ``background`` geom)."""
        segmentation = scene.segmentation() if segmentation is None else segmentation
        ids, types = segmentation[..., 0], segmentation[..., 1]
        mask = ids < 0
        is_background = self.background_geoms(scene.model)
        if is_background.any():
            mask |= (types == int(mujoco.mjtObj.mjOBJ_GEOM)) & is_background[np.maximum(ids, 0)]
        return mask

    def _composite(self, tensordict: TensorDictBase, moves: int) -> TensorDictBase:
        if self.params is None or self.params["video"] < 0:
            return tensordict
        pixels: Tensor = tensordict.get("pixels")
        if pixels.ndim < 3 or pixels.shape[-1] != 3:
            raise ValueError(
                f"VideoBackground composites the env's raw [H, W, 3] frames, but its 'pixels' have shape "
                f"{tuple(pixels.shape)}: it sits after ToTensorImage, which makes frames channel-first (with any "
                "frame_stack). Pass it to the builder, make_env(..., generalization=[VideoBackground(...)]), or insert it "
                "at the start of a built env's chain: env.insert_transform(0, VideoBackground(...))."
            )
        scene = self.scene
        height, width = pixels.shape[-3:-1]
        video = self.videos.frames(self.params["video"], height, width)
        frame = video[self.frame_after(len(video), moves)].to(pixels.device)
        segmentation = scene.segmentation()
        mask = torch.from_numpy(self.background_mask(scene, segmentation)).to(pixels.device)[..., None]
        if self.alpha == 1.0 and self.ground_plane_alpha is None:
            tensordict.set("pixels", torch.where(mask, frame, pixels))
            return tensordict
        weight = mask * self.alpha
        if self.ground_plane_alpha is not None:
            ids, types = segmentation[..., 0], segmentation[..., 1]
            ground = (types == int(mujoco.mjtObj.mjOBJ_GEOM)) & (ids >= 0) & self.ground_geoms(scene.model)[np.maximum(ids, 0)]
            weight = torch.where(torch.from_numpy(ground).to(pixels.device)[..., None],
                                 self.alpha * (1.0 - self.ground_plane_alpha), weight)
        tensordict.set("pixels", (weight * frame.float() + (1.0 - weight) * pixels.float()).to(pixels.dtype))
        return tensordict

    # -- skybox mode: the video in the sky texture, as the Distracting Control Suite draws it ---------------------------
    def sky_texture(self, model: mujoco.MjModel) -> int:
        """The id of the model's skybox texture (DCS: texture 0, which is dm_control's skybox)."""
        skies = np.flatnonzero(model.tex_type == mujoco.mjtTexture.mjTEXTURE_SKYBOX)
        if len(skies) == 0:
            raise ValueError("VideoBackground(skybox=True) writes the video into the skybox texture, but this scene has none; "
                             "use skybox=False (pixels replaced by segmentation).")
        return int(skies[0])

    def _prepare_sky(self, scene: SceneHandle) -> None:
        """Make the sky one square face shown on every side (DCS sets the height to the width) and set the grid's alpha."""
        model = scene.model
        texture = self.sky_texture(model)
        if getattr(self, "_sky_model", None) is not model:
            width, stored = int(model.tex_width[texture]), len(texture_pixels(model, texture))
            side = self.sky_size or (width if self.videos.paths is not None else min(width, PROCEDURAL_SKY_SIZE))
            if model.tex_nchannel[texture] != 3 or side * side * 3 > stored:
                raise ValueError(f"VideoBackground(skybox=True) writes a square RGB face of side {side} into the sky texture, "
                                 f"which has {model.tex_nchannel[texture]} channels and room for {stored} bytes; pass a smaller "
                                 "sky_size.")
            first_face = torch.from_numpy(model.tex_data[model.tex_adr[texture]:][: width * width * 3].copy())
            if side != width:
                first_face = F.interpolate(first_face.view(1, width, width, 3).permute(0, 3, 1, 2).float(), size=(side, side),
                                           mode="bilinear", antialias=True, align_corners=False)
                first_face = first_face.round().clamp(0, 255).to(torch.uint8).permute(0, 2, 3, 1).reshape(-1)
            model.tex_width[texture] = model.tex_height[texture] = side
            self._sky_model, self._sky, self._sky_side = model, texture, side
            self._sky_original = first_face.numpy().astype(np.float32)  # the first face, the one DCS blends over
        if self.ground_plane_alpha is not None:
            model.mat_rgba[named_id(model, mujoco.mjtObj.mjOBJ_MATERIAL, GROUND_MATERIAL), 3] = self.ground_plane_alpha

    def _show_in_sky(self, scene: SceneHandle, moves: int) -> None:
        """Write the current frame (after ``moves`` playback moves) into the sky texture and upload it if it changed."""
        side = self._sky_side
        video = self.videos.frames(self.params["video"], side, side)
        index = self.frame_after(len(video), moves)
        if self.params.get("shown") == index:
            return
        pixels = video[index].numpy().reshape(-1)
        if self.alpha < 1.0:
            pixels = (self.alpha * pixels.astype(np.float32) + (1.0 - self.alpha) * self._sky_original).astype(np.uint8)
        texture_pixels(scene.model, self._sky)[:] = pixels
        scene.upload_texture(self._sky)
        self.params["shown"] = index

    def _reset_env_preprocess(self, tensordict: TensorDictBase | None) -> TensorDictBase | None:
        self.params = self.sample(self.generator())
        if self.skybox:
            scene = self.scene
            self._prepare_sky(scene)
            self._show_in_sky(scene, 0)
        return tensordict

    def _inv_call(self, tensordict: TensorDictBase) -> TensorDictBase:
        # runs before the base env steps and renders: the step's frame shows the new sky
        if self.skybox and self.params is not None:
            self._show_in_sky(self.scene, self.moves_due())
        return tensordict

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        return tensordict_reset if self.skybox else self._composite(tensordict_reset, 0)

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        return next_tensordict if self.skybox else self._composite(next_tensordict, self.moves_due())

    def transform_observation_spec(self, observation_spec):
        return observation_spec

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        return next_tensordict

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        for name in ("_geoms_model", "_geoms", "_ground_model", "_ground", "_sky_model", "_sky", "_sky_side", "_sky_original"):
            state.pop(name, None)  # MuJoCo handles stay in their process
        return state

    def extra_repr(self) -> str:
        background = f", background={self.background}" if self.background else ""
        video = "" if self.video is None else f", video={self.video}"
        playback = "" if self.playback == "forward" else f", playback={self.playback!r}"
        playback += "" if self.first_video is None else f", first_video={self.first_video}"
        alpha = "" if self.alpha == 1.0 else f", alpha={self.alpha}"
        count = "" if self.num_videos is None else f", num_videos={self.num_videos}"
        ground = "" if self.ground_plane_alpha is None else f", ground_plane_alpha={self.ground_plane_alpha}"
        split = "" if self.split is None else f", split={self.split!r}"
        sky = (", skybox=True" + ("" if self.sky_size is None else f", sky_size={self.sky_size}")) if self.skybox else ""
        every = "" if self.update_every is None else f", update_every={self.update_every}"
        return f"videos={self.videos}, floor={self.floor}{background}{video}{playback}{alpha}{count}{ground}{split}{sky}{every}"

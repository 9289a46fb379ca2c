"""DMC-GB's video backgrounds: a new video frame behind the agent at every step, keyed by the scene's segmentation."""

from __future__ import annotations

import os
from collections.abc import Sequence

import mujoco
import numpy as np
import torch
from tensordict import TensorDictBase
from torch import Tensor

from vigen.assets.video_source import VideoSource
from vigen.transforms.scene.base import SceneHandle, SceneParams, SceneTransform

PLAYBACKS = ("forward", "static", "bounce")


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

    * ``"forward"`` (DMC-GB): videos taken in order, one per episode, starting from a seeded
      index; the first frame at reset, then one frame forward per step, wrapping;
    * ``"static"`` (Distracting Control Suite, static): a random video and one random frame of it
      for the whole episode;
    * ``"bounce"`` (Distracting Control Suite, dynamic): a random video, a random start frame and
      direction (±1), one frame per step, turning at the ends as DCS's ``background.py`` does
      (index ``i += d``; at ``i <= 0``: ``i = 0, d = +1``; at ``i >= n``: ``i = n - 1, d = -1``).

    ``alpha`` is DCS's ``video_alpha``: background pixels become ``(1 - α)·render + α·video``
    (truncated to the frame's integer type, as DCS does); 1 replaces them. ``num_videos`` keeps
    only the first videos of the source (DCS: the first 2 to 8 DAVIS videos at low scales, see
    ``DCS_NUM_VIDEOS``). DCS draws the frame into the skybox texture and makes the floor grid
    semi-transparent (its ``ground_plane_alpha``: reacher 0, walker and cheetah 1, other domains
    0.3); vigen composites by segmentation instead: with ``ground_plane_alpha`` set, ground-plane
    pixels become ``(1 - w)·render + w·video`` with ``w = α·(1 - ground_plane_alpha)`` (where DCS
    would show the floor over the sky texture, vigen shows it over the video frame).

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
        playback: ``"forward"``, ``"static"`` or ``"bounce"`` (see above).
        alpha: weight of the video on background pixels, in [0, 1].
        num_videos: use only the first ``num_videos`` videos (``None``: all).
        ground_plane_alpha: the floor's opacity over the video, in [0, 1] (DCS's, per domain:
            ``dcs_ground_plane_alpha``); ``None`` keeps the floor, or replaces it with ``floor=True``.
        seed: see :class:`~vigen.transforms.scene.SceneTransform`.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", generalization="video_hard", seed=0)
        >>> env.rollout(3)["pixels"].shape
        torch.Size([3, 9, 84, 84])
        >>> dcs = VideoBackground(playback="bounce", alpha=0.5, num_videos=2, seed=0)
        >>> make_env("dmc/walker-walk", generalization=[dcs], image_size=32).rollout(3)["pixels"].shape
        torch.Size([3, 9, 32, 32])
    """

    def __init__(
        self,
        videos: VideoSource | str | os.PathLike | None = None,
        floor: bool = False,
        background: Sequence[str] = (),
        video: int | None = None,
        playback: str = "forward",
        alpha: float = 1.0,
        num_videos: int | None = None,
        ground_plane_alpha: float | None = None,
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
        if num_videos is not None and (isinstance(num_videos, bool) or not isinstance(num_videos, int) or num_videos < 1):
            raise ValueError(f"VideoBackground: num_videos is a count >= 1 or None (all videos), got {num_videos!r}.")
        if ground_plane_alpha is not None:
            if isinstance(ground_plane_alpha, bool) or not isinstance(ground_plane_alpha, (int, float)) or not (
                    0.0 <= ground_plane_alpha <= 1.0):
                raise ValueError("VideoBackground: ground_plane_alpha is the floor's opacity in [0, 1] or None, "
                                 f"got {ground_plane_alpha!r}.")
            if floor:
                raise ValueError("VideoBackground: floor=True replaces the floor, ground_plane_alpha blends it; pass one of them.")
        super().__init__(seed=seed, in_keys=["pixels"])
        self.ground_plane_alpha = None if ground_plane_alpha is None else float(ground_plane_alpha)
        self.videos = videos if isinstance(videos, VideoSource) else (
            VideoSource.procedural() if videos is None else VideoSource.from_folder(videos)
        )
        if num_videos is not None and num_videos > len(self.videos):
            raise ValueError(f"VideoBackground: num_videos={num_videos} but the source has {len(self.videos)} videos; "
                             "pass at most that many, or None for all.")
        self.playback, self.alpha, self.num_videos = playback, float(alpha), num_videos
        self.floor = floor
        self.background = tuple(background)
        self.video = video

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

    def sample(self, rng: np.random.Generator) -> SceneParams:
        """The episode's video and where its playback starts.

        ``forward``: the next video in order (the first one drawn from ``rng``; or the fixed
        ``video``) from its first frame. ``static`` / ``bounce``: a uniformly drawn video (or the
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
        previous = self.params["video"] if self.params is not None else int(rng.integers(count)) - 1
        return {"video": (previous + 1) % count, "frame": 0}

    def next_frame(self, length: int) -> int:
        """The frame to show now (of a video of ``length`` frames), moving the playback on by one step."""
        params = self.params
        if self.playback == "forward":
            index = params["frame"] % length
            params["frame"] += 1
            return index
        if params["frame"] is None:
            params["frame"] = min(int(params["start"] * length), length - 1)
        index = params["frame"]
        if self.playback == "bounce":
            following = index + params["direction"]
            if following <= 0:
                following, params["direction"] = 0, 1
            if following >= length:
                following, params["direction"] = length - 1, -1
            params["frame"] = following
        return index

    def background_mask(self, scene: SceneHandle, segmentation: np.ndarray | None = None) -> np.ndarray:
        """``[H, W]`` True where the camera sees the sky (and, with ``floor``, a ground plane, or a ``background`` geom)."""
        segmentation = scene.segmentation() if segmentation is None else segmentation
        ids, types = segmentation[..., 0], segmentation[..., 1]
        mask = ids < 0
        is_background = self.background_geoms(scene.model)
        if is_background.any():
            mask |= (types == int(mujoco.mjtObj.mjOBJ_GEOM)) & is_background[np.maximum(ids, 0)]
        return mask

    def _composite(self, tensordict: TensorDictBase) -> TensorDictBase:
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
        frame = video[self.next_frame(len(video))].to(pixels.device)
        segmentation = scene.segmentation()
        mask = torch.from_numpy(self.background_mask(scene, segmentation)).to(pixels.device)[..., None]
        if self.alpha == 1.0 and self.ground_plane_alpha is None:
            tensordict.set("pixels", torch.where(mask, frame, pixels))
            return tensordict
        weight = mask * self.alpha
        if self.ground_plane_alpha is not None:
            ids, types = segmentation[..., 0], segmentation[..., 1]
            planes = (types == int(mujoco.mjtObj.mjOBJ_GEOM)) & (ids >= 0) & (
                scene.model.geom_type[np.maximum(ids, 0)] == mujoco.mjtGeom.mjGEOM_PLANE)
            weight = torch.where(torch.from_numpy(planes).to(pixels.device)[..., None],
                                 self.alpha * (1.0 - self.ground_plane_alpha), weight)
        tensordict.set("pixels", (weight * frame.float() + (1.0 - weight) * pixels.float()).to(pixels.dtype))
        return tensordict

    def _reset_env_preprocess(self, tensordict: TensorDictBase | None) -> TensorDictBase | None:
        self.params = self.sample(self.generator())
        return tensordict

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        return self._composite(tensordict_reset)

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        return self._composite(next_tensordict)

    def transform_observation_spec(self, observation_spec):
        return observation_spec

    def _call(self, next_tensordict: TensorDictBase) -> TensorDictBase:
        return next_tensordict

    def __getstate__(self) -> dict:
        state = super().__getstate__()
        state.pop("_geoms_model", None)  # MuJoCo handles stay in their process
        state.pop("_geoms", None)
        return state

    def extra_repr(self) -> str:
        background = f", background={self.background}" if self.background else ""
        video = "" if self.video is None else f", video={self.video}"
        playback = "" if self.playback == "forward" else f", playback={self.playback!r}"
        alpha = "" if self.alpha == 1.0 else f", alpha={self.alpha}"
        count = "" if self.num_videos is None else f", num_videos={self.num_videos}"
        ground = "" if self.ground_plane_alpha is None else f", ground_plane_alpha={self.ground_plane_alpha}"
        return f"videos={self.videos}, floor={self.floor}{background}{video}{playback}{alpha}{count}{ground}"

"""DMC-GB2's video order: the video cycle starts from the same seeded index as the colour cycle."""

from __future__ import annotations

import os

import numpy as np
import torch
from tensordict import TensorDictBase

from vigen.assets.video_source import VideoSource
from vigen.transforms.scene.base import SceneParams
from vigen.transforms.scene.dmcgb2_seed import check_source_seed, photometric_start, resolve_source_seed
from vigen.transforms.scene.video import VideoBackground
from vigen.transforms.scene.video_screen import TEXTURE_SIZE, VideoScreen, check_screen_domain


DRAWS = ("dmcgb2", "dmcgb")
"""The video orders: DMC-GB2's cycle from a seeded start, or DMC-GB's (episode ``k`` plays video ``(k + 1) mod n``)."""


class DMCGB2VideoBackground(VideoBackground):
    """:class:`~vigen.transforms.VideoBackground` playing its videos in DMC-GB2's order (``video_*``, ``color_video_*``).

    DMC-GB2's ``ColorVideoWrapper`` draws one start index ``start = np.random.RandomState(s).randint(100)``
    for the env seed ``s`` and uses it for the colours and the videos together
    (``dmcgb_photometric.py:53, 58, 62``); the video index moves on by one before each episode's video
    is loaded (line 120), so episode ``k`` plays video ``(start + 1 + k) % len(videos)`` from its first
    frame, one frame per step (``reset``, ``step``). ``s`` is the seed of the vigen env this transform sits
    in (see :mod:`~vigen.transforms.scene.dmcgb2_seed`) or ``source_seed``; the colours of the same
    level (``RandomSceneColors(dmcgb2_colors=...)``) take the same ``start``.

    By default everything else is :class:`~vigen.transforms.VideoBackground`'s ``forward`` playback:
    the video fills the frame where the segmentation shows background. DMC-GB2 instead textures a lit
    box behind the agent that follows the torso (walker, cheetah), seen in perspective, with the sky
    around it: ``screen=True`` does that (:mod:`~vigen.transforms.scene.video_screen`; it reloads the
    dm_control physics with the box once, at the first reset, and renders each frame a second time
    after moving the box, so it needs a ``dmc/`` env of one of DMC-GB2's domains and costs one extra
    render per step: 1.41x the time per step of the composite for walker-walk at 84 px, the figure of
    ``docs/fidelity.md`` measured with ``benchmarks/dmcgb2_screen_cost.py``). With ``screen=True``,
    ``floor=True`` makes the floor transparent, as DMC-GB2's ``video_hard`` does.

    DMC-GB2's ``video_easy`` / ``video_hard`` take the same wrapper, order and screen as its
    ``color_video_*`` (``dmcgb_photometric.py:45-63, 263-284``). Those level names are DMC-GB's too,
    whose ``VideoWrapper`` plays episode ``k`` on video ``(k + 1) mod n`` whatever the seed; vigen's
    ``video_*`` levels follow DMC-GB by default (``draw="dmcgb"``) and DMC-GB2 with
    ``level_options={"draw": "dmcgb2"}`` (and ``{"screen": True}`` for its screen). The reload replaces the model, so a screen transform goes after the other
    scene transforms of its env: TorchRL prepares a reset from the last transform to the first, so
    it reloads before they edit the model (the ``color_video_*`` levels put it last).

    Paper: Almuzairee et al., DMC-GB2, https://arxiv.org/abs/2405.17416.

    Args:
        videos: a :class:`~vigen.assets.video_source.VideoSource`, a folder of videos, or ``None`` for procedural ones.
        floor: replace the floor too (DMC-GB2 does so only at ``video_hard``).
        screen: show the video on DMC-GB2's in-scene screen instead of compositing it.
        domain: the dm_control domain (needed by ``screen``).
        source_seed: DMC-GB2's env seed; ``None``: the seed of the vigen env this transform sits in.
        draw: ``"dmcgb2"`` (DMC-GB2's order, the default) or ``"dmcgb"`` (DMC-GB's: episode ``k`` plays
            video ``(k + 1) mod n``, no seed involved).
        seed: see :class:`~vigen.transforms.scene.SceneTransform`.

    Examples:
        >>> from vigen.envs import make_env
        >>> video = DMCGB2VideoBackground(source_seed=0)
        >>> env = make_env("dmc/walker-walk", generalization=[video], image_size=32)
        >>> _ = env.reset()
        >>> video.params["video"] == (44 + 1) % len(video.videos)  # np.random.RandomState(0).randint(100) == 44
        True
        >>> DMCGB2VideoBackground(draw="dmcgb").sample(None)  # DMC-GB's order: the first episode plays video 1
        {'video': 1, 'frame': 0}
    """

    def __init__(
        self,
        videos: VideoSource | str | os.PathLike | None = None,
        floor: bool = False,
        screen: bool = False,
        domain: str | None = None,
        source_seed: int | None = None,
        draw: str = "dmcgb2",
        seed: int | None = None,
    ) -> None:
        if draw not in DRAWS:
            raise ValueError(f"DMCGB2VideoBackground: unknown draw {draw!r}; choose 'dmcgb2' (DMC-GB2's order: episode k plays "
                             "video (start + 1 + k) mod n, start = RandomState(seed).randint(100)) or 'dmcgb' (DMC-GB's: "
                             "video (k + 1) mod n).")
        source_seed = check_source_seed(source_seed, "DMCGB2VideoBackground")
        if not isinstance(screen, bool):
            raise TypeError(f"DMCGB2VideoBackground: screen is True (DMC-GB2's in-scene screen) or False, got {screen!r}.")
        video_screen = VideoScreen(check_screen_domain(domain, "DMCGB2VideoBackground(screen=True)"), remove_floor=floor) \
            if screen else None
        super().__init__(videos=videos, floor=floor, first_video=1 if draw == "dmcgb" else None, seed=seed)
        self.source_seed, self.domain, self.video_screen, self.draw = source_seed, domain, video_screen, draw

    def sample(self, rng: np.random.Generator) -> SceneParams:
        """The episode's video, ``(start + 1 + k) % len(videos)`` at episode ``k``, from its first frame
        (``draw="dmcgb"``: ``(k + 1) % len(videos)``, :class:`~vigen.transforms.VideoBackground` with ``first_video=1``)."""
        if self.draw == "dmcgb":
            return super().sample(rng)
        if self.params is not None and "start" in self.params:
            start, episode = self.params["start"], self.params["episode"] + 1
        else:
            start, episode = photometric_start(resolve_source_seed(self.source_seed, self.seed, rng)), 0
        return {"video": (start + 1 + episode) % len(self.videos), "frame": 0, "start": start, "episode": episode}

    def _reset_env_preprocess(self, tensordict: TensorDictBase | None) -> TensorDictBase | None:
        if self.video_screen is not None and self.video_screen.install(self._dmc_env().physics):
            self._dmc_env()._segmentation_camera_cache = None  # built for the model the reload replaced
        return super()._reset_env_preprocess(tensordict)

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        if self.video_screen is None:
            return super()._reset(tensordict, tensordict_reset)
        return self._show_on_screen(tensordict_reset)

    def _step(self, tensordict: TensorDictBase, next_tensordict: TensorDictBase) -> TensorDictBase:
        if self.video_screen is None:
            return super()._step(tensordict, next_tensordict)
        return self._show_on_screen(next_tensordict)

    def _dmc_env(self):
        _ = self.scene  # a clear error outside a single env
        base = self.parent.base_env
        if not hasattr(base, "physics") or not hasattr(base, "render_frame"):
            raise RuntimeError("DMCGB2VideoBackground(screen=True) rebuilds a dm_control physics; it works in dmc/ envs only.")
        return base

    def _show_on_screen(self, tensordict: TensorDictBase) -> TensorDictBase:
        """The episode's next video frame on the screen, the screen moved with the torso, and the frame rendered again."""
        base = self._dmc_env()
        model, data = base.physics.model.ptr, base.physics.data.ptr
        video = self.videos.frames(self.params["video"], TEXTURE_SIZE, TEXTURE_SIZE)
        frame = video[self.params["frame"] % len(video)]
        self.params["frame"] += 1
        texture = self.video_screen.show(model, data, frame.numpy())
        self.scene.upload_texture(texture)
        self.video_screen.follow(model, data)
        pixels = tensordict.get("pixels")
        tensordict.set("pixels", torch.from_numpy(base.render_frame().copy()).to(device=pixels.device, dtype=pixels.dtype))
        return tensordict

    def extra_repr(self) -> str:
        source = "" if self.source_seed is None else f", source_seed={self.source_seed}"
        screen = "" if self.video_screen is None else f", screen=True, domain={self.video_screen.domain!r}"
        draw = "" if self.draw == "dmcgb2" else f", draw={self.draw!r}"
        return super().extra_repr() + screen + source + draw

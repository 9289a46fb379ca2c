"""Background videos: procedural ones (no download) or a user folder of videos or image sequences."""

from __future__ import annotations

import os
import re
from pathlib import Path

import numpy as np
import torch

import vigen.datasets
from vigen.assets.davis import davis_split_folders
from vigen.assets.image_bank import IMAGE_SUFFIXES
from vigen.assets.procedural import procedural_video
from vigen.datasets.identity import DataIdentity, identify_fetched_split, identify_files
from vigen.seeding import derive_seed

VIDEO_SUFFIXES = (".mp4", ".avi", ".mov", ".webm", ".mkv")
# a decoded frame side outside this range means a broken header, not a background video
FRAME_SIDE_RANGE = (2, 8192)
# containers whose frame count comes from an index (exact), unlike the duration-based estimate of webm / mkv
INDEXED_SUFFIXES = (".mp4", ".mov", ".avi")
REENCODE_HINT = ("re-encode it (e.g. `ffmpeg -i in.mp4 -c:v libx264 -pix_fmt yuv420p out.mp4`), copy it again, "
                 "or remove it from the folder")


class VideoSource:
    """An ordered set of background videos, decoded one at a time at the size the env renders.

    :meth:`procedural` (the default of :class:`~vigen.transforms.VideoBackground`) generates
    videos from a seed: a procedural texture (fractal noise, Voronoi cells, plaid or colour
    blobs) seen through a window that drifts and turns, so every frame differs. :meth:`from_folder`
    reads the papers' videos from a user folder: video files (DMC-GB's ``video_easy`` /
    ``video_hard`` ``video*.mp4``, RealEstate10K clips) and/or sub-folders of frames (DAVIS
    ``JPEGImages/480p/<video>/*.jpg``), decoded with OpenCV and resized bilinearly.

    User videos are checked when the source is built, before any episode: each file must open,
    report frames and decode a first frame of a sane size, and each frame folder must start with a
    readable image; a ``ValueError`` names every file that does not, with the fix. Frames that
    fail later (a file cut short in the middle) raise an ``OSError`` naming the file when that
    video is first played, instead of playing a shorter video.

    :attr:`identity` says what the videos are without naming a path (evaluation rows carry it):
    a benchmark's data set part when every file is one of its pinned files (name and git blob id,
    :func:`vigen.datasets.identity.identify_files`; e.g. ``dmcgb-videos/video_easy: 10 of 10, verified``),
    DAVIS 2017's split when the folder is the fetched one, else ``user folder: <n> videos``.

    Args:
        paths: video files or frame folders (for :meth:`from_folder`); ``None`` for procedural.
        count: number of procedural videos.
        max_frames: frames read per video (DMC-GB samples 500 of video_hard's).
        seed: seed of the procedural videos.

    Examples:
        >>> from vigen.transforms import VideoSource
        >>> videos = VideoSource.procedural(count=3, max_frames=20)
        >>> len(videos), videos.frames(0, 84, 84).shape
        (3, torch.Size([20, 84, 84, 3]))
    """

    def __init__(
        self, paths: list[Path] | None = None, count: int = 10, max_frames: int = 500, seed: int = 0, name: str = ""
    ) -> None:
        if paths is not None:
            paths = [Path(path) for path in paths]
            _check_videos(paths, name)
            count = len(paths)
        self.paths, self.count, self.max_frames, self.seed = paths, count, max_frames, seed
        self.name = name or ("procedural" if paths is None else "custom")
        self.split: str | None = None
        self._identity: DataIdentity | None = None
        self._cache: tuple[tuple[int, int, int], torch.Tensor] | None = None

    @classmethod
    def procedural(cls, count: int = 10, max_frames: int = 100, seed: int = 0) -> VideoSource:
        """``count`` generated videos of ``max_frames`` frames."""
        return cls(None, count=count, max_frames=max_frames, seed=seed, name=f"procedural({count})")

    @classmethod
    def from_folder(cls, root: str | os.PathLike, max_frames: int = 500, split: str | None = None) -> VideoSource:
        """Every video file and every folder of frames under ``root`` (recursively), in natural order, each checked.

        Natural order compares runs of digits as numbers (:func:`natural_key`): ``video2.mp4`` comes
        before ``video10.mp4``, as DMC-GB and DMC-GB2 list their videos (``video{i}.mp4`` for ``i`` in
        ``range(n)``), so index ``i`` is ``video{i}.mp4``. With ``split`` (``"train"`` or ``"val"``), ``root`` is a DAVIS 2017 folder and the source
        holds that split's frame folders, in name order (the Distracting Control Suite's videos;
        see :func:`~vigen.assets.davis.davis_split_folders`).
        """
        root = Path(root).expanduser()
        if not root.is_dir():
            raise FileNotFoundError(
                f"Video folder {root} does not exist. Pass a folder of videos (e.g. DMC-GB's "
                "src/env/data/video_hard) or of frame folders (e.g. DAVIS/JPEGImages/480p)."
            )
        if split is not None:
            source = cls(davis_split_folders(root, split), max_frames=max_frames, name=f"{root} ({split})")
            source.split = split
            return source
        paths = folder_videos(root)
        if not paths:
            found = sorted(str(p.relative_to(root)) for p in root.rglob("*") if p.is_file())
            listing = ", ".join(found[:10]) + (f" and {len(found) - 10} more" if len(found) > 10 else "")
            raise FileNotFoundError(
                f"No videos ({', '.join(VIDEO_SUFFIXES)}) or frame folders ({', '.join(IMAGE_SUFFIXES)}) found under "
                f"{root}; it holds {listing or 'no files'}. Point it at DMC-GB's src/env/data/video_hard (video*.mp4) "
                "or a folder of frame folders (DAVIS/JPEGImages/480p)."
            )
        return cls(paths, count=len(paths), max_frames=max_frames, name=str(root))

    def __len__(self) -> int:
        return self.count

    @property
    def identity(self) -> DataIdentity | None:
        """What the videos are, by identity (``None`` for procedural ones); checked once, at the first call.

        Examples:
            >>> import tempfile, pathlib, cv2, numpy as np
            >>> folder = pathlib.Path(tempfile.mkdtemp())
            >>> writer = cv2.VideoWriter(str(folder / "clip.mp4"), cv2.VideoWriter_fourcc(*"mp4v"), 25, (16, 16))
            >>> writer.write(np.zeros((16, 16, 3), np.uint8)); writer.release()
            >>> str(VideoSource.from_folder(folder).identity), VideoSource.procedural(2, 2).identity
            ('user folder: 1 video', None)
        """
        if self.paths is None:
            return None
        if self._identity is None:
            self._identity = self._davis_identity() if self.split is not None else identify_files(
                self.paths, vigen.datasets.DATASETS.values(), kind="videos", where="folder")
        return self._identity

    def _davis_identity(self) -> DataIdentity:
        """DAVIS 2017's split as ``python -m vigen.datasets fetch davis2017`` put it in the cache (``verified`` when extracted
        from the pinned archive, :func:`~vigen.datasets.identity.identify_fetched_split`), or a user's DAVIS folder."""
        fetched = identify_fetched_split(self.paths, vigen.datasets.get_dataset("davis2017"), self.split)
        return fetched or DataIdentity(None, None, len(self.paths), None, "user", note=f"DAVIS 2017 layout, {self.split} split")

    def frames(self, index: int, height: int, width: int) -> torch.Tensor:
        """Video ``index`` as uint8 ``[T, height, width, 3]`` RGB; the last one asked for is cached."""
        key = (index, height, width)
        if self._cache is None or self._cache[0] != key:
            if self.paths is None:
                frames = procedural_video(derive_seed(self.seed, index), self.max_frames, height, width)
            else:
                frames = _decode(self.paths[index], self.max_frames, height, width)
            self._cache = (key, frames)
        return self._cache[1]

    def __getstate__(self) -> dict:
        return {**self.__dict__, "_cache": None}

    def __repr__(self) -> str:
        return f"VideoSource({self.name})"


def folder_videos(root: str | os.PathLike) -> list[Path]:
    """The videos :meth:`VideoSource.from_folder` plays from ``root``: video files and frame folders under it, in natural order.

    Nothing is opened: this is the count a command can check before any work.

    Examples:
        >>> import tempfile, pathlib
        >>> root = pathlib.Path(tempfile.mkdtemp())
        >>> for name in ("video10.mp4", "video2.mp4", "notes.txt"):
        ...     _ = (root / name).write_bytes(b"")
        >>> [path.name for path in folder_videos(root)]
        ['video2.mp4', 'video10.mp4']
    """
    root = Path(root).expanduser()
    videos = [p for p in root.rglob("*") if p.suffix.lower() in VIDEO_SUFFIXES]
    frame_dirs = {p.parent for p in root.rglob("*") if p.suffix.lower() in IMAGE_SUFFIXES}
    return sorted(videos + list(frame_dirs), key=lambda path: natural_key(path.relative_to(root)))


def natural_key(path: str | os.PathLike) -> tuple:
    """Sort key of ``path`` that compares runs of digits as numbers, part by part (``video2`` before ``video10``).

    Each part of the path is split into text and digit runs; digit runs compare by value, then (to
    keep ``video01`` and ``video1`` apart, deterministically) the parts compare as text.

    Examples:
        >>> sorted(["video10.mp4", "video2.mp4", "video1.mp4", "video02.mp4"], key=natural_key)
        ['video1.mp4', 'video02.mp4', 'video2.mp4', 'video10.mp4']
        >>> sorted(["b/clip1", "a10/clip", "a9/clip"], key=natural_key)
        ['a9/clip', 'a10/clip', 'b/clip1']
    """
    parts = Path(path).parts
    return tuple(
        (tuple((int(run), "") if i % 2 else (-1, run) for i, run in enumerate(re.split(r"(\d+)", part))), part)
        for part in parts
    )


def _check_videos(paths: list[Path], name: str) -> None:
    """Raise a ValueError naming every path that OpenCV cannot read as a background video."""
    if not paths:
        raise ValueError("VideoSource got an empty list of paths; give video files or frame folders, or use procedural().")
    problems = {path: problem for path in paths if (problem := _video_problem(path)) is not None}
    if not problems:
        return
    lines = "\n".join(f"  {path}: {problem}" for path, problem in problems.items())
    if len(problems) == len(paths):
        raise ValueError(
            f"VideoSource{f' {name}' if name else ''}: none of its {len(paths)} videos is readable:\n{lines}\n"
            "Give a folder of working videos (e.g. DMC-GB's src/env/data/video_hard) or frame folders."
        )
    raise ValueError(
        f"VideoSource{f' {name}' if name else ''}: {len(problems)} of {len(paths)} videos are unreadable:\n{lines}\n"
        f"For each: {REENCODE_HINT}."
    )


def _video_problem(path: Path) -> str | None:
    """What keeps ``path`` (a video file or a folder of frames) from being a background video, or ``None``."""
    import cv2

    if path.is_dir():
        images = sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        if not images:
            return f"the folder holds no images ({', '.join(IMAGE_SUFFIXES)})"
        first = cv2.imread(str(images[0]), cv2.IMREAD_COLOR)
        if first is None:
            return f"its first frame {images[0].name} does not decode"
        return _frame_problem(first)
    if not path.is_file():
        return "it does not exist"
    capture = cv2.VideoCapture(str(path))
    try:
        if not capture.isOpened():
            return "OpenCV cannot open it as a video (not a video, or cut short: a truncated mp4 loses its index)"
        if int(capture.get(cv2.CAP_PROP_FRAME_COUNT)) == 0:
            return "it reports 0 frames"
        ok, first = capture.read()
        if not ok or first is None:
            return "its first frame does not decode"
        return _frame_problem(first)
    finally:
        capture.release()


def _frame_problem(frame: np.ndarray) -> str | None:
    low, high = FRAME_SIDE_RANGE
    if frame.ndim != 3 or frame.shape[2] != 3 or not all(low <= side <= high for side in frame.shape[:2]):
        return f"its frames decode as shape {frame.shape}, not a colour image with sides in [{low}, {high}]"
    return None


def _decode(path: Path, max_frames: int, height: int, width: int) -> torch.Tensor:
    import cv2

    frames = []
    if path.is_dir():
        for image_path in sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)[:max_frames]:
            image = cv2.imread(str(image_path), cv2.IMREAD_COLOR)
            if image is None:
                raise OSError(f"Frame {image_path} of a background video does not decode; {REENCODE_HINT}.")
            frames.append(cv2.resize(image, (width, height), interpolation=cv2.INTER_LINEAR))
    else:
        capture = cv2.VideoCapture(str(path))
        reported = int(capture.get(cv2.CAP_PROP_FRAME_COUNT))
        while len(frames) < max_frames:
            ok, image = capture.read()
            if not ok:
                break
            frames.append(cv2.resize(image, (width, height), interpolation=cv2.INTER_LINEAR))
        capture.release()
        expected = min(max_frames, reported)
        if path.suffix.lower() in INDEXED_SUFFIXES and len(frames) < expected:
            raise OSError(
                f"Background video {path} stops after {len(frames)} of its {reported} frames (cut short or corrupt); "
                f"{REENCODE_HINT}."
            )
    if not frames:
        raise OSError(f"OpenCV could not decode any frame of {path}; {REENCODE_HINT}.")
    return torch.from_numpy(np.stack(frames)[..., ::-1].copy())

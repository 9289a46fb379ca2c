"""Natural-image stand-ins for overlay augmentations: a built-in bank (no download) or a user folder."""

from __future__ import annotations

import os
from collections.abc import Callable
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from pathlib import Path

import numpy as np
import torch
import torch.nn.functional as F
from torch import Tensor

from vigen.assets.procedural import PROCEDURAL_KINDS, STAND_IN_KINDS, procedural_image, stand_in_image

IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp", ".webp")


class ImageBank:
    """A fixed set of RGB images, stored once as uint8 ``[M, 3, S, S]`` and resized on demand.

    SVEA overlays Places365 images (DMC-GB and RL-ViGen read them with ``ImageFolder``). No
    machine that builds or tests vigen can download Places365, so :meth:`builtin` (the default of
    :class:`~vigen.transforms.RandomOverlay`) needs nothing but the installed packages: the
    floor, wall and sky textures that ``labmaze`` ships with dm_control, plus procedurally
    generated images (fractal noise, Voronoi cells, plaids and colour blobs). For the papers'
    setting, point :meth:`from_folder` at a Places365 copy (``places365_standard/train/<class>/*.jpg``)
    or any folder of images.

    :meth:`builtin` and :meth:`procedural` are the **training side**; :meth:`stand_in` is the
    **test side**, the generated textures test levels show (wood, marble, warped checkers,
    mosaics, :func:`~vigen.assets.procedural.stand_in_image`). The two share no source (no
    generator, no labmaze file), so an agent trained with the default overlays is not tested on
    its own training images.

    Args:
        images: uint8 ``[M, 3, S, S]`` RGB images.
        name: where they came from, for ``repr``.

    Examples:
        >>> from vigen.transforms import ImageBank
        >>> bank = ImageBank.builtin()
        >>> len(bank) >= 100, bank.resized(84, 84).shape[1:]
        (True, torch.Size([3, 84, 84]))
    """

    def __init__(self, images: Tensor, name: str = "custom") -> None:
        if images.dtype != torch.uint8 or images.ndim != 4 or images.shape[1] != 3 or len(images) == 0:
            raise ValueError(f"ImageBank takes a non-empty uint8 [M, 3, H, W] tensor, got {images.dtype} {tuple(images.shape)}.")
        self.images = images
        self.name = name
        self._resized: dict[tuple[int, int, torch.device], Tensor] = {}

    @classmethod
    def builtin(cls, size: int = 128, procedural: int = 128, seed: int = 0) -> ImageBank:
        """labmaze's textures (89 with dm-control 1.0.41) plus ``procedural`` generated images."""
        textures = _load_images(_labmaze_textures(), size)
        generator = torch.Generator().manual_seed(seed)
        generated = [procedural_image(kind=i % PROCEDURAL_KINDS, size=size, generator=generator) for i in range(procedural)]
        images = torch.stack([*textures, *generated])
        return cls(images, name=f"builtin({len(textures)} labmaze textures + {procedural} procedural)")

    @classmethod
    def procedural(cls, count: int, size: int = 128, seed: int = 0) -> ImageBank:
        """``count`` generated images (fractal noise, Voronoi cells, plaids, colour blobs, in turn), the same for a seed."""
        generator = torch.Generator().manual_seed(seed)
        images = torch.stack([procedural_image(kind=i % PROCEDURAL_KINDS, size=size, generator=generator) for i in range(count)])
        return cls(images, name=f"procedural({count}, seed={seed})")

    @classmethod
    def stand_in(cls, count: int, size: int = 128, seed: int = 0, kinds: tuple[str, ...] = STAND_IN_KINDS) -> ImageBank:
        """``count`` generated test-side images of the ``kinds`` in turn (of wood, marble, checker, mosaic), the same for a seed.

        The stand-in textures of test levels: they share no generator with :meth:`builtin`'s and
        :meth:`procedural`'s training-side images.

        Examples:
            >>> bank = ImageBank.stand_in(4, size=16, kinds=("checker", "mosaic"))
            >>> len(bank), bank.name
            (4, 'stand-in(4 checker, mosaic, seed=0)')
        """
        unknown = [kind for kind in kinds if kind not in STAND_IN_KINDS]
        if not kinds or unknown or isinstance(kinds, str):
            raise ValueError(f"ImageBank.stand_in: kinds is a non-empty tuple of {STAND_IN_KINDS}, got {kinds!r}.")
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            raise ValueError(f"ImageBank.stand_in: count is the number of images, an int >= 1; got {count!r}.")
        generator = torch.Generator().manual_seed(seed)
        codes = [STAND_IN_KINDS.index(kind) for kind in kinds]
        images = torch.stack([stand_in_image(codes[i % len(codes)], size, generator) for i in range(count)])
        return cls(images, name=f"stand-in({count} {', '.join(kinds)}, seed={seed})")

    @classmethod
    def from_files(cls, paths: list[str | os.PathLike], size: int = 128) -> ImageBank:
        """The images at ``paths``, in order, center-cropped to a square and resized to ``size``."""
        missing = [str(p) for p in paths if not Path(p).is_file()]
        if missing:
            raise FileNotFoundError(f"Image files not found: {', '.join(missing)}.")
        return cls(torch.stack(_load_images([Path(p) for p in paths], size)), name=f"{len(paths)} files")

    def __add__(self, other: ImageBank) -> ImageBank:
        """Both banks' images, at the smaller of the two sizes."""
        side = min(self.images.shape[-1], other.images.shape[-1])
        images = torch.cat([self.resized(side, side), other.resized(side, side)])
        return ImageBank(images, name=f"{self.name} + {other.name}")

    @classmethod
    def from_folder(
        cls, root: str | os.PathLike, size: int = 128, max_images: int | None = 2000, seed: int = 0
    ) -> ImageBank:
        """Every image under ``root`` (searched recursively), or ``max_images`` of them drawn with ``seed``.

        Images are center-cropped to a square and resized to ``size`` (area interpolation).
        """
        root = Path(root).expanduser()
        if not root.is_dir():
            raise FileNotFoundError(
                f"Image folder {root} does not exist. Pass a folder of images, e.g. a Places365 copy "
                "(<root>/places365_standard/train/<class>/*.jpg) or any folder of .jpg/.png files."
            )
        paths = sorted(p for p in root.rglob("*") if p.suffix.lower() in IMAGE_SUFFIXES)
        if not paths:
            raise FileNotFoundError(f"No images ({', '.join(IMAGE_SUFFIXES)}) found under {root}.")
        if max_images is not None and len(paths) > max_images:
            keep = torch.randperm(len(paths), generator=torch.Generator().manual_seed(seed))[:max_images]
            paths = [paths[i] for i in sorted(keep.tolist())]
        return cls(torch.stack(_load_images(paths, size)), name=f"user folder: {len(paths)} images")  # no path: rows carry it

    @classmethod
    def load(cls, images: ImageBank | str | os.PathLike | Callable[[], ImageBank] | None) -> ImageBank:
        """``images`` itself if it is a bank, the built-in bank for ``None``, a factory's bank, else the folder's images."""
        if isinstance(images, ImageBank):
            return images
        if callable(images):  # built on first use, e.g. functools.partial(texture_bank, "easy")
            return images()
        return cls.builtin() if images is None else cls.from_folder(images)

    def __len__(self) -> int:
        return len(self.images)

    def resized(self, height: int, width: int, device: torch.device | str | None = None) -> Tensor:
        """The images as uint8 ``[M, 3, height, width]`` on ``device`` (default: the CPU), computed once per size and device."""
        device = torch.device("cpu") if device is None else torch.device(device)
        key = (height, width, device)
        if key not in self._resized:
            if device.type != "cpu":
                self._resized[key] = self.resized(height, width).to(device)
            elif self.images.shape[-2:] == (height, width):
                self._resized[key] = self.images
            else:
                resized = F.interpolate(self.images.float(), size=(height, width), mode="bilinear", antialias=True,
                                        align_corners=False)
                self._resized[key] = resized.round_().clamp_(0, 255).to(torch.uint8)
        return self._resized[key]

    def __getstate__(self) -> dict:
        return {"images": self.images, "name": self.name, "_resized": {}}

    def __repr__(self) -> str:
        return f"ImageBank({self.name}, {len(self)} images of {tuple(self.images.shape[-2:])})"


def check_image_folder(images: str | os.PathLike, *, owner: str) -> None:
    """Raise, naming ``owner``, if ``images`` is not a folder: a ``NotADirectoryError`` for a file, else ``FileNotFoundError``.

    Examples:
        >>> check_image_folder("/no/such/folder", owner="RandomOverlay")
        Traceback (most recent call last):
        ...
        FileNotFoundError: RandomOverlay: overlay image folder /no/such/folder does not exist.
    """
    path = Path(images).expanduser()
    if path.is_dir():
        return
    if path.exists():
        raise NotADirectoryError(f"{owner}: {images} is a file, not a folder; give the folder that holds the overlay "
                                 "images (PNG or JPEG files, e.g. a Places365 copy).")
    raise FileNotFoundError(f"{owner}: overlay image folder {images} does not exist.")


def _labmaze_textures() -> list[Path]:
    try:
        import labmaze
    except ImportError:
        return []
    return sorted((Path(labmaze.__file__).parent / "assets").glob("**/*.png"))


def _load_images(paths: list[Path], size: int) -> list[Tensor]:
    """Decode in threads (OpenCV releases the GIL), keeping the order of ``paths``."""
    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        return list(pool.map(partial(_load_image, size=size), paths))


def _load_image(path: Path, size: int) -> Tensor:
    """Decode with OpenCV, center-crop to a square, resize to ``size``, as uint8 ``[3, size, size]``."""
    import cv2

    image = cv2.imread(str(path), cv2.IMREAD_COLOR)
    if image is None:
        raise OSError(f"OpenCV could not decode the image {path}.")
    h, w = image.shape[:2]
    side = min(h, w)
    top, left = (h - side) // 2, (w - side) // 2
    image = cv2.resize(image[top : top + side, left : left + side], (size, size), interpolation=cv2.INTER_AREA)
    return torch.from_numpy(np.ascontiguousarray(image[..., ::-1])).permute(2, 0, 1).contiguous()

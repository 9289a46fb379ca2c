"""Procedural images and videos: stand-ins for the natural-image and video data sets no machine here can download.

Two families that share no generator, one per side of a benchmark, so that an agent never trains
on the family it is tested on (DMC-GB trains SVEA on Places365 images and tests on other, real
videos):

* the **training side**, :func:`procedural_image`: fractal noise, Voronoi cells, plaids and colour
  blobs, the generated part of :meth:`~vigen.assets.ImageBank.builtin` (the overlay bank of SVEA
  and the other overlay augmentations) and of :meth:`~vigen.assets.ImageBank.procedural`;
* the **test side**, :func:`stand_in_image`: wood rings, marble veins, warped checkerboards and
  rectangle mosaics, the stand-ins that test levels show without the benchmarks' data: the
  background videos (:func:`procedural_video`, :meth:`~vigen.assets.VideoSource.procedural`) and
  the generated texture sets (:meth:`~vigen.assets.ImageBank.stand_in`, the default of
  :class:`~vigen.transforms.RandomTextures`).

Examples:
    >>> import torch
    >>> from vigen.assets.procedural import procedural_image, procedural_video, stand_in_image
    >>> procedural_image(1, 16, torch.Generator().manual_seed(0)).shape
    torch.Size([3, 16, 16])
    >>> stand_in_image(0, 16, torch.Generator().manual_seed(0)).shape
    torch.Size([3, 16, 16])
    >>> procedural_video(0, 4, 8, 8).shape
    torch.Size([4, 8, 8, 3])
"""

from __future__ import annotations

import math

import torch
import torch.nn.functional as F
from torch import Tensor

PROCEDURAL_KINDS = 4
"""Training side (:func:`procedural_image`): fractal noise, Voronoi cells, plaid, colour blobs."""

STAND_IN_KINDS = ("wood", "marble", "checker", "mosaic")
"""Test side (:func:`stand_in_image`): wood rings, marble veins, warped checkerboard, rectangle mosaic."""


def procedural_image(kind: int, size: int, generator: torch.Generator) -> Tensor:
    """One generated RGB image of the training side, uint8 ``[3, size, size]``: fractal noise, Voronoi, plaid or blobs."""

    def rand(*shape: int) -> Tensor:
        return torch.rand(shape, generator=generator)

    y, x = torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")
    if kind == 0:  # 1/f^beta noise, each channel its own field
        beta = 1.0 + 1.5 * rand(1)
        fy, fx = torch.fft.fftfreq(size), torch.fft.rfftfreq(size)
        radius = torch.sqrt(fy[:, None] ** 2 + fx[None, :] ** 2).clamp_min(1.0 / size)
        spectrum = torch.fft.rfft2(torch.randn((3, size, size), generator=generator)) / radius**beta
        field = torch.fft.irfft2(spectrum, s=(size, size))
        low, high = field.amin(dim=(1, 2), keepdim=True), field.amax(dim=(1, 2), keepdim=True)
        image = (field - low) / (high - low)
    elif kind == 1:  # Voronoi cells with random colours
        cells = 8 + int(32 * rand(1))
        centers, colors = rand(cells, 2), rand(cells, 3)
        distance = (y[..., None] - centers[:, 0]) ** 2 + (x[..., None] - centers[:, 1]) ** 2
        image = colors[distance.argmin(-1)].permute(2, 0, 1)
    elif kind == 2:  # plaid: a few coloured gratings
        image = torch.zeros(3, size, size)
        for _ in range(3):
            angle, frequency, phase = math.pi * rand(1), 2 + 14 * rand(1), 2 * math.pi * rand(1)
            wave = 0.5 + 0.5 * torch.sin(2 * math.pi * frequency * (x * torch.cos(angle) + y * torch.sin(angle)) + phase)
            image += rand(3, 1, 1) * wave / 3
    else:  # soft colour blobs over a gradient
        image = torch.lerp(rand(3, 1, 1), rand(3, 1, 1), y[None])
        for _ in range(5 + int(15 * rand(1))):
            center, width = rand(2), 0.03 + 0.2 * rand(1)
            weight = torch.exp(-((y - center[0]) ** 2 + (x - center[1]) ** 2) / (2 * width**2))
            image = torch.lerp(image, rand(3, 1, 1), weight[None])
    return (image.clamp(0, 1) * 255).round().to(torch.uint8)


def stand_in_image(kind: int, size: int, generator: torch.Generator) -> Tensor:
    """One generated RGB image of the test side, uint8 ``[3, size, size]``: ``STAND_IN_KINDS[kind % 4]``.

    Wood (rings around an off-centre point, bent by smooth noise), marble (veins of a turbulent
    sine), a warped two-colour checkerboard, or a mosaic of overlapping coloured rectangles. None of
    them uses a generator of :func:`procedural_image`, so test levels' stand-ins never show the
    training side's images.
    """
    name = STAND_IN_KINDS[kind % len(STAND_IN_KINDS)]
    return {"wood": wood_image, "marble": marble_image, "checker": checker_image, "mosaic": mosaic_image}[name](size, generator)


def wood_image(size: int, generator: torch.Generator) -> Tensor:
    """Wood: rings around a point off the image, distorted by smooth noise, between a dark and a light brown-ish tone."""
    y, x = _grid(size)
    center = torch.rand(2, generator=generator) * 3 - 1
    radius = torch.sqrt((y - center[0]) ** 2 + (x - center[1]) ** 2)
    rings = 6 + 18 * float(torch.rand(1, generator=generator))
    phase = rings * radius + 1.5 * _smooth_noise(size, 6, generator)
    grain = (0.5 + 0.5 * torch.sin(2 * math.pi * phase)) ** 3
    light = 0.45 + 0.5 * torch.rand(3, 1, 1, generator=generator)
    dark = light * (0.25 + 0.35 * torch.rand(1, generator=generator))
    return _to_uint8(torch.lerp(light, dark, grain[None]))


def marble_image(size: int, generator: torch.Generator) -> Tensor:
    """Marble: thin dark veins, ``|sin|`` of a tilted ramp plus turbulence, over a pale base."""
    y, x = _grid(size)
    angle = math.pi * float(torch.rand(1, generator=generator))
    frequency = 1.5 + 4 * float(torch.rand(1, generator=generator))
    turbulence = sum(_smooth_noise(size, 3 * 2**octave, generator).abs() / 2**octave for octave in range(4))
    veins = torch.sin(2 * math.pi * (frequency * (x * math.cos(angle) + y * math.sin(angle)) + 2.0 * turbulence)).abs() ** 0.3
    base = 0.6 + 0.4 * torch.rand(3, 1, 1, generator=generator)
    vein = 0.6 * torch.rand(3, 1, 1, generator=generator)
    return _to_uint8(torch.lerp(vein, base, veins[None]))


def checker_image(size: int, generator: torch.Generator) -> Tensor:
    """A warped checkerboard of two contrasting colours: squares bent by sine waves along both axes."""
    y, x = _grid(size)
    squares = 3 + int(12 * float(torch.rand(1, generator=generator)))
    bend, waves, phase = 0.08 * float(torch.rand(1, generator=generator)), 1 + 3 * torch.rand(2, generator=generator), \
        2 * math.pi * torch.rand(2, generator=generator)
    u = x + bend * torch.sin(2 * math.pi * waves[0] * y + phase[0])
    v = y + bend * torch.sin(2 * math.pi * waves[1] * x + phase[1])
    board = (torch.floor(squares * u) + torch.floor(squares * v)).remainder(2)
    first = torch.rand(3, 1, 1, generator=generator)
    second = (1 - first) * (0.6 + 0.4 * torch.rand(1, generator=generator))
    return _to_uint8(torch.lerp(first, second, board[None]))


def mosaic_image(size: int, generator: torch.Generator) -> Tensor:
    """A mosaic: coloured axis-aligned rectangles laid one over the other on a coloured ground, with hard edges."""
    y, x = _grid(size)
    image = torch.rand(3, 1, 1, generator=generator).expand(3, size, size).clone()
    for _ in range(6 + int(20 * float(torch.rand(1, generator=generator)))):
        top, left = torch.rand(2, generator=generator) * 0.9
        height, width = 0.05 + 0.45 * torch.rand(2, generator=generator)
        inside = (y >= top) & (y < top + height) & (x >= left) & (x < left + width)
        image = torch.where(inside[None], torch.rand(3, 1, 1, generator=generator), image)
    return _to_uint8(image)


def _grid(size: int) -> tuple[Tensor, Tensor]:
    return torch.meshgrid(torch.linspace(0, 1, size), torch.linspace(0, 1, size), indexing="ij")


def _smooth_noise(size: int, cells: int, generator: torch.Generator) -> Tensor:
    """Value noise in [-1, 1]: a ``cells``-wide grid of random values, upsampled bicubically to ``[size, size]``."""
    values = torch.rand((1, 1, cells + 1, cells + 1), generator=generator) * 2 - 1
    return F.interpolate(values, size=(size, size), mode="bicubic", align_corners=True)[0, 0]


def _to_uint8(image: Tensor) -> Tensor:
    return (image.clamp(0, 1) * 255).round().to(torch.uint8)


def procedural_video(seed: int, length: int, height: int, width: int) -> torch.Tensor:
    """``length`` generated frames, uint8 ``[length, height, width, 3]``: a test-side image seen through a drifting, turning window.

    The image is :func:`stand_in_image` of kind ``seed % 4`` (wood, marble, checker, mosaic): test
    levels' stand-in videos share no generator with the training side's :func:`procedural_image`.
    """
    generator = torch.Generator().manual_seed(seed)
    side = 2 * max(height, width)
    texture = stand_in_image(kind=seed % len(STAND_IN_KINDS), size=side, generator=generator).float()[None]
    angle0, turn, radius = (torch.rand(3, generator=generator) * torch.tensor([2 * math.pi, 0.02, 0.25])).tolist()
    time = torch.arange(length, dtype=torch.float32)
    cx = 0.5 * side + radius * side * torch.cos(angle0 + 2 * math.pi * time / length)
    cy = 0.5 * side + radius * side * torch.sin(angle0 + 2 * math.pi * time / length)
    angle = angle0 + turn * time
    ys, xs = torch.meshgrid(torch.linspace(-0.5, 0.5, height), torch.linspace(-0.5, 0.5, width), indexing="ij")
    span = 0.45 * side
    cos, sin = torch.cos(angle)[:, None, None], torch.sin(angle)[:, None, None]
    px = cx[:, None, None] + span * (cos * xs - sin * ys)
    py = cy[:, None, None] + span * (sin * xs + cos * ys)
    grid = torch.stack((px / (side - 1) * 2 - 1, py / (side - 1) * 2 - 1), dim=-1)
    frames = F.grid_sample(texture.expand(length, -1, -1, -1), grid, mode="bilinear", padding_mode="reflection", align_corners=True)
    return frames.round_().clamp_(0, 255).to(torch.uint8).permute(0, 2, 3, 1).contiguous()

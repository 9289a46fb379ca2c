"""Procedural images and videos: stand-ins for the natural-image and video data sets no machine here can download.

Examples:
    >>> import torch
    >>> from vigen.assets.procedural import procedural_image, procedural_video
    >>> procedural_image(1, 16, torch.Generator().manual_seed(0)).shape
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
"""Fractal noise, Voronoi cells, plaid, colour blobs."""


def procedural_image(kind: int, size: int, generator: torch.Generator) -> Tensor:
    """One generated RGB image, uint8 ``[3, size, size]``: fractal noise, Voronoi, plaid or blobs."""

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


def procedural_video(seed: int, length: int, height: int, width: int) -> torch.Tensor:
    """``length`` generated frames, uint8 ``[length, height, width, 3]``: a procedural image seen through a drifting, turning window."""
    generator = torch.Generator().manual_seed(seed)
    side = 2 * max(height, width)
    texture = procedural_image(kind=seed % 4, size=side, generator=generator).float()[None]
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

"""MaDi's masker: a small convolutional net that gives every frame of a stack a soft mask."""

from __future__ import annotations


import torch
from torch import Tensor, nn

from vigen.models.checks import check_sizes
from vigen.models.networks import weight_init
from vigen.pixel_format import check_max_value, check_pixels, white_value


FRAMES_PER_PASS = 48
"""Frames the masker convolves at once (16 stacks of 3)."""


class MaDiMasker(nn.Module):
    """MaDi's masker: one soft mask ``[1, H, W]`` per frame, multiplied into that frame.

    The stack ``[..., k·c, H, W]`` is split into its k frames of ``c = frame_channels`` channels.
    Each frame, scaled to ``[0, 1]``, goes through the same three 3×3 convolutions (stride 1,
    zero padding 1, so the size is kept): ``c → 32``, ReLU, ``32 → 32``, ReLU, ``32 → 1``, then a
    sigmoid. The mask of a frame multiplies all of its channels, and the masked stack is returned
    as float pixels on the encoder's scale ``[0, max_value]`` (``[0, 1]`` when ``max_value`` is
    ``None``), so it goes straight into a vigen encoder built with the same ``max_value``:

        ``out[f] = frame[f] · sigmoid(net(frame[f] / white))``

    Pixels follow :mod:`vigen.pixel_format`: uint8 on 0–255 or float on ``[0, max_value]``.
    MaDi trains the masker through the critic's loss only (see the ``madi`` preset of :func:`~vigen.losses.make_loss`,
    which puts it in front of the encoder for every view and for the acting policy). With the
    default sizes it has 10,433 parameters for RGB frames.

    Departure from the original: the weights start from vigen's (DrQ-v2's) orthogonal
    initialisation, which every vigen network uses, instead of DMC-GB's delta-orthogonal one.
    MaDi's optional binary ("hard") masks are not offered; its default, and its paper's
    results, are the soft masks here.

    Paper: MaDi, https://arxiv.org/abs/2312.15339.

    Args:
        frame_channels: channels of one frame (3 for RGB stacks, 1 for grayscale).
        num_filters: channels of the hidden convolutions.
        num_layers: number of convolutions (at least 2).
        max_value: the white of float pixels, in and out; ``None`` for 1.0 (TorchRL's
            ``ToTensorImage()``), 255 for float pixels on the 0–255 scale. uint8 input is 0–255.

    Examples:
        >>> import torch
        >>> masker = MaDiMasker()
        >>> pixels = torch.randint(0, 256, (2, 9, 84, 84), dtype=torch.uint8)
        >>> masked = masker(pixels)  # floats on [0, 1]: the scale of an encoder with max_value=None
        >>> masked.shape, masked.dtype, bool(masked.max() <= 1)
        (torch.Size([2, 9, 84, 84]), torch.float32, True)
        >>> masker.masks(pixels).shape  # one mask per frame, e.g. to look at
        torch.Size([2, 3, 1, 84, 84])
        >>> sum(p.numel() for p in masker.parameters())
        10433
    """

    def __init__(
        self, frame_channels: int = 3, num_filters: int = 32, num_layers: int = 3, *, max_value: float | None = None
    ) -> None:
        super().__init__()
        name = type(self).__name__
        check_sizes(name, ("frame_channels", frame_channels, 1), ("num_filters", num_filters, 1), ("num_layers", num_layers, 2))
        self.frame_channels = int(frame_channels)
        self.max_value = check_max_value(name, max_value)
        layers: list[nn.Module] = [nn.Conv2d(frame_channels, num_filters, 3, padding=1)]
        for _ in range(num_layers - 2):
            layers += [nn.ReLU(), nn.Conv2d(num_filters, num_filters, 3, padding=1)]
        layers += [nn.ReLU(), nn.Conv2d(num_filters, 1, 3, padding=1), nn.Sigmoid()]
        self.net = nn.Sequential(*layers)
        self.apply(weight_init)

    def forward(self, pixels: Tensor) -> Tensor:
        """The masked stack: float pixels ``[..., k·c, H, W]`` on ``[0, max_value or 1]``."""
        frames = self._frames(pixels)
        return (frames * self._masks(frames)).reshape(pixels.shape)

    def masks(self, pixels: Tensor) -> Tensor:
        """The soft masks of ``pixels`` ``[..., k·c, H, W]``: values in (0, 1), shape ``[..., k, 1, H, W]``."""
        return self._masks(self._frames(pixels))

    def _frames(self, pixels: Tensor) -> Tensor:
        """Checked pixels as floats on the output scale, split into frames ``[..., k, c, H, W]``."""
        name = type(self).__name__
        check_pixels(pixels.detach(), name=name, max_value=self.max_value)
        *batch, channels, height, width = pixels.shape
        if channels % self.frame_channels:
            raise ValueError(f"{name}: a stack of frames of {self.frame_channels} channels needs a multiple of "
                             f"{self.frame_channels} channels, got {channels} (shape {tuple(pixels.shape)}); "
                             "set frame_channels to the channels of one frame (1 for grayscale).")
        white = 1.0 if self.max_value is None else self.max_value
        frames = pixels if pixels.is_floating_point() else pixels.float() * (white / white_value(pixels))
        return frames.reshape(*batch, channels // self.frame_channels, self.frame_channels, height, width)

    def _masks(self, frames: Tensor) -> Tensor:
        white = 1.0 if self.max_value is None else self.max_value
        *batch, height, width = frames.shape
        flat = frames.reshape(-1, self.frame_channels, height, width) / white
        # full-resolution 32-channel maps: a few hundred frames at a time stay cache-sized (same math)
        parts = flat.split(FRAMES_PER_PASS) if flat.shape[0] > FRAMES_PER_PASS else (flat,)
        masks = torch.cat([self.net(part) for part in parts]) if len(parts) > 1 else self.net(flat)
        return masks.reshape(*batch[:-1], 1, height, width)

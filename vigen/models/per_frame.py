"""SimGRL's encoder: each frame through the same first convolutions, the frames stacked as features."""

from __future__ import annotations


import torch
from torch import Tensor, nn

from vigen.models.checks import check_sizes, check_stack
from vigen.models.networks import chunks_pay, weight_init
from vigen.pixel_format import check_max_value, white_value


class PerFrameEncoder(nn.Module):
    """SimGRL's feature-level frame stacking: the frames of a stack are encoded one by one, then stacked.

    The stack ``[..., k·c, H, W]`` is split into its k frames of ``c = frame_channels`` channels.
    Every frame goes through the same ``frame_layers`` 3×3 convolutions with ``frame_filters``
    channels (the first with stride 2, ReLU between them); the k feature maps are then
    concatenated along the channels, oldest frame first, and the ``k·frame_filters`` channels go
    through a ReLU and the remaining convolutions of SVEA's 11-layer CNN (``channels`` wide,
    stride 1, ReLU between them, none after the last). With SimGRL's sizes: per frame
    ``c → 16 → 16 → 16``, then ``48 → 32`` and seven ``32 → 32``: eleven convolutions, and an
    84×84 input gives 32×21×21 = 14,112 features, as :class:`~vigen.models.SharedCNN` does.
    The first ``frame_layers`` feature maps of a frame thus depend on that frame alone; frames
    meet only in the later layers.

    Pixels follow :mod:`vigen.pixel_format` (uint8 on 0–255 or float on ``[0, max_value]``) and
    are scaled to ``x / white − 0.5`` as in vigen's other encoders, or to SimGRL's ``x / white``
    with ``centered=False`` (``make_loss("simgrl")``). Weights start from DrQ-v2's orthogonal
    initialisation (SimGRL uses DMC-GB's delta-orthogonal one).

    Paper: SimGRL (NeurIPS 2024; no arXiv version), https://openreview.net/forum?id=0AumdfLzpK.

    Args:
        in_channels: channels of the stack (``k·frame_channels``).
        frame_channels: channels of one frame (3 for RGB).
        num_layers: convolutions in all (11).
        frame_layers: of those, the ones applied to each frame alone (3).
        frame_filters: channels of the per-frame convolutions (16).
        channels: channels of the convolutions after the stacking (32).
        chunk_size, max_value: as in :class:`~vigen.models.DrQv2Encoder`.
        centered: scale to ``x / white − 0.5`` (default); ``False`` for SimGRL's ``x / white``.

    Examples:
        >>> import torch
        >>> encoder = PerFrameEncoder(9)
        >>> pixels = torch.randint(0, 256, (2, 9, 84, 84), dtype=torch.uint8)
        >>> encoder(pixels).shape
        torch.Size([2, 14112])
        >>> encoder.output_dim(9, 84, 84)
        14112
    """

    def __init__(
        self,
        in_channels: int = 9,
        frame_channels: int = 3,
        num_layers: int = 11,
        frame_layers: int = 3,
        frame_filters: int = 16,
        channels: int = 32,
        chunk_size: int | None = 64,
        *,
        max_value: float | None = None,
        centered: bool = True,
    ) -> None:
        super().__init__()
        name = type(self).__name__
        check_sizes(name, ("in_channels", in_channels, 1), ("frame_channels", frame_channels, 1), ("frame_layers", frame_layers, 1),
                    ("frame_filters", frame_filters, 1), ("channels", channels, 1), ("num_layers", num_layers, 1))
        if num_layers <= frame_layers:
            raise ValueError(f"{name}: num_layers must be an int >= {frame_layers + 1}, got {num_layers!r} (at least one "
                             "convolution follows the stacking).")
        if in_channels % frame_channels:
            raise ValueError(f"{name}: in_channels={in_channels} is not a stack of frames of {frame_channels} channels; "
                             "pass in_channels = frames · frame_channels (9 for three RGB frames).")
        self.in_channels, self.frame_channels = int(in_channels), int(frame_channels)
        self.frames = self.in_channels // self.frame_channels
        self.chunk_size = chunk_size
        self.max_value = check_max_value(name, max_value)
        self.centered = bool(centered)
        frame_net: list[nn.Module] = [nn.Conv2d(frame_channels, frame_filters, 3, stride=2)]
        for _ in range(frame_layers - 1):
            frame_net += [nn.ReLU(), nn.Conv2d(frame_filters, frame_filters, 3, stride=1)]
        stack_net: list[nn.Module] = [nn.ReLU(), nn.Conv2d(self.frames * frame_filters, channels, 3, stride=1)]
        for _ in range(num_layers - frame_layers - 1):
            stack_net += [nn.ReLU(), nn.Conv2d(channels, channels, 3, stride=1)]
        self.frame_net = nn.Sequential(*frame_net)
        self.stack_net = nn.Sequential(*stack_net)
        self.apply(weight_init)

    def forward(self, pixels: Tensor) -> Tensor:
        check_stack(type(self).__name__, pixels, self.in_channels, self.max_value)
        white = white_value(pixels, self.max_value)
        batch, image = pixels.shape[:-3], pixels.shape[-3:]
        x = pixels.reshape(-1, *image)
        parts = x.split(self.chunk_size) if chunks_pay(x, self.chunk_size) else (x,)
        features = [self.stack_frames(part if part.is_floating_point() else part.float(), white) for part in parts]
        features = features[0] if len(features) == 1 else torch.cat(features)
        return features.reshape(*batch, -1)

    def stack_frames(self, x: Tensor, white: float) -> Tensor:
        """Flat features of float stacks ``[N, k·c, H, W]`` whose white is ``white``."""
        n, _, height, width = x.shape
        offset = 0.5 if self.centered else 0.0
        per_frame = self.frame_net((x / white - offset).reshape(n * self.frames, self.frame_channels, height, width))
        stacked = per_frame.reshape(n, -1, *per_frame.shape[-2:])  # frame f's maps at channels [f·F, (f+1)·F)
        return self.stack_net(stacked).flatten(1)

    def output_dim(self, channels: int, height: int, width: int) -> int:
        """Size of the flat representation for ``[channels, height, width]`` inputs."""
        with torch.no_grad():
            return self(torch.zeros(1, channels, height, width)).shape[-1]

"""VRL3's encoder: the small ResNet for 84×84 frames ("ResNet84") that RL-ViGen's VRL3 trains on Adroit."""

from __future__ import annotations

import os
import warnings

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from vigen.models.checks import check_sizes, check_stack
from vigen.models.networks import resnet_init
from vigen.pixel_format import check_max_value, white_value

IMAGENET_MEAN = (0.485, 0.456, 0.406)
"""Per-channel mean of ImageNet's RGB images, which VRL3 subtracts from every frame of the stack."""
IMAGENET_STD = (0.229, 0.224, 0.225)
"""Per-channel std of ImageNet's RGB images, which VRL3 divides every frame of the stack by."""
RGB = 3


class VRL3Encoder(nn.Module):
    """VRL3's stage-1/stage-3 encoder: a narrow ResNet with BatchNorm and global average pooling.

    The network (VRL3's ``ResNet84``; the default is its ``resnet6_32channel``, which RL-ViGen
    uses on Adroit):

    * a stem: 3×3 convolution with stride 2, no padding, with bias, to ``channels``; BatchNorm; ReLU;
    * four stages of ``channels``, ``2·channels``, ``4·channels``, ``8·channels`` (the first with
      stride 1, the others stride 2). With ``blocks=0`` a stage is one padded 3×3 convolution
      (no bias), BatchNorm and ReLU; with ``blocks=n ≥ 1`` it is ``n`` residual blocks of
      torchvision's ResNet (``resnet10``: 1, ``resnet18``: 2), with a 1×1 projection where the
      shape changes;
    * global average pooling: ``8·channels`` features (256 by default) for any frame size ≥ 3.

    Pixels follow :mod:`vigen.pixel_format` (uint8 on 0–255 or float on ``[0, max_value]``) and
    are normalised per RGB channel of every frame with ImageNet's mean and std,
    ``(x / white − mean) / std``, as VRL3 does (vigen's other encoders use ``x / white − 0.5``).

    Frame stacks: the stem is built for one RGB frame and its weights are tiled over the ``k``
    frames of the stack and divided by ``k`` (VRL3's "convolutional channel expansion"), so a
    stack of identical frames gives the features of one frame. RL-ViGen does this with random
    weights too (it trains on Adroit without stage 1); ``stage1_weights`` loads a stage-1
    checkpoint of the same architecture first (see :meth:`load_stage1`). Without it a warning
    says that the encoder starts from random weights (once per calling line).

    The BatchNorms use the statistics of each batch in training mode and their running
    statistics in eval mode; a batch is never split into chunks, which would change its
    statistics. Initialisation as in torchvision's ResNet: Kaiming-normal convolutions
    (``fan_out``), BatchNorm weight 1 and bias 0.

    Paper: VRL3, https://arxiv.org/abs/2202.10324; RL-ViGen, https://arxiv.org/abs/2307.10224.

    Args:
        in_channels: channels of the frame stack, ``3·k``.
        channels: width of the stem and the first stage (32; VRL3 also reports 64).
        blocks: residual blocks per stage; 0 is VRL3's shallow ``resnet6``.
        stage1_weights: a stage-1 checkpoint file (VRL3's ``<model>_checkpoint.pth.tar``, or a
            plain state dict); ``None`` starts from random weights, as RL-ViGen does.
        max_value: the white of float pixels, as in :class:`~vigen.models.DrQv2Encoder`.

    Examples:
        >>> import torch, warnings
        >>> with warnings.catch_warnings():
        ...     warnings.simplefilter("ignore")  # no stage-1 weights here: random initialisation
        ...     encoder = VRL3Encoder(9)
        >>> pixels = torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)
        >>> encoder(pixels).shape, encoder.output_dim(9, 84, 84)
        (torch.Size([4, 256]), 256)
    """

    def __init__(
        self,
        in_channels: int = 9,
        channels: int = 32,
        blocks: int = 0,
        *,
        stage1_weights: str | os.PathLike | None = None,
        max_value: float | None = None,
    ) -> None:
        super().__init__()
        name = type(self).__name__
        check_sizes(name, ("in_channels", in_channels, 1), ("channels", channels, 1), ("blocks", blocks, 0))
        if in_channels % RGB:
            raise ValueError(f"{name}: in_channels={in_channels} is not a stack of RGB frames; VRL3 normalises each "
                             "frame with ImageNet's RGB statistics, so pass in_channels = 3·frames (9 for three frames).")
        self.in_channels, self.channels, self.blocks = int(in_channels), int(channels), int(blocks)
        self.frames = self.in_channels // RGB
        self.max_value = check_max_value(name, max_value)
        self.conv1 = nn.Conv2d(in_channels, channels, 3, stride=2)
        self.bn1 = nn.BatchNorm2d(channels)
        width = channels
        for index, multiple in enumerate((1, 2, 4, 8)):
            stride = 1 if index == 0 else 2
            layers: list[nn.Module]
            if blocks == 0:
                layers = [_ConvBlock(width, channels * multiple, stride)]
            else:
                layers = [_ResidualBlock(width, channels * multiple, stride)]
                layers += [_ResidualBlock(channels * multiple, channels * multiple, 1) for _ in range(blocks - 1)]
            setattr(self, f"layer{index + 1}", nn.Sequential(*layers))
            width = channels * multiple
        self.apply(resnet_init)
        if stage1_weights is None:
            warnings.warn(
                f"{name} starts from random weights, as RL-ViGen runs VRL3 on Adroit (stage1_use_pretrain=False). "
                "VRL3's paper pretrains it on ImageNet (stage 1): pass stage1_weights=<checkpoint> to start from one.",
                UserWarning, stacklevel=2,
            )
            one_frame = nn.Conv2d(RGB, channels, 3, stride=2)
            nn.init.kaiming_normal_(one_frame.weight, mode="fan_out", nonlinearity="relu")
            self._expand_stem(one_frame.weight, one_frame.bias)
        else:
            self.load_stage1(stage1_weights)

    @property
    def output_size(self) -> int:
        """Number of features: the last stage's channels, ``8·channels``."""
        return 8 * self.channels

    def forward(self, pixels: Tensor) -> Tensor:
        check_stack(type(self).__name__, pixels, self.in_channels, self.max_value)
        white = white_value(pixels, self.max_value)
        batch, image = pixels.shape[:-3], pixels.shape[-3:]
        x = pixels.reshape(-1, *image)
        x = x if x.is_floating_point() else x.float()
        mean = x.new_tensor(IMAGENET_MEAN * self.frames).view(-1, 1, 1)
        std = x.new_tensor(IMAGENET_STD * self.frames).view(-1, 1, 1)
        x = F.relu(self.bn1(self.conv1((x / white - mean) / std)))
        x = self.layer4(self.layer3(self.layer2(self.layer1(x))))
        return x.mean(dim=(-2, -1)).reshape(*batch, -1)

    def output_dim(self, channels: int, height: int, width: int) -> int:
        """Size of the features for ``[channels, height, width]`` inputs (``8·channels``, pooled), without a forward pass.

        No forward pass: in training mode it would move the BatchNorms' running statistics.
        """
        if channels != self.in_channels:
            raise ValueError(f"{type(self).__name__} was built for stacks of {self.in_channels} channels, not {channels}.")
        if min(height, width) < 3:
            raise ValueError(f"{type(self).__name__}: frames must be at least 3×3 (a 3×3 stem without padding), "
                             f"got {height}×{width}.")
        return self.output_size

    def load_stage1(self, path: str | os.PathLike) -> None:
        """Load a stage-1 checkpoint of one RGB frame's network and tile its stem over the stack.

        The file holds VRL3's ``train_stage1.py`` checkpoint (a dict whose ``"state_dict"`` is the
        ``ResNet84``'s, maybe with DataParallel's ``module.`` prefixes) or a plain state dict with
        the same names. It is read with ``torch.load(weights_only=True)`` (no code runs); the
        classifier (``fc.*``) is dropped. Every weight of this encoder must be in the file, and
        nothing else: a mismatch (another ``channels`` or ``blocks``) raises, naming the keys.
        """
        name = type(self).__name__
        if not os.path.isfile(path):
            raise FileNotFoundError(
                f"{name}: no stage-1 checkpoint at {os.fspath(path)!r}. vigen cannot download VRL3's pretrained "
                "encoders: get one from VRL3's data folder (vrl3data/trained_models/resnet6_32channel_checkpoint.pth.tar) "
                "or train one with VRL3's train_stage1.py, or pass stage1_weights=None to start from random weights."
            )
        checkpoint = torch.load(path, map_location="cpu", weights_only=True)
        state = checkpoint.get("state_dict", checkpoint) if isinstance(checkpoint, dict) else None
        if not isinstance(state, dict):
            raise ValueError(f"{name}: {os.fspath(path)!r} holds a {type(checkpoint).__name__}, not a state dict "
                             "(or a checkpoint with a 'state_dict' entry).")
        state = {key.removeprefix("module."): value for key, value in state.items()}
        state = {key: value for key, value in state.items() if not key.startswith("fc.")}
        expected = {key: value.shape for key, value in self.state_dict().items()}
        expected["conv1.weight"] = self.conv1.weight.shape[:1] + (RGB,) + self.conv1.weight.shape[2:]
        missing = sorted(set(expected) - set(state))
        unexpected = sorted(set(state) - set(expected))
        wrong = sorted(key for key in set(expected) & set(state) if tuple(state[key].shape) != tuple(expected[key]))
        if missing or unexpected or wrong:
            problems = [f"{label}: {', '.join(keys[:6])}{' ...' if len(keys) > 6 else ''}"
                        for label, keys in (("missing", missing), ("unexpected", unexpected), ("wrong shape", wrong)) if keys]
            raise ValueError(f"{name}(channels={self.channels}, blocks={self.blocks}) does not match the checkpoint "
                             f"{os.fspath(path)!r} ({'; '.join(problems)}); build the encoder with the checkpoint's "
                             "width and depth (resnet6_32channel: channels=32, blocks=0; resnet18: blocks=2).")
        stem_weight, stem_bias = state.pop("conv1.weight"), state.pop("conv1.bias")
        self.load_state_dict(state, strict=False)
        self._expand_stem(stem_weight, stem_bias)

    def _expand_stem(self, weight: Tensor, bias: Tensor) -> None:
        """Copy a one-frame stem's weights into the stem, tiled over the ``k`` frames and divided by ``k`` (in place)."""
        with torch.no_grad():
            self.conv1.weight.copy_(weight.detach().to(self.conv1.weight).repeat(1, self.frames, 1, 1) / self.frames)
            self.conv1.bias.copy_(bias.detach().to(self.conv1.bias))


class _ConvBlock(nn.Module):
    """One padded 3×3 convolution (no bias), BatchNorm and ReLU: a stage of VRL3's shallow ResNet."""

    def __init__(self, in_channels: int, out_channels: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(in_channels, out_channels, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(out_channels)

    def forward(self, x: Tensor) -> Tensor:
        return F.relu(self.bn1(self.conv1(x)))


class _ResidualBlock(nn.Module):
    """torchvision's ResNet basic block: two 3×3 conv-BN, a 1×1 conv-BN projection where the shape changes, ReLU."""

    def __init__(self, in_channels: int, out_channels: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(in_channels, out_channels, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(out_channels)
        self.conv2 = nn.Conv2d(out_channels, out_channels, 3, padding=1, bias=False)
        self.bn2 = nn.BatchNorm2d(out_channels)
        self.downsample = None
        if stride != 1 or in_channels != out_channels:
            self.downsample = nn.Sequential(nn.Conv2d(in_channels, out_channels, 1, stride=stride, bias=False),
                                            nn.BatchNorm2d(out_channels))

    def forward(self, x: Tensor) -> Tensor:
        shortcut = x if self.downsample is None else self.downsample(x)
        return F.relu(self.bn2(self.conv2(F.relu(self.bn1(self.conv1(x))))) + shortcut)

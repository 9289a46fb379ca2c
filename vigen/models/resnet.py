"""ResNet-18's early layers under torchvision's names, and PIE-G's frozen encoder built on them.

torchvision is not a dependency of vigen: :class:`ResNet18Features` writes the stem and the basic
blocks out with torchvision's module names (``conv1``, ``bn1``, ``layer1.0.conv1``,
``layer2.0.downsample.0``, ...), so a state dict of torchvision's ImageNet ResNet-18 loads into it
as it is (:meth:`ResNet18Features.load_torchvision_weights`).
"""

from __future__ import annotations

import numbers
import os
import pickle
import warnings
from typing import Literal

import torch
from torch import Tensor, nn

from vigen.models.checks import check_sizes
from vigen.models.networks import resnet_init
from vigen.models.vrl3 import IMAGENET_MEAN, IMAGENET_STD
from vigen.pixel_format import check_max_value, check_pixels, white_value

RGB = 3
RESNET18_URL = "https://download.pytorch.org/models/resnet18-f37072fd.pth"
RESNET18_FETCH = "python -m vigen.datasets fetch torchvision-resnet18"
"""The command that fetches torchvision's ImageNet ResNet-18 into vigen's data cache (:mod:`vigen.datasets`)."""
"""torchvision's ImageNet ResNet-18 (``ResNet18_Weights.IMAGENET1K_V1``), a plain state dict."""
_WIDTHS = (64, 128, 256, 512)
_BATCH_NORM_COUNTER = "num_batches_tracked"


class ResNet18Features(nn.Module):
    """ResNet-18 from its stem up to ``layer{depth}``, on RGB images ``[N, 3, H, W]``.

    The stem (7×7 convolution with stride 2, BatchNorm, ReLU, 3×3 max-pool with stride 2) and
    ``depth`` stages of two basic blocks each (64, 128, 256, 512 channels; every stage after the
    first halves the resolution), as torchvision's ``resnet18`` without its pooling and
    classifier, with the same module names and initialisation (Kaiming-normal convolutions,
    ``fan_out``; BatchNorm weight 1, bias 0). A 16×16 image gives 128×2×2 features at
    ``depth=2``, an 84×84 one 128×11×11.

    Paper: ResNet, https://arxiv.org/abs/1512.03385.

    Args:
        depth: the last stage kept, 1 to 4 (PIE-G: 2).

    Examples:
        >>> import torch
        >>> features = ResNet18Features(depth=2)
        >>> features(torch.zeros(2, 3, 84, 84)).shape, features.output_shape(84, 84)
        (torch.Size([2, 128, 11, 11]), (128, 11, 11))
        >>> sorted(features.state_dict())[:3]
        ['bn1.bias', 'bn1.num_batches_tracked', 'bn1.running_mean']
    """

    def __init__(self, depth: int = 2) -> None:
        super().__init__()
        if isinstance(depth, bool) or not isinstance(depth, numbers.Integral) or not 1 <= depth <= 4:
            raise ValueError(f"{type(self).__name__}: depth is the last ResNet stage kept, 1 to 4, got {depth!r}.")
        self.depth = int(depth)
        self.conv1 = nn.Conv2d(RGB, 64, 7, stride=2, padding=3, bias=False)
        self.bn1 = nn.BatchNorm2d(64)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(3, stride=2, padding=1)
        width = 64
        for index, channels in enumerate(_WIDTHS[: self.depth]):
            stride = 1 if index == 0 else 2
            blocks = (_BasicBlock(width, channels, stride), _BasicBlock(channels, channels, 1))
            setattr(self, f"layer{index + 1}", nn.Sequential(*blocks))
            width = channels
        self.apply(resnet_init)

    @property
    def out_channels(self) -> int:
        """Channels of the last stage kept."""
        return _WIDTHS[self.depth - 1]

    def forward(self, images: Tensor) -> Tensor:
        x = self.maxpool(self.relu(self.bn1(self.conv1(images))))
        for index in range(1, self.depth + 1):
            x = getattr(self, f"layer{index}")(x)
        return x

    def output_shape(self, height: int, width: int) -> tuple[int, int, int]:
        """``(channels, height, width)`` of the features of ``height × width`` images, without a forward pass."""

        def halve(size: int, kernel: int, padding: int) -> int:
            return (size + 2 * padding - kernel) // 2 + 1

        height, width = halve(halve(height, 7, 3), 3, 1), halve(halve(width, 7, 3), 3, 1)  # stem convolution, max-pool
        for _ in range(self.depth - 1):  # every stage after the first halves the size
            height, width = halve(height, 3, 1), halve(width, 3, 1)
        return self.out_channels, height, width

    def load_torchvision_weights(self, path: str | os.PathLike) -> None:
        """Load the layers kept from a file holding a state dict of torchvision's ResNet-18.

        The file is read with ``torch.load(weights_only=True)``: tensors only, no code is
        unpickled. It holds a plain state dict (torchvision's ``resnet18-f37072fd.pth``, or
        ``torch.save(resnet18(...).state_dict(), path)``), or one under a ``"state_dict"`` key,
        maybe with DataParallel's ``module.`` prefixes. The classifier (``fc.*``) and the stages
        past ``depth`` are ignored; BatchNorm counters (``num_batches_tracked``, absent from
        older files) are optional. A missing weight, an unknown one inside the kept layers (a
        deeper ResNet's) or a wrong shape raises, naming the keys.
        """
        name = type(self).__name__
        state = _read_state_dict(path, name)
        kept = ("conv1.", "bn1.", *(f"layer{index}." for index in range(1, self.depth + 1)))
        state = {key: value for key, value in state.items() if key.startswith(kept)}
        expected = self.state_dict()
        missing = sorted(key for key in expected if key not in state and not key.endswith(_BATCH_NORM_COUNTER))
        unexpected = sorted(key for key in state if key not in expected)
        wrong = sorted(key for key in state if key in expected and tuple(state[key].shape) != tuple(expected[key].shape))
        if missing or unexpected or wrong:
            problems = [f"{label}: {', '.join(keys[:6])}{' ...' if len(keys) > 6 else ''}"
                        for label, keys in (("missing", missing), ("unexpected", unexpected), ("wrong shape", wrong)) if keys]
            raise ValueError(
                f"{name}: {os.fspath(path)!r} is not a torchvision ResNet-18 state dict ({'; '.join(problems)}). "
                f"Save one with torch.save(torchvision.models.resnet18(weights='IMAGENET1K_V1').state_dict(), path) "
                f"or download {RESNET18_URL}."
            )
        for key, value in expected.items():
            if key.endswith(_BATCH_NORM_COUNTER) and key not in state:
                state[key] = torch.zeros_like(value)
        self.load_state_dict(state)


class _BasicBlock(nn.Module):
    """torchvision's ResNet basic block: two 3×3 conv-BN, a 1×1 conv-BN shortcut where the shape changes, ReLU."""

    def __init__(self, in_channels: int, out_channels: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(in_channels, out_channels, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(out_channels)
        self.relu = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(out_channels, out_channels, 3, padding=1, bias=False)
        self.bn2 = nn.BatchNorm2d(out_channels)
        self.downsample = None
        if stride != 1 or in_channels != out_channels:
            self.downsample = nn.Sequential(
                nn.Conv2d(in_channels, out_channels, 1, stride=stride, bias=False), nn.BatchNorm2d(out_channels)
            )

    def forward(self, x: Tensor) -> Tensor:
        shortcut = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        return self.relu(self.bn2(self.conv2(out)) + shortcut)


class PIEGEncoder(nn.Module):
    """PIE-G's encoder: frozen ImageNet ResNet-18 layers on every frame, temporal differences, Linear → LayerNorm.

    As RL-ViGen's (and PIE-G's) ``ResEncoder``:

    1. pixels (:mod:`vigen.pixel_format`: uint8 on 0–255 or float on ``[0, max_value]``) are
       scaled to ``x / white − 0.5`` (RL-ViGen's ``obs / 255 − 0.5``, not ImageNet's mean and
       std; ``normalization="imagenet"`` uses those instead);
    2. each of the ``k`` RGB frames of the stack goes through ResNet-18 up to ``layer2`` (``depth``)
       (:class:`ResNet18Features`; ``k`` frames of one sample share the batch), giving maps
       ``f_1 … f_k`` of 128 channels (11×11 for 84×84 frames);
    3. the maps are combined as ``[f_2, …, f_k, f_2 − f_1, …, f_k − f_{k−1}]`` (the later frames
       and their differences with the previous one) and flattened: ``2·(k−1)·128·11·11`` =
       61,952 features for three 84×84 frames;
    4. a Linear layer (PyTorch's default initialisation, as in RL-ViGen; PIE-G's own code
       initialises it orthogonally with zero bias) to ``out_dim`` (1024) and a LayerNorm,
       without activation.

    The ResNet's weights are frozen (``requires_grad=False``) and no graph is built through it
    unless the pixels themselves need a gradient; only the Linear layer and the LayerNorm learn.
    Its BatchNorm layers follow the module's mode: in training mode (the default, and PIE-G's
    updates) they normalise with the statistics of the batch (all ``B·k`` frames) and update
    their running statistics, although their weights are frozen; in eval mode they use the
    running statistics. A batch is never split into chunks, which would change its statistics.
    :class:`~vigen.losses.PIEGLoss` acts with the running statistics, as RL-ViGen does.

    One departure: RL-ViGen's encoder measures its output size with a forward pass of a random
    normal batch (32 stacks) in training mode while it is built, so its running statistics start
    one momentum step (0.1) away from ImageNet's, towards those of that noise. Here the size is
    computed without a forward pass and the statistics start at the loaded values; the difference
    fades by a factor 0.9 with every encoder pass of the updates, and the updates' outputs (batch
    statistics) do not depend on it.

    ``weights`` loads torchvision's ImageNet ResNet-18 (a state dict file, see
    :meth:`ResNet18Features.load_torchvision_weights`); PIE-G's results need them. Without them
    the ResNet starts from torchvision's random initialisation and a warning says so (once per
    process, under Python's default warning filter).

    Paper: PIE-G, https://arxiv.org/abs/2212.08860.

    Args:
        in_channels: channels of the frame stack, ``3·k`` with ``k ≥ 2`` (the features are
            built from frame differences).
        image_size: height (= width) of the frames; it fixes the Linear layer's input.
        out_dim: the representation's size (1024).
        depth: the last ResNet stage kept (2).
        weights: a file with torchvision's ResNet-18 state dict; ``None`` for random weights.
        normalization: ``"centered"`` (``x / white − 0.5``, RL-ViGen) or ``"imagenet"``
            (``(x / white − mean) / std`` per RGB channel).
        max_value: the white of float pixels, as in :class:`~vigen.models.DrQv2Encoder`.

    Examples:
        >>> import torch, warnings
        >>> with warnings.catch_warnings():
        ...     warnings.simplefilter("ignore")  # no ImageNet weights here: random ResNet weights
        ...     encoder = PIEGEncoder(9, image_size=16, out_dim=32)
        >>> pixels = torch.randint(0, 256, (4, 9, 16, 16), dtype=torch.uint8)
        >>> encoder(pixels).shape, encoder.output_dim(9, 16, 16), encoder.conv_dim  # 4 maps of 128×2×2
        (torch.Size([4, 32]), 32, 2048)
        >>> any(p.requires_grad for p in encoder.resnet.parameters())
        False
    """

    def __init__(
        self,
        in_channels: int = 9,
        image_size: int = 84,
        out_dim: int = 1024,
        *,
        depth: int = 2,
        weights: str | os.PathLike | None = None,
        normalization: Literal["centered", "imagenet"] = "centered",
        max_value: float | None = None,
    ) -> None:
        super().__init__()
        name = type(self).__name__
        check_sizes(name, ("in_channels", in_channels, 1), ("image_size", image_size, 1), ("out_dim", out_dim, 1))
        if in_channels % RGB or in_channels < 2 * RGB:
            raise ValueError(
                f"{name}: in_channels={in_channels} is not a stack of at least two RGB frames. PIE-G runs the ResNet on "
                "each RGB frame and builds its features from the differences of consecutive frames: stack k >= 2 frames "
                "(in_channels = 3·k, 9 for three)."
            )
        if normalization not in ("centered", "imagenet"):
            raise ValueError(f"{name}: normalization must be 'centered' (x / white - 0.5, RL-ViGen) or 'imagenet', "
                             f"got {normalization!r}.")
        self.in_channels, self.image_size, self.out_dim = int(in_channels), int(image_size), int(out_dim)
        self.frames = self.in_channels // RGB
        self.normalization = normalization
        self.max_value = check_max_value(name, max_value)
        self.resnet = ResNet18Features(depth)
        channels, height, width = self.resnet.output_shape(self.image_size, self.image_size)
        self.conv_dim = 2 * (self.frames - 1) * channels * height * width
        self.fc = nn.Linear(self.conv_dim, self.out_dim)
        self.ln = nn.LayerNorm(self.out_dim)
        if weights is None:
            warnings.warn(
                f"{name}: the ResNet-18 starts from random weights; PIE-G's results need ImageNet weights. Fetch "
                f"torchvision's ResNet-18 state dict, checked by its sha256, with `{RESNET18_FETCH}` "
                "(examples/train.py --recipe pieg-rlvigen then finds it), or download it "
                f"({RESNET18_URL}, or torch.save(torchvision.models.resnet18(weights='IMAGENET1K_V1').state_dict(), "
                "file)) and pass weights=<file>; with make_loss: make_loss('pieg', ..., encoder_weights=<file>); with "
                "examples/train.py: --encoder-weights <file>.",
                UserWarning, stacklevel=1,  # one location: shown once per process by the default filter
            )
        else:
            self.resnet.load_torchvision_weights(weights)
        self.resnet.requires_grad_(False)
        self._initial_statistics = {key: value.clone() for key, value in self.resnet.named_buffers()}

    def forward(self, pixels: Tensor) -> Tensor:
        name = type(self).__name__
        check_pixels(pixels.detach(), name=name, max_value=self.max_value)
        if tuple(pixels.shape[-3:]) != (self.in_channels, self.image_size, self.image_size):
            raise ValueError(
                f"{name} was built for [..., {self.in_channels}, {self.image_size}, {self.image_size}] frame stacks, got "
                f"shape {tuple(pixels.shape)}; build it with in_channels={pixels.shape[-3]}, image_size={pixels.shape[-1]} "
                "(square frames)."
            )
        white = white_value(pixels, self.max_value)
        batch = pixels.shape[:-3]
        frames = pixels.reshape(-1, RGB, self.image_size, self.image_size)  # sample-major, then frame
        dtype = self.resnet.conv1.weight.dtype
        x = frames.to(dtype) / white
        if self.normalization == "centered":
            x = x - 0.5
        else:
            x = (x - x.new_tensor(IMAGENET_MEAN).view(-1, 1, 1)) / x.new_tensor(IMAGENET_STD).view(-1, 1, 1)
        with torch.set_grad_enabled(torch.is_grad_enabled() and x.requires_grad):
            maps = self.resnet(x)
        maps = maps.reshape(-1, self.frames, *maps.shape[1:])
        later = maps[:, 1:]
        features = torch.cat([later, later - maps[:, :-1]], dim=1).flatten(1)
        return self.ln(self.fc(features)).reshape(*batch, self.out_dim)

    def output_dim(self, channels: int, height: int, width: int) -> int:
        """Size of the representation (``out_dim``) for ``[channels, height, width]`` inputs, without a forward pass.

        No forward pass: in training mode it would move the BatchNorms' running statistics.
        """
        if (channels, height, width) != (self.in_channels, self.image_size, self.image_size):
            raise ValueError(f"{type(self).__name__} was built for {self.in_channels}×{self.image_size}×{self.image_size} "
                             f"frame stacks, not {channels}×{height}×{width}.")
        return self.out_dim

    def reset_parameters(self) -> None:
        """Re-initialise what learns (the Linear layer and the LayerNorm) and put the BatchNorm statistics back.

        The frozen ResNet weights (ImageNet's, when loaded) are kept; the BatchNorms' running
        statistics return to their values after construction (those of the weights file).
        """
        self.fc.reset_parameters()
        self.ln.reset_parameters()
        with torch.no_grad():
            for key, value in self.resnet.named_buffers():
                value.copy_(self._initial_statistics[key])


def _read_state_dict(path: str | os.PathLike, name: str) -> dict[str, Tensor]:
    """The state dict in ``path`` (plain or under ``"state_dict"``, ``module.`` prefixes removed), no code unpickled."""
    if not os.path.isfile(path):
        raise FileNotFoundError(
            f"{name}: no ResNet-18 weights at {os.fspath(path)!r}. Fetch them into vigen's data cache, checked by their "
            f"sha256, with `{RESNET18_FETCH}` (then `python -m vigen.datasets path torchvision-resnet18` prints the folder), "
            f"or download {RESNET18_URL} (or save torchvision.models.resnet18(weights='IMAGENET1K_V1').state_dict() "
            "with torch.save) and pass its path; weights=None starts from random weights."
        )
    try:
        checkpoint = torch.load(path, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as error:
        raise ValueError(f"{name}: {os.fspath(path)!r} holds more than tensors, and vigen never unpickles code from a "
                         "weights file; save the model's state dict alone: torch.save(model.state_dict(), path).") from error
    state = checkpoint.get("state_dict", checkpoint) if isinstance(checkpoint, dict) else None
    if not isinstance(state, dict) or not all(isinstance(value, Tensor) for value in state.values()):
        raise ValueError(f"{name}: {os.fspath(path)!r} holds no state dict (a dict of tensors, plain or under a "
                         "'state_dict' key); save one with torch.save(model.state_dict(), path).")
    return {str(key).removeprefix("module."): value for key, value in state.items()}

"""Networks with the papers' shapes: DrQ-v2's encoder, actor and twin critic, SVEA's 11-layer CNN,
the CURL/SGQN projection encoder, SGQN's attribution decoder and CURL's bilinear head.

The encoders take pixels as :mod:`vigen.pixel_format` defines them: ``[..., C, H, W]``, uint8 on
0–255 or float on ``[0, max_value]`` (``max_value=None``: 1.0, TorchRL's ``ToTensorImage()`` scale;
float pixels on the 0–255 scale need ``max_value=255``). They check that contract, then scale the
pixels to ``x / white − 0.5`` (white: 255 for uint8, ``max_value`` or 1.0 for floats), which is
DrQ-v2's ``x / 255 − 0.5`` for uint8 frames. Weights are initialised as in DrQ-v2's
``utils.weight_init``: orthogonal, gain 1 for linear layers and the ReLU gain for convolutions,
zero biases.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from vigen.pixel_format import check_max_value, check_pixels, white_value


def weight_init(module: nn.Module) -> None:
    """DrQ-v2's initialisation, for ``module.apply(weight_init)``."""
    if isinstance(module, (nn.Linear, nn.Conv2d, nn.ConvTranspose2d)):
        gain = 1.0 if isinstance(module, nn.Linear) else nn.init.calculate_gain("relu")
        weight = torch.empty(module.weight.shape, dtype=module.weight.dtype, device=module.weight.device)
        module.weight.data.copy_(nn.init.orthogonal_(weight, gain))  # copy_ keeps a channels-last layout
        if module.bias is not None:
            module.bias.data.fill_(0.0)


def resnet_init(module: nn.Module) -> None:
    """torchvision's ResNet initialisation, for ``model.apply``: Kaiming-normal convs (``fan_out``), BatchNorm weight 1, bias 0."""
    if isinstance(module, nn.Conv2d):
        nn.init.kaiming_normal_(module.weight, mode="fan_out", nonlinearity="relu")
    elif isinstance(module, nn.BatchNorm2d):
        nn.init.ones_(module.weight)
        nn.init.zeros_(module.bias)


class _PixelEncoder(nn.Module):
    """Check and scale pixels, run ``self.convnet`` ``chunk_size`` samples at a time, flatten, ``project``.

    Pixels are scaled to ``x / white − 0.5`` with ``white = white_value(x, self.max_value)``
    (``x / white`` when ``centered`` is False).

    Convolving a large batch in chunks of about 64 samples keeps each chunk's activations in
    cache: the same math, about twice as fast on CPUs at batch 256. ``chunk_size=None`` convolves
    the whole batch at once. Chunks are used on the CPU only (:func:`chunks_pay`).
    """

    convnet: nn.Module

    def __init__(self, chunk_size: int | None, max_value: float | None, centered: bool = True) -> None:
        super().__init__()
        self.chunk_size = chunk_size
        self.max_value = check_max_value(type(self).__name__, max_value)
        self.centered = bool(centered)  # x / white − 0.5 (DrQ-v2, RL-ViGen); False: x / white (DMC-GB)

    def forward(self, pixels: Tensor) -> Tensor:
        check_pixels(pixels.detach(), name=type(self).__name__, max_value=self.max_value)
        white = white_value(pixels, self.max_value)
        offset = 0.5 if self.centered else 0.0
        batch, image = pixels.shape[:-3], pixels.shape[-3:]
        x = pixels.reshape(-1, *image)
        parts = x.split(self.chunk_size) if chunks_pay(x, self.chunk_size) else (x,)
        features = [self.convnet(_as_float(part) / white - offset).flatten(1) for part in parts]
        features = features[0] if len(features) == 1 else torch.cat(features)
        return self.project(features).reshape(*batch, -1)

    def project(self, features: Tensor) -> Tensor:
        """What follows the convolutions (nothing here; a linear layer in :class:`ProjectedEncoder`)."""
        return features

    def output_dim(self, channels: int, height: int, width: int) -> int:
        """Size of the flat representation for ``[channels, height, width]`` inputs."""
        with torch.no_grad():
            return self(torch.zeros(1, channels, height, width)).shape[-1]


class DrQv2Encoder(_PixelEncoder):
    """DrQ-v2's encoder: four 3×3 convs with 32 channels (stride 2, then 1), ReLU after each.

    An 84×84 input gives 32×35×35 = 39,200 features.

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Args:
        in_channels: channels of the frame stack (3·k).
        channels: channels of every convolution.
        chunk_size: samples convolved at a time (``None``: the whole batch).
        max_value: the white of float pixels; ``None`` for 1.0 (TorchRL's ``ToTensorImage()``),
            255 for float pixels on the 0–255 scale. uint8 pixels are always 0–255.

    Examples:
        >>> import torch
        >>> encoder = DrQv2Encoder(9)
        >>> pixels = torch.randint(0, 256, (2, 9, 84, 84), dtype=torch.uint8)
        >>> encoder(pixels).shape
        torch.Size([2, 39200])
        >>> torch.allclose(encoder(pixels.float() / 255), encoder(pixels))  # ToTensorImage's 0–1 floats
        True
        >>> encoder.max_value = 255  # float pixels on the 0–255 scale
        >>> torch.allclose(encoder(pixels.float()), encoder(pixels))
        True
    """

    def __init__(
        self, in_channels: int = 9, channels: int = 32, chunk_size: int | None = 64, *, max_value: float | None = None
    ) -> None:
        super().__init__(chunk_size, max_value)
        layers: list[nn.Module] = [nn.Conv2d(in_channels, channels, 3, stride=2), nn.ReLU()]
        for _ in range(3):
            layers += [nn.Conv2d(channels, channels, 3, stride=1), nn.ReLU()]
        self.convnet = nn.Sequential(*layers)
        self.apply(weight_init)


class SharedCNN(_PixelEncoder):
    """SVEA's (DMC-GB's) 11-layer shared CNN: 3×3 convs with 32 channels, the first with stride 2,
    ReLU between layers and none after the last. An 84×84 input gives 32×21×21 = 14,112 features.

    Paper: SVEA, https://arxiv.org/abs/2107.00644.

    Args:
        in_channels, channels, chunk_size, max_value: as in :class:`DrQv2Encoder`.
        num_layers: number of convolutions.
        centered: scale pixels to ``x / white − 0.5`` as DrQ-v2 and RL-ViGen do (default); ``False``
            for DMC-GB's ``x / 255`` (SCPL's original, ``make_loss("scpl")``).

    Examples:
        >>> import torch
        >>> SharedCNN(9)(torch.zeros(2, 9, 84, 84)).shape
        torch.Size([2, 14112])
    """

    def __init__(
        self,
        in_channels: int = 9,
        num_layers: int = 11,
        channels: int = 32,
        chunk_size: int | None = 64,
        *,
        max_value: float | None = None,
        centered: bool = True,
    ) -> None:
        super().__init__(chunk_size, max_value, centered)
        layers: list[nn.Module] = [nn.Conv2d(in_channels, channels, 3, stride=2)]
        for _ in range(num_layers - 1):
            layers += [nn.ReLU(), nn.Conv2d(channels, channels, 3, stride=1)]
        self.convnet = nn.Sequential(*layers)
        self.apply(weight_init)


class ProjectedEncoder(_PixelEncoder):
    """CURL's and SGQN's encoder in RL-ViGen: DrQ-v2's four convs, then Linear to ``out_dim`` (512),
    with no normalisation or activation after it.

    Paper: CURL, https://arxiv.org/abs/2004.04136; SGQN, https://arxiv.org/abs/2209.09203.

    Args:
        in_channels, chunk_size, max_value: as in :class:`DrQv2Encoder`.
        image_size: height (= width) of the input frames.
        out_dim: size of the projection.

    Examples:
        >>> import torch
        >>> ProjectedEncoder(9, image_size=84)(torch.zeros(2, 9, 84, 84)).shape
        torch.Size([2, 512])
    """

    def __init__(
        self,
        in_channels: int = 9,
        image_size: int = 84,
        out_dim: int = 512,
        chunk_size: int | None = 64,
        *,
        max_value: float | None = None,
    ) -> None:
        super().__init__(chunk_size, max_value)
        base = DrQv2Encoder(in_channels, chunk_size=chunk_size)
        self.convnet = base.convnet
        self.projection = nn.Linear(base.output_dim(in_channels, image_size, image_size), out_dim)
        self.apply(weight_init)

    def project(self, features: Tensor) -> Tensor:
        return self.projection(features)


def chunks_pay(x: Tensor, chunk_size: int | None) -> bool:
    """Whether convolving ``x`` in chunks of ``chunk_size`` samples is worth it: on the CPU, for batches above a chunk.

    Chunks keep a CPU's caches warm (about 2× at batch 256 on 2 cores); on a GPU they only add
    kernel launches (1.5–2.3× slower on an H100, ``benchmarks/losses.py``), so there the whole
    batch is convolved at once. The math is the same either way.

    Examples:
        >>> import torch
        >>> chunks_pay(torch.zeros(256, 9, 8, 8), 64), chunks_pay(torch.zeros(32, 9, 8, 8), 64)
        (True, False)
    """
    return bool(chunk_size) and x.shape[0] > chunk_size and x.device.type == "cpu"


def _as_float(pixels: Tensor) -> Tensor:
    """Floating pixels as they are (float32 or float64), integer pixels as float32."""
    return pixels if pixels.is_floating_point() else pixels.float()


def _trunk(repr_dim: int, feature_dim: int) -> nn.Sequential:
    return nn.Sequential(nn.Linear(repr_dim, feature_dim), nn.LayerNorm(feature_dim), nn.Tanh())


def _mlp(in_dim: int, hidden_dim: int, out_dim: int) -> nn.Sequential:
    return nn.Sequential(
        nn.Linear(in_dim, hidden_dim), nn.ReLU(inplace=True),
        nn.Linear(hidden_dim, hidden_dim), nn.ReLU(inplace=True),
        nn.Linear(hidden_dim, out_dim),
    )


class Actor(nn.Module):
    """DrQ-v2's deterministic actor head: ``trunk`` Linear → LayerNorm → Tanh, then an MLP (``action_head``) and ``tanh``.

    Returns the action mean μ in [-1, 1]; the exploration noise (a clipped normal with scheduled
    std) is added by the loss or the exploration module. (DrQ-v2 calls the MLP ``policy``; in vigen
    "policy" names the acting module only.)

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Examples:
        >>> import torch
        >>> Actor(39200, action_dim=6)(torch.zeros(2, 39200)).shape
        torch.Size([2, 6])
    """

    def __init__(self, repr_dim: int, action_dim: int, feature_dim: int = 50, hidden_dim: int = 1024) -> None:
        super().__init__()
        self.trunk = _trunk(repr_dim, feature_dim)
        self.action_head = _mlp(feature_dim, hidden_dim, action_dim)
        self.apply(weight_init)

    def forward(self, hidden: Tensor) -> Tensor:
        return torch.tanh(self.action_head(self.trunk(hidden)))


class GaussianActor(nn.Module):
    """A SAC actor: an MLP (``action_head``) on the encoder features, with an optional LayerNorm ``trunk`` in front.

    Returns the mean μ and log σ of a tanh-squashed Gaussian; log σ is ``tanh`` rescaled into
    ``log_std_bounds`` as in DrQ. ``hidden_depth`` hidden layers of ``hidden_dim`` units.
    Without ``feature_dim`` the MLP reads the features directly (RL-ViGen's DrQ actor); with it,
    a Linear → LayerNorm → Tanh trunk to ``feature_dim`` comes first (DMC-GB's and DMC-GB2's SAC
    actor, as in SADA).

    Paper: DrQ, https://arxiv.org/abs/2004.13649.

    Examples:
        >>> import torch
        >>> mean, log_std = GaussianActor(64, action_dim=6)(torch.zeros(2, 64))
        >>> mean.shape, bool(log_std.min() >= -10)
        (torch.Size([2, 6]), True)
    """

    def __init__(
        self,
        repr_dim: int,
        action_dim: int,
        hidden_dim: int = 1024,
        hidden_depth: int = 2,
        log_std_bounds: tuple[float, float] = (-10.0, 2.0),
        feature_dim: int | None = None,
    ) -> None:
        super().__init__()
        self.trunk = nn.Identity() if feature_dim is None else _trunk(repr_dim, feature_dim)
        in_dim = repr_dim if feature_dim is None else feature_dim
        layers: list[nn.Module] = []
        for index in range(hidden_depth):
            layers += [nn.Linear(in_dim if index == 0 else hidden_dim, hidden_dim), nn.ReLU(inplace=True)]
        layers.append(nn.Linear(hidden_dim if hidden_depth else in_dim, 2 * action_dim))
        self.action_head = nn.Sequential(*layers)
        self.log_std_bounds = log_std_bounds
        self.apply(weight_init)

    def forward(self, hidden: Tensor) -> tuple[Tensor, Tensor]:
        mean, log_std = self.action_head(self.trunk(hidden)).chunk(2, dim=-1)
        low, high = self.log_std_bounds
        return mean, low + 0.5 * (high - low) * (torch.tanh(log_std) + 1)


class Critic(nn.Module):
    """DrQ-v2's twin critic: one trunk (Linear → LayerNorm → Tanh), then two Q heads on [features, action].

    Paper: DrQ-v2, https://arxiv.org/abs/2107.09645.

    Examples:
        >>> import torch
        >>> q1, q2 = Critic(39200, action_dim=6)(torch.zeros(2, 39200), torch.zeros(2, 6))
        >>> q1.shape, q2.shape
        (torch.Size([2, 1]), torch.Size([2, 1]))
    """

    def __init__(self, repr_dim: int, action_dim: int, feature_dim: int = 50, hidden_dim: int = 1024) -> None:
        super().__init__()
        self.action_dim = action_dim
        self.trunk = _trunk(repr_dim, feature_dim)
        self.q1 = _mlp(feature_dim + action_dim, hidden_dim, 1)
        self.q2 = _mlp(feature_dim + action_dim, hidden_dim, 1)
        self.apply(weight_init)

    def embed(self, hidden: Tensor) -> Tensor:
        """The trunk's output, ``[..., feature_dim]``: the state embedding both Q heads read (SCPL's latent)."""
        return self.trunk(hidden)

    def forward(self, hidden: Tensor, action: Tensor) -> tuple[Tensor, Tensor]:
        features = torch.cat([self.embed(hidden), action], dim=-1)
        return self.q1(features), self.q2(features)


class AttributionDecoder(nn.Module):
    """SGQN's attribution predictor head: predicts per-pixel saliency logits from [embedding, action].

    Linear → 32×(S/4)×(S/4) (ReLU), then three 3×3 convs 32→128→64→``out_channels`` with two
    nearest ×2 upsamplings (21 → 42 → 84 for ``image_size`` S = 84) and ReLUs between: logits
    ``[B, out_channels, S, S]``.

    Paper: SGQN, https://arxiv.org/abs/2209.09203.

    Examples:
        >>> import torch
        >>> AttributionDecoder(action_dim=6)(torch.zeros(2, 512), torch.zeros(2, 6)).shape
        torch.Size([2, 9, 84, 84])
    """

    def __init__(self, action_dim: int, embedding_dim: int = 512, out_channels: int = 9, image_size: int = 84) -> None:
        super().__init__()
        if image_size % 4:
            raise ValueError(f"AttributionDecoder upsamples twice by 2: image_size must be a multiple of 4, got {image_size}.")
        self.base_size = image_size // 4
        self.proj = nn.Linear(embedding_dim + action_dim, 32 * self.base_size**2)
        self.conv1 = nn.Conv2d(32, 128, 3, padding=1)
        self.conv2 = nn.Conv2d(128, 64, 3, padding=1)
        self.conv3 = nn.Conv2d(64, out_channels, 3, padding=1)
        self.apply(weight_init)

    def forward(self, embedding: Tensor, action: Tensor) -> Tensor:
        x = F.relu(self.proj(torch.cat([embedding, action], dim=-1)))
        x = x.reshape(-1, 32, self.base_size, self.base_size)
        # ReLU before the nearest upsampling: the same values, on a quarter of the elements
        x = F.interpolate(F.relu(self.conv1(x)), scale_factor=2, mode="nearest")
        x = F.interpolate(F.relu(self.conv2(x)), scale_factor=2, mode="nearest")
        return self.conv3(x)


class CURLHead(nn.Module):
    """CURL's bilinear similarity ``z_a · W · z_posᵀ`` over a batch, with W initialised U[0, 1).

    :meth:`logits` returns the ``[B, B]`` scores minus each row's maximum (for a stable
    cross-entropy whose labels are ``arange(B)``: the diagonal holds the positives).

    Paper: CURL, https://arxiv.org/abs/2004.04136.

    Examples:
        >>> import torch
        >>> CURLHead(512).logits(torch.randn(4, 512), torch.randn(4, 512)).shape
        torch.Size([4, 4])
    """

    def __init__(self, dim: int = 512) -> None:
        super().__init__()
        self.W = nn.Parameter(torch.rand(dim, dim))

    def reset_parameters(self) -> None:
        nn.init.uniform_(self.W)

    def logits(self, anchor: Tensor, positive: Tensor) -> Tensor:
        scores = anchor @ self.W @ positive.T
        return scores - scores.max(dim=1, keepdim=True).values

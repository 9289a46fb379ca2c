"""Pure image kernels: apply already-sampled augmentation parameters to a batch of frame stacks.

Every kernel takes images as ``[N, C, H, W]`` and per-sample parameters with a leading ``N``.
:func:`shift`, :func:`crop`, :func:`center_crop` and :func:`mask_frequency` take any channel
count; the colour kernels (:func:`overlay`, :func:`random_conv`, :func:`color_jitter`) take
``C = 3·k`` (k stacked RGB frames, oldest first). Kernels draw no random numbers and never
modify their input, so a draw can be replayed and tested; the ``Random*`` transforms sample the
parameters and call these. ``max_value`` is the value of a white pixel (255 for uint8 frames).
Integer images come back rounded and clipped to their dtype; float images keep their dtype.
:func:`shift`, :func:`crop`, :func:`center_crop` and :func:`rotate` (and :func:`mask_frequency`
with a zero fill) do not depend on the pixel scale: they take float images on any range.
"""

from __future__ import annotations

import torch
import torch.nn.functional as F
from torch import Tensor

from vigen.devices import host_reads_are_free

FRAME_CHANNELS = 3


def split_frames(images: Tensor) -> Tensor:
    """``[N, 3k, H, W]`` -> ``[N, k, 3, H, W]`` (a view); raises if ``C`` is not a multiple of 3.

    Examples:
        >>> import torch
        >>> split_frames(torch.zeros(2, 9, 4, 4)).shape
        torch.Size([2, 3, 3, 4, 4])
    """
    n, c, h, w = images.shape
    if c % FRAME_CHANNELS:
        raise ValueError(f"colour kernels take stacks of RGB frames [N, 3·k, H, W], got {c} channels.")
    return images.reshape(n, c // FRAME_CHANNELS, FRAME_CHANNELS, h, w)


def _in_chunks(kernel, chunk: int, images: Tensor, *per_sample: Tensor | None, **kwargs) -> Tensor:
    """Run ``kernel`` on ``chunk`` samples at a time on the CPU: intermediates then stay in its cache
    (measured 2–3× faster than one pass at batch 256, see benchmarks/augmentations.py). Elsewhere
    (a GPU) the whole batch runs at once: chunks would only add kernel launches."""
    if images.shape[0] <= chunk or images.device.type != "cpu":
        return kernel(images, *per_sample, **kwargs)
    parts = [
        kernel(images[i : i + chunk], *[p if p is None else p[i : i + chunk] for p in per_sample], **kwargs)
        for i in range(0, images.shape[0], chunk)
    ]
    return torch.cat(parts)


def to_dtype(values: Tensor, like: Tensor, max_value: float) -> Tensor:
    """Clip float results to [0, max_value] and cast them to ``like``'s dtype (integers round halves up).

    Modifies ``values`` in place (callers pass their own intermediates).
    """
    if like.dtype.is_floating_point:
        return values.clamp_(0, max_value).to(like.dtype)
    return values.add_(0.5).clamp_(0, max_value).to(like.dtype)  # the cast truncates: floor(v + 0.5)


def to_input_range(values: Tensor, like: Tensor, max_value: float) -> Tensor:
    """:func:`to_dtype` for kernels that do not depend on the pixel scale: float results keep their input's range.

    Float results are clipped per sample to ``[min(0, min like[n]), max(max_value, max like[n])]``:
    exactly :func:`to_dtype`'s ``[0, max_value]`` for inputs on that scale, and the sample's own
    span for inputs on another (normalized observations, ``randn`` frames). Integer results are
    rounded and clipped as :func:`to_dtype` does. Modifies ``values`` in place.

    Examples:
        >>> import torch
        >>> on_scale, normalized = torch.tensor([[0.2, 0.9]]), torch.tensor([[-3.0, 2.0]])
        >>> to_input_range(torch.tensor([[-0.1, 1.2]]), on_scale, 1.0)
        tensor([[0., 1.]])
        >>> to_input_range(torch.tensor([[-3.5, 1.5]]), normalized, 1.0)
        tensor([[-3.0000,  1.5000]])
    """
    if not like.dtype.is_floating_point or like.numel() == 0:
        return to_dtype(values, like, max_value)
    flat = like.reshape(like.shape[0], -1)
    low, high = flat.amin(1), flat.amax(1)
    if host_reads_are_free(like) and bool(low.min() >= 0) and bool(high.max() <= max_value):
        return to_dtype(values, like, max_value)  # all on scale: a scalar clip, 3x faster on the CPU than per-sample bounds
    shape = (-1,) + (1,) * (values.ndim - 1)
    low = low.clamp(max=0).to(values.dtype).reshape(shape)
    high = high.clamp(min=max_value).to(values.dtype).reshape(shape)
    return values.clamp_(low, high).to(like.dtype)


def _gather_windows(images: Tensor, rows: Tensor, cols: Tensor) -> Tensor:
    """``out[n, c, i, j] = images[n, c, rows[n, i], cols[n, j]]`` as one gather (any dtype)."""
    n, c, _, w = images.shape
    index = (rows[:, :, None] * w + cols[:, None, :]).reshape(n, 1, -1)
    out = images.reshape(n, c, -1).gather(2, index.expand(n, c, index.shape[-1]))
    return out.reshape(n, c, rows.shape[1], cols.shape[1])


def shift(images: Tensor, offsets: Tensor, pad: int) -> Tensor:
    """Translate each sample by an integer offset inside its replicate-padded border (DrQ / DrQ-v2).

    ``out[n, :, i, j] = padded[n, :, i + dy_n, j + dx_n]`` where ``padded`` is the image
    replicate-padded by ``pad`` on each side and ``offsets[n] = (dy_n, dx_n)`` lies in
    ``{0, ..., 2·pad}²``; ``(pad, pad)`` is the identity. All channels (so all stacked frames) of a
    sample move together. The padding is never materialized: source indices are clamped to the
    image, which is what replicate padding means, and the result is one gather in the input dtype.

    Args:
        images: ``[N, C, H, W]``.
        offsets: ``[N, 2]`` integer ``(dy, dx)``.
        pad: border width in pixels.
    """
    _, _, h, w = images.shape
    offsets = offsets.long().to(images.device)
    rows = (torch.arange(h, device=images.device) + offsets[:, :1] - pad).clamp_(0, h - 1)
    cols = (torch.arange(w, device=images.device) + offsets[:, 1:] - pad).clamp_(0, w - 1)
    return _gather_windows(images, rows, cols)


def crop(images: Tensor, top: Tensor, left: Tensor, height: int, width: int) -> Tensor:
    """Cut a ``height × width`` window whose corner is ``(top[n], left[n])`` out of each sample (CURL).

    Args:
        images: ``[N, C, H, W]`` with ``H >= height`` and ``W >= width``.
        top, left: ``[N]`` integer corners, ``0 <= top <= H - height``, ``0 <= left <= W - width``.
    """
    rows = torch.arange(height, device=images.device) + top.long().to(images.device)[:, None]
    cols = torch.arange(width, device=images.device) + left.long().to(images.device)[:, None]
    return _gather_windows(images, rows, cols)


def center_crop(images: Tensor, height: int, width: int) -> Tensor:
    """The central ``height × width`` window (the evaluation-time counterpart of :func:`crop`)."""
    top, left = (images.shape[-2] - height) // 2, (images.shape[-1] - width) // 2
    return images[..., top : top + height, left : left + width].clone()


def overlay(images: Tensor, backgrounds: Tensor, alpha: float, max_value: float) -> Tensor:
    """Blend every frame of a sample with that sample's background: ``(1 - α)·x + α·I`` (SVEA).

    uint8 images blended with uint8 backgrounds use 7-bit fixed-point weights in int16 (exact for
    α = j/128, such as 0.5, and within one grey level otherwise), rounding halves up; other
    dtypes blend in float32.

    Args:
        images: ``[N, 3k, H, W]``.
        backgrounds: ``[N, 3, H, W]`` on the same value scale as ``images``; the same background
            is blended into each of a sample's k frames.
        alpha: weight of the background (DMC-GB and RL-ViGen: 0.5).
        max_value: white level, used to clip integer outputs.
    """
    return _in_chunks(_overlay, 64, images, backgrounds, alpha=alpha, max_value=max_value)


def _overlay(images: Tensor, backgrounds: Tensor, alpha: float, max_value: float) -> Tensor:
    if images.dtype == torch.uint8 and backgrounds.dtype == torch.uint8:
        weight = round(alpha * 128)
        mixed = split_frames(images).to(torch.int16) * (128 - weight) + (backgrounds[:, None].to(torch.int16) * weight + 64)
        return (mixed >> 7).to(torch.uint8).reshape(images.shape)
    mixed = torch.lerp(split_frames(images).float(), backgrounds[:, None].float(), alpha)
    return to_dtype(mixed.reshape(images.shape), images, max_value)


def random_conv(images: Tensor, kernels: Tensor, max_value: float) -> Tensor:
    """Filter each sample with its own 3×3 RGB→RGB kernel, then squash: ``sigmoid(k ∗ x/m)·m`` (DMC-GB).

    Each frame is replicate-padded by 1 and convolved with the sample's kernel, as DMC-GB's
    ``random_conv`` does, but for the whole batch in one grouped convolution.

    Args:
        images: ``[N, 3k, H, W]``.
        kernels: ``[N, 3, 3, 3, 3]`` as ``(sample, out RGB, in RGB, kh, kw)``.
        max_value: white level ``m``.
    """
    return _in_chunks(_random_conv, 8, images, kernels, max_value=max_value)


def _random_conv(images: Tensor, kernels: Tensor, max_value: float) -> Tensor:
    n, c, h, w = images.shape
    frames = split_frames(images).shape[1]
    x = images.float().div(max_value).reshape(1, n * c, h, w)
    x = F.pad(x, (1, 1, 1, 1), mode="replicate").contiguous(memory_format=torch.channels_last)
    weight = kernels.float().repeat_interleave(frames, dim=0).reshape(n * c, FRAME_CHANNELS, 3, 3)
    out = torch.sigmoid(F.conv2d(x, weight, groups=n * frames)).mul_(max_value)
    return to_dtype(out.reshape(n, c, h, w), images, max_value)


def frequency_ring(height: int, width: int, low: Tensor, high: Tensor) -> Tensor:
    """Boolean ``[N, H, W//2 + 1]`` masks of the rfft2 coefficients in the square ring ``low <= max(|fy|, |fx|) < high``.

    Frequencies are in cycles per pixel, as ``torch.fft.fftfreq`` gives them (|f| <= 0.5).
    """
    fy = torch.fft.fftfreq(height, device=low.device).abs()
    fx = torch.fft.rfftfreq(width, device=low.device)
    radius = torch.maximum(fy[:, None], fx[None, :])
    return (radius >= low[:, None, None]) & (radius < high[:, None, None])


def mask_frequency(images: Tensor, low: Tensor, high: Tensor, noise: Tensor | None = None) -> Tensor:
    """Remove a square ring of spatial frequencies from every channel of each sample (SRM).

    Computes ``F⁻¹(M·F(x) + (1 - M)·F(z))`` per channel, where ``M`` is 0 inside the sample's
    ring ``low <= max(|fy|, |fx|) < high`` (see :func:`frequency_ring`) and 1 elsewhere. With
    ``noise=None`` the ring is zeroed (RL-ViGen's ``random_mask_freq_v2``); with a noise image
    ``z`` the ring takes ``z``'s coefficients (the SRM paper). ``low == high`` leaves the sample
    unchanged. Returns float32 values that may leave the input range (callers clip).

    Args:
        images: ``[N, C, H, W]``.
        low, high: ``[N]`` ring edges in cycles per pixel.
        noise: optional ``[N, C, H, W]`` replacement image.
    """
    return _in_chunks(_mask_frequency, 16, images, low, high, noise)


def _mask_frequency(images: Tensor, low: Tensor, high: Tensor, noise: Tensor | None) -> Tensor:
    h, w = images.shape[-2:]
    if host_reads_are_free(images) and bool((high <= low).all()):  # no ring: skip the FFTs
        return images.to(torch.float32, copy=True)
    spectrum = torch.fft.rfft2(images.float())
    ring = frequency_ring(h, w, low, high)[:, None]
    if noise is None:
        spectrum.masked_fill_(ring, 0)
    else:
        spectrum = torch.where(ring, torch.fft.rfft2(noise.float()), spectrum)
    return torch.fft.irfft2(spectrum, s=(h, w))


def rgb_to_grayscale(frames: Tensor) -> Tensor:
    """ITU-R 601 luma of ``[..., 3, H, W]`` RGB frames, keeping a channel dim of 1."""
    r, g, b = frames.unbind(-3)
    return (0.299 * r + 0.587 * g + 0.114 * b).unsqueeze(-3)


def rgb_to_hsv(frames: Tensor) -> Tensor:
    """HSV (hue in turns, saturation, value) of ``[..., 3, H, W]`` RGB frames on [0, 1]."""
    r, g, b = frames.unbind(-3)
    value, _ = frames.max(-3)
    chroma = value - frames.min(-3).values
    saturation = torch.where(value > 0, chroma / value.clamp_min(1e-12), torch.zeros_like(value))
    safe = torch.where(chroma > 0, chroma, torch.ones_like(chroma))
    hue = torch.where(
        value == r, ((g - b) / safe) % 6, torch.where(value == g, (b - r) / safe + 2, (r - g) / safe + 4)
    )
    hue = torch.where(chroma > 0, hue / 6, torch.zeros_like(hue))
    return torch.stack((hue, saturation, value), -3)


def hsv_to_rgb(frames: Tensor) -> Tensor:
    """The inverse of :func:`rgb_to_hsv`."""
    hue, saturation, value = frames.unbind(-3)
    sector = hue * 6
    k = torch.stack(((5 + sector) % 6, (3 + sector) % 6, (1 + sector) % 6), -3)
    weight = (torch.minimum(k, 4 - k)).clamp(0, 1)
    return value.unsqueeze(-3) - (value * saturation).unsqueeze(-3) * weight


def color_jitter(
    images: Tensor, brightness: Tensor, contrast: Tensor, saturation: Tensor, hue: Tensor, max_value: float
) -> Tensor:
    """Per-sample photometric changes, in this order: brightness, contrast, saturation, hue.

    With ``x`` in [0, 1] (``images / max_value``) and each step clipped to [0, 1]:
    brightness ``x·b``; contrast ``m + c·(x - m)`` with ``m`` the frame's mean luma; saturation
    ``g + s·(x - g)`` with ``g`` the pixel's luma; hue rotates the HSV hue by ``h`` turns. Factors
    of 1 (and a hue of 0) leave that step out. Every frame of a sample gets the same factors.

    Args:
        images: ``[N, 3k, H, W]``.
        brightness, contrast, saturation: ``[N]`` non-negative factors.
        hue: ``[N]`` shift in turns, in [-0.5, 0.5].
        max_value: white level.
    """
    def per_sample(factor: Tensor) -> Tensor:
        return factor.float().reshape(-1, 1, 1, 1, 1)

    x = split_frames(images).float() / max_value
    x = (x * per_sample(brightness)).clamp_(0, 1)
    mean = rgb_to_grayscale(x).mean(dim=(-3, -2, -1), keepdim=True)
    x = torch.lerp(mean, x, per_sample(contrast)).clamp_(0, 1)
    x = torch.lerp(rgb_to_grayscale(x), x, per_sample(saturation)).clamp_(0, 1)
    hsv = rgb_to_hsv(x)
    hsv = torch.cat(((hsv[..., :1, :, :] + per_sample(hue)) % 1.0, hsv[..., 1:, :, :]), dim=-3)
    x = hsv_to_rgb(hsv).clamp_(0, 1)
    return to_dtype(x.mul_(max_value).reshape(images.shape), images, max_value)


def rotate(images: Tensor, degrees: Tensor, max_value: float) -> Tensor:
    """Rotate each sample about its centre by ``degrees[n]`` (counter-clockwise), bilinear, edge fill.

    ``out[n]`` is ``images[n]`` turned counter-clockwise by ``degrees[n]`` as the image is shown
    (rows down), as ``torchvision``'s ``rotate`` turns it: a quarter turn equals
    ``torch.rot90(images, 1, dims=(-2, -1))``. Pixels are sampled bilinearly at their centres
    (``align_corners=False``); where the turned image leaves the frame, the nearest edge pixel
    fills it (DMC-GB2 edge-pads before rotating for the same reason). All channels (so all
    stacked frames) of a sample turn together. Each output pixel is a weighted mean of input
    pixels, so no pixel scale is assumed: float results are clipped to the input's range
    (:func:`to_input_range`), uint8 results rounded.

    Examples:
        >>> import torch
        >>> x = torch.arange(16.0).reshape(1, 1, 4, 4)
        >>> torch.allclose(rotate(x, torch.tensor([90.0]), 255.0), torch.rot90(x, 1, dims=(-2, -1)), atol=1e-4)
        True
    """
    n, _, h, w = images.shape
    values = images if images.is_floating_point() else images.float()
    radians = torch.deg2rad(degrees.to(values.dtype))
    cos, sin = radians.cos(), radians.sin()
    # output (x, y) in normalised coordinates -> input: rotate back by the angle, in pixel units (x right, y down)
    theta = torch.zeros(n, 2, 3, dtype=values.dtype, device=values.device)
    theta[:, 0, 0], theta[:, 0, 1] = cos, -sin * (h / w)
    theta[:, 1, 0], theta[:, 1, 1] = sin * (w / h), cos
    grid = F.affine_grid(theta, [n, 1, h, w], align_corners=False)
    out = F.grid_sample(values, grid, mode="bilinear", padding_mode="border", align_corners=False)
    return to_input_range(out, images, max_value)

"""Pixel corruptions at five severities (ImageNet-C style) for any pixel env, including ones vigen does not build."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch
import torch.nn.functional as F
from tensordict.utils import NestedKey
from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params, check_parameter

# Severity 1..5 -> parameter, after ImageNet-C (Hendrycks & Dietterich, 2019). Blur sigmas are
# ImageNet-C's (for 224 px images) scaled by 84/224 so that they blur an 84 px frame alike.
SEVERITIES: dict[str, tuple[float, ...]] = {
    "gaussian_noise": (0.08, 0.12, 0.18, 0.26, 0.38),  # noise std, image in [0, 1]
    "gaussian_blur": tuple(s * 84 / 224 for s in (1, 2, 3, 4, 6)),  # sigma in pixels
    "jpeg_compression": (25, 18, 15, 10, 7),  # JPEG quality
    "contrast": (0.4, 0.3, 0.2, 0.1, 0.05),  # contrast factor
    "brightness": (0.1, 0.2, 0.3, 0.4, 0.5),  # added to HSV value
}
# the corruptions that read a pixel's R, G and B together (JPEG's YCbCr, a frame's mean, HSV)
RGB_CORRUPTIONS = frozenset({"jpeg_compression", "contrast", "brightness"})


class PixelCorruption(ImageAugmentation):
    """A common image corruption at severity 1 (mild) to 5 (strong), per frame.

    ======================  =============================================================
    corruption              what it does (parameter per severity 1..5)
    ======================  =============================================================
    ``gaussian_noise``      ``x + N(0, σ²)`` per pixel, σ = 0.08, 0.12, 0.18, 0.26, 0.38
    ``gaussian_blur``       Gaussian blur, σ = 0.375, 0.75, 1.125, 1.5, 2.25 px
    ``jpeg_compression``    JPEG encode/decode at quality 25, 18, 15, 10, 7
    ``contrast``            ``m + c·(x − m)`` (m: the frame's mean), c = 0.4 … 0.05
    ``brightness``          HSV value + b, b = 0.1 … 0.5
    ======================  =============================================================

    Parameters follow ImageNet-C (values for images in [0, 1]; blur scaled to 84 px frames).
    Only ``gaussian_noise`` is random (fresh noise per sample and step). Noise and blur act on
    each channel alone and take any channel count; JPEG, contrast and brightness work on RGB
    frames and need ``C = 3·k`` (see ``RGB_CORRUPTIONS``). Pixels follow the contract of
    :class:`~vigen.transforms.ImageAugmentation`. Every corruption works on ``x / max_value`` in
    [0, 1] (the strengths above are on that scale), so float images must be on ``[0, max_value]``
    (``needs_scale``; float images on 0–255 need ``max_value=255``).

    Paper: ImageNet-C, https://arxiv.org/abs/1903.12261.

    Args:
        corruption: one of the names above.
        severity: an int from 1 to 5.
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import PixelCorruption
        >>> blur = PixelCorruption("gaussian_blur", severity=3)
        >>> blur(pixels=torch.zeros(9, 84, 84, dtype=torch.uint8)).shape
        torch.Size([9, 84, 84])
    """

    def __init__(
        self,
        corruption: str = "gaussian_noise",
        severity: int = 3,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        *,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        name = type(self).__name__
        if not isinstance(corruption, str):
            raise TypeError(f"{name}: corruption must be a name from {sorted(SEVERITIES)}, got "
                            f"{type(corruption).__name__} {corruption!r}; pass severity= by keyword.")
        if corruption not in SEVERITIES:
            raise ValueError(f"{name}: unknown corruption {corruption!r}; choose from {sorted(SEVERITIES)}.")
        check_parameter(name, "severity", severity, low=1, high=5, integer=True)
        super().__init__(in_keys, out_keys, max_value=max_value, seed=seed)
        self.corruption, self.severity = corruption, int(severity)

    needs_scale = True  # severities are set on x / max_value in [0, 1], results clipped there

    @property
    def needs_rgb(self) -> bool:  # type: ignore[override]
        """Whether this corruption reads RGB frames (``C = 3·k``); noise and blur take any channels."""
        return self.corruption in RGB_CORRUPTIONS

    @property
    def strength(self) -> float:
        """The corruption's parameter at this severity (see ``SEVERITIES``)."""
        return SEVERITIES[self.corruption][self.severity - 1]

    def make_params(self, images: Tensor) -> Params:
        if self.corruption == "gaussian_noise":
            return {"noise": self.randn(*images.shape, like=images) * self.strength}
        return {}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        white = self.white(images)
        if self.corruption == "jpeg_compression":
            return _jpeg(images, int(self.strength), white)
        x = images.float() / white
        if self.corruption == "gaussian_noise":
            x = x + params["noise"]
        elif self.corruption == "gaussian_blur":
            x = _gaussian_blur(x, self.strength)
        elif self.corruption == "contrast":
            frames = functional.split_frames(x)
            mean = frames.mean(dim=(-3, -2, -1), keepdim=True)
            x = torch.lerp(mean, frames, self.strength).reshape(x.shape)
        elif self.corruption == "brightness":
            hsv = functional.rgb_to_hsv(functional.split_frames(x))
            hsv = torch.cat((hsv[..., :2, :, :], (hsv[..., 2:, :, :] + self.strength).clamp_(0, 1)), dim=-3)
            x = functional.hsv_to_rgb(hsv).reshape(x.shape)
        return functional.to_dtype(x.mul_(white), images, white)

    def extra_repr(self) -> str:
        return f"{self.corruption!r}, severity={self.severity}"


def _gaussian_blur(x: Tensor, sigma: float) -> Tensor:
    radius = max(1, int(np.ceil(3 * sigma)))
    offsets = torch.arange(-radius, radius + 1, dtype=torch.float32, device=x.device)
    kernel = torch.exp(-(offsets**2) / (2 * sigma**2))
    kernel = kernel / kernel.sum()
    n, c, h, w = x.shape
    flat = x.reshape(n * c, 1, h, w)
    flat = F.conv2d(F.pad(flat, (radius, radius, 0, 0), mode="replicate"), kernel.view(1, 1, 1, -1))
    flat = F.conv2d(F.pad(flat, (0, 0, radius, radius), mode="replicate"), kernel.view(1, 1, -1, 1))
    return flat.reshape(n, c, h, w)


def _jpeg(images: Tensor, quality: int, white: float) -> Tensor:
    import cv2

    frames = functional.split_frames(images).float().div(white).mul(255).round().clamp(0, 255).to(torch.uint8)
    out = torch.empty_like(frames)
    for index in np.ndindex(*frames.shape[:2]):
        rgb = frames[index].permute(1, 2, 0).cpu().numpy()
        ok, encoded = cv2.imencode(".jpg", np.ascontiguousarray(rgb[..., ::-1]), [cv2.IMWRITE_JPEG_QUALITY, quality])
        if not ok:
            raise RuntimeError("OpenCV failed to JPEG-encode a frame.")
        out[index] = torch.from_numpy(cv2.imdecode(encoded, cv2.IMREAD_COLOR)[..., ::-1].copy()).permute(2, 0, 1)
    result = out.reshape(images.shape).to(images.device)
    return result if images.dtype == torch.uint8 else result.float().div(255).mul(white).to(images.dtype)

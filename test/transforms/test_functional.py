"""The kernels against the papers' definitions and the original implementations."""

from __future__ import annotations

import colorsys

import pytest
import torch
import torch.nn.functional as F

from vigen.transforms.augmentations import functional
from vigen.transforms import RandomFrequencyMask, RandomOverlay, RandomShift, ImageBank


def uint8_images(n: int, c: int = 9, h: int = 20, w: int = 20, seed: int = 0) -> torch.Tensor:
    return torch.randint(0, 256, (n, c, h, w), dtype=torch.uint8, generator=torch.Generator().manual_seed(seed))


def drqv2_random_shift(x: torch.Tensor, shifts: torch.Tensor, pad: int) -> torch.Tensor:
    """DrQ-v2's ``RandomShiftsAug.forward`` (drqv2.py) with its random draw replaced by ``shifts`` = (dx, dy)."""
    n, _, h, w = x.size()
    x = F.pad(x, (pad,) * 4, "replicate")
    eps = 1.0 / (h + 2 * pad)
    arange = torch.linspace(-1.0 + eps, 1.0 - eps, h + 2 * pad)[:h]
    arange = arange.unsqueeze(0).repeat(h, 1).unsqueeze(2)
    base_grid = torch.cat([arange, arange.transpose(1, 0)], dim=2).unsqueeze(0).repeat(n, 1, 1, 1)
    grid = base_grid + shifts.float().reshape(n, 1, 1, 2) * 2.0 / (h + 2 * pad)
    return F.grid_sample(x, grid, padding_mode="zeros", align_corners=False)


class TestShift:
    def test_exact_translation_of_the_padded_image(self):
        x = uint8_images(6)
        offsets = torch.tensor([[0, 0], [8, 8], [4, 4], [0, 8], [3, 5], [7, 1]])
        padded = F.pad(x.float(), (4, 4, 4, 4), mode="replicate")
        out = functional.shift(x, offsets, pad=4)
        for n, (dy, dx) in enumerate(offsets.tolist()):
            assert torch.equal(out[n].float(), padded[n, :, dy : dy + 20, dx : dx + 20])
        assert torch.equal(out[2], x[2]), "offset (pad, pad) is the identity"

    def test_matches_drqv2_grid_sample(self):
        x = uint8_images(5).float()
        offsets = torch.randint(0, 9, (5, 2), generator=torch.Generator().manual_seed(1))
        reference = drqv2_random_shift(x, offsets.flip(-1), pad=4)  # grid_sample takes (x, y)
        assert torch.allclose(functional.shift(x, offsets, pad=4), reference, atol=1e-3)

    def test_offsets_cover_the_range_uniformly(self):
        offsets = RandomShift(pad=4, seed=0).make_params(torch.zeros(9000, 3, 8, 8))["offsets"]
        counts = torch.bincount(offsets.flatten(), minlength=9).float()
        assert counts.shape == (9,) and (counts / counts.mean() - 1).abs().max() < 0.1


class TestCrop:
    def test_crop_is_slicing(self):
        x = uint8_images(3, h=30, w=25)
        top, left = torch.tensor([0, 5, 9]), torch.tensor([4, 0, 6])
        out = functional.crop(x, top, left, 21, 19)
        for n in range(3):
            assert torch.equal(out[n], x[n, :, top[n] : top[n] + 21, left[n] : left[n] + 19])

    def test_center_crop(self):
        x = uint8_images(2, h=100, w=100)
        assert torch.equal(functional.center_crop(x, 84, 84), x[..., 8:92, 8:92])


class TestOverlay:
    @pytest.mark.parametrize("alpha, tolerance", [(0.5, 0.5), (0.25, 0.5), (0.3, 1.5)])
    def test_uint8_is_the_stated_blend(self, alpha, tolerance):
        """Exact up to rounding for alpha = j/128 (fixed-point weights), within a grey level otherwise."""
        x = uint8_images(40)
        backgrounds = uint8_images(40, c=3, seed=1)
        out = functional.overlay(x, backgrounds, alpha, 255)
        expected = (1 - alpha) * x.float() + alpha * backgrounds.float().repeat(1, 3, 1, 1)
        assert (out.float() - expected).abs().max() <= tolerance

    def test_float_is_the_stated_blend(self):
        x, backgrounds = torch.rand(40, 9, 8, 8), torch.rand(40, 3, 8, 8)
        expected = 0.7 * x + 0.3 * backgrounds.repeat(1, 3, 1, 1)
        assert torch.allclose(functional.overlay(x, backgrounds, 0.3, 1.0), expected, atol=1e-6)

    def test_transform_uses_its_bank_image_for_every_frame(self):
        bank = ImageBank(uint8_images(5, c=3, seed=2), name="test")
        overlay = RandomOverlay(alpha=0.5, images=bank, seed=0)
        x = torch.rand(3, 9, 20, 20)
        params = overlay.make_params(x)
        background = bank.images[params["index"]].float() / 255
        expected = 0.5 * x + 0.5 * background.repeat(1, 3, 1, 1)
        assert torch.allclose(overlay.apply(x, params), expected, atol=1e-6)


class TestRandomConv:
    def test_matches_dmcgb_per_sample_loop(self):
        x = uint8_images(20).float()  # more than one chunk
        kernels = torch.randn(20, 3, 3, 3, 3, generator=torch.Generator().manual_seed(0))
        expected = []
        for i in range(20):  # DMC-GB's augmentations.random_conv, with its kernel draws given
            frames = x[i : i + 1].reshape(-1, 3, 20, 20) / 255.0
            frames = F.pad(frames, pad=[1] * 4, mode="replicate")
            expected.append(torch.sigmoid(F.conv2d(frames, kernels[i])) * 255.0)
        expected = torch.cat(expected).reshape(20, 9, 20, 20)
        assert torch.allclose(functional.random_conv(x, kernels, 255.0), expected, atol=1e-3)


def rlvigen_random_mask_freq_v2(x: torch.Tensor, low: float, high: float) -> torch.Tensor:
    """RL-ViGen's ``utils.random_mask_freq_v2`` with its draws given: 3-D FFT over (RGB, H, W), ring zeroed."""
    n, c, h, w = x.shape
    x = x.reshape(n, c // 3, 3, h, w)
    spectrum = torch.fft.fftn(x, dim=(2, 3, 4))
    fy = torch.fft.fftfreq(h).abs()[:, None].expand(h, w)
    fx = torch.fft.fftfreq(w).abs()[None, :].expand(h, w)
    outer = (fy < high) & (fx < high)
    inner = (fy < low) & (fx < low)
    mask = ~(outer & ~inner)
    return torch.fft.ifftn(spectrum * mask, dim=(2, 3, 4)).real.reshape(n, c, h, w)


class TestFrequencyMask:
    def test_matches_rlvigen_v2(self):
        x = uint8_images(20, h=84, w=84).float()  # more than one chunk
        low, high = torch.full((20,), 0.12), torch.full((20,), 0.16)
        expected = rlvigen_random_mask_freq_v2(x, 0.12, 0.16)
        assert torch.allclose(functional.mask_frequency(x, low, high), expected, atol=1e-2)

    def test_band_is_empty_and_the_rest_is_kept(self):
        x = uint8_images(4, h=84, w=84).float()
        low, high = torch.tensor([0.0, 0.1, 0.3, 0.2]), torch.tensor([0.05, 0.14, 0.34, 0.2])
        out = functional.mask_frequency(x, low, high)
        ring = functional.frequency_ring(84, 84, low, high)[:, None]
        before, after = torch.fft.rfft2(x), torch.fft.rfft2(out)
        scale = before.abs().max()
        assert ring[:3].any(-1).any(-1).all() and not ring[3].any(), "three rings are non-empty, one is empty"
        assert (after.abs() * ring).max() < 1e-4 * scale, "no energy may remain in the masked band"
        assert ((after - before).abs() * ~ring).max() < 1e-4 * scale, "every other coefficient is kept"
        assert torch.allclose(out[3], x[3], atol=1e-3)

    def test_noise_fill_takes_the_noise_spectrum_in_the_band(self):
        x, noise = uint8_images(2, h=32, w=32).float(), uint8_images(2, h=32, w=32, seed=5).float()
        low, high = torch.tensor([0.1, 0.2]), torch.tensor([0.2, 0.3])
        out = functional.mask_frequency(x, low, high, noise)
        ring = functional.frequency_ring(32, 32, low, high)[:, None]
        expected = torch.where(ring, torch.fft.rfft2(noise), torch.fft.rfft2(x))
        assert torch.allclose(torch.fft.rfft2(out), expected, atol=1e-2)

    def test_rlvigen_draws(self):
        srm = RandomFrequencyMask(seed=0)
        draws = [srm.make_params(torch.zeros(4, 3, 8, 8)) for _ in range(2000)]
        low = torch.stack([d["low"] for d in draws])
        width = torch.stack([d["high"] - d["low"] for d in draws])
        assert (low == low[:, :1]).all() and (width == width[:, :1]).all(), "one ring per batch by default"
        assert torch.allclose(low * 100, (low * 100).round()) and low.max() <= 0.5
        assert width.max() <= 0.05 + 1e-6
        applied = (width[:, 0] > 0).float().mean()
        assert 0.4 < applied < 0.5, "p = 0.5, and a width that rounds to 0 removes nothing"


class TestColorJitter:
    def factors(self, n: int, brightness=1.0, contrast=1.0, saturation=1.0, hue=0.0):
        return [torch.full((n,), v) for v in (brightness, contrast, saturation, hue)]

    def test_identity_factors_keep_the_image(self):
        x = uint8_images(3)
        assert torch.equal(functional.color_jitter(x, *self.factors(3), 255.0), x)

    def test_brightness_scales(self):
        x = torch.rand(2, 6, 8, 8) * 0.5
        out = functional.color_jitter(x, *self.factors(2, brightness=1.5), 1.0)
        assert torch.allclose(out, x * 1.5, atol=1e-5)

    def test_zero_saturation_is_grayscale(self):
        x = torch.rand(2, 3, 8, 8)
        out = functional.color_jitter(x, *self.factors(2, saturation=0.0), 1.0)
        gray = 0.299 * x[:, 0] + 0.587 * x[:, 1] + 0.114 * x[:, 2]
        assert torch.allclose(out, gray[:, None].expand(2, 3, 8, 8), atol=1e-5)

    def test_zero_contrast_is_the_mean_luma(self):
        x = torch.rand(1, 3, 8, 8)
        out = functional.color_jitter(x, *self.factors(1, contrast=0.0), 1.0)
        mean = (0.299 * x[:, 0] + 0.587 * x[:, 1] + 0.114 * x[:, 2]).mean()
        assert torch.allclose(out, torch.full_like(x, mean.item()), atol=1e-5)

    @pytest.mark.parametrize("shift", [0.1, -0.25, 0.5])
    def test_hue_matches_colorsys(self, shift):
        x = torch.rand(1, 3, 4, 4, generator=torch.Generator().manual_seed(0))
        out = functional.color_jitter(x, *self.factors(1, hue=shift), 1.0)
        for i in range(4):
            for j in range(4):
                h, s, v = colorsys.rgb_to_hsv(*x[0, :, i, j].tolist())
                expected = colorsys.hsv_to_rgb((h + shift) % 1.0, s, v)
                assert torch.allclose(out[0, :, i, j], torch.tensor(expected), atol=1e-5)

    def test_frames_of_a_sample_share_factors(self):
        frame = torch.rand(1, 3, 8, 8)
        x = frame.repeat(1, 3, 1, 1)
        out = functional.color_jitter(x, *[torch.tensor([v]) for v in (1.2, 0.7, 1.3, 0.2)], 1.0)
        assert torch.allclose(out[:, 0:3], out[:, 3:6]) and torch.allclose(out[:, 3:6], out[:, 6:9])


class TestCorruptions:
    def test_severity_orders_the_damage(self):
        from vigen.transforms import PixelCorruption

        x = uint8_images(4, h=32, w=32)
        for corruption in ("gaussian_noise", "gaussian_blur", "jpeg_compression", "contrast", "brightness"):
            damage = [
                (PixelCorruption(corruption, severity, seed=0)(pixels=x).float() - x.float()).abs().mean().item()
                for severity in (1, 3, 5)
            ]
            assert 0 < damage[0] < damage[1] < damage[2], corruption

    def test_contrast_and_blur_definitions(self):
        from vigen.transforms import PixelCorruption

        x = torch.rand(2, 3, 16, 16)
        out = PixelCorruption("contrast", 1)(pixels=x)
        mean = x.mean(dim=(1, 2, 3), keepdim=True)
        assert torch.allclose(out, mean + 0.4 * (x - mean), atol=1e-6)
        flat = torch.full((1, 3, 16, 16), 0.3)
        assert torch.allclose(PixelCorruption("gaussian_blur", 5)(pixels=flat), flat, atol=1e-6)

"""Throughput of vigen's augmentations against the original implementations, in the same run.

Input: uint8 frame stacks ``[B, 9, 84, 84]`` (DrQ-v2's observation), B = 256 and 64. Each vigen
transform (sampling + application, output uint8) is timed against a reference written the way the
original code does it:

* RandomShift vs DrQ-v2's ``RandomShiftsAug`` (float conversion, replicate pad, ``grid_sample``);
* RandomConv vs DMC-GB's ``random_conv`` (a Python loop over samples, one conv each);
* RandomFrequencyMask vs RL-ViGen's ``random_mask_freq_v2`` (3-D FFT over the whole stack; both
  forced to mask, p = 1, so that the timed work is the masking);
* RandomOverlay vs the float blend ``((1 - α)·x/255 + α·I)·255`` of DMC-GB / RL-ViGen (images
  already in memory: their data loader is not timed);
* RandomCrop (100×100 → 84×84) vs CURL's ``random_crop`` (NumPy ``view_as_windows`` + fancy indexing;
  both are a strided copy, and NumPy's row copies beat vigen's device-agnostic gather here);
* RandomColorJitter has no reference implementation in these codebases; it is reported alone.

"bandwidth" is the bytes an augmentation must at least move (read the input, write the output)
divided by its time, as a fraction of this machine's copy bandwidth measured in the same run
(``dst.copy_(src)`` on a 256 MB buffer).

Each figure is the median of ``--repeats`` calls, vigen and reference timed in alternation.

Reproduce (about two minutes on 2 CPU cores; run nothing else meanwhile):

    python benchmarks/augmentations.py
    python benchmarks/augmentations.py --batch 256 --repeats 20
"""

from __future__ import annotations

import argparse
import statistics
import time
from typing import Callable

import numpy as np
import torch
import torch.nn.functional as F
from numpy.lib.stride_tricks import sliding_window_view

from vigen.transforms import (
    ImageBank,
    RandomColorJitter,
    RandomConv,
    RandomCrop,
    RandomFrequencyMask,
    RandomOverlay,
    RandomShift,
)


# -- references, written as the original code does it --------------------------------------------
def drqv2_shift(x: torch.Tensor, pad: int = 4) -> torch.Tensor:
    x = x.float()
    n, _, h, w = x.size()
    x = F.pad(x, (pad,) * 4, "replicate")
    eps = 1.0 / (h + 2 * pad)
    arange = torch.linspace(-1.0 + eps, 1.0 - eps, h + 2 * pad, device=x.device, dtype=x.dtype)[:h]
    arange = arange.unsqueeze(0).repeat(h, 1).unsqueeze(2)
    base_grid = torch.cat([arange, arange.transpose(1, 0)], dim=2).unsqueeze(0).repeat(n, 1, 1, 1)
    shift = torch.randint(0, 2 * pad + 1, size=(n, 1, 1, 2), device=x.device, dtype=x.dtype)
    shift *= 2.0 / (h + 2 * pad)
    return F.grid_sample(x, base_grid + shift, padding_mode="zeros", align_corners=False)


def dmcgb_random_conv(x: torch.Tensor) -> torch.Tensor:
    x = x.float()
    n, c, h, w = x.shape
    for i in range(n):
        weights = torch.randn(3, 3, 3, 3, device=x.device)
        temp_x = x[i : i + 1].reshape(-1, 3, h, w) / 255.0
        temp_x = F.pad(temp_x, pad=[1] * 4, mode="replicate")
        out = torch.sigmoid(F.conv2d(temp_x, weights)) * 255.0
        total_out = out if i == 0 else torch.cat([total_out, out], axis=0)
    return total_out.reshape(n, c, h, w)


def rlvigen_random_mask_freq_v2(x: torch.Tensor) -> torch.Tensor:
    x = x.float()
    n, c, h, w = x.shape
    x = x.reshape(n, c // 3, 3, h, w)
    low = round(float(np.random.uniform(0, 0.5)), 2)
    high = low + round(float(np.random.uniform(0, 0.05)), 2)
    spectrum = torch.fft.fftn(x, dim=(2, 3, 4))
    fy = torch.fft.fftfreq(h, device=x.device).abs()[:, None].expand(h, w)
    fx = torch.fft.fftfreq(w, device=x.device).abs()[None, :].expand(h, w)
    ring = ((fy < high) & (fx < high)) & ~((fy < low) & (fx < low))
    return torch.fft.ifftn(spectrum * ~ring, dim=(2, 3, 4)).real.reshape(n, c, h, w)


def float_overlay(x: torch.Tensor, images: torch.Tensor, alpha: float = 0.5) -> torch.Tensor:
    index = torch.randint(0, len(images), (x.shape[0],), device=images.device)
    overlay = images[index].float().div(255).repeat(1, x.shape[1] // 3, 1, 1)
    return ((1 - alpha) * (x.float() / 255) + alpha * overlay) * 255


def curl_random_crop(imgs: np.ndarray, output_size: int = 84) -> np.ndarray:
    n, img_size = imgs.shape[0], imgs.shape[-1]
    crop_max = img_size - output_size
    imgs = np.transpose(imgs, (0, 2, 3, 1))
    w1 = np.random.randint(0, crop_max, n)
    h1 = np.random.randint(0, crop_max, n)
    windows = sliding_window_view(imgs, (1, output_size, output_size, 1))[..., 0, :, :, 0]
    return windows[np.arange(n), w1, h1]


# -- timing --------------------------------------------------------------------------------------
def seconds(*fns: Callable[[], object], repeats: int) -> list[float]:
    """Median seconds per call of each function, timed in alternation so that machine noise hits all alike."""
    for fn in fns:
        fn()
    times: list[list[float]] = [[] for _ in fns]
    for _ in range(repeats):
        for fn, samples in zip(fns, times):
            start = time.perf_counter()
            fn()
            samples.append(time.perf_counter() - start)
    return [statistics.median(samples) for samples in times]


def copy_bandwidth(repeats: int) -> float:
    """Bytes per second of ``dst.copy_(src)`` (a read and a write per byte) on a 256 MB buffer."""
    src, dst = torch.ones(256 * 2**20, dtype=torch.uint8), torch.empty(256 * 2**20, dtype=torch.uint8)
    return 2 * src.numel() / seconds(lambda: dst.copy_(src), repeats=repeats)[0]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--batch", type=int, nargs="+", default=[256, 64])
    parser.add_argument("--repeats", type=int, default=20)
    args = parser.parse_args()

    bank = ImageBank.builtin(size=84)
    bandwidth = copy_bandwidth(args.repeats)
    print(f"torch {torch.__version__}, {torch.get_num_threads()} threads, copy bandwidth {bandwidth / 1e9:.1f} GB/s")
    print("| augmentation | batch | vigen (samples/s) | reference (samples/s) | ratio | bandwidth (of copy) |")
    print("|---|---|---|---|---|---|")
    for batch in args.batch:
        x = torch.randint(0, 256, (batch, 9, 84, 84), dtype=torch.uint8)
        large = torch.randint(0, 256, (batch, 9, 100, 100), dtype=torch.uint8)
        cases = [
            ("RandomShift", RandomShift(seed=0), x, lambda: drqv2_shift(x)),
            ("RandomConv", RandomConv(seed=0), x, lambda: dmcgb_random_conv(x)),
            ("RandomFrequencyMask", RandomFrequencyMask(p=1.0, seed=0), x, lambda: rlvigen_random_mask_freq_v2(x)),
            ("RandomOverlay", RandomOverlay(images=bank, seed=0), x, lambda: float_overlay(x, bank.images)),
            ("RandomCrop 100→84", RandomCrop(84, seed=0), large, lambda: curl_random_crop(large.numpy())),
            ("RandomColorJitter", RandomColorJitter(seed=0), x, None),
        ]
        for name, transform, images, reference in cases:
            def ours_call() -> None:
                transform(pixels=images)

            if reference is None:
                (ours,) = seconds(ours_call, repeats=args.repeats)
                theirs_text, ratio_text = "—", "—"
            else:
                ours, theirs = seconds(ours_call, reference, repeats=args.repeats)
                theirs_text, ratio_text = f"{batch / theirs:,.0f}", f"{theirs / ours:.1f}x"
            fraction = (images.numel() + batch * 9 * 84 * 84) / ours / bandwidth
            print(f"| {name} | {batch} | {batch / ours:,.0f} | {theirs_text} | {ratio_text} | {fraction:.1%} |", flush=True)


if __name__ == "__main__":
    main()

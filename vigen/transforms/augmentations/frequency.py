"""SRM's spectrum random masking: remove a random square ring of spatial frequencies."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import torch
from tensordict.utils import NestedKey
from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params, check_parameter

NYQUIST = 0.5  # the highest spatial frequency, in cycles per pixel


class RandomFrequencyMask(ImageAugmentation):
    """Mask a random square ring of each channel's 2-D spectrum (SRM, "spectrum random masking").

    The ring is ``low <= max(|fy|, |fx|) < low + width`` in cycles per pixel, with
    ``low = round(U(0, max_low), 2)`` and ``width = round(U(0, max_width), 2)``, applied with
    probability ``p``. **Default: RL-ViGen's ``random_mask_freq_v2``** — one ring and one coin
    flip for the whole batch (``per_sample=False``), masked coefficients zeroed (``fill="zero"``).
    Options: ``per_sample=True`` draws a ring and a coin flip per sample; ``fill="noise"`` is the
    SRM paper's form ``F̂ = M·F(o) + (1 − M)·F(Z)``, where the ring takes the coefficients of a
    uniform noise image ``Z`` drawn per sample. Unlike RL-ViGen (which leaves values outside
    [0, 255]), the output is clipped to the value range so that it stays inside the observation
    spec; uint8 inputs are rounded. Each channel is masked alone, so any channel count works.
    Zeroing spectral coefficients does not depend on the pixel scale, so with ``fill="zero"``
    float pixels on any range work (``needs_scale`` is ``False``) and each sample's float output
    is clipped to ``[min(0, its minimum), max(max_value, its maximum)]``: ``[0, max_value]``
    for on-scale pixels. ``fill="noise"`` draws noise on ``[0, max_value]``, so it needs
    float pixels on that scale (``needs_scale`` is ``True``).

    Paper: SRM (Huang et al., NeurIPS 2022),
    https://proceedings.neurips.cc/paper_files/paper/2022/hash/802a4350ca4fced76b13b8b320af1543-Abstract-Conference.html;
    RL-ViGen,
    https://arxiv.org/abs/2307.10224.

    Args:
        p: probability of masking, in [0, 1].
        max_low: upper bound of the ring's inner edge, in [0, 0.5] (0.5 is the Nyquist frequency).
        max_width: upper bound of the ring's width, >= 0.
        per_sample: one ring per sample instead of one per batch.
        fill: ``"zero"`` or ``"noise"``.
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    All arguments but ``p`` are keyword-only: three numbers in [0, 1] in a row are too easy to
    swap.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomFrequencyMask
        >>> srm = RandomFrequencyMask(seed=0, per_sample=True)
        >>> srm(pixels=torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8)).dtype
        torch.uint8
    """

    def __init__(
        self,
        p: float = 0.5,
        *,
        max_low: float = 0.5,
        max_width: float = 0.05,
        per_sample: bool = False,
        fill: Literal["zero", "noise"] = "zero",
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        name = type(self).__name__
        check_parameter(name, "p", p, low=0, high=1)
        check_parameter(name, "max_low", max_low, low=0, high=NYQUIST)
        check_parameter(name, "max_width", max_width, low=0)
        if not isinstance(per_sample, bool):
            raise TypeError(f"{name}: per_sample must be True or False, got {type(per_sample).__name__} {per_sample!r}.")
        if fill not in ("zero", "noise"):
            raise ValueError(f"{name}: fill must be 'zero' (RL-ViGen) or 'noise' (SRM paper), got {fill!r}.")
        super().__init__(in_keys, out_keys, max_value=max_value, seed=seed)
        self.p, self.max_low, self.max_width = p, max_low, max_width
        self.per_sample, self.fill = per_sample, fill

    @property
    def needs_scale(self) -> bool:  # type: ignore[override]
        """Whether the mask needs float pixels on ``[0, max_value]``: only the noise fill, drawn on that scale."""
        return self.fill == "noise"

    def make_params(self, images: Tensor) -> Params:
        n = images.shape[0]
        draws = self.rand(3, n if self.per_sample else 1, like=images).expand(3, n)
        low = torch.round(draws[0] * self.max_low * 100) / 100
        width = torch.round(draws[1] * self.max_width * 100) / 100
        masked = draws[2] < self.p
        params = {"low": low, "high": torch.where(masked, low + width, low)}
        if self.fill == "noise":
            params["noise"] = self.rand(*images.shape, like=images) * self.white(images)
        return params

    def apply(self, images: Tensor, params: Params) -> Tensor:
        out = functional.mask_frequency(images, params["low"], params["high"], params.get("noise"))
        return functional.to_input_range(out, images, self.white(images))

    def extra_repr(self) -> str:
        return (
            f"p={self.p}, max_low={self.max_low}, max_width={self.max_width}, "
            f"per_sample={self.per_sample}, fill={self.fill!r}"
        )

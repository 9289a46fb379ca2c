"""DMC-GB's random convolution: a random 3×3 RGB filter per sample, squashed by a sigmoid."""

from __future__ import annotations

from torch import Tensor

from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import ImageAugmentation, Params


class RandomConv(ImageAugmentation):
    """Filter each sample with its own random 3×3 RGB→RGB kernel, then ``sigmoid`` back to the value range.

    Kernels are drawn from N(0, 1) per sample (``[3, 3, 3, 3]``, no bias) and applied to every
    stacked RGB frame of the sample (so ``C = 3·k``) with replicate padding: ``sigmoid(k ∗ x / m) · m`` with ``m`` the
    white level. This is DMC-GB's ``random_conv`` (SVEA's default strong augmentation there),
    batched as one grouped convolution instead of a loop over samples. The white level is part
    of the math, so float pixels must be on ``[0, max_value]`` (``needs_scale``).

    Papers: SVEA, https://arxiv.org/abs/2107.00644; random conv (network randomization),
    https://arxiv.org/abs/1910.05396.

    Args:
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomConv
        >>> out = RandomConv(seed=0)(pixels=torch.randint(0, 256, (4, 9, 84, 84), dtype=torch.uint8))
        >>> out.dtype, out.shape
        (torch.uint8, torch.Size([4, 9, 84, 84]))
    """

    needs_rgb = True  # the kernel maps each RGB frame to a new RGB frame
    needs_scale = True  # sigmoid(k ∗ x / m)·m: divides by, and squashes back to, the white level m

    def make_params(self, images: Tensor) -> Params:
        return {"kernels": self.randn(images.shape[0], 3, 3, 3, 3, like=images)}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        return functional.random_conv(images, params["kernels"], self.white(images))

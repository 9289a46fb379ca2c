"""SimGRL's shifted random overlay: each frame of a stack blended with its own shifted crop of one image."""

from __future__ import annotations

import os
from collections.abc import Sequence

import torch
from tensordict.utils import NestedKey
from torch import Tensor

from vigen.assets.image_bank import ImageBank
from vigen.devices import host_reads_are_free
from vigen.transforms.augmentations import functional
from vigen.transforms.augmentations.base import Params, check_parameter
from vigen.transforms.augmentations.overlay import RandomOverlay


class RandomShiftedOverlay(RandomOverlay):
    """Blend frame ``f`` of every stack with a crop of the sample's image shifted by ``f·(dy, dx)`` (SimGRL).

    For a stack of k frames of ``H × W`` pixels, each sample draws one image ``I`` from the bank
    and one integer shift ``(dy, dx)``, each uniform on ``{−max_shift, ..., max_shift}``. ``I`` is
    resized to ``(H + 2p) × (W + 2p)`` with ``p = k·max_shift``, and frame ``f`` (``f = 0`` the
    oldest) is blended with the ``H × W`` window whose corner is ``(p + f·dy, p + f·dx)``:

        ``out[f] = (1 − α)·x[f] + α·I[p + f·dy : p + f·dy + H, p + f·dx : p + f·dx + W]``

    The oldest frame sees the central window and the background drifts by ``(dy, dx)`` per
    frame: a moving distraction, where SVEA's :class:`~vigen.transforms.RandomOverlay` pastes
    one still image into every frame. SimGRL uses α = 0.5 and ``max_shift`` = 6 (its
    ``SRO_l``) on stacks of three 84×84 frames (images of 120×120).

    As in :class:`~vigen.transforms.RandomOverlay`, the bank defaults to
    :meth:`ImageBank.builtin` (pass a Places365 folder for the paper's images), images are not
    re-cropped (``RandomResizedCrop``) or flipped at every draw, and the blend of uint8 frames
    is rounded back to uint8 (SimGRL blends floats: at most half a grey level apart). The images
    are scaled to the frames' white level, so float inputs must be on ``[0, max_value]`` (``needs_scale``).

    Paper: SimGRL (NeurIPS 2024; no arXiv version), https://openreview.net/forum?id=0AumdfLzpK.

    Args:
        alpha: weight of the overlaid image, in [0, 1].
        max_shift: the largest shift between two consecutive frames, in pixels (an int >= 0;
            0 gives :class:`~vigen.transforms.RandomOverlay` on an image zoomed to its centre).
        images: an :class:`ImageBank`, a folder of images, or ``None`` for the built-in bank.
        in_keys, out_keys, max_value, seed: see :class:`~vigen.transforms.ImageAugmentation`.

    All arguments but ``alpha`` and ``max_shift`` are keyword-only: a folder goes in ``images=``.

    Examples:
        >>> import torch
        >>> from vigen.transforms import RandomShiftedOverlay
        >>> overlay = RandomShiftedOverlay(alpha=0.5, max_shift=6, seed=0)
        >>> pixels = torch.zeros(4, 9, 84, 84, dtype=torch.uint8)
        >>> params = overlay.make_params(pixels)  # one image and one shift (dy, dx) per sample
        >>> params["index"].shape, params["shift"].shape
        (torch.Size([4]), torch.Size([4, 2]))
        >>> out = overlay.apply(pixels, params)  # replays the draw
        >>> out.shape, out.dtype
        (torch.Size([4, 9, 84, 84]), torch.uint8)
    """

    def __init__(
        self,
        alpha: float = 0.5,
        max_shift: int = 6,
        *,
        images: ImageBank | str | os.PathLike | None = None,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        check_parameter(type(self).__name__, "max_shift", max_shift, low=0, integer=True)
        super().__init__(alpha, images=images, in_keys=in_keys, out_keys=out_keys, max_value=max_value, seed=seed)
        self.max_shift = int(max_shift)

    def prepare(self, shape: torch.Size, device: torch.device) -> None:
        channels, height, width = shape[-3:]
        pad = channels // functional.FRAME_CHANNELS * self.max_shift
        self.bank.resized(height + 2 * pad, width + 2 * pad, device=device)

    def make_params(self, images: Tensor) -> Params:
        n = images.shape[0]
        index = self.randint(len(self.bank), n, like=images)
        shift = self.randint(2 * self.max_shift + 1, n, 2, like=images) - self.max_shift
        return {"index": index, "shift": shift}

    def apply(self, images: Tensor, params: Params) -> Tensor:
        n, channels, height, width = images.shape
        frames = channels // functional.FRAME_CHANNELS
        shift = params["shift"].long().to(images.device)
        if shift.numel() and host_reads_are_free(shift) and int(shift.abs().max()) > self.max_shift:  # a check that would synchronize is left out on accelerators
            raise ValueError(f"{type(self).__name__}: shifts reach {int(shift.abs().max())} pixels, above "
                             f"max_shift={self.max_shift}; draw them with make_params() or raise max_shift.")
        pad = frames * self.max_shift
        bank = self.bank.resized(height + 2 * pad, width + 2 * pad, device=images.device)
        backgrounds = shifted_windows(bank[params["index"]], shift, frames, pad, height, width)
        white = self.white(images)
        per_frame = images.reshape(n * frames, functional.FRAME_CHANNELS, height, width)
        backgrounds = self.at_white(backgrounds, images.dtype, white).reshape(per_frame.shape)
        return functional.overlay(per_frame, backgrounds, self.alpha, white).reshape(images.shape)

    def extra_repr(self) -> str:
        return f"alpha={self.alpha}, max_shift={self.max_shift}, images={self.image_source()}"


def shifted_windows(images: Tensor, shift: Tensor, frames: int, pad: int, height: int, width: int) -> Tensor:
    """The ``height × width`` windows at ``(pad + f·dy, pad + f·dx)`` of each image, for ``f < frames``.

    Args:
        images: ``[N, C, height + 2·pad, width + 2·pad]``.
        shift: ``[N, 2]`` integer ``(dy, dx)`` with ``(frames − 1)·|d| <= pad``.
        frames: windows per image.
        pad: offset of the first (unshifted) window.
        height, width: size of a window.

    Returns:
        ``[N, frames, C, height, width]``, in ``images``' dtype.

    Examples:
        >>> import torch
        >>> image = torch.arange(36.0).reshape(1, 1, 6, 6)
        >>> shifted_windows(image, torch.tensor([[1, -1]]), frames=2, pad=2, height=2, width=2)[0, :, 0]
        tensor([[[14., 15.],
                 [20., 21.]],
        <BLANKLINE>
                [[19., 20.],
                 [25., 26.]]])
    """
    n, channels, _, full_width = images.shape
    step = torch.arange(frames, device=images.device)
    tops = pad + step * shift[:, :1]          # [N, frames]
    lefts = pad + step * shift[:, 1:]
    rows = tops[..., None] + torch.arange(height, device=images.device)   # [N, frames, height]
    cols = lefts[..., None] + torch.arange(width, device=images.device)   # [N, frames, width]
    index = (rows[..., :, None] * full_width + cols[..., None, :]).reshape(n, 1, -1)
    windows = images.reshape(n, channels, -1).gather(2, index.expand(n, channels, index.shape[-1]))
    return windows.reshape(n, channels, frames, height, width).transpose(1, 2)

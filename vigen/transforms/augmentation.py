"""The base of vigen's image augmentations: TorchRL plumbing around ``make_params`` and ``apply``."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from tensordict.utils import NestedKey
from torch import Tensor
from torchrl.data import Composite
from torchrl.data.tensor_specs import ContinuousBox
from torchrl.envs import Transform
from torchrl.envs.transforms.utils import _set_missing_tolerance

from vigen.transforms import functional
from vigen.transforms.functional import FRAME_CHANNELS

Params = dict[str, Tensor]


class ImageAugmentation(Transform):
    """A TorchRL ``Transform`` that draws per-sample parameters, then applies a pure kernel.

    Subclasses implement :meth:`make_params` (all the randomness) and :meth:`apply` (none of
    it), so that a draw can be replayed: ``t.apply(x, params)``. The transform itself handles
    what TorchRL needs:

    * in an env (``TransformedEnv``, also inside ``ParallelEnv`` workers) it augments the reset
      observation and every step's observation;
    * in a replay buffer (``rb.append_transform(t)``) list both ``"pixels"`` and
      ``("next", "pixels")`` as ``in_keys``: each key gets its own draw;
    * standalone on a TensorDict, by keyword (``t(pixels=x)``) and inside ``Compose``.

    Images are ``[..., 3·k, H, W]`` (k stacked RGB frames, channels first) with any leading batch
    dims, uint8 or float; the output has the input's dtype and shape (crops change H and W), and
    the input is never modified. Values stay in ``[0, max_value]``.

    Args:
        in_keys: keys to augment; default ``["pixels"]``.
        out_keys: where to write; default: in place of ``in_keys``.
        max_value: value of a white pixel. ``None``: 255 for integer images, 1.0 for float ones
            (TorchRL's ``ToTensorImage`` scale); pass 255 for float images on the 0–255 scale.
        seed: seed of the transform's own ``torch.Generator`` (one per device), so its draws
            are reproducible and independent of the global RNG. ``None`` draws from torch's
            global RNG, which ``ParallelEnv.set_seed`` seeds differently in each worker.

    Examples:
        >>> import torch
        >>> class RandomInvert(ImageAugmentation):
        ...     def make_params(self, images):
        ...         return {"flip": self.rand(images.shape[0], like=images) < 0.5}
        ...     def apply(self, images, params):
        ...         white = self.white(images)
        ...         return torch.where(params["flip"][:, None, None, None], white - images, images)
        >>> RandomInvert(seed=0)(pixels=torch.zeros(4, 3, 8, 8)).amax(dim=(1, 2, 3))
        tensor([1., 0., 1., 1.])
    """

    def __init__(
        self,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        *,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        in_keys = ["pixels"] if in_keys is None else in_keys
        super().__init__(in_keys=in_keys, out_keys=out_keys if out_keys is not None else in_keys)
        self.max_value = max_value
        self.seed = seed
        self._generators: dict[torch.device, torch.Generator] = {}

    # -- the two methods subclasses write --------------------------------------------------
    def make_params(self, images: Tensor) -> Params:
        """Draw the parameters for a batch ``images`` of shape ``[N, C, H, W]`` (one set per sample)."""
        raise NotImplementedError

    def apply(self, images: Tensor, params: Params) -> Tensor:
        """Apply ``params`` to ``images`` ``[N, C, H, W]`` deterministically."""
        raise NotImplementedError

    def augment(self, images: Tensor) -> Tensor:
        """Draw parameters and apply them to a tensor ``[..., 3·k, H, W]`` (what losses call).

        Examples:
            >>> import torch
            >>> from vigen.transforms import RandomShift
            >>> RandomShift(seed=0).augment(torch.zeros(2, 9, 84, 84, dtype=torch.uint8)).shape
            torch.Size([2, 9, 84, 84])
        """
        return self._apply_transform(images)

    def extra_repr(self) -> str:
        """Hyper-parameters shown in ``repr`` (besides the keys)."""
        return ""

    def output_size(self, height: int, width: int) -> tuple[int, int]:
        """Output ``(H, W)`` for an input of ``(height, width)``; crops override this."""
        return height, width

    # -- randomness ------------------------------------------------------------------------
    def set_seed(self, seed: int | None) -> None:
        """Re-seed the transform's generator (``None``: use torch's global RNG from now on)."""
        self.seed = seed
        self._generators.clear()

    def generator(self, device: torch.device) -> torch.Generator | None:
        """The transform's generator on ``device`` (``None`` when it uses the global RNG)."""
        if self.seed is None:
            return None
        device = torch.device(device)
        if device not in self._generators:
            self._generators[device] = torch.Generator(device=device).manual_seed(self.seed)
        return self._generators[device]

    def rand(self, *shape: int, like: Tensor) -> Tensor:
        """Uniform [0, 1) floats on ``like``'s device from the transform's generator."""
        return torch.rand(shape, generator=self.generator(like.device), device=like.device)

    def randint(self, high: int, *shape: int, like: Tensor) -> Tensor:
        """Integers in ``[0, high)`` on ``like``'s device from the transform's generator."""
        return torch.randint(high, shape, generator=self.generator(like.device), device=like.device)

    def randn(self, *shape: int, like: Tensor) -> Tensor:
        """Standard normal floats on ``like``'s device from the transform's generator."""
        return torch.randn(shape, generator=self.generator(like.device), device=like.device)

    def white(self, images: Tensor) -> float:
        """The value of a white pixel for ``images``."""
        if self.max_value is not None:
            return float(self.max_value)
        return 1.0 if images.dtype.is_floating_point else float(torch.iinfo(images.dtype).max)

    # -- TorchRL plumbing ------------------------------------------------------------------
    @dispatch(source="in_keys", dest="out_keys", auto_batch_size=False)
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Augment ``in_keys`` of a TensorDict (replay-buffer samples, standalone calls, ``t(pixels=x)``)."""
        return super().forward(tensordict)

    def _apply_transform(self, pixels: Tensor) -> Tensor:
        images = self._as_batch(pixels)
        out = self.apply(images, self.make_params(images))
        return out.reshape(*pixels.shape[:-3], *out.shape[-3:])

    def transform_observation_spec(self, observation_spec: Composite) -> Composite:
        for in_key, out_key in zip(self.in_keys, self.out_keys):
            if in_key not in observation_spec.keys(True, True):
                continue
            spec = observation_spec[in_key].clone()
            *batch, channels, height, width = spec.shape
            size = self.output_size(height, width)
            if size != (height, width):
                if isinstance(spec.space, ContinuousBox):
                    spec.space.low = functional.center_crop(spec.space.low, *size)
                    spec.space.high = functional.center_crop(spec.space.high, *size)
                spec.shape = torch.Size([*batch, channels, *size])
            elif in_key == out_key:
                continue
            observation_spec[out_key] = spec
        return observation_spec

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        with _set_missing_tolerance(self, True):
            return self._call(tensordict_reset)

    def _as_batch(self, pixels: Tensor) -> Tensor:
        name = type(self).__name__
        if pixels.dtype not in (torch.uint8, torch.float16, torch.bfloat16, torch.float32, torch.float64):
            raise TypeError(f"{name} takes uint8 or floating-point images, got {pixels.dtype}.")
        if pixels.ndim < 3 or pixels.shape[-3] % FRAME_CHANNELS:
            raise ValueError(
                f"{name} takes channels-first RGB frame stacks [..., 3*k, H, W], got shape {tuple(pixels.shape)}. "
                "For HWC images from an env, put ToTensorImage() before it."
            )
        return pixels.reshape(-1, *pixels.shape[-3:])

    def clone(self) -> ImageAugmentation:
        """A copy whose generators continue from this one's state but advance on their own."""
        copy = super().clone()
        copy._generators = _generators_from_states({d: g.get_state() for d, g in self._generators.items()})
        return copy

    def __getstate__(self) -> dict[str, Any]:
        state = super().__getstate__()
        state["_generators"] = {device: g.get_state() for device, g in state["_generators"].items()}
        return state

    def __setstate__(self, state: dict[str, Any]) -> None:
        state["_generators"] = _generators_from_states(state["_generators"])
        super().__setstate__(state)

    def __repr__(self) -> str:
        keys = f"in_keys={self.in_keys}" + ("" if self.out_keys == self.in_keys else f", out_keys={self.out_keys}")
        extra = self.extra_repr()
        seed = "" if self.seed is None else f", seed={self.seed}"
        return f"{type(self).__name__}({extra + ', ' if extra else ''}{keys}{seed})"


def _generators_from_states(states: dict[torch.device, Tensor]) -> dict[torch.device, torch.Generator]:
    """New generators, one per device, continuing from the saved states."""
    generators = {}
    for device, state in states.items():
        generators[device] = torch.Generator(device=device)
        generators[device].set_state(state)
    return generators

"""The base of vigen's image augmentations: TorchRL plumbing around ``make_params`` and ``apply``."""

from __future__ import annotations

import math
import numbers
from collections.abc import Sequence
from typing import Any, ClassVar

import torch
from tensordict import TensorDictBase
from tensordict.nn import dispatch
from tensordict.utils import NestedKey
from torch import Tensor
from torchrl.data import Composite, TensorSpec
from torchrl.data.tensor_specs import ContinuousBox
from torchrl.envs import Transform
from torchrl.envs.transforms.utils import _set_missing_tolerance

from vigen.pixel_format import check_max_value, check_pixel_layout, check_pixels, white_value
from vigen.transforms.augmentations import functional

Params = dict[str, Tensor]


def check_parameter(
    owner: str,
    name: str,
    value: object,
    *,
    low: float | None = None,
    high: float | None = None,
    integer: bool = False,
    hint: str = "",
) -> None:
    """Raise if a constructor argument is not a finite number (an int if ``integer``) in ``[low, high]``.

    Args:
        owner: the class whose argument it is, put at the start of the message.
        name: the argument's name.
        value: what was passed.
        low, high: inclusive bounds (``None``: unbounded on that side).
        integer: the argument must be an int.
        hint: appended to the message (e.g. how to pass what was probably meant).

    Examples:
        >>> check_parameter("Demo", "p", 0.5, low=0, high=1)
        >>> check_parameter("Demo", "pad", -1, low=0, integer=True)
        Traceback (most recent call last):
        ...
        ValueError: Demo: pad must be an int >= 0, got -1.
    """
    kind = "an int" if integer else "a number"
    if low is not None and high is not None:
        kind += f" in [{low}, {high}]"
    elif low is not None:
        kind += f" >= {low}"
    elif high is not None:
        kind += f" <= {high}"
    wanted = numbers.Integral if integer else numbers.Real
    if isinstance(value, bool) or not isinstance(value, wanted):
        raise TypeError(f"{owner}: {name} must be {kind}, got {type(value).__name__} {value!r}.{hint}")
    if not math.isfinite(value) or (low is not None and value < low) or (high is not None and value > high):
        raise ValueError(f"{owner}: {name} must be {kind}, got {value!r}.{hint}")


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

    Input contract (:mod:`vigen.pixel_format`), checked on every call before any work: images are
    ``[..., C, H, W]`` channels first, with any leading batch dims, uint8 on ``[0, 255]`` or
    float. Channels-last frames, other dtypes and NaN or +inf values raise with the fix. Two
    class attributes say what else an augmentation needs:

    * ``needs_scale`` (default ``True``): its math assumes a white level (a blend, a squashing
      filter, a colour change, noise of a set strength), so float images must be on
      ``[0, max_value]`` (``max_value`` defaults to 1.0, TorchRL's ``ToTensorImage`` scale; float
      images on the 0–255 scale need ``max_value=255``) and values above it raise with the fix.
      Augmentations whose output only moves, interpolates or zeroes input values (shift, crop,
      rotation, zero-filled frequency mask) declare ``needs_scale = False`` and take float
      images on any range, e.g. normalized observations.
    * ``needs_rgb`` (default ``False``): it mixes the colours of a pixel, so it takes stacks of k
      RGB frames, ``C = 3·k``; the others take any channel count (e.g. grayscale stacks).

    The output has the input's dtype and shape (crops change H and W); uint8 and on-scale float
    values stay in ``[0, max_value]``, and an augmentation that does not need the scale keeps
    each sample within ``[min(0, its minimum), max(max_value, its maximum)]``. The input is
    never modified, and an empty batch gives an empty output without drawing anything.

    Args:
        in_keys: keys to augment; default ``["pixels"]``.
        out_keys: where to write; default: in place of ``in_keys``.
        max_value: value of a white float pixel. ``None``: 1.0 (TorchRL's ``ToTensorImage``
            scale); pass 255 for float images on the 0–255 scale. uint8 images are always 0–255.
        seed: seed of the transform's own ``torch.Generator`` (one per device), so its draws
            are reproducible and independent of the global RNG. ``None`` draws from torch's
            global RNG, which ``ParallelEnv.set_seed`` seeds differently in each worker.

    Examples:
        >>> import torch
        >>> class RandomInvert(ImageAugmentation):
        ...     needs_rgb = False  # works on each channel alone
        ...     def make_params(self, images):
        ...         return {"flip": self.rand(images.shape[0], like=images) < 0.5}
        ...     def apply(self, images, params):
        ...         white = self.white(images)
        ...         return torch.where(params["flip"][:, None, None, None], white - images, images)
        >>> RandomInvert(seed=0)(pixels=torch.zeros(4, 3, 8, 8)).amax(dim=(1, 2, 3))
        tensor([1., 0., 1., 1.])
    """

    needs_rgb: ClassVar[bool] = False
    """Whether the augmentation mixes a pixel's R, G and B, so it needs ``C = 3·k`` channels."""

    needs_scale: ClassVar[bool] = True
    """Whether the augmentation's math assumes that ``max_value`` is white, so float pixels must lie
    on ``[0, max_value]``; ``False`` for those that only move, interpolate or zero values (any float range)."""

    def __init__(
        self,
        in_keys: Sequence[NestedKey] | NestedKey | None = None,
        out_keys: Sequence[NestedKey] | NestedKey | None = None,
        *,
        max_value: float | None = None,
        seed: int | None = None,
    ) -> None:
        check_max_value(type(self).__name__, max_value)
        _check_seed(type(self).__name__, seed)
        in_keys = ["pixels"] if in_keys is None else in_keys
        super().__init__(in_keys=in_keys, out_keys=out_keys if out_keys is not None else in_keys)
        if len(self.in_keys) != len(self.out_keys):
            raise ValueError(
                f"{type(self).__name__}: out_keys must have one key per in_key, got in_keys={self.in_keys} and "
                f"out_keys={self.out_keys}; leave out_keys None to write in place."
            )
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
        """Check the pixel contract, draw parameters and apply them to ``[..., C, H, W]`` (what losses call).

        Examples:
            >>> import torch
            >>> from vigen.transforms import RandomShift
            >>> RandomShift(seed=0).augment(torch.zeros(2, 9, 84, 84, dtype=torch.uint8)).shape
            torch.Size([2, 9, 84, 84])
        """
        return self._apply_transform(images)

    def prepare(self, shape: torch.Size, device: torch.device) -> None:
        """Load what the transform builds on first use (image banks, resized and on ``device``) for pixels of ``shape``.

        A compiled update calls it before tracing, so that no file is read inside the graph; the
        default loads nothing.
        """

    def extra_repr(self) -> str:
        """Hyper-parameters shown in ``repr`` (besides the keys)."""
        return ""

    def output_size(self, height: int, width: int) -> tuple[int, int]:
        """Output ``(H, W)`` for an input of ``(height, width)``; crops override this."""
        return height, width

    # -- randomness ------------------------------------------------------------------------
    def set_seed(self, seed: int | None) -> None:
        """Re-seed the transform's generator (``None``: use torch's global RNG from now on)."""
        _check_seed(type(self).__name__, seed)
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

    def generator_devices(self) -> list[torch.device]:
        """The devices on which the transform has drawn from its own generator so far."""
        return list(self._generators)

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
        """The value of a white pixel for ``images`` (see :func:`vigen.pixel_format.white_value`)."""
        return white_value(images, self.max_value)

    # -- TorchRL plumbing ------------------------------------------------------------------
    @dispatch(source="in_keys", dest="out_keys", auto_batch_size=False)
    def forward(self, tensordict: TensorDictBase) -> TensorDictBase:
        """Augment ``in_keys`` of a TensorDict (replay-buffer samples, standalone calls, ``t(pixels=x)``)."""
        return super().forward(tensordict)

    def _apply_transform(self, pixels: Tensor) -> Tensor:
        images = self._as_batch(pixels)
        if images.numel() == 0:
            return pixels.new_empty((*pixels.shape[:-2], *self.output_size(*pixels.shape[-2:])))
        out = self.apply(images, self.make_params(images))
        return out.reshape(*pixels.shape[:-3], *out.shape[-3:])

    def transform_observation_spec(self, observation_spec: Composite | TensorSpec) -> Composite | TensorSpec:
        """The spec after augmentation: a ``Composite`` (its ``in_keys`` are mapped) or one pixel spec.

        The pixel specs are checked against the contract (dtype, channels first, channel count),
        so a misplaced augmentation fails when the env is built.
        """
        if not isinstance(observation_spec, Composite):
            return self._transform_pixel_spec(observation_spec.clone())
        for in_key, out_key in zip(self.in_keys, self.out_keys):
            if in_key not in observation_spec.keys(True, True):
                continue
            spec = self._transform_pixel_spec(observation_spec[in_key].clone())
            if in_key != out_key or spec.shape != observation_spec[in_key].shape:
                observation_spec[out_key] = spec
        return observation_spec

    def _transform_pixel_spec(self, spec: TensorSpec) -> TensorSpec:
        check_pixel_layout(spec.shape, spec.dtype, name=type(self).__name__, max_value=self.max_value, rgb=self.needs_rgb)
        *batch, channels, height, width = spec.shape
        size = self.output_size(height, width)
        if size != (height, width):
            if isinstance(getattr(spec, "space", None), ContinuousBox):
                spec.space.low = functional.center_crop(spec.space.low, *size)
                spec.space.high = functional.center_crop(spec.space.high, *size)
            spec.shape = torch.Size([*batch, channels, *size])
        return spec

    def _reset(self, tensordict: TensorDictBase, tensordict_reset: TensorDictBase) -> TensorDictBase:
        with _set_missing_tolerance(self, True):
            return self._call(tensordict_reset)

    def _as_batch(self, pixels: Tensor) -> Tensor:
        """``pixels`` checked against the contract (once per call) and flattened to ``[N, C, H, W]``."""
        check_pixels(pixels, name=type(self).__name__, max_value=self.max_value, rgb=self.needs_rgb,
                     needs_scale=self.needs_scale)
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


def _check_seed(owner: str, seed: object) -> None:
    if seed is not None and (isinstance(seed, bool) or not isinstance(seed, numbers.Integral)):
        raise TypeError(f"{owner}: seed must be an int or None, got {type(seed).__name__} {seed!r}.")


def _generators_from_states(states: dict[torch.device, Tensor]) -> dict[torch.device, torch.Generator]:
    """New generators, one per device, continuing from the saved states."""
    generators = {}
    for device, state in states.items():
        generators[device] = torch.Generator(device=device)
        generators[device].set_state(state)
    return generators

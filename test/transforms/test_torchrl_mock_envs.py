"""vigen's augmentations in TorchRL's key transform checks, on TorchRL's pixel mock env (issue 31, point 7).

TorchRL's ``ContinuousActionConvMockEnv`` emits float pixels drawn from N(0, 1): outside [0, 1],
as normalized observations are. The pixel contract reads the value scale only where the math
needs a white level (``needs_scale``):

* augmentations that only move, interpolate or zero values (shift, crops, rotation, zero-filled
  frequency mask, chains of them) pass TorchRL's key checks on such pixels: appended to a single
  and to a batched env, inside a ``Compose``, in a replay buffer, before a model; and their output
  is the on-scale output under any affine change of scale;
* the others (overlays, convolution, colour jitter, noise fill, corruptions) refuse them with
  the error that names the fix.
"""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict
from tensordict.nn import TensorDictModule
from torch import nn
from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs import Compose, SerialEnv, TransformedEnv
from torchrl.envs.utils import check_env_specs
from torchrl.testing.mocking_classes import ContinuousActionConvMockEnv

from vigen.transforms import (
    AugmentationChain,
    CenterCrop,
    ImageBank,
    PixelCorruption,
    RandomChoice,
    RandomColorJitter,
    RandomConv,
    RandomCrop,
    RandomFrequencyMask,
    RandomOverlay,
    RandomRotate,
    RandomShift,
    RandomShiftedOverlay,
)

SIZE, CROP = 16, 12
BANK = ImageBank.procedural(4, size=SIZE)

# name -> a fresh augmentation, given keyword arguments (keys, seed)
SCALE_FREE = {
    "shift": lambda **kw: RandomShift(pad=2, **kw),
    "crop": lambda **kw: RandomCrop(CROP, **kw),
    "center_crop": lambda **kw: CenterCrop(CROP, **kw),
    "rotate": lambda **kw: RandomRotate(180, **kw),
    "frequency_zero": lambda **kw: RandomFrequencyMask(1.0, max_width=0.2, **kw),
    "rotate_shift": lambda **kw: AugmentationChain([RandomRotate(180), RandomShift(pad=2)], **kw),
}
SCALE_BOUND = {
    "overlay": lambda **kw: RandomOverlay(images=BANK, **kw),
    "shifted_overlay": lambda **kw: RandomShiftedOverlay(max_shift=1, images=BANK, **kw),
    "conv": lambda **kw: RandomConv(**kw),
    "color_jitter": lambda **kw: RandomColorJitter(**kw),
    "frequency_noise": lambda **kw: RandomFrequencyMask(1.0, max_width=0.2, fill="noise", **kw),
    "rotate_or_conv": lambda **kw: RandomChoice([RandomRotate(180), RandomConv()], **kw),
    **{
        corruption: (lambda corruption: lambda **kw: PixelCorruption(corruption, **kw))(corruption)
        for corruption in ("gaussian_noise", "gaussian_blur", "jpeg_compression", "contrast", "brightness")
    },
}


def out_size(name: str) -> int:
    return CROP if name.endswith("crop") else SIZE


def mock_env() -> ContinuousActionConvMockEnv:
    """TorchRL's pixel mock env: one RGB frame of N(0, 1) floats at reset (diagonal frames at steps)."""
    return ContinuousActionConvMockEnv(pixel_shape=[3, SIZE, SIZE])


def off_scale_pixels(*batch: int, seed: int = 0) -> torch.Tensor:
    """Float frames on about [-12, 12], as an unnormalized counter or a normalized observation gives."""
    return 4 * torch.randn(*batch, 3, SIZE, SIZE, generator=torch.Generator().manual_seed(seed))


def assert_within_own_range(out: torch.Tensor, pixels: torch.Tensor) -> None:
    """Each output sample lies in [min(0, its input's minimum), max(1, its input's maximum)], unclipped to [0, 1]."""
    dims = (-3, -2, -1)
    assert (out.amin(dims) >= pixels.amin(dims).clamp(max=0) - 1e-5).all()
    assert (out.amax(dims) <= pixels.amax(dims).clamp(min=1) + 1e-5).all()
    assert out.min() < 0 and out.max() > 1, "off-scale values must come through, not be clipped to [0, 1]"


@pytest.mark.parametrize("name", SCALE_FREE)
class TestScaleFreeOnTorchRLMockEnv:
    def test_single_env_with_the_transform_appended(self, name):
        torch.manual_seed(0)
        env = TransformedEnv(mock_env(), SCALE_FREE[name](in_keys=["pixels"], out_keys=["augmented"], seed=0))
        check_env_specs(env)
        rollout = env.rollout(3)
        raw, augmented = rollout["pixels"], rollout["augmented"]
        assert raw.min() < 0 and raw.max() > 1, "the mock env must emit pixels outside [0, 1]"
        assert augmented.shape == (3, 3, out_size(name), out_size(name)) and augmented.dtype == raw.dtype
        assert_within_own_range(augmented[:1], raw[:1])  # the reset frame: N(0, 1) everywhere

    def test_transformed_serial_env(self, name):
        env = TransformedEnv(SerialEnv(2, mock_env), SCALE_FREE[name](seed=0))
        try:
            check_env_specs(env)
            assert env.reset()["pixels"].shape == (2, 3, out_size(name), out_size(name))
        finally:
            env.close()

    def test_compose(self, name):
        torch.manual_seed(0)
        check_env_specs(TransformedEnv(mock_env(), Compose(SCALE_FREE[name](seed=0))))
        pixels = off_scale_pixels(2)
        data = TensorDict(pixels=pixels, batch_size=[2])
        for out in (Compose(SCALE_FREE[name](seed=0))(data.clone()), Compose(SCALE_FREE[name](seed=0))._call(data.clone())):
            assert out["pixels"].shape == (2, 3, out_size(name), out_size(name))
            assert_within_own_range(out["pixels"], pixels)

    def test_replay_buffer(self, name):
        rb = TensorDictReplayBuffer(storage=LazyTensorStorage(8), batch_size=4)
        rb.append_transform(SCALE_FREE[name](in_keys=["pixels", ("next", "pixels")], seed=0))
        frames = off_scale_pixels(8)
        rb.extend(TensorDict({"pixels": frames, ("next", "pixels"): frames.clone()}, batch_size=[8]))
        sample = rb.sample()
        assert sample["pixels"].shape == sample["next", "pixels"].shape == (4, 3, out_size(name), out_size(name))
        assert_within_own_range(sample["pixels"], frames[sample["index"]])
        assert torch.equal(rb.storage[:8]["pixels"], frames), "the storage must never be modified"

    def test_model_on_a_tensordict(self, name):
        features = TensorDictModule(nn.Flatten(-3), in_keys=["pixels"], out_keys=["features"])
        out = nn.Sequential(SCALE_FREE[name](seed=0), features)(TensorDict(pixels=off_scale_pixels(2), batch_size=[2]))
        assert out["features"].shape == (2, 3 * out_size(name) ** 2)

    def test_output_follows_an_affine_change_of_scale(self, name):
        # on-scale frames spanning exactly [0, 1]: T(a·x + b) = a·T(x) + b for the same draw
        x = torch.rand(4, 3, SIZE, SIZE, generator=torch.Generator().manual_seed(1))
        low, high = x.amin((1, 2, 3), keepdim=True), x.amax((1, 2, 3), keepdim=True)
        x = (x - low) / (high - low)
        transform = SCALE_FREE[name](seed=0)
        params = transform.make_params(x)
        if name == "frequency_zero":  # a ring that keeps the mean (low > 0), where the offset b lives
            params = {"low": torch.full((4,), 0.1), "high": torch.full((4,), 0.3)}
        scale, offset = 10.0, -3.0
        on_scale = transform.apply(x, params)
        off_scale = transform.apply(scale * x + offset, params)
        torch.testing.assert_close(off_scale, scale * on_scale + offset, atol=1e-4, rtol=1e-5)
        assert off_scale.min() < 0 and off_scale.max() > 1


@pytest.mark.parametrize("name", SCALE_BOUND)
def test_scale_bound_augmentations_refuse_off_scale_pixels_naming_the_fix(name):
    torch.manual_seed(0)
    transform = SCALE_BOUND[name](seed=0)
    owner = type(transform).__name__
    fix = rf"^{owner}: float pixels reach .* above max_value 1\.0, .*pass max_value=255.*normalized pixels"
    env = TransformedEnv(mock_env(), transform)
    with pytest.raises(ValueError, match=fix):
        env.reset()
    with pytest.raises(ValueError, match=fix):
        transform(TensorDict(pixels=off_scale_pixels(2), batch_size=[2]))


def test_needs_scale_is_declared_by_what_the_math_assumes():
    declared = {name: build().needs_scale for name, build in {**SCALE_FREE, **SCALE_BOUND}.items()}
    assert declared == {**dict.fromkeys(SCALE_FREE, False), **dict.fromkeys(SCALE_BOUND, True)}
    assert RandomShift.needs_scale is False and RandomConv.needs_scale is True  # class attributes, not per call

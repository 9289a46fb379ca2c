"""The input contract of the image augmentations (issue 13): nothing lost, nothing silent.

Pixels are ``[..., C, H, W]`` channels first, uint8 on [0, 255] or float; augmentations whose
math assumes a white level (``needs_scale``) take floats on [0, max_value] (max_value 1.0 unless
declared), the geometric and zero-fill ones any float range; colour augmentations need
``C = 3·k``, the others take any channel count; constructor arguments are checked; empty
batches and leaf specs work.
"""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import torch
from tensordict import TensorDict
from torchrl.data import Bounded, Unbounded
from torchrl.envs import CatFrames, ClipTransform, GrayScale, TransformedEnv
from torchrl.envs.utils import check_env_specs
from torchrl.testing.mocking_classes import ContinuousActionConvMockEnv, ContinuousActionConvMockEnvNumpy

from vigen.transforms import (
    CenterCrop,
    ImageBank,
    PixelCorruption,
    RandomColorJitter,
    RandomConv,
    RandomCrop,
    RandomFrequencyMask,
    RandomOverlay,
    RandomShift,
)
from vigen.transforms import AugmentationChain, RandomChoice, RandomRotate, RandomShiftedOverlay

SIZE, CROP = 12, 9
BANK = ImageBank.procedural(4, size=SIZE)

class RotateShift(AugmentationChain):
    """DMC-GB2's rotate_shift at this test's size (a chain with default arguments, for the shared checks)."""

    def __init__(self, **kwargs):
        super().__init__([RandomRotate(180), RandomShift(pad=2)], **kwargs)


class RotateOrConv(RandomChoice):
    """One of a geometric and a colour augmentation per sample (DMC-GB2's compose_augs)."""

    def __init__(self, **kwargs):
        super().__init__([RandomRotate(180), RandomConv()], **kwargs)


# name -> (class, constructor kwargs, needs RGB frames); SCALE_FREE: needs_scale is False
AUGMENTATIONS = {
    "shift": (RandomShift, {}, False),
    "crop": (RandomCrop, {"size": CROP}, False),
    "center_crop": (CenterCrop, {"size": CROP}, False),
    "frequency": (RandomFrequencyMask, {"p": 1.0, "max_width": 0.3}, False),
    "frequency_noise": (RandomFrequencyMask, {"p": 1.0, "max_width": 0.3, "per_sample": True, "fill": "noise"}, False),
    "noise": (PixelCorruption, {"corruption": "gaussian_noise"}, False),
    "blur": (PixelCorruption, {"corruption": "gaussian_blur", "severity": 5}, False),
    "overlay": (RandomOverlay, {"images": BANK}, True),
    "conv": (RandomConv, {}, True),
    "color_jitter": (RandomColorJitter, {}, True),
    "jpeg": (PixelCorruption, {"corruption": "jpeg_compression"}, True),
    "contrast": (PixelCorruption, {"corruption": "contrast"}, True),
    "brightness": (PixelCorruption, {"corruption": "brightness"}, True),
    "rotate": (RandomRotate, {}, False),
    "rotate_per_call": (RandomRotate, {"per_sample": False}, False),
    "rotate_shift": (RotateShift, {}, False),
    "rotate_or_conv": (RotateOrConv, {}, True),
    "shifted_overlay": (RandomShiftedOverlay, {"images": BANK}, True),
}
SCALE_FREE = ["shift", "crop", "center_crop", "frequency", "rotate", "rotate_per_call", "rotate_shift"]
ANY_CHANNELS = [name for name, (_, _, rgb) in AUGMENTATIONS.items() if not rgb]
RGB_ONLY = [name for name, (_, _, rgb) in AUGMENTATIONS.items() if rgb]


def build(name: str, **kwargs):
    cls, defaults, _ = AUGMENTATIONS[name]
    return cls(**{**defaults, **kwargs})


def out_size(name: str) -> int:
    return CROP if "crop" in name else SIZE


def uint8_images(*shape: int, seed: int = 0) -> torch.Tensor:
    return torch.randint(0, 256, shape, dtype=torch.uint8, generator=torch.Generator().manual_seed(seed))


# -- 1. scale ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", [name for name in AUGMENTATIONS if name not in SCALE_FREE])
def test_float_0_255_without_max_value_raises_with_the_fix(name):
    x = uint8_images(2, 9, SIZE, SIZE).float()  # 0–255 floats, max_value not declared
    with pytest.raises(ValueError, match="max_value=255"):
        build(name, seed=0)(pixels=x)


@pytest.mark.parametrize("name", SCALE_FREE)
def test_geometric_and_zero_fill_augmentations_take_any_float_range(name):
    x = uint8_images(2, 9, SIZE, SIZE).float()  # 0–255 floats, max_value not declared
    transform = build(name, seed=0)
    assert transform.needs_scale is False
    from_float = transform(pixels=x)
    from_uint8 = build(name, seed=0)(pixels=x.to(torch.uint8)).float()
    assert from_float.dtype == torch.float32 and from_float.max() > 1, "not clipped to the default [0, 1]"
    assert (from_float - from_uint8).abs().max() <= 1.0  # the same draw; uint8 results are rounded


@pytest.mark.parametrize("name", AUGMENTATIONS)
def test_float_0_255_with_max_value_255_matches_uint8(name):
    x = uint8_images(3, 9, SIZE, SIZE)
    from_uint8 = build(name, seed=1)(pixels=x).float()
    from_float = build(name, seed=1, max_value=255)(pixels=x.float())
    assert from_float.dtype == torch.float32 and from_float.max() <= 255
    assert (from_float - from_uint8).abs().max() <= 1.0  # uint8 results are rounded


def test_uint8_with_another_max_value_raises():
    with pytest.raises(ValueError, match="uint8 pixels are always on 0–255"):
        RandomConv(max_value=1.0)(pixels=uint8_images(2, 9, SIZE, SIZE))


def test_a_rejected_call_draws_nothing():
    transform, fresh = RandomConv(seed=0), RandomConv(seed=0)
    with pytest.raises(ValueError):
        transform(pixels=uint8_images(2, 9, SIZE, SIZE).float())
    x = uint8_images(2, 9, SIZE, SIZE)
    assert torch.equal(transform(pixels=x), fresh(pixels=x))


# -- 2. layout --------------------------------------------------------------------------------
@pytest.mark.parametrize("name", AUGMENTATIONS)
def test_channels_last_frames_raise_even_when_the_height_is_a_multiple_of_3(name):
    hwc = uint8_images(2, SIZE, SIZE, 9)  # SIZE % 3 == 0: the old channel check let this through
    with pytest.raises(ValueError, match="channels-last"):
        build(name)(pixels=hwc)


def test_channels_last_env_spec_raises_when_the_env_is_built():
    env = TransformedEnv(ContinuousActionConvMockEnvNumpy(), RandomShift())  # pixels [7, 7, 3]
    with pytest.raises(ValueError, match="ToTensorImage"):
        env.observation_spec


# -- 3. channel count -------------------------------------------------------------------------
def test_needs_rgb_is_declared_per_augmentation():
    declared = {name: build(name).needs_rgb for name in AUGMENTATIONS}
    assert declared == {name: rgb for name, (_, _, rgb) in AUGMENTATIONS.items()}


@pytest.mark.parametrize("name", ANY_CHANNELS)
@pytest.mark.parametrize("channels", [1, 4])
def test_any_channel_count_acts_on_each_channel_alone(name, channels):
    transform = build(name, seed=0)
    x = uint8_images(3, channels, SIZE, SIZE)
    params = transform.make_params(x)
    out = transform.apply(x, params)
    assert out.shape == (3, channels, out_size(name), out_size(name)) and out.dtype == torch.uint8
    for c in range(channels):  # the definition of "needs no RGB": channel c depends on channel c only
        one = {k: v[:, c : c + 1] if v.shape == x.shape else v for k, v in params.items()}
        assert torch.equal(transform.apply(x[:, c : c + 1], one), out[:, c : c + 1])
    assert build(name, seed=0)(pixels=x).shape == out.shape


@pytest.mark.parametrize("name", ["shift", "frequency", "noise"])
def test_grayscale_frame_stack_pipeline(name):
    """TorchRL's GrayScale() then CatFrames(4): 4 gray channels, the Atari-style DrQ input."""
    env = TransformedEnv(ContinuousActionConvMockEnv(pixel_shape=[3, SIZE, SIZE]))
    env.append_transform(GrayScale(in_keys=["pixels"]))
    env.append_transform(ClipTransform(in_keys=["pixels"], low=0.0, high=1.0))  # the mock's N(0, 1) into [0, 1]
    env.append_transform(CatFrames(4, dim=-3, in_keys=["pixels"]))
    env.append_transform(build(name))
    check_env_specs(env)
    assert env.rollout(3)["pixels"].shape == (3, 4, SIZE, SIZE)


@pytest.mark.parametrize("name", RGB_ONLY)
def test_rgb_augmentations_say_why_they_need_3k_channels(name):
    with pytest.raises(ValueError, match=r"RGB.*3·k channels.*GrayScale"):
        build(name)(pixels=uint8_images(2, 4, SIZE, SIZE))


# -- 4. constructor arguments -----------------------------------------------------------------
@pytest.mark.parametrize(
    "cls, kwargs, argument",
    [
        (RandomFrequencyMask, {"max_width": -0.1}, "max_width"),
        (RandomFrequencyMask, {"max_width": math.nan}, "max_width"),
        (RandomFrequencyMask, {"max_low": -0.1}, "max_low"),
        (RandomFrequencyMask, {"max_low": 0.7}, "max_low"),
        (RandomFrequencyMask, {"p": 1.5}, "p"),
        (RandomFrequencyMask, {"p": math.nan}, "p"),
        (RandomFrequencyMask, {"per_sample": "yes"}, "per_sample"),
        (RandomFrequencyMask, {"fill": "blur"}, "fill"),
        (RandomShift, {"pad": -1}, "pad"),
        (RandomShift, {"pad": 2.5}, "pad"),
        (RandomShift, {"pad": ["pixels"]}, "pad"),
        (RandomCrop, {"size": 0}, "size"),
        (RandomCrop, {"size": (84,)}, "size"),
        (RandomCrop, {"size": 84.5}, "size"),
        (CenterCrop, {"size": (84, -1)}, "size"),
        (RandomOverlay, {"alpha": 1.5}, "alpha"),
        (RandomOverlay, {"alpha": math.nan}, "alpha"),
        (RandomOverlay, {"images": 3}, "images"),
        (RandomColorJitter, {"brightness": -0.1}, "brightness"),
        (RandomColorJitter, {"contrast": math.inf}, "contrast"),
        (RandomColorJitter, {"saturation": "0.4"}, "saturation"),
        (RandomColorJitter, {"hue": 0.6}, "hue"),
        (RandomColorJitter, {"hue": -0.1}, "hue"),
        (PixelCorruption, {"severity": 0}, "severity"),
        (PixelCorruption, {"severity": 2.5}, "severity"),
        (PixelCorruption, {"severity": True}, "severity"),
        (PixelCorruption, {"corruption": "fog"}, "corruption"),
        (RandomConv, {"max_value": 0}, "max_value"),
        (RandomConv, {"max_value": "255"}, "max_value"),
        (RandomShift, {"seed": "0"}, "seed"),
        (RandomShift, {"seed": 1.5}, "seed"),
        (RandomShift, {"in_keys": ["a", "b"], "out_keys": ["c"]}, "out_keys"),
    ],
)
def test_invalid_constructor_arguments_raise_naming_the_argument(cls, kwargs, argument):
    with pytest.raises((TypeError, ValueError), match=argument):
        cls(**kwargs)


def test_set_seed_checks_its_argument():
    with pytest.raises(TypeError, match="seed"):
        RandomShift().set_seed("1")


# -- 5. positional traps ----------------------------------------------------------------------
@pytest.mark.parametrize("folder", ["/data/places365", Path("/data/places365")])
def test_overlay_folder_passed_as_alpha_says_pass_images(folder):
    with pytest.raises(TypeError, match=r"pass images="):
        RandomOverlay(folder)


@pytest.mark.parametrize(
    "call",
    [
        lambda: RandomOverlay(0.5, BANK),
        lambda: RandomFrequencyMask(0.5, 0.3),
    ],
)
def test_ambiguous_positional_arguments_are_keyword_only(call):
    with pytest.raises(TypeError, match="positional"):
        call()


def test_corruption_severity_passed_first_is_named():
    with pytest.raises(TypeError, match="severity="):
        PixelCorruption(3)


# -- 6. empty batches -------------------------------------------------------------------------
@pytest.mark.parametrize("name", AUGMENTATIONS)
@pytest.mark.parametrize("dtype", [torch.uint8, torch.float32])
def test_empty_batch_gives_an_empty_output(name, dtype):
    x = torch.zeros(0, 9, SIZE, SIZE, dtype=dtype)
    out = build(name, seed=0)(pixels=x)
    assert out.shape == (0, 9, out_size(name), out_size(name)) and out.dtype == dtype
    data = TensorDict(pixels=torch.zeros(2, 0, 9, SIZE, SIZE, dtype=dtype), batch_size=[2, 0])
    assert build(name, seed=0)(data)["pixels"].shape == (2, 0, 9, out_size(name), out_size(name))


# -- 7. specs ---------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["shift", "crop", "center_crop", "conv"])
def test_leaf_observation_spec_is_accepted_like_torchrl_image_transforms(name):
    leaf = Bounded(0, 255, shape=(2, 9, SIZE, SIZE), dtype=torch.uint8)
    out = build(name).transform_observation_spec(leaf)
    assert out.shape == (2, 9, out_size(name), out_size(name)) and out.dtype == torch.uint8
    assert leaf.shape == (2, 9, SIZE, SIZE), "the given spec is not edited"
    assert out.is_in(torch.zeros(out.shape, dtype=torch.uint8))
    unbounded = build(name).transform_observation_spec(Unbounded(shape=(9, SIZE, SIZE)))
    assert unbounded.shape == (9, out_size(name), out_size(name))


@pytest.mark.parametrize("value", [float("nan"), float("inf")])
def test_non_finite_float_pixels_are_named_as_such(value):
    x = torch.rand(2, 9, SIZE, SIZE)
    x[1, 4, 2, 3] = value
    with pytest.raises(ValueError, match="NaN or inf"):
        RandomShift(seed=0)(pixels=x)

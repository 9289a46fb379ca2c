"""TorchRL's transform test protocol, plus vigen's augmentation contract, for every augmentation.

TorchRL's ``TransformBase`` checklist (test/transforms/_transforms_common.py): single env, serial
and parallel envs with the transform inside, transform outside a batched env, no env, Compose,
as an ``nn.Module``, replay buffer, real env. vigen adds: dtype/shape/range, no in-place edits,
seeded reproducibility, per-sample draws, replayable parameters, pickling and ``repr``.
"""

from __future__ import annotations

import pickle
from functools import partial

import pytest
import torch
from tensordict import TensorDict
from torch import nn
from torchrl.data import LazyTensorStorage, ReplayBuffer, TensorDictReplayBuffer
from torchrl.envs import ClipTransform, Compose, ParallelEnv, SerialEnv, TransformedEnv
from torchrl.envs.utils import check_env_specs
from torchrl.testing.mocking_classes import ContinuousActionConvMockEnv

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

SIZE, CROP = 16, 12
BANK = ImageBank.builtin(size=SIZE)  # loaded once for the module; RandomOverlay() alone loads its own

class RotateShift(AugmentationChain):
    """DMC-GB2's rotate_shift at this test's size (a chain with default arguments, for the shared checks)."""

    def __init__(self, **kwargs):
        super().__init__([RandomRotate(180), RandomShift(pad=2)], **kwargs)


class RotateOrConv(RandomChoice):
    """One of a geometric and a colour augmentation per sample (DMC-GB2's compose_augs)."""

    def __init__(self, **kwargs):
        super().__init__([RandomRotate(180), RandomConv()], **kwargs)


# name -> (class, constructor kwargs); crops cut CROP×CROP windows out of SIZE×SIZE frames.
AUGMENTATIONS = {
    "shift": (RandomShift, {}),
    "overlay": (RandomOverlay, {"images": BANK}),
    "conv": (RandomConv, {}),
    "frequency": (RandomFrequencyMask, {}),
    "frequency_per_sample_noise": (RandomFrequencyMask, {"per_sample": True, "fill": "noise", "p": 1.0, "max_width": 0.2}),
    "crop": (RandomCrop, {"size": CROP}),
    "center_crop": (CenterCrop, {"size": CROP}),
    "color_jitter": (RandomColorJitter, {}),
    "noise": (PixelCorruption, {"corruption": "gaussian_noise", "severity": 5}),
    "blur": (PixelCorruption, {"corruption": "gaussian_blur", "severity": 5}),
    "jpeg": (PixelCorruption, {"corruption": "jpeg_compression", "severity": 5}),
    "contrast": (PixelCorruption, {"corruption": "contrast", "severity": 5}),
    "brightness": (PixelCorruption, {"corruption": "brightness", "severity": 5}),
    "rotate": (RandomRotate, {}),
    "rotate_shift": (RotateShift, {}),
    "rotate_or_conv": (RotateOrConv, {}),
    "shifted_overlay": (RandomShiftedOverlay, {"images": BANK}),
}
RANDOM = [name for name in AUGMENTATIONS if name not in ("center_crop", "blur", "jpeg", "contrast", "brightness")]


def build(name: str, **kwargs):
    cls, defaults = AUGMENTATIONS[name]
    return cls(**{**defaults, **kwargs})


def out_size(name: str) -> int:
    return CROP if "crop" in name else SIZE


def mock_env() -> TransformedEnv:
    """TorchRL's pixel mock env, its N(0, 1) pixels clipped to the contract's float range [0, 1]."""
    env = ContinuousActionConvMockEnv(pixel_shape=[9, SIZE, SIZE])
    return TransformedEnv(env, ClipTransform(in_keys=["pixels"], low=0.0, high=1.0))


def transformed_mock_env(name: str) -> TransformedEnv:
    return TransformedEnv(mock_env(), build(name))


def images(*batch: int, dtype: torch.dtype = torch.uint8, seed: int = 0) -> torch.Tensor:
    generator = torch.Generator().manual_seed(seed)
    if dtype == torch.uint8:
        return torch.randint(0, 256, (*batch, 9, SIZE, SIZE), dtype=dtype, generator=generator)
    return torch.rand((*batch, 9, SIZE, SIZE), generator=generator).to(dtype)


@pytest.mark.parametrize("name", AUGMENTATIONS)
class TestTorchRLProtocol:
    def test_single_trans_env_check(self, name):
        check_env_specs(transformed_mock_env(name))

    def test_single_trans_env_new_out_key(self, name):
        env = TransformedEnv(mock_env(), build(name, in_keys=["pixels"], out_keys=["pixels_aug"]))
        check_env_specs(env)
        assert env.observation_spec["pixels_aug"].shape[-1] == out_size(name)
        assert env.observation_spec["pixels"].shape[-1] == SIZE

    def test_serial_trans_env_check(self, name):
        env = SerialEnv(2, partial(transformed_mock_env, name))
        try:
            check_env_specs(env)
        finally:
            env.close()

    def test_parallel_trans_env_check(self, name):
        env = ParallelEnv(2, partial(transformed_mock_env, name), mp_start_method="fork")
        try:
            check_env_specs(env)
        finally:
            env.close()

    def test_trans_serial_env_check(self, name):
        env = TransformedEnv(SerialEnv(2, mock_env), build(name))
        try:
            check_env_specs(env)
        finally:
            env.close()

    def test_trans_parallel_env_check(self, name):
        env = TransformedEnv(ParallelEnv(2, mock_env, mp_start_method="fork"), build(name))
        try:
            check_env_specs(env)
        finally:
            env.close()

    @pytest.mark.parametrize("batch", [[], [2], [2, 4]])
    def test_transform_no_env(self, name, batch):
        transform = build(name, in_keys=["pixels", ("nested", "pixels")])
        data = TensorDict(
            {"pixels": images(*batch), ("nested", "pixels"): images(*batch, seed=1), "dont touch": images(*batch, seed=2)},
            batch_size=batch,
        )
        untouched = data["dont touch"].clone()
        out = transform(data)
        assert out["pixels"].shape == (*batch, 9, out_size(name), out_size(name))
        assert out["nested", "pixels"].shape == out["pixels"].shape
        assert torch.equal(out["dont touch"], untouched)

    def test_transform_compose(self, name):
        transform = Compose(build(name))
        data = TensorDict(pixels=images(3), batch_size=[3])
        assert transform(data.clone())["pixels"].shape == (3, 9, out_size(name), out_size(name))
        assert transform._call(data.clone())["pixels"].shape == (3, 9, out_size(name), out_size(name))

    def test_transform_model(self, name):
        model = nn.Sequential(build(name), nn.Identity())
        out = model(TensorDict(pixels=images(3), batch_size=[3]))
        assert out["pixels"].shape == (3, 9, out_size(name), out_size(name))

    @pytest.mark.parametrize("rb_class", [ReplayBuffer, TensorDictReplayBuffer])
    def test_transform_rb(self, name, rb_class):
        rb = rb_class(storage=LazyTensorStorage(10), batch_size=4)
        rb.append_transform(build(name, in_keys=["pixels", ("next", "pixels")], seed=0))
        frames = images(10)
        rb.extend(TensorDict({"pixels": frames, ("next", "pixels"): frames.clone()}, batch_size=[10]))
        sample = rb.sample()
        assert sample["pixels"].shape == (4, 9, out_size(name), out_size(name))
        assert sample["pixels"].dtype == torch.uint8
        if name in RANDOM:
            assert not torch.equal(sample["pixels"], sample["next", "pixels"]), "obs and next obs need their own draws"
        stored = rb[:3]  # indexing hands the transform views of the storage
        assert stored["pixels"].shape[-1] == out_size(name)
        assert torch.equal(rb.storage[:10]["pixels"], frames), "the storage must never be modified"

    def test_transform_inverse(self, name):
        pytest.skip("image augmentations have no inverse")


@pytest.mark.render
@pytest.mark.parametrize("name", ["shift", "overlay", "conv", "frequency", "crop", "color_jitter"])
def test_transform_env_dm_control(name):
    from vigen.envs import make_env
    from vigen.rendering import RenderSettings

    transform = build(name, size=24) if name == "crop" else build(name)
    env = TransformedEnv(make_env("dmc/walker-walk", seed=0, image_size=32, render_settings=RenderSettings.fast()), transform)
    reset = env.reset()
    side = 24 if name == "crop" else 32
    assert reset["pixels"].shape == (9, side, side) and reset["pixels"].dtype == torch.uint8
    rollout = env.rollout(4)
    assert rollout["pixels"].shape == (4, 9, side, side)
    check_env_specs(env)


@pytest.mark.parametrize("name", AUGMENTATIONS)
class TestAugmentationContract:
    @pytest.mark.parametrize("dtype", [torch.uint8, torch.float32])
    def test_dtype_shape_range_and_no_in_place(self, name, dtype):
        x = images(5, dtype=dtype)
        before = x.clone()
        y = build(name, seed=0)(pixels=x)
        assert torch.equal(x, before), "the input must not be modified"
        assert y.dtype == dtype and y.shape == (5, 9, out_size(name), out_size(name))
        white = 255 if dtype == torch.uint8 else 1.0
        assert y.min() >= 0 and y.max() <= white

    def test_float_on_the_0_255_scale(self, name):
        y = build(name, seed=0, max_value=255)(pixels=images(4).float())
        assert y.dtype == torch.float32 and y.max() <= 255 and y.max() > 1

    def test_same_seed_same_output(self, name):
        x = images(8)
        assert torch.equal(build(name, seed=3)(pixels=x), build(name, seed=3)(pixels=x))

    def test_different_seeds_differ(self, name):
        if name not in RANDOM:
            pytest.skip("deterministic transform")
        x = images(8)
        assert not torch.equal(build(name, seed=3)(pixels=x), build(name, seed=4)(pixels=x))

    def test_per_sample_draws(self, name):
        if name not in RANDOM or name == "frequency":
            pytest.skip("deterministic, or one draw per batch by design (RL-ViGen's SRM)")
        x = images(1).expand(16, 9, SIZE, SIZE)
        y = build(name, seed=0)(pixels=x)
        distinct = {tuple(y[i].flatten().tolist()) for i in range(16)}
        assert len(distinct) > 8, "identical inputs should get different parameters"

    def test_params_replay_and_batched_equals_per_sample(self, name):
        transform = build(name, seed=0)
        x = images(6).reshape(6, 9, SIZE, SIZE)
        params = transform.make_params(x)
        y = transform.apply(x, params)
        assert torch.equal(transform.apply(x, params), y)
        for i in range(6):
            one = {key: value[i : i + 1] for key, value in params.items()}
            assert torch.allclose(transform.apply(x[i : i + 1], one).float(), y[i : i + 1].float(), atol=1)

    def test_pickle_continues_the_stream(self, name):
        transform = build(name, seed=5)
        x = images(4)
        transform(pixels=x)
        copy = pickle.loads(pickle.dumps(transform))
        assert torch.equal(copy(pixels=x), transform(pixels=x))

    def test_clone_continues_independently(self, name):
        transform = build(name, seed=5)
        x = images(4)
        clone = transform.clone()
        assert torch.equal(clone(pixels=x), transform(pixels=x))

    def test_defaults_and_repr(self, name):
        cls, _ = AUGMENTATIONS[name]
        text = repr(cls())
        assert text.startswith(f"{cls.__name__}(") and text.endswith(")") and "in_keys=['pixels']" in text


@pytest.mark.parametrize(
    "bad, error, match",
    [
        (torch.zeros(2, 9, SIZE, SIZE, dtype=torch.int64), TypeError, "uint8 or floating-point"),
        (torch.zeros(2, SIZE, SIZE, 9, dtype=torch.uint8), ValueError, "ToTensorImage"),
        (torch.zeros(SIZE, SIZE), ValueError, "channels-first"),
    ],
)
def test_bad_input_errors(bad, error, match):
    with pytest.raises(error, match=match):
        RandomShift()(pixels=bad)


def test_crop_larger_than_image():
    with pytest.raises(ValueError, match="render larger"):
        RandomCrop(84)(pixels=images(2))


def walker_with_augmentations(seed: int) -> TransformedEnv:
    from vigen.envs import make_env
    from vigen.rendering import RenderSettings

    env = make_env("dmc/walker-walk", seed=seed, image_size=32, render_settings=RenderSettings.fast())
    return TransformedEnv(env, Compose(RandomShift(), RandomOverlay(images=BANK), RandomFrequencyMask(per_sample=True)))


@pytest.mark.render
@pytest.mark.slow
def test_inside_spawned_parallel_env_workers():
    env = ParallelEnv(2, [partial(walker_with_augmentations, 0), partial(walker_with_augmentations, 1)])
    try:
        check_env_specs(env)
        env.set_seed(0)
        rollout = env.rollout(3)
        assert rollout["pixels"].shape == (2, 3, 9, 32, 32) and rollout["pixels"].dtype == torch.uint8
    finally:
        env.close()

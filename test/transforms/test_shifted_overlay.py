"""SimGRL's shifted random overlay against crops computed by hand, and vigen's augmentation contract."""

from __future__ import annotations

import pickle

import pytest
import torch
from tensordict import TensorDict
from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs import ClipTransform, TransformedEnv
from torchrl.envs.utils import check_env_specs
from torchrl.testing.mocking_classes import ContinuousActionConvMockEnv

from vigen.transforms import ImageBank, RandomShiftedOverlay
from vigen.transforms.augmentations.shifted_overlay import shifted_windows

SIZE = 16
BANK = ImageBank.procedural(8, size=64)


def _images(*batch: int, dtype: torch.dtype = torch.uint8, seed: int = 0, channels: int = 9) -> torch.Tensor:
    generator = torch.Generator().manual_seed(seed)
    if dtype == torch.uint8:
        return torch.randint(0, 256, (*batch, channels, SIZE, SIZE), dtype=dtype, generator=generator)
    return torch.rand((*batch, channels, SIZE, SIZE), generator=generator).to(dtype)


def _tiny_bank(side: int) -> ImageBank:
    """Two images of exactly the size the overlay asks for, so no resize happens."""
    generator = torch.Generator().manual_seed(1)
    return ImageBank(torch.randint(0, 256, (2, 3, side, side), dtype=torch.uint8, generator=generator))


# -- the formula -----------------------------------------------------------------------------------
def test_each_frame_gets_its_shifted_crop_by_hand():
    """Frame f of sample n: 0.5·x + 0.5·I_n[p + f·dy : p + f·dy + H, p + f·dx : p + f·dx + W], p = k·max_shift."""
    height = width = 4
    frames, max_shift = 3, 2
    pad = frames * max_shift  # 6: the images are 16×16
    bank = _tiny_bank(height + 2 * pad)
    overlay = RandomShiftedOverlay(alpha=0.5, max_shift=max_shift, images=bank)
    x = torch.rand(2, 9, height, width)
    params = {"index": torch.tensor([1, 0]), "shift": torch.tensor([[2, -1], [-2, 1]])}
    out = overlay.apply(x, params)
    image = bank.images.float() / 255
    for n, (index, (dy, dx)) in enumerate(zip([1, 0], [(2, -1), (-2, 1)])):
        for f in range(frames):
            top, left = pad + f * dy, pad + f * dx
            crop = image[index, :, top : top + height, left : left + width]
            assert torch.allclose(out[n, 3 * f : 3 * f + 3], 0.5 * x[n, 3 * f : 3 * f + 3] + 0.5 * crop, atol=1e-6), (n, f)
    uint8 = (x * 255).round().to(torch.uint8)
    got = overlay.apply(uint8, params)
    assert got.dtype == torch.uint8
    for n, (index, (dy, dx)) in enumerate(zip([1, 0], [(2, -1), (-2, 1)])):
        for f in range(frames):
            top, left = pad + f * dy, pad + f * dx
            crop = bank.images[index, :, top : top + height, left : left + width].float()
            expected = torch.floor((uint8[n, 3 * f : 3 * f + 3].float() + crop) / 2 + 0.5)  # rounded half up
            assert torch.equal(got[n, 3 * f : 3 * f + 3].float(), expected), (n, f)


def test_simgrls_offsets_on_84_pixel_stacks():
    """Three 84×84 frames, SRO_l = 6: a 120×120 image, windows at (18 + f·dy, 18 + f·dx)."""
    rows = torch.arange(120.0)[:, None].expand(120, 120)
    cols = torch.arange(120.0)[None, :].expand(120, 120)
    image = torch.stack([rows, cols, rows * 0])[None]  # each pixel holds its own (row, col)
    windows = shifted_windows(image, torch.tensor([[-6, 5]]), frames=3, pad=18, height=84, width=84)
    assert windows.shape == (1, 3, 3, 84, 84)
    corners = [(int(windows[0, f, 0, 0, 0]), int(windows[0, f, 1, 0, 0])) for f in range(3)]
    assert corners == [(18, 18), (12, 23), (6, 28)]
    assert int(windows[0, 2, 0, -1, 0]) == 6 + 83 and int(windows[0, 2, 1, 0, -1]) == 28 + 83


def test_frames_differ_and_zero_shift_is_a_still_overlay():
    overlay = RandomShiftedOverlay(max_shift=3, images=BANK)
    black = torch.zeros(1, 9, SIZE, SIZE, dtype=torch.uint8)
    moving = overlay.apply(black, {"index": torch.tensor([2]), "shift": torch.tensor([[3, 1]])})
    assert not torch.equal(moving[:, 0:3], moving[:, 3:6]) and not torch.equal(moving[:, 3:6], moving[:, 6:9])
    still = overlay.apply(black, {"index": torch.tensor([2]), "shift": torch.tensor([[0, 0]])})
    assert torch.equal(still[:, 0:3], still[:, 3:6]) and torch.equal(still[:, 3:6], still[:, 6:9])
    assert torch.equal(still[:, 0:3], moving[:, 0:3]), "the oldest frame always sees the central window"


def test_shifts_are_drawn_per_sample_on_the_whole_range():
    overlay = RandomShiftedOverlay(max_shift=2, images=BANK, seed=0)
    params = overlay.make_params(_images(400))
    assert params["index"].shape == (400,) and params["shift"].shape == (400, 2)
    assert set(params["shift"].flatten().tolist()) == {-2, -1, 0, 1, 2}
    assert set(params["index"].tolist()) == set(range(len(BANK)))


def test_shift_beyond_max_shift_is_refused():
    overlay = RandomShiftedOverlay(max_shift=1, images=BANK)
    with pytest.raises(ValueError, match="max_shift=1"):
        overlay.apply(_images(1), {"index": torch.tensor([0]), "shift": torch.tensor([[2, 0]])})


@pytest.mark.parametrize(
    "kwargs, error, match",
    [({"alpha": 1.5}, ValueError, "alpha"), ({"max_shift": -1}, ValueError, "max_shift"),
     ({"max_shift": 2.5}, TypeError, "max_shift"), ({"alpha": "folder"}, TypeError, "images=")],
)
def test_bad_arguments_are_explained(kwargs, error, match):
    with pytest.raises(error, match=match):
        RandomShiftedOverlay(**kwargs)


def test_needs_rgb_stacks():
    with pytest.raises(ValueError, match="3·k channels"):
        RandomShiftedOverlay(images=BANK)(pixels=_images(2, channels=4))


# -- the augmentation contract ---------------------------------------------------------------------
@pytest.mark.parametrize("dtype", [torch.uint8, torch.float32])
def test_dtype_shape_range_and_no_in_place(dtype):
    x = _images(5, dtype=dtype)
    before = x.clone()
    y = RandomShiftedOverlay(images=BANK, seed=0)(pixels=x)
    assert torch.equal(x, before) and y.dtype == dtype and y.shape == x.shape
    assert y.min() >= 0 and y.max() <= (255 if dtype == torch.uint8 else 1.0)


def test_float_on_the_0_255_scale_matches_uint8():
    x = _images(4)
    uint8 = RandomShiftedOverlay(images=BANK, seed=0)(pixels=x)
    floats = RandomShiftedOverlay(images=BANK, seed=0, max_value=255)(pixels=x.float())
    assert floats.dtype == torch.float32 and (floats - uint8.float()).abs().max() <= 0.5


def test_seeded_replayable_and_per_sample():
    x = _images(8)
    a = RandomShiftedOverlay(images=BANK, seed=3)
    assert torch.equal(a(pixels=x), RandomShiftedOverlay(images=BANK, seed=3)(pixels=x))
    assert not torch.equal(RandomShiftedOverlay(images=BANK, seed=3)(pixels=x), RandomShiftedOverlay(images=BANK, seed=4)(pixels=x))
    params = a.make_params(x)
    y = a.apply(x, params)
    assert torch.equal(a.apply(x, params), y)
    for i in range(8):
        one = {key: value[i : i + 1] for key, value in params.items()}
        assert torch.equal(a.apply(x[i : i + 1], one), y[i : i + 1]), "batched equals per sample"
    same = _images(1).expand(16, 9, SIZE, SIZE)
    out = RandomShiftedOverlay(images=BANK, seed=0)(pixels=same)
    assert len({tuple(out[i].flatten().tolist()) for i in range(16)}) > 8


def test_pickle_and_clone_continue_the_stream():
    transform = RandomShiftedOverlay(images=BANK, seed=5)
    x = _images(4)
    transform(pixels=x)
    copy = pickle.loads(pickle.dumps(transform))
    clone = transform.clone()
    expected = transform(pixels=x)
    assert torch.equal(copy(pixels=x), expected) and torch.equal(clone(pixels=x), expected)


def test_defaults_and_repr():
    text = repr(RandomShiftedOverlay())
    assert text == "RandomShiftedOverlay(alpha=0.5, max_shift=6, images=builtin, in_keys=['pixels'])"
    assert RandomShiftedOverlay().needs_rgb


def test_in_an_env_and_a_replay_buffer():
    env = TransformedEnv(ContinuousActionConvMockEnv(pixel_shape=[9, SIZE, SIZE]), ClipTransform(in_keys=["pixels"], low=0.0, high=1.0))
    env.append_transform(RandomShiftedOverlay(images=BANK, seed=0))
    check_env_specs(env)
    buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(10), batch_size=4)
    buffer.append_transform(RandomShiftedOverlay(images=BANK, in_keys=["pixels", ("next", "pixels")], seed=0))
    frames = _images(10)
    buffer.extend(TensorDict({"pixels": frames, ("next", "pixels"): frames.clone()}, batch_size=[10]))
    sample = buffer.sample()
    assert sample["pixels"].shape == (4, 9, SIZE, SIZE) and sample["pixels"].dtype == torch.uint8
    assert not torch.equal(sample["pixels"], sample["next", "pixels"]), "obs and next obs get their own draws"
    assert torch.equal(buffer.storage[:10]["pixels"], frames), "the storage is never modified"

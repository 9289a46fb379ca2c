"""DMC-GB2's geometric augmentations and compositions, checked against their definitions."""

from __future__ import annotations

import contextlib
import math

import pytest
import torch
import torch.nn.functional as F

from vigen.transforms import (
    DMCGB2_AUGMENTATIONS,
    AugmentationChain,
    ImageBank,
    RandomChoice,
    RandomConv,
    RandomCrop,
    RandomOverlay,
    RandomRotate,
    RandomShift,
    dmcgb2_strong_augmentation,
)
from vigen.devices import accelerator_paths
from vigen.transforms.augmentations import functional

SIZE = 20


def pixels(batch: int = 4, channels: int = 9, size: int = SIZE, seed: int = 0) -> torch.Tensor:
    return torch.randint(0, 256, (batch, channels, size, size), dtype=torch.uint8, generator=torch.Generator().manual_seed(seed))


# -- rotation ---------------------------------------------------------------------------------
@pytest.mark.parametrize("quarters", [1, 2, -1])
def test_quarter_turns_equal_rot90_counter_clockwise(quarters):
    x = pixels()
    out = RandomRotate().apply(x, {"degrees": torch.full((4,), 90.0 * quarters)})
    assert torch.equal(out, torch.rot90(x, quarters, dims=(-2, -1)))


def test_angle_zero_is_the_identity():
    x = pixels()
    assert torch.equal(RandomRotate().apply(x, {"degrees": torch.zeros(4)}), x)
    floats = x.float() / 255
    assert torch.allclose(RandomRotate().apply(floats, {"degrees": torch.zeros(4)}), floats, atol=1e-6)


def test_a_turn_samples_the_input_at_the_rotated_pixel_centre():
    """out(p) = in(R(−θ)·p) about the centre, bilinear: a smooth image makes the check exact up to interpolation."""
    size, theta = 32, 30.0
    rows, cols = torch.meshgrid(torch.arange(size, dtype=torch.float64), torch.arange(size, dtype=torch.float64), indexing="ij")
    centre = (size - 1) / 2
    plane = lambda r, c: 0.3 + 0.01 * (c - centre) - 0.005 * (r - centre)  # noqa: E731  (linear: bilinear is exact)
    image = plane(rows, cols)[None, None]
    out = functional.rotate(image, torch.tensor([theta], dtype=torch.float64), 1.0)[0, 0]
    t = math.radians(theta)
    # counter-clockwise on screen (rows down): the source of output (r, c) is the point turned back by θ
    x, y = cols - centre, rows - centre
    src_c, src_r = centre + math.cos(t) * x - math.sin(t) * y, centre + math.sin(t) * x + math.cos(t) * y
    inside = (src_r >= 0) & (src_r <= size - 1) & (src_c >= 0) & (src_c <= size - 1)
    expected = plane(src_r, src_c)
    assert inside.sum() > 0.5 * size * size
    assert torch.allclose(out[inside], expected[inside], atol=1e-9)


def test_corners_left_empty_take_the_edge_not_black():
    x = torch.full((1, 3, SIZE, SIZE), 200, dtype=torch.uint8)
    out = RandomRotate().apply(x, {"degrees": torch.tensor([45.0])})
    assert torch.equal(out, x)


def test_every_frame_of_a_stack_turns_by_the_same_angle():
    x = pixels(batch=2)
    params = RandomRotate(seed=3).make_params(x)
    out = RandomRotate().apply(x, params)
    for frame in range(3):
        one = x[:, 3 * frame : 3 * frame + 3]
        assert torch.equal(out[:, 3 * frame : 3 * frame + 3], RandomRotate().apply(one, params))


def test_angles_are_uniform_in_the_range_per_sample_or_per_call():
    x = torch.zeros(4000, 3, 4, 4, dtype=torch.uint8)
    per_sample = RandomRotate(90, seed=0).make_params(x)["degrees"]
    assert per_sample.abs().max() <= 90 and per_sample.abs().max() > 89
    assert abs(per_sample.mean()) < 3 and abs(per_sample.std() - 90 / math.sqrt(3)) < 2  # U(−90, 90): std 90/√3
    per_call = RandomRotate(90, per_sample=False, seed=0).make_params(x)["degrees"]
    assert per_call.shape == (4000,) and torch.all(per_call == per_call[0])


def test_seeded_rotations_repeat_and_seeds_differ():
    x = pixels()
    assert torch.equal(RandomRotate(seed=1)(pixels=x), RandomRotate(seed=1)(pixels=x))
    assert not torch.equal(RandomRotate(seed=1)(pixels=x), RandomRotate(seed=2)(pixels=x))


@pytest.mark.parametrize("degrees", [-1, 181, float("nan")])
def test_bad_degrees_are_named(degrees):
    with pytest.raises(ValueError, match="degrees"):
        RandomRotate(degrees)


# -- DMC-GB2's shift is DrQ-v2's, with pad 16 -------------------------------------------------------
def dmcgb2_shift(x: torch.Tensor, shift: torch.Tensor, pad: int) -> torch.Tensor:
    """DMC-GB2's ``random_shift`` (DrQ-v2's grid_sample shift) for given integer shifts (x, y) in [0, 2·pad]."""
    n, _, h, _ = x.shape
    x = F.pad(x, (pad,) * 4, "replicate")
    eps = 1.0 / (h + 2 * pad)
    arange = torch.linspace(-1.0 + eps, 1.0 - eps, h + 2 * pad, dtype=x.dtype)[:h]
    arange = arange.unsqueeze(0).repeat(h, 1).unsqueeze(2)
    base_grid = torch.cat([arange, arange.transpose(1, 0)], dim=2).unsqueeze(0).repeat(n, 1, 1, 1)
    grid = base_grid + shift.to(x.dtype).reshape(n, 1, 1, 2) * 2.0 / (h + 2 * pad)
    return F.grid_sample(x, grid, padding_mode="zeros", align_corners=False)


def test_dmcgb2_shift_is_random_shift_with_pad_16():
    x = pixels(size=84)
    shift = dmcgb2_strong_augmentation("shift", seed=0)
    assert isinstance(shift, RandomShift) and shift.pad == 16
    params = shift.make_params(x)
    dy, dx = params["offsets"].unbind(-1)
    expected = dmcgb2_shift(x.double(), torch.stack([dx, dy], -1), 16)
    assert torch.equal(shift.apply(x, params), expected.round().to(torch.uint8))


# -- compositions -----------------------------------------------------------------------------------
def test_a_chain_applies_its_members_in_order_with_their_draws():
    x = pixels()
    chain = AugmentationChain([RandomRotate(), RandomShift(pad=3)], seed=0)
    params = chain.make_params(x)
    rotate, shift = chain.members
    expected = shift.apply(rotate.apply(x, {"degrees": params["0.degrees"]}), {"offsets": params["1.offsets"]})
    assert torch.equal(chain.apply(x, params), expected)
    fresh = [AugmentationChain([RandomRotate(), RandomShift(pad=3)], seed=0) for _ in range(2)]
    assert torch.equal(fresh[0](pixels=x), fresh[1](pixels=x))
    assert repr(fresh[0]) == "AugmentationChain([RandomRotate(degrees=180), RandomShift(pad=3)], in_keys=['pixels'], seed=0)"


@pytest.mark.parametrize("path", ["cpu", "accelerator"])
def test_a_choice_gives_each_sample_its_members_output(path):
    """On the CPU a member augments the samples that chose it; on an accelerator's path every member augments the batch
    and each sample keeps its own member's output (no mask index): either way, sample i is its member's image of x[i]."""
    x = pixels(batch=12)
    choice = RandomChoice([RandomRotate(), RandomConv(), RandomShift(pad=2)], seed=0)
    params = choice.make_params(x)
    with accelerator_paths() if path == "accelerator" else contextlib.nullcontext():
        out = choice.apply(x, params)
    for i in range(12):
        member = choice.members[int(params["choice"][i])]
        index = int(params["choice"][i])
        own = {key.split(".", 1)[1]: value[i : i + 1] for key, value in params.items() if key.startswith(f"{index}.")}
        assert torch.equal(out[i : i + 1], member.apply(x[i : i + 1], own))


def test_a_choice_draws_its_members_uniformly():
    x = torch.zeros(6000, 3, 4, 4, dtype=torch.uint8)
    choice = RandomChoice([RandomRotate(), RandomShift(pad=1), RandomConv()], seed=0).make_params(x)["choice"]
    counts = torch.bincount(choice, minlength=3).float() / 6000
    assert torch.all((counts - 1 / 3).abs() < 0.03)  # 5 standard errors


@pytest.mark.parametrize("dtype", [torch.uint8, torch.float32])
def test_dmcgb2_all_choice_never_reads_a_value_back_on_an_accelerator_and_gives_the_cpu_s_images(dtype, no_host_sync):
    """SADA's DMC-GB2 "all" choice (six members) on an accelerator's path: no torch call reads a value back to the host
    (the boolean-mask selection did, a synchronization per member on a GPU), and the images equal the CPU path's."""
    x = pixels(batch=24, size=84, seed=3)
    x = x if dtype == torch.uint8 else x.float() / 255
    choice = dmcgb2_strong_augmentation("all", seed=0)
    choice.prepare(x.shape, x.device)  # the overlay's image bank loads once, outside the update (as UpdateStep does)
    params = choice.make_params(x)
    assert set(params["choice"].tolist()) == set(range(6)), "every member chosen by some sample"
    expected = choice.apply(x, params)
    with no_host_sync():
        out = choice.apply(x, params)
        fresh = choice(pixels=x)  # drawing and applying together
    assert torch.equal(out, expected)
    assert fresh.shape == x.shape and fresh.dtype == dtype


def test_composite_seed_and_max_value_reach_the_members():
    chain = AugmentationChain([RandomRotate(), RandomShift()], seed=7, max_value=255)
    assert [member.max_value for member in chain.members] == [255, 255]
    assert len({member.seed for member in chain.members} | {chain.seed}) == 3
    x = pixels().float()
    assert torch.equal(chain(pixels=x), AugmentationChain([RandomRotate(), RandomShift()], seed=7, max_value=255)(pixels=x))
    assert chain.needs_rgb is False and RandomChoice([RandomRotate(), RandomConv()]).needs_rgb is True


@pytest.mark.parametrize(
    "members, error, match",
    [
        ([], TypeError, "non-empty list"),
        (RandomRotate(), TypeError, "non-empty list"),
        ([RandomRotate(), "shift"], TypeError, "ImageAugmentation"),
        ([RandomRotate(), RandomCrop(size=80)], ValueError, "changes the image size"),
    ],
)
def test_bad_members_are_named(members, error, match):
    with pytest.raises(error, match=match):
        AugmentationChain(members)


def test_dmcgb2_names_and_groups():
    full = dmcgb2_strong_augmentation("all", seed=0)
    assert isinstance(full, RandomChoice) and len(full.members) == len(DMCGB2_AUGMENTATIONS) == 6
    assert [type(m).__name__ for m in dmcgb2_strong_augmentation("geo").members] == ["RandomRotate", "RandomShift", "AugmentationChain"]
    conv_overlay = dmcgb2_strong_augmentation("conv_overlay")
    assert [type(m).__name__ for m in conv_overlay.members] == ["RandomConv", "RandomOverlay"]
    with pytest.raises(ValueError, match="Unknown DMC-GB2 augmentation 'flip'"):
        dmcgb2_strong_augmentation("flip")


def test_the_all_choice_keeps_uint8_and_shape_and_runs_in_a_loss():
    from vigen.losses import make_loss

    bank = ImageBank.procedural(4, size=SIZE)
    strong = RandomChoice([RandomRotate(), RandomShift(pad=4), RandomConv(), RandomOverlay(images=bank)])
    x = pixels()
    out = strong(pixels=x)
    assert out.dtype == torch.uint8 and out.shape == x.shape
    loss = make_loss("sada", (9, 84, 84), action_dim=2, hidden_dim=16, feature_dim=8, strong_augmentation=strong, seed=0)
    views = [loss.augment(pixels(size=84), loss.strong_augmentation) for _ in range(2)]
    loss.seed_augmentations(0)
    again = [loss.augment(pixels(size=84), loss.strong_augmentation) for _ in range(2)]
    assert all(torch.equal(a, b) for a, b in zip(views, again))

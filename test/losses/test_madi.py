"""MaDi (https://arxiv.org/abs/2312.15339): the masker's formula and SVEA's loss behind it, by hand."""

from __future__ import annotations

import copy

import pytest
import torch
import torch.nn.functional as F
from tensordict.nn import InteractionType, set_interaction_type
from torchrl.data import Bounded
from torchrl.objectives import SoftUpdate

from loss_helpers import SIZE, dmcgb_squashed_sample, make_batch, make_loss
from vigen.losses import ALGOS, SquashedGaussian, SVEALoss, build_loss
from vigen.losses import make_loss as make_paper_loss
from vigen.models import Critic, DrQv2Encoder, GaussianActor, MaDiMasker, SharedCNN
from vigen.transforms import ImageAugmentation, RandomOverlay

pytestmark = pytest.mark.filterwarnings("ignore:No target network updater")
GAMMA = 0.9  # what loss_helpers gives the value estimator


class Invert(ImageAugmentation):
    """A deterministic strong view, so that the hand computation sees the same pixels."""

    def make_params(self, images):
        return {}

    def apply(self, images, params):
        return (self.white(images) - images).to(images.dtype)


def _masks_by_hand(masker: MaDiMasker, unit_frames: torch.Tensor) -> torch.Tensor:
    """sigmoid(conv3(relu(conv2(relu(conv1(frame)))))) with 3×3 kernels, stride 1, zero padding 1."""
    conv1, conv2, conv3 = (m for m in masker.modules() if isinstance(m, torch.nn.Conv2d))
    x = F.relu(F.conv2d(unit_frames, conv1.weight, conv1.bias, padding=1))
    x = F.relu(F.conv2d(x, conv2.weight, conv2.bias, padding=1))
    return torch.sigmoid(F.conv2d(x, conv3.weight, conv3.bias, padding=1))


# -- the masker ------------------------------------------------------------------------------------
def test_masker_has_madis_three_layers():
    masker = MaDiMasker()
    convs = [m for m in masker.modules() if isinstance(m, torch.nn.Conv2d)]
    shapes = [(c.in_channels, c.out_channels, c.kernel_size, c.stride, c.padding) for c in convs]
    assert shapes == [(3, 32, (3, 3), (1, 1), (1, 1)), (32, 32, (3, 3), (1, 1), (1, 1)), (32, 1, (3, 3), (1, 1), (1, 1))]
    # 3·32·9 + 32 + 32·32·9 + 32 + 32·9 + 1
    assert sum(p.numel() for p in masker.parameters()) == 896 + 9248 + 289
    assert isinstance(list(masker.net)[-1], torch.nn.Sigmoid)


def test_masker_multiplies_each_frame_by_its_own_mask():
    torch.manual_seed(0)
    masker = MaDiMasker(num_filters=4)
    pixels = torch.randint(0, 256, (2, 9, 6, 6), dtype=torch.uint8)
    unit = pixels.float() / 255
    out = masker(pixels)
    for frame in range(3):
        rgb = unit[:, 3 * frame : 3 * frame + 3]
        mask = _masks_by_hand(masker, rgb)  # [2, 1, 6, 6]: one mask for the frame's three channels
        assert torch.allclose(out[:, 3 * frame : 3 * frame + 3], rgb * mask, atol=1e-6)
        assert torch.allclose(masker.masks(pixels)[:, frame], mask, atol=1e-6)
    masks = masker.masks(pixels)
    assert masks.shape == (2, 3, 1, 6, 6) and bool(((masks > 0) & (masks < 1)).all())
    assert not torch.allclose(masks[:, 0], masks[:, 1]), "frames with other pixels get other masks"


def test_masker_keeps_the_float_scale():
    """uint8, floats on 0–1 and floats on 0–255 (max_value=255) are the same frames: the same masks."""
    torch.manual_seed(0)
    masker = MaDiMasker(num_filters=4)
    pixels = torch.randint(0, 256, (2, 6, 5, 5), dtype=torch.uint8)
    unit = masker(pixels)
    assert unit.dtype == torch.float32 and unit.max() <= 1
    assert torch.allclose(masker(pixels.float() / 255), unit, atol=1e-6)
    masker.max_value = 255
    assert torch.allclose(masker(pixels.float()), unit * 255, atol=1e-4)
    assert torch.allclose(masker(pixels), unit * 255, atol=1e-4), "uint8 in, floats on the encoder's 0–255 scale out"
    with pytest.raises(ValueError, match="max_value=255"):
        MaDiMasker()(pixels.float())


def test_masker_masks_frames_independently_and_keeps_leading_dims():
    torch.manual_seed(0)
    masker = MaDiMasker(num_filters=4)
    pixels = torch.randint(0, 256, (2, 9, 6, 6), dtype=torch.uint8)
    changed = pixels.clone()
    changed[:, 6:] = 255 - changed[:, 6:]  # only the newest frame
    a, b = masker.masks(pixels), masker.masks(changed)
    assert torch.equal(a[:, :2], b[:, :2]) and not torch.allclose(a[:, 2], b[:, 2])
    stacked = torch.stack([pixels, changed])  # [2, 2, 9, 6, 6]
    assert torch.allclose(masker(stacked)[1], masker(changed), atol=1e-6)


def test_masker_bad_input_is_explained():
    with pytest.raises(ValueError, match="frame_channels"):
        MaDiMasker()(torch.zeros(1, 4, 6, 6))
    with pytest.raises(ValueError, match="num_layers"):
        MaDiMasker(num_layers=1)
    with pytest.raises(ValueError, match="max_value"):
        MaDiMasker(max_value=0)
    assert MaDiMasker(frame_channels=1)(torch.rand(1, 3, 6, 6)).shape == (1, 3, 6, 6), "grayscale stacks"


# -- the loss --------------------------------------------------------------------------------------
ALPHA = 0.1  # the initial temperature


def _madi(**kwargs) -> SVEALoss:
    torch.manual_seed(0)
    return make_loss("madi", augmentation=None, strong_augmentation=Invert(), **kwargs)



def test_loss_is_sac_sveas_on_masked_views():
    """MaDi's update (DMC-GB's SVEA): 0.5·TD(M(s)) + 0.5·TD(M(s̃)) against the SAC target of M(next obs),
    the next action sampled on the online encoder and scored on the target encoder; SAC actor and α on M(s)."""
    loss = _madi()
    with torch.no_grad():  # a target encoder apart from the online one
        for value in loss.target_encoder_params.values(True, True):
            value.mul_(0.9)
    batch = make_batch()
    torch.manual_seed(4)
    out = loss(batch)
    masker, encoder, critic, actor = loss.input_mask, loss.encoder, loss.critic, loss.actor
    target_encoder = copy.deepcopy(encoder)
    with torch.no_grad():
        for param, value in zip(target_encoder.parameters(), loss.target_encoder_params.values(True, True)):
            param.copy_(value)
    torch.manual_seed(4)
    with torch.no_grad():
        next_masked = masker(batch["next", "pixels"])
        next_action, next_log_prob = dmcgb_squashed_sample(*actor(encoder(next_masked)))
        with loss.target_critic_params.to_module(critic):
            next_value = torch.min(*critic(target_encoder(next_masked), next_action)) - ALPHA * next_log_prob
        target = batch["next", "reward"] + GAMMA * next_value
        hidden = encoder(masker(batch["pixels"]))
        strong = encoder(masker(255 - batch["pixels"]))
        weak_td = F.mse_loss(critic(hidden, batch["action"])[0], target) + F.mse_loss(critic(hidden, batch["action"])[1], target)
        strong_td = F.mse_loss(critic(strong, batch["action"])[0], target) + F.mse_loss(critic(strong, batch["action"])[1], target)
        action, log_prob = dmcgb_squashed_sample(*actor(hidden))
        actor_q = torch.min(*critic(hidden, action))
    assert torch.allclose(out["target_mean"], target.mean(), atol=1e-6)
    assert torch.allclose(out["loss_critic"], 0.5 * weak_td + 0.5 * strong_td, atol=1e-6)
    assert torch.allclose(out["loss_actor"], (ALPHA * log_prob - actor_q).mean(), atol=1e-6)
    assert torch.allclose(out["loss_alpha"], (ALPHA * (-log_prob + 2)).mean(), atol=1e-6), "target entropy −|A|"
    unmasked = SVEALoss(encoder, actor, critic, sampler=SquashedGaussian(squash_epsilon=1e-6), augmentation=None,
                        strong_augmentation=Invert(), weak_weight=0.5, strong_weight=0.5, augment_next=False,
                        target_encoder=True)
    unmasked.make_value_estimator(gamma=GAMMA)
    unmasked.load_state_dict({k: v for k, v in loss.state_dict().items() if not k.startswith("input_mask")}, strict=False)
    torch.manual_seed(4)
    assert not torch.allclose(unmasked(batch)["loss_critic"], out["loss_critic"]), "the mask changes the loss"


def test_only_the_critic_loss_reaches_the_masker():
    loss = _madi()
    SoftUpdate(loss, tau=0.01)
    out = loss(make_batch())
    masker = list(loss.input_mask.parameters())
    loss.zero_grad(set_to_none=True)
    out["loss_actor"].backward(retain_graph=True)
    assert all(p.grad is None or not p.grad.any() for p in masker), "the actor reads detached features"
    out["loss_critic"].backward()
    assert all(p.grad is not None and p.grad.abs().sum() > 0 for p in masker)


def test_the_target_passes_through_the_masker_have_no_gradient():
    """Two masked passes without gradient (next obs, for the online and the target encoder), one with (both critic views)."""
    loss = _madi()
    calls = []
    loss.input_mask.register_forward_hook(lambda module, args, output: calls.append((args[0].shape[0], output.requires_grad)))
    loss(make_batch(batch=6))
    assert calls[:2] == [(6, False), (6, False)], "the target's passes come first, without gradient"
    assert all(grad for _, grad in calls[2:]) and sum(n for n, _ in calls[2:]) == 12, "weak and strong views"


def test_the_acting_policy_masks_its_pixels():
    loss = _madi()
    policy = loss.make_policy(Bounded(-1, 1, shape=(2,)))
    pixels = make_batch(batch=3)["pixels"]
    with set_interaction_type(InteractionType.DETERMINISTIC), torch.no_grad():
        action = policy(make_batch(batch=3).select("pixels"))["action"]
        expected = torch.tanh(loss.actor(loss.encoder(loss.input_mask(pixels)))[0])  # the squashed Gaussian's mean action
        unmasked = torch.tanh(loss.actor(loss.encoder(pixels))[0])
    assert torch.allclose(action, expected, atol=1e-6) and not torch.allclose(action, unmasked, atol=1e-4)


def test_the_masker_has_its_own_learning_rate_and_betas():
    loss = make_loss("madi")
    groups = loss.optimizer_groups(lr=3e-4)
    assert [g["lr"] for g in groups] == [3e-4, 1e-3] and groups[1]["betas"] == (0.9, 0.999)
    masker = {id(p) for p in loss.input_mask.parameters()}
    assert {id(p) for p in groups[1]["params"]} == masker
    assert not masker & {id(p) for p in groups[0]["params"]}
    assert {id(p) for g in groups for p in g["params"]} == {id(p) for p in loss.parameters()}
    other = make_loss("madi", param_groups={"input_mask": {"lr": 5e-4, "betas": (0.5, 0.999)}}).optimizer_groups(lr=1e-4)[1]
    assert other["lr"] == 5e-4 and other["betas"] == (0.5, 0.999)
    lr_only = make_loss("madi", param_groups={"input_mask": {"lr": 5e-4}}).optimizer_groups(lr=1e-4)[1]
    assert lr_only["lr"] == 5e-4 and lr_only["betas"] == (0.9, 0.999), "merged over MaDi's group"
    optimizer = torch.optim.Adam(groups)
    assert optimizer.param_groups[0]["betas"] == (0.9, 0.999)


def test_the_masker_takes_the_encoders_max_value():
    loss = make_loss("madi", max_value=255)
    assert loss.input_mask.max_value == 255 == loss.max_value
    encoder = DrQv2Encoder(9, max_value=255)
    features = encoder.output_dim(9, SIZE, SIZE)
    heads = GaussianActor(features, 2, hidden_dim=16, feature_dim=8), Critic(features, 2, feature_dim=8, hidden_dim=16)
    with pytest.raises(ValueError, match="max_value"):
        build_loss("madi", encoder, *heads, MaDiMasker(max_value=1.0))
    with pytest.raises(ValueError, match="max_value"):
        build_loss("madi", encoder, *heads, input_mask=MaDiMasker())  # a loss never changes what the caller passed
    assert build_loss("madi", encoder, *heads, MaDiMasker(max_value=255)).input_mask.max_value == 255
    with pytest.raises(TypeError, match="input_mask network"):
        build_loss("madi", encoder, *heads)  # MaDi without its masker would be SVEA
    with pytest.raises(ValueError, match="'lr'"):
        build_loss("madi", encoder, *heads, MaDiMasker(max_value=255), param_groups={"input_mask": {"lr": 0.0}})


def test_make_loss_builds_madi_on_dmcgbs_networks():
    assert ALGOS["madi"].loss is SVEALoss and ALGOS["madi"].sampler is SquashedGaussian
    loss = make_paper_loss("madi", (9, 44, 44), action_dim=2, hidden_dim=8, max_value=255)
    assert isinstance(loss, SVEALoss) and isinstance(loss.encoder, SharedCNN) and isinstance(loss.input_mask, MaDiMasker)
    assert loss.input_mask.max_value == 255 and not loss.encoder.centered, "DMC-GB's x / 255"
    assert isinstance(loss.actor, GaussianActor) and isinstance(loss.actor.trunk, torch.nn.Sequential), "its own projection"
    assert loss.scores_on_target_encoder and not loss.augment_next and loss.sampler.squash_epsilon == 1e-6, "DMC-GB's SVEA"
    assert isinstance(loss.strong_augmentation[0], RandomOverlay)


def test_masker_convolves_large_batches_in_passes_with_the_same_result():
    from vigen.models import masker as masker_module

    masker = MaDiMasker(num_filters=4)
    pixels = torch.randint(0, 256, (40, 9, 8, 8), dtype=torch.uint8, generator=torch.Generator().manual_seed(0))
    assert 40 * 3 > masker_module.FRAMES_PER_PASS
    frames = pixels.float().reshape(40 * 3, 3, 8, 8) / 255
    whole = masker.net(frames).reshape(40, 3, 1, 8, 8)
    torch.testing.assert_close(masker.masks(pixels), whole)

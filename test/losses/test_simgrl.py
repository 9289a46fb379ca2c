"""SimGRL (NeurIPS 2024, https://openreview.net/forum?id=0AumdfLzpK): per-frame encoder and loss, by hand."""

from __future__ import annotations

import copy

import pytest
import torch
import torch.nn.functional as F
from torch import nn

from loss_helpers import dmcgb_squashed_sample, make_batch, make_loss
from vigen.losses import ALGOS, SquashedGaussian, SVEALoss
from vigen.losses import make_loss as make_paper_loss
from vigen.models import PerFrameEncoder
from vigen.transforms import ImageBank, RandomShiftedOverlay

pytestmark = pytest.mark.filterwarnings("ignore:No target network updater")
GAMMA = 0.9  # what loss_helpers gives the value estimator
BANK = ImageBank.procedural(6, size=64)


def _convs(module: nn.Module) -> list[nn.Conv2d]:
    return [m for m in module.modules() if isinstance(m, nn.Conv2d)]


# -- the per-frame encoder -------------------------------------------------------------------------
def test_per_frame_encoder_has_simgrls_layers():
    """Per frame 3→16 (stride 2), 16→16, 16→16; stacked 48→32, then seven 32→32: eleven 3×3 convs."""
    encoder = PerFrameEncoder(9)
    frame = [(c.in_channels, c.out_channels, c.stride[0]) for c in _convs(encoder.frame_net)]
    stack = [(c.in_channels, c.out_channels, c.stride[0]) for c in _convs(encoder.stack_net)]
    assert frame == [(3, 16, 2), (16, 16, 1), (16, 16, 1)]
    assert stack == [(48, 32, 1)] + [(32, 32, 1)] * 7
    assert all(c.kernel_size == (3, 3) and c.padding == (0, 0) for c in _convs(encoder))
    kinds = [type(m).__name__ for m in (*encoder.frame_net, *encoder.stack_net)]
    assert kinds == ["Conv2d", "ReLU", "Conv2d", "ReLU", "Conv2d"] + ["ReLU", "Conv2d"] * 8, "no ReLU after the last conv"
    assert encoder.output_dim(9, 84, 84) == 32 * 21 * 21


def test_per_frame_encoder_encodes_each_frame_then_stacks_features():
    """features = stack_net(concat_f frame_net(frame_f / 255 − 0.5)), written out with F.conv2d."""
    torch.manual_seed(0)
    encoder = PerFrameEncoder(9, num_layers=4, frame_layers=2, frame_filters=4, channels=5)
    pixels = torch.randint(0, 256, (3, 9, 16, 16), dtype=torch.uint8)
    x = pixels.float() / 255 - 0.5
    a, b, c, d = _convs(encoder)
    per_frame = []
    for f in range(3):
        h = F.relu(F.conv2d(x[:, 3 * f : 3 * f + 3], a.weight, a.bias, stride=2))
        per_frame.append(F.conv2d(h, b.weight, b.bias))
    h = F.relu(F.conv2d(F.relu(torch.cat(per_frame, dim=1)), c.weight, c.bias))
    expected = F.conv2d(h, d.weight, d.bias).flatten(1)
    assert torch.allclose(encoder(pixels), expected, atol=1e-5)


def test_per_frame_encoder_pixel_contract():
    torch.manual_seed(0)
    encoder = PerFrameEncoder(9, num_layers=4, frame_layers=2, frame_filters=4, channels=5, chunk_size=2)
    pixels = torch.randint(0, 256, (5, 9, 16, 16), dtype=torch.uint8)
    whole = PerFrameEncoder(9, num_layers=4, frame_layers=2, frame_filters=4, channels=5, chunk_size=None)
    whole.load_state_dict(encoder.state_dict())
    reference = encoder(pixels)
    assert torch.allclose(whole(pixels), reference, atol=1e-6), "chunks change nothing"
    assert torch.allclose(encoder(pixels.float() / 255), reference, atol=1e-5)
    assert torch.allclose(encoder(pixels.reshape(1, 5, 9, 16, 16))[0], reference, atol=1e-6)
    with pytest.raises(ValueError, match="max_value=255"):
        encoder(pixels.float())
    encoder.max_value = 255
    assert torch.allclose(encoder(pixels.float()), reference, atol=1e-5)
    with pytest.raises(ValueError, match="in_channels=6"):
        encoder(pixels[:, :6])
    with pytest.raises(ValueError, match="frame_channels"):
        PerFrameEncoder(8)
    with pytest.raises(ValueError, match="num_layers"):
        PerFrameEncoder(9, num_layers=3, frame_layers=3)


# -- the loss --------------------------------------------------------------------------------------
ALPHA = 0.1  # the initial temperature



def test_default_strong_view_is_the_shifted_overlay():
    loss = make_loss("simgrl")
    (strong,) = loss.strong_augmentation
    assert isinstance(strong, RandomShiftedOverlay) and strong.alpha == 0.5 and strong.max_shift == 6
    assert float(loss.weak_weight) == float(loss.strong_weight) == 0.5
    assert loss.augment_next, "SimGRL samples with sample_drq: the next observation is shifted too"


def test_loss_is_half_clean_plus_half_shifted_overlay_on_sac():
    """SimGRL's update: 0.5·[MSE(Q1(s̃), y) + MSE(Q2(s̃), y)] + 0.5·[MSE(Q1(s), y) + MSE(Q2(s), y)], s̃ the shifted
    overlay of s, y the SAC target (sampled on the online encoder, scored on the target one); SAC actor on s."""
    torch.manual_seed(0)
    loss = make_loss("simgrl", augmentation=None, strong_augmentation=RandomShiftedOverlay(images=BANK, seed=3))
    with torch.no_grad():
        for value in loss.target_encoder_params.values(True, True):
            value.mul_(0.9)
    batch = make_batch()
    strong_pixels = RandomShiftedOverlay(images=BANK, seed=3).augment(batch["pixels"])  # the loss's draw, replayed
    torch.manual_seed(1)
    out = loss(batch)
    encoder, critic, actor = loss.encoder, loss.critic, loss.actor
    target_encoder = copy.deepcopy(encoder)
    with torch.no_grad():
        for param, value in zip(target_encoder.parameters(), loss.target_encoder_params.values(True, True)):
            param.copy_(value)
    torch.manual_seed(1)
    with torch.no_grad():
        next_action, next_log_prob = dmcgb_squashed_sample(*actor(encoder(batch["next", "pixels"])))
        with loss.target_critic_params.to_module(critic):
            next_value = torch.min(*critic(target_encoder(batch["next", "pixels"]), next_action)) - ALPHA * next_log_prob
        target = batch["next", "reward"] + GAMMA * next_value
        q_clean = critic(encoder(batch["pixels"]), batch["action"])
        q_strong = critic(encoder(strong_pixels), batch["action"])
        expected = 0.5 * (F.mse_loss(q_strong[0], target) + F.mse_loss(q_strong[1], target)
                          + F.mse_loss(q_clean[0], target) + F.mse_loss(q_clean[1], target))
        hidden = encoder(batch["pixels"])
        action, log_prob = dmcgb_squashed_sample(*actor(hidden))
        actor_q = torch.min(*critic(hidden, action))
    assert not torch.equal(strong_pixels, batch["pixels"])
    assert torch.allclose(out["loss_critic"], expected, atol=1e-6)
    assert torch.allclose(out["q_strong_mean"], q_strong[0].mean(), atol=1e-6)
    assert torch.allclose(out["loss_actor"], (ALPHA * log_prob - actor_q).mean(), atol=1e-6), "the actor reads the clean view"


def test_make_loss_builds_simgrl_on_the_per_frame_encoder():
    assert ALGOS["simgrl"].loss is SVEALoss and ALGOS["simgrl"].sampler is SquashedGaussian
    loss = make_paper_loss("simgrl", (9, 44, 44), action_dim=2, hidden_dim=8, max_value=255, seed=0)
    assert isinstance(loss, SVEALoss) and isinstance(loss.encoder, PerFrameEncoder)
    assert loss.encoder.max_value == 255 and loss.strong_augmentation[0].max_value == 255
    assert not loss.encoder.centered and loss.scores_on_target_encoder and loss.sampler.squash_epsilon == 1e-6, "SimGRL's DMC-GB SAC"


def test_per_frame_encoder_on_simgrls_pixel_scale():
    torch.manual_seed(0)
    encoder = PerFrameEncoder(9, num_layers=4, frame_layers=2, frame_filters=4, channels=5, centered=False)
    pixels = torch.randint(0, 256, (2, 9, 16, 16), dtype=torch.uint8)
    centered = PerFrameEncoder(9, num_layers=4, frame_layers=2, frame_filters=4, channels=5)
    centered.load_state_dict(encoder.state_dict())
    assert torch.allclose(encoder(pixels), centered.stack_frames(pixels.float() / 255 + 0.5, 1.0), atol=1e-5), "x / 255"
    assert torch.allclose(centered(pixels), encoder.stack_frames(pixels.float() / 255 - 0.5, 1.0), atol=1e-5)
    assert not torch.allclose(encoder(pixels), centered(pixels))

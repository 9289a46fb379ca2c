"""Networks: the papers' shapes, DrQ-v2's initialisation, and the heads' definitions."""

from __future__ import annotations

import math
import warnings

import pytest
import torch
from torch import nn

from vigen.models import (AttributionDecoder, Actor, Critic, CURLHead, DrQv2Encoder, PerFrameEncoder, PIEGEncoder,
                          ProjectedEncoder, SharedCNN, VRL3Encoder)


@pytest.mark.parametrize(
    "encoder, size, features",
    [(DrQv2Encoder(9), 84, 32 * 35 * 35), (SharedCNN(9), 84, 32 * 21 * 21), (ProjectedEncoder(9, 84), 84, 512)],
)
def test_encoder_shapes(encoder, size, features):
    out = encoder(torch.randint(0, 256, (3, 9, size, size), dtype=torch.uint8))
    assert out.shape == (3, features) and encoder.output_dim(9, size, size) == features
    assert encoder(torch.zeros(2, 5, 9, size, size)).shape == (2, 5, features), "any leading batch dims"


def test_layer_counts():
    assert sum(isinstance(m, nn.Conv2d) for m in DrQv2Encoder().modules()) == 4
    shared = [m for m in SharedCNN().convnet]
    assert sum(isinstance(m, nn.Conv2d) for m in shared) == 11
    assert isinstance(shared[-1], nn.Conv2d), "no ReLU after the last conv"
    assert shared[0].stride == (2, 2) and all(m.stride == (1, 1) for m in shared[1:] if isinstance(m, nn.Conv2d))


def test_pixels_are_scaled_like_drqv2():
    """uint8 keeps DrQ-v2's exact x / 255 − 0.5; floats are x / max_value − 0.5 (max_value 1.0 unless declared)."""
    encoder = DrQv2Encoder(3)
    x = torch.randint(0, 256, (2, 3, 20, 20), dtype=torch.uint8)
    expected = encoder.convnet(x.float() / 255.0 - 0.5).flatten(1)
    assert torch.equal(encoder(x), expected), "uint8: the same numbers as DrQ-v2"
    unit = torch.rand(2, 3, 20, 20)  # TorchRL's ToTensorImage() scale
    assert torch.allclose(encoder(unit), encoder.convnet(unit - 0.5).flatten(1), atol=1e-6)
    assert torch.allclose(encoder(x.float() / 255), expected, atol=1e-6)


def _pieg(**kw) -> PIEGEncoder:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no ImageNet weights here: random ResNet weights
        return PIEGEncoder(6, image_size=44, out_dim=32, **kw)


def _vrl3(**kw) -> VRL3Encoder:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # no stage-1 weights here: random initialisation
        return VRL3Encoder(6, **kw)


@pytest.mark.parametrize("make", [lambda **kw: DrQv2Encoder(6, **kw), lambda **kw: SharedCNN(6, **kw),
                                  lambda **kw: ProjectedEncoder(6, image_size=44, **kw), lambda **kw: PerFrameEncoder(6, **kw),
                                  _vrl3, _pieg], ids=["drqv2", "shared_cnn", "projected", "per_frame", "vrl3", "pieg"])
def test_encoders_take_the_pixel_contract(make):
    """Every encoder: float pixels are 0–max_value (1.0 unless declared, TorchRL's ToTensorImage scale), uint8 is 0–255;
    a wrong scale or layout raises instead of encoding. (MaDi's masker, whose output is pixels: test/losses/test_madi.py.)"""
    x = torch.randint(0, 256, (2, 6, 44, 44), dtype=torch.uint8)
    encoder = make()
    assert torch.allclose(encoder(x.float() / 255), encoder(x), atol=1e-5), "ToTensorImage's 0–1 floats"
    with pytest.raises(ValueError, match="max_value=255"):
        encoder(x.float())  # 0–255 floats without saying so would be scaled 255 times too bright
    with pytest.raises(ValueError, match="channels-first"):
        encoder(torch.rand(2, 44, 44, 6))
    declared = make(max_value=255)
    declared.load_state_dict(encoder.state_dict())
    assert torch.allclose(declared(x.float()), encoder(x), atol=1e-5)
    assert torch.equal(declared(x), encoder(x)), "uint8 is 0–255 whatever max_value says"
    with pytest.raises(ValueError, match="max_value"):
        make(max_value=0)


def test_orthogonal_initialisation():
    actor = Actor(64, 6, feature_dim=50, hidden_dim=128)
    weight = actor.trunk[0].weight  # 50 x 64: orthonormal rows
    assert torch.allclose(weight @ weight.T, torch.eye(50), atol=1e-5)
    assert all((m.bias == 0).all() for m in actor.modules() if isinstance(m, nn.Linear))
    conv = DrQv2Encoder(9).convnet[2].weight.flatten(1)  # 32 x 288, gain sqrt(2)
    assert torch.allclose(conv @ conv.T, 2 * torch.eye(32), atol=1e-4)


def test_actor_and_critic_heads():
    actor, critic = Actor(64, 6, hidden_dim=128), Critic(64, 6, hidden_dim=128)
    hidden = torch.randn(5, 64) * 10
    action = actor(hidden)
    assert action.shape == (5, 6) and action.abs().max() < 1
    assert isinstance(actor.trunk[1], nn.LayerNorm) and isinstance(actor.trunk[2], nn.Tanh)
    q1, q2 = critic(hidden, action)
    assert q1.shape == q2.shape == (5, 1) and not torch.allclose(q1, q2), "two independent heads"


def test_attribution_decoder_shape_and_curl_logits():
    assert AttributionDecoder(6)(torch.randn(2, 512), torch.randn(2, 6)).shape == (2, 9, 84, 84)
    head = CURLHead(8)
    assert (head.W >= 0).all() and (head.W < 1).all()
    anchor, positive = torch.randn(4, 8), torch.randn(4, 8)
    logits = head.logits(anchor, positive)
    raw = anchor @ head.W @ positive.T
    assert torch.allclose(logits, raw - raw.max(dim=1, keepdim=True).values)
    assert torch.allclose(logits.max(dim=1).values, torch.zeros(4)) and math.isfinite(logits.sum().item())

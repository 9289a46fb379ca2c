"""PIE-G's encoder: torchvision's ResNet-18 layout and weights files, the per-frame math, frozen weights, BN modes."""

from __future__ import annotations

import copy
import warnings

import pytest
import torch
import torch.nn.functional as F

from vigen.models import PIEGEncoder
from vigen.models.resnet import RESNET18_URL, ResNet18Features

SIZE = 16


def _quiet_encoder(**kwargs) -> PIEGEncoder:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # random ResNet weights
        return PIEGEncoder(**{"in_channels": 9, "image_size": SIZE, **kwargs})


def torchvision_resnet18_state(seed: int = 0, counters: bool = True) -> dict[str, torch.Tensor]:
    """A state dict in the layout of torchvision's ``resnet18().state_dict()``, written from its architecture.

    Stem conv 64×3×7×7 and BN; four stages of two basic blocks (64, 128, 256, 512 channels), the
    first block of stages 2–4 with a 1×1 ``downsample`` (conv ``.0``, BN ``.1``); classifier
    ``fc`` 1000×512. Random values; running variances positive.
    """
    generator = torch.Generator().manual_seed(seed)
    state: dict[str, torch.Tensor] = {}

    def batch_norm(prefix: str, channels: int) -> None:
        state[f"{prefix}.weight"] = torch.rand(channels, generator=generator) + 0.5
        state[f"{prefix}.bias"] = torch.randn(channels, generator=generator) * 0.1
        state[f"{prefix}.running_mean"] = torch.randn(channels, generator=generator) * 0.1
        state[f"{prefix}.running_var"] = torch.rand(channels, generator=generator) + 0.5
        if counters:
            state[f"{prefix}.num_batches_tracked"] = torch.tensor(12345)

    def conv(key: str, out_channels: int, in_channels: int, kernel: int) -> None:
        scale = (2 / (in_channels * kernel**2)) ** 0.5
        state[key] = torch.randn(out_channels, in_channels, kernel, kernel, generator=generator) * scale

    conv("conv1.weight", 64, 3, 7)
    batch_norm("bn1", 64)
    in_channels = 64
    for stage, width in enumerate((64, 128, 256, 512), start=1):
        for block in range(2):
            prefix = f"layer{stage}.{block}"
            conv(f"{prefix}.conv1.weight", width, in_channels if block == 0 else width, 3)
            batch_norm(f"{prefix}.bn1", width)
            conv(f"{prefix}.conv2.weight", width, width, 3)
            batch_norm(f"{prefix}.bn2", width)
            if block == 0 and stage > 1:
                conv(f"{prefix}.downsample.0.weight", width, in_channels, 1)
                batch_norm(f"{prefix}.downsample.1", width)
        in_channels = width
    state["fc.weight"] = torch.randn(1000, 512, generator=generator) * 0.01
    state["fc.bias"] = torch.zeros(1000)
    return state


# -- the hand computation: ResNet-18 to layer2 with torch.nn.functional, per frame ----------------------
def _bn(x, state, prefix, training):
    return F.batch_norm(x, state[f"{prefix}.running_mean"].clone(), state[f"{prefix}.running_var"].clone(),
                        state[f"{prefix}.weight"], state[f"{prefix}.bias"], training=training, momentum=0.1, eps=1e-5)


def _block(x, state, prefix, stride, training):
    out = F.relu(_bn(F.conv2d(x, state[f"{prefix}.conv1.weight"], stride=stride, padding=1), state, f"{prefix}.bn1", training))
    out = _bn(F.conv2d(out, state[f"{prefix}.conv2.weight"], padding=1), state, f"{prefix}.bn2", training)
    shortcut = x
    if f"{prefix}.downsample.0.weight" in state:
        projected = F.conv2d(x, state[f"{prefix}.downsample.0.weight"], stride=stride)
        shortcut = _bn(projected, state, f"{prefix}.downsample.1", training)
    return F.relu(out + shortcut)


def hand_features(pixels, state, fc_weight, fc_bias, ln_weight, ln_bias, training=True, imagenet=False):
    """PIE-G's features of uint8 stacks [B, 9, H, W]: frames → ResNet → [f2, f3, f2 − f1, f3 − f2] → fc → LN."""
    b = pixels.shape[0]
    x = pixels.float().reshape(b * 3, 3, *pixels.shape[-2:]) / 255  # frames of sample 0, then of sample 1, ...
    if imagenet:
        x = (x - torch.tensor([0.485, 0.456, 0.406]).view(3, 1, 1)) / torch.tensor([0.229, 0.224, 0.225]).view(3, 1, 1)
    else:
        x = x - 0.5
    x = F.relu(_bn(F.conv2d(x, state["conv1.weight"], stride=2, padding=3), state, "bn1", training))
    x = F.max_pool2d(x, 3, stride=2, padding=1)
    x = _block(_block(x, state, "layer1.0", 1, training), state, "layer1.1", 1, training)
    x = _block(_block(x, state, "layer2.0", 2, training), state, "layer2.1", 1, training)
    f = x.reshape(b, 3, *x.shape[1:])
    combined = torch.cat([f[:, 1], f[:, 2], f[:, 1] - f[:, 0], f[:, 2] - f[:, 1]], dim=1).reshape(b, -1)
    return F.layer_norm(F.linear(combined, fc_weight, fc_bias), (fc_weight.shape[0],), ln_weight, ln_bias)


@pytest.fixture
def weights_file(tmp_path):
    path = tmp_path / "resnet18.pth"
    torch.save(torchvision_resnet18_state(), path)
    return path


# -- torchvision's layout and weights files ---------------------------------------------------------------
def test_module_names_are_torchvision_resnet18_state_dict_keys():
    reference = torchvision_resnet18_state()
    full = ResNet18Features(depth=4).state_dict()
    assert set(full) == set(reference) - {"fc.weight", "fc.bias"}
    assert all(full[key].shape == reference[key].shape for key in full)
    kept = ("conv1.", "bn1.", "layer1.", "layer2.")
    assert set(ResNet18Features(depth=2).state_dict()) == {key for key in full if key.startswith(kept)}


def test_weights_file_round_trips(weights_file):
    reference = torchvision_resnet18_state()
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # weights given: no random-weights warning
        encoder = PIEGEncoder(9, image_size=SIZE, out_dim=8, weights=weights_file)
    loaded = encoder.resnet.state_dict()
    assert len(loaded) == 10 + 10 * 5  # 10 convolutions and 10 BatchNorms (5 entries each) up to layer2
    for key, value in loaded.items():
        assert torch.equal(value, reference[key]), key
    assert not any(p.requires_grad for p in encoder.resnet.parameters())
    assert all(p.requires_grad for p in (*encoder.fc.parameters(), *encoder.ln.parameters()))


def test_weights_under_state_dict_with_module_prefixes_and_without_counters(tmp_path):
    reference = torchvision_resnet18_state(counters=False)  # older torchvision files have no num_batches_tracked
    path = tmp_path / "checkpoint.pth"
    torch.save({"state_dict": {f"module.{key}": value for key, value in reference.items()}, "epoch": torch.tensor(90)}, path)
    encoder = PIEGEncoder(9, image_size=SIZE, out_dim=8, weights=path)
    assert torch.equal(encoder.resnet.layer2[0].downsample[0].weight, reference["layer2.0.downsample.0.weight"])
    assert int(encoder.resnet.bn1.num_batches_tracked) == 0


def test_bad_weights_files_are_explained(tmp_path):
    with pytest.raises(FileNotFoundError, match=RESNET18_URL.replace(".", r"\.")):
        PIEGEncoder(9, image_size=SIZE, weights=tmp_path / "absent.pth")
    state = torchvision_resnet18_state()
    cases = {
        "missing": ({k: v for k, v in state.items() if k != "layer2.1.bn2.weight"}, "missing: layer2.1.bn2.weight"),
        "deeper": ({**state, "layer1.2.conv1.weight": torch.zeros(64, 64, 3, 3)}, "unexpected: layer1.2.conv1.weight"),
        "shape": ({**state, "conv1.weight": torch.zeros(64, 1, 7, 7)}, "wrong shape: conv1.weight"),
    }
    for name, (bad, message) in cases.items():
        path = tmp_path / f"{name}.pth"
        torch.save(bad, path)
        with pytest.raises(ValueError, match=message):
            PIEGEncoder(9, image_size=SIZE, weights=path)
    torch.save(torch.nn.Linear(2, 2), tmp_path / "module.pth")  # a pickled module, not a state dict
    with pytest.raises(ValueError, match="never unpickles code"):
        PIEGEncoder(9, image_size=SIZE, weights=tmp_path / "module.pth")


def test_unused_layers_and_classifier_are_ignored(weights_file):
    """layer3, layer4 and fc are in the file; only what the encoder keeps is read (depth=1 keeps layer1)."""
    encoder = PIEGEncoder(9, image_size=SIZE, out_dim=8, depth=1, weights=weights_file)
    assert not hasattr(encoder.resnet, "layer2")
    assert torch.equal(encoder.resnet.layer1[1].conv2.weight, torchvision_resnet18_state()["layer1.1.conv2.weight"])


def test_random_weights_warn_once():
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("default")  # Python's default: each warning once per location
        PIEGEncoder(9, image_size=SIZE)
        PIEGEncoder(9, image_size=SIZE, out_dim=8)
    assert len(caught) == 1
    message = str(caught[0].message)
    assert "random weights" in message and "ImageNet" in message and "weights=" in message and "encoder_weights=" in message


# -- the forward pass, by hand ----------------------------------------------------------------------------
@pytest.mark.parametrize("normalization", ["centered", "imagenet"])
def test_features_by_hand_in_training_mode(weights_file, normalization):
    encoder = PIEGEncoder(9, image_size=SIZE, out_dim=8, weights=weights_file, normalization=normalization)
    state = torchvision_resnet18_state()
    pixels = torch.randint(0, 256, (3, 9, SIZE, SIZE), dtype=torch.uint8, generator=torch.Generator().manual_seed(1))
    expected = hand_features(pixels, state, encoder.fc.weight, encoder.fc.bias, encoder.ln.weight, encoder.ln.bias,
                             imagenet=normalization == "imagenet")
    assert torch.allclose(encoder(pixels), expected, atol=1e-5)
    assert encoder.conv_dim == 4 * 128 * 2 * 2


def test_features_by_hand_in_eval_mode_use_running_statistics(weights_file):
    encoder = PIEGEncoder(9, image_size=SIZE, out_dim=8, weights=weights_file).eval()
    state = torchvision_resnet18_state()
    pixels = torch.randint(0, 256, (2, 9, SIZE, SIZE), dtype=torch.uint8, generator=torch.Generator().manual_seed(2))
    args = (state, encoder.fc.weight, encoder.fc.bias, encoder.ln.weight, encoder.ln.bias)
    assert torch.allclose(encoder(pixels), hand_features(pixels, *args, training=False), atol=1e-5)
    assert not torch.allclose(encoder(pixels), hand_features(pixels, *args, training=True), atol=1e-3)
    assert int(encoder.resnet.bn1.num_batches_tracked) == 12345, "eval mode leaves the statistics alone"


def test_training_mode_moves_running_statistics_with_momentum(weights_file):
    """PIE-G keeps the BatchNorm statistics adapting: running ← 0.9·running + 0.1·batch (unbiased variance)."""
    encoder = PIEGEncoder(9, image_size=SIZE, out_dim=8, weights=weights_file)
    state = torchvision_resnet18_state()
    pixels = torch.randint(0, 256, (2, 9, SIZE, SIZE), dtype=torch.uint8, generator=torch.Generator().manual_seed(3))
    stem = F.conv2d(pixels.float().reshape(6, 3, SIZE, SIZE) / 255 - 0.5, state["conv1.weight"], stride=2, padding=3)
    mean, var = stem.mean(dim=(0, 2, 3)), stem.var(dim=(0, 2, 3), unbiased=True)
    encoder(pixels)
    assert torch.allclose(encoder.resnet.bn1.running_mean, 0.9 * state["bn1.running_mean"] + 0.1 * mean, atol=1e-5)
    assert torch.allclose(encoder.resnet.bn1.running_var, 0.9 * state["bn1.running_var"] + 0.1 * var, atol=1e-4)
    assert int(encoder.resnet.bn1.num_batches_tracked) == 12346


def test_leading_batch_dims_and_pixel_formats():
    encoder = _quiet_encoder(out_dim=8)
    pixels = torch.randint(0, 256, (2, 3, 9, SIZE, SIZE), dtype=torch.uint8)
    flat = encoder(pixels.reshape(6, 9, SIZE, SIZE))
    assert torch.allclose(encoder(pixels), flat.reshape(2, 3, 8), atol=1e-6)
    assert torch.allclose(encoder(pixels.float() / 255), encoder(pixels), atol=1e-5)
    with pytest.raises(ValueError, match="max_value=255"):
        encoder(pixels.float())
    declared = _quiet_encoder(out_dim=8, max_value=255)
    declared.load_state_dict(encoder.state_dict())
    assert torch.allclose(declared(pixels.float()), encoder(pixels), atol=1e-5)
    with pytest.raises(ValueError, match="image_size=20"):
        encoder(torch.zeros(1, 9, 20, 20, dtype=torch.uint8))


def test_frozen_resnet_gets_no_gradient_and_no_graph():
    encoder = _quiet_encoder(out_dim=8)
    pixels = torch.randint(0, 256, (2, 9, SIZE, SIZE), dtype=torch.uint8)
    encoder(pixels)[:, 0].sum().backward()
    assert all(p.grad is None for p in encoder.resnet.parameters())
    assert encoder.fc.weight.grad is not None and encoder.fc.weight.grad.abs().sum() > 0
    floats = (pixels.float() / 255).requires_grad_()  # a gradient to the pixels (e.g. for saliency) still flows
    encoder(floats)[:, 0].sum().backward()  # (the sum of all LayerNorm outputs is constant)
    assert floats.grad is not None and floats.grad.abs().sum() > 0
    assert all(p.grad is None for p in encoder.resnet.parameters())


def test_output_dim_makes_no_forward_pass():
    encoder = _quiet_encoder(out_dim=24)
    assert encoder.output_dim(9, SIZE, SIZE) == 24
    assert int(encoder.resnet.bn1.num_batches_tracked) == 0
    with pytest.raises(ValueError, match="9×16×16"):
        encoder.output_dim(9, 84, 84)
    assert ResNet18Features(2).output_shape(84, 84) == (128, 11, 11)  # RL-ViGen: 4·128·11·11 = 61,952 features
    assert 4 * 128 * 11 * 11 == 61952


def test_reset_parameters_keeps_the_resnet(weights_file):
    encoder = PIEGEncoder(9, image_size=SIZE, out_dim=8, weights=weights_file)
    loaded = copy.deepcopy(encoder.resnet.state_dict())
    fc = encoder.fc.weight.detach().clone()
    encoder(torch.randint(0, 256, (2, 9, SIZE, SIZE), dtype=torch.uint8))
    assert not torch.equal(encoder.resnet.bn1.running_mean, loaded["bn1.running_mean"])
    encoder.reset_parameters()
    assert all(torch.equal(value, loaded[key]) for key, value in encoder.resnet.state_dict().items())
    assert not torch.equal(encoder.fc.weight, fc)


@pytest.mark.parametrize("kwargs, match", [
    ({"in_channels": 3}, "at least two RGB frames"),
    ({"in_channels": 10}, "at least two RGB frames"),
    ({"normalization": "imagenet1k"}, "normalization"),
    ({"max_value": 0}, "max_value"),
    ({"depth": 5}, "depth"),
    ({"image_size": 0}, "image_size"),
])
def test_bad_arguments_are_explained(kwargs, match):
    with pytest.raises(ValueError, match=match):
        _quiet_encoder(out_dim=8, **kwargs)

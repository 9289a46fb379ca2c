"""Stand-ins for what the originals import but the parity tool does not have or need.

Stubbed modules (every attribute fails loudly if the update uses it), captum's ``GuidedBackprop``
rule for when captum does not import, and torchvision's ResNet-18 and ``Normalize`` for the
originals that build from torchvision (PIE-G, VRL3).
"""

from __future__ import annotations

import copy
import importlib
import types
from collections.abc import Sequence
from typing import Any

import torch
from torch import Tensor, nn


# -- modules an original imports but its update does not use -----------------------------------
class _Unavailable:
    """Stand-in for an attribute of a stubbed module: fails loudly if the update ever uses it."""

    def __init__(self, name: str) -> None:
        self._name = name

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise RuntimeError(f"benchmarks.parity stubbed {self._name}: the original's update used it, so the stub is wrong here.")

    def __getattr__(self, item: str) -> Any:
        if item.startswith("__"):
            raise AttributeError(item)
        return _Unavailable(f"{self._name}.{item}")


def stub(name: str) -> types.ModuleType:
    """A module ``name`` whose every attribute fails if used, and whose submodules import as further stubs."""
    module = types.ModuleType(name)
    module.__getattr__ = lambda item: _Unavailable(f"{name}.{item}")  # type: ignore[attr-defined]
    module.__path__ = []  # a package, so submodule imports resolve to further stubs
    return module


def importable(name: str) -> bool:
    """Whether ``name`` imports here (any error counts as no)."""
    try:
        importlib.import_module(name)
        return True
    except Exception:
        return False


# -- captum's guided backprop, when captum is not installed ------------------------------------
class GuidedBackpropStandIn:
    """captum's ``GuidedBackprop(model).attribute(inputs)`` rule, for when captum does not import.

    At every ``nn.ReLU`` module of the model the incoming gradient is clamped at 0 before the
    ReLU's own backward (captum returns ``relu(grad_input)`` of the ReLU, the same value); the
    attribution is the gradient of the summed output with respect to the inputs.
    """

    def __init__(self, model: nn.Module) -> None:
        self.model = model

    def attribute(self, inputs: Tensor, **kwargs: Any) -> Tensor:
        def hook(module: nn.Module, args: Any, output: Tensor) -> None:
            if output.requires_grad:
                output.register_hook(lambda grad: grad.clamp(min=0))

        handles = [m.register_forward_hook(hook) for m in self.model.modules() if isinstance(m, nn.ReLU)]
        try:
            x = inputs.detach().requires_grad_(True)
            with torch.enable_grad():
                (grad,) = torch.autograd.grad(self.model(x).sum(), x)
        finally:
            for handle in handles:
                handle.remove()
        return grad


def captum_substitute() -> tuple[dict[str, types.ModuleType], list[str]]:
    """``{}`` if captum imports; else a ``captum.attr`` stand-in holding :class:`GuidedBackpropStandIn`."""
    if importable("captum.attr"):
        import captum

        return {}, [f"captum {captum.__version__} (real GuidedBackprop)"]
    attr = stub("captum.attr")
    attr.GuidedBackprop = GuidedBackpropStandIn  # type: ignore[attr-defined]
    return {"captum": stub("captum"), "captum.attr": attr}, [
        "captum not installed: GuidedBackprop is the tool's stand-in with captum's rule (use --pythonpath DIR with captum for the real one)"
    ]


# -- torchvision, for the originals that build from it (it need not import here) ----------------
class _BuildOnly:
    """A torchvision class the original builds but its update never calls: building works, using it fails."""

    def __init__(self, name: str) -> None:
        self._name = name

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return _Unavailable(f"{self._name}(...)")


class NormalizeStandIn:
    """torchvision's ``transforms.Normalize(mean, std)`` on a tensor ``[..., C, H, W]``: ``(x − mean) / std`` per channel."""

    def __init__(self, mean: Sequence[float], std: Sequence[float], inplace: bool = False) -> None:
        self.mean, self.std = tuple(mean), tuple(std)

    def __call__(self, x: Tensor) -> Tensor:
        mean = torch.as_tensor(self.mean, dtype=x.dtype, device=x.device).view(-1, 1, 1)
        std = torch.as_tensor(self.std, dtype=x.dtype, device=x.device).view(-1, 1, 1)
        return (x - mean) / std


class _TorchvisionBasicBlock(nn.Module):
    """torchvision's ResNet ``BasicBlock``: its module names, order and arithmetic."""

    def __init__(self, in_channels: int, channels: int, stride: int) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(in_channels, channels, 3, stride=stride, padding=1, bias=False)
        self.bn1 = nn.BatchNorm2d(channels)
        self.relu = nn.ReLU(inplace=True)
        self.conv2 = nn.Conv2d(channels, channels, 3, padding=1, bias=False)
        self.bn2 = nn.BatchNorm2d(channels)
        self.downsample: nn.Module | None = None
        if stride != 1 or in_channels != channels:
            self.downsample = nn.Sequential(nn.Conv2d(in_channels, channels, 1, stride=stride, bias=False),
                                            nn.BatchNorm2d(channels))

    def forward(self, x: Tensor) -> Tensor:
        identity = x if self.downsample is None else self.downsample(x)
        out = self.relu(self.bn1(self.conv1(x)))
        out = self.bn2(self.conv2(out))
        out += identity
        return self.relu(out)


class TorchvisionResNet18(nn.Module):
    """torchvision's ``resnet18()``: the same child modules in the same order, state-dict names and initialisation.

    Written here (not vigen's :class:`~vigen.models.resnet.ResNet18Features`) so that an original
    that builds ``torchvision.models.resnet18`` runs an independent network. Kaiming-normal
    convolutions (``fan_out``), BatchNorm weight 1 and bias 0, PyTorch's default Linear.
    """

    def __init__(self, num_classes: int = 1000) -> None:
        super().__init__()
        self.conv1 = nn.Conv2d(3, 64, 7, stride=2, padding=3, bias=False)
        self.bn1 = nn.BatchNorm2d(64)
        self.relu = nn.ReLU(inplace=True)
        self.maxpool = nn.MaxPool2d(3, stride=2, padding=1)
        width = 64
        for index, channels in enumerate((64, 128, 256, 512)):
            stride = 1 if index == 0 else 2
            setattr(self, f"layer{index + 1}", nn.Sequential(_TorchvisionBasicBlock(width, channels, stride),
                                                             _TorchvisionBasicBlock(channels, channels, 1)))
            width = channels
        self.avgpool = nn.AdaptiveAvgPool2d((1, 1))
        self.fc = nn.Linear(512, num_classes)
        for module in self.modules():
            if isinstance(module, nn.Conv2d):
                nn.init.kaiming_normal_(module.weight, mode="fan_out", nonlinearity="relu")
            elif isinstance(module, nn.BatchNorm2d):
                nn.init.constant_(module.weight, 1)
                nn.init.constant_(module.bias, 0)

    def forward(self, x: Tensor) -> Tensor:
        x = self.maxpool(self.relu(self.bn1(self.conv1(x))))
        x = self.layer4(self.layer3(self.layer2(self.layer1(x))))
        return self.fc(torch.flatten(self.avgpool(x), 1))


def imagenet_stand_in(seed: int) -> TorchvisionResNet18:
    """A :class:`TorchvisionResNet18` standing in for the ImageNet weights (no download here).

    torchvision's initialisation, then every BatchNorm's weight, bias, running mean and running
    variance drawn from a seeded generator (weight and variance in [0.5, 1.5), bias and mean
    N(0, 0.1²)), so that no BatchNorm is the identity and its statistics are distinguishable.
    """
    g = torch.Generator().manual_seed(seed)
    model = TorchvisionResNet18()
    with torch.no_grad():
        for module in model.modules():
            if isinstance(module, nn.BatchNorm2d):
                size, dtype = module.num_features, module.weight.dtype
                module.weight.copy_(0.5 + torch.rand(size, generator=g, dtype=dtype))
                module.bias.copy_(0.1 * torch.randn(size, generator=g, dtype=dtype))
                module.running_mean.copy_(0.1 * torch.randn(size, generator=g, dtype=dtype))
                module.running_var.copy_(0.5 + torch.rand(size, generator=g, dtype=dtype))
    return model


def torchvision_substitute(resnet18: nn.Module | None = None) -> tuple[dict[str, types.ModuleType], list[str]]:
    """Stand-ins for ``torchvision`` and its submodules, as :func:`~benchmarks.parity.checkout.import_reference` ``substitutes``.

    ``models.resnet18(...)`` returns a copy of ``resnet18`` (whatever its arguments, e.g.
    ``pretrained=True``); ``transforms.Normalize`` is :class:`NormalizeStandIn`;
    ``transforms.Compose``, ``Resize`` and ``CenterCrop`` build objects that fail if used. Every
    other attribute fails if used.
    """
    names = ("torchvision", "torchvision.models", "torchvision.transforms", "torchvision.datasets", "torchvision.utils")
    modules = {name: stub(name) for name in names}
    root = modules["torchvision"]
    for name in names[1:]:
        setattr(root, name.split(".")[1], modules[name])
    transforms = modules["torchvision.transforms"]
    transforms.Normalize = NormalizeStandIn  # type: ignore[attr-defined]
    for name in ("Compose", "Resize", "CenterCrop"):
        setattr(transforms, name, _BuildOnly(f"torchvision.transforms.{name}"))
    notes = ["torchvision is the tool's stand-in: transforms.Normalize is (x − mean) / std per channel; "
             "Compose, Resize and CenterCrop build but fail if used; everything else fails if used"]
    if resnet18 is not None:
        modules["torchvision.models"].resnet18 = lambda *args, **kwargs: copy.deepcopy(resnet18)  # type: ignore[attr-defined]
        notes.append("torchvision.models.resnet18(pretrained=True) is the tool's TorchvisionResNet18 (torchvision's layout "
                     "and initialisation) with random BatchNorm weights, biases and statistics standing in for ImageNet's; "
                     "vigen's encoder loads the same state dict (PIEGEncoder(weights=file)), as it loads torchvision's")
    return modules, notes

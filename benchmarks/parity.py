"""Parity of vigen's losses with the original implementations: one update, same weights, same draws.

For each algorithm the tool imports the ORIGINAL agent from a user-given checkout (by path: nothing
of it is copied into vigen), builds it and vigen's loss with the same architecture, copies the
original's weights into vigen's networks (mapping the parameter names), gives both sides the same
pre-drawn augmented views, the same action noise and the same scalar draws, runs ONE update on the
same batch in float64 and compares every loss value and every parameter gradient.

How the update is compared:

* the original's optimizer steps are *recorded, not taken*: each ``step()`` saves the gradients of
  its parameters and leaves them unchanged, and each ``backward()`` saves its loss value. So every
  quantity of the original is measured at the same parameters as vigen's single forward pass; the
  ordering departures (RL-ViGen's actor loss, CURL anchor and SGQN mask are computed after its
  critic step) become comparable. The column "steps taken" repeats the original's update with its
  real Adam steps and shows how much that order changes each quantity (a departure by design);
* vigen's gradients are taken per ``loss_*`` entry (``autograd.grad``) and matched with the
  original's optimizer step that consumes that loss (e.g. ``loss_curl`` with CURL's second
  ``encoder_opt`` step). A gradient that vigen's loss sends to a parameter the original's step does
  not own is reported as a stray row;
* views: drawn once with vigen's augmentations (seeded) and replayed: the original's ``aug``,
  ``random_overlay`` and ``random_mask_freq_v2`` return them, and vigen's loss gets replay
  augmentations (``make_params``/``apply``) that return them. A replay checks that it is asked
  to augment the expected source (e.g. the strong view is built on the weak view). The
  augmentation kernels themselves are compared with the originals in vigen's transform tests;
* noise: one stream of standard normals hands out values in call order to ``torch.randn_like`` /
  ``torch.randn`` (vigen) and ``_standard_normal`` (the originals' ``TruncatedNormal`` and
  ``Normal.rsample``); one scalar ``u`` serves SGQN's fill value (``random.uniform`` there,
  ``torch.rand(())`` in vigen);
* float64: ``torch.set_default_dtype(torch.float64)``, ``Tensor.float()`` keeps float64 and
  ``torch.FloatTensor(...)`` builds float64 while the tool runs (both sides call ``.float()`` on
  their pixels; VRL3's original adds a ``torch.FloatTensor([0])`` to its actor loss).

Per quantity the relative difference is ``max|a − b| / max(max|b|, tiny)`` (b = original; for a
gradient tensor the max runs over its elements, and the value columns show its L2 norm). A gradient
that is 0 in exact arithmetic (VRL3's stem bias, before a training-mode BatchNorm: both sides are
rounding noise) is measured against the largest gradient of its step instead, and its row says so.

Missing imports of the originals that their update does not use (hydra, omegaconf, torchvision,
kornia) are stubbed in ``sys.modules`` while they load; every stub is listed in the output. PIE-G's
original builds torchvision's ResNet-18 and VRL3's normalises with torchvision's ``Normalize``: for
them torchvision is the tool's stand-in (:func:`torchvision_substitute`; said so in the output): a
ResNet-18 written here in torchvision's layout, whose random BatchNorm weights and statistics stand
in for ImageNet's (vigen's ``PIEGEncoder`` loads the same state dict from a file), and ``Normalize``
as ``(x − mean) / std``.
RL-ViGen's SGQN needs captum's ``GuidedBackprop``: if captum does not import, a stand-in with
captum's rule (at every ``nn.ReLU`` the gradient is clamped at 0 before the ReLU's own backward)
is used and said so; put captum on the path (``--pythonpath DIR``) to use the real one.

Reproduce (RL-ViGen master, https://github.com/gemcollector/RL-ViGen):

    # a plain checkout of the original (outside the vigen tree); only its code is needed
    git clone https://github.com/gemcollector/RL-ViGen /work/refs/RL-ViGen
    # or from a bare mirror: git --git-dir=<mirror> archive HEAD algos utils.py rl_utils.py cfgs | tar -x -C /work/refs/RL-ViGen
    cd /work/main && OMP_NUM_THREADS=1 .venv/bin/python benchmarks/parity.py --reference /work/refs/RL-ViGen
    # real captum, installed outside the venv:
    pip install --no-deps --target /work/refs/pydeps captum
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/parity.py --reference /work/refs/RL-ViGen --pythonpath /work/refs/pydeps
    # some algorithms, a reference per algorithm:
    .venv/bin/python benchmarks/parity.py --algos curl sgqn --reference curl=/path/RL-ViGen --reference sgqn=/path/RL-ViGen

SADA's original is DMC-GB2's (https://github.com/aalmuzairee/dmcgb2, algos/sada.py): give it as
``--reference sada=PATH``. Without ``--algos`` every algorithm whose reference holds its original
runs; the others are listed as skipped (``sada`` and ``vrl3`` beside a plain RL-ViGen ``PATH``):

    # a plain checkout of DMC-GB2's code (its envs and data are not needed)
    git clone https://github.com/aalmuzairee/dmcgb2 /work/refs/dmcgb2
    # or from a bare mirror: git --git-dir=<mirror> archive HEAD algos augmentations.py utils.py | tar -x -C /work/refs/dmcgb2
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/parity.py --algos sada --reference sada=/work/refs/dmcgb2
    # RL-ViGen's seven (with PIE-G) and SADA
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/parity.py --reference /work/refs/RL-ViGen --reference sada=/work/refs/dmcgb2 --pythonpath /work/refs/pydeps

VRL3's original lives only on RL-ViGen's ViGen-adroit branch (``src/algos/vrl3_agent.py``): give
its ``src`` folder as ``--reference vrl3=PATH``. (That folder also has agents named ``svea``,
``pieg``, ... built on VRL3's update: it never counts as a master checkout.)

    git clone -b ViGen-adroit https://github.com/gemcollector/RL-ViGen /work/refs/RL-ViGen-adroit
    # or from a bare mirror: git --git-dir=<mirror> archive ViGen-adroit src | tar -x -C /work/refs/RL-ViGen-adroit
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/parity.py --algos vrl3 --reference vrl3=/work/refs/RL-ViGen-adroit/src

MaDi, SimGRL and SCPL are their authors' forks of DMC-GB (SAC agents with ``update(replay_buffer, L,
step)``, built with ``.cuda()``, which the tool maps to the CPU while they are built): give each
repository's root as ``--reference NAME=PATH`` (their ``src/algorithms`` need captum). SCPL's draws
of actions it never uses are counted apart (``unused_normals``).

    git clone https://github.com/bramgrooten/mask-distractions /work/refs/MaDi
    git clone https://github.com/W-Song11/SimGRL-Code /work/refs/SimGRL
    git clone https://github.com/bofusun/SCPL /work/refs/SCPL
    # or from bare mirrors: git --git-dir=<mirror> archive HEAD src/algorithms src/augmentations.py src/utils.py | tar -x -C <dir>
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/parity.py --algos madi simgrl scpl --reference madi=/work/refs/MaDi \\
        --reference simgrl=/work/refs/SimGRL --reference scpl=/work/refs/SCPL --pythonpath /work/refs/pydeps
    # everything: RL-ViGen's seven, SADA, VRL3, MaDi, SimGRL and SCPL
    OMP_NUM_THREADS=1 .venv/bin/python benchmarks/parity.py --reference /work/refs/RL-ViGen --reference sada=/work/refs/dmcgb2 \\
        --reference vrl3=/work/refs/RL-ViGen-adroit/src --reference madi=/work/refs/MaDi --reference simgrl=/work/refs/SimGRL \\
        --reference scpl=/work/refs/SCPL --pythonpath /work/refs/pydeps

Adding an algorithm: write one ``build_<name>(reference, setup) -> Case`` function that imports the
original's modules with :func:`import_reference`, builds its agent and vigen's loss, and says which
original module maps to which vigen network (:class:`ModuleMap`), which optimizer step consumes
which ``loss_*`` (:class:`StepMap`), which callables of the original are replaced by view replays,
and its documented departures (optionally: extra arguments of the original's ``update``, gradients
that are 0 in exact arithmetic, and measures of what the update leaves behind, such as BatchNorm
statistics); then add it to ``ALGORITHMS`` and its repository and identifying files to
``ORIGINALS``.
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import importlib
import io
import math
import sys
import tempfile
import time
import types
import warnings
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import torch
from torch import Tensor, nn

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:
    sys.path.insert(0, str(ROOT))

Pairs = list[tuple[Tensor, Tensor]]  # (source the augmentation must be given, the view it returns)


# -- settings ----------------------------------------------------------------------------------
@dataclass(frozen=True)
class Setup:
    """The shared sizes and draws of one parity run (tiny, float64)."""

    batch_size: int = 8
    image_size: int = 84
    frames: int = 3
    action_dim: int = 4
    feature_dim: int = 50
    hidden_dim: int = 32
    lr: float = 1e-4
    gamma: float = 0.99
    nstep: int = 3
    step: int = 90_000  # the std schedule linear(1.0, 0.1, 100000) gives 0.19 here: some noise clipped, some not
    seed: int = 0

    @property
    def channels(self) -> int:
        return 3 * self.frames

    @property
    def obs_shape(self) -> tuple[int, int, int]:
        return (self.channels, self.image_size, self.image_size)


@dataclass
class Batch:
    """One replay batch, float64 pixels on the 0–255 scale (integer-valued, as stored uint8 frames)."""

    pixels: Tensor
    next_pixels: Tensor
    action: Tensor
    reward: Tensor
    nstep: int
    gamma: float

    @classmethod
    def draw(cls, setup: Setup, nstep: int) -> Batch:
        g = torch.Generator().manual_seed(setup.seed)
        shape = (setup.batch_size, *setup.obs_shape)
        return cls(
            pixels=torch.randint(0, 256, shape, generator=g).to(torch.float64),
            next_pixels=torch.randint(0, 256, shape, generator=g).to(torch.float64),
            action=torch.rand(setup.batch_size, setup.action_dim, generator=g, dtype=torch.float64) * 2 - 1,
            reward=torch.randn(setup.batch_size, 1, generator=g, dtype=torch.float64),
            nstep=nstep,
            gamma=setup.gamma,
        )

    def for_original(self) -> tuple[Tensor, ...]:
        """``(obs, action, reward, discount, next_obs)`` as RL-ViGen's replay buffer yields it."""
        discount = torch.full_like(self.reward, self.gamma**self.nstep)
        return (self.pixels.clone(), self.action.clone(), self.reward.clone(), discount, self.next_pixels.clone())

    def for_vigen(self) -> Any:
        from tensordict import TensorDict

        size = self.pixels.shape[0]
        no = torch.zeros(size, 1, dtype=torch.bool)
        data = {
            "pixels": self.pixels.clone(), "action": self.action.clone(),
            "next": {"pixels": self.next_pixels.clone(), "reward": self.reward.clone(), "done": no, "terminated": no.clone()},
        }
        if self.nstep != 1:
            data["steps_to_next_obs"] = torch.full((size, 1), self.nstep, dtype=torch.long)
        return TensorDict(data, batch_size=[size])


# -- float64 everywhere ------------------------------------------------------------------------
@contextmanager
def float64_mode() -> Iterator[None]:
    """float64 while the block runs: the default dtype, ``Tensor.float()`` and ``torch.FloatTensor(...)``.

    ``Tensor.float()`` keeps float64 (complex: the real part, as ``.float()`` does);
    ``torch.FloatTensor(...)`` builds float64 (VRL3's zero BC term would make its actor loss float32).
    """
    real_float, real_float_tensor, default = torch.Tensor.float, torch.FloatTensor, torch.get_default_dtype()

    def as_float64(self: Tensor, *args: Any, **kwargs: Any) -> Tensor:
        return (self.real if self.is_complex() else self).to(torch.float64)

    def float_tensor(*args: Any, **kwargs: Any) -> Tensor:  # torch.FloatTensor(data) or torch.FloatTensor(*size)
        if len(args) == 1 and not isinstance(args[0], (int, torch.Size)):
            return torch.as_tensor(args[0], dtype=torch.float64)
        return torch.empty(*args, dtype=torch.float64)

    torch.set_default_dtype(torch.float64)
    torch.Tensor.float = as_float64  # type: ignore[method-assign]
    torch.FloatTensor = float_tensor  # type: ignore[misc, assignment]
    try:
        yield
    finally:
        torch.Tensor.float = real_float  # type: ignore[method-assign]
        torch.FloatTensor = real_float_tensor  # type: ignore[misc]
        torch.set_default_dtype(default)


# -- importing an original checkout ------------------------------------------------------------
class _Unavailable:
    """Stand-in for an attribute of a stubbed module: fails loudly if the update ever uses it."""

    def __init__(self, name: str) -> None:
        self._name = name

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        raise RuntimeError(f"parity.py stubbed {self._name}: the original's update used it, so the stub is wrong here.")

    def __getattr__(self, item: str) -> Any:
        if item.startswith("__"):
            raise AttributeError(item)
        return _Unavailable(f"{self._name}.{item}")


def _stub(name: str) -> types.ModuleType:
    module = types.ModuleType(name)
    module.__getattr__ = lambda item: _Unavailable(f"{name}.{item}")  # type: ignore[attr-defined]
    module.__path__ = []  # a package, so submodule imports resolve to further stubs
    return module


def _importable(name: str) -> bool:
    try:
        importlib.import_module(name)
        return True
    except Exception:
        return False


@dataclass
class Reference:
    """The modules of one original checkout, and what was stubbed to load them."""

    root: Path
    modules: dict[str, types.ModuleType]
    stubbed: list[str]
    notes: list[str] = field(default_factory=list)


def import_reference(
    root: Path,
    names: Sequence[str],
    *,
    paths: Sequence[str] = ("",),
    optional: Sequence[str] = (),
    substitutes: dict[str, types.ModuleType] | None = None,
) -> Reference:
    """Import the modules ``names`` of a checkout at ``root`` (its ``paths`` put first on ``sys.path``).

    The checkout's top-level names (``utils``, ``drqv2``, ...) are generic: the import runs with
    them removed from ``sys.modules`` and puts back what was there afterwards, so two checkouts
    (or a checkout and vigen) never see each other's modules. Modules of ``optional`` that do not
    import are stubbed; ``substitutes`` replace modules outright (e.g. a captum stand-in).
    """
    root = Path(root).resolve()
    dirs = [str(root / p) if p else str(root) for p in paths]
    missing = [d for d in dirs if not Path(d).is_dir()]
    if missing:
        raise FileNotFoundError(f"--reference {root}: no directory {missing[0]}; give a plain checkout of the original repository.")
    substitutes = dict(substitutes or {})
    stubbed = []
    for name in optional:
        if name not in substitutes and not _importable(name):
            stubbed.append(name)
    fake: dict[str, types.ModuleType] = dict(substitutes)
    for name in stubbed:
        fake[name] = _stub(name)
    saved_path = list(sys.path)
    own = {name.split(".")[0] for name in names}  # top-level packages: two forks may both have algorithms.modules
    saved = {k: v for k, v in sys.modules.items() if k.split(".")[0] in own or k.split(".")[0] in fake}
    for key in saved:
        del sys.modules[key]
    sys.path[:0] = dirs
    try:
        for key, module in fake.items():
            sys.modules[key] = module
            parts = key.split(".")
            for i in range(1, len(parts)):  # parents of a dotted stub, so `import a.b as c` binds
                sys.modules.setdefault(".".join(parts[:i]), _stub(".".join(parts[:i])))
        modules = {name: importlib.import_module(name) for name in names}
    finally:
        sys.path[:] = saved_path
        for key in [k for k in sys.modules if k.split(".")[0] in own or k.split(".")[0] in fake]:
            del sys.modules[key]
        sys.modules.update(saved)
    return Reference(root, modules, stubbed)


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
    if _importable("captum.attr"):
        import captum

        return {}, [f"captum {captum.__version__} (real GuidedBackprop)"]
    attr = _stub("captum.attr")
    attr.GuidedBackprop = GuidedBackpropStandIn  # type: ignore[attr-defined]
    return {"captum": _stub("captum"), "captum.attr": attr}, [
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
    """Stand-ins for ``torchvision`` and its submodules, as :func:`import_reference` ``substitutes``.

    ``models.resnet18(...)`` returns a copy of ``resnet18`` (whatever its arguments, e.g.
    ``pretrained=True``); ``transforms.Normalize`` is :class:`NormalizeStandIn`;
    ``transforms.Compose``, ``Resize`` and ``CenterCrop`` build objects that fail if used. Every
    other attribute fails if used.
    """
    names = ("torchvision", "torchvision.models", "torchvision.transforms", "torchvision.datasets", "torchvision.utils")
    modules = {name: _stub(name) for name in names}
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


# -- replayed draws ----------------------------------------------------------------------------
def _find(pairs: Pairs, used: list[bool], images: Tensor, who: str) -> Tensor:
    for index, (source, view) in enumerate(pairs):
        if not used[index] and source.shape == images.shape and torch.equal(source, images.detach()):
            used[index] = True
            return view.clone()
    raise RuntimeError(
        f"{who} was asked to augment a tensor that is none of its expected sources (shape {tuple(images.shape)}): "
        "the update feeds this augmentation something else than the original does."
    )


class ReplayCallable:
    """Replaces an original's augmentation callable: returns the pre-drawn view of each source, in order."""

    def __init__(self, pairs: Pairs, name: str) -> None:
        self.pairs, self.name, self.used = pairs, name, [False] * len(pairs)

    def __call__(self, images: Tensor, *args: Any, **kwargs: Any) -> Tensor:
        return _find(self.pairs, self.used, images, f"original {self.name}")


def replay_augmentation(pairs: Pairs, name: str) -> Any:
    """A vigen ``ImageAugmentation`` whose ``make_params`` picks the pre-drawn view of its input."""
    from vigen.transforms import ImageAugmentation

    class ReplayViews(ImageAugmentation):
        def __init__(self) -> None:
            super().__init__(max_value=255)
            self.pairs, self.name, self.used = pairs, name, [False] * len(pairs)

        def make_params(self, images: Tensor) -> dict[str, Tensor]:
            return {"view": _find(self.pairs, self.used, images, f"vigen {self.name}")}

        def apply(self, images: Tensor, params: dict[str, Tensor]) -> Tensor:
            return params["view"].reshape(images.shape).to(images.dtype)

    return ReplayViews()


class Draws:
    """One stream of standard normals (handed out in call order) and one uniform scalar ``u``."""

    def __init__(self, seed: int, size: int = 100_000) -> None:
        g = torch.Generator().manual_seed(seed + 1)
        self.normals = torch.randn(size, generator=g, dtype=torch.float64)
        self.u = float(torch.rand((), generator=g, dtype=torch.float64))
        self.cursor = 0
        self.uniform_calls = 0

    def normal(self, shape: Sequence[int], dtype: torch.dtype | None) -> Tensor:
        count = math.prod(shape)
        if self.cursor + count > self.normals.numel():
            raise RuntimeError("parity.py: the noise stream ran out; raise Draws(size=...).")
        out = self.normals[self.cursor: self.cursor + count].reshape(tuple(shape))
        self.cursor += count
        return out.to(dtype or torch.get_default_dtype(), copy=True)  # the originals scale it in place

    def uniform(self, low: Any, high: Any) -> Any:
        self.uniform_calls += 1
        return low + (high - low) * self.u

    @contextmanager
    def patched(self, python_random_modules: Sequence[types.ModuleType] = ()) -> Iterator[None]:
        """Route the draws of both sides through this object while the block runs."""
        import torch.distributions.normal as normal_module
        import torch.distributions.utils as dist_utils

        draws = self
        real = {"randn_like": torch.randn_like, "randn": torch.randn, "rand": torch.rand}

        def randn_like(t: Tensor, *args: Any, dtype: torch.dtype | None = None, **kwargs: Any) -> Tensor:
            return draws.normal(t.shape, dtype or t.dtype).to(t.device)

        def randn(*size: Any, generator: Any = None, dtype: torch.dtype | None = None, **kwargs: Any) -> Tensor:
            if generator is not None:
                return real["randn"](*size, generator=generator, dtype=dtype, **kwargs)
            shape = size[0] if len(size) == 1 and isinstance(size[0], (tuple, list, torch.Size)) else size
            return draws.normal(shape, dtype)

        def rand(*size: Any, generator: Any = None, **kwargs: Any) -> Tensor:
            shape = size[0] if len(size) == 1 and isinstance(size[0], (tuple, list, torch.Size)) else size
            if generator is None and tuple(shape) == ():
                return torch.tensor(draws.uniform(0.0, 1.0), dtype=kwargs.get("dtype"), device=kwargs.get("device"))
            return real["rand"](*size, generator=generator, **kwargs)

        def standard_normal(shape: Sequence[int], dtype: torch.dtype, device: Any) -> Tensor:
            return draws.normal(shape, dtype).to(device)

        shim = types.SimpleNamespace(uniform=self.uniform)
        targets = [(torch, "randn_like", randn_like), (torch, "randn", randn), (torch, "rand", rand),
                   (dist_utils, "_standard_normal", standard_normal), (normal_module, "_standard_normal", standard_normal)]
        for module in python_random_modules:
            if hasattr(module, "_standard_normal"):
                targets.append((module, "_standard_normal", standard_normal))
            if hasattr(module, "random"):
                targets.append((module, "random", shim))
        saved = [(obj, name, getattr(obj, name)) for obj, name, _ in targets]
        for obj, name, value in targets:
            setattr(obj, name, value)
        try:
            yield
        finally:
            for obj, name, value in saved:
                setattr(obj, name, value)

    def reset(self) -> None:
        self.cursor, self.uniform_calls = 0, 0


# -- what an algorithm entry declares ----------------------------------------------------------
@dataclass(frozen=True)
class ModuleMap:
    """An original network (attribute path on the agent) → a vigen network (canonical prefix).

    ``renames`` maps a leading part of the original's parameter names to vigen's (e.g. ``Q1`` →
    ``q1``). A plain tensor attribute (DrQ's ``log_alpha``) maps to the name ``prefix`` itself.
    """

    attribute: str
    prefix: str
    renames: tuple[tuple[str, str], ...] = ()

    def resolve(self, agent: Any) -> dict[str, Tensor]:
        obj = agent
        for part in self.attribute.split("."):
            obj = getattr(obj, part)
        if isinstance(obj, Tensor):
            return {self.prefix: obj}
        out = {}
        for name, param in obj.named_parameters():
            for old, new in self.renames:
                if name == old or name.startswith(old + "."):
                    name = new + name[len(old):]
                    break
            out[f"{self.prefix}.{name}"] = param
        return out


@dataclass(frozen=True)
class StepMap:
    """An update step of the original (its optimizers' k-th ``step()`` calls) and vigen's ``loss_*`` for it."""

    name: str
    loss: str
    optimizers: tuple[tuple[str, int], ...]


Measure = Callable[[Any, Any], str]  # (the original's agent, vigen's loss), both after their update → a sentence


@dataclass
class Case:
    """Both sides of one algorithm, ready to run, and what the comparison needs to know."""

    name: str
    agent: Any
    loss: Any
    modules: list[ModuleMap]
    steps: list[StepMap]
    agent_views: dict[str, Pairs]
    module_views: list[tuple[types.ModuleType, str, Pairs]]
    draw_modules: list[types.ModuleType]
    metrics: list[tuple[str, str]]  # (vigen output key, original metric key)
    departures: list[str]
    reference: Reference
    batch: Batch
    setup: Setup
    update_kwargs: dict[str, Any] = field(default_factory=dict)  # the original's update(replay_iter, step, **these)
    # gradients that are 0 in exact arithmetic (name → why): compared on the scale of their step's largest gradient
    zero_gradients: dict[str, str] = field(default_factory=dict)
    measures: list[Measure] = field(default_factory=list)  # sentences on what the update leaves behind (not compared)
    # normals the original draws for outputs it never uses (after all the ones it uses): not owed by vigen
    unused_normals: int = 0


def canonical(vigen_name: str) -> str:
    """``encoder_params.convnet.0.weight`` → ``encoder.convnet.0.weight`` (the table's names)."""
    head, _, rest = vigen_name.partition(".")
    head = head[: -len("_params")] if head.endswith("_params") else head
    return f"{head}.{rest}" if rest else head


def copy_weights(case: Case) -> None:
    """Original → vigen, by mapped names; every vigen parameter must be covered, shapes must agree."""
    original = {}
    for module_map in case.modules:
        original.update(module_map.resolve(case.agent))
    vigen = {canonical(n): p for n, p in case.loss.named_parameters()}
    missing = sorted(set(vigen) - set(original))
    extra = sorted(set(original) - set(vigen))
    if missing or extra:
        raise RuntimeError(f"{case.name}: parameter names do not map: vigen only {missing}, original only {extra}.")
    with torch.no_grad():
        for name, param in vigen.items():
            if param.shape != original[name].shape:
                raise RuntimeError(f"{case.name}: {name} has shape {tuple(param.shape)} in vigen, {tuple(original[name].shape)} in the original.")
            param.copy_(original[name])
        target = getattr(case.loss, "target_critic_params", None)
        if target is not None:  # from the original's own target critic (equal to its critic at start)
            critic_target = ModuleMap("critic_target", "critic", next(m.renames for m in case.modules if m.prefix == "critic"))
            source = critic_target.resolve(case.agent)
            for key, value in target.items(True, True):
                name = "critic." + ".".join(key if isinstance(key, tuple) else (key,))
                value.data.copy_(source[name])


# -- running both sides ------------------------------------------------------------------------
@dataclass
class StepRecord:
    optimizer: str
    loss_index: int
    grads: dict[int, Tensor]


@dataclass
class OriginalRun:
    losses: list[Tensor]
    steps: list[StepRecord]
    metrics: dict[str, float]
    names: dict[int, str]  # id(parameter) → canonical name
    normals: int
    uniforms: int
    agent: Any = None  # the original's agent after the update


def run_original(case: Case, draws: Draws, take_steps: bool) -> OriginalRun:
    agent = copy.deepcopy(case.agent)
    names = {}
    for module_map in case.modules:
        names.update({id(p): n for n, p in module_map.resolve(agent).items()})
    optimizers = {k: v for k, v in vars(agent).items() if isinstance(v, torch.optim.Optimizer)}
    losses: list[Tensor] = []
    steps: list[StepRecord] = []
    real_backward = torch.Tensor.backward

    def backward(self: Tensor, *args: Any, **kwargs: Any) -> None:
        losses.append(self.detach().clone())
        real_backward(self, *args, **kwargs)

    def recorder(name: str, optimizer: torch.optim.Optimizer) -> Callable[..., Any]:
        def step(*args: Any, **kwargs: Any) -> Any:
            grads = {id(p): p.grad.detach().clone() for group in optimizer.param_groups for p in group["params"] if p.grad is not None}
            steps.append(StepRecord(name, len(losses) - 1, grads))
            return type(optimizer).step(optimizer, *args, **kwargs) if take_steps else None
        return step

    for attr, pairs in case.agent_views.items():
        setattr(agent, attr, ReplayCallable(pairs, attr))
    for name, optimizer in optimizers.items():
        optimizer.step = recorder(name, optimizer)  # type: ignore[method-assign]
    saved = [(module, attr, getattr(module, attr)) for module, attr, _ in case.module_views]
    for module, attr, pairs in case.module_views:
        setattr(module, attr, ReplayCallable(pairs, f"{module.__name__}.{attr}"))
    draws.reset()
    torch.Tensor.backward = backward  # type: ignore[method-assign]
    try:
        with draws.patched(case.draw_modules):
            metrics = agent.update(iter([case.batch.for_original()]), case.setup.step, **case.update_kwargs)
    finally:
        torch.Tensor.backward = real_backward  # type: ignore[method-assign]
        for module, attr, value in saved:
            setattr(module, attr, value)
    return OriginalRun(losses, steps, dict(metrics or {}), names, draws.cursor, draws.uniform_calls, agent)


@dataclass
class VigenRun:
    values: dict[str, float]
    grads: dict[str, dict[str, Tensor | None]]  # loss key → canonical name → gradient
    normals: int
    uniforms: int


def run_vigen(case: Case, draws: Draws) -> VigenRun:
    loss = case.loss
    draws.reset()
    params = dict(loss.named_parameters())
    trainable = {name: p for name, p in params.items() if p.requires_grad}  # frozen ones (PIE-G's ResNet) get none
    with draws.patched():
        out = loss(case.batch.for_vigen())
    grads: dict[str, dict[str, Tensor | None]] = {}
    for key in [k for k in out.keys() if k.startswith("loss_")]:
        result = torch.autograd.grad(out[key], list(trainable.values()), retain_graph=True, allow_unused=True)
        grads[key] = {canonical(n): None for n in params} | {canonical(n): g for n, g in zip(trainable, result)}
    values = {k: float(v.detach()) for k, v in out.items() if v.numel() == 1}
    return VigenRun(values, grads, draws.cursor, draws.uniform_calls)


# -- comparison --------------------------------------------------------------------------------
TINY = torch.finfo(torch.float64).tiny


def relative(a: Tensor | float, b: Tensor | float, scale: float | None = None) -> float:
    """``max|a − b| / max(max|b|, tiny)``; ``scale`` replaces ``max|b|`` (a quantity that is 0 in exact arithmetic)."""
    a, b = torch.as_tensor(a, dtype=torch.float64), torch.as_tensor(b, dtype=torch.float64)
    if scale is None:
        scale = b.abs().max().item() if b.numel() else 0.0
    diff = (a - b).abs().max().item() if a.numel() else 0.0
    return diff / max(scale, TINY) if diff else 0.0


@dataclass
class Row:
    quantity: str
    vigen: float
    original: float
    rel: float
    stepped: float | None = None  # rel. diff against the original with its optimizer steps taken
    kind: str = "grad"  # "loss", "metric", "grad", "stray"


def _step_records(run: OriginalRun, step: StepMap, case: Case) -> list[StepRecord]:
    records = []
    for optimizer, index in step.optimizers:
        calls = [r for r in run.steps if r.optimizer == optimizer]
        if index >= len(calls):
            raise RuntimeError(f"{case.name}: the original called {optimizer}.step() {len(calls)} times, the map expects call #{index}.")
        records.append(calls[index])
    if len({r.loss_index for r in records}) != 1:
        raise RuntimeError(f"{case.name}: the optimizers of step {step.name!r} consumed different backward passes.")
    return records


def compare(case: Case, fixed: OriginalRun, stepped: OriginalRun, ours: VigenRun) -> list[Row]:
    rows: list[Row] = []
    for step in case.steps:
        records = _step_records(fixed, step, case)
        records_stepped = _step_records(stepped, step, case)
        value, value_stepped = fixed.losses[records[0].loss_index], stepped.losses[records_stepped[0].loss_index]
        mine = ours.values[step.loss]
        rows.append(Row(f"{step.loss} ({step.name} step)", mine, float(value), relative(mine, value), relative(mine, value_stepped), "loss"))
    for vigen_key, original_key in case.metrics:
        if original_key in fixed.metrics and vigen_key in ours.values:
            mine, theirs = ours.values[vigen_key], fixed.metrics[original_key]
            rows.append(Row(f"{vigen_key} ({original_key})", mine, theirs, relative(mine, theirs),
                            relative(mine, stepped.metrics[original_key]), "metric"))
    for step in case.steps:
        owned: set[str] = set()
        stepped_grads = {}
        for record in _step_records(stepped, step, case):
            stepped_grads.update({stepped.names[i]: g for i, g in record.grads.items()})
        records = _step_records(fixed, step, case)
        largest = max((g.abs().max().item() for r in records for g in r.grads.values() if g.numel()), default=0.0)
        for record in records:
            for pid, theirs in record.grads.items():
                name = fixed.names[pid]
                owned.add(name)
                mine = ours.grads[step.loss].get(name)
                mine = torch.zeros_like(theirs) if mine is None else mine
                quantity, scale = f"∂{step.loss}/∂{name}", None
                if name in case.zero_gradients:  # both sides are rounding noise: measure it against the step's gradients
                    quantity, scale = f"{quantity} (0 in exact arithmetic; rel. to the step's largest gradient)", largest
                rows.append(Row(quantity, mine.norm().item(), theirs.norm().item(), relative(mine, theirs, scale),
                                relative(mine, stepped_grads[name], scale) if name in stepped_grads else None))
        for name, mine in ours.grads[step.loss].items():
            if name not in owned and mine is not None and mine.abs().max().item() > 0:
                rows.append(Row(f"stray ∂{step.loss}/∂{name}", mine.norm().item(), 0.0, math.inf, None, "stray"))
    return rows


def _fmt(x: float | None) -> str:
    if x is None:
        return "—"
    return f"{x:.3e}" if x else "0"


def report(case: Case, rows: list[Row], fixed: OriginalRun, ours: VigenRun, seconds: float, tolerance: float,
           measured: Sequence[str] = ()) -> bool:
    print(f"\n## {case.name}  (reference: {case.reference.root})\n")
    print("| quantity | vigen | original | rel. diff | rel. diff, steps taken |")
    print("| --- | ---: | ---: | ---: | ---: |")
    for row in rows:
        print(f"| {row.quantity} | {_fmt(row.vigen)} | {_fmt(row.original)} | {_fmt(row.rel)} | {_fmt(row.stepped)} |")
    values = [r.rel for r in rows if r.kind in ("loss", "metric")]
    grads = [r.rel for r in rows if r.kind in ("grad", "stray")]
    worst = max(values + grads)
    draws_ok = fixed.normals == ours.normals + case.unused_normals and fixed.uniforms == ours.uniforms
    ok = worst <= tolerance and draws_ok
    unused = f" ({case.unused_normals} of them for outputs it never uses)" if case.unused_normals else ""
    print(f"\nnoise draws: vigen {ours.normals} normals, {ours.uniforms} uniform; original {fixed.normals} normals{unused}, "
          f"{fixed.uniforms} uniform")
    for note in case.reference.notes:
        print(f"note: {note}")
    if case.reference.stubbed:
        print(f"stubbed (not used by the update): {', '.join(case.reference.stubbed)}")
    print("departures (documented; how they are compared):")
    for departure in case.departures:
        print(f"- {departure}")
    for name, why in case.zero_gradients.items():
        print(f"0 in exact arithmetic: the gradient of {name} ({why})")
    for sentence in measured:
        print(f"measured (not compared): {sentence}")
    print(f"\nSUMMARY {case.name}: max rel. diff losses/metrics {max(values):.2e} ({len(values)}), "
          f"gradients {max(grads):.2e} ({len(grads)} tensors); {'OK' if ok else 'MISMATCH'} at tolerance {tolerance:g}"
          f"{'' if draws_ok else ' (draw counts differ)'}; {seconds:.1f} s")
    return ok


# -- RL-ViGen (gemcollector/RL-ViGen, master): the six current losses ---------------------------
RLVIGEN_OPTIONAL = ("hydra", "omegaconf", "torchvision", "torchvision.transforms", "torchvision.datasets",
                    "torchvision.utils", "kornia")
DDPG_DEPARTURE = (
    "RL-ViGen computes the actor loss after its critic/encoder Adam step; vigen's actor loss sees the critic "
    "before the step (TorchRL's DDPG). Compared at the same parameters (steps recorded, not taken); "
    "'steps taken' shows the effect of the order."
)
CRITIC_STEPS = [
    StepMap("critic", "loss_critic", (("critic_opt", 0), ("encoder_opt", 0))),
    StepMap("actor", "loss_actor", (("actor_opt", 0),)),
]
CRITIC_MODULES = [
    ModuleMap("actor", "actor"),
    ModuleMap("critic", "critic", (("Q1", "q1"), ("Q2", "q2"))),
]
DDPG_METRICS = [("target_mean", "critic_target_q"), ("q_mean", "critic_q1")]


def _rlvigen(reference: Path, names: Sequence[str], captum: bool = False) -> Reference:
    substitutes, notes = captum_substitute() if captum else ({}, [])
    ref = import_reference(reference, names, paths=("", "algos"), optional=RLVIGEN_OPTIONAL, substitutes=substitutes)
    ref.notes.extend(notes)
    return ref


def _agent_kwargs(setup: Setup) -> dict[str, Any]:
    return dict(
        obs_shape=setup.obs_shape, action_shape=(setup.action_dim,), device="cpu", lr=setup.lr,
        feature_dim=setup.feature_dim, hidden_dim=setup.hidden_dim, critic_target_tau=0.01, num_expl_steps=2000,
        update_every_steps=2, stddev_schedule="linear(1.0,0.1,100000)", stddev_clip=0.3, use_tb=True,
    )


def _heads(setup: Setup, repr_dim: int) -> tuple[nn.Module, nn.Module]:
    from vigen.models import Actor, Critic

    return (Actor(repr_dim, setup.action_dim, setup.feature_dim, setup.hidden_dim),
            Critic(repr_dim, setup.action_dim, setup.feature_dim, setup.hidden_dim))


def _ddpg_options() -> dict[str, Any]:
    from vigen.losses import LinearSchedule

    return dict(std=LinearSchedule(1.0, 0.1, 100_000), std_clip=0.3)


def _finish(loss: Any, setup: Setup) -> Any:
    loss.make_value_estimator(gamma=setup.gamma)
    loss.set_step(setup.step)
    return loss


class Views:
    """The views of one batch, drawn once with vigen's augmentations (seeded), float64 on 0–255."""

    def __init__(self, batch: Batch, setup: Setup) -> None:
        from vigen.transforms import RandomFrequencyMask, RandomOverlay, RandomShift

        self.batch = batch
        seed = setup.seed + 100
        self._shift = lambda k, x: RandomShift(pad=4, max_value=255, seed=seed + k).augment(x)
        self._overlay = lambda k, x: RandomOverlay(alpha=0.5, max_value=255, seed=seed + 10 + k).augment(x)
        # p=1 so that the frequency ring is really cut in this one batch (RL-ViGen draws p=0.5 per batch)
        self._srm = lambda x: RandomFrequencyMask(p=1.0, max_value=255, seed=seed + 20).augment(x)
        self.obs = self._shift(0, batch.pixels)
        self.next_obs = self._shift(1, batch.next_pixels)

    def weak(self) -> Pairs:
        return [(self.batch.pixels, self.obs), (self.batch.next_pixels, self.next_obs)]

    def shift(self, k: int) -> Tensor:
        return self._shift(2 + k, self.batch.pixels)

    def overlay(self, k: int, x: Tensor) -> Tensor:
        return self._overlay(k, x)

    def srm(self, x: Tensor) -> Tensor:
        return self._srm(x)


def build_drqv2(reference: Path, setup: Setup) -> Case:
    from vigen.losses import DrQv2Loss
    from vigen.models import DrQv2Encoder

    ref = _rlvigen(reference, ["utils", "drqv2"])
    agent = ref.modules["drqv2"].DrQV2Agent(**_agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    encoder = DrQv2Encoder(setup.channels, max_value=255)
    loss = DrQv2Loss(encoder, *_heads(setup, 32 * 35 * 35), augmentation=replay_augmentation(views.weak(), "shift"), **_ddpg_options())
    return Case("drqv2", agent, _finish(loss, setup), [ModuleMap("encoder", "encoder"), *CRITIC_MODULES], CRITIC_STEPS,
                {"aug": views.weak()}, [], [ref.modules["utils"]], DDPG_METRICS, [DDPG_DEPARTURE], ref, batch, setup)


def _svea_like(reference: Path, setup: Setup, name: str) -> Case:
    from vigen.losses import SRMLoss, SVEALoss
    from vigen.models import SharedCNN

    ref = _rlvigen(reference, ["utils", "svea", "srm"])
    module = ref.modules[name]
    agent = (module.SRMAgent if name == "srm" else module.SVEAAgent)(**_agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    overlaid = views.overlay(0, views.obs)
    overlay_pairs: Pairs = [(views.obs, overlaid)]
    module_views = [(module, "random_overlay", overlay_pairs)]
    strong = [replay_augmentation(overlay_pairs, "overlay")]
    departures = [
        DDPG_DEPARTURE,
        "vigen rounds the overlay blend of uint8 frames to uint8 (RL-ViGen blends floats); the views here are float "
        "and replayed to both sides, so the rounding is not exercised.",
    ]
    if name == "srm":
        masked = views.srm(overlaid)
        mask_pairs: Pairs = [(overlaid, masked)]
        module_views.append((module, "random_mask_freq_v2", mask_pairs))
        strong.append(replay_augmentation(mask_pairs, "frequency mask"))
        departures.append("RL-ViGen's frequency mask is not clamped to [0, 255] and applies with p=0.5 per batch; the "
                          "replayed view is vigen's RandomFrequencyMask(p=1) draw (clamped), given to both sides.")
    cls = SRMLoss if name == "srm" else SVEALoss
    encoder = SharedCNN(setup.channels, max_value=255)
    loss = cls(encoder, *_heads(setup, 32 * 21 * 21), augmentation=replay_augmentation(views.weak(), "shift"),
               strong_augmentation=strong, **_ddpg_options())
    modules = [ModuleMap("encoder", "encoder", (("layers", "convnet"),)), *CRITIC_MODULES]
    return Case(name, agent, _finish(loss, setup), modules, CRITIC_STEPS, {"aug": views.weak()}, module_views,
                [ref.modules["utils"]], DDPG_METRICS, departures, ref, batch, setup)


def build_svea(reference: Path, setup: Setup) -> Case:
    return _svea_like(reference, setup, "svea")


def build_srm(reference: Path, setup: Setup) -> Case:
    return _svea_like(reference, setup, "srm")


def build_curl(reference: Path, setup: Setup) -> Case:
    from vigen.losses import CURLLoss
    from vigen.models import CURLHead, ProjectedEncoder

    ref = _rlvigen(reference, ["utils", "drqv2", "drq", "curl"])
    agent = ref.modules["curl"].CURLAgent(aux_lr=1e-4, aux_beta=0.99, **_agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    anchor, positive = views.shift(0), views.shift(1)
    contrastive: Pairs = [(batch.pixels, anchor), (batch.pixels, positive)]
    original_order = views.weak() + contrastive  # obs, next_obs, anchor, positive: the order of CURLAgent.update
    encoder = ProjectedEncoder(setup.channels, image_size=setup.image_size, max_value=255)
    loss = CURLLoss(encoder, *_heads(setup, 512), CURLHead(512), augmentation=replay_augmentation(views.weak(), "shift"),
                    contrastive_augmentation=replay_augmentation(contrastive, "contrastive shift"), **_ddpg_options())
    modules = [ModuleMap("encoder", "encoder", (("projector", "projection"),)), ModuleMap("curl_head", "head"), *CRITIC_MODULES]
    steps = CRITIC_STEPS + [StepMap("curl", "loss_curl", (("curl_optimizer", 0), ("encoder_opt", 1)))]
    departures = [
        DDPG_DEPARTURE,
        "RL-ViGen encodes the contrastive anchor after the critic step and steps the encoder a second time "
        "(encoder_opt, plus curl_optimizer with betas (0.99, 0.999)); vigen takes loss_curl from the same "
        "parameters as loss_critic, in one backward. Compared: ∂loss_curl against the gradients of that second "
        "step, at unchanged parameters ('steps taken': after the critic step).",
        "Positives come from the online encoder without gradient on both sides (no momentum key encoder).",
    ]
    return Case("curl", agent, _finish(loss, setup), modules, steps, {"aug": original_order}, [], [ref.modules["utils"]],
                DDPG_METRICS, departures, ref, batch, setup)


def build_sgqn(reference: Path, setup: Setup) -> Case:
    from vigen.losses import SGQNLoss
    from vigen.models import AttributionDecoder, ProjectedEncoder

    ref = _rlvigen(reference, ["utils", "rl_utils", "drqv2", "sgqn"], captum=True)
    module = ref.modules["sgqn"]
    agent = module.SGQNAgent(aux_lr=1e-4, aux_beta=0.99, sgqn_quantile=0.93, **_agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    overlay_pairs: Pairs = [(views.obs, views.overlay(0, views.obs))]
    encoder = ProjectedEncoder(setup.channels, image_size=setup.image_size, max_value=255)
    decoder = AttributionDecoder(setup.action_dim, embedding_dim=512, image_size=setup.image_size)
    loss = SGQNLoss(encoder, *_heads(setup, 512), decoder, quantile=0.93, consistency_weight=0.9,
                    augmentation=replay_augmentation(views.weak(), "shift"),
                    attribution_augmentation=replay_augmentation(overlay_pairs, "overlay"), **_ddpg_options())
    modules = [ModuleMap("encoder", "encoder", (("projector", "projection"),)),
               ModuleMap("attribution_predictor.decoder", "decoder"), *CRITIC_MODULES]
    steps = CRITIC_STEPS + [StepMap("attribution", "loss_attribution", (("aux_optimizer", 0),))]
    departures = [
        DDPG_DEPARTURE,
        "RL-ViGen recomputes the guided-backprop mask after the critic step and trains the attribution head "
        "with its own Adam over encoder + decoder (aux_lr, betas (0.99, 0.999)); vigen uses the mask of the "
        "critic step and one backward. At unchanged parameters both masks are the same; 'steps taken' shows "
        "the recomputed mask's effect.",
        "The fill of non-salient pixels is one scalar U(min s, max s) on both sides (the same u).",
    ]
    return Case("sgqn", agent, _finish(loss, setup), modules, steps, {"aug": views.weak()},
                [(module, "random_overlay", overlay_pairs)], [ref.modules["utils"], module], DDPG_METRICS, departures,
                ref, batch, setup)


def build_drq(reference: Path, setup: Setup) -> Case:
    from vigen.losses import DrQLoss
    from vigen.models import Critic, DrQv2Encoder, GaussianActor

    ref = _rlvigen(reference, ["utils", "drq"])
    kwargs = _agent_kwargs(setup)
    kwargs["use_tb"] = False  # its metrics call SquashedNormal.entropy(), which torch does not implement
    agent = ref.modules["drq"].DrQAgent(init_temperature=0.1, log_std_bounds=[-10, 2], hidden_depth=2, **kwargs)
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    repr_dim = 32 * 35 * 35
    loss = DrQLoss(DrQv2Encoder(setup.channels, max_value=255),
                   GaussianActor(repr_dim, setup.action_dim, setup.hidden_dim, hidden_depth=2, log_std_bounds=(-10.0, 2.0)),
                   Critic(repr_dim, setup.action_dim, setup.feature_dim, setup.hidden_dim),
                   init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"))
    loss.make_value_estimator(gamma=setup.gamma)
    modules = [ModuleMap("encoder", "encoder"), ModuleMap("actor", "actor", (("trunk", "policy"),)),
               ModuleMap("critic", "critic", (("Q1", "q1"), ("Q2", "q2"))), ModuleMap("log_alpha", "log_alpha")]
    steps = [
        StepMap("critic", "loss_critic", (("critic_opt", 0), ("encoder_opt", 0))),
        StepMap("actor", "loss_actor", (("actor_opt", 0),)),
        StepMap("alpha", "loss_alpha", (("log_alpha_optimizer", 0),)),
    ]
    departures = [
        "Like RL-ViGen (and unlike the original DrQ's K = M = 2 shifted views), vigen's default pairs the raw "
        "view with one shifted view; DrQLoss(clean_view=False, target_encoder=True) is the original DrQ and is "
        "not compared here.",
        "RL-ViGen computes the actor and temperature losses after its critic step; compared at the same "
        "parameters ('steps taken' shows the order's effect). nstep = 1 as in RL-ViGen's DrQ config.",
    ]
    return Case("drq", agent, loss, modules, steps, {"aug": views.weak()}, [], [ref.modules["utils"]], [],
                departures, ref, batch, setup)


# -- DMC-GB2 (aalmuzairee/dmcgb2, main): SADA -----------------------------------------------------
DMCGB2_OPTIONAL = ("torchvision", "torchvision.transforms", "torchvision.datasets")


def build_sada(reference: Path, setup: Setup) -> Case:
    from vigen.losses import make_loss
    from vigen.transforms import DMCGB2_AUGMENTATIONS, dmcgb2_strong_augmentation

    ref = import_reference(reference, ["utils", "augmentations", "sada"], paths=("", "algos"), optional=DMCGB2_OPTIONAL)
    kwargs = _agent_kwargs(setup)
    for option in ("stddev_schedule", "stddev_clip", "use_tb"):
        del kwargs[option]
    # strong_augs only builds the callable that the replay replaces; "overlay" builds without torchvision
    agent = ref.modules["sada"].AGENT(init_temperature=0.1, log_std_bounds=[-10, 2], strong_augs=["overlay"], **kwargs)
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    strong, twin = (dmcgb2_strong_augmentation("all", seed=setup.seed + 130) for _ in range(2))
    strong.max_value = twin.max_value = 255
    strong_pairs: Pairs = [(views.obs, strong.augment(views.obs))]
    drawn = sorted({DMCGB2_AUGMENTATIONS[int(i)] for i in twin.make_params(views.obs)["choice"]}, key=DMCGB2_AUGMENTATIONS.index)
    # make_loss builds DMC-GB2's networks: DrQ-v2's encoder, the LayerNorm-trunk twin critic, the SAC actor on a trunk
    loss = make_loss("sada", setup.obs_shape, setup.action_dim, feature_dim=setup.feature_dim, hidden_dim=setup.hidden_dim,
                     max_value=255, init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"),
                     strong_augmentation=replay_augmentation(strong_pairs, "strong"))
    loss.make_value_estimator(gamma=setup.gamma)
    modules = [ModuleMap("encoder", "encoder"), ModuleMap("actor", "actor"),
               ModuleMap("critic", "critic", (("Q1", "q1"), ("Q2", "q2"))), ModuleMap("log_alpha", "log_alpha")]
    steps = [
        StepMap("critic", "loss_critic", (("critic_opt", 0), ("encoder_opt", 0))),
        StepMap("actor", "loss_actor", (("actor_opt", 0),)),
        StepMap("alpha", "loss_alpha", (("log_alpha_optimizer", 0),)),
    ]
    metrics = [("target_mean", "critic_target_q"), ("q_mean", "reg_critic_q1"), ("q_strong_mean", "aug_critic_q1"),
               ("entropy", "actor_entropy"), ("alpha", "alpha_value")]
    departures = [
        "DMC-GB2 computes the actor and temperature losses after its critic/encoder Adam step (the actor then reads "
        "the stepped critic); vigen's come from the same parameters as loss_critic. Compared at unchanged "
        "parameters; 'steps taken' shows the order's effect (default setup: loss_actor 1.4e-1, ∂loss_actor up to "
        "1.1e-1; loss_alpha and ∂loss_alpha unchanged: their log π comes from before the actor step). The actor, the "
        "critic and α are all updated on every update call (no delayed actor; update_every_steps=2 gates the whole "
        "update and is met at this step).",
        "DMC-GB2's metric alpha_value is read after its temperature step: equal at unchanged parameters, 'steps "
        "taken' differs by the one Adam step on log α (about lr = 1e-4).",
        "DMC-GB2's actor loss is backpropagated through the critic (not frozen) and leaves gradients in the critic's "
        ".grad, which actor_opt does not step and the next critic update zeroes first; vigen freezes the critic. No effect on "
        "any step (no stray gradient row).",
        "Strong view: DMC-GB2's compose_augs(['all']) (per sample one of conv, overlay, conv+overlay, rotate, shift, "
        "rotate+shift; overlay images from Places365 on CUDA, rotation by torchvision) is replaced by one draw of "
        "vigen's dmcgb2_strong_augmentation('all') (built-in image bank), replayed to both sides; the kernels are "
        f"checked against DMC-GB2's definitions in vigen's transform tests, not here. This batch's draw: {', '.join(drawn)}.",
        "nstep = 1 and discount γ as in DMC-GB2's config; the next observation is encoded by the online encoder "
        "without gradient on both sides (no target encoder).",
    ]
    return Case("sada", agent, loss, modules, steps, {"aug": views.weak(), "apply_strong_aug": strong_pairs}, [],
                [ref.modules["utils"]], metrics, departures, ref, batch, setup)


# -- BatchNorm running statistics: what an update leaves behind ---------------------------------
_STATISTICS = ("running_mean", "running_var", "num_batches_tracked")


def batchnorm_statistics(agent: Any, attribute: str, prefix: str, loss: Any) -> tuple[dict[str, Tensor], dict[str, Tensor]]:
    """The BatchNorm buffers of vigen's ``loss`` and of the original's module ``attribute`` (under vigen's name ``prefix``).

    Both as ``{canonical name: copy}``: running means, variances and batch counts; every one of
    vigen's must have its counterpart in the original.
    """
    module = agent
    for part in attribute.split("."):
        module = getattr(module, part)
    ours = {canonical(n): b.detach().clone() for n, b in loss.named_buffers() if n.rsplit(".", 1)[-1] in _STATISTICS}
    theirs = {f"{prefix}.{n}": b.detach().clone() for n, b in module.named_buffers() if f"{prefix}.{n}" in ours}
    if set(ours) != set(theirs):
        raise RuntimeError(f"BatchNorm buffers of vigen without a counterpart in the original: {sorted(set(ours) - set(theirs))[:4]}")
    return theirs, ours


class StatisticsGap:
    """How far vigen's BatchNorm running statistics are from the original's, at build and after the update.

    The running statistics are an exponential average (momentum m): after p passes, ``(1 − m)^p``
    of a gap at build is left; the rest of the gap after the update comes from the order in which
    the passes saw their batches. Every gap is relative to the original's statistics after the
    update (those it acts with), per tensor, then the max over tensors. What the gap changes when
    acting: the original's deterministic actions (``agent.act(obs, step, eval_mode=True)`` in eval
    mode) on the observations ``pixels`` with its own statistics and with vigen's. Called as a
    :data:`Measure`.
    """

    def __init__(self, agent: Any, attribute: str, prefix: str, loss: Any, pixels: Tensor, step: int) -> None:
        self.attribute, self.prefix, self.pixels, self.step = attribute, prefix, pixels, step
        self.original, self.vigen = batchnorm_statistics(agent, attribute, prefix, loss)
        module = agent
        for part in attribute.split("."):
            module = getattr(module, part)
        momenta = {m.momentum for m in module.modules() if isinstance(m, nn.modules.batchnorm._BatchNorm)}
        if len(momenta) != 1 or None in momenta:
            raise RuntimeError(f"StatisticsGap needs one BatchNorm momentum, found {momenta}.")
        self.momentum = float(momenta.pop())

    def __call__(self, agent: Any, loss: Any) -> str:
        original, vigen = batchnorm_statistics(agent, self.attribute, self.prefix, loss)
        count = next(k for k in vigen if k.endswith("num_batches_tracked"))
        passes = int(original[count] - self.original[count]), int(vigen[count] - self.vigen[count])
        decay = (1 - self.momentum) ** passes[0]
        built, after, order = 0.0, 0.0, 0.0
        running = [k for k in vigen if not k.endswith("num_batches_tracked")]
        for key in running:
            scale = max(original[key].abs().max().item(), TINY)
            start = self.vigen[key] - self.original[key]
            built = max(built, start.abs().max().item() / scale)
            after = max(after, (vigen[key] - original[key]).abs().max().item() / scale)
            order = max(order, (vigen[key] - original[key] - decay * start).abs().max().item() / scale)
        swapped = copy.deepcopy(agent)
        module = swapped
        for part in self.attribute.split("."):
            module = getattr(module, part)
        with torch.no_grad():
            for name, buffer in module.named_buffers():
                if f"{self.prefix}.{name}" in vigen:
                    buffer.copy_(vigen[f"{self.prefix}.{name}"])
        acting = relative(self._actions(swapped), self._actions(agent))
        return (f"BatchNorm running statistics ({len(running)} tensors; {passes[1]} encoder passes in vigen, {passes[0]} in the "
                f"original), max rel. diff vigen vs original (to the original's after the update): {built:.1e} at build, "
                f"{after:.1e} after the update, of which {decay * built:.1e} is what is left of the build-time gap "
                f"((1 − {self.momentum:g})^{passes[0]} of it) and {order:.1e} comes from the order of the passes. Acting "
                f"(eval mode, running statistics) on the batch's {len(self.pixels)} observations, the original's "
                f"deterministic actions with vigen's statistics instead of its own: max rel. diff {acting:.1e}")

    def _actions(self, agent: Any) -> Tensor:
        agent.train(False)
        try:
            with torch.no_grad():
                return torch.stack([torch.as_tensor(agent.act(obs, self.step, eval_mode=True)) for obs in self.pixels])
        finally:
            agent.train(True)


# -- PIE-G (RL-ViGen master) and VRL3 (RL-ViGen, branch ViGen-adroit) ------------------------------
def build_pieg(reference: Path, setup: Setup) -> Case:
    from vigen.losses import PIEGLoss
    from vigen.models import PIEGEncoder

    imagenet = imagenet_stand_in(setup.seed + 200)
    substitutes, notes = torchvision_substitute(imagenet)
    ref = import_reference(reference, ["utils", "pieg"], paths=("", "algos"), optional=RLVIGEN_OPTIONAL, substitutes=substitutes)
    ref.notes.extend(notes)
    module = ref.modules["pieg"]
    agent = module.PIEGAgent(**_agent_kwargs(setup))
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    overlay_pairs: Pairs = [(views.obs, views.overlay(0, views.obs))]
    with tempfile.TemporaryDirectory() as folder:  # vigen loads torchvision's state dict from a file
        weights = Path(folder) / "resnet18.pth"
        torch.save(imagenet.state_dict(), weights)
        encoder = PIEGEncoder(setup.channels, image_size=setup.image_size, out_dim=agent.encoder.repr_dim, weights=weights,
                              max_value=255)
    loss = PIEGLoss(encoder, *_heads(setup, encoder.out_dim), augmentation=replay_augmentation(views.weak(), "shift"),
                    strong_augmentation=replay_augmentation(overlay_pairs, "overlay"), **_ddpg_options())
    loss = _finish(loss, setup)
    resnet = [ModuleMap(f"encoder.model.{name}", f"encoder.resnet.{name}") for name in ("conv1", "bn1", "layer1", "layer2")]
    modules = [*resnet, ModuleMap("encoder.fc", "encoder.fc"), ModuleMap("encoder.ln", "encoder.ln"), *CRITIC_MODULES]
    gap = StatisticsGap(agent, "encoder.model", "encoder.resnet", loss, batch.pixels, setup.step)
    departures = [
        DDPG_DEPARTURE + " Default setup: loss_actor 5.6e-2, ∂loss_actor up to 3.5e-1.",
        "RL-ViGen's ResEncoder measures its output size with a training-mode forward pass of 32 random-normal stacks "
        "while it is built, which moves its BatchNorm running statistics one momentum step (0.1) from the loaded "
        "weights' towards that noise's; vigen's start at the loaded values. They are left different here: the update "
        "normalises with batch statistics, so no loss or gradient depends on them (confirmed by the rows above); they "
        "matter when acting (running statistics), until the gap fades (× 0.9 per encoder pass, 3 per update: below "
        "1e-6 of it after 44 updates): see 'measured'.",
        "vigen encodes the next view first (its target comes before the critic loss), then the clean and the overlaid "
        "view, one pass each; RL-ViGen encodes clean, overlaid, next. Same batch statistics, so the same outputs; the "
        "running statistics see the three batches in another order (see 'measured').",
        "The ResNet's weights are frozen on both sides (no gradient; RL-ViGen's encoder_opt holds them but they get "
        "none); only the encoder's Linear and LayerNorm learn, from the critic loss.",
        "vigen rounds the overlay blend of uint8 frames to uint8 (RL-ViGen blends floats); the views here are float "
        "and replayed to both sides, so the rounding is not exercised.",
        "RL-ViGen's ViGen-adroit branch runs PIE-G on VRL3's stage-3 update (safe Q target, std 0.01, feature_dim 256, "
        "hand joint positions); this row is the master branch's agent (DMC, robosuite), which PIEGLoss implements.",
    ]
    return Case("pieg", agent, loss, modules, CRITIC_STEPS, {"aug": views.weak()}, [(module, "random_overlay", overlay_pairs)],
                [ref.modules["utils"]], DDPG_METRICS, departures, ref, batch, setup, measures=[gap])


# RL-ViGen's thresholds (200 and 5) are not reached by a random initial network: lowered on both sides so that both
# branches of each run (default setup: 4 of the 8 targets above 0 compressed; 8 of the 32 pre-tanh outputs beyond 0.2)
VRL3_SAFE_Q_THRESHOLD = -1.0
VRL3_PRETANH_THRESHOLD = 0.2


def build_vrl3(reference: Path, setup: Setup) -> Case:
    from vigen.losses import VRL3Loss
    from vigen.models import VRL3Encoder

    substitutes, notes = torchvision_substitute()
    ref = import_reference(reference, ["utils", "stage1_models", "transfer_util", "vrl3_agent"], paths=("", "algos"),
                           optional=("hydra", "omegaconf"), substitutes=substitutes)
    ref.notes.extend(notes)
    agent = ref.modules["vrl3_agent"].VRL3Agent(
        obs_shape=setup.obs_shape, action_shape=(setup.action_dim,), device="cpu", use_sensor=False, lr=setup.lr,
        feature_dim=setup.feature_dim, hidden_dim=setup.hidden_dim, critic_target_tau=0.01, num_expl_steps=0,
        update_every_steps=2, stddev_clip=0.3, use_tb=False, use_data_aug=True, encoder_lr_scale=1,
        stage1_model_name="resnet6_32channel", safe_q_target_factor=0.5, safe_q_threshold=VRL3_SAFE_Q_THRESHOLD,
        pretanh_penalty=0.001, pretanh_threshold=VRL3_PRETANH_THRESHOLD, stage2_update_encoder=True, cql_weight=1,
        cql_temp=1, cql_n_random=10, stage2_std=0.1, stage2_bc_weight=0, stage3_update_encoder=True, std0=0.01,
        std1=0.01, std_n_decay=500000, stage3_bc_lam0=0, stage3_bc_lam1=0.95,
    )
    agent.switch_to_RL_stages(verbose=False)  # its training script does this before stages 2 and 3
    batch = Batch.draw(setup, setup.nstep)
    views = Views(batch, setup)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # random initial weights, as RL-ViGen (stage1_use_pretrain=False)
        encoder = VRL3Encoder(setup.channels, max_value=255)
    loss = VRL3Loss(encoder, *_heads(setup, encoder.output_size), augmentation=replay_augmentation(views.weak(), "shift"),
                    safe_q_threshold=VRL3_SAFE_Q_THRESHOLD, pretanh_threshold=VRL3_PRETANH_THRESHOLD, std=0.01, std_clip=0.3)
    loss = _finish(loss, setup)
    modules = [ModuleMap("encoder.model", "encoder"), *CRITIC_MODULES]
    metrics = [*DDPG_METRICS, ("abs_pretanh", "abs_pretanh"), ("max_abs_pretanh", "max_abs_pretanh")]
    gap = StatisticsGap(agent, "encoder.model", "encoder", loss, batch.pixels, setup.step)
    departures = [
        DDPG_DEPARTURE + " Default setup: loss_actor 1.0e-1, ∂loss_actor up to 8.9e-1.",
        "RL-ViGen's Adroit config (use_sensor: true) feeds the actor and critic the hand's 24 joint positions next to "
        "the image features; vigen's loss is pixels only. The original runs here with use_sensor=False, its own "
        "pixel-only branch: the same math as zero joint positions (the trunks' 24 extra input columns would add "
        "nothing and get no gradient). With real joint positions the networks' inputs differ: nothing to compare.",
        "RL-ViGen fills its replay buffer with 25 demonstrations and runs stage 3 alone (train.sh: stage1_use_pretrain="
        "False, stage2_n_update=0); the demonstrations are data, not the update (both sides get the same synthetic "
        "batch), and its stage-3 BC weight stage3_bc_lam0 = 0 keeps its BC branch off (vigen has none). Without stage "
        "1 both encoders start from random weights (here the original's, copied), the one-frame stem tiled over the "
        "3 frames and divided by 3 (the original's switch_to_RL_stages(), VRL3Encoder's construction).",
        "encoder_lr_scale (RL-ViGen: 1; relocate 0.01) scales the encoder's Adam learning rate (RL-ViGen's "
        "encoder_opt, vigen's VRL3Loss.optimizer_groups): it changes the step, not any loss or gradient; 'steps "
        "taken' uses 1.",
        "σ = 0.01 on both sides (RL-ViGen: linear(0.01, 0.01, 500000), the same constant); the clip 0.3 is never "
        "reached at that σ.",
        f"safe_q_threshold {VRL3_SAFE_Q_THRESHOLD:g} and pretanh_threshold {VRL3_PRETANH_THRESHOLD:g} on both sides "
        "(RL-ViGen: 200, on Adroit rewards scaled by 1/20 to 1/100, and 5, which random initial networks never reach), "
        "so that in the default setup the safe target compresses 4 of the 8 targets and the penalty acts on 8 of the "
        "32 pre-tanh outputs; the penalty weight is RL-ViGen's 0.001.",
        "vigen encodes the next observation first (its target comes before the critic loss), RL-ViGen the current one: "
        "the same batch statistics, so the same outputs; the running statistics see the two batches in the other "
        "order (see 'measured').",
        "RL-ViGen's zero BC term is torch.FloatTensor([0]), a one-element float32 tensor: under the tool's float64 it "
        "would make the summed actor loss float32 by type promotion (its value rounded by 2.6e-8, gradients "
        "unchanged), so the tool builds it float64. In RL-ViGen's float32 training it changes nothing.",
    ]
    return Case("vrl3", agent, loss, modules, CRITIC_STEPS, {"aug": views.weak()}, [], [ref.modules["utils"]], metrics,
                departures, ref, batch, setup, update_kwargs={"stage": 3, "use_sensor": False}, measures=[gap],
                zero_gradients={"encoder.conv1.bias": "the stem's bias is followed by a training-mode BatchNorm, which "
                                "subtracts each channel's batch mean"})

# -- DMC-GB's SAC agents: MaDi, SimGRL, SCPL (their authors' code, each a fork of DMC-GB) ------------
DMCGB_OPTIONAL = ("torchvision", "torchvision.transforms", "torchvision.datasets", "torchvision.utils", "kornia",
                  "env", "env.wrappers", "video")
DMCGB_STEP = 2  # even (actor, target and auxiliary updates run), no multiple of 10,000 (the forks save images there)
DMCGB_DEPARTURES = [
    "DMC-GB's SAC steps the critic, then the actor and temperature (reading the stepped critic and encoder), each with "
    "its own Adam; vigen takes every term at the parameters of the batch's start and steps once. Compared at unchanged "
    "parameters; 'steps taken' shows the order's effect.",
    f"DMC-GB updates the actor and the target networks on every second update (actor_update_freq, "
    f"critic_target_update_freq 2); compared at step {DMCGB_STEP}, where both run. vigen's loss computes every term at "
    "every call. SoftUpdate has one τ (DMC-GB: 0.01 for the Q heads, 0.05 for the encoder and the critic projection).",
    "DMC-GB's actor recomputes the convolutions on the observation for the actor and for the critic's score (after "
    "the critic step); vigen's actor reads the critic step's detached features: at unchanged parameters, the same.",
]


class _NoWriter:
    """``torch.utils.tensorboard.SummaryWriter`` for SCPL's constructor: accepts everything, writes nothing."""

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        pass

    def add_image(self, *args: Any, **kwargs: Any) -> None:
        pass


class _NoRecorder:
    """MaDi's ``AugmentationRecorder``: records nothing."""

    def record(self, *args: Any, **kwargs: Any) -> None:
        pass


class _Log:
    """DMC-GB's logger ``L``: keeps the last value of each key."""

    def __init__(self) -> None:
        self.values: dict[str, float] = {}

    def log(self, key: str, value: Any, step: int) -> None:
        self.values[key] = float(value.detach()) if isinstance(value, Tensor) else float(value)


class DMCGBDriver:
    """A DMC-GB agent (``update(replay_buffer, L, step)``) behind the tool's ``update(replay_iter, step)``.

    The buffer hands out DMC-GB's ``sample_drq()`` (obs and next obs shifted) and ``sample_svea()``
    (obs shifted), the shifts from the tool's replay (the ``aug`` attribute); the update runs at
    :data:`DMCGB_STEP`. The driver exposes the agent's optimizers and, as ``critic`` and
    ``critic_target``, modules holding the original's critic projection and Q networks under
    vigen's names (``trunk``, ``q1``, ``q2``).
    """

    def __init__(self, agent: Any) -> None:
        self.agent = agent
        for name, value in vars(agent).items():
            if isinstance(value, torch.optim.Optimizer):
                setattr(self, name, value)
        self.critic = self._heads(agent.critic)
        self.critic_target = self._heads(agent.critic_target)
        self.aug: Callable[[Tensor], Tensor] | None = None

    @staticmethod
    def _heads(critic: nn.Module) -> nn.Module:
        heads = nn.Module()
        heads.trunk = critic.encoder.projection.projection
        heads.q1, heads.q2 = critic.Q1.trunk, critic.Q2.trunk
        return heads

    def update(self, replay_iter: Iterator[tuple[Tensor, ...]], step: int) -> dict[str, float]:
        obs, action, reward, _, next_obs = next(replay_iter)
        aug, not_done = self.aug, torch.ones_like(reward)
        assert aug is not None
        buffer = types.SimpleNamespace(sample_drq=lambda: (aug(obs), action, reward, aug(next_obs), not_done),
                                       sample_svea=lambda: (aug(obs), action, reward, next_obs, not_done))
        log = _Log()
        self.agent.update(buffer, log, DMCGB_STEP)
        return log.values


@contextlib.contextmanager
def cuda_is_cpu() -> Iterator[None]:
    """``Module.cuda()`` and ``Tensor.cuda()`` return their object while the block runs (the forks build on ``.cuda()``)."""
    module_cuda, tensor_cuda = nn.Module.cuda, torch.Tensor.cuda
    nn.Module.cuda = lambda self, *args, **kwargs: self  # type: ignore[method-assign]
    torch.Tensor.cuda = lambda self, *args, **kwargs: self  # type: ignore[method-assign]
    try:
        yield
    finally:
        nn.Module.cuda, torch.Tensor.cuda = module_cuda, tensor_cuda  # type: ignore[method-assign]


def _dmcgb_args(setup: Setup, **extra: Any) -> types.SimpleNamespace:
    """The arguments DMC-GB's SAC reads (its defaults, the tool's sizes, one learning rate)."""
    return types.SimpleNamespace(
        discount=setup.gamma, critic_tau=0.01, encoder_tau=0.05, actor_update_freq=2, critic_target_update_freq=2,
        num_shared_layers=11, num_head_layers=0, num_filters=32, projection_dim=setup.feature_dim,
        hidden_dim=setup.hidden_dim, actor_log_std_min=-10, actor_log_std_max=2, init_temperature=0.1,
        actor_lr=setup.lr, actor_beta=0.9, critic_lr=setup.lr, critic_beta=0.9, alpha_lr=setup.lr, alpha_beta=0.5,
        critic_weight_decay=0.0, device="cpu", work_dir=tempfile.gettempdir(), log_dir=tempfile.gettempdir(),
        domain_name="walker", task_name="walk", seed=0, frame_stack=3, init_steps=1000, **extra,
    )


def _dmcgb_maps(convs: list[ModuleMap]) -> list[ModuleMap]:
    """DMC-GB's SAC networks → vigen's: the shared convolutions (``convs``), the critic's projection and Q
    heads (through the driver's ``critic``), the actor's projection and MLP, log α."""
    return [*convs, ModuleMap("critic", "critic"), ModuleMap("agent.actor.encoder.projection.projection", "actor.trunk"),
            ModuleMap("agent.actor.mlp", "actor.policy"), ModuleMap("agent.log_alpha", "log_alpha")]


def _shared_cnn_map(attribute: str, prefix: str, layers: int = 11) -> ModuleMap:
    """DMC-GB's SharedCNN ``layers`` (CenterCrop, NormalizeImg, conv, ReLU, conv, ...) → a vigen ``convnet``."""
    return ModuleMap(attribute, prefix, tuple((str(2 + 2 * i), str(2 * i)) for i in range(layers)))


def _load_original_weights(networks: dict[str, nn.Module], maps: list[ModuleMap], driver: DMCGBDriver) -> None:
    """The original's weights into vigen's networks before the loss is built (so its target encoder starts as the original's)."""
    originals: dict[str, Tensor] = {}
    for module_map in maps:
        originals.update(module_map.resolve(driver))
    with torch.no_grad():
        for prefix, network in networks.items():
            for name, param in network.named_parameters():
                param.copy_(originals[f"{prefix}.{name}"])


def _import_dmcgb_fork(reference: Path, algorithm: str) -> Reference:
    substitutes, notes = captum_substitute()
    writer = types.ModuleType("torch.utils.tensorboard")
    writer.SummaryWriter = _NoWriter  # type: ignore[attr-defined]
    substitutes["torch.utils.tensorboard"] = writer
    names = ["utils", "augmentations", "algorithms.modules", "algorithms.sac", f"algorithms.{algorithm}"]
    ref = import_reference(reference, names, paths=("src",), optional=DMCGB_OPTIONAL, substitutes=substitutes)
    ref.notes.extend(notes)
    return ref


def _sac_networks(encoder: nn.Module, setup: Setup) -> dict[str, nn.Module]:
    from vigen.models import Critic, GaussianActor

    features = encoder.output_dim(setup.channels, setup.image_size, setup.image_size)
    return {"encoder": encoder,
            "actor": GaussianActor(features, setup.action_dim, setup.hidden_dim, feature_dim=setup.feature_dim),
            "critic": Critic(features, setup.action_dim, setup.feature_dim, setup.hidden_dim)}


SAC_STEPS = [
    StepMap("critic", "loss_critic", (("critic_optimizer", 0),)),
    StepMap("actor", "loss_actor", (("actor_optimizer", 0),)),
    StepMap("alpha", "loss_alpha", (("log_alpha_optimizer", 0),)),
]


def build_madi(reference: Path, setup: Setup) -> Case:
    from vigen.losses import MaDiLoss
    from vigen.models import MaDiMasker, SharedCNN

    ref = _import_dmcgb_fork(reference, "madi")
    module = ref.modules["algorithms.madi"]
    args = _dmcgb_args(setup, algorithm="madi", svea_alpha=0.5, svea_beta=0.5, augment="overlay", overlay_alpha=0.5,
                       masker_lr=1e-3, masker_beta=0.9, masker_num_layers=3, masker_num_filters=32, mask_type="soft",
                       mask_threshold=0.5, mask_threshold_type="fix", encoder="cnn")
    with cuda_is_cpu():
        driver = DMCGBDriver(module.MaDi(setup.obs_shape, (setup.action_dim,), args, _NoRecorder()))
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    overlay_pairs: Pairs = [(views.obs, views.overlay(0, views.obs))]
    networks = _sac_networks(SharedCNN(setup.channels, max_value=255, centered=False), setup)
    networks["masker"] = MaDiMasker(num_filters=32, max_value=255)
    maps = _dmcgb_maps([_shared_cnn_map("agent.critic.encoder.shared.layers", "encoder.convnet")])  # MaDi renames shared_cnn
    maps.append(ModuleMap("agent.masker.layers", "masker.net", (("2", "0"), ("4", "2"), ("6", "4"))))
    _load_original_weights(networks, maps, driver)
    maps[-1] = ModuleMap("agent.masker.layers", "input_mask.net", (("2", "0"), ("4", "2"), ("6", "4")))  # the loss's name
    loss = MaDiLoss(*networks.values(), init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"),
                    strong_augmentation=replay_augmentation(overlay_pairs, "overlay"))
    loss.make_value_estimator(gamma=setup.gamma)
    steps = [StepMap("critic", "loss_critic", (("critic_optimizer", 0), ("masker_optimizer", 0))), *SAC_STEPS[1:]]
    departures = [*DMCGB_DEPARTURES,
                  "MaDi's masker steps with the critic (its own Adam, lr 1e-3, β1 0.9): vigen's optimizer_groups gives it "
                  "the same group; compared as one step with the critic.",
                  "Strong view: vigen's RandomOverlay of the shifted observation, replayed to both sides (MaDi's from "
                  "Places365); the next observation is not shifted on either side (DMC-GB's sample_svea)."]
    return Case("madi", driver, loss, maps, steps, {"aug": views.weak()}, [(module, "strong_augment", overlay_pairs)],
                [module], [("alpha", "train_alpha/value")], departures, ref, batch, setup)


def build_simgrl(reference: Path, setup: Setup) -> Case:
    from vigen.losses import SimGRLLoss
    from vigen.models import PerFrameEncoder
    from vigen.transforms import RandomShiftedOverlay

    ref = _import_dmcgb_fork(reference, "simgrl")
    module = ref.modules["algorithms.simgrl"]
    with cuda_is_cpu():
        driver = DMCGBDriver(module.SimGRL(setup.obs_shape, (setup.action_dim,), _dmcgb_args(setup, algorithm="simgrl")))
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    shifted_overlay = RandomShiftedOverlay(alpha=0.5, max_shift=6, max_value=255, seed=setup.seed + 140)
    overlay_pairs: Pairs = [(views.obs, shifted_overlay.augment(views.obs))]
    networks = _sac_networks(PerFrameEncoder(setup.channels, max_value=255, centered=False), setup)
    frame = tuple((str(2 + 2 * i), str(2 * i)) for i in range(3))  # CenterCrop, NormalizeImg, conv, ReLU, conv, ...
    maps = _dmcgb_maps([ModuleMap("agent.critic.encoder.shared_cnn.layers", "encoder.frame_net", frame),
                        ModuleMap("agent.critic.encoder.shared_cnn.layers2", "encoder.stack_net")])
    _load_original_weights(networks, maps, driver)
    loss = SimGRLLoss(*networks.values(), init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"),
                      strong_augmentation=replay_augmentation(overlay_pairs, "shifted overlay"))
    loss.make_value_estimator(gamma=setup.gamma)
    departures = [*DMCGB_DEPARTURES,
                  "Strong view: vigen's RandomShiftedOverlay of the shifted observation (each frame its own shifted crop "
                  "of the image), replayed to both sides (SimGRL's from Places365); obs and next obs shifted on both "
                  "sides (its sample_drq)."]
    return Case("simgrl", driver, loss, maps, SAC_STEPS, {"aug": views.weak()},
                [(ref.modules["augmentations"], "random_overlay_shift", overlay_pairs)], [module],
                [("alpha", "train_alpha/value")], departures, ref, batch, setup)


def build_scpl(reference: Path, setup: Setup) -> Case:
    from vigen.losses import SCPLLoss
    from vigen.models import LatentDynamics, SharedCNN

    ref = _import_dmcgb_fork(reference, "SCPL")
    ref.notes.append("torch.utils.tensorboard.SummaryWriter is a stand-in that writes nothing")
    module = ref.modules["algorithms.SCPL"]
    with contextlib.redirect_stdout(io.StringIO()):  # its transition model prints a line when built
        driver = DMCGBDriver(module.SCPL(setup.obs_shape, (setup.action_dim,), _dmcgb_args(setup, algorithm="scpl")))
    batch = Batch.draw(setup, 1)
    views = Views(batch, setup)
    pair = torch.cat([views.obs, views.next_obs], dim=1)  # SCPL overlays obs and next obs stacked on the channels
    overlay_pairs: Pairs = [(pair, views.overlay(0, pair))]
    networks = _sac_networks(SharedCNN(setup.channels, max_value=255, centered=False), setup)
    networks["dynamics"] = LatentDynamics(setup.feature_dim, setup.action_dim)
    maps = _dmcgb_maps([_shared_cnn_map("agent.critic.encoder.shared_cnn.layers", "encoder.convnet")])
    maps.append(ModuleMap("agent.transition_model", "dynamics",
                          (("fc_mu", "next_embedding"), ("fc_reward", "reward"), ("fc", "hidden"), ("ln", "norm"))))
    _load_original_weights(networks, maps, driver)
    loss = SCPLLoss(*networks.values(), init_temperature=0.1, augmentation=replay_augmentation(views.weak(), "shift"),
                    strong_augmentation=replay_augmentation(overlay_pairs, "overlay"))
    loss.make_value_estimator(gamma=setup.gamma)
    steps = [*SAC_STEPS, StepMap("dynamics", "loss_dynamics", (("encoder_optimizer", 0), ("decoder_optimizer", 0)))]
    metrics = [("policy_kl", "train/kl_loss"), ("reward_error", "train_ae/reward_loss"),
               ("loss_dynamics", "train_ae/transition_loss"), ("alpha", "train_alpha/value")]
    departures = [
        *DMCGB_DEPARTURES,
        "After its actor step SCPL steps the encoder (with the critic's projection) and the dynamics model with their "
        "own Adam (lr 3e-4), every second update (aux_update_freq 2; it runs at the step compared).",
        "SCPL computes two more saliency maps (after the critic step, and of the next observation in the model step) "
        "and samples two more actions that nothing uses; vigen does not (the draw counts above say so).",
        "Strong views: one overlay of obs and next obs stacked on the channels (the same image for both), drawn "
        "with vigen's RandomOverlay and replayed to both sides; SCPL's comes from Places365 on float pixels.",
    ]
    unused = 3 * setup.batch_size * setup.action_dim  # actor(aug_obs) in the actor step, actor(next obs of both views) in the model step
    return Case("scpl", driver, loss, maps, steps, {"aug": views.weak()},
                [(ref.modules["augmentations"], "random_overlay", overlay_pairs)], [module], metrics, departures,
                ref, batch, setup, unused_normals=unused)


ALGORITHMS: dict[str, Callable[[Path, Setup], Case]] = {
    "drqv2": build_drqv2,
    "svea": build_svea,
    "srm": build_srm,
    "sgqn": build_sgqn,
    "curl": build_curl,
    "drq": build_drq,
    "sada": build_sada,
    "pieg": build_pieg,
    "vrl3": build_vrl3,
    "madi": build_madi,
    "simgrl": build_simgrl,
    "scpl": build_scpl,
}


@dataclass(frozen=True)
class Original:
    """The repository an algorithm's original lives in, and files that tell a checkout of it apart."""

    repository: str
    url: str
    files: tuple[str, ...]


RLVIGEN_URL, DMCGB2_URL = "https://github.com/gemcollector/RL-ViGen", "https://github.com/aalmuzairee/dmcgb2"
RLVIGEN_ADROIT_URL = "https://github.com/gemcollector/RL-ViGen/tree/ViGen-adroit"
SCPL_URL = "https://github.com/bofusun/SCPL"
MADI_URL, SIMGRL_URL = "https://github.com/bramgrooten/mask-distractions", "https://github.com/W-Song11/SimGRL-Code"
ORIGINALS: dict[str, Original] = {
    # cfgs/config.yaml tells master from the ViGen-adroit branch's src/, which has other agents under the same names
    **{name: Original("RL-ViGen", RLVIGEN_URL, ("rl_utils.py", "cfgs/config.yaml", f"algos/{name}.py"))
       for name in ("drqv2", "svea", "srm", "sgqn", "curl", "drq", "pieg")},
    "sada": Original("DMC-GB2", DMCGB2_URL, ("augmentations.py", "algos/sada.py")),
    "vrl3": Original("RL-ViGen ViGen-adroit/src", RLVIGEN_ADROIT_URL,
                     ("stage1_models.py", "cfgs_adroit/config.yaml", "algos/vrl3_agent.py")),
    "madi": Original("MaDi", MADI_URL, ("src/augmentations.py", "src/algorithms/madi.py")),
    "simgrl": Original("SimGRL", SIMGRL_URL, ("src/augmentations.py", "src/algorithms/simgrl.py")),
    "scpl": Original("SCPL", SCPL_URL, ("src/augmentations.py", "src/algorithms/SCPL.py")),
}


# -- command line ------------------------------------------------------------------------------
def parse_references(values: Sequence[str], algos: Sequence[str]) -> dict[str, Path]:
    """``PATH`` gives every algorithm its reference, ``NAME=PATH`` one algorithm (it wins over ``PATH``)."""
    default: Path | None = None
    per_algo: dict[str, Path] = {}
    for value in values:
        name, sep, path = value.partition("=")
        if sep and name in ALGORITHMS:
            per_algo[name] = Path(path)
        elif sep and name.isidentifier() and not Path(value).exists():
            raise ValueError(f"--reference {value!r}: {name!r} is not an algorithm; choose from {', '.join(ALGORITHMS)}.")
        else:
            default = Path(value)
    out = {algo: per_algo.get(algo, default) for algo in algos}
    return {algo: path for algo, path in out.items() if path is not None}


def select_algorithms(requested: Sequence[str] | None, references: dict[str, Path]) -> tuple[list[str], list[str]]:
    """The algorithms to run, and a note for each one left out.

    Every algorithm of ``requested`` needs a reference holding its original's files (else
    ``ValueError`` naming the fix). ``requested=None`` (no ``--algos``) runs every algorithm whose
    reference holds its original and notes the others (e.g. ``sada`` next to an RL-ViGen checkout).
    """
    run, skipped = [], []
    for algo in requested or list(ALGORITHMS):
        original, path = ORIGINALS[algo], references.get(algo)
        fix = f"give --reference {algo}=PATH to a checkout of {original.repository} ({original.url})"
        absent = list(original.files) if path is None else [f for f in original.files if not (path / f).is_file()]
        if not absent:
            run.append(algo)
            continue
        problem = "no --reference" if path is None else f"{path} has no {', '.join(absent)} (so it is no {original.repository} checkout)"
        if requested:
            raise ValueError(f"{algo}: {problem}; {fix}.")
        skipped.append(f"skipped {algo}: {problem}; {fix}.")
    if not run:
        raise ValueError("no algorithm has a checkout of its original: " + " ".join(skipped))
    return run, skipped


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--reference", action="append", required=True,
                        help="checkout of the original repository: PATH (every algorithm) or NAME=PATH (one); repeatable")
    parser.add_argument("--algos", nargs="+", choices=list(ALGORITHMS),
                        help="default: every algorithm whose --reference holds its original")
    parser.add_argument("--pythonpath", action="append", default=[], help="extra import directory for the originals' dependencies (e.g. captum)")
    parser.add_argument("--tolerance", type=float, default=1e-10, help="max relative difference counted as equal")
    parser.add_argument("--batch-size", type=int, default=Setup.batch_size)
    parser.add_argument("--seed", type=int, default=Setup.seed)
    args = parser.parse_args(argv)
    sys.path[1:1] = args.pythonpath
    try:
        references = parse_references(args.reference, args.algos or list(ALGORITHMS))
    except ValueError as error:
        parser.error(str(error))
    for algo, path in references.items():
        if not path.is_dir():
            parser.error(f"--reference for {algo}: {path} is not a directory; give a plain checkout of the original repository.")
    try:
        algos, skipped = select_algorithms(args.algos, references)
    except ValueError as error:
        parser.error(str(error))
    # the originals' deprecation notices and TorchRL's note on target parameters without an updater
    warnings.filterwarnings("ignore", category=UserWarning, message=".*(upsample|target network updater|required_grads|backward hooks on ReLU).*")
    torch.set_num_threads(1)
    setup = Setup(batch_size=args.batch_size, seed=args.seed)
    print(f"# vigen parity: one update in float64, batch {setup.batch_size}, {setup.image_size}×{setup.image_size}×"
          f"{setup.channels}, action dim {setup.action_dim}, hidden {setup.hidden_dim}, feature {setup.feature_dim}, step {setup.step}")
    print("rel. diff = max|vigen − original| / max|original| per quantity (gradients: over the tensor; the value "
          "columns show its L2 norm). The original's optimizer steps are recorded, not taken; 'steps taken' "
          "compares against its real sequential update.")
    for note in skipped:
        print(note)
    results = {}
    for name in algos:
        start = time.perf_counter()
        torch.manual_seed(setup.seed)
        with float64_mode():
            case = ALGORITHMS[name](references[name], setup)
            copy_weights(case)
            draws = Draws(setup.seed)
            fixed = run_original(case, draws, take_steps=False)
            stepped = run_original(case, draws, take_steps=True)
            ours = run_vigen(case, draws)
            measured = [measure(fixed.agent, case.loss) for measure in case.measures]
        rows = compare(case, fixed, stepped, ours)
        results[name] = report(case, rows, fixed, ours, time.perf_counter() - start, args.tolerance, measured)
    print("\n" + " ".join(f"{n}: {'OK' if ok else 'MISMATCH'}" for n, ok in results.items()))
    return 0 if all(results.values()) else 1


if __name__ == "__main__":
    sys.exit(main())

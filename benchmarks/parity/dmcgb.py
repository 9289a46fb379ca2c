"""DMC-GB's SAC agents, shared by MaDi, SimGRL and SCPL (their authors' code, each a fork of DMC-GB).

The driver that runs a DMC-GB agent behind the tool's ``update(replay_iter, step)``, the arguments
its SAC reads, the map of its networks onto vigen's, and the departures all three share.
"""

from __future__ import annotations

import contextlib
import tempfile
import types
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import torch
from torch import Tensor, nn

from benchmarks.parity.checkout import Reference, import_reference
from benchmarks.parity.harness import ModuleMap, Setup, StepMap
from benchmarks.parity.stand_ins import captum_substitute

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


def dmcgb_args(setup: Setup, **extra: Any) -> types.SimpleNamespace:
    """The arguments DMC-GB's SAC reads (its defaults, the tool's sizes, one learning rate)."""
    return types.SimpleNamespace(
        discount=setup.gamma, critic_tau=0.01, encoder_tau=0.05, actor_update_freq=2, critic_target_update_freq=2,
        num_shared_layers=11, num_head_layers=0, num_filters=32, projection_dim=setup.feature_dim,
        hidden_dim=setup.hidden_dim, actor_log_std_min=-10, actor_log_std_max=2, init_temperature=0.1,
        actor_lr=setup.lr, actor_beta=0.9, critic_lr=setup.lr, critic_beta=0.9, alpha_lr=setup.lr, alpha_beta=0.5,
        critic_weight_decay=0.0, device="cpu", work_dir=tempfile.gettempdir(), log_dir=tempfile.gettempdir(),
        domain_name="walker", task_name="walk", seed=0, frame_stack=3, init_steps=1000, **extra,
    )


def dmcgb_maps(convs: list[ModuleMap]) -> list[ModuleMap]:
    """DMC-GB's SAC networks → vigen's: the shared convolutions (``convs``), the critic's projection and Q
    heads (through the driver's ``critic``), the actor's projection and MLP, log α."""
    return [*convs, ModuleMap("critic", "critic"), ModuleMap("agent.actor.encoder.projection.projection", "actor.trunk"),
            ModuleMap("agent.actor.mlp", "actor.action_head"), ModuleMap("agent.log_alpha", "sampler.log_alpha")]


def shared_cnn_map(attribute: str, prefix: str, layers: int = 11) -> ModuleMap:
    """DMC-GB's SharedCNN ``layers`` (CenterCrop, NormalizeImg, conv, ReLU, conv, ...) → a vigen ``convnet``."""
    return ModuleMap(attribute, prefix, tuple((str(2 + 2 * i), str(2 * i)) for i in range(layers)))


def load_original_weights(networks: dict[str, nn.Module], maps: list[ModuleMap], driver: DMCGBDriver) -> None:
    """The original's weights into vigen's networks before the loss is built (so its target encoder starts as the original's)."""
    originals: dict[str, Tensor] = {}
    for module_map in maps:
        originals.update(module_map.resolve(driver))
    with torch.no_grad():
        for prefix, network in networks.items():
            for name, param in network.named_parameters():
                param.copy_(originals[f"{prefix}.{name}"])


def import_dmcgb_fork(reference: Path, algorithm: str) -> Reference:
    substitutes, notes = captum_substitute()
    writer = types.ModuleType("torch.utils.tensorboard")
    writer.SummaryWriter = _NoWriter  # type: ignore[attr-defined]
    substitutes["torch.utils.tensorboard"] = writer
    names = ["utils", "augmentations", "algorithms.modules", "algorithms.sac", f"algorithms.{algorithm}"]
    ref = import_reference(reference, names, paths=("src",), optional=DMCGB_OPTIONAL, substitutes=substitutes)
    ref.notes.extend(notes)
    return ref


def sac_networks(encoder: nn.Module, setup: Setup) -> dict[str, nn.Module]:
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

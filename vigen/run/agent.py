"""The agent of a training run, built from its :class:`TrainConfig`: the loss on the paper's networks and its acting policy."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import torch
from tensordict.nn import TensorDictModuleBase
from torchrl.data import TensorSpec
from torchrl.modules import AdditiveGaussianModule

from vigen.checkpoint import CheckpointError, load_checkpoint, newest_checkpoint
from vigen.envs import make_env
from vigen.losses import ALGOS, ActorCriticLoss, LinearSchedule, make_loss
from vigen.run.config import WEIGHTS_OPTION, TrainConfig


@dataclass
class Agent:
    """A vigen loss and its acting policy, which shares the loss's live parameters.

    Paper (exploration schedule): DrQ-v2, https://arxiv.org/abs/2107.09645.

    Examples:
        >>> from torchrl.data import Bounded
        >>> from vigen.run import TrainConfig, build_agent
        >>> config = TrainConfig(hidden_dim=32, observation_shape=(9, 84, 84), action_dim=1)
        >>> agent = build_agent(config, Bounded(-1.0, 1.0, shape=(1,)))
        >>> type(agent.loss).__name__, agent.exploration_noise.sigma.item()
        ('DrQv2Loss', 1.0)
    """

    loss: ActorCriticLoss
    policy: TensorDictModuleBase

    @property
    def exploration_noise(self) -> AdditiveGaussianModule | None:
        """The policy's scheduled Gaussian noise, stepped as frames are collected; ``None`` for a policy that samples (SAC)."""
        return next((module for module in self.policy.modules() if isinstance(module, AdditiveGaussianModule)), None)


def explores_with_noise(algo: str) -> bool:
    """Whether ``algo`` acts with DrQ-v2's scheduled Gaussian noise (takes ``std``); SAC losses sample from their policy.

    Examples:
        >>> explores_with_noise("drqv2"), explores_with_noise("drq")
        (True, False)
    """
    return ALGOS[algo].takes_std


def build_agent(
    config: TrainConfig,
    action_spec: TensorSpec,
    *,
    device: torch.device | str | None = None,
    pretrained: bool = True,
) -> Agent:
    """The run's loss (:func:`vigen.losses.make_loss`, with its value estimator) and its acting policy.

    The policy explores with the config's std schedule (linear ``std_init`` → ``std_final`` over
    ``std_duration`` agent steps) where the algorithm takes one, and is bounded by ``action_spec``.
    The loss's augmentations are seeded by ``config.seed`` unless the update is compiled
    (torch.compile cannot trace their own generators; they then draw from torch's global RNG).

    Args:
        config: the run's config, with the env's shapes recorded (``observation_shape``, ``action_dim``).
        action_spec: the env's action spec; its last dimension must be ``config.action_dim``.
        device: where the networks live and the policy acts (default: the CPU).
        pretrained: load ``config.encoder_weights`` into the encoder. ``False`` when trained
            weights are loaded over the networks next (evaluating a checkpoint): the file is not read.

    Raises:
        ValueError: the config has no recorded shapes, or the action spec is not the config's action size.
    """
    if config.observation_shape is None or config.action_dim is None:
        raise ValueError("build_agent: the config has no observation_shape / action_dim; record the env's with "
                         "dataclasses.replace(config, observation_shape=..., action_dim=...) first.")
    if action_spec.shape[-1] != config.action_dim:
        raise ValueError(f"build_agent: the action spec has {action_spec.shape[-1]} dimensions, the config's action_dim "
                         f"is {config.action_dim}; build the spec from the run's env ({config.env}).")
    options = {}
    if explores_with_noise(config.algo):
        options["std"] = LinearSchedule(config.std_init, config.std_final, config.std_duration)
    if pretrained and config.encoder_weights is not None:
        options[WEIGHTS_OPTION[config.algo]] = str(Path(config.encoder_weights).expanduser())
    loss = make_loss(config.algo, config.observation_shape, config.action_dim, feature_dim=config.feature_dim,
                     hidden_dim=config.hidden_dim, seed=None if config.compile else config.seed, device=device, **options)
    loss.make_value_estimator(gamma=config.gamma)  # its gamma is part of the saved state
    return Agent(loss, loss.make_policy(action_spec))


@dataclass
class TrainedAgent:
    """A run's agent with the weights of one of its checkpoints (:func:`load_agent`)."""

    config: TrainConfig
    agent: Agent
    frames: int
    """The environment frames the checkpoint was trained for."""
    checkpoint: Path
    skipped: list[tuple[Path, str]]
    """Newer checkpoints that did not load, with the reason."""


def load_agent(path: str | Path, *, device: torch.device | str = "cpu") -> TrainedAgent:
    """The agent of a run of ``examples/train.py`` with trained weights.

    ``path`` is the run folder (its newest checkpoint that loads is used) or one checkpoint file.

    The config comes from the run folder's ``config.json``; the action bounds from the run's env.
    Checkpoints load with ``weights_only=True`` onto the CPU (a GPU run's checkpoint loads on any
    machine), then move to ``device``; one holding anything but tensors and plain data is refused.

    Raises:
        CheckpointError: no checkpoint loads (a ``ValueError``).
        FileNotFoundError: the checkpoint is not in its run folder's ``checkpoints/``, next to ``config.json``.
    """
    path = Path(path)
    try:
        if path.is_file():
            file, checkpoint, skipped = path, load_checkpoint(path), []
        else:
            file, checkpoint, skipped = newest_checkpoint(path / "checkpoints")
    except CheckpointError as error:
        raise CheckpointError(f"{error} Is it a run folder of examples/train.py?") from None
    config_path = file.parent.parent / "config.json"
    if not config_path.is_file():
        raise FileNotFoundError(f"no config.json at {config_path}; a checkpoint is read with its run's config.json "
                                "(the network sizes and env settings): keep the checkpoint in its run folder's "
                                "checkpoints/ and pass the run folder or that file.")
    config = TrainConfig.from_json(json.loads(config_path.read_text()))
    agent = build_agent(config, env_action_spec(config), device=device, pretrained=False)
    agent.loss.load_state_dict(checkpoint["loss"])
    return TrainedAgent(config, agent, checkpoint["frames"], file, skipped)


def env_action_spec(config: TrainConfig) -> TensorSpec:
    """The action spec of the run's env, built with the run's options, then closed."""
    env = make_env(config.env, **config.env_options())
    try:
        return env.action_spec.clone()
    finally:
        env.close()

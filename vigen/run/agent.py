"""The agent of a training run, built from its :class:`TrainConfig`: the loss on the paper's networks and its acting policy.

Here a config meets the simulators, the losses and Ray: :func:`check_runnable` checks what needs
them, :func:`build_agent` fills the settings left unset from the algorithm's record.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import torch
from tensordict.nn import TensorDictModuleBase
from torchrl.data import TensorSpec
from torchrl.modules import AdditiveGaussianModule

from vigen.checkpoint import CheckpointError, load_checkpoint, newest_checkpoint
from vigen.envs import available_envs, make_env
from vigen.envs.levels import resolve_levels
from vigen.losses import ALGOS, ActorCriticLoss, LinearSchedule, make_loss
from vigen.ray_cluster import import_ray
from vigen.run.config import TrainConfig


@dataclass
class Agent:
    """A vigen loss, its acting policy (which shares the loss's live parameters) and the rewards' scale of the run.

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
    reward_scale: float = 1.0
    """The factor on the rewards stored in the replay buffer: the config's, or its algorithm's (VRL3 on Adroit)."""

    @property
    def exploration_noise(self) -> AdditiveGaussianModule | None:
        """The policy's scheduled Gaussian noise, stepped as frames are collected; ``None`` for a policy that samples (SAC)."""
        return next((module for module in self.policy.modules() if isinstance(module, AdditiveGaussianModule)), None)


def check_runnable(config: TrainConfig) -> None:
    """Raise a ``ValueError`` naming the flag and the fix for what :meth:`TrainConfig.check` cannot see alone.

    The algorithm, whether it has a pretrained encoder for ``--encoder-weights`` (and the file),
    the env's name (with the closest matches), the evaluation levels on its suite and the Ray
    collector's import: the checks that need the losses, the simulators' registry or Ray.

    Examples:
        >>> check_runnable(TrainConfig(algo="svea", encoder_weights=None))
        >>> check_runnable(TrainConfig(algo="nope"))
        Traceback (most recent call last):
        ...
        ValueError: --algo nope: no such algorithm; choose one of drqv2, svea, ...
    """
    if config.algo not in ALGOS:
        raise ValueError(f"--algo {config.algo}: no such algorithm; choose one of {', '.join(ALGOS)}.")
    if config.encoder_weights is not None and ALGOS[config.algo].encoder_weights is None:
        pretrained = [name for name, record in ALGOS.items() if record.encoder_weights is not None]
        raise ValueError(f"--encoder-weights: {config.algo} has no pretrained encoder; it applies to {', '.join(pretrained)}.")
    if config.encoder_weights is not None and not Path(config.encoder_weights).expanduser().is_file():
        raise ValueError(f"--encoder-weights {config.encoder_weights}: no such file; give the path of the weights file.")
    if config.collector == "ray":
        try:
            import_ray()
        except ImportError as error:
            raise ValueError(f"--collector ray: {error}") from None
    suite = config.env.split("/")[0]
    if config.env not in available_envs(suite if "/" in config.env else None):
        make_env(config.env)  # raises with the valid names and the closest matches
    try:
        resolve_levels(list(config.eval_levels), suite=suite)
    except ValueError as error:
        raise ValueError(f"--eval-levels: {error}") from None


def exploration_std(config: TrainConfig) -> LinearSchedule | None:
    """The run's exploration std: the algorithm's schedule with the config's ``std_*`` settings over it; ``None`` for SAC.

    Examples:
        >>> exploration_std(TrainConfig(algo="drqv2", std_final=0.2))
        LinearSchedule(init=1.0, final=0.2, duration=100000)
        >>> exploration_std(TrainConfig(algo="vrl3")).final, exploration_std(TrainConfig(algo="drq"))
        (0.01, None)
    """
    record = ALGOS[config.algo]
    if not record.takes_std:
        return None
    own = record.std
    return LinearSchedule(own.init if config.std_init is None else config.std_init,
                          own.final if config.std_final is None else config.std_final,
                          own.duration if config.std_duration is None else config.std_duration)


def build_agent(
    config: TrainConfig,
    action_spec: TensorSpec,
    *,
    device: torch.device | str | None = None,
    pretrained: bool = True,
) -> Agent:
    """The run's loss (:func:`vigen.losses.make_loss`, with its value estimator) and its acting policy.

    The policy explores with the run's std schedule (linear ``std_init`` → ``std_final`` over
    ``std_duration`` agent steps, each the algorithm's where the config leaves it unset,
    :func:`exploration_std`) where the algorithm takes one, and is bounded by ``action_spec``.
    The loss's augmentations are seeded by ``config.seed`` unless the update is compiled
    (torch.compile cannot trace their own generators; they then draw from torch's global RNG).
    The loss checks its losses are finite inside the call on the CPU only (elsewhere reading the
    check would synchronize; :class:`~vigen.losses.UpdateStep` guards with tensor ops there).

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
    record = ALGOS[config.algo]
    options: dict[str, object] = {}  # check_finite stays on: it raises on the CPU and counts on the device elsewhere
    std = exploration_std(config)
    if std is not None:
        options["std"] = std
    if pretrained and config.encoder_weights is not None:
        if record.encoder_weights is None:
            raise ValueError(f"build_agent: {config.algo} has no pretrained encoder for encoder_weights.")
        options[record.encoder_weights] = str(Path(config.encoder_weights).expanduser())
    loss = make_loss(config.algo, config.observation_shape, config.action_dim, feature_dim=config.feature_dim,
                     hidden_dim=config.hidden_dim, seed=None if config.compile else config.seed, device=device, **options)
    loss.make_value_estimator(gamma=config.gamma)  # its gamma is part of the saved state
    reward_scale = record.reward_scale(config.env) if config.reward_scale is None else config.reward_scale
    return Agent(loss, loss.make_policy(action_spec), reward_scale)


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

"""The agent of a training run, built from its :class:`TrainConfig`: the loss on the paper's networks and its acting policy.

Here a config meets the simulators, the losses and Ray: :func:`check_runnable` checks what needs
them, :func:`build_agent` fills the settings left unset from the algorithm's record.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import torch
from tensordict.nn import TensorDictModuleBase
from torch import nn
from torchrl.data import TensorSpec
from torchrl.modules import AdditiveGaussianModule
from torchrl.objectives import SoftUpdate

from vigen.run.checkpoint import CheckpointError, load_checkpoint, newest_checkpoint
from vigen.datasets import fetch_command, get_dataset, locate
from vigen.envs import available_envs, make_env
from vigen.envs.levels import resolve_levels
from vigen.losses import ALGOS, ActorCriticLoss, LinearSchedule, NoisyDeterministic, SplitSoftUpdate, UpdateStep, make_loss
from vigen.ray_cluster import import_ray
from vigen.run.config import TrainConfig
from vigen.transforms import RandomConv, RandomFrequencyMask, RandomOverlay, RandomShiftedOverlay
from vigen.transforms.augmentations.dmcgb2 import dmcgb2_strong_augmentation

AUGMENTATIONS = {
    "overlay": lambda: RandomOverlay(alpha=0.5),
    "random_conv": lambda: RandomConv(),
    "shifted_overlay": lambda: RandomShiftedOverlay(alpha=0.5, max_shift=6),
    "srm": lambda: [RandomOverlay(alpha=0.5), RandomFrequencyMask()],
    "dmcgb2_all": lambda: dmcgb2_strong_augmentation("all"),
}
"""A recipe's strong augmentation by name (:data:`vigen.run.recipes.AUGMENTATION_NAMES`) → a fresh one."""


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
    recipe_weights(config)  # a recipe's pretrained encoder: fetched, or the command that fetches it
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


def exploration_std_schedule(config: TrainConfig) -> LinearSchedule | None:
    """The run's schedule of the exploration std: the algorithm's, with the config's ``std_*`` settings over it; ``None`` for SAC.

    Examples:
        >>> exploration_std_schedule(TrainConfig(algo="drqv2", std_final=0.2))
        LinearSchedule(init=1.0, final=0.2, duration=100000)
        >>> exploration_std_schedule(TrainConfig(algo="vrl3")).final, exploration_std_schedule(TrainConfig(algo="drq"))
        (0.01, None)
    """
    record = ALGOS[config.algo]
    kind = (config.recipe_settings or {}).get("loss.sampler_type")
    if not (record.takes_std if kind is None else kind == "noisy_deterministic"):
        return None
    own = record.std_schedule if record.takes_std else NoisyDeterministic().std_schedule  # DrQ-v2's, for a swapped-in sampler
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
    :func:`exploration_std_schedule`) where the algorithm takes one, and is bounded by ``action_spec``.
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
    # check_finite stays on: it raises on the CPU and counts on the device elsewhere
    options: dict[str, object] = recipe_loss_options(config)
    std_schedule = exploration_std_schedule(config)
    if std_schedule is not None:
        options["std_schedule"] = std_schedule
    weights = config.encoder_weights if config.encoder_weights is not None else recipe_weights(config) if pretrained else None
    if pretrained and weights is not None:
        if record.encoder_weights is None:
            raise ValueError(f"build_agent: {config.algo} has no pretrained encoder for encoder_weights.")
        options[record.encoder_weights] = str(Path(weights).expanduser())
    loss = make_loss(config.algo, config.observation_shape, config.action_dim, feature_dim=config.feature_dim,
                     hidden_dim=config.hidden_dim, seed=None if config.compile else config.seed, device=device, **options)
    check_networks(loss, config.recipe_settings or {})
    loss.make_value_estimator(gamma=config.gamma)  # its gamma is part of the saved state
    reward_scale = record.reward_scale(config.env) if config.reward_scale is None else config.reward_scale
    return Agent(loss, loss.make_policy(action_spec), reward_scale)


def recipe_loss_options(config: TrainConfig) -> dict[str, Any]:
    """The :func:`vigen.losses.make_loss` options of the run: its recipe's ``loss.*`` settings and per-module optimizer groups.

    ``loss.strong_augmentation`` names an augmentation (:data:`AUGMENTATIONS`); ``optimizer.<module>.<option>`` becomes
    ``param_groups[<module>][<option>]``; ``actor_update_every`` above 1 steps the actor (and a SAC temperature) on every
    N-th update only (their groups' ``every``), recipe or not.

    Examples:
        >>> from vigen.run import new_config
        >>> options = recipe_loss_options(new_config({"recipe": "svea-dmcgb", "env": "dmc/walker-walk"}))
        >>> options["param_groups"]["sampler"], type(options["strong_augmentation"]).__name__
        ({'lr': 0.0001, 'betas': [0.5, 0.999], 'every': 2}, 'RandomConv')
    """
    settings = config.recipe_settings or {}
    options: dict[str, Any] = {key.removeprefix("loss."): value for key, value in settings.items() if key.startswith("loss.")}
    if "strong_augmentation" in options:
        name = options["strong_augmentation"]
        if name not in AUGMENTATIONS:
            raise ValueError(f"recipe {config.recipe}: strong augmentation {name!r} is not one of {', '.join(AUGMENTATIONS)}.")
        options["strong_augmentation"] = AUGMENTATIONS[name]()
    groups: dict[str, dict[str, Any]] = {}
    for key, value in settings.items():
        parts = key.split(".")
        if parts[0] == "optimizer" and len(parts) == 3:
            groups.setdefault(parts[1], {})[parts[2]] = value
    if config.actor_update_every > 1:
        sampler = options.get("sampler_type", "noisy_deterministic" if ALGOS[config.algo].takes_std else "squashed_gaussian")
        for module in ("actor", *(("sampler",) if sampler == "squashed_gaussian" else ())):
            groups.setdefault(module, {})["every"] = config.actor_update_every
    if groups:
        options["param_groups"] = groups
    return options


def recipe_weights(config: TrainConfig) -> Path | None:
    """The pretrained encoder file a recipe loads (``network.weights``, a data set of :mod:`vigen.datasets`), from the cache.

    ``None`` when the run gives ``--encoder-weights`` or its recipe loads none.

    Raises:
        ValueError: the data set is not fetched; the message holds the command that fetches it.
    """
    dataset = (config.recipe_settings or {}).get("network.weights")
    if dataset is None or config.encoder_weights is not None:
        return None
    record = get_dataset(dataset)
    folder = locate(record)
    if folder is None:
        raise ValueError(f"--recipe {config.recipe} loads the data set {record.name} ({record.title}) into its encoder, "
                         f"and it is not in the data cache. Fetch it (checked by its sha256) with `{fetch_command(record.name)}`, "
                         "or pass --encoder-weights PATH.")
    return folder / record.files[0].path


def check_networks(loss: ActorCriticLoss, settings: Mapping[str, Any]) -> None:
    """Raise if the built networks are not what a recipe's ``network.*`` settings say (its encoder's layers and channels).

    Examples:
        >>> from vigen.losses import make_loss
        >>> check_networks(make_loss("madi", (9, 64, 64), 2, hidden_dim=8), {"network.encoder_layers": 11})
        >>> check_networks(make_loss("drqv2", (9, 64, 64), 2, hidden_dim=8), {"network.encoder_layers": 11})
        Traceback (most recent call last):
        ...
        ValueError: the recipe's encoder has 11 convolutions, vigen's DrQv2Encoder 4; the recipe cannot be built as it is.
    """
    for part, module in (("encoder", loss.encoder), ("masker", loss.input_mask)):
        convolutions = [layer for layer in module.modules() if isinstance(layer, nn.Conv2d)] if module is not None else []
        hidden = convolutions[:-1] if part == "masker" else convolutions  # a masker's last convolution makes the mask
        built = {"layers": [len(convolutions)], "channels": sorted({layer.out_channels for layer in hidden})}
        for what, words in (("layers", "convolutions"), ("channels", "channels")):
            key = f"network.{part}_{what}"
            if key in settings and built[what] != [settings[key]]:
                raise ValueError(f"the recipe's {part} has {settings[key]} {words}, vigen's "
                                 f"{type(module).__name__} {', '.join(map(str, built[what])) or 'none'}; the recipe "
                                 "cannot be built as it is.")


def make_update(config: TrainConfig, loss: ActorCriticLoss, device: torch.device | str = "cpu") -> UpdateStep:
    """The run's update: Adam over the loss's groups (the recipe's betas), the target update and the schedule.

    Adam is fused when eager (the same step, ~10x faster on the CPU); compiled, torch.compile fuses it, capturable for a
    CUDA graph. The targets move at ``tau``, the target encoder and the critic's trunk at ``encoder_tau`` where it is set
    (:class:`~vigen.losses.SplitSoftUpdate`), on every ``target_update_every``-th update; a group with ``every`` (the
    actor's with ``actor_update_every``) is stepped on every N-th. A compiled update with such a schedule is not captured
    as a CUDA graph (:class:`~vigen.losses.UpdateStep` has not been checked there).

    Examples:
        >>> from torchrl.data import Bounded
        >>> from vigen.run import build_agent, new_config
        >>> from dataclasses import replace
        >>> config = replace(new_config({"recipe": "svea-dmcgb", "env": "dmc/walker-walk", "hidden_dim": 16}),
        ...                  observation_shape=(9, 84, 84), action_dim=2)
        >>> update = make_update(config, build_agent(config, Bounded(-1.0, 1.0, shape=(2,))).loss)
        >>> update.target_every, update.group_every, update.target_update.rates()["critic.trunk"]
        (2, (1, 2, 2), 0.05)
    """
    device = torch.device(device)
    betas = tuple((config.recipe_settings or {}).get("optimizer.betas", (0.9, 0.999)))
    optimizer = torch.optim.Adam(loss.optimizer_groups(config.lr), betas=betas, fused=not config.compile,
                                 capturable=config.compile and device.type == "cuda")
    if config.encoder_tau is not None and config.encoder_tau != config.tau:
        taus = {"critic.trunk": config.encoder_tau}
        if "target_encoder_params" in dict(loss.named_children()):  # DMC-GB's target critic holds its own encoder
            taus = {"encoder": config.encoder_tau, **taus}
        target: SoftUpdate = SplitSoftUpdate(loss, tau=config.tau, taus=taus)
    else:
        target = SoftUpdate(loss, tau=config.tau)
    scheduled = config.target_update_every > 1 or any(group.get("every", 1) > 1 for group in optimizer.param_groups)
    return UpdateStep(loss, optimizer, target, target_every=config.target_update_every, compile=config.compile,
                      cudagraph=False if scheduled else None)


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

"""The settings of one training run of ``examples/train.py``: :class:`TrainConfig`, its presets and its protocols.

A new run's config is built in layers, each a :class:`TrainConfig` value: a preset (:data:`PRESETS`),
the flags, a recipe (:func:`with_recipe`: a method's original settings, :data:`vigen.run.RECIPES`, which
the flags override), then a protocol (:func:`with_protocol`, which the flags override). A setting left unset
(``None``) takes its algorithm's value when the run is built (the exploration std, the rewards'
scale: fields of the algorithm's record, :data:`vigen.losses.ALGOS`). ``config.json`` in the run
folder holds the result (:meth:`TrainConfig.to_json`); ``--resume`` reads it back
(:func:`resumed_config`), also the files of runs older than a setting, which then get that
setting's default.

This module imports no simulator, loss, torch or Ray module: a config can be read, checked
(:meth:`TrainConfig.check`) and written where none of them is installed. The checks that need
them (the env's name, the levels, Ray, the algorithm's pretrained encoder) run when the run is
built (:func:`vigen.run.check_runnable`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Collection, Mapping
from dataclasses import dataclass, replace
from types import MappingProxyType
from typing import Annotated, Any, Literal

from vigen.protocols import PROTOCOLS
from tyro.conf import Suppress, arg

from vigen.run.cli import flag_name, flag_value, unset_means
from vigen.run.recipes import RECIPES, TRAIN_KEYS, get_recipe

DEFAULT_FRAMES = 100_000
"""A run's budget in environment frames when neither ``--frames`` nor a protocol sets it."""

PROTOCOL_KEYS = ("frames", "action_repeat", "frame_stack", "image_size", "episode_length", "eval_every", "eval_episodes",
                 "eval_levels")
"""The settings a protocol fixes (:meth:`vigen.protocols.Protocol.settings`); flags override them."""



def _algorithm_choices() -> Any:
    """The algorithms' names (:data:`vigen.losses.ALGOS`) as the flag's choices, imported only when the flags are
    parsed."""
    from vigen.losses import ALGOS

    return Literal[tuple(ALGOS)]


def _preset_choices() -> Any:
    return Literal[tuple(PRESETS)]


def _protocol_choices() -> Any:
    return Literal[tuple(PROTOCOLS)] | None




@dataclass(frozen=True)
class TrainConfig:
    """Every setting of a training run, with the ``cpu`` preset's values as defaults.

    Each field documented below is a flag of ``examples/train.py`` (``batch_size`` is ``--batch-size``,
    its docstring the flag's help: :func:`vigen.run.parse_flags`). Frames count environment frames
    (agent steps × action repeat), as in DrQ-v2's curves. ``frames`` is not saved: a resumed run takes
    it from the flag or, failing that, from its protocol. The last six fields are recorded by the run itself.

    Paper (the ``paper`` preset): DrQ-v2, https://arxiv.org/abs/2107.09645; RL-ViGen,
    https://arxiv.org/abs/2307.10224.

    Examples:
        >>> from dataclasses import replace
        >>> from vigen.run import PRESETS, TrainConfig
        >>> config = replace(PRESETS["paper"], algo="svea", seed=3)
        >>> config.batch_size, config.buffer_size, config.lr
        (256, 1000000, 0.0001)
        >>> TrainConfig.from_json(config.to_json()) == config
        True
    """

    algo: Annotated[str, arg(constructor_factory=_algorithm_choices, help_behavior_hint="(default: drqv2)")] = "drqv2"
    """the algorithm (vigen.losses.ALGOS)"""
    env: str = "dmc/cartpole-balance"
    """the task, <suite>/<task> (vigen.envs.available_envs)"""
    preset: Annotated[str, arg(constructor_factory=_preset_choices, help_behavior_hint="(default: cpu)")] = "cpu"
    """the base settings: paper (DrQ-v2 / RL-ViGen's) or cpu (batch 64, a 100k buffer)"""
    seed: int = 0
    """seeds the networks, envs, augmentations and evaluations"""
    workers: int = 1
    ("envs stepping in parallel, each in its own worker (a process; with Ray an actor): the local collector's "
     "MultiSyncCollector for more than 1, Ray's actors with --ray")
    collector: Literal["local", "ray"] = "local"
    """local: this machine's processes; ray: TorchRL's RayCollector, one Ray actor per worker (what --ray sets)"""
    overlap: bool = False
    ("collect the next batch in worker processes while updating on the last (local collector): the same updates per "
     "agent step, the policy acting one batch of updates behind the serial run; resumes exactly")
    eval_levels: tuple[str, ...] = ("train",)
    """levels evaluated at every checkpoint"""
    logger: Literal["csv", "wandb"] = "csv"
    """csv, or wandb offline"""
    episode_length: Annotated[int | None, unset_means("the suite's, dm_control 1000, robosuite 500, Adroit 200, pen 100")] = None
    """control steps per episode"""
    encoder_weights: Annotated[str | None, unset_means("none")] = None
    """pretrained encoder weights: PIE-G's ImageNet ResNet-18 (a torchvision state dict), VRL3's stage-1 checkpoint"""
    protocol: Annotated[str | None, arg(constructor_factory=_protocol_choices, help_behavior_hint="(default: none)")] = None
    """train as a paper did: its budget, action repeat, frame stack, image size and evaluation"""
    action_repeat: Annotated[int | None, unset_means("the suite's")] = None
    """control steps per agent step"""
    frame_stack: Annotated[int | None, unset_means("3")] = None
    """frames per observation"""
    image_size: Annotated[int | None, unset_means("84")] = None
    """pixels per side"""
    compile: bool = False
    ("compile the whole update (torch.compile; on CUDA also a CUDA graph). The augmentations then draw from torch's RNG"
     " seeded by --seed (torch.compile cannot trace their own generators)")
    batch_size: int = 64
    """transitions per gradient update (paper preset: 256)"""
    buffer_size: int = 100_000
    """replay capacity in transitions (paper preset: 1000000)"""
    lr: float = 1e-4
    """Adam's learning rate"""
    hidden_dim: int = 1024
    """width of the actor's and critic's MLPs"""
    feature_dim: int = 50
    """output size of the actor's and critic's trunk"""
    n_step: int = 3
    """steps of the n-step return"""
    gamma: float = 0.99
    """discount"""
    tau: float = 0.01
    """target critic update rate"""
    seed_frames: int = 4000
    """frames of random actions before the first update"""
    update_every: int = 2
    """agent steps per gradient update"""
    std_duration: Annotated[int | None, unset_means("the algorithm's, DrQ-v2 100000")] = None
    """agent steps of the exploration std's linear schedule"""
    eval_every: int = 10_000
    """frames between evaluations, each followed by a checkpoint"""
    eval_episodes: int = 5
    """episodes per evaluation level (paper preset: 10)"""
    std_init: Annotated[float | None, unset_means("the algorithm's, DrQ-v2 1.0, VRL3 0.01")] = None
    """exploration std at the start (losses with a SAC sampler ignore it)"""
    std_final: Annotated[float | None, unset_means("the algorithm's, DrQ-v2 0.1, VRL3 0.01")] = None
    """exploration std at the schedule's end"""
    reward_scale: Annotated[float | None, unset_means("the algorithm's, 1; VRL3 on Adroit RL-ViGen's, door 1/20, hammer "
                                                      "1/100, pen 1/50")] = None
    """factor on the rewards stored in the replay buffer"""
    frames: int = DEFAULT_FRAMES
    """environment frames in all, with action repeat (a protocol sets its budget)"""
    recipe: Annotated[str | None, arg(metavar="NAME"), unset_means("none")] = None
    ("train as a method's original code does: its loss, networks, optimizer, update schedule and protocol "
     "(vigen.run.RECIPES); --recipe list prints them")
    seed_steps: Annotated[int | None, unset_means("--seed-frames / action repeat")] = None
    """agent steps of random actions before the first update (DMC-GB's init_steps); overrides --seed-frames"""
    seed_catch_up: bool = False
    ("when the seed steps end, make at once the updates they would have had, then one per --update-every (DMC-GB's "
     "init_steps updates at step init_steps)")
    actor_update_every: int = 1
    ("gradient updates per step of the actor and SAC's temperature (DMC-GB's actor_update_freq 2); their Adam state is "
     "untouched in between")
    target_update_every: int = 1
    """gradient updates per target-network update (DMC-GB's critic_target_update_freq 2)"""
    encoder_tau: Annotated[float | None, unset_means("--tau")] = None
    ("update rate of the target encoder and the target critic's trunk (DMC-GB's encoder_tau 0.05: its critic encoder is"
     " the convolutions and the projection)")
    protocol_settings: Suppress[Mapping[str, Any] | None] = None
    """Every value the protocol fixes on the env (:meth:`vigen.protocols.Protocol.settings`)."""
    protocol_overrides: Suppress[Mapping[str, Mapping[str, Any]] | None] = None
    """The protocol settings a flag changed: ``{name: {"protocol": value, "flag": value}}``."""
    recipe_settings: Suppress[Mapping[str, Any] | None] = None
    """Every setting of the recipe on the run's env (:meth:`vigen.run.recipes.Recipe.settings`), as the run was built
    with."""
    recipe_overrides: Suppress[Mapping[str, Mapping[str, Any]] | None] = None
    """The recipe settings a flag changed: ``{name: {"recipe": value, "flag": value}}``."""
    observation_shape: Suppress[tuple[int, int, int] | None] = None
    """The pixels' shape, ``(3 · frame stack, height, width)``, read from the env at the run's start."""
    action_dim: Suppress[int | None] = None
    """The action's size, read from the env at the run's start."""

    def to_json(self) -> dict[str, Any]:
        """The run's ``config.json``: every field but ``frames``, the protocol's two only with a protocol, ``overlap``,
        the recipe's and the update schedule's (:data:`WRITTEN_WHEN_SET`) only when set, tuples as lists."""
        saved = {field.name: _plain(getattr(self, field.name)) for field in dataclasses.fields(self) if field.name != "frames"}
        if self.protocol is None:
            del saved["protocol_settings"], saved["protocol_overrides"]
        for name in WRITTEN_WHEN_SET:  # a run without them keeps the format of the runs before the settings
            if getattr(self, name) == getattr(TrainConfig, name):
                del saved[name]
        return saved

    @classmethod
    def from_json(cls, saved: Mapping[str, Any]) -> TrainConfig:
        """A config from :meth:`to_json`'s dict; a key it lacks (a setting newer than the run) gets its default.

        Keys that are no field (a setting this version does not know) are ignored.

        Examples:
            >>> TrainConfig.from_json({"algo": "svea", "eval_levels": ["train", "color_hard"]}).eval_levels
            ('train', 'color_hard')
        """
        return cls(**{field.name: _tupled(saved[field.name]) for field in dataclasses.fields(cls) if field.name in saved})

    def env_options(self) -> dict[str, int]:
        """The :func:`vigen.envs.make_env` options the run sets (episode length, action repeat, frame stack, image
        size)."""
        names = ("episode_length", "action_repeat", "frame_stack", "image_size")
        return {name: getattr(self, name) for name in names if getattr(self, name) is not None}

    def training_env_options(self) -> dict[str, Any]:
        """:meth:`env_options` and the protocol's options of its training envs (``train_env_options``).

        Examples:
            >>> config = new_config({"protocol": "rlvigen_loco", "env": "loco/unitree-walk"})
            >>> config.training_env_options()["action_mapping"], config.training_env_options()["start_clearance"]
            ('rlvigen_train', 'rlvigen')
        """
        return {**self.env_options(), **(self.protocol_settings or {}).get("train_env_options", {})}

    def test_env_options(self) -> dict[str, Any]:
        """:meth:`env_options` and the protocol's options of its evaluation envs (``test_env_options``).

        Examples:
            >>> new_config({"protocol": "rlvigen_loco", "env": "loco/unitree-walk"}).test_env_options()["action_mapping"]
            'scaled'
        """
        return {**self.env_options(), **(self.protocol_settings or {}).get("test_env_options", {})}

    def evaluation_seed(self) -> int:
        """The env seed of the evaluations while training: the protocol's (DMC-GB: ``seed + 42``), else ``seed + 10000``.

        Examples:
            >>> new_config({"protocol": "dmcgb", "env": "dmc/walker-walk", "seed": 1}).evaluation_seed()
            43
            >>> new_config({"seed": 1}).evaluation_seed()
            10001
        """
        offset = (self.protocol_settings or {}).get("eval_seed_offset")
        return self.seed + (10_000 if offset is None else offset)

    def resumed_frames(self) -> int:
        """A resumed run's budget without ``--frames``: the flag that overrode its protocol's, the protocol's, or the
        default."""
        overridden = (self.protocol_overrides or {}).get("frames")
        return overridden["flag"] if overridden else (self.protocol_settings or {}).get("frames", DEFAULT_FRAMES)

    def describe(self) -> list[str]:
        """The recipe and the protocol the run trains by, and the flags that override them: what a run prints at its start.

        Examples:
            >>> new_config({"protocol": "dmcgb", "env": "dmc/walker-walk", "frames": 800}).describe()[-1]
            '  overridden by a flag: frames = 800 (protocol: 2000000)'
        """
        lines = []
        if self.recipe is not None:
            lines += (RECIPES[self.recipe].describe(self.env) if self.recipe in RECIPES else
                      [f"recipe {self.recipe} (as recorded in config.json)"])
            lines += [f"  overridden by a flag: {key} = {values['flag']} (recipe: {values['recipe']})"
                      for key, values in (self.recipe_overrides or {}).items()]
        if self.protocol is not None:
            lines += PROTOCOLS[self.protocol].describe(self.env)
            lines += [f"  overridden by a flag: {key} = {values['flag']} (protocol: {values['protocol']})"
                      for key, values in (self.protocol_overrides or {}).items()]
        return lines

    def check(self) -> None:
        """Raise a ``ValueError`` naming the flag and the fix for any setting that cannot run, before anything is built.

        The settings are checked on their own here; :func:`vigen.run.check_runnable` checks what
        needs the simulators, the losses or Ray (the env, the levels, the collector, the weights).
        """
        for name in ("batch_size", "buffer_size", "hidden_dim", "feature_dim", "n_step", "update_every",
                     "eval_every", "eval_episodes", "workers"):
            value = getattr(self, name)
            if not isinstance(value, int) or value < 1:
                raise ValueError(f"{flag_name(name)} must be an integer >= 1, got {value}.")
        for name in ("action_repeat", "frame_stack", "image_size", "std_duration"):
            if getattr(self, name) is not None and getattr(self, name) < 1:
                raise ValueError(f"{flag_name(name)} must be an integer >= 1, got {getattr(self, name)}.")
        for name in ("actor_update_every", "target_update_every"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 1:
                raise ValueError(f"{flag_name(name)} must be an integer >= 1, got {value}.")
        if self.seed_steps is not None and self.seed_steps < 0:
            raise ValueError(f"--seed-steps must be >= 0, got {self.seed_steps}.")
        if self.encoder_tau is not None and not 0 < self.encoder_tau <= 1:
            raise ValueError(f"--encoder-tau must be in (0, 1], got {self.encoder_tau}.")
        if self.frames < 0 or self.seed_frames < 0:
            raise ValueError(f"--frames and --seed-frames must be >= 0, got {self.frames} and {self.seed_frames}.")
        if self.buffer_size < self.batch_size:
            raise ValueError(f"--buffer-size {self.buffer_size} is below --batch-size {self.batch_size}: "
                             "the buffer could never fill one batch; raise it.")
        if not (self.lr > 0 and 0 < self.gamma <= 1 and 0 < self.tau <= 1):
            raise ValueError(f"--lr must be > 0 and --gamma, --tau in (0, 1], got {self.lr}, {self.gamma}, {self.tau}.")
        stds_ok = all(std is None or std >= 0 for std in (self.std_init, self.std_final))
        if not (stds_ok and (self.reward_scale is None or 0 < self.reward_scale < float("inf"))):
            raise ValueError(f"--std-init and --std-final must be >= 0 and --reward-scale positive, got {self.std_init}, "
                             f"{self.std_final} and {self.reward_scale}.")
        if self.episode_length is not None and self.episode_length < 1:
            raise ValueError(f"--episode-length must be >= 1, got {self.episode_length}.")
        if self.overlap and self.collector != "local":
            raise ValueError(f"--overlap collects in this machine's worker processes; it does not combine with --collector "
                             f"{self.collector}. Drop one of them.")


WRITTEN_WHEN_SET = ("overlap", "recipe", "seed_steps", "seed_catch_up", "actor_update_every", "target_update_every",
                    "encoder_tau", "recipe_settings", "recipe_overrides")
"""Settings ``config.json`` holds only when they differ from their default (the format of the runs before them)."""

PRESETS: Mapping[str, TrainConfig] = MappingProxyType({
    "paper": TrainConfig(preset="paper", batch_size=256, buffer_size=1_000_000, eval_episodes=10),
    "cpu": TrainConfig(preset="cpu"),
})
"""``paper``: DrQ-v2 / RL-ViGen's setup (batch 256, a 1M-transition buffer, lr 1e-4, 3-step returns, τ = 0.01, 4000 seed
frames, an update every 2 agent steps, 10 evaluation episodes); ``cpu``: the same agent with batch 64, a 100k buffer and
5 evaluation episodes, to learn easy tasks on a laptop CPU."""


def new_config(flags: Mapping[str, Any]) -> TrainConfig:
    """A new run's config: the preset, the flags, then the recipe and the protocol, which the flags override.

    Settings left unset take their algorithm's value when the run is built (:func:`vigen.run.build_agent`).

    Args:
        flags: :class:`TrainConfig` fields given on the command line (or by a caller).

    Raises:
        ValueError: an unknown preset or recipe, or a recipe or protocol that does not cover the env.

    Examples:
        >>> config = new_config({"algo": "vrl3", "preset": "paper", "frames": 800})
        >>> config.batch_size, config.std_init, config.frames  # std_init: VRL3's, when the run is built
        (256, None, 800)
        >>> new_config({"protocol": "dmcgb", "env": "dmc/walker-walk"}).action_repeat
        4
        >>> recipe = new_config({"recipe": "svea-dmcgb", "env": "dmc/walker-walk"})
        >>> recipe.algo, recipe.batch_size, recipe.lr, recipe.protocol, recipe.action_repeat  # the recipe's protocol too
        ('svea', 128, 0.001, 'dmcgb', 4)
    """
    preset = flags.get("preset", TrainConfig.preset)
    if preset not in PRESETS:
        raise ValueError(f"--preset {preset}: no such preset; choose one of {', '.join(PRESETS)}.")
    base = PRESETS[preset]
    config = replace(base, **flags)
    if config.recipe is not None:
        config = with_recipe(config, base, explicit=flags.keys())
    return config if config.protocol is None else with_protocol(config, explicit=flags.keys())


def with_recipe(config: TrainConfig, base: TrainConfig | None = None, explicit: Collection[str] = ()) -> TrainConfig:
    """``config`` trained as its recipe says on its env, keeping the settings named in ``explicit`` (recorded as overrides).

    The recipe sets its :class:`TrainConfig` fields (and its protocol, unless ``--protocol`` is given) and is recorded
    whole in ``recipe_settings``; each explicit flag that differs from what the recipe would have set is recorded in
    ``recipe_overrides`` as ``{"recipe": value, "flag": value}`` (``base``, the preset, gives the value of a setting the
    recipe leaves to it). The recipe's algorithm cannot be overridden, nor its seed steps given in frames.

    Raises:
        ValueError: an unknown recipe, an env it does not cover, ``--algo`` other than its algorithm, or
            ``--seed-frames`` where it counts seed steps.

    Examples:
        >>> config = with_recipe(TrainConfig(recipe="svea-dmcgb", env="dmc/cartpole-balance", seed_steps=10),
        ...                      explicit={"seed_steps"})
        >>> config.algo, config.batch_size, config.seed_steps, config.protocol, config.recipe_overrides
        ('svea', 128, 10, 'dmcgb', {'seed_steps': {'recipe': 1000, 'flag': 10}})
    """
    base = TrainConfig() if base is None else base
    recipe = get_recipe(str(config.recipe))
    try:
        settings = recipe.settings(config.env)
    except ValueError as error:
        raise ValueError(f"--recipe {recipe.name}: {error}") from None
    if "algo" in explicit and config.algo != recipe.algo:
        raise ValueError(f"--algo {config.algo} and --recipe {recipe.name}: the recipe trains vigen's {recipe.algo}; drop "
                         "--algo (or the recipe).")
    if "seed_frames" in explicit and "seed_steps" in settings and "seed_steps" not in explicit:
        raise ValueError(f"--seed-frames and --recipe {recipe.name}: the recipe counts its seed phase in agent steps "
                         f"({settings['seed_steps']}); give --seed-steps instead.")
    own = {key: settings[key] for key in TRAIN_KEYS if key in settings}
    recipe_values = replace(base, **{key: _tupled(value) for key, value in own.items()})
    overrides = {key: {"recipe": _plain(getattr(recipe_values, key)), "flag": _plain(getattr(config, key))}
                 for key in TRAIN_KEYS if key in explicit and key != "algo" and getattr(config, key) != getattr(recipe_values, key)}
    kept = {key: value for key, value in own.items() if key not in explicit}
    return replace(config, **{key: _tupled(value) for key, value in kept.items()},
                   recipe_settings={key: _plain(value) for key, value in settings.items()}, recipe_overrides=overrides)


def with_protocol(config: TrainConfig, explicit: Collection[str] = ()) -> TrainConfig:
    """``config`` trained as its protocol says on its env, keeping the settings named in ``explicit`` (recorded as overrides).

    Raises:
        ValueError: the protocol does not cover ``config.env`` (``--protocol NAME: ...``).

    Examples:
        >>> from vigen.run import TrainConfig
        >>> config = with_protocol(TrainConfig(env="dmc/walker-walk", protocol="dmcgb", frames=800), explicit={"frames"})
        >>> config.frames, config.eval_episodes, config.protocol_overrides["frames"]
        (800, 30, {'protocol': 2000000, 'flag': 800})
    """
    if config.protocol is None:
        raise ValueError("with_protocol: the config names no protocol; set protocol= first.")
    try:
        settings = PROTOCOLS[config.protocol].settings(config.env)
    except ValueError as error:
        raise ValueError(f"--protocol {config.protocol}: {error}") from None
    kept = {key: _plain(getattr(config, key)) for key in PROTOCOL_KEYS if key in explicit}
    overrides = {key: {"protocol": settings[key], "flag": value} for key, value in kept.items() if value != settings[key]}
    protocol_values = {key: _tupled(settings[key]) for key in PROTOCOL_KEYS if key not in kept}
    return replace(config, **protocol_values, protocol_settings=settings, protocol_overrides=overrides)


def resumed_config(saved: Mapping[str, Any], flags: Mapping[str, Any]) -> TrainConfig:
    """A resumed run's config: its ``config.json`` (``saved``), whose settings the flags may not contradict, but for ``frames``.

    Without a ``frames`` flag the run goes on to its own budget (:meth:`TrainConfig.resumed_frames`).

    Raises:
        ValueError: naming each flag that contradicts the saved config and its saved value.

    Examples:
        >>> resumed_config({"algo": "svea", "batch_size": 8}, {"frames": 800}).frames
        800
        >>> resumed_config({"algo": "svea", "batch_size": 8}, {"batch_size": 16})  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        ValueError: these flags contradict its config.json: --batch-size 16 (the run has 8). Drop them to continue the run ...
    """
    config = TrainConfig.from_json(saved)
    conflicts = [f"{flag_name(name)} {flag_value(value)} (the run has {flag_value(getattr(config, name))})"
                 for name, value in flags.items() if name != "frames" and getattr(config, name) != value]
    if conflicts:
        raise ValueError(f"these flags contradict its config.json: {'; '.join(conflicts)}. "
                         "Drop them to continue the run as it was, or start a new run.")
    return replace(config, frames=flags.get("frames", config.resumed_frames()))


def _plain(value: Any) -> Any:
    """A field's value as JSON holds it (tuples as lists)."""
    return list(value) if isinstance(value, tuple) else value


def _tupled(value: Any) -> Any:
    """A JSON value as the field holds it (lists as tuples)."""
    return tuple(value) if isinstance(value, list) else value

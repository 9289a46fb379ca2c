"""Trained agents as an evaluation plays them: each in its env as it was trained, with the columns its rows carry; a random
policy beside them; their levels; the protocol the evaluation follows.

``examples/evaluate.py`` loads runs (:func:`vigen.run.load_agent`) and shipped agents
(:func:`vigen.pretrained.load_agent`) as :class:`vigen.run.TrainedAgent`; :func:`run_evaluated`
puts each in its env with the action repeat, frame stack and image size it was trained with and
its protocol's options of evaluation envs; :func:`levels_per_env` resolves the levels asked for.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from tensordict.nn import TensorDictModuleBase

from vigen.envs import factors, get_suite
from vigen.envs.levels import resolve_levels
from vigen.evaluation.comparison import Comparison
from vigen.evaluation.level_data import shown_data
from vigen.protocols import PROTOCOLS, Protocol
from vigen.rendering import RenderSettings
from vigen.run import TrainConfig, TrainedAgent

DEFAULT_GROUPS = {"dmc": "dmcgb", "robosuite": "rlvigen", "adroit": "rlvigen"}
"""The test levels evaluated by default beside ``train``, per suite (others: ``all``)."""

RUN_SETTINGS = ("action_repeat", "frame_stack", "image_size")
"""The env options a run was trained with (``config.json``); its evaluation uses the same."""


@dataclass(frozen=True)
class Evaluated:
    """One policy to evaluate (``None``: random actions) in its env, with the env's options and the columns of its rows."""

    policy: TensorDictModuleBase | None
    env: str
    env_options: dict[str, Any]
    tags: dict[str, Any]


def run_evaluated(trained: TrainedAgent, episode_length: int | None) -> Evaluated:
    """A run's policy in its env as it was trained (the episode length asked for), with the columns its rows carry."""
    options = run_env_options(trained.config, episode_length)
    return Evaluated(trained.agent.policy, trained.config.env, options, run_tags(trained, options))


def random_evaluated(runs: list[Evaluated]) -> list[Evaluated]:
    """A random policy in each env, as the env's first run saw it (``--random``)."""
    first: dict[str, dict] = {}
    for run in runs:
        first.setdefault(run.env, run.env_options)
    return [Evaluated(None, env, env_options, {"method": "random", "run": 0}) for env, env_options in first.items()]


def run_env_options(config: TrainConfig, episode_length: int | None) -> dict:
    """The evaluation env of a run: its action repeat, frame stack and image size, the episode length asked for and its
    protocol's options of evaluation envs (``test_env_options``: RL-ViGen's loco evaluator's scaled actions, ...)."""
    length = episode_length or config.episode_length
    return {"render_settings": RenderSettings.fast(),
            **({} if length is None else {"episode_length": length}),
            **{name: getattr(config, name) for name in RUN_SETTINGS if getattr(config, name) is not None},
            **(config.protocol_settings or {}).get("test_env_options", {})}


def run_tags(trained: TrainedAgent, env_options: dict) -> dict:
    """The columns every row of a run carries: method, run, frames, its training batch, its recipe (and the settings a flag
    overrode in it) and the settings a protocol fixes (for ``--compare``)."""
    config = trained.config
    channels, _, width = config.observation_shape  # uint8 [3 * frame stack, H, W]
    defaults = get_suite(config.env).env_options
    settings = {"action_repeat": config.action_repeat or defaults.get("action_repeat"), "frame_stack": channels // 3,
                "image_size": width, "episode_length": env_options.get("episode_length", defaults.get("episode_length"))}
    return {"method": config.algo, "run": config.seed, "frames": trained.frames, "protocol": config.protocol or "",
            "batch_size": config.batch_size, "recipe": config.recipe or "",
            "recipe_overrides": json.dumps(config.recipe_overrides) if config.recipe_overrides else "",
            **{name: value for name, value in settings.items() if value is not None}}


def levels_per_env(envs: list[str], levels: tuple[str, ...] | None, comparison: Comparison | None = None,
                   sweeps: list[list[Any]] = ()) -> dict[str, list[Any]]:
    """Each env's levels: ``levels`` (default: train and the suite's group, or with a comparison train and its protocol's
    test levels), then the sweeps' levels.

    Raises:
        ValueError: an unknown level or group (``--compare NAME: ...`` with a comparison), or a swept factor the env lacks.

    Examples:
        >>> levels_per_env(["dmc/walker-walk"], ("train", "color_hard"))
        {'dmc/walker-walk': ['train', 'color_hard']}
        >>> levels_per_env(["dmc/walker-walk"], None, Comparison.named("dmcgb"))["dmc/walker-walk"]
        ['train', 'color_easy', 'color_hard', 'video_easy', 'video_hard']
    """
    found = {}
    for env in dict.fromkeys(envs):
        suite = env.split("/")[0]
        try:
            default = (["train", *PROTOCOLS[comparison.protocol].test_levels(env)] if comparison
                       else ["train", DEFAULT_GROUPS.get(suite, "all")])
            found[env] = resolve_levels(list(levels or default), suite=suite)
        except ValueError as error:
            raise ValueError(f"--compare {comparison.name}: {error}" if comparison else str(error)) from None
        for swept in sweeps:
            if swept[0].factor not in factors(env):
                raise ValueError(f"--sweep {swept[0].factor}: not a factor of {env}; its factors are {', '.join(factors(env))}.")
            found[env] += swept
    return found


def evaluation_protocol(agents: list[TrainedAgent], comparison: Comparison | None = None) -> Protocol | None:
    """The protocol an evaluation follows: the comparison's (``--compare``), else the one every run was trained under,
    else none."""
    if comparison is not None:
        return PROTOCOLS[comparison.protocol]
    trained = {trained.config.protocol for trained in agents}
    return PROTOCOLS[trained.pop()] if len(trained) == 1 and None not in trained and "" not in trained else None


def check_comparable(runs: list[Evaluated], levels: dict[str, list[Any]], videos: list[tuple[str, Any]],
                     comparison: Comparison) -> None:
    """Before any episode runs: raise the comparison's error (naming every difference) unless each run followed its
    protocol and its levels show the benchmark's data (what :meth:`Comparison.lines` checks, on rows of no episodes)."""
    probe = [{**run.tags, "env": run.env, "level": level, "return": 0.0, "success": 0.0, **shown_data(run.env, level, videos)}
             for run in runs for level in levels[run.env] if isinstance(level, str)]
    comparison.lines(probe)

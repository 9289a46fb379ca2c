"""Zero-shot evaluation: run a trained policy on generalization levels it never saw, one row per episode."""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from typing import Any

import torch
from tensordict import TensorDictBase
from torchrl.envs import EnvBase
from torchrl.envs.utils import ExplorationType, set_exploration_type

from vigen.envs import make_env
from vigen.envs.levels import resolve_levels

EnvFactory = Callable[[str, int], EnvBase]
"""``(level, seed) -> env``: how :func:`evaluate` builds an env when a name is not enough."""

Policy = Callable[[TensorDictBase], TensorDictBase]


def evaluate(
    policy: Policy,
    env: str | EnvFactory,
    levels: str | Sequence[str] = "train",
    *,
    episodes: int = 10,
    seeds: Sequence[int] = (0,),
    max_steps: int = 100_000,
    env_options: Mapping[str, Any] | None = None,
    tags: Mapping[str, Any] | None = None,
) -> list[dict[str, Any]]:
    """Run ``policy`` zero-shot on each level and return one row per episode.

    For every level and seed, one env is built (``make_env(env, generalization=level, seed=seed,
    **env_options)``, or ``env(level, seed)`` for a factory) and ``episodes`` episodes are played
    in it back to back, with TorchRL's exploration type set to ``DETERMINISTIC`` (the policy's
    mean action). The seed fixes the task's initial states and the level's perturbations, so two
    methods evaluated with the same seeds see the same scenes.

    Args:
        policy: a TorchRL policy (``TensorDictModule`` or any callable on a TensorDict) that reads
            the env's observation keys and writes ``"action"``.
        env: a vigen env name such as ``"dmc/walker-walk"``, or a factory ``(level, seed) -> env``.
        levels: level or group names (:func:`vigen.envs.levels.resolve_levels`), e.g.
            ``["train", "dmcgb"]``; with a factory, any labels the factory understands.
        episodes: episodes per level and seed.
        seeds: the env and level seeds.
        max_steps: a cap on agent steps per episode (the env's own time limit usually ends it first).
        env_options: more keyword arguments for :func:`vigen.envs.make_env` (e.g. ``render_settings``).
        tags: constant columns added to every row, e.g. ``{"method": "svea", "run": 1}``.

    Returns:
        Rows with ``env``, ``level``, ``seed``, ``episode``, ``return``, ``length`` and, where the
        task reports one, ``success`` (whether the episode ever succeeded), after the ``tags``.

    Examples:
        >>> from vigen.evaluation import evaluate
        >>> rows = evaluate(None, "dmc/cartpole-balance", ["train", "color_hard"], episodes=1, max_steps=5)
        >>> [(row["level"], row["length"]) for row in rows]
        [('train', 5), ('color_hard', 5)]

    ``policy=None`` plays random actions, a baseline worth reporting next to trained agents.
    """
    if episodes < 1:
        raise ValueError(f"episodes must be at least 1, got {episodes}.")
    if not seeds:
        raise ValueError("seeds is empty: give at least one seed, e.g. seeds=[0].")
    rows: list[dict[str, Any]] = []
    name = env if isinstance(env, str) else getattr(env, "__name__", "env")
    level_names = [levels] if isinstance(levels, str) else list(levels)
    if isinstance(env, str):
        level_names = resolve_levels(level_names, suite=env.split("/")[0])
    for level in level_names:
        for seed in seeds:
            if isinstance(env, str):
                instance = make_env(env, generalization=level, seed=seed, **dict(env_options or {}))
            else:
                instance = env(level, seed)
            try:
                for episode in range(episodes):
                    rows.append(
                        {**dict(tags or {}), "env": name, "level": level, "seed": seed, "episode": episode,
                         **_play(policy, instance, max_steps)}
                    )
            finally:
                instance.close()
    return rows


def _play(policy: Policy | None, env: EnvBase, max_steps: int) -> dict[str, Any]:
    with set_exploration_type(ExplorationType.DETERMINISTIC), torch.no_grad():
        trajectory = env.rollout(max_steps, policy, break_when_any_done=True)
    episode = trajectory["next"]
    result: dict[str, Any] = {
        "return": float(episode["reward"].sum()),
        "length": int(trajectory.numel()),
    }
    if "success" in episode.keys():
        result["success"] = bool(episode["success"].any())
    return result

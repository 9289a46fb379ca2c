"""Env names: ``"<suite>/<task>"`` strings, each suite a :class:`~vigen.envs.suite.Suite` record.

The suite records are imported here directly; each imports its simulator only when its first
env is built (robosuite and gymnasium-robotics are optional extras).
"""

from __future__ import annotations

from typing import Any

from torchrl.envs import EnvBase

from vigen.envs.adroit.suite import ADROIT
from vigen.envs.dmc.suite import DMC
from vigen.envs.loco.suite import LOCO
from vigen.envs.robosuite.suite import ROBOSUITE
from vigen.envs.level_types import level_label
from vigen.envs.suite import Suite

SUITES: dict[str, Suite] = {suite.name: suite for suite in (DMC, ROBOSUITE, ADROIT, LOCO)}
"""Suite prefix -> its record."""


def get_suite(name: str) -> Suite:
    """The suite of a prefix (``"dmc"``) or an env name (``"dmc/walker-walk"``); unknown ones raise listing the suites.

    Examples:
        >>> get_suite("dmc/walker-walk").name
        'dmc'
    """
    prefix = name.split("/", 1)[0] if isinstance(name, str) else name
    if prefix not in SUITES:
        raise ValueError(f"Unknown suite {prefix!r}. {_suites_hint()}")
    return SUITES[prefix]


def available_envs(suite: str | None = None) -> list[str]:
    """Every env name :func:`make_env` accepts, optionally for one suite only.

    Examples:
        >>> from vigen.envs import available_envs
        >>> "dmc/cheetah-run" in available_envs("dmc")
        True
    """
    suites = list(SUITES.values()) if suite is None else [get_suite(suite)]
    return [name for record in suites for name in record.env_names()]


def factors(name: str) -> list[str]:
    """The factor names a suite (``"dmc"``) or an env (``"dmc/walker-walk"``) supports, for ``generalization={factor: x}``.

    Examples:
        >>> from vigen.envs import factors
        >>> "camera_rotation" in factors("dmc/walker-walk")
        True
    """
    return list(get_suite(name).factors)


def make_env(name: str, **kwargs: Any) -> EnvBase:
    """Build a TorchRL pixel env from its vigen name: the one builder of every suite.

    Args:
        name: ``"<suite>/<task>"``, e.g. ``"dmc/walker-walk"``; :func:`available_envs` lists them.
        **kwargs: :meth:`Suite.make <vigen.envs.suite.Suite.make>`'s arguments:

            * ``generalization``: a level name (``None`` or ``"train"`` is the clean scene), a dict of
              factor intensities (e.g. ``{"camera_rotation": 0.3}``) or a list of vigen transforms;
            * ``seed``: seeds the task and every perturbation of the env, the ``i``-th with
              ``derive_seed(seed, i)``; ``env.set_seed(seed)`` later does the same;
            * ``frame_stack`` (3): frames stacked along channels (``"pixels"`` is ``[3·frame_stack, H, W]``);
            * ``level_options``: passed to the level's transforms that accept them, e.g.
              ``{"videos": folder}``; a key no transform of the suite takes raises, listing the valid ones;
            * ``scene_id`` (suites with scenes, robosuite's 10): the scene a level shows; ``None``
              follows the seed, ``seed % 10``;
            * the suite's env options, those of its base env: :class:`~vigen.envs.dmc.env.DMCPixelEnv`
              for ``dmc/`` (e.g. ``image_size``, ``action_repeat``, ``camera_id``, ``render_settings``),
              :class:`~vigen.envs.robosuite.env.RobosuitePixelEnv` for ``robosuite/``,
              :class:`~vigen.envs.adroit.env.AdroitPixelEnv` for ``adroit/`` and
              :class:`~vigen.envs.loco.env.LocoPixelEnv` for ``loco/``.

    Returns:
        A :class:`~vigen.envs.pixels.PixelEnv` (a ``TransformedEnv``) with uint8 ``"pixels"``, float32
        ``"action"`` and ``"reward"``, the done flags, and ``"success"`` where the task reports one.

    ``make_env`` is a module-level function, so ``functools.partial(make_env, name, ...)`` pickles
    and can be handed to ``ParallelEnv`` and TorchRL's multiprocess collectors.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", seed=0)
        >>> env.rollout(3)["pixels"].dtype
        torch.uint8
        >>> env = make_env("dmc/walker-walk", generalization={"camera_rotation": 0.3}, seed=0, image_size=32)
        >>> env.level.label
        'camera_rotation=0.3'
    """
    if not isinstance(name, str) or "/" not in name:
        raise ValueError(
            f"Env names look like '<suite>/<task>' (e.g. 'dmc/walker-walk'), got {name!r}. {_suites_hint()}"
        )
    prefix, task = name.split("/", 1)
    return get_suite(prefix).make(task, **kwargs)


def level_options_for(name: str, generalization: Any, options: dict[str, Any] | None) -> dict[str, Any]:
    """The ``level_options`` the transforms of one level of env ``name`` take, for callers that share options across levels.

    :func:`make_env` refuses options its level would drop (a palette on a video level); a caller
    that builds many levels from one set of options (:func:`~vigen.evaluation.evaluate`) gives each
    level its share. Your own transforms (a list) get none.

    Examples:
        >>> level_options_for("dmc/walker-walk", "video_easy", {"videos": "/data/davis", "palette": "/data/palette.npy"})
        {'videos': '/data/davis'}
        >>> level_options_for("dmc/walker-walk", "train", {"videos": "/data/davis"})
        {}
    """
    if not options:
        return {}
    if generalization is not None and not isinstance(generalization, (str, dict)):
        return {}
    prefix, task = name.split("/", 1)
    taken = get_suite(prefix).options_taken(generalization or "train", task)
    return {key: value for key, value in options.items() if key in taken}


def check_level_options_used(name: str, levels: list[Any], options: dict[str, Any] | None) -> None:
    """Raise on ``level_options`` keys that no level of ``levels`` takes (each would be dropped everywhere)."""
    if not options:
        return
    used = set().union(*(level_options_for(name, level, options) for level in levels))
    unused = sorted(key for key in options if key not in used)
    if unused:
        raise ValueError(f"level_options {', '.join(map(repr, unused))} do nothing at any of the levels "
                         f"{', '.join(level_label(level) for level in levels)} of {name}; drop them or add a level that takes them.")


def _suites_hint() -> str:
    return "Valid suites: " + "; ".join(f"{prefix} ({suite.about})" for prefix, suite in SUITES.items()) + "."

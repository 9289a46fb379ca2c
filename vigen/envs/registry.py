"""Env names: ``"<suite>/<env>"`` strings mapped to suite builders, with helpful errors for bad names.

Each suite is a module of ``vigen.envs`` that provides ``env_names() -> list[str]`` (the full
``"<suite>/<env>"`` names it builds) and ``make_named(env: str, **kwargs)`` (the builder for the
part after the slash). Suites import their simulator only when used.
"""

from __future__ import annotations

import difflib
import importlib
from types import ModuleType
from typing import Any

from torchrl.envs import EnvBase

SUITES: dict[str, tuple[str, str]] = {
    "dmc": ("vigen.envs.dmc", "dm_control suite tasks, dmc/<domain>-<task> (e.g. dmc/walker-walk)"),
    "robosuite": ("vigen.envs.robosuite", "robosuite manipulation, robosuite/<task> (e.g. robosuite/door); extra [robosuite]"),
    "adroit": ("vigen.envs.adroit", "Adroit dexterous hand, adroit/<task> (door, hammer, pen); extra [adroit]"),
}
"""Suite prefix -> (module, description)."""


def available_envs(suite: str | None = None) -> list[str]:
    """Every env name :func:`make_env` accepts, optionally for one suite only.

    Examples:
        >>> from vigen.envs import available_envs
        >>> "dmc/cheetah-run" in available_envs("dmc")
        True
    """
    prefixes = list(SUITES) if suite is None else [suite]
    return [name for prefix in prefixes for name in suite_module(prefix).env_names()]


def make_env(name: str, **kwargs: Any) -> EnvBase:
    """Build a TorchRL pixel env from its vigen name.

    Args:
        name: ``"<suite>/<env>"``, e.g. ``"dmc/walker-walk"``; :func:`available_envs` lists them.
        **kwargs: forwarded to the suite's builder (for ``dmc/``: :func:`vigen.envs.dmc.make_dmc_env`,
            e.g. ``seed``, ``frame_stack``, ``action_repeat``, ``camera_id``, ``render_settings``; for
            ``robosuite/``: :func:`vigen.envs.robosuite.make_robosuite_env`; for ``adroit/``:
            :func:`vigen.envs.adroit.make_adroit_env`).

    ``make_env`` is a module-level function, so ``functools.partial(make_env, name, ...)`` pickles
    and can be handed to ``ParallelEnv`` and TorchRL's multiprocess collectors.

    Examples:
        >>> from vigen.envs import make_env
        >>> env = make_env("dmc/walker-walk", seed=0)
        >>> env.rollout(3)["pixels"].dtype
        torch.uint8
    """
    if not isinstance(name, str) or "/" not in name:
        raise ValueError(
            f"Env names look like '<suite>/<env>' (e.g. 'dmc/walker-walk'), got {name!r}. {_suites_hint()}"
        )
    suite, env = name.split("/", 1)
    module = suite_module(suite)
    valid = module.env_names()
    if name not in valid:
        close = difflib.get_close_matches(name, valid, n=3, cutoff=0.6)
        hint = f" Did you mean {' or '.join(close)}?" if close else ""
        raise ValueError(f"Unknown env {name!r}.{hint} Valid names: {', '.join(valid)}.")
    return module.make_named(env, **kwargs)


def suite_module(suite: str) -> ModuleType:
    """The module that builds a suite's envs (and holds its ``LEVELS`` unless it is ``dmc``)."""
    if suite not in SUITES:
        raise ValueError(f"Unknown suite {suite!r}. {_suites_hint()}")
    return importlib.import_module(SUITES[suite][0])


def _suites_hint() -> str:
    return "Valid suites: " + "; ".join(f"{prefix} ({about})" for prefix, (_, about) in SUITES.items()) + "."

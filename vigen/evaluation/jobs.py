"""An evaluation's unit of work, a (level, seed) job, and the errors that stop a job and the evaluation.

:func:`~vigen.evaluation.evaluate` splits an evaluation into :class:`Job` records and runs them one
after another or on Ray (:mod:`vigen.evaluation.ray_backend`); both raise :class:`EvaluationError`
from a job's :class:`JobError`. This module imports neither backend, so both build on it.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from pathlib import Path
from typing import Any

Level = str | Mapping[str, float]
"""A level name (or group name), or a generalization dict ``{factor: intensity}`` (see :func:`~vigen.evaluation.sweep`)."""


class EvaluationError(RuntimeError):
    """An evaluation stopped on an error; the episodes that finished before it are kept in :attr:`rows`.

    Attributes:
        rows: one row per finished episode, as :func:`~vigen.evaluation.evaluate` returns them.
        level, seed: where the error happened (the job: one env, its episodes).
        episode: the episode that was running, or ``None`` if building or closing the env failed.
        rows_path: the CSV file that holds the same rows, if :func:`~vigen.evaluation.evaluate` was given one.
        reason: what stopped the job when it was not an exception of its own (a Ray worker that died).

    The message ends with the original error's own message (``cause``), so that its advice is read
    where the evaluation stopped.

    The original exception is chained (``__cause__``); ``reason`` says what stopped the job when it is
    not an exception of the job itself (a Ray worker that died).

    Examples:
        >>> error = EvaluationError([{"level": "train", "return": 1.0}], level="video_hard", seed=0, episode=2)
        >>> print(error)
        evaluation failed at level 'video_hard', seed 0, episode 2 after 1 finished episode(s); they are in .rows.
    """

    def __init__(self, rows: list[dict[str, Any]], *, level: str, seed: int, episode: int | None,
                 rows_path: Path | None = None, reason: str | None = None, cause: BaseException | None = None) -> None:
        self.rows, self.level, self.seed, self.episode, self.rows_path = rows, level, seed, episode, rows_path
        self.reason = reason
        where = f"level {level!r}, seed {seed}" + ("" if episode is None else f", episode {episode}")
        where += "" if reason is None else f" ({reason})"
        kept = f"they are in .rows{'' if rows_path is None else f' and {rows_path}'}"
        told = "" if cause is None else f" The error: {type(cause).__name__}: {cause}"  # its hint ("Did you mean ...") too
        super().__init__(f"evaluation failed at {where} after {len(rows)} finished episode(s); {kept}.{told}")


@dataclasses.dataclass(frozen=True)
class Job:
    """One (level, seed) of an evaluation: an env built once and ``episodes`` episodes played in it.

    Examples:
        >>> from vigen.evaluation.jobs import Job
        >>> Job(label="color_hard", level="color_hard", seed=0)
        Job(label='color_hard', level='color_hard', seed=0)
    """

    label: str
    level: Level
    seed: int


class JobError(Exception):
    """A job stopped: the rows it finished, the episode that was running (``None``: building or closing the env) and why.

    Examples:
        >>> from vigen.evaluation.jobs import Job, JobError
        >>> from vigen.evaluation.rollout import run_job
        >>> def no_env(level, seed):
        ...     raise OSError("no display")
        >>> try:
        ...     run_job(Job("train", "train", 0), policy=None, env=no_env, name="broken", episodes=1, max_steps=5,
        ...             env_options={}, tags={}, device=None)
        ... except JobError as failure:
        ...     print(failure.rows, failure.episode, repr(failure.error))
        [] None OSError('no display')
    """

    def __init__(self, rows: list[dict[str, Any]], episode: int | None, error: BaseException) -> None:
        super().__init__(rows, episode, error)
        self.rows, self.episode, self.error = rows, episode, error

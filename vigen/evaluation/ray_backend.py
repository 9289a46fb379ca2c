"""Zero-shot evaluation fanned out over Ray: one task per (level, seed) job, rows returned in the serial order.

:func:`~vigen.evaluation.evaluate` calls :func:`run_jobs_on_ray` for ``backend="ray"``. Every job
builds its own env from its seed, so a job gives the same rows on any worker as in the serial
loop. The policy is put in Ray's object store once and each task reads it from there. A job that
raises, or whose worker process dies, stops the evaluation with an
:class:`~vigen.evaluation.EvaluationError` naming the job; the jobs still queued are cancelled.
Tasks are not retried: a crashed worker is reported at once instead of the job being re-run
silently.
"""

from __future__ import annotations

import functools
from collections.abc import Callable, Sequence
from typing import Any

import torch

from vigen.evaluation.jobs import EvaluationError, Job, JobError
from vigen.ray_cluster import ray_session

Rows = list[dict[str, Any]]


def run_jobs_on_ray(jobs: Sequence[Job], run: Callable[[Job], Rows], *, workers: int | None = None,
                    progress: Callable[[int, int], None] | None = None, log: Any = None) -> Rows:
    """Run ``run(job)`` for every job in Ray tasks, at most ``workers`` at once, and return their rows in job order.

    Args:
        jobs: the (level, seed) jobs, in the order their rows are returned.
        run: the picklable job runner (:func:`vigen.evaluation.rollout.run_job` with its arguments bound).
        workers: jobs in flight at once (default: the cluster's CPUs).
        progress: ``progress(finished_jobs, total_jobs)`` after each job.
        log: an object with ``append(row)`` (the ``rows_path`` file), fed each job's rows as it ends.

    Raises:
        EvaluationError: a job failed or its worker died; ``.rows`` holds the rows of the jobs that
            finished (in job order), ``.level`` and ``.seed`` name the failed job.

    Examples:
        >>> from vigen.evaluation import evaluate
        >>> rows = evaluate(None, "dmc/cartpole-balance", ["train", "color_hard"], episodes=1, max_steps=3,
        ...                 env_options={"image_size": 16}, backend="ray", workers=1)
        >>> [(row["level"], row["length"]) for row in rows]
        [('train', 3), ('color_hard', 3)]
    """
    with ray_session() as ray:
        limit = workers or max(1, int(ray.cluster_resources().get("CPU", 1)))
        task = ray.remote(num_cpus=1, max_retries=0)(_run_in_worker)
        runner = ray.put(run)
        results: dict[int, Rows] = {}
        pending: dict[Any, int] = {}
        queue = list(enumerate(jobs))
        try:
            while queue or pending:
                while queue and len(pending) < limit:
                    index, job = queue.pop(0)
                    pending[task.remote(runner, job)] = index
                (ready, *_), _ = ray.wait(list(pending), num_returns=1)
                index = pending.pop(ready)
                results[index] = _rows_or_raise(ray, ready, index, jobs, results, log)
                if log is not None:
                    _log_rows(log, index, jobs, results)
                if progress is not None:
                    progress(len(results), len(jobs))
        finally:
            for ref in pending:
                ray.cancel(ref, force=True)
    return [row for index in range(len(jobs)) for row in results[index]]


def _run_in_worker(run: Callable[[Job], Rows], job: Job) -> Rows:
    """A Ray task: one job on one thread (Ray gives each task one CPU); the worker's thread count is put back after."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        return run(job)
    finally:
        torch.set_num_threads(threads)


def _rows_or_raise(ray: Any, ref: Any, index: int, jobs: Sequence[Job], results: dict[int, Rows], log: Any) -> Rows:
    """Job ``index``'s rows, or the EvaluationError that names it, with every finished row in job order (and in ``log``)."""
    try:
        return ray.get(ref)
    except Exception as error:
        job = jobs[index]
        failure = _job_error(ray, error)
        partial = [] if failure is None else failure.rows
        if log is not None:
            for row in partial:
                log.append(row)
        finished = [row for i in sorted([*results, index]) for row in (partial if i == index else results[i])]
        where = functools.partial(EvaluationError, finished, level=job.label, seed=job.seed,
                                  rows_path=None if log is None else getattr(log, "path", None))
        if failure is not None:
            raise where(episode=failure.episode, cause=failure.error) from failure.error
        died = isinstance(error, (ray.exceptions.WorkerCrashedError, ray.exceptions.NodeDiedError, ray.exceptions.ActorDiedError))
        root = error.cause if isinstance(error, ray.exceptions.RayTaskError) and error.cause is not None else error
        reason = f"its Ray worker died: {type(root).__name__}" if died else f"Ray failed to run it: {type(root).__name__}"
        raise where(episode=None, reason=reason) from error


def _log_rows(log: Any, index: int, jobs: Sequence[Job], results: dict[int, Rows]) -> None:
    """Append job ``index``'s rows to the ``rows_path`` file; a failed write stops the evaluation with every finished row."""
    try:
        for row in results[index]:
            log.append(row)
    except OSError as error:
        job = jobs[index]
        finished = [row for i in sorted(results) for row in results[i]]
        raise EvaluationError(finished, level=job.label, seed=job.seed, episode=None,
                              reason=f"writing its rows to {log.path} failed: {error}") from error


def _job_error(ray: Any, error: Exception) -> JobError | None:
    """The :class:`JobError` a task raised, unwrapped from Ray's ``RayTaskError``; ``None`` for a dead worker and the like."""
    if isinstance(error, ray.exceptions.RayTaskError):  # it also subclasses the task's exception; .cause is the original
        error = error.cause
    return error if isinstance(error, JobError) else None

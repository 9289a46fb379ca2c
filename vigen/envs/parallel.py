"""TorchRL's ``ParallelEnv``, plus the original exception of a worker that fails.

A worker of ``torchrl.envs.ParallelEnv`` that raises dies, and the parent only learns
``"Cannot proceed, worker 1 dead."``: the exception stays in the worker's stderr. Here each
worker's env writes the traceback of its failure to a private report file before it dies
(vigen's :class:`~vigen.envs.pixels.PixelEnv` does it for its steps, resets and seeds; the
worker's factory for the env's construction), and the parent raises a :class:`WorkerError`
that holds it.
"""

from __future__ import annotations

import shutil
import tempfile
import weakref
from collections.abc import Callable, Iterator, Sequence
from contextlib import contextmanager, suppress
from functools import partial
from pathlib import Path
from typing import Any

import torchrl.envs
from tensordict import TensorDictBase
from torchrl.envs import EnvBase, TransformedEnv

from vigen.envs.failure_report import failures_recorded
from vigen.envs.pixels import PixelEnv

REPORT_KWARG = "vigen_failure_report"
"""The keyword :class:`ParallelEnv` adds to each worker's factory call: the file its failures go to."""

TRACEBACK_TAIL = 25
"""Lines of a worker's traceback quoted in a :class:`WorkerError` (the whole one is ``error.reports``)."""


def build_reporting_env(
    create_env_fn: Callable[..., EnvBase], vigen_failure_report: str | None = None, **kwargs: Any
) -> EnvBase:
    """``create_env_fn(**kwargs)``, with its failures (at construction, and in every vigen ``PixelEnv`` of its chain) written to ``vigen_failure_report``.

    :class:`ParallelEnv` hands each worker ``partial(build_reporting_env, create_env_fn)``
    (picklable whenever ``create_env_fn`` is) and the worker's own report file.

    Examples:
        >>> from functools import partial
        >>> from vigen.envs import make_env
        >>> env = build_reporting_env(partial(make_env, "dmc/cartpole-balance", image_size=16), "/tmp/report.txt")
        >>> env.failure_report
        '/tmp/report.txt'
    """
    with failures_recorded(vigen_failure_report):
        env = create_env_fn(**kwargs)
    link = env
    while isinstance(link, TransformedEnv):
        if isinstance(link, PixelEnv):
            link.failure_report = vigen_failure_report
        link = link.base_env
    return env


class WorkerError(RuntimeError):
    """A :class:`ParallelEnv` worker failed; the message quotes its exception and the tail of its traceback.

    Attributes:
        worker: the index of the first worker that failed.
        reports: each failed worker's index and full traceback, in worker order.
    """

    def __init__(self, reports: dict[int, str]) -> None:
        self.reports = dict(sorted(reports.items()))
        self.worker = next(iter(self.reports))
        parts = []
        for worker, report in self.reports.items():
            lines = report.rstrip().splitlines()
            tail = "\n".join(lines[-TRACEBACK_TAIL:])
            parts.append(f"ParallelEnv worker {worker} failed: {lines[-1]}\nWorker {worker}'s traceback (last lines):\n{tail}")
        super().__init__("\n\n".join(parts))


class ParallelEnv(torchrl.envs.ParallelEnv):
    """``torchrl.envs.ParallelEnv`` (same arguments, same data) whose worker failures show their cause.

    When a worker's env raises (at construction, reset, step or ``set_seed``), TorchRL's parent
    only sees a dead worker. This env wraps each factory with :func:`build_reporting_env`, so
    the worker writes its traceback to a private temporary folder before it dies, and raises a
    :class:`WorkerError` (chained from TorchRL's error) naming the worker and quoting its
    exception. The failed env's workers are then stopped; ``close()`` still works. The folder
    is removed by ``close()`` and when the env is garbage collected. Steps, resets and seeds
    of vigen's envs are reported; a non-vigen env's construction failures are reported too,
    its later failures keep TorchRL's message.

    An ``EnvCreator`` factory is built once more in the parent for the metadata (it is wrapped).
    Workers are spawned: in a script, build the env under ``if __name__ == "__main__":``.

    Examples:
        >>> from functools import partial
        >>> from vigen.envs import ParallelEnv, make_env
        >>> env = ParallelEnv(2, partial(make_env, "dmc/cartpole-balance", image_size=16))
        >>> try:
        ...     _ = env.set_seed(0)
        ...     data = env.rollout(3)
        ... finally:
        ...     env.close()
        >>> data["pixels"].shape, env.failure_reports()
        (torch.Size([2, 3, 9, 16, 16]), {})
    """

    _report_folder: Path | None = None
    _remove_report_folder: weakref.finalize | None = None
    _workers_stopped: bool = False

    def __init__(
        self,
        num_workers: int,
        create_env_fn: Callable[..., EnvBase] | Sequence[Callable[..., EnvBase]],
        **kwargs: Any,
    ) -> None:
        if callable(create_env_fn) and not isinstance(create_env_fn, EnvBase):
            create_env_fn = partial(build_reporting_env, create_env_fn)
        elif isinstance(create_env_fn, Sequence):
            wrapped: dict[int, Any] = {}  # one wrapper per distinct factory: TorchRL's single-task check compares them
            for fn in create_env_fn:
                if id(fn) not in wrapped:
                    wrapped[id(fn)] = fn if isinstance(fn, EnvBase) else partial(build_reporting_env, fn)
            create_env_fn = [wrapped[id(fn)] for fn in create_env_fn]
        super().__init__(num_workers, create_env_fn, **kwargs)

    def _start_workers(self) -> None:
        self._open_report_folder()
        self._workers_stopped = False
        for index, (fn, kwargs) in enumerate(zip(self.create_env_fn, self.create_env_kwargs)):
            if isinstance(fn, partial) and fn.func is build_reporting_env:
                kwargs[REPORT_KWARG] = str(self._report_folder / f"worker-{index}.txt")
        with self._failures_explained():
            super()._start_workers()

    def _open_report_folder(self) -> None:
        self._close_report_folder()
        self._report_folder = Path(tempfile.mkdtemp(prefix="vigen-parallel-env-"))
        self._remove_report_folder = weakref.finalize(self, shutil.rmtree, self._report_folder, ignore_errors=True)

    def _close_report_folder(self) -> None:
        if self._remove_report_folder is not None:
            self._remove_report_folder()
        self._report_folder = self._remove_report_folder = None

    def failure_reports(self) -> dict[int, str]:
        """The traceback each failed worker wrote, by worker index (empty while every worker is well, and once closed)."""
        if self._report_folder is None:
            return {}
        reports = {}
        for index in range(self.num_workers):
            with suppress(FileNotFoundError):
                reports[index] = (self._report_folder / f"worker-{index}.txt").read_text()
        return reports

    @contextmanager
    def _failures_explained(self) -> Iterator[None]:
        try:
            yield
        except WorkerError:
            raise
        except Exception as error:
            reports = self.failure_reports()
            if not reports:
                raise
            self._stop_workers()
            raise WorkerError(reports) from error

    def _stop_workers(self) -> None:
        for process in self.__dict__.get("_workers", []):
            with suppress(ValueError):  # TorchRL may have closed it already
                if process.is_alive():
                    process.terminate()
                process.join(self._timeout)
                process.close()
        for channel in self.__dict__.get("parent_channels", []):
            channel.close()
        self._workers_stopped = True

    def _shutdown_workers(self) -> None:
        if self._workers_stopped:
            self._workers_stopped = False
            return
        super()._shutdown_workers()

    def close(self, *, raise_if_closed: bool = True) -> None:
        """Stop the workers (TorchRL's ``close``, which also works after a worker failed) and remove the report folder."""
        try:  # a failure while starting leaves TorchRL's env closed: closing it again is then no error
            super().close(raise_if_closed=raise_if_closed and not self._workers_stopped)
        finally:
            self._close_report_folder()

    def set_seed(self, seed: int | None = None, static_seed: bool = False) -> int | None:
        with self._failures_explained():
            return super().set_seed(seed, static_seed=static_seed)

    def _reset(self, tensordict: TensorDictBase | None, **kwargs: Any) -> TensorDictBase:
        with self._failures_explained():
            return super()._reset(tensordict, **kwargs)

    def _step(self, tensordict: TensorDictBase) -> TensorDictBase:
        with self._failures_explained():
            return super()._step(tensordict)

    def step_and_maybe_reset(self, tensordict: TensorDictBase) -> tuple[TensorDictBase, TensorDictBase]:
        with self._failures_explained():
            return super().step_and_maybe_reset(tensordict)

"""Where a training loop's time goes: wall seconds per stage (:class:`StageClock`), the GPU's busy share (:class:`GpuBusy`),
and both logged per collector batch (:class:`StageTimes`).

``examples/train.py --time-stages`` logs them, per collector batch, as ``time/*`` scalars; the
env workers' own figures (physics, rendering) come from :func:`vigen.envs.add_step_timers`.
``benchmarks/train_throughput.py`` reads them back.
"""

from __future__ import annotations

import contextlib
import time
import warnings
from collections.abc import Iterable, Iterator
from typing import Any, Protocol

import torch


class StageClock:
    """Wall seconds per named stage, summed until :meth:`take` reads and clears them.

    Examples:
        >>> from vigen.run.timing import StageClock
        >>> clock = StageClock()
        >>> with clock("store"):
        ...     pass
        >>> clock.add("update", 0.25)
        >>> clock.add("update", 0.25)
        >>> times = clock.take()
        >>> sorted(times), times["update"], clock.take()
        (['store', 'update'], 0.5, {})
    """

    def __init__(self) -> None:
        self._seconds: dict[str, float] = {}

    @contextlib.contextmanager
    def __call__(self, stage: str) -> Iterator[None]:
        """Time the ``with`` block as ``stage``."""
        started = time.perf_counter()
        try:
            yield
        finally:
            self.add(stage, time.perf_counter() - started)

    def add(self, stage: str, seconds: float) -> None:
        """Add ``seconds`` to ``stage``."""
        self._seconds[stage] = self._seconds.get(stage, 0.0) + seconds

    def take(self) -> dict[str, float]:
        """The seconds per stage since the last call, then start again from zero."""
        seconds, self._seconds = self._seconds, {}
        return seconds


def busy_seconds(intervals: Iterable[tuple[float, float]]) -> float:
    """The length of the union of ``(start, end)`` intervals: time during which at least one of them ran.

    Kernels on several streams may overlap; counting their union keeps the busy share at most 1.

    Examples:
        >>> from vigen.run.timing import busy_seconds
        >>> busy_seconds([(0.0, 2.0), (1.0, 3.0), (5.0, 6.0)])
        4.0
    """
    total, reach = 0.0, None
    for start, end in sorted(intervals):
        if reach is None or start > reach:
            total += end - start
            reach = end
        elif end > reach:
            total += end - reach
            reach = end
    return total


def device_intervals(profiler: Any, device_type: str = "cuda") -> list[tuple[float, float]]:
    """The ``(start, end)`` seconds of every activity a ``torch.profiler.profile`` recorded on ``device_type``.

    On CUDA these are the kernels, memory copies and memsets; ``"cpu"`` gives the host's operators
    (what a CPU-only test can check).
    """
    kind = getattr(torch.autograd.DeviceType, device_type.upper())
    events = profiler.profiler.kineto_results.events()
    return [(event.start_ns() / 1e9, (event.start_ns() + event.duration_ns()) / 1e9)
            for event in events if event.device_type() == kind and event.duration_ns() > 0]


class GpuBusy:
    """The share of a window of wall time during which the GPU ran anything (kernels, copies): torch.profiler, CUDA activity only.

    ``start()`` and ``stop()`` synchronize the device at the window's ends; ``stop()`` returns the
    busy seconds (the union of the recorded device activities) over the window's wall seconds, or
    ``None`` with a warning if the profiler failed: a figure is never worth stopping a run for.

    Examples:
        >>> from vigen.run.timing import GpuBusy
        >>> busy = GpuBusy(torch.device("cpu"))  # the host's operators stand in for the GPU's kernels
        >>> busy.start()
        >>> _ = torch.ones(256, 256) @ torch.ones(256, 256)
        >>> 0 < busy.stop() <= 1
        True
    """

    def __init__(self, device: torch.device) -> None:
        self.device = torch.device(device)
        self._profiler: Any = None
        self._started = 0.0

    def _synchronize(self) -> None:
        if self.device.type == "cuda":
            torch.cuda.synchronize(self.device)

    def start(self) -> None:
        """Begin the window."""
        activity = torch.profiler.ProfilerActivity.CUDA if self.device.type == "cuda" else torch.profiler.ProfilerActivity.CPU
        try:
            self._synchronize()
            self._profiler = torch.profiler.profile(activities=[activity])
            self._profiler.__enter__()
        except Exception as error:  # noqa: BLE001 - see the class docstring
            warnings.warn(f"GpuBusy: the profiler did not start ({type(error).__name__}: {error}); no busy share", stacklevel=2)
            self._profiler = None
        self._started = time.perf_counter()

    def stop(self) -> float | None:
        """End the window: the device's busy share of it, in [0, 1] (``None`` if the profiler failed)."""
        if self._profiler is None:
            return None
        try:
            self._synchronize()
            wall = time.perf_counter() - self._started
            self._profiler.__exit__(None, None, None)
            busy = busy_seconds(device_intervals(self._profiler, self.device.type))
        except Exception as error:  # noqa: BLE001 - see the class docstring
            warnings.warn(f"GpuBusy: the profile could not be read ({type(error).__name__}: {error}); no busy share", stacklevel=2)
            return None
        finally:
            self._profiler = None
        return min(busy / wall, 1.0) if wall > 0 else None


class TimedBatches(Protocol):
    """Batches that say how each was got (:class:`vigen.run.CollectorBatches`)."""

    collect_seconds: float
    wait_seconds: float
    sync_seconds: float

    def __iter__(self) -> Iterator[Any]: ...


class StageTimes:
    """``--time-stages``: one row of ``time/*`` scalars per collector batch, where its time went.

    The loop times its own stages on :attr:`clock` (``store``, ``sample``, ``update``);
    :meth:`batches` adds each batch's ``collect``, ``wait`` and ``sync`` seconds and, when enabled,
    takes the env workers' step times out of the batch (:func:`vigen.envs.step_times`); :meth:`log`
    writes the row after the batch's updates. On CUDA, the GPU's busy share is measured once, over
    the whole batch that follows the first batch of updates (compilation done), collection included.

    A row: ``wall_s`` (seconds since the run started, to read frames/s between two rows), the
    batch's ``steps`` and ``updates``; the loop's seconds in this batch per stage (``collect_s``:
    the collector's own time, in the background when overlapping; ``wait_s``: the part the loop
    waited for; ``sync_s``, ``store_s``, ``sample_s``, ``update_s``); the env workers' mean
    milliseconds per agent step (``env_step_ms`` and its ``env_physics_ms``, ``env_render_ms``;
    ``env_policy_ms``, ``env_reset_ms``); ``gpu_busy`` once.

    Args:
        log_scalar: ``(name, value, step)``, e.g. a TorchRL logger's ``log_scalar``.
        device: the updates' device (the busy share is measured on CUDA only).
        enabled: log the rows; when off, :meth:`batches` passes the batches through and :meth:`log` writes nothing.

    Examples:
        >>> logged = {}
        >>> times = StageTimes(lambda name, value, step: logged.setdefault(name, value), torch.device("cpu"), enabled=True)
        >>> with times.clock("store"):
        ...     pass
        >>> times.log(frames=200, steps=100, updates=50)
        >>> sorted(logged)
        ['time/steps', 'time/store_s', 'time/updates', 'time/wall_s']
    """

    def __init__(self, log_scalar: Any, device: torch.device, *, enabled: bool) -> None:
        self.log_scalar, self.device, self.enabled = log_scalar, torch.device(device), enabled
        self.clock = StageClock()
        self.started = time.perf_counter()
        self.update_batches = 0  # collector batches after which updates were made
        self._env_times: dict[str, float] | None = None
        self._busy: GpuBusy | None = None

    def batches(self, batches: TimedBatches) -> Iterator[Any]:
        """The batches of ``batches``, each timed (and, enabled, without its env step times)."""
        from vigen.envs import step_times, without_step_times

        iterator = iter(batches)
        while True:
            busy = GpuBusy(self.device) if self.enabled and self.device.type == "cuda" and self.update_batches == 1 else None
            if busy is not None:  # one whole batch, end to end, once the updates have started (compilation done)
                busy.start()
            batch = next(iterator, None)
            if batch is None:
                if busy is not None:
                    busy.stop()
                return
            for stage in ("collect", "wait", "sync"):
                self.clock.add(stage, getattr(batches, f"{stage}_seconds"))
            self._env_times, self._busy = None, busy
            if self.enabled:
                self._env_times, batch = step_times(batch), without_step_times(batch)
            yield batch

    def log(self, frames: int, steps: int, updates: int) -> None:
        """After a batch's updates: count them and, enabled, log the batch's row at ``frames``."""
        self.update_batches += updates > 0
        if not self.enabled:
            return
        gpu_busy = self._busy.stop() if self._busy is not None else None
        self._busy = None
        rows = {"wall_s": time.perf_counter() - self.started, "steps": steps, "updates": updates}
        rows.update({f"{stage}_s": seconds for stage, seconds in self.clock.take().items()})
        if self._env_times is not None:
            rows.update({f"env_{name}_ms": 1000 * value for name, value in self._env_times.items() if value == value})
        if gpu_busy is not None:
            rows["gpu_busy"] = gpu_busy
        for name, value in rows.items():
            self.log_scalar(f"time/{name}", value, step=frames)

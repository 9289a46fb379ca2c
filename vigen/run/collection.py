"""A collector's batches for a training loop: collected one after the other, or the next collected while the loop trains.

:class:`CollectorBatches` hands a loop the batches of one collector, with the call that sends
the collector the policy's current weights made at a fixed point of the sequence:

* **serial** (``overlap=False``): batch ``k + 1`` is collected after the loop's work on batch
  ``k`` and after the weights were sent, so it acts with the weights of every update made so
  far. This is what iterating the collector directly does.
* **overlapped** (``overlap=True``): as soon as batch ``k`` arrives, the weights are sent and batch
  ``k + 1`` starts collecting in a background thread while the loop stores batch ``k`` and
  updates. Batch ``k + 1`` therefore acts with the weights of the updates made up to batch
  ``k - 1``: exactly one batch of updates behind the serial run, every time. The loop's own
  work (which batches it stores, when and how often it updates) is unchanged.

Both are deterministic: the weights each batch acts with, and the order of the batches, depend on
nothing but the sequence. The weights are sent only while no batch is being collected, so the
collector never acts with half-updated weights, provided the collector acts with its own copy
of the policy (TorchRL's multi-process collectors keep their weights in their processes, or in
shared memory that only ``update_policy_weights_`` writes when given a copy of the policy). When
the collector's iteration ends (a segment's last batch), nothing is left in flight.

The overlapped mode needs a collector whose yielded batch is not overwritten by the next one
(TorchRL's ``MultiSyncCollector`` stacks its workers' batches into a new tensordict each time; a
single-process ``Collector`` reuses its buffer).
"""

from __future__ import annotations

import contextlib
import os
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Generic, TypeVar

Batch = TypeVar("Batch")
_END = object()  # the collector has no more batches

WEIGHT_SYNC_SECONDS = 300.0
"""How long a TorchRL worker process waits for its first weights, in vigen's runs (TorchRL 0.14.1's default: 60 s)."""

WEIGHT_SYNC_VARIABLES = ("WEIGHT_SYNC_TIMEOUT", "TORCHRL_WEIGHT_SYNC_TIMEOUT")
"""The environment variables TorchRL reads the wait from: ``WEIGHT_SYNC_TIMEOUT`` (``torchrl._utils``, read in torchrl
0.14.1) and ``TORCHRL_WEIGHT_SYNC_TIMEOUT`` (``torchrl.collectors._constants``, defined there, read by nothing yet)."""


@contextlib.contextmanager
def worker_timeouts(seconds: float = WEIGHT_SYNC_SECONDS) -> Iterator[dict[str, str]]:
    """Within it, the worker processes a TorchRL collector starts wait up to ``seconds`` for their first weights.

    TorchRL reads ``WEIGHT_SYNC_TIMEOUT`` once, when a process imports it, as the default wait of
    its shared-memory weight transport (``SharedMemTransport.setup_connection_and_weights_on_receiver``,
    60 s): a worker that gets no weights within it fails with ``_queue.Empty`` in the weight
    scheme's ``connect`` -- what stopped both 8-worker runs on the H200 (2026-11-28). The variable
    reaches a worker only through the environment it is started with (TorchRL spawns its
    workers), so vigen sets it around the collector's construction, where the workers start,
    and puts the environment back after. A value set by the user is kept.

    Yields the variables as the workers see them.

    Examples:
        >>> import os
        >>> with worker_timeouts(120) as seen:
        ...     os.environ["WEIGHT_SYNC_TIMEOUT"] == seen["WEIGHT_SYNC_TIMEOUT"]
        True
    """
    if not seconds > 0:
        raise ValueError(f"worker_timeouts: seconds must be > 0, got {seconds!r}.")
    saved = {name: os.environ.get(name) for name in WEIGHT_SYNC_VARIABLES}
    for name in WEIGHT_SYNC_VARIABLES:
        os.environ.setdefault(name, f"{float(seconds):g}")
    try:
        yield {name: os.environ[name] for name in WEIGHT_SYNC_VARIABLES}
    finally:
        for name, value in saved.items():
            if value is None:
                os.environ.pop(name, None)
            else:
                os.environ[name] = value


def _timed_next(iterator: Iterator) -> tuple[object, float]:
    started = time.perf_counter()
    batch = next(iterator, _END)
    return batch, time.perf_counter() - started


class CollectorBatches(Generic[Batch]):
    """The batches of ``collector``, serial or overlapped, with ``sync_weights()`` called between them (see the module).

    After each batch is handed out, three attributes say how it was got (wall seconds):
    ``collect_seconds`` (the collector's ``next``, in whichever thread ran it), ``wait_seconds``
    (how long the loop was kept waiting for it: equal to ``collect_seconds`` when serial, the part
    of the collection the loop's own work did not hide when overlapped) and ``sync_seconds`` (the
    loop's time sending weights on its way to this batch).

    Args:
        collector: any iterable of batches (a TorchRL collector).
        sync_weights: sends the policy's current weights to the collector.
        overlap: collect the next batch in a background thread while the loop works on this one.

    Examples:
        >>> weights, acting, seen = [0], [0], []  # the policy's version, the collector's copy, each batch's version
        >>> def collector():
        ...     for _ in range(4):
        ...         seen.append(acting[0])  # collecting with the weights last sent
        ...         yield len(seen)
        >>> def sync_weights():
        ...     acting[0] = weights[0]
        >>> for overlap in (False, True):
        ...     weights[0], acting[0], seen[:] = 0, 0, []
        ...     for batch in CollectorBatches(collector(), sync_weights, overlap=overlap):
        ...         weights[0] += 1  # the loop's updates on this batch
        ...     print(seen)
        [0, 1, 2, 3]
        [0, 0, 1, 2]
    """

    def __init__(self, collector: Iterable[Batch], sync_weights: Callable[[], None], *, overlap: bool = False) -> None:
        self.collector, self.sync_weights, self.overlap = collector, sync_weights, overlap
        self.collect_seconds = self.wait_seconds = self.sync_seconds = 0.0

    def __iter__(self) -> Iterator[Batch]:
        iterator = iter(self.collector)
        if not self.overlap:
            yield from self._serial(iterator)
        else:
            yield from self._overlapped(iterator)

    def _serial(self, iterator: Iterator[Batch]) -> Iterator[Batch]:
        self.sync_seconds = 0.0
        while True:
            batch, self.collect_seconds = _timed_next(iterator)
            self.wait_seconds = self.collect_seconds
            if batch is _END:
                return
            yield batch  # the loop stores it and updates
            started = time.perf_counter()
            self.sync_weights()
            self.sync_seconds = time.perf_counter() - started

    def _overlapped(self, iterator: Iterator[Batch]) -> Iterator[Batch]:
        # one thread, one batch in flight; leaving the generator (an error in the loop) waits for it
        with ThreadPoolExecutor(max_workers=1, thread_name_prefix="vigen-collector") as pool:
            pending = pool.submit(_timed_next, iterator)
            while True:
                started = time.perf_counter()
                batch, collect_seconds = pending.result()
                wait_seconds = time.perf_counter() - started
                if batch is _END:
                    self.collect_seconds, self.wait_seconds = collect_seconds, wait_seconds
                    return
                started = time.perf_counter()
                self.sync_weights()  # nothing is collecting now: the next batch acts with these weights
                sync_seconds = time.perf_counter() - started
                pending = pool.submit(_timed_next, iterator)
                self.collect_seconds, self.wait_seconds, self.sync_seconds = collect_seconds, wait_seconds, sync_seconds
                yield batch  # the loop stores it and updates while the next one is collected

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

import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from typing import Generic, TypeVar

Batch = TypeVar("Batch")
_END = object()  # the collector has no more batches


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

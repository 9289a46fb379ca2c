"""A training run's collectors: one per segment (:class:`SegmentCollectors`), and their batches for the loop, collected one
after the other, or the next collected while the loop trains (:class:`CollectorBatches`).

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

:class:`SegmentCollectors` gives ``examples/train.py`` each segment's batches (a segment ends at each
checkpoint): a collector built for the segment, its envs freshly reset with the segment's seed
``derive_seed(seed, agent steps)``, or, with ``--overlap``, the worker processes kept for the whole
run, reseeded and reset at each segment's start. Either way a run resumed at a checkpoint collects
what the run never killed collects after it.
"""

from __future__ import annotations

import contextlib
import copy
import itertools
import os
import time
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import ThreadPoolExecutor
from functools import partial
from typing import Any, Generic, TypeVar

import torch
from tensordict import TensorDict
from torch import nn
from torchrl.collectors import Collector, MultiSyncCollector

from vigen.run.checkpoint import random_states, set_random_states
from vigen.run.config import TrainConfig
from vigen.run.schedule import RunSchedule
from vigen.seeding import ENV_SEED_LIMIT, derive_seed

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

    def __init__(self, collector: Iterable[Batch], sync_weights: Callable[[], None], *, overlap: bool = False,
                 when_done: Callable[[], None] | None = None) -> None:
        self.collector, self.sync_weights, self.overlap, self.when_done = collector, sync_weights, overlap, when_done
        self.collect_seconds = self.wait_seconds = self.sync_seconds = 0.0

    def __iter__(self) -> Iterator[Batch]:
        """The batches; ``when_done`` (e.g. the collector's shutdown) is called once the collector has no more."""
        iterator = iter(self.collector)
        if not self.overlap:
            yield from self._serial(iterator)
        else:
            yield from self._overlapped(iterator)
        if self.when_done is not None:
            self.when_done()

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


class SegmentCollectors:
    """The collector of each segment of a run (a segment ends at each checkpoint), as :class:`CollectorBatches`.

    Serial (``--overlap`` off): each segment builds its collector (:func:`make_collector`), its envs reset with
    ``derive_seed(seed, agent steps)``, and shuts it down after its last batch. ``--overlap``: the worker processes are
    built at the first segment of this process and kept for the rest of the run; each segment sends them the current
    weights, reseeds them (``collector.set_seed(derive_seed(seed, agent steps))``: each worker's env, perturbations, torch
    and numpy generators, a chain from that seed) and resets them. A run never killed builds them once, a resumed run
    at its resume: so that both go on alike, building them draws nothing from this process's random generators (their
    states are put back), and the trajectory ids (``"collector"``), which kept workers go on counting, are dropped from
    the batches.

    Args:
        make: ``make(seed=...)`` builds one env; in a worker process or Ray actor ``make(seed=..., worker=index)``
            (picklable).
        policy: the acting policy; worker processes act with a copy, sent between batches.
        config: the run's ``workers``, ``collector``, ``overlap`` and ``seed``.
        schedule: the run's agent steps (batches, segments, seed steps).
    """

    def __init__(self, make: Callable[..., Any], policy: nn.Module, config: TrainConfig, schedule: RunSchedule) -> None:
        self.make, self.policy, self.config, self.schedule = make, policy, config, schedule
        self._kept: tuple[Any, Iterator[Any], Callable[[], None]] | None = None

    def segment(self, steps: int) -> CollectorBatches:
        """The batches from ``steps`` agent steps to the next checkpoint (serial: a fresh collector, built now)."""
        schedule, config = self.schedule, self.config
        env_seed = derive_seed(config.seed, steps, below=ENV_SEED_LIMIT)
        count = schedule.segment_batches(steps)
        if config.overlap:
            collector, running, sync_weights = self._kept_workers(steps, env_seed)
            sync_weights()  # the segment's first batch acts with every update so far, as after a rebuild
            collector.set_seed(env_seed)  # each worker's env, perturbations, torch and numpy reseeded (a chain from env_seed), reset
            source = (batch.exclude("collector") for batch in itertools.islice(running, count))
            return CollectorBatches(source, sync_weights, overlap=True)
        collector, sync_weights = make_collector(self.make, self.policy, config, env_seed=env_seed,
                                                 steps_per_batch=schedule.worker_batch_steps, batches=count,
                                                 random_steps=max(0, schedule.seed_steps - steps))
        return CollectorBatches(collector, sync_weights, when_done=collector.shutdown)

    def _kept_workers(self, steps: int, env_seed: int) -> tuple[Any, Iterator[Any], Callable[[], None]]:
        if self._kept is None:
            schedule = self.schedule
            saved = random_states()
            collector, send_weights = make_collector(
                self.make, self.policy, self.config, env_seed=env_seed, steps_per_batch=schedule.worker_batch_steps,
                batches=-(-(schedule.total_steps - steps) // schedule.batch_steps),
                random_steps=max(0, schedule.seed_steps - steps))
            set_random_states(saved)
            self._kept = (collector, iter(collector), send_weights)
        return self._kept

    def shutdown(self) -> None:
        """Stop the kept worker processes (``--overlap``); a serial segment's collector stops after its last batch."""
        if self._kept is not None:
            self._kept[0].shutdown()
            self._kept = None


def make_collector(make: Callable[..., Any], policy: nn.Module, config: TrainConfig, *, env_seed: int, steps_per_batch: int,
                   batches: int, random_steps: int) -> tuple[Any, Callable[[], None]]:
    """A TorchRL collector for one segment, its env freshly reset with ``env_seed`` (of several, worker ``w``:
    ``derive_seed(env_seed, w)``), and the call that sends it the policy's current weights.

    One worker of the local collector steps in this process (whose generator the run saves), its env built by
    ``make(seed=...)``; more, ``--overlap``, or Ray step in worker processes or actors, each seeding its torch generator
    and building its env by ``make(seed=..., worker=index)`` (:func:`worker_env`). ``--overlap``: the
    workers act with a copy of the policy, which only the returned call updates, so the weights never change under a
    batch being collected.
    """
    workers = config.workers
    if workers == 1 and config.collector == "local" and not config.overlap:  # in this process, whose generator the run saves
        makers = [partial(make, seed=env_seed)]
    else:
        makers = [partial(worker_env, make, seed=derive_seed(env_seed, w, below=ENV_SEED_LIMIT) if workers > 1 else env_seed,
                          torch_seed=derive_seed(env_seed, w, 1), worker=w) for w in range(workers)]
    options = dict(frames_per_batch=steps_per_batch * workers, total_frames=steps_per_batch * workers * batches,
                   init_random_frames=random_steps)
    if config.collector == "ray":
        from torchrl.collectors.distributed import RayCollector

        # the actors' copy keeps its tensors contiguous (TorchRL's Ray weight transport refuses channels-last
        # conv weights); it receives the trained weights, then sends them on
        acting = contiguous_copy(policy).to("cpu")  # Ray actors act on their CPU
        collector = RayCollector(makers, acting, sync=True, collector_kwargs={"auto_register_policy_transforms": False},
                                 remote_configs={"num_cpus": 1}, **options)

        def sync_weights() -> None:
            TensorDict.from_module(acting).data.update_(TensorDict.from_module(policy).data)
            collector.update_policy_weights_()
        sync_weights()  # the actors start from the weights the segment starts with
        return collector, sync_weights
    options["auto_register_policy_transforms"] = False
    device = next(policy.parameters()).device
    if config.overlap or (workers > 1 and device.type != "cpu"):
        # worker processes act with a CPU copy of the policy, sent between batches: a copy on the GPU would be shared
        # with the workers through CUDA IPC, and TorchRL's weight set-up with 8 such workers timed out on the H200
        # (2026-11-28); on the CPU each worker's exploration noise also comes from its own seeded CPU generator
        acting = copy.deepcopy(policy).to("cpu")
        with worker_timeouts():  # the workers' wait for their first weights (TorchRL reads it as they start)
            collector = MultiSyncCollector(makers, acting, cat_results="stack", **options)

        def send_weights() -> None:
            TensorDict.from_module(acting).data.update_(TensorDict.from_module(policy).data)
            collector.update_policy_weights_()
        return collector, send_weights
    if device.type != "cpu":  # envs step on the CPU; the policy acts on the device; frames are stored on the CPU
        options.update(policy_device=device, env_device="cpu", storing_device="cpu")
    if workers > 1:
        with worker_timeouts():
            collector = MultiSyncCollector(makers, policy, cat_results="stack", **options)
    else:
        collector = Collector(makers[0](), policy, **options)
    return collector, collector.update_policy_weights_


def worker_env(make: Callable[..., Any], *, seed: int, torch_seed: int, worker: int = 0) -> Any:
    """``make(seed=seed, worker=worker)`` in a worker process, after seeding that process's torch generator with ``torch_seed``.

    A worker's exploration noise and seed-phase random actions come from its own torch generator,
    which neither TorchRL's collectors nor Ray seed: unseeded, every worker (and every segment's new
    worker) would draw the same sequence. ``worker`` is the worker's index (``examples/train.py``'s
    env says with it what it renders with, under ``--time-stages``).
    """
    torch.manual_seed(torch_seed)
    return make(seed=seed, worker=worker)


def contiguous_copy(module: nn.Module) -> nn.Module:
    """A deep copy of ``module`` whose parameters and buffers are contiguous (channels-last conv weights become NCHW)."""
    duplicate = copy.deepcopy(module)
    for tensor in [*duplicate.parameters(), *duplicate.buffers()]:
        tensor.data = tensor.data.contiguous()
    return duplicate

"""vigen sets TorchRL's wait for a worker's first weights (WEIGHT_SYNC_TIMEOUT) where it starts worker processes."""

from __future__ import annotations

import contextlib
import multiprocessing
import os
from dataclasses import replace

import pytest
import torch

from vigen.run import PRESETS, worker_timeouts
from vigen.run.collection import WEIGHT_SYNC_SECONDS, WEIGHT_SYNC_VARIABLES



def _read_torchrl_wait(queue) -> None:
    """In a spawned process, as a TorchRL worker starts: the wait TorchRL bound when it was imported."""
    import inspect

    import torchrl._utils
    from torchrl.weight_update._shared import SharedMemTransport

    default = inspect.signature(SharedMemTransport.setup_connection_and_weights_on_receiver).parameters["timeout"].default
    queue.put((torchrl._utils.WEIGHT_SYNC_TIMEOUT, default))


@pytest.fixture
def clean_environment(monkeypatch):
    for name in WEIGHT_SYNC_VARIABLES:
        monkeypatch.delenv(name, raising=False)


@pytest.mark.slow
def test_a_worker_started_inside_waits_vigen_s_time_for_its_weights_not_torchrl_s_60_s(clean_environment):
    """TorchRL reads WEIGHT_SYNC_TIMEOUT when a process imports it and binds it as its shared-memory transport's default wait;
    a worker spawned inside worker_timeouts() gets vigen's value there, one spawned outside TorchRL's 60 s."""
    context = multiprocessing.get_context("spawn")  # TorchRL's collectors spawn their workers
    waits = []
    for inside in (True, False):
        queue = context.Queue()
        with worker_timeouts() if inside else contextlib.nullcontext():
            process = context.Process(target=_read_torchrl_wait, args=(queue,))
            process.start()
        waits.append(queue.get(timeout=120))
        process.join(timeout=30)
    assert waits == [(WEIGHT_SYNC_SECONDS, WEIGHT_SYNC_SECONDS), (60.0, 60.0)]


def test_the_environment_is_set_only_around_the_start_and_a_value_the_user_set_is_kept(clean_environment, monkeypatch):
    with worker_timeouts(90) as seen:
        assert seen == {name: "90" for name in WEIGHT_SYNC_VARIABLES} == {name: os.environ[name] for name in WEIGHT_SYNC_VARIABLES}
    assert not any(name in os.environ for name in WEIGHT_SYNC_VARIABLES), "put back as it was"
    monkeypatch.setenv("WEIGHT_SYNC_TIMEOUT", "1000")
    with worker_timeouts(90) as seen:
        assert seen["WEIGHT_SYNC_TIMEOUT"] == "1000"
    assert os.environ["WEIGHT_SYNC_TIMEOUT"] == "1000"
    with pytest.raises(ValueError, match="seconds must be > 0"):
        with worker_timeouts(0):
            pass


@pytest.mark.parametrize("overlap", [False, True])
def test_train_py_starts_its_worker_processes_inside_it(monkeypatch, clean_environment, overlap):
    """examples/train.py's multi-process collectors (--workers N, --overlap; vigen.run.make_collector) are built with the
    wait set, whoever calls it."""
    from vigen.run import collection

    seen = []

    class Recording:
        def __init__(self, *args, **kwargs):
            seen.append({name: os.environ.get(name) for name in WEIGHT_SYNC_VARIABLES})

        def update_policy_weights_(self) -> None:
            return None

    monkeypatch.setattr(collection, "MultiSyncCollector", Recording)
    policy = torch.nn.Linear(1, 1)
    config = replace(PRESETS["cpu"], workers=2, overlap=overlap)
    collection.make_collector(lambda seed: None, policy, config, env_seed=0, steps_per_batch=10, batches=1, random_steps=0)
    assert seen == [{name: f"{WEIGHT_SYNC_SECONDS:g}" for name in WEIGHT_SYNC_VARIABLES}]
    assert not any(name in os.environ for name in WEIGHT_SYNC_VARIABLES)

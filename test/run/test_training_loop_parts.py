"""The training loop's parts: a collector's batches serial or overlapped (the policy lag, the concurrency, the errors), the
replay buffer's device copy (the same samples, the same slots, reloaded after a resume), and the stage clocks."""

from __future__ import annotations

import threading
import time

import pytest
import torch
from tensordict import TensorDict

from vigen.run.checkpoint import ReplayJournal, replay_state, restore_replay
from vigen.run import CollectorBatches, GpuBusy, RunReplay, StageClock, busy_seconds


class FakeCollector:
    """Batches numbered from 1, each recording the weights' version the collector acted with when it collected it."""

    def __init__(self, batches: int, seconds: float = 0.0) -> None:
        self.batches, self.seconds = batches, seconds
        self.acting, self.seen, self.threads = 0, [], set()
        self.collecting = threading.Event()

    def __iter__(self):
        for index in range(1, self.batches + 1):
            self.collecting.set()
            self.threads.add(threading.get_ident())
            self.seen.append(self.acting)
            time.sleep(self.seconds)
            yield index


def train(batches: int, overlap: bool, updates_per_batch: int = 3) -> tuple[FakeCollector, list[int], list[int]]:
    """A loop that 'updates' (bumps the version) on every batch, as train.py does; (collector, batches, updates after each)."""
    collector, version = FakeCollector(batches), [0]

    def sync() -> None:
        collector.acting = version[0]

    got, updates = [], []
    for batch in CollectorBatches(collector, sync, overlap=overlap):
        got.append(batch)
        version[0] += updates_per_batch
        updates.append(version[0])
    return collector, got, updates


@pytest.mark.parametrize("overlap", [False, True])
def test_the_same_batches_and_updates_and_overlap_acts_exactly_one_batch_of_updates_behind(overlap):
    serial, serial_batches, serial_updates = train(6, overlap=False)
    run, batches, updates = train(6, overlap=overlap)
    assert batches == serial_batches == [1, 2, 3, 4, 5, 6]
    assert updates == serial_updates, "the same updates after each batch: the update ratio is the loop's, unchanged"
    assert serial.seen == [0, 3, 6, 9, 12, 15], "serial: each batch acts with every update so far"
    lag = [0, 0, 3, 6, 9, 12] if overlap else serial.seen
    assert run.seen == lag, "overlapped: the weights of the updates up to the batch before the last"


def test_overlapped_batches_are_collected_while_the_loop_works_and_the_wait_is_what_the_work_did_not_hide():
    collector = FakeCollector(3, seconds=0.2)
    batches = CollectorBatches(collector, lambda: None, overlap=True)
    iterator = iter(batches)
    assert next(iterator) == 1
    collector.collecting.clear()
    assert collector.collecting.wait(timeout=5), "batch 2 started collecting while the loop holds batch 1"
    assert threading.get_ident() not in collector.threads, "collected in a background thread"
    time.sleep(0.4)  # the loop's updates, longer than a batch's collection
    assert next(iterator) == 2
    assert batches.collect_seconds >= 0.2 and batches.wait_seconds < 0.1, "collection hidden behind the loop's work"
    assert list(iterator) == [3]
    serial = CollectorBatches(FakeCollector(2, seconds=0.1), lambda: None)
    for _ in serial:
        assert serial.wait_seconds == serial.collect_seconds >= 0.1


def test_a_collector_error_reaches_the_loop_and_a_loop_error_waits_for_the_batch_in_flight():
    def failing():
        yield 1
        raise RuntimeError("worker died")

    with pytest.raises(RuntimeError, match="worker died"):
        for _ in CollectorBatches(failing(), lambda: None, overlap=True):
            pass
    collector = FakeCollector(5, seconds=0.1)
    before = threading.active_count()
    with pytest.raises(ValueError):
        for _ in CollectorBatches(collector, lambda: None, overlap=True):
            raise ValueError("the loop failed")
    assert threading.active_count() == before, "no collector thread is left running"
    assert collector.seen == [0, 0], "batch 2 was in flight and finished; batch 3 was never asked for"


def transitions(start: int, count: int) -> TensorDict:
    values = torch.arange(start, start + count)
    return TensorDict({"pixels": values.to(torch.uint8)[:, None].expand(count, 4).clone(), ("next", "reward"): values[:, None].float()},
                      batch_size=[count])


def test_the_device_copy_holds_every_slot_of_the_memory_map_and_samples_the_same_batches(tmp_path):
    plain = RunReplay(10, 4, tmp_path / "plain", torch.device("cpu"))
    copied = RunReplay(10, 4, tmp_path / "copied", torch.device("cpu"), on_device=True)
    for start, count in ((0, 6), (6, 7), (13, 5)):  # wraps around the 10 slots twice
        for replay in (plain, copied):
            replay.extend(transitions(start, count))
    assert (copied.memory.storage[:] == copied.disk.storage[:]).all(), "slot for slot"
    assert replay_state(copied.disk) == replay_state(plain.disk) == {"cursor": 8, "write_count": 18, "len": 10}
    for _ in range(3):
        torch.manual_seed(7)
        a = plain.sample()
        torch.manual_seed(7)
        b = copied.sample()
        assert (a == b).all()
    assert copied.memory.storage.device == torch.device("cpu") and a["pixels"].device == torch.device("cpu")


def test_a_resumed_run_refills_the_device_copy_from_the_restored_memory_map_and_samples_as_the_run_never_stopped(tmp_path):
    """What ``--resume --replay-on-device`` does: restore the memory map (journal rolled back), then reload the copy."""
    storage = tmp_path / "storage"
    whole = RunReplay(10, 4, storage, torch.device("cpu"), on_device=True)
    journal = ReplayJournal(tmp_path / "journal", whole.disk)
    whole.extend(transitions(0, 8))
    saved = replay_state(whole.disk)  # a checkpoint
    journal.commit(saved)
    journal.protect(5)
    whole.extend(transitions(100, 5))  # after the checkpoint: overwrites slots 8, 9, 0, 1, 2; then the run is killed

    resumed = RunReplay(10, 4, storage, torch.device("cpu"), on_device=True)
    restore_replay(resumed.disk, saved, storage)
    assert ReplayJournal(tmp_path / "journal", resumed.disk).rollback(saved) == []
    resumed.reload(chunk=3)
    reference = RunReplay(10, 4, tmp_path / "reference", torch.device("cpu"), on_device=True)
    reference.extend(transitions(0, 8))  # the run as it was at the checkpoint
    assert len(resumed.memory.storage) == 8 and (resumed.memory.storage[:8] == reference.memory.storage[:8]).all()
    for replay in (resumed, reference):
        replay.extend(transitions(200, 4))
    assert (resumed.memory.storage[:] == reference.memory.storage[:]).all()
    assert replay_state(resumed.disk) == replay_state(reference.disk)
    torch.manual_seed(3)
    a = resumed.sample()
    torch.manual_seed(3)
    assert (a == reference.sample()).all()
    with pytest.raises(RuntimeError, match="new device copy"):
        resumed.reload()


def test_stage_clock_and_busy_share():
    clock = StageClock()
    with clock("store"):
        time.sleep(0.01)
    clock.add("store", 1.0)
    assert 1.01 <= clock.take()["store"] < 1.5 and clock.take() == {}
    assert busy_seconds([(0, 1), (0.5, 0.7), (2, 3), (2.5, 4)]) == 3
    busy = GpuBusy(torch.device("cpu"))  # on the CPU the profiler's host operators stand in for the GPU's kernels
    busy.start()
    for _ in range(20):
        torch.ones(128, 128) @ torch.ones(128, 128)
    time.sleep(0.2)  # idle: not busy
    share = busy.stop()
    assert share is not None and 0 < share < 0.9

"""Atomic writes, safe loading, the replay undo journal and log rewinding of vigen.run.checkpoint / vigen.io."""

from __future__ import annotations

import os
import pickle

import pytest
import torch
from tensordict import TensorDict
from torchrl.data import LazyMemmapStorage, TensorDictReplayBuffer

from vigen.run.checkpoint import (CheckpointError, ReplayJournal, load_checkpoint, load_optimizer_state, newest_checkpoint,
                              replay_state, restore_replay, save_checkpoint, truncate_csv_logs)
from vigen.io import atomic_write


def test_a_failed_atomic_write_keeps_the_old_file_and_no_temporary(tmp_path):
    path = atomic_write(tmp_path / "state.pt", b"old")

    def explode(file):
        file.write(b"half")
        raise RuntimeError("killed")

    with pytest.raises(RuntimeError):
        atomic_write(path, explode)
    assert path.read_bytes() == b"old" and [p.name for p in tmp_path.iterdir()] == ["state.pt"]


class _Marker:
    def __init__(self, path):
        self.path = path

    def __reduce__(self):
        return (os.system, (f"touch {self.path}",))


def test_a_pickle_that_runs_code_is_refused_and_never_run(tmp_path):
    marker = tmp_path / "marker"
    path = tmp_path / "frames_00000010.pt"
    path.write_bytes(pickle.dumps({"loss": _Marker(marker)}, protocol=2))
    with pytest.raises(CheckpointError, match="refused .*could run code"):
        load_checkpoint(path)
    assert not marker.exists()


def test_save_refuses_objects_that_would_need_code_to_load(tmp_path):
    with pytest.raises(TypeError, match=r"state\['rng'\] is a Generator"):
        save_checkpoint(tmp_path / "frames_00000001.pt", {"rng": torch.Generator()})
    assert not list(tmp_path.iterdir())


def test_newest_checkpoint_falls_back_past_broken_ones(tmp_path):
    save_checkpoint(tmp_path / "frames_00000100.pt", {"frames": 100})
    (tmp_path / "frames_00000200.pt").write_bytes(b"")
    path, state, skipped = newest_checkpoint(tmp_path)
    assert state["frames"] == 100 and [p.name for p, _ in skipped] == ["frames_00000200.pt"]
    (tmp_path / "frames_00000100.pt").write_bytes(b"\x80\x02cos\nsystem\n.")
    with pytest.raises(CheckpointError, match="no checkpoint .* loads"):
        newest_checkpoint(tmp_path)


def _batch(start: int, count: int) -> TensorDict:
    values = torch.arange(start, start + count)
    return TensorDict({"x": values, ("next", "x"): values + 1}, batch_size=[count])


def test_the_journal_restores_a_wrapped_memmap_buffer_to_the_checkpoint(tmp_path):
    """A 6-slot buffer checkpointed at 5 items, then extended by 4 + 4 (wrapping twice over valid slots) and killed."""
    storage_dir = tmp_path / "storage"
    buffer = TensorDictReplayBuffer(storage=LazyMemmapStorage(6, scratch_dir=storage_dir))
    journal = ReplayJournal(tmp_path / "journal", buffer)
    buffer.extend(_batch(0, 5))
    saved = replay_state(buffer)
    journal.commit(saved)
    for start in (100, 200):
        journal.protect(4)
        buffer.extend(_batch(start, 4))
    assert buffer.storage[:]["x"].tolist() != [0, 1, 2, 3, 4, 203]

    resumed = TensorDictReplayBuffer(storage=LazyMemmapStorage(6, scratch_dir=storage_dir))
    restore_replay(resumed, saved, storage_dir)
    assert ReplayJournal(tmp_path / "journal", resumed).rollback(saved) == []
    assert len(resumed) == 5 and replay_state(resumed) == saved
    assert resumed.storage[:5]["x"].tolist() == [0, 1, 2, 3, 4]
    assert resumed.storage[:5]["next", "x"].tolist() == [1, 2, 3, 4, 5]


def test_a_journal_of_an_older_checkpoint_is_not_applied(tmp_path):
    buffer = TensorDictReplayBuffer(storage=LazyMemmapStorage(4, scratch_dir=tmp_path / "storage"))
    journal = ReplayJournal(tmp_path / "journal", buffer)
    buffer.extend(_batch(0, 4))
    journal.commit(replay_state(buffer))
    journal.protect(2)
    buffer.extend(_batch(10, 2))
    newer = replay_state(buffer)  # a checkpoint written, killed before its commit() cleared the journal
    assert journal.rollback(newer) == []
    assert buffer.storage[:]["x"].tolist() == [10, 11, 2, 3]


def test_truncate_csv_logs_keeps_rows_up_to_the_step(tmp_path):
    (tmp_path / "train").mkdir()
    (tmp_path / "train" / "loss.csv").write_text("100,1.0\n200,0.5\n300,0.25\n400,0.1\n")
    (tmp_path / "eval.csv").write_text("200,10\n")
    notes = truncate_csv_logs(tmp_path, 200)
    assert (tmp_path / "train" / "loss.csv").read_text() == "100,1.0\n200,0.5\n"
    assert (tmp_path / "eval.csv").read_text() == "200,10\n"
    assert notes == ["train/loss.csv: dropped 2 rows logged after step 200"]


def test_random_states_carry_every_cuda_generator_once_cuda_is_in_use():
    from vigen.run.checkpoint import random_states, set_random_states

    states = random_states()
    if torch.cuda.is_available() and torch.cuda.is_initialized():
        assert len(states["cuda"]) == torch.cuda.device_count()
        first = torch.rand(3, device="cuda")
        set_random_states(states)
        assert torch.equal(torch.rand(3, device="cuda"), first), "a GPU run resumes its CUDA draws exactly"
    else:
        assert "cuda" not in states
    gpu_made = dict(states, cuda=[torch.zeros(16, dtype=torch.uint8)])  # a checkpoint written on a GPU machine
    if not torch.cuda.is_available():
        set_random_states(gpu_made)  # restores the rest on a CPU-only machine


def test_generator_states_of_a_gpu_run_load_on_a_cpu_only_machine():
    from torch import nn

    from vigen.run.checkpoint import generator_states, set_generator_states
    from vigen.transforms import RandomShift

    model = nn.Sequential(RandomShift(seed=0))
    states = generator_states(model)
    assert set(states) == {"0"}
    states["0@cuda:0"] = torch.zeros(16, dtype=torch.uint8)  # what a GPU run adds beside the CPU state
    if not torch.cuda.is_available():
        set_generator_states(model, states)
        assert model[0].generator_devices() == [torch.device("cpu")]
    with pytest.raises(KeyError, match="not a seeded augmentation"):
        set_generator_states(model, {"1@cuda:0": torch.zeros(16, dtype=torch.uint8)})


@pytest.mark.parametrize("saved_flags, run_flags", [
    ({"fused": False, "capturable": False}, {"fused": False, "capturable": True}),  # compiled on a CPU, resumed on CUDA
    ({"fused": True, "capturable": False}, {"fused": False, "capturable": False}),  # eager (fused Adam), resumed compiled
    ({"fused": False, "capturable": True}, {"fused": True, "capturable": False}),   # a CUDA graph's, resumed eager
])
def test_a_resumed_optimizer_keeps_this_run_s_flags_and_the_file_s_state(tmp_path, saved_flags, run_flags):
    """Optimizer.load_state_dict would bring back the saving run's capturable/fused flags (a non-capturable Adam under
    a CUDA graph); load_optimizer_state keeps the resumed run's and takes the moments and hyper-parameters from the file."""
    weights = [torch.nn.Parameter(torch.randn(3, 2)), torch.nn.Parameter(torch.randn(2))]
    saved = torch.optim.Adam(weights, lr=0.01, betas=(0.8, 0.99), **({"fused": True} if saved_flags["fused"] else {}))
    for _ in range(3):
        for weight in weights:
            weight.grad = torch.randn_like(weight)
        saved.step()
    saved.param_groups[0]["capturable"] = saved_flags["capturable"]  # as a CUDA graph's run records it (no CPU step)
    path = save_checkpoint(tmp_path / "frames_10.pt", {"optimizer": saved.state_dict()})
    resumed = torch.optim.Adam(weights, lr=1.0, **({"fused": True} if run_flags["fused"] else {}),
                               capturable=run_flags["capturable"])
    load_optimizer_state(resumed, load_checkpoint(path)["optimizer"])
    group = resumed.param_groups[0]
    assert {key: bool(group[key]) for key in run_flags} == run_flags, "the flags are this run's"
    assert group["lr"] == 0.01 and group["betas"] == (0.8, 0.99), "the hyper-parameters are the file's"
    for weight in weights:
        state, reference = resumed.state[weight], saved.state[weight]
        assert torch.equal(state["exp_avg"], reference["exp_avg"]) and torch.equal(state["exp_avg_sq"], reference["exp_avg_sq"])
        assert state["step"].dtype == torch.float32 and float(state["step"]) == 3.0
        assert state["step"].device == (weight.device if run_flags["fused"] or run_flags["capturable"] else torch.device("cpu"))

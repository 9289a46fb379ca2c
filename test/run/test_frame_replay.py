"""FrameReplay: one frame per observation on the device, and every transition it gives equal, bit for bit, to the stacked
replay buffer of train.py (TorchRL's MultiStepTransform over the env's CatFrames stacks, in a LazyTensorStorage)."""

from __future__ import annotations

import pytest
import torch
from torchrl.data import LazyTensorStorage, TensorDictReplayBuffer
from torchrl.envs.transforms import MultiStepTransform

from replay_helpers import collector_batches, cut_segment
from vigen.run import FrameReplay, frame_bytes, transition_bytes

N_STEP, GAMMA = 3, 0.99


class Reference:
    """train.py's buffer: MultiStepTransform on the collector's batch, the flat transitions into a ring of stacks."""

    def __init__(self, capacity: int) -> None:
        self.n_step = MultiStepTransform(N_STEP, GAMMA)
        self.buffer = TensorDictReplayBuffer(storage=LazyTensorStorage(capacity), batch_size=4)

    def extend(self, batch) -> None:
        transitions = self.n_step.inv(batch)
        if transitions is not None:
            self.buffer.extend(transitions.reshape(-1))


def assert_same(got, expected, where: str) -> None:
    """Every entry of the stacked buffer's transitions but TorchRL's "index" (the slot, which the buffers write themselves)."""
    keys = sorted((key for key in expected.keys(include_nested=True, leaves_only=True) if key != "index"), key=str)
    assert sorted((key for key in got.keys(include_nested=True, leaves_only=True) if key != "index"), key=str) == keys, where
    for key in keys:
        assert torch.equal(got[key], expected[key]), f"{where}: {key}"


def fill_and_compare(batches, capacity: int, **options) -> FrameReplay:
    reference, replay = Reference(capacity), FrameReplay(capacity, 4, n_step=N_STEP, gamma=GAMMA, device="cpu", **options)
    for number, batch in enumerate(batches):
        reference.extend(batch)
        replay.extend(batch)
        assert len(replay) == len(reference.buffer), f"batch {number}"
        slots = torch.arange(len(replay))
        assert_same(replay.gather(slots), reference.buffer.storage[slots], f"after batch {number}, every slot")
    return replay


@pytest.mark.parametrize("workers", [1, 2])
def test_every_transition_equals_the_stacked_buffer_s_through_episode_ends_segment_cuts_and_wraps(workers):
    """Stacks at resets (CatFrames shows the reset frame k times), terminations and step-limit truncations inside the n-step
    window, train.py's segment cut (the last step marked truncated and done, then a fresh collector), and both rings wrapping:
    the frame-per-observation buffer gives back exactly the stacked buffer's transitions, slot for slot."""
    first = collector_batches(workers, steps=7, batches=3, seed=1)
    first[-1] = cut_segment(first[-1])
    batches = first + collector_batches(workers, steps=7, batches=4, seed=2)
    assert any(bool(batch["next", "terminated"].any()) for batch in batches), "the episodes include terminations"
    assert any(bool((batch["next", "truncated"] & ~batch["next", "terminated"]).any()) for batch in batches), "and truncations"
    capacity = 9 * workers  # a small ring: it wraps several times
    replay = fill_and_compare(batches, capacity, frame_capacity=3 * capacity + 16)
    assert replay.frames_stored < 2 * sum(batch.numel() for batch in batches)


def test_a_sample_is_drawn_on_the_device_from_the_buffer_s_generator_and_equals_the_stacked_buffer_at_its_slots(no_host_sync):
    batches = collector_batches(2, steps=6, batches=3, seed=3)
    reference = Reference(40)
    replay = FrameReplay(40, 64, n_step=N_STEP, gamma=GAMMA, device="cpu", seed=7)
    for batch in batches:
        reference.extend(batch)
        replay.extend(batch)
    with no_host_sync():  # the draw and the gathers read nothing back (what a CUDA graph captures)
        samples = [replay.sample() for _ in range(20)]
    index = torch.cat([sample["index"] for sample in samples])
    assert index.min() >= 0 and index.max() < len(replay) and len(index.unique()) == len(replay), "uniform over every slot"
    assert_same(samples[0], reference.buffer.storage[samples[0]["index"]], "a sample")
    again = FrameReplay(40, 64, n_step=N_STEP, gamma=GAMMA, device="cpu", seed=7)
    for batch in batches:
        again.extend(batch)
    assert torch.equal(again.sample()["index"], samples[0]["index"]), "the same seed draws the same slots"


def test_a_frame_takes_a_sixth_of_a_stacked_transition():
    assert transition_bytes((9, 84, 84)) / frame_bytes((9, 84, 84)) > 5.9  # 127 KB against 21 KB: 1M transitions in ~22 GB
    batches = collector_batches(1, steps=50, batches=2, seed=4)
    replay = FrameReplay(1000, 8, n_step=N_STEP, gamma=GAMMA, device="cpu")
    for batch in batches:
        replay.extend(batch)
    done = torch.cat([batch["next", "done"].flatten() for batch in batches])
    resets = 1 + int(done[:-1].sum())  # the first observation, and each one after an episode's end
    assert replay.frames_stored == len(done) + resets, "one frame per step, plus each episode's reset frame"


def test_stacks_it_cannot_rebuild_are_refused_naming_the_step():
    batches = collector_batches(2, steps=6, batches=2, seed=5)
    replay = FrameReplay(50, 4, n_step=N_STEP, gamma=GAMMA, device="cpu")
    replay.extend(batches[0])
    skipped = collector_batches(2, steps=6, batches=3, seed=5)[2]  # a batch later than the next: the trajectory jumps
    with pytest.raises(ValueError, match="worker 0 at step 0 .* is not the step before's next observation"):
        replay.extend(skipped)
    zero_padded = batches[0].clone()
    zero_padded["pixels"][1, 0, :3] = 0  # a reset stack padded with zeros, not with its frame
    with pytest.raises(ValueError, match="worker 1 at step 0 .* starts an episode but is not its newest frame repeated"):
        FrameReplay(50, 4, n_step=N_STEP, gamma=GAMMA, device="cpu").extend(zero_padded)
    with pytest.raises(ValueError, match="this batch has 1 worker\\(s\\) .* started with 2"):
        replay.extend(batches[1][0])
    replay.extend(batches[1])  # a refused batch changed nothing: the trajectory goes on


def test_a_frame_ring_too_small_for_its_transitions_is_refused_before_a_frame_is_overwritten():
    replay = FrameReplay(30, 4, n_step=N_STEP, gamma=GAMMA, device="cpu", frame_capacity=32)
    with pytest.raises(RuntimeError, match="frame ring of 32 frames is too small .* Pass frame_capacity="):
        for batch in collector_batches(1, steps=10, batches=6, seed=6):
            replay.extend(batch)
    with pytest.raises(RuntimeError, match="an earlier extend failed"):
        replay.sample()


def test_sampling_an_empty_buffer_says_so():
    with pytest.raises(RuntimeError, match="holds no transition yet"):
        FrameReplay(10, 4, n_step=1, gamma=0.9, device="cpu").sample()

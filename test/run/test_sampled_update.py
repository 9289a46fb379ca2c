"""SampledUpdate: sampling on the device and the update as one call, captured as one CUDA graph on CUDA; equal to the
eager loop ``update(replay.sample())`` and free of host synchronizations (on the CPU through the accelerator's path)."""

from __future__ import annotations

import pytest
import torch
from torchrl.objectives import SoftUpdate

from replay_helpers import collector_batches
from vigen.losses import UpdateStep, make_loss
from vigen.run import FrameReplay, SampledUpdate

CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA: a CUDA graph is captured and replayed on a CUDA device")
SIZE, ADAM = 16, dict(lr=1e-3, eps=0.1)  # eps near the gradients' size: Adam's step stays linear in them (see test_update.py)


def filled_replay(device: torch.device, seed: int = 0) -> FrameReplay:
    replay = FrameReplay(200, 8, n_step=3, gamma=0.99, device=device, seed=seed)
    for batch in collector_batches(2, steps=10, batches=3, seed=11, size=SIZE):
        replay.extend(batch)
    return replay


def build(device: torch.device, *, compile: bool = False, capturable: bool = False, fused: bool = False) -> UpdateStep:
    torch.manual_seed(0)
    loss = make_loss("drqv2", (9, SIZE, SIZE), 2, hidden_dim=16, feature_dim=8, device=device).make_value_estimator(gamma=0.99)
    optimizer = torch.optim.Adam(loss.optimizer_groups(ADAM["lr"]), eps=ADAM["eps"], capturable=capturable, fused=fused)
    return UpdateStep(loss, optimizer, SoftUpdate(loss, tau=0.05), compile=compile, cudagraph=False,
                      **({"backend": "aot_eager"} if compile else {}))


def eager_loop(update: UpdateStep, replay: FrameReplay, updates: int) -> list[dict[str, torch.Tensor]]:
    torch.manual_seed(5)
    return [{key: value.clone() for key, value in update(replay.sample()).items()} for _ in range(updates)]


def sampled_loop(sampled: SampledUpdate, updates: int) -> list[dict[str, torch.Tensor]]:
    torch.manual_seed(5)
    return [{key: value.clone() for key, value in sampled().items()} for _ in range(updates)]


def assert_same_state(got: UpdateStep, expected: UpdateStep, **tolerance) -> None:
    """Every parameter and buffer, every gradient and Adam's moments and step counts."""
    for (key, value), (_, reference) in zip(got.loss.state_dict().items(), expected.loss.state_dict().items()):
        torch.testing.assert_close(value, reference, **tolerance, msg=lambda m: f"{key}: {m}")
    parameters = [p for group in got.optimizer.param_groups for p in group["params"]]
    references = [p for group in expected.optimizer.param_groups for p in group["params"]]
    for index, (parameter, reference) in enumerate(zip(parameters, references)):
        torch.testing.assert_close(parameter.grad, reference.grad, **tolerance, msg=lambda m: f"grad {index}: {m}")
        for name in ("exp_avg", "exp_avg_sq", "step"):
            torch.testing.assert_close(got.optimizer.state[parameter][name], expected.optimizer.state[reference][name],
                                       **tolerance, msg=lambda m: f"Adam's {name} of parameter {index}: {m}")


@pytest.mark.parametrize("compile", [False, pytest.param(True, marks=pytest.mark.slow)], ids=["eager", "compiled"])
def test_sampled_updates_equal_the_eager_loop_on_the_replay_s_samples(compile):
    """The static-buffer path on the CPU: eager, bit for bit; compiled (aot_eager, static gradients), within float rounding."""
    cpu = torch.device("cpu")
    eager = build(cpu)
    expected = eager_loop(eager, filled_replay(cpu), 6)
    update = build(cpu, compile=compile)
    sampled = SampledUpdate(update, filled_replay(cpu))
    got = sampled_loop(sampled, 6)
    tolerance = dict(rtol=1e-4, atol=1e-5) if compile else dict(rtol=0, atol=0)
    for step, (out, reference) in enumerate(zip(got, expected)):
        assert out.keys() == reference.keys()
        for key in reference:
            torch.testing.assert_close(out[key], reference[key], **tolerance, msg=lambda m: f"update {step}, {key}: {m}")
    assert_same_state(update, eager, **tolerance)


def test_fifty_sampled_updates_read_nothing_back_on_the_accelerator_s_path(no_host_sync):
    """The whole captured call as a GPU runs it (sampling, loss with its tensor guard, backward, Adam, target update), on the
    CPU through vigen.devices.accelerator_paths: no torch call reads a value back; the outputs are the same tensors every call
    after the warm-up, as a replay's are."""
    cpu = torch.device("cpu")
    replay = filled_replay(cpu)
    with no_host_sync():  # train.py's fused Adam on the CPU (the for-loop Adam reads its step count; a capturable one does not)
        sampled = SampledUpdate(build(cpu, fused=True), replay)
        outs = [sampled() for _ in range(50)]
    assert not sampled.update.guard_in_loss, "built on the accelerator's path: the tensor guard, not the loss's raising check"
    assert outs[2]["loss_critic"] is outs[49]["loss_critic"] and outs[0]["loss_critic"] is not outs[1]["loss_critic"]
    sampled.update.raise_if_diverged()


def test_a_sampled_update_refuses_what_it_cannot_capture():
    cpu = torch.device("cpu")
    with pytest.raises(ValueError, match="cudagraph=True needs the update on CUDA"):
        SampledUpdate(build(cpu), filled_replay(cpu), cudagraph=True)


@CUDA
@pytest.mark.slow
@pytest.mark.parametrize("compile", [False, True], ids=["eager", "compiled"])
def test_a_captured_sampled_update_equals_the_eager_one_over_six_updates_on_cuda(compile):
    """On CUDA, the sampling (slots drawn from the replay's seeded generator) and the update (eager, or aot_eager-compiled)
    captured as one CUDA graph: the first calls warm up, the third captures, the rest replay. Losses, parameters,
    gradients and Adam's state equal the eager loop's over six updates."""
    cuda = torch.device("cuda")
    with torch.backends.cudnn.flags(enabled=True, benchmark=False, deterministic=True, allow_tf32=False):
        eager = build(cuda, capturable=True)
        expected = eager_loop(eager, filled_replay(cuda), 6)
        update = build(cuda, compile=compile, capturable=True)
        sampled = SampledUpdate(update, filled_replay(cuda))
        got = sampled_loop(sampled, 6)
    assert sampled.captured
    for step, (out, reference) in enumerate(zip(got, expected)):
        for key in reference:
            torch.testing.assert_close(out[key], reference[key], rtol=1e-4, atol=1e-5, msg=lambda m: f"update {step}, {key}: {m}")
    assert_same_state(update, eager, rtol=1e-4, atol=1e-5)


@CUDA
@pytest.mark.parametrize("compile", [False, True], ids=["eager", "compiled"])
def test_fifty_captured_sampled_updates_never_synchronize_on_cuda(compile, no_host_sync, monkeypatch):
    """After the warm-up and the capture, fifty updates (sampling included) launch one graph each: torch's sync debug mode
    raises at any implicit synchronization, a replaced torch.cuda.synchronize at an explicit one, and the host-read
    detector at any value read back."""
    cuda = torch.device("cuda")
    replay = filled_replay(cuda)
    sampled = SampledUpdate(build(cuda, compile=compile, capturable=True), replay)
    for _ in range(3):
        sampled()
    torch.cuda.synchronize()

    def forbidden(*args, **kwargs):
        raise AssertionError("torch.cuda.synchronize() called during an update")

    monkeypatch.setattr(torch.cuda, "synchronize", forbidden)
    torch.cuda.set_sync_debug_mode("error")
    try:
        with no_host_sync():
            for _ in range(50):
                out = sampled()
    finally:
        torch.cuda.set_sync_debug_mode("default")
        monkeypatch.undo()
    assert sampled.captured and torch.isfinite(out["loss_critic"])
    sampled.update.raise_if_diverged()

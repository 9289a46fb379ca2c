"""CudaGraphCall: the static-buffer path on any device (each call runs once, inputs copied in, outputs the same tensors
after the capture call, nothing read back), and on CUDA the captured replays equal the eager calls without a host wait."""

from __future__ import annotations

import pytest
import torch
from tensordict import TensorDict

from vigen.cuda_graph import CudaGraphCall

CUDA = pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA: a CUDA graph is captured and replayed on a CUDA device")


def forbid_synchronize(*args, **kwargs):
    raise AssertionError("torch.cuda.synchronize() called during a replay")


class Recorder:
    """``fn``: counts its runs, keeps the input objects it was given, adds the input into a running total."""

    def __init__(self, device: torch.device = torch.device("cpu")) -> None:
        self.runs, self.seen = 0, []
        self.total = torch.zeros((), device=device)

    def __call__(self, x: torch.Tensor, batch: TensorDict) -> dict[str, torch.Tensor]:
        self.runs += 1
        self.seen.append((x, batch["a"]))
        self.total.add_(x.sum() + batch["a"].sum())
        batch.set("written", x * 2)  # an entry fn sets: it must not leak into the graph's buffers
        return {"total": self.total * 1, "y": x + batch["next", "b"]}


def inputs(k: float) -> tuple[torch.Tensor, TensorDict]:
    return torch.full((3,), k), TensorDict({"a": torch.full((2,), k), "next": {"b": torch.full((3,), 10 * k)}}, [])


def test_off_cuda_each_call_runs_once_on_the_static_buffers_and_returns_what_a_replay_would():
    fn = Recorder()
    call = CudaGraphCall(fn, warmup=2, device="cpu")
    given = [inputs(k) for k in (1.0, 2.0, 3.0, 4.0)]
    outs = [call(*args) for args in given]
    assert fn.runs == 4 and call.calls == 4 and not call.captured, "each call runs fn exactly once"
    assert [out["total"].item() for out in outs[:2]] == [5.0, 15.0], "the warm-up calls return fn's own outputs"
    assert outs[2]["total"] is outs[3]["total"] and outs[3]["total"].item() == 50.0, \
        "from the capture call on: the same output tensors, overwritten by each call (no clone)"
    assert torch.equal(outs[3]["y"], torch.full((3,), 44.0))
    assert all(x is fn.seen[0][0] and a is fn.seen[0][1] for x, a in fn.seen), "fn always reads the same input buffers"
    assert all(x is not fn.seen[0][0] for x, _ in given), "the buffers are the wrapper's: the caller's tensors are copied in"
    assert all("written" not in batch.keys() for _, batch in given), "and what fn writes stays out of the caller's batch"


def test_inputs_keep_their_structure_shapes_and_entries_and_extra_entries_are_ignored():
    call = CudaGraphCall(Recorder(), warmup=1, device="cpu")
    call(*inputs(1.0))
    x, batch = inputs(2.0)
    call(x, batch.set("extra", torch.zeros(5)))  # an entry the first call did not have (e.g. a priority written back)
    with pytest.raises(ValueError, match="input tensor 0 is torch.float32\\[4\\], the graph's buffer torch.float32\\[3\\]"):
        call(torch.zeros(4), batch)
    with pytest.raises(KeyError, match="lacks \\[\\('next', 'b'\\)\\]"):
        call(x, batch.exclude(("next", "b")))
    with pytest.raises(ValueError, match="structured as"):
        call(x)
    with pytest.raises(ValueError, match="warmup must be an integer >= 1"):
        CudaGraphCall(Recorder(), warmup=0)


def test_the_static_path_reads_nothing_back_to_the_host_over_fifty_calls(no_host_sync):
    fn = Recorder()
    call = CudaGraphCall(fn, device="cpu")
    with no_host_sync():
        for k in range(50):
            out = call(*inputs(float(k)))
    assert fn.runs == 50 and out["total"].item() == sum(3 * k + 2 * k for k in range(50))


@CUDA
def test_a_cuda_graph_call_equals_the_eager_calls_draws_included_and_never_waits_for_the_gpu(no_host_sync, monkeypatch):
    """Random draws from torch's default CUDA generator and from a registered one follow the eager sequence; after the
    capture, fifty replays neither synchronize (torch.cuda.set_sync_debug_mode('error'), and no torch.cuda.synchronize(),
    which tensordict 0.14.3's CudaGraphModule called before every replay) nor read a value back."""
    device = torch.device("cuda")

    def make():
        generator = torch.Generator(device=device).manual_seed(3)
        state = torch.zeros(4, device=device)

        def fn(x):
            state.add_(torch.rand(4, device=device, generator=generator) + torch.randn(4, device=device) * x)
            return state * 1
        return fn, generator

    torch.manual_seed(0)
    eager_fn, _ = make()
    expected = [eager_fn(torch.full((4,), float(k), device=device)).clone() for k in range(8)]
    torch.manual_seed(0)
    fn, generator = make()
    call = CudaGraphCall(fn, warmup=2, device=device, generators=[generator])
    got = [call(torch.full((4,), float(k), device=device)).clone() for k in range(8)]
    assert call.captured
    for step, (out, reference) in enumerate(zip(got, expected)):
        torch.testing.assert_close(out, reference, msg=lambda m: f"call {step}: {m}")
    x = torch.ones(4, device=device)
    torch.cuda.synchronize()
    monkeypatch.setattr(torch.cuda, "synchronize", forbid_synchronize)  # sync debug mode does not flag the explicit one
    torch.cuda.set_sync_debug_mode("error")
    try:
        with no_host_sync():
            for _ in range(50):
                out = call(x)
    finally:
        torch.cuda.set_sync_debug_mode("default")
        monkeypatch.undo()
    assert torch.isfinite(out).all()

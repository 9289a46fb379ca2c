"""UpdateStep: one update (loss, backward, Adam, target update) eager or compiled whole, with no host synchronization."""

from __future__ import annotations

import math

import pytest
import torch
from torchrl.objectives import SoftUpdate

from loss_helpers import LOSSES, make_batch, make_loss
from vigen.losses import LinearSchedule, UpdateStep, update_metrics

# Adam's step m/(√v + ε) turns a float-rounding difference in a near-zero gradient into a step of up to ±lr; an ε
# near the gradients' size keeps the step linear in them, so the comparison sees the update's math, not that amplification.
ADAM = dict(lr=1e-3, eps=0.1)
COMPILE_SAMPLE = ["drqv2"]  # DrQ-v2 in the default run (CI time); all twelve with -m matrix


def build(name: str, seed: int = 0):
    torch.manual_seed(seed)
    loss = make_loss(name)
    optimizer = torch.optim.Adam(loss.optimizer_groups(ADAM["lr"]), eps=ADAM["eps"])
    return loss, optimizer, SoftUpdate(loss, tau=0.05)


def run_updates(update: UpdateStep, batches) -> list[dict[str, torch.Tensor]]:
    torch.manual_seed(5)  # the augmentations and the policy's noise draw from torch's RNG, the same in both runs
    outs = []
    for step, batch in enumerate(batches):
        update.loss.set_step(1000 * step)
        outs.append({key: value.clone() for key, value in update(batch.clone()).items()})
    return outs


def test_the_eager_update_is_the_written_out_loop():
    """UpdateStep on the CPU = loss, backward of the summed loss_* entries, optimizer step, SoftUpdate: bit for bit."""
    batches = [make_batch(seed=seed) for seed in range(3)]
    loss, optimizer, target = build("svea")
    outs = run_updates(UpdateStep(loss, optimizer, target), batches)
    reference, reference_optimizer, reference_target = build("svea")
    torch.manual_seed(5)
    for step, batch in enumerate(batches):
        reference.set_step(1000 * step)
        out = reference(batch.clone())
        reference_optimizer.zero_grad()
        sum(value for key, value in out.items() if key.startswith("loss_")).backward()
        reference_optimizer.step()
        reference_target.step()
        assert all(torch.equal(out[key].detach(), outs[step][key]) for key in out.keys())
    for (name, value), (_, expected) in zip(loss.state_dict().items(), reference.state_dict().items()):
        assert torch.equal(value, expected), name


@pytest.mark.slow
@pytest.mark.parametrize("name", [*COMPILE_SAMPLE, *(pytest.param(name, marks=pytest.mark.matrix)
                                                     for name in LOSSES if name not in COMPILE_SAMPLE)])
def test_the_compiled_update_equals_the_eager_one(name):
    """torch.compile of the whole update (fullgraph where the loss says so) gives the eager update's losses and parameters.

    ``aot_eager`` traces forward, backward, Adam and the target update as inductor would (dynamo and AOT autograd),
    without generating code: the graph is the same, the check takes seconds.
    """
    batches = [make_batch(seed=seed) for seed in range(3)]
    eager_loss, *rest = build(name)
    eager = run_updates(UpdateStep(eager_loss, *rest), batches)
    compiled_loss, *rest = build(name)
    update = UpdateStep(compiled_loss, *rest, compile=True, backend="aot_eager")
    compiled = run_updates(update, batches)
    for step, (expected, got) in enumerate(zip(eager, compiled)):
        for key in expected:
            torch.testing.assert_close(got[key], expected[key], rtol=1e-4, atol=1e-5, msg=lambda m: f"update {step}, {key}: {m}")
    for (key, value), (_, expected) in zip(compiled_loss.state_dict().items(), eager_loss.state_dict().items()):
        torch.testing.assert_close(value, expected, rtol=1e-4, atol=1e-6, msg=lambda m: f"{key}: {m}")
    assert update.compile_seconds is not None and update.compile_seconds > 0


@pytest.mark.slow
def test_each_update_step_compiles_on_its_own_cache():
    """Two UpdateSteps in one process do not share dynamo's per-code-object cache and recompile limit."""
    with torch._dynamo.config.patch(recompile_limit=1):
        for _ in range(2):
            loss, optimizer, target = build("drqv2")
            UpdateStep(loss, optimizer, target, compile=True, backend="aot_eager")(make_batch())


@pytest.mark.slow
def test_a_nan_loss_in_a_compiled_update_leaves_the_parameters_finite_and_is_reported():
    loss, optimizer, target = build("drqv2")
    update = UpdateStep(loss, optimizer, target, compile=True, backend="aot_eager")
    update(make_batch())
    update(make_batch(reward=torch.full((6, 1), math.nan)))
    assert int(update.diverged_updates) == 1
    assert all(torch.isfinite(parameter).all() for parameter in loss.parameters())
    with pytest.raises(FloatingPointError, match="1 update\\(s\\) had a NaN or inf loss"):
        update.raise_if_diverged()


def test_an_eager_cpu_update_keeps_the_loss_s_own_check_which_names_the_batch_entry():
    loss, optimizer, target = build("drqv2")
    with pytest.raises(ValueError, match="\\('next', 'reward'\\)"):
        UpdateStep(loss, optimizer, target)(make_batch(reward=torch.full((6, 1), math.nan)))


def test_compiling_refuses_what_it_cannot_trace():
    loss, optimizer, target = build("drqv2")
    loss.seed_augmentations(0)
    with pytest.raises(ValueError, match="torch.Generator, which torch.compile cannot trace"):
        UpdateStep(loss, optimizer, target, compile=True)
    loss.seed_augmentations(None)
    with pytest.raises(TypeError, match="steps torch.optim.Adam or AdamW"):
        UpdateStep(loss, torch.optim.SGD(loss.parameters(), lr=0.1), target, compile=True)
    with pytest.raises(ValueError, match="does not trace a fused Adam"):
        UpdateStep(loss, torch.optim.Adam(loss.parameters(), fused=True), target, compile=True)
    with pytest.raises(ValueError, match="cudagraph=True needs a loss on CUDA"):
        UpdateStep(loss, optimizer, target, cudagraph=True)
    unready = make_loss("drqv2")
    unready._value_estimator = None
    with pytest.raises(ValueError, match="make_value_estimator"):
        UpdateStep(unready, optimizer)


def test_the_scheduled_std_is_a_tensor_equal_to_the_schedule():
    """The update reads the noise std as a tensor op on the step buffer (no int(step)), the same value as DrQ-v2's linear()."""
    loss = make_loss("drqv2", std=LinearSchedule(1.0, 0.1, 100_000))
    for step in (0, 1, 12_345, 50_000, 10**6):
        loss.set_step(step)
        std = loss.sampler.std(loss.schedule_step)
        assert std.dtype == torch.float32 and std.ndim == 0
        assert std.item() == torch.tensor(LinearSchedule(1.0, 0.1, 100_000)(step), dtype=torch.float32).item()


def test_update_metrics_reads_every_scalar_at_once():
    loss, optimizer, target = build("drqv2")
    out = UpdateStep(loss, optimizer, target)(make_batch())
    metrics = update_metrics(out)
    assert set(metrics) == set(out.keys()) and all(isinstance(value, float) for value in metrics.values())
    assert metrics["loss_critic"] == pytest.approx(out["loss_critic"].item())


@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA: host synchronizations only exist on an accelerator")
@pytest.mark.parametrize("compile", [False, True])
def test_a_cuda_update_never_synchronizes_with_the_host(compile):
    loss, optimizer, target = build("svea")
    loss.to("cuda")
    optimizer = torch.optim.Adam(loss.optimizer_groups(1e-3), capturable=True)
    update = UpdateStep(loss, optimizer, SoftUpdate(loss, tau=0.05), compile=compile)
    batches = [make_batch(seed=seed).to("cuda") for seed in range(4)]
    update(batches[0])  # the first calls compile, warm up and capture
    update(batches[1])
    torch.cuda.synchronize()
    torch.cuda.set_sync_debug_mode("error")
    try:
        for batch in batches[2:]:
            loss.set_step(100)
            update(batch)
    finally:
        torch.cuda.set_sync_debug_mode("default")
    update.raise_if_diverged()


def test_a_loss_without_its_own_check_gets_the_tensor_guard_and_the_update_never_changes_the_loss():
    """check_finite=False (build_agent's choice off the CPU): a NaN update is zeroed and counted, not raised inside the call."""
    loss, optimizer, target = build("drqv2")
    loss.check_finite = False
    update = UpdateStep(loss, optimizer, target)
    update(make_batch(reward=torch.full((6, 1), math.nan)))
    assert loss.check_finite is False and int(update.diverged_updates) == 1
    assert all(torch.isfinite(parameter).all() for parameter in loss.parameters())
    with pytest.raises(FloatingPointError, match="1 update\\(s\\) had a NaN or inf loss"):
        update.raise_if_diverged()
    checked, optimizer, target = build("drqv2")
    UpdateStep(checked, optimizer, target)(make_batch())
    assert checked.check_finite is True, "UpdateStep leaves the caller's loss as it was"

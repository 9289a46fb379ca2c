"""UpdateStep: one update (loss, backward, Adam, target update) eager or compiled whole, with no host synchronization."""

from __future__ import annotations

import math

import pytest
import torch
from torchrl.objectives import SoftUpdate

from loss_helpers import LOSSES, make_batch, make_loss
from vigen.devices import accelerator_paths
from vigen.losses import LinearSchedule, UpdateStep, update_metrics
from vigen.losses.update import _compile_options

# Adam's step m/(√v + ε) turns a float-rounding difference in a near-zero gradient into a step of up to ±lr; an ε
# near the gradients' size keeps the step linear in them, so the comparison sees the update's math, not that amplification.
ADAM = dict(lr=1e-3, eps=0.1)
COMPILE_SAMPLE = ["drq"]  # one SAC loss in the default run (CI time; DrQ-v2 compiles in the one-graph test below); all twelve with -m matrix


def build(name: str, seed: int = 0):
    torch.manual_seed(seed)
    loss = make_loss(name)
    optimizer = torch.optim.Adam(loss.optimizer_groups(ADAM["lr"]), eps=ADAM["eps"])
    return loss, optimizer, SoftUpdate(loss, tau=0.05)


def run_updates(update: UpdateStep, batches) -> list[dict[str, torch.Tensor]]:
    """Each update's losses and metrics, and the ``td_error`` it wrote into the batch it was given."""
    torch.manual_seed(5)  # the augmentations and the policy's noise draw from torch's RNG, the same in both runs
    outs = []
    for step, batch in enumerate(batches):
        update.loss.set_step(1000 * step)
        given = batch.clone()
        out = {key: value.clone() for key, value in update(given).items()}
        outs.append({**out, "td_error": given["td_error"].clone()})
    return outs


def assert_same_training_state(got: UpdateStep, expected: UpdateStep, rtol: float = 1e-4, atol: float = 1e-6) -> None:
    """Every parameter and buffer of the loss, every gradient and Adam's moments and step counts."""
    for (key, value), (_, reference) in zip(got.loss.state_dict().items(), expected.loss.state_dict().items()):
        torch.testing.assert_close(value, reference, rtol=rtol, atol=atol, msg=lambda m: f"{key}: {m}")
    for index, (parameter, reference) in enumerate(zip(got._parameters, expected._parameters)):
        torch.testing.assert_close(parameter.grad, reference.grad, rtol=rtol, atol=atol, msg=lambda m: f"grad {index}: {m}")
        state, reference_state = got.optimizer.state[parameter], expected.optimizer.state[reference]
        for name in ("exp_avg", "exp_avg_sq", "step"):
            torch.testing.assert_close(state[name].to(reference_state[name].device), reference_state[name], rtol=rtol,
                                       atol=atol, msg=lambda m: f"Adam's {name} of parameter {index}: {m}")


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
def test_the_compiled_update_traces_one_graph_with_gradients_present_and_equals_the_eager_one():
    """The graph a CUDA graph captures is the one with gradients present (accumulated in place); on the CPU too.

    Every ``.grad`` exists before the first trace (zeros), nothing recompiles over five updates, and the losses,
    priorities, parameters, gradients and Adam's state after them equal the eager update's.
    """
    batches = [make_batch(seed=seed) for seed in range(5)]
    eager = UpdateStep(*build("drqv2"))
    expected = run_updates(eager, batches)
    update = UpdateStep(*build("drqv2"), compile=True, backend="aot_eager")
    step, traced_with_gradients = update._step, []

    def spy(batch):
        traced_with_gradients.append(all(parameter.grad is not None for parameter in update._parameters))
        return step(batch)

    update._step = spy
    with torch._dynamo.config.patch(error_on_recompile=True):
        got = run_updates(update, batches)
    assert traced_with_gradients == [True] * 5
    for index, (reference, out) in enumerate(zip(expected, got)):
        for key in reference:
            torch.testing.assert_close(out[key], reference[key], rtol=1e-4, atol=1e-5, msg=lambda m: f"update {index}, {key}: {m}")
    assert_same_training_state(update, eager)


@pytest.mark.slow
@pytest.mark.skipif(not torch.cuda.is_available(), reason="needs CUDA: a CUDA graph is captured and replayed on a CUDA device")
def test_a_cuda_graph_update_equals_the_eager_one_over_six_updates():
    """UpdateStep(compile=True) on CUDA (aot_eager, captured by CudaGraphModule) against the eager CUDA update.

    The first call traces, the second warms up and captures, the others replay: losses, the priorities written back
    into each batch, parameters, gradients and Adam's state equal the eager update's (deterministic cuDNN, no TF32).
    """
    batches = [make_batch(seed=seed).to("cuda") for seed in range(6)]

    def build_cuda() -> tuple:
        loss, _, _ = build("drqv2")
        loss.to("cuda")
        optimizer = torch.optim.Adam(loss.optimizer_groups(ADAM["lr"]), eps=ADAM["eps"], capturable=True)
        return loss, optimizer, SoftUpdate(loss, tau=0.05)

    with torch.backends.cudnn.flags(enabled=True, benchmark=False, deterministic=True, allow_tf32=False):
        eager = UpdateStep(*build_cuda())
        expected = run_updates(eager, batches)
        update = UpdateStep(*build_cuda(), compile=True, backend="aot_eager")
        assert update.cudagraph
        got = run_updates(update, batches)
    for index, (reference, out) in enumerate(zip(expected, got)):
        for key in reference:
            torch.testing.assert_close(out[key], reference[key], rtol=1e-4, atol=1e-5, msg=lambda m: f"update {index}, {key}: {m}")
    assert_same_training_state(update, eager, rtol=1e-4, atol=1e-5)
    update.raise_if_diverged()


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
    loss = make_loss("drqv2", std_schedule=LinearSchedule(1.0, 0.1, 100_000))
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
def test_a_cuda_update_never_synchronizes_with_the_host(compile, monkeypatch):
    """The loss as built by default (check_finite=True): no synchronization, and a NaN update is still caught.

    torch's sync debug mode flags the implicit synchronizations (a value read back); an explicit
    ``torch.cuda.synchronize()``, which tensordict 0.14.3's CudaGraphModule made before every replay, it does not: that
    one is refused here by replacing it."""
    loss, optimizer, target = build("svea")
    assert loss.check_finite
    loss.to("cuda")
    optimizer = torch.optim.Adam(loss.optimizer_groups(1e-3), capturable=True)
    update = UpdateStep(loss, optimizer, SoftUpdate(loss, tau=0.05), compile=compile)
    batches = [make_batch(seed=seed).to("cuda") for seed in range(4)]
    batches.insert(3, make_batch(seed=9, reward=torch.full((6, 1), math.nan)).to("cuda"))
    for batch in batches[:3]:  # the first calls compile, warm up and capture (the capture synchronizes once)
        update(batch)
    torch.cuda.synchronize()

    def forbidden(*args, **kwargs):
        raise AssertionError("torch.cuda.synchronize() called during an update")

    monkeypatch.setattr(torch.cuda, "synchronize", forbidden)
    torch.cuda.set_sync_debug_mode("error")
    try:
        for batch in batches[3:]:
            loss.set_step(100)
            update(batch)
    finally:
        torch.cuda.set_sync_debug_mode("default")
        monkeypatch.undo()
    assert int(update.diverged_updates) == 1 and int(loss.nonfinite_calls) == 1
    assert all(torch.isfinite(parameter).all() for parameter in loss.parameters())
    with pytest.raises(FloatingPointError, match="1 update\\(s\\) had a NaN or inf loss"):
        update.raise_if_diverged()


@pytest.mark.parametrize("name", LOSSES)
def test_an_eager_update_on_an_accelerator_s_path_reads_no_value_back_and_still_catches_a_nan(name, no_host_sync):
    """The eager update as a GPU runs it (vigen.devices.accelerator_paths), from a loss built by default
    (check_finite=True) and train.py's fused Adam, on the CPU: no torch call reads a value back to the host (the
    loss's finite check did, the synchronization the first GPU run found). A NaN update is still caught: its
    gradients are zeroed, the update and the loss count it on the device, and both raise when asked."""
    torch.manual_seed(0)
    loss = make_loss(name)
    optimizer = torch.optim.Adam(loss.optimizer_groups(1e-3), fused=True)
    batches = [make_batch(seed=0), make_batch(seed=1, reward=torch.full((6, 1), math.nan)), make_batch(seed=2)]
    with no_host_sync():
        update = UpdateStep(loss, optimizer, SoftUpdate(loss, tau=0.05))
        for step, batch in enumerate(batches):
            loss.set_step(100 * step)
            update(batch)
    assert loss.check_finite and not update.guard_in_loss
    assert int(update.diverged_updates) == 1 and int(loss.nonfinite_calls) == 1
    # every parameter got a gradient, so a compiled update (which steps every parameter, its gradient zeroed and then
    # accumulated) steps the same ones as the eager update (which skips a parameter whose gradient is None)
    assert not [key for key, parameter in loss.named_parameters() if parameter.requires_grad and parameter.grad is None]
    assert all(torch.isfinite(parameter).all() for parameter in loss.parameters())
    with pytest.raises(FloatingPointError, match="1 update\\(s\\) had a NaN or inf loss"):
        update.raise_if_diverged()
    with pytest.raises(FloatingPointError, match="1 call\\(s\\) on cpu gave a NaN or inf loss_"):
        loss.raise_if_nonfinite()
    with no_host_sync(accelerator=False), pytest.raises(AssertionError, match="host synchronization"):
        UpdateStep(loss, optimizer)(make_batch())  # the CPU's path reads values (free there): the detector sees it


def test_a_float_pixel_batch_is_scanned_once_off_the_cpu_and_every_time_on_it(no_host_sync):
    """The range scan of float pixels (one amax, read back) runs on the first batch only on an accelerator's path."""
    loss = make_loss("drqv2", max_value=1.0)
    batch = make_batch()
    floats = batch.clone().set("pixels", batch["pixels"].float() / 255).set(("next", "pixels"), batch["next", "pixels"].float() / 255)
    too_bright = floats.clone().set("pixels", floats["pixels"] * 255)
    with accelerator_paths():
        with pytest.raises(ValueError, match="float pixels reach .* above max_value 1.0"):
            loss(too_bright)  # the first batch is scanned on any device
        loss(floats)
    with no_host_sync():
        loss(floats)
        loss(too_bright)  # not scanned again: a wrong scale is the data pipeline's, caught on its first batch
    with pytest.raises(ValueError, match="float pixels reach .* above max_value 1.0"):
        loss(too_bright)  # on the CPU every batch is scanned


def test_a_compiled_update_checks_its_first_batch_before_it_traces():
    """A wrong batch is refused with the loss's own message, before dynamo would trace it (and wrap the error)."""
    update = UpdateStep(*build("drqv2"), compile=True, backend="aot_eager")
    batch = make_batch()
    with pytest.raises(ValueError, match="float pixels reach .* above max_value 1.0"):
        update(batch.set("pixels", batch["pixels"].float()))
    with pytest.raises(KeyError, match="the batch has no \\('next', 'terminated'\\)"):
        update(make_batch().exclude(("next", "terminated")))


def test_the_caller_s_batch_gets_the_priority_when_the_update_runs_on_a_copy():
    """TorchRL's convention (the loss writes ``td_error`` into the batch it reads, for
    ``rb.update_tensordict_priority(batch)``) holds when the update's step runs on a copy of the batch, as a CUDA
    graph's replay does (CudaGraphModule copies the batch into the graph's static inputs)."""
    reference, *_ = build("drqv2")
    batch, given = make_batch(), make_batch()
    torch.manual_seed(5)
    reference(given)
    expected = given["td_error"]
    update = UpdateStep(*build("drqv2"))
    step = update._step
    update._step = lambda batch: step(batch.clone())  # the replay's own copies
    torch.manual_seed(5)
    update(batch)
    assert torch.equal(batch["td_error"], expected)
    assert batch["td_error"].shape == (6,) and (batch["td_error"] >= 0).all()


def test_a_compile_mode_is_passed_as_its_options_beside_the_update_s_own(monkeypatch):
    """torch.compile takes mode= or options=, not both: a mode is passed as the options it stands for."""
    seen = {}
    compile_ = torch.compile

    def spy(function, **kwargs):
        seen.update(kwargs)
        return compile_(function, **kwargs)  # the real one: it refused mode= with options= when called

    monkeypatch.setattr(torch, "compile", spy)
    loss, optimizer, target = build("drqv2")
    UpdateStep(loss, optimizer, target, compile=True, mode="max-autotune-no-cudagraphs")
    assert "mode" not in seen
    assert seen["options"] == {"max_autotune": True, "coordinate_descent_tuning": True, "fallback_random": True}
    with pytest.raises(ValueError, match="unknown torch.compile mode 'fastest'; the modes are 'default'"):
        UpdateStep(loss, optimizer, target, compile=True, mode="fastest")
    with pytest.raises(ValueError, match="captures CUDA graphs itself"):
        _compile_options("inductor", "reduce-overhead", cudagraph=True)
    assert _compile_options("aot_eager", None, cudagraph=False) == {}


def test_a_loss_without_its_own_check_gets_the_tensor_guard_and_the_update_never_changes_the_loss():
    """check_finite=False on the CPU: a NaN update is zeroed and counted by the update's guard, not raised inside the call."""
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


def build_scheduled(seed: int = 0, **options):
    """MaDi's loss (DMC-GB's SAC) with DMC-GB's optimizer groups and schedule: actor and temperature every second update."""
    from vigen.losses import SplitSoftUpdate

    loss = build("madi", seed)[0]
    loss.param_groups.update({"actor": {"lr": 1e-3, "every": 2}, "sampler": {"lr": 1e-3, "betas": (0.5, 0.999), "every": 2}})
    optimizer = torch.optim.Adam(loss.optimizer_groups(ADAM["lr"]), eps=ADAM["eps"], **options)
    return loss, optimizer, SplitSoftUpdate(loss, tau=0.01, taus={"encoder": 0.05, "critic.trunk": 0.05})


def test_a_group_of_every_n_updates_is_a_separate_optimizer_called_every_n_updates():
    """DMC-GB's SAC (src/algorithms/sac.py): the critic's Adam every update, the actor's and the temperature's every second
    (their own Adams, betas (0.9, 0.999) and (0.5, 0.999)), the target every second with τ 0.01 (Q heads) and 0.05
    (encoder and critic trunk). Written out with four optimizers; UpdateStep with one Adam of groups: bit for bit."""
    batches = [make_batch(seed=seed) for seed in range(4)]
    loss, optimizer, target = build_scheduled()
    update = UpdateStep(loss, optimizer, target, target_every=2)
    outs = run_updates(update, batches)
    reference = build("madi")[0]
    actor, alpha = list(reference.actor.parameters()), list(reference.sampler.parameters())
    rest = [p for p in reference.parameters() if all(p is not q for q in (*actor, *alpha))]
    optimizers = [torch.optim.Adam(rest, lr=ADAM["lr"], eps=ADAM["eps"]), torch.optim.Adam(actor, lr=1e-3, eps=ADAM["eps"]),
                  torch.optim.Adam(alpha, lr=1e-3, betas=(0.5, 0.999), eps=ADAM["eps"])]
    torch.manual_seed(5)
    for step, batch in enumerate(batches):
        reference.set_step(1000 * step)
        out = reference(batch.clone())
        for each in optimizers:
            each.zero_grad()
        sum(value for key, value in out.items() if key.startswith("loss_")).backward()
        for index, each in enumerate(optimizers):
            if index == 0 or step % 2 == 0:
                each.step()
        if step % 2 == 0:
            with torch.no_grad():
                for name, rate in (("encoder_params", 0.05), ("critic_params", None)):
                    for key, source in getattr(reference, name).items(True, True):
                        tau = rate if rate is not None else (0.05 if key[0] == "trunk" else 0.01)
                        getattr(reference, f"target_{name}").get(key).data.lerp_(source.data, tau)
        assert all(torch.equal(out[key].detach(), outs[step][key]) for key in out.keys())
    for (name, value), (_, expected) in zip(loss.state_dict().items(), reference.state_dict().items()):
        assert torch.equal(value, expected), name
    assert [int(optimizer.state[p]["step"]) for p in (next(loss.actor.parameters()), loss.sampler.log_alpha,
                                                       next(loss.critic.parameters()))] == [2, 2, 4]
    assert update.count == 4 and update.due(5) == ((True, True, False, False), False)


def test_the_schedule_follows_the_update_count_which_a_resumed_run_sets():
    loss, optimizer, target = build_scheduled()
    update = UpdateStep(loss, optimizer, target, target_every=2)
    update.count = 7  # a run resumed after 7 updates: the next is the 8th (index 7), odd: no actor, no target
    before = [p.clone() for p in loss.actor.parameters()]
    update(make_batch(seed=0))
    assert all(torch.equal(p, q) for p, q in zip(loss.actor.parameters(), before)) and update.count == 8


@pytest.mark.slow
def test_a_compiled_schedule_is_one_graph_per_pattern_and_equals_the_eager_one():
    batches = [make_batch(seed=seed) for seed in range(4)]
    eager = UpdateStep(*build_scheduled(), target_every=2)
    expected = run_updates(eager, batches)
    update = UpdateStep(*build_scheduled(), target_every=2, compile=True, backend="aot_eager")
    with torch._dynamo.config.patch(error_on_recompile=True):
        got = run_updates(update, batches)
    assert len(update._scheduled_steps) == 1, "every-second-update: two graphs, the all-due one and this one"
    for index, (reference, out) in enumerate(zip(expected, got)):
        for key in reference:
            torch.testing.assert_close(out[key], reference[key], rtol=1e-4, atol=1e-5, msg=lambda m: f"update {index}, {key}: {m}")
    assert_same_training_state(update, eager)


def test_a_cuda_graph_of_a_schedule_is_refused_naming_the_fix():
    with pytest.raises(ValueError, match="not yet checked as CUDA graphs on a GPU; pass cudagraph=False"):
        UpdateStep(*build_scheduled(), target_every=2, cudagraph=True)
    with pytest.raises(ValueError, match="target_every is a number of updates"):
        UpdateStep(*build("drqv2"), target_every=0)

"""Why DrQ-v2's eager update takes longer inside ``examples/train.py`` than in ``benchmarks/losses.py``: one condition at a time.

On the H200 (2026-11-28, ``docs/performance.md``) the eager DrQ-v2 update at batch 256 took 9.9 ms in
``benchmarks/losses.py`` (a median of single updates, ``torch.cuda.synchronize()`` after each) and
15.5 ms per update in ``train.py``'s ``update`` stage (host seconds of 50 updates in a row, the
metrics read once at the end), with sampling (6.4 ms per update) in between. The two measure
different things in several ways at once; this runs the same update under each of ``train.py``'s
conditions in turn, on the same device, so that the step that adds the time shows:

A. ``losses.py``'s update: ``make_networks`` (convolution weights in NCHW, inputs channels-last),
   a fixed exploration std, augmentations on torch's global RNG; synchronized after each update;
B. ``train.py``'s agent: ``vigen.run.build_agent`` with the ``paper`` preset (weights channels-last too,
   DrQ-v2's std schedule read from a step buffer, augmentations on their own seeded generators),
   the batch with ``steps_to_next_obs`` (γⁿ); synchronized after each update;
C. B's updates 50 in a row, then ``raise_if_diverged()`` (one read): ``train.py``'s ``update`` stage per update;
D. C with ``train.py``'s sampling before each update: ``vigen.run.RunReplay`` from its memory map (gathered
   into pinned memory, copied without blocking); ``update`` and ``sample`` timed apart, as ``train.py`` does;
E. D with the replay's copy on the device (``--replay-on-device``).

Per row: host ms per update (what ``train.py``'s clock sees), the device's busy ms per update (the
union of its activity intervals, ``vigen.run.timing``, from torch.profiler over the same loop), and
for D and E the sampling's host ms.

    python benchmarks/update_gap.py --device cuda            # the device check runs this (~30 s)
    python benchmarks/update_gap.py --quick                  # tiny sizes on the CPU (the test)
"""

from __future__ import annotations

import argparse
import copy
import json
import statistics
import sys
import tempfile
import time
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path

import torch
from tensordict import TensorDict
from torchrl.data import Bounded
from torchrl.objectives import SoftUpdate

from vigen.devices import resolve_device
from vigen.losses import UpdateStep, build_loss, make_networks
from vigen.run import PRESETS, RunReplay, build_agent
from vigen.run.timing import busy_seconds, device_intervals

ACTIONS, LR, TAU, GAMMA = 6, 1e-4, 0.01, 0.99


def transitions(count: int, shape: tuple[int, int, int], generator: torch.Generator) -> TensorDict:
    """``count`` n-step transitions as ``train.py`` stores them (random pixels)."""
    pixels = lambda: torch.randint(0, 256, (count, *shape), dtype=torch.uint8, generator=generator)  # noqa: E731
    flags = torch.zeros(count, 1, dtype=torch.bool)
    return TensorDict({"pixels": pixels(), "action": torch.rand(count, ACTIONS, generator=generator) * 2 - 1,
                       "steps_to_next_obs": torch.full((count, 1), 3), "next": {
                           "pixels": pixels(), "reward": torch.rand(count, 1, generator=generator), "done": flags,
                           "terminated": flags.clone(), "truncated": flags.clone()}}, batch_size=[count])


def losses_py_update(shape: tuple[int, int, int], hidden: int, feature: int, device: torch.device) -> UpdateStep:
    """A: as benchmarks/losses.py builds vigen's side (make_networks, not channels-last weights; std 0.2; global RNG)."""
    nets = make_networks("drqv2", shape, ACTIONS, hidden_dim=hidden, feature_dim=feature)
    loss = build_loss("drqv2", *nets.values(), std_schedule=0.2).to(device).make_value_estimator(gamma=GAMMA)
    return UpdateStep(loss, torch.optim.Adam(loss.optimizer_groups(LR), fused=True), SoftUpdate(loss, tau=TAU))


def train_py_update(shape: tuple[int, int, int], hidden: int, feature: int, batch_size: int, device: torch.device) -> UpdateStep:
    """B: as examples/train.py builds it (build_agent, the paper preset, fused Adam)."""
    config = replace(PRESETS["paper"], algo="drqv2", observation_shape=shape, action_dim=ACTIONS, hidden_dim=hidden,
                     feature_dim=feature, batch_size=batch_size)
    agent = build_agent(config, Bounded(-1.0, 1.0, shape=(ACTIONS,)), device=device)
    agent.loss.set_step(10_000)
    loss = agent.loss
    return UpdateStep(loss, torch.optim.Adam(loss.optimizer_groups(config.lr), fused=True), SoftUpdate(loss, tau=config.tau))


def synchronize(device: torch.device) -> None:
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def single(update: UpdateStep, batch: TensorDict, repeats: int, device: torch.device) -> float:
    """Median host seconds of one update followed by a synchronize (losses.py's way)."""
    samples = []
    for _ in range(repeats + 1):
        started = time.perf_counter()
        update(batch.clone())
        synchronize(device)
        samples.append(time.perf_counter() - started)
    return statistics.median(samples[1:])


def in_a_row(update: UpdateStep, sample: Callable[[], TensorDict], count: int, device: torch.device) -> tuple[float, float]:
    """(update, sample) host seconds per update over ``count`` updates in a row, the metrics read once (train.py's clock)."""
    synchronize(device)
    sampling = updating = 0.0
    for _ in range(count):
        started = time.perf_counter()
        batch = sample()
        sampling += time.perf_counter() - started
        started = time.perf_counter()
        update(batch)
        updating += time.perf_counter() - started
    started = time.perf_counter()
    update.raise_if_diverged()  # train.py reads the guard (one synchronization) inside its update clock
    updating += time.perf_counter() - started
    return updating / count, sampling / count


def device_ms(run: Callable[[], object], count: int, device: torch.device) -> float | None:
    """The union of the device's activity intervals per update over ``run()`` (which makes ``count`` updates), ms."""
    if device.type != "cuda":
        return None
    synchronize(device)
    with torch.profiler.profile(activities=[torch.profiler.ProfilerActivity.CUDA]) as prof:
        run()
        synchronize(device)
    return 1e3 * busy_seconds(device_intervals(prof, "cuda")) / count


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--device", default="cpu")
    parser.add_argument("--quick", action="store_true", help="tiny sizes on the CPU (the test)")
    parser.add_argument("--count", type=int, default=None, help="updates per measurement (50: one collector batch)")
    parser.add_argument("--json", type=Path, default=None, help="also write the rows there")
    args = parser.parse_args(argv)
    device = resolve_device("cpu" if args.quick else args.device)
    shape, hidden, feature, batch_size = ((9, 32, 32), 32, 8, 8) if args.quick else ((9, 84, 84), 1024, 50, 256)
    count = args.count or (5 if args.quick else 50)
    print("reproduce: python benchmarks/update_gap.py " + " ".join(sys.argv[1:] if argv is None else argv), flush=True)
    name = torch.cuda.get_device_name(device) if device.type == "cuda" else "cpu"
    print(f"torch {torch.__version__} on {name}; DrQ-v2, batch {batch_size}, {shape}; {count} updates per measurement", flush=True)
    generator = torch.Generator().manual_seed(0)
    stored = transitions(max(4 * batch_size, 64), shape, generator)
    batch = stored[:batch_size].to(device)
    rows: list[dict] = []
    a = losses_py_update(shape, hidden, feature, device)
    b = train_py_update(shape, hidden, feature, batch_size, device)
    rows.append({"row": "A: losses.py's update, synchronized", "update_ms": 1e3 * single(a, batch, count, device),
                 "device_ms": device_ms(lambda: [a(batch.clone()) for _ in range(count)], count, device)})
    rows.append({"row": "B: train.py's agent, synchronized", "update_ms": 1e3 * single(b, batch, count, device),
                 "device_ms": device_ms(lambda: [b(batch.clone()) for _ in range(count)], count, device)})
    update_s, _ = in_a_row(b, lambda: batch.clone(), count, device)
    rows.append({"row": f"C: B, {count} in a row, one read", "update_ms": 1e3 * update_s,
                 "device_ms": device_ms(lambda: in_a_row(b, lambda: batch.clone(), count, device), count, device)})
    with tempfile.TemporaryDirectory() as folder:
        for label, on_device in (("D: C, sampled from the memory map (pinned, non-blocking)", False),
                                 ("E: C, sampled from the replay's device copy", True)):
            replay = RunReplay(len(stored), batch_size, Path(folder) / ("device" if on_device else "memmap"), device,
                               on_device=on_device)
            replay.extend(stored)
            in_a_row(b, replay.sample, 2, device)  # the first samples allocate pinned memory
            update_s, sample_s = in_a_row(b, replay.sample, count, device)
            rows.append({"row": label, "update_ms": 1e3 * update_s, "sample_ms": 1e3 * sample_s,
                         "device_ms": device_ms(lambda: in_a_row(b, replay.sample, count, device), count, device)})
    print("\n| condition | update ms (host) | sample ms (host) | device ms (busy) |\n|---|---|---|---|")
    for row in rows:
        cells = [f"{row[key]:.2f}" if row.get(key) is not None else "—" for key in ("update_ms", "sample_ms", "device_ms")]
        print(f"| {row['row']} | " + " | ".join(cells) + " |", flush=True)
    if args.json is not None:
        args.json.write_text(json.dumps({"device": name, "torch": torch.__version__, "rows": rows}, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())

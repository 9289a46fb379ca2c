"""End-to-end throughput of ``examples/train.py`` per configuration: env workers, serial or overlapped collection, eager or
compiled update, replay sampled from the memory map or from the device; frames/s, updates/s, the GPU's busy share and
the time of each stage.

Each configuration runs ``examples/train.py --time-stages`` in its own process and run folder. The
run logs one row per collector batch (``logs/scalars/time/*.csv``, see ``vigen.run.StageTimes``): the run's
wall clock, the batch's agent steps and updates, the loop's
seconds per stage and the env workers' milliseconds per agent step, each *measured* where it
happens (the env workers time their own steps, physics and rendering). The benchmark reads those
rows while the run trains and stops it once ``--warmup`` batches of updates (the first update,
where a compiled update compiles, and the batch whose GPU activity is profiled) and then the
measured ones (``--batches`` at least, and as many as hold ``--min-updates`` updates) are
logged. Figures, over the measured batches:

* **frames/s**: environment frames (agent steps × action repeat) over the run's wall time,
  everything included (collection, storing, sampling, updates, weight syncs);
* **updates/s**: gradient updates over the same wall time;
* **collect frames/s**: frames over the collector's own seconds (its ``next``): how fast the
  workers produce frames, whether or not the loop waits for them; **seed frames/s**: the same
  end to end while the run only collects (random actions, no updates), start-up excluded;
* **hidden**: the share of the collector's time the loop did not wait for (0 when serial; with
  ``--overlap``, how much of the collection the updates hid);
* per stage: the env workers' mean ms per agent step (step, and its physics and render; the
  policy, resets), the loop's store ms per agent step, sample and update ms per update, and the
  share of the wall time the loop spent waiting for frames;
* **runs** (``--runs N``): N training processes of the configuration at once, seeds 0 to N - 1,
  sharing the machine (the GPU and the cores; each ``train.py --threads cores / N``); every run is
  measured as above and none is stopped before all are, so that each run's window lies in the
  time all N trained together. **aggregate frames/s** (``aggregate_frames_per_s``) is the sum of the
  runs' frames/s, beside each run's own (``frames_per_s_each``; the stage columns are the runs'
  means): what the machine trains in all, five seeds at once being how researchers use it;
* **GPU busy**: the share of one whole batch (collection to updates, the batch after the first
  updates) during which the GPU ran the training process's kernels or copies (torch.profiler,
  ``time/gpu_busy``; the workers' acting is in other processes, not in it); and, where
  ``nvidia-smi`` exists, **GPU util**: its utilization (every process) sampled every 200 ms over the
  measured batches.

Modes (sizes, configurations and budget; any flag overrides them):

    python benchmarks/train_throughput.py --quick --out /tmp/tt      # tiny sizes on the CPU, ~1 min (the test)
    python benchmarks/train_throughput.py --out /tmp/tt              # this CPU's figures (workers 1, 2; serial, overlap)
    python benchmarks/train_throughput.py --gpu --out $OUT/throughput  # one GPU call, <= 150 s: walker-walk, batch 256,
                                                                       # 1/4/8 workers, serial vs overlapped, eager
    python benchmarks/train_throughput.py --updates eager compiled --workers 1 2   # compiled too (each compiles once)
    python benchmarks/train_throughput.py --gpu --configs 1/overlap/device --runs 1 4 8  # several runs sharing the GPU
    python benchmarks/train_throughput.py --quick --configs 1 --runs 2 --out /tmp/tt   # two runs at once, tiny, on the CPU

It prints a markdown table and writes ``<out>/train_throughput.json`` (every row of every run,
and the figures; rewritten atomically after each configuration) and ``<out>/train_logs.txt``
(each run's output). Configurations run in the order given, most important first, and whatever
does not fit ``--deadline`` is skipped (said so in the table and the JSON).
"""

from __future__ import annotations

import argparse
import csv
import dataclasses
import datetime
import itertools
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import threading
import time
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any

from gpu_check import stop  # benchmarks/gpu_check.py, beside this script

ROOT = Path(__file__).resolve().parents[1]
BASE_KEYS = ("wall_s", "steps", "updates")


@dataclasses.dataclass(frozen=True)
class Config:
    """One configuration of ``examples/train.py``."""

    workers: int = 1
    overlap: bool = False
    compiled: bool = False
    replay: str = "memmap"  # or "device": --replay-on-device
    seconds: float | None = None  # this configuration's own time limit (default: --timeout)
    runs: int | None = None  # training processes at once (default: each of --runs)

    @classmethod
    def parse(cls, spec: str) -> Config:
        """``WORKERS[/overlap][/compiled][/device][*RUNS][@SECONDS]``, e.g. ``8/overlap/compiled/device@130``, ``1/overlap*8@100``.

        Examples:
            >>> Config.parse("1/overlap*8@100")
            Config(workers=1, overlap=True, compiled=False, replay='memmap', seconds=100.0, runs=8)
        """
        head, _, seconds = spec.partition("@")
        head, _, runs = head.partition("*")
        workers, *words = head.split("/")
        unknown = set(words) - {"overlap", "compiled", "device"}
        if not workers.isdigit() or int(workers) < 1 or unknown or (runs and (not runs.isdigit() or int(runs) < 1)):
            raise argparse.ArgumentTypeError(
                f"--configs {spec!r}: expected WORKERS[/overlap][/compiled][/device][*RUNS][@SECONDS], e.g. 8/overlap/device@60"
                + (f" ({', '.join(sorted(unknown))} unknown)" if unknown else ""))
        return cls(int(workers), "overlap" in words, "compiled" in words, "device" if "device" in words else "memmap",
                   float(seconds) if seconds else None, int(runs) if runs else None)

    @property
    def name(self) -> str:
        return (f"{self.workers}w-{'overlap' if self.overlap else 'serial'}-{'compiled' if self.compiled else 'eager'}"
                f"-{self.replay}")

    def flags(self) -> list[str]:
        return [*(["--workers", str(self.workers)] if self.workers > 1 else []), *(["--overlap"] if self.overlap else []),
                *(["--compile"] if self.compiled else []), *(["--replay-on-device"] if self.replay == "device" else [])]


SIZES = {  # train.py's flags per mode (--threads, --device are added from the flags)
    "quick": ["--env", "dmc/cartpole-balance", "--image-size", "32", "--hidden-dim", "32", "--feature-dim", "8",
              "--batch-size", "8", "--buffer-size", "2000", "--seed-frames", "200"],
    "cpu": ["--env", "dmc/cartpole-balance", "--preset", "cpu", "--buffer-size", "20000", "--seed-frames", "1000"],
    "gpu": ["--env", "dmc/walker-walk", "--preset", "paper", "--buffer-size", "100000", "--seed-frames", "1000"],
}
DEFAULTS = {  # per mode: device, warm-up batches, measured batches and updates, deadline s, per-configuration timeout s,
    # configurations (most important first: what does not fit the deadline is skipped)
    "quick": dict(device="cpu", warmup=1, batches=1, min_updates=1, deadline=150, timeout=90,
                  configs=[Config(1), Config(2, overlap=True, replay="device")]),
    "cpu": dict(device="cpu", warmup=1, batches=3, min_updates=150, deadline=3600, timeout=900,
                configs=[Config(1), Config(2), Config(1, overlap=True), Config(2, overlap=True)]),
    "gpu": dict(device="cuda", warmup=2, batches=1, min_updates=100, deadline=140, timeout=60,
                configs=[Config(8, True, replay="device"), Config(1), Config(1, replay="device"), Config(1, True, replay="device"),
                         Config(4, True, replay="device"), Config(8, replay="device"), Config(4, replay="device")]),
}


def read_rows(run_dir: Path) -> list[dict[str, float]]:
    """The run's ``time/*`` rows joined by frames (the CSV logger's step), complete ones only, oldest first."""
    folder = run_dir / "logs" / "scalars" / "time"
    by_frames: dict[float, dict[str, float]] = {}
    for path in sorted(folder.glob("*.csv")) if folder.is_dir() else []:
        with path.open() as file:
            for row in csv.reader(file):
                if len(row) >= 2:
                    try:
                        by_frames.setdefault(float(row[0]), {})[path.stem] = float(row[1])
                    except ValueError:
                        continue  # a row being written
    rows = [{"frames": frames, **values} for frames, values in sorted(by_frames.items())]
    return [row for row in rows if all(key in row for key in BASE_KEYS)]


def weighted(rows: list[dict[str, float]], key: str, weight: str = "steps") -> float | None:
    pairs = [(row[key], row[weight]) for row in rows if key in row and row[key] == row[key]]
    total = sum(w for _, w in pairs)
    return sum(v * w for v, w in pairs) / total if total else None


def measured(rows: list[dict[str, float]], warmup: int, batches: int, min_updates: int) -> tuple[list[int], bool]:
    """The indices of the measured rows (the batches with updates after ``warmup`` of them, ``batches`` at least and
    ``min_updates`` updates at least), and whether they are all logged yet."""
    updating = [index for index, row in enumerate(rows) if row["updates"] > 0][warmup:]
    chosen, updates = [], 0
    for index in updating:
        if len(chosen) >= batches and updates >= min_updates:
            break
        chosen.append(index)
        updates += rows[index]["updates"]
    return chosen, len(chosen) >= batches and updates >= min_updates


def summarize(rows: list[dict[str, float]], warmup: int, batches: int, min_updates: int = 1) -> dict[str, Any]:
    """The figures of a run's rows (see the module docstring); ``{"error": ...}`` if no measured batch was logged."""
    chosen, _ = measured(rows, warmup, batches, min_updates)
    updating = [index for index, row in enumerate(rows) if row["updates"] > 0]
    if not chosen:
        return {"error": f"{len(updating)} batches with updates logged; {warmup + 1} at least are needed"}
    first, last = chosen[0], chosen[-1]
    window, before = rows[first:last + 1], rows[first - 1]
    wall = window[-1]["wall_s"] - before["wall_s"]
    frames = window[-1]["frames"] - before["frames"]
    steps = sum(row["steps"] for row in window)
    updates = sum(row["updates"] for row in window)
    stage = {key: sum(row.get(f"{key}_s", 0.0) for row in window) for key in ("collect", "wait", "sync", "store", "sample", "update")}
    figures: dict[str, Any] = {
        "measured_batches": len(window), "frames": frames, "updates": updates, "wall_s": round(wall, 3),
        "frames_per_s": frames / wall, "updates_per_s": updates / wall,
        "collect_frames_per_s": frames / stage["collect"] if stage["collect"] > 0 else None,
        "hidden": 1 - stage["wait"] / stage["collect"] if stage["collect"] > 0 else None,
        "wait_share": stage["wait"] / wall, "update_share": stage["update"] / wall,
        "store_ms_per_step": 1000 * stage["store"] / steps, "sample_ms_per_update": 1000 * stage["sample"] / updates,
        "update_ms_per_update": 1000 * stage["update"] / updates, "sync_s_per_batch": stage["sync"] / len(window),
    }
    for name in ("step", "physics", "render", "policy", "reset"):
        figures[f"env_{name}_ms"] = weighted(window, f"env_{name}_ms")
    seeding = [row for row in rows[:updating[0]]][1:]  # the first row carries the start-up
    if len(seeding) >= 2:
        figures["seed_frames_per_s"] = (seeding[-1]["frames"] - seeding[0]["frames"]) / (seeding[-1]["wall_s"] - seeding[0]["wall_s"])
    busy = [row["gpu_busy"] for row in rows if "gpu_busy" in row]
    figures["gpu_busy"] = busy[0] if busy else None
    figures["first_batch_wall_s"] = rows[0]["wall_s"]
    return figures


class UtilizationSampler:
    """``nvidia-smi``'s GPU utilization every 200 ms, in a thread, with the benchmark's clock; inactive without nvidia-smi."""

    def __init__(self) -> None:
        self.samples: list[tuple[float, float]] = []
        self.process = None
        if shutil.which("nvidia-smi"):
            self.process = subprocess.Popen(["nvidia-smi", "--query-gpu=utilization.gpu", "--format=csv,noheader,nounits",
                                             "-lms", "200"], stdout=subprocess.PIPE, stderr=subprocess.DEVNULL, text=True)
            threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.process.stdout:
            try:
                self.samples.append((time.time(), float(line.split(",")[0])))
            except ValueError:
                continue

    def mean(self, start: float, end: float) -> float | None:
        inside = [value for at, value in self.samples if start <= at <= end]
        return sum(inside) / len(inside) / 100 if inside else None

    def close(self) -> None:
        if self.process is not None:
            self.process.terminate()
            self.process.wait(timeout=5)


def renderers(output: str) -> list[str]:
    """What the run's processes said they render with (``--time-stages``: "... renders with NAME (MUJOCO_EGL_DEVICE_ID=...)").

    Examples:
        >>> renderers("this process renders with llvmpipe (LLVM 15)\\nenv worker 0 renders with NVIDIA H100 (MUJOCO_EGL_DEVICE_ID=0)")
        ['NVIDIA H100', 'llvmpipe (LLVM 15)']
    """
    found = re.findall(r"renders with (.+?)(?: \(MUJOCO_EGL_DEVICE_ID=[^)]*\))?$", output.replace("\r", "\n"), re.MULTILINE)
    return sorted(set(found))


def run_group(config: Config, args: argparse.Namespace, scratch: Path, log, timeout: float,
              sampler: UtilizationSampler | None, runs: int = 1) -> dict[str, Any]:
    """Train ``runs`` processes with ``config`` at once (seeds 0 .. runs - 1), until each has logged its measured batches (or
    ``timeout``), then stop them all and summarize each; with several runs, their aggregate beside each run's figures.

    No run is stopped before every run is measured, so each run's measured window lies in the time all of them trained
    together; ``aggregate_frames_per_s`` is the sum of the runs' frames/s (and ``aggregate_updates_per_s`` of their
    updates/s): what the machine trains in all while shared by ``runs`` training processes."""
    name = config.name if runs == 1 else f"{config.name} x{runs}"
    threads = args.threads if args.threads else (max(1, (os.cpu_count() or 1) // runs) if runs > 1 else None)
    members = []
    for run in range(runs):
        run_dir = scratch / (config.name if runs == 1 else f"{config.name}-x{runs}-seed{run}")
        command = [args.python, str(ROOT / "examples" / "train.py"), "--algo", args.algo, *args.sizes, "--device", args.device,
                   "--frames", "100000000", "--eval-every", "100000000", "--eval-episodes", "1", "--time-stages",
                   "--out", str(run_dir), *(["--threads", str(threads)] if threads else []),
                   *(["--seed", str(run)] if runs > 1 else []), *config.flags()]
        output = scratch / f"{run_dir.name}.log"
        with output.open("w") as file:
            file.write(f"$ {' '.join(command)}\n")
            file.flush()
            process = subprocess.Popen(command, cwd=ROOT, stdout=file, stderr=subprocess.STDOUT, start_new_session=True)
        members.append({"run_dir": run_dir, "command": command, "output": output, "process": process, "appeared": {}})
    started = time.time()
    while True:
        codes = [member["process"].poll() for member in members]
        complete = []
        for member in members:
            rows = read_rows(member["run_dir"])
            for row in rows:
                member["appeared"].setdefault(row["frames"], time.time())
            complete.append(measured(rows, args.warmup, args.batches, args.min_updates)[1])
        if all(complete) or any(code not in (None, 0) for code in codes) or all(code is not None for code in codes) \
                or time.time() - started > timeout:
            break
        time.sleep(0.1)
    with ThreadPoolExecutor(max_workers=len(members)) as pool:  # every run and its worker processes, at once
        list(pool.map(lambda member: stop(member["process"], term_wait=10), members))
    log.write(f"\n===== {name}\n")
    results = []
    for run, (member, code) in enumerate(zip(members, codes)):
        output = member["output"].read_text(errors="replace")
        log.write(output + "\n")
        rows = read_rows(member["run_dir"])
        result: dict[str, Any] = {"seed": run, "command": " ".join(member["command"]), "exit_code": code,
                                  "renderers": renderers(output), "rows": rows}
        figures = summarize(rows, args.warmup, args.batches, args.min_updates)
        chosen, complete = measured(rows, args.warmup, args.batches, args.min_updates)
        if "error" not in figures:
            appeared = member["appeared"]
            figures["start_s"] = round(appeared.get(rows[0]["frames"], started) - started, 1)
            if sampler is not None:
                before, last = rows[chosen[0] - 1], rows[chosen[-1]]
                figures["gpu_utilization"] = sampler.mean(appeared.get(before["frames"], 0), appeared.get(last["frames"], 0))
        result["figures"] = figures
        result["status"] = "failed" if code not in (None, 0) else "passed" if complete else "incomplete"
        results.append(result)
    log.flush()
    group: dict[str, Any] = {"config": dataclasses.asdict(config), "name": name, "runs": runs,
                             "seconds": round(time.time() - started, 1)}
    statuses = {result["status"] for result in results}
    group["status"] = "failed" if "failed" in statuses else "passed" if statuses == {"passed"} else "incomplete"
    if runs == 1:
        (result,) = results
        group.update({key: result[key] for key in ("command", "exit_code", "renderers", "rows", "figures")})
        if "frames_per_s" in group["figures"]:
            group["figures"]["aggregate_frames_per_s"] = group["figures"]["frames_per_s"]
            group["figures"]["aggregate_updates_per_s"] = group["figures"]["updates_per_s"]
        return group
    group["results"] = results
    measured_runs = [result["figures"] for result in results if "frames_per_s" in result["figures"]]
    if len(measured_runs) < runs:
        group["figures"] = {"error": f"{runs - len(measured_runs)} of {runs} runs logged no measured batch",
                            "frames_per_s_each": [figures["frames_per_s"] for figures in measured_runs]}
        return group
    mean = {key: _mean([figures.get(key) for figures in measured_runs]) for key in measured_runs[0]}
    group["figures"] = {**mean, "measured_batches": min(figures["measured_batches"] for figures in measured_runs),
                        "frames_per_s_each": [figures["frames_per_s"] for figures in measured_runs],
                        "aggregate_frames_per_s": sum(figures["frames_per_s"] for figures in measured_runs),
                        "aggregate_updates_per_s": sum(figures["updates_per_s"] for figures in measured_runs)}
    return group


def _mean(values: list[Any]) -> Any:
    numbers = [value for value in values if isinstance(value, (int, float)) and not isinstance(value, bool)]
    return sum(numbers) / len(numbers) if numbers and len(numbers) == len(values) else None


def cell(value: Any, spec: str = ".1f", scale: float = 1.0, suffix: str = "") -> str:
    return "—" if value is None else f"{value * scale:{spec}}{suffix}"


def table(results: list[dict[str, Any]]) -> str:
    """The results as a markdown table, sorted by update, replay, workers, overlap."""
    header = ("| config | runs | aggregate frames/s | frames/s (each run) | updates/s | collect frames/s | seed frames/s | hidden "
              "| GPU busy | GPU util | env step ms | render ms | physics ms | policy ms | store ms/step | sample ms/upd "
              "| update ms/upd | wait | start s |")
    lines = [header, "|" + "---|" * (header.count("|") - 1)]
    order = sorted(results, key=lambda r: (r["config"]["compiled"], r["config"]["replay"] != "memmap", r["config"]["workers"],
                                           r["config"]["overlap"], r.get("runs", 1)))
    for result in order:
        f = result.get("figures", {})
        if "frames_per_s" not in f:
            why = f.get("error") or result.get("reason") or f"exit {result.get('exit_code')}"
            lines.append(f"| {result['name']} | {result.get('runs', 1)} | {result['status']}: {why} |" + " |" * (header.count("|") - 4))
            continue
        name = result["name"] if result["status"] == "passed" else f"{result['name']} ({result['status']}: {f['measured_batches']} batches)"
        each = " / ".join(f"{value:.1f}" for value in f.get("frames_per_s_each", [f["frames_per_s"]]))
        lines.append(
            f"| {name} | {result.get('runs', 1)} | {cell(f.get('aggregate_frames_per_s'))} | {each} "
            f"| {cell(f['updates_per_s'])} | {cell(f['collect_frames_per_s'])} "
            f"| {cell(f.get('seed_frames_per_s'))} | {cell(f['hidden'], '.0f', 100, ' %')} | {cell(f['gpu_busy'], '.0f', 100, ' %')} "
            f"| {cell(f.get('gpu_utilization'), '.0f', 100, ' %')} | {cell(f['env_step_ms'], '.2f')} | {cell(f['env_render_ms'], '.2f')} "
            f"| {cell(f['env_physics_ms'], '.2f')} | {cell(f['env_policy_ms'], '.2f')} | {cell(f['store_ms_per_step'], '.2f')} "
            f"| {cell(f['sample_ms_per_update'], '.2f')} | {cell(f['update_ms_per_update'], '.2f')} "
            f"| {cell(f['wait_share'], '.0f', 100, ' %')} | {cell(f.get('start_s'))} |")
    return "\n".join(lines)


def write_json(path: Path, data: dict) -> None:
    """Atomically: a benchmark stopped while writing leaves the previous figures."""
    with tempfile.NamedTemporaryFile("w", dir=path.parent, prefix=f".{path.name}.", suffix=".tmp", delete=False) as tmp:
        json.dump(data, tmp, indent=1)
    os.replace(tmp.name, path)


def git_commit() -> str | None:
    try:
        result = subprocess.run(["git", "rev-parse", "HEAD"], cwd=ROOT, capture_output=True, text=True, timeout=10)
    except (OSError, subprocess.TimeoutExpired):
        return None
    return result.stdout.strip() or None


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0], formatter_class=argparse.RawDescriptionHelpFormatter)
    which = parser.add_mutually_exclusive_group()
    which.add_argument("--quick", action="store_true", help="tiny sizes on the CPU, two configurations (the test)")
    which.add_argument("--gpu", action="store_true", help="one call on the GPU machine: walker-walk, batch 256, 1/4/8 workers")
    parser.add_argument("--out", type=Path, default=Path("train-throughput"))
    parser.add_argument("--algo", default="drqv2")
    parser.add_argument("--device", default=None)
    parser.add_argument("--workers", type=int, nargs="+", default=None, help="replaces the mode's configurations with the "
                        "product of --workers, --collection, --updates and --replay")
    parser.add_argument("--configs", nargs="+", type=Config.parse, default=None, metavar="SPEC",
                        help="the configurations in this order, each WORKERS[/overlap][/compiled][/device][*RUNS][@SECONDS] "
                             "(instead of --workers/--collection/--updates/--replay)")
    parser.add_argument("--collection", nargs="+", choices=["serial", "overlap"], default=None)
    parser.add_argument("--updates", nargs="+", choices=["eager", "compiled"], default=None)
    parser.add_argument("--replay", nargs="+", choices=["memmap", "device"], default=None)
    parser.add_argument("--warmup", type=int, default=None, help="batches of updates left out before measuring")
    parser.add_argument("--batches", type=int, default=None, help="batches of updates measured, at least")
    parser.add_argument("--min-updates", type=int, default=None, help="updates measured, at least (more batches if needed)")
    parser.add_argument("--deadline", type=float, default=None, help="seconds for every configuration together")
    parser.add_argument("--timeout", type=float, default=None, help="seconds per configuration, start-up included")
    parser.add_argument("--threads", type=int, default=None,
                        help="train.py --threads (default: torch's; with --runs N > 1, the cores / N)")
    parser.add_argument("--runs", type=int, nargs="+", default=[1], metavar="N",
                        help="training processes sharing the machine, per configuration: each N in turn (e.g. --runs 1 4 8); "
                             "the table adds their aggregate frames/s beside each run's")
    parser.add_argument("--train-flags", nargs=argparse.REMAINDER, default=[],
                        help="more train.py flags, after the mode's sizes (last on the line)")
    parser.add_argument("--python", default=sys.executable)
    args = parser.parse_args(argv)
    if any(runs < 1 for runs in args.runs):
        parser.error(f"--runs takes numbers of runs >= 1, got {args.runs}")
    args.mode = "quick" if args.quick else "gpu" if args.gpu else "cpu"
    defaults = DEFAULTS[args.mode]
    for key in ("device", "warmup", "batches", "min_updates", "deadline", "timeout"):
        if getattr(args, key) is None:
            setattr(args, key, defaults[key])
    if args.threads is None and args.mode == "quick":
        args.threads = 1
    args.sizes = [*SIZES[args.mode], *args.train_flags]
    if args.configs is not None:
        if any(value is not None for value in (args.workers, args.collection, args.updates, args.replay)):
            raise SystemExit("--configs names every configuration: leave out --workers, --collection, --updates and --replay")
    elif any(value is not None for value in (args.workers, args.collection, args.updates, args.replay)):
        args.configs = [Config(workers, collection == "overlap", updates == "compiled", replay) for workers, collection, updates, replay
                        in itertools.product(args.workers or [1], args.collection or ["serial"], args.updates or ["eager"],
                                             args.replay or ["memmap"])]
    else:
        args.configs = list(defaults["configs"])
    return args


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    out = args.out.resolve()
    out.mkdir(parents=True, exist_ok=True)
    started = time.time()
    report: dict[str, Any] = {
        "schema": 1, "started": datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds"),
        "command": "python benchmarks/train_throughput.py " + " ".join(sys.argv[1:] if argv is None else argv),
        "mode": args.mode, "device": args.device, "algo": args.algo, "sizes": args.sizes, "warmup": args.warmup,
        "batches": args.batches, "min_updates": args.min_updates, "deadline_s": args.deadline, "commit": git_commit(), "results": [], "status": "running"}
    print(f"reproduce: {report['command']}", flush=True)
    sampler = UtilizationSampler() if args.device.startswith("cuda") else None
    scratch = Path(tempfile.mkdtemp(prefix="vigen-throughput-"))
    try:
        with (out / "train_logs.txt").open("w") as log:
            for config in args.configs:
                for runs in [config.runs] if config.runs else args.runs:
                    name = config.name if runs == 1 else f"{config.name} x{runs}"
                    left = args.deadline - (time.time() - started)
                    limit = args.timeout if config.seconds is None else config.seconds
                    if left < min(limit, 20):
                        report["results"].append({"config": dataclasses.asdict(config), "name": name, "runs": runs,
                                                  "status": "skipped", "reason": f"{left:.0f} s left before the deadline",
                                                  "figures": {}})
                        continue
                    result = run_group(config, args, scratch, log, min(limit, left), sampler, runs)
                    report["results"].append(result)
                    write_json(out / "train_throughput.json", report)
                    figures = result["figures"]
                    print(f"{name}: {result['status']} in {result['seconds']:.0f} s"
                          + (f", {figures['aggregate_frames_per_s']:.1f} frames/s" + (" in all" if runs > 1 else "")
                             if figures.get("aggregate_frames_per_s") is not None else ""), flush=True)
    finally:
        if sampler is not None:
            sampler.close()
        shutil.rmtree(scratch, ignore_errors=True)
    statuses = {result["status"] for result in report["results"]}
    report["status"] = "passed" if statuses == {"passed"} else "failed" if "failed" in statuses else "incomplete"
    report["seconds"] = round(time.time() - started, 1)
    report["table"] = table(report["results"])
    write_json(out / "train_throughput.json", report)
    print(f"\n{args.algo}, {' '.join(args.sizes)}, device {args.device}; batches measured after {args.warmup} of warm-up: "
          f"{args.batches} at least, holding {args.min_updates} updates at least\n")
    print(report["table"], flush=True)
    rendered = sorted({name for result in report["results"] for each in [result, *result.get("results", [])]
                       for name in each.get("renderers", [])})
    print(f"\nMuJoCo rendered with: {', '.join(rendered) or 'not reported'}", flush=True)
    return 0 if report["status"] == "passed" else 1


if __name__ == "__main__":
    sys.exit(main())

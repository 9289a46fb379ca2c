"""The device check: install what travelled, then the GPU figures in tiers, most important first, within one call.

Run through ``bash benchmarks/gpu_check.sh`` (which starts the clock) from a fresh copy of the repository
with the folder ``python scripts/gpu_carry.py`` builds (``.gpu-carry/``) beside it. It

0. installs: checks the carry folder against its manifest, unpacks the GL loader where the machine
   has no ``libEGL.so.1``, installs the wheels with ``pip --target`` into a temporary folder (torch
   stays the machine's own), unzips the trimmed dm-control there, then imports every module that
   travelled and vigen, and (not ``--dry``) checks that CUDA and MuJoCo's EGL work. Anything missing
   stops the check here, within a minute, naming it;
1. the device tests: ``test/test_devices.py`` and the CUDA cases of ``test/losses/test_update.py``;
2. DrQ-v2 and SVEA, eager and compiled (and captured as a CUDA graph), against the same-math
   reference: ``benchmarks/losses.py --algos drqv2 svea --compile``;
3. one minute of end-to-end training: ``examples/train.py`` (DrQ-v2, walker-walk, batch 256), its
   environment frames/s and updates/s read from the run's logs while it trains, then stopped;
4. the other losses as in tier 2, as many as the time left allows;
5. (only when asked, ``--tiers 5``) the training throughput: ``benchmarks/train_throughput.py --gpu``,
   walker-walk at batch 256 with 1/4/8 env workers, serial and overlapped collection, the replay
   sampled on the GPU (and today's memory-mapped baseline): frames/s, updates/s, the GPU's busy
   share and each stage's time, in the time left before the deadline (``--quick`` when ``--dry``);
   ``--throughput-args "--gpu --configs 8/overlap/compiled/device@130 1@50"`` picks configurations in order;
6. (when asked) every loss in one tier: ``benchmarks/losses.py --compile --jobs 15``, the twelve losses and the captured
   DrQ-v2 learner (with TF32, and bf16) compiled in parallel processes, then each timed alone against its reference;
7. (when asked) ``benchmarks/update_gap.py``: the eager DrQ-v2 update under each of ``train.py``'s conditions in turn.

``--call e2e`` and ``--call learner`` are issue 48's two calls (tiers 5; then 1, 7, 6), each with its deadline
(540 s, 560 s): docs/performance.md says how to run them.

Each tier has a time budget and the whole check stops itself at ``--deadline`` seconds (default 450,
install included, counted from when ``gpu_check.sh`` started), keeping what finished. It writes, under
``--out`` (default ``$OUT``, else ``gpu-check/``): ``figures.json`` (rewritten atomically after each
tier: device, torch and CUDA versions, the commit, per tier its status, seconds and figures) and
``logs/<stage>.log``, each command's full output. That is at most 6 files, within the device tool's 8.

``--dry`` runs the same stages on the CPU at tiny sizes in seconds (``test/benchmarks/test_gpu_check.py``
runs it); ``--carry none`` uses the current environment instead of installing.
"""

from __future__ import annotations

import argparse
import ast
import csv
import datetime
import hashlib
import json
import os
import platform
import shlex
import shutil
import signal
import statistics
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ElementTree
import zipfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
RESERVE_S = 5  # kept back from the deadline to stop the last command and write the figures
TIERS = {1: "device tests", 2: "drqv2 and svea against the reference", 3: "end-to-end training", 4: "the other losses",
         5: "training throughput", 6: "every loss, compiled in parallel", 7: "the eager update inside train.py"}
DEFAULT_TIERS = [1, 2, 3, 4]  # tiers 5 to 7 run when asked (--tiers, or a --call)
THROUGHPUT_E2E = ("--gpu --configs 8/overlap/compiled/device@180 8/overlap/device@60 1/overlap@50 1/overlap*4@90 "
                  "1/overlap*8@100")
CALLS = {  # issue 48's two device calls, the end-to-end one first: (tiers, deadline s, tier 5's flags, and --dry's)
    "e2e": ([5], 540, THROUGHPUT_E2E, "--quick --configs 2/overlap/device 1/overlap*2"),
    "learner": ([1, 7, 6], 560, None, None),
}
ALSO = ["drqv2 --captured", "drqv2 --captured --tf32 on", "drqv2 --captured --tf32 on --precision bf16"]
"""Tier 6's DrQ-v2 processes, timed first: the captured learner (sampling inside the graph), with TF32, with TF32 and bf16.
Channels-last against NCHW weights is tier 7's A against B."""
MIN_BATCHES = 3  # tier 3 trains until this many batches of updates are logged (frames/s needs two intervals at least)
INSTALL_S = 60  # the pip install, and then the imports, each stop there: a missing piece is named within a minute
BUDGET_S = {"gpu": {1: 120, 2: 200, 3: 100, 4: None, 5: None, 6: None, 7: 60},  # seconds per tier; None: what is left
            "dry": {1: 60, 2: 60, 3: 40, 4: 60, 5: 120, 6: 120, 7: 60}}
DRY_MODULES = ["torchrl", "tensordict", "mujoco", "dm_control", "gymnasium", "vigen"]  # --carry none: the environment's
PREFLIGHT = r"""
import importlib, json, os, sys, traceback
modules, dry = json.loads(sys.argv[1]), sys.argv[2] == "dry"
failed = {}
for name in modules:
    try:
        importlib.import_module(name)
    except BaseException as error:
        failed[name] = f"{type(error).__name__}: {error}"
        traceback.print_exc()
import torch
info = {"python": sys.version.split()[0], "torch": torch.__version__, "cuda": torch.version.cuda,
        "cuda_available": torch.cuda.is_available(), "failed_imports": failed}
info["device"] = torch.cuda.get_device_name(0) if torch.cuda.is_available() else "cpu"
import importlib.metadata
for name in ("torchrl", "tensordict", "mujoco", "dm-control", "numpy"):
    try:
        info[name] = importlib.metadata.version(name)
    except importlib.metadata.PackageNotFoundError:
        info[name] = None
if not dry:
    try:
        import mujoco
        context = mujoco.GLContext(16, 16)
        context.make_current()
        context.free()
        info["egl"] = "ok"
    except BaseException as error:
        info["egl"] = f"{type(error).__name__}: {error}"
        traceback.print_exc()
print("PREFLIGHT " + json.dumps(info))
"""


class Failed(Exception):
    """A stage that cannot go on; its message names what is missing and the fix."""


def now_iso() -> str:
    return datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")


def write_json(path: Path, data: dict) -> None:
    """Atomically: a check killed while writing leaves the previous figures, never half a file."""
    with tempfile.NamedTemporaryFile("w", dir=path.parent, prefix=f".{path.name}.", suffix=".tmp", delete=False) as tmp:
        json.dump(data, tmp, indent=1)
    os.replace(tmp.name, path)


def git_state(carry: dict | None) -> dict:
    """The commit checked: git's where the copy has .git, else the one the carry folder was built at (said so)."""
    def git(*args: str) -> str | None:
        try:
            result = subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True, timeout=10)
        except (OSError, subprocess.TimeoutExpired):
            return None
        return result.stdout.strip() if result.returncode == 0 else None
    commit = git("rev-parse", "HEAD")
    if commit:
        state = {"commit": commit, "dirty": bool(git("status", "--porcelain", "--untracked-files=no")), "from": "git"}
        if carry and carry.get("commit") and carry["commit"] != commit:
            # seen on the device tool's copy (2026-11-28): its .git named an older commit than the tree it carried
            state["carry_commit"] = carry["commit"]
            state["note"] = ("the copy's .git and the carry folder name different commits; the carry folder was "
                             "built from the tree that was sent, so its commit is likely the one checked")
        return state
    if carry and carry.get("commit"):
        return {"commit": carry["commit"], "dirty": carry.get("dirty"), "from": "the carry folder's MANIFEST.json"}
    return {"commit": None, "dirty": None, "from": "unknown: no .git and no carry manifest"}


class Clock:
    def __init__(self, t0: float, deadline_s: float) -> None:
        self.t0, self.deadline = t0, t0 + deadline_s

    def elapsed(self) -> float:
        return time.time() - self.t0

    def left(self) -> float:
        return self.deadline - RESERVE_S - time.time()


def run_logged(command: list[str], log: Path, env: dict, timeout: float, cwd: Path = ROOT) -> tuple[int | None, float]:
    """Run ``command`` with its whole output appended to ``log``; (exit status or None if stopped at ``timeout``, seconds)."""
    started = time.time()
    with log.open("a") as out:
        out.write(f"\n$ {' '.join(command)}\n")
        out.flush()
        process = subprocess.Popen(command, cwd=cwd, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        try:
            return process.wait(timeout=max(timeout, 0.1)), time.time() - started
        except subprocess.TimeoutExpired:
            stop(process)
            out.write(f"\n[gpu_check] stopped after {time.time() - started:.0f} s: the time budget ran out\n")
            return None, time.time() - started


def stop(process: subprocess.Popen, term_wait: float = 5) -> None:
    """End a command and everything it started (its own process group): SIGTERM, ``term_wait`` s, then SIGKILL."""
    for sig, wait in ((signal.SIGTERM, term_wait), (signal.SIGKILL, 5)):
        try:
            os.killpg(process.pid, sig)
        except ProcessLookupError:
            return
        try:
            process.wait(timeout=wait)
            return
        except subprocess.TimeoutExpired:
            continue


def sha256(path: Path) -> str:
    digest = hashlib.sha256()
    with path.open("rb") as file:
        for block in iter(lambda: file.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def have_library(name: str) -> bool:
    try:
        listed = subprocess.run(["ldconfig", "-p"], capture_output=True, text=True, timeout=10).stdout
    except (OSError, subprocess.TimeoutExpired):
        return False
    return name in listed


def install(args: argparse.Namespace, site: Path, log: Path, clock: Clock) -> tuple[dict, dict, dict | None]:
    """(the environment the tiers run in, what the install found, the carry manifest); raises Failed naming what is missing."""
    env = {**os.environ, "PYTHONUNBUFFERED": "1", "MUJOCO_GL": os.environ.get("MUJOCO_GL", "egl")}
    info: dict = {}
    manifest = None
    paths = [str(ROOT)]
    if args.carry is not None:
        carry = args.carry
        rebuild = ("build it on a development machine with `python scripts/gpu_carry.py` and name it in the device "
                   f"call's carry (carry=[\"{carry.relative_to(ROOT) if carry.is_relative_to(ROOT) else carry}\"])")
        if not (carry / "MANIFEST.json").is_file():
            raise Failed(f"no carry folder at {carry} (its MANIFEST.json is missing): {rebuild}")
        manifest = json.loads((carry / "MANIFEST.json").read_text())
        entries = [*manifest["wheels"], manifest["dm_control"], *manifest["gl"]]
        missing = [entry["file"] for entry in entries if not (carry / entry["file"]).is_file()]
        if missing:
            raise Failed(f"missing from the carry folder {carry}: {', '.join(missing)}; {rebuild}")
        damaged = [entry["file"] for entry in entries if sha256(carry / entry["file"]) != entry["sha256"]]
        if damaged:
            raise Failed(f"damaged in the carry folder {carry} (sha256 differs from MANIFEST.json): {', '.join(damaged)}; {rebuild}")
        info["carry"] = {"folder": str(carry), "built": manifest.get("built"), "wheels": len(manifest["wheels"]),
                         "bytes": sum(entry["bytes"] for entry in entries)}
        if not args.dry and not (have_library("libEGL.so.1") and have_library("libOpenGL.so.0")):
            debs = [str(carry / entry["file"]) for entry in manifest["gl"]]
            if os.geteuid() == 0:  # the recipe that ran on the lent machine: unpack into / and refresh the linker's cache
                for deb in debs:
                    if run_logged(["dpkg", "-x", deb, "/"], log, env, 30)[0] != 0:
                        raise Failed(f"dpkg -x {deb} / failed (see logs/install.log)")
                run_logged(["ldconfig"], log, env, 30)
            else:
                for deb in debs:
                    if run_logged(["dpkg", "-x", deb, str(site / "gl")], log, env, 30)[0] != 0:
                        raise Failed(f"dpkg -x {deb} failed (see logs/install.log)")
                env["LD_LIBRARY_PATH"] = ":".join(filter(None, [str(site / "gl/usr/lib/x86_64-linux-gnu"), env.get("LD_LIBRARY_PATH")]))
            info["gl"] = "unpacked " + ", ".join(Path(deb).name for deb in debs)
        vendor = Path("/usr/local/nvidia/share/glvnd/egl_vendor.d/10_nvidia.json")
        if vendor.is_file():
            env.setdefault("__EGL_VENDOR_LIBRARY_FILENAMES", str(vendor))
        wheels = [str(carry / entry["file"]) for entry in manifest["wheels"]]
        code, seconds = (0, 0.0) if not wheels else run_logged([args.python, "-m", "pip", "install", "-q", "--no-index", "--no-deps", "--no-compile",
                                    "--no-cache-dir", "--upgrade", "--target", str(site / "lib"), *wheels],
                                   log, env, min(INSTALL_S, clock.left()))
        if code != 0:
            raise Failed(f"pip install of the carried wheels {'ran out of time' if code is None else 'failed'} "
                         f"(see logs/install.log)")
        with zipfile.ZipFile(carry / manifest["dm_control"]["file"]) as archive:
            archive.extractall(site / "lib")
        info["pip_install_s"] = round(seconds, 1)
        paths.insert(0, str(site / "lib"))
        modules = manifest["modules"]
    else:
        modules = DRY_MODULES
        info["carry"] = None
    env["PYTHONPATH"] = os.pathsep.join(filter(None, [*paths, os.environ.get("PYTHONPATH")]))
    with log.open("a") as out:
        out.write(f"\n$ preflight: import {' '.join(modules)}\n")
        out.flush()
        try:
            result = subprocess.run([args.python, "-c", PREFLIGHT, json.dumps(modules), "dry" if args.dry else "gpu"], cwd=ROOT,
                                    env=env, stdout=subprocess.PIPE, stderr=out, text=True, timeout=max(1.0, min(INSTALL_S, clock.left())))
        except subprocess.TimeoutExpired:
            raise Failed("importing the modules that travelled took over a minute (see logs/install.log)") from None
        out.write(result.stdout)
    lines = [line for line in result.stdout.splitlines() if line.startswith("PREFLIGHT ")]
    if not lines:
        raise Failed(f"{args.python} could not import torch (exit {result.returncode}; see logs/install.log)")
    found = json.loads(lines[-1].removeprefix("PREFLIGHT "))
    info.update(found)
    if found["failed_imports"]:
        names = "; ".join(f"{name} ({why})" for name, why in found["failed_imports"].items())
        raise Failed(f"cannot import {names}: rebuild the carry folder (python scripts/gpu_carry.py) "
                     "or install the package (see logs/install.log)")
    if not args.dry and not found["cuda_available"]:
        raise Failed(f"torch {found['torch']} sees no CUDA device: run the check on the GPU machine, or --dry on a CPU")
    if not args.dry and found.get("egl") != "ok":
        raise Failed(f"MuJoCo cannot open an EGL context ({found.get('egl')}): the GL loader (carry's gl/*.deb) and "
                     "__EGL_VENDOR_LIBRARY_FILENAMES are what it needs (see logs/install.log)")
    return env, info, manifest


def pytest_figures(junit: Path) -> dict:
    if not junit.is_file():
        return {}
    root = ElementTree.parse(junit).getroot()
    suites = [root] if root.tag == "testsuite" else list(root.iter("testsuite"))
    count = {key: sum(int(suite.get(key, 0)) for suite in suites) for key in ("tests", "failures", "errors", "skipped")}
    failed = []
    for case in root.iter("testcase"):
        for problem in (*case.findall("failure"), *case.findall("error")):
            failed.append({"test": f"{case.get('classname')}::{case.get('name')}", "message": (problem.get("message") or "")[:500]})
    return {"passed": count["tests"] - count["failures"] - count["errors"] - count["skipped"], "failed": count["failures"],
            "errors": count["errors"], "skipped": count["skipped"], "failures": failed}


def number(cell: str) -> float | str:
    text = cell.strip().rstrip("×%").strip()
    try:
        return float(text)
    except ValueError:
        return cell.strip()


def table_rows(log: Path) -> list[dict]:
    """The rows of the tables ``benchmarks/losses.py`` printed under its ``| algo |`` header, warnings between them skipped."""
    rows, header = [], None
    for line in log.read_text(errors="replace").splitlines():
        cells = [cell.strip() for cell in line.strip().strip("|").split("|")]
        if line.startswith("| algo |"):
            header = cells
        elif header and line.startswith("| ") and len(cells) == len(header):  # the profiles' tables have 3 columns
            rows.append({name: number(cell) for name, cell in zip(header, cells)})
    return rows


def losses_tier(args: argparse.Namespace, algos: list[str], log: Path, env: dict, timeout: float) -> dict:
    """``benchmarks/losses.py`` once per algorithm (one that fails, e.g. does not compile, does not stop the others)."""
    sizes = ["--batch", "2", "--repeats", "1"] if args.dry else ["--batch", "256", "--repeats", "10", "--compile"]
    command = [args.python, "benchmarks/losses.py", "--device", args.device, *sizes, "--algos"]
    ends = time.time() + timeout
    failed, stopped = [], False
    for algo in algos:
        if ends - time.time() < 5:
            break
        code, _ = run_logged([*command, algo], log, env, ends - time.time())
        if code is None:
            stopped = True
            break
        if code != 0:
            failed.append(algo)
    rows = table_rows(log)
    done = [row.get("algo") for row in rows]
    figures = {"command": " ".join(["python", *command[1:], "ALGO"]), "rows": rows, "failed": failed,
               "not_reached": [algo for algo in algos if algo not in done and algo not in failed]}
    status = "failed" if failed else "timed_out" if stopped or figures["not_reached"] else "passed"
    return {"status": status, "figures": figures}


def read_scalars(path: Path) -> list[tuple[float, float]]:
    if not path.is_file():
        return []
    with path.open() as file:
        return [(float(row[0]), float(row[1])) for row in csv.reader(file) if len(row) >= 2]


def training_tier(args: argparse.Namespace, log: Path, env: dict, timeout: float, scratch: Path) -> dict:
    """examples/train.py until ``--train-seconds`` after its first logged batch of updates (and MIN_BATCHES batches logged);
    figures from its own logs."""
    run_dir = scratch / "train"
    if args.dry:
        sizes = ["--env", "dmc/cartpole-balance", "--image-size", "32", "--hidden-dim", "32", "--feature-dim", "8",
                 "--batch-size", "8", "--buffer-size", "2000", "--seed-frames", "400", "--threads", "1"]
    else:
        sizes = ["--env", "dmc/walker-walk", "--preset", "paper", "--buffer-size", "100000", "--seed-frames", "2000"]
    command = [args.python, "examples/train.py", "--algo", "drqv2", "--device", args.device, *sizes,
               "--frames", "10000000", "--eval-every", "10000000", "--eval-episodes", "1", "--out", str(run_dir)]
    scalars = run_dir / "logs" / "scalars" / "train" / "seconds_per_update.csv"
    started = time.time()
    points: list[tuple[float, float]] = []  # (seconds since start, environment frames) when each update batch was logged
    seen = 0
    with log.open("a") as out:
        out.write(f"\n$ {' '.join(command)}\n")
        out.flush()
        process = subprocess.Popen(command, cwd=ROOT, env=env, stdout=out, stderr=subprocess.STDOUT, start_new_session=True)
        while True:
            code = process.poll()
            rows = read_scalars(scalars)
            for frames, _ in rows[seen:]:
                points.append((time.time() - started, frames))
            seen = len(rows)
            elapsed = time.time() - started
            trained = len(points) >= MIN_BATCHES and elapsed - points[0][0] >= args.train_seconds
            if code is not None or elapsed >= timeout or trained:
                break
            time.sleep(0.2)
        stopped_by_budget = code is None and not trained
        if code is None:
            stop(process)
            out.write(f"\n[gpu_check] stopped after {elapsed:.0f} s"
                      f"{': the time budget ran out' if stopped_by_budget else f' ({args.train_seconds:g} s of training)'}\n")
    per_update = [value for _, value in read_scalars(scalars)]
    figures: dict = {"command": " ".join(["python", *command[1:]]), "logged_batches": len(points)}
    if points:
        figures["seconds_to_first_update"] = round(points[0][0], 1)
        figures["frames"] = points[-1][1]
    if len(points) >= 2:
        (t0, f0), (t1, f1) = points[0], points[-1]
        figures.update(window_s=round(t1 - t0, 1), frames_per_s=round((f1 - f0) / (t1 - t0), 1),
                       updates_per_s=round(1 / statistics.median(per_update), 1), seconds_per_update=statistics.median(per_update))
    compile_seconds = read_scalars(run_dir / "logs" / "scalars" / "train" / "compile_seconds.csv")
    if compile_seconds:
        figures["compile_s"] = compile_seconds[0][1]
    if code not in (None, 0):
        status = "failed"
    elif len(points) < 2:
        status = "timed_out" if stopped_by_budget else "failed"
    else:
        status = "timed_out" if stopped_by_budget else "passed"
    return {"status": status, "figures": figures, "exit_code": code}


def throughput_tier(args: argparse.Namespace, log: Path, env: dict, timeout: float, scratch: Path) -> dict:
    """``benchmarks/train_throughput.py --gpu`` (``--quick`` when dry), stopping itself before ``timeout``; its figures and
    table into figures.json, its runs' output appended to the tier's log."""
    out = scratch / "throughput"
    chosen = shlex.split(args.throughput_args) if args.throughput_args else ["--quick" if args.dry else "--gpu"]
    command = [args.python, "benchmarks/train_throughput.py", *chosen, "--out", str(out), "--deadline", str(round(max(timeout - 15, 10)))]
    code, _ = run_logged(command, log, env, timeout)
    report = json.loads((out / "train_throughput.json").read_text()) if (out / "train_throughput.json").is_file() else {}
    if (out / "train_logs.txt").is_file():
        with log.open("a") as whole:
            whole.write("\n[gpu_check] the output of each examples/train.py run:\n")
            whole.write((out / "train_logs.txt").read_text(errors="replace"))
    figures = {"command": " ".join(["python", *command[1:-4]]), "table": report.get("table"),
               "results": [{key: result.get(key) for key in ("name", "runs", "status", "reason", "seconds", "figures", "rows")
                            if key in result or key != "runs"}
                           | ({"each_run": [{key: run.get(key) for key in ("seed", "status", "exit_code", "figures")}
                                            for run in result["results"]]} if "results" in result else {})
                           for result in report.get("results", [])]}
    status = "timed_out" if code is None else "passed" if code == 0 else "timed_out" if report.get("status") == "incomplete" else "failed"
    return {"status": status, "figures": figures, "exit_code": code}


def all_losses_tier(args: argparse.Namespace, log: Path, env: dict, timeout: float, scratch: Path) -> dict:
    """``benchmarks/losses.py --jobs``: every loss compiled in parallel processes, then each timed alone against its reference
    (and DrQ-v2 with the GPU learner's options, ``ALSO``); the losses.py run stops itself before ``timeout``."""
    algos = ast.literal_eval((ROOT / "benchmarks" / "losses.py").read_text().split("\nALGOS = ", 1)[1].split("\n")[0])
    if args.dry:
        sizes, algos, also = ["--batch", "2", "--repeats", "1", "--jobs", "2"], ["drqv2", "drq"], ["drqv2 --captured --channels-last off"]
    else:
        sizes, also = ["--batch", "256", "--repeats", "10", "--compile", "--jobs", str(len(algos) + len(ALSO))], ALSO
    command = [args.python, "benchmarks/losses.py", "--device", args.device, *sizes,
               "--deadline", str(round(max(timeout - 15, 10))), "--cache-dir", str(scratch / "inductor"),
               "--save-cache", str(scratch / "cache-artifacts" / "losses"), "--algos", *algos, "--also", *also]
    code, _ = run_logged(command, log, env, timeout)
    rows = table_rows(log)
    done = {row.get("algo") for row in rows}
    summary = [line for line in log.read_text(errors="replace").splitlines() if line.startswith(("--jobs ", "## "))]
    figures = {"command": " ".join(["python", *command[1:]]), "rows": rows, "summary": summary,
               "not_reached": [algo for algo in algos if algo not in done],
               "cache_artifacts": [line for line in log.read_text(errors="replace").splitlines()
                                   if line.startswith("save_cache_artifacts")]}
    status = "timed_out" if code is None or figures["not_reached"] else "passed" if code == 0 else "failed"
    return {"status": status, "figures": figures, "exit_code": code}


def gap_tier(args: argparse.Namespace, log: Path, env: dict, timeout: float, scratch: Path) -> dict:
    """``benchmarks/update_gap.py``: the eager DrQ-v2 update under each of train.py's conditions in turn."""
    out = scratch / "update_gap.json"
    command = [args.python, "benchmarks/update_gap.py", *(["--quick"] if args.dry else ["--device", args.device]), "--json", str(out)]
    code, _ = run_logged(command, log, env, timeout)
    report = json.loads(out.read_text()) if out.is_file() else {}
    figures = {"command": " ".join(["python", *command[1:-2]]), "rows": report.get("rows", [])}
    status = "timed_out" if code is None else "passed" if code == 0 else "failed"
    return {"status": status, "figures": figures, "exit_code": code}


def device_tests_tier(args: argparse.Namespace, log: Path, env: dict, timeout: float, scratch: Path) -> dict:
    junit = scratch / "device-tests.xml"
    select = "(test_devices or cuda) and drqv2 and not evaluation" if args.dry else "test_devices or cuda"
    command = [args.python, "-m", "pytest", "-v", "--tb=long", "-p", "no:cacheprovider", f"--junitxml={junit}",
               "test/test_devices.py", "test/losses/test_update.py", "test/test_cuda_graph.py", "test/run/test_sampled_update.py",
               "-k", select]
    code, _ = run_logged(command, log, env, timeout)
    figures = {"command": " ".join(["python", *command[1:]]), **pytest_figures(junit)}
    status = "timed_out" if code is None else "passed" if code == 0 else "failed"
    return {"status": status, "figures": figures, "exit_code": code}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--dry", action="store_true", help="on the CPU at tiny sizes, in seconds (the test of this script)")
    parser.add_argument("--carry", default=str(ROOT / ".gpu-carry"),
                        help="the folder scripts/gpu_carry.py built (default .gpu-carry); 'none': use this environment as it is")
    parser.add_argument("--out", type=Path, default=Path(os.environ.get("OUT") or ROOT / "gpu-check"))
    parser.add_argument("--deadline", type=float, default=None, help="seconds for everything, install included "
                        "(default 450: under 8 minutes; --dry 300), counted from GPU_CHECK_T0 (set by gpu_check.sh)")
    parser.add_argument("--tiers", type=int, nargs="+", default=None, choices=sorted(TIERS),
                        help="which tiers, in this order (default 1 2 3 4; 5 to 7 run when named)")
    parser.add_argument("--call", choices=sorted(CALLS), default=None,
                        help="issue 48's device calls: e2e (tier 5: the 8-worker runs, compiled first, and 1, 4 and 8 runs "
                             "sharing the machine; deadline 540 s) first, then learner (tiers 1, 7, 6: the device tests, the "
                             "eager update's gap, every loss compiled in parallel; deadline 560 s)")
    parser.add_argument("--train-seconds", type=float, default=None, help="tier 3's training, from its first update (60; --dry 3)")
    parser.add_argument("--python", default=sys.executable, help="the interpreter whose torch is checked (default this one)")
    parser.add_argument("--throughput-args", default=None, help="tier 5: benchmarks/train_throughput.py's flags instead of "
                        "--gpu (--quick when --dry), as one string, e.g. \"--gpu --workers 8 --collection overlap --updates compiled "
                        "--replay device --timeout 140\"")
    args = parser.parse_args()
    args.carry = None if args.carry == "none" else Path(args.carry).resolve()
    args.device = "cpu" if args.dry else "cuda"
    if args.call is not None:
        if args.tiers is not None:
            parser.error("--call names its tiers; leave out --tiers")
        args.tiers, deadline, throughput, dry_throughput = CALLS[args.call]
        args.deadline = args.deadline or (None if args.dry else deadline)
        args.throughput_args = args.throughput_args or (dry_throughput if args.dry else throughput)
    args.tiers = args.tiers or DEFAULT_TIERS
    args.deadline = args.deadline or (300 if args.dry else 450)
    args.train_seconds = args.train_seconds or (3 if args.dry else 60)
    clock = Clock(float(os.environ.get("GPU_CHECK_T0") or time.time()), args.deadline)
    budgets = BUDGET_S["dry" if args.dry else "gpu"]
    out = args.out.resolve()
    (out / "logs").mkdir(parents=True, exist_ok=True)
    figures_path = out / "figures.json"
    report: dict = {
        "schema": 1, "started": now_iso(), "dry": args.dry, "host": platform.node(), "deadline_s": args.deadline,
        "command": "bash benchmarks/gpu_check.sh " + " ".join(sys.argv[1:]),
        "git": None, "python": None, "torch": None, "cuda": None, "device": None,
        "install": {"status": "running", "seconds": None, "log": "logs/install.log"},
        "tiers": [{"tier": tier, "name": TIERS[tier], "status": "pending", "seconds": None, "budget_s": budgets[tier],
                   "log": f"logs/tier{tier}.log", "figures": {}} for tier in args.tiers],
        "status": "running", "seconds": None,
    }
    scratch = Path(tempfile.mkdtemp(prefix="vigen-gpu-check-"))  # the install, pytest's XML, the training run
    try:
        return check(args, clock, budgets, report, figures_path, scratch, out)
    finally:
        shutil.rmtree(scratch, ignore_errors=True)


def check(args: argparse.Namespace, clock: Clock, budgets: dict, report: dict, figures_path: Path, scratch: Path,
          out: Path) -> int:
    def save(status: str | None = None) -> None:
        report["seconds"] = round(clock.elapsed(), 1)
        if status:
            report["status"] = status
        write_json(figures_path, report)

    started = clock.elapsed()
    try:
        env, info, manifest = install(args, scratch / "site", out / "logs" / "install.log", clock)
    except Failed as error:
        report["git"] = git_state(None)
        report["install"].update(status="failed", seconds=round(clock.elapsed() - started, 1), error=str(error))
        for tier in report["tiers"]:
            tier["status"] = "skipped"
            tier["reason"] = "the install failed"
        save("failed")
        print(f"gpu_check: install failed after {clock.elapsed():.0f} s: {error}", file=sys.stderr)
        return 2
    report["git"] = git_state(manifest)
    for key in ("python", "torch", "cuda", "device"):
        report[key] = info.pop(key)
    report["install"].update(status="passed", seconds=round(clock.elapsed() - started, 1), found=info)
    save()
    print(f"gpu_check: installed in {clock.elapsed():.0f} s; torch {report['torch']} (CUDA {report['cuda']}) on {report['device']}",
          flush=True)

    for entry in report["tiers"]:
        tier, log = entry["tier"], out / entry["log"]
        budget = budgets[tier]
        timeout = clock.left() if budget is None else min(budget, clock.left())
        if timeout < 10:
            entry.update(status="skipped", reason=f"no time left ({clock.left():.0f} s before the deadline)")
            save()
            continue
        entry["status"] = "running"
        save()
        started = time.time()
        if tier == 1:
            result = device_tests_tier(args, log, env, timeout, scratch)
        elif tier == 2:
            result = losses_tier(args, ["drqv2"] if args.dry else ["drqv2", "svea"], log, env, timeout)
        elif tier == 3:
            result = training_tier(args, log, env, timeout, scratch)
        elif tier == 5:
            result = throughput_tier(args, log, env, timeout, scratch)
        elif tier == 6:
            result = all_losses_tier(args, log, env, timeout, scratch)
        elif tier == 7:
            result = gap_tier(args, log, env, timeout, scratch)
        else:
            algos = ast.literal_eval((ROOT / "benchmarks" / "losses.py").read_text().split("\nALGOS = ", 1)[1].split("\n")[0])
            others = [algo for algo in algos if algo not in ("drqv2", "svea")]
            result = losses_tier(args, others[:1] if args.dry else others, log, env, timeout)
        entry.update(result, seconds=round(time.time() - started, 1), timeout_s=round(timeout, 1))
        save()
        print(f"gpu_check: tier {tier} ({entry['name']}): {entry['status']} in {entry['seconds']:.0f} s", flush=True)
    statuses = {entry["status"] for entry in report["tiers"]}
    save("passed" if statuses <= {"passed"} else "failed" if "failed" in statuses else "incomplete")
    print(f"gpu_check: {report['status']} in {clock.elapsed():.0f} s; figures in {figures_path}", flush=True)
    return 0 if report["status"] == "passed" else 1


if __name__ == "__main__":
    sys.exit(main())

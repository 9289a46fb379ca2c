"""The example scripts run in the test process: ``main(argv)`` does what ``python examples/<name>.py argv`` does.

A subprocess pays the interpreter's start and the imports of torch, TorchRL and vigen (about 6 s on a 2-core machine)
before the script's first line. Tests that need no process of their own (to kill it, or to start from a fresh global
state) call ``main`` here instead, with what it prints captured.
"""

from __future__ import annotations

import contextlib
import functools
import importlib.util
import io
import sys
from dataclasses import dataclass
from pathlib import Path
from types import ModuleType

import torch

ROOT = Path(__file__).resolve().parents[2]


@dataclass
class Finished:
    """What a script run left: its exit status and what it printed (the fields of ``subprocess.CompletedProcess``)."""

    returncode: int
    stdout: str
    stderr: str


@functools.cache
def load_example(name: str) -> ModuleType:
    """``examples/<name>.py`` as a module, once per process (registered in ``sys.modules``: tyro and dataclasses look the
    module up there)."""
    spec = importlib.util.spec_from_file_location(f"{name}_example_under_test", ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


def run_example(name: str, *args: str | Path) -> Finished:
    """``main(args)`` of ``examples/<name>.py`` with its output captured; a ``SystemExit`` becomes the exit status, as the
    interpreter would make it (a message goes to stderr and exits 1). torch's thread count and global random state,
    which a script sets (``--threads``, ``--seed``), are put back afterwards."""
    out, err = io.StringIO(), io.StringIO()
    code, threads, rng = 0, torch.get_num_threads(), torch.get_rng_state()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        try:
            load_example(name).main([str(arg) for arg in args])
        except SystemExit as stop:
            if isinstance(stop.code, str):
                err.write(stop.code + "\n")
            code = stop.code if isinstance(stop.code, int) else 0 if stop.code is None else 1
        finally:
            torch.set_num_threads(threads)
            torch.set_rng_state(rng)
    return Finished(code, out.getvalue(), err.getvalue())


def run(script: str, *args: str | Path) -> Finished:
    """``python examples/<script> args`` in this process (:func:`run_example`), which must exit 0."""
    result = run_example(script.removesuffix(".py"), *args)
    assert result.returncode == 0, result.stderr[-3000:]
    return result

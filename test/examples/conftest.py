"""The example scripts loaded as modules, so a test can call their ``main`` in this process.

A script's error paths stop before any work: calling ``main(argv)`` here checks the same message and exit as a
subprocess would, without paying the interpreter's start and torch's import again for each case.
"""

from __future__ import annotations

import importlib.util
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType

import pytest

ROOT = Path(__file__).resolve().parents[2]


def load_example(name: str) -> ModuleType:
    """``examples/<name>.py`` as a module (registered in ``sys.modules``: dataclasses look their module up there)."""
    spec = importlib.util.spec_from_file_location(f"{name}_example_under_test", ROOT / "examples" / f"{name}.py")
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module
    spec.loader.exec_module(module)
    return module


@pytest.fixture
def stopped(capsys: pytest.CaptureFixture[str]) -> Callable[[Callable[[list[str]], None], list[str]], str]:
    """``stopped(main, argv)``: what ``main(argv)`` says when it stops with a non-zero exit (its SystemExit message and
    what it printed to stderr); a run that does not stop fails the test."""

    def run(main: Callable[[list[str]], None], argv: list[str]) -> str:
        with pytest.raises(SystemExit) as stop:
            main([str(arg) for arg in argv])
        code = stop.value.code
        assert code not in (0, None), "the command was expected to stop with an error"
        return (code if isinstance(code, str) else "") + capsys.readouterr().err

    return run


@pytest.fixture(scope="module")
def train_script() -> Iterator[ModuleType]:
    module = load_example("train")
    yield module
    del sys.modules[module.__name__]


@pytest.fixture(scope="module")
def evaluate_script() -> Iterator[ModuleType]:
    module = load_example("evaluate")
    yield module
    del sys.modules[module.__name__]


@pytest.fixture(scope="module")
def gallery_script() -> Iterator[ModuleType]:
    module = load_example("gallery")
    yield module
    del sys.modules[module.__name__]

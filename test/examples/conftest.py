"""The example scripts loaded as modules (``in_process.py``), so a test can call their ``main`` in this process.

A script's error paths stop before any work: calling ``main(argv)`` here checks the same message and exit as a
subprocess would, without paying the interpreter's start and torch's import again for each case.
"""

from __future__ import annotations

from collections.abc import Callable
from types import ModuleType

import pytest
from in_process import load_example


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
def train_script() -> ModuleType:
    return load_example("train")


@pytest.fixture(scope="module")
def evaluate_script() -> ModuleType:
    return load_example("evaluate")


@pytest.fixture(scope="module")
def gallery_script() -> ModuleType:
    return load_example("gallery")

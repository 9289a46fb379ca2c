"""Shared fixtures: every test leaves the global RNGs as it found them."""

from __future__ import annotations

import random

import numpy as np
import pytest
import torch

import vigen  # noqa: F401  (selects MuJoCo's EGL backend before any test imports mujoco)


@pytest.fixture(autouse=True)
def prevent_leaking_rng():
    """Restore torch's, numpy's and Python's global RNG states after each test (as TorchRL's conftest does)."""
    torch_state = torch.get_rng_state()
    numpy_state = np.random.get_state()
    python_state = random.getstate()
    yield
    torch.set_rng_state(torch_state)
    np.random.set_state(numpy_state)
    random.setstate(python_state)

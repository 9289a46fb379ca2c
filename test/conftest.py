"""Shared fixtures: every test leaves the global RNGs as it found them."""

from __future__ import annotations

import random
import weakref

import numpy as np
import pytest
import torch
from torch.utils._pytree import tree_leaves

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


SYNCHRONIZING = frozenset({
    "__bool__", "__int__", "__float__", "__complex__", "__index__", "__array__", "item", "tolist", "numpy", "cpu",
    "nonzero", "argwhere", "masked_select", "unique", "unique_consecutive", "bincount", "equal", "allclose", "is_nonzero",
})
"""Tensor methods and torch functions that read values back to the host (on an accelerator: wait for every queued kernel)."""

MASK_INDEXED = frozenset({"__getitem__", "__setitem__", "index_put", "index_put_"})
"""Indexing calls whose index (their second argument) holds a boolean mask: the output size depends on values."""

FACTORIES = frozenset({"tensor", "as_tensor", "scalar_tensor", "zeros", "ones", "full", "empty", "arange", "linspace",
                       "eye", "rand", "randn", "randint", "randperm"})
"""torch functions that make a tensor; without ``device=`` they make it on the host, on a GPU machine too."""


def _holds_a_mask(value) -> bool:
    if isinstance(value, torch.Tensor):
        return value.dtype == torch.bool and value.ndim > 0
    if isinstance(value, (tuple, list)):
        return any(_holds_a_mask(item) for item in value)
    return False


class HostSyncDetector(torch.overrides.TorchFunctionMode):
    """Raises ``AssertionError`` at any torch call that would read a device tensor's values back to the host.

    A CPU stand-in for ``torch.cuda.set_sync_debug_mode("error")``: ``.item()``, ``bool()``/``int()``/``float()``
    of a tensor (a Python ``if`` on one), ``.tolist()``, ``.cpu()``, ``nonzero`` and every op whose output size
    depends on values (a boolean-mask index or assignment, ``masked_select``, ``unique``, one-argument
    ``torch.where``, ``repeat_interleave`` of tensor repeats without ``output_size``).

    Every tensor that exists when the mode starts (parameters, buffers, batches) counts as on the device.
    A tensor made inside it without ``device=`` (``torch.tensor(0.93)``) would be a host tensor on a GPU
    machine as well, and so is every result computed from host tensors only: reading those is free there,
    and allowed here.
    """

    def __init__(self) -> None:
        super().__init__()
        self._host: dict[int, weakref.ref] = {}

    def _on_host(self, tensor: torch.Tensor) -> bool:
        ref = self._host.get(id(tensor))
        return ref is not None and ref() is tensor

    def __torch_function__(self, func, types, args=(), kwargs=None):
        kwargs = kwargs or {}
        name = getattr(func, "__name__", repr(func))
        tensors = [leaf for leaf in tree_leaves((args, kwargs)) if isinstance(leaf, torch.Tensor)]
        on_host = bool(tensors) and all(self._on_host(tensor) for tensor in tensors)
        reads = name in SYNCHRONIZING or (name in MASK_INDEXED and len(args) > 1 and _holds_a_mask(args[1])) \
            or (name == "where" and len(args) + len(kwargs) == 1) \
            or (name == "repeat_interleave" and "output_size" not in kwargs
                and (len(args) == 1 or isinstance(kwargs.get("repeats", args[1] if len(args) > 1 else None), torch.Tensor)))
        if reads and not on_host:
            raise AssertionError(f"host synchronization: torch call {name!r} reads tensor values back to the host")
        out = func(*args, **kwargs)
        if "device" not in kwargs and (on_host or (name in FACTORIES and not tensors)):
            for leaf in tree_leaves(out):
                if isinstance(leaf, torch.Tensor):
                    self._host[id(leaf)] = weakref.ref(leaf)
        return out


@pytest.fixture
def no_host_sync():
    """``no_host_sync()``, a context manager: vigen's accelerator code paths (``vigen.devices.accelerator_paths``) with
    every read of a device tensor's values raising (:class:`HostSyncDetector`); ``accelerator=False`` keeps the CPU's."""
    import contextlib

    from vigen.devices import accelerator_paths

    @contextlib.contextmanager
    def detect(accelerator: bool = True):
        with accelerator_paths() if accelerator else contextlib.nullcontext(), HostSyncDetector():
            yield

    return detect

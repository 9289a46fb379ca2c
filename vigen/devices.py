"""One device for a whole run: ``--device auto|cpu|cuda|cuda:N|mps``, checked before anything is built; where reading
a tensor's values back to Python is free (:func:`host_reads_are_free`)."""

from __future__ import annotations

import contextlib
import contextvars
from collections.abc import Iterator

import torch
from torch import Tensor

DEVICE_CHOICES = "auto, cpu, cuda, cuda:N or mps"


def resolve_device(name: str | torch.device = "auto") -> torch.device:
    """The device ``name`` asks for, after checking that this machine has it.

    ``"auto"`` is the first CUDA device when CUDA is there, else the CPU. A device this machine
    lacks (``"cuda"`` without CUDA, ``"cuda:3"`` on a one-GPU machine, ``"mps"`` off Apple
    silicon) raises a ``ValueError`` that says what the machine has, before a run builds anything.

    Examples:
        >>> resolve_device("cpu")
        device(type='cpu')
        >>> resolve_device("auto") == (torch.device("cuda", 0) if torch.cuda.is_available() else torch.device("cpu"))
        True
        >>> resolve_device("gpu")
        Traceback (most recent call last):
        ...
        ValueError: device 'gpu' is not a device name; give auto, cpu, cuda, cuda:N or mps.
    """
    if isinstance(name, str) and name == "auto":
        return torch.device("cuda", 0) if torch.cuda.is_available() else torch.device("cpu")
    try:
        device = torch.device(name)
    except (RuntimeError, TypeError):
        raise ValueError(f"device {name!r} is not a device name; give {DEVICE_CHOICES}.") from None
    if device.type == "cpu":
        return torch.device("cpu")
    if device.type == "cuda":
        if not torch.cuda.is_available():
            raise ValueError(f"device {str(device)!r}: this machine has no CUDA device (torch {torch.__version__}, "
                             f"CUDA build: {torch.version.cuda or 'no'}); use --device cpu or auto.")
        count = torch.cuda.device_count()
        index = 0 if device.index is None else device.index
        if index >= count:
            raise ValueError(f"device {str(device)!r}: this machine has {count} CUDA device(s), cuda:0"
                             f"{f' to cuda:{count - 1}' if count > 1 else ''}; pick one of them.")
        return torch.device("cuda", index)
    if device.type == "mps":
        if not (getattr(torch.backends, "mps", None) is not None and torch.backends.mps.is_available()):
            raise ValueError("device 'mps': this machine has no Apple-silicon GPU; use --device cpu or auto.")
        return device
    raise ValueError(f"device {str(device)!r}: vigen runs on {DEVICE_CHOICES}.")


_ACCELERATOR_PATHS: contextvars.ContextVar[bool] = contextvars.ContextVar("vigen_accelerator_paths", default=False)


def host_reads_are_free(where: Tensor | torch.device) -> bool:
    """Whether reading a tensor's values back to Python costs nothing here: a CPU tensor, outside ``torch.compile``.

    ``.item()``, ``bool(tensor)``, a Python ``if`` on a tensor or a boolean-mask index read values
    back to the host. On the CPU that is free; on an accelerator it waits for every queued kernel
    (a host synchronization), and ``torch.compile`` cannot trace it. vigen's checks that read
    values (float-pixel ranges, a non-finite loss raised at once) and its shortcuts that branch on
    values (skipping work that a batch does not need) run only where this is ``True``; elsewhere
    they are left out or done with tensor ops. :func:`accelerator_paths` makes it ``False``
    everywhere, so a CPU test can run the accelerator's code.

    Examples:
        >>> import torch
        >>> host_reads_are_free(torch.zeros(2)), host_reads_are_free(torch.device("cuda"))
        (True, False)
        >>> with accelerator_paths():
        ...     host_reads_are_free(torch.zeros(2))
        False
    """
    if torch.compiler.is_compiling():
        return False
    device = where.device if isinstance(where, Tensor) else torch.device(where)
    return device.type == "cpu" and not _ACCELERATOR_PATHS.get()


@contextlib.contextmanager
def accelerator_paths() -> Iterator[None]:
    """Within it, vigen takes the code paths it takes on an accelerator, on any device (:func:`host_reads_are_free` is ``False``).

    For tests: a CPU run of an update under it, with a check that no value is read back to the
    host, proves the GPU's update free of host synchronizations on a machine without a GPU.
    Objects that decide once, when they are built (:class:`~vigen.losses.UpdateStep`'s guard),
    must be built inside it.
    """
    token = _ACCELERATOR_PATHS.set(True)
    try:
        yield
    finally:
        _ACCELERATOR_PATHS.reset(token)

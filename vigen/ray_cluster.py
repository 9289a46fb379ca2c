"""Join a Ray cluster, or start a local one that listens on 127.0.0.1 only, for the whole of a ``with`` block.

Ray is an optional extra (``pip install -e ".[ray]"``); vigen imports it only here and in the
Ray paths of :func:`~vigen.evaluation.evaluate` and ``examples/train.py --ray``.
"""

from __future__ import annotations

import contextlib
import os
from collections.abc import Iterator
from typing import Any

RAY_EXTRA = 'pip install -e ".[ray]"'
LOOPBACK_SWITCH = "RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER"
"""Ray's switch that, at 0, makes a node take 127.0.0.1 as its address on Linux too (as on macOS and Windows)."""


def import_ray() -> Any:
    """``import ray``, with an error that names the extra when it is not installed.

    Examples:
        >>> from vigen.ray_cluster import import_ray
        >>> import_ray().__name__
        'ray'
    """
    try:
        import ray
    except ImportError as error:
        raise ImportError(f"Ray is not installed; install vigen's Ray extra: {RAY_EXTRA}") from error
    return ray


@contextlib.contextmanager
def _on_loopback(ray: Any) -> Iterator[None]:
    """A node started in the block takes 127.0.0.1 as its address, here and in the processes it spawns.

    Ray reads its switch from the environment once, at import (TorchRL imports Ray early), and looks
    the value up when a node picks its address: the spawned processes get it from the environment,
    this process from the constant, which is put back afterwards.
    """
    constants = ray._private.ray_constants
    saved_env, saved_constant = os.environ.get(LOOPBACK_SWITCH), constants.ENABLE_RAY_CLUSTER
    os.environ[LOOPBACK_SWITCH], constants.ENABLE_RAY_CLUSTER = "0", False
    try:
        yield
    finally:
        constants.ENABLE_RAY_CLUSTER = saved_constant
        if saved_env is None:
            os.environ.pop(LOOPBACK_SWITCH)
        else:
            os.environ[LOOPBACK_SWITCH] = saved_env


def _is_loopback(address: str) -> bool:
    """Whether a cluster address (``host:port``, ``ray://host:port``) names this machine's loopback interface."""
    host = address.split("://")[-1].rsplit(":", 1)[0].strip("[]")
    return host in ("localhost", "::1") or host.startswith("127.")


@contextlib.contextmanager
def ray_session(address: str | None = None, *, num_cpus: int | None = None) -> Iterator[Any]:
    """Ray for the duration of the block: the running session, the cluster at ``address``, or a new local one.

    A session that is already initialised is used as it is (``address`` and ``num_cpus`` must then be
    ``None``); a cluster joined at ``address`` is left running; a local cluster started here is shut
    down at the end of the block. The local cluster has no dashboard and listens on 127.0.0.1 only.

    Args:
        address: a running cluster's address (``"ray://host:10001"``, ``"host:6379"`` or ``"auto"``);
            ``None`` starts a local one.
        num_cpus: CPUs the local cluster offers (default: the machine's).

    Yields:
        The ``ray`` module.

    Examples:
        >>> from vigen.ray_cluster import ray_session
        >>> with ray_session() as ray:  # a local cluster for the block (or the session already running)
        ...     ray.get(ray.remote(lambda: 1 + 1).remote())
        2
    """
    ray = import_ray()
    if ray.is_initialized():
        if address is not None or num_cpus is not None:
            raise RuntimeError("Ray is already initialised in this process; drop address and num_cpus to use that "
                               "session, or call ray.shutdown() first.")
        yield ray
        return
    if num_cpus is not None and (address is not None or num_cpus < 1):
        raise ValueError(f"num_cpus={num_cpus}: it sizes a new local cluster (>= 1) and cannot be given with an address.")
    options: dict[str, Any] = dict(include_dashboard=False, log_to_driver=False, configure_logging=False)
    # a new cluster ("local": never one found through RAY_ADDRESS or `ray start`) or one of this machine on
    # 127.0.0.1 takes the loopback address for this driver too
    loopback = address is None or _is_loopback(address)
    with _on_loopback(ray) if loopback else contextlib.nullcontext():
        ray.init(address="local" if address is None else address, num_cpus=num_cpus, **options)
    try:
        yield ray
    finally:
        ray.shutdown()

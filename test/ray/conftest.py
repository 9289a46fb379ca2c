"""One local Ray cluster for the Ray tests, on 127.0.0.1 only, started and stopped by the tests with bounded waits."""

from __future__ import annotations

import importlib.util

import pytest

if importlib.util.find_spec("ray") is None:  # not imported here: vigen imports it first, so the cluster binds to loopback
    pytest.skip("Ray is vigen's optional extra: pip install -e \".[ray]\"", allow_module_level=True)


@pytest.fixture(scope="package")
def ray_cluster():
    """A 2-CPU local cluster for the package's tests (the machine has 2 cores); shut down after the last test."""
    from vigen.ray_cluster import ray_session

    with ray_session(num_cpus=2) as session:
        yield session

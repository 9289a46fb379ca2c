"""vigen.ray_cluster: the local cluster listens on loopback only, joins a running session, and names the extra when Ray is missing."""

from __future__ import annotations

import subprocess
import sys

import pytest

from vigen.ray_cluster import import_ray, ray_session


def test_the_local_cluster_listens_on_loopback_only(ray_cluster):
    assert [node["NodeManagerAddress"] for node in ray_cluster.nodes()] == ["127.0.0.1"]
    assert ray_cluster.cluster_resources()["CPU"] == 2


def test_a_running_session_is_used_as_it_is_and_left_running(ray_cluster):
    with ray_session() as session:
        assert session.get(session.remote(lambda: 3).remote()) == 3
    assert ray_cluster.is_initialized()
    with pytest.raises(RuntimeError, match="already initialised"):
        with ray_session(num_cpus=1):
            pass


@pytest.mark.timeout(180)
def test_another_driver_joins_the_cluster_at_its_address_and_leaves_it_running(ray_cluster):
    address = ray_cluster.get_runtime_context().gcs_address
    assert address.startswith("127.0.0.1:")
    code = ("from vigen.ray_cluster import ray_session\n"
            f"with ray_session({address!r}) as ray:\n"
            "    print(ray.get(ray.remote(lambda: 40 + 2).remote()), ray.get_runtime_context().gcs_address)\n")
    joined = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=150)
    assert joined.returncode == 0, joined.stderr[-2000:]
    assert joined.stdout.split() == ["42", address], "the task ran on this cluster, not on a new one"
    assert ray_cluster.get(ray_cluster.remote(lambda: 1).remote()) == 1, "the cluster still runs after the driver left"


def test_a_missing_ray_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # what `import ray` sees when Ray is not installed
    with pytest.raises(ImportError, match=r'pip install -e "\.\[ray\]"'):
        import_ray()

"""vigen.ray_cluster: the local cluster listens on loopback only, joins a running session, and names the extra when Ray is missing."""

from __future__ import annotations

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


def test_a_missing_ray_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "ray", None)  # what `import ray` sees when Ray is not installed
    with pytest.raises(ImportError, match=r'pip install -e "\.\[ray\]"'):
        import_ray()

"""Doctest collection over the package (modules of an extra that is not installed are skipped: their tests skip with the
reason), and the test run's parallel workers (``scripts/test.sh`` runs pytest-xdist, one worker per core)."""

import importlib.util
import os

import pytest

collect_ignore = [] if importlib.util.find_spec("ray") else ["vigen/ray_cluster.py", "vigen/evaluation/ray_backend.py"]

RAY_PATHS = ("test/ray/", "vigen/ray_cluster.py", "vigen/evaluation/ray_backend.py")


def pytest_configure(config: pytest.Config) -> None:
    """Each xdist worker gets its share of the cores for torch's intra-op threads (two 2-thread workers on 2 cores crawl)."""
    workers = int(os.environ.get("PYTEST_XDIST_WORKER_COUNT", "1"))
    if workers > 1:
        import torch

        torch.set_num_threads(max(1, (os.cpu_count() or 1) // workers))


def pytest_collection_modifyitems(config: pytest.Config, items: list[pytest.Item]) -> None:
    """Tests that start a Ray cluster run in one worker, one after another (``--dist loadgroup``)."""
    for item in items:
        path = item.nodeid.split("::")[0]
        words = item.name.replace("[", "_").replace("-", "_").lower().split("_")
        if path.startswith(RAY_PATHS) or "ray" in words:
            item.add_marker(pytest.mark.xdist_group("ray"))

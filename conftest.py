"""Doctest collection over the package: modules of an extra that is not installed are skipped (their tests skip with the reason)."""

import importlib.util

collect_ignore = [] if importlib.util.find_spec("ray") else ["vigen/ray_cluster.py", "vigen/evaluation/ray_backend.py"]

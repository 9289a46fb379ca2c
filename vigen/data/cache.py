"""Where fetched data lives: the cache folder and each data set's folder in it."""

from __future__ import annotations

import os
from pathlib import Path

from vigen.data.records import DataSet


def cache_root(root: str | os.PathLike | None = None) -> Path:
    """The folder that holds every fetched data set (not created here).

    ``root`` if given, else ``$VIGEN_DATA``, else ``$XDG_CACHE_HOME/vigen`` (when that is an
    absolute path), else ``~/.cache/vigen``.

    Examples:
        >>> import os
        >>> from vigen.data import cache_root
        >>> str(cache_root("/scratch/vigen"))
        '/scratch/vigen'
        >>> cache_root() == cache_root(os.environ["VIGEN_DATA"]) if os.environ.get("VIGEN_DATA") else True
        True
    """
    if root is not None:
        return Path(root).expanduser()
    if os.environ.get("VIGEN_DATA"):
        return Path(os.environ["VIGEN_DATA"]).expanduser()
    xdg = os.environ.get("XDG_CACHE_HOME", "")
    if xdg and os.path.isabs(xdg):
        return Path(xdg) / "vigen"
    return Path.home() / ".cache" / "vigen"


def dataset_folder(dataset: DataSet, root: str | os.PathLike | None = None) -> Path:
    """``<cache root>/<data set name>``: the folder a data set is fetched into.

    Examples:
        >>> from vigen.data import get_dataset
        >>> from vigen.data.cache import dataset_folder
        >>> str(dataset_folder(get_dataset("dmcgb-videos"), "/scratch/vigen"))
        '/scratch/vigen/dmcgb-videos'
    """
    return cache_root(root) / dataset.name

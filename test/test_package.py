"""The package layout the design promises: rooms importable, version exposed."""

from __future__ import annotations

import importlib

import pytest

import vigen


def test_version():
    assert isinstance(vigen.__version__, str) and vigen.__version__.count(".") == 2


@pytest.mark.parametrize("room", ["vigen.envs", "vigen.transforms", "vigen.losses", "vigen.rendering", "vigen.models", "vigen.io"])
def test_rooms_import(room):
    importlib.import_module(room)

"""vigen's modules import each other without a cycle, at module level or through a deferred (in-function) import."""

from __future__ import annotations

import importlib.util
import sys
import textwrap
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
_spec = importlib.util.spec_from_file_location("vigen_import_graph", ROOT / "scripts" / "import_graph.py")
import_graph = sys.modules.setdefault(_spec.name, importlib.util.module_from_spec(_spec))
_spec.loader.exec_module(import_graph)


def test_vigen_has_no_import_cycle():
    imports = import_graph.import_graph(ROOT / "vigen")
    assert import_graph.cycles(imports, ("module",)) == [], import_graph.report(imports)[0]
    assert import_graph.cycles(imports, ("module", "deferred")) == [], import_graph.report(imports)[0]


def _package(tmp_path: Path, files: dict[str, str]) -> list:
    for name, text in files.items():
        path = tmp_path / "pkg" / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(textwrap.dedent(text))
    return import_graph.import_graph(tmp_path / "pkg")


def test_a_cycle_through_a_package_reexport_and_a_relative_import_is_found(tmp_path):
    """``from pkg.sub import name`` runs ``pkg/sub/__init__.py``, which imports the module that asked for it."""
    imports = _package(tmp_path, {
        "__init__.py": "",
        "sub/__init__.py": "from .records import Record\n",
        "sub/records.py": "from pkg.tables import TABLE\nRecord = 1\n",
        "tables.py": "from pkg.sub import Record\nTABLE = Record\n",
    })
    assert import_graph.cycles(imports, ("module",)) == [["pkg.sub", "pkg.sub.records", "pkg.tables"]]


def test_a_cycle_closed_by_a_deferred_import_is_reported_but_type_checking_imports_are_not(tmp_path):
    imports = _package(tmp_path, {
        "__init__.py": "",
        "a.py": "from pkg import b\n",
        "b.py": "from typing import TYPE_CHECKING\nif TYPE_CHECKING:\n    from pkg import c\ndef f():\n    from pkg.a import x\n",
        "c.py": "import pkg.b\n",
    })
    assert import_graph.cycles(imports, ("module",)) == []
    assert import_graph.cycles(imports, ("module", "deferred")) == [["pkg.a", "pkg.b"]]
    text, has_cycles = import_graph.report(imports)
    assert has_cycles and "pkg.b -> pkg.a  (line 5, deferred)" in text and "pkg.b -> pkg.c  (line 3)" in text


def test_sibling_imports_do_not_depend_on_their_own_package_init(tmp_path):
    """A submodule importing a sibling does not re-run its package's ``__init__`` (already in ``sys.modules``)."""
    imports = _package(tmp_path, {
        "__init__.py": "from pkg.a import A\n",
        "a.py": "from pkg.b import B\nA = B\n",
        "b.py": "B = 1\n",
    })
    assert import_graph.cycles(imports, ("module", "deferred")) == []
    assert {(edge.importer, edge.target) for edge in imports} == {("pkg", "pkg.a"), ("pkg.a", "pkg.b")}

"""docs/layout.md names the package as it is: every sub-package and top-level module of vigen/, and nothing that is gone."""

from __future__ import annotations

import re
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
LAYOUT = ROOT / "docs" / "layout.md"
ENTRY = re.compile(r"^( {0,4})(\S+?(?:/|\.py))(?:\s{2,}|$)")
"""A line of the tree that names a path: at most 4 spaces in (2 per level), then the name, then its description."""


def package_tree(text: str) -> list[str]:
    """The paths the tree under "## The package" names, each with its parents' (``vigen/envs/dmc/``, ``vigen/io.py``)."""
    block = text.split("## The package", 1)[1].split("```", 2)[1]
    parents: list[str] = []
    named = []
    for line in block.splitlines():
        match = ENTRY.match(line)
        if match is None:
            continue
        depth = len(match.group(1)) // 2
        parents = parents[:depth]
        path = "".join(parents) + match.group(2)
        named.append(path)
        if path.endswith("/"):
            parents.append(match.group(2))
    return named


def packages_and_top_modules() -> set[str]:
    """Every folder of vigen/ with an ``__init__.py`` (``vigen/envs/dmc/``) and every module at vigen/'s top level."""
    packages = {f"{init.parent.relative_to(ROOT).as_posix()}/" for init in (ROOT / "vigen").rglob("__init__.py")}
    return packages | {module.relative_to(ROOT).as_posix() for module in (ROOT / "vigen").glob("*.py")}


def test_the_tree_reader_follows_indentation():
    text = ("## The package\n\n```\nvigen/a.py     x\nvigen/b/       y\n  __init__.py  z\n  c/           w\n"
            "                 c.py (a description, not an entry)\n```\n")
    assert package_tree(text) == ["vigen/a.py", "vigen/b/", "vigen/b/__init__.py", "vigen/b/c/"]


def test_every_package_and_top_level_module_is_named():
    named = set(package_tree(LAYOUT.read_text()))
    missing = sorted(packages_and_top_modules() - named - {"vigen/"})
    assert not missing, f"docs/layout.md does not name {missing}: add each to the tree under '## The package'."


def test_the_tree_names_nothing_that_is_not_there():
    gone = [path for path in package_tree(LAYOUT.read_text()) if not (ROOT / path).exists()]
    assert not gone, f"docs/layout.md names {gone}, which vigen/ does not hold: update the tree under '## The package'."

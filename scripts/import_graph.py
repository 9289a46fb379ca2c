"""vigen's import graph between its own modules, and the cycles in it.

Run ``.venv/bin/python scripts/import_graph.py``: it prints every import cycle (strongly connected
component) among vigen's modules, or "no import cycles", and exits 1 when there is a cycle -- among
module-level imports, or one that a deferred import closes. ``test/test_import_graph.py`` asserts
there is none.

How an import becomes edges (chosen to follow what Python executes):

* ``import vigen.a.b`` and ``from vigen.a.b import name`` depend on ``vigen.a.b``; relative imports
  are resolved against the importing module's package first.
* ``from vigen.a import name``: if ``vigen.a.name`` is a module, the import depends on that module;
  otherwise ``name`` is read from the package, so it depends on ``vigen.a`` itself, i.e. on
  ``vigen/a/__init__.py`` -- which in turn depends on every submodule it imports. A name
  re-exported by a package's ``__init__`` is therefore not resolved to the submodule that defines
  it: importing it runs the whole ``__init__``, and the graph says so.
* Python imports the parent packages of a module first, so importing ``vigen.a.b`` also depends on
  ``vigen.a`` (its ``__init__``) -- except for the importer's own packages, which are already in
  ``sys.modules`` while the importer runs (``vigen.a.c`` importing ``vigen.a.b`` does not re-run
  ``vigen/a/__init__.py``).
* Imports inside a function or method body run when it is called, not when the module is imported:
  they are *deferred* edges, listed separately. A cycle they close is still a cycle (the modules
  still depend on each other; the deferral only hides it from the import system) and fails the run.
  Imports under ``if TYPE_CHECKING:`` never run; they are listed and left out of the graph.
"""

from __future__ import annotations

import argparse
import ast
import sys
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

MODULE, DEFERRED, TYPING = "module", "deferred", "typing"


@dataclass(frozen=True)
class Import:
    """One dependency of ``importer`` on ``target``, at ``line``, of kind ``module``, ``deferred`` or ``typing``."""

    importer: str
    target: str
    line: int
    kind: str


def module_names(root: Path) -> dict[str, Path]:
    """Module name -> file, for every ``.py`` under the package directory ``root`` (``__init__.py`` names the package)."""
    names = {}
    for path in sorted(root.rglob("*.py")):
        parts = path.relative_to(root.parent).with_suffix("").parts
        names[".".join(parts[:-1] if parts[-1] == "__init__" else parts)] = path
    return names


def _is_type_checking(test: ast.expr) -> bool:
    return (isinstance(test, ast.Name) and test.id == "TYPE_CHECKING") or (
        isinstance(test, ast.Attribute) and test.attr == "TYPE_CHECKING")


def _import_nodes(tree: ast.AST) -> Iterator[tuple[ast.Import | ast.ImportFrom, str]]:
    """Every import statement of a module with its kind, walking function bodies (deferred) and TYPE_CHECKING blocks."""
    stack: list[tuple[ast.AST, str]] = [(tree, MODULE)]
    while stack:
        node, kind = stack.pop()
        for child in ast.iter_child_nodes(node):
            child_kind = kind
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda)) and kind == MODULE:
                child_kind = DEFERRED
            if isinstance(child, ast.If) and _is_type_checking(child.test):
                stack.append((ast.Module(body=child.body, type_ignores=[]), TYPING))
                stack.append((ast.Module(body=child.orelse, type_ignores=[]), kind))
                continue
            if isinstance(child, (ast.Import, ast.ImportFrom)):
                yield child, child_kind
            stack.append((child, child_kind))


def _targets(node: ast.Import | ast.ImportFrom, importer: str, is_package: bool, modules: Mapping[str, Path]) -> list[str]:
    """The vigen modules one import statement names explicitly (before parent packages are added)."""
    if isinstance(node, ast.Import):
        return [alias.name for alias in node.names if alias.name in modules]
    if node.level:
        package = importer if is_package else importer.rpartition(".")[0]
        base_parts = package.split(".")[: len(package.split(".")) - (node.level - 1)]
        base = ".".join(base_parts + ([node.module] if node.module else []))
    else:
        base = node.module or ""
    if base not in modules:
        return []
    submodules = [f"{base}.{alias.name}" for alias in node.names if f"{base}.{alias.name}" in modules]
    reads_package = len(submodules) < len(node.names)
    return ([base] if reads_package else []) + submodules


def imports_of(importer: str, path: Path, modules: Mapping[str, Path]) -> list[Import]:
    """The dependencies of one module on vigen modules (see the module docstring for the rules)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    is_package = path.name == "__init__.py"
    parts = importer.split(".")
    already_running = {".".join(parts[:i]) for i in range(1, len(parts) + 1)} if is_package else {
        ".".join(parts[:i]) for i in range(1, len(parts))}
    found = []
    for node, kind in _import_nodes(tree):
        for target in _targets(node, importer, is_package, modules):
            target_parts = target.split(".")
            parents = [".".join(target_parts[:i]) for i in range(1, len(target_parts))]
            for dependency in [*(p for p in parents if p not in already_running and p in modules), target]:
                if dependency != importer or kind != MODULE:
                    found.append(Import(importer, dependency, node.lineno, kind))
    return found


def import_graph(root: Path) -> list[Import]:
    """Every import of a vigen module by a vigen module under the package directory ``root``."""
    modules = module_names(root)
    return [edge for name, path in modules.items() for edge in imports_of(name, path, modules)]


def strongly_connected_components(nodes: list[str], edges: Mapping[str, set[str]]) -> list[list[str]]:
    """Tarjan's algorithm (iterative): the components with more than one module, or one that imports itself."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    on_stack: set[str] = set()
    stack: list[str] = []
    components: list[list[str]] = []
    for start in nodes:
        if start in index:
            continue
        work = [(start, iter(sorted(edges.get(start, ()))))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, successors = work[-1]
            for successor in successors:
                if successor not in index:
                    index[successor] = low[successor] = len(index)
                    stack.append(successor)
                    on_stack.add(successor)
                    work.append((successor, iter(sorted(edges.get(successor, ())))))
                    break
                if successor in on_stack:
                    low[node] = min(low[node], index[successor])
            else:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        member = stack.pop()
                        on_stack.discard(member)
                        component.append(member)
                        if member == node:
                            break
                    if len(component) > 1 or node in edges.get(node, ()):
                        components.append(sorted(component))
    return sorted(components)


def cycles(imports: list[Import], kinds: tuple[str, ...]) -> list[list[str]]:
    """The import cycles formed by the imports of the given kinds."""
    edges: dict[str, set[str]] = {}
    for edge in imports:
        if edge.kind in kinds:
            edges.setdefault(edge.importer, set()).add(edge.target)
    nodes = sorted({edge.importer for edge in imports} | {edge.target for edge in imports})
    return strongly_connected_components(nodes, edges)


def _describe(component: list[str], imports: list[Import], kinds: tuple[str, ...]) -> list[str]:
    members = set(component)
    inside = sorted({(e.importer, e.target, e.line, e.kind) for e in imports
                     if e.kind in kinds and e.importer in members and e.target in members})
    lines = [f"  {len(component)} modules: {', '.join(component)}"]
    lines += [f"    {importer} -> {target}  (line {line}{', deferred' if kind == DEFERRED else ''})"
              for importer, target, line, kind in inside]
    return lines


def report(imports: list[Import]) -> tuple[str, bool]:
    """The printed report, and whether a cycle exists (among module-level imports, or closed by a deferred one)."""
    module_cycles = cycles(imports, (MODULE,))
    all_cycles = cycles(imports, (MODULE, DEFERRED))
    modules = {e.importer for e in imports} | {e.target for e in imports}
    module_edges = {(e.importer, e.target) for e in imports if e.kind == MODULE}
    lines = [f"{len(modules)} modules, {len(module_edges)} module-level imports between them."]
    if module_cycles:
        lines.append(f"{len(module_cycles)} import cycle(s) among module-level imports:")
        for component in module_cycles:
            lines += _describe(component, imports, (MODULE,))
    else:
        lines.append("no import cycles among module-level imports")
    deferred_only = [c for c in all_cycles if c not in module_cycles]
    if deferred_only:
        lines.append(f"{len(deferred_only)} cycle(s) closed by deferred imports (inside functions):")
        for component in deferred_only:
            lines += _describe(component, imports, (MODULE, DEFERRED))
    else:
        lines.append("no cycles closed by deferred imports")
    deferred = sorted({(e.importer, e.target, e.line) for e in imports if e.kind == DEFERRED})
    lines.append(f"{len(deferred)} deferred import(s) of vigen modules:")
    lines += [f"  {importer} -> {target}  (line {line})" for importer, target, line in deferred]
    typing_only = sorted({(e.importer, e.target, e.line) for e in imports if e.kind == TYPING})
    if typing_only:
        lines.append(f"{len(typing_only)} TYPE_CHECKING-only import(s), not in the graph:")
        lines += [f"  {importer} -> {target}  (line {line})" for importer, target, line in typing_only]
    if not module_cycles and not deferred_only:
        lines.append("no import cycles")
    return "\n".join(lines), bool(all_cycles)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("package", nargs="?", type=Path, default=Path(__file__).resolve().parent.parent / "vigen",
                        help="the package directory (default: this checkout's vigen/)")
    text, has_cycles = report(import_graph(parser.parse_args().package))
    print(text)
    return 1 if has_cycles else 0


if __name__ == "__main__":
    sys.exit(main())

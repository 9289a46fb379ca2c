"""Importing an original's modules from a user-given checkout, apart from vigen's and other checkouts' modules."""

from __future__ import annotations

import importlib
import sys
import types
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

from benchmarks.parity.stand_ins import importable, stub


@dataclass
class Reference:
    """The modules of one original checkout, and what was stubbed to load them."""

    root: Path
    modules: dict[str, types.ModuleType]
    stubbed: list[str]
    notes: list[str] = field(default_factory=list)


def import_reference(
    root: Path,
    names: Sequence[str],
    *,
    paths: Sequence[str] = ("",),
    optional: Sequence[str] = (),
    substitutes: dict[str, types.ModuleType] | None = None,
) -> Reference:
    """Import the modules ``names`` of a checkout at ``root`` (its ``paths`` put first on ``sys.path``).

    The checkout's top-level names (``utils``, ``drqv2``, ...) are generic: the import runs with
    them removed from ``sys.modules`` and puts back what was there afterwards, so two checkouts
    (or a checkout and vigen) never see each other's modules. Modules of ``optional`` that do not
    import are stubbed; ``substitutes`` replace modules outright (e.g. a captum stand-in).
    """
    root = Path(root).resolve()
    dirs = [str(root / p) if p else str(root) for p in paths]
    missing = [d for d in dirs if not Path(d).is_dir()]
    if missing:
        raise FileNotFoundError(f"--reference {root}: no directory {missing[0]}; give a plain checkout of the original repository.")
    substitutes = dict(substitutes or {})
    stubbed = []
    for name in optional:
        if name not in substitutes and not importable(name):
            stubbed.append(name)
    fake: dict[str, types.ModuleType] = dict(substitutes)
    for name in stubbed:
        fake[name] = stub(name)
    saved_path = list(sys.path)
    own = {name.split(".")[0] for name in names}  # top-level packages: two forks may both have algorithms.modules
    saved = {k: v for k, v in sys.modules.items() if k.split(".")[0] in own or k.split(".")[0] in fake}
    for key in saved:
        del sys.modules[key]
    sys.path[:0] = dirs
    try:
        for key, module in fake.items():
            sys.modules[key] = module
            parts = key.split(".")
            for i in range(1, len(parts)):  # parents of a dotted stub, so `import a.b as c` binds
                sys.modules.setdefault(".".join(parts[:i]), stub(".".join(parts[:i])))
        modules = {name: importlib.import_module(name) for name in names}
    finally:
        sys.path[:] = saved_path
        for key in [k for k in sys.modules if k.split(".")[0] in own or k.split(".")[0] in fake]:
            del sys.modules[key]
        sys.modules.update(saved)
    return Reference(root, modules, stubbed)

"""The notebooks use only public imports (issue 13, DESIGN.md "three tiers").

Every import statement of every code cell (IPython lines ``%...`` / ``!...`` dropped, imports
inside functions included) that names ``hybobs_opt`` must be one of:

* a public name of ``hybobs_opt`` or of a core sub-package's ``__init__`` (``systems``, ``sim``,
  ``regions``, ``lmi``, ``mhe``, ``observers``, ``geometry``), i.e. a name in its ``__all__``;
* a name from a module under ``hybobs_opt.studies`` (the paper studies, at their new paths).

Refused: the application tier (``hybobs_opt.report``, ``hybobs_opt.cli``), any name or module
component starting with ``_``, deeper core module paths (``hybobs_opt.observers.lookup``,
``from hybobs_opt.observers import hybrid_observer as ho``), the old paths of the modules that
issue 13 moved (``hybobs_opt.examples.*``, ``hybobs_opt.lmi.presets`` ...: :data:`MOVED_PATHS`), star
and relative imports.  Only the source is parsed; nothing of a notebook is run here.
"""

from __future__ import annotations

import ast
import importlib
import importlib.util
import json
from pathlib import Path

import pytest

NOTEBOOKS = sorted((Path(__file__).resolve().parents[2] / "notebooks").glob("*.ipynb"))

#: Core sub-packages whose ``__init__`` is a public face (names in ``__all__``).
CORE_PACKAGES = ("hybobs_opt.systems", "hybobs_opt.sim", "hybobs_opt.regions", "hybobs_opt.synthesis", "hybobs_opt.lmi",
                 "hybobs_opt.mhe", "hybobs_opt.observers", "hybobs_opt.geometry")
STUDIES = "hybobs_opt.studies"
APPLICATION = ("hybobs_opt.report", "hybobs_opt.cli")
#: Old module / package path -> its new home (the modules and the package issue 13 moved).
MOVED_PATHS = {
    "hybobs_opt.examples": "hybobs_opt.studies",
    "hybobs_opt.examples.registry": "hybobs_opt.studies.registry",
    "hybobs_opt.examples.driveline": "hybobs_opt.studies.paper000_driveline.systems",
    "hybobs_opt.examples.sliding_mode": "hybobs_opt.studies.paper001_sliding_mode.systems",
    "hybobs_opt.examples.powertrain": "hybobs_opt.studies.paper002_powertrain.systems",
    "hybobs_opt.examples.switching": "hybobs_opt.studies.paper003_switching.systems",
    "hybobs_opt.examples.nonmonotonic": "hybobs_opt.studies.paper004_nonmonotonic.systems",
    "hybobs_opt.examples.piston_pwa": "hybobs_opt.studies.paper004_nonmonotonic.piston_pwa",
    "hybobs_opt.lmi.presets": "hybobs_opt.studies.paper004_nonmonotonic.presets",
    "hybobs_opt.lmi.commands": "hybobs_opt.cli.diagnose",
    "hybobs_opt.observers.bench": "hybobs_opt.studies.paper002_powertrain.bench",
    "hybobs_opt.observers.piston_comparison": "hybobs_opt.studies.paper004_nonmonotonic.piston_comparison",
    "hybobs_opt.observers.scenarios": "hybobs_opt.studies.scenarios",
}
OLD_PATHS = tuple(sorted(MOVED_PATHS, key=len, reverse=True))  # longest first


def _under(mod: str, prefix: str) -> bool:
    return mod == prefix or mod.startswith(prefix + ".")


def _public_names(package: str) -> frozenset[str]:
    if importlib.util.find_spec(package) is None:
        return frozenset()
    return frozenset(getattr(importlib.import_module(package), "__all__", ()))


def cell_code(cell: dict) -> str:
    """A code cell's source without the IPython magic / shell lines."""
    src = cell["source"] if isinstance(cell["source"], str) else "".join(cell["source"])
    return "\n".join(line for line in src.splitlines() if not line.lstrip().startswith(("%", "!")))


def module_problem(mod: str) -> str | None:
    """Why importing from module ``mod`` (a ``hybobs_opt`` path) is not public, or ``None``."""
    if any(part.startswith("_") for part in mod.split(".")):
        return "private module"
    for old in OLD_PATHS:
        if _under(mod, old):
            return f"old alias path {old} (use its new home {MOVED_PATHS[old]})"
    for app in APPLICATION:
        if _under(mod, app):
            return "application tier (report / CLI)"
    if _under(mod, STUDIES):
        return None if importlib.util.find_spec(mod) is not None else "no such study module"
    if mod == "hybobs_opt" or mod in CORE_PACKAGES:
        return None
    return "deeper core module path (import from hybobs_opt or the sub-package's __init__)"


def import_problems(source: str, where: str = "<cell>") -> list[str]:
    """Every non-public ``hybobs_opt`` import of ``source``, as ``where:line: statement: reason``."""
    out: list[str] = []
    for node in ast.walk(ast.parse(source, where)):
        if isinstance(node, ast.Import):
            for alias in node.names:
                if not _under(alias.name, "hybobs_opt"):
                    continue
                reason = module_problem(alias.name)
                if reason:
                    out.append(f"{where}:{node.lineno}: import {alias.name}: {reason}")
        elif isinstance(node, ast.ImportFrom):
            mod = node.module or ""
            if node.level:
                out.append(f"{where}:{node.lineno}: relative import from {'.' * node.level}{mod}")
                continue
            if not _under(mod, "hybobs_opt"):
                continue
            stmt = f"from {mod} import {', '.join(a.name for a in node.names)}"
            reason = module_problem(mod)
            if reason:
                out.append(f"{where}:{node.lineno}: {stmt}: {reason}")
                continue
            public = None if _under(mod, STUDIES) else _public_names(mod)
            for alias in node.names:
                if alias.name == "*":
                    out.append(f"{where}:{node.lineno}: {stmt}: star import")
                elif alias.name.startswith("_"):
                    out.append(f"{where}:{node.lineno}: {stmt}: private name {alias.name}")
                elif public is not None and alias.name not in public:
                    out.append(f"{where}:{node.lineno}: {stmt}: {alias.name} is not in {mod}.__all__")
    return out


def notebook_problems(nb: dict, name: str = "<notebook>") -> list[str]:
    out: list[str] = []
    for i, cell in enumerate(nb["cells"]):
        if cell["cell_type"] == "code":
            out += import_problems(cell_code(cell), f"{name}[cell {i}]")
    return out


def test_the_notebooks_are_found():
    assert len(NOTEBOOKS) >= 7


@pytest.mark.parametrize("path", NOTEBOOKS, ids=[p.stem for p in NOTEBOOKS])
def test_notebook_imports_only_public_names(path):
    nb = json.loads(path.read_text(encoding="utf-8"))
    assert notebook_problems(nb, path.name) == []


def test_the_checker_flags_non_public_imports():
    """The checker itself: a fake notebook with one forbidden import per rule, and allowed ones."""
    bad = {
        "from hybobs_opt.report.regions_section import band_mask": "application tier",
        "import hybobs_opt.cli.regions": "application tier",
        "from hybobs_opt.observers.lookup import LookupObserver": "deeper core module path",
        "from hybobs_opt.observers import hybrid_observer as ho": "not in hybobs_opt.observers.__all__",
        "from hybobs_opt.examples.driveline import driveline": "old alias path",
        "from hybobs_opt.examples import get_example": "old alias path",
        "from hybobs_opt.lmi.presets import get_preset": "old alias path",
        "from hybobs_opt.studies.registry import _resolve_example": "private name",
        "from hybobs_opt._lazy import lazy_exports": "private module",
        "from hybobs_opt import _lazy": "private name",
        "from hybobs_opt.observers import *": "star import",
        "from hybobs_opt import NoSuchThing": "not in hybobs_opt.__all__",
    }
    good = ("import numpy as np\n%matplotlib inline\n!echo hi\nimport hybobs_opt\n"
            "from hybobs_opt import ModelError, LookupObserver\n"
            "from hybobs_opt.observers import summarise_run\n"
            "from hybobs_opt.studies import get_example\n"
            "from hybobs_opt.studies.paper002_powertrain.figures import band_mask\n")
    cells = [{"cell_type": "code", "source": good.splitlines(keepends=True), "outputs": []},
             {"cell_type": "markdown", "source": "from hybobs_opt.report import x"}]
    cells += [{"cell_type": "code", "source": f"def f():\n    {stmt}\n", "outputs": []} for stmt in bad]
    found = notebook_problems({"cells": cells}, "fake")
    assert not [p for p in found if "[cell 0]" in p or "[cell 1]" in p], found
    for i, (stmt, reason) in enumerate(bad.items(), start=2):
        hits = [p for p in found if f"[cell {i}]" in p]
        assert len(hits) == 1 and reason in hits[0], (stmt, hits)

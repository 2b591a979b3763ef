"""The three tiers of DESIGN.md: every import points down (issue 13).

Walks the syntax tree of every module of the package, imports inside functions included, and
resolves relative imports to absolute module names.  Core modules may not import the studies,
the CLI or the report; studies may not import the CLI or the report; ``mhe`` may not import
``observers``.  String references (``importlib.import_module("hybobs_opt.studies...")``) count
as imports too, except in :mod:`hybobs_opt._compat`, the table of old import paths.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "hybobs_opt"

UPPER = {"core": ("hybobs_opt.studies", "hybobs_opt.cli", "hybobs_opt.report", "hybobs_opt.examples"),
         "studies": ("hybobs_opt.cli", "hybobs_opt.report")}


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def tier(name: str) -> str:
    if name == "hybobs_opt" or name == "hybobs_opt._compat":
        return "face"
    for prefix, label in (("hybobs_opt.studies", "studies"), ("hybobs_opt.cli", "application"),
                          ("hybobs_opt.report", "application")):
        if name == prefix or name.startswith(prefix + "."):
            return label
    return "core"


def imports_of(path: Path) -> list[tuple[int, str]]:
    """``(line, absolute module)`` of every import statement and every ``hybobs_opt.*`` string."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.split(".")
                base = base[: len(base) - (node.level - 1)]
                mod = ".".join(base + ([node.module] if node.module else []))
            else:
                mod = node.module or ""
            out.append((node.lineno, mod))
            # ``from . import studies`` names a module through the alias
            out += [(node.lineno, f"{mod}.{a.name}") for a in node.names]
        elif isinstance(node, ast.Constant) and isinstance(node.value, str) and node.value.startswith("hybobs_opt."):
            out.append((node.lineno, node.value.split(":")[0].split()[0]))
    return out


def _under(mod: str, prefix: str) -> bool:
    return mod == prefix or mod.startswith(prefix + ".")


def violations() -> list[str]:
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        name = module_name(path)
        t = tier(name)
        if t not in UPPER or name == "hybobs_opt._compat":
            continue
        for line, mod in imports_of(path):
            for upper in UPPER[t]:
                if _under(mod, upper):
                    bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {t} module {name} imports {mod}")
            if t == "core" and mod == "argparse":
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: core module {name} imports argparse (CLI glue)")
            if _under(name, "hybobs_opt.mhe") and _under(mod, "hybobs_opt.observers"):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: mhe module {name} imports {mod} (mhe sits below observers)")
    return bad


def test_every_import_points_down():
    assert violations() == []


def cli_flags_in_core_errors() -> list[str]:
    """Core ``ModelError``/``SolverError`` calls whose field names a command-line flag (``"--cut"``)."""
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if tier(module_name(path)) != "core":
            continue
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if not (isinstance(node, ast.Call) and getattr(node.func, "id", getattr(node.func, "attr", "")) in
                    ("ModelError", "SolverError", "InfeasibleError") and node.args):
                continue
            first = node.args[0]
            text = first.value if isinstance(first, ast.Constant) else (
                first.values[0].value if isinstance(first, ast.JoinedStr) and first.values
                and isinstance(first.values[0], ast.Constant) else "")
            if isinstance(text, str) and text.startswith("--"):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}: {text!r}")
    return bad


def test_core_errors_never_name_a_cli_flag():
    """A core error names the argument of the function the user called; the CLI names its flags."""
    assert cli_flags_in_core_errors() == []


def test_the_walker_sees_upward_imports(tmp_path, monkeypatch):
    """The checker itself: a core module with a function-level relative import of a study is caught."""
    fake = PACKAGE / "regions" / "_architecture_probe.py"
    assert not fake.exists()
    try:
        fake.write_text("def f():\n    from ..studies import get_example\n    import importlib\n"
                        "    return importlib.import_module('hybobs_opt.cli.regions')\n")
        found = [v for v in violations() if "_architecture_probe" in v]
        assert any("imports hybobs_opt.studies" in v for v in found)
        assert any("imports hybobs_opt.cli.regions" in v for v in found)
    finally:
        fake.unlink()


def test_compat_imports_nothing_of_the_package():
    """The alias table is strings only: it can be installed before anything else is imported."""
    mods = [m for _, m in imports_of(PACKAGE / "_compat.py") if not m.startswith("hybobs_opt.")]
    stmts = [n for n in ast.walk(ast.parse((PACKAGE / "_compat.py").read_text()))
             if isinstance(n, ast.ImportFrom) and (n.level or (n.module or "").startswith("hybobs_opt"))]
    assert stmts == [] and "hybobs_opt" not in mods


@pytest.mark.parametrize("argv", [["--help"], ["examples", "--json"]])
def test_cli_start_imports_no_solver(argv):
    """``hybobs --help`` and ``hybobs examples`` load neither cvxpy, CasADi, numba, scipy nor numpy."""
    from benchmarks.bench_startup import heavy_modules_imported

    assert heavy_modules_imported(argv) == []

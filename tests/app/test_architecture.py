"""The three tiers of DESIGN.md: every import points down.

Walks the syntax tree of every module of the package, imports inside functions included, and
resolves relative imports to absolute module names.  Core modules -- the root package included --
may not import the studies, the CLI or the report; studies may not import the CLI or the report;
``mhe`` may not import ``observers``, and ``synthesis`` (the offline designs) imports neither.  String references (``importlib.import_module("hybobs_opt.studies...")``,
a lazy export table) count as imports too, and no core module forwards names through a module
``__getattr__`` function (the lazy export tables of the package faces are assignments whose
strings the first rule checks).
"""

from __future__ import annotations

import ast
import sys
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[2] / "hybobs_opt"

UPPER = {"core": ("hybobs_opt.studies", "hybobs_opt.cli", "hybobs_opt.report"),
         "studies": ("hybobs_opt.cli", "hybobs_opt.report")}


def module_name(path: Path) -> str:
    rel = path.relative_to(PACKAGE.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return ".".join(parts)


def tier(name: str) -> str:
    for prefix, label in (("hybobs_opt.studies", "studies"), ("hybobs_opt.cli", "application"),
                          ("hybobs_opt.report", "application")):
        if name == prefix or name.startswith(prefix + "."):
            return label
    return "core"


def from_module(node: ast.ImportFrom, package: str) -> str:
    """The absolute module of ``from X import ...`` written in ``package`` (relative levels resolved)."""
    if not node.level:
        return node.module or ""
    base = package.split(".")
    base = base[: len(base) - (node.level - 1)]
    return ".".join(base + ([node.module] if node.module else []))


def imports_of(path: Path) -> list[tuple[int, str]]:
    """``(line, absolute module)`` of every import statement and every ``hybobs_opt.*`` string."""
    name = module_name(path)
    package = name if path.name == "__init__.py" else name.rpartition(".")[0]
    out: list[tuple[int, str]] = []
    for node in ast.walk(ast.parse(path.read_text(), str(path))):
        if isinstance(node, ast.Import):
            out += [(node.lineno, a.name) for a in node.names]
        elif isinstance(node, ast.ImportFrom):
            mod = from_module(node, package)
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
        if t not in UPPER:
            continue
        for line, mod in imports_of(path):
            for upper in UPPER[t]:
                if _under(mod, upper):
                    bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: {t} module {name} imports {mod}")
            if t == "core" and mod == "argparse":
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: core module {name} imports argparse (CLI glue)")
            if _under(name, "hybobs_opt.mhe") and _under(mod, "hybobs_opt.observers"):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: mhe module {name} imports {mod} (mhe sits below observers)")
            for runtime in ("hybobs_opt.mhe", "hybobs_opt.observers"):
                if _under(name, "hybobs_opt.synthesis") and _under(mod, runtime):
                    bad.append(f"{path.relative_to(PACKAGE.parent)}:{line}: synthesis module {name} imports {mod} "
                               "(offline designs sit below the runtime observers)")
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
    """The checker itself: a core module with a function-level relative import of a study is caught.

    The probe goes into a copy of the package (writing it into the real one raced with the other
    walkers of this module under pytest-xdist: they listed the file and found it gone)."""
    import shutil

    real = PACKAGE / "regions" / "_architecture_probe.py"
    copy = tmp_path / "hybobs_opt"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", copy)
    (copy / "regions" / "_architecture_probe.py").write_text(
        "def f():\n    from ..studies import get_example\n    import importlib\n"
        "    return importlib.import_module('hybobs_opt.cli.regions')\n")
    found = [v for v in violations() if "_architecture_probe" in v]
    assert any("imports hybobs_opt.studies" in v for v in found)
    assert any("imports hybobs_opt.cli.regions" in v for v in found)
    assert not real.exists()


def test_the_walker_sees_a_design_importing_a_runtime_observer():
    found = _violations_of_text("hybobs_opt/synthesis/periodic_gains.py", "from ..observers.periodic import PeriodicObserver\n")
    assert any("synthesis module hybobs_opt.synthesis.periodic_gains imports hybobs_opt.observers.periodic" in v for v in found)


def module_getattr_functions() -> list[str]:
    """``file:line`` of every module-level ``def __getattr__`` in a core module."""
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if tier(module_name(path)) != "core":
            continue
        for node in ast.parse(path.read_text(), str(path)).body:
            if isinstance(node, ast.FunctionDef) and node.name == "__getattr__":
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{node.lineno}")
    return bad


def test_no_core_module_forwards_names_through_getattr():
    """A name lives in one module and is imported from there: no core module serves another's
    names on attribute access (the moved-name forwarding into the studies is gone)."""
    assert module_getattr_functions() == []


def test_the_root_package_is_core():
    assert tier("hybobs_opt") == "core"
    assert any(v.startswith("hybobs_opt/__init__.py") for v in _violations_of_text(
        "hybobs_opt/__init__.py", "_EXPORTS = {'get_example': 'hybobs_opt.studies'}\n"))


def _violations_of_text(rel: str, text: str) -> list[str]:
    """:func:`violations` of a copy of the package in which ``rel`` holds ``text`` (the checker's own test)."""
    import shutil
    import tempfile

    global PACKAGE
    with tempfile.TemporaryDirectory() as tmp:
        copy = Path(tmp) / "hybobs_opt"
        shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
        (copy.parent / rel).write_text(text)
        saved, PACKAGE = PACKAGE, copy
        try:
            return violations()
        finally:
            PACKAGE = saved


@pytest.mark.parametrize("argv", [["--help"], ["examples", "--json"]])
def test_cli_start_imports_no_solver(argv):
    """``hybobs --help`` and ``hybobs examples`` load neither cvxpy, CasADi, numba, scipy nor numpy."""
    from benchmarks.bench_startup import heavy_modules_imported

    assert heavy_modules_imported(argv) == []


# ------------------------------------------------------------------ the range of a row over a polytope, once
#: Loops over the two signs of an objective that call an LP solver but are not a range:
#: ``certified_width_below`` bounds the width from DAQP's multipliers (a certificate, with an
#: early exit), ``fixed_state_witness`` searches for a second state and stops at the first, and
#: the dimension search of the paper 002 figures stops at the first direction that moves.
NOT_A_RANGE = {"hybobs_opt/geometry/lp.py:certified_width_below",
               "hybobs_opt/regions/pair_geometry.py:fixed_state_witness",
               "hybobs_opt/studies/paper002_powertrain/figures.py:reduced_pair_dimensions"}
LP_CALLS = {"solve_lp", "linprog"}


def sign_loops_calling_an_lp() -> set[str]:
    """``file:function`` of every ``for`` over a literal tuple holding both signs whose body calls an LP."""
    found = set()
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        for fn in ast.walk(tree):
            if not isinstance(fn, (ast.FunctionDef, ast.AsyncFunctionDef)):
                continue
            for loop in ast.walk(fn):
                if not (isinstance(loop, ast.For) and isinstance(loop.iter, ast.Tuple)):
                    continue
                consts = {c.value for c in ast.walk(loop.iter) if isinstance(c, ast.Constant) and isinstance(c.value, float)}
                signs = {c.operand.value for c in ast.walk(loop.iter) if isinstance(c, ast.UnaryOp)
                         and isinstance(c.op, ast.USub) and isinstance(c.operand, ast.Constant)}
                if not (1.0 in consts and 1.0 in signs):
                    continue
                calls = {getattr(c.func, "id", getattr(c.func, "attr", "")) for s in loop.body for c in ast.walk(s)
                         if isinstance(c, ast.Call)}
                if calls & LP_CALLS:
                    found.add(f"{path.relative_to(PACKAGE.parent)}:{fn.name}")
    return found


def test_the_range_of_a_row_over_a_polytope_is_written_once():
    """Two LPs per row (min and max) live in geometry.lp.row_range; everything else calls it."""
    assert sign_loops_calling_an_lp() - NOT_A_RANGE == {"hybobs_opt/geometry/lp.py:row_range"}


# ------------------------------------------------------------------ no import circles
def _module_edges() -> dict[str, set[str]]:
    """Module -> the package modules it imports (statements anywhere in the file; names imported
    from a package count as that package unless they are one of its modules)."""
    files = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    edges: dict[str, set[str]] = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        out = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            targets = []
            if isinstance(node, ast.Import):
                targets = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                mod = from_module(node, package)
                subs = [f"{mod}.{a.name}" for a in node.names if f"{mod}.{a.name}" in files]
                targets = subs if subs and len(subs) == len(node.names) else [mod, *subs]
            out |= {t for t in targets if t in files and t != name}
        edges[name] = out
    return edges


def import_circles() -> list[list[str]]:
    """Strongly connected components of more than one module (Tarjan)."""
    edges = _module_edges()
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on: set[str] = set()
    out: list[list[str]] = []
    sys.setrecursionlimit(max(sys.getrecursionlimit(), 10_000))

    def visit(v: str) -> None:
        index[v] = low[v] = len(index)
        stack.append(v)
        on.add(v)
        for w in edges[v]:
            if w not in index:
                visit(w)
                low[v] = min(low[v], low[w])
            elif w in on:
                low[v] = min(low[v], index[w])
        if low[v] == index[v]:
            comp = []
            while True:
                w = stack.pop()
                on.discard(w)
                comp.append(w)
                if w == v:
                    break
            if len(comp) > 1:
                out.append(sorted(comp))

    for v in sorted(edges):
        if v not in index:
            visit(v)
    return out


def test_no_import_circles():
    """Every module can be read bottom-up: no two modules import each other, directly or around a ring."""
    assert import_circles() == []


def test_the_circle_finder_finds_a_circle(monkeypatch):
    fake = {"a": {"b"}, "b": {"c"}, "c": {"a"}, "d": {"a"}}
    monkeypatch.setattr(sys.modules[__name__], "_module_edges", lambda: fake)
    assert import_circles() == [["a", "b", "c"]]


def history_in_core_text() -> list[str]:
    """``file:line`` of each core module line (docstrings, comments, messages) naming an issue number:
    history belongs in the CHANGELOG and commit messages, not in the code."""
    import re

    pattern = re.compile(r"\b(?:issue|issues|ticket)\s*#?\d+|(?<![\w/])#\d{2,}\b", re.IGNORECASE)
    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        if tier(module_name(path)) != "core":
            continue
        for number, line in enumerate(path.read_text().splitlines(), 1):
            if pattern.search(line):
                bad.append(f"{path.relative_to(PACKAGE.parent)}:{number}: {line.strip()[:80]}")
    return bad


def test_no_core_module_names_an_issue_number():
    assert history_in_core_text() == []


def test_the_history_finder_finds_an_issue_number(monkeypatch, tmp_path):
    import shutil

    copy = tmp_path / "hybobs_opt"
    shutil.copytree(PACKAGE, copy, ignore=shutil.ignore_patterns("__pycache__"))
    (copy / "geometry" / "_probe.py").write_text('"""Faster since issue 19 (was 2.3 s)."""\nX = 1  # see #34\n')
    monkeypatch.setattr(sys.modules[__name__], "PACKAGE", copy)
    found = history_in_core_text()
    assert len([v for v in found if "_probe.py" in v]) == 2


# ---------------------------------------------------------------------- the value modules
#: Core modules that hold named values, each with its reason: numerical tolerances, design
#: defaults and budgets, resource limits.  They sit at the bottom of the core.
VALUE_MODULES = ("hybobs_opt.tolerances", "hybobs_opt.defaults", "hybobs_opt.limits")

#: A module-level constant whose name says "tolerance" or "default" belongs in tolerances.py or
#: defaults.py, not in another core module.
VALUE_NAME = r"(_RTOL|_ATOL|_TOL|_EPS|_MARGIN)$|^DEFAULT_"


def _constants(path: Path) -> list[tuple[int, str]]:
    out = []
    for node in ast.parse(path.read_text(), str(path)).body:
        if isinstance(node, (ast.Assign, ast.AnnAssign)):
            target = node.target if isinstance(node, ast.AnnAssign) else node.targets[0]
            if isinstance(target, ast.Name) and target.id.isupper():
                out.append((node.lineno, target.id))
    return out


@pytest.mark.parametrize("name", ["hybobs_opt.tolerances", "hybobs_opt.defaults"])
def test_tolerances_and_defaults_are_core_leaves(name):
    """tolerances.py and defaults.py are core and import nothing of the package (every module may
    import them; limits.py needs the errors)."""
    assert tier(name) == "core"
    path = PACKAGE.parent / (name.replace(".", "/") + ".py")
    assert [mod for _, mod in imports_of(path) if _under(mod, "hybobs_opt")] == []


@pytest.mark.parametrize("name", ["hybobs_opt.tolerances", "hybobs_opt.defaults"])
def test_every_tolerance_and_default_states_its_reason(name):
    """Every constant of tolerances.py / defaults.py has a ``#:`` comment (Sphinx reads it) right
    above it, or continues the line of a pair documented together (``*_RTOL`` then ``*_ATOL``)."""
    path = PACKAGE.parent / (name.replace(".", "/") + ".py")
    lines = path.read_text().splitlines()
    consts = _constants(path)
    assert consts
    previous = {line for line, _ in consts}
    bare = [f"{name}.{const}" for line, const in consts
            if not lines[line - 2].startswith("#:") and (line - 1) not in previous]
    assert bare == []


def test_no_other_core_module_defines_a_tolerance_or_default():
    """Tolerance- and default-named constants of the core live in tolerances.py / defaults.py."""
    import re

    bad = []
    for path in sorted(PACKAGE.rglob("*.py")):
        name = module_name(path)
        if tier(name) != "core" or name in VALUE_MODULES:
            continue
        bad += [f"{path.relative_to(PACKAGE.parent)}:{line}: {const}" for line, const in _constants(path)
                if re.search(VALUE_NAME, const)]
    assert bad == []

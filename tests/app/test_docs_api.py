"""The API reference (docs/api/*.rst) and the numpydoc docstrings agree with the code.

No documentation build is needed: the autosummary lists are parsed from the reST sources and the
docstrings with ``numpydoc.docscrape``.

* every name of ``hybobs_opt.__all__`` and of each sub-package's ``__all__`` is listed in an
  autosummary block of ``docs/api/`` (as that object, under any of its public names), and every
  listed entry resolves;
* for every public function, class (its constructor) and public method of a public class whose
  docstring has a numpydoc ``Parameters`` (or ``Other Parameters``) section, the documented names
  are exactly the signature's parameters (like python-control's docstring test).  A docstring
  without such a section is not checked here.
"""

from __future__ import annotations

import importlib
import inspect
import pkgutil
import re
import warnings
from pathlib import Path

import pytest

import hybobs_opt

docscrape = pytest.importorskip("numpydoc.docscrape", reason="numpydoc (the docs extra) is not installed")

API_DIR = Path(__file__).resolve().parents[2] / "docs" / "api"

#: ``qualified name -> reason`` of public callables whose documented parameters may differ from
#: their signature.  Empty: every Parameters section matches.
KNOWN_MISMATCHES: dict[str, str] = {}


def public_packages() -> list[str]:
    """``hybobs_opt`` and every public sub-package that declares ``__all__`` (the CLI has none)."""
    names = ["hybobs_opt"]
    for info in pkgutil.walk_packages(hybobs_opt.__path__, "hybobs_opt."):
        parts = info.name.split(".")[1:]
        if info.ispkg and not any(p.startswith("_") for p in parts) and parts[0] != "cli":
            if hasattr(importlib.import_module(info.name), "__all__"):
                names.append(info.name)
    return names


def public_names() -> list[tuple[str, str, object]]:
    """``(package, name, object)`` for every name in a public ``__all__``."""
    out = []
    for package in public_packages():
        module = importlib.import_module(package)
        for name in module.__all__:
            out.append((package, name, getattr(module, name)))
    return out


_AUTOSUMMARY = re.compile(r"^\.\. autosummary::\s*$")
_CURRENT = re.compile(r"^\.\. currentmodule::\s*(\S+)\s*$")


def autosummary_entries() -> list[tuple[Path, str, str]]:
    """``(file, module, name)`` of each entry of each autosummary block of ``docs/api/*.rst``."""
    entries = []
    for path in sorted(API_DIR.glob("*.rst")):
        module = None
        lines = path.read_text(encoding="utf-8").splitlines()
        i = 0
        while i < len(lines):
            line = lines[i]
            if m := _CURRENT.match(line):
                module = m.group(1)
            elif _AUTOSUMMARY.match(line):
                i += 1
                while i < len(lines) and (not lines[i].strip() or lines[i].startswith("   ")):
                    item = lines[i].strip()
                    if item and not item.startswith(":"):
                        assert module is not None, f"{path.name}: autosummary before any currentmodule"
                        entries.append((path, module, item))
                    i += 1
                continue
            i += 1
    return entries


def _resolve(module: str, name: str):
    obj = importlib.import_module(module)
    for part in name.split("."):
        obj = getattr(obj, part)
    return obj


def test_api_pages_exist():
    assert (API_DIR / "index.rst").is_file()
    assert len(autosummary_entries()) > 100


def test_every_entry_resolves():
    bad = []
    for path, module, name in autosummary_entries():
        try:
            _resolve(module, name)
        except (ImportError, AttributeError) as exc:
            bad.append(f"{path.name}: {module}.{name}: {exc}")
    assert not bad, "autosummary entries that do not resolve:\n" + "\n".join(bad)


def test_entries_listed_once():
    seen: dict[str, str] = {}
    dup = []
    for path, module, name in autosummary_entries():
        key = f"{module}.{name}"
        if key in seen:
            dup.append(f"{key} in {seen[key]} and {path.name}")
        seen[key] = path.name
    assert not dup, "\n".join(dup)


def test_every_public_name_is_in_the_api_reference():
    documented_names = {(module, name) for _, module, name in autosummary_entries()}
    documented_ids = set()
    for _, module, name in autosummary_entries():
        obj = _resolve(module, name)
        if inspect.isclass(obj) or inspect.isroutine(obj):
            documented_ids.add(id(obj))
    missing = []
    for package, name, obj in public_names():
        if name == "__version__":
            continue
        if (package, name) in documented_names:
            continue
        if (inspect.isclass(obj) or inspect.isroutine(obj)) and id(obj) in documented_ids:
            continue  # a re-export of an object documented under another public name
        missing.append(f"{package}.{name}")
    assert not missing, ("public names missing from the autosummary lists of docs/api/*.rst "
                         "(add each to the page of its sub-package):\n" + "\n".join(missing))


# ------------------------------------------------------------------------------ docstrings
def _documented(doc) -> list[str]:
    names = []
    for section in ("Parameters", "Other Parameters"):
        for param in doc[section]:
            for part in param.name.split(","):
                part = part.strip().lstrip("*")
                if part:
                    names.append(part)
    return names


def _signature_names(func, drop_first: bool) -> list[str] | None:
    try:
        params = list(inspect.signature(func).parameters.values())
    except (TypeError, ValueError):  # builtins without a signature
        return None
    if drop_first and params and params[0].name in ("self", "cls"):
        params = params[1:]
    return [p.name for p in params]


def public_callables() -> list[tuple[str, object, object, bool]]:
    """``(name, signature source, docstring source, drop_first)`` of each public callable once."""
    seen = set()
    out = []
    for package, name, obj in public_names():
        if id(obj) in seen or not (inspect.isclass(obj) or inspect.isroutine(obj)):
            continue
        seen.add(id(obj))
        label = f"{package}.{name}"
        if inspect.isclass(obj):
            if obj.__init__ is not object.__init__:
                out.append((label, obj.__init__, obj, True))
            for attr, member in vars(obj).items():
                if attr.startswith("_"):
                    continue
                func = member.__func__ if isinstance(member, (classmethod, staticmethod)) else member
                if inspect.isfunction(func):
                    out.append((f"{label}.{attr}", func, func, not isinstance(member, staticmethod)))
        else:
            out.append((label, obj, obj, False))
    return out


def test_parameters_sections_match_signatures():
    bad, checked = [], 0
    for label, func, doc_source, drop_first in public_callables():
        names = _signature_names(func, drop_first)
        if names is None:
            continue
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # numpydoc warns on sections it does not know
            doc = docscrape.NumpyDocString(inspect.getdoc(doc_source) or "")
        documented = _documented(doc)
        if not documented:
            continue
        checked += 1
        extra = sorted(set(documented) - set(names))
        undocumented = [n for n in names if n not in documented]
        repeated = sorted({n for n in documented if documented.count(n) > 1})
        if (extra or undocumented or repeated) and label not in KNOWN_MISMATCHES:
            bad.append(f"{label}: documented but not in the signature {extra}, "
                       f"in the signature but not documented {undocumented}, documented twice {repeated}")
    assert checked > 50, f"only {checked} docstrings with a Parameters section found"
    assert not bad, "numpydoc Parameters sections that disagree with the signature:\n" + "\n".join(bad)


def test_known_mismatches_are_current():
    labels = {label for label, *_ in public_callables()}
    stale = sorted(set(KNOWN_MISMATCHES) - labels)
    assert not stale, f"KNOWN_MISMATCHES names no public callable: {stale}"

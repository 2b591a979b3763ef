"""Every entry of the API reference teaches by example: an Examples section, a Returns section when
it returns a value, and a See Also section.

The entries are those of the autosummary lists of ``docs/api/*.rst`` (``tests/app/test_docs_api.py``
checks that they are exactly the public names of ``hybobs_opt.__all__`` and each sub-package's
``__all__``); the test is parametrised by page, so each page can be checked on its own
(``pytest tests/app/test_docs_examples.py -k geometry``).  For every function and class listed:

* its numpydoc docstring has an ``Examples`` section (``make doctest`` runs them);
* its docstring has a ``See Also`` section;
* a function that returns a value (a return annotation other than ``None``, or a ``return <value>``
  in its own body) has a ``Returns`` (or, for a generator, ``Yields``) section, and so has every
  public method of a listed class that returns a value (properties excepted: their docstring is
  the attribute's description).

Constants (``CONDITIONS``, ``COUNTERS``, ...) are data, not callables, and are not counted.
"""

from __future__ import annotations

import ast
import inspect
import textwrap
import warnings
from collections import defaultdict

import pytest

from tests.app.test_docs_api import _resolve, autosummary_entries, docscrape

_PAGES: dict[str, list[tuple[str, str]]] = defaultdict(list)
for _path, _module, _name in autosummary_entries():
    _PAGES[_path.stem].append((_module, _name))


def _doc(obj) -> "docscrape.NumpyDocString":
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # numpydoc warns on sections it does not know
        return docscrape.NumpyDocString(inspect.getdoc(obj) or "")


def returns_value(func) -> bool:
    """Whether ``func`` returns a value: its return annotation is not ``None`` / ``NoReturn``, or
    its own body (not a nested function's) has a ``return <expression>`` other than ``return None``."""
    func = inspect.unwrap(func)
    annotation = func.__annotations__.get("return", inspect.Signature.empty) if hasattr(func, "__annotations__") else inspect.Signature.empty
    if annotation is not inspect.Signature.empty:
        return annotation not in (None, "None", "NoReturn", "typing.NoReturn", "Never")
    try:
        source = textwrap.dedent(inspect.getsource(func))
    except (OSError, TypeError):
        return False
    tree = ast.parse(source)
    top = tree.body[0]

    def walk(node) -> bool:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef, ast.Lambda, ast.ClassDef)):
                continue
            if isinstance(child, ast.Return) and child.value is not None:
                if not (isinstance(child.value, ast.Constant) and child.value.value is None):
                    return True
            if walk(child):
                return True
        return False

    return walk(top)


def _callables(page: str):
    seen = set()
    for module, name in _PAGES[page]:
        obj = _resolve(module, name)
        if not (inspect.isclass(obj) or inspect.isroutine(obj)) or id(obj) in seen:
            continue
        seen.add(id(obj))
        yield f"{module}.{name}", obj


def _public_methods(cls):
    """``(name, function)`` of each public method defined in ``cls`` itself (not properties)."""
    for attr, member in vars(cls).items():
        if attr.startswith("_") or isinstance(member, property):
            continue
        func = member.__func__ if isinstance(member, (classmethod, staticmethod)) else member
        if inspect.isfunction(func):
            yield attr, func


def offenders(page: str) -> dict[str, list[str]]:
    """The entries of ``page`` without each section: ``"Examples"``, ``"See Also"``, ``"Returns"``
    (functions) and ``"Returns of methods"`` (public methods of the classes)."""
    out: dict[str, list[str]] = {"Examples": [], "Returns": [], "See Also": [], "Returns of methods": []}
    for label, obj in _callables(page):
        doc = _doc(obj)
        if not doc["Examples"]:
            out["Examples"].append(label)
        if not doc["See Also"]:
            out["See Also"].append(label)
        is_exception = inspect.isclass(obj) and issubclass(obj, BaseException)
        if inspect.isroutine(obj) and not is_exception and returns_value(obj) and not (doc["Returns"] or doc["Yields"]):
            out["Returns"].append(label)
        if inspect.isclass(obj) and not is_exception:
            for attr, func in _public_methods(obj):
                method_doc = _doc(func)
                if returns_value(func) and not (method_doc["Returns"] or method_doc["Yields"]):
                    out["Returns of methods"].append(f"{label}.{attr}")
    return out


def test_pages_found():
    assert {"core", "geometry", "systems", "sim"} <= set(_PAGES)


@pytest.mark.parametrize("page", sorted(_PAGES))
@pytest.mark.parametrize("section", ["Examples", "Returns", "See Also", "Returns of methods"])
def test_every_entry_has_section(page, section):
    missing = offenders(page)[section]
    print(f"{page}: {len(missing)} without {section}: {missing}")
    assert not missing, f"docs/api/{page}.rst: entries whose docstring has no {section} section:\n" + "\n".join(missing)


def test_returns_value_detection():
    def annotated() -> int:
        return 1

    def annotated_none() -> None:
        return None

    def plain(x):
        def inner():
            return 3

        return x

    def procedure(x):
        def inner():
            return 3

        if x:
            return
        print(x)

    assert returns_value(annotated)
    assert not returns_value(annotated_none)
    assert returns_value(plain)
    assert not returns_value(procedure)

"""Write the small Sphinx inventories (``*.inv``) that ``docs/conf.py`` gives intersphinx.

The documentation is built without a network, so the projects' own ``objects.inv`` cannot be
downloaded; these list only the outside objects that the docstrings of hybobs_opt name (in a
Parameters or Returns type, a See Also entry or a cross-reference), each with its page in that
project's published documentation.  Run ``python docs/_intersphinx/make_inventories.py`` after
adding an entry and commit the ``.inv`` files with this script.

Each file is Sphinx's inventory format version 2: four header lines, then zlib-compressed lines
``name domain:role priority uri display-name`` (a ``$`` at the end of ``uri`` stands for ``name``,
a display name ``-`` for ``name``).
"""

from __future__ import annotations

import zlib
from pathlib import Path

HERE = Path(__file__).resolve().parent

#: project -> (title, version, [(name, domain:role, uri relative to the project's base URL[, title])]);
#: the base URLs are those of ``intersphinx_mapping`` in docs/conf.py.
INVENTORIES: dict[str, tuple[str, str, list[tuple[str, ...]]]] = {
    # https://docs.python.org/3/
    "python": ("Python", "3", [
        ("bool", "py:class", "library/functions.html#bool"),
        ("int", "py:class", "library/functions.html#int"),
        ("float", "py:class", "library/functions.html#float"),
        ("str", "py:class", "library/stdtypes.html#str"),
        ("dict", "py:class", "library/stdtypes.html#dict"),
        ("list", "py:class", "library/stdtypes.html#list"),
        ("tuple", "py:class", "library/stdtypes.html#tuple"),
        ("callable", "py:function", "library/functions.html#callable"),
        ("pathlib.Path", "py:class", "library/pathlib.html#pathlib.Path"),
        ("collections.abc.Mapping", "py:class", "library/collections.abc.html#collections.abc.Mapping"),
        ("collections.abc.Sequence", "py:class", "library/collections.abc.html#collections.abc.Sequence"),
        ("collections.abc.Iterable", "py:class", "library/collections.abc.html#collections.abc.Iterable"),
        ("concurrent.futures.Executor", "py:class", "library/concurrent.futures.html#concurrent.futures.Executor"),
        ("enum.Enum", "py:class", "library/enum.html#enum.Enum"),
        ("None", "py:data", "library/constants.html#None"),
        ("doctest", "py:module", "library/doctest.html#module-doctest"),
        # numpydoc's own aliases write ``True`` / ``False`` in a type as a reference to this label
        ("bltin-boolean-values", "std:label", "library/stdtypes.html#boolean-type", "Boolean Type"),
    ]),
    # https://numpy.org/doc/stable/
    "numpy": ("NumPy", "stable", [
        ("numpy.ndarray", "py:class", "reference/generated/numpy.ndarray.html#$"),
        ("numpy.random.Generator", "py:class", "reference/random/generator.html#$"),
        ("numpy.random.default_rng", "py:function", "reference/random/generator.html#$"),
        ("numpy.round", "py:function", "reference/generated/numpy.round.html#$"),
        ("numpy.allclose", "py:function", "reference/generated/numpy.allclose.html#$"),
        ("array_like", "std:term", "glossary.html#term-array_like"),
        # numpydoc's alias of ``scalar`` in a type
        ("arrays.scalars", "std:label", "reference/arrays.scalars.html", "Scalars"),
    ]),
    # https://docs.scipy.org/doc/scipy/
    "scipy": ("SciPy", "stable", [
        ("scipy.optimize.linprog", "py:function", "reference/generated/scipy.optimize.linprog.html#$"),
        ("scipy.optimize.OptimizeResult", "py:class", "reference/generated/scipy.optimize.OptimizeResult.html#$"),
        ("scipy.sparse.csr_matrix", "py:class", "reference/generated/scipy.sparse.csr_matrix.html#$"),
        ("scipy.sparse.csc_matrix", "py:class", "reference/generated/scipy.sparse.csc_matrix.html#$"),
        ("scipy.sparse.csr_array", "py:class", "reference/generated/scipy.sparse.csr_array.html#$"),
        ("scipy.sparse.csc_array", "py:class", "reference/generated/scipy.sparse.csc_array.html#$"),
        ("scipy.spatial.ConvexHull", "py:class", "reference/generated/scipy.spatial.ConvexHull.html#$"),
        ("scipy.integrate.solve_ivp", "py:function", "reference/generated/scipy.integrate.solve_ivp.html#$"),
        ("scipy.linalg.expm", "py:function", "reference/generated/scipy.linalg.expm.html#$"),
    ]),
    # https://www.cvxpy.org/
    "cvxpy": ("CVXPY", "stable", [
        ("cvxpy.Problem", "py:class", "api_reference/cvxpy.problems.html#cvxpy.problems.problem.Problem"),
        ("cvxpy.problems.problem.Problem", "py:class", "api_reference/cvxpy.problems.html#$"),
        ("cvxpy.Variable", "py:class", "api_reference/cvxpy.expressions.html#cvxpy.expressions.variable.Variable"),
        ("cvxpy.expressions.variable.Variable", "py:class", "api_reference/cvxpy.expressions.html#$"),
        ("cvxpy.Parameter", "py:class", "api_reference/cvxpy.expressions.html#cvxpy.expressions.constants.parameter.Parameter"),
        ("cvxpy.expressions.constants.parameter.Parameter", "py:class", "api_reference/cvxpy.expressions.html#$"),
    ]),
    # https://web.casadi.org/
    "casadi": ("CasADi", "3", [
        ("casadi.Function", "py:class", "api/html/da/da4/classcasadi_1_1Function.html"),
        ("casadi.SX", "py:class", "docs/#the-sx-symbolics"),
        ("casadi.MX", "py:class", "docs/#the-mx-symbolics"),
        ("casadi.Opti", "py:class", "docs/#opti-stack"),
    ]),
    # https://python-control.readthedocs.io/en/stable/
    "control": ("python-control", "stable", [
        ("control.StateSpace", "py:class", "generated/control.StateSpace.html#$"),
        ("control.ss", "py:function", "generated/control.ss.html#$"),
    ]),
    # https://pandas.pydata.org/docs/
    "pandas": ("pandas", "stable", [
        ("pandas.DataFrame", "py:class", "reference/api/pandas.DataFrame.html#$"),
    ]),
    # https://matplotlib.org/stable/
    "matplotlib": ("Matplotlib", "stable", [
        ("matplotlib.figure.Figure", "py:class", "api/_as_gen/matplotlib.figure.Figure.html#$"),
        ("matplotlib.axes.Axes", "py:class", "api/_as_gen/matplotlib.axes.Axes.html#$"),
    ]),
}


def inventory_bytes(project: str, version: str, entries: list[tuple[str, ...]]) -> bytes:
    """The bytes of one inventory file (format version 2) listing ``entries``."""
    header = (f"# Sphinx inventory version 2\n# Project: {project}\n# Version: {version}\n"
              "# The remainder of this file is compressed using zlib.\n").encode()
    lines = []
    for name, role, uri, *title in entries:
        lines.append(f"{name} {role} {-1 if role == 'std:label' else 1} {uri} {title[0] if title else '-'}\n")
    body = "".join(lines).encode()
    return header + zlib.compress(body, 9)


def main() -> None:
    for key, (project, version, entries) in INVENTORIES.items():
        (HERE / f"{key}.inv").write_bytes(inventory_bytes(project, version, entries))


if __name__ == "__main__":
    main()

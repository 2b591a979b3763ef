"""Sphinx configuration of the hybobs_opt documentation (``make docs``)."""

import os
import sys
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
sys.path.insert(0, str(Path(__file__).parent / "_ext"))

import hybobs_opt  # noqa: E402

project = "hybobs_opt"
author = "hybobs_opt developers"
copyright = "hybobs_opt developers"
release = version = hybobs_opt.__version__

extensions = [
    "sphinx.ext.autodoc",
    "sphinx.ext.autosummary",
    "sphinx.ext.mathjax",
    "sphinx-mathjax-offline",  # MathJax copied into _static: the maths renders without a network
    "sphinx.ext.intersphinx",
    "sphinx.ext.viewcode",
    "numpydoc",
    "myst_nb",
    "matplotlib.sphinxext.plot_directive",
    "hybobs_docs",
]

exclude_patterns = ["_build", "_intersphinx", "Thumbs.db", ".DS_Store", "**.ipynb_checkpoints"]
source_suffix = {".rst": "restructuredtext", ".md": "myst-nb", ".ipynb": "myst-nb"}

# API reference: stubs generated from the autosummary lists of api/*.rst into api/generated.
autosummary_generate = True
autosummary_imported_members = True
autodoc_default_options = {"member-order": "bysource"}
autodoc_typehints = "none"  # numpydoc's Parameters sections carry the types
numpydoc_show_class_members = False
numpydoc_class_members_toctree = False
# The types of Parameters / Returns sections link to their documentation: hybobs_opt's own classes
# through autodoc, the outside ones through the local inventories below.
numpydoc_xref_param_type = True
numpydoc_xref_aliases = {
    "ndarray": "numpy.ndarray",
    "array_like": ":term:`numpy:array_like`",
    "Generator": "numpy.random.Generator",
    "Path": "pathlib.Path",
    "path-like": "pathlib.Path",
    "mapping": "collections.abc.Mapping",
    "sequence": "collections.abc.Sequence",
    "iterable": "collections.abc.Iterable",
    "casadi.SX": "casadi.SX",
    "SX": "casadi.SX",
    "casadi.Function": "casadi.Function",
    "cvxpy.Problem": "cvxpy.Problem",
    "cvxpy.Variable": "cvxpy.Variable",
    "StateSpace": "control.StateSpace",
    "DataFrame": "pandas.DataFrame",
    "Figure": "matplotlib.figure.Figure",
    "Axes": "matplotlib.axes.Axes",
}
# words of the type descriptions that are not types (shapes, defaults, alternatives)
numpydoc_xref_ignore = {
    "optional", "default", "of", "or", "and", "to", "shape", "length", "one", "each", "a", "an",
    "n", "N", "m", "p", "k", "d", "T", "K", "V", "Q", "L", "G", "P", "R", "r", "i", "j", "x", "u",
    "nv", "nr", "nc", "n_vars", "n_params", "lower", "upper", "lo", "hi", "samples", "index",
    "arrays", "array", "floats", "ndarrays", "boolean", "len", "status", "state", "seed", "name",
    "pair", "zeros", "object",
}

# Outside projects: the network is closed where the site is built, so each project's inventory is a
# small local file listing only the objects the docstrings name (docs/_intersphinx/make_inventories.py).
_INV = "_intersphinx/"
intersphinx_mapping = {
    "python": ("https://docs.python.org/3/", _INV + "python.inv"),
    "numpy": ("https://numpy.org/doc/stable/", _INV + "numpy.inv"),
    "scipy": ("https://docs.scipy.org/doc/scipy/", _INV + "scipy.inv"),
    "cvxpy": ("https://www.cvxpy.org/", _INV + "cvxpy.inv"),
    "casadi": ("https://web.casadi.org/", _INV + "casadi.inv"),
    "control": ("https://python-control.readthedocs.io/en/stable/", _INV + "control.inv"),
    "pandas": ("https://pandas.pydata.org/docs/", _INV + "pandas.inv"),
    "matplotlib": ("https://matplotlib.org/stable/", _INV + "matplotlib.inv"),
}
intersphinx_timeout = 1

# Observer gallery: the figures of docs/gallery are drawn by their ``.. plot::`` code at build time.
plot_include_source = True
plot_html_show_source_link = False
plot_html_show_formats = False
plot_formats = [("png", 100)]
plot_rcparams = {"figure.max_open_warning": 0}

# Notebooks: rendered with their stored outputs (tests/app/test_notebooks.py executes them).
nb_execution_mode = "off"
nb_output_stderr = "remove"
myst_enable_extensions = ["dollarmath", "amsmath"]

html_theme = "pydata_sphinx_theme"
html_title = f"hybobs_opt {release}"
html_theme_options = {
    "navigation_depth": 2,
    "show_toc_level": 2,
    "secondary_sidebar_items": ["page-toc"],
}
html_static_path = ["_static"]
# long code lines wrap instead of running past the column (docs/_static/hybobs.css)
html_css_files = ["hybobs.css"]
templates_path = ["_templates"]

"""scipy.spatial's qhull and k-d tree classes, imported at their first use.

Importing ``scipy.spatial`` costs about a quarter of a second of CPU (it loads ``scipy.sparse``,
``scipy.linalg``, ``scipy.special`` and, through scipy's array-API layer, ``numpy.f2py`` and
``numpy.testing``): more than a small observability analysis takes, which needs no hull.  The
geometry modules that use qhull bind these names in their globals when a function first needs
them (:func:`bind`) and resolve them as module attributes on request (:func:`module_getattr`), so
``module.ConvexHull`` can still be read or replaced from outside (tests substitute faulty hulls).
"""

from __future__ import annotations

#: The names of ``scipy.spatial`` the geometry modules use.
NAMES = ("ConvexHull", "HalfspaceIntersection", "QhullError", "cKDTree")


def bind(namespace: dict) -> None:
    """Put the :data:`NAMES` not yet in ``namespace`` (a module's globals) there, from ``scipy.spatial``."""
    if all(name in namespace for name in NAMES):
        return
    import scipy.spatial

    for name in NAMES:
        namespace.setdefault(name, getattr(scipy.spatial, name))


def module_getattr(namespace: dict, name: str):
    """A module's ``__getattr__`` for :data:`NAMES` (PEP 562): bound at the first request."""
    if name in NAMES:
        bind(namespace)
        return namespace[name]
    raise AttributeError(f"module {namespace.get('__name__')!r} has no attribute {name!r}")

"""scipy.spatial's qhull and k-d tree classes, imported at their first use.

Importing ``scipy.spatial`` costs about a quarter of a second of CPU (it loads ``scipy.sparse``,
``scipy.linalg``, ``scipy.special`` and, through scipy's array-API layer, ``numpy.f2py`` and
``numpy.testing``): more than a small observability analysis takes, which needs no hull.  The
geometry modules that use qhull hold ``None`` under these names until a function first needs them
(:func:`bind`), so ``module.ConvexHull`` still exists and can be replaced from outside (tests
substitute faulty hulls): a replacement is kept.
"""

from __future__ import annotations

#: The names of ``scipy.spatial`` the geometry modules use.
NAMES = ("ConvexHull", "HalfspaceIntersection", "QhullError", "cKDTree")


def bind(namespace: dict) -> None:
    """Set the :data:`NAMES` that are ``None`` (or missing) in ``namespace`` (a module's globals) from ``scipy.spatial``."""
    if all(namespace.get(name) is not None for name in NAMES):
        return
    import scipy.spatial

    for name in NAMES:
        if namespace.get(name) is None:
            namespace[name] = getattr(scipy.spatial, name)

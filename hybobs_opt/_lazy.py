"""Lazy re-exports for package ``__init__`` modules (PEP 562).

``from hybobs_opt import LookupObserver`` must work, and ``import hybobs_opt`` must stay cheap
(``hybobs --help`` may not load cvxpy, CasADi or numba): each package names what it re-exports
and from which module, and the module is imported on first access of one of its names.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any


def lazy_exports(package: str, exports: Mapping[str, str], moved: Mapping[str, str] | None = None,
                 ) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """``(__getattr__, __dir__)`` for ``package`` re-exporting ``{name: module}``.

    ``module`` is absolute or relative to ``package`` (``".polytope"``).  Resolved names are
    cached in the package's namespace, so each costs one import.  ``moved`` maps documented names
    that left ``package`` to their new absolute module: they still resolve, for one release, with
    the ``FutureWarning`` of :func:`~hybobs_opt._deprecation.warn_renamed` on every access (never
    cached, never listed by ``dir``).
    """
    moved = dict(moved or {})

    def __getattr__(name: str) -> Any:
        module = exports.get(name)
        if module is None and name in moved:
            from ._deprecation import warn_renamed

            warn_renamed(f"{package}.{name}", f"{moved[name]}.{name}")
            return getattr(importlib.import_module(moved[name]), name)
        if module is None:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = getattr(importlib.import_module(module, package), name)
        setattr(importlib.import_module(package), name, value)
        return value

    def __dir__() -> list[str]:
        return sorted(set(exports) | set(vars(importlib.import_module(package))))

    return __getattr__, __dir__

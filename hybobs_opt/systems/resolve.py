"""Naming a system: a saved result names the system it was computed for, and this module builds
it again from that name.

A name is resolved by the resolvers registered with :func:`register_resolver` (the example
library of :mod:`hybobs_opt.studies` registers one for its example names when it is imported,
which ``import hybobs_opt`` does), or, when it has the form ``"package.module:function"``, by
importing the function and calling it with the stored parameters.  The core never imports the
studies: they plug in here.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable
from typing import Any

from ..errors import ModelError

#: ``resolver(name, params) -> system or None`` (``None``: not a name it knows).
Resolver = Callable[[str, dict[str, Any]], Any]

_RESOLVERS: list[tuple[str, Resolver]] = []


def register_resolver(label: str, resolver: Resolver) -> None:
    """Add (or replace, by ``label``) a resolver of system names."""
    _RESOLVERS[:] = [(k, r) for k, r in _RESOLVERS if k != label]
    _RESOLVERS.append((label, resolver))


def resolve_system(name: str, params: dict[str, Any] | None = None) -> Any:
    """The system called ``name``, built with ``params``.

    Raises
    ------
    ModelError
        No resolver knows ``name`` and it is not an importable ``"module:function"``.
    """
    params = dict(params or {})
    if not isinstance(name, str) or not name:
        raise ModelError("system name", "a non-empty string (an example name or 'module:function')", repr(name))
    for _, resolver in _RESOLVERS:
        system = resolver(name, params)
        if system is not None:
            return system
    module, sep, function = name.partition(":")
    if sep and module and function:
        try:
            fn = getattr(importlib.import_module(module), function)
        except (ImportError, AttributeError) as exc:
            raise ModelError("system name", f"an importable 'module:function' ({exc})", repr(name)) from None
        return fn(**params)
    known = ", ".join(label for label, _ in _RESOLVERS) or "none registered"
    raise ModelError("system name", f"a name known to a resolver ({known}) or 'module:function'", repr(name))

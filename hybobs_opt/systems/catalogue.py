"""Example catalogues: named systems that installed packages ship, found through an entry point.

The core does not know which examples exist.  A distribution offers a catalogue under the entry
point group ``hybobs_opt.catalogues`` (``pyproject.toml``: ``[project.entry-points."hybobs_opt.catalogues"]
name = "package.module"``); the object it names has ``get_example(name)``, ``list_examples()`` and
``resolve_example(name, params)`` (a resolver of :mod:`hybobs_opt.systems.resolve`: ``None`` for a
name it does not know).  This package's own catalogue is its five seed papers
(:mod:`hybobs_opt.studies`), offered the same way, so ``import hybobs_opt`` loads no study and a
saved file that names an example is rebuilt in any process.

Catalogues are loaded on the first call that needs one, once per process.  An installed
distribution's entry point is code the user installed (as pytest's plugins are), not data read
from a file: nothing a saved file says chooses what is imported.
"""

from __future__ import annotations

from typing import Any

from ..errors import ModelError

__all__ = ["ENTRY_POINT_GROUP", "example_catalogues", "get_example", "list_examples"]

#: The entry point group of example catalogues.
ENTRY_POINT_GROUP = "hybobs_opt.catalogues"

_LOADED: list[tuple[str, Any]] | None = None


def example_catalogues() -> list[tuple[str, Any]]:
    """``[(entry point name, catalogue)]`` of every installed catalogue, loaded once per process.

    Raises
    ------
    ModelError
        A catalogue lacks ``get_example``, ``list_examples`` or ``resolve_example``.
    """
    global _LOADED
    if _LOADED is None:
        from importlib.metadata import entry_points

        loaded = []
        for ep in sorted(entry_points(group=ENTRY_POINT_GROUP), key=lambda e: (e.name != "examples", e.name)):
            catalogue = ep.load()
            missing = [f for f in ("get_example", "list_examples", "resolve_example") if not callable(getattr(catalogue, f, None))]
            if missing:
                raise ModelError(f"entry point {ENTRY_POINT_GROUP}:{ep.name}", "a catalogue with get_example, "
                                 "list_examples and resolve_example", f"{ep.value} without {', '.join(missing)}")
            loaded.append((ep.name, catalogue))
        _LOADED = loaded
    return list(_LOADED)


def list_examples() -> list:
    """Every example of every installed catalogue (this package's: papers 000 to 004, in order).

    Returns
    -------
    list of Example
        The examples of every installed catalogue.

    See Also
    --------
    get_example : one by name.

    Examples
    --------
    >>> from hybobs_opt.systems import list_examples
    >>> [example.name for example in list_examples()][:4]
    ['driveline', 'switched_unstable', 'triangular', 'double_scroll']
    """
    return [ex for _, catalogue in example_catalogues() for ex in catalogue.list_examples()]


def get_example(name: str):
    """The example called ``name`` (an ``Example``: ``build()``, ``simulate()``, its paper and settings).

    Returns
    -------
    Example
        The example; ``build()`` gives its system.

    Raises
    ------
    ModelError
        No installed catalogue has ``name``; the message lists the names there are.

    See Also
    --------
    list_examples : every example.
    hybobs_opt.studies.Example : what it returns.

    Examples
    --------
    >>> from hybobs_opt.systems import get_example
    >>> example = get_example("driveline")
    >>> example.paper, example.kind, example.state_names
    ('000', 'hybrid_automaton', ('theta_e', 'omega_c', 'omega_p'))
    """
    catalogues = example_catalogues()
    for _, catalogue in catalogues:
        if any(ex.name == name for ex in catalogue.list_examples()):
            return catalogue.get_example(name)
    names = sorted(ex.name for _, catalogue in catalogues for ex in catalogue.list_examples())
    where = ("one of " + ", ".join(names)) if names else (f"an example of an installed catalogue (none is: no entry "
                                                          f"point in the group {ENTRY_POINT_GROUP!r}; install hybobs_opt "
                                                          "with pip to register its own)")
    raise ModelError("example", where, repr(name))

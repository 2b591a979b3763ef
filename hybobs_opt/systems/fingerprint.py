"""Fingerprints of systems, for saved results that must not be applied to another system.

A fingerprint is the SHA-256 (hex) of the canonical JSON of the model dictionary
(:func:`hybobs_opt.systems.model_dict.system_to_dict`):
``json.dumps(d, sort_keys=True, separators=(",", ":"))``.  The model dictionary holds every
array bit for bit (``repr`` of a float round-trips), the names and the expressions, so two
systems have the same fingerprint exactly when they have the same model dictionary: a rotation
angle of pi/3 instead of pi/4, another gear ratio or a renamed mode all change it.  The one thing
left out is the coordinate labels of the sets (the ``names`` of an ``{A, b}`` set): they are
derived labels (``Polytope.from_box`` without names gives ``z1, z2``), so a box written by hand in
a model file and the same box built in Python are the same plant (:func:`identity_dict`).

:func:`first_difference` names the first entry in which two model dictionaries differ
(``"modes[0].A"``), for the error message of a refused saved result.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from typing import Any


def canonical_json(data: Any) -> str:
    """``data`` as canonical JSON: sorted keys, no whitespace (the text that is hashed)."""
    return json.dumps(data, sort_keys=True, separators=(",", ":"))


def sha256_of(data: Any) -> str:
    """SHA-256 (hex) of :func:`canonical_json` of ``data``."""
    return hashlib.sha256(canonical_json(data).encode("utf-8")).hexdigest()


def identity_dict(data: Any) -> Any:
    """``data`` without what does not change the plant: the coordinate labels of its sets (``names``
    of every mapping with ``A`` and ``b``), comment keys (``_...``) and the sign of zeros
    (``-0.0`` and ``0.0`` are one number: ``x1 <= 0`` reads as ``b = -0.0``, ``from_box`` writes ``0.0``)."""
    if isinstance(data, Mapping):
        is_set = "A" in data and "b" in data
        return {k: identity_dict(v) for k, v in data.items()
                if not (is_set and k == "names") and not (isinstance(k, str) and k.startswith("_"))}
    if isinstance(data, (list, tuple)):
        return [identity_dict(v) for v in data]
    if isinstance(data, float) and data == 0.0:
        return 0.0
    return data


def model_fingerprint(model: Mapping[str, Any]) -> str:
    """Fingerprint of a model dictionary (as stored in a saved result), set labels left out."""
    # Through JSON once so that tuples and lists, numpy floats and floats hash alike.
    return sha256_of(identity_dict(json.loads(canonical_json(model))))


def system_fingerprint(system: Any) -> str:
    """SHA-256 (hex) of the canonical JSON of ``system.to_dict()``.

    Parameters
    ----------
    system : PWASystem, HybridAutomaton, ConstantDriftSystem or ScalarNonlinearSystem
        The system to fingerprint.

    Returns
    -------
    str
        64 hexadecimal digits; equal systems (same model dictionary) have equal fingerprints.

    Raises
    ------
    ModelError
        If ``system`` has no model dictionary (not a system class of :mod:`hybobs_opt.systems`).

    See Also
    --------
    hybobs_opt.regions.save_analysis : stores it with a saved result.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import system_fingerprint
    >>> example = get_example("powertrain3")
    >>> a, b = system_fingerprint(example.build()), system_fingerprint(example.build())
    >>> len(a), a == b, a == system_fingerprint(example.build(gear_ratio=0.5))
    (64, True, False)
    """
    from .model_dict import system_to_dict

    return model_fingerprint(system_to_dict(system))


def first_difference(a: Any, b: Any, path: str = "") -> str | None:
    """The first entry (``"modes[0].A"``) in which two model dictionaries differ, ``None`` if equal.

    Mappings are compared key by key (in the order of ``a``, then the keys only ``b`` has) and
    lists of mappings item by item; any other value (a matrix, a list of names, a number) is
    one entry.  A list of mappings of another length is reported as the list itself.  The
    coordinate labels of sets are not compared (see :func:`identity_dict`).
    """
    if not path:
        a, b = identity_dict(a), identity_dict(b)
    if isinstance(a, Mapping) and isinstance(b, Mapping):
        for key in list(a) + [k for k in b if k not in a]:
            sub = f"{path}.{key}" if path else str(key)
            if key not in a or key not in b:
                return sub
            found = first_difference(a[key], b[key], sub)
            if found is not None:
                return found
        return None
    if (isinstance(a, list) and isinstance(b, list) and len(a) == len(b) and a
            and all(isinstance(v, Mapping) for v in a) and all(isinstance(v, Mapping) for v in b)):
        for i, (u, v) in enumerate(zip(a, b)):
            found = first_difference(u, v, f"{path}[{i}]")
            if found is not None:
                return found
        return None
    return None if canonical_json(a) == canonical_json(b) else (path or "(the whole model)")

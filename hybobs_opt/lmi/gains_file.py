"""The gains file of ``hybobs synth --out``: switched gains per region, sealed like every saved result.

The file is the JSON of :meth:`~hybobs_opt.lmi.switched.SwitchedDesign.to_dict` (plus what the
CLI adds: the system label, the range, the settings) sealed by
:mod:`hybobs_opt.systems.saved_file`: ``format`` (``"hybobs_opt.gains"``), ``format_version``,
``system_fingerprint`` (the system the gains were designed for) and ``checksum``.  The observer
reads it through :func:`hybobs_opt.observers.recorded.gains_from_json`, which calls
:func:`check_gains`: a file of another system, an edited or corrupted file, a malformed file and
a file from before gains files were sealed are refused with a
:class:`~hybobs_opt.errors.ModelError` naming the file (recompute it with ``hybobs synth``).
The checksum detects edits, not forgery; after it the content is checked for what the observer
uses: each region's scheduling coordinate (one state of the system, the same for every region),
its interval (``lo < hi``, the displayed ``interval`` with one unit factor for all), and its gain
``L`` (shape ``(n, p)``, finite, of the stored 2-norm ``gain_norm``).  A consistent edit of a
gain and its norm cannot be seen without re-solving the LMIs (``hybobs synth`` again).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from ..systems.saved_file import SavedFormat, check_fingerprint, check_sealed, finite_number, read_json, write_sealed
from ..tolerances import MATRIX_EQUAL_RTOL

#: The saved-file format of gains files.
GAINS_FILE = SavedFormat(
    name="hybobs_opt.gains", version=1, label="gains file", writer="'hybobs synth --out'",
    recompute="recompute it with 'hybobs synth SYSTEM --out FILE'", version_key="format_version")


def save_gains(path: str | Path, data: Mapping[str, Any], system, *, indent: int | None = 2,
               default: Callable[[Any], Any] | None = None) -> dict[str, Any]:
    """Write the gains ``data`` of ``system`` to ``path``, sealed; returns what was written."""
    from ..systems.fingerprint import system_fingerprint

    return write_sealed(path, data, GAINS_FILE, system_fingerprint(system), indent=indent, default=default)


def read_gains(path: str | Path) -> dict[str, Any]:
    """The JSON object of a gains file (unreadable, binary, non-JSON and non-object files are refused)."""
    return read_json(path, GAINS_FILE)


def check_gains(data: Any, system, source: str) -> list[tuple[str, float, float, np.ndarray]]:
    """``(coordinate, lo, hi, L)`` per region of a sealed gains file for ``system``.

    ``source`` names the file in errors.

    Raises
    ------
    ModelError
        Naming the file: not a gains file, another format version, edited or corrupted (the
        checksum), designed for another system (the fingerprint), or an entry the observer uses
        is malformed.
    """
    where = GAINS_FILE.where(source)
    check_sealed(data, GAINS_FILE, where)
    check_fingerprint(data, GAINS_FILE, where, system, data.get("system") if isinstance(data.get("system"), str) else None)
    for key, names in (("state_names", system.state_names), ("output_names", system.output_names)):
        if data.get(key) != list(names):  # implied by the fingerprint; kept as a plain check
            raise ModelError(f"{where}: {key}", f"{list(names)} (the gains were designed for another system)",
                             _short(data.get(key)))
    regions = data.get("regions")
    if not isinstance(regions, list) or not regions:
        raise ModelError(f"{where}: regions", "a non-empty list of regions with their gains", _short(regions))
    coordinate = data.get("coordinate")
    if not isinstance(coordinate, str) or coordinate not in system.state_names:
        raise ModelError(f"{where}: coordinate", f"the scheduling state, one of {list(system.state_names)}", _short(coordinate))
    n, p = system.n, system.p
    out, factors = [], []
    for i, r in enumerate(regions):
        f = f"{where}: regions[{i}]"
        if not isinstance(r, dict):
            raise ModelError(f, "an object with interval_model, L and coordinate", type(r).__name__)
        if r.get("index") != i or isinstance(r.get("index"), bool):
            raise ModelError(f"{f}.index", f"{i}, the region's place in the list (a region was removed or moved)",
                             _short(r.get("index")))
        if r.get("coordinate") != coordinate:
            raise ModelError(f"{f}.coordinate", f"{coordinate!r}, the coordinate of the design", _short(r.get("coordinate")))
        interval = r.get("interval_model")
        if not isinstance(interval, list) or len(interval) != 2:
            raise ModelError(f"{f}.interval_model", "[lo, hi] in the model's units", _short(interval))
        lo, hi = (finite_number(v, f"{f}.interval_model", "[lo, hi]: two finite numbers") for v in interval)
        if not lo < hi:
            raise ModelError(f"{f}.interval_model", "[lo, hi] with lo < hi", f"[{lo}, {hi}]")
        L = _matrix(r.get("L"), f"{f}.L", (n, p))
        norm = finite_number(r.get("gain_norm"), f"{f}.gain_norm", "the 2-norm of L (a finite number)")
        if abs(norm - float(np.linalg.norm(L, 2))) > MATRIX_EQUAL_RTOL * (1.0 + abs(norm)):
            raise ModelError(f"{f}.L", f"a gain of 2-norm gain_norm = {norm:.17g}",
                             f"a gain of 2-norm {np.linalg.norm(L, 2):.17g}: the file was edited; {GAINS_FILE.recompute}")
        display = r.get("interval")
        shown = [finite_number(v, f"{f}.interval", "[lo, hi] in display units") for v in
                 (display if isinstance(display, list) and len(display) == 2 else [None, None])]
        factors.extend(_factors((lo, hi), shown, f"{f}.interval"))
        out.append((coordinate, lo, hi, L))
    pairs = data.get("pairs")
    if not isinstance(pairs, list) or not all(
            isinstance(q, list) and len(q) == 2 and all(isinstance(k, int) and not isinstance(k, bool)
                                                        and 0 <= k < len(regions) for k in q) for q in pairs):
        raise ModelError(f"{where}: pairs", f"pairs [a, b] of region indices in 0..{len(regions) - 1}", _short(pairs))
    # interval = interval_model / factor with one unit factor for every end of every region (an
    # edited end of interval_model is seen against its display value)
    if factors and max(factors) - min(factors) > MATRIX_EQUAL_RTOL * max(abs(v) for v in factors):
        raise ModelError(f"{where}: regions[*].interval_model", "the intervals shown in 'interval' in the model's units "
                         "(one unit factor for all)", f"factors from {min(factors):.17g} to {max(factors):.17g}: the file "
                         f"was edited; {GAINS_FILE.recompute}")
    return out


def _factors(model: tuple[float, float], shown: list[float], field: str) -> list[float]:
    out = []
    for a, b in zip(model, shown):
        if (a == 0.0) != (b == 0.0):
            raise ModelError(field, "the interval_model in display units (zero where it is zero)", f"{shown}")
        if a != 0.0:
            out.append(a / b)
    return out


def _matrix(value: Any, field: str, shape: tuple[int, int]) -> np.ndarray:
    def numbers(v):
        if isinstance(v, list):
            return [numbers(x) for x in v]
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
            raise ModelError(field, f"a finite {shape[0]} x {shape[1]} gain matrix (rows of numbers)", f"an entry {_short(v)}")
        return v

    if not isinstance(value, list):
        raise ModelError(field, f"a finite {shape[0]} x {shape[1]} gain matrix (rows of numbers)", _short(value))
    try:
        arr = np.array(numbers(value), dtype=float)
    except ValueError:
        raise ModelError(field, f"a finite {shape[0]} x {shape[1]} gain matrix", "rows of different lengths") from None
    if arr.shape != shape:
        raise ModelError(field, f"a finite {shape[0]} x {shape[1]} gain matrix", f"shape {arr.shape}")
    return arr


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


__all__ = ["GAINS_FILE", "check_gains", "read_gains", "save_gains"]

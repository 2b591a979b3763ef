"""Versioned save/load of observability results (the file the lookup observer reads).

Format: JSON, ``{"format": "hybobs_opt.regions", "version": 2, ...}`` holding the regions of
eq. (4) (mode sequence, ``H, h``, ``C, D, f``, ``Phi, Gamma, phi``), the index set ``I``, the
non-empty pair sets ``R_ij`` (as index pairs; their constraints are rebuilt from the regions),
the example name and parameters (for information, and to rebuild the system from a file that
holds no model), the summary, and, so that a file cannot be applied to the wrong plant or
after an edit:

``system_model``
    the model dictionary of the system the result was computed for (``system.to_dict()``,
    :mod:`hybobs_opt.systems.model_dict`);
``system_fingerprint``
    :func:`hybobs_opt.systems.fingerprint.system_fingerprint` of that system (SHA-256 of the
    canonical JSON of its model dictionary);
``checksum``
    SHA-256 (hex) of the canonical JSON (sorted keys, no whitespace) of every other entry of the
    file (:func:`content_checksum`).

The format version, fingerprint and checksum are written and checked by
:mod:`hybobs_opt.systems.saved_file`, shared with the other saved results (the gains of
``hybobs synth --out``).  :func:`load_analysis` refuses, with a
:class:`~hybobs_opt.errors.ModelError` naming the file, a file that is unreadable, not UTF-8, not
JSON or not an object, of another format or version, whose checksum does not match (edited or
corrupted), a ``system`` whose fingerprint is not the stored one (computed for another system)
and a stored model that does not match the stored fingerprint.  The checksum detects edits and
corruption, not forgery: whoever edits the file on purpose can recompute it.  So the content is
then checked against the system before it is used (no LP is solved): every entry has its type
and shape; every region's output and state maps (``C, D, f, Phi, Gamma, phi`` and the ``_last``
maps) are recomputed from its mode sequence and must match; its rows ``H, h`` must be the
sequence's guard rows in order, a row left out only where the state and input box implies it;
``full_rank`` is the rank test again; the pairs are index pairs of ``I``; ``scale``/``centre``
are the box's; the counts of the summary agree with the content and the statistics.  What the
file alone cannot prove without re-solving Algorithm 3.1 is that no pair set was left out and
the slacks (information only, no answer uses them).  Version-1 files (no model, no checksum) are
refused: recompute them with ``hybobs regions SYSTEM --horizon T --out FILE``.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from ..systems.fingerprint import first_difference, model_fingerprint, system_fingerprint
from ..systems.pwa import PWASystem
from ..systems.saved_file import (
    CHECKSUM_KEY,
    FINGERPRINT_KEY,
    SavedFormat,
    check_fingerprint,
    check_sealed,
    content_checksum,
    finite_number,
    read_json,
    write_sealed,
)
from ..tolerances import BOX_IMPLIED_RTOL, MATRIX_EQUAL_RTOL, REGION_SLACK_TOL
from .enumeration import ModeEnumeration, ModeRegion, _child, _root, check_horizon, horizon_scaling
from .observability import ObservabilityAnalysis
from .pair_sets import PairSets

FORMAT = "hybobs_opt.regions"
VERSION = 2

_RECOMPUTE = "recompute it with 'hybobs regions SYSTEM --horizon T --out FILE'"

#: The saved-file format of regions files (:mod:`hybobs_opt.systems.saved_file`).
REGIONS_FILE = SavedFormat(
    name=FORMAT, version=VERSION, label="regions file", writer="'hybobs regions --out'", recompute=_RECOMPUTE,
    old_versions={1: "a file from before saved results carried their system and a checksum, so it cannot be "
                     "checked against the system it is used for"})

#: The arrays of a region as saved, in the order of :class:`~.enumeration.ModeRegion`.
_MAPS = ("C", "D", "f", "Phi", "Gamma", "phi", "Phi_last", "Gamma_last", "phi_last")

__all__ = ["CHECKSUM_KEY", "FORMAT", "REGIONS_FILE", "VERSION", "content_checksum", "load_analysis", "save_analysis"]


def _pair_items(pairs):
    """``((i, j), slack)`` of every piece, read from the indices when compact (no constraints built)."""
    if isinstance(pairs, PairSets):
        return zip(pairs.ij, pairs.slacks.tolist())
    return (((int(p.i), int(p.j)), p.slack) for p in pairs)


def save_analysis(analysis: ObservabilityAnalysis, path: str | Path, example: str | None = None, params: dict | None = None) -> Path:
    """Write ``analysis`` to ``path`` (JSON, format :data:`FORMAT`, version :data:`VERSION`).

    ``example`` and ``params`` (the name the system was built from) are stored for information;
    the system itself is stored as its model dictionary with its fingerprint, and the content
    with a checksum (see the module docstring).

    Parameters
    ----------
    analysis : ObservabilityAnalysis
        The result of Algorithm 3.1 to save.
    path : str or Path
        Output JSON file.
    example : str, optional
        Name the system was built from (stored for information).
    params : dict, optional
        Parameters it was built with (stored for information).

    Returns
    -------
    Path
        ``path``.

    See Also
    --------
    load_analysis : reads the file back.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt.regions import load_analysis, save_analysis
    >>> path = save_analysis(analysis, Path(tempfile.mkdtemp()) / "regions.json", example="powertrain3")
    >>> path.suffix, load_analysis(path).is_observable(np.array([0.06, 39.0, 3.25]))
    ('.json', True)
    """
    enum = analysis.enumeration
    model = enum.system.to_dict()
    data = {
        "example": example,
        "params": params or {},
        "system_name": enum.system.name,
        "state_names": list(enum.system.state_names),
        "system_model": model,
        "horizon": enum.T,
        "scale": enum.scale.tolist(),
        "centre": enum.centre.tolist(),
        "regions": [
            {"sequence": list(r.sequence), "H": r.H.tolist(), "h": r.h.tolist(), "C": r.C.tolist(), "D": r.D.tolist(),
             "f": r.f.tolist(), "Phi": r.Phi.tolist(), "Gamma": r.Gamma.tolist(), "phi": r.phi.tolist(), "slack": r.slack,
             "Phi_last": r.Phi_last.tolist(), "Gamma_last": r.Gamma_last.tolist(), "phi_last": r.phi_last.tolist()}
            for r in enum.regions
        ],
        "full_rank": list(analysis.full_rank),
        "pairs": [{"i": i, "j": j, "slack": float(slack)} for (i, j), slack in _pair_items(analysis.pairs)],
        "enumeration_stats": {"n_lps": enum.n_lps, "n_prefixes_tested": enum.n_prefixes_tested,
                              "n_prefixes_total": enum.n_prefixes_total, "seconds": enum.seconds},
        "analysis_stats": {"n_pair_lps": analysis.n_pair_lps, "n_pairs_tested": analysis.n_pairs_tested,
                           "n_pairs_skipped_rank": analysis.n_pairs_skipped_rank, "seconds": analysis.seconds,
                           "n_pairs_dropped_thin": analysis.stats.get("n_pairs_dropped_thin"),
                           "n_pairs_dropped_same_state": analysis.stats.get("n_pairs_dropped_same_state"),
                           "n_pairs_ruled_out_by_group": analysis.stats.get("n_pairs_ruled_out_by_group"),
                           "n_decisions_exact": analysis.stats.get("n_decisions_exact")},
        "summary": analysis.summary(),
    }
    path = Path(path)
    write_sealed(path, data, REGIONS_FILE, model_fingerprint(model))
    return path


def load_analysis(path: str | Path, system=None) -> ObservabilityAnalysis:
    """Read a file written by :func:`save_analysis`.

    Parameters
    ----------
    path : path-like
    system : PWASystem, optional
        The system the file is to be used for: its fingerprint must be the stored one.  By
        default the system is rebuilt from the stored model dictionary (and, in a file that
        holds no model, from the stored example name and parameters,
        :func:`hybobs_opt.systems.resolve.resolve_system`); its fingerprint is checked too.

    Returns
    -------
    ObservabilityAnalysis
        The analysis as saved, its system rebuilt from the stored model (or checked against
        ``system``).

    Raises
    ------
    ModelError
        Naming the file: it is not a readable regions file (not UTF-8, not JSON, not an object),
        has another version (version-1 files have no checksum: recompute them), its content does
        not match its checksum (edited or corrupted), it was computed for another system than
        ``system``, or its content is not consistent with the system (an entry of the wrong type
        or shape, a region whose maps are not its mode sequence's).

    See Also
    --------
    save_analysis : writes the file.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt.regions import load_analysis, save_analysis
    >>> path = save_analysis(analysis, Path(tempfile.mkdtemp()) / "regions.json")
    >>> loaded = load_analysis(path, system=plant)        # refuses a file of another system
    >>> loaded.T, len(loaded.regions), loaded.is_observable(np.array([0.06, 39.0, 3.25]))
    (3, 16, True)
    """
    where = REGIONS_FILE.where(path)
    data = read_json(path, REGIONS_FILE)
    # Integrity first: nothing of the content is used before it matches its checksum.
    check_sealed(data, REGIONS_FILE, where)
    try:
        return _analysis_from_data(data, system, where)
    except ModelError as exc:
        if exc.field.startswith(where):
            raise
        raise ModelError(f"{where}: {exc.field}", exc.expected, exc.got) from None
    except (KeyError, TypeError, ValueError, IndexError, AttributeError, OverflowError) as exc:
        # A malformed entry this reader did not foresee: still a refusal naming the file.
        raise ModelError(where, "the entries 'hybobs regions --out' writes", f"{type(exc).__name__}: {exc}") from None


def _analysis_from_data(data: dict[str, Any], system, where: str) -> ObservabilityAnalysis:
    fingerprint = data[FINGERPRINT_KEY]
    model = data.get("system_model")
    if "system_model" in data and (not isinstance(model, dict) or model_fingerprint(model) != fingerprint):
        raise ModelError(f"{where}: system_model", "the model whose fingerprint the file stores",
                         f"another model (its SHA-256 is not system_fingerprint): the file was edited; {_RECOMPUTE}")
    if system is None:
        if model is not None:
            from ..systems.model_dict import system_from_dict

            try:
                system = system_from_dict(model)
            except ModelError as exc:
                raise ModelError(f"{where}: system_model.{exc.field}", exc.expected, exc.got) from None
        elif data.get("example"):
            from ..systems.resolve import resolve_registered

            example, params = data["example"], data.get("params", {})
            if not isinstance(example, str) or not isinstance(params, dict):
                raise ModelError(f"{where}: example", "an example name (a string) and its params (an object)",
                                 f"{type(example).__name__} and {type(params).__name__}")
            try:  # a registered example only: the file never names code to run
                system = resolve_registered(example, params, source=where)
            except ModelError as exc:
                raise ModelError(f"{where}: {exc.field}", exc.expected, exc.got) from None
        else:
            raise ModelError("system", "a PWASystem (the file holds no model and names no example to rebuild it from)",
                             "None")
    if not isinstance(system, PWASystem) or system_fingerprint(system) != fingerprint:
        detail = ""
        if isinstance(model, dict) and isinstance(system, PWASystem):
            # The names say which systems; the entry says how they differ (the dynamics first).
            ours = system.to_dict()
            entry = first_difference({k: v for k, v in model.items() if k != "name"},
                                     {k: v for k, v in ours.items() if k != "name"}) or "name"
            detail = f", first differing entry of the model dictionaries: {entry}"
        check_fingerprint(data, REGIONS_FILE, where, system, _text(data.get("system_name")), detail)
        raise ModelError("system", "a PWASystem (regions files hold the regions of a PWA system)",
                         type(system).__name__)
    return _checked_analysis(data, system, where)


def _text(value) -> str | None:
    return value if isinstance(value, str) else None


# ---------------------------------------------------------------------------------- content checks

def _entry(data: dict, key: str, kind: type | tuple, where: str, what: str):
    if key not in data:
        raise ModelError(f"{where}: {key}", what, "missing")
    value = data[key]
    if isinstance(value, bool) and bool not in (kind if isinstance(kind, tuple) else (kind,)):
        raise ModelError(f"{where}: {key}", what, repr(value))
    if not isinstance(value, kind):
        raise ModelError(f"{where}: {key}", what, f"{type(value).__name__} {_short(value)}")
    return value


def _count(data: dict, key: str, where: str, allow_none: bool = False) -> int | None:
    value = data.get(key, ...)
    if value is None and allow_none:
        return None
    if isinstance(value, bool) or not isinstance(value, int) or value < 0:
        raise ModelError(f"{where}: {key}", "a count (an integer >= 0)" + (" or null" if allow_none else ""),
                         "missing" if value is ... else _short(value))
    return value


def _seconds(data: dict, key: str, where: str) -> float:
    value = finite_number(data.get(key), f"{where}: {key}", "a time in seconds (a finite number >= 0)")
    if value < 0:
        raise ModelError(f"{where}: {key}", "a time in seconds (a finite number >= 0)", repr(value))
    return value


def _array(value, field: str, shape: tuple[int, ...]) -> np.ndarray:
    """A JSON array of numbers of exactly ``shape`` (an empty matrix may be written as ``[]``)."""
    def bad(got):
        return ModelError(field, f"an array of numbers of shape {shape}", got)

    def walk(v, depth):
        if isinstance(v, list):
            return [walk(x, depth + 1) for x in v]
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            raise bad(f"an entry {_short(v)}")
        return v

    if not isinstance(value, list):
        raise bad(f"{type(value).__name__} {_short(value)}")
    leaves = walk(value, 0)
    try:
        arr = np.array(leaves, dtype=float)
    except (ValueError, OverflowError):
        raise bad("rows of different lengths") from None
    if arr.size == 0 and 0 in shape:
        arr = arr.reshape(shape)
    if arr.shape != shape:
        raise bad(f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise bad("NaN or infinity")
    return arr


def _same(stored: np.ndarray, ref: np.ndarray) -> bool:
    """Equal up to rounding: the recomputation repeats the products that wrote the file."""
    if stored.shape != ref.shape:
        return False
    if ref.size == 0:
        return True
    return bool(np.all(np.abs(stored - ref) <= MATRIX_EQUAL_RTOL * (1.0 + np.max(np.abs(ref)))))


def _checked_analysis(data: dict[str, Any], system: PWASystem, where: str) -> ObservabilityAnalysis:
    n, m = system.n, system.m
    state_names = _entry(data, "state_names", list, where, f"the state names {list(system.state_names)}")
    if state_names != list(system.state_names):  # implied by the fingerprint; kept as a plain check
        raise ModelError(f"{where}: state_names", f"the system's states {list(system.state_names)}", f"{state_names}")
    if data.get("system_name") != system.name:
        raise ModelError(f"{where}: system_name", f"the system's name {system.name!r}", _short(data.get("system_name")))
    T = _entry(data, "horizon", int, where, "the horizon T (a positive integer)")
    try:
        check_horizon(system, T)
    except ModelError as exc:
        raise ModelError(f"{where}: horizon", exc.expected, exc.got) from None
    scale, centre = horizon_scaling(system, T)
    d = n + T * m
    for key, ref in (("scale", scale), ("centre", centre)):
        if not _same(_array(data.get(key), f"{where}: {key}", (d,)), ref):
            raise ModelError(f"{where}: {key}", f"the {key} of the state and input box of the system over T = {T}",
                             f"other numbers: the file was edited; {_RECOMPUTE}")
    items = _entry(data, "regions", list, where, "a list of regions")
    if not items:
        raise ModelError(f"{where}: regions", "at least one region (X x U is not empty)", "an empty list")
    domain = system.domain
    domain_rows = (domain.A, domain.b)
    regions, seen = [], set()
    for k, item in enumerate(items):
        regions.append(_checked_region(item, k, system, T, domain_rows, scale, centre, f"{where}: regions[{k}]"))
        if regions[-1].sequence in seen:
            raise ModelError(f"{where}: regions[{k}].sequence", "a mode sequence no other region has",
                             f"{list(regions[-1].sequence)} twice")
        seen.add(regions[-1].sequence)
    full_rank = _entry(data, "full_rank", list, where, f"a list of {len(regions)} booleans")
    if len(full_rank) != len(regions):
        raise ModelError(f"{where}: full_rank", f"{len(regions)} booleans (one per region)", f"{len(full_rank)}")
    from . import observability

    sx = scale[:n]
    for k, (flag, reg) in enumerate(zip(full_rank, regions)):
        if not isinstance(flag, bool):
            raise ModelError(f"{where}: full_rank[{k}]", "a boolean", _short(flag))
        if flag != (observability._rank(reg.C * sx[None, :]) == n):
            raise ModelError(f"{where}: full_rank[{k}]", f"{not flag} (the rank test of C of region {k} gives it)",
                             f"{flag}: the file was edited; {_RECOMPUTE}")
    pairs_in = _entry(data, "pairs", list, where, "a list of pairs {i, j, slack}")
    pairs, seen_pairs = [], set()
    for q, item in enumerate(pairs_in):
        f = f"{where}: pairs[{q}]"
        if not isinstance(item, dict):
            raise ModelError(f, "an object {i, j, slack}", type(item).__name__)
        i, j = (_index(item.get(key), f"{f}.{key}", len(regions)) for key in ("i", "j"))
        if not full_rank[i]:
            raise ModelError(f"{f}.i", "a region of I (full_rank): pairs are tested from those only", repr(i))
        if j == i or (i, j) in seen_pairs:
            raise ModelError(f, "a pair of two different regions, listed once", f"({i}, {j})")
        seen_pairs.add((i, j))
        slack = _slack(item.get("slack"), f"{f}.slack")
        pairs.append((i, j, slack))
    es = _entry(data, "enumeration_stats", dict, where, "an object of counts")
    ew = f"{where}: enumeration_stats"
    n_lps, tested, total = (_count(es, key, ew) for key in ("n_lps", "n_prefixes_tested", "n_prefixes_total"))
    if total != sum(system.n_modes ** k for k in range(1, T + 1)) or tested > total:
        raise ModelError(f"{ew}.n_prefixes_total", f"{sum(system.n_modes ** k for k in range(1, T + 1))} prefixes of "
                         f"{system.n_modes} modes up to length {T}, at least n_prefixes_tested", f"{total}, {tested} tested")
    enum = ModeEnumeration(system, T, tuple(regions), scale, centre, n_lps, tested, total, _seconds(es, "seconds", ew))
    st = _entry(data, "analysis_stats", dict, where, "an object of counts")
    aw = f"{where}: analysis_stats"
    analysis = ObservabilityAnalysis(enum, tuple(full_rank), PairSets(enum.regions, n, [t[:2] for t in pairs], [t[2] for t in pairs]), _count(st, "n_pair_lps", aw),
                                     _count(st, "n_pairs_tested", aw), _count(st, "n_pairs_skipped_rank", aw),
                                     _seconds(st, "seconds", aw),
                                     {"n_pairs_dropped_thin": _count(st, "n_pairs_dropped_thin", aw, allow_none=True),
                                      # absent from files written before it was saved
                                      "n_pairs_dropped_same_state": _count(st, "n_pairs_dropped_same_state", aw, allow_none=True)
                                      if "n_pairs_dropped_same_state" in st else None,
                                      # absent from files written before the grouped pair tests
                                      "n_pairs_ruled_out_by_group": _count(st, "n_pairs_ruled_out_by_group", aw, allow_none=True)
                                      if "n_pairs_ruled_out_by_group" in st else None,
                                      # absent from files written before the exact re-decisions
                                      "n_decisions_exact": _count(st, "n_decisions_exact", aw, allow_none=True)
                                      if "n_decisions_exact" in st else None})
    _check_summary(data, analysis, where)
    for key in ("example", "params"):
        if key in data and not isinstance(data[key], (str, type(None)) if key == "example" else dict):
            raise ModelError(f"{where}: {key}", "a string or null" if key == "example" else "an object",
                             type(data[key]).__name__)
    return analysis


def _index(value, field: str, size: int) -> int:
    if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value < size:
        raise ModelError(field, f"a region index in 0..{size - 1}", _short(value))
    return value


def _slack(value, field: str) -> float:
    slack = finite_number(value, field, f"a Chebyshev radius above REGION_SLACK_TOL = {REGION_SLACK_TOL:g}")
    if not slack > REGION_SLACK_TOL:
        raise ModelError(field, f"a Chebyshev radius above REGION_SLACK_TOL = {REGION_SLACK_TOL:g} (thinner regions "
                         "and pairs are never saved)", repr(slack))
    return slack


def _checked_region(item, k: int, system: PWASystem, T: int, domain_rows, scale: np.ndarray, centre: np.ndarray,
                    where: str) -> ModeRegion:
    """Region ``k`` as saved, each array checked against its mode sequence's (no LP)."""
    n, m = system.n, system.m
    if not isinstance(item, dict):
        raise ModelError(where, "an object with the region's sequence and arrays", type(item).__name__)
    seq = item.get("sequence")
    if not isinstance(seq, list) or len(seq) != T or any(isinstance(q, bool) or not isinstance(q, int)
                                                         or not 0 <= q < system.n_modes for q in seq):
        raise ModelError(f"{where}.sequence", f"{T} mode indices in 0..{system.n_modes - 1}", _short(seq))
    # The maps of the sequence without the box's row pruning (which only leaves rows out).
    node = _root(system, T)
    for q in seq:
        node = _child(system, T, node, q, domain_rows, None)
    last = node.prev
    refs = dict(zip(_MAPS, (node.C, node.D, node.f, node.Phi, node.Gamma, node.phi, *last)))
    arrays = {}
    for key in _MAPS:
        ref = refs[key]
        arr = _array(item.get(key), f"{where}.{key}", ref.shape)
        if not _same(arr, ref):
            raise ModelError(f"{where}.{key}", f"the map of the mode sequence {seq} (recomputed from the system)",
                             f"other numbers: the file was edited; {_RECOMPUTE}")
        arrays[key] = arr
    H_in, h_in = item.get("H"), item.get("h")
    rows = len(H_in) if isinstance(H_in, list) else -1
    H = _array(H_in, f"{where}.H", (max(rows, 0), n + T * m))
    h = _array(h_in, f"{where}.h", (H.shape[0],))
    _check_rows(H, h, node.H, node.h, scale, centre, f"{where}.H", seq)
    slack = _slack(item.get("slack"), f"{where}.slack")
    return ModeRegion(tuple(seq), H, h, arrays["C"], arrays["D"], arrays["f"], arrays["Phi"], arrays["Gamma"],
                      arrays["phi"], slack, arrays["Phi_last"], arrays["Gamma_last"], arrays["phi_last"])


def _check_rows(H: np.ndarray, h: np.ndarray, full_H: np.ndarray, full_h: np.ndarray, scale: np.ndarray,
                centre: np.ndarray, field: str, seq) -> None:
    """The saved rows are the sequence's rows in order; a row may be left out only if the box implies it.

    Enumeration drops rows that cannot be active anywhere in the box ``X x U^T`` (interval
    arithmetic); so does any later version of that pruning.  So every saved row must match the
    next rows of the sequence in order, and each row it skips must be implied by the box.
    """
    reach = full_H @ centre + np.abs(full_H) @ scale
    implied = reach <= full_h + BOX_IMPLIED_RTOL * (np.abs(full_H) @ scale + np.abs(full_h))
    j = 0
    for i in range(full_H.shape[0]):
        if j < H.shape[0]:
            row_scale = 1.0 + max(float(np.max(np.abs(full_H[i]), initial=0.0)), abs(float(full_h[i])))
            if (np.all(np.abs(H[j] - full_H[i]) <= MATRIX_EQUAL_RTOL * row_scale)
                    and abs(h[j] - full_h[i]) <= MATRIX_EQUAL_RTOL * row_scale):
                j += 1
                continue
        if not implied[i]:
            raise ModelError(field, f"the guard rows of the mode sequence {list(seq)} (recomputed from the system; "
                             "only rows implied by the state and input box may be left out)",
                             f"row {j} differs from the sequence's row {i}, which the box does not imply: the file "
                             f"was edited; {_RECOMPUTE}")
    if j != H.shape[0]:
        raise ModelError(field, f"the guard rows of the mode sequence {list(seq)} (recomputed from the system)",
                         f"row {j} is none of them: the file was edited; {_RECOMPUTE}")


def _check_summary(data: dict, analysis: ObservabilityAnalysis, where: str) -> None:
    summary = _entry(data, "summary", dict, where, "the summary object 'hybobs regions --json' prints")
    ours = analysis.summary()
    keys = ("example", "horizon", "n_regions", "n_full_rank", "n_unobservable_pieces", "n_reduced_pieces", "n_lps",
            "n_lps_enumeration", "n_lps_pairs", "n_lps_avoided_by_pruning", "n_pairs_tested", "n_pairs_skipped_rank",
            "n_pairs_dropped_thin", "seconds_enumeration", "seconds_algorithm_3_1", "seconds")
    if "n_pairs_ruled_out_by_group" in summary or ours["n_pairs_ruled_out_by_group"] is not None:
        keys += ("n_pairs_ruled_out_by_group",)  # files written before the grouped pair tests have none
    if "n_decisions_exact" in summary or ours["n_decisions_exact"] is not None:
        keys += ("n_decisions_exact",)  # nor those written before the exact re-decisions
    if ours["n_pairs_dropped_same_state"] is not None:
        keys += ("n_pairs_dropped_same_state",)  # nor those written before it was saved
    for key in keys:
        if key not in summary or summary[key] != ours[key] or isinstance(summary[key], bool) != isinstance(ours[key], bool):
            raise ModelError(f"{where}: summary.{key}", f"{ours[key]!r} (from the file's regions, pairs and statistics)",
                             f"{_short(summary.get(key, 'missing'))}: the file was edited; {_RECOMPUTE}")


def _short(value, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."

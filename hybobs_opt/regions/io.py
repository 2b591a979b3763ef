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

:func:`load_analysis` refuses a file whose checksum does not match (edited or corrupted), a
``system`` whose fingerprint is not the stored one (computed for another system) and a stored
model that does not match the stored fingerprint.  The checksum detects edits and corruption,
not forgery: whoever edits the file on purpose can recompute it.  Version-1 files (no model, no
checksum) are refused: recompute them with ``hybobs regions SYSTEM --horizon T --save FILE``.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from ..systems.fingerprint import first_difference, model_fingerprint, sha256_of, system_fingerprint
from .enumeration import ModeEnumeration, ModeRegion
from .observability import ObservabilityAnalysis, PairSet, pair_constraints

FORMAT = "hybobs_opt.regions"
VERSION = 2
#: The entry holding :func:`content_checksum` (the one entry the checksum does not cover).
CHECKSUM_KEY = "checksum"

_RECOMPUTE = "recompute it with 'hybobs regions SYSTEM --horizon T --save FILE'"


def content_checksum(data: dict[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of ``data`` without its ``"checksum"`` entry."""
    return sha256_of({k: v for k, v in data.items() if k != CHECKSUM_KEY})


def save_analysis(analysis: ObservabilityAnalysis, path: str | Path, example: str | None = None, params: dict | None = None) -> Path:
    """Write ``analysis`` to ``path`` (JSON, format :data:`FORMAT`, version :data:`VERSION`).

    ``example`` and ``params`` (the name the system was built from) are stored for information;
    the system itself is stored as its model dictionary with its fingerprint, and the content
    with a checksum (see the module docstring).
    """
    enum = analysis.enumeration
    model = enum.system.to_dict()
    data = {
        "format": FORMAT,
        "version": VERSION,
        "example": example,
        "params": params or {},
        "system_name": enum.system.name,
        "state_names": list(enum.system.state_names),
        "system_model": model,
        "system_fingerprint": model_fingerprint(model),
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
        "pairs": [{"i": p.i, "j": p.j, "slack": p.slack} for p in analysis.pairs],
        "enumeration_stats": {"n_lps": enum.n_lps, "n_prefixes_tested": enum.n_prefixes_tested,
                              "n_prefixes_total": enum.n_prefixes_total, "seconds": enum.seconds},
        "analysis_stats": {"n_pair_lps": analysis.n_pair_lps, "n_pairs_tested": analysis.n_pairs_tested,
                           "n_pairs_skipped_rank": analysis.n_pairs_skipped_rank, "seconds": analysis.seconds,
                           "n_pairs_dropped_thin": analysis.stats.get("n_pairs_dropped_thin")},
        "summary": analysis.summary(),
    }
    text = json.dumps(data)
    data = json.loads(text)  # the checksum covers exactly what a reader gets back
    data[CHECKSUM_KEY] = content_checksum(data)
    path = Path(path)
    path.write_text(json.dumps(data))
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

    Raises
    ------
    ModelError
        If the file is not a regions file, has another version (version-1 files have no
        checksum: recompute them), its content does not match its checksum (edited or
        corrupted), or it was computed for another system than ``system``.
    """
    where = f"regions file {str(path)!r}"
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
        raise ModelError("regions file", "a readable JSON file written by 'hybobs regions --save'", str(exc)) from None
    if not isinstance(data, dict):
        raise ModelError(where, "a JSON object written by 'hybobs regions --save'", type(data).__name__)
    if data.get("format") != FORMAT:
        raise ModelError("regions file format", repr(FORMAT), repr(data.get("format")))
    if data.get("version") != VERSION:
        got = repr(data.get("version"))
        if data.get("version") == 1:
            got += (" (a file from before saved results carried their system and a checksum, so it cannot be "
                    f"checked against the system it is used for: {_RECOMPUTE})")
        raise ModelError("regions file version", str(VERSION), got)
    # Integrity first: nothing of the content is used before it matches its checksum.
    stored_sum = data.get(CHECKSUM_KEY)
    if not isinstance(stored_sum, str) or stored_sum != content_checksum(data):
        what = "no checksum" if not isinstance(stored_sum, str) else "content whose checksum does not match the stored one"
        raise ModelError(where, "content matching its SHA-256 checksum",
                         f"{what}: the file was edited or corrupted after it was saved; {_RECOMPUTE}")
    try:
        return _analysis_from_data(data, system, where)
    except (KeyError, TypeError, ValueError, IndexError) as exc:
        if isinstance(exc, ModelError):
            raise
        raise ModelError(where, "the entries 'hybobs regions --save' writes", f"{type(exc).__name__}: {exc}") from None


def _analysis_from_data(data: dict[str, Any], system, where: str) -> ObservabilityAnalysis:
    fingerprint = data["system_fingerprint"]
    model = data.get("system_model")
    if model is not None and model_fingerprint(model) != fingerprint:
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
            from ..systems.resolve import resolve_system

            system = resolve_system(data["example"], data.get("params", {}))
        else:
            raise ModelError("system", "a PWASystem (the file holds no model and names no example to rebuild it from)",
                             "None")
    given = system_fingerprint(system)
    if given != fingerprint:
        diff = ""
        if model is not None:
            # The names say which systems; the entry says how they differ (the dynamics first).
            ours = system.to_dict()
            entry = first_difference({k: v for k, v in model.items() if k != "name"},
                                     {k: v for k, v in ours.items() if k != "name"}) or "name"
            diff = f", first differing entry of the model dictionaries: {entry}"
        raise ModelError(where, f"the system it was computed for, {data.get('system_name')!r} "
                         f"(fingerprint {fingerprint[:16]})",
                         f"{system.name!r} (fingerprint {given[:16]}){diff}: the file was computed for another "
                         "system; recompute it for this one")
    if list(system.state_names) != data["state_names"]:  # implied by the fingerprint; kept as a plain check
        raise ModelError("system", f"states {data['state_names']}", f"{list(system.state_names)}")
    regions = tuple(
        ModeRegion(tuple(r["sequence"]), *(np.asarray(r[k], dtype=float) for k in ("H", "h", "C", "D", "f", "Phi", "Gamma", "phi")),
                   float(r["slack"]), *(np.asarray(r[k], dtype=float) for k in ("Phi_last", "Gamma_last", "phi_last")))
        for r in data["regions"]
    )
    es = data["enumeration_stats"]
    enum = ModeEnumeration(system, int(data["horizon"]), regions, np.asarray(data["scale"]), np.asarray(data["centre"]),
                           es["n_lps"], es["n_prefixes_tested"], es["n_prefixes_total"], es["seconds"])
    n = system.n
    pairs = tuple(
        PairSet(p["i"], p["j"], *pair_constraints(regions[p["i"]], regions[p["j"]], n), float(p["slack"]))
        for p in data["pairs"]
    )
    st = data["analysis_stats"]
    return ObservabilityAnalysis(enum, tuple(bool(b) for b in data["full_rank"]), pairs, st["n_pair_lps"],
                                 st["n_pairs_tested"], st["n_pairs_skipped_rank"], st["seconds"],
                                 {"n_pairs_dropped_thin": st.get("n_pairs_dropped_thin")})

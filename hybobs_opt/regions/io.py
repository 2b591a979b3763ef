"""Versioned save/load of observability results (the file the lookup observer reads).

Format: JSON, ``{"format": "hybobs_opt.regions", "version": 1, ...}`` holding the regions of
eq. (4) (mode sequence, ``H, h``, ``C, D, f``, ``Phi, Gamma, phi``), the index set ``I``, the
non-empty pair sets ``R_ij`` (as index pairs; their constraints are rebuilt from the regions),
the example name and parameters (to rebuild the system) and the summary.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from ..errors import ModelError
from .enumeration import ModeEnumeration, ModeRegion
from .observability import ObservabilityAnalysis, PairSet, pair_constraints

FORMAT = "hybobs_opt.regions"
VERSION = 1


def save_analysis(analysis: ObservabilityAnalysis, path: str | Path, example: str | None = None, params: dict | None = None) -> Path:
    """Write ``analysis`` to ``path`` (JSON, format :data:`FORMAT`, version :data:`VERSION`)."""
    enum = analysis.enumeration
    data = {
        "format": FORMAT,
        "version": VERSION,
        "example": example,
        "params": params or {},
        "system_name": enum.system.name,
        "state_names": list(enum.system.state_names),
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
    path = Path(path)
    path.write_text(json.dumps(data))
    return path


def load_analysis(path: str | Path, system=None) -> ObservabilityAnalysis:
    """Read a file written by :func:`save_analysis`.

    Parameters
    ----------
    path : path-like
    system : PWASystem, optional
        The system the file was computed for; by default it is rebuilt from the stored example
        name and parameters (:func:`hybobs_opt.systems.resolve.resolve_system`).

    Raises
    ------
    ModelError
        If the file is not a regions file, has another version, or does not match ``system``.
    """
    try:
        data = json.loads(Path(path).read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ModelError("regions file", "a readable JSON file written by 'hybobs regions --save'", str(exc)) from None
    if data.get("format") != FORMAT:
        raise ModelError("regions file format", repr(FORMAT), repr(data.get("format")))
    if data.get("version") != VERSION:
        raise ModelError("regions file version", str(VERSION), repr(data.get("version")))
    if system is None:
        if not data.get("example"):
            raise ModelError("system", "a PWASystem (the file names no example to rebuild it from)", "None")
        from ..systems.resolve import resolve_system

        system = resolve_system(data["example"], data.get("params", {}))
    if list(system.state_names) != data["state_names"]:
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

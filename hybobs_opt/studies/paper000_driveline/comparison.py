"""Paper 000's comparison: the hybrid observer (location + continuous observer) against the
lookup-table deadbeat observer of paper 002 run on the same samples of the driveline discretised
with ``HybridAutomaton.discretize`` (location right / unknown / wrong, detection delays, errors
after convergence, time per ``step``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from hybobs_opt.contract import Observer, ObserverTrace

#: Horizons of the lookup observer: T = 3 = n / p is the shortest deadbeat horizon, T = 4 the
#: shortest at which almost every window of the scenario is observable.
LOOKUP_HORIZONS = (3, 4)

#: Errors are compared from this time on (both observers have converged; the step is at 2 s).
COMPARE_FROM = 1.0


def timed(observer: Observer, U: np.ndarray, Y: np.ndarray) -> ObserverTrace:
    """Run ``step`` sample by sample from the reset state (the per-step online cost)."""
    observer.reset()
    return Observer.run(observer, U, Y)


def _delays(t: np.ndarray, events: list[dict], mode: np.ndarray) -> list[float | None]:
    from hybobs_opt.observers.location_observer import detection_delays

    return detection_delays(t, events, mode)


def compare(res, horizons=LOOKUP_HORIZONS) -> tuple[dict[str, dict[str, Any]], dict[str, ObserverTrace]]:
    """Rows of the comparison table: the hybrid observer of paper 000 and the lookup observer."""
    from hybobs_opt.observers.hybrid_observer import HybridObserver
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.regions import analyse_observability

    tr = res.trace
    Ts = float(tr.t[1] - tr.t[0])
    rows: dict[str, dict[str, Any]] = {}
    outs: dict[str, ObserverTrace] = {}
    obs = HybridObserver(res.bank, res.design, Ts, x0=res.run.x_hat[0])
    outs["location + continuous (paper 000)"] = timed(obs, tr.u, tr.y)
    pwa = res.automaton.discretize(Ts)
    for T in horizons:
        an = analyse_observability(pwa, T)
        lk = LookupObserver(an)
        lk.run(tr.u[: 3 * T], tr.y[: 3 * T])  # compile the kernel before timing
        outs[f"lookup T={T} (paper 002)"] = timed(lk, tr.u, tr.y)
    sel = tr.t >= COMPARE_FROM
    for name, out in outs.items():
        err = np.abs(out.x_hat - tr.x)
        right = out.mode == tr.q
        unknown = out.mode < 0
        rows[name] = {
            "location_right": float(right.mean()),
            "location_unknown_or_ambiguous": float(unknown.mean()),
            "location_wrong": float((~right & ~unknown).mean()),
            "detection_delays": _delays(tr.t, tr.events, out.mode),
            "max_abs_error": np.nanmax(err[sel], axis=0).tolist(),
            "rms_error": np.sqrt(np.nanmean(err[sel] ** 2, axis=0)).tolist(),
            **out.timing(),
        }
    return rows, outs

"""Paper 001's comparison: the sliding-mode observer (5) against the lookup-table deadbeat
observer of paper 002 on the same continuous double-scroll trajectory (Example 3), the lookup
observer running on the model discretised with ``HybridAutomaton.discretize``.

Shared with the report (section "Sliding-mode observer") and
``notebooks/01_sliding_mode_observers.ipynb``.
"""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from .scenarios import ScenarioResult, run_scenario

#: Tolerance of the comparison with the lookup observer: an observer has converged when every
#: state's error stays below this fraction of the state's range on the trajectory (the same test
#: for both observers).
COMPARISON_RTOL = 1e-2

#: Horizon T of the lookup observer (paper 002): the smallest with a full-rank region for every
#: mode sequence of the double scroll (n = 3 states, one output).
LOOKUP_HORIZON = 3


def _converged_after(t: np.ndarray, err: np.ndarray, tol: np.ndarray) -> float:
    bad = np.nonzero(np.any(np.abs(err) > tol[None, :], axis=1))[0]
    if bad.size == 0:
        return float(t[0])
    return float(t[bad[-1] + 1]) if bad[-1] < t.size - 1 else float("nan")


def lookup_comparison(smo: ScenarioResult | None = None, sample_periods: tuple[float, ...] = (1e-3, 1e-2)) -> list[dict[str, Any]]:
    """Sliding-mode observer (5) vs the lookup-table deadbeat observer (paper 002, Algorithm 4.1).

    Both observe the same continuous double-scroll trajectory (event-located simulation of
    Example 3, started on the attractor).  The lookup observer works on
    ``double_scroll().discretize(Ts)`` with horizon :data:`LOOKUP_HORIZON` (offline:
    ``analyse_observability``), so it is exact except for samples whose interval contains a
    switch (the location is frozen over a sample).  Convergence time: first time after which every
    state's error stays below :data:`COMPARISON_RTOL` of its range.  Compute time per step: the
    median of the Python loop (sliding mode) and the mean of the compiled loop (lookup, after a
    warm-up run that compiles it).

    Returns
    -------
    list of dict
        One row per observer (and sample period for the lookup).
    """
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.regions import analyse_observability
    from hybobs_opt.sim.hybrid import simulate_hybrid

    smo = smo if smo is not None else run_scenario("double_scroll")
    a = smo.form.automaton
    x0 = smo.truth.x[0]
    t_final = float(smo.truth.t[-1])
    x_range = np.ptp(smo.truth.x, axis=0)
    tol = COMPARISON_RTOL * x_range
    rows = []
    err = smo.run.trace.x_hat - smo.truth.x
    tc = _converged_after(smo.t, err, tol)
    after = smo.t >= tc if np.isfinite(tc) else np.zeros(smo.t.size, bool)
    rows.append({
        "observer": "sliding mode (eq. 5)", "Ts": smo.observer.Ts, "offline_s": None,
        "convergence_time_s": tc,
        "max_error_after": np.abs(err[after]).max(axis=0).tolist() if after.any() else None,
        "rms_error_after": np.sqrt(np.mean(err[after] ** 2, axis=0)).tolist() if after.any() else None,
        "step_s": float(np.median(smo.run.trace.seconds)), "note": "Python loop, no offline work",
    })
    for Ts in sample_periods:
        same = np.isclose(Ts, smo.observer.Ts, rtol=1e-12)
        truth = smo.truth if same else simulate_hybrid(a, x0, t_final, dt=Ts)
        t0 = time.perf_counter()
        analysis = analyse_observability(a.discretize(Ts), LOOKUP_HORIZON)
        obs = LookupObserver(analysis)
        offline = time.perf_counter() - t0
        U = np.zeros((truth.t.size, 0))
        obs.run(U[:50], truth.y[:50], x0=np.zeros(3))  # compiles the loop once
        ot = obs.run(U, truth.y, x0=np.zeros(3))
        e = ot.x_hat - truth.x
        tcl = _converged_after(truth.t, e, tol)
        aft = truth.t >= tcl if np.isfinite(tcl) else np.zeros(truth.t.size, bool)
        rows.append({
            "observer": f"lookup (paper 002, T = {LOOKUP_HORIZON})", "Ts": Ts, "offline_s": offline,
            "convergence_time_s": tcl,
            "max_error_after": np.abs(e[aft]).max(axis=0).tolist() if aft.any() else None,
            "rms_error_after": np.sqrt(np.mean(e[aft] ** 2, axis=0)).tolist() if aft.any() else None,
            "step_s": float(ot.seconds[0]), "note": "compiled loop; flags: " + ", ".join(f"{k} {v}" for k, v in ot.flag_counts().items()),
        })
    return rows

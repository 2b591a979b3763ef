"""Paper 002 with the backlash gap unknown to the observer (issue 18).

Section 8 of paper 002: "the backlash gap alpha is assumed known, seldom true in real powertrains".
This study hides ``alpha``: for each of ``draws`` values drawn uniformly in ``[0.02, 0.08]`` rad
(seeded), model (16) with that gap runs the bench scenario (noise-free; the twist bound widened to
``theta_max = 0.3`` rad, because the scenario's torque profile twists the shaft beyond the paper's
0.2 rad when ``alpha > 0.055``), and a :class:`~hybobs_opt.observers.parameter_bank.ParameterBank`
of lookup observers over a grid of gaps (built once, not told the truth) estimates the gap and the
state.  Reported per draw: the estimate after the first backlash crossing (the first time the
shaft has gone through the whole gap) and its relative error, the spread of the estimate over the
rest of the run, when the gap became determined, the bank's state errors where it flags
``observable``, and those of the lookup observer told the true gap (the reference).

Why a bank and not the MIQP with ``alpha`` as a decision variable: that problem is the MIQP (10)
of the system augmented with ``alpha``
(:func:`~hybobs_opt.systems.parameters.augment_parameters`), but ``alpha`` is determined only by
windows that hold a whole traversal of the gap (Algorithm 3.1 on the augmented system: at ``T = 4``
only the sequences contact, backlash, other contact have full rank), and on this scenario a
traversal lasts 50-120 samples; ``benchmarks/bench_unknown_gap.py`` measures the augmented MIQP
on a window of 20 samples.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hybobs_opt.contract import OBSERVABLE
from hybobs_opt.errors import ModelError

#: Interval of the hidden gap (rad), as in issue 18.
GAP_INTERVAL = (0.02, 0.08)

#: Twist bound of the study (rad): the scenario stays inside it for every gap of the interval.
GAP_STUDY_THETA_MAX = 0.3

#: Grid spacing of the bank (rad): 31 observers over the interval.
GAP_GRID_STEP = 0.002


def first_crossing(q: np.ndarray, gap_mode: int = 1) -> int | None:
    """Index of the first sample after the shaft has crossed the whole gap (contact, gap, the other contact).

    Parameters
    ----------
    q : (N,) int array
        The true mode per sample (0 and 2 the contacts, ``gap_mode`` the backlash).
    gap_mode : int, default 1
        The backlash mode.

    Returns
    -------
    int or None
        The first sample in the other contact mode, or ``None`` if the run has no crossing.
    """
    q = np.asarray(q)
    for t in range(1, q.size):
        if q[t] != gap_mode and q[t - 1] == gap_mode:
            before = q[:t][q[:t] != gap_mode]
            if before.size and before[-1] != q[t]:
                return t
    return None


def run_unknown_gap_study(draws: int = 10, steps: int = 3000, *, seed: int = 0, grid_step: float = GAP_GRID_STEP,
                          T: int = 3, progress: Callable[[str, int, int], None] | None = None,
                          traces: list | None = None) -> dict[str, Any]:
    """Run the study (module docstring) and return its JSON-ready table.

    Parameters
    ----------
    draws : int, default 10
        Hidden gaps drawn in :data:`GAP_INTERVAL`.
    steps : int, default 3000
        Samples of the scenario.
    seed : int, default 0
        Seed of the draws.
    grid_step : float, default GAP_GRID_STEP
        Spacing of the bank's grid over :data:`GAP_INTERVAL`.
    T : int, default 3
        Horizon of the bank's lookup observers.
    progress : callable, optional
        ``progress(what, done, total)``.
    traces : list, optional
        If given, filled with ``(t, alpha, estimate per sample)`` per draw
        (:func:`~hybobs_opt.studies.paper002_powertrain.plots.plot_gap_estimates`).

    Returns
    -------
    dict
        ``{"draws": [per-draw record], "summary": {...}, ...}``.
    """
    from hybobs_opt.cache import cached_analysis
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.observers.parameter_bank import ParameterBank

    from .systems import SCENARIO_TORQUES, backlash_scenario, powertrain3

    if isinstance(draws, bool) or not isinstance(draws, (int, np.integer)) or draws < 1:
        raise ModelError("draws", "a positive number of hidden gaps", repr(draws))
    lo, hi = GAP_INTERVAL
    if not (np.isfinite(grid_step) and 0 < grid_step <= (hi - lo) / 2):
        raise ModelError("grid_step", f"a positive spacing of at most {(hi - lo) / 2:g} rad", repr(grid_step))
    grid = np.arange(lo, hi + grid_step / 2, grid_step)

    def build(alpha: float):
        return powertrain3(alpha=alpha, theta_max=GAP_STUDY_THETA_MAX)

    t0 = time.perf_counter()
    bank = ParameterBank(build, "alpha", grid, T,
                         progress=None if progress is None else (lambda d, n: progress("bank members", d, n)))
    truths = np.random.default_rng(seed).uniform(lo, hi, draws)
    records = []
    for k, alpha in enumerate(truths):
        plant = build(float(alpha))
        trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=steps * plant.Ts)
        out = bank.run(trace.u, trace.y)
        known = LookupObserver(cached_analysis(plant, T)).run(trace.u, trace.y)
        cross = first_crossing(trace.q)
        if traces is not None:
            traces.append((trace.t, float(alpha), out.parameter.copy()))
        rec: dict[str, Any] = {"alpha": float(alpha), "first_crossing_sample": cross}
        det = np.nonzero(out.determined)[0]
        rec["determined_from_sample"] = int(det[0]) if det.size else None
        after = None if cross is None else out.parameter[cross + T:]
        if after is not None and after.size and np.all(np.isfinite(after)):
            rel = np.abs(after - alpha) / alpha
            rec["estimate_after_first_crossing"] = float(after[0])
            rec["relative_error_after_first_crossing"] = float(rel[0])
            rec["max_relative_error_after_first_crossing"] = float(rel.max())
            rec["estimate_spread_after_first_crossing"] = [float(after.min()), float(after.max())]
        else:
            rec["estimate_after_first_crossing"] = None
            rec["relative_error_after_first_crossing"] = None
            rec["max_relative_error_after_first_crossing"] = None
            rec["estimate_spread_after_first_crossing"] = None
        rec["final_estimate"] = float(out.parameter[-1]) if np.isfinite(out.parameter[-1]) else None
        for label, run in (("bank", out), ("known_gap", known)):
            flagged = run.flags == OBSERVABLE
            err = run.x_hat - trace.x
            rec[f"{label}_flags"] = run.flag_counts()
            rec[f"{label}_max_abs_error_flagged"] = ({nm: float(np.abs(err[flagged, i]).max())
                                                     for i, nm in enumerate(plant.state_names)} if flagged.any() else None)
            rec[f"{label}_rms_error_flagged"] = ({nm: float(np.sqrt(np.mean(err[flagged, i] ** 2)))
                                                 for i, nm in enumerate(plant.state_names)} if flagged.any() else None)
        rec["bank_seconds_per_step"] = float(out.seconds[0])
        rec["refined_at"] = bank.refined_value
        records.append(rec)
        if progress:
            progress(f"alpha = {alpha:.5f}", k + 1, draws)
    rels = [r["max_relative_error_after_first_crossing"] for r in records]
    return {
        "example": "powertrain3",
        "theta_max": GAP_STUDY_THETA_MAX,
        "interval": list(GAP_INTERVAL),
        "grid": {"step": grid_step, "n": int(grid.size)},
        "horizon": T,
        "steps": steps,
        "bank_build_seconds": bank.build_seconds,
        "draws": records,
        "summary": {
            "worst_relative_error_after_first_crossing": None if any(r is None for r in rels) else float(max(rels)),
            "within_5_percent": all(r is not None and r <= 0.05 for r in rels),
        },
        "seconds": time.perf_counter() - t0,
    }

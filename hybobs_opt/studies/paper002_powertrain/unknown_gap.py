"""Paper 002 with the backlash gap unknown to the observer.

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

#: Interval of the hidden gap (rad), around Table 1's alpha = 0.05 rad.
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


def run_gap_interval_study(alphas, steps: int = 3000, noise_bound: float = 1e-3, *, noise: str = "uniform",
                           start: int = 0, seed: int = 0,
                           progress: Callable[[str, int, int], None] | None = None) -> dict[str, Any]:
    """The interval of gaps consistent with the data, certified under bounded noise.

    For each hidden gap, the bench scenario runs on model (16) with that gap (twist bound
    :data:`GAP_STUDY_THETA_MAX`), the engine speed is measured with noise, and a
    :class:`~hybobs_opt.observers.set_filter.SetMembershipFilter` on the system augmented with the
    gap (:func:`~hybobs_opt.systems.parameters.augment_parameters`, ``alpha`` in
    :data:`GAP_INTERVAL`) keeps every augmented state consistent with the whole record.  Its box
    gives the interval of gaps and a radius per state; the filter flags ``observable`` only when
    every radius, the twist's included (which carries the gap's uncertainty), is within the
    tolerance.

    Parameters
    ----------
    alphas : sequence of float
        The hidden gaps (rad), inside :data:`GAP_INTERVAL`.
    steps : int, default 3000
        Samples of the scenario used (from ``start``).
    noise_bound : float, default 1e-3
        The bound told to the filter (rad/s).
    noise : {"uniform", "gaussian"}
        ``"uniform"``: noise drawn uniformly within the bound (the bound holds by construction);
        ``"gaussian"``: white Gaussian noise of standard deviation ``noise_bound / 5`` (the bound,
        five standard deviations, then holds with probability about ``1 - 6e-7`` per sample).
    start : int, default 0
        First sample of the scenario given to the filter (it starts from the whole state set).
    seed : int, default 0
        Seed of the noise.
    progress : callable, optional
        ``progress(what, done, total)``.

    Returns
    -------
    dict
        Per gap: the final interval and its width, the first sample where the interval is within
        1 % of the gap, the number of steps where a true state (gap included) lies outside the
        reported box (must be 0 whenever the noise respects the bound), the flags, the largest
        twist error where flagged against the radius, the median seconds per step.
    """
    from hybobs_opt.contract import FALLBACK
    from hybobs_opt.observers.set_filter import SetMembershipFilter
    from hybobs_opt.systems.parameters import augment_parameters

    from .systems import SCENARIO_TORQUES, backlash_scenario, powertrain3

    if noise not in ("uniform", "gaussian"):
        raise ModelError("noise", "'uniform' or 'gaussian'", repr(noise))
    lo, hi = GAP_INTERVAL
    alphas = [float(a) for a in np.atleast_1d(np.asarray(alphas, dtype=float))]
    if not alphas or not all(lo <= a <= hi for a in alphas):
        raise ModelError("alphas", f"gaps in [{lo:g}, {hi:g}] rad", repr(alphas))

    def build(alpha: float):
        return powertrain3(alpha=alpha, theta_max=GAP_STUDY_THETA_MAX)

    aug = augment_parameters(build, {"alpha": GAP_INTERVAL})
    t0 = time.perf_counter()
    rng = np.random.default_rng(seed)
    records = []
    for k, alpha in enumerate(alphas):
        plant = build(alpha)
        trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=(start + steps) * plant.Ts)
        U, X, Y = trace.u[start:], trace.x[start:], trace.y[start:]
        if noise == "uniform":
            Y = Y + rng.uniform(-noise_bound, noise_bound, size=Y.shape)
        else:
            Y = Y + rng.normal(size=Y.shape) * (noise_bound / 5.0)
        within = bool(np.all(np.abs(Y - trace.y[start:]) <= noise_bound))
        filt = SetMembershipFilter(aug.system, noise_bound)
        a_i = len(plant.state_names)
        n_out, flagged, worst, secs = 0, 0, 0.0, []
        widths = np.full(len(U), np.nan)
        first_1pc = None
        interval = (lo, hi)
        for t in range(len(U)):
            est = filt.step(U[t], Y[t])
            secs.append(est.seconds)
            if est.flag == FALLBACK or "lower" not in est.info:
                continue
            lower, upper = est.info["lower"], est.info["upper"]
            truth = np.append(X[t], alpha)
            n_out += bool(np.any((truth < lower) | (truth > upper)))
            interval = (float(lower[a_i]), float(upper[a_i]))
            widths[t] = interval[1] - interval[0]
            if first_1pc is None and widths[t] <= 0.01 * alpha:
                first_1pc = t + start
            if est.flag == OBSERVABLE:
                flagged += 1
                worst = max(worst, float(np.abs(est.x[0] - X[t, 0]) / max(est.info["radius"][0], 1e-300)))
        cross = first_crossing(trace.q)
        records.append({"alpha": alpha, "noise": noise, "noise_within_bound": within,
                        "first_crossing_sample": cross, "final_interval": list(interval),
                        "final_width": interval[1] - interval[0], "interval_within_1_percent_from_sample": first_1pc,
                        "n_outside_box": n_out, "n_flagged_observable": flagged,
                        "max_theta_error_over_radius_flagged": worst if flagged else None,
                        "median_step_s": float(np.median(secs)), "lps": filt.n_lps})
        if progress:
            progress(f"alpha = {alpha:.5f}", k + 1, len(alphas))
    return {"example": "powertrain3", "theta_max": GAP_STUDY_THETA_MAX, "interval": list(GAP_INTERVAL),
            "noise_bound": noise_bound, "noise": noise, "steps": steps, "start": start, "draws": records,
            "summary": {"n_outside_box": sum(r["n_outside_box"] for r in records),
                        "max_final_width": max(r["final_width"] for r in records),
                        "n_flagged_observable": sum(r["n_flagged_observable"] for r in records)},
            "seconds": time.perf_counter() - t0}

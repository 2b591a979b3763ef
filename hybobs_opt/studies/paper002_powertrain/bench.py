"""Paper 002, Section 7: the lookup observer against the MIQP/MILP moving-horizon observers.

The study behind ``hybobs bench`` and ``hybobs observe powertrain3/powertrain5``.

All observers run on the same simulated trace (model (16), the torque profile that drives the
shaft through the backlash, optional output noise).  Reported per observer: per-step compute
time (median, p95, max over ``step`` calls), the largest state error over the steps it flags
observable, the errors of ``theta`` and ``omega_l`` on the intervals where the true window is
observable (its mode sequence has ``rank C_i = n``) and where it is not, and how often it flags
unobservability.  Plots like the paper's Figs. 7-9.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.contract import ObserverTrace
from hybobs_opt.defaults import NOISE_FIT_SIGMAS
from hybobs_opt.progress import phase_bars
from hybobs_opt.regions import PointClass
from hybobs_opt.observers.comparison import (
    exact_window_labels,
    summarise as _summarise,
    timed_steps,
    true_window_observable,
    wilson_interval,
)

#: States whose errors are reported on the observable / unobservable intervals (Figs. 7-9).
INTERVAL_STATES = ("theta", "omega_l")

#: The examples with a bench scenario (a torque profile through the backlash).
SCENARIO_EXAMPLES = ("powertrain3", "powertrain5")


def summarise(out: ObserverTrace, x_true: np.ndarray, truly_observable: np.ndarray, state_names, solver: str,
              warmup: int = 0) -> dict[str, Any]:
    """:func:`hybobs_opt.observers.comparison.summarise` with the paper's interval states ``theta``, ``omega_l``."""
    return _summarise(out, x_true, truly_observable, state_names, solver, warmup, INTERVAL_STATES)


def bench_trace(example: str, T: int, steps: int, noise: float, seed: int = 0, params: dict | None = None,
                progress: Callable[[int, int], None] | None = None):
    """The plant, its regions analysis and the (noisy) trace of the paper's scenario.

    ``progress`` (a ``(done, total)`` callable or a :class:`~hybobs_opt.progress.PhaseProgress`)
    follows Algorithm 3.1 (:func:`~hybobs_opt.regions.analyse_observability`); the analysis comes
    from the active cache when there is one (:mod:`hybobs_opt.cache`).
    """
    from hybobs_opt.cache import cached_analysis
    from hybobs_opt.studies import get_example

    from .systems import SCENARIO_TORQUES, backlash_scenario

    ex = get_example(example)
    if ex.kind != "pwa" or example not in SCENARIO_TORQUES:
        raise ModelError("example", f"a PWA example with a bench scenario ({', '.join(sorted(SCENARIO_TORQUES))}; "
                         "for any other PWA system pass a CSV log with --data)", f"{example!r} of kind {ex.kind!r}")
    if steps < T + 1:
        raise ModelError("--steps", f"more than the horizon T = {T}", repr(steps))
    if not (np.isfinite(noise) and noise >= 0):
        raise ModelError("--noise", "a non-negative standard deviation", repr(noise))
    plant = ex.build(**(params or {}))
    trace = backlash_scenario(plant, SCENARIO_TORQUES[example], t_final=steps * plant.Ts)
    y = trace.y + (np.random.default_rng(seed).normal(0.0, noise, trace.y.shape) if noise > 0 else 0.0)
    analysis = cached_analysis(plant, T, progress=progress)
    return plant, trace, y, analysis


def run_bench(example: str, T: int, steps: int, noise: float, observers: list[str], mhe_steps: int | None = None,
              plot: str | None = None, seed: int = 0,
              progress: Callable[[str, str, int, int], None] | None = None, params: dict | None = None) -> dict[str, Any]:
    """Run the comparison and return the JSON-ready summary (see module docstring).

    ``progress(phase, unit, done, total)`` follows the phases (Algorithm 3.1, the lookup tables,
    the observers' steps); see :func:`hybobs_opt.progress.phase_bars`.
    """
    from hybobs_opt.observers.lookup import LookupObserver

    def phase(name: str, unit: str):
        return None if progress is None else (lambda done, total: progress(name, unit, done, total))

    from hybobs_opt.progress import PhaseProgress

    t0 = time.perf_counter()
    analysis_progress = None if progress is None else PhaseProgress(
        lambda name, unit, done, total: progress(f"Algorithm 3.1: {name}", unit, done, total))
    plant, trace, y, analysis = bench_trace(example, T, steps, noise, seed, params, progress=analysis_progress)
    analysis_s = time.perf_counter() - t0
    truly = true_window_observable(analysis, trace.q)
    _, labels = exact_window_labels(analysis, trace.x, progress=phase("exact labels", "state"))
    n_obs = int(np.count_nonzero(labels == PointClass.OBSERVABLE))
    exact_share = n_obs / len(labels) if len(labels) else None
    U = trace.u
    results: dict[str, Any] = {}
    outs: dict[str, ObserverTrace] = {}
    for name in observers:
        if name == "lookup":
            # The exact output tolerance also with noise: accepting noisy windows would hand them to
            # an ill-conditioned pseudo-inverse (omega_l is weakly visible in three engine speeds).
            obs = LookupObserver(analysis, progress=phase("lookup tables", "piece"))
            obs.run(U[: 2 * T], y[: 2 * T])  # load the compiled kernel before timing
            t0 = time.perf_counter()
            batch = obs.run(U, y, progress=phase("lookup (batch)", "step"))
            batch_s = time.perf_counter() - t0
            out = timed_steps(obs, U, y, progress=phase("lookup (step by step)", "step"))
            solver = ("none (lookup table, numba kernel)" if obs.btilde_test == "polytopes" else
                      "numba kernel; certified DAQP LPs for the B~_T pieces the screen leaves" if obs.btilde_test == "pairs"
                      else "numba kernel; certified DAQP LPs on the data (exact variant)")
            rec = summarise(out, trace.x, truly, plant.state_names, solver, T - 1)
            rec["batch_steps_per_s"] = steps / batch_s
            rec["batch_equals_steps"] = bool(np.array_equal(batch.flags, out.flags))
            rec["table_seconds"] = obs.table_seconds
            rec["btilde_test"] = obs.btilde_test
            rec["lookup_stats"] = obs.stats()
            rec["fallback_reasons"] = batch.fallback_reasons()
        elif name in ("miqp", "milp", "milp_inf"):
            from hybobs_opt.mhe import MHEObserver

            norm = {"miqp": "2", "milp": "1", "milp_inf": "inf"}[name]
            # with output noise the windows fit the model only to the noise level: the MIQP is told it
            # (noise_std: weight, fit tolerance and a confidence-region uniqueness test); the MILPs
            # only get the fit tolerance (their flags keep the noise-free meaning, see the note)
            if noise > 0 and norm == "2":
                obs = MHEObserver(plant, T, norm=norm, noise_std=noise)
            else:
                obs = MHEObserver(plant, T, norm=norm, fit_tolerance=NOISE_FIT_SIGMAS * noise if noise > 0 else None)
            n_mhe = min(steps, mhe_steps or steps)
            out = timed_steps(obs, U[:n_mhe], y[:n_mhe], progress=phase(name, "step"), chunk=10)
            rec = summarise(out, trace.x[:n_mhe], truly[:n_mhe], plant.state_names, obs.solver, T - 1)
        else:
            raise ModelError("--observers", "names among lookup, miqp, milp, milp_inf", repr(name))
        results[name] = rec
        outs[name] = out
    if "lookup" in results:
        base = results["lookup"]["median_step_s"]
        for rec in results.values():
            rec["ratio_to_lookup"] = rec["median_step_s"] / base if base else None
    summary = {
        "example": example,
        "horizon": T,
        "steps": steps,
        "noise": noise,
        "observers": results,
        # the rank condition of the true mode sequence (necessary only); the exact share follows
        "full_rank_sequence_fraction": float(truly[T - 1 :].mean()),
        "truly_observable_fraction": exact_share,
        "truly_observable_fraction_ci95": wilson_interval(n_obs, len(labels)),
        "truly_observable_windows_classified": int(len(labels)),
        "analysis_seconds": analysis_s,
        "paper_seconds_per_step": {"miqp": 3.0, "lookup": 0.031},
    }
    if noise > 0:
        square = T * plant.p == plant.n
        summary["note"] = (
            "with output noise the lookup observer's consistency test (eq. 12) can reject a noisy window only when "
            "T p > n; " + ("here T p = n, so every window fits some region exactly and the noise reaches the estimate "
                           "through the inverse of C_i (see max_abs_error_observable); " if square else "")
            + "windows pushed out of every region leave chi empty and the observer predicts open loop "
            "(flags unobservable/fallback); the moving-horizon observers return a least-error estimate instead. The "
            "MIQP is told the noise level (noise_std): it flags a window observable only when the 99.9 % confidence "
            "region of its start state lies within delta; the MILPs' uniqueness test keeps its noise-free epsilon. "
            "The noise-aware lookup observer is compared in the noise study (benchmarks.bench_noise)"
        )
    if plot:
        plot_bench(trace, outs, plot)
        summary["plot"] = plot
    return summary


def plot_bench(trace, outs: dict[str, ObserverTrace], path: str) -> str:
    """Figs. 7-9 of paper 002: true twist angle and wheel speed; each observer's errors and flags.

    The errors of both states are drawn on a log scale and each observer's observability flag on
    its own labelled axis (:func:`hybobs_opt.studies.paper002_powertrain.plots.plot_observer_errors`).
    """
    from .plots import plot_observer_errors
    from .systems import TABLE1

    return plot_observer_errors(trace, outs, path, backlash=TABLE1["alpha"] if "theta" in trace.state_names else None)


def _observe_scenario(example: str, horizon: int):
    def scenario(args) -> dict[str, Any]:
        kind = args.observer or "lookup"
        progress, close = phase_bars(not getattr(args, "json", False))
        try:
            summary = run_bench(example, horizon, 3000, 0.0, [kind], plot=args.plot, progress=progress)
        finally:
            close()
        summary["observer"] = kind
        return summary

    return scenario


#: The study's scenario runner under the name every study uses.
run_scenario = run_bench


def register_scenarios(register) -> None:
    """``hybobs observe powertrain3`` / ``powertrain5``: the lookup observer (or ``--observers``) on the scenario."""
    register("powertrain3", _observe_scenario("powertrain3", 3))
    register("powertrain5", _observe_scenario("powertrain5", 5))

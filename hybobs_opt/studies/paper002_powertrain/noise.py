"""Paper 002 with noisy sensors: the observers of the bench against a Kalman filter.

Section 8 of paper 002 names noise-free measurements as an assumption that keeps its observers
off a real vehicle.  This study runs, on the bench scenario of model (16) (the torque profile that
drives the shaft through the backlash, :mod:`.bench`) with white Gaussian output noise of standard
deviation ``sigma`` (rad/s) added to the engine speed:

* ``lookup``: the paper's lookup observer (Algorithm 4.1, ``T = 3``, exact tests);
* ``lookup-noise``: :class:`~hybobs_opt.observers.noise_lookup.NoiseAwareLookupObserver`
  (``T = 4`` by default: the residual test needs ``T p > n``; also ``T = 6`` as
  ``lookup-noise-T6``), at false-alarm ``1e-3``;
* ``miqp``: the moving-horizon observer (10) told the noise level (``noise_std``: output weight
  ``1 / sigma``, fit tolerance :data:`~hybobs_opt.defaults.NOISE_FIT_SIGMAS` ``sigma``, and
  ``observable`` only when the 99.9 % confidence region of the window-start state lies within
  ``delta``);
* ``miqp-kalman``: the same with the arrival cost tuned from the noise level
  (``arrival_weight="kalman"``: the prior of each window is a Kalman filter's prediction from the
  samples before it, in the modes the windows estimated, weighted by its inverse covariance), so
  the confidence region is the posterior's; its estimates state a covariance;
* ``kalman``: :class:`~hybobs_opt.observers.kalman.ModeSequenceKalmanFilter`, told the *true*
  mode sequence -- the unattainable reference: no hybrid observer knows the modes.

Per observer and noise level: RMS error per state over the samples whose true window is
observable (its mode sequence has ``rank C_i = n`` at the paper's ``T = 3``) and over the samples
the observer flags ``observable``; the flag counts; per-step compute time (median, p95, max over
``step`` calls); and for the observers that state a covariance, the largest Mahalanobis distance
of a flagged estimate's error and how many exceed 5.  ``benchmarks/bench_noise.py`` writes the
table to ``benchmarks/results/noise.json``; the report shows a shorter run.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from typing import Any

import numpy as np

from hybobs_opt.contract import OBSERVABLE, ObserverTrace
from hybobs_opt.errors import ModelError

#: Output noise standard deviations of the study (rad/s, on the engine speed): three decades, up to the level
#: at which windows of a few 1 ms samples no longer tell the contact modes apart.
NOISE_LEVELS = (0.001, 0.01, 0.1)

#: Observers of the study, in the order of its table.
NOISE_OBSERVERS = ("lookup", "lookup-noise", "miqp", "miqp-kalman", "kalman")

#: Horizons of the noise-aware lookup observer on model (16): T p = 4 > n = 3 (within the 1 ms
#: sample period per step), and T = 6 (more windows observable, about 1 ms per step).  The record
#: of the first is ``lookup-noise``, of the others ``lookup-noise-T<T>``.
NOISE_LOOKUP_HORIZONS = (4, 6)

#: Mahalanobis distance beyond which a flagged estimate contradicts its stated covariance.
COVARIANCE_SIGMAS = 5.0


def _record(out: ObserverTrace, x_true: np.ndarray, truly: np.ndarray, names, warmup: int) -> dict[str, Any]:
    err = out.x_hat - x_true
    flagged = out.flags == OBSERVABLE
    after = np.arange(err.shape[0]) >= warmup
    rec: dict[str, Any] = dict(out.timing())
    rec["flags"] = out.flag_counts()
    for label, mask in (("truly_observable", truly & after), ("flagged_observable", flagged)):
        sel = mask & np.all(np.isfinite(err), axis=1)
        rec[f"rms_error_{label}"] = ({nm: float(np.sqrt(np.mean(err[sel, i] ** 2))) for i, nm in enumerate(names)}
                                     if sel.any() else None)
    rec["max_abs_error_flagged_observable"] = ({nm: float(np.max(np.abs(err[flagged, i]))) for i, nm in enumerate(names)}
                                               if flagged.any() else None)
    covs = [out.info[k].get("covariance") if k < len(out.info) else None for k in np.nonzero(flagged)[0]]
    if flagged.any() and all(c is not None for c in covs):
        dist = np.array([float(np.sqrt(max(e @ np.linalg.lstsq(P, e, rcond=None)[0], 0.0)))
                         for e, P in zip(err[flagged], covs)])
        rec["max_mahalanobis_flagged"] = float(dist.max())
        rec[f"n_flagged_beyond_{COVARIANCE_SIGMAS:g}_sigma"] = int(np.count_nonzero(dist > COVARIANCE_SIGMAS))
    return rec


def run_noise_study(example: str = "powertrain3", noise_levels=NOISE_LEVELS, steps: int = 3000, *,
                    observers=NOISE_OBSERVERS, mhe_steps: int | None = None, lookup_horizons=NOISE_LOOKUP_HORIZONS,
                    false_alarm: float | None = None, seed: int = 0,
                    progress: Callable[[str, int, int], None] | None = None,
                    traces: dict | None = None) -> dict[str, Any]:
    """Run the study (module docstring) and return its JSON-ready table.

    Parameters
    ----------
    example : str, default "powertrain3"
        A PWA example with a bench scenario (:data:`.bench.SCENARIO_EXAMPLES`).
    noise_levels : sequence of float
        Output noise standard deviations (output units).
    steps : int, default 3000
        Samples of the scenario (1 ms each on model 16).
    observers : sequence of str
        Names among :data:`NOISE_OBSERVERS`.
    mhe_steps : int, optional
        Samples given to the moving-horizon observers (default: all).
    lookup_horizons : sequence of int, default NOISE_LOOKUP_HORIZONS
        Horizons of the noise-aware lookup observer (each with ``T p > n``).
    false_alarm : float, optional
        Its false-alarm probability (default :data:`~hybobs_opt.defaults.NOISE_LOOKUP_FALSE_ALARM`).
    seed : int, default 0
        Seed of the noise (the same draw scaled to each level).
    progress : callable, optional
        ``progress(what, done, total)`` per observer run.
    traces : dict, optional
        If given, filled with the runs: ``traces["truth"]`` the simulated trace and
        ``traces[(sigma, name)]`` each observer's :class:`~hybobs_opt.contract.ObserverTrace`
        (for :func:`~hybobs_opt.studies.paper002_powertrain.plots.plot_noise_errors`).

    Returns
    -------
    dict
        ``{"example", "steps", "levels": [{"noise", "observers": {name: record}}], ...}``.
    """
    from hybobs_opt.cache import cached_analysis
    from hybobs_opt.observers.comparison import true_window_observable
    from hybobs_opt.observers.kalman import ModeSequenceKalmanFilter
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.defaults import NOISE_LOOKUP_FALSE_ALARM
    from hybobs_opt.observers.noise_lookup import NoiseAwareLookupObserver
    from hybobs_opt.observers.comparison import timed_steps

    from .bench import bench_trace

    unknown = [o for o in observers if o not in NOISE_OBSERVERS]
    if unknown:
        raise ModelError("observers", f"names among {', '.join(NOISE_OBSERVERS)}", repr(unknown[0]))
    levels = [float(s) for s in noise_levels]
    if not levels or not all(np.isfinite(s) and s > 0 for s in levels):
        raise ModelError("noise_levels", "positive finite standard deviations", repr(noise_levels))
    plant, trace, _, analysis = bench_trace(example, 3, steps, 0.0, seed)
    truly = true_window_observable(analysis, trace.q)
    horizons = [int(T) for T in lookup_horizons]
    if not horizons:
        raise ModelError("lookup_horizons", "at least one horizon T with T p > n", repr(lookup_horizons))
    noise_analyses = {T: cached_analysis(plant, T) for T in horizons} if "lookup-noise" in observers else {}
    runs = [(name, None) for name in observers if name != "lookup-noise"]
    if "lookup-noise" in observers:
        at = list(observers).index("lookup-noise")
        runs[at:at] = [("lookup-noise" if k == 0 else f"lookup-noise-T{T}", T) for k, T in enumerate(horizons)]
    if traces is not None:
        traces["truth"] = trace
    draw = np.random.default_rng(seed).standard_normal(trace.y.shape)
    names = tuple(plant.state_names)
    out_levels = []
    total = len(levels) * len(runs)
    done = 0
    for sigma in levels:
        y = trace.y + sigma * draw
        recs: dict[str, Any] = {}
        for name, horizon in runs:
            t0 = time.perf_counter()
            n_run = steps
            if name == "lookup":
                obs = LookupObserver(analysis)
                obs.run(trace.u[:6], y[:6])  # load the compiled kernel before timing
                out, warm = timed_steps(obs, trace.u, y), 2
            elif horizon is not None:
                obs = NoiseAwareLookupObserver(noise_analyses[horizon], sigma,
                                               false_alarm=(NOISE_LOOKUP_FALSE_ALARM if false_alarm is None
                                                            else false_alarm))
                out, warm = timed_steps(obs, trace.u, y), horizon - 1
            elif name in ("miqp", "miqp-kalman"):
                from hybobs_opt.mhe import MHEObserver

                n_run = min(steps, mhe_steps or steps)
                obs = MHEObserver(plant, 3, norm="2", noise_std=sigma,
                                  arrival_weight="kalman" if name == "miqp-kalman" else None)
                out, warm = timed_steps(obs, trace.u[:n_run], y[:n_run]), 2
            else:
                obs = ModeSequenceKalmanFilter(plant, sigma, modes=trace.q)
                out, warm = timed_steps(obs, trace.u, y), 0
            rec = _record(out, trace.x[:n_run], truly[:n_run], names, warm)
            rec["n_steps"] = n_run
            rec["seconds"] = time.perf_counter() - t0
            if horizon is not None:
                rec["horizon"] = horizon
                rec.update({k: v for k, v in obs.stats().items() if k in ("n_lps", "false_alarm", "table_seconds")})
            recs[name] = rec
            if traces is not None:
                traces[(sigma, name)] = out
            done += 1
            if progress:
                progress(f"sigma {sigma:g}: {name}", done, total)
        out_levels.append({"noise": sigma, "observers": recs})
    return {
        "example": example,
        "steps": steps,
        "mhe_steps": min(steps, mhe_steps or steps),
        "state_names": list(names),
        "truly_observable_fraction": float(truly[2:].mean()),
        "levels": out_levels,
        "notes": {
            "lookup": "paper 002's observer, T = 3: exact tests, so with noise every window fits some region and the "
                      "noise reaches the estimate through the inverse of C_i, flagged observable",
            "lookup-noise": f"T = {', '.join(map(str, horizons))}: chi-square residual test and membership margins at the stated "
                            "false-alarm probability; observable only when exactly one full-rank mode sequence passes",
            "miqp": "MIQP moving horizon, T = 3, noise_std = sigma: output weight 1/sigma, fit tolerance 5 sigma, and "
                    "observable only when the 99.9 % confidence region of the window-start state lies within delta "
                    "(0.05 of the state box's half-widths)",
            "miqp-kalman": "the same MIQP with the arrival cost tuned from the noise level (arrival_weight='kalman'): "
                           "each window's prior is a Kalman filter's prediction from the samples before it, in the "
                           "estimated modes, weighted by its inverse covariance (floor 1e-3 of the state box); "
                           "observable means unique given that prior, and each estimate states its covariance",
            "kalman": "time-varying Kalman filter told the true mode sequence: the unattainable reference",
        },
    }

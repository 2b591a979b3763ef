"""Switched-gain observer (paper 004) against the lookup-table deadbeat observer (paper 002).

The plant is the magnetic piston of paper 004 (eq. 63) with its two sensor curves replaced by a
continuous piecewise-linear fit in the position (:func:`~hybobs_opt.studies.paper004_nonmonotonic.piston_pwa.magnetic_piston_pwa`),
so it is a PWA system and both observers apply to the same data:

* **lookup** (paper 002, Algorithm 4.1): designed on the PWA plant itself -- mode enumeration and
  Algorithm 3.1 at the smallest horizon ``T`` with ``T p >= n`` whose set ``I`` is non-empty.
  Noise-free data of the plant it was designed for: it reconstructs the state exactly (up to
  rounding) whenever it flags a step observable.
* **switched-gain** (paper 004, Section 5): the gains, regions and dwell time are synthesised on the
  **smooth** piston model (``hybobs_opt.studies.paper004_nonmonotonic.presets.preset_design("magnetic_piston")``), while the
  **data come from the PWA fit**.  The fit error is therefore a model mismatch the observer sees as
  an output disturbance; its estimation error after convergence measures that mismatch, not a flaw
  of the synthesis.

Both observers start from the same estimate (the true initial position plus
:data:`~hybobs_opt.observers.switched_gain.PISTON_POSITION_ERROR_MM`, at rest) and run sample by
sample through :func:`~hybobs_opt.observers.comparison.timed_steps`, which gives the per-step times.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.studies.paper004_nonmonotonic.systems import PISTON_DT, PISTON_MARGIN, PISTON_PERIOD_S
from hybobs_opt.studies.paper004_nonmonotonic.piston_pwa import magnetic_piston_pwa, piston_sensor_fit
from hybobs_opt.sim.pwa import simulate_pwa
from hybobs_opt.sim.trace import Trace
from hybobs_opt.systems.pwa import PWASystem
from hybobs_opt.contract import OBSERVABLE, ObserverTrace
from hybobs_opt.observers.comparison import timed_steps
from hybobs_opt.observers.switched_gain import SwitchedGainObserver, convergence_time

from .scenarios import CONVERGENCE_TOL, PISTON_POSITION_ERROR_MM

#: Pieces of the sensor fit used by the comparison: the 11 monotonic pieces split further (greedy,
#: see :func:`piston_sensor_fit`) until the fit is within 0.075 mT of the smooth curves, 1.6 % of
#: their +-4.7 mT range.  Coarser fits are a larger mismatch for the switched-gain observer, which is
#: designed on the smooth curves: measured on this stroke, it enters the band below only at 3.9 s
#: (11 pieces, 1.06 mT), 3.7 s (22) or 3.2 s (33) of the 4 s stroke, and at 1.0 s with 44 pieces.
PISTON_COMPARISON_PIECES = 44

#: Convergence band (per state, model units): the switched-gain observer's band of the smooth
#: piston, 0.5 mm and 5 mm/s; the acceleration is not banded (as in ``hybobs observe``).
PISTON_COMPARISON_BAND: dict[str, float] = dict(CONVERGENCE_TOL["magnetic_piston"])

#: Largest horizon tried by the lookup observer's search for a non-empty ``I``.
MAX_HORIZON = 6


@contextmanager
def _seeded_reset(observer, x0: np.ndarray):
    """Make ``observer.reset()`` (called without arguments by ``timed_steps``) start from ``x0``."""
    plain = observer.reset
    observer.reset = lambda *args, **kwargs: plain(x0)
    try:
        yield observer
    finally:
        del observer.reset


def _metrics(t: np.ndarray, err: np.ndarray, names: tuple[str, ...], band: Mapping[str, float]) -> dict[str, Any]:
    """Error metrics of one run: convergence time into ``band`` and the errors before and after it."""
    idx = [names.index(k) for k in band]
    conv = convergence_time(t, err[:, idx], np.array([band[k] for k in band]))
    after = np.zeros(t.size, dtype=bool) if conv is None else t >= conv
    return {
        "convergence_time": conv,
        "converged": conv is not None,
        "rms_error_after_convergence": ({n: float(np.sqrt(np.mean(err[after, i] ** 2))) for i, n in enumerate(names)}
                                        if after.any() else None),
        "max_abs_error_after_convergence": ({n: float(np.max(np.abs(err[after, i]))) for i, n in enumerate(names)}
                                            if after.any() else None),
        "max_abs_error": {n: float(np.max(np.abs(err[:, i]))) for i, n in enumerate(names)},
        "final_abs_error": {n: float(abs(err[-1, i])) for i, n in enumerate(names)},
    }


def piston_pwa_scenario(pwa: PWASystem, t_final: float | None = None) -> Trace:
    """One extend-retract stroke of the PWA piston: the scenario of ``piston_scenario``, sampled.

    ``x0 = [z_c - A, 0, A w^2]`` and the jerk ``u(t) = -A w^3 sin(w t)`` of
    :func:`~hybobs_opt.studies.paper004_nonmonotonic.systems.piston_scenario`, taken at the sample instants and held
    over each sample (the ZOH the PWA model is exact for).  Holding instead of integrating the sine
    moves the stroke's far end by about 0.24 mm; it stays inside the box.

    The sample instants (not the mid-sample values) are also what ``piston_scenario`` feeds the
    observers.  (The switched-gain observer's initial-region selection once depended on that
    choice; it no longer does, see ``tests/test_lmi.py::test_piston_initial_region_does_not_depend_on_input_timing``.)
    """
    t_final = PISTON_PERIOD_S if t_final is None else float(t_final)
    lo, hi = pwa.state_bounds.bounding_box()
    i_z = pwa.state_names.index("z")
    zc = 0.5 * (lo[i_z] + hi[i_z])
    amp = 0.5 * (hi[i_z] - lo[i_z]) - PISTON_MARGIN * (hi[i_z] - lo[i_z])
    w = 2 * math.pi / PISTON_PERIOD_S
    N = int(round(t_final / pwa.Ts)) + 1
    U = (-amp * w**3 * np.sin(w * pwa.Ts * np.arange(N)))[:, None]
    x0 = np.zeros(pwa.n)
    x0[i_z] = zc - amp
    x0[pwa.state_names.index("a")] = amp * w**2
    return simulate_pwa(pwa, x0, U)


def lookup_for(pwa: PWASystem, max_horizon: int = MAX_HORIZON) -> tuple[Any, Any, list[dict[str, Any]]]:
    """The lookup observer at the smallest horizon ``T >= ceil(n / p)`` whose ``I`` is non-empty.

    Returns
    -------
    (LookupObserver, ObservabilityAnalysis, list of dict)
        The observer, its analysis, and per horizon tried its regions, full-rank regions and seconds
        (mode enumeration plus Algorithm 3.1 of paper 002; ``table_seconds`` for the lookup tables).

    Raises
    ------
    ModelError
        If no horizon up to ``max_horizon`` has a region of full rank.
    """
    from hybobs_opt.regions import analyse_observability
    from hybobs_opt.observers.lookup import LookupObserver

    tried = []
    for T in range(max(1, math.ceil(pwa.n / pwa.p)), int(max_horizon) + 1):
        t0 = time.perf_counter()
        analysis = analyse_observability(pwa, T)
        tried.append({"T": T, "n_regions": len(analysis.regions), "n_full_rank": len(analysis.index_set),
                      "seconds": time.perf_counter() - t0})
        if analysis.index_set:
            t0 = time.perf_counter()
            obs = LookupObserver(analysis)
            tried[-1]["table_seconds"] = time.perf_counter() - t0
            return obs, analysis, tried
    raise ModelError("max_horizon", f"a horizon up to which some region has rank C_i = n = {pwa.n}",
                     f"none up to T = {max_horizon}")


def compare_piston(
    n_pieces: int | None = PISTON_COMPARISON_PIECES,
    *,
    Ts: float = PISTON_DT,
    t_final: float | None = None,
    position_error: float = PISTON_POSITION_ERROR_MM,
    band: Mapping[str, float] | None = None,
    design=None,
    max_horizon: int = MAX_HORIZON,
) -> dict[str, Any]:
    """Run both observers on one stroke of the PWA-fitted piston and compare them.

    Parameters
    ----------
    n_pieces : int or None
        Pieces of the sensor fit (:func:`~hybobs_opt.studies.paper004_nonmonotonic.piston_pwa.piston_sensor_fit`;
        ``None``: the 11 monotonic pieces).
    Ts : float
        Sampling period (default: that of the smooth piston scenario, 1 ms).
    t_final : float, optional
        Duration (default: one period of the stroke, 4 s).
    position_error : float
        Initial estimation error in ``z`` (mm); both observers start at rest from
        ``[z(0) + position_error, 0, 0]``.
    band : mapping, optional
        Convergence band per state (default :data:`PISTON_COMPARISON_BAND`).
    design : SwitchedDesign, optional
        Switched-gain design for the *smooth* piston (default: ``preset_design("magnetic_piston")``,
        timed here).
    max_horizon : int
        Largest horizon the lookup observer may use.

    Returns
    -------
    dict
        ``plant`` (name, modes, ``Ts``, ``fit``: method, pieces, ``max_error_mT``...),
        ``scenario``, ``band``, and per observer (``lookup``, ``switched_gain``):
        ``convergence_time`` (first time from which every banded error stays inside ``band``;
        ``None`` if never), ``converged``, ``rms_error_after_convergence`` and
        ``max_abs_error_after_convergence`` (per state, from the convergence time on),
        ``max_abs_error`` (whole run), ``final_abs_error``, ``median_step_s``, ``p95_step_s``,
        ``max_step_s``, ``flags`` (counts), ``offline_s``.  The lookup entry adds ``T``,
        ``n_regions``, ``n_full_rank``, ``horizons_tried``, ``n_unobservable_pieces`` and
        ``max_scaled_error_observable`` (largest ``|x_hat - x|`` over the steps flagged observable,
        divided by the state box's half-widths); the switched-gain entry adds ``n_regions``,
        ``tau``, ``design_model``, ``data`` and ``initial_selection``.  ``traces`` (arrays, the two
        ``ObserverTrace``s and the ``SensorFit``) feeds :func:`plot_piston_comparison` and is not JSON
        (see :func:`comparison_summary`).
    """
    band = dict(PISTON_COMPARISON_BAND if band is None else band)
    fit = piston_sensor_fit(n_pieces)
    pwa = magnetic_piston_pwa(Ts=Ts, fit=fit)
    for k, v in band.items():
        if k not in pwa.state_names or not (np.isfinite(v) and v > 0):
            raise ModelError("band", f"positive bounds on states among {pwa.state_names}", f"{k}={v!r}")
    trace = piston_pwa_scenario(pwa, t_final)
    names = pwa.state_names
    t, x = trace.t, trace.x
    x_hat0 = np.zeros(pwa.n)
    x_hat0[names.index("z")] = x[0, names.index("z")] + float(position_error)

    lookup, analysis, tried = lookup_for(pwa, max_horizon)
    lookup.run(trace.u[: 2 * lookup.T], trace.y[: 2 * lookup.T])  # load the compiled kernel before timing
    with _seeded_reset(lookup, x_hat0):
        lk = timed_steps(lookup, trace.u, trace.y)

    if design is None:
        from hybobs_opt.studies.paper004_nonmonotonic.presets import preset_design

        t0 = time.perf_counter()
        design = preset_design("magnetic_piston")
        design_s, design_note = time.perf_counter() - t0, "wall time of preset_design (regions grown, gains, dwell search)"
    else:
        design_s, design_note = float(design.seconds), "synthesis time recorded by the given design (gains, dwell search)"
    sg_obs = SwitchedGainObserver(design.system, design.regions, float(pwa.Ts))
    with _seeded_reset(sg_obs, x_hat0):
        sg = timed_steps(sg_obs, trace.u, trace.y)

    half = 0.5 * np.diff(np.vstack(pwa.state_bounds.bounding_box()), axis=0)[0]
    flagged = lk.flags == OBSERVABLE
    lk_err, sg_err = lk.errors(x), sg.errors(x)
    lookup_rec = {
        "observer": "lookup-table deadbeat (paper 002, Algorithm 4.1), designed on the PWA plant",
        "T": int(analysis.T), "n_regions": len(analysis.regions), "n_full_rank": len(analysis.index_set),
        "n_unobservable_pieces": int(analysis.n_unobservable_pieces), "horizons_tried": tried,
        "offline_s": float(sum(h["seconds"] for h in tried) + tried[-1]["table_seconds"]),
        "offline_note": "mode enumeration and Algorithm 3.1 at every horizon tried, plus the lookup tables",
        "flags": lk.flag_counts(), **lk.timing(), **_metrics(t, lk_err, names, band),
        "max_scaled_error_observable": float(np.max(np.abs(lk_err[flagged]) / half)) if flagged.any() else None,
        "max_abs_error_observable": ({n: float(np.max(np.abs(lk_err[flagged, i]))) for i, n in enumerate(names)}
                                     if flagged.any() else None),
    }
    sg_rec = {
        "observer": "switched-gain (paper 004, Section 5)",
        "design_model": "smooth magnetic_piston (eq. 63, synthetic sensor curves)",
        "data": f"PWA plant {pwa.name} (piecewise-linear sensor fit)",
        "n_regions": len(design.regions), "tau": float(design.tau), "substeps": int(sg_obs.substeps),
        "offline_s": float(design_s), "offline_note": design_note,
        "initial_selection": {k: (float(v) if isinstance(v, float) else v) for k, v in sg_obs.selected.items()},
        "flags": sg.flag_counts(), **sg.timing(), **_metrics(t, sg_err, names, band),
    }
    return {
        "plant": {"name": pwa.name, "n_modes": pwa.n_modes, "Ts": float(pwa.Ts), "fit": fit.to_dict(),
                  "input_bound": float(pwa.input_bounds.bounding_box()[1][0])},
        "scenario": {"t_final": float(t[-1]), "samples": int(t.size), "x0": x[0].tolist(), "x_hat0": x_hat0.tolist(),
                     "input": "jerk of piston_scenario at the sample instants, held over each sample (ZOH)"},
        "band": band,
        "lookup": lookup_rec,
        "switched_gain": sg_rec,
        "traces": {"t": t, "x": x, "y": trace.y, "q": trace.q, "lookup": lk, "switched_gain": sg, "fit": fit},
    }


def comparison_summary(result: Mapping[str, Any]) -> dict[str, Any]:
    """The JSON-ready part of :func:`compare_piston`'s result (everything but ``traces``)."""
    return {k: v for k, v in result.items() if k != "traces"}


def plot_piston_comparison(result: Mapping[str, Any], path: str | Path) -> Path:
    """Sensor curves against their fit, and both observers' absolute errors (log scale) with the band.

    Parameters
    ----------
    result : dict
        The result of :func:`compare_piston` (with its ``traces``).
    path : str or Path
        PNG file to write.

    Returns
    -------
    Path
    """
    from hybobs_opt.plotting import pyplot

    plt = pyplot()

    from hybobs_opt.studies.paper004_nonmonotonic.systems import magnetic_piston

    path = Path(path)
    tr = result["traces"]
    fit = tr["fit"]
    t, x = tr["t"], tr["x"]
    runs: dict[str, ObserverTrace] = {"lookup": tr["lookup"], "switched-gain": tr["switched_gain"]}
    names = tuple(runs["lookup"].state_names) or ("z", "v", "a")
    band = result["band"]
    fig, axes = plt.subplots(1 + len(names), 1, figsize=(8, 2.0 * (1 + len(names)) + 0.5))
    z = np.linspace(fit.breakpoints[0], fit.breakpoints[-1], 2001)
    smooth = magnetic_piston(stroke=float(fit.breakpoints[-1]))
    for j, fn in enumerate(smooth.h):
        axes[0].plot(z, np.asarray(fn.value(z)).reshape(-1), color=f"C{j}", lw=1.0, label=f"h_{j + 1} smooth")
        axes[0].plot(fit.breakpoints, fit.values[:, j], color=f"C{j}", lw=0.8, ls="--", marker=".", ms=3,
                     label=f"h_{j + 1} PWL fit")
    axes[0].set_xlabel("z [mm]")
    axes[0].set_ylabel("reading [mT]")
    axes[0].set_title(f"{fit.n_pieces}-piece fit, max error {max(fit.max_error):.3g} mT", fontsize=9)
    axes[0].legend(fontsize=7, ncol=2)
    for i, n in enumerate(names):
        ax = axes[1 + i]
        for k, (label, run) in enumerate(runs.items()):
            ax.semilogy(t, np.maximum(np.abs(run.x_hat[:, i] - x[:, i]), 1e-14), color=f"C{k + 2}", lw=0.9, label=label)
        if n in band:
            ax.axhline(band[n], color="0.4", ls=":", lw=1, label="band")
        ax.set_ylabel(f"|error {n}|")
        ax.grid(alpha=0.3)
    axes[1].legend(fontsize=7, loc="center", ncol=3)  # between the two error levels, hiding neither
    for i, n in enumerate(names):  # the piston's units (paper 004, Sec. 7): z in mm, v in mm/s, a in mm/s^2
        unit = dict(zip(("z", "v", "a"), ("mm", "mm/s", "mm/s^2"))).get(n, "")
        axes[1 + i].set_ylabel(f"|error {n}|" + (f" [{unit}]" if unit else ""))
    axes[-1].set_xlabel("t [s]")
    for ax in axes[1:-1]:  # the error panels share the time axis of the last one
        ax.sharex(axes[-1])
        ax.tick_params(axis="x", labelbottom=False)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle("Magnetic piston with PWL sensor fit: lookup-table vs switched-gain observer", fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path

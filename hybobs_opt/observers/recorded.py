"""Observers on recorded data: the PWA observers of the toolbox run on a :class:`~hybobs_opt.sim.log.SignalLog`.

What ``hybobs observe SYSTEM --data LOG.csv`` and ``hybobs bench SYSTEM --data LOG.csv`` run: the
lookup-table deadbeat observer (Algorithm 4.1 of paper 002) and the MIQP / MILP moving-horizon
observers (eq. 10), built for any :class:`~hybobs_opt.systems.pwa.PWASystem`, each reset and run
with ``run(U, Y)`` on the log, exactly as a script would.  When the log holds the true states the
summary says how far the estimates are from them where each observer flags ``observable``.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..contract import FLAGS, OBSERVABLE, ObserverTrace
from ..errors import ModelError
from ..tolerances import UNIFORM_PERIOD_RTOL, WRONG_ESTIMATE_RTOL

#: Observer kinds for PWA systems, and the norm of the moving-horizon ones.
PWA_OBSERVERS: dict[str, str | None] = {"lookup": None, "miqp": "2", "milp": "1", "milp_inf": "inf",
                                        "set_membership": None}
#: Observer kinds that take a bound on the output noise (required by ``set_membership``; the lookup
#: observer with one reports certified radii).
NOISE_BOUND_OBSERVERS = ("lookup", "set_membership", "miqp", "milp", "milp_inf")


def check_observer_kinds(kinds: Sequence[str]) -> list[str]:
    """The observer names, each checked against :data:`PWA_OBSERVERS`."""
    kinds = list(kinds)
    if not kinds:
        raise ModelError("observers", f"at least one of {list(PWA_OBSERVERS)}", "none")
    for kind in kinds:
        if kind not in PWA_OBSERVERS:
            raise ModelError("observer", f"one of {list(PWA_OBSERVERS)} for a PWA system", repr(kind))
    return kinds


def make_pwa_observer(kind: str, system, horizon: int, analysis=None,
                      progress: Callable[[str, str, int, int], None] | None = None, fit_tolerance=None,
                      noise_bound=None, input_noise_bound=None):
    """The observer ``kind`` for ``system``; the lookup observer uses ``analysis`` (of horizon ``horizon``),
    the moving-horizon ones ``fit_tolerance`` (:class:`~hybobs_opt.mhe.MHEObserver`; noisy data), the
    set-membership one ``noise_bound`` (:class:`~hybobs_opt.mhe.SetMembershipObserver`); the lookup
    observer with a ``noise_bound`` is the bounded-noise one with radii
    (:class:`~hybobs_opt.observers.NoiseAwareLookupObserver`), which also takes ``input_noise_bound``;
    a moving-horizon observer with a ``noise_bound`` states radii too (its flag is then the radius's)."""
    check_observer_kinds([kind])
    if input_noise_bound is not None and (kind != "lookup" or noise_bound is None):
        raise ModelError("input_noise_bound", "the lookup observer with a noise_bound", f"observer {kind!r}")
    if (noise_bound is None and kind == "set_membership") or (noise_bound is not None and kind not in NOISE_BOUND_OBSERVERS):
        raise ModelError("noise_bound", "a bound on each output's noise for the set-membership observer (0 for "
                         "noise-free data), optional for the lookup and moving-horizon observers",
                         f"{noise_bound!r} with observer {kind!r}")
    if kind == "set_membership":
        if fit_tolerance is not None:
            raise ModelError("fit_tolerance", "no value for the set-membership observer (it takes noise_bound)",
                             repr(fit_tolerance))
        from ..mhe import SetMembershipObserver

        return SetMembershipObserver(system, horizon, noise_bound)
    if kind == "lookup" and fit_tolerance is not None:
        raise ModelError("fit_tolerance", "no value for the lookup observer (it fits no window: declare noisy data with "
                         "noise_bound, the bounded-noise lookup observer with radii, or use a moving-horizon observer "
                         "miqp, milp or milp_inf, which take fit_tolerance)", repr(fit_tolerance))
    if kind == "lookup":
        from .lookup import LookupObserver

        if analysis is None:
            raise ModelError("analysis", "the observability analysis of the system (Algorithm 3.1) for the lookup observer", "None")
        if noise_bound is not None:
            from .noise_lookup import NoiseAwareLookupObserver

            return NoiseAwareLookupObserver(analysis, noise_bound=noise_bound, input_noise_bound=input_noise_bound)
        return LookupObserver(analysis, progress=None if progress is None else (lambda d, t: progress("lookup tables", "piece", d, t)))
    from ..mhe import MHEObserver

    return MHEObserver(system, horizon, norm=PWA_OBSERVERS[kind], analysis=None if noise_bound is not None else analysis,
                       fit_tolerance=fit_tolerance, noise_bound=noise_bound)


def run_on_log(observer, log) -> tuple[ObserverTrace, float]:
    """``observer.reset(); observer.run(log.U, log.Y)`` and the wall-clock seconds of the run."""
    observer.reset()
    t0 = time.perf_counter()
    trace = observer.run(log.U, log.Y)
    return trace, time.perf_counter() - t0


def log_summary(trace: ObserverTrace, log, seconds: float) -> dict[str, Any]:
    """JSON-ready record of one observer's run on a log (flags, timing, errors against the log's states)."""
    rec: dict[str, Any] = {"observer": trace.observer, "n_samples": int(trace.n_steps),
                           "flag_counts": trace.flag_counts(), "run_seconds": seconds,
                           "seconds_per_sample": seconds / max(1, trace.n_steps), **trace.timing()}
    rec["n_flagged_observable"] = rec["flag_counts"][OBSERVABLE]
    R = trace.radii()
    radii = R[np.all(np.isfinite(R), axis=1)] if R is not None else np.zeros((0, 0))
    if radii.size:  # an observer stating certified radii per state
        rec["radius_median"] = np.median(radii, axis=0).tolist()
        rec["radius_max"] = radii.max(axis=0).tolist()
    if log.X is not None:
        flagged = trace.flags == OBSERVABLE
        err = np.abs(trace.x_hat - log.X)
        rel = err / np.maximum(1.0, np.abs(log.X))
        rec["has_true_states"] = True
        rec["max_abs_error_observable"] = err[flagged].max(axis=0).tolist() if flagged.any() else None
        rec["max_rel_error_observable"] = float(rel[flagged].max()) if flagged.any() else None
        rec["n_flagged_observable_wrong"] = int(np.count_nonzero(rel[flagged].max(axis=1) > WRONG_ESTIMATE_RTOL)) if flagged.any() else 0
        if radii.size:
            rec["n_outside_radius"] = trace.n_outside_radius(log.X)
    else:
        rec["has_true_states"] = False
    return rec


def observe_log(system, log, kinds: Sequence[str], horizon: int, analysis=None,
                progress: Callable[[str, str, int, int], None] | None = None,
                fit_tolerance=None, noise_bound=None,
                input_noise_bound=None) -> dict[str, tuple[ObserverTrace, dict[str, Any]]]:
    """Run each observer of ``kinds`` on ``log``: ``{kind: (trace, summary)}``.

    ``analysis`` (Algorithm 3.1 at ``horizon``) is computed here when the lookup observer needs it
    and none is given.

    Parameters
    ----------
    system : PWASystem
        The plant the log was recorded on.
    log : SignalLog
        The recorded inputs and outputs (:func:`~hybobs_opt.sim.log.read_log`).
    kinds : sequence of str
        Observer names, keys of :data:`PWA_OBSERVERS` (``"lookup"``, ``"miqp"``, ``"milp"``,
        ``"milp_inf"``, ``"set_membership"``).
    horizon : int
        Window length ``T`` (samples) of every observer.
    analysis : ObservabilityAnalysis, optional
        Algorithm 3.1 at ``horizon`` for the lookup observer (default: computed, or read from the
        cache).
    progress : callable, optional
        ``progress(phase, unit, done, total)``.
    fit_tolerance : optional
        Passed to the moving-horizon observers (:class:`~hybobs_opt.mhe.MHEObserver`), not to the
        lookup observer.
    noise_bound : optional
        Bound on each output's noise, for the set-membership observer
        (:class:`~hybobs_opt.mhe.SetMembershipObserver`, required) and the lookup observer (which
        then reports radii: :class:`~hybobs_opt.observers.NoiseAwareLookupObserver`).
    input_noise_bound : optional
        Bound on each measured input's noise, for the lookup observer with ``noise_bound``.

    Returns
    -------
    dict of str to (ObserverTrace, dict)
        Per observer of ``kinds``: its estimates and a summary (flag counts, timing, and the errors
        against the true states when the log has them).

    Raises
    ------
    ModelError
        On an unknown kind, or an ``analysis`` of another horizon.

    See Also
    --------
    read_log : the log.
    write_estimates : the estimates to CSV.

    Examples
    --------
    The lookup observer (Algorithm 4.1 of paper 002) on a recorded log of the powertrain:

    >>> import numpy as np, tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt import get_example, read_log, simulate_pwa
    >>> plant = get_example("powertrain3").build()
    >>> trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((50, 1), 40.0))
    >>> folder = Path(tempfile.mkdtemp())
    >>> trace.to_csv(folder / "log.csv")         # columns t, states, q, inputs, outputs

    >>> from hybobs_opt import observe_log
    >>> results = observe_log(plant, read_log(folder / "log.csv", plant), ["lookup"], 3)
    >>> trace, summary = results["lookup"]
    >>> trace.x_hat.shape, summary["flag_counts"]
    ((50, 3), {'observable': 41, 'unobservable': 7, 'fallback': 0, 'warming_up': 2})
    >>> summary["n_flagged_observable_wrong"], summary["max_rel_error_observable"] < 1e-8
    (0, True)
    """
    kinds = check_observer_kinds(kinds)
    if analysis is not None and analysis.T != horizon:
        raise ModelError("horizon", f"the horizon of the saved analysis, T = {analysis.T}", repr(horizon))
    if "lookup" in kinds and analysis is None:
        from ..cache import cached_analysis
        from ..progress import PhaseProgress

        analysis = cached_analysis(system, horizon, progress=None if progress is None else
                                   PhaseProgress(lambda phase, unit, d, t: progress(f"Algorithm 3.1: {phase}", unit, d, t)))
    out = {}
    for kind in kinds:
        obs = make_pwa_observer(kind, system, horizon, analysis if kind == "lookup" else None, progress,
                                fit_tolerance=None if kind in ("lookup", "set_membership") else fit_tolerance,
                                noise_bound=noise_bound if kind in NOISE_BOUND_OBSERVERS else None,
                                input_noise_bound=input_noise_bound if kind == "lookup" else None)
        trace, seconds = run_on_log(obs, log)
        rec = log_summary(trace, log, seconds)
        rec["solver"] = getattr(obs, "solver", "highs (MILPs)" if kind == "set_membership" else
                                "none (lookup table)" if noise_bound is None else "none (lookup table, bounded noise)")
        out[kind] = (trace, rec)
    return out


#: Observer kinds for scalar-nonlinear systems on a log (paper 004).
NONLINEAR_OBSERVERS = ("switched",)


def gains_from_json(system, data, source: str = "gains"):
    """The per-region gains of a ``hybobs synth --out`` file, for :class:`~.switched_gain.SwitchedGainObserver`.

    ``data`` is the file's JSON object (``source`` names the file in errors) or the file's path.
    The file must be sealed (:mod:`hybobs_opt.lmi.gains_file`): format version, the fingerprint
    of ``system`` and a checksum of its content.

    Raises
    ------
    ModelError
        Naming the file: it is for another system (fingerprint, state or output names), was
        edited or corrupted (checksum), was written before gains files were sealed (recompute it
        with ``hybobs synth``), is not a readable JSON object, or an entry is malformed.
    """
    import os
    from types import SimpleNamespace

    from ..lmi.gains_file import GAINS_FILE, check_gains, read_gains
    from ..lmi.schedule import make_region

    if isinstance(data, (str, os.PathLike)):
        source = str(data) if source == "gains" else source
        data = read_gains(data)
    out = []
    for i, (coordinate, lo, hi, L) in enumerate(check_gains(data, system, source)):
        try:
            region = make_region(system, coordinate, lo, hi, i)
        except ModelError as exc:
            raise ModelError(f"{GAINS_FILE.where(source)}: regions[{i}].interval_model", exc.expected, exc.got) from None
        out.append(SimpleNamespace(region=region, L=L, **_lyapunov_entry(data["regions"][i], system.n,
                                                                        f"{GAINS_FILE.where(source)}: regions[{i}]")))
    return out


def _lyapunov_entry(entry: dict, n: int, where: str) -> dict:
    """``P``, ``sigma`` and ``sigma_verified`` of one region of a gains file (the certificate behind
    the switched-gain observer's error bound); absent entries are left out (no certificate)."""
    out: dict = {}
    if entry.get("P") is None or entry.get("sigma") is None:
        return out
    try:
        P = np.asarray(entry["P"], dtype=float)
        sigma = float(entry["sigma"])
        sv = entry.get("sigma_verified")
        sv = None if sv is None else float(sv)
    except (TypeError, ValueError) as exc:
        raise ModelError(f"{where}.P", "a real (n, n) Lyapunov matrix and real decay rates", str(exc)) from None
    if P.shape != (n, n) or not np.all(np.isfinite(P)) or not np.allclose(P, P.T, rtol=1e-9, atol=0.0):
        raise ModelError(f"{where}.P", f"a finite symmetric ({n}, {n}) Lyapunov matrix", f"shape {P.shape}")
    if np.linalg.eigvalsh(P)[0] <= 0:
        raise ModelError(f"{where}.P", "a positive definite Lyapunov matrix", "an indefinite matrix")
    out.update(P=P, sigma=sigma, sigma_verified=sv)
    return out


def sample_period(log, field: str = "t") -> float:
    """The sampling period of a log's time column (uniform to
    :data:`~hybobs_opt.tolerances.UNIFORM_PERIOD_RTOL`), for continuous-time observers."""
    if log.t is None or log.t.size < 2:
        raise ModelError(field, "a time column (t or time) with at least two samples: a continuous-time observer "
                         "integrates between samples", "none")
    d = np.diff(log.t)
    dt = float(np.median(d))
    if np.max(np.abs(d - dt)) > UNIFORM_PERIOD_RTOL * dt:
        k = int(np.argmax(np.abs(d - dt)))
        raise ModelError(f"{field} (sample {k + 1})", f"a uniform sampling period ({dt:.6g})", f"a step of {d[k]:.6g}")
    return dt


def observe_nonlinear_log(system, log, gains) -> tuple[ObserverTrace, dict[str, Any]]:
    """The switched-gain observer (paper 004, Section 5) with ``gains`` run on ``log`` (period from its time column)."""
    from .switched_gain import SwitchedGainObserver

    obs = SwitchedGainObserver(system, gains, sample_period(log))
    trace, seconds = run_on_log(obs, log)
    rec = log_summary(trace, log, seconds)
    rec["solver"] = "none (explicit RK4 with the designed gains)"
    rec["n_regions"] = len(list(getattr(gains, "regions", gains)))
    if log.X is not None:
        err = np.abs(trace.x_hat - log.X)
        rec["final_abs_error"] = err[-1].tolist()
        rec["max_abs_error_last_tenth"] = err[int(0.9 * len(err)):].max(axis=0).tolist()
    return trace, rec


__all__ = ["FLAGS", "NONLINEAR_OBSERVERS", "gains_from_json", "observe_nonlinear_log", "sample_period", "PWA_OBSERVERS", "check_observer_kinds", "log_summary", "make_pwa_observer", "observe_log", "run_on_log"]

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

#: Observer kinds for PWA systems, and the norm of the moving-horizon ones.
PWA_OBSERVERS: dict[str, str | None] = {"lookup": None, "miqp": "2", "milp": "1", "milp_inf": "inf"}

#: Relative error (to ``max(1, |x|)``) above which an estimate flagged observable counts as wrong
#: in a summary against a noise-free log.
WRONG_ESTIMATE_RTOL = 1e-6


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
                      progress: Callable[[str, str, int, int], None] | None = None):
    """The observer ``kind`` for ``system``; the lookup observer uses ``analysis`` (of horizon ``horizon``)."""
    check_observer_kinds([kind])
    if kind == "lookup":
        from .lookup import LookupObserver

        if analysis is None:
            raise ModelError("analysis", "the observability analysis of the system (Algorithm 3.1) for the lookup observer", "None")
        return LookupObserver(analysis, progress=None if progress is None else (lambda d, t: progress("lookup tables", "piece", d, t)))
    from ..mhe import MHEObserver

    return MHEObserver(system, horizon, norm=PWA_OBSERVERS[kind], analysis=analysis)


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
    if log.X is not None:
        flagged = trace.flags == OBSERVABLE
        err = np.abs(trace.x_hat - log.X)
        rel = err / np.maximum(1.0, np.abs(log.X))
        rec["has_true_states"] = True
        rec["max_abs_error_observable"] = err[flagged].max(axis=0).tolist() if flagged.any() else None
        rec["max_rel_error_observable"] = float(rel[flagged].max()) if flagged.any() else None
        rec["n_flagged_observable_wrong"] = int(np.count_nonzero(rel[flagged].max(axis=1) > WRONG_ESTIMATE_RTOL)) if flagged.any() else 0
    else:
        rec["has_true_states"] = False
    return rec


def observe_log(system, log, kinds: Sequence[str], horizon: int, analysis=None,
                progress: Callable[[str, str, int, int], None] | None = None) -> dict[str, tuple[ObserverTrace, dict[str, Any]]]:
    """Run each observer of ``kinds`` on ``log``: ``{kind: (trace, summary)}``.

    ``analysis`` (Algorithm 3.1 at ``horizon``) is computed here when the lookup observer needs it
    and none is given.
    """
    kinds = check_observer_kinds(kinds)
    if analysis is not None and analysis.T != horizon:
        raise ModelError("horizon", f"the horizon of the saved analysis, T = {analysis.T}", repr(horizon))
    if "lookup" in kinds and analysis is None:
        from ..regions import analyse_observability

        analysis = analyse_observability(system, horizon, progress=None if progress is None else
                                         (lambda d, t: progress("Algorithm 3.1", "region", d, t)))
    out = {}
    for kind in kinds:
        obs = make_pwa_observer(kind, system, horizon, analysis if kind == "lookup" else None, progress)
        trace, seconds = run_on_log(obs, log)
        rec = log_summary(trace, log, seconds)
        rec["solver"] = getattr(obs, "solver", "none (lookup table)")
        out[kind] = (trace, rec)
    return out


__all__ = ["FLAGS", "PWA_OBSERVERS", "check_observer_kinds", "log_summary", "make_pwa_observer", "observe_log", "run_on_log"]

"""Comparing observers on one trace: timing of the ``step`` loop, errors where each flags
``observable``, and the exact observability labels of the true window-start states.

Every observer of the package is compared against the lookup-table deadbeat observer this way
(paper 002, Section 7); the study modules (``studies.paper002_powertrain.bench``,
``studies.paper004_nonmonotonic.piston_comparison``) build their comparisons from these pieces.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np

from ..contract import OBSERVABLE, Observer, ObserverTrace
from ..defaults import EXACT_LABEL_SAMPLES


def true_window_observable(analysis, q: np.ndarray) -> np.ndarray:
    """Per time ``t``: is the true mode sequence of the window ``t-T+1`` to ``t`` a region of ``I``?

    A necessary condition for the window-start state to be observable (its output map has full
    rank), not a sufficient one: another mode sequence may explain the same data.  For the
    exact answer see :func:`exact_window_labels`.

    Parameters
    ----------
    analysis : ObservabilityAnalysis
        Algorithm 3.1 at horizon ``T``.
    q : (N,) int ndarray
        The true mode at each sample.

    Returns
    -------
    (N,) bool ndarray
        ``False`` for the first ``T - 1`` samples (no full window).

    See Also
    --------
    exact_window_labels : The exact labels of the windows.
    summarise : Splits errors by this mask.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import true_window_observable
    >>> mask = true_window_observable(analysis, truth.q)
    >>> mask.shape, bool(mask[2:].all())
    ((40,), True)
    """
    seqs = {r.sequence: k for k, r in enumerate(analysis.regions)}
    T = analysis.T
    out = np.zeros(q.size, dtype=bool)
    for t in range(T - 1, q.size):
        k = seqs.get(tuple(int(v) for v in q[t - T + 1 : t + 1]))
        out[t] = k is not None and analysis.full_rank[k]
    return out


def exact_window_labels(analysis, x: np.ndarray, samples: int = EXACT_LABEL_SAMPLES,
                        progress: Callable[[int, int], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Exact labels (``classify``, Definition 2.2) of the window-start states ``x[t - T + 1]``, on an even stride.

    Returns ``(times, labels)``: the window end times ``t`` that were classified (every
    ``k``-th one, at most ``samples``) and their labels.

    Parameters
    ----------
    analysis : ObservabilityAnalysis
        Algorithm 3.1 at horizon ``T``.
    x : (N, n) ndarray
        The true states.
    samples : int, default EXACT_LABEL_SAMPLES
        Largest number of windows classified.
    progress : callable, optional
        ``progress(done, total)`` per classified window.

    Returns
    -------
    times : (k,) int array
        The window end times classified.
    labels : (k,) array
        Their labels (:class:`~hybobs_opt.regions.PointClass`).

    See Also
    --------
    true_window_observable : The necessary condition from the mode sequence.
    hybobs_opt.ObservabilityAnalysis.classify : Labels one state.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import exact_window_labels
    >>> times, labels = exact_window_labels(analysis, truth.x, samples=5)
    >>> times.shape == labels.shape, [str(l) for l in labels[:2]]
    (True, ['observable', 'observable'])
    """
    T = analysis.T
    ends = np.arange(T - 1, x.shape[0])
    if ends.size > samples:
        ends = ends[np.linspace(0, ends.size - 1, samples).round().astype(int)]
    starts = np.ascontiguousarray(x[ends - T + 1], dtype=float)

    def compute() -> dict[str, np.ndarray]:
        out = []
        for k, x0 in enumerate(starts):
            out.append(analysis.classify(x0))
            if progress:
                progress(k + 1, ends.size)
        return {"labels": np.array(out, dtype=str)}

    from ..cache import active_cache, analysis_key_parts, array_digest

    cache = active_cache()
    if cache is None or not ends.size:
        found = compute()["labels"] if ends.size else np.zeros(0, dtype=str)
    else:
        parts = {**analysis_key_parts(analysis), "states": array_digest({"states": starts})}
        what = f"exact labels of {ends.size} windows of {analysis.system.name!r} (T = {T})"
        found = cache.arrays("exact-labels", parts, compute, what)["labels"]
    labels = np.empty(ends.size, dtype=object)
    labels[:] = [str(v) for v in found]
    return ends, labels


def timed_steps(observer, U: np.ndarray, Y: np.ndarray, progress: Callable[[int, int], None] | None = None,
                chunk: int = 500) -> ObserverTrace:
    """Run ``observer.step`` sample by sample from a reset state (the online cost).

    Calls the base class's :meth:`Observer.run`, which loops ``step``, even for observers whose
    own ``run`` is a vectorised batch; with ``progress(done, total)``, in chunks of ``chunk``
    samples (the observer keeps its state between them).

    Parameters
    ----------
    observer : Observer
        The observer (reset first).
    U : (N, m) ndarray
        Inputs.
    Y : (N, p) ndarray
        Outputs.
    progress : callable, optional
        ``progress(done, total)`` after each chunk.
    chunk : int, default 500
        Samples per chunk when ``progress`` is given.

    Returns
    -------
    ObserverTrace
        The run, with each step's own wall time in ``seconds``.

    See Also
    --------
    Observer.run : The same loop (some observers batch their ``run``).
    summarise : Summarises the run.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import timed_steps
    >>> trace = timed_steps(LookupObserver(analysis), U, truth.y)
    >>> trace.n_steps, trace.flag_counts()["observable"]
    (40, 38)
    """
    observer.reset()
    if progress is None:
        return Observer.run(observer, U, Y)
    N = len(U)
    parts = []
    for a in range(0, N, chunk):
        parts.append(Observer.run(observer, U[a : a + chunk], Y[a : a + chunk]))
        progress(min(N, a + chunk), N)
    first = parts[0]
    return ObserverTrace(np.concatenate([q.x_hat for q in parts]), np.concatenate([q.mode for q in parts]),
                         np.concatenate([q.flags for q in parts]), np.concatenate([q.seconds for q in parts]),
                         first.state_names, first.observer, tuple(i for q in parts for i in q.info))


def summarise(out: ObserverTrace, x_true: np.ndarray, truly_observable: np.ndarray, state_names, solver: str,
              warmup: int = 0, interval_states: Sequence[str] = ()) -> dict[str, Any]:
    """The record of one observer in a comparison (``observers.<name>`` of ``hybobs bench --json``).

    Timing (``out.timing()``), the largest error over the steps flagged observable (absolute per
    state, and relative to ``max(1, |x|)`` over all states), the flag counts, and for each state
    named in ``interval_states`` the RMS error on the samples where ``truly_observable`` holds and
    where it does not.  The interval errors leave out the first ``warmup`` samples (``T - 1``: no
    window yet, every observer shows its initial guess there).

    Parameters
    ----------
    out : ObserverTrace
        The observer's run.
    x_true : (N, n) ndarray
        The true states.
    truly_observable : (N,) bool ndarray
        Which samples are observable (e.g. :func:`true_window_observable`).
    state_names : sequence of str
        Names of the states (columns of ``x_true``).
    solver : str
        The observer's solver, stored in the record.
    warmup : int, default 0
        Samples left out of the interval errors.
    interval_states : sequence of str, optional
        States whose RMS errors on the observable and unobservable intervals are reported.

    Returns
    -------
    dict
        JSON-ready: timing, the largest errors over the steps flagged ``observable``, the flag
        counts and the interval errors.

    See Also
    --------
    timed_steps : The run it summarises.
    true_window_observable : The mask ``truly_observable``.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> analysis = hy.analyse_observability(plant, 3)      # Algorithm 3.1, T = 3
    >>> from hybobs_opt.observers import summarise, true_window_observable
    >>> trace = LookupObserver(analysis).run(U, truth.y)
    >>> record = summarise(trace, truth.x, true_window_observable(analysis, truth.q), plant.state_names,
    ...                    "lookup", warmup=2)
    >>> sorted(record)  # doctest: +ELLIPSIS
    ['max_abs_error_observable', 'max_abs_error_observable_all', 'max_step_s', ...
    >>> max(record["max_abs_error_observable"]) < 1e-6
    True
    """
    err = np.abs(out.x_hat - x_true)
    flagged = out.flags == OBSERVABLE
    rec: dict[str, Any] = dict(out.timing())
    rec["solver"] = solver
    rec["n_steps"] = out.n_steps
    rec["max_abs_error_observable"] = err[flagged].max(axis=0).tolist() if flagged.any() else None
    rec["max_abs_error_observable_all"] = float(np.max(err[flagged] / np.maximum(1.0, np.abs(x_true[flagged])))) if flagged.any() else None
    rec["n_flagged_observable"] = int(flagged.sum())
    rec["n_flagged_unobservable"] = int(np.count_nonzero(out.flags == "unobservable"))
    rec["n_fallback"] = int(np.count_nonzero(out.flags == "fallback"))
    # windows whose separated cost fell in the decision band of the uniqueness threshold: decided
    # to the safe side (fallback) so that no rounding can flip them
    rec["n_uniqueness_in_decision_band"] = sum(
        1 for inf in out.info if isinstance(inf, dict) and (inf.get("uniqueness") or {}).get("in_decision_band"))
    for name in interval_states:
        if name in state_names:
            i = state_names.index(name)
            after = np.arange(err.shape[0]) >= warmup
            for label, mask in (("observable", truly_observable), ("unobservable", ~truly_observable)):
                sel = mask & after & np.isfinite(err[:, i])
                rec[f"rms_error_{name}_{label}_intervals"] = float(np.sqrt(np.mean(err[sel, i] ** 2))) if sel.any() else None
    return rec


def wilson_interval(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float] | None:
    """95 % Wilson score interval of a binomial proportion ``k / n`` (``None`` when ``n = 0``).

    Parameters
    ----------
    k : int
        Number of successes.
    n : int
        Number of trials.
    z : float, default 1.959963984540054
        Standard normal quantile of the confidence level (the default gives 95 %).

    Returns
    -------
    (float, float) or None
        Lower and upper end, clipped to ``[0, 1]``.

    See Also
    --------
    summarise : Reports rates with it.

    Examples
    --------
    >>> from hybobs_opt.observers import wilson_interval
    >>> lo, hi = wilson_interval(45, 50)
    >>> round(lo, 3), round(hi, 3)
    (0.786, 0.957)
    >>> wilson_interval(0, 0) is None
    True
    """
    if n == 0:
        return None
    p = k / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * float(np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))) / den
    return (max(0.0, centre - half), min(1.0, centre + half))

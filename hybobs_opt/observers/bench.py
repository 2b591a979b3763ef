"""``hybobs bench``: the lookup observer against the MIQP/MILP moving-horizon observers (paper 002, Section 7).

All observers run on the same simulated trace (model (16), the torque profile that drives the
shaft through the backlash, optional output noise).  Reported per observer: per-step compute
time (median, p95, max over ``step`` calls), the largest state error over the steps it flags
observable, the errors of ``theta`` and ``omega_l`` on the intervals where the true window is
observable (its mode sequence has ``rank C_i = n``) and where it is not, and how often it flags
unobservability.  Plots like the paper's Figs. 7-9.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from ..errors import ModelError
from .base import OBSERVABLE, Observer, ObserverTrace


def bench_trace(example: str, T: int, steps: int, noise: float, seed: int = 0, params: dict | None = None,
                progress: Callable[[int, int], None] | None = None):
    """The plant, its regions analysis and the (noisy) trace of the paper's scenario.

    ``progress(done, total)`` follows Algorithm 3.1 (per region of ``I``).
    """
    from ..examples import get_example
    from ..examples.powertrain import SCENARIO_TORQUES, backlash_scenario
    from ..regions import analyse_observability

    ex = get_example(example)
    if ex.kind != "pwa":
        raise ModelError("example", "a PWA example (powertrain3, powertrain5)", f"{example!r} of kind {ex.kind!r}")
    if steps < T + 1:
        raise ModelError("--steps", f"more than the horizon T = {T}", repr(steps))
    if not (np.isfinite(noise) and noise >= 0):
        raise ModelError("--noise", "a non-negative standard deviation", repr(noise))
    plant = ex.build(**(params or {}))
    trace = backlash_scenario(plant, SCENARIO_TORQUES[example], t_final=steps * plant.Ts)
    y = trace.y + (np.random.default_rng(seed).normal(0.0, noise, trace.y.shape) if noise > 0 else 0.0)
    analysis = analyse_observability(plant, T, progress=progress)
    return plant, trace, y, analysis


def true_window_observable(analysis, q: np.ndarray) -> np.ndarray:
    """Per time ``t``: is the true mode sequence of the window ``t-T+1 .. t`` a region of ``I``?

    A necessary condition for the window-start state to be observable (its output map has full
    rank), not a sufficient one: another mode sequence may explain the same data.  For the
    exact answer see :func:`exact_window_labels`.
    """
    seqs = {r.sequence: k for k, r in enumerate(analysis.regions)}
    T = analysis.T
    out = np.zeros(q.size, dtype=bool)
    for t in range(T - 1, q.size):
        k = seqs.get(tuple(int(v) for v in q[t - T + 1 : t + 1]))
        out[t] = k is not None and analysis.full_rank[k]
    return out


#: At most this many window-start states are classified exactly per bench run (point queries of
#: Definition 2.2, about 1 ms each on model 16 at T = 3 and 17 ms on model 17 at T = 5).
EXACT_LABEL_SAMPLES = 300


def exact_window_labels(analysis, x: np.ndarray, samples: int = EXACT_LABEL_SAMPLES,
                        progress: Callable[[int, int], None] | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Exact labels (``classify``, Definition 2.2) of the window-start states ``x[t - T + 1]``, on an even stride.

    Returns ``(times, labels)``: the window end times ``t`` that were classified (every
    ``k``-th one, at most ``samples``) and their labels.
    """
    T = analysis.T
    ends = np.arange(T - 1, x.shape[0])
    if ends.size > samples:
        ends = ends[np.linspace(0, ends.size - 1, samples).round().astype(int)]
    labels = np.empty(ends.size, dtype=object)
    for k, t in enumerate(ends):
        labels[k] = analysis.classify(x[t - T + 1])
        if progress:
            progress(k + 1, ends.size)
    return ends, labels


def timed_steps(observer, U: np.ndarray, Y: np.ndarray, progress: Callable[[int, int], None] | None = None,
                chunk: int = 500) -> ObserverTrace:
    """Run ``observer.step`` sample by sample from a reset state (the online cost).

    Calls the base class's :meth:`Observer.run`, which loops ``step``, even for observers whose
    own ``run`` is a vectorised batch; with ``progress(done, total)``, in chunks of ``chunk``
    samples (the observer keeps its state between them).
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
                         first.state_names, first.observer)


def summarise(out: ObserverTrace, x_true: np.ndarray, truly_observable: np.ndarray, state_names, solver: str,
              warmup: int = 0) -> dict[str, Any]:
    """The ``observers.<name>`` record of ``hybobs bench --json``.

    The interval errors leave out the first ``warmup`` samples (``T - 1``: no window yet, every
    observer shows its initial guess there).
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
    for name in ("theta", "omega_l"):
        if name in state_names:
            i = state_names.index(name)
            after = np.arange(err.shape[0]) >= warmup
            for label, mask in (("observable", truly_observable), ("unobservable", ~truly_observable)):
                sel = mask & after & np.isfinite(err[:, i])
                rec[f"rms_error_{name}_{label}_intervals"] = float(np.sqrt(np.mean(err[sel, i] ** 2))) if sel.any() else None
    return rec


def run_bench(example: str, T: int, steps: int, noise: float, observers: list[str], mhe_steps: int | None = None,
              plot: str | None = None, seed: int = 0,
              progress: Callable[[str, str, int, int], None] | None = None) -> dict[str, Any]:
    """Run the comparison and return the JSON-ready summary (see module docstring).

    ``progress(phase, unit, done, total)`` follows the phases (Algorithm 3.1, the lookup tables,
    the observers' steps); see :func:`progress_bar`.
    """
    from .lookup import LookupObserver

    def phase(name: str, unit: str):
        return None if progress is None else (lambda done, total: progress(name, unit, done, total))

    t0 = time.perf_counter()
    plant, trace, y, analysis = bench_trace(example, T, steps, noise, seed, progress=phase("Algorithm 3.1", "region"))
    analysis_s = time.perf_counter() - t0
    truly = true_window_observable(analysis, trace.q)
    _, labels = exact_window_labels(analysis, trace.x, progress=phase("exact labels", "state"))
    n_obs = int(np.count_nonzero(labels == "observable"))
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
            from ..mhe import MHEObserver

            norm = {"miqp": "2", "milp": "1", "milp_inf": "inf"}[name]
            obs = MHEObserver(plant, T, norm=norm)
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
            "(flags unobservable/fallback); the moving-horizon observers return a least-error estimate instead"
        )
    if plot:
        plot_bench(trace, outs, plot)
        summary["plot"] = plot
    return summary


def wilson_interval(k: int, n: int, z: float = 1.959963984540054) -> tuple[float, float] | None:
    """95 % Wilson score interval of a binomial proportion ``k / n`` (``None`` when ``n = 0``)."""
    if n == 0:
        return None
    p = k / n
    den = 1.0 + z * z / n
    centre = (p + z * z / (2 * n)) / den
    half = z * float(np.sqrt(p * (1 - p) / n + z * z / (4 * n * n))) / den
    return (max(0.0, centre - half), min(1.0, centre + half))


def plot_bench(trace, outs: dict[str, ObserverTrace], path: str) -> str:
    """Figs. 7-9 of paper 002: true twist angle and wheel speed; each observer's errors and flags."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = list(outs)
    fig, axes = plt.subplots(2 + len(names), 1, figsize=(8, 2.0 * (2 + len(names))), sharex=True)
    t = trace.t
    axes[0].plot(t, trace.state("theta"))
    axes[0].axhspan(-0.05, 0.05, color="0.9")
    axes[0].set_ylabel("theta")
    axes[1].plot(t, trace.state("omega_l"))
    axes[1].set_ylabel("omega_l")
    for ax, name in zip(axes[2:], names):
        out = outs[name]
        n = out.n_steps
        i = trace.state_names.index("theta")
        ax.plot(t[:n], out.x_hat[:, i] - trace.x[:n, i], label="theta error")
        flag = np.where(out.flags == OBSERVABLE, 1.0, -1.0)
        ax2 = ax.twinx()
        ax2.plot(t[:n], flag, "k--", lw=0.7, label="observable (+1) / not (-1)")
        ax2.set_ylim(-1.5, 1.5)
        ax.set_ylabel(f"{name}\nerror")
    axes[-1].set_xlabel("t [s]")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)
    return path


def cmd_bench(args: argparse.Namespace) -> int:
    from ..cli import _print_json

    observers = [s.strip() for s in args.observers.split(",") if s.strip()]
    progress, close = progress_bar(not args.json)
    try:
        summary = run_bench(args.example, args.horizon, args.steps, args.noise, observers, args.mhe_steps, args.plot,
                            args.seed, progress=progress)
    finally:
        close()
    if args.json:
        _print_json(summary)
        return 0
    print(f"{summary['example']}, T = {summary['horizon']}, {summary['steps']} steps, noise {summary['noise']:g}")
    for name, rec in summary["observers"].items():
        err = rec["max_abs_error_observable_all"]
        print(f"  {name:<9} median {1e6 * rec['median_step_s']:9.1f} us  p95 {1e6 * rec['p95_step_s']:9.1f} us  "
              f"flagged unobservable {rec['n_flagged_unobservable']:5d}  max rel. error where flagged observable "
              f"{'n/a' if err is None else f'{err:.2e}'}  [{rec['solver']}]")
    if "note" in summary:
        print("note:", summary["note"])
    return 0


def add_commands(sub) -> None:
    p = sub.add_parser("bench", help="lookup observer vs MIQP/MILP moving-horizon observers (paper 002, Section 7)")
    p.add_argument("example", help="a PWA example (powertrain3)")
    p.add_argument("--horizon", "-T", type=int, default=3, help="observation horizon T (default 3)")
    p.add_argument("--steps", type=int, default=3000, help="number of samples of the scenario (1 ms each)")
    p.add_argument("--noise", type=float, default=0.0, help="standard deviation of output noise (rad/s)")
    p.add_argument("--observers", default="lookup,miqp,milp", help="comma-separated: lookup, miqp, milp, milp_inf")
    p.add_argument("--mhe-steps", type=int, default=None, help="run the MHE observers on the first N steps only")
    p.add_argument("--seed", type=int, default=0, help="noise seed")
    p.add_argument("--plot", metavar="FILE", help="PNG like the paper's Figs. 7-9")
    p.add_argument("--json", action="store_true", help="machine-readable summary")
    p.set_defaults(func=cmd_bench)


def progress_bar(enabled: bool):
    """``(progress, close)`` for :func:`run_bench`: one tqdm bar per phase, with its unit, on stderr.

    Silent (``progress`` is ``None``) when ``enabled`` is false (``--json``) or stderr is not a
    terminal (tests, pipes).
    """
    import sys

    if not enabled or not sys.stderr.isatty():
        return None, lambda: None
    from tqdm import tqdm

    state: dict[str, Any] = {"bar": None, "phase": None}

    def close() -> None:
        if state["bar"] is not None:
            state["bar"].close()
            state["bar"] = None

    def progress(phase: str, unit: str, done: int, total: int) -> None:
        if state["phase"] != phase:
            close()
            state["bar"] = tqdm(total=total, desc=phase, unit=unit, file=sys.stderr, leave=False)
            state["phase"] = phase
        bar = state["bar"]
        bar.total = total
        bar.n = done
        bar.refresh()

    return progress, close


def _observe_scenario(example: str, horizon: int):
    def scenario(args: argparse.Namespace) -> dict[str, Any]:
        kind = args.observer or "lookup"
        progress, close = progress_bar(not getattr(args, "json", False))
        try:
            summary = run_bench(example, horizon, 3000, 0.0, [kind], plot=args.plot, progress=progress)
        finally:
            close()
        summary["observer"] = kind
        return summary

    return scenario


def _register_scenarios() -> None:
    from .scenarios import register_scenario

    register_scenario("powertrain3", _observe_scenario("powertrain3", 3))
    register_scenario("powertrain5", _observe_scenario("powertrain5", 5))


_register_scenarios()

"""Report section "Constant-drift observers (paper 003)": event-sampled models, gains, observers.

Recomputes, for the two-product switching server (Section 2.1) and the 3-flow T-junction
(Section 5) of paper 003: the periodic system (14) at the visible events, the deadbeat gains of
the sequential algorithm and the positive observers of the LP (Remark 4.4), the run of the
continuous-time observer (18) on the paper's junction scenario next to the paper's printed numbers
(Figure 3 and the text of Section 5), and a comparison of the periodic deadbeat and positive
observers with the lookup-table deadbeat observer of paper 002 on the same event-sampled data
(visible events until the estimate is exact, positivity, compute time).  Two systems built here
(not from the paper) show the limits: a polling server whose deadbeat observer is not positive,
and a server with an unserved buffer for which no observer converges.

The helpers (:func:`polling_server`, :func:`unserved_buffer_server`, :func:`visible_samples`,
:func:`compare_observers`) are shared with ``notebooks/03_constant_drift_observers.ipynb``.
"""

from __future__ import annotations

import html
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InfeasibleError
from ..systems.constant_drift import ConstantDriftSystem
from ..systems.event_sampled import PeriodicSystem, periodic_system, phase_augmented_pwa
from .html import ReportSection, register_section

#: Paper 003, Section 5: printed numbers of the junction run (observer from t = 50).
PAPER_003_JUNCTION = {
    "first_event_t": 70.7,
    "first_event_predicted_t": 81.7,
    "x_tilde_predicted": [101.7, 58.3, 15.0],
    "x_after_first_event": [90.7, 52.8, 15.0],
    "second_event_t": 79.2,
    "x1_after_second_event": 0.0,
    "third_event_predicted_t": 137.0,
    "third_event_t": 140.3,
}

#: Random initial estimates per example in the comparison (kept small: the section must stay fast).
COMPARISON_TRIALS = 12


# ---------------------------------------------------------------------------- extra systems
def polling_server() -> ConstantDriftSystem:
    """A polling server with table (1, 1, 2), built here to show a deadbeat observer that is not positive.

    Not from paper 003.  Buffer 1 (arrivals 2/s) is served twice per cycle, at 10/s after a 2 s
    setup and at 5/s after a 3 s setup; buffer 2 (arrivals 0.5/s) at 8.5/s with no setup before
    it.  Only the second setup (mode 3) is visible.  Modes: 1 setup, 2 serve 1, 3 setup
    (visible), 4 serve 1 again, 5 serve 2.  A deadbeat observer exists, a positive one converges,
    but no positive one is deadbeat (the monodromy at the largest positive gains has spectral
    radius 1/69).
    """
    return ConstantDriftSystem(
        f=[[-1.0, 2.0, 0.5], [0.0, -8.0, 0.5], [-1.0, 2.0, 0.5], [0.0, -3.0, 0.5], [0.0, 2.0, -8.0]],
        trigger=[0, 1, 0, 1, 2],
        alpha=[0.0, 3.0, 0.0, 0.0, 2.0],
        h=[0, 0, 3, 0, 0],
        mode_names=("setup A", "serve 1 (fast)", "setup B", "serve 1 (slow)", "serve 2"),
    )


def unserved_buffer_server() -> ConstantDriftSystem:
    """A server whose buffer 2 is never served, built here as a system with no convergent observer.

    Not from paper 003; it satisfies Assumptions 2.1-2.6, but ``x2`` never influences an event
    time, so no gain (positive or not) reconstructs it.
    """
    return ConstantDriftSystem(f=[[-1.0, 1.0, 0.5], [0.0, -3.0, 0.5]], trigger=[0, 1], alpha=[0.0, 2.0], h=[0, 2],
                               mode_names=("setup", "serve 1"))


# ---------------------------------------------------------------------------- data and comparison
def visible_samples(trace, ps: PeriodicSystem) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(t_j, v_j, x-bar(t_j))`` of the true visible events of a simulated trace (the data of eq. 14)."""
    evs = [e for e in trace.events if e["from_mode"] in ps.event_modes]
    t = np.array([e["t"] for e in evs])
    v = np.array([e["from_mode"] for e in evs], dtype=int)
    x = np.array([np.asarray(e["x"])[1:] for e in evs]).reshape(len(evs), ps.n)
    return t, v, x


def _truth(name: str, cycles: float = 12.0):
    from ..examples.switching import switching_server, switching_server_scenario, traffic_junction, traffic_junction_scenario

    if name == "traffic_junction":
        system = traffic_junction()
        return system, traffic_junction_scenario(system, t_final=70.6 * cycles)
    if name == "switching_server":
        system = switching_server()
        return system, switching_server_scenario(system, t_final=12.0 * cycles)
    from ..sim.constant_drift import simulate_constant_drift

    system = polling_server()
    return system, simulate_constant_drift(system, [0.0, 20.0, 10.0, ], 2, 0.0, 25.0 * cycles)


def _exact(err: np.ndarray, x: np.ndarray) -> np.ndarray:
    return np.max(np.abs(err), axis=-1) <= 1e-6 * (1.0 + np.max(np.abs(x), axis=-1))


def compare_observers(name: str, designs: dict[str, Any], trials: int = COMPARISON_TRIALS, seed: int = 0,
                      lookup: bool = True) -> dict[str, Any]:
    """Periodic observers (16) with the given gains and the lookup-table observer on the same event data.

    For each of ``trials`` non-negative initial estimates (the first ``N`` overestimate one queue
    by ``10 (1 + max x)``, the others are uniform in ``[0, 10 (1 + max x)]``), started at a visible
    event of random phase, every observer reads the same true sequence of visible-event times;
    recorded are the number of event-time increments until the relative error stays below 1e-6
    (exact for deadbeat gains, ``events_to_converge``), the smallest estimate of any queue
    (positivity) and the median time per step.  The lookup-table observer (paper 002, Algorithm 4.1) reads the phase-augmented
    PWA form :func:`~hybobs_opt.systems.event_sampled.phase_augmented_pwa` with the smallest
    horizon ``T`` at which ``T`` event times determine the state from every phase.
    """
    from ..observers.periodic import PeriodicObserver

    system, trace = _truth(name)
    ps = periodic_system(system)
    t, v, x = visible_samples(trace, ps)
    rng = np.random.default_rng(seed)
    hi = 10.0 * (1.0 + float(x.max()))
    out: dict[str, Any] = {"example": name, "trials": trials, "events": int(t.size), "observers": {}}
    starts = rng.integers(0, ps.period, trials)
    guesses = rng.uniform(0.0, hi, (trials, ps.n))
    # one badly overestimated queue each: where sign-indefinite gains drive other estimates negative
    guesses[: min(trials, ps.n)] = hi * np.eye(ps.n)[: min(trials, ps.n)]
    for label, gains in designs.items():
        obs = PeriodicObserver(ps, gains)
        steps, mins, secs = [], [], []
        for s, g in zip(starts, guesses):
            obs.reset(g, t0=t[s], mode=int(v[s]))
            est = [g]
            for k in range(s + 1, t.size):
                e = obs.step([t[k]], [v[k]])
                est.append(e.x)
                secs.append(e.seconds)
            est = np.array(est)
            ok = _exact(est - x[s:], x[s:])
            bad = np.nonzero(~ok)[0]
            steps.append(int(bad[-1] + 1) if bad.size and bad[-1] + 1 < ok.size else (0 if not bad.size else None))
            mins.append(float(est.min()))
        out["observers"][label] = {
            "events_to_converge": None if any(s_ is None for s_ in steps) else max(steps),
            "min_estimate": min(mins),
            "median_step_s": float(np.median(secs)),
            "design_seconds": float(getattr(gains, "seconds", 0.0)),
            "positive_gains": bool(getattr(gains, "positive", False)),
        }
    if lookup:
        out["observers"]["lookup table (paper 002)"] = _lookup_comparison(ps, t, v, x, starts, guesses)
    return out


def _lookup_comparison(ps: PeriodicSystem, t, v, x, starts, guesses) -> dict[str, Any]:
    from ..observers.lookup import LookupObserver
    from ..regions import analyse_observability

    T = next((T for T in range(1, ps.n * ps.period + 2)
              if all(np.linalg.matrix_rank(ps.observability_matrix(j, T)) == ps.n for j in range(1, ps.period + 1))), None)
    if T is None:
        return {"applies": False, "reason": "no horizon T makes the window-start state observable from the event times"}
    t0 = time.perf_counter()
    # the box must hold the open-loop seeds as well as the true queues
    pwa = phase_augmented_pwa(ps, upper=2.0 * np.maximum(np.maximum(x.max(axis=0), guesses.max(axis=0)), 1.0) + 10.0)
    analysis = analyse_observability(pwa, T)
    obs = LookupObserver(analysis)
    design = time.perf_counter() - t0
    phase = np.array([ps.phase_of(int(m)) - 1 for m in v], dtype=float)
    steps, mins, secs = [], [], []
    for s, g in zip(starts, guesses):
        Y = np.column_stack([np.diff(t[s:]), phase[s:-1]])
        obs.reset(np.append(g, phase[s]))
        est = []
        for k in range(Y.shape[0]):
            e = obs.step(np.zeros(0), Y[k])
            est.append(e.x[:-1])
            secs.append(e.seconds)
        est = np.array(est)
        xs = x[s:-1]
        ok = _exact(est - xs, xs)
        bad = np.nonzero(~ok)[0]
        # sample k uses k + 1 event-time increments
        steps.append(int(bad[-1] + 2) if bad.size and bad[-1] + 1 < ok.size else (1 if not bad.size else None))
        mins.append(float(est.min()))
    return {"applies": True, "horizon_T": T, "events_to_converge": None if any(s_ is None for s_ in steps) else max(steps),
            "min_estimate": min(mins), "median_step_s": float(np.median(secs)), "design_seconds": design,
            "positive_gains": None}


# ---------------------------------------------------------------------------- html helpers
def _mat(M) -> str:
    M = np.atleast_2d(np.asarray(M, dtype=float))
    rows = "; ".join(" ".join(f"{v:.4g}" for v in r) for r in M)
    return f"<code>[{html.escape(rows)}]</code>"


def _table(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _fmt(v) -> str:
    if v is None:
        return "never"
    if isinstance(v, float):
        return f"{v:.4g}"
    return html.escape(str(v))


def drift_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Build the section (about 10-20 s: a few small LPs, two scenario runs, the comparison)."""
    from ..examples.switching import switching_server, traffic_junction
    from ..observers.drift_observer import plot_drift_run, run_drift_scenario
    from ..observers.periodic import deadbeat_gains, positive_deadbeat_gains, positive_observer

    parts: list[str] = []
    summary: dict[str, Any] = {}
    figs: list[str] = []
    parts.append(
        "<p>Paper 003 samples a constant-drift hybrid system at its <em>visible</em> events (the output changes) and "
        "gets a periodic affine system (14): <code>x(t<sub>j+1</sub>) = A<sub>j</sub> x(t<sub>j</sub>) + a<sub>j</sub></code>, "
        "<code>t<sub>j+1</sub> = t<sub>j</sub> + C<sub>j</sub> x(t<sub>j</sub>) + c<sub>j</sub></code>. The only measurement is "
        "the event time; the observer (16) corrects with <code>L<sub>j</sub> (t<sub>j+1</sub> - t^<sub>j+1</sub>)</code>, and "
        "(18) predicts between events, waiting in extra modes when an event is late. Deadbeat gains come from the "
        "sequential algorithm (fastest error subspaces, linear conditions per phase, closed form); positive observers "
        "from an LP with a periodic copositive Lyapunov function (change of variables Z<sub>j</sub> = diag(p<sub>j+1</sub>) "
        "L<sub>j</sub>). Because A<sub>j</sub>, C<sub>j</sub> &ge; 0 the admissible positive gains form a box whose corner U is "
        "the best positive gain for every monotone criterion, which also yields the infeasibility certificates.</p>")

    # ---------------------------------------------------------------- models and gains
    systems = {"switching_server": switching_server(), "traffic_junction": traffic_junction(),
               "polling_server (built here)": polling_server(), "unserved_buffer (built here)": unserved_buffer_server()}
    designs_by_system: dict[str, dict[str, Any]] = {}
    rows_model, rows_gain = [], []
    for name, system in systems.items():
        progress(f"drift/{name}")
        ps = periodic_system(system)
        for j in range(1, ps.period + 1):
            rows_model.append([html.escape(name), str(j), str(ps.event_modes[j - 1]), _mat(ps.A[j - 1]), _mat(ps.a[j - 1]),
                               _mat(ps.C[j - 1]), f"{ps.c[j - 1]:.4g}"])
        designs: dict[str, Any] = {}
        for label, fn in (("sequential deadbeat", deadbeat_gains), ("positive deadbeat", positive_deadbeat_gains),
                          ("positive LP", positive_observer)):
            try:
                g = fn(ps)
                designs[label] = g
                rows_gain.append([html.escape(name), label, _mat(g.L), _fmt(g.deadbeat_steps), f"{g.monodromy_radius:.3g}",
                                  "yes" if g.positive else "no", _fmt(g.rate), f"{g.seconds * 1e3:.0f} ms"])
            except InfeasibleError as exc:
                ok = exc.certificate.verify() if exc.certificate is not None else False
                rows_gain.append([html.escape(name), label, "<em>infeasible</em>", "", "", "", "",
                                  f"{html.escape(exc.certificate.reason)} (certificate re-checked in numpy: {ok})"])
                summary.setdefault("infeasible", []).append({"system": name, "design": label, "verified": bool(ok)})
        designs_by_system[name] = designs
    parts.append("<h3>Event-sampled periodic systems (eqs. 14-15)</h3>")
    parts.append(_table(["system", "phase j", "leaves mode v_j", "A_j", "a_j", "C_j", "c_j"], rows_model))
    parts.append("<h3>Observer gains</h3><p>deadbeat = visible events until the error of (16) is zero from any "
                 "phase; rate = certified contraction of the copositive Lyapunov function per visible event.</p>")
    parts.append(_table(["system", "design", "L_j (rows)", "deadbeat in", "monodromy radius", "positive", "rate",
                         "time / reason"], rows_gain))

    # ---------------------------------------------------------------- the paper's junction run
    progress("drift/junction scenario")
    res = run_drift_scenario("traffic_junction", "paper")
    fig = "drift_junction.png"
    plot_drift_run(res, out / fig, "T-junction, gains (20a-b): estimated (solid) and true (dashed) queues")
    figs.append(fig)
    ev = res["observer"].events
    paper = PAPER_003_JUNCTION
    rows = [
        ["first visible event", f"{paper['first_event_t']}", f"{ev[0].t:.2f}"],
        ["its predicted time", f"{paper['first_event_predicted_t']}", f"{ev[0].predicted_t:.2f}"],
        ["predicted x~ there", str(paper["x_tilde_predicted"]), str(np.round(ev[0].x_predicted, 2).tolist())],
        ["x^ after the jump (18d)", str(paper["x_after_first_event"]), str(np.round(ev[0].x_after[1:], 2).tolist())],
        ["second visible event", f"{paper['second_event_t']}", f"{ev[1].t:.2f}"],
        ["x1^ after it (18e)", "0", f"{ev[1].x_after[1]:.3g}"],
        ["next predicted event", f"{paper['third_event_predicted_t']:.0f}", f"{ev[2].predicted_t:.2f}"],
        ["actual (waiting mode used)", f"{paper['third_event_t']}", f"{ev[2].t:.2f} (waited: {ev[2].waited})"],
        ["first exact reconstruction", f"{paper['third_event_t']}", _fmt(res["summary"]["first_exact_visible_event"])],
    ]
    parts.append("<h3>The T-junction of Section 5 (Figure 3)</h3><p>True system from x(0) = [5, 40, 60, 0] in mode 1 "
                 "(chosen so that its visible events fall at the printed times); observer from t = 50 with "
                 "x^(50) = [0, 70, 20, 30] in mode 4. The paper computed the jump from its rounded numbers "
                 "(58.3 + 0.5 (70.7 - 81.7) = 52.8); the exact value is 52.86.</p>")
    parts.append(_table(["quantity", "paper 003", "recomputed"], rows))
    parts.append(f"<img src='{fig}' alt='junction observer'>")
    summary["junction"] = {k: res["summary"][k] for k in ("final_error", "first_exact_visible_event", "nonnegative")}
    summary["junction"]["visible_events"] = [{"t": r.t, "predicted_t": r.predicted_t} for r in ev[:3]]

    progress("drift/server scenario")
    res_s = run_drift_scenario("switching_server", "deadbeat")
    fig = "drift_server.png"
    plot_drift_run(res_s, out / fig, "Switching server, sequential deadbeat gains: estimated (solid) and true (dashed)")
    figs.append(fig)
    parts.append("<h3>The switching server of Section 2.1</h3><p>Parameters lam1 = 1, mu1 = 3, mu2 = 4, gamma1 = 2, "
                 "gamma2 = 1 (chosen; the paper keeps them symbolic), observer from x^(0) = [gamma1, 0, 0] in mode 1. "
                 f"Exact from t = {_fmt(res_s['summary']['first_exact_visible_event'])} s.</p><img src='{fig}' alt='server observer'>")
    summary["server"] = {k: res_s["summary"][k] for k in ("final_error", "first_exact_visible_event", "nonnegative")}

    # ---------------------------------------------------------------- comparison
    progress("drift/comparison")
    rows_cmp = []
    summary["comparison"] = {}
    for name, key in (("switching_server", "switching_server"), ("traffic_junction", "traffic_junction"),
                      ("polling_server (built here)", "polling_server")):
        designs = designs_by_system[name]
        cmp_ = compare_observers(key, designs)
        summary["comparison"][key] = cmp_
        for label, rec in cmp_["observers"].items():
            if rec.get("applies") is False:
                rows_cmp.append([html.escape(name), html.escape(label), "does not apply", html.escape(rec["reason"]), "", ""])
                continue
            extra = f" (T = {rec['horizon_T']}, phase-augmented PWA)" if "horizon_T" in rec else ""
            rows_cmp.append([html.escape(name), html.escape(label) + extra, _fmt(rec["events_to_converge"]),
                             f"{rec['min_estimate']:.3g}", f"{rec['median_step_s'] * 1e6:.0f} us",
                             f"{rec['design_seconds'] * 1e3:.0f} ms"])
    parts.append(
        "<h3>Deadbeat vs positive vs lookup table on the same event-sampled data</h3>"
        f"<p>{COMPARISON_TRIALS} random non-negative initial estimates per system, started at a visible event of random "
        "phase; all observers read the same true visible-event times. The lookup-table observer of paper 002 applies "
        "once the phase is made a state: the periodic system (14) is then a PWA system with one region per phase "
        "(phi+ = phi + 1 mod V, output [t<sub>j+1</sub> - t<sub>j</sub>, phi], the phase being known from y). It "
        "reconstructs the state from T event-time increments when they determine it (rank condition) and gives "
        "estimates only at the visible events, whereas (16) reaches exactness through the emptied queues "
        "(reconstructibility) and feeds the continuous-time observer (18) between events.</p>")
    parts.append(_table(["system", "observer", "events until relative error < 1e-6 (worst trial)", "smallest estimate",
                         "median step", "design time"], rows_cmp))
    return ReportSection("Constant-drift observers (paper 003)", "\n".join(parts), summary, figs)


register_section("drift", drift_section)

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

The systems built here and the comparison are the study
:mod:`hybobs_opt.studies.paper003_switching.comparison` (shared with
``notebooks/03_constant_drift_observers.ipynb``).
"""

from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InfeasibleError
from ..systems.event_sampled import periodic_system
from ..studies.paper003_switching.comparison import (
    COMPARISON_TRIALS,
    compare_observers,
    polling_server,
    unserved_buffer_server,
)
from .section import ReportSection, register_section
from .text import num, vector, yes_no

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

# ---------------------------------------------------------------------------- html helpers
def _mat(M) -> str:
    M = np.atleast_2d(np.asarray(M, dtype=float))
    rows = "; ".join(" ".join(num(v) for v in r) for r in M)
    return f"<code>[{html.escape(rows)}]</code>"


def _table(header: list[str], rows: list[list[str]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{c}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def _fmt(v) -> str:
    if v is None:
        return "never"
    if isinstance(v, (int, float, np.integer, np.floating)) and not isinstance(v, (bool, np.bool_)):
        return num(v)
    return html.escape(str(v))


def drift_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Build the section (about 10-20 s: a few small LPs, two scenario runs, the comparison)."""
    from ..studies.paper003_switching.scenarios import plot_drift_run, run_drift_scenario
    from ..studies.paper003_switching.systems import switching_server, traffic_junction
    from ..synthesis.periodic_gains import deadbeat_gains, positive_deadbeat_gains, positive_observer

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
                               _mat(ps.C[j - 1]), num(ps.c[j - 1])])
        designs: dict[str, Any] = {}
        for label, fn in (("sequential deadbeat", deadbeat_gains), ("positive deadbeat", positive_deadbeat_gains),
                          ("positive LP", positive_observer)):
            try:
                g = fn(ps)
                designs[label] = g
                rows_gain.append([html.escape(name), label, _mat(g.L), _fmt(g.deadbeat_steps), num(g.monodromy_radius),
                                  yes_no(bool(g.positive)), _fmt(g.rate), num(g.seconds * 1e3)])
            except InfeasibleError as exc:
                ok = exc.certificate.verify() if exc.certificate is not None else False
                rows_gain.append([html.escape(name), label, "<em>infeasible</em>", "", "", "", "",
                                  f"{html.escape(exc.certificate.reason)} (certificate re-checked in numpy: {yes_no(bool(ok))})"])
                summary.setdefault("infeasible", []).append({"system": name, "design": label, "verified": bool(ok)})
        designs_by_system[name] = designs
    parts.append("<h3>Event-sampled periodic systems (eqs. 14-15)</h3>")
    parts.append(_table(["system", "phase j", "leaves mode v_j", "A_j", "a_j", "C_j", "c_j [s]"], rows_model))
    parts.append("<h3>Observer gains</h3><p>deadbeat = visible events until the error of (16) is zero from any "
                 "phase; rate = certified contraction of the copositive Lyapunov function per visible event.</p>")
    parts.append(_table(["system", "design", "L_j (rows)", "deadbeat in [visible events]", "monodromy radius", "positive",
                         "rate [per visible event]", "design time [ms] / reason"], rows_gain))

    # ---------------------------------------------------------------- the paper's junction run
    progress("drift/junction scenario")
    res = run_drift_scenario("traffic_junction", "paper")
    fig = "drift_junction.png"
    plot_drift_run(res, out / fig, "T-junction, gains (20a-b): estimated (solid) and true (dashed) queues")
    figs.append(fig)
    ev = res["observer"].events
    paper = PAPER_003_JUNCTION
    rows = [
        ["first visible event [s]", f"{paper['first_event_t']}", f"{ev[0].t:.2f}"],
        ["its predicted time [s]", f"{paper['first_event_predicted_t']}", f"{ev[0].predicted_t:.2f}"],
        ["predicted x~ there [vehicles]", vector(paper["x_tilde_predicted"]), vector(np.round(ev[0].x_predicted, 2))],
        ["x^ after the jump (18d) [vehicles]", vector(paper["x_after_first_event"]), vector(np.round(ev[0].x_after[1:], 2))],
        ["second visible event [s]", f"{paper['second_event_t']}", f"{ev[1].t:.2f}"],
        ["x1^ after it (18e) [vehicles]", "0", f"{ev[1].x_after[1]:.3g}"],
        ["next predicted event [s]", f"{paper['third_event_predicted_t']:.0f}", f"{ev[2].predicted_t:.2f}"],
        ["actual (waiting mode used) [s]", f"{paper['third_event_t']}", f"{ev[2].t:.2f} (waited: {yes_no(bool(ev[2].waited))})"],
        ["first exact reconstruction [s]", f"{paper['third_event_t']}", _fmt(res["summary"]["first_exact_visible_event"])],
    ]
    parts.append("<h3>The T-junction of Section 5 (Figure 3)</h3><p>True system from x(0) = [5, 40, 60, 0] in mode 1 "
                 "(chosen so that its visible events fall at the printed times); observer from t = 50 with "
                 "x^(50) = [0, 70, 20, 30] in mode 4. The paper computed the jump from its rounded numbers "
                 "(58.3 + 0.5 (70.7 - 81.7) = 52.8); the exact value is 52.86.</p>")
    parts.append(_table(["quantity", "paper 003", "recomputed"], rows))
    alt = (f"Queue lengths x1, x2, x3 [vehicles] of the T-junction against t [s] up to {res['t'][-1]:g} s: observer (18) "
           f"with the gains (20a-b), estimated (solid) and true (dashed), the {len(ev)} visible events marked by vertical lines")
    parts.append(f"<img src='{fig}' alt='{html.escape(alt, quote=True)}'>")
    summary["junction"] = {k: res["summary"][k] for k in ("final_error", "first_exact_visible_event", "nonnegative")}
    summary["junction"]["visible_events"] = [{"t": r.t, "predicted_t": r.predicted_t} for r in ev[:3]]

    progress("drift/server scenario")
    res_s = run_drift_scenario("switching_server", "deadbeat")
    fig = "drift_server.png"
    plot_drift_run(res_s, out / fig, "Switching server, sequential deadbeat gains: estimated (solid) and true (dashed)")
    figs.append(fig)
    alt_s = (f"Buffer contents x1, x2 [jobs] of the switching server against t [s] up to {res_s['t'][-1]:g} s: observer "
             f"(18) with the sequential deadbeat gains, estimated (solid) and true (dashed), the "
             f"{len(res_s['observer'].events)} visible events marked by vertical lines")
    parts.append("<h3>The switching server of Section 2.1</h3><p>Parameters lam1 = 1, mu1 = 3, mu2 = 4, gamma1 = 2, "
                 "gamma2 = 1 (chosen; the paper keeps them symbolic), observer from x^(0) = [gamma1, 0, 0] in mode 1. "
                 f"Exact from t = {_fmt(res_s['summary']['first_exact_visible_event'])} s.</p>"
                 f"<img src='{fig}' alt='{html.escape(alt_s, quote=True)}'>")
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
                             num(rec["min_estimate"]), num(rec["median_step_s"] * 1e3), num(rec["design_seconds"] * 1e3)])
    parts.append(
        "<h3>Deadbeat vs positive vs lookup table on the same event-sampled data</h3>"
        f"<p>{COMPARISON_TRIALS} random non-negative initial estimates per system, started at a visible event of random "
        "phase; all observers read the same true visible-event times. The lookup-table observer of paper 002 applies "
        "once the phase is made a state: the periodic system (14) is then a PWA system with one region per phase "
        "(phi+ = phi + 1 mod V, output [t<sub>j+1</sub> - t<sub>j</sub>, phi], the phase being known from y). It "
        "reconstructs the state from T event-time increments when they determine it (rank condition) and gives "
        "estimates only at the visible events, whereas (16) reaches exactness through the emptied queues "
        "(reconstructibility) and feeds the continuous-time observer (18) between events.</p>")
    parts.append(_table(["system", "observer", "visible events until relative error < 1e-6, worst trial [events]",
                         "smallest estimate [jobs or vehicles]", "median step [ms]", "design time [ms]"], rows_cmp))
    return ReportSection("Constant-drift observers (paper 003)", "\n".join(parts), summary, figs)


register_section("drift", drift_section)

"""Report section "Driveline hybrid observer (paper 000)": the location observer and the switched
continuous observer on the Fig. 6 scenario, against the lookup-table deadbeat observer of paper
002 run on the same samples of the driveline discretised with ``HybridAutomaton.discretize``.

Shown: a figure like Fig. 6 (torsion angle, decision signals, locations), the designs (LMI decay
rates and conditioning, the residual bound against the paper's Jordan-form bound of eq. (9), M0
against eq. (20) as printed), and the comparison table: location estimate (right / ambiguous or
unknown / wrong), detection delay per location change, state errors after both observers have
converged, and compute time per ``step`` call.
"""

from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..studies.paper000_driveline.comparison import COMPARE_FROM, compare
from .section import ReportSection, register_section
from .text import num, yes_no

def _fmt(v: Any, digits: int = 3) -> str:
    if v is None:
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return yes_no(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        return ", ".join(_fmt(x, digits) for x in v)
    if isinstance(v, (float, np.floating)):
        return num(v, digits)
    return html.escape(str(v))


#: Units of the driveline's states (theta_e [rad], then two speeds [rad/s]), for the column headers.
_STATE_UNITS = ("rad", "rad/s", "rad/s")


def _ms(v: Any) -> str:
    """A time in seconds written in ms (``-`` when missing)."""
    return "-" if v is None else num(1e3 * float(v))


def driveline_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Fig. 6 of paper 000 with the designed hybrid observer, and the comparison with the lookup observer."""
    from ..studies.paper000_driveline.scenario import DRIVELINE_K_LOW, plot_fig6, run_driveline

    progress("driveline/design and run")
    res = run_driveline()
    progress("driveline/lookup comparison")
    rows, outs = compare(res)
    lookup_name = next(k for k in rows if k.startswith("lookup T=4"))
    fig = "driveline_fig6.png"
    plot_fig6(res, str(out / fig), lookup=outs[lookup_name].mode)
    alt = ("Driveline from 1.9 s to 2.6 s around the -10 N m torque step: the torsion theta_e - theta_e0 [rad] of the "
           "plant and of the continuous observer with the location thresholds -0.01 and -0.04 rad; the decision "
           "signals sigma_r2 and sigma_r3 (false/true); the true location, the estimated one (gaps: ambiguous) and "
           f"the location found by the {lookup_name} observer, against t [s]")
    s = res.summary
    names = res.automaton.state_names

    gen_rows = "".join(
        f"<tr><td>{html.escape(g.label)}</td><td>{_fmt(g.decay)}</td><td>{_fmt(g.cond_P)}</td><td>{_fmt(g.gain_norm)}</td>"
        f"<td>{_fmt(g.residual_bound)}</td><td>{_fmt(g.lmi_bound)}</td><td>{_fmt(g.guaranteed_delay)}</td>"
        f"<td>{_fmt(g.spectral_abscissa)}</td><td>{_fmt(g.jordan_kappa)}</td><td>{_fmt(g.paper_delay)}</td></tr>"
        for g in res.bank.generators
    )
    gen_table = (
        "<table><tr><th>generator</th><th>decay alpha [1/s]</th><th>cond P</th><th>||L|| [model units]</th>"
        "<th>||C P^-1/2|| ||P^1/2||</th><th>||C|| sqrt(cond P)</th><th>guaranteed delay [s]</th>"
        "<th>spectral abscissa alpha(H) [1/s]</th><th>kappa(H)</th><th>delay certified by eq. (9) [s]</th></tr>"
        + gen_rows + "</table>"
    )
    b = res.bound
    cont = (
        f"<p>Continuous observer (eq. 15), one Lyapunov matrix for all locations: certified decay "
        f"{_fmt(res.design.decay)} 1/s, cond P = {_fmt(res.design.cond_P)}, ||G_i|| = {_fmt(list(res.design.gain_norms))}. "
        f"With Delta = {_fmt(b.delta)} s, D = {_fmt(b.dwell_time)} s and the operating box of the scenario: "
        f"M0 = {_fmt(b.M0)} (per state {_fmt(b.M0_per_state.tolist())}); eq. (20) as printed, with the Jordan "
        f"conditioning kappa(F_j): {_fmt(b.M0_paper)}. Measured error after convergence (t &ge; "
        f"{_fmt(s['t_convergence'])} s): {_fmt(s['max_error_after_convergence'])}; per state "
        f"{_fmt(s['max_abs_error_after_convergence_per_state'])}.</p>"
    )
    units = ", ".join(f"{nm} [{u}]" for nm, u in zip(names, _STATE_UNITS))
    head = "".join(f"<th>{html.escape(h)}</th>" for h in (
        "observer", "location right [samples]", "unknown / ambiguous [samples]", "wrong [samples]", "detection delays [s]",
        f"max |error| after {COMPARE_FROM:g} s: {units}", f"RMS error: {units}", "median step [ms]", "p95 step [ms]"))
    body = "".join(
        f"<tr><td>{html.escape(k)}</td><td>{_fmt(r['location_right'])}</td><td>{_fmt(r['location_unknown_or_ambiguous'])}</td>"
        f"<td>{_fmt(r['location_wrong'])}</td><td>{_fmt(r['detection_delays'])}</td><td>{_fmt(r['max_abs_error'])}</td>"
        f"<td>{_fmt(r['rms_error'])}</td><td>{_ms(r['median_step_s'])}</td><td>{_ms(r['p95_step_s'])}</td></tr>"
        for k, r in rows.items()
    )
    comparison = f"<table><tr>{head}</tr>{body}</table>"
    intro = (
        f"<p>The driveline of paper 000 with the low elasticity k = {DRIVELINE_K_LOW:g} N m/rad (the example's default "
        "k = 0 makes the backlash location unobservable from the crankshaft speed, which Proposition 3.3.1 excludes), "
        "the -10 N m torque step at 2 s, 1 ms samples. Location changes: "
        + ", ".join(f"{c['from']} &rarr; {c['to']} at {c['t']:.4f} s" for c in s["location_changes"])
        + f". Designed detection delay Delta = {_fmt(s['delta_design'])} s (threshold epsilon = {_fmt(s['epsilon'])} rpm, "
        f"Z0 = {_fmt(s['z0_bound'])}); measured delays {_fmt(s['detection_delays'])} s; {s['ambiguous_steps']} samples "
        f"reported ambiguous, {s['wrong_location_steps']} with a wrong location.</p>"
        "<p>The residuals alone do not separate the locations here: the dynamics of q2 and q3 coincide on the "
        "switching surface and the fast generators track the crankshaft speed under either model (every sigma_j "
        "stays true, dashed in the figure). The identification comes from the invariant test on each generator's "
        "state, whose margin is the error bound the design guarantees Delta after a change; the logic reports "
        "ambiguity, not a guess, while both tests pass.</p>"
    )
    body_html = (
        intro + f"<img src='{fig}' alt='{html.escape(alt, quote=True)}'>" + "<h3>Residual generators (Proposition 3.1.1)</h3>" + gen_table + cont
        + "<h3>Against the lookup observer on the discretised driveline</h3>" + comparison
    )
    summary = {k: v for k, v in s.items() if k not in ("residual_design", "continuous_design")}
    summary["comparison"] = rows
    return ReportSection("Driveline hybrid observer (paper 000)", body_html, summary, [fig])


register_section("driveline_observer", driveline_section)

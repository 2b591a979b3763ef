"""Report section "Sliding-mode observer (paper 001)": Examples 1-3, the filter trade-off, and the
comparison with the lookup-table deadbeat observer on the discretised double scroll.

Figures after the paper's: Fig. 2-3 (Example 1: stable subsystems, unstable switched system),
Fig. 4 (Example 2: x_i and their estimates), Figs. 5-6 (switching indicator S and S_o with and
without filter), Fig. 7 (double-scroll phase portrait), Fig. 8 (step-by-step convergence), Fig. 9
(S, S_o and sigma(x~) near a switching value).  Every number is recomputed here.

The comparison with the lookup observer is the study
:mod:`hybobs_opt.studies.paper001_sliding_mode.comparison` (shared with
``notebooks/01_sliding_mode_observers.ipynb``).
"""

from __future__ import annotations

import html
from collections.abc import Callable
from pathlib import Path
from typing import Any

from ..plotting import pyplot

plt = pyplot()
import numpy as np  # noqa: E402
from scipy.linalg import expm  # noqa: E402

from ..studies.paper001_sliding_mode.systems import P_DERIVED, P_PRINTED, SIGMA1, SIGMA2, double_scroll  # noqa: E402
from ..studies.paper001_sliding_mode.scenarios import (  # noqa: E402
    SCENARIOS,
    TRADEOFF_NOISE_REL,
    ScenarioResult,
    filter_tradeoff,
    run_scenario,
    summarize,
)
from ..studies.paper001_sliding_mode.comparison import COMPARISON_RTOL, lookup_comparison  # noqa: E402
from ..systems.canonical_form import theorem1_pairs  # noqa: E402
from ..defaults import SMO_FILTER_STEPS  # noqa: E402
from .section import ReportSection, register_section  # noqa: E402
from .text import matrix_table, num, vector, yes_no  # noqa: E402


# ---------------------------------------------------------------------------------- figures
#: Alt text of each figure written by :func:`_save` in the current section run (what it shows).
_ALTS: dict[str, str] = {}


#: The heading of each figure in the section.
_HEADINGS = {
    "smo_fig2_subsystems.png": "Example 1: the two subsystems alone (Fig. 2)",
    "smo_fig3_switched.png": "Example 1: the unstable switched system and the observer (Fig. 3)",
    "smo_fig7_phase.png": "Example 3: the double scroll's phase portrait (Fig. 7)",
    "smo_fig4_triangular.png": "Example 2: the triangular system and its estimates (Fig. 4)",
    "smo_fig8_double_scroll.png": "Example 3: the double scroll and its estimates (Fig. 8)",
    "smo_relay.png": "A relay oscillator (not from the paper)",
    "smo_indicator_triangular.png": "Example 2: switching-function estimates (Figs. 5-6)",
    "smo_indicator_double_scroll.png": "Example 3: switching-function estimate near a switch (Fig. 9)",
}


def _save(fig, out: Path, name: str, figs: list[str], alt: str) -> None:
    fig.tight_layout()
    fig.savefig(out / name, dpi=100)
    plt.close(fig)
    figs.append(name)
    _ALTS[name] = alt


def _fig_example1(out: Path, ex1: ScenarioResult, figs: list[str]) -> None:
    t = np.linspace(0.0, 10.0, 1001)
    fig, axes = plt.subplots(1, 2, figsize=(9, 2.8), sharey=True)
    for ax, A, label in zip(axes, (SIGMA1, SIGMA2), ("Sigma_1", "Sigma_2")):
        X = np.array([expm(A * s) @ np.array([1.0, 0.0]) for s in t])
        ax.plot(t, X[:, 0], label="x1")
        ax.plot(t, X[:, 1], label="x2")
        ax.set_title(f"{label} alone (stable)", fontsize=9)
        ax.set_xlabel("t [s]")
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("x1, x2")
    axes[0].legend(fontsize=7)
    _save(fig, out, "smo_fig2_subsystems.png", figs,
          "x1 and x2 of Example 1's subsystems Sigma_1 and Sigma_2, each alone, over 10 s from (1, 0): both are "
          "stable centres (Fig. 2)")

    tt = ex1.t
    names = ex1.form.automaton.location_names
    S = np.array([1 if names[q].startswith("Sigma1") else 2 for q in ex1.S])
    fig, axes = plt.subplots(3, 1, figsize=(8, 5.5), sharex=True)
    for j in range(2):
        axes[j].plot(tt, ex1.truth.x[:, j], lw=1.2, label=f"x{j + 1}")
        axes[j].plot(tt, ex1.run.trace.x_hat[:, j], "--", lw=1.0, label="estimate")
        axes[j].grid(alpha=0.3)
        axes[j].set_ylabel(f"x{j + 1}")
        axes[j].legend(fontsize=7, loc="upper left")
    axes[2].step(tt, S, where="post", lw=1.0)
    axes[2].set_yticks([1, 2])
    axes[2].set_ylabel("S (active Sigma)")
    axes[2].set_xlabel("t [s]")
    fig.suptitle("Example 1: the switched system is unstable (Fig. 3), with observer (5)", fontsize=10)
    _save(fig, out, "smo_fig3_switched.png", figs,
          f"Example 1 switched by sign(x1 x2) over {tt[-1]:g} s: x1 and x2 growing, with the sliding-mode "
          "observer's estimates, and the active subsystem S (1 or 2) against time (Fig. 3)")


def _fig_states(out: Path, res: ScenarioResult, name: str, title: str, figs: list[str], t_max: float | None = None,
                alt: str = "") -> None:
    n = res.form.n
    fig, axes = plt.subplots(n, 2, figsize=(10, 1.9 * n + 0.6), sharex="col")  # one time axis per column
    t = res.t
    for j in range(n):
        ax = axes[j, 0]
        ax.plot(t, res.z_true[:, j], lw=1.2, label="true")
        ax.plot(t, res.run.z_hat[:, j], "--", lw=1.0, label="estimate")
        ax.set_ylabel(res.form.names[j])
        ax.grid(alpha=0.3)
        ax = axes[j, 1]
        e = np.abs(res.run.z_hat[:, j] - res.z_true[:, j])
        ax.semilogy(t, np.maximum(e, 1e-14), lw=0.8)
        ax.axhline(res.band[j], color="k", ls=":", lw=0.8, label="stated band")
        if np.isfinite(res.conv_times[j]):
            ax.axvline(res.conv_times[j], color="tab:red", lw=0.8, label="converged")
        if t_max is not None:
            ax.set_xlim(0, t_max)
        ax.set_ylabel(f"|error {res.form.names[j]}|")
        ax.grid(alpha=0.3)
    axes[0, 0].legend(fontsize=7)
    axes[0, 1].legend(fontsize=7)
    axes[-1, 0].set_xlabel("t [s]")
    axes[-1, 1].set_xlabel("t [s]")
    fig.suptitle(title, fontsize=10)
    names = ", ".join(res.form.names[:n])
    _save(fig, out, name, figs,
          (alt or title) + f": {names} true and estimated over {t[-1]:g} s (left), their absolute errors on a log "
          "scale with the stated band and the convergence times (right)")


def _fig_indicator(out: Path, raw: ScenarioResult, filt: ScenarioResult, sigma_index: int, window: tuple[float, float],
                   name: str, title: str, figs: list[str]) -> None:
    t = raw.t
    sel = (t >= window[0]) & (t <= window[1])
    fig, axes = plt.subplots(3, 1, figsize=(8, 5.5), sharex=True)
    axes[0].step(t[sel], raw.S[sel], where="post", lw=1.4, label="S (true)")
    axes[0].step(t[sel], raw.run.mode[sel] + 0.05, where="post", lw=0.8, label="S_o, no filter")
    axes[0].legend(fontsize=7)
    axes[0].set_ylabel("indicator S")
    axes[1].step(t[sel], raw.S[sel], where="post", lw=1.4, label="S (true)")
    axes[1].step(t[sel], filt.run.mode[sel] + 0.05, where="post", lw=0.8, label=f"S_o, filter tau = {filt.observer.filter_tau:g} s")
    axes[1].legend(fontsize=7)
    axes[1].set_ylabel("indicator S")
    sig_true = raw.form.sigma(raw.z_true)[:, sigma_index]
    sig_raw = raw.form.sigma(raw.run.z_switch)[:, sigma_index]
    sig_f = raw.form.sigma(filt.run.z_switch)[:, sigma_index]
    axes[2].plot(t[sel], sig_raw[sel], lw=0.6, label="sigma(x~), no filter")
    axes[2].plot(t[sel], sig_f[sel], lw=1.0, label="sigma(x~), filtered")
    axes[2].plot(t[sel], sig_true[sel], "k", lw=1.0, label="sigma(x)")
    for thr in raw.form.switching[sigma_index].thresholds:
        axes[2].axhline(thr, color="grey", ls=":", lw=0.8)
    axes[2].legend(fontsize=7)
    axes[2].set_ylabel("switching function sigma")
    axes[2].set_xlabel("t [s]")
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle(title, fontsize=10)
    _save(fig, out, name, figs,
          f"{title}: from {window[0]:.3g} s to {window[1]:.3g} s, the true location indicator S against the observer's "
          "S_o without and with the low-pass filter, and the switching function sigma of the true and estimated states")


def _fig_phase(out: Path, ds: ScenarioResult, figs: list[str]) -> None:
    from ..studies.paper001_sliding_mode.systems import DOUBLE_SCROLL_X0
    from ..sim.hybrid import simulate_hybrid

    tr = simulate_hybrid(double_scroll(), np.array(DOUBLE_SCROLL_X0), 50.0, dt=1e-2)
    fig, axes = plt.subplots(1, 2, figsize=(10, 3.8))
    axes[0].plot(tr.x[:, 0], tr.x[:, 2], lw=0.5)
    axes[0].set_xlabel("x1")
    axes[0].set_ylabel("x3")
    axes[0].set_title("double scroll, 50 s from (0.1, 0, 0) (Fig. 7)", fontsize=9)
    after = ds.t >= ds.t_settled
    axes[1].plot(ds.truth.x[:, 0], ds.truth.x[:, 1], lw=1.5, alpha=0.4, label="true")
    axes[1].plot(ds.run.trace.x_hat[after, 0], ds.run.trace.x_hat[after, 1], "--", lw=0.6, label="estimate (after convergence)")
    axes[1].set_xlabel("x1")
    axes[1].set_ylabel("x2")
    axes[1].legend(fontsize=7)
    for ax in axes:
        ax.axvline(1, color="grey", ls=":", lw=0.8)
        ax.axvline(-1, color="grey", ls=":", lw=0.8)
        ax.grid(alpha=0.3)
    _save(fig, out, "smo_fig7_phase.png", figs,
          "Double scroll: x3 against x1 over 50 s from (0.1, 0, 0) (Fig. 7, left), and x2 against x1 of the true "
          "trajectory with the sliding-mode estimate after convergence (right); dotted lines at the switching "
          "surfaces x1 = -1 and x1 = 1")


# ---------------------------------------------------------------------------------- tables
def _fmt(v, digits: int = 3) -> str:
    if v is None:
        return "-"
    if isinstance(v, (bool, np.bool_)):
        return yes_no(v)
    if isinstance(v, (list, tuple, np.ndarray)):
        return ", ".join(_fmt(x, digits) for x in v)
    if isinstance(v, (float, np.floating)):
        if not np.isfinite(v):
            return "not reached"
        return num(v, digits)
    return html.escape(str(v))


def _table(header: list[str], rows: list[list[Any]]) -> str:
    head = "".join(f"<th>{html.escape(h)}</th>" for h in header)
    body = "".join("<tr>" + "".join(f"<td>{_fmt(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table><tr>{head}</tr>{body}</table>"


def sliding_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Examples 1-3 of paper 001 with observer (5), the filter trade-off and the lookup comparison."""
    out = Path(out)
    figs: list[str] = []
    summary: dict[str, Any] = {}
    parts: list[str] = []

    progress("sliding/canonical form")
    ds = run_scenario("double_scroll")
    form = ds.form
    P_rows = []
    for q in range(3):
        P_rows.append([form.automaton.locations[q].name, list(np.round(form.alpha[q], 4)) + [round(float(form.beta[q]), 4)],
                       list(np.round(P_DERIVED[q], 4)), list(np.round(P_PRINTED[q], 4))])
    th = theorem1_pairs(form.automaton)
    th_rows = [[f"{form.automaton.locations[r.i].name}-{form.automaton.locations[r.j].name}", r.M_dim, r.nontransverse_dim,
                r.S_dim, r.L_dim, ", ".join(k for k, v in r.items.items() if v) or "none", r.observable] for r in th]
    parts.append(
        "<p>Observer (5) of paper 001 runs on the canonical form (4). For the double scroll (Example 3) the "
        "coordinates <code>z = T x</code> (output and its derivatives) and <code>z3' = P_q(z)</code> are computed "
        "from (A_q, B_q, C): T (the paper's diffeomorphism) is</p>" + matrix_table(form.T)
        + "<p>and <code>sigma(z) = "
        f"{vector(form.switching[0].z_row)} . z</code> (the paper's "
        "<code>(z3 + z2)/c1 - z1</code>). The computed P_q agree with the paper's formulas; the printed "
        "P1 (sign of beta) and P2 do not (the study's canonical form of the double scroll says where).</p>"
        + _table(["location", "computed alpha1, alpha2, alpha3, beta (dimensionless)", "paper's formulas (dimensionless)",
                  "as printed (dimensionless)"], P_rows)
        + "<p>Theorem 1 for adjacent locations (dimensions: -1 empty; M: where g_i = g_j; non-transverse part of M; "
        "S: where the switching functions agree; L: common equilibria):</p>"
        + _table(["pair", "dim M", "dim non-transverse", "dim S", "dim L", "items that apply", "distinguishable"], th_rows)
    )
    summary["theorem1_double_scroll"] = [r.to_dict() for r in th]

    progress("sliding/examples")
    ex1 = run_scenario("switched_unstable")
    ex2 = run_scenario("triangular")
    relay = run_scenario("relay_oscillator")
    _fig_example1(out, ex1, figs)
    _fig_states(out, ex2, "smo_fig4_triangular.png", "Example 2: x_i and estimates (left), errors and stated band (right)",
                figs, t_max=1.0)
    _fig_phase(out, ds, figs)
    _fig_states(out, ds, "smo_fig8_double_scroll.png",
                "Example 3 in z = T x: step-by-step convergence z1, z2, z3 (Fig. 8)", figs, t_max=0.2)
    _fig_states(out, relay, "smo_relay.png", "Relay oscillator (not from the paper): same code", figs, t_max=1.0)
    rows = []
    for label, r in (("Example 1 (switched_unstable)", ex1), ("Example 2 (triangular)", ex2), ("Example 3 (double_scroll)", ds),
                     ("relay oscillator (not in paper)", relay)):
        s = summarize(r)
        summary[r.spec.name] = s
        rows.append([label, r.observer.Ts, list(r.observer.gains.lambdas), list(r.band),
                     [c["state"] + " at " + _fmt(c["t"]) + " s" for c in s["convergence_times"]], list(r.final_error),
                     list(r.error_last_half), s["indicator"]["mismatch_fraction"], s["indicator"]["window"],
                     1e3 * s["compute_time_per_step_s"]])
    parts.append(
        "<p>Gains by the explicit rule <code>lambda_j = 1.5 x range width of z_(j+1)</code>, <code>lambda_n = 1.5 x range "
        "width of f</code> (operating box, all locations). Stated band: <code>j h D_j</code> (D_j: bound of z_j'). "
        "The observer starts 10 % of the operating range away from the plant. Errors are in the canonical "
        "coordinates, measured from the first sample at which all stages slide.</p>"
        + _table(["system", "h [s]", "lambda_j [units of z_(j+1)]", "stated band [units of z_j]", "converged (in order)",
                  "max error after [units of z_j]", "max error, 2nd half [units of z_j]", "S_o != S fraction",
                  "mismatch window [s]", "compute time per step [ms]"], rows)
    )

    progress("sliding/filter trade-off")
    rel = TRADEOFF_NOISE_REL
    runs_ds: dict = {}
    runs_tri: dict = {}
    trade = filter_tradeoff("double_scroll", base=ds, results=runs_ds)
    trade += filter_tradeoff("triangular", base=ex2, filter_steps=(None, SMO_FILTER_STEPS), results=runs_tri)
    summary["filter_tradeoff"] = trade
    parts.append(
        f"<h3>Filter trade-off (Figs. 5-6, 9)</h3><p>Noise: {rel:g} x output range (white, Gaussian). "
        "A spurious switch leaves S_o different from S; the delay runs from a true switch until S_o agrees.</p>"
        + _table(["example", "noise / range", "filter [samples]", "spurious switches", "true switches", "delay median [s]",
                  "delay max [s]", "S_o != S fraction", "window [s]", "max error of z_n [units of z_n]"],
                 [[r["example"], r["noise_rel"], r["filter_steps"] or "none", r["spurious_switches"], r["true_switches"],
                   r["delay_median_s"], r["delay_max_s"], r["mismatch_fraction"], r["window_s"], r["last_state_error"]]
                  for r in trade])
    )
    ks = np.nonzero(np.diff(ds.S))[0]
    tk = float(ds.t[ks[len(ks) // 2]]) if ks.size else float(ds.t[-1]) / 2
    k2 = np.nonzero(np.diff(ex2.S))[0]
    t2 = float(ex2.t[k2[0]]) if k2.size else float(ex2.t[-1]) / 2
    _fig_indicator(out, runs_tri[(rel, None)], runs_tri[(rel, SMO_FILTER_STEPS)], 0, (t2 - 0.02, t2 + 0.02),
                   "smo_indicator_triangular.png", "Example 2: S, S_o with and without filter, sigma = x2 (Figs. 5-6)", figs)
    _fig_indicator(out, runs_ds[(rel, None)], runs_ds[(rel, SMO_FILTER_STEPS)], 0, (tk - 0.1, tk + 0.1),
                   "smo_indicator_double_scroll.png", "Example 3: S, S_o and sigma(x~) near a switch (Fig. 9)", figs)

    progress("sliding/lookup comparison")
    comp = lookup_comparison(ds)
    summary["lookup_comparison"] = comp
    parts.append(
        "<h3>Against the lookup-table deadbeat observer (paper 002) on the discretised double scroll</h3>"
        f"<p>Same continuous trajectory; converged = every error below {COMPARISON_RTOL:g} x the state's range from then "
        "on. The lookup observer is exact for its ZOH model (the double-scroll flow is continuous across x1 = +-1, so "
        "freezing the location over a crossing sample costs little); the sliding-mode observer needs no offline work "
        "and no model discretisation, but differentiates y (band ~ j h D_j) and is a Python loop.</p>"
        + _table(["observer", "Ts [s]", "offline [s]", "converged at [s]", "max |error| after, x1, x2, x3 (dimensionless)",
                  "RMS error after (dimensionless)", "compute time per step [ms]", "note"],
                 [[r["observer"], r["Ts"], r["offline_s"], r["convergence_time_s"], r["max_error_after"], r["rms_error_after"],
                   None if r["step_s"] is None else 1e3 * r["step_s"], r["note"]] for r in comp])
    )
    images = "".join(f"<h3>{html.escape(_HEADINGS.get(f, f[4:-4].replace('_', ' ')))}</h3>"
                     f"<img src='{f}' alt='{html.escape(_ALTS[f], quote=True)}'>" for f in figs)
    scen = "<ul>" + "".join(f"<li><b>{k}</b>: {html.escape(v.note)}</li>" for k, v in SCENARIOS.items()) + "</ul>"
    return ReportSection("Sliding-mode observer (paper 001)", "".join(parts) + scen + images, summary, figs)


register_section("sliding_mode", sliding_section)

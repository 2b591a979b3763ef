"""``hybobs report SYSTEM``: the report of one system (a user's model), with the sections that
apply to its class.

Every class: the model (sizes, names, modes or locations, the model dictionary) and a simulation
from the centre of the state bounds under the centre input.  PWA systems: the observability
regions (Algorithm 3.1 of paper 002, a cut plot for two states) and, with a recorded log, the
lookup observer against the moving-horizon observers on it.  Scalar-nonlinear systems: the
constant-gain diagnosis (LMI (8) of paper 004) and the switched-gain synthesis with settings read
from the model.
"""

from __future__ import annotations

import dataclasses
import html
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from .html import assemble_report
from .plots import plot_estimates, plot_trace
from .section import ReportSection
from .text import num, yes_no
from .._output_files import write_output_text

#: Sections per system class, in page order.
SECTIONS_BY_CLASS: dict[str, tuple[str, ...]] = {
    "PWASystem": ("model", "simulation", "regions", "observers"),
    "HybridAutomaton": ("model", "simulation"),
    "ConstantDriftSystem": ("model", "simulation"),
    "ScalarNonlinearSystem": ("model", "simulation", "diagnosis", "synthesis"),
}


def _state_values(names: list[str], values) -> str:
    """``name value`` per state (HTML-escaped), or ``n/a``."""
    if values is None:
        return "n/a"
    return ", ".join(f"{html.escape(nm)} {v:.3g}" for nm, v in zip(names, values))


def _value(v: Any) -> str:
    """A table value in words: a flag yes/no, a number to 4 significant digits, anything else as text."""
    if v is None or isinstance(v, (bool, np.bool_)):
        return yes_no(v)
    if isinstance(v, (int, float, np.integer, np.floating)):
        return num(v)
    return str(v)


def _table(rows: list[tuple[str, Any]]) -> str:
    return "<table>" + "".join(f"<tr><th>{html.escape(str(k))}</th><td>{html.escape(_value(v))}</td></tr>" for k, v in rows) + "</table>"


def system_report_keys(system, data: str | None = None) -> list[str]:
    """The keys of the sections :func:`build_system_report` builds for ``system``, in order."""
    kind = type(system).__name__
    return [k for k in SECTIONS_BY_CLASS.get(kind, ("model", "simulation")) if k != "observers" or data]


def build_system_report(system, label: str, out_dir: str | Path, *, horizon: int = 2, data: str | None = None,
                        noise_bound=None, progress: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Build ``out_dir/index.html`` for ``system`` (named ``label``); returns what :func:`assemble_report` does.

    ``horizon`` is the observation horizon of the PWA sections; ``data`` a CSV log
    (:func:`hybobs_opt.sim.log.read_log`) for the observers section (skipped without one);
    ``noise_bound`` (with ``data``) a bound on each output's noise
    (:func:`~hybobs_opt.contract.noise_bound_vector`): the observers then state certified radii
    under it and the set-membership observer joins them.
    """
    if noise_bound is not None and data is None:
        raise ModelError("noise_bound", "given only with data (the radii are those of the observers on a log)",
                         repr(noise_bound))
    keys = system_report_keys(system, data)
    slug = "".join(c if c.isalnum() or c in "-_" else "_" for c in Path(label).name)
    shared: dict[str, Any] = {}

    def model(out: Path, progress) -> ReportSection:
        d = system.to_dict()
        sizes = [("class", d["class"]), ("name", d.get("name", "")), ("states", ", ".join(d.get("states", []))),
                 ("inputs", ", ".join(d.get("inputs", [])) or "none"), ("outputs", ", ".join(d.get("outputs", [])))]
        if "modes" in d and isinstance(d["modes"], list):
            sizes.append(("modes", ", ".join(m.get("name", "") for m in d["modes"]) if isinstance(d["modes"][0], dict) else len(d["modes"])))
        if "locations" in d:
            sizes.append(("locations", ", ".join(loc.get("name", "") for loc in d["locations"])))
        write_output_text(out / f"model_{slug}.json", json.dumps(d, indent=1))
        body = _table(sizes) + f"<p>Model dictionary: <a href='model_{slug}.json'>model_{slug}.json</a> (load it with <code>hybobs_opt.load_model</code>).</p>"
        return ReportSection(f"Model {label}", body, {"class": d["class"], "n_states": len(d.get("states", []))})

    def simulation(out: Path, progress) -> ReportSection:
        from ..sim.any_system import simulate_system

        from ..errors import HybobsError

        try:
            trace = simulate_system(system)
        except HybobsError as exc:  # e.g. a Zeno automaton before the default horizon: say so, keep the page
            return ReportSection("Simulation", f"<p>The run from the centre of the state bounds under the centre input "
                                 f"stopped: {html.escape(str(exc))}. Choose the run with <code>hybobs simulate SYSTEM "
                                 f"--x0 ... --t-final ...</code>.</p>", {"error": str(exc)}, error=str(exc))
        fig = f"simulation_{slug}.png"
        plot_trace(trace, out / fig, title=f"{label}: from the centre of the state bounds")
        alt = (f"Simulation of {label} from the centre of its state bounds over {trace.t[-1] - trace.t[0]:g} s: "
               f"{', '.join(trace.state_names[:6])} and the discrete state q against time")
        return ReportSection("Simulation", f"<p>{trace.n_samples} samples; initial state and constant input at the "
                             f"centre of the bounds.</p><img src='{fig}' alt='{html.escape(alt, quote=True)}'>",
                             {"samples": trace.n_samples, "final_state": trace.x[-1].tolist()}, [fig])

    def regions(out: Path, progress) -> ReportSection:
        from ..regions import PointClass, analyse_observability, compute_cut
        from .plots import CUT_COLOURS, plot_region_cut

        analysis = analyse_observability(system, horizon)
        shared["analysis"] = analysis
        s = analysis.summary()
        body = _table([("horizon T", horizon), ("regions of I", s["n_regions"]), ("with rank C_i = n", s["n_full_rank"]),
                       ("pieces of B_T", s["n_unobservable_pieces"]), ("pieces of B~_T", s["n_reduced_pieces"]),
                       ("LPs", s["n_lps"]), ("time [s]", s["seconds"])])
        figs = []
        if system.n == 2:
            fig = f"regions_{slug}.png"
            cut = compute_cut(analysis, {}, (41, 31))
            plot_region_cut(cut, out / fig, title=f"{label}, T = {horizon}")
            figs.append(fig)
            shares = ", ".join(f"{CUT_COLOURS[k][0]} {w} {100 * float(np.mean(cut.labels == k)):.3g} %" for k, w in
                               ((PointClass.OBSERVABLE, "observable"), (PointClass.UNOBSERVABLE, "unobservable"),
                                (PointClass.INFEASIBLE, "outside X*_T")))
            alt = (f"Observability regions of {label} at T = {horizon} on a 41 x 31 grid of {cut.axes[0]} against "
                   f"{cut.axes[1]}: {shares}")
            body += f"<img src='{fig}' alt='{html.escape(alt, quote=True)}'>"
        else:
            body += "<p>A cut plot needs fixed values for all but two states: <code>hybobs regions SYSTEM --cut ...</code>.</p>"
        return ReportSection(f"Observability regions (paper 002, Algorithm 3.1, T = {horizon})", body, s, figs)

    def observers(out: Path, progress) -> ReportSection:
        from ..observers.recorded import observe_log
        from ..sim.log import read_log

        log = read_log(data, system)
        kinds = ["lookup", "miqp", "milp"] + (["set_membership"] if noise_bound is not None else [])
        if noise_bound is not None and system.p * horizon < system.n:
            kinds.remove("lookup")  # no lookup table: T p < n leaves every window without a full-rank map
        runs = observe_log(system, log, kinds, horizon, shared.get("analysis"), noise_bound=noise_bound)
        rows, figs, summary, alts = [], [], {}, {}
        names = list(system.state_names)
        for kind_, (trace, rec) in runs.items():
            summary[kind_] = rec
            err = rec.get("max_rel_error_observable")
            radius = ""
            if noise_bound is not None:
                radius = (f"<td>{_state_values(names, rec.get('radius_median'))}</td><td>{_state_values(names, rec.get('radius_max'))}</td>"
                          f"<td>{rec.get('n_outside_radius', 'n/a (no true states in the log)')}</td>")
            rows.append(f"<tr><td>{kind_}</td><td>{rec['flag_counts']['observable']}</td><td>{rec['flag_counts']['unobservable']}</td>"
                        f"<td>{rec['flag_counts']['fallback']}</td><td>{num(1e6 * rec['median_step_s'])}</td>"
                        f"<td>{num(err)}</td>{radius}</tr>")
            fig = f"observer_{kind_}_{slug}.png"
            plot_estimates(trace, log, out / fig, title=f"{label}: {kind_} on {Path(data).name}")
            figs.append(fig)
            alts[fig] = (f"The {kind_} observer on {Path(data).name}: each estimated state "
                         + ("with its certified radius as a band " if "radius_max" in rec else "")
                         + ("against the logged one " if log.X is not None else "")
                         + f"with the {rec['flag_counts']['observable']} samples flagged observable marked, and its flag "
                         "(observable, unobservable, warming up, fallback) on a separate axis")
        head = ("<tr><th>observer</th><th>flagged observable [samples]</th><th>flagged unobservable [samples]</th>"
                "<th>fallback [samples]</th><th>median step [µs]</th><th>max relative error where flagged observable</th>"
                + ("<th>median radius [state units]</th><th>largest radius [state units]</th>"
                   "<th>true state outside the radius [samples]</th>"
                   if noise_bound is not None else "") + "</tr>")
        intro = ""
        if noise_bound is not None:
            from ..contract import noise_bound_vector
            from ..defaults import MHE_UNIQUENESS_DELTA

            beta = noise_bound_vector(noise_bound, system.output_names)
            intro = ("<p>Bounded output noise: "
                     + ", ".join(f"|noise of {html.escape(nm)}| &lt;= {b:.4g}" for nm, b in zip(system.output_names, beta))
                     + ". Each estimate carries a certified radius per state: every state consistent with the window's "
                     "data under this bound and the model lies within it (set-membership MILPs solved to a zero gap for "
                     "set_membership, miqp and milp; the bounded-noise lookup table's outer box for lookup). "
                     f"A step is flagged observable when every radius is within the tolerance ({MHE_UNIQUENESS_DELTA:g} "
                     "of the half-widths of the state bounds). The promise holds only when the data satisfy the bound.</p>")
        body = (intro + "<table>" + head + "".join(rows) + "</table>"
                + "".join(f"<img src='{f}' alt='{html.escape(alts[f], quote=True)}'>" for f in figs))
        return ReportSection(f"Observers on {Path(data).name}", body, summary, figs)

    def diagnosis(out: Path, progress) -> ReportSection:
        from ..lmi.auto_design import design_settings
        from ..lmi.diagnose import diagnose
        from ..lmi.plots import plot_jacobian_bounds

        st = design_settings(system)
        shared["settings"] = st
        diag = diagnose(system, st.coordinate, st.lo, st.hi, gain_bound=st.gain_bound, min_decay=st.min_decay,
                        overlap=st.overlap, sigma_cap=st.sigma_cap, scaling=st.scaling, condition=st.condition)
        fig = f"bounds_{slug}.png"
        plot_jacobian_bounds(diag, out / fig)
        alt = (f"Slopes of the nonlinear functions of {label} over {st.coordinate} in [{st.lo:.4g}, {st.hi:.4g}], "
               "with their lower and upper Jacobian bounds (eqs. 4-5 of paper 004)")
        verdict = (f"feasible ({diag.hierarchy.feasible_condition} condition): a constant gain exists" if diag.feasible
                   else f"infeasible up to the {diag.hierarchy.strongest_infeasible} condition (certified)"
                   if diag.hierarchy.strongest_infeasible else "not decided")
        rows = [("coordinate", st.coordinate), ("range", f"[{st.lo:.4g}, {st.hi:.4g}]"), ("verdict", verdict)]
        for c in diag.hierarchy.conditions:
            rows.append((c.name, "feasible" if c.feasible else ("infeasible, certificate verified" if c.verified
                                                                 else f"not decided ({c.skipped or c.status})")))
        rows += [("undetectable point", p.claim) for p in diag.undetectable]
        rows += [("indistinguishable states", q.claim) for q in diag.symmetries]
        if diag.certificate is not None:
            rows.append(("certificate", f"{diag.certificate.theorem}: verified in numpy: {yes_no(diag.certificate.verify())}"))
        rows += [(f"setting {k}", v) for k, v in st.sources.items()]
        return ReportSection("Constant-gain diagnosis (paper 004)",
                             f"<p>{html.escape(diag.verdict)}</p>" + _table(rows)
                             + f"<img src='{fig}' alt='{html.escape(alt, quote=True)}'>",
                             {"feasible": diag.feasible, "strongest_infeasible": diag.hierarchy.strongest_infeasible,
                              "settings": st.to_dict()}, [fig])

    def synthesis(out: Path, progress) -> ReportSection:
        from ..lmi.auto_design import design_settings, design_switched
        from .lmi_section import _design_table

        from ..lmi.switched import DwellTimeError
        from ..observers.switched_verification import verify_switched_design

        st = shared.get("settings") or design_settings(system)
        try:
            design = design_switched(system, st)
        except DwellTimeError as exc:  # the page shows the rejected design with the reason
            design = exc.design
        verification = verify_switched_design(design)
        design = dataclasses.replace(design, verification=verification)
        warn = "".join(f"<p class='error'>{html.escape(w)}</p>" for w in design.warnings + verification.notes)
        sim = verification.simulation
        warn += (f"<p>Checked on the system: frozen error dynamics max Re(lambda) = {verification.max_real_eig:.4g}; "
                 f"{html.escape(sim.scenario)}: converged from {sum(t is not None for t in sim.convergence_times)}/"
                 f"{len(sim.convergence_times)} initial errors.</p>")
        body = (_table([("regions", len(design.regions)), ("dwell time tau [s]", design.tau),
                        ("dwell enforced by the hysteresis", bool(design.dwell_enforced))])
                + _design_table(design, st.coordinate, "", 1.0) + warn)
        return ReportSection("Switched-gain synthesis (paper 004, Section 5)", body,
                             {"n_regions": len(design.regions), "tau": design.tau, "warnings": design.warnings,
                              "verification_ok": verification.ok,
                              "gain_norms": [float(np.round(g.gain_norm, 6)) for g in design.regions]})

    builders = {"model": model, "simulation": simulation, "regions": regions, "observers": observers,
                "diagnosis": diagnosis, "synthesis": synthesis}
    return assemble_report(out_dir, [(k, builders[k]) for k in keys], progress, title=f"hybobs_opt report: {label}")

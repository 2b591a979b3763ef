"""Report section "Switched-gain observers (paper 004)" and the ``hybobs diagnose`` report.

The section recomputes, for the vehicle tracker and the magnetic piston: the constant-gain LMI's
verdict over the full range with its verified certificate, the Jacobian-bound plots, Theorem 5's
check, the switched gains with their decay rates, the dwell time searched jointly versus the
fixed-``P`` value, the hysteresis, and the observers on the scenarios (switched versus the first
region's gain alone, the counterpart of Figs. 3-4).  :func:`write_diagnosis_report` is shared
with ``hybobs diagnose`` and ``hybobs observe --plot``; the Jacobian-bound figure is the core's
:func:`hybobs_opt.lmi.plots.plot_jacobian_bounds` (also used by
``notebooks/04_switched_gain_observers.ipynb``).

A second section, "vehicle_paper_design", runs the vehicle with the paper's printed gains (eqs.
61-62) next to the synthesised ones (:mod:`hybobs_opt.studies.paper004_nonmonotonic.paper_design`).
"""

from __future__ import annotations

import html
import time
from collections.abc import Callable
from pathlib import Path

from ..plotting import pyplot

plt = pyplot()
import numpy as np  # noqa: E402

from ..lmi.plots import plot_jacobian_bounds
from ..observers.plots import plot_observer_run
from .section import ReportSection, register_section  # noqa: E402
from .text import matrix_table, num, yes_no  # noqa: E402
from .._output_files import write_output_text


def _decay_and_noise_markdown(diag, tradeoff_fig: str | None) -> list[str]:
    """The decay-optimal design per condition and, under stated noise, the certified bound and its curve."""
    lines: list[str] = []
    if diag.design is not None:
        bound = "none" if diag.design.gain_bound is None else f"{diag.design.gain_bound:g}"
        lines += ["## Largest decay rate within the gain bound", "",
                  f"Gain bound ||L||_2 <= {bound}; decay rate of V = e'Pe proven on every vertex of the Jacobian box "
                  "(numpy).", "", "| condition | decay rate [1/s] | ||L||_2 | note |", "|---|---|---|---|"]
        for c in diag.design.by_condition:
            if c.feasible:
                lines.append(f"| {c.condition} | {c.sigma_verified:.4g} | {np.linalg.norm(c.L, 2):.4g} | |")
            else:
                lines.append(f"| {c.condition} | - | - | {c.reason[:160]} |")
        lines.append("")
    nd = diag.noise_design
    if nd is not None and nd.feasible:
        names = diag.system.state_names
        lines += ["## Error bound under bounded output noise", "",
                  f"Noise |v| <= {', '.join(num(v) for v in np.ravel(nd.noise))} (output units).  Gain with ||L||_2 = {nd.gain_norm:.4g}, "
                  f"decay rate {nd.alpha:.4g} 1/s of V without noise; certified ultimate bound (invariant ellipsoid, "
                  "re-checked in numpy, while the state and the estimate stay on the range):", "",
                  "| state | bound |", "|---|---|"] + [f"| {n} | {b:.4g} |" for n, b in zip(names, nd.bound)] + [""]
        if tradeoff_fig is not None:
            lines += [f"![The smallest certified error bound against the decay rate of V under the stated noise]({tradeoff_fig})",
                      ""]
    elif diag.noise_error:
        lines += ["## Error bound under bounded output noise", "", diag.noise_error, ""]
    return lines


def _diagnosis_markdown(diag, example: str, fig_name: str, tradeoff_fig: str | None = None) -> str:
    d = diag.to_dict()
    u = diag.unit
    lines = [f"# Observer LMI diagnosis: {example}", "",
             f"Range: {diag.region.name} in [{d['range'][0]:.4g}, {d['range'][1]:.4g}] {u}; "
             f"LMI {diag.solution.form} (paper 004); solver status `{diag.solution.status}`.", "",
             "## Verdict", "", diag.verdict, "",
             "## Hierarchy of sufficient conditions", "", "| condition | verdict | evidence |", "|---|---|---|"]
    for c in diag.hierarchy.conditions:
        if c.feasible:
            ev = ("implied by " + c.implied_by) if c.implied_by else (
                f"gain found; decay {c.sigma_verified:.4g} 1/s proven on the Jacobian-box vertices (numpy)"
                if c.sigma_verified is not None else "gain found")
            lines.append(f"| {c.name} | feasible | {ev} |")
        else:
            lines.append(f"| {c.name} | {'infeasible' if c.verified else 'not decided'} | "
                         + ("dual certificate re-checked in numpy" if c.verified else (c.skipped or str(c.status))) + " |")
    lines.append("")
    lines += _decay_and_noise_markdown(diag, tradeoff_fig)
    if diag.undetectable:
        lines += ["## Undetectable points (hold for every gain)", ""] + [f"- {p.claim}" for p in diag.undetectable] + [""]
    if diag.symmetries:
        lines += ["## Indistinguishable states", ""] + [f"- {q.claim}" for q in diag.symmetries] + [""]
    if diag.certificate is not None:
        c = diag.certificate
        lines += ["## Certificate of the paper's LMI", "", f"- Theorem: {c.theorem} (LMI {c.form}, sigma = {c.sigma:g})",
                  f"- Dual certificate re-checked in numpy: **{yes_no(c.verify())}**"
                  + (f" (source: {c.dual.source})" if c.dual is not None else ""),
                  f"- Structural certificate re-checked in numpy: {yes_no(c.structural_verified)}", "", c.reason, ""]
        if c.dual is not None:
            lines += ["Scalar inequality: " + c.dual.inequality, ""]
    if diag.feasible and "gain" in d:
        g = d["gain"]
        gain = np.atleast_2d(np.array(g["L"], dtype=float))
        outputs = list(getattr(diag.system, "output_names", ())) or [f"y{j + 1}" for j in range(gain.shape[1])]
        states = list(diag.system.state_names)
        lines += ["## Gain", "", f"sigma = {g['sigma']:.4g} 1/s"
                  + (f" (largest {g['sigma_max']:.4g} 1/s)" if g["sigma_max"] is not None else ""), "",
                  "| L | " + " | ".join(outputs) + " |", "|---|" + "---|" * gain.shape[1]]
        lines += [f"| {states[i] if i < len(states) else i} | " + " | ".join(num(v) for v in row) + " |"
                  for i, row in enumerate(gain)]
        lines.append("")
    lines += ["## Jacobian bounds (eqs. 4-5)", "", "| function | argument interval | lower | upper | monotonicity | method |",
              "|---|---|---|---|---|---|"]
    for b in (*diag.bounds.f, *diag.bounds.h):
        lines.append(f"| {b.kind}[{b.index}] {b.name} | [{b.interval[0]:.4g}, {b.interval[1]:.4g}] | {b.lower:.5g} | "
                     f"{b.upper:.5g} | {b.monotonicity} | {b.method} (margin {b.margin:.2g}) |")
    t5 = diag.theorem5
    lines += ["", f"![Jacobian bounds]({fig_name})", "", "## Theorem 5 (subtracting a linear term)", "",
              f"Original LMI feasible: {yes_no(t5.original_feasible)}; transformed LMI (45) feasible: "
              f"{yes_no(t5.shifted_feasible)}; "
              f"the Schur forms (43) and (44) agree to {t5.identity_residual:.2g} (relative).", "",
              "## What to do next", ""]
    lines += [f"- {s}" for s in diag.next_steps]
    lines += ["", f"_Computed in {diag.seconds:.2f} s._", ""]
    return "\n".join(lines)


def _markdown_to_html(md: str, title: str) -> str:
    """A small Markdown subset (headings, lists, bold, code, tables, images) to HTML."""
    out, in_list, in_code, table = [], False, False, []

    def inline(text: str) -> str:
        import re

        text = html.escape(text)
        text = re.sub(r"!\[([^\]]*)\]\(([^)]+)\)", r"<img src='\2' alt='\1'>", text)
        text = re.sub(r"\*\*([^*]+)\*\*", r"<b>\1</b>", text)
        text = re.sub(r"`([^`]+)`", r"<code>\1</code>", text)
        return re.sub(r"_([^_]+)_$", r"<i>\1</i>", text)

    def flush_table():
        if table:
            rows = [r for r in table if not set(r.replace("|", "").strip()) <= {"-"}]
            cells = [[c.strip() for c in r.strip().strip("|").split("|")] for r in rows]
            out.append("<table>" + "".join("<tr>" + "".join(f"<{'th' if i == 0 else 'td'}>{inline(c)}</{'th' if i == 0 else 'td'}>"
                                                            for c in row) + "</tr>" for i, row in enumerate(cells)) + "</table>")
            table.clear()

    for line in md.splitlines():
        if line.startswith("```"):
            out.append("</pre>" if in_code else "<pre>")
            in_code = not in_code
            continue
        if in_code:
            out.append(html.escape(line))
            continue
        if line.startswith("|"):
            table.append(line)
            continue
        flush_table()
        if line.startswith("- "):
            if not in_list:
                out.append("<ul>")
                in_list = True
            out.append(f"<li>{inline(line[2:])}</li>")
            continue
        if in_list:
            out.append("</ul>")
            in_list = False
        if line.startswith("#"):
            level = len(line) - len(line.lstrip("#"))
            out.append(f"<h{level}>{inline(line[level:].strip())}</h{level}>")
        elif line.strip():
            out.append(f"<p>{inline(line)}</p>")
    flush_table()
    if in_list:
        out.append("</ul>")
    return (f"<!doctype html><html lang='en'><head><meta charset='utf-8'><title>{html.escape(title)}</title>"
            "<style>body{font-family:system-ui,sans-serif;max-width:1000px;margin:2em auto;color:#222}"
            "table{border-collapse:collapse}td,th{border:1px solid #ccc;padding:.3em .6em;font-size:.9em}"
            "img{max-width:100%}code,pre{background:#f6f6f6}</style></head><body>" + "\n".join(out) + "</body></html>")


def write_diagnosis_report(diag, out_dir: str | Path, example: str) -> dict:
    """Write ``diagnose_<example>.md``, ``.html`` and the bounds PNG into ``out_dir``; return the paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    fig = f"bounds_{example}.png"
    plot_jacobian_bounds(diag, out / fig)
    figures = [str(out / fig)]
    tradeoff = _tradeoff_figure(diag, out, example)
    if tradeoff is not None:
        figures.append(str(out / tradeoff))
    md = _diagnosis_markdown(diag, example, fig, tradeoff)
    md_path, html_path = out / f"diagnose_{example}.md", out / f"diagnose_{example}.html"
    write_output_text(md_path, md)
    write_output_text(html_path, _markdown_to_html(md, f"diagnose {example}"))
    return {"markdown": str(md_path), "html": str(html_path), "figures": figures}


def _tradeoff_figure(diag, out: Path, example: str) -> str | None:
    """``noise_tradeoff_<example>.png``: the certified bound against the decay rate, over rates from a tenth of
    the noise design's to the largest proven one (``None`` without a noise design)."""
    nd = diag.noise_design
    if nd is None or not nd.feasible or diag.design is None or diag.design.best is None:
        return None
    from ..lmi.noise_gain import noise_tradeoff
    from ..lmi.plots import plot_noise_tradeoff

    top = max(diag.design.best.sigma_verified, nd.alpha)
    alphas = np.geomspace(max(nd.alpha / 10.0, top * 1e-3), top, 12)
    curve = noise_tradeoff(diag.system, diag.bounds, nd.noise, alphas, gain_bound=diag.gain_bound, scaling=None)
    name = f"noise_tradeoff_{example}.png"
    plot_noise_tradeoff(curve, out / name, design=nd, state_names=diag.system.state_names)
    return name


# ---------------------------------------------------------------------------- the section
def _design_table(design, coordinate: str, unit: str, factor: float) -> str:
    rows = "".join(
        f"<tr><td>{g.region.index}</td><td>{num(g.region.lo / factor)} to {num(g.region.hi / factor)}</td>"
        f"<td>{num(g.sigma)}</td><td>{num(g.sigma_max)}</td><td>{num(g.gain_norm)}</td>"
        f"<td>{matrix_table(g.L, digits=3)}</td></tr>"
        for g in design.regions)
    unit = html.escape(unit) if unit else "model units"
    return (f"<table><tr><th>region</th><th>{html.escape(coordinate)} interval [{unit}]</th>"
            "<th>design decay rate sigma [1/s]</th><th>largest decay rate [1/s]</th><th>||L||_2 [model units]</th>"
            "<th>gain L</th></tr>" + rows + "</table>")


def lmi_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Paper 004 on the vehicle tracker and the magnetic piston (see the module docstring)."""
    from ..studies import get_example
    from ..lmi.diagnose import diagnose
    from ..studies.paper004_nonmonotonic.presets import FUNCTION_UNITS, get_preset, preset_design, scaling_for
    from ..studies.paper004_nonmonotonic.scenarios import run_example

    parts, figs, summary = [], [], {}
    for name in ("vehicle_tracking", "magnetic_piston"):
        t0 = time.perf_counter()
        progress(f"lmi/{name}")
        preset = get_preset(name)
        system = get_example(name).build()
        lo, hi = preset.diagnose_range
        diag = diagnose(system, preset.coordinate, preset.to_model(lo), preset.to_model(hi), unit=preset.unit,
                        factor=preset.factor, gain_bound=preset.gain_bound, min_decay=preset.min_decay,
                        overlap=preset.to_model(preset.overlap), sigma_cap=preset.sigma_cap,
                        scaling=scaling_for(preset, system), suggest=False)
        fb = f"lmi_bounds_{name}.png"
        plot_jacobian_bounds(diag, out / fb, units=FUNCTION_UNITS.get(name))
        design = preset_design(name, system)
        trace, sw, s_sw = run_example(name, "switched", design=design)
        _, single, s_1 = run_example(name, "single", design=design)
        fr = f"lmi_observer_{name}.png"
        example = get_example(name)
        plot_observer_run(trace, [sw, single], out / fr, title=f"{name}: switched gains vs the first region's gain alone",
                          labels=["switched", "single gain"], units=example.state_units)
        nonlinear = [b.name for b in (*diag.bounds.f, *diag.bounds.h) if b.method != "linear"]
        alt_bounds = (f"Slopes of the nonlinear functions of {name} ({', '.join(nonlinear)}) over {preset.coordinate} "
                      f"in [{lo:g}, {hi:g}] {preset.unit}, with their lower and upper Jacobian bounds")
        alt_run = (f"{name}: true states {', '.join(example.state_label(s) for s in example.state_names[:4])} against "
                   f"the switched-gain and the single-gain estimates over {trace.t[-1]:g} s, their errors, the region "
                   f"index and the error norm on a log scale")
        figs += [fb, fr]
        c = diag.certificate
        d = design.to_dict(preset.unit, preset.factor)
        summary[name] = {
            "constant_gain_feasible": diag.feasible, "certificate_verified": None if c is None else c.verify(),
            "strongest_infeasible": diag.hierarchy.strongest_infeasible,
            "theorem": None if c is None else c.theorem, "theorem5_equivalent": diag.theorem5.equivalent,
            "regions": len(design.regions), "tau": design.tau, "tau_fixed_P": design.tau_fixed,
            "epsilon_required": d["epsilon_required"], "dwell_enforced": d["dwell_enforced"],
            "switched_converged": s_sw["converged"], "switched_convergence_time": s_sw["convergence_time"],
            "single_converged": s_1["converged"],
            "switched_rms_second_half": s_sw["rms_error_second_half"], "single_rms_second_half": s_1["rms_error_second_half"],
            "median_step_s": s_sw["timing"]["median_step_s"], "seconds": time.perf_counter() - t0,
        }
        noise_html = ""
        if name == "vehicle_tracking":
            noise_html, summary[name]["noise"], noise_figs = _vehicle_noise_part(system, design, preset, out)
            figs += noise_figs
        u = preset.unit
        parts.append(
            f"<h3>{html.escape(name)}</h3>"
            f"<p>Constant gain over {preset.coordinate} in [{lo:g}, {hi:g}] {u}: {html.escape(diag.verdict)}</p>"
            f"<p>The paper's LMI {diag.solution.form} alone is "
            f"<b>{'feasible' if diag.paper_lmi_feasible else 'infeasible'}</b>"
            + ("" if c is None else f"; certificate ({html.escape(c.theorem)}) verified in numpy: <b>{yes_no(c.verify())}</b>")
            + f". Theorem 5: the linearly shifted LMI is {'feasible' if diag.theorem5.shifted_feasible else 'infeasible'} too.</p>"
            + ("" if c is None else f"<p>{html.escape(c.reason)}</p>")
            + f"<img src='{fb}' alt='{html.escape(alt_bounds, quote=True)}'>"
            f"<p>Switched gains on {len(design.regions)} regions (gain bound {preset.gain_bound:g}, design rate = "
            f"{preset.decay_fraction:g} x largest rate):</p>" + _design_table(design, preset.coordinate, u, preset.factor)
            + f"<p>Dwell time of eqs. (47)-(48) searched jointly over the P_i: tau = {num(design.tau)} s "
            f"(with the per-region P_i fixed: {num(design.tau_fixed)} s). At a maximum rate of {num(d['max_rate'])} {u}/s "
            f"the hysteresis must be at least {num(d['epsilon_required'])} {u}; the regions use {num(d['epsilon'])} {u} "
            f"(dwell time {'enforced' if d['dwell_enforced'] else 'not enforced'}).</p>"
            f"<p>Scenario: the switched observer "
            + (f"converged (at t = {num(s_sw['convergence_time'])} s)" if s_sw["converged"] else "did not converge")
            + f", regions visited {html.escape(_visited(s_sw['regions_visited']))}; the first region's gain alone "
            + ("converged" if s_1["converged"] else "did not converge")
            + f". Median compute time per step {num(1e3 * s_sw['timing']['median_step_s'])} ms.</p>"
            f"<img src='{fr}' alt='{html.escape(alt_run, quote=True)}'>" + noise_html)
    intro = ("<p>Paper 004 (Rajamani et al.): no constant-gain observer LMI is feasible when the nonlinear functions "
             "are non-monotonic over the operating range; the certificates below prove it for each system and for each "
             "condition of the hierarchy (the paper's LMI, one multiplier per function, the polytopic condition on the "
             "Jacobian-box vertices): dual multipliers re-checked in numpy, and the structural direction of Theorems 3-4. "
             "What they rule out is a constant gain with a quadratic Lyapunov function, not every constant gain.  Switched gains on "
             "regions of the scheduling variable, with a dwell time and hysteresis, restore convergence.  The comparison "
             "with the lookup-table observer on a PWA-fitted piston is not part of this section.</p>")
    return ReportSection("Switched-gain observers (paper 004)", intro + "".join(parts), summary, figs)


def _visited(regions) -> str:
    """The regions a run visited, as words (``0, 1 and 2``)."""
    items = [str(r) for r in (regions if isinstance(regions, (list, tuple, np.ndarray)) else [regions])]
    return items[0] if len(items) == 1 else ", ".join(items[:-1]) + " and " + items[-1]


register_section("lmi", lmi_section)


#: The vehicle's radar noise of the report's noise part (m on X and Y).
VEHICLE_RADAR_NOISE = 0.2


def _vehicle_noise_part(system, design, preset, out: Path) -> tuple[str, dict, list[str]]:
    """The decay rate / noise trade-off on the vehicle's first region.

    For each decay rate ``alpha`` of ``V``, the gain (``||L||_2 <=`` the preset's bound) with the
    smallest certified ultimate bound under radar noise :data:`VEHICLE_RADAR_NOISE`
    (:func:`~hybobs_opt.lmi.noise_gain.noise_tradeoff`).  The switched observer's own bound under
    that noise is ``hybobs synth vehicle_tracking --noise-bound 0.2`` (about 30 s, so not in the report).
    """
    from ..lmi.noise_gain import noise_tradeoff
    from ..lmi.plots import plot_noise_tradeoff
    from ..studies.paper004_nonmonotonic.presets import scaling_for

    scaling = scaling_for(preset, system)
    noise = [VEHICLE_RADAR_NOISE] * system.p
    first = design.regions[0]
    alphas = np.geomspace(0.02, 1.0, 10) * first.sigma_max
    curve = noise_tradeoff(system, first.bounds, noise, alphas, gain_bound=preset.gain_bound, scaling=scaling,
                           reference=scaling)
    name = "lmi_noise_tradeoff_vehicle_tracking.png"
    plot_noise_tradeoff(curve, out / name, state_names=system.state_names)
    lo, hi = first.region.lo / preset.factor, first.region.hi / preset.factor
    alt = (f"Certified ultimate bound on each error component of the vehicle against the decay rate of V, on psi in "
           f"[{lo:g}, {hi:g}] {preset.unit} with radar noise {VEHICLE_RADAR_NOISE:g} m and ||L||_2 <= "
           f"{preset.gain_bound:g}: faster decay costs a larger bound")
    ok = np.asarray(curve.feasible, dtype=bool)
    text = (f"<h4>Decay rate against noise</h4><p>On the first region ({preset.coordinate} in [{lo:g}, {hi:g}] "
            f"{preset.unit}) under radar noise |v| <= {VEHICLE_RADAR_NOISE:g} m: the smallest certified ultimate "
            f"error bound (invariant ellipsoid on the Jacobian-box vertices, re-checked in numpy) for each decay rate "
            f"of V, {int(ok.sum())} of {ok.size} rates certified.</p><img src='{name}' alt='{html.escape(alt, quote=True)}'>"
            f"<p>The switched observer's own bound under this noise, with the dwell time it needs: "
            f"<code>hybobs synth {preset.example} --noise-bound {VEHICLE_RADAR_NOISE:g}</code>.</p>")
    summary = {"noise": noise, "tradeoff_alpha": [None if not np.isfinite(a) else float(a) for a in curve.alpha_certified],
               "tradeoff_worst_relative": [None if not np.isfinite(v) else float(v) for v in curve.worst_relative]}
    return text, summary, [name]


# ---------------------------------------------------------------------------- vehicle: the paper's gains as published
def _bracket_unit(header: str) -> str:
    """``"conv. time (s)"`` -> ``"conv. time [s]"``: the report's headers give units in brackets."""
    import re

    return re.sub(r"\s\(([^()]*)\)$", r" [\1]", header)


def vehicle_paper_design_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Paper 004's vehicle gains (eqs. 61-62, switched at 60 deg) against the synthesised design.

    Built by :func:`hybobs_opt.studies.paper004_nonmonotonic.paper_design.run_paper_comparison`:
    four observers on the scenario of Sec. 6.2, yaw wrapped modulo 2 pi.
    """
    from ..studies.paper004_nonmonotonic.paper_design import PAPER_L1, PAPER_L2, run_paper_comparison

    t0 = time.perf_counter()
    progress("vehicle_paper_design")
    res = run_paper_comparison()
    rows = res.rows()
    table = ("<table><tr>" + "".join(f"<th>{html.escape(_bracket_unit(c))}</th>" for c in rows[0]) + "</tr>"
             + "".join("<tr>" + "".join(f"<td>{html.escape(c)}</td>" for c in r) + "</tr>" for r in rows[1:])
             + "</table>")
    tol = res.tolerance
    # the gains as printed in the paper (four decimals), not rounded further
    gains = "".join(f"<p>{name}, as printed:</p>{matrix_table(L, digits=6)}"
                    for name, L in (("L_1 (eq. 61, 0-80 deg)", PAPER_L1), ("L_2 (eq. 62, 60-140 deg)", PAPER_L2)))
    body = (
        "<p>The vehicle tracker of paper 004 (Sec. 6) with the gains printed in the paper, switched 'at 60 degrees "
        "of the estimated yaw angle' (Sec. 6.2), against the toolbox's own LMI synthesis on the preset regions; each "
        "also with its first gain alone (Fig. 4's single-gain observer). All four start at (0, 0) m with 0 deg yaw "
        "(Sec. 6.2), wrap the yaw estimate modulo 360 deg and run on the same simulated manoeuvre (straight, left "
        "turn to 120 deg, straight). The paper gives no Lyapunov matrix for its gains; they are used as printed, "
        "in m and rad.</p>" + gains
        + f"<p>Convergence time: the first time from which |e_X|, |e_Y| &lt;= {tol['X']:g} m and |e_psi| &lt;= "
        f"{np.degrees(tol['psi']):g} deg at every later sample ('-': never). A single-gain run that leaves this band "
        "again after settling has a divergence time instead (the first sample outside it after 2 s inside). "
        "Errors of psi are measured along the circle.</p>" + table
        + "<p>Differences from the paper and their causes:</p><ul>"
        + "".join(f"<li>{html.escape(d)}</li>" for d in res.differences) + "</ul>")
    summary = res.to_dict()
    summary["seconds"] = time.perf_counter() - t0
    return ReportSection("Vehicle tracker: the paper's gains as published vs the synthesised design (paper 004)",
                         body, summary, [])


register_section("vehicle_paper_design", vehicle_paper_design_section)


# ---------------------------------------------------------------------------- piston: PWA fit, lookup vs switched
def _fmt_states(d: dict | None, digits: int = 3) -> str:
    if d is None:
        return "n/a"
    return ", ".join(f"{k} {v:.{digits}g}" for k, v in d.items())


def piston_comparison_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """The switched-gain observer against the lookup-table deadbeat observer on the PWA-fitted piston.

    Built by :func:`hybobs_opt.studies.paper004_nonmonotonic.piston_comparison.compare_piston`.
    """
    from ..studies.paper004_nonmonotonic.piston_comparison import compare_piston, comparison_summary, plot_piston_comparison

    t0 = time.perf_counter()
    progress("piston_comparison")
    res = compare_piston()
    fig = "piston_comparison.png"
    plot_piston_comparison(res, out / fig)
    s = comparison_summary(res)
    fit, lk, sg, band = s["plant"]["fit"], s["lookup"], s["switched_gain"], s["band"]
    band_txt = ", ".join(f"|e_{k}| <= {v:g}" for k, v in band.items())
    alt = (f"Top: the two sensor curves h_1, h_2 [mT] against z [mm] with their {fit['n_pieces']}-piece linear fit; "
           f"below: absolute errors of z [mm], v [mm/s] and a [mm/s^2] of the lookup-table and switched-gain observers "
           f"on a log scale over {s['scenario']['t_final']:g} s, with the convergence band")

    def conv(rec: dict) -> str:
        return "never" if rec["convergence_time"] is None else num(rec["convergence_time"])

    rows = []
    for label, rec, model in (("lookup-table deadbeat (paper 002)", lk, f"the PWA plant (T = {lk['T']}, "
                                f"{lk['n_regions']} regions)"),
                              ("switched-gain (paper 004)", sg, f"the smooth piston ({sg['n_regions']} regions, "
                               f"tau = {sg['tau']:.3g} s)")):
        rows.append(
            f"<tr><td>{label}</td><td>{html.escape(model)}</td><td>{num(rec['offline_s'])}</td><td>{conv(rec)}</td>"
            f"<td>{html.escape(_fmt_states(rec['rms_error_after_convergence']))}</td>"
            f"<td>{html.escape(_fmt_states(rec['max_abs_error_after_convergence']))}</td>"
            f"<td>{html.escape(_fmt_states(rec['max_abs_error']))}</td>"
            f"<td>{num(1e3 * rec['median_step_s'])}</td><td>{num(1e3 * rec['p95_step_s'])}</td>"
            f"<td>{html.escape(', '.join(f'{k} {v}' for k, v in rec['flags'].items() if v))}</td></tr>")
    table = ("<table><tr><th>observer</th><th>designed on</th><th>offline [s]</th><th>convergence time [s]</th>"
             "<th>RMS error after convergence [mm, mm/s, mm/s^2]</th>"
             "<th>max |error| after convergence [mm, mm/s, mm/s^2]</th>"
             "<th>max |error| whole run [mm, mm/s, mm/s^2]</th><th>median step [ms]</th><th>p95 step [ms]</th>"
             "<th>flags [samples]</th></tr>"
             + "".join(rows) + "</table>")
    tried = "; ".join(f"T = {h['T']}: {h['n_regions']} regions, {h['n_full_rank']} with rank C_i = n" for h in lk["horizons_tried"])
    body = (
        "<p>The magnetic piston of paper 004 (eq. 63) with its two sensor curves replaced by a continuous "
        f"piecewise-linear interpolant in z: {fit['n_pieces']} pieces, {html.escape(fit['method'])}. The fit is within "
        f"{max(fit['max_error_mT']):.3g} mT of the smooth curves (RMS {max(fit['rms_error_mT']):.3g} mT; readings within "
        "about +-4.7 mT). The integrator chain is discretised exactly (ZOH, "
        f"Ts = {1e3 * s['plant']['Ts']:g} ms), one mode per z-interval: {html.escape(s['plant']['name'])}, "
        f"|jerk| <= {s['plant']['input_bound']:g} mm/s^3.</p>"
        "<p><b>The switched-gain observer's LMI design uses the smooth piston model; the data it runs on come from the "
        "PWA fit.</b> The fit error is a model mismatch it sees as an output disturbance, so its error after convergence "
        "measures that mismatch. The lookup observer is designed on the PWA plant itself (smallest horizon with "
        f"T p >= n and a non-empty I: {html.escape(tried)}); every region has full rank, so B~_T is empty and a step "
        "is flagged observable when exactly one candidate state fits the window.</p>"
        f"<p>One extend-retract stroke ({s['scenario']['t_final']:g} s, {s['scenario']['samples']} samples, the jerk of "
        "the smooth scenario held over each sample); both observers start at rest, "
        f"{s['scenario']['x_hat0'][0] - s['scenario']['x0'][0]:g} mm off in position. Convergence time: the first time "
        f"from which {band_txt} holds at every later sample. Per-step times are medians of single steps "
        "(<code>timed_steps</code>); the offline column is the mode enumeration and Algorithm 3.1 for the lookup and "
        "the region growth, LMI synthesis and dwell-time search for the switched gains.</p>"
        + table
        + f"<p>Lookup: largest error at the {lk['flags']['observable']} steps flagged observable "
        f"{lk['max_scaled_error_observable']:.2g} of the state box's half-widths (exact up to rounding). "
        f"Switched-gain: initial region {num(sg['initial_selection'].get('region'))} selected from the first samples "
        f"(identified z = {num(sg['initial_selection'].get('s'))} mm). "
        f"The switched-gain observer costs {sg['median_step_s'] / lk['median_step_s']:.0f} times the lookup's median "
        "step (RK4 through a CasADi function versus one table product in a compiled kernel).</p>"
        f"<img src='{fig}' alt='{html.escape(alt, quote=True)}'>"
        "<p>Errors are drawn on a log scale, floored at 1e-14.</p>")
    s["seconds"] = time.perf_counter() - t0
    return ReportSection("Piston with PWA sensor fit: lookup-table vs switched-gain observer (papers 002, 004)",
                         body, s, [fig])


register_section("piston_comparison", piston_comparison_section)

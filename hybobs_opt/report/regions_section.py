"""Report section "Observability regions (paper 002)": Algorithm 3.1 on models (16) and (17).

Reproduces Section 6 of paper 002 with the ``regions`` package: the sizes of ``B_T`` and
``B~_T`` for model (16) at T = 3, 5, 7 and model (17) at T = 5, the cuts of Figs. 3(b), 4, 5
(model 16, ``omega_l = 25`` rad/s; theta drawn unscaled in rad, where the paper stretches it x10) and Fig. 6 (model 17, T = 5), the
share of the backlash band ``|theta| < alpha`` that is unobservable, and the paper's timings
next to ours.  Every number is recomputed here; the paper's published figures are labelled.

The cut planes and their helpers (``feasible_interval``, ``band_mask``,
``reduced_pair_dimensions``, ``fig6_planes``) are the study
:mod:`hybobs_opt.studies.paper002_powertrain.figures` (shared with ``benchmarks/bench_regions.py``
and ``notebooks/02_observability_regions.ipynb``).
"""

from __future__ import annotations

import html
import os
import statistics
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np

from ..studies.paper002_powertrain.figures import (
    OMEGA_L_CUT,
    THETA_STRETCH,
    band_mask,
    feasible_interval,
    fig6_planes,
    reduced_pair_dimensions,
)
from ..studies.paper002_powertrain.systems import TABLE1, TABLE2, powertrain3, powertrain5
from ..regions import PointClass, analyse_observability, compute_cut
from .plots import CUT_COLOURS, plot_region_cut
from .section import ReportSection, register_section, samples

#: Published figures of paper 002 (Sections 6-7), quoted for comparison only.
PAPER_002 = {
    "machine": "Pentium 4, 2.4 GHz, Matlab 6.5.1",
    "model16_T3_enumeration_seconds": 1.4,
    "model16_T3_algorithm_3_1_seconds": 0.3,
    "model16_T3_total_seconds": 1.7,
    "model16_T3_reduced_pieces": 8,
    "model17_T7_B_seconds": 33.0,
    "model17_O7": "not obtained after 4 h of MPT set differences",
}

#: Units of the states of models (16) and (17) on the cut axes (paper 002, Section 5.1).
UNITS = {"theta": "rad", "theta_mc": "rad", "theta_cl": "rad", "omega_m": "rad/s", "omega_c": "rad/s", "omega_l": "rad/s"}

#: Grid of the report's cuts (modest, to keep the section under ~90 s).
REPORT_GRID = (31, 21)


# ---------------------------------------------------------------------------- the section
def _model16_job(spec: dict) -> dict:
    """Analysis + cut of model (16) for one (T, gear ratio); run in a worker process."""
    T, tau, grid = spec["T"], spec["gear_ratio"], tuple(spec["grid"])
    system = powertrain3(gear_ratio=tau)
    t0 = time.perf_counter()
    analysis = analyse_observability(system, T)
    seconds = time.perf_counter() - t0
    out = {"spec": spec, "summary": analysis.summary(), "wall_seconds": seconds}
    limits = None
    if spec.get("fit_omega_m"):
        rng = feasible_interval(analysis, "omega_m", {"omega_l": OMEGA_L_CUT})
        limits = {"omega_m": rng}
        out["omega_m_range"] = rng
    cut = compute_cut(analysis, {"omega_l": OMEGA_L_CUT}, resolution=grid, limits=limits)
    band = band_mask(cut, TABLE1["alpha"])
    out.update(cut=cut, band_points=int(np.count_nonzero(band & (cut.labels != PointClass.INFEASIBLE))),
               band_unobservable=cut.fraction_of_feasible(PointClass.UNOBSERVABLE, band),
               band_observable=cut.fraction_of_feasible(PointClass.OBSERVABLE, band),
               observable_of_feasible=cut.fraction_of_feasible(PointClass.OBSERVABLE))
    if spec.get("dimensions"):
        out["reduced_pair_dimensions"] = reduced_pair_dimensions(analysis)
    return out


def _model17_job(spec: dict) -> dict:
    T, grid = spec["T"], tuple(spec["grid"])
    system = powertrain5()
    t0 = time.perf_counter()
    analysis = analyse_observability(system, T)
    out = {"spec": spec, "summary": analysis.summary(), "wall_seconds": time.perf_counter() - t0}
    planes = fig6_planes(analysis)
    out["planes"] = planes
    cut = compute_cut(analysis, planes["paper"], resolution=grid)
    out.update(paper_cut=cut)
    if planes["consistent"] is not None:
        cut2 = compute_cut(analysis, planes["consistent"], resolution=grid,
                                 limits={"omega_c": planes["consistent_omega_c_range"]})
        out.update(consistent_cut=cut2,
                   consistent_observable_of_feasible=cut2.fraction_of_feasible(PointClass.OBSERVABLE))
    return out


def _run_job(spec: dict) -> dict:
    return _model16_job(spec) if spec["model"] == 16 else _model17_job(spec)


def _gear_ratio_statement(band_tau: dict[float, float]) -> str:
    """What the band shares at T = 7 say about the gear ratio, read from the numbers (Fig. 5 of paper 002)."""
    taus = sorted(band_tau)
    shares = [band_tau[t] for t in taus]
    if all(a < b for a, b in zip(shares, shares[1:])):
        return ("The observable share grows with the gear ratio, as Figs. 4(b) and 5 of the paper show: a larger ratio "
                "makes the shaft leave the backlash band faster.")
    return ("The observable share does <b>not</b> grow monotonically with the gear ratio on this grid ("
            + ", ".join(f"{t:.4g}: {_fmt(100 * v)} %" for t, v in zip(taus, shares))
            + "), unlike Figs. 4(b) and 5 of the paper.")


def _fmt(v, digits=3) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.{digits}g}"
    return str(v)


def _describe_cut(cut, caption: str) -> str:
    """An alt text saying what a cut shows: its plane, its axes and its classified shares."""
    share = {k: float(np.mean(cut.labels == k)) for k in CUT_COLOURS}
    fixed = ", ".join(f"{k} = {v:g} {UNITS.get(k, '')}".rstrip() for k, v in cut.fixed.items())
    return (f"{caption}: grid of {cut.axes[0]} ({_fmt(float(cut.x_values[0]))} to {_fmt(float(cut.x_values[-1]))} "
            f"{UNITS.get(cut.axes[0], '')}) against {cut.axes[1]} ({_fmt(float(cut.y_values[0]))} to "
            f"{_fmt(float(cut.y_values[-1]))} {UNITS.get(cut.axes[1], '')}) at {fixed}, coloured "
            + ", ".join(f"{CUT_COLOURS[k][0]} where {w} ({_fmt(100 * share[k])} % of the points)" for k, w in
                        ((PointClass.OBSERVABLE, "observable"), (PointClass.UNOBSERVABLE, "unobservable"),
                         (PointClass.INFEASIBLE, "outside X*_T"))))


def regions_section(out: Path, progress: Callable[[str], None]) -> ReportSection:
    """Observability regions of the powertrain models (paper 002, Section 6)."""
    from ..executor import ProcessExecutor, SerialExecutor

    t_start = time.perf_counter()
    tau16 = TABLE1["gear_ratio"]
    grid = [samples(REPORT_GRID[0], 13), samples(REPORT_GRID[1], 9)]
    specs = [
        {"model": 16, "T": 7, "gear_ratio": tau16, "grid": grid, "fig": "4b"},
        {"model": 16, "T": 7, "gear_ratio": 0.5, "grid": grid, "fig": "5a", "fit_omega_m": True},
        {"model": 16, "T": 7, "gear_ratio": 1.0, "grid": grid, "fig": "5b", "fit_omega_m": True},
        {"model": 16, "T": 5, "gear_ratio": tau16, "grid": grid, "fig": "4a"},
        {"model": 17, "T": 5, "gear_ratio": TABLE2["gear_ratio"], "grid": grid, "fig": "6a"},
        {"model": 16, "T": 3, "gear_ratio": tau16, "grid": grid, "fig": "3b", "dimensions": True},
    ]
    progress("regions: Algorithm 3.1 and cuts")
    executor = ProcessExecutor(2) if (os.cpu_count() or 1) >= 2 else SerialExecutor()
    try:
        results = executor.map(_run_job, specs)
    finally:
        executor.close()
    by_fig = {r["spec"]["fig"]: r for r in results}

    # timings of model (16), T = 3 against the paper's (median of repeated runs in this process)
    progress("regions: timing model (16), T = 3")
    runs = [analyse_observability(powertrain3(), 3).summary() for _ in range(samples(7, 3))]
    t_enum = statistics.median(r["seconds_enumeration"] for r in runs)
    t_alg = statistics.median(r["seconds_algorithm_3_1"] for r in runs)

    figs: list[str] = []
    captions = {
        "3b": "Fig. 3(b): model (16), T = 3, tau = 1/12",
        "4a": "Fig. 4(a): model (16), T = 5, tau = 1/12",
        "4b": "Fig. 4(b): model (16), T = 7, tau = 1/12",
        "5a": "Fig. 5(a): model (16), T = 7, tau = 1/2",
        "5b": "Fig. 5(b): model (16), T = 7, tau = 1",
    }
    images = []
    for key in ("3b", "4a", "4b", "5a", "5b"):
        r = by_fig[key]
        name = f"regions_fig{key}.png"
        plot_region_cut(r["cut"], out / name, title=f"{captions[key]}, omega_l = {OMEGA_L_CUT:g} rad/s", units=UNITS)
        figs.append(name)
        alt = html.escape(_describe_cut(r["cut"], captions[key]), quote=True)
        images.append(f"<figure><img src='{name}' alt='{alt}'><figcaption>{html.escape(captions[key])}: "
                      f"{r['band_points']} grid points of X*_T in the band |theta| &lt; alpha, "
                      f"{_fmt(100 * r['band_unobservable'])} % unobservable.</figcaption></figure>")
    r17 = by_fig["6a"]
    planes = r17["planes"]
    wl = planes["omega_l_range"]
    paper_cut = r17["paper_cut"]
    # The paper's plane may miss X*_5 altogether (it does with Table 2): its cut is then one white
    # rectangle, an empty panel, so it is drawn only when some grid point lies in X*_5.
    fig6_html = ""
    if np.any(paper_cut.labels != PointClass.INFEASIBLE):
        name = "regions_fig6a_paper_plane.png"
        caption = "Fig. 6(a) plane: model (17), T = 5, theta_mc = 0 rad, omega_m = 90 rad/s, omega_l = 30 rad/s"
        plot_region_cut(paper_cut, out / name, title=caption, units=UNITS)
        figs.append(name)
        fig6_html += f"<figure><img src='{name}' alt='{html.escape(_describe_cut(paper_cut, caption), quote=True)}'></figure>"
    fig6_html += (
        "<p>Model (17), T = 5, at the paper's plane "
        + html.escape(", ".join(f"{k} = {_fmt(float(v))} {UNITS.get(k, '')}".rstrip() for k, v in planes["paper"].items()))
        + ": "
        + ("the plane does not meet X*_5 (LP over every region: no feasible omega_c; all "
           f"{paper_cut.labels.size} points of its cut lie outside X*_5, so it is not drawn)"
           if planes["paper_omega_c_range"] is None
           else f"omega_c over X*_5 in [{_fmt(planes['paper_omega_c_range'][0])}, {_fmt(planes['paper_omega_c_range'][1])}]")
        + ".</p>"
    )
    if planes["consistent"] is not None:
        name = "regions_fig6a_consistent_plane.png"
        cp = planes["consistent"]
        caption = f"Model (17), T = 5, theta_mc = 0 rad, omega_m = 90 rad/s, omega_l = {cp['omega_l']:.4g} rad/s"
        plot_region_cut(r17["consistent_cut"], out / name, title=caption, units=UNITS)
        figs.append(name)
        fig6_html += (
            f"<p>With theta_mc = 0 and omega_m = 90 rad/s, omega_l ranges over [{_fmt(wl[0])}, {_fmt(wl[1])}] rad/s "
            f"on X*_5 (gear ratio tau = 1/6.9576 ties the wheel to tau times the clutch speed, and the clutch to the "
            f"engine)"
            + (", so omega_l = 30 lies outside" if planes["paper_omega_c_range"] is None else "")
            + f". The cut below is at the midpoint omega_l = {cp['omega_l']:.4g} "
            f"rad/s, with omega_c over its feasible range [{_fmt(planes['consistent_omega_c_range'][0])}, "
            f"{_fmt(planes['consistent_omega_c_range'][1])}]: {_fmt(100 * r17['consistent_observable_of_feasible'])} % "
            f"of its X*_5 points are observable.</p>"
            f"<figure><img src='{name}' alt='{html.escape(_describe_cut(r17['consistent_cut'], caption), quote=True)}'></figure>"
        )

    # summary table
    rows_spec = [("16", "3b"), ("16", "4a"), ("16", "4b"), ("16", "5a"), ("16", "5b"), ("17", "6a")]
    table_rows = []
    table_summary = []
    for model, key in rows_spec:
        r = by_fig[key]
        s = r["summary"]
        row = {"model": int(model), "T": s["horizon"], "gear_ratio": r["spec"]["gear_ratio"], "n_regions": s["n_regions"],
               "I": s["n_full_rank"], "pieces_B": s["n_unobservable_pieces"], "pieces_B_reduced": s["n_reduced_pieces"],
               "lps": s["n_lps"], "seconds": s["seconds"]}
        table_summary.append(row)
        table_rows.append("<tr>" + "".join(f"<td>{_fmt(v)}</td>" for v in (
            f"({model})", row["T"], f"{row['gear_ratio']:.4g}", row["n_regions"], row["I"], row["pieces_B"],
            row["pieces_B_reduced"], row["lps"], _fmt(row["seconds"], 4))) + "</tr>")
    table = ("<table><tr><th>model</th><th>T [samples]</th><th>gear ratio</th><th>regions</th>"
             "<th>|I| (full-rank regions)</th><th>pieces of B_T</th><th>pieces of B~_T</th><th>LPs</th><th>time [s]</th></tr>"
             + "".join(table_rows) + "</table>"
             + "<p>time: enumeration + Algorithm 3.1 (serial) inside this section's two worker processes, "
               "which run two analyses at a time; see the timings below for medians.</p>")

    band_T = {by_fig[k]["spec"]["T"]: by_fig[k]["band_unobservable"] for k in ("3b", "4a", "4b")}
    band_tau = {by_fig[k]["spec"]["gear_ratio"]: by_fig[k]["band_observable"] for k in ("4b", "5a", "5b")}
    band_html = (
        "<p>Share of the grid points of X*_T in the backlash band |theta| &lt; alpha = "
        f"{TABLE1['alpha']:g} rad (plane omega_l = {OMEGA_L_CUT:g}) that are <b>unobservable</b>, tau = 1/12: "
        + ", ".join(f"T = {T}: {_fmt(100 * v)} %" for T, v in band_T.items())
        + ". Share that is <b>observable</b> at T = 7: "
        + ", ".join(f"tau = {tau:.4g}: {_fmt(100 * v)} %" for tau, v in band_tau.items())
        + " (for tau = 1/2 and 1 the omega_m axis spans the range of omega_m over X*_7 at omega_l = 25, by LP: "
        + ", ".join(f"tau = {by_fig[k]['spec']['gear_ratio']:g}: [{_fmt(by_fig[k]['omega_m_range'][0])}, "
                    f"{_fmt(by_fig[k]['omega_m_range'][1])}]" for k in ("5a", "5b"))
        + " rad/s). "
        + _gear_ratio_statement(band_tau)
        + "</p>"
    )
    dims = by_fig["3b"]["reduced_pair_dimensions"]
    s3 = by_fig["3b"]["summary"]
    dims_txt = ", ".join(f"{c} of dimension {d}" for d, c in dims.items()) or "none"
    note = (
        f"<p>The paper reports {PAPER_002['model16_T3_reduced_pieces']} polytopes in B~_3 (paper's figure). Here "
        f"B~_3 has {s3['n_reduced_pieces']} full-dimensional pieces: the non-empty R_ij with i in I and j not in I "
        f"have projections onto x of {dims_txt} (n = 3), i.e. sets of measure zero, which Algorithm 3.1 "
        f"discards by design (it computes B_T up to a set of zero measure).</p>"
    )
    timing_rows = [
        ("model (16), T = 3: mode enumeration", PAPER_002["model16_T3_enumeration_seconds"], t_enum),
        ("model (16), T = 3: Algorithm 3.1", PAPER_002["model16_T3_algorithm_3_1_seconds"], t_alg),
    ]
    # Only timings measured in this run are tabulated: the paper's 33 s for all of B_7 of model (17)
    # is measured by benchmarks/bench_regions.py (about 15 s serial), too long for the report, and a
    # figure read from a results file of the repository would not be "recomputed" (nor exist in a wheel).
    timing = ("<table><tr><th>task</th><th>paper, published (Pentium 4, Matlab) [s]</th><th>here, median [s]</th>"
              "<th>ratio here/paper</th></tr>"
              + "".join(f"<tr><td>{html.escape(t)}</td><td>{p:g}</td><td>{_fmt(o, 4)}</td><td>{_fmt(o / p, 2)}</td></tr>"
                        for t, p, o in timing_rows)
              + "</table>"
              + f"<p>The paper did not obtain O_7 of model (17) after 4 h of set differences (paper's figure); here O_T is "
                f"never formed: each cut point is an exact point query (LPs), so a {grid[0]}x{grid[1]} cut costs seconds. "
                f"The paper's {PAPER_002['model17_T7_B_seconds']:g} s for all of B_7 of model (17) is not re-timed here "
                f"(it is a benchmark: <code>python -m benchmarks.bench_regions</code>); every time in the table was "
                f"measured in this run.</p>")
    seconds = time.perf_counter() - t_start
    body = (
        "<p>Algorithm 3.1 of paper 002 on the powertrain models with backlash. Cuts: every grid point is classified "
        "exactly (" + ", ".join(f"{w}: {CUT_COLOURS[k][0]}" for k, w in ((PointClass.OBSERVABLE, "observable"),
        (PointClass.UNOBSERVABLE, "unobservable B_T"), (PointClass.INFEASIBLE, "outside X*_T"))) + "); model (16) cuts are at "
        f"omega_l = {OMEGA_L_CUT:g} rad/s, with theta in rad on an unscaled axis (the paper multiplies it by "
        f"{THETA_STRETCH:g} for display).</p>"
        + table + band_html + note + "<h3>Timings</h3>" + timing + "<h3>Figures 3(b), 4, 5</h3>" + "".join(images)
        + "<h3>Figure 6 (T = 5 only)</h3>" + fig6_html
        + f"<p>Section computed in {seconds:.1f} s.</p>"
    )
    summary = {
        "table": table_summary,
        "band_unobservable_by_T": {str(k): v for k, v in band_T.items()},
        "band_observable_by_gear_ratio_T7": {f"{k:.6g}": v for k, v in band_tau.items()},
        "reduced_pair_projection_dimensions_T3": {str(k): v for k, v in dims.items()},
        "fig6_paper_plane_meets_X5": planes["paper_omega_c_range"] is not None,
        "fig6_omega_l_range": wl,
        "seconds_model16_T3": {"enumeration": t_enum, "algorithm_3_1": t_alg},
        "seconds": seconds,
    }
    return ReportSection("Observability regions (paper 002)", body, summary, figs)


register_section("regions", regions_section)

"""Benchmark of the observability-region computations of paper 002 (Algorithm 3.1, Sections 6-7).

Run ``python -m benchmarks.bench_regions`` (full, a few minutes) or ``--quick`` (smoke test,
under a minute).  Writes ``benchmarks/results/regions.json`` (quick runs go to
``benchmarks/results/quick/``) and the Fig. 6 cut PNGs next to it.

Measured (medians over the stated number of repeats, with the ratio to the paper's figure):

(a) model (16), T = 3: mode enumeration + Algorithm 3.1, serial (paper: 1.4 s + 0.3 s);
(b) model (17), T = 7: every non-empty R_ij (paper: 33 s), serial / processes / Dask, with the
    pair lists checked identical across executors;
(c) model (17), T = 8: the same summary (no published figure);
(d) model (17): share of X*_7 that is observable (paper: O_7 not obtained in 4 h), by sampling
    with exact point queries under a time budget, with a 95 % Wilson interval, plus the Fig. 6 cut;
(e) issue 19, long horizons: model (17) at T = 7, 8, 9 on serial, 2 processes and a 2-worker Dask
    LocalCluster in the same run (load average recorded around every run): pair LPs, times,
    speed-ups, and the pair lists compared (sha256) with the ones recorded before the LP savings
    (``results/regions_before_issue19.json``).  ``--only long_horizons`` runs this part alone and
    updates its key of ``regions.json``;
(f) issue 39, scaling: model (17), the pair tests at T = 7, 8, 9 alternating serial, 2 processes and
    a Dask cluster of 2 worker processes joined by its scheduler address (best of 3 rounds, load
    average and CPU seconds of the caller and of every worker recorded, lists compared), then fresh
    processes running one analysis each: serial at T = 8, 9, 10 and 2 processes at T = 10, 11, with
    peak RSS.  ``--only scaling`` runs this part alone (key ``model17_scaling``).
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from hybobs_opt.errors import SolverError
from hybobs_opt.executor import DaskExecutor, ProcessExecutor, SerialExecutor
from hybobs_opt.geometry.lp import counting_lps, solve_lp
from hybobs_opt.observers.comparison import wilson_interval
from hybobs_opt.regions import Cut, analyse_observability, compute_cut, plot_cut
from hybobs_opt.report.regions_section import PAPER_002
from hybobs_opt.studies.paper002_powertrain.figures import fig6_planes
from hybobs_opt.studies.paper002_powertrain.systems import TABLE2, powertrain3, powertrain5

from ._machine import machine, versions

RESULTS = Path(__file__).resolve().parent / "results"
ROOT = Path(__file__).resolve().parents[1]

#: Targets of the issue (seconds), checked in the JSON (never asserted).
TARGET_MODEL16_T3 = 0.020
TARGET_MODEL17_T7 = 3.0
#: Wall-clock budget of part (d), seconds.
BUDGET_O7 = 60.0


def log(msg: str) -> None:
    print(f"[bench_regions] {msg}", file=sys.stderr, flush=True)


def _machine() -> dict:
    return machine()


def _versions() -> dict:
    return versions(("hybobs_opt", "numpy", "scipy", "daqp", "highspy", "matplotlib", "dask", "distributed"))


wilson = wilson_interval


def _median(xs):
    return float(statistics.median(xs)) if xs else None


# ---------------------------------------------------------------------------- (a)
def bench_model16_T3(repeats: int) -> dict:
    """Model (16), T = 3, serial: enumeration + Algorithm 3.1 (paper: 1.4 s + 0.3 s)."""
    log(f"(a) model (16), T = 3, serial, {repeats} repeats")
    for _ in range(2):  # warm-up (imports, first-call caches), not counted
        analyse_observability(powertrain3(), 3)
    wall, enum, alg, summary = [], [], [], None
    for _ in range(repeats):
        system = powertrain3()
        t0 = time.perf_counter()
        a = analyse_observability(system, 3, executor=SerialExecutor())
        wall.append(time.perf_counter() - t0)
        summary = a.summary()
        enum.append(summary["seconds_enumeration"])
        alg.append(summary["seconds_algorithm_3_1"])
    med = _median(wall)
    return {
        "what": "analyse_observability(powertrain3(), T=3): mode enumeration + Algorithm 3.1, serial executor",
        "repeats": repeats,
        "median_wall_seconds": med,
        "min_wall_seconds": min(wall),
        "median_seconds_enumeration": _median(enum),
        "median_seconds_algorithm_3_1": _median(alg),
        "paper_seconds": PAPER_002["model16_T3_total_seconds"],
        "paper_seconds_enumeration": PAPER_002["model16_T3_enumeration_seconds"],
        "paper_seconds_algorithm_3_1": PAPER_002["model16_T3_algorithm_3_1_seconds"],
        "ratio_to_paper": med / PAPER_002["model16_T3_total_seconds"],
        "ratio_to_paper_enumeration": _median(enum) / PAPER_002["model16_T3_enumeration_seconds"],
        "ratio_to_paper_algorithm_3_1": _median(alg) / PAPER_002["model16_T3_algorithm_3_1_seconds"],
        "target_seconds": TARGET_MODEL16_T3,
        "meets_target": med <= TARGET_MODEL16_T3,
        "paper_reduced_pieces": PAPER_002["model16_T3_reduced_pieces"],
        "summary": summary,
    }


# ---------------------------------------------------------------------------- (b), (c)
def _timed_runs(system_factory, T: int, executor, repeats: int, count_lps: bool):
    wall, runs, highs = [], [], []
    analysis = None
    for _ in range(repeats):
        system = system_factory()
        t0 = time.perf_counter()
        with counting_lps() as counters:
            analysis = analyse_observability(system, T, executor=executor)
        wall.append(time.perf_counter() - t0)
        runs.append(analysis.summary())
        highs.append(counters.confirmed_by_highs)
    s = runs[-1]
    rec = {
        "repeats": repeats,
        "median_wall_seconds": _median(wall),
        "wall_seconds": wall,
        "median_seconds_enumeration": _median([r["seconds_enumeration"] for r in runs]),
        "median_seconds_algorithm_3_1": _median([r["seconds_algorithm_3_1"] for r in runs]),
        "n_pairs": len(analysis.pairs),
        "summary": s,
    }
    if count_lps:
        rec["highs_confirmations"] = highs[-1]
        rec["daqp_lps"] = counters.fast
    else:
        rec["highs_confirmations"] = None
        rec["note"] = "LP counters live in the worker processes; see the serial run for HiGHS confirmations"
    return rec, analysis


def bench_model17(T: int, repeats: int, executors: tuple[str, ...], target: float | None, paper: float | None) -> tuple[dict, object]:
    """All non-empty R_ij of model (17) at horizon T, on each executor; pair lists compared."""
    out: dict = {"what": f"analyse_observability(powertrain5(), T={T}): enumeration + all non-empty R_ij (B_{T}, B~_{T})",
                 "horizon": T, "executors": {}}
    pair_lists = {}
    analysis_serial = None
    for kind in executors:
        log(f"model (17), T = {T}, {kind}, {repeats} repeat(s)")
        rec: dict = {}
        try:
            t0 = time.perf_counter()
            if kind == "serial":
                ex = SerialExecutor()
            elif kind == "processes":
                ex = ProcessExecutor(2)
            elif kind == "dask":
                ex = DaskExecutor(local_workers=2)
                rec["cluster_startup_seconds"] = time.perf_counter() - t0
            else:
                raise ValueError(kind)
            try:
                r, a = _timed_runs(powertrain5, T, ex, repeats, count_lps=(kind == "serial"))
            finally:
                t1 = time.perf_counter()
                ex.close()
                if kind == "dask":
                    rec["cluster_close_seconds"] = time.perf_counter() - t1
            rec.update(r)
            rec["n_workers"] = ex.n_workers
            pair_lists[kind] = [(p.i, p.j) for p in a.pairs]
            if kind == "serial":
                analysis_serial = a
            elif analysis_serial is None:
                analysis_serial = a
        except Exception as exc:  # a failing executor is reported, not fatal
            rec["error"] = f"{type(exc).__name__}: {exc}"
            log(f"  failed: {rec['error']}")
        if paper is not None and rec.get("median_wall_seconds") is not None:
            rec["ratio_to_paper"] = rec["median_wall_seconds"] / paper
        if target is not None and rec.get("median_wall_seconds") is not None:
            rec["meets_target"] = rec["median_wall_seconds"] <= target
        out["executors"][kind] = rec
    lists = list(pair_lists.values())
    out["executors_compared"] = list(pair_lists)
    out["identical_pair_lists"] = bool(lists) and all(lst == lists[0] for lst in lists)
    if paper is not None:
        out["paper_seconds"] = paper
    if target is not None:
        out["target_seconds"] = target
    serial = out["executors"].get("serial", {})
    if "summary" in serial:
        s = serial["summary"]
        out.update(n_lps=s["n_lps"], n_lps_avoided_by_pruning=s["n_lps_avoided_by_pruning"],
                   highs_confirmations=serial["highs_confirmations"], n_regions=s["n_regions"],
                   n_unobservable_pieces=s["n_unobservable_pieces"], n_reduced_pieces=s["n_reduced_pieces"])
    return out, analysis_serial


# ---------------------------------------------------------------------------- (d)
def _slip_coordinates() -> np.ndarray:
    """``z = M x``: (theta_mc, theta_cl, omega_m, omega_c - omega_m, omega_l - tau omega_c); det M = 1."""
    tau = TABLE2["gear_ratio"]
    M = np.eye(5)
    M[3, 2] = -1.0  # omega_c - omega_m
    M[4, 3] = -tau  # omega_l - tau omega_c
    return M


def _z_box(analysis, M: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """A box containing ``M X*_T``: state bounds for the rows of ``M`` that are coordinates, LPs over
    every region (scaled coordinates) for the others."""
    enum = analysis.enumeration
    n = analysis.system.n
    scale, centre = enum.scale, enum.centre
    xlo, xhi = analysis.system.state_bounds.bounding_box()
    unit = [r for r in range(n) if np.count_nonzero(M[r]) == 1 and M[r, r] == 1.0]
    lo = np.full(n, np.inf)
    hi = np.full(n, -np.inf)
    lo[unit], hi[unit] = xlo[unit], xhi[unit]
    for reg in enum.regions:
        G = reg.H * scale[None, :]
        g = reg.h - reg.H @ centre
        for r in (r for r in range(n) if r not in unit):
            c = np.zeros(scale.size)
            c[:n] = M[r] * scale[:n]
            off = float(M[r] @ centre[:n])
            for sign in (1.0, -1.0):
                res = solve_lp(sign * c, G, g, problem="bounding box of M X*_T")
                if res.status == "optimal":
                    v = sign * res.objective + off
                    lo[r], hi[r] = min(lo[r], v), max(hi[r], v)
    return lo, hi


_SAMPLING_ANALYSIS = None  # inherited by forked workers (avoids pickling ~MBs of pair sets)


def _sample_worker(args) -> dict:
    seed, seconds, Minv, zlo, zhi, xlo, xhi = args
    analysis = _SAMPLING_ANALYSIS
    if analysis is None:
        raise RuntimeError("the sampling workers need the fork start method (analysis inherited from the parent)")
    rng = np.random.default_rng(seed)
    counts = {"observable": 0, "unobservable": 0, "infeasible": 0}
    drawn = outside = errors = 0
    deadline = time.perf_counter() + seconds
    while time.perf_counter() < deadline:
        x = Minv @ (zlo + (zhi - zlo) * rng.random(zlo.size))
        drawn += 1
        if np.any(x < xlo) or np.any(x > xhi):
            outside += 1
            continue
        try:
            counts[analysis.classify(x)] += 1
        except SolverError:
            errors += 1
    return {"drawn": drawn, "outside_box": outside, "counts": counts, "errors": errors}


def _cut_block(args):
    fixed, limits, resolution = args
    return compute_cut(_SAMPLING_ANALYSIS, fixed, resolution=resolution, limits=limits)


def parallel_cut(analysis, ex, fixed: dict, grid: tuple[int, int], limits: dict | None = None) -> Cut:
    """:func:`compute_cut` with the rows of the vertical axis split among the executor's workers."""
    names = analysis.system.state_names
    free = [nm for nm in names if nm not in fixed]
    limits = dict(limits or {})
    nx, ny = grid
    blocks = np.array_split(np.arange(ny), ex.n_workers)
    if ex.n_workers == 1 or min(len(b) for b in blocks) < 2:
        return compute_cut(analysis, fixed, resolution=grid, limits=limits)
    xlo, xhi = analysis.system.state_bounds.bounding_box()
    k = names.index(free[1])
    y = np.linspace(*limits.get(free[1], (xlo[k], xhi[k])), ny)
    parts = ex.map(_cut_block, [(fixed, {**limits, free[1]: (y[b[0]], y[b[-1]])}, (nx, len(b))) for b in blocks])
    cuts = list(parts)
    cut = Cut(cuts[0].axes, dict(fixed), cuts[0].x_values, np.concatenate([c.y_values for c in cuts]),
              np.vstack([c.labels for c in cuts]))
    return cut


def bench_O7(analysis, budget: float, grid: tuple[int, int], n_workers: int) -> dict:
    """Share of X*_T that is observable, by uniform sampling with exact point queries (budget in s)."""
    global _SAMPLING_ANALYSIS
    T = analysis.T
    log(f"(d) model (17): observable share of X*_{T}, budget {budget:g} s")
    t0 = time.perf_counter()
    system = analysis.system
    _SAMPLING_ANALYSIS = analysis  # set before the pool forks
    lo, hi = system.state_bounds.bounding_box()
    analysis.classify(0.5 * (lo + hi))  # builds the point query's caches once, before the workers fork
    ex = ProcessExecutor(n_workers) if n_workers > 1 else SerialExecutor()
    try:
        return _bench_O7(analysis, ex, t0, budget, grid, system, T)
    finally:
        ex.close()
        _SAMPLING_ANALYSIS = None


def _bench_O7(analysis, ex, t0, budget, grid, system, T) -> dict:
    # Fig. 6 cut at the paper's plane, and at the nearest plane that meets X*_T
    planes = fig6_planes(analysis)
    t_planes = time.perf_counter() - t0
    figs = {}
    cut = parallel_cut(analysis, ex, planes["paper"], grid)
    name = f"regions_fig6_T{T}_paper_plane.png"
    plot_cut(cut, RESULTS_DIR / name, title=f"Fig. 6: model (17), T = {T}, theta_mc = 0, omega_m = 90, omega_l = 30")
    figs["paper_plane"] = {"png": name, "plane": planes["paper"], "fraction_in_X*": float(np.mean(cut.labels != "infeasible")),
                           "omega_c_range_on_plane": planes["paper_omega_c_range"]}
    if planes["consistent"] is not None:
        cut2 = parallel_cut(analysis, ex, planes["consistent"], grid,
                                   limits={"omega_c": planes["consistent_omega_c_range"]})
        name = f"regions_fig6_T{T}_consistent_plane.png"
        plot_cut(cut2, RESULTS_DIR / name,
                 title=f"model (17), T = {T}, theta_mc = 0, omega_m = 90, omega_l = {planes['consistent']['omega_l']:.4g}")
        figs["consistent_plane"] = {"png": name, "plane": planes["consistent"],
                                    "omega_c_limits": planes["consistent_omega_c_range"],
                                    "observable_of_feasible": cut2.fraction_of_feasible("observable")}
    figs["omega_l_range_at_theta_mc_0_omega_m_90"] = planes["omega_l_range"]
    figs["grid"] = list(grid)
    t_cut = time.perf_counter() - t0 - t_planes
    # sampling: uniform in the state box; drawn in the slip coordinates z = M x (det M = 1) over the
    # bounding box of M X*_T, which contains X*_T, so the accepted points are uniform on X*_T too.
    M = _slip_coordinates()
    zlo, zhi = _z_box(analysis, M)
    xlo, xhi = system.state_bounds.bounding_box()
    t_prep = time.perf_counter() - t0
    remaining = budget - (time.perf_counter() - t0) - 2.0  # margin for the workers' return
    t_s = time.perf_counter()
    parts = ex.map(_sample_worker, [(1000 + k, max(remaining, 0.5), np.linalg.inv(M), zlo, zhi, xlo, xhi)
                                    for k in range(ex.n_workers)])
    t_sampling = time.perf_counter() - t_s
    counts = {lab: sum(p["counts"][lab] for p in parts) for lab in ("observable", "unobservable", "infeasible")}
    drawn = sum(p["drawn"] for p in parts)
    in_box = drawn - sum(p["outside_box"] for p in parts)
    feasible = counts["observable"] + counts["unobservable"]
    seconds = time.perf_counter() - t0
    vol_ratio = float(np.prod(zhi - zlo) / np.prod(xhi - xlo))
    share_in = wilson(feasible, drawn)
    return {
        "what": f"share of X*_{T} (model 17) that is observable: uniform samples in the state box, kept when "
                f"classify(x) != 'infeasible' (exact point queries), 95 % Wilson interval",
        "horizon": T,
        "paper": PAPER_002["model17_O7"],
        "sampling": "uniform in the slip coordinates z = (theta_mc, theta_cl, omega_m, omega_c - omega_m, "
                    "omega_l - tau omega_c) over the LP bounding box of z(X*_T), points outside the state box "
                    "rejected: the same uniform law on X*_T as plain box sampling, with fewer wasted draws",
        "z_box": {"lower": zlo.tolist(), "upper": zhi.tolist()},
        "workers": ex.n_workers,
        "points_drawn": drawn,
        "points_in_state_box": in_box,
        "points_classified": sum(counts.values()),
        "points_in_X*": feasible,
        "points_observable": counts["observable"],
        "points_unobservable": counts["unobservable"],
        "points_solver_error": sum(p["errors"] for p in parts),
        "observable_share_of_X*": counts["observable"] / feasible if feasible else None,
        "observable_share_wilson95": wilson(counts["observable"], feasible),
        "volume_share_of_state_box_in_X*": (feasible / drawn) * vol_ratio if drawn else None,
        "volume_share_of_state_box_in_X*_wilson95": [share_in[0] * vol_ratio, share_in[1] * vol_ratio] if share_in else None,
        "fig6": figs,
        "seconds_fig6_planes_lps": t_planes,
        "seconds_cuts": t_cut,
        "seconds_sampling_box_lps": t_prep - t_planes - t_cut,
        "seconds_sampling": t_sampling,
        "seconds_total": seconds,
        "budget_seconds": budget,
        "within_budget": seconds <= budget,
    }


# ---------------------------------------------------------------------------- (e)
#: Issue 19's figures for model (17), pair LPs at T = 5..9 when it was filed (an older code base,
#: before the face / same-state handling of the pair sets; the code of HEAD a0105dd needed more:
#: results/regions_before_issue19.json).
ISSUE19_FILED_LPS = {5: 2546, 6: 7070, 7: 21223, 8: 66026, 9: 216478}
#: Issue 19's target: T = 9 serial under this many seconds.
TARGET_T9_SERIAL = 120.0


def _pair_list_hashes(analysis) -> dict:
    import hashlib

    ij = analysis.pairs.ij if hasattr(analysis.pairs, "ij") else [(p.i, p.j) for p in analysis.pairs]
    lists = {"pairs": [list(p) for p in ij],
             "thin": [list(p) for p in analysis.stats["pairs_dropped_thin"]],
             "same": [list(p) for p in analysis.stats["pairs_dropped_same_state"]],
             "ruled_out_by_group": [list(p) for p in analysis.stats.get("pairs_ruled_out_by_group", ())]}
    return {f"sha256_{k}": hashlib.sha256(json.dumps(v, separators=(",", ":")).encode()).hexdigest() for k, v in lists.items()}


def _pair_oracle():
    """``oracle(enum, a, b, exact)`` of scripts/check_t9_pair_lists.py (its own pair sets and LPs)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("check_pair_lists", ROOT / "scripts" / "check_t9_pair_lists.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.oracle


def _load() -> list[float] | None:
    return [round(x, 2) for x in os.getloadavg()] if hasattr(os, "getloadavg") else None


def _merge_long_horizons(path: Path, header: dict, T: int | None, rec: dict | None) -> None:
    """Read-modify-write of ``regions.json``'s ``model17_long_horizons`` under a file lock (runs of
    different horizons may write concurrently; each result is saved as soon as it exists)."""
    import fcntl

    import tempfile

    with open(Path(tempfile.gettempdir()) / "hybobs_bench_regions.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        record = json.loads(path.read_text()) if path.exists() else {"benchmark": "regions"}
        part = record.setdefault("model17_long_horizons", {})
        part.update({k: v for k, v in header.items() if k != "horizons"})
        if T is not None:
            part.setdefault("horizons", {})[str(T)] = rec
        path.write_text(json.dumps(record, indent=2, default=_json_default) + "\n")


def bench_long_horizons(Ts: tuple[int, ...], executors: tuple[str, ...], path: Path | None = None,
                        pair_by_pair: bool = True) -> dict:
    """Model (17) at each horizon on each executor, one run each, in one process (same load).

    The analyses run with the grouped pair tests (the default); with ``pair_by_pair`` a serial run
    with ``group_tests=False`` follows on the same enumeration: its LPs, time and pieces against
    the grouped run's.  With ``path``, every finished (horizon, executor) is merged into that
    ``regions.json`` at once."""
    from hybobs_opt.regions import enumerate_modes
    from hybobs_opt.regions.pair_geometry import RESCUED

    before_path = RESULTS / "regions_before_issue19.json"
    before = json.loads(before_path.read_text())["horizons"] if before_path.exists() else {}
    out: dict = {"what": "analyse_observability(powertrain5(), T) for T in %s: serial, ProcessExecutor(2), "
                         "DaskExecutor(local_workers=2) (cluster started once, excluded from the times); "
                         "pair LPs and wall times of the pair tests (Algorithm 3.1 steps 1-3, grouped pair tests) on the "
                         "same enumeration; then serial pair by pair (group_tests=False) for the LP count and pieces "
                         "without groups; pair lists compared with the code before the LP savings" % (list(Ts),),
                 "issue19_filed_pair_lps": ISSUE19_FILED_LPS, "horizons": {}}
    exes = {}
    for kind in executors:
        t0 = time.perf_counter()
        try:
            exes[kind] = (SerialExecutor() if kind == "serial" else ProcessExecutor(2) if kind == "processes"
                          else DaskExecutor(local_workers=2))
        except Exception as exc:  # a missing extra is reported, not fatal
            out[f"{kind}_error"] = f"{type(exc).__name__}: {exc}"
            continue
        out[f"{kind}_startup_seconds"] = time.perf_counter() - t0
    try:
        for kind, ex in exes.items():  # warm the workers (imports, numba caches), not timed
            if kind != "serial":
                analyse_observability(enumerate_modes(powertrain5(), 5), executor=ex)
        for T in Ts:
            rec: dict = {"executors": {}}
            enum = enumerate_modes(powertrain5(), T)
            rec["n_regions"] = len(enum.regions)
            rec["seconds_enumeration_serial"] = enum.seconds
            for kind, ex in exes.items():
                log(f"(e) model (17), T = {T}, {kind}")
                r: dict = {"load_average_before": _load()}
                for key in RESCUED:
                    RESCUED[key] = 0
                t0 = time.perf_counter()
                try:
                    with counting_lps() as counters:
                        a = analyse_observability(enum, executor=ex)
                except Exception as exc:
                    r["error"] = f"{type(exc).__name__}: {exc}"
                    rec["executors"][kind] = r
                    continue
                r["wall_seconds_pair_tests"] = time.perf_counter() - t0
                r["load_average_after"] = _load()
                r["n_pair_lps"] = a.n_pair_lps
                r["n_pairs"], r["n_pairs_dropped_thin"] = len(a.pairs), len(a.stats["pairs_dropped_thin"])
                r["n_pairs_dropped_same_state"] = len(a.stats["pairs_dropped_same_state"])
                r["n_pairs_tested"], r["n_pairs_skipped_rank"] = a.n_pairs_tested, a.n_pairs_skipped_rank
                for key in ("n_pairs_ruled_out_by_group", "n_group_tests", "n_group_lps", "group_depths"):
                    r[key] = a.stats.get(key)
                if kind == "serial":
                    grouped_pieces = [(p.i, p.j) for p in a.pairs]
                    r["highs_confirmations"] = counters.confirmed_by_highs
                    r["decided_by_tight_daqp"] = RESCUED["tight_daqp"]
                r.update(_pair_list_hashes(a))
                rec["executors"][kind] = r
                if path is not None:
                    _merge_long_horizons(path, {"what": out["what"], "issue19_filed_pair_lps": ISSUE19_FILED_LPS}, T,
                                         {**rec, "partial": True})
            ser = rec["executors"].get("serial", {})
            for kind, r in rec["executors"].items():
                if kind != "serial" and "wall_seconds_pair_tests" in r and "wall_seconds_pair_tests" in ser:
                    r["speedup_vs_serial"] = ser["wall_seconds_pair_tests"] / r["wall_seconds_pair_tests"]
            if pair_by_pair and "n_pair_lps" in ser:
                # the same enumeration, every pair tested on its own (group_tests=False)
                log(f"(e) model (17), T = {T}, serial, pair by pair")
                t0 = time.perf_counter()
                b1 = analyse_observability(enum, group_tests=False)
                wall1 = time.perf_counter() - t0
                one = [(p.i, p.j) for p in b1.pairs]
                only_one, only_grouped = sorted(set(one) - set(grouped_pieces)), sorted(set(grouped_pieces) - set(one))
                rec["pair_by_pair"] = {"wall_seconds_pair_tests": wall1, "n_pair_lps": b1.n_pair_lps,
                                       "n_pairs": len(one), "n_pairs_dropped_thin": len(b1.stats["pairs_dropped_thin"]),
                                       "n_pairs_dropped_same_state": len(b1.stats["pairs_dropped_same_state"]),
                                       "pieces_identical_to_grouped": one == grouped_pieces,
                                       "pieces_only_pair_by_pair": only_one, "pieces_only_grouped": only_grouped,
                                       "lp_ratio_pair_by_pair_over_grouped": b1.n_pair_lps / ser["n_pair_lps"],
                                       "wall_ratio_pair_by_pair_over_grouped": wall1 / ser["wall_seconds_pair_tests"],
                                       **_pair_list_hashes(b1)}
                if only_one or only_grouped:  # who is right: the independent LP oracle decides each one
                    oracle = _pair_oracle()
                    rec["pair_by_pair"]["oracle_labels_of_differing_pieces"] = {
                        f"{a_},{b_}": oracle(enum, a_, b_, exact=False)["label"] for a_, b_ in only_one + only_grouped}
            hashes = [tuple(r.get(f"sha256_{k}") for k in ("pairs", "thin", "same", "ruled_out_by_group"))
                      for r in rec["executors"].values() if "sha256_pairs" in r]
            rec["identical_across_executors"] = bool(hashes) and all(h == hashes[0] for h in hashes)
            b = before.get(str(T))
            if b is not None and "pair_by_pair" in rec:  # every pair's own verdict, as the code before had
                one = rec["pair_by_pair"]
                rec["before"] = {k: b[k] for k in ("n_pair_lps", "wall", "n_pairs", "n_thin", "n_same")}
                rec["identical_to_before"] = (one["sha256_pairs"], one["sha256_thin"], one["sha256_same"]) == \
                    (b["sha256_pairs"], b["sha256_thin"], b["sha256_same"])
                if "n_pair_lps" in ser:
                    rec["lp_ratio_before_over_now"] = b["n_pair_lps"] / ser["n_pair_lps"]
            if T in ISSUE19_FILED_LPS and "n_pair_lps" in ser:
                rec["lp_ratio_issue19_filed_over_now"] = ISSUE19_FILED_LPS[T] / ser["n_pair_lps"]
            if T == 9 and "wall_seconds_pair_tests" in ser:
                rec["target_serial_seconds"] = TARGET_T9_SERIAL
                rec["meets_target_serial"] = ser["wall_seconds_pair_tests"] + enum.seconds <= TARGET_T9_SERIAL
            out["horizons"][str(T)] = rec
            if path is not None:
                _merge_long_horizons(path, {}, T, {**rec, "machine_load_at_end": _load()})
    finally:
        for ex in exes.values():
            ex.close()
    return out


# ---------------------------------------------------------------------------- (f)
#: Issue 39's figures for model (17) when it was filed (serial, idle 2-core machine): seconds of
#: one analysis (enumeration + Algorithm 3.1) and peak RSS, and its targets.
ISSUE39_FILED = {"serial_seconds": {8: 3.8, 9: 11.5, 10: 35.8}, "peak_rss_mb": {9: 1100, 10: 3100},
                 "T10_pair_lps": 240569, "T10_pieces": 64249, "speedup_2_processes": {8: 1.41, 9: 1.43}}
ISSUE39_TARGETS = {"T10_serial_seconds": 20.0, "T10_peak_rss_mb": 1500.0, "T11_2_workers_seconds": 120.0,
                   "speedup_2_workers_T7_to_9": 1.8}

_FRESH_CHILD = r"""
import json, resource, sys, time
args = json.loads(sys.argv[1])
t0 = time.perf_counter()
from hybobs_opt.executor import ProcessExecutor, SerialExecutor
from hybobs_opt.regions import analyse_observability, enumerate_modes
from hybobs_opt.studies.paper002_powertrain.systems import powertrain5
t_import = time.perf_counter() - t0
ex = SerialExecutor() if args["executor"] == "serial" else ProcessExecutor(args["workers"])
try:
    t1 = time.perf_counter()
    enum = enumerate_modes(powertrain5(), args["T"], executor=ex)
    t2 = time.perf_counter()
    a = analyse_observability(enum, executor=ex)
    t3 = time.perf_counter()
finally:
    ex.close()
lists = {"pairs": [list(p) for p in a.pairs.ij], "thin": [list(p) for p in a.stats["pairs_dropped_thin"]],
         "same": [list(p) for p in a.stats["pairs_dropped_same_state"]],
         "ruled_out_by_group": [list(p) for p in a.stats["pairs_ruled_out_by_group"]]}
import hashlib
print(json.dumps({"seconds_import": t_import, "seconds_enumeration": t2 - t1, "seconds_pair_tests": t3 - t2,
                  "seconds_analysis": t3 - t1, "n_regions": len(enum.regions), "n_pieces": len(a.pairs),
                  "n_pair_lps": a.n_pair_lps, "executor_used": a.stats["executor"],
                  "cpu_seconds": sum(resource.getrusage(resource.RUSAGE_SELF)[:2]),
                  "cpu_seconds_workers": sum(resource.getrusage(resource.RUSAGE_CHILDREN)[:2]),
                  "peak_rss_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
                  "peak_rss_workers_mb": resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss / 1024,
                  **{"sha256_" + k: hashlib.sha256(json.dumps(v, separators=(",", ":")).encode()).hexdigest()
                     for k, v in lists.items()}}))
"""


def _fresh_analysis(T: int, executor: str, workers: int = 2, timeout: float = 1800.0) -> dict:
    """Model (17) at ``T`` in a fresh Python process running only that analysis: its wall times, its
    peak RSS (``getrusage`` of that process; ``peak_rss_workers_mb``: the largest of its worker
    processes), counts and the sha256 of its lists."""
    import subprocess

    rec: dict = {"executor": executor if executor == "serial" else f"processes({workers})", "load_average_before": _load()}
    t0 = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _FRESH_CHILD, json.dumps({"T": T, "executor": executor, "workers": workers})],
                          capture_output=True, text=True, timeout=timeout, cwd=ROOT, env={**os.environ, "PYTHONPATH": str(ROOT)})
    rec["wall_seconds_process"] = time.perf_counter() - t0
    rec["load_average_after"] = _load()
    if proc.returncode != 0:
        rec["error"] = proc.stderr.strip().splitlines()[-1] if proc.stderr.strip() else f"exit status {proc.returncode}"
        return rec
    rec.update(json.loads(proc.stdout.strip().splitlines()[-1]))
    return rec


def _pool_pids(ex) -> list[int]:
    """The worker pids of a ProcessExecutor (its pool is started on first use)."""
    pool = getattr(ex, "_pool", None)
    return sorted(getattr(pool, "_processes", {}) or {}) if pool is not None else []


def _cpu_of(pids) -> dict[int, float]:
    """CPU seconds (user + system) of live processes, from /proc (Linux; empty elsewhere)."""
    out = {}
    tick = os.sysconf("SC_CLK_TCK") if hasattr(os, "sysconf") else 100
    for pid in pids:
        try:
            fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
            out[pid] = (int(fields[11]) + int(fields[12])) / tick
        except (OSError, IndexError, ValueError):
            pass
    return out


def _worker_cpu(kind: str, ex) -> dict:
    """CPU seconds of each worker of ``ex`` (pool processes, or Dask workers asked directly)."""
    if kind == "processes":
        return _cpu_of(_pool_pids(ex))
    if kind == "dask":
        return {k: float(v) for k, v in ex._client.run(time.process_time).items()}
    return {}


def _start_dask_cluster(n_workers: int, timeout: float = 120.0):
    """A Dask scheduler and ``n_workers`` single-threaded worker processes started with the ``dask``
    command line, as a user would on a cluster; returns ``(address, [Popen, ...], folder)`` once
    every worker has joined."""
    import subprocess
    import tempfile

    from distributed import Client

    folder = tempfile.mkdtemp(prefix="hybobs-bench-dask-")
    sched_file = os.path.join(folder, "scheduler.json")
    env = {**os.environ, "PYTHONPATH": str(ROOT)}
    dask = [sys.executable, "-m", "distributed.cli.dask_scheduler"]
    procs = [subprocess.Popen(dask + ["--host", "127.0.0.1", "--port", "0", "--dashboard-address", ":0",
                                      "--scheduler-file", sched_file], env=env, stdout=subprocess.DEVNULL,
                              stderr=subprocess.DEVNULL)]
    try:
        t0 = time.perf_counter()
        while not os.path.exists(sched_file):
            if time.perf_counter() - t0 > timeout:
                raise TimeoutError(f"the Dask scheduler did not start within {timeout} s")
            time.sleep(0.2)
        procs.append(subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", "--scheduler-file", sched_file,
                                       "--nworkers", str(n_workers), "--nthreads", "1", "--no-dashboard"], env=env,
                                      stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL))
        with Client(scheduler_file=sched_file, timeout=timeout) as client:
            client.wait_for_workers(n_workers, timeout=timeout)
            address = client.scheduler.address
    except Exception:
        _stop_dask_cluster((None, procs, folder))
        raise
    return address, procs, folder


def _stop_dask_cluster(cluster) -> None:
    import shutil

    _, procs, folder = cluster
    for proc in reversed(procs):
        proc.terminate()
    for proc in reversed(procs):
        try:
            proc.wait(timeout=30)
        except Exception:
            proc.kill()
    shutil.rmtree(folder, ignore_errors=True)


def bench_scaling(Ts: tuple[int, ...] = (7, 8, 9), rounds: int = 3, fresh: bool = True,
                  executors: tuple[str, ...] = ("serial", "processes", "dask"), path: Path | None = None) -> dict:
    """Issue 39's measurements of model (17): the parallel split and the memory at long horizons.

    (1) At each ``T`` of ``Ts``, one enumeration, then ``rounds`` rounds of the pair tests
    (Algorithm 3.1) alternating serial, ``ProcessExecutor(2)`` and a Dask cluster of 2 worker
    processes joined by its scheduler address (``dask scheduler`` / ``dask worker`` started as
    processes of their own, as on a user's cluster; start-up excluded; the workers' algebra of the
    timed enumeration evicted before every parallel run, so that each run starts cold as the serial
    one does): wall times (best of the rounds), load average before and after every run,
    the speed-up over serial, the pair lists' sha256 compared across executors and rounds, and a
    CPU account that a shared machine cannot distort: the calling process's CPU seconds (its
    serial part) plus the busiest worker's CPU seconds, against the serial run's CPU seconds
    (``cpu_speedup_estimate``: the speed-up on an idle machine if the workers never waited).
    (2) ``fresh``: model (17) in fresh processes running only that analysis (enumeration + pair
    tests): serial at T = 8, 9, 10 and 2 processes at T = 10 and 11, with peak RSS; lists at
    T = 10 compared between serial and 2 processes.
    """
    from hybobs_opt.regions import enumerate_modes

    out: dict = {"what": bench_scaling.__doc__.split("\n\n", 1)[1].strip().replace("\n    ", " "),
                 "issue39_filed": ISSUE39_FILED, "targets": ISSUE39_TARGETS, "machine_load_at_start": _load(),
                 "horizons": {}}
    exes: dict = {}
    cluster = None
    for kind in executors:
        t0 = time.perf_counter()
        try:
            if kind == "serial":
                exes[kind] = SerialExecutor()
            elif kind == "processes":
                exes[kind] = ProcessExecutor(2)
            else:
                cluster = _start_dask_cluster(2)
                exes[kind] = DaskExecutor(scheduler=cluster[0])
                out["dask_cluster"] = ("`dask scheduler` and `dask worker --nworkers 2 --nthreads 1` started as processes of "
                                       "their own (the scheduler out of the caller, whose CPU seconds are measured), "
                                       "joined by DaskExecutor(scheduler=ADDRESS)")
        except Exception as exc:  # a missing extra is reported, not fatal
            out[f"{kind}_error"] = f"{type(exc).__name__}: {exc}"
            continue
        out[f"{kind}_startup_seconds"] = time.perf_counter() - t0
    try:
        # warm the workers (imports, numba caches), not timed; before every timed parallel run the
        # workers analyse this other enumeration again, so that the class-pair algebra they keep
        # between analyses of one enumeration (observability._WORKER_STATE) is not the timed one's:
        # every run starts cold, as the serial one does
        other = enumerate_modes(powertrain5(), 6)
        for kind, ex in exes.items():
            if kind != "serial":
                analyse_observability(other, executor=ex)
        for T in Ts:
            enum = enumerate_modes(powertrain5(), T)
            rec: dict = {"n_regions": len(enum.regions), "seconds_enumeration_serial": enum.seconds, "runs": {k: [] for k in exes}}
            for rnd in range(rounds):
                for kind, ex in exes.items():
                    log(f"(f) model (17), T = {T}, {kind}, round {rnd + 1} of {rounds}")
                    if kind != "serial":
                        analyse_observability(other, executor=ex)  # evict the workers' algebra of `enum` (see above)
                    r: dict = {"load_average_before": _load()}
                    w0 = _worker_cpu(kind, ex)
                    c0, t0 = time.process_time(), time.perf_counter()
                    try:
                        a = analyse_observability(enum, executor=ex)
                    except Exception as exc:
                        r["error"] = f"{type(exc).__name__}: {exc}"
                        rec["runs"][kind].append(r)
                        continue
                    r["wall_seconds"] = time.perf_counter() - t0
                    r["cpu_seconds_caller"] = time.process_time() - c0
                    w1 = _worker_cpu(kind, ex)
                    r["cpu_seconds_workers"] = [round(w1[k] - w0.get(k, 0.0), 3) for k in sorted(w1)]
                    r["load_average_after"] = _load()
                    r["n_pair_lps"], r["n_pieces"], r["executor_used"] = a.n_pair_lps, len(a.pairs), a.stats["executor"]
                    r.update(_pair_list_hashes(a))
                    del a
                    rec["runs"][kind].append(r)
                    if path is not None:
                        _merge_part(path, "model17_scaling", T, {**rec, "partial": True})
            summary = {}
            for kind, runs in rec["runs"].items():
                ok = [r for r in runs if "wall_seconds" in r]
                if not ok:
                    continue
                best = min(ok, key=lambda r: r["wall_seconds"])
                summary[kind] = {"best_wall_seconds": best["wall_seconds"],
                                 "median_wall_seconds": _median([r["wall_seconds"] for r in ok]),
                                 "cpu_critical_path_seconds": min(r["cpu_seconds_caller"] + max(r["cpu_seconds_workers"] or [0.0])
                                                                  for r in ok)}
            ser = summary.get("serial")
            for kind, s in summary.items():
                if kind != "serial" and ser:
                    s["speedup_vs_serial_best_of_rounds"] = ser["best_wall_seconds"] / s["best_wall_seconds"]
                    s["speedup_vs_serial_median"] = ser["median_wall_seconds"] / s["median_wall_seconds"]
                    s["cpu_speedup_estimate"] = ser["cpu_critical_path_seconds"] / s["cpu_critical_path_seconds"]
            rec["summary"] = summary
            hashes = {tuple(r.get(f"sha256_{k}") for k in ("pairs", "thin", "same", "ruled_out_by_group"))
                      for runs in rec["runs"].values() for r in runs if "sha256_pairs" in r}
            rec["identical_across_executors_and_rounds"] = len(hashes) == 1
            out["horizons"][str(T)] = rec
            if path is not None:
                _merge_part(path, "model17_scaling", T, rec)
    finally:
        for ex in exes.values():
            ex.close()
        if cluster is not None:
            _stop_dask_cluster(cluster)
    if fresh:
        runs = [(8, "serial"), (9, "serial"), (10, "serial"), (10, "processes"), (11, "processes")]
        out["fresh_process"] = {}
        for T, kind in runs:
            log(f"(f) model (17), T = {T}, {kind}, fresh process")
            r = _fresh_analysis(T, kind)
            out["fresh_process"][f"T{T}_{kind}"] = r
            if path is not None:
                _merge_part(path, "model17_scaling", None, {"fresh_process": out["fresh_process"]})
        fp = out["fresh_process"]
        s10, p10, p11 = fp.get("T10_serial", {}), fp.get("T10_processes", {}), fp.get("T11_processes", {})
        verdict = {}
        if "seconds_analysis" in s10:
            verdict["T10_serial_seconds"] = s10["seconds_analysis"]
            verdict["T10_serial_under_20_s"] = s10["seconds_analysis"] < ISSUE39_TARGETS["T10_serial_seconds"]
            verdict["T10_peak_rss_mb"] = s10["peak_rss_mb"]
            verdict["T10_peak_rss_under_1_5_GB"] = s10["peak_rss_mb"] < ISSUE39_TARGETS["T10_peak_rss_mb"]
            verdict["T10_pieces_and_lps_as_filed"] = [s10["n_pieces"], s10["n_pair_lps"]] == [ISSUE39_FILED["T10_pieces"],
                                                                                          ISSUE39_FILED["T10_pair_lps"]]
        if "sha256_pairs" in s10 and "sha256_pairs" in p10:
            verdict["T10_lists_identical_serial_and_2_processes"] = all(
                s10[f"sha256_{k}"] == p10[f"sha256_{k}"] for k in ("pairs", "thin", "same", "ruled_out_by_group"))
            verdict["T10_speedup_2_processes"] = s10["seconds_pair_tests"] / p10["seconds_pair_tests"]
        if "seconds_analysis" in p11:
            verdict["T11_2_workers_seconds"] = p11["seconds_analysis"]
            verdict["T11_2_workers_under_2_min"] = p11["seconds_analysis"] < ISSUE39_TARGETS["T11_2_workers_seconds"]
        sp = [out["horizons"][str(T)]["summary"].get("processes", {}).get("speedup_vs_serial_best_of_rounds")
              for T in Ts if str(T) in out["horizons"]]
        if sp and all(x is not None for x in sp):
            verdict["speedup_2_processes_best_of_rounds"] = sp
            verdict["speedup_at_least_1_8"] = all(x >= ISSUE39_TARGETS["speedup_2_workers_T7_to_9"] for x in sp)
        out["targets_met"] = verdict
    out["machine_load_at_end"] = _load()
    return out


def _merge_part(path: Path, key: str, T: int | None, rec: dict | None, header: dict | None = None) -> None:
    """Read-modify-write of one key of ``regions.json`` under a file lock (see :func:`_merge_long_horizons`)."""
    import fcntl
    import tempfile

    with open(Path(tempfile.gettempdir()) / "hybobs_bench_regions.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        record = json.loads(path.read_text()) if path.exists() else {"benchmark": "regions"}
        part = record.setdefault(key, {})
        part.update(header or {})
        if T is not None:
            part.setdefault("horizons", {})[str(T)] = rec
        elif rec:
            part.update(rec)
        path.write_text(json.dumps(record, indent=2, default=_json_default) + "\n")


RESULTS_DIR = RESULTS  # reassigned for --quick


def main(argv: list[str] | None = None) -> int:
    global RESULTS_DIR
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_regions", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny versions (smoke test); results in results/quick/")
    parser.add_argument("--no-dask", action="store_true", help="skip the Dask executor")
    parser.add_argument("--only", choices=["long_horizons", "scaling"],
                        help="run one part and update its key of regions.json (scaling: issue 39's measurements, "
                             "a few minutes on an idle 2-core machine)")
    parser.add_argument("--rounds", type=int, default=3, help="alternating rounds of --only scaling (best of them)")
    parser.add_argument("--no-fresh", action="store_true", help="--only scaling without the fresh-process runs (T = 8..11)")
    parser.add_argument("--horizons", type=int, nargs="+", help="horizons of --only long_horizons (default 7 8 9)")
    parser.add_argument("--executors", nargs="+", choices=["serial", "processes", "dask"], help="executors of --only long_horizons")
    args = parser.parse_args(argv)
    quick = args.quick
    RESULTS_DIR = RESULTS / "quick" if quick else RESULTS
    RESULTS_DIR.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    executors = ("serial", "processes") if args.no_dask else ("serial", "processes", "dask")
    if args.only == "scaling":
        path = RESULTS_DIR / "regions.json"
        Ts = tuple(args.horizons) if args.horizons else ((5, 6) if quick else (7, 8, 9))
        exs = tuple(args.executors) if args.executors else executors
        _merge_part(path, "model17_scaling", None, None, {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "machine": _machine(),
                                                          "versions": _versions(), "horizons": {}})
        out = bench_scaling(Ts, 1 if quick else args.rounds, fresh=not (quick or args.no_fresh), executors=exs, path=path)
        _merge_part(path, "model17_scaling", None, {k: v for k, v in out.items() if k != "horizons"})
        log(f"wrote {path} ({time.perf_counter() - t_start:.0f} s)")
        return 0
    if args.only == "long_horizons":
        path = RESULTS_DIR / "regions.json"
        Ts = tuple(args.horizons) if args.horizons else ((5, 6) if quick else (7, 8, 9))
        exs = tuple(args.executors) if args.executors else executors
        _merge_long_horizons(path, {"created": time.strftime("%Y-%m-%dT%H:%M:%S%z"), "machine": _machine()}, None, None)
        out = bench_long_horizons(Ts, exs, path)
        _merge_long_horizons(path, {k: v for k, v in out.items() if k != "horizons"}, None, None)
        log(f"wrote {path} ({time.perf_counter() - t_start:.0f} s)")
        return 0
    record: dict = {
        "benchmark": "regions",
        "quick": quick,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": _machine(),
        "versions": _versions(),
        "paper_002_published": PAPER_002,
        "notes": "medians over the stated repeats; the machine may be shared (see load_average); "
                 "ratio_to_paper = ours / paper (below 1 is faster)",
    }
    try:
        record["model16_T3"] = bench_model16_T3(3 if quick else 30)
    except Exception as exc:
        record["model16_T3"] = {"error": f"{type(exc).__name__}: {exc}"}
    T_b = 5 if quick else 7
    rec_b, analysis_b = bench_model17(T_b, 1 if quick else 3, executors, None if quick else TARGET_MODEL17_T7,
                                      None if quick else PAPER_002["model17_T7_B_seconds"])
    record[f"model17_T{T_b}"] = rec_b
    T_c = 6 if quick else 8
    rec_c, _ = bench_model17(T_c, 1, ("processes",), None, None)
    record[f"model17_T{T_c}"] = rec_c
    if analysis_b is not None:
        try:
            record[f"model17_O{T_b}"] = bench_O7(analysis_b, 10.0 if quick else BUDGET_O7, (11, 9) if quick else (31, 21),
                                                 min(2, os.cpu_count() or 1))
        except Exception as exc:
            record[f"model17_O{T_b}"] = {"error": f"{type(exc).__name__}: {exc}"}
    else:
        record[f"model17_O{T_b}"] = {"error": "no analysis of model (17) available (part b failed)"}
    record["machine"]["load_average_at_end"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    record["seconds_total"] = time.perf_counter() - t_start
    path = RESULTS_DIR / "regions.json"
    path.write_text(json.dumps(record, indent=2, default=_json_default) + "\n")
    log(f"wrote {path} ({record['seconds_total']:.0f} s)")
    return 0


def _json_default(o):
    if isinstance(o, (np.integer,)):
        return int(o)
    if isinstance(o, (np.floating,)):
        return float(o)
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.bool_,)):
        return bool(o)
    raise TypeError(type(o).__name__)


if __name__ == "__main__":
    sys.exit(main())

"""Real-time question of issue 18: the MILP observer (1-norm, T = 3) on the noisy model (16) scenario.

Issue 18: "MILP T = 3 on the noisy model (16) scenario: median step under 1 ms and 99th percentile
under the 1 ms sample period, or the measured reason why not."

Run ``python -m benchmarks.bench_mhe_milp`` (full, about three minutes on a shared 2-core machine)
or ``--quick`` (smoke test, under a minute).  Writes ``benchmarks/results/mhe_milp.json`` (quick
runs: ``benchmarks/results/quick/``).

Data: the bench scenario of ``hybobs bench powertrain3`` (:func:`hybobs_opt.studies.paper002_powertrain.bench.bench_trace`:
model (16), the torque profile through the backlash, output noise 0.01 rad/s with seed 0), its
first 1500 samples (1.5 s: one second of positive contact at steady state, then the shaft leaves
contact and rattles through the backlash; four mode switches), ``fit_tolerance = 5 sigma`` as
``bench.py`` sets it.

Runs (each ``MHEObserver(plant, 3, norm=..., solver=..., fit_tolerance=5 sigma)``):

* ``milp1_highs``: norm 1, HiGHS through highspy (the default), timed without instrumentation;
  per-step time is :attr:`Estimate.seconds` (the whole :meth:`Observer.step`).
* ``milp1_highs_profiled``: the same again with timers around the calls made inside a step
  (the observer's methods wrapped on the instance from outside; nothing in ``hybobs_opt/mhe`` is
  changed): the window MILP (``highs.run()`` itself and the backend's row-bound updates around it),
  the uniqueness programme (its norm-2 separated MIQP by DAQP, its separated MILP by HiGHS, its
  QP polishes along weak directions, its verification), the window's polishes, the checks of the
  answer (MLD rows, fit, cost), the warm start, and the rest (``Observer.step``'s sample checks,
  ``WindowResult.to_dict``...).  Each call's time is *exclusive* of the wrapped calls below it,
  so the parts add up to the step.  Also per step: solves and branch-and-bound nodes of each
  solver (HiGHS ``mip_node_count``, DAQP ``nodes``), and how the step was certified.
* ``milp1_highs_cprofile``: cProfile over 300 of the steps (after the switches begin), top
  functions by own time.
* ``highs_floor``: the window MILP of one recorded window solved again and again (the same row
  bounds, warm HiGHS instance): the least a HiGHS call costs on this problem.
* ``milp1_cbc`` (CBC through CasADi, if it loads) and ``miqp2_daqp`` (the norm-2 default, DAQP):
  the same, profiled.
* ``milp1_sequences`` (``solver="sequences"``: :mod:`hybobs_opt.mhe.sequence_lp`, the exact
  mode-prefix branch and bound of tiny condensed LPs, DAQP's LP mode with HiGHS as fallback),
  ``milp1_sequences_highs_lp`` (the same with HiGHS for every LP), ``milpinf_highs`` and
  ``milpinf_sequences`` (the inf-norm both ways): on the same samples in the same run, with the
  flags, estimates and certified costs compared step by step with the HiGHS run of the same norm.

Every run also records the thread CPU time of each step (``cpu``): on a shared machine the wall
clock includes time the process waited for a core, which the CPU time does not.

Per-step times are wall-clock on a shared machine (see the load averages); speed is measured, not
asserted (DESIGN.md).
"""

from __future__ import annotations

import argparse
import collections
import cProfile
import io
import json
import os
import pstats
import re
import sys
import time
from pathlib import Path

import numpy as np

from hybobs_opt.defaults import NOISE_FIT_SIGMAS

from ._machine import json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"

#: The sample period of model (16) and the issue's budget per step (seconds).
BUDGET_S = 1e-3
#: Output noise of the scenario (rad/s on the engine speed) and its seed (``hybobs bench`` defaults).
NOISE = 0.01
SEED = 0
T = 3


def log(msg: str) -> None:
    print(f"[bench_mhe_milp] {msg}", file=sys.stderr, flush=True)


def git_state() -> dict:
    """The commit the run measured and whether ``hybobs_opt/mhe`` differed from it (a shared working tree)."""
    import subprocess

    root = Path(__file__).resolve().parents[1]
    try:
        head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=10).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "hybobs_opt/mhe"], cwd=root, capture_output=True,
                               text=True, timeout=10).stdout.splitlines()
    except (OSError, subprocess.SubprocessError) as exc:
        return {"error": f"{type(exc).__name__}: {exc}"}
    return {"head": head, "uncommitted_in_hybobs_opt_mhe": [ln.strip() for ln in dirty]}


def stats_of(s) -> dict:
    s = np.asarray(s, dtype=float)
    if s.size == 0:
        return {"n": 0}
    return {"n": int(s.size), "median": float(np.median(s)), "mean": float(s.mean()), "p95": float(np.percentile(s, 95)),
            "p99": float(np.percentile(s, 99)), "max": float(s.max())}


def timing(secs: np.ndarray) -> dict:
    return {"median_step_s": float(np.median(secs)), "p95_step_s": float(np.percentile(secs, 95)),
            "p99_step_s": float(np.percentile(secs, 99)), "max_step_s": float(secs.max()), "mean_step_s": float(secs.mean()),
            "steps": int(secs.size), "fraction_over_budget": float(np.mean(secs > BUDGET_S)),
            "meets_median_budget": bool(np.median(secs) < BUDGET_S),
            "meets_p99_budget": bool(np.percentile(secs, 99) < BUDGET_S)}


# ---------------------------------------------------------------------------------- probes
class Probe:
    """Exclusive wall-clock time per label of wrapped calls, per step (a stack of open calls)."""

    def __init__(self):
        self.stack: list[float] = []
        self.step_time: dict[str, float] = collections.defaultdict(float)
        self.step_calls: collections.Counter = collections.Counter()
        self.step_nodes: collections.Counter = collections.Counter()
        self.wrapped: list[str] = []

    def new_step(self) -> None:
        self.step_time = collections.defaultdict(float)
        self.step_calls = collections.Counter()
        self.step_nodes = collections.Counter()

    def wrap(self, obj, attr: str, label: str, nodes: bool = False) -> bool:
        fn = getattr(obj, attr, None)
        if fn is None:
            return False
        probe = self

        def wrapper(*args, **kwargs):
            t0 = time.perf_counter()
            probe.stack.append(0.0)
            try:
                out = fn(*args, **kwargs)
            finally:
                dt = time.perf_counter() - t0
                child = probe.stack.pop()
                probe.step_time[label] += dt - child
                probe.step_calls[label] += 1
                if probe.stack:
                    probe.stack[-1] += dt
            if nodes:
                detail = getattr(out, "detail", None) or {}
                n = detail.get("nodes")
                if isinstance(n, (int, np.integer)) and n >= 0:
                    probe.step_nodes[label] += int(n)
            return out

        try:
            object.__setattr__(obj, attr, wrapper)
        except (AttributeError, TypeError):
            return False
        self.wrapped.append(f"{label}: {type(obj).__name__}.{attr}")
        return True


def instrument(obs, probe: Probe) -> None:
    """Wrap the calls a step makes on this observer's own objects (instance attributes only)."""
    sep = obs._separated
    # solvers first (innermost): the window program, the uniqueness programmes
    for backend, label in ((obs._backend, "window_solver"), (getattr(sep, "milp", None), "uniqueness_milp_solver"),
                           (getattr(sep, "miqp", None), "uniqueness_miqp_solver")):
        if backend is None:
            continue
        h = getattr(backend, "_h", None)  # highspy: time Highs.run() apart from the backend's bookkeeping
        if h is not None:
            probe.wrap(h, "run", label.replace("_solver", "_highs_run"))
        probe.wrap(backend, "solve", label, nodes=True)
    probe.wrap(obs.model, "polish", "polish_qp")
    for attr in ("feasible", "mld_violation", "output_residuals"):
        probe.wrap(obs.model, attr, "checks")
    probe.wrap(obs.model, "cost", "checks")
    probe.wrap(obs.enc, "violation", "checks")
    probe.wrap(obs.enc, "bounds", "window_data")
    probe.wrap(obs.enc, "pack", "window_data")
    probe.wrap(obs._res, "offset", "window_data")
    probe.wrap(obs.model, "simulate", "warm_start")
    probe.wrap(obs.model, "sequence_problem", "uniqueness_other")
    probe.wrap(obs, "_shifted", "warm_start")
    probe.wrap(obs, "_misfit", "checks")
    probe.wrap(sep, "verified", "uniqueness_verify")
    probe.wrap(sep, "alternative", "uniqueness_verify")
    probe.wrap(sep, "decide", "uniqueness_other")
    probe.wrap(obs, "_certified_by_search", "prefix_search")
    probe.wrap(obs, "_solve", "window_other")
    probe.wrap(obs, "_decide", "uniqueness_other")
    seq = getattr(obs, "_sequences", None)
    if seq is not None:  # solver "sequences": its LPs by engine, the window's search and the uniqueness search
        probe.wrap(seq, "_solve_daqp", "sequence_lp_daqp")
        probe.wrap(seq, "_solve_highs", "sequence_lp_highs")
        probe.wrap(seq, "solve", "sequence_window_search")
        probe.wrap(seq, "decide", "sequence_uniqueness_search")


def run(plant, U, Y, *, norm: str, solver: str | None, profiled: bool, budget_s: float | None = None,
        solver_options: dict | None = None) -> dict:
    from hybobs_opt.mhe import MHEObserver, MHESettings

    t_build = time.perf_counter()
    obs = MHEObserver(plant, T, norm=norm, solver=solver, fit_tolerance=NOISE_FIT_SIGMAS * NOISE,
                      settings=MHESettings(solver_options=solver_options))
    build_s = time.perf_counter() - t_build
    probe = Probe()
    if profiled:
        instrument(obs, probe)
    secs, flags, solved, decided = [], collections.Counter(), collections.Counter(), collections.Counter()
    cpu, costs = [], []
    xs, fl = [], []
    parts: list[dict] = []
    calls: list[dict] = []
    nodes: list[dict] = []
    t0 = time.perf_counter()
    for k in range(len(U)):
        probe.new_step()
        c0 = time.thread_time()
        est = obs.step(U[k], Y[k])
        c1 = time.thread_time()
        xs.append(est.x)
        fl.append(est.flag)
        if k >= T - 1:  # the warm-up steps solve nothing
            secs.append(est.seconds)
            cpu.append(c1 - c0)
            costs.append(est.info.get("cost", np.nan) if est.info.get("certified_optimum") else np.nan)
            flags[est.flag] += 1
            solved[str(est.info.get("solved_by"))] += 1
            uq = est.info.get("uniqueness")
            decided[str(uq.get("decided_by") if isinstance(uq, dict) else None)] += 1
            if profiled:
                d = dict(probe.step_time)
                d["rest_of_step"] = max(est.seconds - sum(d.values()), 0.0)
                parts.append(d)
                calls.append(dict(probe.step_calls))
                nodes.append(dict(probe.step_nodes))
        if budget_s is not None and time.perf_counter() - t0 > budget_s:
            break
    secs = np.array(secs)
    out = {"norm": norm, "solver": obs.solver, "solver_options": solver_options or {}, "T": T, "build_s": build_s, **timing(secs),
           "samples_run": k + 1, "wall_s": time.perf_counter() - t0, "flags": dict(flags), "solved_by": dict(solved),
           "uniqueness_decided_by": dict(decided), "_x": np.array(xs), "_flags": fl, "_costs": np.array(costs, dtype=float),
           "cpu": {k.replace("_step_s", "_cpu_step_s"): v for k, v in timing(np.array(cpu)).items()
                   if k.endswith("_step_s")}}
    if profiled:
        out["wrapped_calls"] = probe.wrapped
        out["breakdown"] = breakdown(secs, parts, calls, nodes)
    return out


def breakdown(secs: np.ndarray, parts: list[dict], calls: list[dict], nodes: list[dict]) -> dict:
    labels = sorted({k for d in parts for k in d})
    total = float(secs.sum())
    over = secs > BUDGET_S
    per = {}
    for lab in labels:
        v = np.array([d.get(lab, 0.0) for d in parts])
        c = np.array([c.get(lab, 0) for c in calls])
        per[lab] = {"share_of_total_time": float(v.sum() / total) if total else None,
                    "per_step_s": stats_of(v), "mean_per_step_over_budget_s": float(v[over].mean()) if over.any() else None,
                    "mean_per_step_within_budget_s": float(v[~over].mean()) if (~over).any() else None,
                    "steps_with_a_call": int(np.count_nonzero(c)), "calls_per_step": stats_of(c)}
    solver_labels = sorted({k for d in nodes for k in d} | {lab for lab in labels if lab.endswith("_solver")})
    nd = {lab: {"nodes_per_step": stats_of([d.get(lab, 0) for d in nodes]),
                "solves_per_step": stats_of([c.get(lab, 0) for c in calls])} for lab in solver_labels}
    # the largest part of each step over the budget
    dominant = collections.Counter(max(d, key=d.get) for d, o in zip(parts, over) if o)
    win = np.array([c.get("window_solver", 0) for c in calls]) > 0
    by_window = {"steps_with_a_window_solve": {**stats_of(secs[win]), "fraction_over_budget": float(np.mean(secs[win] > BUDGET_S)) if win.any() else None},
                 "steps_without_a_window_solve": {**stats_of(secs[~win]), "fraction_over_budget": float(np.mean(secs[~win] > BUDGET_S)) if (~win).any() else None}}
    for lab in ("uniqueness_miqp_solver", "polish_qp", "uniqueness_other"):
        if lab in per:
            by_window["steps_without_a_window_solve"][f"{lab}_mean_s"] = float(np.mean([d.get(lab, 0.0) for d, w in zip(parts, win) if not w])) if (~win).any() else None
    return {"parts": per, "solver_work": nd, "by_window_solve": by_window,
            "largest_part_of_steps_over_budget": dict(dominant),
            "steps_over_budget": int(over.sum())}


def cprofile_steps(plant, U, Y, start: int, count: int, top: int = 25) -> dict:
    from hybobs_opt.mhe import MHEObserver

    obs = MHEObserver(plant, T, norm="1", fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    for k in range(start):  # bring the window to the profiled stretch (not profiled)
        obs.step(U[k], Y[k])
    prof = cProfile.Profile()
    prof.enable()
    for k in range(start, start + count):
        obs.step(U[k], Y[k])
    prof.disable()
    st = pstats.Stats(prof, stream=io.StringIO())
    total = st.total_tt
    rows = []
    for (file, line, func), (cc, nc, tt, ct, _) in st.stats.items():
        rows.append({"function": f"{Path(file).name}:{line}({func})", "ncalls": int(nc), "tottime_s": float(tt),
                     "cumtime_s": float(ct), "tottime_per_step_s": float(tt / count)})
    by_tt = sorted(rows, key=lambda r: -r["tottime_s"])[:top]
    by_ct = sorted(rows, key=lambda r: -r["cumtime_s"])[:top]
    return {"samples": [start, start + count], "total_s": float(total), "per_step_s": float(total / count),
            "top_by_tottime": by_tt, "top_by_cumtime": by_ct,
            "note": "cProfile adds overhead per Python call; compare shares, not absolute times"}


#: HiGHS option sets tried on the window MILP (passed as
#: ``MHEObserver(settings=MHESettings(solver_options=...))``, no code change): its log on one
#: window shows two sub-MIPs (RINS / RENS heuristics) and ~170 cuts at the root of a 31-column
#: problem, which is where a 1-node solve spends its milliseconds.
HIGHS_VARIANTS = {
    "default": {},
    "no_sub_mip": {"mip_heuristic_run_rins": False, "mip_heuristic_run_rens": False},
    "no_heuristics": {"mip_heuristic_run_rins": False, "mip_heuristic_run_rens": False, "mip_heuristic_effort": 0.0},
    "no_heuristics_no_presolve": {"mip_heuristic_run_rins": False, "mip_heuristic_run_rens": False,
                                  "mip_heuristic_effort": 0.0, "presolve": "off"},
}


def highs_floor(plant, U, Y, repeats: int) -> dict:
    """Re-solve the window MILP of one window (the first one the observer sends to HiGHS on ``U, Y``)
    ``repeats`` times on a warm HiGHS instance, per option set of :data:`HIGHS_VARIANTS`
    (round robin, so the machine's load falls on all alike), and once with every binary fixed
    at the optimum (an LP through the same call)."""
    from hybobs_opt.mhe import MHEObserver, MHESettings

    obs = {name: MHEObserver(plant, T, norm="1", fit_tolerance=NOISE_FIT_SIGMAS * NOISE,
                             settings=MHESettings(check_uniqueness=False, solver_options=opts))
           for name, opts in HIGHS_VARIANTS.items()}
    ref = obs["default"]
    captured = {}
    solve = ref._backend.solve

    def capture(*args, **kwargs):
        captured.setdefault("call", (args, kwargs))
        return solve(*args, **kwargs)

    ref._backend.solve = capture
    for j in range(len(U)):  # step until a window MILP is solved; that window is re-solved below
        ref.step(U[j], Y[j])
        if "call" in captured:
            break
    ref._backend.solve = solve
    if "call" not in captured:
        return {"error": "no window MILP was solved on these samples"}
    args, kwargs = captured["call"][0], dict(captured["call"][1])
    kwargs.pop("start", None)
    times = {name: [] for name in obs}
    detail = {}
    for _ in range(repeats):
        for name, o in obs.items():
            t0 = time.perf_counter()
            out = o._backend.solve(*args, **kwargs)
            times[name].append(time.perf_counter() - t0)
            detail[name] = {"status": out.detail.get("status"), "nodes": out.detail.get("nodes"),
                            "objective": out.detail.get("objective")}
    v = solve(*args, **kwargs).v
    disc = np.nonzero(ref._milp[4])[0]
    fixed = np.round(v[disc])
    lp_t = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        solve(*args, **kwargs, col_bounds=(disc, fixed, fixed))
        lp_t.append(time.perf_counter() - t0)
    rows, cols = ref._milp[1].shape
    logs = {name: highs_log(obs[name], args, kwargs) for name in ("default", "no_heuristics")}
    return {"window_first_sample": int(j), "repeats": repeats, "highs_log": logs,
            "window_milp_s": stats_of(times["default"]), "nodes": detail["default"]["nodes"],
            "options": {name: {"solver_options": HIGHS_VARIANTS[name], "window_milp_s": stats_of(times[name]),
                               **detail[name]} for name in obs},
            "binaries_fixed_lp_s": stats_of(lp_t),
            "problem": {"rows": int(rows), "columns": int(cols), "binaries": int(len(disc)),
                        "nonzeros": int(np.count_nonzero(ref._milp[1]))}}


def highs_log(obs, args, kwargs) -> list[str]:
    """HiGHS's own solving report and sub-solver profile (``log_dev_level = 3``) of one window solve."""
    import tempfile

    h = obs._backend._h
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "highs.log"
        for key, value in (("output_flag", True), ("log_to_console", False), ("log_file", str(path)),
                           ("log_dev_level", 3)):
            h.setOptionValue(key, value)
        try:
            obs._backend.solve(*args, **kwargs)
        finally:
            for key, value in (("log_dev_level", 0), ("output_flag", False), ("log_file", "")):
                h.setOptionValue(key, value)
        lines = [ln.rstrip() for ln in path.read_text().splitlines() if ln.strip()]
    keep, on = [], False
    for ln in lines:
        if ln.startswith(("Solving report", "MIP sub-solver profiling")) or "Proc. InQueue" in ln:
            on = True
        if on:
            keep.append(ln)
        if ln.startswith(("getKktFailures", "====")):
            on = False
    return [ln for ln in keep if not ln.startswith("getKktFailures")][:80]


def _log_profile(lines: list[str]) -> dict | None:
    """Nodes, LP iterations and the LP solvers' share of HiGHS's MIP time, read from :func:`highs_log`."""
    out = {"lp_calls": 0}
    for ln in lines:
        tok = ln.split()
        if ln.strip().startswith("Nodes") and len(tok) == 2:
            out["nodes"] = int(tok[1])
        elif ln.strip().startswith("LP iterations") and len(tok) == 3:
            out["lp_iterations"] = int(tok[2])
        elif tok[:1] == ["MIP"] and len(tok) == 4 and "mip_s" not in out:
            out["mip_s"] = float(tok[2])
        elif tok[:1] == ["TOTAL"]:
            out["lp_percent"] = float(tok[-1])
        else:
            m = re.match(r"^(Du simplex|IPX|Pr simplex|PDLP)[^\d]*\s(\d+)\s+[\d.]+e[+-]\d+", ln.strip())
            if m:
                out["lp_calls"] += int(m.group(2))
    return out if {"nodes", "lp_iterations", "mip_s", "lp_percent"} <= out.keys() else None


def reason(rec: dict) -> str:
    """The measured reason, from the profiled HiGHS run, in one paragraph."""
    t = rec["runs"]["milp1_highs"]
    b = rec["runs"]["milp1_highs_profiled"]["breakdown"]
    parts = b["parts"]
    shares = sorted(((v["share_of_total_time"] or 0.0, k) for k, v in parts.items()), reverse=True)
    top = ", ".join(f"{k} {100 * s:.0f} %" for s, k in shares[:5])
    floor = rec.get("highs_floor", {})
    fl = floor.get("window_milp_s", {}).get("median")
    lp = floor.get("binaries_fixed_lp_s", {}).get("median")
    mean = {k: v["per_step_s"]["mean"] for k, v in parts.items()}
    ok = t["meets_median_budget"] and t["meets_p99_budget"]
    head = ("meets both targets" if ok else
            f"misses {'both targets' if not (t['meets_median_budget'] or t['meets_p99_budget']) else ('the median target' if not t['meets_median_budget'] else 'the p99 target')}")
    text = (f"MILP T = 3 (HiGHS) {head}: median {1e3 * t['median_step_s']:.2f} ms, p99 {1e3 * t['p99_step_s']:.2f} ms, "
            f"max {1e3 * t['max_step_s']:.2f} ms against the 1 ms period; {100 * t['fraction_over_budget']:.0f} % of the "
            f"steps exceed 1 ms.  Share of all step time: {top}.  Mean per step: window HiGHS run "
            f"{1e3 * mean.get('window_highs_run', 0.0):.2f} ms, uniqueness programme "
            f"{1e3 * sum(v for k, v in mean.items() if k.startswith('uniqueness')):.2f} ms (of which its HiGHS MILP "
            f"{1e3 * (mean.get('uniqueness_milp_highs_run', 0.0)):.2f} ms, its DAQP MIQP "
            f"{1e3 * mean.get('uniqueness_miqp_solver', 0.0):.2f} ms), QP polishes {1e3 * mean.get('polish_qp', 0.0):.2f} ms, "
            f"rest {1e3 * mean.get('rest_of_step', 0.0):.2f} ms.")
    bw = b.get("by_window_solve", {})
    wo, wi = bw.get("steps_without_a_window_solve", {}), bw.get("steps_with_a_window_solve", {})
    if wo.get("n") and wi.get("n"):
        text += (f"  The {wi['n']} steps that solve the window MILP take {1e3 * wi['median']:.2f} ms median; the {wo['n']} "
                 f"whose warm start fits the data (no window MILP) still take {1e3 * wo['median']:.2f} ms median "
                 f"({100 * wo['fraction_over_budget']:.0f} % over 1 ms): the uniqueness programme of the observable flag "
                 f"(its DAQP MIQP {1e3 * (wo.get('uniqueness_miqp_solver_mean_s') or 0.0):.2f} ms mean) and the QP polishes.")
    if fl is not None:
        text += (f"  One warm HiGHS call on this window MILP ({floor['problem']['rows']} rows, "
                 f"{floor['problem']['columns']} columns, {floor['problem']['binaries']} binaries) costs "
                 f"{1e3 * fl:.2f} ms median even re-solving the same window, and {1e3 * lp:.2f} ms with every binary "
                 f"fixed (an LP): a step that calls HiGHS at all is close to or over the budget by the solver's "
                 f"per-call cost alone.")
        opts = floor.get("options", {})
        prof = _log_profile(floor.get("highs_log", {}).get("default", []))
        if prof:
            text += (f"  HiGHS's own profile of that solve: {prof['nodes']} node(s), {prof['lp_iterations']} LP iterations, "
                     f"LP solves {prof['lp_percent']:.0f} % of its {1e3 * prof['mip_s']:.1f} ms "
                     f"({prof['lp_calls']} calls), the rest in its MIP machinery (cut separation, propagation, "
                     f"heuristics) around a {floor['problem']['columns']}-column problem.")
        opts = floor.get("options", {})
        text += ("  The window MILP's median by HiGHS option set (solver_options, no code change): " + ", ".join(
            f"{k} {1e3 * v['window_milp_s']['median']:.2f} ms ({v['nodes']} nodes)" for k, v in opts.items()) + ".")
    nh = rec["runs"].get("milp1_highs_no_heuristics", {})
    if "median_step_s" in nh:
        text += (f"  The observer with solver_options={HIGHS_VARIANTS['no_heuristics']}: median "
                 f"{1e3 * nh['median_step_s']:.2f} ms, p99 {1e3 * nh['p99_step_s']:.2f} ms, max {1e3 * nh['max_step_s']:.2f} ms "
                 f"({nh.get('flags_differing_steps')} steps with another flag than the default's).")
    for key, label in (("milp1_sequences", "norm 1"), ("milp1_sequences_highs_lp", "norm 1, HiGHS LPs"),
                       ("milpinf_sequences", "norm inf")):
        sq = rec["runs"].get(key, {})
        if "median_step_s" not in sq:
            continue
        cpu = sq.get("cpu", {})
        ok = sq["meets_median_budget"] and sq["meets_p99_budget"]
        text += (f"  Solver 'sequences' ({label}; mhe.sequence_lp, a mode-prefix branch and bound of tiny LPs, no MIP) "
                 f"in the same run: median {1e3 * sq['median_step_s']:.2f} ms, p95 {1e3 * sq['p95_step_s']:.2f} ms, "
                 f"p99 {1e3 * sq['p99_step_s']:.2f} ms, max {1e3 * sq['max_step_s']:.2f} ms wall "
                 f"(thread CPU time median {1e3 * cpu.get('median_cpu_step_s', np.nan):.2f} ms, p99 "
                 f"{1e3 * cpu.get('p99_cpu_step_s', np.nan):.2f} ms), {'meeting' if ok else 'missing'} "
                 f"{'both targets' if ok else ('the p99 target' if sq['meets_median_budget'] else 'both targets')}; "
                 f"{sq.get('flags_differing_steps')} steps with another flag than {sq.get('compared_with')}.")
    prof = rec["runs"].get("milp1_sequences_profiled", {}).get("breakdown")
    if prof:
        parts = prof["parts"]
        mean = {k: v["per_step_s"]["mean"] for k, v in parts.items()}
        calls = {k: v["calls_per_step"]["mean"] for k, v in parts.items()}
        text += ("  Where a 'sequences' step goes (norm 1, profiled, mean per step): "
                 + ", ".join(f"{k} {1e3 * v:.3f} ms" + (f" ({calls[k]:.2f} calls)" if k.startswith("sequence_lp") else "")
                             for k, v in sorted(mean.items(), key=lambda kv: -kv[1]) if v > 0) + ".")
    return text


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_mhe_milp", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny version (smoke test); results in results/quick/")
    args = parser.parse_args(argv)
    quick = args.quick
    out_dir = RESULTS / "quick" if quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()

    from hybobs_opt.studies import get_example
    from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario

    steps = 200 if quick else 1500
    plant = get_example("powertrain3").build()
    trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=steps * plant.Ts)
    U = trace.u
    Y = trace.y + np.random.default_rng(SEED).normal(0.0, NOISE, trace.y.shape)  # as bench_trace does
    first = 0 if quick else 900  # the quick run: the steady state only
    record: dict = {
        "benchmark": "mhe_milp",
        "issue": "18: MILP T = 3 on the noisy model (16) scenario: median step under 1 ms and 99th percentile under "
                 "the 1 ms sample period, or the measured reason why not",
        "quick": quick,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": machine(),
        "versions": versions(("hybobs_opt", "numpy", "scipy", "highspy", "daqp", "casadi")),
        "git": git_state(),
        "scenario": {"example": "powertrain3", "model": "paper 002, eq. (16)", "samples": steps,
                     "noise_std_rad_s": NOISE, "seed": SEED, "fit_tolerance": NOISE_FIT_SIGMAS * NOISE,
                     "sample_period_s": plant.Ts, "mode_switches": np.nonzero(np.diff(trace.q))[0] + 1,
                     "source": "backlash_scenario(plant, SCENARIO_TORQUES['powertrain3'], t_final=samples * Ts) + "
                               "N(0, noise^2) with default_rng(seed), as bench.bench_trace"},
        "budget_s": BUDGET_S,
        "notes": "per-step times are Estimate.seconds of MHEObserver.step over the samples after the T - 1 warm-up "
                 "steps; breakdown parts are exclusive wall-clock times of the wrapped calls (window_highs_run = "
                 "Highs.run() of the window MILP, window_solver = the backend's bookkeeping around it; "
                 "uniqueness_* = the separated programmes of the observable flag; polish_qp = the QPs with the "
                 "modes fixed, of the window's candidate incumbents and of the uniqueness test's weak directions; "
                 "checks = MLD rows, fit, cost; window_other = the certification logic of MHEObserver._solve; "
                 "rest_of_step = Observer.step minus the wrapped calls). The machine is shared: see the load averages.",
        "runs": {},
    }
    budgets = {"milp1_cbc": 40.0 if not quick else 10.0, "miqp2_daqp": 60.0 if not quick else 10.0}
    configs = [("milp1_highs", "1", None, False, None), ("milp1_highs_profiled", "1", None, True, None),
               ("milp1_highs_no_heuristics", "1", None, False, HIGHS_VARIANTS["no_heuristics"]),
               ("milp1_highs_no_heuristics_profiled", "1", None, True, HIGHS_VARIANTS["no_heuristics"]),
               ("milp1_cbc", "1", "cbc", True, None), ("miqp2_daqp", "2", None, True, None),
               # the exact mode-prefix branch and bound of tiny LPs (mhe.sequence_lp), beside HiGHS in the same
               # run: its default LP engine (DAQP, HiGHS fallback) and HiGHS alone; the inf-norm both ways
               ("milp1_sequences", "1", "sequences", False, None),
               ("milp1_sequences_profiled", "1", "sequences", True, None),
               ("milp1_sequences_highs_lp", "1", "sequences", False, {"lp": "highs"}),
               ("milpinf_highs", "inf", None, False, None), ("milpinf_sequences", "inf", "sequences", False, None)]
    refs: dict = {}
    for key, norm, solver, profiled, options in configs:
        log(f"{key} ...")
        try:
            res = run(plant, U, Y, norm=norm, solver=solver, profiled=profiled, budget_s=budgets.get(key),
                      solver_options=options)
        except Exception as exc:  # one failing configuration must not hide the others
            res = {"error": f"{type(exc).__name__}: {exc}"}
        x_run, f_run, c_run = res.pop("_x", None), res.pop("_flags", None), res.pop("_costs", None)
        if key in ("milp1_highs", "milpinf_highs"):
            refs[res.get("norm")] = (key, x_run, f_run, c_run)
        elif x_run is not None and res.get("norm") in refs:
            ref_key, x_ref, f_ref, c_ref = refs[res["norm"]]
            n = min(len(x_run), len(x_ref))
            half = plant.scales()[0][: plant.n]
            res["compared_with"] = ref_key
            res["same_flags_as_highs"] = f_run[:n] == f_ref[:n]
            res["flags_differing_steps"] = int(sum(a != b for a, b in zip(f_run[:n], f_ref[:n])))
            res["max_scaled_estimate_difference_to_highs"] = float(np.max(np.abs(x_run[:n] - x_ref[:n]) / half))
            both = [k for k in range(n) if f_run[k] == "observable" and f_ref[k] == "observable"]
            res["max_scaled_estimate_difference_where_both_observable"] = float(
                np.max(np.abs(x_run[both] - x_ref[both]) / half)) if both else None
            m = min(len(c_run), len(c_ref))
            d = np.abs(c_run[:m] - c_ref[:m])
            res["certified_cost_difference_to_highs"] = {"max": float(np.nanmax(d)) if np.isfinite(d).any() else None,
                                                          "windows_both_certified": int(np.isfinite(d).sum())}
        record["runs"][key] = res
        log(f"{key}: {json.dumps({k: res.get(k) for k in ('median_step_s', 'p95_step_s', 'p99_step_s', 'max_step_s', 'samples_run', 'error')})}")
    log("cProfile ...")
    try:
        start = 0 if quick else min(1000, steps - 300)
        record["milp1_highs_cprofile"] = cprofile_steps(plant, U, Y, start, 100 if quick else 300)
    except Exception as exc:
        record["milp1_highs_cprofile"] = {"error": f"{type(exc).__name__}: {exc}"}
    log("HiGHS floor ...")
    try:
        record["highs_floor"] = highs_floor(plant, U[first:first + 50], Y[first:first + 50], 50 if quick else 300)
    except Exception as exc:
        record["highs_floor"] = {"error": f"{type(exc).__name__}: {exc}"}
    try:
        record["reason"] = reason(record)
    except Exception as exc:
        record["reason"] = f"(not derived: {type(exc).__name__}: {exc})"
    log(record["reason"])
    record["machine"]["load_average_at_end"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    record["seconds_total"] = time.perf_counter() - t_start
    path = out_dir / "mhe_milp.json"
    path.write_text(json.dumps(record, indent=2, default=json_default) + "\n")
    log(f"wrote {path} ({record['seconds_total']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""What ``hybobs synth`` spends outside the LMI solver: the synthesis against a plain cvxpy + Clarabel
solve of the same LMIs.

Run ``python -m benchmarks.bench_synth_overhead`` (full, a few minutes) or ``--quick`` (smoke test).
Writes ``benchmarks/results/synth_overhead.json`` (quick runs go to ``benchmarks/results/quick/``).

Two syntheses, each as ``hybobs synth`` runs it (without the verification that follows it):

* ``vehicle``: :func:`hybobs_opt.studies.paper004_nonmonotonic.presets.preset_design` on
  ``vehicle_tracking`` (the paper's two regions, per-region decay bisection, joint dwell-time search);
* ``robot``: ``examples/models/flexible_joint_robot.toml`` through the command's own model path
  (``hybobs_opt.cli._schedule.design_setup`` on the parsed ``synth`` arguments, then
  :func:`hybobs_opt.lmi.auto_design.design_switched`: region growth, decay bisection, dwell search,
  with the polytopic condition).  The settings (read from the model) are computed once, outside
  the timed call.

Measured per synthesis:

``toolbox``
    Wall time of the synthesis call: ``cold_seconds`` the first call of the process on a system
    object nothing was compiled for (cvxpy's canonicalisation of every problem included), then
    ``warm_seconds``, the median over ``repeats`` calls after one warm-up call in the same process
    (the compiled problems are cached per system object, so this is the re-solve cost).
``breakdown``
    One more warm call with timers around the solver chain (exclusive times, seconds and share of
    that call's wall time): per solver attempt, cvxpy's compilation (``problem.compilation_time``:
    the parameter substitution of a cached problem, a full canonicalisation otherwise), the
    solver's own time (``solver_stats.solve_time``) and the rest of ``problem.solve`` (cvxpy's
    data formatting and unpacking around the solver), for the first Clarabel attempt of every solve
    (``first_attempt_*``) and for the fallback solvers (``fallback_*``, with the rescuing solver
    named); the numpy re-checks of every returned point (``recheck``: the callers' ``accept`` and
    point read-outs), the solver-side residuals (``residuals``), the Jacobian bounds, the final
    verified rates, and everything else (``python_other``: wall minus the timed parts).
``plain``
    The baseline.  "The same LMIs" means: the sequence of cvxpy problems the synthesis hands to
    :func:`hybobs_opt.lmi.solve.solve_problem`, in the order it does, each with the values its
    ``Parameter`` objects held at that call (recorded in one more warm call by wrapping
    ``solve_problem`` wherever the package imported it).  For each recorded solve the problem's
    expression tree is copied with fresh ``Variable`` objects and every ``Parameter`` replaced by a
    constant of its recorded value (the problem a user writes with numpy data), and solved once with
    ``problem.solve(solver="CLARABEL")``: no package code, no cache, no re-check, no fallback.  Its
    time is that call (canonicalisation, Clarabel, unpacking; building the expression tree is
    reported apart as ``build_seconds``), summed over the sequence; the median over ``repeats``
    passes.  ``failed`` counts the solves whose status is neither ``optimal`` nor ``infeasible``
    (an error, ``*_inaccurate``...), ``disagree`` those whose status differs from the status the
    toolbox's chain ended with.
``plain_dpp``
    A stricter baseline: the same sequence on one plain parametrised copy of each distinct problem
    (fresh ``Variable`` and ``Parameter`` objects, compiled once in a warm-up pass), the recorded
    values assigned before each ``problem.solve(solver="CLARABEL")``: cvxpy's own re-use of a
    compiled problem, again without re-checks or fallbacks.

``ratio`` is ``toolbox.warm_seconds / plain.seconds`` (target: at most 1.3, recorded, never
asserted); ``ratio_dpp`` the same against ``plain_dpp``.  The toolbox does more work than either
baseline on purpose: it re-checks every point in numpy and rescues the solves Clarabel leaves
undecided with its fallback chain; the breakdown shows what that costs.
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from contextlib import contextmanager
from pathlib import Path

import numpy as np

from ._machine import git_state, json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"
ROOT = Path(__file__).resolve().parents[1]
ROBOT_MODEL = ROOT / "examples" / "models" / "flexible_joint_robot.toml"

#: Target of the ratio toolbox / plain (recorded in the JSON, never asserted).
TARGET_RATIO = 1.3


def log(msg: str) -> None:
    print(f"[bench_synth_overhead] {msg}", file=sys.stderr, flush=True)


def _load() -> list[float]:
    import os

    try:
        return [round(v, 2) for v in os.getloadavg()]
    except OSError:
        return []


# ---------------------------------------------------------------------------- the two syntheses
def vehicle_case():
    """``(make_system, synthesize(system))`` for ``hybobs synth vehicle_tracking``."""
    from hybobs_opt.studies.paper004_nonmonotonic.presets import preset_design
    from hybobs_opt.studies.paper004_nonmonotonic.systems import vehicle_tracking

    return vehicle_tracking, lambda system: preset_design("vehicle_tracking", system)


def robot_case():
    """``(make_system, synthesize(system))`` for ``hybobs synth examples/models/flexible_joint_robot.toml``."""
    from hybobs_opt.cli import synth
    from hybobs_opt.cli._schedule import design_setup
    from hybobs_opt.lmi.auto_design import design_switched

    parser = argparse.ArgumentParser()
    synth.add_arguments(parser)
    args = parser.parse_args([str(ROBOT_MODEL), "--out", "unused.json"])
    named, _, settings = design_setup(args)

    def make_system():
        return design_setup(args)[0].system

    return make_system, lambda system: design_switched(system, settings)


CASES = {"vehicle": vehicle_case, "robot": robot_case}


def summary(design) -> dict:
    """The design's numbers that must not change: per region ``sigma_max``, ``sigma``, ``||L||``; ``tau``."""
    return {"regions": [{"interval": [g.region.lo, g.region.hi], "sigma_max": g.sigma_max, "sigma": g.sigma,
                         "gain_norm": g.gain_norm} for g in design.regions],
            "tau": design.tau, "tau_fixed_P": design.tau_fixed, "solves": design.solves,
            "solver_counts": design.solver_counts}


# ---------------------------------------------------------------------------- instrumentation
def _patch_everywhere(name: str, original, replacement) -> list:
    """Replace ``original`` by ``replacement`` in every loaded ``hybobs_opt`` module that holds it as ``name``."""
    done = []
    for modname, mod in list(sys.modules.items()):
        if modname.startswith("hybobs_opt") and mod is not None and getattr(mod, name, None) is original:
            setattr(mod, name, replacement)
            done.append(mod)
    return done


class _Timers:
    """Exclusive timers: a section's time excludes the sections timed inside it."""

    def __init__(self):
        self.seconds: dict[str, float] = {}
        self.counts: dict[str, int] = {}
        self._stack: list[list] = []

    @contextmanager
    def section(self, key: str):
        t0 = time.perf_counter()
        self._stack.append([key, 0.0])
        try:
            yield
        finally:
            key, inner = self._stack.pop()
            total = time.perf_counter() - t0
            self.add(key, total - inner)
            if self._stack:
                self._stack[-1][1] += total

    def add(self, key: str, seconds: float, count: int = 1) -> None:
        self.seconds[key] = self.seconds.get(key, 0.0) + seconds
        self.counts[key] = self.counts.get(key, 0) + count


@contextmanager
def instrumented(timers: _Timers | None = None, records: list | None = None):
    """Timers around the solver chain (``timers``) and/or the record of every solve (``records``)."""
    from hybobs_opt.lmi import bounds as bounds_mod
    from hybobs_opt.lmi import dwell, hierarchy, observer_lmi, polytopic
    from hybobs_opt.lmi import solve as solve_mod

    undo = []

    def patch_attr(obj, name, new):
        old = getattr(obj, name)
        setattr(obj, name, new)
        undo.append(lambda: setattr(obj, name, old))

    orig_solve = solve_mod.solve_problem
    attempt_index = [0]

    def solve_problem(problem, *args, accept=None, **kwargs):
        if records is not None:
            records.append({"problem": problem,
                            "values": [(p, None if p.value is None else np.array(p.value, dtype=float, copy=True))
                                       for p in problem.parameters()]})
        if timers is not None and accept is not None:
            inner_accept = accept

            def accept():
                with timers.section("recheck"):
                    return inner_accept()
        attempt_index[0] = 0
        if timers is None:
            out = orig_solve(problem, *args, accept=accept, **kwargs)
        else:
            with timers.section("solve_problem_other"):
                out = orig_solve(problem, *args, accept=accept, **kwargs)
        if records is not None:
            records[-1]["status"] = str(out.status)
            records[-1]["attempts"] = [list(a) for a in out.attempts]
        return out

    for mod in _patch_everywhere("solve_problem", orig_solve, solve_problem):
        undo.append(lambda mod=mod: setattr(mod, "solve_problem", orig_solve))

    if timers is not None:
        orig_run = solve_mod._run_once

        def run_once(problem, solver, options):
            k = attempt_index[0]
            attempt_index[0] += 1
            prefix = "first_attempt" if k == 0 else "fallback"
            t0 = time.perf_counter()
            with timers.section(f"{prefix}_cvxpy_other"):
                out = orig_run(problem, solver, options)
            wall = time.perf_counter() - t0
            comp = min(float(getattr(problem, "compilation_time", 0.0) or 0.0), wall)
            if str(out[0]) == "solver_error":
                # cvxpy raised before updating solver_stats: the rest of the attempt is the failed solve
                failed, solv = wall - comp, 0.0
            else:
                stats = getattr(problem, "solver_stats", None)
                solv = float(getattr(stats, "solve_time", 0.0) or 0.0) if stats is not None else 0.0
                failed, solv = 0.0, min(solv, wall - comp)
            # move the compilation and the solver's own time out of the "other" bucket
            timers.add(f"{prefix}_cvxpy_other", -(comp + solv + failed), 0)
            timers.add(f"{prefix}_compile", comp)
            timers.add(f"{prefix}_solver", solv)
            if failed:
                timers.add(f"{prefix}_failed_solve", failed)
            if k:  # per fallback solver, its whole wall time (already inside the fallback_* parts)
                timers.add(f"fallback_{solver}{'(options)' if options else ''}_wall", wall)
            return out

        patch_attr(solve_mod, "_run_once", run_once)

        orig_res = solve_mod.constraint_residuals

        def residuals(problem):
            with timers.section("residuals"):
                return orig_res(problem)

        patch_attr(solve_mod, "constraint_residuals", residuals)

        for cls, meth in ((observer_lmi.ObserverLMI, "_read_point"), (polytopic.PolytopicLMI, "_read_point"),
                          (dwell.DwellTimeLMI, "_check")):
            orig = getattr(cls, meth)

            def timed(*a, _orig=orig, **k):
                with timers.section("recheck"):
                    return _orig(*a, **k)

            patch_attr(cls, meth, timed)

        orig_jb = bounds_mod.jacobian_bounds

        def jacobian_bounds(*a, **k):
            with timers.section("jacobian_bounds"):
                return orig_jb(*a, **k)

        for mod in _patch_everywhere("jacobian_bounds", orig_jb, jacobian_bounds):
            undo.append(lambda mod=mod: setattr(mod, "jacobian_bounds", orig_jb))

        orig_vr = hierarchy.verified_rate

        def verified_rate(*a, **k):
            with timers.section("verified_rate"):
                return orig_vr(*a, **k)

        patch_attr(hierarchy, "verified_rate", verified_rate)
    try:
        yield
    finally:
        for fn in reversed(undo):
            fn()


# ---------------------------------------------------------------------------- the plain problems
def _fresh_variable(v):
    import cvxpy as cp

    attrs = {k: True for k, val in v.attributes.items() if val is True}
    return cp.Variable(v.shape, name=v.name(), **attrs)


def _copy_tree(expr, leaf):
    """``expr`` with every leaf replaced by ``leaf(x)`` (atoms and constraints rebuilt by ``copy``)."""
    import cvxpy as cp
    from cvxpy.expressions.leaf import Leaf

    if isinstance(expr, Leaf):
        return leaf(expr)
    args = [_copy_tree(a, leaf) for a in expr.args]
    if isinstance(expr, cp.constraints.constraint.Constraint):
        return type(expr)(*args) if not hasattr(expr, "copy") else expr.copy(args)
    return expr.copy(args)


def plain_problem(problem, values: dict | None, variables: dict, parameters: dict | None = None):
    """A plain copy of ``problem``: fresh variables; parameters as constants of ``values`` (or, with
    ``parameters``, as fresh ``Parameter`` objects, the map filled on the way)."""
    import cvxpy as cp
    from cvxpy.expressions.constants.parameter import Parameter
    from cvxpy.expressions.variable import Variable

    def leaf(x):
        if isinstance(x, Variable):
            if x.id not in variables:
                variables[x.id] = _fresh_variable(x)
            return variables[x.id]
        if isinstance(x, Parameter):
            if parameters is None:
                return cp.Constant(values[x.id])
            if x.id not in parameters:
                attrs = {k: True for k, val in x.attributes.items() if val is True}
                parameters[x.id] = cp.Parameter(x.shape, name=x.name(), **attrs)
            return parameters[x.id]
        return x

    objective = type(problem.objective)(_copy_tree(problem.objective.args[0], leaf))
    return cp.Problem(objective, [_copy_tree(c, leaf) for c in problem.constraints])


DECIDED = ("optimal", "infeasible")


def _plain_solve(prob) -> str:
    """One plain ``prob.solve(solver="CLARABEL")``: its status, or ``error: ...`` (a Rust panic included)."""
    import warnings

    import cvxpy as cp

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        try:
            prob.solve(solver="CLARABEL")
            return str(prob.status)
        except (cp.error.SolverError, ArithmeticError, ValueError, RuntimeError) as exc:
            return f"error: {type(exc).__name__}"
        except BaseException as exc:  # Clarabel's Rust panic; its solver object is dropped from the cache
            if type(exc).__name__ != "PanicException":
                raise
            prob._solver_cache.pop("CLARABEL", None)
            return "error: PanicException"


def plain_pass(records: list) -> dict:
    """Each recorded solve on its plain constant copy, once: times and statuses."""
    build = solve = 0.0
    statuses = []
    for rec in records:
        t0 = time.perf_counter()
        prob = plain_problem(rec["problem"], {p.id: v for p, v in rec["values"]}, {})
        t1 = time.perf_counter()
        st = _plain_solve(prob)
        t2 = time.perf_counter()
        build += t1 - t0
        solve += t2 - t1
        statuses.append(st)
    return {"seconds": solve, "build_seconds": build, "statuses": statuses}


def plain_dpp_setup(records: list) -> list:
    """One plain parametrised copy per distinct recorded problem; per record ``(problem, [(param, value)])``."""
    copies: dict[int, tuple] = {}
    out = []
    for rec in records:
        key = id(rec["problem"])
        if key not in copies:
            params: dict = {}
            copies[key] = (plain_problem(rec["problem"], None, {}, params), params)
        prob, params = copies[key]
        out.append((prob, [(params[p.id], v) for p, v in rec["values"] if p.id in params]))
    return out


def plain_dpp_pass(seq: list) -> dict:
    total = 0.0
    statuses = []
    for prob, vals in seq:
        t0 = time.perf_counter()
        for par, v in vals:
            par.value = v if np.ndim(v) else float(v)
        st = _plain_solve(prob)
        total += time.perf_counter() - t0
        statuses.append(st)
    return {"seconds": total, "statuses": statuses}


# ---------------------------------------------------------------------------- one case
def bench_case(name: str, repeats: int) -> dict:
    make_system, synthesize = CASES[name]()
    system = make_system()
    t0 = time.perf_counter()
    design = synthesize(system)  # cold: every problem of this system object built and canonicalised
    cold = time.perf_counter() - t0
    walls = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        design = synthesize(system)
        walls.append(time.perf_counter() - t0)
    warm = statistics.median(walls)

    timers = _Timers()
    with instrumented(timers=timers):
        t0 = time.perf_counter()
        synthesize(system)
        bwall = time.perf_counter() - t0
    parts = dict(sorted(timers.seconds.items()))
    timed = sum(v for k, v in parts.items() if not k.endswith("_wall"))
    parts["python_other"] = bwall - timed
    groups = {
        "cvxpy_compile": sum(v for k, v in parts.items() if k.endswith("_compile")),
        "solver": parts.get("first_attempt_solver", 0.0) + parts.get("first_attempt_failed_solve", 0.0),
        "cvxpy_around_solver": parts.get("first_attempt_cvxpy_other", 0.0),
        "fallback_solvers": sum(parts.get(f"fallback_{p}", 0.0) for p in ("compile", "solver", "cvxpy_other",
                                                                             "failed_solve")),
        "numpy_rechecks": parts.get("recheck", 0.0) + parts.get("verified_rate", 0.0),
        "solver_residuals": parts.get("residuals", 0.0),
        "jacobian_bounds": parts.get("jacobian_bounds", 0.0),
        "python_other": parts.get("solve_problem_other", 0.0) + parts["python_other"],
    }
    groups["cvxpy_compile"] -= parts.get("fallback_compile", 0.0)  # counted with the fallbacks

    records: list = []
    with instrumented(records=records):
        synthesize(system)
    toolbox_status = [r["status"] for r in records]
    plain_runs = [plain_pass(records) for _ in range(max(1, repeats // 2))]
    plain = plain_runs[0]
    seq = plain_dpp_setup(records)
    plain_dpp_pass(seq)  # warm-up: compiles each distinct problem once
    dpp_runs = [plain_dpp_pass(seq) for _ in range(max(1, repeats // 2))]
    plain_s = statistics.median(r["seconds"] for r in plain_runs)
    dpp_s = statistics.median(r["seconds"] for r in dpp_runs)

    def status_summary(statuses):
        return {"failed": sum(s not in DECIDED for s in statuses),
                "disagree": sum(a != b for a, b in zip(statuses, toolbox_status)),
                "counts": {s: statuses.count(s) for s in sorted(set(statuses))}}

    return {
        "toolbox": {"cold_seconds": cold, "warm_seconds": warm, "repeats": repeats, "warm_min_seconds": min(walls),
                    "solves": len(records), "statuses": {s: toolbox_status.count(s) for s in sorted(set(toolbox_status))},
                    "first_attempt_undecided": sum(len(r["attempts"]) > 1 for r in records),
                    "attempts": [r["attempts"] for r in records]},
        "breakdown": {"wall_seconds": bwall, "groups": groups,
                      "group_shares": {k: v / bwall for k, v in groups.items()},
                      "parts": parts, "counts": dict(sorted(timers.counts.items()))},
        "plain": {"seconds": plain_s, "repeats": len(plain_runs),
                  "build_seconds": statistics.median(r["build_seconds"] for r in plain_runs),
                  **status_summary(plain["statuses"]), "statuses": plain["statuses"]},
        "plain_dpp": {"seconds": dpp_s, "repeats": len(dpp_runs), **status_summary(dpp_runs[0]["statuses"]),
                      "statuses": dpp_runs[0]["statuses"]},
        "ratio": warm / plain_s,
        "ratio_dpp": warm / dpp_s,
        "target_ratio": TARGET_RATIO,
        "meets_target": warm / plain_s <= TARGET_RATIO,
        "design": summary(design),
    }


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_synth_overhead", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="few repeats (smoke test); results in results/quick/")
    parser.add_argument("--repeats", type=int, default=None, help="warm repeats (default 10, quick 2)")
    parser.add_argument("--only", choices=sorted(CASES), default=None, help="one synthesis")
    args = parser.parse_args(argv)
    repeats = args.repeats or (2 if args.quick else 10)
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    record: dict = {"machine": {**machine(), "versions": versions(("numpy", "scipy", "cvxpy", "clarabel", "cvxopt",
                                                                     "scs", "casadi"))},
                    "git": git_state("hybobs_opt/lmi"), "load_start": _load(), "quick": args.quick,
                    "target_ratio": TARGET_RATIO}
    for name in ([args.only] if args.only else list(CASES)):
        log(name)
        try:
            record[name] = rec = bench_case(name, repeats)
            log(f"{name}: toolbox {rec['toolbox']['warm_seconds']:.3f} s (cold {rec['toolbox']['cold_seconds']:.3f} s), "
                f"plain {rec['plain']['seconds']:.3f} s, plain DPP {rec['plain_dpp']['seconds']:.3f} s: "
                f"ratio {rec['ratio']:.2f} (DPP {rec['ratio_dpp']:.2f}); {rec['toolbox']['solves']} solves, "
                f"{rec['plain']['failed']} plain failed")
            log("  " + ", ".join(f"{k} {v:.3f}" for k, v in rec["breakdown"]["groups"].items()))
        except Exception as exc:  # one failing part must not hide the other
            record[name] = {"error": f"{type(exc).__name__}: {exc}"}
            log(f"{name} failed: {exc}")
    record["load_end"] = _load()
    path = out_dir / "synth_overhead.json"
    path.write_text(json.dumps(record, indent=2, default=json_default) + "\n")
    log(f"written {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())

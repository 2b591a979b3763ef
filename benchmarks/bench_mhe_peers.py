"""The MIQP moving-horizon observer (10) of paper 002 against Gurobi on the same windows.

Run ``python -m benchmarks.bench_mhe_peers`` (full: T = 10 noisy over 200 steps, T = 3 clean and
noisy over 200 steps each; several minutes) or ``--quick`` (a few steps each, results in
``results/quick/``).  Writes ``benchmarks/results/mhe_peers.json``.

Scenario: the powertrain3 example (model (16)), samples from 500 on, outputs with Gaussian noise of
std 0.01 rad/s (seed 0) for the noisy runs, as ``benchmarks/bench_mhe.py`` builds them; the
observer ``MHEObserver(plant, T, norm="2")`` with ``fit_tolerance = NOISE_FIT_SIGMAS * 0.01`` on
noisy data (its defaults otherwise: DAQP, the uniqueness test of the flag ``observable``).

For every active step the window the observer solved is also posed from the plant data in
gurobipy (:mod:`benchmarks.mhe_peers`: big-M, one thread, MIPGap 0, MIPGapAbs 0, IntFeasTol and
FeasibilityTol 1e-9; built afresh per window, its build time reported apart).  Recorded per run:
the observer's median / p95 / max ``Estimate.seconds`` (which includes its uniqueness program,
which Gurobi does not solve), Gurobi's median ``Runtime`` (``solver_seconds``) and wall time
including the model build, the ratio ``observer median / Gurobi median runtime`` (target <= 1 at
T = 10 noisy; T = 3: stay ahead), the flag counts (target: no ``fallback``) with the reasons of
any fallback, and the optimum agreement on every window: the observer's certified cost against
Gurobi's cost recomputed in numpy at its point (``|a - b| <= AGREE_RTOL max(a, b) + AGREE_ATOL``,
the observer's certified relative gap); a disagreement is decided by the exact enumeration of
``tests/mhe_exact_reference.py`` (Clarabel node QPs, KKT-polished) and recorded.
"""

from __future__ import annotations

import argparse
import collections
import json
import os
import sys
import time
from pathlib import Path

import numpy as np

from hybobs_opt.defaults import NOISE_FIT_SIGMAS
from hybobs_opt.mhe.mld import big_m_constants
from hybobs_opt.mhe.observer import MHEObserver
from hybobs_opt.studies.registry import get_example

from ._machine import git_state, json_default, machine, versions
from .mhe_peers import PeerWindow, gurobi_available, solve_window_gurobi

RESULTS = Path(__file__).resolve().parent / "results"
NOISE = 0.01
#: Agreement of two optima: the observer's certified relative gap (MHE_CERTIFIED_RTOL) plus an
#: absolute floor far below the noise level's cost (1e-4 per sample at std 0.01).
AGREE_RTOL = 1e-6
AGREE_ATOL = 1e-12


def log(msg: str) -> None:
    print(f"[bench_mhe_peers] {msg}", file=sys.stderr, flush=True)


def _exact(plant, U, Y):
    """The exact optimum of a disputed window (tests/mhe_exact_reference.py), or an error string."""
    try:
        root = Path(__file__).resolve().parents[1]
        if str(root) not in sys.path:
            sys.path.insert(0, str(root))
        from tests.mhe_exact_reference import ExactWindowReference

        ref = ExactWindowReference(plant, U.shape[0]).solve(U, Y, bound_prune=True)
        return {"optimum": ref.optimum, "modes": None if ref.modes is None else list(ref.modes),
                "seconds": ref.seconds, "n_unpolished_near": ref.n_unpolished_near}
    except Exception as exc:  # the reference is a referee: its failure is recorded, not raised
        return {"error": f"{type(exc).__name__}: {exc}"}


def run(plant, peer: PeerWindow | None, T: int, U, Y, noisy: bool, bm, x0) -> dict:
    """Step the observer over ``U, Y``; Gurobi on each active step's window."""
    obs = MHEObserver(plant, T=T, norm="2", big_m=bm, x0=x0,
                      fit_tolerance=NOISE_FIT_SIGMAS * NOISE if noisy else None)
    secs, g_run, g_wall, g_build = [], [], [], []
    flags, solved_by, reasons = collections.Counter(), collections.Counter(), collections.Counter()
    agree = {"windows": 0, "agree": 0, "disagree": [], "not_compared": 0, "max_rel_diff": 0.0}
    uq_secs, pfx_nodes = [], []
    for k in range(len(U)):
        est = obs.step(U[k], Y[k])
        if k < T - 1:
            continue
        info = est.info
        secs.append(est.seconds)
        flags[est.flag] += 1
        solved_by[str(info.get("solved_by"))] += 1
        if est.flag == "fallback":
            reasons[str(info.get("reason"))[:160]] += 1
        uq = info.get("uniqueness")
        if isinstance(uq, dict) and uq.get("seconds") is not None:
            uq_secs.append(float(uq["seconds"]))
        ps = info.get("solver_prefix_search")
        if isinstance(ps, dict):
            pfx_nodes.append(int(ps.get("nodes", 0)))
        if peer is None:
            continue
        w = slice(k - T + 1, k + 1)
        g = solve_window_gurobi(peer, U[w], Y[w], "2")
        agree["windows"] += 1
        if g.status != "optimal" or not info.get("certified_optimum"):
            agree["not_compared"] += 1
            agree.setdefault("not_compared_detail", []).append({"step": k, "gurobi": g.status, "reason": g.reason,
                                                               "observer_certified": info.get("certified_optimum")})
            continue
        g_run.append(g.solver_seconds)
        g_wall.append(g.wall_seconds)
        g_build.append(g.build_seconds)
        a, b = float(info["cost"]), float(g.cost)
        diff = abs(a - b)
        agree["max_rel_diff"] = max(agree["max_rel_diff"], diff / max(a, b, 1e-300))
        if diff <= AGREE_RTOL * max(a, b) + AGREE_ATOL:
            agree["agree"] += 1
        else:
            ref = _exact(plant, np.asarray(U[w]), np.asarray(Y[w]))
            agree["disagree"].append({"step": k, "observer": a, "gurobi": b, "gurobi_objective": g.optimum,
                                      "observer_modes": list(map(int, info.get("modes", []))),
                                      "gurobi_modes": list(g.modes), "exact_reference": ref})
    secs = np.array(secs)
    out = {"T": T, "noisy": noisy, "steps": int(secs.size), "median_step_s": float(np.median(secs)),
           "p95_step_s": float(np.percentile(secs, 95)), "max_step_s": float(secs.max()),
           "flags": dict(flags), "fallback_reasons": dict(reasons), "solved_by": dict(solved_by),
           "uniqueness_median_s": float(np.median(uq_secs)) if uq_secs else None,
           "prefix_nodes_median": float(np.median(pfx_nodes)) if pfx_nodes else None,
           "prefix_nodes_max": int(max(pfx_nodes)) if pfx_nodes else None}
    if peer is not None and g_run:
        out["gurobi"] = {"median_runtime_s": float(np.median(g_run)), "p95_runtime_s": float(np.percentile(g_run, 95)),
                         "median_wall_s": float(np.median(g_wall)), "median_build_s": float(np.median(g_build)),
                         "windows": len(g_run)}
        out["ratio_median_to_gurobi_runtime"] = out["median_step_s"] / out["gurobi"]["median_runtime_s"]
        out["ratio_median_to_gurobi_wall"] = out["median_step_s"] / out["gurobi"]["median_wall_s"]
    out["agreement"] = agree
    return out


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_mhe_peers", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a few steps per run; results in results/quick/")
    parser.add_argument("--steps", type=int, default=None, help="active steps per run (default 200; quick 12)")
    parser.add_argument("--only", choices=("T10", "T3"), default=None, help="one part only")
    args = parser.parse_args(argv)
    steps = args.steps or (12 if args.quick else 200)
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()
    ex = get_example("powertrain3")
    plant = ex.build()
    trace = ex.scenario(plant)
    first = 500
    U, Y = trace.u[first:first + 2000], trace.y[first:first + 2000]
    rng = np.random.default_rng(0)
    Y_noisy = Y + NOISE * rng.normal(size=Y.shape)
    bm = big_m_constants(plant)
    have = gurobi_available()
    peer = PeerWindow(plant) if have else None
    record = {"benchmark": "mhe_peers", "quick": args.quick, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
              "machine": machine(), "git": git_state("hybobs_opt/mhe"),
              "versions": versions(("hybobs_opt", "numpy", "scipy", "daqp", "gurobipy", "clarabel")),
              "peer": "gurobi" if have else "not installed",
              "scenario": {"example": "powertrain3", "model": "paper 002, eq. (16)", "first_sample": first,
                           "noise_std_rad_s": NOISE, "seed": 0, "active_steps_per_run": steps,
                           "observer_x0": "the true state at the first sample"},
              "agreement_tolerance": {"rtol": AGREE_RTOL, "atol": AGREE_ATOL},
              "targets": {"T10_noisy_ratio_median": 1.0, "T10_noisy_fallback": 0, "T3_ratio": "< 1 (stay ahead)"},
              "notes": "observer seconds include its uniqueness program (Gurobi solves eq. (10) only); ratios use "
                       "Gurobi's own Runtime (the stricter figure) and its wall time including the model build",
              "runs": {}}
    parts = [("miqp_T10_noisy", 10, True), ("miqp_T3_clean", 3, False), ("miqp_T3_noisy", 3, True)]
    for key, T, noisy in parts:
        if args.only and not key.startswith(f"miqp_{args.only}_"):
            continue
        n = steps + T - 1
        log(f"{key}: {steps} active steps ...")
        t0 = time.perf_counter()
        try:
            res = run(plant, peer, T, U[:n], (Y_noisy if noisy else Y)[:n], noisy, bm, trace.x[first])
        except Exception as exc:  # one failing part must not hide the others
            res = {"error": f"{type(exc).__name__}: {exc}"}
        res["wall_seconds"] = time.perf_counter() - t0
        record["runs"][key] = res
        log(f"{key}: " + json.dumps({k: res.get(k) for k in ("median_step_s", "ratio_median_to_gurobi_runtime",
                                                                 "flags", "error")}, default=json_default)
            + f" gurobi {res.get('gurobi', {}).get('median_runtime_s')} agree "
            + json.dumps({k: v for k, v in res.get("agreement", {}).items() if k != "not_compared_detail"},
                         default=json_default)[:400])
    record["machine"]["load_average_at_end"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    record["seconds_total"] = time.perf_counter() - t_start
    path = out_dir / "mhe_peers.json"
    if args.only and path.exists():
        # one part re-run: the other parts' records are kept, this run's record is kept beside them
        old = json.loads(path.read_text())
        old.setdefault("rerun", {})[args.only] = {k: record[k] for k in ("created", "machine", "git", "versions",
                                                                        "seconds_total")}
        old["runs"].update(record["runs"])
        total, record = record["seconds_total"], old
        record["rerun"][args.only]["seconds_total"] = total
    path.write_text(json.dumps(record, indent=2, default=json_default) + "\n")
    log(f"wrote {path} ({time.perf_counter() - t_start:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

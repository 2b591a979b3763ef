"""Issue 18, "The MHE formulated in CasADi": per-step time of the default observer before and after.

Run ``python -m benchmarks.bench_mhe_formulation`` (full) or ``--quick`` (smoke test).  Writes
``benchmarks/results/mhe_formulation.json`` (quick runs: ``benchmarks/results/quick/``).

The same runs on two source trees in one session: the commit before the problem was written in
CasADi (``--before``, default ``02f51b1``, extracted with ``git archive`` into a temporary
directory) and the working tree (``after``).  Each run is a fresh subprocess (the source tree
first on ``sys.path``, checked), alternating before / after ``--repeats`` times so that the load
of a shared machine hits both alike.

Scenario: model (16) (example ``powertrain3``, paper 002), the noisy data of
``benchmarks/bench_mhe.py``: samples 500.. of the scenario with output noise 0.01 rad/s (seeded),
``fit_tolerance = NOISE_FIT_SIGMAS * 0.01``, ``x0`` the true initial state.  Observers: the
default one (norm 2, DAQP, uniqueness test on) at T = 3 and T = 10, plus norms 1 and inf at
T = 3.  Per run: the median, 95th percentile and maximum of ``Estimate.seconds`` over the active
steps, the flag counts and the estimates; the JSON compares the estimates of the two trees
(same flags, largest state difference) and gives the ratio after / before of the medians.
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
RESULTS = ROOT / "benchmarks" / "results"
BEFORE = "02f51b1"
NOISE = 0.01
FIRST = 500


def log(msg: str) -> None:
    print(f"[bench_mhe_formulation] {msg}", file=sys.stderr, flush=True)


def worker(src: str, T: int, norm: str, steps: int) -> dict:
    """One run on the source tree ``src`` (this function only imports hybobs_opt from it)."""
    sys.path.insert(0, src)
    import hybobs_opt
    from hybobs_opt.defaults import NOISE_FIT_SIGMAS
    from hybobs_opt.mhe import MHEObserver
    from hybobs_opt.studies.registry import get_example

    if not str(Path(hybobs_opt.__file__).resolve()).startswith(str(Path(src).resolve())):
        raise RuntimeError(f"hybobs_opt imported from {hybobs_opt.__file__}, not {src}")
    ex = get_example("powertrain3")
    plant = ex.build()
    trace = ex.scenario(plant)
    U, Y, X = trace.u[FIRST:FIRST + steps], trace.y[FIRST:FIRST + steps], trace.x[FIRST:FIRST + steps]
    Y = Y + NOISE * np.random.default_rng(0).normal(size=Y.shape)
    t0 = time.perf_counter()
    obs = MHEObserver(plant, T, norm=norm, x0=X[0], fit_tolerance=NOISE_FIT_SIGMAS * NOISE)
    build_s = time.perf_counter() - t0
    secs, flags, xs = [], [], []
    for k in range(len(U)):
        est = obs.step(U[k], Y[k])
        secs.append(est.seconds)
        flags.append(est.flag)
        xs.append(np.asarray(est.x, dtype=float).tolist())
    active = np.array(secs[T - 1:])
    return {"module": hybobs_opt.__file__, "build_s": build_s, "median_step_s": float(np.median(active)),
            "p95_step_s": float(np.percentile(active, 95)), "max_step_s": float(active.max()),
            "steps": int(active.size), "flags": flags, "x": xs}


def run(src: str, T: int, norm: str, steps: int) -> dict:
    env = dict(os.environ, PYTHONPATH=src)
    cmd = [sys.executable, str(Path(__file__).resolve()), "--worker", src, str(T), norm, str(steps)]
    out = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if out.returncode != 0:
        raise RuntimeError(f"worker failed ({src}, T={T}, norm {norm}):\n{out.stderr[-3000:]}")
    return json.loads(out.stdout.splitlines()[-1])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_mhe_formulation",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short runs (smoke test); results in results/quick/")
    parser.add_argument("--before", default=BEFORE, help="commit of the 'before' tree (default %(default)s)")
    parser.add_argument("--repeats", type=int, default=2, help="alternating before/after runs per configuration")
    parser.add_argument("--worker", nargs=4, metavar=("SRC", "T", "NORM", "STEPS"), help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    if args.worker:
        src, T, norm, steps = args.worker
        print(json.dumps(worker(src, int(T), norm, int(steps))))
        return 0
    sys.path.insert(0, str(ROOT))
    from benchmarks._machine import json_default, machine, versions

    quick = args.quick
    out_dir = RESULTS / "quick" if quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    after_commit = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", "HEAD"], capture_output=True,
                                  text=True).stdout.strip()
    dirty = subprocess.run(["git", "-C", str(ROOT), "status", "--porcelain", "--", "hybobs_opt/mhe"],
                           capture_output=True, text=True).stdout.strip()
    configs = [(3, "2", 60 if quick else 400), (10, "2", 20 if quick else 40),
               (3, "1", 60 if quick else 400), (3, "inf", 60 if quick else 400)]
    record: dict = {"benchmark": "mhe_formulation", "quick": quick, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                    "machine": machine(), "versions": versions(("hybobs_opt", "numpy", "daqp", "highspy", "casadi")),
                    "before_commit": args.before, "after_commit": after_commit,
                    "after_tree_has_uncommitted_mhe_changes": bool(dirty),
                    "scenario": {"example": "powertrain3", "model": "paper 002, eq. (16)", "first_sample": FIRST,
                                 "noise_std_rad_s": NOISE, "noise_seed": 0},
                    "notes": "Estimate.seconds per step (the solve, verification, uniqueness test, propagation); "
                             "medians over the active steps of each run, then the median over the repeats. "
                             "ratio = after / before (target <= 1.2). same_flags / max_x_difference compare the "
                             "estimates of the two trees step by step.",
                    "runs": {}}
    with tempfile.TemporaryDirectory() as tmp:
        arch = subprocess.run(["git", "-C", str(ROOT), "archive", args.before, "hybobs_opt"], capture_output=True,
                              check=True)
        subprocess.run(["tar", "-x", "-C", tmp], input=arch.stdout, check=True)
        trees = {"before": tmp, "after": str(ROOT)}
        for T, norm, steps in configs:
            key = f"norm{norm}_T{T}"
            res = {"before": [], "after": []}
            for rep in range(args.repeats):
                for name in ("before", "after") if rep % 2 == 0 else ("after", "before"):
                    log(f"{key} {name} (repeat {rep + 1}/{args.repeats}, {steps} steps) ...")
                    res[name].append(run(trees[name], T, norm, steps))
            b, a = res["before"][0], res["after"][0]
            same = b["flags"] == a["flags"]
            both_obs = [k for k, (fb, fa) in enumerate(zip(b["flags"], a["flags"])) if fb == fa]
            dx = float(np.max(np.abs(np.array(b["x"])[both_obs] - np.array(a["x"])[both_obs]), initial=0.0))
            med = {name: float(np.median([r["median_step_s"] for r in res[name]])) for name in res}
            record["runs"][key] = {
                "T": T, "norm": norm, "steps": a["steps"],
                "median_step_s_before": med["before"], "median_step_s_after": med["after"],
                "ratio_after_over_before": med["after"] / med["before"],
                "median_step_s_per_repeat": {n: [r["median_step_s"] for r in res[n]] for n in res},
                "p95_step_s": {n: [r["p95_step_s"] for r in res[n]] for n in res},
                "max_step_s": {n: [r["max_step_s"] for r in res[n]] for n in res},
                "build_s": {n: [r["build_s"] for r in res[n]] for n in res},
                "flag_counts": {n: {f: res[n][0]["flags"].count(f) for f in sorted(set(res[n][0]["flags"]))}
                                for n in res},
                "same_flags": same, "steps_with_different_flags": int(sum(fb != fa for fb, fa in
                                                                          zip(b["flags"], a["flags"]))),
                "max_x_difference_same_flag_steps": dx,
            }
            log(f"{key}: median before {med['before'] * 1e3:.3f} ms, after {med['after'] * 1e3:.3f} ms, "
                f"ratio {med['after'] / med['before']:.3f}, same flags {same}, max |dx| {dx:.3g}")
    path = out_dir / "mhe_formulation.json"
    path.write_text(json.dumps(record, indent=2, default=json_default) + "\n")
    log(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

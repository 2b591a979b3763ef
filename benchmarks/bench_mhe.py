"""Benchmark of the moving-horizon observer (10) of paper 002 (MIQP / MILP), Section 7.

Run ``python -m benchmarks.bench_mhe`` (full, a few minutes) or ``--quick`` (smoke test, well under
a minute).  Writes ``benchmarks/results/mhe.json`` (quick runs: ``benchmarks/results/quick/``).

Per-step compute time (median, 95th percentile, maximum of :meth:`Observer.step`, which includes
building the window's data, the solve, its verification and the propagation to the current time)
over the powertrain3 scenario (model (16), noise-free, three backlash traversals), for

(a) MIQP (2-norm), T = 3, DAQP branch-and-bound (target 0.5 ms; paper: 3 s for a single instance);
(b) MIQP, T = 10 (target 30 ms);
(c) MILP, 1-norm and inf-norm, T = 3, HiGHS (target 15 ms; the paper gives no figure for them);

each in its default configuration (a warm start of zero cost is accepted as the optimum, since
the cost is nonnegative) and with the branch-and-bound forced at every step
(``MHESettings(zero_cost_certificate=False)``), plus a noisy run (output noise 0.01 rad/s) where the warm start
rarely has zero cost.  For every run: the solver, how each step was certified
(``solved_by``), the flag counts, the largest state error at steps whose window starts in an
observable state, and the ratio to the paper's 3 s and to the lookup observer's per-step time
measured in the same run.
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
from hybobs_opt.mhe import MHESettings
from hybobs_opt.mhe.observer import MHEObserver
from hybobs_opt.studies.registry import get_example

from ._machine import machine, versions, json_default

RESULTS = Path(__file__).resolve().parent / "results"

#: Paper 002, Section 7: "The maximal time for running a single instance of the observer is 3 sec."
PAPER_MIQP_T3_SECONDS = 3.0
#: Paper 002, Section 7: the lookup observer's maximal time per instance (31 ms).
PAPER_LOOKUP_SECONDS = 0.031
#: Targets of the issue (seconds per step, medians), recorded in the JSON, never asserted.
TARGETS = {"miqp_T3": 5e-4, "miqp_T10": 0.030, "milp1_T3": 0.015, "milpinf_T3": 0.015}
#: Output noise of the noisy runs (rad/s on the engine speed).
NOISE = 0.01


def log(msg: str) -> None:
    print(f"[bench_mhe] {msg}", file=sys.stderr, flush=True)


def _machine() -> dict:
    return machine()


def _versions() -> dict:
    return versions(("hybobs_opt", "numpy", "scipy", "daqp", "highspy", "casadi"))


def run_observer(obs: MHEObserver, U: np.ndarray, Y: np.ndarray, X: np.ndarray, observable: np.ndarray | None) -> dict:
    """Step ``obs`` over the data; per-step timing, certification and error summary."""
    secs = np.empty(len(U))
    useconds = []  # the uniqueness program's share of each step (issue: reported separately)
    flags = collections.Counter()
    solved = collections.Counter()
    err_obs = 0.0
    half = obs.system.scales()[0][: obs.n]
    for k in range(len(U)):
        est = obs.step(U[k], Y[k])
        secs[k] = est.seconds
        uq = est.info.get("uniqueness") if isinstance(est.info, dict) else None
        if isinstance(uq, dict) and uq.get("seconds") is not None:
            useconds.append(float(uq["seconds"]))
        flags[est.flag] += 1
        if est.flag == "observable":
            solved[est.info.get("solved_by", "?")] += 1
            if observable is not None and observable[k]:
                err_obs = max(err_obs, float(np.max(np.abs(est.x - X[k]) / half)))
    active = secs[obs.T - 1:]  # the warm-up steps do not solve anything
    out = {
        "solver": obs.solver,
        "T": obs.T,
        "norm": obs.norm,
        "steps": int(active.size),
        "median_step_s": float(np.median(active)),
        "p95_step_s": float(np.percentile(active, 95)),
        "max_step_s": float(active.max()),
        "flags": dict(flags),
        "solved_by": dict(solved),
        "uniqueness_steps": len(useconds),
        "uniqueness_median_s": float(np.median(useconds)) if useconds else None,
        "uniqueness_p95_s": float(np.percentile(useconds, 95)) if useconds else None,
    }
    if observable is not None:
        out["max_scaled_error_observable_windows"] = err_obs
        out["n_observable_windows"] = int(observable.sum())
    return out


def bench_lookup(plant, U: np.ndarray, Y: np.ndarray, T: int) -> dict:
    """Per-step time of the lookup observer (Algorithm 4.1) on the same data, for the ratios."""
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.regions import analyse_observability

    obs = LookupObserver(analyse_observability(plant, T))
    secs = np.array([obs.step(U[k], Y[k]).seconds for k in range(len(U))])[T - 1:]
    return {"median_step_s": float(np.median(secs)), "p95_step_s": float(np.percentile(secs, 95)),
            "max_step_s": float(secs.max()), "steps": int(secs.size), "paper_seconds": PAPER_LOOKUP_SECONDS}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_mhe", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="tiny versions (smoke test); results in results/quick/")
    args = parser.parse_args(argv)
    quick = args.quick
    out_dir = RESULTS / "quick" if quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    t_start = time.perf_counter()

    ex = get_example("powertrain3")
    plant = ex.build()
    trace = ex.scenario(plant)
    # 2000 steps (full) around the three backlash traversals; 150 steps (quick) around the first
    first, stop = (950, 1100) if quick else (500, 2500)
    U, Y, X = trace.u[first:stop], trace.y[first:stop], trace.x[first:stop]
    noisy_stop = first + (60 if quick else 400)
    # the noisy T = 10 MIQP runs the branch-and-bound nearly every step (0.1 s to seconds each)
    noisy_T10_stop = first + (40 if quick else 150)
    rng = np.random.default_rng(0)
    Y_noisy = Y + NOISE * rng.normal(size=Y.shape)
    bm = big_m_constants(plant)

    record: dict = {
        "benchmark": "mhe",
        "quick": quick,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": _machine(),
        "versions": _versions(),
        "scenario": {"example": "powertrain3", "model": "paper 002, eq. (16), Table 1", "first_sample": first,
                     "samples": stop - first, "noisy_samples": noisy_stop - first,
                     "noisy_samples_T10": noisy_T10_stop - first, "noise_std_rad_s": NOISE,
                     "q_changes": int(np.count_nonzero(np.diff(trace.q[first:stop])))},
        "paper_002": {"miqp_T3_max_seconds": PAPER_MIQP_T3_SECONDS, "lookup_max_seconds": PAPER_LOOKUP_SECONDS,
                      "machine": "Matlab 6.5.1, Pentium 4 2.4 GHz"},
        "targets_median_s": TARGETS,
        "notes": "per-step times of Observer.step (seconds); medians over the active steps; the machine may be "
                 "shared (see load_average). ratio_to_paper = median / 3 s (the paper's MIQP figure, a maximum); "
                 "solved_by: 'warm start' = zero-cost warm start accepted (the cost is >= 0), "
                 "'branch-and-bound' = the solver's point, 'branch-and-bound (incumbent)' = the solver proved the "
                 "warm start optimal. max_scaled_error_observable_windows: largest |x^ - x| / half-width of X at "
                 "steps whose window starts in an observable state (noise-free runs). 'observable' means the "
                 "uniqueness program proved no window-start state MHE_UNIQUENESS_DELTA away fits within epsilon; "
                 "uniqueness_median_s / _p95_s: that program's own time per step; *_no_uniqueness: the same "
                 "observer with check_uniqueness=False (the old flag, a certified optimum only).",
        "runs": {},
    }
    from hybobs_opt.regions import analyse_observability

    # Algorithm 3.1 at T = 10 enumerates up to 3^10 mode sequences (minutes, gigabytes): the T = 3
    # analysis decides the T = 10 windows too (observable in 3 steps implies in 10)
    analysis3 = analyse_observability(plant, 3)
    labels = np.array([analysis3.classify(x) == "observable" for x in X])
    observable = {T: np.r_[np.zeros(T - 1, dtype=bool), labels[: len(X) - T + 1]] for T in (3, 10)}
    lookup = bench_lookup(plant, U, Y, 3)
    record["lookup_T3"] = lookup

    configs = [
        ("miqp_T3", dict(T=3, norm="2"), True),
        ("miqp_T3_no_uniqueness", dict(T=3, norm="2", settings=MHESettings(check_uniqueness=False)), True),
        ("miqp_T3_bnb_every_step", dict(T=3, norm="2", settings=MHESettings(zero_cost_certificate=False)), True),
        ("miqp_T10", dict(T=10, norm="2"), True),
        ("miqp_T10_no_uniqueness", dict(T=10, norm="2", settings=MHESettings(check_uniqueness=False)), True),
        ("miqp_T10_bnb_every_step", dict(T=10, norm="2", settings=MHESettings(zero_cost_certificate=False)), True),
        ("milp1_T3", dict(T=3, norm="1"), True),
        ("milp1_T3_bnb_every_step", dict(T=3, norm="1", settings=MHESettings(zero_cost_certificate=False)), True),
        ("milpinf_T3", dict(T=3, norm="inf"), True),
        ("milpinf_T3_bnb_every_step", dict(T=3, norm="inf", settings=MHESettings(zero_cost_certificate=False)), True),
        ("miqp_T3_noisy", dict(T=3, norm="2"), False),
        ("miqp_T10_noisy", dict(T=10, norm="2"), False),
        ("milp1_T3_noisy", dict(T=3, norm="1"), False),
        ("milpinf_T3_noisy", dict(T=3, norm="inf"), False),
    ]
    for key, kw, clean in configs:
        log(f"{key} ...")
        t0 = time.perf_counter()
        try:
            obs = MHEObserver(plant, big_m=bm, x0=X[0], **kw,
                              fit_tolerance=None if clean else NOISE_FIT_SIGMAS * NOISE)
            if clean:
                res = run_observer(obs, U, Y, X, observable[kw["T"]])
            else:
                n = (noisy_T10_stop if kw["T"] == 10 else noisy_stop) - first
                res = run_observer(obs, U[:n], Y_noisy[:n], X[:n], None)
            res["ratio_to_paper_3s"] = res["median_step_s"] / PAPER_MIQP_T3_SECONDS
            res["ratio_to_lookup_median"] = res["median_step_s"] / lookup["median_step_s"]
            base = key.replace("_bnb_every_step", "").replace("_no_uniqueness", "")
            if clean and base in TARGETS:
                res["target_median_s"] = TARGETS[base]
                res["meets_target"] = bool(res["median_step_s"] <= TARGETS[base])
            res["wall_seconds"] = time.perf_counter() - t0
        except Exception as exc:  # one failing configuration must not hide the others
            res = {"error": f"{type(exc).__name__}: {exc}"}
        record["runs"][key] = res
        log(f"{key}: {json.dumps({k: res.get(k) for k in ('median_step_s', 'p95_step_s', 'max_step_s', 'solved_by', 'error')})}")
    record["machine"]["load_average_at_end"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    record["seconds_total"] = time.perf_counter() - t_start
    path = out_dir / "mhe.json"
    path.write_text(json.dumps(record, indent=2, default=json_default) + "\n")
    log(f"wrote {path} ({record['seconds_total']:.0f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())

"""Issue 18, "Unknown backlash gap": the gap of model (16) hidden from the observer.

Run ``python -m benchmarks.bench_unknown_gap`` (about a minute) or ``--quick`` (results in
``benchmarks/results/quick/``).  Writes ``benchmarks/results/unknown_gap.json``: the table of
:func:`hybobs_opt.studies.paper002_powertrain.unknown_gap.run_unknown_gap_study` (10 gaps drawn in
[0.02, 0.08] rad, a bank of 31 lookup observers over the interval, the bench scenario noise-free)
-- the estimate after the first backlash crossing, its relative error and spread, the state
errors -- and, as the measured reason the MIQP with the gap as a decision variable is not the
estimator here, one window of that MIQP (the augmented system of
:func:`hybobs_opt.systems.parameters.augment_parameters`) at T = 20, still far shorter than a
traversal of the gap (50-120 samples on this scenario), timed with its certification status.

Section ``interval``: the interval of gaps certified under bounded noise by the set-membership
filter on the augmented system (:func:`~hybobs_opt.studies.paper002_powertrain.unknown_gap.run_gap_interval_study`),
4 hidden gaps drawn in [0.02, 0.08] rad, the whole scenario, the engine speed measured within
1e-3 rad/s (uniform noise at the bound, and Gaussian noise with the bound at 5 sigma): the steps
where a true state or the gap lies outside the reported box (must be 0), the final interval, when it
came within 1 % of the gap, the flags and the twist's error against its radius where flagged.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from hybobs_opt.studies.paper002_powertrain.unknown_gap import (GAP_INTERVAL, GAP_STUDY_THETA_MAX, run_gap_interval_study,
                                                                run_unknown_gap_study)

from ._machine import json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"


def augmented_mhe_window(T: int, start: int = 1000, alpha: float = 0.037) -> dict:
    """One window of the MIQP (10) on model (16) augmented with alpha, from the scenario's first switch."""
    from hybobs_opt.mhe import MHEObserver, MHESettings
    from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario, powertrain3
    from hybobs_opt.systems.parameters import augment_parameters

    aug = augment_parameters(lambda alpha: powertrain3(alpha=alpha, theta_max=GAP_STUDY_THETA_MAX), {"alpha": (0.02, 0.08)})
    plant = powertrain3(alpha=alpha, theta_max=GAP_STUDY_THETA_MAX)
    trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=(start + T + 1) * plant.Ts)
    t0 = time.perf_counter()
    obs = MHEObserver(aug.system, T, settings=MHESettings(check_uniqueness=False))
    build_s = time.perf_counter() - t0
    t0 = time.perf_counter()
    res = obs.solve_window(trace.u[start : start + T], trace.y[start : start + T])
    return {"T": T, "window_start": start, "alpha": alpha, "build_seconds": build_s,
            "solve_seconds": time.perf_counter() - t0, "status": str(getattr(res, "status", res)),
            "modes_in_window": [int(q) for q in trace.q[start : start + T]]}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_unknown_gap", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="2 gaps, 1,500 samples, no MIQP window; results in results/quick/")
    args = parser.parse_args(argv)
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()

    def progress(what: str, done: int, total: int) -> None:
        print(f"[bench_unknown_gap] {done}/{total} {what} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)

    table = run_unknown_gap_study(2 if args.quick else 10, 1500 if args.quick else 3000, progress=progress)
    gaps = np.random.default_rng(11).uniform(*GAP_INTERVAL, 1 if args.quick else 4)
    interval = {noise: run_gap_interval_study(gaps, 1300 if args.quick else 3000, 1e-3, noise=noise, seed=3,
                                              progress=progress)
                for noise in ("uniform", "gaussian")}
    record = {
        "benchmark": "unknown_gap",
        "issue": 18,
        "quick": args.quick,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": machine(),
        "versions": versions(("hybobs_opt", "numpy", "scipy", "daqp", "numba")),
        "table": table,
        "interval": interval,
        "augmented_miqp_window": None if args.quick else augmented_mhe_window(20),
        "seconds": None,
    }
    record["seconds"] = time.perf_counter() - t0
    path = out_dir / "unknown_gap.json"
    path.write_text(json.dumps(record, indent=1, default=json_default) + "\n")
    print(f"[bench_unknown_gap] wrote {path} in {record['seconds']:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Lookup-table deadbeat observer (paper 002, Algorithm 4.1): per-step time and batch throughput.

Writes ``benchmarks/results/lookup.json``.  Targets (issue 4): at most 10 us per ``step``
(paper: 31 ms in Matlab on a 2.4 GHz Pentium 4) and at least 300,000 steps/s for ``run``.
"""

from __future__ import annotations

import argparse
import json
import platform
import statistics
import time
from pathlib import Path

import numpy as np

RESULTS = Path(__file__).resolve().parent / "results"
PAPER_STEP_S = 0.031


def main(argv: list[str] | None = None) -> int:
    from hybobs_opt.observers.bench import bench_trace, timed_steps
    from hybobs_opt.observers.lookup import LookupObserver

    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_lookup")
    parser.add_argument("--quick", action="store_true", help="small smoke run")
    args = parser.parse_args(argv)
    steps = 1000 if args.quick else 3000
    repeats = 2 if args.quick else 5
    plant, trace, y, analysis = bench_trace("powertrain3", 3, steps, 0.0)
    obs = LookupObserver(analysis)
    obs.run(trace.u[:10], y[:10])  # load the compiled kernels
    step_medians, batch_rates = [], []
    U_long, Y_long = np.tile(trace.u, (100, 1)), np.tile(y, (100, 1))
    for _ in range(repeats):
        out = timed_steps(obs, trace.u, y)
        step_medians.append(float(np.median(out.seconds)))
        t0 = time.perf_counter()
        obs.run(U_long, Y_long)
        batch_rates.append(U_long.shape[0] / (time.perf_counter() - t0))
    flagged = out.flags == "observable"
    rel = np.abs(out.x_hat[flagged] - trace.x[flagged]) / np.maximum(1.0, np.abs(trace.x[flagged]))
    step_s = statistics.median(step_medians)
    record = {
        "benchmark": "lookup observer, model (16), T = 3, noise-free scenario",
        "steps_per_repeat": steps,
        "repeats": repeats,
        "median_step_s": step_s,
        "step_target_s": 10e-6,
        "step_target_met": step_s <= 10e-6,
        "paper_step_s": PAPER_STEP_S,
        "ratio_to_paper": step_s / PAPER_STEP_S,
        "batch_steps_per_s_median": statistics.median(batch_rates),
        "batch_target_steps_per_s": 300_000,
        "batch_target_met": statistics.median(batch_rates) >= 300_000,
        "batch_steps_per_run": int(U_long.shape[0]),
        "n_flagged_observable": int(flagged.sum()),
        "max_relative_error_flagged_observable": float(rel.max()),
        "machine": {"platform": platform.platform(), "python": platform.python_version()},
    }
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "lookup.json").write_text(json.dumps(record, indent=2))
    print(json.dumps(record, indent=2))
    return 0


if __name__ == "__main__":
    main()

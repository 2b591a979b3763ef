"""Issue 18, "Noisy sensors": the observers of paper 002 on noisy data against a Kalman filter.

Run ``python -m benchmarks.bench_noise`` (full, a few minutes) or ``--quick`` (smoke test, results in
``benchmarks/results/quick/``).  Writes ``benchmarks/results/noise.json``: the table of
:func:`hybobs_opt.studies.paper002_powertrain.noise.run_noise_study` on the bench scenario of
model (16) (3,000 samples of 1 ms) with output noise of 0.001, 0.01 and 0.1 rad/s on the engine
speed -- RMS error per state over the truly observable samples and over the flagged ones, flag
counts, per-step compute time (median / p95 / max over ``step`` calls), and for the observers
that state a covariance (noise-aware lookup, Kalman filter) the largest Mahalanobis distance of a
flagged estimate's error -- plus a check of the issue's criterion at 0.01 rad/s: no window flagged
observable by the noise-aware lookup with an error beyond 5 sigma of its stated covariance.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

from hybobs_opt.studies.paper002_powertrain.noise import COVARIANCE_SIGMAS, NOISE_LEVELS, run_noise_study

from ._machine import json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_noise", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="300 samples, MHE on 100 (smoke test); results in results/quick/")
    parser.add_argument("--mhe-steps", type=int, default=None, help="samples given to the MIQP observers (default: all)")
    args = parser.parse_args(argv)
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    steps = 300 if args.quick else 3000
    mhe_steps = 100 if args.quick else args.mhe_steps
    t0 = time.perf_counter()

    def progress(what: str, done: int, total: int) -> None:
        print(f"[bench_noise] {done}/{total} {what} ({time.perf_counter() - t0:.0f} s)", file=sys.stderr, flush=True)

    table = run_noise_study("powertrain3", NOISE_LEVELS, steps, mhe_steps=mhe_steps, progress=progress)
    key = f"n_flagged_beyond_{COVARIANCE_SIGMAS:g}_sigma"
    criterion = {}
    for level in table["levels"]:
        for name, rec in level["observers"].items():
            if name.startswith("lookup-noise") or name == "miqp-kalman":
                criterion[f"{name} at {level['noise']:g}"] = {key: rec.get(key, 0),
                                                              "max_mahalanobis_flagged": rec.get("max_mahalanobis_flagged"),
                                                              "n_flagged_observable": rec["flags"]["observable"]}
    record = {
        "benchmark": "noise",
        "issue": 18,
        "quick": args.quick,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": machine(),
        "versions": versions(("hybobs_opt", "numpy", "scipy", "daqp", "highspy", "numba")),
        "scenario": {"call": f"run_noise_study('powertrain3', {NOISE_LEVELS}, {steps}, mhe_steps={mhe_steps})",
                     "model": "paper 002, eq. (16)", "noise_on": "engine speed omega_m (rad/s), white Gaussian, seed 0"},
        "criterion_5_sigma": criterion,
        "table": table,
        "seconds": time.perf_counter() - t0,
    }
    path = out_dir / "noise.json"
    path.write_text(json.dumps(record, indent=1, default=json_default) + "\n")
    print(f"[bench_noise] wrote {path} in {record['seconds']:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""Stated covariances against true errors: the moving-horizon observer with the Kalman arrival cost.

Run ``python -m benchmarks.bench_gaussian_consistency`` (about two minutes) or ``--quick``
(results in ``benchmarks/results/quick/``).  Writes
``benchmarks/results/gaussian_consistency.json``: on model (16) of paper 002 (its backlash
scenario, 3,000 samples), the dead-zone spring and the DC motor with piecewise friction of
``tests/canonical.py`` (1,500 samples each), white Gaussian output noise, ``MHEObserver(T=3,
noise_std=..., arrival_weight="kalman")`` told the right noise level and one 10x too small: the
steps flagged ``observable``, the share of their errors beyond 3 and the number beyond 5 and 6
standard deviations of the stated covariance (Mahalanobis distance), and the flags the
noise-consistency test withdrew or withheld, and how many flagged windows several mode sequences
fit (their covariance is the mixture of :mod:`hybobs_opt.mhe.mixture`).  The targets: at least 1,000 flagged, at most 1 %
beyond 3 sigma and none beyond 6 with the right level; none beyond 5 sigma with the wrong one.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

from tests.canonical import noise_study_case

from ._machine import json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"


def run_case(name: str, steps: int, factor: float) -> dict:
    from hybobs_opt import MHEObserver
    from hybobs_opt.contract import OBSERVABLE

    system, U, trace, sigma = noise_study_case(name, steps)
    Y = trace.y + np.random.default_rng(1).normal(size=trace.y.shape) * sigma
    obs = MHEObserver(system, 3, noise_std=sigma / factor, arrival_weight="kalman")
    dist, withdrawn, withheld, flags, several, mix_seconds = [], 0, 0, {}, 0, []
    t0 = time.perf_counter()
    for k in range(steps):
        est = obs.step(U[k], Y[k])
        flags[str(est.flag)] = flags.get(str(est.flag), 0) + 1
        note = est.info.get("note", "")
        withdrawn += note.startswith("flag withdrawn")
        withheld += note.startswith("flag withheld")
        mix = est.info.get("mixture")
        if mix is not None:
            mix_seconds.append(mix["seconds"])
        if est.flag == OBSERVABLE:
            several += mix["n_sequences"] > 1
            d = est.x - trace.x[k]
            dist.append(float(np.sqrt(d @ np.linalg.solve(np.asarray(est.info["covariance"]), d))))
    d = np.array(dist)
    return {"system": name, "samples": steps, "noise_std_true": sigma, "noise_std_stated": sigma / factor,
            "flags": flags, "n_flagged": int(d.size), "share_beyond_3_sigma": float(np.mean(d > 3)) if d.size else None,
            "n_beyond_5_sigma": int(np.sum(d > 5)), "n_beyond_6_sigma": int(np.sum(d > 6)),
            "max_mahalanobis": float(d.max()) if d.size else None, "n_withdrawn_by_consistency_test": withdrawn,
            "n_withheld_until_tested": withheld, "n_flagged_with_several_sequences": several,
            "mixture_seconds_median": float(np.median(mix_seconds)) if mix_seconds else None,
            "seconds": time.perf_counter() - t0}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_gaussian_consistency",
                                     description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="300 samples per case; results in results/quick/")
    args = parser.parse_args(argv)
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    table = []
    for name, steps in (("model16", 3000), ("deadzone_spring", 1500), ("dc_motor", 1500)):
        for factor in (1.0, 10.0):
            rec = run_case(name, 300 if args.quick else steps, factor)
            rec["stated_level"] = "right" if factor == 1.0 else "10x too small"
            table.append(rec)
            print(f"[bench_gaussian_consistency] {name} {rec['stated_level']}: flagged {rec['n_flagged']}, "
                  f"beyond 3 sigma {rec['share_beyond_3_sigma']}, beyond 5 {rec['n_beyond_5_sigma']}, "
                  f"withdrawn {rec['n_withdrawn_by_consistency_test']} ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr, flush=True)
    right = [r for r in table if r["stated_level"] == "right"]
    wrong = [r for r in table if r["stated_level"] != "right"]
    record = {"benchmark": "gaussian_consistency", "quick": args.quick, "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
              "machine": machine(), "versions": versions(("hybobs_opt", "numpy", "scipy", "daqp")), "table": table,
              "targets_met": {"right_level": all(r["n_flagged"] >= 1000 and r["share_beyond_3_sigma"] <= 0.01
                                                 and r["n_beyond_6_sigma"] == 0 for r in right) if not args.quick else None,
                              "wrong_level": all(r["n_beyond_5_sigma"] == 0 for r in wrong)},
              "seconds": time.perf_counter() - t0}
    path = out_dir / "gaussian_consistency.json"
    path.write_text(json.dumps(record, indent=1, default=json_default) + "\n")
    print(f"[bench_gaussian_consistency] wrote {path}", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

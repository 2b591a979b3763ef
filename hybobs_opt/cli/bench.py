"""``hybobs bench EXAMPLE``: the lookup observer against the MIQP/MILP moving-horizon observers
(paper 002, Section 7; the study :mod:`hybobs_opt.studies.paper002_powertrain.bench`).
"""

from __future__ import annotations

import argparse

from ._common import print_json

HELP = "lookup observer vs MIQP/MILP moving-horizon observers (paper 002, Section 7)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("example", help="a PWA example (powertrain3)")
    p.add_argument("--horizon", "-T", type=int, default=3, help="observation horizon T (default 3)")
    p.add_argument("--steps", type=int, default=3000, help="number of samples of the scenario (1 ms each)")
    p.add_argument("--noise", type=float, default=0.0, help="standard deviation of output noise (rad/s)")
    p.add_argument("--observers", default="lookup,miqp,milp", help="comma-separated: lookup, miqp, milp, milp_inf")
    p.add_argument("--mhe-steps", type=int, default=None, help="run the MHE observers on the first N steps only")
    p.add_argument("--seed", type=int, default=0, help="noise seed")
    p.add_argument("--plot", metavar="FILE", help="PNG like the paper's Figs. 7-9")
    p.add_argument("--json", action="store_true", help="machine-readable summary")


def run(args: argparse.Namespace) -> int:
    from ..progress import phase_bars
    from ..studies.paper002_powertrain.bench import run_bench

    observers = [s.strip() for s in args.observers.split(",") if s.strip()]
    progress, close = phase_bars(not args.json)
    try:
        summary = run_bench(args.example, args.horizon, args.steps, args.noise, observers, args.mhe_steps, args.plot,
                            args.seed, progress=progress)
    finally:
        close()
    if args.json:
        print_json(summary)
        return 0
    print(f"{summary['example']}, T = {summary['horizon']}, {summary['steps']} steps, noise {summary['noise']:g}")
    for name, rec in summary["observers"].items():
        err = rec["max_abs_error_observable_all"]
        print(f"  {name:<9} median {1e6 * rec['median_step_s']:9.1f} us  p95 {1e6 * rec['p95_step_s']:9.1f} us  "
              f"flagged unobservable {rec['n_flagged_unobservable']:5d}  max rel. error where flagged observable "
              f"{'n/a' if err is None else f'{err:.2e}'}  [{rec['solver']}]")
    if "note" in summary:
        print("note:", summary["note"])
    return 0

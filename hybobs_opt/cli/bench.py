"""``hybobs bench SYSTEM``: the lookup observer against the MIQP/MILP moving-horizon observers on
the same data: the paper's scenario for the powertrain examples (paper 002, Section 7; the study
:mod:`hybobs_opt.studies.paper002_powertrain.bench`), or a recorded CSV log of any PWA system
(``--data LOG.csv``).
"""

from __future__ import annotations

import argparse

from ..errors import ModelError
from ._common import add_system_argument, load_system, print_json

HELP = "lookup observer vs MIQP/MILP moving-horizon observers on one scenario or CSV log (paper 002, Section 7)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--horizon", "-T", type=int, default=3, help="observation horizon T (default 3)")
    p.add_argument("--data", metavar="LOG.csv", help="compare the observers on this recorded log (any PWA system)")
    p.add_argument("--regions", metavar="FILE", help="with --data: saved analysis for the lookup observer")
    p.add_argument("--steps", type=int, default=3000, help="number of samples of the scenario (1 ms each)")
    p.add_argument("--noise", type=float, default=0.0, help="standard deviation of output noise (rad/s)")
    p.add_argument("--observers", default="lookup,miqp,milp", help="comma-separated: lookup, miqp, milp, milp_inf")
    p.add_argument("--mhe-steps", type=int, default=None, help="run the MHE observers on the first N steps only")
    p.add_argument("--seed", type=int, default=0, help="noise seed")
    p.add_argument("--plot", metavar="FILE", help="PNG like the paper's Figs. 7-9")
    p.add_argument("--json", action="store_true", help="machine-readable summary")


def run(args: argparse.Namespace) -> int:
    from ..progress import phase_bars

    observers = [s.strip() for s in args.observers.split(",") if s.strip()]
    named = load_system(args)
    if args.data is not None:
        summary = bench_recorded(named, args, observers)
    else:
        from ..studies.paper002_powertrain.bench import SCENARIO_EXAMPLES, run_bench

        if named.example is None or named.example.name not in SCENARIO_EXAMPLES:
            raise ModelError("--data", f"a CSV log to compare the observers on (only {sorted(SCENARIO_EXAMPLES)} "
                             f"have a bench scenario)", f"none for {named.label!r}")
        if args.regions:
            raise ModelError("--regions", "--data as well (the scenario computes its own analysis)", "no --data")
        progress, close = phase_bars(not args.json)
        try:
            summary = run_bench(named.example.name, args.horizon, args.steps, args.noise, observers, args.mhe_steps,
                                args.plot, args.seed, progress=progress, params=named.params)
        finally:
            close()
    summary.setdefault("system", named.label)
    if args.json:
        print_json(summary)
        return 0
    print(f"{summary['example']}, T = {summary['horizon']}, {summary['steps']} steps, noise {summary['noise']:g}")
    for name, rec in summary["observers"].items():
        err = rec.get("max_abs_error_observable_all")
        print(f"  {name:<9} median {1e6 * rec['median_step_s']:9.1f} us  p95 {1e6 * rec['p95_step_s']:9.1f} us  "
              f"flagged unobservable {rec['n_flagged_unobservable']:5d}  max rel. error where flagged observable "
              f"{'n/a' if err is None else f'{err:.2e}'}  [{rec['solver']}]")
    if "note" in summary:
        print("note:", summary["note"])
    return 0


def bench_recorded(named, args, observers: list[str]) -> dict:
    """Every observer of ``observers`` on the log ``args.data`` (same data, same analysis)."""
    from ..observers.recorded import observe_log
    from ..progress import phase_bars
    from .observe import open_log

    for option, default in (("noise", 0.0), ("mhe_steps", None), ("plot", None)):
        if getattr(args, option) != default:
            raise ModelError(f"--{option.replace('_', '-')}", "no value with --data (the log is the data)", repr(getattr(args, option)))
    log, horizon, analysis = open_log(named, args)
    progress, close = phase_bars(not args.json)
    try:
        runs = observe_log(named.system, log, observers, horizon, analysis, progress=progress)
    finally:
        close()
    results = {}
    for kind, (_, rec) in runs.items():
        rec = dict(rec)
        rec["n_flagged_unobservable"] = rec["flag_counts"]["unobservable"]
        rec["n_fallback"] = rec["flag_counts"]["fallback"]
        rec["max_abs_error_observable_all"] = rec.get("max_rel_error_observable")
        results[kind] = rec
    if "lookup" in results:
        base = results["lookup"]["median_step_s"]
        for rec in results.values():
            rec["ratio_to_lookup"] = rec["median_step_s"] / base if base else None
    return {"example": named.label, "system": named.label, "data": str(args.data), "horizon": horizon,
            "steps": log.n_samples, "noise": 0.0, "has_true_states": log.X is not None, "observers": results}

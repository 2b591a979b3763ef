"""``hybobs bench SYSTEM``: the lookup observer against the MIQP/MILP moving-horizon observers on
the same data: the paper's scenario for the powertrain examples (paper 002, Section 7; the study
:mod:`hybobs_opt.studies.paper002_powertrain.bench`), or a recorded CSV log of any PWA system
(``--data LOG.csv``).
"""

from __future__ import annotations

import argparse

from ..errors import ModelError
from ..defaults import DEFAULT_HORIZON
from ..limits import MAX_HORIZON, MAX_SAMPLES
from ._common import (add_force_argument, add_cache_argument, add_lp_budget_argument, add_system_argument, announce, as_options, check_figure_path,
                      command_cache, load_system, print_json)
from ._text import sig

#: Observer names of ``--observers`` (:data:`hybobs_opt.observers.recorded.PWA_OBSERVERS`) and the default list.
OBSERVER_NAMES = ("lookup", "miqp", "milp", "milp_inf", "set_membership")
DEFAULT_OBSERVERS = "lookup,miqp,milp"
#: Samples of the bench scenario when --steps is not given (3 s at 1 ms).
DEFAULT_STEPS = 3000

HELP = "lookup observer vs MIQP/MILP moving-horizon observers on one scenario or CSV log (paper 002, Section 7)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--horizon", "-T", type=int, metavar="T", default=DEFAULT_HORIZON,
                   help=f"observation horizon T (default {DEFAULT_HORIZON}, at most {MAX_HORIZON})")
    p.add_argument("--data", metavar="LOG.csv", help="compare the observers on this recorded log (any PWA system)")
    p.add_argument("--regions", metavar="FILE", help="with --data: saved analysis for the lookup observer")
    p.add_argument("--steps", type=int, default=None, metavar="N",
                   help=f"number of samples of the scenario (1 ms each; default {DEFAULT_STEPS}, at most {MAX_SAMPLES:,})")
    p.add_argument("--noise", type=float, default=0.0, metavar="SIGMA", help="standard deviation of output noise (rad/s)")
    p.add_argument("--observers", default=DEFAULT_OBSERVERS, metavar="NAME[,NAME...]",
                   help=f"comma-separated, among: {', '.join(OBSERVER_NAMES)} (default {DEFAULT_OBSERVERS})")
    p.add_argument("--noise-bound", action="append", metavar="NAME=VALUE", dest="noise_bound",
                   help="with --data, for set_membership (required) and the other observers (radii under bounded noise) in --observers: "
                        "the bound on an output's noise in its units (repeatable; a bare VALUE bounds every output)")
    p.add_argument("--mhe-steps", type=int, default=None, metavar="N",
                   help="run the MHE observers (miqp, milp, milp_inf) on the first N >= 1 steps only")
    p.add_argument("--seed", type=int, default=None, metavar="N", help="seed of the output noise (with --noise; a non-negative integer, default 0)")
    add_force_argument(p)
    p.add_argument("--plot", metavar="FILE", help="PNG like the paper's Figs. 7-9")
    add_cache_argument(p)
    add_lp_budget_argument(p)
    p.add_argument("--json", action="store_true", help="machine-readable summary")


def run(args: argparse.Namespace) -> int:
    announce(args, "loading the solvers (numpy, cvxpy, CasADi)")
    observers = parse_observers(args.observers)
    check_figure_path("--plot", args.plot, args.force)
    if args.horizon < 1 or args.horizon > MAX_HORIZON:
        raise ModelError("--horizon", f"a horizon T in 1..{MAX_HORIZON} (hybobs_opt.limits.MAX_HORIZON)", repr(args.horizon))
    if args.mhe_steps is not None:
        if args.mhe_steps < 1:
            raise ModelError("--mhe-steps", "a positive number of steps", repr(args.mhe_steps))
        if not set(observers) & {"miqp", "milp", "milp_inf"}:
            raise ModelError("--mhe-steps", "a moving-horizon observer (miqp, milp, milp_inf) in --observers as well",
                             repr(args.observers))
    if args.seed is not None:
        if args.seed < 0:
            raise ModelError("--seed", "a non-negative integer (numpy's random generator)", repr(args.seed))
        if args.data is None and not args.noise:
            raise ModelError("--seed", "--noise as well (the seed draws the output noise)", "no --noise")
    named = load_system(args)
    if "set_membership" in observers and args.data is None:
        raise ModelError("--observers", "set_membership with --data only (the bench scenarios have no noise bound)",
                         repr(args.observers))
    from .observe import noise_bound_option

    args.noise_bound = noise_bound_option(args.noise_bound, named.system, observers)
    if args.noise_bound is not None and args.data is None:
        raise ModelError("--noise-bound", "--data as well (the bench scenarios' noise is Gaussian: --noise)",
                         repr(args.noise_bound))
    with command_cache(args) as cache:
        summary = _bench(named, args, observers)
    if cache is not None and cache.events:
        summary["cache"] = cache.events
    summary.setdefault("system", named.label)
    if args.json:
        print_json(summary)
        return 0
    print(f"{summary['example']}, T = {summary['horizon']}, {summary['steps']} steps, noise {sig(summary['noise'])}")
    for name, rec in summary["observers"].items():
        err = rec.get("max_abs_error_observable_all")
        print(f"  {name:<9} median {1e6 * rec['median_step_s']:9.1f} us  p95 {1e6 * rec['p95_step_s']:9.1f} us  "
              f"flagged unobservable {rec['n_flagged_unobservable']:5d}  max rel. error where flagged observable "
              f"{'n/a' if err is None else f'{err:.2e}'}  [{rec['solver']}]")
        if "radius_max" in rec:
            print(f"  {'':<9} certified radius: median {_values(rec['radius_median'])}, largest "
                  f"{_values(rec['radius_max'])}; true state outside it: {sig(rec.get('n_outside_radius'))}")
    if "note" in summary:
        print("note:", summary["note"])
    return 0


def _values(value) -> str:
    """A number, or a record or list of numbers, rounded for the text summary."""
    if isinstance(value, dict):
        return ", ".join(f"{k} {sig(v)}" for k, v in value.items())
    if isinstance(value, (list, tuple)):
        return ", ".join(sig(v) for v in value)
    return sig(value)


def _bench(named, args, observers: list[str]) -> dict:
    """The summary of the comparison on ``--data`` or on the example's scenario."""
    from ..progress import phase_bars

    if args.data is not None:
        return bench_recorded(named, args, observers)
    else:
        from ..studies.paper002_powertrain.bench import SCENARIO_EXAMPLES, run_bench

        if named.example is None or named.example.name not in SCENARIO_EXAMPLES:
            raise ModelError("--data", f"a CSV log to compare the observers on (only {sorted(SCENARIO_EXAMPLES)} "
                             f"have a bench scenario)", f"none for {named.label!r}")
        if args.regions:
            raise ModelError("--regions", "--data as well (the scenario computes its own analysis)", "no --data")
        steps = DEFAULT_STEPS if args.steps is None else args.steps
        if steps > MAX_SAMPLES:
            raise ModelError("--steps", f"at most {MAX_SAMPLES:,} samples (hybobs_opt.limits.MAX_SAMPLES)", repr(steps))
        progress, close = phase_bars(not args.json)
        try:
            with as_options({"horizon T": "--horizon"}):
                summary = run_bench(named.example.name, args.horizon, steps, args.noise, observers, args.mhe_steps,
                                    args.plot, args.seed or 0, progress=progress, params=named.params)
        finally:
            close()
        return summary


def parse_observers(text: str) -> list[str]:
    """``--observers a,b`` -> ``[a, b]``: at least one, each known, none twice."""
    names = [s.strip() for s in text.split(",")]
    if not any(names):
        raise ModelError("--observers", f"at least one of {', '.join(OBSERVER_NAMES)} (comma-separated)", repr(text))
    for name in names:
        if name not in OBSERVER_NAMES:
            raise ModelError("--observers", f"comma-separated names among {', '.join(OBSERVER_NAMES)}",
                             repr(name) if name else f"an empty name in {text!r}")
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise ModelError("--observers", "each observer once", f"{', '.join(twice)} twice in {text!r}")
    return names


def bench_recorded(named, args, observers: list[str]) -> dict:
    """Every observer of ``observers`` on the log ``args.data`` (same data, same analysis)."""
    from ..observers.recorded import observe_log
    from ..progress import phase_bars
    from .observe import open_log

    for option, default in (("noise", 0.0), ("mhe_steps", None), ("plot", None), ("steps", None), ("seed", None)):
        if getattr(args, option) != default:
            raise ModelError(f"--{option.replace('_', '-')}", "no value with --data (the log is the data)", repr(getattr(args, option)))
    log, horizon, analysis = open_log(named, args)
    progress, close = phase_bars(not args.json)
    try:
        with as_options({"horizon T": "--horizon", "horizon": "--horizon"}):
            runs = observe_log(named.system, log, observers, horizon, analysis, progress=progress,
                               noise_bound=args.noise_bound)
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

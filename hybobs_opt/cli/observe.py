"""``hybobs observe SYSTEM``: an observer on an example's scenario, or on a recorded CSV log of any
PWA system (``--data LOG.csv``)."""

from __future__ import annotations

import argparse

from ..errors import ModelError
from ..defaults import DEFAULT_HORIZON
from ._common import (add_force_argument, add_cache_argument, add_lp_budget_argument, add_system_argument,
                      announce, as_options, bound_entries, check_figure_path, check_output_path, command_cache, load_system,
                      print_json)
from ._text import print_summary
from ._vocabulary import add_hidden_alias

HELP = "run an observer on an example's scenario, or on a CSV log (--data) of any PWA system"

#: What to use instead of ``--fit-tolerance`` (a residual allowance of the moving-horizon observers'
#: fit) with the observers that have no fit: noisy data is declared to them by a noise bound.
FIT_TOLERANCE_INSTEAD = {
    "lookup": "it fits no window, so it takes no residual tolerance; on noisy data declare the noise with "
              "--noise-bound NAME=VALUE (the bounded-noise lookup observer, with certified radii), or choose a "
              "moving-horizon observer with --observers miqp, milp or milp_inf to use --fit-tolerance",
    "set_membership": "it takes the noise as a bound, --noise-bound NAME=VALUE (--fit-tolerance belongs to miqp, "
                      "milp and milp_inf)",
}


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--observers", dest="observer", default=None, metavar="NAME[,NAME...]", help=_observer_help)
    add_hidden_alias(p, "--observers", "--observer")
    p.add_argument("--data", metavar="LOG.csv", help="recorded inputs and outputs, columns named by the system "
                   "(optional: t or time, the true states)")
    p.add_argument("--horizon", "-T", type=int, metavar="T", default=None,
                   help=f"observation horizon T (with --data; default {DEFAULT_HORIZON}, or the --regions file's)")
    p.add_argument("--regions", metavar="FILE", help="saved analysis ('hybobs regions --out') for the lookup observer")
    p.add_argument("--gains", metavar="FILE", help="switched gains ('hybobs synth --out') for a scalar-nonlinear "
                   "system (default: designed now with the model's settings)")
    p.add_argument("--fit-tolerance", type=float, default=None, metavar="Y",
                   help="with --data and a moving-horizon observer: the largest output residual a window may "
                        "leave (noisy logs: about 5 noise standard deviations; default 1e-3 of each output's range)")
    p.add_argument("--noise-bound", action="append", metavar="NAME=VALUE", dest="noise_bound",
                   help="with --data and --observers set_membership (required), lookup, miqp, milp or milp_inf (radii "
                        "under bounded noise; the flag is then the radius's): "
                        "the bound on an output's noise in its units (repeatable; a bare VALUE bounds every output; "
                        "outputs not named: 0)")
    p.add_argument("--input-noise-bound", action="append", metavar="NAME=VALUE", dest="input_noise_bound",
                   help="with --observers lookup and --noise-bound: the bound on a measured input's noise in its units "
                        "(repeatable; a bare VALUE bounds every input; inputs not named: 0)")
    p.add_argument("--out", "-o", metavar="ESTIMATES.csv", help="write t, estimates, mode and flag per sample "
                   "(and radius_<state> per state with the set-membership observer, and the others with --noise-bound)")
    p.add_argument("--filter", action="store_true", help="low-pass filter variant (sliding-mode observers)")
    add_force_argument(p)
    p.add_argument("--plot", metavar="FILE", help="write a PNG of the run")
    add_cache_argument(p)
    add_lp_budget_argument(p)
    p.add_argument("--json", action="store_true", help="print a JSON summary")


def _observer_help() -> str:
    """The ``--observers`` help: the kinds of every example's scenario and of a log (shown by ``--help`` only)."""
    from ..studies import list_examples

    per_example = "; ".join(f"{ex.name}: {', '.join(ex.observers)}" for ex in list_examples() if ex.observers)
    return ("the observer (one name here; 'hybobs bench --observers a,b' compares several), the first listed is the "
            "default. On an example's scenario: " + per_example
            + ". With --data: lookup, miqp, milp, milp_inf, set_membership for a PWA system (default lookup); switched for a "
            "scalar-nonlinear one")


def check_scenario_options(example, args: argparse.Namespace) -> None:
    """The options of ``hybobs observe EXAMPLE`` (no --data) against what the example's scenario runs."""
    if args.param:
        raise ModelError("--param", f"no value for the observer scenario of {example.name!r} (it runs the paper's plant; "
                         "simulate another one and pass it with --data LOG.csv)", repr(args.param[0]))
    if example.observers and args.observer is not None and args.observer not in example.observers:
        raise ModelError("--observers", f"one of {', '.join(example.observers)} (the observers of the scenario of "
                         f"{example.name!r})", repr(args.observer))
    if example.observers and args.filter and not example.observer_filter:
        raise ModelError("--filter", f"no --filter for {example.name!r} (the filtered variant belongs to the sliding-mode "
                         "observers of paper 001: switched_unstable, triangular, double_scroll)", "--filter")


def one_observer(text: str | None) -> str | None:
    """``--observers NAME`` of ``observe``: exactly one name (it runs one observer)."""
    if text is None:
        return None
    names = [s.strip() for s in text.split(",")]
    if len(names) != 1 or not names[0]:
        raise ModelError("--observers", "one observer name ('hybobs observe' runs one observer; 'hybobs bench --data "
                         "LOG.csv --observers a,b' compares several on one log)", repr(text))
    return names[0]


def run(args: argparse.Namespace) -> int:
    announce(args, "loading the solvers (numpy, cvxpy, CasADi)")
    args.observer = one_observer(args.observer)
    check_figure_path("--plot", args.plot, args.force)
    check_output_path("--out", args.out, args.force)
    named = load_system(args)
    with command_cache(args) as cache:
        summary = _observe(named, args)
    if cache is not None and cache.events:
        summary["cache"] = cache.events
    if args.json:
        print_json(summary)
    else:
        ex = named.example
        units = dict(zip(ex.state_names, ex.state_units)) if ex is not None and ex.state_units else None
        print_summary(summary, units, skip=("cache",))  # the cache events were printed on stderr
    return 0


def _observe(named, args: argparse.Namespace) -> dict:
    """The summary of the example's scenario, or of the run on ``--data``."""
    if args.data is None:
        for option in ("horizon", "regions", "out", "gains", "fit_tolerance", "noise_bound"):
            if getattr(args, option) is not None:
                flag = "--" + option.replace("_", "-")
                raise ModelError(flag, "--data LOG.csv as well (it applies to a recorded log)", "no --data")
        if named.example is None:
            raise ModelError("--data", f"a CSV log for {named.label!r} (only the shipped examples have scenarios)", "none")
        from ..studies.scenarios import get_scenario

        check_scenario_options(named.example, args)
        summary = get_scenario(named.example.name)(args)
    elif named.kind == "scalar_nonlinear":
        summary = observe_recorded_nonlinear(named, args)
    else:
        summary = observe_recorded(named, args)
    return summary


def open_log(named, args):
    """The analysis-ready PWA system, its log and the saved analysis (if ``--regions``)."""
    from ..sim.log import read_log
    from ._common import require_kind

    from ..limits import check_horizon_limit

    require_kind(named, ("pwa",), "the PWA observers of paper 002 on recorded data")
    if getattr(args, "gains", None):
        raise ModelError("--gains", "no value for a PWA system (switched gains belong to scalar-nonlinear systems)", "a file")
    if args.horizon is not None and args.horizon < 1:
        raise ModelError("--horizon", "a horizon T >= 1", repr(args.horizon))
    if args.horizon is not None:
        check_horizon_limit(args.horizon, "--horizon")
    analysis = None
    if args.regions:
        from ..regions import load_analysis

        analysis = load_analysis(args.regions, system=named.system)
        if args.horizon is not None and args.horizon != analysis.T:
            raise ModelError("--horizon", f"the horizon of {args.regions}, T = {analysis.T}", repr(args.horizon))
    horizon = analysis.T if analysis is not None else (args.horizon or DEFAULT_HORIZON)
    return read_log(args.data, named.system), horizon, analysis


def observe_recorded_nonlinear(named, args) -> dict:
    """The switched-gain observer of paper 004 on a log of a scalar-nonlinear system."""

    from ..observers.recorded import gains_from_json, observe_nonlinear_log
    from ..sim.log import read_log

    kind = args.observer or "switched"
    if kind != "switched":
        raise ModelError("--observers", "switched (the observer of a scalar-nonlinear system on a log)", repr(kind))
    for option in ("horizon", "regions", "fit_tolerance"):
        if getattr(args, option) is not None:
            raise ModelError("--" + option.replace("_", "-"), "no value for a scalar-nonlinear system (it belongs to the "
                             "PWA observers)", "a value")
    if args.filter:
        raise ModelError("--filter", "no --filter with --data (it belongs to the sliding-mode scenarios)", "--filter")
    log = read_log(args.data, named.system)
    if args.gains:
        # the package's reader: unreadable, non-JSON, too deeply nested or unsealed files are ModelErrors naming it
        try:
            gains, source = gains_from_json(named.system, args.gains), str(args.gains)
        except ModelError as exc:
            raise ModelError(f"--gains: {exc.field}", exc.expected, exc.got) from None
    else:
        from ..lmi.auto_design import design_settings, design_switched

        gains, source = design_switched(named.system, design_settings(named.system)), "designed with the model's settings"
    trace, rec = observe_nonlinear_log(named.system, log, gains)
    summary = {"system": named.label, "kind": named.kind, "data": str(args.data), "gains": source, **rec}
    return _write_outputs(summary, trace, log, args, f"{named.label}: switched-gain observer on {args.data}")


def _write_outputs(summary: dict, trace, log, args, title: str) -> dict:
    """``--out`` (estimates CSV) and ``--plot`` of a run on a log, recorded in ``summary``."""
    from ..sim.log import write_estimates

    if args.out:
        write_estimates(args.out, trace, log.t)
        summary["out"] = str(args.out)
    if args.plot:
        from ..report.plots import plot_estimates

        plot_estimates(trace, log, args.plot, title=title)
        summary["plot"] = str(args.plot)
    return summary


def observe_recorded(named, args) -> dict:
    from ..observers.recorded import check_observer_kinds, observe_log
    from ..progress import phase_bars

    kind = args.observer or "lookup"
    if args.filter:
        raise ModelError("--filter", "no --filter with --data (it belongs to the sliding-mode scenarios)", "--filter")
    with as_options({"observer": "--observers"}):
        check_observer_kinds([kind])
    if args.fit_tolerance is not None and kind in ("lookup", "set_membership"):
        raise ModelError("--fit-tolerance", f"no value for the {kind} observer: {FIT_TOLERANCE_INSTEAD[kind]}",
                         repr(args.fit_tolerance))
    noise_bound = noise_bound_option(args.noise_bound, named.system, kind)
    input_noise_bound = input_noise_bound_option(args.input_noise_bound, named.system, kind, noise_bound)
    log, horizon, analysis = open_log(named, args)
    progress, close = phase_bars(not args.json)
    try:
        with as_options({"horizon T": "--horizon", "horizon": "--horizon", "fit_tolerance": "--fit-tolerance"}):
            trace, rec = observe_log(named.system, log, [kind], horizon, analysis, progress=progress,
                                     fit_tolerance=args.fit_tolerance, noise_bound=noise_bound,
                                     input_noise_bound=input_noise_bound)[kind]
    finally:
        close()
    summary = {"system": named.label, "kind": named.kind, "data": str(args.data), "horizon": horizon, **rec}
    return _write_outputs(summary, trace, log, args, f"{named.label}: {kind} on {args.data}")


def noise_bound_option(entries, system, kinds):
    """``--noise-bound`` as the ``noise_bound`` of the set-membership observer (required) and of the
    lookup and moving-horizon observers (optional: radii under bounded noise), a dict by output
    name; ``kinds`` is the observer or the observers of the command."""
    kinds = [kinds] if isinstance(kinds, str) else list(kinds)
    from ..observers.recorded import NOISE_BOUND_OBSERVERS

    if not any(k in NOISE_BOUND_OBSERVERS for k in kinds):
        if entries:
            raise ModelError("--noise-bound", "no value for the observer " + ", ".join(map(repr, kinds))
                             + " (it belongs to --observers set_membership, lookup, miqp, milp or milp_inf)",
                             repr(entries[0]))
        return None
    if not entries:
        if "set_membership" not in kinds:
            return None
        raise ModelError("--noise-bound", "a bound on the outputs' noise for the set-membership observer "
                         "(NAME=VALUE per output, or one VALUE; 0 for noise-free data)", "none")
    return bound_entries(entries, tuple(system.output_names), "--noise-bound", "noise_bound", "output")


def input_noise_bound_option(entries, system, kinds, noise_bound):
    """``--input-noise-bound`` as the lookup observer's ``input_noise_bound`` (with ``--noise-bound``)."""
    if not entries:
        return None
    kinds = [kinds] if isinstance(kinds, str) else list(kinds)
    if "lookup" not in kinds or noise_bound is None:
        raise ModelError("--input-noise-bound", "--observers lookup with --noise-bound (the bounded-noise lookup "
                         "observer is the one that takes measured inputs' noise)", repr(entries[0]))
    if "set_membership" in kinds:
        raise ModelError("--input-noise-bound", "no set_membership among the observers (its MILPs take the inputs "
                         "as exact)", repr(entries[0]))
    return bound_entries(entries, tuple(system.input_names), "--input-noise-bound", "input_noise_bound", "input")

"""``hybobs simulate SYSTEM``: an example's paper scenario, or a run of any system from an initial
state under a constant input or time-varying inputs from a CSV (``--inputs``); as a summary, JSON,
CSV or a plot."""

from __future__ import annotations

import argparse
import math
import time

from ..errors import ModelError
from ..limits import MAX_SAMPLES
from ._common import (add_force_argument, add_system_argument, announce, as_options, check_figure_path, check_output_path,
                      load_system, print_json)
from ._text import sig
from ._vocabulary import add_hidden_alias

#: Options whose name on the command line is not ``--`` + their dest with dashes.
OPTION_NAMES = {"dt": "--ts", "csv": "--out"}

HELP = "simulate a system (an example on its paper's scenario, or any system from --x0 under --u or --inputs)"

def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--t-final", type=float, default=None, metavar="SECONDS",
                   help=f"final time in seconds (a run of at most {MAX_SAMPLES:,} samples: hybobs_opt.limits.MAX_SAMPLES)")
    p.add_argument("--x0", action="append", metavar="STATE=VALUE",
                   help="initial state (repeat; default: centre of the state bounds). Not for examples")
    p.add_argument("--u", action="append", metavar="INPUT=VALUE",
                   help="constant input (repeat; default: centre of the input bounds, or 0). Not for examples")
    p.add_argument("--inputs", metavar="U.csv",
                   help="time-varying inputs instead of --u: a CSV with one column per input (named as the system "
                        "names them) and a time column t in seconds (from 0, increasing; each row holds until the "
                        "next). A PWA system takes one row per sample (t optional, then 0, Ts, 2 Ts, ...; the run "
                        "has as many samples as rows); a continuous-time run ends at --t-final, by default the "
                        "last row's time. Not for examples")
    p.add_argument("--q0", type=int, default=None, metavar="Q",
                   help="initial mode/location of a hybrid automaton (0..N-1) or constant-drift system (1..Q, default 1)")
    p.add_argument("--steps", type=int, default=None, metavar="N",
                   help="samples of a PWA run (default 100: hybobs_opt.defaults.SIM_PWA_STEPS)")
    p.add_argument("--ts", dest="dt", type=float, default=None, metavar="SECONDS",
                   help="sampling period of the output of a continuous-time run (not for a PWA system, whose "
                        "sampling period is its Ts)")
    add_hidden_alias(p, "--ts", "--dt")
    add_force_argument(p)
    p.add_argument("--plot", metavar="FILE", help="write a PNG plot of the trace")
    p.add_argument("--out", "-o", dest="csv", metavar="FILE.csv",
                   help="write the trace as CSV (header: t, states, q, inputs, outputs)")
    add_hidden_alias(p, "--out", "--csv")
    p.add_argument("--json", action="store_true", help="print t, x, q, u, y arrays as JSON")


def run(args: argparse.Namespace) -> int:
    announce(args, "loading the simulators (numpy, scipy)")
    import numpy as np

    if args.t_final is not None and not (math.isfinite(args.t_final) and args.t_final > 0):
        raise ModelError("--t-final", "a positive finite time in seconds", repr(args.t_final))
    check_figure_path("--plot", args.plot, args.force)
    check_output_path("--out", args.csv, args.force)
    named = load_system(args)
    t0 = time.perf_counter()
    if named.example is not None:
        for option in ("x0", "u", "inputs", "steps", "dt", "q0"):
            if getattr(args, option) is not None:
                raise ModelError(OPTION_NAMES.get(option, f"--{option.replace('_', '-')}"), f"no value for the example {named.label!r} "
                                 "(it runs its paper's scenario; pass a model file or PATH.py:FUNCTION to choose)", "a value")
        t_final = named.example.default_t_final if args.t_final is None else args.t_final
        with as_options({"t_final": "--t-final"}):
            named.example.check_t_final(t_final)
        trace = named.example.scenario(named.system, t_final=t_final)
        title = f"{named.label} (paper {named.example.paper})"
    else:
        trace = simulate_system(named.system, args)
        title = named.label
    seconds = time.perf_counter() - t0
    if args.plot:
        from ..report.plots import plot_trace

        ex = named.example
        units = dict(zip(ex.state_names, ex.state_units)) if ex is not None and ex.state_units else None
        plot_trace(trace, args.plot, title=title, units=units)
    if args.csv:
        trace.to_csv(args.csv)
    if args.json:
        out = trace.to_dict()
        out.update({"example": named.label, "system": named.label, "kind": named.kind, "seconds": seconds})
        print_json(out)
        return 0
    ex = named.example
    units = dict(zip(ex.state_names, ex.state_units)) if ex is not None and ex.state_units else {}
    print(f"{named.label}: {trace.n_samples} samples over [{sig(trace.t[0])}, {sig(trace.t[-1])}] s, "
          f"{int(np.count_nonzero(np.diff(trace.q)))} discrete-state changes, {seconds:.2f} s")
    for i, name in enumerate(trace.state_names):
        unit = units.get(name, "")
        print(f"  {name:<10} min {sig(trace.x[:, i].min(), unit)}  max {sig(trace.x[:, i].max(), unit)}  "
              f"final {sig(trace.x[-1, i], unit)}")
    if args.plot:
        print(f"plot written to {args.plot}")
    if args.csv:
        print(f"CSV written to {args.csv}")
    return 0


def simulate_system(system, args: argparse.Namespace):
    """Run any system of the four classes from ``--x0`` under the constant input ``--u``."""
    from ..regions.cuts import parse_assignments
    from ..sim.any_system import simulate_system as run_system

    if args.u and not tuple(getattr(system, "input_names", ())):
        raise ModelError("--u", "no value (the system has no inputs)", repr(args.u[0]))
    inputs = None
    if args.inputs is not None:
        from ..sim.input_table import read_input_table

        if args.u:
            raise ModelError("--u", "no value with --inputs (the CSV gives every input)", repr(args.u[0]))
        if not tuple(getattr(system, "input_names", ())):
            raise ModelError("--inputs", "no value (the system has no inputs)", repr(args.inputs))
        inputs = read_input_table(args.inputs, system)
    x0 = parse_assignments(args.x0, tuple(system.state_names), "--x0")
    u = parse_assignments(args.u, tuple(getattr(system, "input_names", ())), "--u")
    for option, values in (("--x0", x0), ("--u", u)):
        for key, value in values.items():
            if not math.isfinite(value):
                raise ModelError(f"{option} {key}", "a finite number", repr(value))
    bounds = getattr(system, "box", None) if type(system).__name__ == "ScalarNonlinearSystem" else getattr(system, "state_bounds", None)
    if x0 and bounds is not None and type(system).__name__ != "PWASystem":  # a PWA run stops at the bounds itself
        from ..tolerances import MEMBERSHIP_RTOL

        lo, hi = bounds.bounding_box()
        for key, value in x0.items():
            k = list(system.state_names).index(key)
            if not lo[k] - MEMBERSHIP_RTOL * (1 + abs(lo[k])) <= value <= hi[k] + MEMBERSHIP_RTOL * (1 + abs(hi[k])):
                raise ModelError(f"--x0 {key}", f"a value within the model's bounds of {key}, [{lo[k]:g}, {hi[k]:g}]", repr(value))
    kind = type(system).__name__
    if args.steps is not None and (kind != "PWASystem" or args.steps < 1):
        raise ModelError("--steps", "a positive number of samples, for a PWA system (others take --t-final)", repr(args.steps))
    if args.dt is not None and not (math.isfinite(args.dt) and args.dt > 0):
        raise ModelError("--ts", "a positive finite sampling period in seconds", repr(args.dt))
    if kind == "PWASystem":
        if args.t_final is not None and system.Ts is None:
            raise ModelError("--t-final", "--steps for a PWA system without a sampling period Ts", repr(args.t_final))
        if args.t_final is not None and args.steps is not None:
            raise ModelError("--t-final", "either --steps or --t-final for a PWA system (both give the length of the run)", "both")
        for option in ("dt", "q0"):
            if getattr(args, option) is not None:
                raise ModelError(OPTION_NAMES.get(option, f"--{option}"), "no value for a PWA system (its sample time is Ts and the mode follows "
                                 "from the state)", repr(getattr(args, option)))
    if kind == "ScalarNonlinearSystem" and args.q0 is not None:
        raise ModelError("--q0", "no value for a scalar-nonlinear system (it has no modes)", repr(args.q0))
    if kind in ("HybridAutomaton", "ConstantDriftSystem") and args.q0 is not None:
        count = len(system.locations) if kind == "HybridAutomaton" else system.n_modes
        first = 0 if kind == "HybridAutomaton" else 1
        if not first <= args.q0 < first + count:
            raise ModelError("--q0", f"a {'location' if first == 0 else 'mode'} index in {first}..{first + count - 1}",
                             repr(args.q0))
    with as_options({"t_final": "--t-final", "t_final / dt": "--t-final / --ts", "steps": "--steps", "dt": "--ts",
                     "q0": "--q0", "x0": "--x0", "u": "--u", "x(0)": "--x0 / --u", "inputs": "--inputs"}):
        return run_system(system, x0=x0, u=u, q0=args.q0, steps=args.steps, t_final=args.t_final, dt=args.dt,
                          inputs=inputs)

"""``hybobs simulate SYSTEM``: an example's paper scenario, or a run of any system from an initial
state under a constant input; as a summary, JSON, CSV or a plot."""

from __future__ import annotations

import argparse
import math
import time

from ..errors import ModelError
from ._common import add_system_argument, load_system, print_json

HELP = "simulate a system (an example on its paper's scenario, or any system from --x0 under --u)"

#: Samples of a PWA run when neither --steps nor --t-final is given.
DEFAULT_PWA_STEPS = 100
#: Final time of a continuous-time run when --t-final is not given (seconds).
DEFAULT_T_FINAL = 10.0


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--t-final", type=float, default=None, help="final time in seconds")
    p.add_argument("--x0", action="append", metavar="STATE=VALUE",
                   help="initial state (repeat; default: centre of the state bounds). Not for examples")
    p.add_argument("--u", action="append", metavar="INPUT=VALUE",
                   help="constant input (repeat; default: centre of the input bounds, or 0). Not for examples")
    p.add_argument("--q0", type=int, default=None, help="initial mode/location (constant-drift: 1..Q, default 1)")
    p.add_argument("--steps", type=int, default=None, help=f"samples of a PWA run (default {DEFAULT_PWA_STEPS})")
    p.add_argument("--dt", type=float, default=None, help="output sample time of a continuous-time run (s)")
    p.add_argument("--plot", metavar="FILE", help="write a PNG plot of the trace")
    p.add_argument("--csv", metavar="FILE", help="write the trace as CSV (header: t, states, q, inputs, outputs)")
    p.add_argument("--json", action="store_true", help="print t, x, q, u, y arrays as JSON")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    if args.t_final is not None and not (math.isfinite(args.t_final) and args.t_final > 0):
        raise ModelError("--t-final", "a positive finite time in seconds", repr(args.t_final))
    named = load_system(args)
    t0 = time.perf_counter()
    if named.example is not None:
        for option in ("x0", "u", "steps", "dt", "q0"):
            if getattr(args, option) is not None:
                raise ModelError(f"--{option.replace('_', '-')}", f"no value for the example {named.label!r} "
                                 "(it runs its paper's scenario; pass a model file or PATH.py:FUNCTION to choose)", "a value")
        trace = named.example.scenario(named.system, t_final=named.example.default_t_final if args.t_final is None else args.t_final)
        title = f"{named.label} (paper {named.example.paper})"
    else:
        trace = simulate_system(named.system, args)
        title = named.label
    seconds = time.perf_counter() - t0
    if args.plot:
        from ..report.plots import plot_trace

        plot_trace(trace, args.plot, title=title)
    if args.csv:
        trace.to_csv(args.csv)
    if args.json:
        out = trace.to_dict()
        out.update({"example": named.label, "system": named.label, "kind": named.kind, "seconds": seconds})
        print_json(out)
        return 0
    print(f"{named.label}: {trace.n_samples} samples over [{trace.t[0]:.4g}, {trace.t[-1]:.4g}] s, "
          f"{int(np.count_nonzero(np.diff(trace.q)))} discrete-state changes, {seconds:.2f} s")
    for i, name in enumerate(trace.state_names):
        print(f"  {name:<10} min {trace.x[:, i].min():+.5g}  max {trace.x[:, i].max():+.5g}  final {trace.x[-1, i]:+.5g}")
    if args.plot:
        print(f"plot written to {args.plot}")
    if args.csv:
        print(f"CSV written to {args.csv}")
    return 0


def _vector(items, names, field: str, default):
    import numpy as np

    from ..regions.cuts import parse_assignments

    values = parse_assignments(items, tuple(names), field)
    out = np.array(default, dtype=float).reshape(len(names))
    for k, nm in enumerate(names):
        if nm in values:
            out[k] = values[nm]
    return out


def _centre(poly, size: int):
    import numpy as np

    if poly is None or size == 0:
        return np.zeros(size)
    lo, hi = poly.bounding_box()
    return (lo + hi) / 2.0


def simulate_system(system, args: argparse.Namespace):
    """Run any system of the four classes from ``--x0`` under the constant input ``--u``."""
    import numpy as np

    from .. import sim

    kind = type(system).__name__
    if args.steps is not None and (kind != "PWASystem" or args.steps < 1):
        raise ModelError("--steps", "a positive number of samples, for a PWA system (others take --t-final)", repr(args.steps))
    if args.dt is not None and not (math.isfinite(args.dt) and args.dt > 0):
        raise ModelError("--dt", "a positive finite sample time", repr(args.dt))
    if kind == "ConstantDriftSystem":
        if args.u:
            raise ModelError("--u", "no input (a constant-drift system has none)", f"{args.u}")
        x0 = _vector(args.x0, system.state_names, "--x0", np.r_[1.0, np.ones(system.n_states - 1)])
        return sim.simulate_constant_drift(system, x0, 1 if args.q0 is None else args.q0, 0.0,
                                           args.t_final or DEFAULT_T_FINAL, args.dt)
    bounds = system.box if kind == "ScalarNonlinearSystem" else system.state_bounds
    x0 = _vector(args.x0, system.state_names, "--x0", _centre(bounds, system.n))
    u = _vector(args.u, system.input_names, "--u", _centre(getattr(system, "input_bounds", None), system.m))
    if kind == "PWASystem":
        if args.t_final is not None and system.Ts is None:
            raise ModelError("--t-final", "--steps for a PWA system without a sampling period Ts", repr(args.t_final))
        steps = args.steps or (int(round(args.t_final / system.Ts)) if args.t_final else DEFAULT_PWA_STEPS)
        return sim.simulate_pwa(system, x0, np.tile(u, (steps, 1)), on_blocked="stop")
    if kind == "HybridAutomaton":
        return sim.simulate_hybrid(system, x0, args.t_final or DEFAULT_T_FINAL, u=u, q0=args.q0,
                                   dt=args.dt or 1e-2)
    t_final = args.t_final or DEFAULT_T_FINAL
    return sim.simulate_nonlinear(system, x0, (lambda t: u) if system.m else None, t_final, args.dt or t_final / 1000)

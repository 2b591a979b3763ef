"""``hybobs simulate EXAMPLE``: the example's paper scenario, as a summary, JSON, CSV or a plot."""

from __future__ import annotations

import argparse
import math
import time

from ..errors import ModelError
from ._common import parse_params, print_json

HELP = "simulate an example on its paper's scenario"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("example", help="example name (see 'hybobs examples')")
    p.add_argument("--t-final", type=float, default=None, help="final time in seconds")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="model parameter, e.g. gear_ratio=1/2")
    p.add_argument("--plot", metavar="FILE", help="write a PNG plot of the trace")
    p.add_argument("--csv", metavar="FILE", help="write the trace as CSV (header: t, states, q, inputs, outputs)")
    p.add_argument("--json", action="store_true", help="print t, x, q, u, y arrays as JSON")


def run(args: argparse.Namespace) -> int:
    import numpy as np

    from ..studies import get_example

    example = get_example(args.example)
    if args.t_final is not None and not (math.isfinite(args.t_final) and args.t_final > 0):
        raise ModelError("--t-final", "a positive finite time in seconds", repr(args.t_final))
    t0 = time.perf_counter()
    trace = example.simulate(args.t_final, **parse_params(args.param))
    seconds = time.perf_counter() - t0
    if args.plot:
        from ..report.plots import plot_trace

        plot_trace(trace, args.plot, title=f"{example.name} (paper {example.paper})")
    if args.csv:
        trace.to_csv(args.csv)
    if args.json:
        out = trace.to_dict()
        out.update({"example": example.name, "seconds": seconds})
        print_json(out)
        return 0
    print(f"{example.name}: {trace.n_samples} samples over [{trace.t[0]:.4g}, {trace.t[-1]:.4g}] s, "
          f"{int(np.count_nonzero(np.diff(trace.q)))} discrete-state changes, {seconds:.2f} s")
    for i, name in enumerate(trace.state_names):
        print(f"  {name:<10} min {trace.x[:, i].min():+.5g}  max {trace.x[:, i].max():+.5g}  final {trace.x[-1, i]:+.5g}")
    if args.plot:
        print(f"plot written to {args.plot}")
    if args.csv:
        print(f"CSV written to {args.csv}")
    return 0

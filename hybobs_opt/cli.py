"""The ``hybobs`` command: a thin layer over the package, ``--json`` on every command.

Exit codes: 0 success, 2 bad input or a failed computation (one-line message on stderr).
"""

from __future__ import annotations

import argparse
import importlib
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from .errors import HybobsError, ModelError


def _print_json(obj: Any) -> None:
    print(json.dumps(obj, default=_json_default))


def _json_default(value: Any) -> Any:
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def _parse_params(items: list[str] | None) -> dict[str, float]:
    params: dict[str, float] = {}
    for item in items or []:
        if "=" not in item:
            raise ModelError("--param", "NAME=VALUE (e.g. gear_ratio=0.5)", repr(item))
        key, value = item.split("=", 1)
        try:
            params[key.strip()] = _number(value)
        except ValueError:
            raise ModelError(f"--param {key}", "a number (fractions like 1/12 allowed)", repr(value)) from None
    return params


def _number(text: str) -> float:
    text = text.strip()
    if "/" in text:
        num, den = text.split("/", 1)
        return float(num) / float(den)
    return float(text)


def _progress(enabled: bool):
    """A progress callback: a tqdm status line on a terminal, silent otherwise."""
    if not enabled or not sys.stderr.isatty():
        return lambda msg: None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=None, file=sys.stderr, bar_format="{desc} [{elapsed}]", leave=False)

    def update(msg: str) -> None:
        bar.set_description_str(msg)
        bar.update(0)

    return update, bar.close


# ---------------------------------------------------------------------------- commands
def cmd_examples(args: argparse.Namespace) -> int:
    from .examples import list_examples

    examples = list_examples()
    if args.json:
        _print_json([ex.to_dict() for ex in examples])
        return 0
    width = max(len(ex.name) for ex in examples)
    for ex in examples:
        print(f"{ex.name:<{width}}  paper {ex.paper}  {ex.kind:<17} n={ex.n_states}  {ex.summary}")
    return 0


def cmd_simulate(args: argparse.Namespace) -> int:
    from .examples import get_example

    example = get_example(args.example)
    if args.t_final is not None and not (np.isfinite(args.t_final) and args.t_final > 0):
        raise ModelError("--t-final", "a positive finite time in seconds", repr(args.t_final))
    t0 = time.perf_counter()
    trace = example.simulate(args.t_final, **_parse_params(args.param))
    seconds = time.perf_counter() - t0
    if args.plot:
        from .report.plots import plot_trace

        plot_trace(trace, args.plot, title=f"{example.name} (paper {example.paper})")
    if args.csv:
        trace.to_csv(args.csv)
    if args.json:
        out = trace.to_dict()
        out.update({"example": example.name, "seconds": seconds})
        _print_json(out)
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


def cmd_report(args: argparse.Namespace) -> int:
    from .report import build_report

    update, close = _progress(not args.json)
    try:
        result = build_report(args.out, progress=update, only=args.section)
    finally:
        close()
    if args.json:
        _print_json(result)
    else:
        for rec in result["sections"]:
            status = "ok" if rec["ok"] else f"FAILED: {rec['error']}"
            print(f"  {rec['title']}: {status} ({rec['seconds']:.1f} s)")
        print(f"report written to {Path(result['index']).resolve()}")
    return 0 if all(r["ok"] for r in result["sections"]) else 2


def _executor_from_args(args: argparse.Namespace):
    from .executor import make_executor

    if args.workers is not None and args.workers < 1:
        raise ModelError("--workers", "a positive number of processes", repr(args.workers))
    return make_executor(args.executor, args.workers, args.scheduler, args.dask_local)


def _progress_bar(enabled: bool, desc: str):
    """A tqdm bar on a terminal (stderr), nothing in tests or --json mode."""
    if not enabled or not sys.stderr.isatty():
        return None, lambda: None
    from tqdm import tqdm

    bar = tqdm(total=0, desc=desc, file=sys.stderr, leave=False)

    def update(done: int, total: int) -> None:
        bar.total = total
        bar.n = done
        bar.refresh()

    return update, bar.close


def cmd_regions(args: argparse.Namespace) -> int:
    from .examples import get_example
    from .regions import analyse_observability, compute_cut, parse_assignments, plot_cut, save_analysis

    example = get_example(args.example)
    if example.kind != "pwa":
        raise ModelError("example", "a PWA example (observability regions need a PWASystem)",
                         f"{example.name!r} of kind {example.kind!r}")
    params = _parse_params(args.param)
    system = example.build(**params)
    fixed = parse_assignments(args.cut, system.state_names)
    executor = _executor_from_args(args)
    update, close = _progress_bar(not args.json, "Algorithm 3.1")
    try:
        analysis = analyse_observability(system, args.horizon, executor=executor, progress=update)
    finally:
        close()
        executor.close()
    out = analysis.summary()
    out["example"] = example.name
    out["params"] = params
    if args.save:
        save_analysis(analysis, args.save, example.name, params)
        out["saved"] = str(args.save)
    if args.query:
        out["observable"] = _query_points(analysis, args.query, system.state_names)
    if fixed or args.plot:
        if not fixed:
            raise ModelError("--plot", f"a --cut fixing {system.n - 2} states so that a 2-D plane remains", "no --cut")
        nx, ny = _resolution(args.resolution)
        update, close = _progress_bar(not args.json, "cut")
        try:
            cut = compute_cut(analysis, fixed, (nx, ny), progress=update)
        finally:
            close()
        out["cut"] = {"axes": list(cut.axes), "fixed": cut.fixed, "resolution": [nx, ny],
                      "fraction_observable_of_feasible": cut.fraction_of_feasible("observable"),
                      "fraction_unobservable_of_feasible": cut.fraction_of_feasible("unobservable")}
        if args.plot:
            stretch = {"theta": 10.0} if "theta" in cut.axes else None  # as the paper's figures
            plot_cut(cut, args.plot, title=f"{example.name}, T = {args.horizon}, " + ", ".join(f"{k} = {v:g}" for k, v in fixed.items()), stretch=stretch)
            out["plot"] = str(args.plot)
    if args.json:
        _print_json(out)
        return 0
    print(f"{example.name} (T = {args.horizon}): {out['n_regions']} regions, {out['n_full_rank']} with rank C_i = n, "
          f"{out['n_unobservable_pieces']} polytopes in B_T ({out['n_reduced_pieces']} in B~_T), "
          f"{out['n_lps']} LPs ({out['n_lps_avoided_by_pruning']} avoided by pruning), {out['seconds']:.2f} s [{out['executor']}]")
    if "cut" in out:
        c = out["cut"]
        print(f"cut {c['fixed']}: {100 * c['fraction_observable_of_feasible']:.1f} % of the feasible grid points observable")
    for key in ("saved", "plot"):
        if key in out:
            print(f"{key}: {out[key]}")
    if "observable" in out:
        print(f"query: {sum(out['observable'])} of {len(out['observable'])} states observable")
    return 0


def _resolution(text: str) -> tuple[int, int]:
    try:
        nx, ny = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ModelError("--resolution", "NXxNY, e.g. 41x31", repr(text)) from None
    if nx < 2 or ny < 2:
        raise ModelError("--resolution", "at least 2 points per axis", repr(text))
    return nx, ny


def _query_points(analysis, path: str, state_names: tuple[str, ...]) -> list[bool]:
    import csv

    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows:
        raise ModelError(f"--query {path}", "a header row naming the states", "an empty file")
    header = [h.strip() for h in rows[0]]
    if sorted(header) != sorted(state_names):
        raise ModelError(f"--query {path} header", f"the state names {list(state_names)}", f"{header}")
    order = [header.index(nm) for nm in state_names]
    points = []
    for k, row in enumerate(rows[1:], start=2):
        if not row:
            continue
        try:
            values = [float(row[c]) for c in order]
        except (ValueError, IndexError):
            raise ModelError(f"--query {path} line {k}", f"{len(state_names)} numbers", repr(row)) from None
        points.append(values)
    return [analysis.is_observable(p) for p in points]


def cmd_observe(args: argparse.Namespace) -> int:
    from .examples import get_example
    from .observers.scenarios import get_scenario

    example = get_example(args.example)
    scenario = get_scenario(example.name)
    summary = scenario(args)
    if args.json:
        _print_json(summary)
    else:
        for key, value in summary.items():
            if isinstance(value, (list, dict)) and len(str(value)) > 200:
                value = f"{type(value).__name__} of {len(value)} items (use --json)"
            print(f"{key}: {value}")
    return 0


# ---------------------------------------------------------------------------- parser
def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hybobs",
        description="Optimization-based state observers for hybrid systems (hybobs_opt).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("examples", help="list the seed papers' example systems")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_examples)

    p = sub.add_parser("simulate", help="simulate an example on its paper's scenario")
    p.add_argument("example", help="example name (see 'hybobs examples')")
    p.add_argument("--t-final", type=float, default=None, help="final time in seconds")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="model parameter, e.g. gear_ratio=1/2")
    p.add_argument("--plot", metavar="FILE", help="write a PNG plot of the trace")
    p.add_argument("--csv", metavar="FILE", help="write the trace as CSV (header: t, states, q, inputs, outputs)")
    p.add_argument("--json", action="store_true", help="print t, x, q, u, y arrays as JSON")
    p.set_defaults(func=cmd_simulate)

    p = sub.add_parser("report", help="build the HTML report of every result")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--section", action="append", metavar="KEY", help="build only these sections")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=cmd_report)

    p = sub.add_parser("regions", help="observability regions of a PWA example (paper 002, Algorithm 3.1)")
    p.add_argument("example", help="a PWA example (powertrain3, powertrain5)")
    p.add_argument("--horizon", "-T", type=int, required=True, help="observation horizon T")
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="model parameter, e.g. gear_ratio=1/2")
    p.add_argument("--cut", action="append", metavar="STATE=VALUE", help="fix a state for a 2-D cut (repeat)")
    p.add_argument("--resolution", default="41x31", metavar="NXxNY", help="grid of the cut (default 41x31)")
    p.add_argument("--plot", metavar="FILE", help="PNG of the cut")
    p.add_argument("--save", metavar="FILE", help="save the result (JSON) for the lookup observer")
    p.add_argument("--query", metavar="FILE.csv", help="CSV of states (header = state names): adds 'observable'")
    p.add_argument("--executor", choices=("serial", "processes"), default="processes", help="where the LPs run")
    p.add_argument("--workers", type=int, default=None, help="number of local processes (default: all cores)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run on a Dask distributed scheduler")
    p.add_argument("--dask-local", type=int, metavar="N", help="start a Dask LocalCluster with N workers")
    p.add_argument("--json", action="store_true", help="machine-readable summary")
    p.set_defaults(func=cmd_regions)

    p = sub.add_parser("observe", help="run an observer on an example's scenario")
    p.add_argument("example", help="example name")
    p.add_argument("--observer", default=None, metavar="KIND", help="observer kind")
    p.add_argument("--filter", action="store_true", help="low-pass filter variant (sliding-mode observers)")
    p.add_argument("--plot", metavar="FILE", help="write a PNG of the run")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=cmd_observe)

    for module in COMMAND_MODULES:
        importlib.import_module(module).add_commands(sub)
    return parser


#: Modules that add subcommands: each defines ``add_commands(subparsers)`` and the command
#: functions (which return an exit code and raise HybobsError on bad input).
COMMAND_MODULES: list[str] = ["hybobs_opt.observers.bench", "hybobs_opt.lmi.commands"]


def main(argv: list[str] | None = None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        return int(args.func(args) or 0)
    except HybobsError as exc:
        print(f"hybobs {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except OSError as exc:
        print(f"hybobs {args.command}: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""The ``hybobs`` command: a thin layer over the package, ``--json`` on every command.

Exit codes: 0 success, 2 bad input or a failed computation (one-line message on stderr).
"""

from __future__ import annotations

import argparse
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


def cmd_observe(args: argparse.Namespace) -> int:
    from .examples import get_example

    example = get_example(args.example)
    raise ModelError(
        "hybobs observe",
        "an example with an observer scenario",
        f"no observer is available for {example.name!r} (paper {example.paper}) in this version",
    )


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

    p = sub.add_parser("observe", help="run an observer on an example's scenario")
    p.add_argument("example", help="example name")
    p.add_argument("--observer", default=None, metavar="KIND", help="observer kind")
    p.add_argument("--json", action="store_true", help="print a JSON summary")
    p.set_defaults(func=cmd_observe)
    return parser


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

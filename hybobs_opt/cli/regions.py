"""``hybobs regions SYSTEM -T N``: observability regions of a PWA system (paper 002, Algorithm 3.1).

Optional 2-D cut (``--cut``, ``--plot``), saved result for the lookup observer (``--out``) and
point queries from a CSV (``--query``: each state observable, unobservable or infeasible).
"""

from __future__ import annotations

import argparse
import math

from ..errors import ModelError
from ..defaults import DEFAULT_HORIZON
from ..limits import MAX_GRID_POINTS, MAX_HORIZON
from ._common import (add_force_argument, add_cache_argument, add_executor_arguments, add_lp_budget_argument, add_system_argument,
                      as_options, check_figure_path, check_output_path, command_cache, executor_from_args, load_system,
                      announce, print_json)
from ._text import sig
from ._vocabulary import add_hidden_alias

#: Query rows listed one per line in text mode (the counts cover them all).
QUERY_LISTED = 20

#: Grid of a cut when --resolution is not given.
DEFAULT_RESOLUTION = "41x31"

HELP = "observability regions of a PWA system (paper 002, Algorithm 3.1)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--horizon", "-T", type=int, metavar="T", default=DEFAULT_HORIZON,
                   help=f"observation horizon T (default {DEFAULT_HORIZON}, 1 to {MAX_HORIZON}: hybobs_opt.limits.MAX_HORIZON)")
    p.add_argument("--ts", type=float, default=None, metavar="SECONDS",
                   help="sampling period in seconds: discretise an affine hybrid automaton exactly (ZOH) first")
    p.add_argument("--cut", action="append", metavar="STATE=VALUE", help="fix a state for a 2-D cut (repeat)")
    p.add_argument("--resolution", default=None, metavar="NXxNY",
                   help=f"grid of the cut (default {DEFAULT_RESOLUTION}, at most {MAX_GRID_POINTS:,} points; with --cut or --plot)")
    add_force_argument(p)
    p.add_argument("--plot", metavar="FILE", help="PNG of the cut")
    p.add_argument("--out", "-o", dest="save", metavar="FILE",
                   help="write the result (JSON) for the lookup observer ('hybobs observe --regions')")
    add_hidden_alias(p, "--out", "--save")
    p.add_argument("--query", metavar="FILE.csv",
                   help="CSV of states (header = state names): adds 'query' (each state observable, unobservable or "
                        "infeasible: outside X*_T, no input keeps its trajectory in the domain) and 'observable' "
                        "(true for the observable ones)")
    p.add_argument("--pair-by-pair", action="store_true",
                   help="classify every pair set on its own (no grouped pair tests: the full counts of thin and "
                        "same-state pairs, more LPs); computed afresh, not cached")
    add_executor_arguments(p)
    add_cache_argument(p)
    add_lp_budget_argument(p)
    p.add_argument("--json", action="store_true", help="machine-readable summary")


def run(args: argparse.Namespace) -> int:
    announce(args, "loading the LP solvers (numpy, scipy, HiGHS)")
    from ..limits import check_horizon_limit
    from ..cache import cached_analysis
    from ..progress import counter_bar, phase_bars
    from ..regions import PointClass, compute_cut, parse_assignments, save_analysis

    check_horizon_limit(args.horizon, "--horizon")
    check_figure_path("--plot", args.plot, args.force)
    check_output_path("--out", args.save, args.force)
    named = load_system(args)
    if named.kind == "hybrid_automaton" and args.ts is not None:
        with as_options({"Ts": "--ts"}):
            system = named.system.discretize(args.ts)
    elif args.ts is not None:
        raise ModelError("--ts", "only for a hybrid automaton (a PWA system is already discrete-time)", repr(args.ts))
    elif named.kind != "pwa":
        hint = " (an affine hybrid automaton: add --ts SECONDS to discretise it)" if named.kind == "hybrid_automaton" else ""
        raise ModelError("SYSTEM", "a PWA system (observability regions need a PWASystem)" + hint,
                         f"{named.label!r}, a {named.kind.replace('_', '-')} system")
    else:
        system = named.system
    params, label = named.params, named.label
    fixed = parse_assignments(args.cut, system.state_names, "--cut")
    for key, value in fixed.items():
        if not math.isfinite(value):
            raise ModelError(f"--cut {key}", "a finite number", repr(value))
    if fixed and len(fixed) != system.n - 2:
        raise ModelError("--cut", f"values for exactly {system.n - 2} of the states {list(system.state_names)} (two stay free)",
                         f"{sorted(fixed)}")
    cut_wanted = bool(fixed or args.plot)
    if cut_wanted:
        if system.n < 2:
            raise ModelError("--plot", "a system with at least 2 states (a cut is a plane)", f"{system.n} state")
        if not fixed and system.n > 2:
            raise ModelError("--plot", f"a --cut fixing {system.n - 2} states so that a 2-D plane remains", "no --cut")
        nx, ny = _resolution(args.resolution or DEFAULT_RESOLUTION)
    elif args.resolution is not None:
        raise ModelError("--resolution", "--cut or --plot as well (it is the grid of the cut)", repr(args.resolution))
    points = _read_query(args.query, system.state_names) if args.query else None
    executor = executor_from_args(args)
    progress, close = phase_bars(not args.json)
    try:
        with as_options({"horizon T": "--horizon"}), command_cache(args) as cache:
            if args.pair_by_pair:  # not what the cache holds (the grouped analysis): computed here
                from ..regions import analyse_observability

                analysis = analyse_observability(system, args.horizon, executor=executor, progress=progress,
                                                 group_tests=False)
            else:
                analysis = cached_analysis(system, args.horizon, executor=executor, progress=progress)
    finally:
        close()
        executor.close()
    out = analysis.summary()
    if cache is not None:
        out["cache"] = cache.events
    out["example"] = label
    out["system"] = label
    out["params"] = params
    if args.save:
        save_analysis(analysis, args.save, label if named.example is not None else None, params)
        out["saved"] = str(args.save)
    if points is not None:
        classes = [str(analysis.classify(p)) for p in points]
        out["query"] = classes
        out["observable"] = [c == PointClass.OBSERVABLE for c in classes]
    if cut_wanted:
        update, close = counter_bar(not args.json, "cut", "point")
        try:
            cut = compute_cut(analysis, fixed, (nx, ny), progress=update)
        finally:
            close()
        out["cut"] = {"axes": list(cut.axes), "fixed": cut.fixed, "resolution": [nx, ny],
                      "fraction_observable_of_feasible": cut.fraction_of_feasible(PointClass.OBSERVABLE),
                      "fraction_unobservable_of_feasible": cut.fraction_of_feasible(PointClass.UNOBSERVABLE)}
        if args.plot:
            from ..report.plots import plot_region_cut

            example = named.example
            units = dict(zip(example.state_names, example.state_units)) if example is not None and example.state_units else None
            plot_region_cut(cut, args.plot, units=units,
                            title=f"{label}, T = {args.horizon}" + "".join(f", {k} = {v:g}" for k, v in fixed.items()))
            out["plot"] = str(args.plot)
    if args.json:
        print_json(out)
        return 0
    print(f"{label} (T = {args.horizon}): {out['n_regions']} regions, {out['n_full_rank']} with rank C_i = n, "
          f"{out['n_unobservable_pieces']} polytopes in B_T ({out['n_reduced_pieces']} in B~_T), "
          f"{out['n_lps']} LPs ({out['n_lps_avoided_by_pruning']} avoided by pruning), {out['seconds']:.2f} s [{out['executor']}]"
          + (" (computed in an earlier run: loaded from the cache)" if any(e["outcome"] == "hit" for e in out.get("cache", ()))
             else ""))
    if "cut" in out:
        c = out["cut"]
        example = named.example
        units = dict(zip(example.state_names, example.state_units)) if example is not None and example.state_units else {}
        fixed_text = ", ".join(f"{k} = {sig(v, units.get(k, ''))}" for k, v in c["fixed"].items())
        print(f"cut{' at ' + fixed_text if fixed_text else ''}: {100 * c['fraction_observable_of_feasible']:.1f} % of the feasible grid points "
              f"observable, {100 * c['fraction_unobservable_of_feasible']:.1f} % unobservable")
    for key in ("saved", "plot"):
        if key in out:
            print(f"{key}: {out[key]}")
    if "query" in out:
        counts = {c: out["query"].count(str(c)) for c in PointClass}
        print(f"query: {len(out['query'])} states: " + ", ".join(f"{n} {c}" for c, n in counts.items()))
        for k, c in enumerate(out["query"][:QUERY_LISTED]):
            print(f"  row {k + 1}: {c}")
        if len(out["query"]) > QUERY_LISTED:
            print(f"  ... ({len(out['query']) - QUERY_LISTED} more: --json lists them)")
    return 0


def _resolution(text: str) -> tuple[int, int]:
    try:
        nx, ny = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise ModelError("--resolution", "NXxNY, e.g. 41x31", repr(text)) from None
    if nx < 2 or ny < 2:
        raise ModelError("--resolution", "at least 2 points per axis", repr(text))
    if nx * ny > MAX_GRID_POINTS:
        raise ModelError("--resolution", f"at most {MAX_GRID_POINTS:,} grid points (hybobs_opt.limits.MAX_GRID_POINTS)",
                         f"{text!r}, {nx * ny:,} points")
    return nx, ny


def _read_query(path: str, state_names: tuple[str, ...]) -> list[list[float]]:
    import csv
    import math

    try:
        with open(path, newline="", encoding="utf-8") as fh:
            rows = list(csv.reader(fh))
    except (UnicodeDecodeError, csv.Error) as exc:
        raise ModelError(f"--query {path}", "a CSV text file (UTF-8) of states", f"{type(exc).__name__}: {exc}") from None
    except OSError as exc:
        raise ModelError(f"--query {path}", "a readable CSV file of states", f"{type(exc).__name__}: {exc.strerror or exc}") from None
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
        if len(row) != len(header) or not all(math.isfinite(v) for v in values):
            raise ModelError(f"--query {path} line {k}", f"{len(header)} finite numbers (one per column of the header)", repr(row))
        points.append(values)
    return points

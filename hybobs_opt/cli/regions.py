"""``hybobs regions SYSTEM -T N``: observability regions of a PWA system (paper 002, Algorithm 3.1).

Optional 2-D cut (``--cut``, ``--plot``), saved result for the lookup observer (``--save``) and
point queries from a CSV (``--query``).
"""

from __future__ import annotations

import argparse

from ..errors import ModelError
from ._common import add_executor_arguments, add_system_argument, executor_from_args, load_system, print_json

HELP = "observability regions of a PWA system (paper 002, Algorithm 3.1)"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--horizon", "-T", type=int, required=True, help="observation horizon T")
    p.add_argument("--ts", type=float, default=None, metavar="SECONDS",
                   help="sampling period: discretise an affine hybrid automaton exactly (ZOH) first")
    p.add_argument("--cut", action="append", metavar="STATE=VALUE", help="fix a state for a 2-D cut (repeat)")
    p.add_argument("--resolution", default="41x31", metavar="NXxNY", help="grid of the cut (default 41x31)")
    p.add_argument("--plot", metavar="FILE", help="PNG of the cut")
    p.add_argument("--save", metavar="FILE", help="save the result (JSON) for the lookup observer")
    p.add_argument("--query", metavar="FILE.csv", help="CSV of states (header = state names): adds 'observable'")
    add_executor_arguments(p)
    p.add_argument("--json", action="store_true", help="machine-readable summary")


def run(args: argparse.Namespace) -> int:
    from ..progress import counter_bar
    from ..regions import analyse_observability, compute_cut, parse_assignments, plot_cut, save_analysis
    named = load_system(args)
    if named.kind == "hybrid_automaton" and args.ts is not None:
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
    if fixed and len(fixed) != system.n - 2:
        raise ModelError("--cut", f"values for exactly {system.n - 2} of the states {list(system.state_names)} (two stay free)",
                         f"{sorted(fixed)}")
    executor = executor_from_args(args)
    update, close = counter_bar(not args.json, "Algorithm 3.1")
    try:
        analysis = analyse_observability(system, args.horizon, executor=executor, progress=update)
    finally:
        close()
        executor.close()
    out = analysis.summary()
    out["example"] = label
    out["system"] = label
    out["params"] = params
    if args.save:
        save_analysis(analysis, args.save, label if named.example is not None else None, params)
        out["saved"] = str(args.save)
    if args.query:
        out["observable"] = _query_points(analysis, args.query, system.state_names)
    if fixed or args.plot:
        if system.n < 2:
            raise ModelError("--plot", "a system with at least 2 states (a cut is a plane)", f"{system.n} state")
        if not fixed and system.n > 2:
            raise ModelError("--plot", f"a --cut fixing {system.n - 2} states so that a 2-D plane remains", "no --cut")
        nx, ny = _resolution(args.resolution)
        update, close = counter_bar(not args.json, "cut")
        try:
            cut = compute_cut(analysis, fixed, (nx, ny), progress=update)
        finally:
            close()
        out["cut"] = {"axes": list(cut.axes), "fixed": cut.fixed, "resolution": [nx, ny],
                      "fraction_observable_of_feasible": cut.fraction_of_feasible("observable"),
                      "fraction_unobservable_of_feasible": cut.fraction_of_feasible("unobservable")}
        if args.plot:
            stretch = {"theta": 10.0} if "theta" in cut.axes else None  # as the paper's figures
            plot_cut(cut, args.plot, title=f"{label}, T = {args.horizon}" + "".join(f", {k} = {v:g}" for k, v in fixed.items()), stretch=stretch)
            out["plot"] = str(args.plot)
    if args.json:
        print_json(out)
        return 0
    print(f"{label} (T = {args.horizon}): {out['n_regions']} regions, {out['n_full_rank']} with rank C_i = n, "
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

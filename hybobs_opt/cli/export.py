"""``hybobs export SYSTEM -T N --out-dir DIR``: the lookup-table observer of a PWA system (paper 002,
Algorithm 4.1) as self-contained C99 source, header and CSV replay driver
(:func:`hybobs_opt.observers.c_export.export_lookup_c`), with the size of its tables and the
worst-case cost of one step.
"""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import ModelError
from ..defaults import DEFAULT_HORIZON
from ..limits import MAX_HORIZON
from ._common import (add_cache_argument, add_lp_budget_argument, add_system_argument, announce, as_options,
                      command_cache, load_system, print_json)
from ._vocabulary import add_hidden_alias

HELP = "write the lookup-table observer (paper 002, Algorithm 4.1) as self-contained C99 with a CSV replay driver"


def add_arguments(p: argparse.ArgumentParser) -> None:
    add_system_argument(p)
    p.add_argument("--horizon", "-T", type=int, metavar="T", default=DEFAULT_HORIZON,
                   help=f"observation horizon T (default {DEFAULT_HORIZON}, 1 to {MAX_HORIZON}: hybobs_opt.limits.MAX_HORIZON)")
    p.add_argument("--out-dir", dest="out_dir", metavar="DIR", required=True,
                   help="directory of hybobs_lookup.h, hybobs_lookup.c and hybobs_lookup_driver.c (created if missing)")
    add_hidden_alias(p, "--out-dir", "--out")
    p.add_argument("--float32", action="store_true",
                   help="float tables and arithmetic (tolerances raised to single precision; refused when the "
                        "pseudo-inverses amplify its rounding beyond 5 %% of a state's range)")
    p.add_argument("--force", action="store_true",
                   help="replace the three files if they exist (never through a symbolic link)")
    p.add_argument("--no-build", action="store_true",
                   help="skip the build check (by default, when a C compiler is found, the files are compiled "
                        "with -std=c99 -Wall -Werror -pedantic and the driver replays a one-sample log; a failure "
                        "exits non-zero)")
    p.add_argument("--max-bytes", type=int, default=None, metavar="N",
                   help="warn when the tables (flash) exceed N bytes")
    p.add_argument("--max-ops", type=int, default=None, metavar="N",
                   help="warn when the worst-case step exceeds N multiply-adds")
    add_cache_argument(p)
    add_lp_budget_argument(p)
    p.add_argument("--json", action="store_true", help="machine-readable summary")


def run(args: argparse.Namespace) -> int:
    announce(args, "loading the LP solvers (numpy, scipy, HiGHS)")
    import sys

    from ..limits import check_horizon_limit

    if args.horizon < 1:
        raise ModelError("--horizon", "a horizon T >= 1", repr(args.horizon))
    check_horizon_limit(args.horizon, "--horizon")
    for option, value, unit in (("--max-bytes", args.max_bytes, "bytes"), ("--max-ops", args.max_ops, "multiply-adds")):
        if value is not None and value < 1:
            raise ModelError(option, f"a positive number of {unit}", repr(value))
    from ..observers.c_export import export_targets

    with as_options({"out_dir": "--out-dir"}):
        export_targets(Path(args.out_dir), overwrite=args.force)  # before any work
    named = load_system(args)
    if named.kind != "pwa":
        raise ModelError("SYSTEM", "a PWA system (the lookup-table observer of paper 002 is built from its "
                         "observability regions)", f"{named.label!r}, a {named.kind.replace('_', '-')} system")
    summary = _export(named, args)
    warnings = summary["warnings"]
    if args.json:
        print_json(summary)
        return 0
    for text in warnings:
        print(f"hybobs export: warning: {text}", file=sys.stderr)
    files = summary["files"]
    print(f"{named.label}, T = {args.horizon} ({'float' if args.float32 else 'double'}): wrote {files['header']}, "
          f"{files['source']}, {files['driver']}")
    print(f"  tables {summary['table_bytes']:,} bytes (flash), state {summary['state_bytes']:,} bytes (RAM), worst-case "
          f"step {summary['max_ops']:,} multiply-adds ({summary['n_regions']} regions, {summary['n_btilde_pieces']} "
          f"pieces of B~_T, test: {summary['btilde_test']})")
    print(f"  build the replay driver: cd {summary['out_dir']} && {summary['compile']}")
    build = summary["build"]
    if build is None:
        print("  build check skipped (--no-build)")
    elif build["compiler"] is None:
        print("  build check: no C compiler found (cc, gcc, clang): the files were not compiled")
    else:
        print(f"  build check: compiled with {build['compiler']} {' '.join(build['flags'])} and replayed a one-sample "
              f"log ({build['seconds']:.1f} s)")
    return 0


def _export(named, args: argparse.Namespace) -> dict:
    """Algorithm 3.1 (cached), the lookup observer's tables and the export; the JSON-ready summary."""
    from ..cache import cached_analysis
    from ..observers.c_export import export_lookup_c
    from ..observers.lookup import LookupObserver
    from ..progress import phase_bars

    progress, close = phase_bars(not args.json)
    try:
        with as_options({"horizon T": "--horizon", "analysis": "--horizon", "tables": "--horizon", "float32": "--float32",
                         "out_dir": "--out-dir"}), command_cache(args) as cache:
            analysis = cached_analysis(named.system, args.horizon, progress=progress)
            observer = LookupObserver(analysis, progress=None if progress is None else
                                      (lambda d, t: progress("lookup tables", "piece", d, t)))
            export = export_lookup_c(observer, args.out_dir, float32=args.float32, overwrite=args.force)
    finally:
        close()
    from ..observers.c_export import check_build

    build = None if args.no_build else check_build(export, named.system)  # BuildError: exit 2, one line
    rec = export.to_dict()
    warnings = []
    if args.max_bytes is not None and export.table_bytes > args.max_bytes:
        warnings.append(f"the tables take {export.table_bytes:,} bytes, more than --max-bytes {args.max_bytes:,}")
    if args.max_ops is not None and export.max_ops > args.max_ops:
        warnings.append(f"the worst-case step takes {export.max_ops:,} multiply-adds, more than --max-ops "
                        f"{args.max_ops:,} (of which {export.ops['btilde_lps']:,} in the B~_T LPs)")
    summary = {"system": named.label, "kind": named.kind, "params": named.params, "horizon": args.horizon,
               "out_dir": rec["directory"], "files": rec["files"], "float32": export.float32,
               "table_bytes": export.table_bytes, "state_bytes": export.state_bytes, "max_ops": export.max_ops,
               "ops": rec["ops"], "n_regions": export.sizes["n_regions"], "n_btilde_pieces": export.sizes["n_btilde_pieces"],
               "btilde_test": export.btilde_test, "sizes": rec["sizes"], "tolerances": rec["tolerances"],
               "float32_rounding": export.float32_rounding, "compile": rec["compile"],
               "max_bytes": args.max_bytes, "max_ops_limit": args.max_ops, "warnings": warnings, "build": build}
    if cache is not None and cache.events:
        summary["cache"] = cache.events
    return summary

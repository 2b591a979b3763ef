"""``hybobs report --out-dir DIR``: the HTML report of every result (``--section KEY`` for some);
``hybobs report SYSTEM --out-dir DIR``: the report of one system, with the sections of its class."""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..errors import ModelError
from ..defaults import DEFAULT_HORIZON
from ..limits import MAX_HORIZON
from ._common import (SYSTEM_HELP, add_force_argument, add_param_argument, announce, as_options, check_output_dir,
                      examples_help, load_system, print_json)
from ._vocabulary import add_hidden_alias


#: The keys of the report's built-in sections, in the report's order (listed here so that ``--help``
#: does not import the report and its studies; a test checks it against
#: :func:`hybobs_opt.report.html.section_keys`).
SECTION_KEYS = ("examples", "regions", "lmi", "vehicle_paper_design", "piston_comparison", "driveline_observer", "drift",
                "sliding_mode", "observers")

HELP = "build the HTML report of every result, or of one system"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("system", nargs="?", default=None, metavar="SYSTEM",
                   help=lambda: f"optional: {SYSTEM_HELP}; the examples: {examples_help()}")
    add_param_argument(p)
    p.add_argument("--out-dir", dest="out", required=True, metavar="DIR",
                   help="output directory (index.html and the figures; created if missing)")
    add_hidden_alias(p, "--out-dir", "--out")
    p.add_argument("--section", action="append", metavar="KEY",
                   help=f"build only these sections of the report of every result (repeatable), among: "
                        f"{', '.join(SECTION_KEYS)}")
    p.add_argument("--horizon", "-T", type=int, metavar="T", default=None,
                   help=f"with a PWA SYSTEM: horizon of the regions and observers (default {DEFAULT_HORIZON}, at most {MAX_HORIZON})")
    p.add_argument("--data", metavar="LOG.csv", help="with a PWA SYSTEM: compare the observers on this log")
    p.add_argument("--noise-bound", action="append", metavar="NAME=VALUE", dest="noise_bound",
                   help="with --data: the bound on an output's noise in its units (repeatable; a bare VALUE bounds every "
                        "output; outputs not named: 0); the observers then state certified radii and the "
                        "set-membership observer joins them")
    p.add_argument("--quick", action="store_true",
                   help="a preview of the report of every result: every section and figure from fewer samples (about a third of the time)")
    add_force_argument(p)
    p.add_argument("--json", action="store_true", help="print a JSON summary")


def run(args: argparse.Namespace) -> int:
    announce(args, "loading the report (numpy, matplotlib, the solvers)")
    from ..progress import section_bar

    check_output_dir("--out-dir", args.out, args.force, "index.html")
    named = None
    if args.system is None:
        for option in ("param", "data", "horizon", "noise_bound"):
            if getattr(args, option) is not None:
                raise ModelError(f"--{option.replace('_', '-')}", "a SYSTEM as well (it applies to the report of one system)",
                                 "no SYSTEM")
    elif args.quick:
        raise ModelError("--quick", "no --quick with SYSTEM (it previews the report of every result)", "--quick")
    if args.system is None:
        if args.section:
            from ..report.html import section_keys

            keys = section_keys()
            unknown = [k for k in args.section if k not in keys]
            if unknown:
                raise ModelError("--section", f"section keys among {', '.join(keys)}", repr(unknown[0]))
    else:
        if args.section:
            raise ModelError("--section", "no --section with SYSTEM (the sections follow the system's class)", f"{args.section}")
        if args.horizon is not None and not 1 <= args.horizon <= MAX_HORIZON:
            raise ModelError("--horizon", f"a horizon T in 1..{MAX_HORIZON} (hybobs_opt.limits.MAX_HORIZON)", repr(args.horizon))
        named = load_system(args)
        if named.kind != "pwa":
            for option in ("horizon", "data", "noise_bound"):
                if getattr(args, option) is not None:
                    raise ModelError(f"--{option.replace('_', '-')}", f"no value for a {named.kind.replace('_', '-')} system "
                                     "(it applies to the PWA sections: regions, observers)", repr(getattr(args, option)))
        elif args.horizon is not None:
            from ..regions.enumeration import check_horizon

            with as_options({"horizon T": "--horizon"}):
                check_horizon(named.system, args.horizon)
        if args.data is not None:
            from ..sim.log import read_log

            read_log(args.data, named.system)  # a bad log is bad input, not a failed section
        if args.noise_bound is not None:
            if args.data is None:
                raise ModelError("--noise-bound", "--data as well (the radii are those of the observers on a log)",
                                 repr(args.noise_bound[0]))
            from ._common import bound_entries

            args.noise_bound = bound_entries(args.noise_bound, tuple(named.system.output_names), "--noise-bound",
                                             "noise_bound", "output")
    if named is None:
        from ..report.html import section_keys

        keys = [k for k in section_keys() if not args.section or k in args.section]
    else:
        from ..report.system_report import system_report_keys

        keys = system_report_keys(named.system, args.data)
    update, close = section_bar(not args.json, keys)
    try:
        if named is None:
            from ..report import build_report

            result = build_report(args.out, progress=update, only=args.section, quick=args.quick)
        else:
            from ..report.system_report import build_system_report

            horizon = DEFAULT_HORIZON if args.horizon is None else args.horizon
            result = build_system_report(named.system, named.label, args.out, horizon=horizon, data=args.data,
                                         noise_bound=args.noise_bound, progress=update)
            result["system"] = named.label
    finally:
        close()
    failed = [r for r in result["sections"] if not r["ok"]]
    if failed:
        result["error"] = (f"{len(failed)} of {len(result['sections'])} sections failed: "
                           + "; ".join(f"{r['key']} ({r['error']})" for r in failed))
    if args.json:
        print_json(result)
    else:
        for rec in result["sections"]:
            status = "ok" if rec["ok"] else f"FAILED: {rec['error']}"
            print(f"  {rec['title']}: {status} ({rec['seconds']:.1f} s)")
        print(f"report written to {Path(result['index']).resolve()}")
        if failed:
            print(f"hybobs report: error: {' '.join(result['error'].split())}", file=sys.stderr)
    return 0 if not failed else 2

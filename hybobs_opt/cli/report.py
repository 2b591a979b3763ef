"""``hybobs report --out DIR``: the HTML report of every result (``--section KEY`` for some);
``hybobs report SYSTEM --out DIR``: the report of one system, with the sections of its class."""

from __future__ import annotations

import argparse
from pathlib import Path

from ..errors import ModelError
from ._common import SYSTEM_HELP, load_system, print_json

HELP = "build the HTML report of every result, or of one system"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("system", nargs="?", default=None, metavar="SYSTEM", help="optional: " + SYSTEM_HELP)
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help="parameter of an example or of FUNCTION")
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--section", action="append", metavar="KEY", help="build only these sections (report of every result)")
    p.add_argument("--horizon", "-T", type=int, default=2, help="with SYSTEM: horizon of the PWA sections (default 2)")
    p.add_argument("--data", metavar="LOG.csv", help="with SYSTEM (PWA): compare the observers on this log")
    p.add_argument("--json", action="store_true", help="print a JSON summary")


def run(args: argparse.Namespace) -> int:
    from ..progress import status_line

    if args.system is None:
        for option in ("param", "data"):
            if getattr(args, option):
                raise ModelError(f"--{option}", "a SYSTEM as well (it applies to the report of one system)", "no SYSTEM")
    elif args.section:
        raise ModelError("--section", "no --section with SYSTEM (the sections follow the system's class)", f"{args.section}")
    if args.horizon < 1:
        raise ModelError("--horizon", "a horizon T >= 1", repr(args.horizon))
    update, close = status_line(not args.json)
    try:
        if args.system is None:
            from ..report import build_report

            result = build_report(args.out, progress=update, only=args.section)
        else:
            from ..report.system_report import build_system_report

            named = load_system(args)
            result = build_system_report(named.system, named.label, args.out, horizon=args.horizon, data=args.data,
                                         progress=update)
            result["system"] = named.label
    finally:
        close()
    if args.json:
        print_json(result)
    else:
        for rec in result["sections"]:
            status = "ok" if rec["ok"] else f"FAILED: {rec['error']}"
            print(f"  {rec['title']}: {status} ({rec['seconds']:.1f} s)")
        print(f"report written to {Path(result['index']).resolve()}")
    return 0 if all(r["ok"] for r in result["sections"]) else 2

"""``hybobs report --out DIR``: the HTML report of every result (``--section KEY`` for some)."""

from __future__ import annotations

import argparse
from pathlib import Path

from ._common import print_json

HELP = "build the HTML report of every result"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--out", required=True, metavar="DIR", help="output directory")
    p.add_argument("--section", action="append", metavar="KEY", help="build only these sections")
    p.add_argument("--json", action="store_true", help="print a JSON summary")


def run(args: argparse.Namespace) -> int:
    from ..progress import status_line
    from ..report import build_report

    update, close = status_line(not args.json)
    try:
        result = build_report(args.out, progress=update, only=args.section)
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

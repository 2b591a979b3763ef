"""``hybobs observe EXAMPLE``: run an observer on an example's scenario (the studies' scenarios)."""

from __future__ import annotations

import argparse

from ._common import print_json

HELP = "run an observer on an example's scenario"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("example", help="example name")
    p.add_argument("--observer", default=None, metavar="KIND", help="observer kind")
    p.add_argument("--filter", action="store_true", help="low-pass filter variant (sliding-mode observers)")
    p.add_argument("--plot", metavar="FILE", help="write a PNG of the run")
    p.add_argument("--json", action="store_true", help="print a JSON summary")


def run(args: argparse.Namespace) -> int:
    from ..studies import get_example
    from ..studies.scenarios import get_scenario

    example = get_example(args.example)
    scenario = get_scenario(example.name)
    summary = scenario(args)
    if args.json:
        print_json(summary)
    else:
        for key, value in summary.items():
            if isinstance(value, (list, dict)) and len(str(value)) > 200:
                value = f"{type(value).__name__} of {len(value)} items (use --json)"
            print(f"{key}: {value}")
    return 0

"""``hybobs examples [--json]``: the seed papers' example systems (no system is built)."""

from __future__ import annotations

import argparse

from ._common import print_json

HELP = "list the seed papers' example systems"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--json", action="store_true", help="machine-readable output")


def run(args: argparse.Namespace) -> int:
    from ..studies import list_examples

    examples = list_examples()
    if args.json:
        print_json([ex.to_dict() for ex in examples])
        return 0
    width = max(len(ex.name) for ex in examples)
    for ex in examples:
        print(f"{ex.name:<{width}}  paper {ex.paper}  {ex.kind:<17} n={ex.n_states}  {ex.summary}")
    return 0

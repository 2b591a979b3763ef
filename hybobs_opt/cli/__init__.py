"""The ``hybobs`` command: a thin layer over the package, ``--json`` on every command.

One module per command (``examples``, ``simulate``, ``report``, ``regions``, ``observe``,
``bench``, ``diagnose``, ``synth``, ``model``), each with ``HELP``, ``add_arguments(parser)`` and
``run(args) -> exit code``.  Command modules import only the standard library at import time;
the package (numpy, the solvers) is loaded inside ``run``, so ``hybobs --help`` and
``hybobs examples`` start without importing cvxpy, CasADi or numba.

Exit codes: 0 success, 2 bad input or a failed computation (one-line message on stderr).
"""

from __future__ import annotations

import argparse
import importlib
import sys

from ..errors import HybobsError
from ._common import json_default as _json_default  # noqa: F401  (old private names)
from ._common import number as _number  # noqa: F401
from ._common import parse_params as _parse_params  # noqa: F401
from ._common import print_json as _print_json  # noqa: F401

#: The commands, in the order ``hybobs --help`` lists them: name -> module of this package.
COMMANDS: dict[str, str] = {
    "examples": "examples",
    "simulate": "simulate",
    "report": "report",
    "regions": "regions",
    "observe": "observe",
    "bench": "bench",
    "diagnose": "diagnose",
    "synth": "synth",
    "model": "model",
}

#: Extra modules that add subcommands through ``add_commands(subparsers)`` (a hook for plug-ins).
COMMAND_MODULES: list[str] = []


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="hybobs",
        description="Optimization-based state observers for hybrid systems (hybobs_opt).",
    )
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"{__name__}.{module_name}")
        p = sub.add_parser(name, help=module.HELP)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    for module in COMMAND_MODULES:
        importlib.import_module(module).add_commands(sub)
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

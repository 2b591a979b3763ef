"""``hybobs model schema|check|export``: the model-file format from the command line.

``schema`` prints the JSON Schema of model files; ``check SYSTEM`` builds the system (every check of
its class runs, the PWA partition check included) and prints its sizes and names; ``export SYSTEM
--out FILE.toml|.yaml|.json`` writes any system (an example, ``PATH.py:FUNCTION`` ...) as a model
file, the starting point for a model of one's own.
"""

from __future__ import annotations

import argparse

from ._common import (SYSTEM_HELP, add_force_argument, add_param_argument, announce, check_output_path, examples_help,
                      load_system, print_json)
from ._text import print_summary

HELP = "model files: print the JSON Schema, check a model, export a system as a model file"


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("action", choices=("schema", "check", "export"), help="what to do")
    p.add_argument("system", nargs="?", metavar="SYSTEM",
                   help=lambda: f"for check/export: {SYSTEM_HELP}; the examples: {examples_help()}")
    add_param_argument(p)
    add_force_argument(p)
    p.add_argument("--out", "-o", metavar="FILE",
                   help="export: the model file to write (.toml, .yaml, .json; its directory is created if missing)")
    p.add_argument("--json", action="store_true", help="machine-readable output")


def run(args: argparse.Namespace) -> int:
    from ..errors import ModelError

    if args.action == "schema":
        from ..systems.model_file import model_schema

        for option, value in (("SYSTEM", args.system), ("--param", args.param), ("--out", args.out)):
            if value:
                raise ModelError(option, "no value for 'model schema' (it prints the JSON Schema of model files)",
                                 repr(value if isinstance(value, str) else value[0]))

        print_json(model_schema())
        return 0
    if not args.system:
        raise ModelError("SYSTEM", f"a system to {args.action}", "none")
    if args.action == "check" and args.out:
        raise ModelError("--out", "no value for 'model check' (export writes a model file)", repr(args.out))
    if args.action == "export" and not args.out:
        raise ModelError("--out", "a file name ending in .toml, .yaml or .json", "none")
    check_output_path("--out", args.out, args.force, create_parents=True)
    announce(args, "loading the model (numpy, scipy)")
    named = load_system(args)
    if args.action == "export":
        from pathlib import Path

        from ..systems.model_file import save_model

        Path(args.out).parent.mkdir(parents=True, exist_ok=True)
        path = save_model(named.system, args.out)
        out = {"system": named.label, "class": named.kind, "written": str(path)}
    else:
        d = named.system.to_dict()
        out = {"system": named.label, "class": d["class"], "name": d.get("name", ""), "states": d.get("states", []),
               "inputs": d.get("inputs", []), "outputs": d.get("outputs", []),
               "n_modes": len(d["modes"]) if d["class"] in ("pwa", "constant_drift") else None,
               "n_locations": len(d["locations"]) if d["class"] == "hybrid_automaton" else None,
               "partition": d.get("partition"), "valid": True}
    if args.json:
        print_json(out)
    else:
        print_summary({k: v for k, v in out.items() if v is not None})
    return 0

"""What every ``hybobs`` command shares: JSON output, ``--param`` parsing, the executor options.

Imports nothing heavy (``hybobs --help`` builds every command's parser without loading numpy,
cvxpy, CasADi or numba).
"""

from __future__ import annotations

import argparse
import json
from typing import Any

from ..errors import ModelError


def print_json(obj: Any) -> None:
    """Print ``obj`` as one line of JSON (numpy arrays and scalars become lists and numbers)."""
    print(json.dumps(obj, default=json_default))


def json_default(value: Any) -> Any:
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def parse_params(items: list[str] | None) -> dict[str, float]:
    """``--param NAME=VALUE`` (repeatable) -> ``{NAME: float}``; fractions like ``1/12`` allowed."""
    params: dict[str, float] = {}
    for item in items or []:
        if "=" not in item:
            raise ModelError("--param", "NAME=VALUE (e.g. gear_ratio=0.5)", repr(item))
        key, value = item.split("=", 1)
        try:
            params[key.strip()] = number(value)
        except ValueError:
            raise ModelError(f"--param {key}", "a number (fractions like 1/12 allowed)", repr(value)) from None
    return params


def number(text: str) -> float:
    text = text.strip()
    if "/" in text:
        num, den = text.split("/", 1)
        return float(num) / float(den)
    return float(text)


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    """``--executor``, ``--workers``, ``--scheduler``, ``--dask-local``: where the LPs run."""
    p.add_argument("--executor", choices=("serial", "processes"), default="processes", help="where the LPs run")
    p.add_argument("--workers", type=int, default=None, help="number of local processes (default: all cores)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run on a Dask distributed scheduler")
    p.add_argument("--dask-local", type=int, metavar="N", help="start a Dask LocalCluster with N workers")


def executor_from_args(args: argparse.Namespace):
    from ..executor import make_executor

    if args.workers is not None and args.workers < 1:
        raise ModelError("--workers", "a positive number of processes", repr(args.workers))
    if args.dask_local is not None and args.dask_local < 1:
        raise ModelError("--dask-local", "a positive number of workers", repr(args.dask_local))
    return make_executor(args.executor, args.workers, args.scheduler, args.dask_local)


#: Help text of the positional system argument of every command.
SYSTEM_HELP = ("the system: an example name ('hybobs examples'), a model file PATH.toml|.yaml|.json, "
               "PATH.py:FUNCTION or package.module:FUNCTION (called with the --param values)")


def add_system_argument(p: argparse.ArgumentParser, help: str = SYSTEM_HELP) -> None:
    """The positional ``SYSTEM`` and the repeatable ``--param NAME=VALUE`` of every command."""
    p.add_argument("system", metavar="SYSTEM", help=help)
    p.add_argument("--param", action="append", metavar="NAME=VALUE",
                   help="parameter of an example or of FUNCTION (repeatable), e.g. gear_ratio=1/2")


class NamedSystem:
    """A system named on the command line: ``label`` (what the user typed), the system object,
    the example (``None`` unless the name is a shipped example) and the parameters."""

    def __init__(self, label: str, system: Any, example: Any, params: dict[str, float]):
        self.label, self.system, self.example, self.params = label, system, example, params

    @property
    def kind(self) -> str:
        """``pwa``, ``hybrid_automaton``, ``constant_drift`` or ``scalar_nonlinear`` (the model-file class)."""
        from ..systems.model_dict import model_class

        return model_class(self.system)


def load_system(args: argparse.Namespace) -> NamedSystem:
    """Resolve ``args.system`` with ``args.param`` (:func:`hybobs_opt.systems.resolve.resolve_system`)."""
    from ..studies import list_examples
    from ..systems.model_file import is_model_path
    from ..systems.resolve import resolve_system

    params = parse_params(getattr(args, "param", None))
    examples = {ex.name: ex for ex in list_examples()}
    example = examples.get(args.system)
    if example is None and ":" not in args.system and not is_model_path(args.system):
        raise ModelError("SYSTEM", f"one of the examples {sorted(examples)}, a model file (.toml, .yaml, .json), "
                         "PATH.py:FUNCTION or module:FUNCTION", repr(args.system))
    if example is not None:
        unknown = set(params) - set(example.params)
        if unknown:
            raise ModelError(f"--param (parameters of example {example.name!r})", f"names among {sorted(example.params) or 'none'}",
                             f"{sorted(unknown)}")
    return NamedSystem(args.system, resolve_system(args.system, params), example, params)


def require_kind(named: NamedSystem, kinds: tuple[str, ...], why: str) -> None:
    """``ModelError`` unless the system is of one of ``kinds`` (``why`` says what needs it)."""
    if named.kind not in kinds:
        show = [k.replace("_", "-") for k in kinds]
        raise ModelError("SYSTEM", f"a {' or '.join(show)} system ({why})", f"{named.label!r}, a {named.kind.replace('_', '-')} system")


def file_slug(label: str) -> str:
    """A file-name-safe form of a system label (``examples/models/robot.toml`` -> ``robot.toml``)."""
    from pathlib import Path

    return "".join(c if c.isalnum() or c in "-_." else "_" for c in Path(label).name) or "system"

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

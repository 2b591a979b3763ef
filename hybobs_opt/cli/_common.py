"""What every ``hybobs`` command shares: JSON output, ``--param`` parsing, the executor options.

Imports nothing heavy (``hybobs --help`` builds every command's parser without loading numpy,
cvxpy, CasADi or numba).
"""

from __future__ import annotations

import argparse
import json
import os
import re
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from ..errors import ModelError
from ..limits import MAX_WORKERS_PER_CORE


def print_json(obj: Any) -> None:
    """Print ``obj`` as one line of strict JSON: numpy arrays and scalars become lists and numbers, and
    a NaN or infinite number becomes ``null`` (``NaN`` / ``Infinity`` are not JSON and strict parsers
    refuse them)."""
    print(json.dumps(strict_json(obj), default=json_default, allow_nan=False))


def strict_json(value: Any) -> Any:
    """``value`` with every NaN or infinite float (numpy's included, in arrays too) replaced by ``None``."""
    import math
    import sys

    np = sys.modules.get("numpy")  # no numpy value can exist unless numpy is loaded: do not load it
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [strict_json(v) for v in value]
    if np is not None and isinstance(value, np.ndarray):
        return strict_json(value.tolist())
    if np is not None and isinstance(value, np.floating):
        return strict_json(float(value))
    return value


def json_default(value: Any) -> Any:
    import numpy as np

    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def parse_params(items: list[str] | None, vectors: dict[str, int] | None = None,
                 text: frozenset[str] | set[str] | None = None) -> dict[str, Any]:
    """``--param NAME=VALUE`` (repeatable) -> ``{NAME: value}``; fractions like ``1/12`` allowed.

    A value that reads as a number is a float.  ``text`` names the parameters whose value may be a
    string (``None``: any parameter; a builder function's signature decides later, see
    :func:`hybobs_opt.systems.resolve.resolve_system`); any other value must be a number.
    ``vectors`` names the parameters that are vectors (name -> length): their value is a
    comma-separated list of that many numbers (``lam=1,2,3``) and becomes a tuple.
    """
    params: dict[str, Any] = {}
    vectors = vectors or {}
    for item in items or []:
        if "=" not in item:
            raise ModelError("--param", "NAME=VALUE (e.g. gear_ratio=0.5)", repr(item))
        key, value = item.split("=", 1)
        if key.strip() in vectors:
            params[key.strip()] = _vector(key.strip(), value, vectors[key.strip()])
            continue
        if not key.strip():
            raise ModelError("--param", "NAME=VALUE with a parameter name before '='", repr(item))
        try:
            params[key.strip()] = number(value)
        except ValueError:
            if text is None or key.strip() in text:
                params[key.strip()] = value
                continue
            why = " (division by zero)" if "/" in value and _zero_denominator(value) else ""
            raise ModelError(f"--param {key}", "a number (fractions like 1/12 allowed, with a non-zero denominator)",
                             repr(value) + why) from None
    return params


def _vector(key: str, text: str, size: int) -> tuple[float, ...]:
    parts = [p for p in text.split(",")]
    try:
        values = tuple(number(p) for p in parts)
    except ValueError:
        values = ()
    if len(values) != size:
        raise ModelError(f"--param {key}", f"{size} comma-separated numbers (a vector parameter, e.g. "
                         f"{key}={','.join(['1'] * size)})", repr(text))
    return values


def _zero_denominator(text: str) -> bool:
    try:
        return float(text.split("/", 1)[1]) == 0
    except ValueError:
        return False


def number(text: str) -> float:
    """``"0.5"``, ``"1e-3"`` or a fraction ``"1/12"`` -> float; ``ValueError`` otherwise (also ``"1/0"``)."""
    text = text.strip()
    if "/" in text:
        num, den = text.split("/", 1)
        den_value = float(den)
        if den_value == 0:
            raise ValueError(f"division by zero in {text!r}")
        return float(num) / den_value
    return float(text)


#: Address schemes of a Dask scheduler (``--scheduler SCHEME://HOST:PORT``), as ``distributed`` names them.
SCHEDULER_SCHEMES = ("tcp", "tls", "ws", "wss", "ucx", "inproc")

_SCHEDULER = re.compile(r"^(?:(?P<scheme>[a-z]+)://)?(?P<host>\[[0-9a-fA-F:]+\]|[A-Za-z0-9_.-]+):(?P<port>[0-9]+)$")


def add_executor_arguments(p: argparse.ArgumentParser) -> None:
    """``--executor``, ``--workers``, ``--scheduler``, ``--dask-local``: where the LPs run."""
    p.add_argument("--executor", choices=("serial", "processes"), default=None,
                   help="where the LPs run: serial or processes (default processes)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help=f"number of local processes (default: all cores; at most {MAX_WORKERS_PER_CORE} per core)")
    p.add_argument("--scheduler", metavar="tcp://HOST:PORT",
                   help=f"run on a Dask distributed scheduler (address schemes: {', '.join(SCHEDULER_SCHEMES)})")
    p.add_argument("--dask-local", type=int, metavar="N", help="start a Dask LocalCluster with N workers")


def check_scheduler(address: str) -> None:
    """``ModelError("--scheduler")`` unless ``address`` is ``[SCHEME://]HOST:PORT`` with a known scheme and a port."""
    m = _SCHEDULER.match(address or "")
    scheme = m and m.group("scheme")
    if not m or (scheme is not None and scheme not in SCHEDULER_SCHEMES) or not 0 < int(m.group("port")) < 65536:
        raise ModelError("--scheduler", f"a scheduler address SCHEME://HOST:PORT (SCHEME one of {', '.join(SCHEDULER_SCHEMES)}; "
                         "PORT in 1..65535), e.g. tcp://127.0.0.1:8786", repr(address))


def executor_from_args(args: argparse.Namespace):
    from ..executor import make_executor

    dask = [o for o, v in (("--scheduler", args.scheduler), ("--dask-local", args.dask_local)) if v is not None]
    if len(dask) == 2:
        raise ModelError("--scheduler", "either --scheduler or --dask-local (one Dask cluster)", "both")
    if dask and args.executor is not None:
        raise ModelError("--executor", f"no value with {dask[0]} (the Dask cluster runs the LPs)", repr(args.executor))
    if args.workers is not None:
        if dask:
            raise ModelError("--workers", f"no value with {dask[0]} (the cluster has its own workers)", repr(args.workers))
        if args.executor == "serial":
            raise ModelError("--workers", "no value with --executor serial (one process)", repr(args.workers))
        _check_count("--workers", args.workers, "processes", "processes")
    if args.dask_local is not None:
        _check_count("--dask-local", args.dask_local, "workers", "local workers")
    if args.scheduler is not None:
        check_scheduler(args.scheduler)
    return make_executor(args.executor or "processes", args.workers, args.scheduler, args.dask_local)



def _check_count(option: str, value: int, unit: str, limit_unit: str) -> None:
    """A worker count between 1 and :func:`~hybobs_opt.limits.max_workers` (``MAX_WORKERS_PER_CORE`` per core)."""
    from ..limits import max_workers

    if value < 1:
        raise ModelError(option, f"a positive number of {unit}", repr(value))
    if value > max_workers():
        raise ModelError(option, f"at most {max_workers()} {limit_unit} (hybobs_opt.limits.MAX_WORKERS_PER_CORE = "
                         f"{MAX_WORKERS_PER_CORE} per core)", repr(value))

#: Help text of the positional system argument of every command.
SYSTEM_HELP = ("the system: an example name ('hybobs examples'), a model file PATH.toml|.yaml|.json, "
               "PATH.py:FUNCTION or package.module:FUNCTION (called with the --param values)")


def add_system_argument(p: argparse.ArgumentParser, help: str = SYSTEM_HELP) -> None:
    """The positional ``SYSTEM`` and the repeatable ``--param NAME=VALUE`` of every command."""
    p.add_argument("system", metavar="SYSTEM", help=(lambda: help + f"; the examples: {examples_help()}"))
    add_param_argument(p)


#: Help text of ``--param``.
PARAM_HELP = ("parameter of an example or of FUNCTION (repeatable), e.g. gear_ratio=1/2; a number (fractions "
              "allowed), or a string where FUNCTION's parameter is one (annotated str or with a str default)")


def add_param_argument(p: argparse.ArgumentParser) -> None:
    """The repeatable ``--param NAME=VALUE``."""
    p.add_argument("--param", action="append", metavar="NAME=VALUE", help=PARAM_HELP)


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

    examples = {ex.name: ex for ex in list_examples()}
    example = examples.get(args.system)
    vectors = {k: len(v) for k, v in example.params.items() if isinstance(v, (tuple, list))} if example else {}
    text = frozenset(k for k, v in example.params.items() if isinstance(v, str)) if example else None
    params = parse_params(getattr(args, "param", None), vectors, text)
    if example is None and ":" not in args.system and not is_model_path(args.system):
        raise ModelError("SYSTEM", f"one of the examples {sorted(examples)}, a model file (.toml, .yaml, .json), "
                         "PATH.py:FUNCTION or module:FUNCTION", repr(args.system))
    if example is not None:
        unknown = set(params) - set(example.params)
        if unknown:
            raise ModelError(f"--param (parameters of example {example.name!r})", f"names among {sorted(example.params) or 'none'}",
                             f"{sorted(unknown)}")
        for key, value in list(params.items()):
            if isinstance(example.params[key], bool):
                if value not in (0.0, 1.0):
                    raise ModelError(f"--param {key}", f"0 or 1 (a yes/no parameter of example {example.name!r})", repr(value))
                params[key] = bool(value)
    fields = {key: f"--param {key}" for key in params} if example is not None else {
        f"{args.system}: params {key}": f"--param {key}" for key in params}
    with as_options(fields):
        system = resolve_system(args.system, params)
    return NamedSystem(args.system, system, example, params)


def require_kind(named: NamedSystem, kinds: tuple[str, ...], why: str) -> None:
    """``ModelError`` unless the system is of one of ``kinds`` (``why`` says what needs it)."""
    if named.kind not in kinds:
        show = [k.replace("_", "-") for k in kinds]
        raise ModelError("SYSTEM", f"a {' or '.join(show)} system ({why})", f"{named.label!r}, a {named.kind.replace('_', '-')} system")


def file_slug(label: str) -> str:
    """A file-name-safe form of a system label (``examples/models/robot.toml`` -> ``robot.toml``)."""
    from pathlib import Path

    return "".join(c if c.isalnum() or c in "-_." else "_" for c in Path(label).name) or "system"


def examples_help() -> str:
    """The names of the examples (for a lazily computed ``--help`` text)."""
    from ..studies import list_examples

    return ", ".join(ex.name for ex in list_examples())


def check_figure_path(option: str, path: Any, force: bool = False) -> None:
    """``ModelError`` unless ``path`` names a figure file matplotlib can write and
    :func:`check_output_path` accepts it (checked before any work).

    The extension chooses the format (``.png``, ``.pdf``, ``.svg`` ...): a name without one would be
    written under another name (matplotlib appends ``.png``), an unknown one fails after the run.
    """
    if path is None:
        return
    from matplotlib.backend_bases import FigureCanvasBase

    formats = sorted(FigureCanvasBase.get_supported_filetypes())
    p = Path(str(path))
    suffix = p.suffix.lower().lstrip(".")
    if suffix not in formats:
        raise ModelError(option, f"a figure file name ending in one of {', '.join('.' + f for f in formats)}", repr(str(path)))
    check_output_path(option, path, force)


def add_force_argument(p: argparse.ArgumentParser) -> None:
    """``--force``: replace output files that exist (a symbolic link is refused even then)."""
    p.add_argument("--force", action="store_true",
                   help="replace output files that already exist (without it they are refused before any work; a "
                        "symbolic link at an output path is never followed)")


def check_output_path(option: str, path: Any, force: bool = False, create_parents: bool = False) -> None:
    """``ModelError`` before any work if ``path`` (a file to write) is a symbolic link (never
    followed), an existing directory or other non-regular file, an existing file without
    ``force``, or if its directory is missing (unless ``create_parents``: then it must be creatable,
    its nearest existing ancestor a writable directory, and the writer creates it) or not writable."""
    if path is None:
        return
    p = Path(str(path))
    if p.is_symlink():
        raise ModelError(option, "a path that is not a symbolic link (a link is never followed, not even with --force)",
                         f"{str(path)!r}, a link to {os.readlink(p)!r}")
    if p.is_dir():
        raise ModelError(option, "a file name (not a directory)", repr(str(path)))
    if p.exists() and not p.is_file():
        raise ModelError(option, "a regular file or a new name", f"{str(path)!r}")
    if p.exists() and not force:
        raise ModelError(option, "a new file (or --force to replace it)", f"{str(path)!r} exists")
    parent = p.parent if str(p.parent) else Path(".")
    if not parent.exists() and create_parents:
        ancestor = parent
        while not ancestor.exists() and ancestor.parent != ancestor:
            ancestor = ancestor.parent
        if ancestor.is_symlink() or not ancestor.is_dir() or not os.access(ancestor, os.W_OK | os.X_OK):
            raise ModelError(option, "a file in a directory that can be created", f"{str(path)!r} (below {str(ancestor)!r})")
        return
    if not parent.is_dir():
        raise ModelError(option, "a file in an existing directory", f"{str(path)!r} (no directory {str(parent)!r})")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise ModelError(option, "a file in a directory you can write", f"{str(path)!r}")


def check_output_dir(option: str, path: Any, force: bool, marker: str | None) -> None:
    """``ModelError`` before any work if ``path`` (a directory to fill) is a symbolic link or a
    file, holds a symbolic link (the files written there never follow one), or already holds
    ``marker`` (the index of an earlier run; ``None``: not checked) without ``force``; a missing directory must be
    creatable (its nearest existing ancestor a writable directory)."""
    if path is None:
        return
    p = Path(str(path))
    if p.is_symlink():
        raise ModelError(option, "a directory that is not a symbolic link", f"{str(path)!r}, a link to {os.readlink(p)!r}")
    if p.exists() and not p.is_dir():
        raise ModelError(option, "a directory (created if missing)", f"{str(path)!r}, an existing file")
    if p.is_dir():
        links = sorted(q.name for q in p.iterdir() if q.is_symlink())
        if links:
            raise ModelError(option, "a directory without symbolic links (the files written there never follow one)",
                             f"{str(path)!r} holds {', '.join(map(repr, links[:5]))}")
        if marker is not None and (p / marker).exists() and not force:
            raise ModelError(option, f"a directory without an earlier {marker} (or --force to replace it)",
                             f"{str(p / marker)!r} exists")
        if not os.access(p, os.W_OK | os.X_OK):
            raise ModelError(option, "a directory you can write", repr(str(path)))
        return
    ancestor = p.parent if str(p.parent) else Path(".")
    while not ancestor.exists() and ancestor.parent != ancestor:
        ancestor = ancestor.parent
    if not ancestor.is_dir() or not os.access(ancestor, os.W_OK | os.X_OK):
        raise ModelError(option, "a directory that can be created", f"{str(path)!r} (below {str(ancestor)!r})")


@contextmanager
def as_options(fields: Mapping[str, str]) -> Iterator[None]:
    """Re-raise a core ``ModelError`` about a parameter (``t_final``, ``horizon T`` ...) as one about the
    command-line option it came from (``fields``: parameter -> option).  Core messages never name a
    flag (DESIGN.md); the CLI translates, and only around calls whose parameters the user gave."""
    try:
        yield
    except ModelError as exc:
        option = fields.get(exc.field)
        if option is None:
            raise
        raise ModelError(option, exc.expected, exc.got) from exc


def add_lp_budget_argument(p: argparse.ArgumentParser) -> None:
    """``--max-lps N``: run an analysis predicted beyond the default budget of pair LPs."""
    from ..limits import MAX_PREDICTED_PAIR_LPS

    p.add_argument("--max-lps", type=int, default=None, metavar="N",
                   help=f"run Algorithm 3.1 when its predicted pair LPs exceed the default budget of "
                        f"{MAX_PREDICTED_PAIR_LPS:,} (a horizon predicted beyond the budget is refused before any LP, "
                        "with the prediction)")


def add_cache_argument(p: argparse.ArgumentParser) -> None:
    """``--no-cache``: compute the analyses and lookup tables afresh (:mod:`hybobs_opt.cache`)."""
    p.add_argument("--no-cache", action="store_true",
                   help="compute the observability analysis and lookup tables afresh, without reading or writing the "
                        "cache (~/.cache/hybobs_opt, or $HYBOBS_CACHE_DIR; empty it with 'hybobs cache clear'; "
                        "HYBOBS_NO_CACHE=1 has the same effect)")


def cache_disabled(args: argparse.Namespace) -> bool:
    """``--no-cache`` or ``HYBOBS_NO_CACHE`` set to 1/true/yes."""
    from .._environment import result_cache_switched_off

    return bool(getattr(args, "no_cache", False)) or result_cache_switched_off()


@contextmanager
def command_cache(args: argparse.Namespace) -> Iterator[Any]:
    """The command's :class:`~hybobs_opt.cache.ResultCache`, active inside the block (``None`` with ``--no-cache``).

    Each cache event is printed on stderr (``hybobs COMMAND: ...``), except under ``--json``,
    where the command lists :attr:`~hybobs_opt.cache.ResultCache.events` under ``"cache"``.
    """
    import sys

    from ..cache import ResultCache, use_cache

    if cache_disabled(args):
        yield None
        return
    log = None if getattr(args, "json", False) else (lambda msg: print(f"hybobs {args.command}: {msg}", file=sys.stderr))
    cache = ResultCache(log=log)
    with use_cache(cache):
        yield cache


def bound_entries(entries, names: tuple, option: str, field: str, what: str) -> dict:
    """``NAME=VALUE`` entries (or one bare ``VALUE`` for every name) as a dict by name, checked."""
    from ..contract import noise_bound_vector

    bound: dict[str, float] = {}
    for entry in entries:
        name, sep, value = entry.partition("=")
        if not sep:
            name, value = "", entry
        try:
            number = float(value)
        except ValueError:
            raise ModelError(option, "NAME=VALUE with a number VALUE (or one number)", repr(entry)) from None
        for nm in ([name] if name else names):
            if nm in bound:
                raise ModelError(option, f"each {what} once", repr(entry))
            bound[nm] = number
    with as_options({field: option}):
        noise_bound_vector(bound, names, field)
    return bound


def announce(args: argparse.Namespace, what: str) -> None:
    """The first line of a command on a terminal, before its heavy imports: ``hybobs CMD: WHAT ...`` on stderr.

    Loading numpy, scipy, cvxpy and CasADi takes seconds, and a first analysis more: the line says
    the command started.  Only in text mode on a terminal, like the progress bars: logs, pipes,
    tests and ``--json`` runs see the output they always saw.
    """
    import sys

    if getattr(args, "json", False) or sys.stderr is None or not sys.stderr.isatty():
        return
    print(f"hybobs {getattr(args, 'command', None) or 'hybobs'}: {what} ...", file=sys.stderr, flush=True)

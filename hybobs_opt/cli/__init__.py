"""The ``hybobs`` command: a thin layer over the package, ``--json`` on every command.

One module per command (``examples``, ``simulate``, ``report``, ``regions``, ``observe``,
``bench``, ``export``, ``diagnose``, ``synth``, ``model``, ``cache``), each with ``HELP``, ``add_arguments(parser)`` and
``run(args) -> exit code``.  Command modules import only the standard library at import time;
the package (numpy, the solvers) is loaded inside ``run``, so ``hybobs --help`` and
``hybobs examples`` start without importing cvxpy, CasADi or numba.

``hybobs -v COMMAND ...`` logs the package's progress at INFO (``-vv``: DEBUG, every solver call)
to stderr, never to stdout, so ``--json`` output stays one JSON document.

Exit codes: 0 success, 2 bad input or a failed computation.  Every error is one line: on stderr
``hybobs COMMAND: error: MESSAGE``, or under ``--json`` one JSON object on stdout with ``error``
(the message), ``command`` and, when known, ``field``, ``expected`` and ``got`` (a
:class:`~hybobs_opt.errors.ModelError`) and ``kind`` (the class of the error).  argparse's own
errors (an unknown option, a missing argument, a malformed number) are reduced to one line too.
"""

from __future__ import annotations

import argparse
import importlib
import json
import os
import re
import sys

from ..errors import HybobsError, ModelError

#: The commands, in the order ``hybobs --help`` lists them: name -> module of this package.
COMMANDS: dict[str, str] = {
    "examples": "examples",
    "simulate": "simulate",
    "report": "report",
    "regions": "regions",
    "observe": "observe",
    "bench": "bench",
    "export": "export",
    "diagnose": "diagnose",
    "synth": "synth",
    "model": "model",
    "cache": "cache",
}

#: Extra modules that add subcommands through ``add_commands(subparsers)`` (a hook for plug-ins).
COMMAND_MODULES: list[str] = []


class UsageError(Exception):
    """An argparse error of the parser ``prog`` (raised instead of printing usage and exiting)."""

    def __init__(self, prog: str, message: str):
        self.prog, self.message = prog, message
        super().__init__(message)


class ArgumentParser(argparse.ArgumentParser):
    """argparse with one-line errors (:class:`UsageError`) and help texts computed when shown.

    A help text may be a callable returning the text: it is called only by ``--help`` (lists of
    examples or report sections import part of the package, which ``hybobs --help`` must not).
    """

    def error(self, message: str):  # noqa: D102  (argparse API)
        raise UsageError(self.prog, message)

    def _check_help(self, action):  # Python >= 3.13 formats help texts in add_argument
        if not callable(action.help):
            getattr(super(), "_check_help", lambda a: None)(action)

    def format_help(self) -> str:
        for action in self._actions:
            if callable(action.help):
                action.help = action.help().replace("%", "%%")
        return super().format_help()


def build_parser() -> argparse.ArgumentParser:
    from .. import __version__

    parser = ArgumentParser(
        prog="hybobs",
        description="Optimization-based state observers for hybrid systems (hybobs_opt).",
    )
    parser.add_argument("--version", action="version", version=f"hybobs {__version__}")
    parser.add_argument("-v", "--verbose", action="count", default=0,
                        help="log progress to stderr: -v at INFO (phases, undecided solves), -vv at DEBUG (every solve)")
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    for name, module_name in COMMANDS.items():
        module = importlib.import_module(f"{__name__}.{module_name}")
        p = sub.add_parser(name, help=module.HELP)
        module.add_arguments(p)
        p.set_defaults(func=module.run)
    for module in COMMAND_MODULES:
        importlib.import_module(module).add_commands(sub)
    return parser


def _wants_json(argv: list[str]) -> bool:
    """``--json`` (or an abbreviation argparse accepts, ``--js``) anywhere before a ``--``."""
    for arg in argv:
        if arg == "--":
            return False
        if len(arg) >= 3 and "--json".startswith(arg):
            return True
    return False


def _command_of(argv: list[str], choices) -> str | None:
    """The subcommand named in ``argv`` (the first token that is one), for the error prefix."""
    return next((a for a in argv if a in choices), None)


_ARGUMENT = re.compile(r"^argument ([^:\s/]+)(?:/[^:\s]+)?: ")
_REQUIRED = re.compile(r"^the following arguments are required: (.+)$")
_UNRECOGNIZED = re.compile(r"^unrecognized arguments: (\S+)")


def _usage_field(message: str) -> str | None:
    """The option an argparse message is about (``--t-final``, ``SYSTEM``, ``--out``), if it names one."""
    m = _ARGUMENT.match(message)
    if m:
        return m.group(1)
    m = _REQUIRED.match(message)
    if m:
        return m.group(1).split(",")[0].split("/")[0].strip()
    m = _UNRECOGNIZED.match(message)
    if m:
        return m.group(1)
    return None


def report_error(command: str | None, message: str, as_json: bool, **fields) -> int:
    """Print one error line (stderr, or a JSON object on stdout under ``--json``) and return 2."""
    message = " ".join(message.split())
    if as_json:
        record = {"error": message, "command": command}
        record.update({k: v for k, v in fields.items() if v is not None})
        print(json.dumps(record, default=str))
    else:
        prefix = f"hybobs {command}" if command else "hybobs"
        print(f"{prefix}: error: {message}", file=sys.stderr)
    return 2


def _error_fields(exc: BaseException) -> dict:
    out = {"kind": type(exc).__name__}
    for key in ("field", "expected", "got"):
        if getattr(exc, key, None) is not None:
            out[key] = getattr(exc, key)
    return out


def main(argv: list[str] | None = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    as_json = _wants_json([str(a) for a in argv])
    parser = build_parser()
    try:
        args = parser.parse_args(argv)
    except UsageError as exc:
        command = exc.prog.split()[1] if len(exc.prog.split()) > 1 else _command_of([str(a) for a in argv], COMMANDS)
        hint = f"see 'hybobs {command} --help'" if command else "see 'hybobs --help'"
        return report_error(command, f"{exc.message} ({hint})", as_json, field=_usage_field(exc.message), kind="usage")
    except SystemExit as exc:  # --help: argparse printed the help
        return int(exc.code or 0) if not isinstance(exc.code, str) else 2
    as_json = bool(getattr(args, "json", False)) or as_json
    try:
        import logging

        from .._logging import verbose_logging
        from ..limits import raised_pair_lp_budget
        from ._common import as_options

        max_lps = getattr(args, "max_lps", None)
        if max_lps is not None and max_lps < 1:
            raise ModelError("--max-lps", "a positive number of LPs", repr(max_lps))
        verbose = getattr(args, "verbose", 0)
        level = None if not verbose else logging.INFO if verbose == 1 else logging.DEBUG
        with verbose_logging(level), raised_pair_lp_budget(max_lps), as_options({"max_pair_lps": "--max-lps"}):
            return int(args.func(args) or 0)
    except HybobsError as exc:
        return report_error(args.command, str(exc), as_json, **_error_fields(exc))
    except BrokenPipeError:  # the reader closed the pipe ('hybobs ... | head'): nothing more to say
        os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())  # no second error at exit
        return 0
    except OSError as exc:
        fields = _error_fields(exc)
        if getattr(exc, "filename", None) is not None:
            fields["field"] = str(exc.filename)
        return report_error(args.command, str(exc), as_json, **fields)


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())

"""The option vocabulary of ``hybobs``: the kind of value each option takes, and the old spellings.

One option name means one kind of value in every command: ``--out`` is always a file, ``--out-dir``
always a directory, ``--observers`` always a list, ``--ts`` always a sampling period in seconds.
The kind of an option is read from its argparse action (:func:`option_kind`): a flag when it takes no
value, a choice when it has ``choices``, otherwise the kind its metavar declares in
:data:`METAVAR_KINDS` (a metavar like ``LOG.csv`` or ``ESTIMATES.csv`` is a file too); an option given
several times (``action="append"``) is marked repeatable.  ``tests/app/test_cli_vocabulary.py``
walks every command's parser and asserts one kind per option name, so a new option that reuses a
name for another kind of value, or a metavar nobody declared, fails there.

An old spelling keeps working for one release as a hidden alias (:func:`add_hidden_alias`): it parses
as the new option, is not listed by ``--help`` or in the documentation, and warns with the new
spelling (:func:`hybobs_opt._deprecation.warn_renamed`).
"""

from __future__ import annotations

import argparse
import re

#: Metavar -> the kind of value it names.  Every option that takes a value uses one of these
#: (or a file metavar ``NAME.ext``, :data:`FILE_METAVAR`).
METAVAR_KINDS: dict[str, str] = {
    "FILE": "file",
    "DIR": "directory",
    "SECONDS": "seconds",
    "N": "integer",
    "T": "integer",
    "Q": "integer",
    "X": "number",
    "Y": "number",
    "SIGMA": "number",
    "RATE": "number",
    "NAME[,NAME...]": "list",
    "NAME=VALUE": "assignment",
    "STATE=VALUE": "assignment",
    "INPUT=VALUE": "assignment",
    "STATE=PERIOD": "assignment",
    "NAME=LO:HI": "range",
    "NXxNY": "grid",
    "tcp://HOST:PORT": "address",
    "KEY": "name",
    "STATE": "name",
}

#: A metavar naming a file by an example name and its extension (``LOG.csv``, ``ESTIMATES.csv``).
FILE_METAVAR = re.compile(r"^[A-Z][A-Z0-9_]*\.(csv|json|toml|yaml|png|pdf|svg)$")

#: Kind -> the argparse ``type`` of its values (a kind not listed keeps the text; the command parses it).
KIND_TYPES: dict[str, type] = {"integer": int, "number": float, "seconds": float}

#: How each kind reads in the documentation's table of options.
KIND_DESCRIPTIONS: dict[str, str] = {
    "flag": "no value (a switch)",
    "choice": "one of the listed words",
    "file": "a file",
    "directory": "a directory",
    "seconds": "a time in seconds",
    "integer": "an integer",
    "number": "a number",
    "list": "comma-separated names",
    "assignment": "NAME=VALUE",
    "range": "NAME=LO:HI",
    "grid": "NXxNY points",
    "address": "a scheduler address",
    "name": "a name",
}


def metavar_kind(metavar: str | None) -> str:
    """The kind of value ``metavar`` names (:data:`METAVAR_KINDS`, or ``file`` for ``NAME.ext``).

    Raises
    ------
    KeyError
        ``metavar`` is not declared (every option that takes a value must use a declared one).
    """
    if metavar in METAVAR_KINDS:
        return METAVAR_KINDS[metavar]
    if isinstance(metavar, str) and FILE_METAVAR.match(metavar):
        return "file"
    raise KeyError(f"metavar {metavar!r} is not in hybobs_opt.cli._vocabulary.METAVAR_KINDS")


def option_kind(action: argparse.Action) -> str:
    """The kind of value of an option: ``flag``, ``choice`` or its metavar's kind, ``(repeatable)`` when appended."""
    if action.nargs == 0:
        return "flag"
    kind = "choice" if action.choices is not None else metavar_kind(action.metavar)
    return kind + (" (repeatable)" if isinstance(action, argparse._AppendAction) else "")


def visible_options(parser: argparse.ArgumentParser) -> list[argparse.Action]:
    """The options ``parser --help`` lists (not ``--help`` itself, not suppressed ones)."""
    return [a for a in parser._actions if a.option_strings and a.help is not argparse.SUPPRESS
            and not isinstance(a, (argparse._HelpAction, argparse._VersionAction))]


class _Renamed:
    """Mixed into an action that answers to hidden old spellings (``renamed``: old -> new)."""

    renamed: dict[str, str]

    def __call__(self, parser, namespace, values, option_string=None):
        if option_string in self.renamed:
            from .._deprecation import warn_renamed

            warn_renamed(option_string, self.renamed[option_string], stacklevel=2)
        super().__call__(parser, namespace, values, option_string)  # type: ignore[misc]


_RENAMED_CLASSES: dict[type, type] = {}


def add_hidden_alias(parser: argparse.ArgumentParser, option: str, old: str) -> None:
    """Let the old spelling ``old`` parse as ``option`` of ``parser`` for one release.

    ``old`` is not one of the action's ``option_strings`` (so neither ``--help`` nor the generated
    documentation lists it) but the parser finds it; using it warns with the new spelling.
    """
    action = parser._option_string_actions[option]
    if old in parser._option_string_actions:
        raise ValueError(f"{old} is already an option of {parser.prog}")
    parser._option_string_actions[old] = action
    if not isinstance(action, _Renamed):
        base = type(action)
        cls = _RENAMED_CLASSES.setdefault(base, type(f"Renamed{base.__name__.lstrip('_')}", (_Renamed, base), {}))
        action.__class__ = cls
        action.renamed = {}  # type: ignore[attr-defined]
    action.renamed[old] = option  # type: ignore[attr-defined]


def hidden_aliases(parser: argparse.ArgumentParser) -> dict[str, str]:
    """The hidden old spellings of ``parser``'s options: old -> new."""
    return {s: a.renamed[s] for s, a in parser._option_string_actions.items() if isinstance(a, _Renamed) and s in a.renamed}

"""The one number grammar of the files the toolbox reads (CSV logs, model-file expressions).

A number is written in ASCII decimal: an optional sign, digits with an optional fraction (or a
fraction alone), an optional exponent -- ``-12``, ``0.5``, ``.5``, ``3.``, ``1e-3``, ``2.5E+4`` --
at most :data:`MAX_NUMBER_CHARS` characters, and its value is finite.  Python's own readers accept
more (``8_0``, ``0x10``, Arabic-Indic or full-width digits, ``inf``, 400-digit integers that then
overflow); the toolbox refuses them with a message naming the field, so a file means the same to
every reader.
"""

from __future__ import annotations

import math
import re

from .errors import ModelError

__all__ = ["MAX_NUMBER_CHARS", "is_decimal", "parse_decimal"]

#: Longest number written in a file (a double needs 25 characters at most).
MAX_NUMBER_CHARS: int = 64

_DECIMAL = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?", re.ASCII)


def is_decimal(text: str) -> bool:
    """Whether ``text`` (surrounding blanks and tabs aside) is written in the grammar (value not checked)."""
    t = text.strip(" \t")
    return len(t) <= MAX_NUMBER_CHARS and _DECIMAL.fullmatch(t) is not None


def parse_decimal(text: str, field: str) -> float:
    """The finite value of ``text`` written in the grammar, else a :class:`ModelError` naming ``field``."""
    if not isinstance(text, str) or not is_decimal(text):
        shown = text if not isinstance(text, str) or len(text) <= 40 else text[:37] + "..."
        raise ModelError(field, f"a decimal number in ASCII digits (such as -1.5e-3, at most {MAX_NUMBER_CHARS} "
                         "characters)", repr(shown))
    value = float(text.strip(" \t"))
    if not math.isfinite(value):
        raise ModelError(field, "a finite number", repr(text.strip()))
    return value

"""Text-mode summaries of the ``hybobs`` commands: a JSON-ready summary as readable lines.

Numbers are rounded to :data:`DIGITS` significant digits and carry their unit when it is known
(from the key: ``t``, ``t_*``, ``*seconds*``, ``*_s``, ``*delay*`` are seconds; or from a map of names to units, e.g.
an example's state units); nested records are indented, short records and lists fit on one line and
long lists are summarised by their length and range.  No Python ``repr`` of a container reaches the
terminal.  Imports nothing heavy (numpy values are recognised without importing numpy).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

#: Significant digits of a number in a text summary.
DIGITS = 4
#: A list with more items than this is summarised (count and range) instead of listed.
MAX_LISTED = 8
#: Records in a list of records shown one per line before the rest is counted.
MAX_RECORDS = 5

#: Unit of a value by its key, when the key says it (checked in order; the first match wins).
KEY_UNITS: tuple[tuple[str, str], ...] = (
    ("seconds", "s"), ("_s", "s"), ("delay", "s"), ("dwell_time", "s"), ("t_", "s"), ("decay", "1/s"),
)


def key_unit(key: str) -> str:
    """The unit a key names (``run_seconds`` -> ``s``), or ``""``."""
    key = str(key)
    if key in ("t", "time"):
        return "s"
    for part, unit in KEY_UNITS:
        if part == "t_" and key.startswith(part):
            return unit
        if part == "_s" and key.endswith(part):
            return unit
        if part not in ("t_", "_s") and part in key:
            return unit
    return ""


def sig(value: Any, unit: str = "") -> str:
    """``value`` as text: a number rounded to :data:`DIGITS` significant digits (``unit`` appended),
    a boolean as yes/no, ``None`` as n/a, anything else as ``str``."""
    if value is None:
        return "n/a"
    if isinstance(value, bool) or type(value).__name__ == "bool_":
        return "yes" if value else "no"
    if isinstance(value, int) or type(value).__name__.startswith(("int", "uint")):
        return f"{int(value)}" + (f" {unit}" if unit else "")
    if isinstance(value, float) or type(value).__name__.startswith("float"):
        v = float(value)
        text = f"{v:.{DIGITS}g}" if math.isfinite(v) else ("nan" if math.isnan(v) else ("inf" if v > 0 else "-inf"))
        return text + (f" {unit}" if unit else "")
    return str(value)


def _is_scalar(value: Any) -> bool:
    return not isinstance(value, (Mapping, list, tuple)) and type(value).__name__ != "ndarray"


def _as_list(value: Any) -> Any:
    return value.tolist() if type(value).__name__ == "ndarray" else value


def _inline_record(record: Mapping, units: Mapping[str, str], unit: str = "") -> str:
    return ", ".join(f"{k} {sig(v, units.get(str(k)) or key_unit(k) or unit)}" for k, v in record.items())


def _inline_list(key: str, values: list, units: Mapping[str, str]) -> str:
    unit = units.get(key) or key_unit(key)
    if not values:
        return "none"
    numbers = [v for v in values if isinstance(v, (int, float)) and not isinstance(v, bool)]
    if len(values) <= MAX_LISTED:
        return ", ".join(sig(v, unit) for v in values)
    if len(numbers) == len(values):
        finite = [float(v) for v in numbers if math.isfinite(float(v))]
        span = f" from {sig(min(finite), unit)} to {sig(max(finite), unit)}" if finite else ""
        return f"{len(values)} values{span}"
    return ", ".join(sig(v, unit) for v in values[:MAX_LISTED]) + f", ... ({len(values)} in all)"


def summary_lines(summary: Mapping[str, Any], units: Mapping[str, str] | None = None, indent: str = "",
                  skip: tuple[str, ...] = ()) -> list[str]:
    """Readable lines of a JSON-ready summary (``units``: unit by key or by a name in a record, e.g. state units).

    Parameters
    ----------
    summary : mapping
        What ``--json`` prints.
    units : mapping of str to str, optional
        Units by key (``{"omega_m": "rad/s"}``); keys not in it get :func:`key_unit`'s.
    indent : str
        Prefix of every line (nested records add two spaces).
    skip : tuple of str
        Top-level keys not shown (printed elsewhere, e.g. cache events on stderr).
    """
    units = dict(units or {})
    lines: list[str] = []
    for key, value in summary.items():
        if key in skip:
            continue
        value = _as_list(value)
        unit = units.get(str(key)) or key_unit(key)
        if _is_scalar(value):
            lines.append(f"{indent}{key}: {sig(value, unit)}")
        elif isinstance(value, Mapping):
            if not value:
                lines.append(f"{indent}{key}: none")
            elif all(_is_scalar(_as_list(v)) for v in value.values()) and len(value) <= MAX_LISTED:
                lines.append(f"{indent}{key}: {_inline_record(value, units, unit)}")
            else:
                lines.append(f"{indent}{key}:")
                lines += summary_lines(value, units, indent + "  ")
        else:
            items = [_as_list(v) for v in value]
            if all(_is_scalar(v) for v in items):
                lines.append(f"{indent}{key}: {_inline_list(str(key), items, units)}")
            elif all(isinstance(v, Mapping) and all(_is_scalar(_as_list(x)) for x in v.values()) for v in items):
                lines.append(f"{indent}{key}: {len(items)} entr{'y' if len(items) == 1 else 'ies'}")
                lines += [f"{indent}  {_inline_record(v, units)}" for v in items[:MAX_RECORDS]]
                if len(items) > MAX_RECORDS:
                    lines.append(f"{indent}  ... ({len(items) - MAX_RECORDS} more: --json lists them)")
            else:
                lines.append(f"{indent}{key}: {len(items)} entr{'y' if len(items) == 1 else 'ies'}")
                for i, v in enumerate(items[:MAX_RECORDS]):
                    if isinstance(v, Mapping):
                        lines.append(f"{indent}  [{i}]")
                        lines += summary_lines(v, units, indent + "    ")
                    else:
                        lines.append(f"{indent}  [{i}] {_inline_list(str(key), list(v), units)}")
                if len(items) > MAX_RECORDS:
                    lines.append(f"{indent}  ... ({len(items) - MAX_RECORDS} more: --json lists them)")
    return lines


def print_summary(summary: Mapping[str, Any], units: Mapping[str, str] | None = None, skip: tuple[str, ...] = ()) -> None:
    """Print :func:`summary_lines` of ``summary`` on stdout."""
    for line in summary_lines(summary, units, skip=skip):
        print(line)

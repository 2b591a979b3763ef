"""Saved results that cannot be applied to another system or loaded after an edit.

DESIGN.md: "Saved results (regions, gains, tables) carry a format version, the system's
fingerprint and a checksum; loading refuses a mismatch."  This module is that rule, written once
for every kind of saved file (the regions of :mod:`hybobs_opt.regions.io`, the switched gains
of ``hybobs synth --out`` read by :func:`hybobs_opt.observers.recorded.gains_from_json`).  A
:class:`SavedFormat` describes one kind: its ``format`` name, its version (and the key that
holds it), and what to tell a user whose file is refused (how to recompute it).

A sealed file is a JSON object holding

``format`` and the version key
    which kind of file and which version of its layout;
``system_fingerprint``
    :func:`hybobs_opt.systems.fingerprint.system_fingerprint` of the system it was computed for;
``checksum``
    SHA-256 (hex) of the canonical JSON (sorted keys, no whitespace) of every other entry
    (:func:`content_checksum`), computed on what a reader gets back from the JSON text.

:func:`read_json` refuses a file that is missing, not UTF-8, not JSON or not a JSON object;
:func:`check_sealed` one of another format or version, without a checksum or whose content does
not match it; :func:`check_fingerprint` one computed for another system.  Every refusal is a
:class:`~hybobs_opt.errors.ModelError` whose field names the file.  The checksum detects edits and
corruption, not forgery: whoever edits a file on purpose can recompute it, so each reader still
checks that the content is consistent before it uses it.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from ..errors import ModelError
from .fingerprint import sha256_of
from .._output_files import write_output_text

#: The entry holding :func:`content_checksum` (the one entry the checksum does not cover).
CHECKSUM_KEY = "checksum"
#: The entry holding the fingerprint of the system the result was computed for.
FINGERPRINT_KEY = "system_fingerprint"
#: The entry holding the format name.
FORMAT_KEY = "format"


@dataclass(frozen=True)
class SavedFormat:
    """One kind of saved file.

    Attributes
    ----------
    name : str
        The ``format`` entry (``"hybobs_opt.regions"``).
    version : int
        The version this code writes and reads.
    label : str
        What the file is called in messages (``"regions file"``).
    writer : str
        What writes it (``"'hybobs regions --out'"``), for messages.
    recompute : str
        How to get a valid file again (``"recompute it with 'hybobs regions ...'"``).
    version_key : str
        The entry holding the version (``"version"`` in regions files, ``"format_version"`` in
        gains files).
    old_versions : mapping of int to str
        Why an older version is refused (shown with :attr:`recompute`).
    """

    name: str
    version: int
    label: str
    writer: str
    recompute: str
    version_key: str = "version"
    old_versions: Mapping[int, str] = field(default_factory=dict)

    def where(self, path: str | Path) -> str:
        """``"regions file 'path'"``: the field of every error about the file."""
        return f"{self.label} {str(path)!r}"


def content_checksum(data: Mapping[str, Any]) -> str:
    """SHA-256 (hex) of the canonical JSON of ``data`` without its ``"checksum"`` entry."""
    return sha256_of({k: v for k, v in data.items() if k != CHECKSUM_KEY})


def seal(data: Mapping[str, Any], fmt: SavedFormat, fingerprint: str,
         default: Callable[[Any], Any] | None = None) -> dict[str, Any]:
    """``data`` with the format, version and fingerprint entries, through JSON, with its checksum.

    The result is what a reader of the JSON text gets back (numpy values converted by
    ``default``), so the checksum covers exactly that.  Format, version and fingerprint come
    first, the checksum last.
    """
    if not isinstance(fingerprint, str) or len(fingerprint) != 64:
        raise ModelError(FINGERPRINT_KEY, "a SHA-256 fingerprint (64 hex digits) of the system", repr(fingerprint))
    body = {FORMAT_KEY: fmt.name, fmt.version_key: fmt.version,
            **{k: v for k, v in data.items() if k not in (FORMAT_KEY, fmt.version_key, FINGERPRINT_KEY, CHECKSUM_KEY)},
            FINGERPRINT_KEY: fingerprint}
    out = json.loads(json.dumps(body, default=default))
    out[CHECKSUM_KEY] = content_checksum(out)
    return out


def write_sealed(path: str | Path, data: Mapping[str, Any], fmt: SavedFormat, fingerprint: str, *,
                 indent: int | None = None, default: Callable[[Any], Any] | None = None) -> dict[str, Any]:
    """Write :func:`seal` of ``data`` to ``path`` as JSON; returns the sealed dictionary."""
    sealed = seal(data, fmt, fingerprint, default)
    write_output_text(path, json.dumps(sealed, indent=indent))
    return sealed


def read_json(path: str | Path, fmt: SavedFormat) -> dict[str, Any]:
    """The JSON object in ``path``; a missing, binary, non-UTF-8, non-JSON or non-object file is refused."""
    where = fmt.where(path)
    expected = f"a readable JSON file written by {fmt.writer}"
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise ModelError(where, expected, f"{type(exc).__name__}: {exc.strerror or exc}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise ModelError(where, expected, f"bytes that are not UTF-8 text ({exc.reason} at byte {exc.start})") from None
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ModelError(where, expected, f"text that is not JSON ({exc.msg} at line {exc.lineno}, column {exc.colno})") from None
    except RecursionError:
        raise ModelError(where, expected, "JSON nested too deeply to read") from None
    if not isinstance(data, dict):
        raise ModelError(where, f"a JSON object written by {fmt.writer}", f"a JSON {type(data).__name__}")
    return data


def check_sealed(data: Any, fmt: SavedFormat, where: str) -> None:
    """Refuse ``data`` unless it is of ``fmt``'s format and version and matches its checksum.

    Nothing of the content is used before it matches its checksum; the checks after this one
    (the fingerprint, the content's consistency) are the reader's.
    """
    if not isinstance(data, dict):
        raise ModelError(where, f"a JSON object written by {fmt.writer}", type(data).__name__)
    if FORMAT_KEY not in data:
        raise ModelError(f"{where}: {FORMAT_KEY}", repr(fmt.name),
                         f"no {FORMAT_KEY} entry (a file written before {fmt.label}s carried a format version, the "
                         f"system's fingerprint and a checksum, or not a {fmt.label}): {fmt.recompute}")
    if data.get(FORMAT_KEY) != fmt.name:
        raise ModelError(f"{where}: {FORMAT_KEY}", repr(fmt.name), f"{_short(data.get(FORMAT_KEY))} (not a {fmt.label}"
                         f" written by {fmt.writer})")
    version = data.get(fmt.version_key)
    if isinstance(version, bool) or version != fmt.version:
        got = _short(version)
        if isinstance(version, int) and not isinstance(version, bool) and version in fmt.old_versions:
            got += f" ({fmt.old_versions[version]}: {fmt.recompute})"
        elif version is None:
            got = f"no {fmt.version_key} (a file from before {fmt.label}s carried their system and a checksum: {fmt.recompute})"
        raise ModelError(f"{where}: {fmt.version_key}", str(fmt.version), got)
    stored = data.get(CHECKSUM_KEY)
    if not isinstance(stored, str) or stored != content_checksum(data):
        what = "no checksum" if not isinstance(stored, str) else "content whose checksum does not match the stored one"
        raise ModelError(where, "content matching its SHA-256 checksum",
                         f"{what}: the file was edited or corrupted after it was saved; {fmt.recompute}")
    fingerprint = data.get(FINGERPRINT_KEY)
    if not isinstance(fingerprint, str) or len(fingerprint) != 64:
        raise ModelError(f"{where}: {FINGERPRINT_KEY}", "the SHA-256 fingerprint (64 hex digits) of a system",
                         f"{_short(fingerprint)}: the file was edited; {fmt.recompute}")


def check_fingerprint(data: Mapping[str, Any], fmt: SavedFormat, where: str, system: Any,
                      stored_name: str | None = None, detail: str = "") -> None:
    """Refuse a file whose stored fingerprint is not ``system``'s (computed for another system).

    ``stored_name`` names the system the file was computed for and ``detail`` says how the two
    differ, in the message.
    """
    from .fingerprint import system_fingerprint

    stored = data[FINGERPRINT_KEY]
    given = system_fingerprint(system)
    if given != stored:
        what = f"{stored_name!r} " if stored_name else ""
        raise ModelError(where, f"the system it was computed for, {what}(fingerprint {stored[:16]})",
                         f"{getattr(system, 'name', type(system).__name__)!r} (fingerprint {given[:16]}){detail}: the "
                         f"file was computed for another system; {fmt.recompute.replace('recompute it', 'recompute it for this one', 1)}")


def finite_number(value: Any, where: str, what: str = "a finite number") -> float:
    """A JSON number that is finite (not a bool, string or null); for the readers' content checks."""
    if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
        raise ModelError(where, what, _short(value))
    return float(value)


def _short(value: Any, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


__all__ = ["CHECKSUM_KEY", "FINGERPRINT_KEY", "FORMAT_KEY", "SavedFormat", "check_fingerprint", "check_sealed",
           "content_checksum", "finite_number", "read_json", "seal", "write_sealed"]

"""Fuzz family 5: corrupted saved files (issue 16).

Two kinds of saved results, each written once per process by the toolbox itself and then
corrupted by hypothesis:

* a regions file: ``hybobs_opt.regions.save_analysis`` of Algorithm 3.1 on ``powertrain3`` at
  ``T = 3`` (the smallest horizon with ``T p >= n``), read back by ``load_analysis``;
* a gains file: ``hybobs synth vehicle_tracking --out FILE --no-verify``, read back by the public
  path a user has, ``hybobs observe vehicle_tracking --data LOG.csv --gains FILE`` (a five-sample
  log), in-process.

Corruptions (:mod:`.strategies`): truncation, a flipped byte, a span of binary garbage, an empty
file, NUL bytes, invalid UTF-8, a BOM; and JSON-level edits that keep the file JSON: an edited
number (relative changes from 1e-12 to 1e300), a value of another JSON type, a missing key, an
extra key, a null, a NaN, a reversed list, the whole object wrapped in a list, a deeply nested
value.  Regions files are also tried *resealed* (the edit made, then the checksum recomputed as a
forger would), which only the content checks can catch.

Required: a :class:`~hybobs_opt.errors.ModelError` (CLI: exit 2, one line) naming the file.  A
corruption that leaves the parsed content unchanged may be accepted (``accepted-valid``); so may a
resealed edit whose loaded analysis answers exactly like the original.  Outcomes: ``ModelError``,
``ModelError-not-naming-file``, ``accepted-valid``, ``accepted-garbage``, ``other-exception:<type>``.
"""

from __future__ import annotations

import copy
import functools
import json
import math
import tempfile
import warnings
from pathlib import Path

import numpy as np
import pytest
from hypothesis import strategies as st

from . import strategies as S
from .common import (
    ACCEPTED_GARBAGE,
    ACCEPTED_VALID,
    CLI_OK,
    MODEL_ERROR,
    MODEL_ERROR_UNNAMED,
    Family,
    Target,
    assert_no_bugs,
    exception_outcome,
    run_target,
    strict_warnings,
)

# ---------------------------------------------------------------------------------- the valid files


@functools.cache
def workdir() -> Path:
    return Path(tempfile.mkdtemp(prefix="hybobs-fuzz-files-"))


@functools.cache
def regions_file() -> tuple[Path, bytes, object]:
    from hybobs_opt.regions import analyse_observability, save_analysis
    from hybobs_opt.studies import get_example

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        system = get_example("powertrain3").build()
        an = analyse_observability(system, 3)
    path = workdir() / "regions.json"
    save_analysis(an, path, example="powertrain3")
    return path, path.read_bytes(), an


@functools.cache
def gains_file() -> tuple[Path, bytes, Path]:
    from .test_cli import run_cli

    log, path = workdir() / "vehicle_log.csv", workdir() / "gains.json"
    for argv in (["simulate", "vehicle_tracking", "--t-final", "0.04", "--out", str(log)],
                 ["synth", "vehicle_tracking", "--out", str(path), "--no-verify"]):
        code, out, err = run_cli(argv)
        assert code == 0, (argv, code, err[-500:])
    return path, path.read_bytes(), log


# ---------------------------------------------------------------------------------- corruptions

def corrupt_bytes(raw: bytes, fault) -> bytes:
    kind, where, value, span = fault
    k = min(int(where * len(raw)), len(raw) - 1)
    if kind == "truncate":
        return raw[:k]
    if kind == "flip":
        b = bytearray(raw)
        b[k] ^= value
        return bytes(b)
    if kind == "garbage":
        junk = bytes((value * (i + 7) * 131) % 256 for i in range(span))
        return raw[:k] + junk + raw[k + span:]
    if kind == "empty":
        return b""
    if kind == "nul":
        return raw[:k] + b"\x00" * span + raw[k:]
    if kind == "latin1":
        return raw[:k] + b"\xe9\xff" + raw[k:]
    if kind == "bom":
        return b"\xef\xbb\xbf" + raw
    raise AssertionError(kind)


def _paths(node, prefix=()):
    """Every path to a value of the JSON tree (dict keys and list indices), leaves and inner nodes."""
    yield prefix
    if isinstance(node, dict):
        for k, v in node.items():
            yield from _paths(v, prefix + (k,))
    elif isinstance(node, list):
        for i, v in enumerate(node):
            yield from _paths(v, prefix + (i,))


def _get(node, path):
    for p in path:
        node = node[p]
    return node


def _set(node, path, value):
    _get(node, path[:-1])[path[-1]] = value


def edit_json(data, fault):
    """The JSON edit ``fault`` of ``data`` (a deep copy), or ``None`` when it has nothing to edit."""
    kind, where, factor, _ = fault
    data = copy.deepcopy(data)
    paths = [p for p in _paths(data) if p]
    if kind == "toplevel-list":
        return [data]
    if kind == "number":
        nums = [p for p in paths if isinstance(_get(data, p), (int, float)) and not isinstance(_get(data, p), bool)]
        if not nums:
            return None
        p = nums[min(int(where * len(nums)), len(nums) - 1)]
        v = _get(data, p)
        _set(data, p, factor if factor in (-1.0, 1e300) else v * (1.0 + factor) + (factor if v == 0 else 0.0))
        return data
    if kind == "nan-number":
        nums = [p for p in paths if isinstance(_get(data, p), float)]
        if not nums:
            return None
        _set(data, nums[min(int(where * len(nums)), len(nums) - 1)], math.nan)
        return data
    if kind == "swap-list":
        lists = [p for p in paths if isinstance(_get(data, p), list) and len(_get(data, p)) >= 2
                 and _get(data, p) != _get(data, p)[::-1]]
        if not lists:
            return None
        p = lists[min(int(where * len(lists)), len(lists) - 1)]
        _set(data, p, _get(data, p)[::-1])
        return data
    if kind in ("missing", "extra-key"):
        dicts = [p for p in [()] + paths if isinstance(_get(data, p), dict) and _get(data, p)]
        p = dicts[min(int(where * len(dicts)), len(dicts) - 1)]
        d = _get(data, p)
        if kind == "missing":
            del d[sorted(d)[min(int(where * 997) % len(d), len(d) - 1)]]
        else:
            d["unexpected_entry"] = 1
        return data
    p = paths[min(int(where * len(paths)), len(paths) - 1)]
    v = _get(data, p)
    if kind == "null":
        if v is None:
            return None
        _set(data, p, None)
    elif kind == "type":
        _set(data, p, {"x": 1} if isinstance(v, list) else ["x"] if isinstance(v, (str, int, float)) else "x")
    elif kind == "deep":
        _set(data, p, _DEEP)  # written as 100 000 nested lists by dumps()
    else:
        raise AssertionError(kind)
    return data


_DEEP = "__deeply_nested__"


def dumps(data) -> bytes:
    text = json.dumps(data, indent=None)
    return text.replace(json.dumps(_DEEP), "[" * 100_000 + "0" + "]" * 100_000).encode()


def parsed(raw: bytes):
    """The JSON content of ``raw`` as a reader would get it, or a marker when it is not JSON text."""
    try:
        return json.loads(raw.decode("utf-8"))
    except (UnicodeDecodeError, ValueError, RecursionError):
        return "<not JSON>"


def same_content(a, b) -> bool:
    try:
        return json.dumps(a, sort_keys=True) == json.dumps(b, sort_keys=True)
    except (ValueError, RecursionError):
        return False


# ---------------------------------------------------------------------------------- loading

def analysis_signature(an):
    """What a loaded analysis answers with: regions (sequence and maps), I, the pairs, the summary counts."""
    enum = an.enumeration
    regs = [(tuple(r.sequence), [np.asarray(getattr(r, k), float) for k in ("H", "h", "C", "D", "f", "Phi", "Gamma", "phi")])
            for r in enum.regions]
    return regs, tuple(an.index_set), tuple(an.full_rank), tuple(sorted((p.i, p.j) for p in an.pairs))


def same_analysis(a, b) -> bool:
    ra, *rest_a = analysis_signature(a)
    rb, *rest_b = analysis_signature(b)
    if rest_a != rest_b or len(ra) != len(rb):
        return False
    for (sa, ma), (sb, mb) in zip(ra, rb):
        if sa != sb or any(x.shape != y.shape or not np.allclose(x, y, rtol=1e-9, atol=1e-12) for x, y in zip(ma, mb)):
            return False
    return True


def load_regions(raw: bytes, name: str):
    from hybobs_opt.regions import load_analysis

    path = workdir() / name
    path.write_bytes(raw)
    try:
        with strict_warnings():
            an = load_analysis(path)
    except Exception as exc:
        outcome = exception_outcome(exc)
        if outcome == MODEL_ERROR and str(path) not in str(exc):
            outcome = MODEL_ERROR_UNNAMED
        return outcome, f"{type(exc).__name__}: {str(exc)[:200]}", None
    return None, "accepted", an


def try_regions(value, json_level: bool, reseal: bool = False) -> tuple[str, str]:
    _, raw, original = regions_file()
    if json_level:
        data0 = json.loads(raw)
        edited = edit_json(data0, value)
        if edited is None:
            return ACCEPTED_VALID, f"{value}: nothing to edit"
        if reseal and isinstance(edited, dict):
            from hybobs_opt.systems.saved_file import CHECKSUM_KEY, content_checksum

            edited[CHECKSUM_KEY] = content_checksum(json.loads(json.dumps(edited)))
        bad = dumps(edited)
    else:
        bad = corrupt_bytes(raw, value)
    outcome, detail, an = load_regions(bad, "regions-corrupted.json")
    what = f"regions file {'resealed ' if reseal else ''}{value}"
    if outcome is not None:
        return outcome, f"{what}: {detail}"
    if same_content(parsed(bad), json.loads(raw)) or (reseal and same_analysis(an, original)):
        return ACCEPTED_VALID, f"{what}: accepted (same content)"
    return ACCEPTED_GARBAGE, f"{what}: accepted"


def try_gains(value, json_level: bool) -> tuple[str, str]:
    from .test_cli import classify, run_cli

    _, raw, log = gains_file()
    if json_level:
        edited = edit_json(json.loads(raw), value)
        if edited is None:
            return ACCEPTED_VALID, f"{value}: nothing to edit"
        bad = dumps(edited)
    else:
        bad = corrupt_bytes(raw, value)
    path = workdir() / "gains-corrupted.json"
    path.write_bytes(bad)
    code, out, err = run_cli(["observe", "vehicle_tracking", "--data", str(log), "--gains", str(path)])
    what = f"gains file {value}"
    if code == 0:
        if same_content(parsed(bad), json.loads(raw)):
            return ACCEPTED_VALID, f"{what}: accepted (same content)"
        return ACCEPTED_GARBAGE, f"{what}: accepted (exit 0)"
    outcome = classify(code, out, err, False)
    if outcome == CLI_OK:
        return (MODEL_ERROR if str(path) in err else MODEL_ERROR_UNNAMED), f"{what}: {err.strip()[:200]}"
    return outcome, f"{what}: exit {code}: {(err or out).strip()[:300]}"


FAMILY = Family(
    "corrupted saved files",
    "ModelError naming the file (a content-preserving corruption may be accepted)",
    [
        Target("regions file [bytes]", S.byte_fault(), lambda v: try_regions(v, False), 14),
        Target("regions file [json]", S.json_fault(), lambda v: try_regions(v, True), 14),
        Target("regions file [json, resealed]", S.json_fault(), lambda v: try_regions(v, True, reseal=True), 14),
        Target("gains file [bytes]", S.byte_fault(), lambda v: try_gains(v, False), 10),
        Target("gains file [json]", S.json_fault(), lambda v: try_gains(v, True), 10),
    ],
)

KNOWN_DEFECTS: dict[str, str] = {}


@pytest.mark.parametrize("target", [pytest.param(t, id=t.name, marks=[pytest.mark.xfail(strict=True, reason=KNOWN_DEFECTS[t.name])]
                                                 if t.name in KNOWN_DEFECTS else []) for t in FAMILY.targets])
def test_corrupted_files_are_refused(target):
    assert_no_bugs(run_target(target))


def test_the_valid_files_load():
    """The oracle is sound: the files as written load (the regions to the same analysis)."""
    from .test_cli import run_cli

    path, raw, original = regions_file()
    outcome, detail, an = load_regions(raw, "regions-copy.json")
    assert outcome is None, detail
    assert same_analysis(an, original)
    gpath, _, log = gains_file()
    code, _, err = run_cli(["observe", "vehicle_tracking", "--data", str(log), "--gains", str(gpath)])
    assert code == 0, err


def test_defect_deeply_nested_gains_file():
    """Was a RecursionError traceback: ``hybobs observe --gains`` read the file with its own json.loads."""
    outcome, detail = try_gains(("deep", 0.01, 1e-12, True), True)
    assert outcome == MODEL_ERROR, f"{outcome}: {detail}"

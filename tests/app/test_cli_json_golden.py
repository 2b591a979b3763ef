"""The JSON of every ``hybobs`` command is unchanged: each case of
``tests/app/record_cli_json_golden.py`` runs in process and is compared with its golden record in
``tests/app/cli_json_golden/`` (same keys, same strings/booleans/integers/nulls, same list lengths,
floats within rtol = 1e-6, atol = 1e-9; times and run-dependent paths masked).

A failure names the case and the JSON path of the first difference.  When the change is intended,
re-record with ``python -m tests.app.record_cli_json_golden CASE`` and say so in the commit.
"""

from __future__ import annotations

import copy
import shutil

import pytest

from record_cli_json_golden import (ATOL, CASES, CASES_BY_NAME, GOLDEN_DIR, MASK, RTOL, compare, compare_record,
                                    golden_path, load_golden, normalise, run_case)


def _param(case):
    return pytest.param(case, id=case.name, marks=[pytest.mark.slow] if case.slow else [])


@pytest.mark.parametrize("case", [_param(c) for c in CASES])
def test_cli_json_matches_golden_record(case, tmp_path):
    if case.needs_cc and shutil.which("cc") is None:
        pytest.skip("no C compiler 'cc' (the build check's answer is part of the JSON)")
    assert golden_path(case).is_file(), (f"case {case.name!r} has no golden record: python -m "
                                         f"tests.app.record_cli_json_golden {case.name}")
    diff = compare_record(load_golden(case), run_case(case, tmp_path))
    assert diff is None, (f"hybobs {' '.join(case.argv)}: the JSON of case {case.name!r} changed: {diff}\n"
                          f"(if intended: python -m tests.app.record_cli_json_golden {case.name}, and say so in the commit)")


def test_every_golden_record_belongs_to_a_case():
    stale = sorted(p.name for p in GOLDEN_DIR.glob("*.json") if p.stem not in CASES_BY_NAME)
    assert not stale, f"golden records of no case in record_cli_json_golden.CASES: {stale}"


def test_every_json_command_has_a_case_outside_slow():
    """Each command with ``--json`` (each action of ``model`` and ``cache``) has an unmarked case."""
    import argparse

    from hybobs_opt.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction))
    fast = [c.argv for c in CASES if not c.slow]
    for name, p in sub.choices.items():
        options = {o for a in p._actions for o in a.option_strings}
        if "--json" not in options:
            continue
        actions = next((a.choices for a in p._actions if a.dest == "action"), None)
        for action in actions or [None]:
            covered = [a for a in fast if a[0] == name and (action is None or action in a[1:2])]
            assert covered, f"no unmarked golden case for 'hybobs {name}{' ' + action if action else ''} --json'"


# ------------------------------------------------------------------- the comparison can fail
BASE = {"name": "powertrain3", "n": 3, "ok": True, "none": None, "x": 2.5, "tiny": 1e-12,
        "list": [1.0, 2.0, 3.0], "nested": {"flags": {"observable": 58}, "radius": [0.125, 0.5]}}


def _changed(edit):
    value = copy.deepcopy(BASE)
    edit(value)
    return value


def _rename(d, old, new):
    d[new] = d.pop(old)


@pytest.mark.parametrize("edit, where", [
    (lambda d: _rename(d, "x", "x_value"), "$: missing keys ['x']; unexpected keys ['x_value']"),
    (lambda d: _rename(d["nested"]["flags"], "observable", "n_observable"), "$.nested.flags: missing keys"),
    (lambda d: d.pop("none"), "$: missing keys ['none']"),
    (lambda d: d.update(extra=1), "$: unexpected keys ['extra']"),
    (lambda d: d.update(x=2.5 * (1 + 1e-4)), "$.x: expected 2.5, got 2.50025"),
    (lambda d: d["nested"]["radius"].__setitem__(1, 0.5 * (1 - 1e-4)), "$.nested.radius[1]"),
    (lambda d: d.update(tiny=1e-8), "$.tiny"),
    (lambda d: d.update(name="powertrain5"), '$.name: expected "powertrain3", got "powertrain5"'),
    (lambda d: d.update(name="powertrain3 "), "$.name"),
    (lambda d: d.update(n=4), "$.n: expected 3, got 4"),
    (lambda d: d.update(n=3.0), "$.n: expected integer 3, got float 3.0"),
    (lambda d: d.update(ok=False), "$.ok"),
    (lambda d: d.update(ok=1), "$.ok: expected boolean true, got integer 1"),
    (lambda d: d.update(none=0), "$.none: expected null"),
    (lambda d: d.update(x=None), "$.x: expected float"),
    (lambda d: d["list"].pop(), "$.list: expected a list of 3 items, got 2"),
    (lambda d: d.update(list=[1.0, 2.0, float("nan")]), "$.list[2]"),
    (lambda d: d["nested"].update(flags=[58]), "$.nested.flags: expected an object"),
], ids=["renamed-key", "renamed-nested-key", "dropped-key", "added-key", "float-1e-4-relative",
        "nested-float-1e-4-relative", "float-beyond-atol", "string", "string-whitespace", "integer", "integer-to-float",
        "boolean", "boolean-to-integer", "null-to-number", "number-to-null", "list-length", "nan", "object-to-list"])
def test_compare_reports_the_first_difference(edit, where):
    diff = compare(BASE, _changed(edit))
    assert diff is not None and diff.startswith(where), diff


@pytest.mark.parametrize("edit", [
    lambda d: None,
    lambda d: d.update(x=2.5 * (1 + 0.5 * RTOL)),                 # another CPU's last digits
    lambda d: d.update(tiny=1e-12 + 0.5 * ATOL),                  # rounding noise near zero
    lambda d: d["nested"]["radius"].__setitem__(0, 0.125 * (1 - 1e-9)),
    lambda d: d.update(reversed(list(d.items()))),                # key order is not compared
], ids=["same", "float-within-rtol", "float-within-atol", "nested-float-within-rtol", "key-order"])
def test_compare_accepts_rounding_differences(edit):
    assert compare(BASE, _changed(edit)) is None


def test_compare_of_nan_and_infinity():
    assert compare({"a": float("nan")}, {"a": float("nan")}) is None
    assert compare({"a": float("inf")}, {"a": float("inf")}) is None
    assert compare({"a": float("inf")}, {"a": float("-inf")}) is not None
    assert compare({"a": 1.0}, {"a": float("nan")}) is not None


def test_masking_keeps_the_keys_so_a_renamed_timing_still_fails():
    a = normalise({"seconds": 1.25, "timing": {"median_step_s": 1e-5, "p95": [1, 2]}, "n": 3})
    assert a == {"seconds": MASK, "timing": {"median_step_s": MASK, "p95": [MASK, MASK]}, "n": 3}
    assert compare(a, normalise({"seconds": 9.0, "timing": {"median_step_s": 2e-5, "p95": [3, 4]}, "n": 3})) is None
    assert compare(a, normalise({"secs": 1.25, "timing": {"median_step_s": 1e-5, "p95": [1, 2]}, "n": 3})) is not None
    assert compare(a, normalise({"seconds": 1.25, "timing": {"median_step_s": 1e-5, "p95": [1]}, "n": 3})) is not None


def test_normalise_replaces_run_paths_and_cache_digests():
    out = normalise({"out": "/tmp/x1/tmp/c/hybobs_lookup.c",
                     "path": "/tmp/x1/cache/analysis-2da2dd6f012f633f3b3ecba691fd9773.json"},
                    {"/tmp/x1/tmp": "<TMP>", "/tmp/x1/cache": "<CACHE>"})
    assert out == {"out": "<TMP>/c/hybobs_lookup.c", "path": "<CACHE>/analysis-<digest>.json"}


def test_a_changed_golden_record_fails_with_the_case_and_path():
    """A real record, one field renamed deep inside: the message names the JSON path."""
    case = CASES_BY_NAME["regions-rotation-T3"]
    expected = load_golden(case)
    actual = copy.deepcopy(expected)
    actual["json"]["n_lps_pairs_renamed"] = actual["json"].pop("n_lps_pairs")
    assert compare_record(expected, actual).startswith("$: missing keys ['n_lps_pairs']")
    actual = copy.deepcopy(expected)
    actual["exit_code"] = 2
    assert compare_record(expected, actual) == "exit code: expected 0, got 2"

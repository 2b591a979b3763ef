"""Fuzz family "hostile files" (issue 36): files are data, never code.

Targets, each with its oracle:

* hostile system names through the C export: the generated C, stripped of comments and literals
  as a C compiler does, holds none of the name's text, and compiles with ``-std=c99 -Wall -Werror
  -pedantic`` (when ``cc`` is present) -- ``accepted-valid``; a refusal is a ``ModelError``;
* saved-file fields naming modules, files or models: ``load_analysis`` refuses the file with a
  ``ModelError`` and imports nothing (``sys.modules``) -- anything else is a bug;
* YAML aliases of every depth and fan-out: read within 10 s, refused (``ModelError``) beyond the
  alias budget;
* Unicode identifiers: names that collide after NFKC are refused, the others load with the
  normalised names;
* cache-directory tampering: whatever is done to an entry or its MAC, ``cached_analysis`` gives
  the analysis computed afresh (``correct-answer``);
* output-path tricks for ``hybobs export``: a planted link, an existing file, a missing directory
  -- refused in one line before any work, the planted target untouched (``cli-exit-2-one-line``),
  or written as asked.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest
from hypothesis import strategies as st

from .common import (ACCEPTED_VALID, CLI_OK, CORRECT, MODEL_ERROR, WRONG_ANSWER, Family, Target, assert_no_bugs,
                     describe, exception_outcome, run_target)

_TESTS = str(Path(__file__).resolve().parents[1])
if _TESTS not in sys.path:  # canonical.py and c_replay.py, also when the summary runs outside pytest
    sys.path.insert(0, _TESTS)

_WORK: dict[str, Path] = {}


def workdir() -> Path:
    import tempfile

    if "dir" not in _WORK:
        _WORK["dir"] = Path(tempfile.mkdtemp(prefix="hybobs-fuzz-hostile-"))
    return _WORK["dir"]


def _spring():
    from canonical import deadzone_spring

    return deadzone_spring()


def _analysis():
    if "analysis" not in _WORK:
        from hybobs_opt.regions import analyse_observability

        _WORK["analysis"] = analyse_observability(_spring(), 2)
    return _WORK["analysis"]


# ---------------------------------------------------------------------------------- names into C
_DANGER = ["*/", "/*", "\\", "\n", "\r", "??/", "?", '"', "'", "#", "%:", "\u2028", "\x00", "\t", "//", "é", "\U0001d431"]
_PAYLOAD = "hb_pwn_x"


def _names():
    piece = st.sampled_from(_DANGER) | st.text(alphabet="abc ;{}()=", max_size=4)
    return st.lists(piece, min_size=1, max_size=8).map(lambda parts: "".join(parts) + _PAYLOAD + "".join(reversed(parts)))


def try_c_name(name: str) -> tuple[str, str]:
    from hybobs_opt.errors import HybobsError
    from hybobs_opt.observers.c_export import check_build, export_lookup_c
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.regions import analyse_observability
    from hybobs_opt.systems import PWASystem

    from c_replay import code_only

    s = _spring()
    out = workdir() / f"c{abs(hash(name)) % 10**8}"
    try:
        system = PWASystem(s.modes, s.state_bounds, s.input_bounds, s.state_names, s.input_names, s.output_names,
                           name=name)
        export = export_lookup_c(LookupObserver(analyse_observability(system, 2)), out, overwrite=True)
        if shutil.which("cc"):
            check_build(export, system)
    except HybobsError as exc:
        return exception_outcome(exc), f"{describe(name)}: {exc}"[:300]
    for f in (export.header, export.source, export.driver):
        text = f.read_text()
        if "\\\n" in text or "??" in text or _PAYLOAD in code_only(text):
            return "user-text-in-code", f"{describe(name)} in {f.name}"
    return ACCEPTED_VALID, describe(name)


# ---------------------------------------------------------------------------------- saved-file fields
def _examples():
    modules = st.sampled_from(["subprocess:run", "os:system", "builtins:exec", "importlib:import_module",
                               "hybobs_opt.cli:main", "json:loads", "pickle:loads", "shutil:rmtree"])
    paths = st.sampled_from(["evil.py:build", "/tmp/x.py:f", "../../a.py:g", "C:\\x.py:f", "models/m.toml",
                             "/etc/passwd.json", "m.yaml", "a/b:c"])
    return modules | paths


def try_saved_example(example: str) -> tuple[str, str]:
    from hybobs_opt.errors import HybobsError
    from hybobs_opt.regions import load_analysis, save_analysis
    from hybobs_opt.systems.saved_file import content_checksum

    path = workdir() / "regions.json"
    if not path.exists():
        save_analysis(_analysis(), path, "x", {})
    data = json.loads(path.read_text())
    data = {k: v for k, v in data.items() if k not in ("system_model", "checksum")}
    data.update(example=example, params={"args": "true", "shell": True})
    data["checksum"] = content_checksum(data)
    evil = workdir() / "evil.json"
    evil.write_text(json.dumps(data))
    before = set(sys.modules)
    try:
        load_analysis(evil)
    except HybobsError as exc:
        new = {m for m in set(sys.modules) - before if not m.startswith(("hybobs_opt", "numba", "scipy", "numpy"))}
        if new:
            return "imported-from-a-file", f"{example}: {sorted(new)[:3]}"
        return exception_outcome(exc), f"{example}: {str(exc)[:160]}"
    return "accepted-garbage", f"{example}: loaded"


# ---------------------------------------------------------------------------------- YAML aliases
def _alias_shapes():
    return st.tuples(st.integers(1, 12), st.integers(1, 9))


def try_yaml_aliases(shape) -> tuple[str, str]:
    from hybobs_opt.errors import HybobsError
    from hybobs_opt.systems.model_file import read_model_dict

    depth, fan = shape
    lines = ["a0: &a0 [1, 2, 3]"] + [f"a{k}: &a{k} [{', '.join([f'*a{k - 1}'] * fan)}]" for k in range(1, depth + 1)]
    path = workdir() / "aliases.yaml"
    path.write_text("\n".join(lines) + "\n")
    t0 = time.perf_counter()
    try:
        read_model_dict(path)
        outcome = ACCEPTED_VALID  # a mapping: read_model_dict does not build a model
    except HybobsError as exc:
        outcome = exception_outcome(exc)
    seconds = time.perf_counter() - t0
    if seconds > 10:
        return "too-slow", f"depth {depth} fan-out {fan}: {seconds:.1f} s"
    if depth * fan > 64 and outcome != MODEL_ERROR:
        return "accepted-garbage", f"depth {depth} fan-out {fan}: {depth * fan} aliases accepted"
    return outcome, f"depth {depth} fan-out {fan}"


# ---------------------------------------------------------------------------------- identifiers
_CONFUSABLE = [("x", "\U0001d431"), ("x", "\uff58"), ("fi", "\ufb01"), ("a1", "a\u2081"), ("K", "\u212a"),
               ("x2", "x\u00b2"), ("u", "\u1d64"), ("y", "y")]


def try_identifiers(pair) -> tuple[str, str]:
    import unicodedata

    from hybobs_opt.errors import HybobsError
    from hybobs_opt.systems import load_model, save_model

    a, b = pair
    path = workdir() / "ids.json"
    save_model(_spring(), path)
    data = json.loads(path.read_text())
    data["states"] = [a, b]
    path.write_text(json.dumps(data, ensure_ascii=False))
    same = unicodedata.normalize("NFKC", a) == unicodedata.normalize("NFKC", b)
    try:
        system = load_model(path)
    except HybobsError as exc:
        outcome = exception_outcome(exc)
        if not same and "NFKC" in str(exc):
            return "wrong-refusal", f"{a!r}, {b!r}: {exc}"
        return outcome, f"{a!r}, {b!r}"
    if same:
        return "accepted-garbage", f"{a!r} and {b!r} both accepted"
    if tuple(system.state_names) != tuple(unicodedata.normalize("NFKC", n) for n in (a, b)):
        return WRONG_ANSWER, f"names {system.state_names}"
    return ACCEPTED_VALID, f"{a!r}, {b!r}"


# ---------------------------------------------------------------------------------- cache tampering
_TAMPER = ["flip-byte", "truncate", "drop-mac", "swap-mac", "other-sealed-file", "empty", "garbage-mac", "unicode-mac"]


def try_cache_tamper(kind: str) -> tuple[str, str]:
    from hybobs_opt import cached_analysis, use_cache
    from hybobs_opt.cache import ResultCache
    from hybobs_opt.regions import analyse_observability, save_analysis

    system = _spring()
    d = workdir() / f"cache-{kind}"
    shutil.rmtree(d, ignore_errors=True)
    cache = ResultCache(d)
    with use_cache(cache):
        fresh = cached_analysis(system, 2)
    (entry,) = d.glob("analysis-*.json")
    mac = entry.with_name(entry.name + ".mac")
    raw = entry.read_bytes()
    if kind == "flip-byte":
        entry.write_bytes(raw[:100] + bytes([raw[100] ^ 1]) + raw[101:])
    elif kind == "truncate":
        entry.write_bytes(raw[: len(raw) // 2])
    elif kind == "drop-mac":
        mac.unlink()
    elif kind == "swap-mac":
        mac.write_text("0" * 64)
    elif kind == "other-sealed-file":
        other = d / "other.json"
        save_analysis(analyse_observability(system, 3), other)
        entry.write_bytes(other.read_bytes())
    elif kind == "empty":
        entry.write_bytes(b"")
    elif kind == "unicode-mac":
        mac.write_text("é" * 64)
    else:
        mac.write_bytes(b"\xff\xfe not a mac")
    with use_cache(cache):
        again = cached_analysis(system, 2)
    same = again.T == fresh.T and [(p.i, p.j) for p in again.pairs] == [(p.i, p.j) for p in fresh.pairs] \
        and len(again.regions) == len(fresh.regions)
    refused = cache.events[-1]["outcome"] == "refused"
    return (CORRECT if same and refused else WRONG_ANSWER), f"{kind}: {cache.events[-1]['outcome']}"


# ---------------------------------------------------------------------------------- output paths
_TRICKS = ["symlink-to-file", "symlink-to-missing", "existing-file", "missing-parent", "dir-is-a-file"]


def try_output_trick(trick: str) -> tuple[str, str]:
    from .test_cli import classify, run_cli

    base = workdir() / f"out-{trick}"
    shutil.rmtree(base, ignore_errors=True)
    base.mkdir()
    victim = base / "victim.txt"
    victim.write_text("keep")
    out = base / "c"
    if trick == "missing-parent":
        out = base / "no" / "such" / "c"  # "no" is a file: no directory can be made below it
        (base / "no").write_text("a file where a directory should be")
    elif trick == "dir-is-a-file":
        out.write_text("a file")
    else:
        out.mkdir()
        target = out / "hybobs_lookup.c"
        if trick == "symlink-to-file":
            os.symlink(victim, target)
        elif trick == "symlink-to-missing":
            os.symlink(base / "created-through-link.c", target)
        else:
            target.write_text("user's file")
    model = workdir() / "spring.json"
    if not model.exists():
        from hybobs_opt.systems import save_model

        save_model(_spring(), model)
    code, o, e = run_cli(["export", str(model), "-T", "2", "--out-dir", str(out), "--no-build", "--no-cache"])
    if victim.read_text() != "keep" or (base / "created-through-link.c").exists():
        return "wrote-through-a-link", trick
    if trick == "existing-file" and code == 0:
        return "overwrote-without-force", trick
    return (classify(code, o, e, False) if code != 0 else ACCEPTED_VALID), f"{trick}: exit {code} {e.strip()[:120]}"


FAMILY = Family(
    "hostile files",
    "no user text compiled, no code named by a file run, limits before the work, tampered caches recomputed",
    [
        Target("names into generated C", _names(), try_c_name, 6),
        Target("saved-file fields naming code", _examples(), try_saved_example, 8),
        Target("YAML aliases", _alias_shapes(), try_yaml_aliases, 10, explicit=((9, 9), (12, 9), (7, 9))),
        Target("Unicode identifiers", st.sampled_from(_CONFUSABLE), try_identifiers, 8),
        Target("cache tampering", st.sampled_from(_TAMPER), try_cache_tamper, 2, explicit=tuple(_TAMPER)),
        Target("output-path tricks", st.sampled_from(_TRICKS), try_output_trick, 1, explicit=tuple(_TRICKS)),
    ],
)


@pytest.mark.parametrize("target", [pytest.param(t, id=t.name) for t in FAMILY.targets])
def test_hostile_files(target):
    assert_no_bugs(run_target(target))

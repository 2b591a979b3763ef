"""Fuzz family 4: ``hybobs`` invocations with a bad value for an option (issue 16).

For every subcommand and every option ``hybobs COMMAND --help`` lists, a table of bad values
(malformed numbers, NaN/inf, out-of-range values, unknown names and choices, files that are
missing, binary, empty or a directory, options that do not apply); hypothesis draws a row, a bad
value, whether ``--json`` is given and where the option goes (before or after ``SYSTEM``).  Every
base invocation is cheap and every bad value is refused during validation, so no scenario,
analysis or LMI starts (a run that goes on for :data:`TIME_LIMIT` seconds is a bug of its own).

``hybobs_opt.cli.main(argv)`` runs in-process with stdout and stderr captured.  Required: exit code
2 and exactly one stderr line (under ``--json``: stdout is one JSON object with ``error`` and
stderr is empty), no traceback.  Outcomes: ``cli-exit-2-one-line``, ``cli-traceback`` (an
exception escaped ``main``), ``cli-exit-0-on-bad-input``, ``cli-exit-2-malformed`` (several
lines, a warning, or no JSON error object), ``cli-exit-<code>``, ``cli-slow-on-bad-input``.
"""

from __future__ import annotations

import contextlib
import functools
import io
import json
import signal
import tempfile
import warnings
from pathlib import Path

import pytest
from hypothesis import strategies as st

from .common import CLI_EXIT0, CLI_MALFORMED, CLI_OK, CLI_TRACEBACK, Family, Target, assert_no_bugs, run_target

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "examples" / "models"
PWA_MODEL = str(MODELS / "bemporad_morari_rotation.toml")
HYBRID_MODEL = str(MODELS / "water_tanks.toml")

#: Seconds after which a bad invocation counts as having started a computation.
TIME_LIMIT = 20
CLI_SLOW = "cli-slow-on-bad-input"


@functools.cache
def files() -> dict[str, str]:
    """Bad files shared by the rows (one temporary directory per process)."""
    d = Path(tempfile.mkdtemp(prefix="hybobs-fuzz-cli-"))
    out = {"dir": str(d), "nosuch": str(d / "nosuch" / "x.csv")}
    (d / "bin").write_bytes(b"\x00\x01\x02\xff\xfe binary \x89PNG\x00")
    (d / "empty").write_text("")
    (d / "header_only.csv").write_text("theta,omega_m\n")
    (d / "text.json").write_text('{"a": 1}')
    (d / "list.json").write_text("[1, 2, 3]")
    (d / "existing").write_text("x")
    (d / "bad_rows.csv").write_text("t,T_m,omega_m\n0,1,2\n0.001,abc,2\n")
    for name in ("bin", "empty", "header_only.csv", "text.json", "list.json", "existing", "bad_rows.csv"):
        out[name] = str(d / name)
    return out


def F(name: str) -> str:
    return "{" + name + "}"


#: ``(base argv, option or None for a positional, bad values)``.  The base invocation of each row
#: is valid and cheap; ``{name}`` stands for a file of :func:`files`.
NUMBER = ["abc", "nan", "inf", "-inf", "", "1e999", "0x1p3", "1,5", "--"]
ROWS: list[tuple[list[str], str | None, list[str]]] = [
    # the command itself
    ([], None, ["nosuch", "", "-x", "SIMULATE"]),
    (["examples"], "--nosuch", ["1"]),
    (["examples"], None, ["extra"]),
    # simulate
    (["simulate"], None, ["nosuch", "", F("nosuch"), F("bin"), F("empty"), F("text.json"), F("list.json"), "nosuch.py:f",
                          "nosuchmodule_xyz:f", "os:getcwd", F("dir"), "powertrain3:build", ":", "a:b:c"]),
    (["simulate", "powertrain3"], "--param", ["gear_ratio", "=1", "nosuch=1", "gear_ratio=abc", "gear_ratio=1/0", "gear_ratio=nan",
                                             "gear_ratio=-1", "gear_ratio=inf", "gear_ratio=1e999", "gear_ratio=", "gear_ratio=[1]"]),
    (["simulate", "powertrain3"], "--t-final", NUMBER + ["-1", "0", "1e-300", "1e12", "1e308"]),
    (["simulate", "powertrain3"], "--x0", ["theta=0", "nosuch=1", "theta", "theta=abc"]),
    (["simulate", "powertrain3"], "--u", ["T_m=0", "nosuch=1", "T_m"]),
    (["simulate", "powertrain3"], "--q0", ["0", "-1", "abc", "1.5"]),
    (["simulate", "powertrain3"], "--steps", ["abc", "1.5", "-1", "1e12"]),
    (["simulate", "powertrain3"], "--ts", ["0.1", "abc", "0", "-1"]),
    (["simulate", "powertrain3", "--t-final", "0.01"], "--plot", [F("dir"), F("dir") + "/p.xyz", F("dir") + "/p"]),
    (["simulate", "powertrain3", "--t-final", "0.01"], "--out", [F("dir"), F("nosuch")]),
    (["simulate", PWA_MODEL], "--inputs", [F("nosuch"), F("bin"), F("empty"), F("dir"), F("header_only.csv"),
                                          F("text.json"), F("bad_rows.csv")]),
    (["simulate", "powertrain3"], "--inputs", [F("header_only.csv")]),
    (["simulate", HYBRID_MODEL], "--inputs", [F("header_only.csv")]),
    (["simulate", HYBRID_MODEL, "--t-final", "0.5"], "--ts", NUMBER + ["0", "-1", "1e-15", "1e300"]),
    (["simulate", HYBRID_MODEL, "--t-final", "0.5"], "--q0", ["7", "-1", "abc", "1.5", "1e300"]),
    (["simulate", HYBRID_MODEL, "--t-final", "0.5"], "--x0", ["x1=nan", "x1=1e300", "nosuch=1", "x1", "x1=-5", "x1=inf"]),
    (["simulate", HYBRID_MODEL, "--t-final", "0.5"], "--u", ["u=1"]),
    (["simulate", PWA_MODEL], "--steps", ["0", "-3", "1e12", "abc", "1000000000000"]),
    (["simulate", PWA_MODEL], "--u", ["u=1e300", "u=nan", "nosuch=1"]),
    # regions
    (["regions", "powertrain3"], "--horizon", NUMBER + ["0", "-1", "1.5", "2", "101", "1000000"]),
    (["regions", "powertrain3", "-T", "3"], "--ts", ["0.1", "abc", "0"]),
    (["regions", "driveline", "-T", "3"], "--ts", NUMBER + ["0", "-1", "1e-300"]),
    (["regions", "powertrain3", "-T", "3"], "--cut", ["theta=abc", "theta=nan", "nosuch=1", "theta", "theta=inf"]),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=0"], "--resolution", ["0x0", "abc", "41", "100000x100000", "-1x5", "2x1e3"]),
    (["regions", "powertrain3", "-T", "3"], "--resolution", ["41x31"]),
    (["regions", "powertrain3", "-T", "3", "--cut", "theta=0"], "--plot", [F("dir") + "/c.xyz", F("dir")]),
    (["regions", "powertrain3", "-T", "3"], "--out", [F("dir"), F("nosuch")]),
    (["regions", "powertrain3", "-T", "3"], "--query", [F("nosuch"), F("bin"), F("empty"), F("header_only.csv"), F("dir"),
                                                       F("bad_rows.csv")]),
    (["regions", "powertrain3", "-T", "3"], "--executor", ["nosuch", ""]),
    (["regions", "powertrain3", "-T", "3"], "--workers", ["0", "-1", "abc", "100000"]),
    (["regions", "powertrain3", "-T", "3", "--executor", "serial"], "--workers", ["2"]),
    (["regions", "powertrain3", "-T", "3"], "--scheduler", ["nonsense", "tcp://", "foo://h:1", "tcp://h:0", "tcp://h:99999", ""]),
    (["regions", "powertrain3", "-T", "3"], "--dask-local", ["0", "-1", "abc", "100000"]),
    (["regions", "vehicle_tracking"], "--horizon", ["3"]),
    (["regions", "powertrain3", "-T", "3"], "--param", ["gear_ratio", "nosuch=1", "gear_ratio=abc", "gear_ratio=0/0"]),
    # observe
    (["observe"], None, ["traffic_light", "", F("bin")]),
    (["observe", "powertrain3"], "--observers", ["nosuch", "", "LOOKUP", "lookup,miqp"]),
    (["observe", "driveline"], "--observers", ["nosuch", "miqp"]),
    (["observe", "vehicle_tracking"], "--observers", ["nosuch", "lookup"]),
    (["observe", "traffic_junction"], "--observers", ["nosuch", "switched"]),
    (["observe", "powertrain3"], "--filter", [None]),
    # --no-cache is a flag: a value after it is an unknown argument
    (["observe", "powertrain3"], "--no-cache", ["yes"]),
    (["regions", "powertrain3", "-T", "3"], "--no-cache", ["1"]),
    (["regions", "powertrain3", "-T", "3"], "--pair-by-pair", ["1", "yes"]),
    (["bench", "powertrain3", "--steps", "5"], "--no-cache", ["true"]),
    (["observe", "powertrain3"], "--param", ["gear_ratio=0.1", "nosuch=1"]),
    (["observe", "powertrain3"], "--horizon", ["3", "0", "abc"]),
    (["observe", "powertrain3"], "--fit-tolerance", ["0.1", "-1", "abc", "nan"]),
    # --noise-bound: without --data, or not a bound on a named output
    (["observe", "powertrain3"], "--noise-bound", ["0.1"]),
    (["observe", PWA_MODEL, "--data", F("nosuch"), "--observers", "miqp"], "--noise-bound", ["-1", "z=0.1"]),
    # --input-noise-bound: without --noise-bound, with another observer, not a bound on a named input
    (["observe", PWA_MODEL, "--data", F("nosuch"), "--observers", "lookup"], "--input-noise-bound", ["0.1"]),
    (["observe", PWA_MODEL, "--data", F("nosuch"), "--observers", "miqp", "--noise-bound", "0.1"],
     "--input-noise-bound", ["0.1"]),
    (["observe", PWA_MODEL, "--data", F("nosuch"), "--observers", "lookup", "--noise-bound", "0.1"],
     "--input-noise-bound", ["-1", "z=1", "abc"]),
    (["observe", PWA_MODEL, "--data", F("nosuch"), "--observers", "set_membership"], "--noise-bound",
     ["-1", "abc", "nan", "z=0.1", "y=", "y=inf"]),
    (["observe", "powertrain3"], "--regions", [F("nosuch"), F("bin")]),
    (["observe", "powertrain3"], "--gains", [F("nosuch"), F("text.json")]),
    (["observe", "driveline"], "--plot", [F("dir") + "/o.xyz", F("dir")]),
    (["observe", "driveline"], "--out", [F("dir"), F("nosuch")]),
    (["observe", PWA_MODEL], "--data", [F("nosuch"), F("bin"), F("empty"), F("dir"), F("header_only.csv"), F("text.json")]),
    (["observe", "magnetic_piston"], "--data", [F("nosuch"), F("bin"), F("empty"), F("header_only.csv")]),
    # bench
    (["bench", "powertrain3"], "--horizon", NUMBER + ["0", "-1", "1000000"]),
    (["bench", "powertrain3"], "--steps", NUMBER + ["0", "2", "-5", "1000000000000"]),
    (["bench", "powertrain3"], "--noise", NUMBER + ["-1"]),
    (["bench", "powertrain3"], "--observers", ["", ",,", "nosuch", "lookup,lookup", "lookup,,milp", "LOOKUP"]),
    (["bench", "powertrain3"], "--mhe-steps", ["0", "-5", "abc", "1.5"]),
    (["bench", "powertrain3"], "--noise-bound", ["0.1"]),
    (["bench", PWA_MODEL, "--data", F("nosuch"), "--observers", "set_membership"], "--noise-bound", ["-1", "z=1", "abc"]),
    (["bench", "powertrain3", "--observers", "lookup"], "--mhe-steps", ["5"]),
    (["bench", "powertrain3"], "--seed", ["3", "-1", "abc"]),
    (["bench", "powertrain3", "--noise", "0.1"], "--seed", ["-1", "abc", "1.5", "1e300"]),
    (["bench", "powertrain3"], "--plot", [F("dir") + "/b.xyz", F("dir")]),
    (["bench", "powertrain3"], "--regions", [F("nosuch"), F("bin")]),
    (["bench", "powertrain3"], "--data", [F("nosuch"), F("bin"), F("empty"), F("dir")]),
    (["bench", "driveline"], "--horizon", ["3"]),
    (["bench", "powertrain3"], "--param", ["nosuch=1", "gear_ratio=abc", "gear_ratio"]),
    # export
    (["export"], None, ["nosuch", "", F("bin"), F("empty"), "vehicle_tracking"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--horizon", NUMBER + ["0", "-1", "2", "1000000"]),
    (["export", "powertrain3"], "--out-dir", [F("existing")]),
    (["export", "vehicle_tracking"], "--out-dir", [F("dir") + "/c"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--float32", ["yes", "1"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--force", ["yes", "1"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--max-lps", ["0", "-1", "abc", "1e3"]),
    (["regions", "powertrain3", "-T", "40"], "--max-lps", ["0", "-1", "abc", "1000"]),
    (["observe", "powertrain3"], "--max-lps", ["0", "abc"]),
    (["bench", "powertrain3"], "--max-lps", ["0", "abc"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--no-build", ["yes", "1"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--max-bytes", ["0", "-1", "abc", "1.5", ""]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--max-ops", ["0", "-1", "abc", "1e3"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--no-cache", ["1"]),
    (["export", "powertrain3", "--out-dir", F("dir") + "/c"], "--param", ["nosuch=1", "gear_ratio=abc", "gear_ratio"]),
    # diagnose
    (["diagnose", "vehicle_tracking"], "--range", ["psi=1:0", "nosuch=0:1", "psi=abc", "psi=0:1e300", "psi", "psi=0:nan", "psi=:"]),
    (["diagnose", "vehicle_tracking"], "--coordinate", ["nosuch", ""]),
    (["diagnose", "vehicle_tracking", "--settings", "model"], "--gain-bound", NUMBER + ["0", "-1", "1e300"]),
    (["diagnose", "vehicle_tracking", "--settings", "model"], "--min-decay", NUMBER + ["-1", "1e300"]),
    (["diagnose", "vehicle_tracking", "--settings", "model"], "--overlap", NUMBER + ["-1", "1e300"]),
    (["diagnose", "vehicle_tracking"], "--condition", ["nosuch", ""]),
    (["diagnose", "vehicle_tracking"], "--noise-bound", ["-1", "nosuch=0.1", "abc", "nan", "X=0.1,Y=0.1"]),
    (["diagnose", "vehicle_tracking"], "--exact-bound-search", ["yes", "0"]),
    (["diagnose", "vehicle_tracking"], "--settings", ["nosuch", ""]),
    (["diagnose", "vehicle_tracking"], "--out-dir", [F("existing")]),
    (["diagnose"], None, ["nosuch", "powertrain3", F("bin")]),
    (["diagnose", "vehicle_tracking"], "--param", ["nosuch=1", "delta_max_deg=90", "delta_max_deg=abc"]),
    # synth
    (["synth", "vehicle_tracking"], "--out", [F("dir")]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--range", ["psi=1:0", "nosuch=0:1", "psi=abc", "psi=0:1e300"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--max-rate", NUMBER + ["0", "-1"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--periodic", ["nosuch=1", "psi=-1", "psi=abc", "psi", "psi=nan"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json", "--no-verify"], "--periodic", ["psi=6.28"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json", "--settings", "model"], "--gain-bound", ["0", "-1", "abc", "1e300"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--coordinate", ["nosuch"]),
    (["synth"], None, ["nosuch", "powertrain3"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--param", ["nosuch=1", "delta_max_deg=1e300"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json", "--settings", "model"], "--min-decay", NUMBER + ["-1", "1e300"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json", "--settings", "model"], "--overlap", ["-1", "nan", "1e300", "abc"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--condition", ["nosuch", ""]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--settings", ["nosuch", ""]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--accept-unenforced-dwell", ["1", "yes"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--no-verify", ["yes", "0"]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--noise-bound",
     ["-1", "nosuch=0.1", "abc", "nan", "X_meas=0.1,Y_meas=0.1"]),
    # model
    (["model"], None, ["nosuch", ""]),
    (["model", "check"], None, ["nosuch", F("bin"), F("empty"), F("text.json"), F("dir")]),
    # a missing directory of --out is created; a file in its place is not
    (["model", "export", "powertrain3"], "--out", [F("dir") + "/m.txt", F("dir"), F("bin") + "/m.toml"]),
    (["model", "schema"], "--out", [F("dir") + "/s.json"]),
    (["model", "check", "powertrain3"], "--param", ["nosuch=1", "gear_ratio=abc"]),
    # report
    (["report", "--out-dir", F("dir") + "/rep"], "--section", ["nosuch", "", "EXAMPLES"]),
    (["report", "--out-dir", F("dir") + "/rep"], "--horizon", ["3", "abc"]),
    (["report", "--out-dir", F("dir") + "/rep"], "--data", [F("nosuch")]),
    (["report", "--out-dir", F("dir") + "/rep"], "--param", ["gear_ratio=2"]),
    (["report", PWA_MODEL, "--out-dir", F("dir") + "/rep"], "--horizon", ["0", "1000000", "1", "abc"]),
    (["report", PWA_MODEL, "--out-dir", F("dir") + "/rep"], "--data", [F("bin"), F("nosuch"), F("dir")]),
    # --noise-bound: without --data, or not a bound on a named output
    (["report", PWA_MODEL, "--out-dir", F("dir") + "/rep"], "--noise-bound", ["0.1"]),
    (["report", "--out-dir", F("dir") + "/rep"], "--noise-bound", ["0.1"]),
    # --quick previews the report of every result: refused with a SYSTEM; a flag takes no value
    (["report", PWA_MODEL, "--out-dir", F("dir") + "/rep"], "--quick", [None]),
    (["report", "--out-dir", F("dir") + "/rep"], "--quick", ["yes"]),
    (["report", "--section", "examples"], "--out-dir", [F("existing")]),
    (["report"], None, ["nosuch"]),
    # outputs: an existing file is refused without --force (a flag: it takes no value)
    (["simulate", "powertrain3", "--t-final", "0.01"], "--out", [F("existing")]),
    (["simulate", "powertrain3", "--t-final", "0.01", "--out", F("existing")], "--force", ["yes"]),
    (["regions", "powertrain3", "-T", "3"], "--out", [F("existing")]),
    (["regions", "powertrain3", "-T", "3", "--out", F("existing")], "--force", ["yes"]),
    (["observe", "driveline"], "--out", [F("existing")]),
    (["observe", "driveline", "--out", F("existing")], "--force", ["1"]),
    (["bench", "powertrain3", "--plot", F("dir") + "/b.png"], "--force", ["yes"]),
    (["diagnose", "vehicle_tracking"], "--force", ["yes"]),
    (["synth", "vehicle_tracking"], "--out", [F("existing")]),
    (["synth", "vehicle_tracking", "--out", F("dir") + "/g.json"], "--force", ["yes"]),
    (["model", "export", "powertrain3", "--out", F("dir") + "/m.toml"], "--force", ["yes"]),
    (["report", "--out-dir", F("dir") + "/rep"], "--force", ["yes"]),
]


def argv_of(value) -> tuple[list[str], bool]:
    row, which, with_json, before = value
    base, option, bad = ROWS[row % len(ROWS)]
    v = bad[which % len(bad)]
    fs = files()

    def fill(a):
        for k, path in fs.items():
            a = a.replace("{" + k + "}", path)
        return a

    base = [fill(a) for a in base]
    v = None if v is None else fill(v)
    if option is None:
        args = base + ([] if v is None else [v])
    else:
        extra = [option] + ([] if v is None else [v])
        # an option before the positional SYSTEM (after the subcommand) or after the base
        args = base[:1] + extra + base[1:] if before and len(base) > 1 else base + extra
    if with_json and args[:1] != [] and args[0] not in ("nosuch", "", "-x", "SIMULATE"):
        args = args + ["--json"]
    # --json counts only before a "--" (after it, it is a positional argument)
    head = args[: args.index("--")] if "--" in args else args
    return args, "--json" in head


class _Timeout(Exception):
    pass


def run_cli(argv: list[str]) -> tuple[int | str, str, str]:
    """``main(argv)`` in-process: (exit code or the exception's class name, stdout, stderr)."""
    from hybobs_opt.cli import main

    out, err = io.StringIO(), io.StringIO()

    def alarm(*_):
        raise _Timeout()

    old = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(TIME_LIMIT)
    try:
        with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err), warnings.catch_warnings():
            warnings.simplefilter("default")
            warnings.showwarning = lambda m, c, f, l, file=None, line=None: print(f"{f}:{l}: {c.__name__}: {m}", file=err)
            try:
                code = main(argv)
            except SystemExit as exc:  # main must return, not exit
                code = f"SystemExit({exc.code})"
    except _Timeout:
        return "timeout", out.getvalue(), err.getvalue()
    except Exception as exc:
        return f"exception:{type(exc).__name__}: {exc}", out.getvalue(), err.getvalue()
    finally:
        signal.alarm(0)
        signal.signal(signal.SIGALRM, old)
    return code, out.getvalue(), err.getvalue()


def classify(code, out: str, err: str, as_json: bool) -> str:
    if code == "timeout":
        return CLI_SLOW
    if isinstance(code, str) and code.startswith("exception:") or "Traceback (most recent call last)" in out + err:
        return CLI_TRACEBACK
    if code == 0:
        return CLI_EXIT0
    if code != 2:
        return f"cli-exit-{code}"
    if as_json:
        try:
            record = json.loads(out)
        except ValueError:
            return CLI_MALFORMED
        ok = isinstance(record, dict) and isinstance(record.get("error"), str) and record["error"].strip() and not err.strip()
        return CLI_OK if ok else CLI_MALFORMED
    lines = [line for line in err.splitlines() if line.strip()]
    return CLI_OK if len(lines) == 1 and "error" in lines[0] else CLI_MALFORMED


def try_one(value) -> tuple[str, str]:
    argv, as_json = argv_of(value)
    code, out, err = run_cli(argv)
    outcome = classify(code, out, err, as_json)
    shown = (err.strip() or out.strip()).replace("\n", " | ")[:300]
    return outcome, f"hybobs {' '.join(repr(a) if not a or ' ' in a else a for a in argv)} -> {code}: {shown}"


def _strategy() -> st.SearchStrategy:
    return st.tuples(st.integers(0, len(ROWS) - 1), st.integers(0, 63), st.booleans(), st.booleans())


def _commands():
    out: dict[str, list[int]] = {}
    for i, (base, _, _) in enumerate(ROWS):
        out.setdefault(base[0] if base else "(none)", []).append(i)
    return out


def _target(command: str, rows: list[int], examples: int) -> Target:
    strategy = st.tuples(st.sampled_from(rows), st.integers(0, 63), st.booleans(), st.booleans())
    return Target(f"hybobs {command}", strategy, try_one, examples)


FAMILY = Family(
    "CLI invocations",
    "exit 2 with exactly one stderr line (--json: one JSON object with 'error'), no traceback",
    [_target(cmd, rows, max(4, len(rows) + 2)) for cmd, rows in _commands().items()],
)

KNOWN_DEFECTS: dict[str, str] = {}


@pytest.mark.parametrize("target", [pytest.param(t, id=t.name, marks=[pytest.mark.xfail(strict=True, reason=KNOWN_DEFECTS[t.name])]
                                                 if t.name in KNOWN_DEFECTS else []) for t in FAMILY.targets])
def test_bad_invocations(target):
    assert_no_bugs(run_target(target))


def test_every_option_of_every_command_has_a_row():
    """The table covers every option ``hybobs COMMAND --help`` lists (besides --help and --json)."""
    from hybobs_opt.cli import build_parser

    parser = build_parser()
    sub = next(a for a in parser._actions if a.dest == "command")
    covered = {(base[0] if base else None, opt) for base, opt, _ in ROWS}
    missing = []
    for name, p in sub.choices.items():
        for action in p._actions:
            for opt in action.option_strings:
                if opt.startswith("--") and opt not in ("--help", "--json") and (name, opt) not in covered:
                    if not any((name, o) in covered for o in action.option_strings):
                        missing.append(f"{name} {opt}")
    assert not missing, missing

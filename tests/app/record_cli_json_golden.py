"""Golden records of the ``--json`` output of every ``hybobs`` command (tests/app/cli_json_golden/).

``tests/app/test_cli_json_golden.py`` runs each case of :data:`CASES` through the CLI's ``main`` (in
process), normalises its JSON (:func:`normalise`) and compares it with the record stored here
(:func:`compare`: the same keys, the same strings, booleans, integers and nulls, the same list
lengths, floats within ``rtol = 1e-6, atol = 1e-9``).  It guards refactors that move code between
modules: the JSON of every command must stay what it is.

Run this script ONLY when a change of a command's JSON output is intended, and say so in the commit
message (which cases changed and why)::

    python -m tests.app.record_cli_json_golden                  # every case
    python -m tests.app.record_cli_json_golden CASE [CASE ...]  # some cases (names as in CASES)
    python -m tests.app.record_cli_json_golden --list           # the cases
    python -m tests.app.record_cli_json_golden --inputs         # also rewrite the input logs (rarely)

Every case runs twice (each time in a fresh output directory and a fresh, empty cache of analyses) and
nothing is written unless both runs normalise to the same JSON: a field that measures time or
depends on the run and is not yet masked (:data:`VOLATILE_KEYS`) is reported instead of recorded.

What is masked (the key stays, its value becomes ``"<masked>"``): wall-clock times and rates computed
from them (``seconds``, ``median_step_s``, ``ratio_to_lookup`` ...), file modification times, byte
counts of cache files (they hold those times), and the gains file's checksum (it covers the design's
``seconds``).  What is replaced: the case's temporary directory by ``<TMP>``, its cache directory by
``<CACHE>``, the repository by ``<REPO>``, and the 32-hex digests of cache file names (they hash the
package's source code, so any refactor changes them) by ``<digest>``.

The input logs under ``cli_json_golden/inputs/`` are fixed data (made once by ``--inputs``: the
rotation model under a sine input, a window of the powertrain3 scenario, a run of the flexible-joint
robot); the cases run from the repository root with relative paths, so the JSON holds no absolute path.
"""

from __future__ import annotations

import contextlib
import io
import json
import math
import os
import re
import shutil
import sys
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parents[2]
GOLDEN_DIR = REPO / "tests" / "app" / "cli_json_golden"
#: The input logs, relative to the repository root (the cases run there).
INPUTS = "tests/app/cli_json_golden/inputs"

#: Float comparison: ``|actual - expected| <= ATOL + RTOL * |expected|`` (numpy's ``isclose``).
RTOL = 1e-6
ATOL = 1e-9

#: What a masked value becomes.
MASK = "<masked>"

#: Keys whose values measure time or depend on the run (masked wherever they occur, structure kept).
VOLATILE_KEYS = frozenset({
    # wall-clock times
    "seconds", "run_seconds", "seconds_per_sample", "seconds_enumeration", "seconds_algorithm_3_1",
    "table_seconds", "analysis_seconds", "design_seconds", "solver_seconds",
    "median_step_s", "p95_step_s", "max_step_s", "compute_time_per_step_s", "timing",
    # rates and ratios of wall-clock times
    "batch_steps_per_s", "ratio_to_lookup",
    # the cache's files: modification time, size (an analysis entry holds its seconds)
    "modified", "bytes", "removed_bytes",
    # the gains file's checksum covers the design's seconds
    "checksum",
})

#: A cache file name: ``KIND-<32 hex>.json|.npz`` (the digest hashes the package's sources).
_CACHE_FILE = re.compile(r"(?<![0-9a-f])([a-z][a-z0-9-]*)-[0-9a-f]{32}\.(json|npz)")


@dataclass(frozen=True)
class Case:
    """One golden record: ``hybobs ARGV``, after the ``before`` commands (same cache, same directory).

    In ``argv`` and ``before``, ``{tmp}`` is the case's temporary directory and ``{inputs}`` the
    input logs.  ``slow`` marks the test ``slow``; ``needs_cc``: skipped without a C compiler.
    """

    name: str
    argv: tuple[str, ...]
    before: tuple[tuple[str, ...], ...] = ()
    slow: bool = False
    needs_cc: bool = False

    @property
    def command(self) -> str:
        return self.argv[0]


def _case(name: str, line: str, *, before: tuple[str, ...] = (), slow: bool = False, needs_cc: bool = False) -> Case:
    return Case(name, tuple(line.split()), tuple(tuple(b.split()) for b in before), slow, needs_cc)


ROT = "examples/models/bemporad_morari_rotation.toml"
ROT_LOG = "{inputs}/rotation_sine.csv"
PT3_LOG = "{inputs}/powertrain3_window.csv"
ROBOT = "examples/models/flexible_joint_robot.toml"
ROBOT_LOG = "{inputs}/flexible_joint_robot.csv"
EXAMPLES = ("driveline", "switched_unstable", "triangular", "double_scroll", "powertrain3", "powertrain5",
            "switching_server", "traffic_junction", "vehicle_tracking", "magnetic_piston")
MODEL_FILES = ("bemporad_morari_rotation.json", "bemporad_morari_rotation.toml", "flexible_joint_robot.toml",
               "flexible_joint_robot.yaml", "water_tanks.toml")
#: A short run of each example (``simulate EXAMPLE --t-final T``).
SIM_T_FINAL = {"driveline": "0.2", "switched_unstable": "1", "triangular": "0.1", "double_scroll": "1",
               "powertrain3": "0.05", "powertrain5": "0.02", "switching_server": "5", "traffic_junction": "5",
               "vehicle_tracking": "0.5", "magnetic_piston": "0.05"}

CASES: list[Case] = [
    # --- examples
    _case("examples", "examples --json"),
    # --- model
    _case("model-schema", "model schema --json"),
    *[_case(f"model-check-{ex}", f"model check {ex} --json") for ex in EXAMPLES],
    *[_case(f"model-check-{f}", f"model check examples/models/{f} --json") for f in MODEL_FILES],
    _case("model-check-builder-water_tanks", "model check examples/builders/water_tanks.py:build --json"),
    _case("model-check-builder-rotation-param",
          "model check examples/builders/bemporad_morari_rotation.py:build --param gain=0.5 --json"),
    _case("model-check-powertrain3-param", "model check powertrain3 --param gear_ratio=1/2 --json"),
    _case("model-export-powertrain3-toml", "model export powertrain3 --out {tmp}/powertrain3.toml --json"),
    _case("model-export-water_tanks-json", "model export examples/models/water_tanks.toml --out {tmp}/tanks.json --json"),
    # --- simulate
    *[_case(f"simulate-{ex}", f"simulate {ex} --t-final {t} --json") for ex, t in SIM_T_FINAL.items()],
    _case("simulate-powertrain3-param", "simulate powertrain3 --t-final 0.02 --param gear_ratio=1/2 --json"),
    _case("simulate-rotation-toml", f"simulate {ROT} --steps 20 --x0 x1=3 --x0 x2=-2 --u u=0.5 --json"),
    _case("simulate-rotation-builder", "simulate examples/builders/bemporad_morari_rotation.py:build --steps 10 --json"),
    _case("simulate-water_tanks-toml", "simulate examples/models/water_tanks.toml --t-final 1 --json"),
    _case("simulate-robot-yaml", "simulate examples/models/flexible_joint_robot.yaml --t-final 0.05 --dt 0.005 --x0 theta_l=0.5 --json"),
    # --- regions
    _case("regions-rotation-T3", f"regions {ROT} -T 3 --executor serial --out {{tmp}}/rotation_regions.json "
          "--query {inputs}/rotation_query.csv --json"),
    # a second run answers from the cache (the first stored the analysis)
    _case("regions-rotation-T3-cached", f"regions {ROT} -T 3 --executor serial --json",
          before=(f"regions {ROT} -T 3 --executor serial --json",)),
    _case("regions-rotation-T3-pair-by-pair", f"regions {ROT} -T 3 --executor serial --pair-by-pair --json"),
    _case("regions-powertrain3-T3-cut", "regions powertrain3 -T 3 --executor serial --cut omega_l=0 --resolution 6x5 --json"),
    _case("regions-powertrain5-T5", "regions powertrain5 -T 5 --executor serial --json"),
    _case("regions-error-powertrain3-T2", "regions powertrain3 -T 2 --executor serial --json"),
    _case("regions-error-water_tanks-ts", "regions examples/models/water_tanks.toml --ts 0.1 -T 2 --executor serial --json"),
    # --- observe: recorded logs
    *[_case(f"observe-rotation-{kind}", f"observe {ROT} --data {ROT_LOG} -T 3 --observer {kind} --json")
      for kind in ("lookup", "miqp", "milp", "milp_inf")],
    _case("observe-rotation-set_membership",
          f"observe {ROT} --data {ROT_LOG} -T 3 --observer set_membership --noise-bound y=0.01 --json"),
    _case("observe-rotation-lookup-noise-bound",
          f"observe {ROT} --data {ROT_LOG} -T 3 --observer lookup --noise-bound y=0.01 --input-noise-bound u=0.001 --json"),
    _case("observe-powertrain3-log-lookup", f"observe powertrain3 --data {PT3_LOG} -T 3 --json"),
    _case("observe-powertrain3-log-miqp", f"observe powertrain3 --data {PT3_LOG} -T 3 --observer miqp --json"),
    _case("observe-powertrain3-log-saved-regions", f"observe powertrain3 --data {PT3_LOG} --regions {{tmp}}/pt3.json "
          "--out {tmp}/estimates.csv --json",
          before=("regions powertrain3 -T 3 --executor serial --out {tmp}/pt3.json --json",)),
    _case("observe-robot-log-switched", f"observe {ROBOT} --data {ROBOT_LOG} --json"),
    # --- observe: the examples' scenarios
    _case("observe-switched_unstable", "observe switched_unstable --json"),
    _case("observe-switched_unstable-filter", "observe switched_unstable --filter --json"),
    _case("observe-triangular", "observe triangular --json"),
    _case("observe-double_scroll", "observe double_scroll --json"),
    _case("observe-switching_server", "observe switching_server --json"),
    _case("observe-switching_server-positive-projection", "observe switching_server --observer positive+projection --json"),
    _case("observe-traffic_junction", "observe traffic_junction --json"),
    _case("observe-traffic_junction-deadbeat", "observe traffic_junction --observer deadbeat --json"),
    _case("observe-powertrain3", "observe powertrain3 --json", slow=True),
    _case("observe-vehicle_tracking", "observe vehicle_tracking --json", slow=True),
    _case("observe-magnetic_piston", "observe magnetic_piston --json", slow=True),
    _case("observe-driveline", "observe driveline --json", slow=True),
    # --- bench
    _case("bench-powertrain3-lookup", "bench powertrain3 -T 3 --steps 100 --observers lookup --json"),
    _case("bench-powertrain3-lookup-miqp-milp", "bench powertrain3 -T 3 --steps 100 --observers lookup,miqp,milp "
          "--mhe-steps 10 --json"),
    _case("bench-powertrain3-noise", "bench powertrain3 -T 3 --steps 100 --observers lookup --noise 0.01 --seed 3 --json"),
    _case("bench-rotation-log", f"bench {ROT} --data {ROT_LOG} -T 3 --observers lookup,miqp,milp,set_membership "
          "--noise-bound y=0.01 --json"),
    _case("bench-powertrain5-lookup", "bench powertrain5 -T 5 --steps 50 --observers lookup --json", slow=True),
    # --- export
    _case("export-rotation", f"export {ROT} -T 3 --out-dir {{tmp}}/c --no-build --json"),
    _case("export-powertrain3", "export powertrain3 -T 3 --out-dir {tmp}/c --no-build --json"),
    _case("export-powertrain3-float32-limits", "export powertrain3 -T 3 --out-dir {tmp}/c --no-build --float32 "
          "--max-bytes 100 --max-ops 10 --json"),
    _case("export-rotation-build", f"export {ROT} -T 3 --out-dir {{tmp}}/c --json", needs_cc=True),
    # --- diagnose
    _case("diagnose-vehicle_tracking-range", "diagnose vehicle_tracking --range psi=0:60 --json"),
    _case("diagnose-vehicle_tracking-range-report", "diagnose vehicle_tracking --range psi=0:60 --out-dir {tmp}/d --json"),
    _case("diagnose-robot", f"diagnose {ROBOT} --json"),
    _case("diagnose-magnetic_piston", "diagnose magnetic_piston --json"),
    _case("diagnose-vehicle_tracking", "diagnose vehicle_tracking --json", slow=True),
    _case("diagnose-error-powertrain3", "diagnose powertrain3 --json"),
    # --- synth
    _case("synth-robot", f"synth {ROBOT} --out {{tmp}}/gains.json --no-verify --json"),
    _case("synth-vehicle_tracking-no-verify", "synth vehicle_tracking --out {tmp}/gains.json --no-verify --json"),
    _case("synth-vehicle_tracking", "synth vehicle_tracking --out {tmp}/gains.json --json", slow=True),
    _case("synth-magnetic_piston-no-verify", "synth magnetic_piston --out {tmp}/gains.json --no-verify --json", slow=True),
    # --- report
    _case("report-water_tanks", "report examples/models/water_tanks.toml --out-dir {tmp}/r --json"),
    _case("report-rotation", f"report {ROT} --out-dir {{tmp}}/r -T 3 --json", slow=True),
    _case("report-section-examples", "report --out-dir {tmp}/r --section examples --json", slow=True),
    # --- cache
    _case("cache-info-empty", "cache info --json"),
    _case("cache-info", "cache info --json", before=(f"regions {ROT} -T 3 --executor serial --json",
                                                     f"observe {ROT} --data {ROT_LOG} -T 3 --json")),
    _case("cache-clear", "cache clear --json", before=(f"regions {ROT} -T 3 --executor serial --json",)),
    # --- errors under --json (one JSON object on stdout, exit code 2)
    _case("error-unknown-system", "simulate no_such_example --json"),
    _case("error-usage-missing-system", "regions --json"),
    _case("error-unknown-param", "simulate powertrain3 --param warp=2 --json"),
    _case("error-bench-set_membership-without-data", "bench powertrain3 --observers set_membership --json"),
]

CASES_BY_NAME: dict[str, Case] = {c.name: c for c in CASES}
assert len(CASES_BY_NAME) == len(CASES), "case names must be unique"


# ---------------------------------------------------------------------------------------- running
@contextlib.contextmanager
def _case_environment(tmp: Path, cache: Path) -> Iterator[None]:
    """The repository root as working directory and ``cache`` as the (empty) cache of analyses.

    numba's kernel cache stays where it was (fixed before ``HYBOBS_CACHE_DIR`` moves, as
    tests/conftest.py does): otherwise every case would compile the kernels afresh.
    """
    saved_env = {k: os.environ.get(k) for k in ("HYBOBS_CACHE_DIR", "HYBOBS_NO_CACHE", "NUMBA_CACHE_DIR")}
    saved_cwd = os.getcwd()
    if "NUMBA_CACHE_DIR" not in os.environ:
        from hybobs_opt._numba_cache import numba_cache_dir

        os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()
    os.environ["HYBOBS_CACHE_DIR"] = str(cache)
    os.environ.pop("HYBOBS_NO_CACHE", None)
    os.chdir(REPO)
    try:
        yield
    finally:
        os.chdir(saved_cwd)
        for key, value in saved_env.items():
            if value is None:
                os.environ.pop(key, None)
            else:
                os.environ[key] = value


def _fill(argv: tuple[str, ...], tmp: Path) -> list[str]:
    return [a.replace("{tmp}", str(tmp)).replace("{inputs}", INPUTS) for a in argv]


def _run_cli(argv: list[str]) -> tuple[int, str]:
    from hybobs_opt.cli import main

    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main(argv)
    return code, out.getvalue()


def run_case(case: Case, workdir: Path) -> dict[str, Any]:
    """Run ``case`` in ``workdir`` (its ``{tmp}``; the cache goes in a sibling directory); the
    normalised record ``{"case", "argv", "exit_code", "json"}``."""
    tmp = Path(workdir) / "tmp"
    cache = Path(workdir) / "cache"
    tmp.mkdir(parents=True, exist_ok=True)
    with _case_environment(tmp, cache):
        for before in case.before:
            code, out = _run_cli(_fill(before, tmp))
            if code != 0:
                raise AssertionError(f"case {case.name!r}: the set-up command {' '.join(before)!r} exited {code}: {out}")
        code, out = _run_cli(_fill(case.argv, tmp))
    lines = out.splitlines()
    if len(lines) != 1:
        raise AssertionError(f"case {case.name!r}: expected one line of JSON on stdout, got {len(lines)} lines: {out[:500]!r}")
    data = json.loads(lines[0])
    return {"case": case.name, "argv": list(case.argv), "exit_code": code,
            "json": normalise(data, {str(tmp): "<TMP>", str(cache): "<CACHE>", str(REPO): "<REPO>"})}


# ---------------------------------------------------------------------------------- normalising
def _masked(value: Any) -> Any:
    """``value`` with every leaf but ``None`` replaced by :data:`MASK` (keys and list lengths kept)."""
    if isinstance(value, dict):
        return {k: _masked(v) for k, v in value.items()}
    if isinstance(value, list):
        return [_masked(v) for v in value]
    return None if value is None else MASK


def _normal_string(text: str, replacements: dict[str, str]) -> str:
    for old, new in sorted(replacements.items(), key=lambda kv: -len(kv[0])):  # longest first: nested paths
        if old:
            text = text.replace(old, new)
            real = os.path.realpath(old)
            if real != old:
                text = text.replace(real, new)
    return _CACHE_FILE.sub(r"\1-<digest>.\2", text)


def normalise(value: Any, replacements: dict[str, str] | None = None) -> Any:
    """The JSON ``value`` with :data:`VOLATILE_KEYS` masked and run-dependent paths replaced."""
    replacements = replacements or {}
    if isinstance(value, dict):
        return {k: _masked(v) if k in VOLATILE_KEYS else normalise(v, replacements) for k, v in value.items()}
    if isinstance(value, list):
        return [normalise(v, replacements) for v in value]
    if isinstance(value, str):
        return _normal_string(value, replacements)
    return value


# ---------------------------------------------------------------------------------- comparing
def _step(path: str, key: Any) -> str:
    if isinstance(key, int):
        return f"{path}[{key}]"
    return f"{path}.{key}" if re.fullmatch(r"[A-Za-z_][A-Za-z0-9_]*", key) else f"{path}[{key!r}]"


def _show(value: Any) -> str:
    text = json.dumps(value)
    return text if len(text) <= 120 else text[:117] + "..."


def _kind(value: Any) -> str:
    return {bool: "boolean", int: "integer", float: "float", str: "string", type(None): "null",
            list: "list", dict: "object"}.get(type(value), type(value).__name__)


def compare(expected: Any, actual: Any, path: str = "$") -> str | None:
    """The first difference between two JSON values, as ``"PATH: message"``, or ``None``.

    Objects: the same set of keys; lists: the same length; strings, booleans, integers and nulls:
    equal (``1`` and ``1.0`` differ: the JSON text differs); floats: ``|a - e| <= ATOL + RTOL |e|``
    (both NaN, or the same infinity, are equal).
    """
    if isinstance(expected, dict):
        if not isinstance(actual, dict):
            return f"{path}: expected an object, got {_kind(actual)} {_show(actual)}"
        missing = [k for k in expected if k not in actual]
        extra = [k for k in actual if k not in expected]
        if missing or extra:
            parts = ([f"missing keys {missing}"] if missing else []) + ([f"unexpected keys {extra}"] if extra else [])
            return f"{path}: {'; '.join(parts)}"
        for key in expected:
            diff = compare(expected[key], actual[key], _step(path, key))
            if diff is not None:
                return diff
        return None
    if isinstance(expected, list):
        if not isinstance(actual, list):
            return f"{path}: expected a list, got {_kind(actual)} {_show(actual)}"
        if len(expected) != len(actual):
            return f"{path}: expected a list of {len(expected)} items, got {len(actual)}"
        for i, (e, a) in enumerate(zip(expected, actual)):
            diff = compare(e, a, _step(path, i))
            if diff is not None:
                return diff
        return None
    if type(expected) is not type(actual):
        return f"{path}: expected {_kind(expected)} {_show(expected)}, got {_kind(actual)} {_show(actual)}"
    if isinstance(expected, float):
        if math.isnan(expected) or math.isnan(actual):
            same = math.isnan(expected) and math.isnan(actual)
        elif math.isinf(expected) or math.isinf(actual):
            same = expected == actual
        else:
            same = abs(actual - expected) <= ATOL + RTOL * abs(expected)
        if not same:
            return (f"{path}: expected {expected!r}, got {actual!r} (beyond rtol={RTOL:g}, atol={ATOL:g}; "
                    f"relative difference {abs(actual - expected) / max(abs(expected), 1e-300):.3g})")
        return None
    if expected != actual:
        return f"{path}: expected {_show(expected)}, got {_show(actual)}"
    return None


# ---------------------------------------------------------------------------------- golden files
def golden_path(case: Case) -> Path:
    return GOLDEN_DIR / f"{case.name}.json"


def load_golden(case: Case) -> dict[str, Any]:
    return json.loads(golden_path(case).read_text(encoding="utf-8"))


def compare_record(expected: dict[str, Any], actual: dict[str, Any]) -> str | None:
    """The first difference between two records of a case (exit code, then the JSON), or ``None``."""
    if expected["argv"] != actual["argv"]:
        return f"the golden record was made for argv {expected['argv']}, the case runs {actual['argv']} (re-record it)"
    if expected["exit_code"] != actual["exit_code"]:
        return f"exit code: expected {expected['exit_code']}, got {actual['exit_code']}"
    return compare(expected["json"], actual["json"])


def _write(record: dict[str, Any], path: Path) -> None:
    path.write_text(json.dumps(record, indent=1) + "\n", encoding="utf-8")


# ---------------------------------------------------------------------------------- input logs
def write_inputs() -> None:
    """(Re)write the input logs under :data:`INPUTS` (fixed data: only when a case needs new ones)."""
    import csv

    import numpy as np

    from hybobs_opt.sim import simulate_pwa
    from hybobs_opt.systems import load_model

    inputs = REPO / INPUTS
    inputs.mkdir(parents=True, exist_ok=True)
    # the rotation model of Bemporad & Morari under a sine input (no noise)
    system = load_model(REPO / ROT)
    u = np.array([[0.8 * math.sin(0.7 * k)] for k in range(30)])
    trace = simulate_pwa(system, np.array([3.0, -2.0]), u)
    with (inputs / "rotation_sine.csv").open("w", newline="", encoding="utf-8") as fh:
        w = csv.writer(fh)
        w.writerow(["t", "u", "y", "x1", "x2"])
        for k in range(len(u)):
            w.writerow([k, repr(float(u[k, 0])), repr(float(trace.y[k, 0])), repr(float(trace.x[k, 0])),
                        repr(float(trace.x[k, 1]))])
    with (inputs / "rotation_query.csv").open("w", newline="", encoding="utf-8") as fh:
        fh.write("x2,x1\n0,0\n1.5,-2\n-3,4\n9,9\n")
    with tempfile.TemporaryDirectory() as tmp, _case_environment(Path(tmp), Path(tmp) / "cache"):
        # a window of the powertrain3 scenario around two changes of the dead-zone mode (t = 1.373, 1.490 s)
        full = Path(tmp) / "powertrain3.csv"
        assert _run_cli(["simulate", "powertrain3", "--out", str(full)])[0] == 0
        lines = full.read_text(encoding="utf-8").splitlines()
        (inputs / "powertrain3_window.csv").write_text("\n".join([lines[0], *lines[1360:1510]]) + "\n", encoding="utf-8")
        # the flexible-joint robot released from theta_l = 0.5 rad
        code, _ = _run_cli(["simulate", ROBOT, "--t-final", "0.5", "--ts", "0.005", "--x0", "theta_l=0.5",
                            "--out", str(inputs / "flexible_joint_robot.csv"), "--force"])
        assert code == 0


# ---------------------------------------------------------------------------------- recording
def record(case: Case) -> dict[str, Any]:
    """The record of ``case``, from two runs that must agree (else ``AssertionError`` naming the field)."""
    records = []
    for _ in range(2):
        with tempfile.TemporaryDirectory(prefix="hybobs-golden-") as workdir:
            records.append(run_case(case, Path(workdir)))
    first, second = records
    diff = compare(first["json"], second["json"])
    if diff is None and json.dumps(first["json"]) != json.dumps(second["json"]):
        diff = "the two runs differ within the float tolerance (a timing?): " + _first_exact_difference(first["json"], second["json"])
    if diff is not None:
        raise AssertionError(f"case {case.name!r} is not reproducible: {diff} (a field to mask in VOLATILE_KEYS?)")
    return first


def _first_exact_difference(a: Any, b: Any, path: str = "$") -> str:
    if isinstance(a, dict) and isinstance(b, dict):
        for k in a:
            if k in b and json.dumps(a[k]) != json.dumps(b[k]):
                return _first_exact_difference(a[k], b[k], _step(path, k))
    if isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            if json.dumps(x) != json.dumps(y):
                return _first_exact_difference(x, y, _step(path, i))
    return f"{path}: {_show(a)} vs {_show(b)}"


def main(argv: list[str] | None = None) -> int:
    import time

    args = list(sys.argv[1:] if argv is None else argv)
    if "--list" in args:
        for c in CASES:
            print(f"{c.name:<48} hybobs {' '.join(c.argv)}" + ("  [slow]" if c.slow else ""))
        return 0
    if "--inputs" in args:
        args.remove("--inputs")
        write_inputs()
    unknown = [a for a in args if a not in CASES_BY_NAME]
    if unknown:
        print(f"unknown cases {unknown}; see --list", file=sys.stderr)
        return 2
    cases = [CASES_BY_NAME[a] for a in args] if args else CASES
    GOLDEN_DIR.mkdir(parents=True, exist_ok=True)
    failed = 0
    for case in cases:
        if case.needs_cc and shutil.which("cc") is None:
            print(f"skipped {case.name}: no C compiler 'cc'", file=sys.stderr)
            continue
        t0 = time.perf_counter()
        try:
            rec = record(case)
        except AssertionError as exc:
            print(f"FAILED {exc}", file=sys.stderr)
            failed += 1
            continue
        _write(rec, golden_path(case))
        print(f"{time.perf_counter() - t0:6.1f} s  {case.name}  (exit {rec['exit_code']})")
    if not args:
        stale = sorted(p.name for p in GOLDEN_DIR.glob("*.json") if p.stem not in CASES_BY_NAME)
        for name in stale:
            print(f"note: {name} belongs to no case (delete it)", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())

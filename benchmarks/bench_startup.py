"""Start-up time of the ``hybobs`` command (issue 13): ``hybobs --help`` and ``hybobs examples --json``.

Writes ``benchmarks/results/startup.json``.  Each command runs in a fresh Python process (a cold
start of the interpreter and the package; the operating system's file cache is warm after the
first run), ``repeats`` times; the median is compared with the 0.5 s target of issue 13.  Also
recorded: which heavy modules each command imported (none of cvxpy, CasADi, numba may be), and
the same for a bare ``python -c pass`` (the interpreter's own floor on this machine) so the
package's share can be read as a difference.
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
import time
from pathlib import Path

from ._machine import machine, versions

RESULTS = Path(__file__).resolve().parent / "results"
TARGET_S = 0.5
HEAVY = ("cvxpy", "casadi", "numba", "scipy", "matplotlib", "numpy", "daqp", "highspy", "clarabel")

COMMANDS = {
    "python -c pass": None,
    "hybobs --help": ["--help"],
    "hybobs examples --json": ["examples", "--json"],
}


def _hybobs() -> list[str]:
    """The installed console script next to this interpreter, else ``python -m hybobs_opt.cli``."""
    script = Path(sys.executable).with_name("hybobs")
    return [str(script)] if script.exists() else [sys.executable, "-m", "hybobs_opt.cli"]


def _probe(argv: list[str] | None) -> str:
    if argv is None:
        return "pass"
    return ("import sys, contextlib, io\n"
            "from hybobs_opt.cli import main\n"
            "with contextlib.redirect_stdout(io.StringIO()):\n"
            "    try:\n"
            f"        main({argv!r})\n"
            "    except SystemExit:\n"
            "        pass\n"
            f"print(','.join(m for m in {HEAVY!r} if m in sys.modules))\n")


def measure(argv: list[str] | None, repeats: int) -> dict:
    """Median wall time of ``repeats`` cold processes running the command, and the heavy imports."""
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        if argv is None:
            subprocess.run([sys.executable, "-c", "pass"], check=True)
        else:
            subprocess.run([*_hybobs(), *argv], check=True, capture_output=True)
        times.append(time.perf_counter() - t0)
    heavy = [] if argv is None else heavy_modules_imported(argv)
    return {"median_s": statistics.median(times), "times_s": times, "heavy_modules_imported": heavy}


def heavy_modules_imported(argv: list[str]) -> list[str]:
    """The modules of :data:`HEAVY` that ``hybobs ARGV`` imports (run in a fresh interpreter)."""
    out = subprocess.run([sys.executable, "-c", _probe(argv)], check=True, capture_output=True, text=True).stdout.strip()
    return out.split(",") if out else []


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_startup")
    parser.add_argument("--quick", action="store_true", help="3 repeats instead of 5")
    args = parser.parse_args(argv)
    repeats = 3 if args.quick else 5
    record: dict = {"benchmark": "hybobs start-up, cold processes", "command": " ".join(_hybobs()),
                    "repeats": repeats, "target_s": TARGET_S,
                    "machine": machine(), "versions": versions(["hybobs_opt"]), "commands": {}}
    for label, cmd in COMMANDS.items():
        rec = measure(cmd, repeats)
        if cmd is not None:
            rec["target_met"] = rec["median_s"] <= TARGET_S
            rec["no_solver_imported"] = not set(rec["heavy_modules_imported"]) & {"cvxpy", "casadi", "numba"}
        record["commands"][label] = rec
    floor = record["commands"]["python -c pass"]["median_s"]
    for label, rec in record["commands"].items():
        rec["above_interpreter_s"] = rec["median_s"] - floor
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "startup.json").write_text(json.dumps(record, indent=2))
    print(json.dumps({k: {"median_s": v["median_s"], "heavy": v["heavy_modules_imported"]} for k, v in record["commands"].items()}, indent=2))
    ok = all(r.get("target_met", True) and r.get("no_solver_imported", True) for r in record["commands"].values())
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

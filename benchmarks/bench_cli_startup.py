"""Time to the first output line of the long ``hybobs`` commands, against 0.5 s and ``python -c pass``.

Writes ``benchmarks/results/cli_startup.json``.  Each command runs in a fresh process with its
stderr on a pseudo-terminal (where a user sees the first line, ``hybobs CMD: loading ... ...``,
printed before the heavy imports) and its stdout on a pipe; the time to the first complete line on
either is measured from the process's start, and the time to its exit too.  Every command runs
``repeats`` times (5 by default), interleaved with the others so that the machine's load falls on
all alike; medians are reported, with the ratio to the limit of 0.5 s and to a bare
``python -c pass`` (the interpreter's own start-up on this machine, measured the same way, to its exit).

The commands: ``hybobs model check`` of a shipped model file, ``hybobs observe`` of the rotation
model on a recorded log (lookup observer, T = 3) and ``hybobs regions powertrain3 -T 3`` (serial
executor), the last two with an empty cache directory (a first run on a new system, the case that
was silent for tens of seconds).
"""

from __future__ import annotations

import argparse
import json
import os
import pty
import select
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ._machine import machine, versions

RESULTS = Path(__file__).resolve().parent / "results"
REPO = Path(__file__).resolve().parents[1]
LIMIT_S = 0.5

COMMANDS: dict[str, list[str]] = {
    "model check examples/models/flexible_joint_robot.toml": ["model", "check", "examples/models/flexible_joint_robot.toml"],
    "observe rotation --data LOG -T 3 --observers lookup": [
        "observe", "examples/models/bemporad_morari_rotation.toml", "--data",
        "tests/app/cli_json_golden/inputs/rotation_sine.csv", "-T", "3", "--observers", "lookup"],
    "regions powertrain3 -T 3 --executor serial": ["regions", "powertrain3", "-T", "3", "--executor", "serial"],
}


def _hybobs() -> list[str]:
    script = Path(sys.executable).with_name("hybobs")
    return [str(script)] if script.exists() else [sys.executable, "-m", "hybobs_opt.cli"]


def first_line(cmd: list[str], env: dict[str, str]) -> dict:
    """Seconds from the start of ``cmd`` to its first complete output line (stdout pipe or stderr
    terminal), the line itself and where it came, and seconds to its exit."""
    master, slave = pty.openpty()
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=slave, stdin=subprocess.DEVNULL, cwd=REPO, env=env)
    os.close(slave)
    buffers = {proc.stdout.fileno(): b"", master: b""}
    names = {proc.stdout.fileno(): "stdout", master: "stderr"}
    first, first_s, source = None, None, None
    open_fds = set(buffers)
    while open_fds:
        ready, _, _ = select.select(list(open_fds), [], [], 60.0)
        if not ready:
            break
        for fd in ready:
            try:
                chunk = os.read(fd, 65536)
            except OSError:  # the terminal's other end closed
                chunk = b""
            if not chunk:
                open_fds.discard(fd)
                continue
            buffers[fd] += chunk
            if first is None and b"\n" in buffers[fd]:
                first_s = time.perf_counter() - t0
                first, source = buffers[fd].split(b"\n", 1)[0].decode(errors="replace").strip(), names[fd]
    proc.wait()
    exit_s = time.perf_counter() - t0
    os.close(master)
    if proc.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} exited {proc.returncode}: {buffers}")
    return {"first_line_s": first_s, "first_line": first, "from": source, "exit_s": exit_s}


def python_pass() -> float:
    t0 = time.perf_counter()
    subprocess.run([sys.executable, "-c", "pass"], check=True)
    return time.perf_counter() - t0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat (results/quick/)")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    runs: dict[str, list[dict]] = {name: [] for name in COMMANDS}
    baseline: list[float] = []
    load_start = os.getloadavg()
    for _ in range(repeats):
        baseline.append(python_pass())
        for name, cmd in COMMANDS.items():
            with tempfile.TemporaryDirectory(prefix="hybobs-bench-cache-") as d:
                env = {**os.environ, "HYBOBS_CACHE_DIR": d, "PYTHONPATH": str(REPO)}
                env.pop("HYBOBS_NO_CACHE", None)
                runs[name].append(first_line(_hybobs() + cmd, env))
    base = statistics.median(baseline)
    out = {"benchmark": "cli_startup", "repeats": repeats, "limit_s": LIMIT_S, "machine": machine(),
           "versions": versions(["hybobs_opt", "numpy", "scipy", "cvxpy", "casadi"]),
           "load_average_start": list(load_start), "load_average_end": list(os.getloadavg()),
           "python_c_pass_s": {"median_s": base, "runs_s": baseline}, "commands": {}}
    for name, recs in runs.items():
        first = statistics.median(r["first_line_s"] for r in recs)
        done = statistics.median(r["exit_s"] for r in recs)
        out["commands"][name] = {
            "argv": COMMANDS[name], "first_line_median_s": first, "exit_median_s": done,
            "first_line_over_limit": first / LIMIT_S, "first_line_over_python_pass": first / base,
            "within_limit": first <= LIMIT_S, "first_line": recs[0]["first_line"], "first_line_from": recs[0]["from"],
            "runs": recs}
        print(f"{name:<56} first line {first:5.2f} s ({first / LIMIT_S:4.2f} x limit, {first / base:4.1f} x python -c pass)"
              f"  exit {done:5.2f} s", file=sys.stderr)
    folder = RESULTS / "quick" if args.quick else RESULTS
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cli_startup.json").write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

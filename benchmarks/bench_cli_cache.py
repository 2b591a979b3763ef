"""Cold and warm runs of the long ``hybobs`` commands (issue 17): the wall time a user waits.

Writes ``benchmarks/results/cli_cache.json``.  Each command runs in a fresh process (the
interpreter, the package's imports and numba's on-disk kernel cache included), ``repeats`` times
in three ways, interleaved so that the machine's load falls on all alike:

``cold``
    an empty cache directory (``HYBOBS_CACHE_DIR`` pointing at a new one): the analysis, the
    lookup tables and the exact labels are computed and stored;
``warm``
    the same command again on that directory: they are loaded from the cache;
``no_cache``
    ``--no-cache`` (what every run cost before the cache).

Reported per command: the median of each, the ratio warm / cold, and the in-process time of the
analysis itself (``analysis_seconds`` of the JSON summary, where the command reports one) so the
share of the interpreter's and the imports' start-up can be read off.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from ._machine import machine, versions

RESULTS = Path(__file__).resolve().parent / "results"

COMMANDS = {
    "observe powertrain5": ["observe", "powertrain5", "--json"],
    "observe powertrain3": ["observe", "powertrain3", "--json"],
    "regions powertrain5 -T 5": ["regions", "powertrain5", "-T", "5", "--json"],
    "bench powertrain3 --observers lookup": ["bench", "powertrain3", "--observers", "lookup", "--json"],
}


def _hybobs() -> list[str]:
    script = Path(sys.executable).with_name("hybobs")
    return [str(script)] if script.exists() else [sys.executable, "-m", "hybobs_opt.cli"]


def _run(argv: list[str], cache_dir: str) -> tuple[float, dict]:
    env = {**os.environ, "HYBOBS_CACHE_DIR": cache_dir}
    env.pop("HYBOBS_NO_CACHE", None)
    t0 = time.perf_counter()
    done = subprocess.run(_hybobs() + argv, capture_output=True, text=True, env=env, check=True)
    return time.perf_counter() - t0, json.loads(done.stdout)


def measure(argv: list[str], repeats: int) -> dict:
    """Medians of ``repeats`` cold, warm and ``--no-cache`` runs of ``hybobs ARGV``."""
    times: dict[str, list[float]] = {"cold": [], "warm": [], "no_cache": []}
    outcomes: dict[str, list[str]] = {"cold": [], "warm": []}
    inner: list[float] = []
    for _ in range(repeats):
        with tempfile.TemporaryDirectory(prefix="hybobs-bench-cache-") as d:
            for mode in ("cold", "warm"):
                seconds, summary = _run(argv, d)
                times[mode].append(seconds)
                outcomes[mode] = sorted({e["outcome"] for e in summary.get("cache", [])})
            seconds, summary = _run(argv + ["--no-cache"], d)
            times["no_cache"].append(seconds)
            if "analysis_seconds" in summary:
                inner.append(float(summary["analysis_seconds"]))
            elif "seconds" in summary:
                inner.append(float(summary["seconds"]))
    med = {k: statistics.median(v) for k, v in times.items()}
    return {"median_s": med, "runs_s": times, "warm_over_cold": med["warm"] / med["cold"],
            "cache_outcomes": outcomes,
            "analysis_seconds_in_process_no_cache": statistics.median(inner) if inner else None}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="one repeat (results/quick/)")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args(argv)
    repeats = 1 if args.quick else args.repeats
    out = {"benchmark": "cli_cache", "repeats": repeats, "machine": machine(),
           "versions": versions(["hybobs_opt", "numpy", "scipy", "numba"]), "commands": {}}
    for name, cmd in COMMANDS.items():
        out["commands"][name] = rec = measure(cmd, repeats)
        m = rec["median_s"]
        print(f"{name:<40} cold {m['cold']:6.2f} s  warm {m['warm']:6.2f} s  --no-cache {m['no_cache']:6.2f} s  "
              f"(warm/cold {rec['warm_over_cold']:.2f})", file=sys.stderr)
    folder = RESULTS / "quick" if args.quick else RESULTS
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "cli_cache.json").write_text(json.dumps(out, indent=2))
    return 0


if __name__ == "__main__":
    sys.exit(main())

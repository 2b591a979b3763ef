"""Start-up time of the ``hybobs`` command (issue 13) and first calls of the library (issues 19, 39).

Writes ``benchmarks/results/startup.json``.

``first_analysis`` (issue 39) is the issue's two figures.  (1) A fresh process that runs
``from hybobs_opt import analyse_observability, get_example`` and one
``analyse_observability(get_example("powertrain3").build(), 3)``, timed from outside as a whole
process (wall clock, and the CPU time of the child from ``getrusage``), against the target of
1 s and against ``python -c pass`` timed alike, interleaved, ``repeats`` times; the medians.
(2) In fresh processes, the first such analysis against the second (wall and CPU; the median
ratio), target at most 2.  Both with the caches warm, as after an install: numba's kernel cache
(``python -m hybobs_opt._warm_up`` first, a no-op when warm) and Python's bytecode cache (a
temporary ``PYTHONPYCACHEPREFIX``, written by one unmeasured run; the environment may set
``PYTHONDONTWRITEBYTECODE``, under which every process compiles the package's sources again:
that variant is recorded too, ``no_bytecode_cache``).  With ``--baseline PATH`` (a checkout of
another commit, e.g. the main branch) the same process and first/second probes also run with that
checkout first on ``PYTHONPATH``, interleaved in the same rounds (its numba cache warmed the same
way), and the medians and ours-over-baseline ratios are recorded under ``baseline``; each probe
also records which heavy modules (numba, scipy.optimize, scipy.spatial) its process imported.

``first_calls`` (issue 19): in fresh processes, with numba's cache directory empty (``cold``: the
kernels run as plain Python in that process while a background process compiles them into the
cache, see ``hybobs_opt._numba_cache``; the wait for it is recorded) and then present (``warm``), the wall times of ``from hybobs_opt import ...``,
the first and second ``analyse_observability(powertrain3(), 3)`` (system construction
included), the lookup observer's construction, its first ``step()`` against the median of the
next 50, and its first and second ``run()`` (200 samples).  Target: a first call within 2 x the
second.  Each command runs in a fresh Python process (a cold
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


_FIRST_CALLS_PROBE = r"""
import json, statistics, sys, time
t0 = time.perf_counter()
from hybobs_opt import LookupObserver, analyse_observability, get_example, simulate_pwa
import numpy as np
rec = {"import_s": time.perf_counter() - t0}
def analysis():
    return analyse_observability(get_example("powertrain3").build(), 3)
for k in ("first", "second"):
    t0 = time.perf_counter(); an = analysis(); rec[f"analysis_{k}_s"] = time.perf_counter() - t0
plant = an.system
trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((260, 1), 40.0))
U, Y = np.ascontiguousarray(trace.u), np.ascontiguousarray(trace.y)
t0 = time.perf_counter(); obs = LookupObserver(an); rec["observer_build_s"] = time.perf_counter() - t0
steps = []
for k in range(51):
    t0 = time.perf_counter(); obs.step(U[k], Y[k]); steps.append(time.perf_counter() - t0)
rec["step_first_s"], rec["step_second_s"], rec["step_next_50_median_s"] = steps[0], steps[1], statistics.median(steps[1:])
for k in ("first", "second"):
    t0 = time.perf_counter(); obs.run(U[:200], Y[:200]); rec[f"run_{k}_s"] = time.perf_counter() - t0
rec["numba_cache_dir"] = __import__("os").environ.get("NUMBA_CACHE_DIR")
from hybobs_opt._numba_cache import kernels_compiled
rec["kernels_compiled"] = kernels_compiled()
print(json.dumps(rec))
"""


_ANALYSIS_PROBE = ("from hybobs_opt import analyse_observability, get_example\n"
                   "analyse_observability(get_example('powertrain3').build(), 3)\n")

_RATIO_PROBE = r"""
import json, sys, time
wall, cpu = time.perf_counter, time.process_time
c00 = cpu()
from hybobs_opt import analyse_observability, get_example
rec = {"import_cpu_s": cpu() - c00}
for k in ("first", "second"):
    w0, c0 = wall(), cpu()
    analyse_observability(get_example("powertrain3").build(), 3)
    rec[f"analysis_{k}_s"], rec[f"analysis_{k}_cpu_s"] = wall() - w0, cpu() - c0
rec["imported"] = [m for m in ("numba", "scipy.optimize", "scipy.spatial", "highspy") if m in sys.modules]
import hybobs_opt
rec["package"] = hybobs_opt.__file__
print(json.dumps(rec))
"""


def _child(code: str, env: dict, cwd: str | None = None) -> tuple[float, float, str]:
    """Wall time, CPU time (user + system, from ``getrusage``) and stdout of ``python -c code``
    (run in ``cwd``: ``python -c`` imports from its working directory first)."""
    import resource

    r0 = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", code], env=env, check=True, capture_output=True, text=True, cwd=cwd).stdout
    wall = time.perf_counter() - t0
    r1 = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (r1.ru_utime + r1.ru_stime) - (r0.ru_utime + r0.ru_stime), out


def _git_commit(path: str) -> str | None:
    try:
        return subprocess.run(["git", "-C", path, "rev-parse", "HEAD"], check=True, capture_output=True,
                              text=True).stdout.strip()
    except (OSError, subprocess.CalledProcessError):
        return None


def first_analysis(repeats: int, baseline: str | None = None) -> dict:
    """Issue 39's figures (module docstring): import + one analysis as a whole process, and the
    first analysis of a process against its second, with numba's and Python's caches warm;
    with ``baseline`` (a checkout's path) the same for that checkout, interleaved."""
    import os
    import tempfile

    load_start = list(os.getloadavg())
    base = {k: v for k, v in os.environ.items() if k not in ("PYTHONDONTWRITEBYTECODE", "PYTHONPYCACHEPREFIX")}
    ours_root = str(Path(__file__).resolve().parents[1])
    base["PYTHONPATH"] = os.pathsep.join([ours_root, *[p for p in base.get("PYTHONPATH", "").split(os.pathsep) if p]])
    out: dict = {"target_s": 1.0, "target_first_over_second_at_most": 2.0, "repeats": repeats,
                 "load_average_at_start": load_start, "commit": _git_commit(ours_root)}
    with tempfile.TemporaryDirectory(prefix="hybobs-pycache-") as pycache, \
            tempfile.TemporaryDirectory(prefix="hybobs-pycache-base-") as pycache_base:
        warm = {**base, "PYTHONPYCACHEPREFIX": pycache}
        subprocess.run([sys.executable, "-m", "hybobs_opt._warm_up"], env=warm, check=True, capture_output=True)
        warm_base = None
        if baseline:
            warm_base = {**warm, "PYTHONPYCACHEPREFIX": pycache_base, "PYTHONPATH": str(Path(baseline).resolve())}
            subprocess.run([sys.executable, "-m", "hybobs_opt._warm_up"], env=warm_base, check=True, capture_output=True,
                           cwd=baseline)
            _child(_ANALYSIS_PROBE, warm_base, baseline)
        base_rows: dict[str, list] = {"process_s": [], "process_cpu_s": []}
        base_ratios = []
        no_pyc = {k: v for k, v in base.items() if k != "PYTHONPYCACHEPREFIX"}
        no_pyc["PYTHONDONTWRITEBYTECODE"] = "1"  # the installed packages' own bytecode is still read
        _child(_ANALYSIS_PROBE, warm)  # writes the bytecode cache
        rows: dict[str, list] = {k: [] for k in ("pass_s", "pass_cpu_s", "process_s", "process_cpu_s",
                                                 "no_bytecode_cache_process_s", "no_bytecode_cache_process_cpu_s")}
        ratios = []
        for _ in range(repeats):  # interleaved, so that the load falls on all alike
            w, c, _out = _child("pass", warm)
            rows["pass_s"].append(w)
            rows["pass_cpu_s"].append(c)
            w, c, _out = _child(_ANALYSIS_PROBE, warm)
            rows["process_s"].append(w)
            rows["process_cpu_s"].append(c)
            w, c, _out = _child(_ANALYSIS_PROBE, no_pyc)
            rows["no_bytecode_cache_process_s"].append(w)
            rows["no_bytecode_cache_process_cpu_s"].append(c)
            ratios.append(json.loads(_child(_RATIO_PROBE, warm)[2].strip().splitlines()[-1]))
            if warm_base is not None:
                w, c, _out = _child(_ANALYSIS_PROBE, warm_base, baseline)
                base_rows["process_s"].append(w)
                base_rows["process_cpu_s"].append(c)
                base_ratios.append(json.loads(_child(_RATIO_PROBE, warm_base, baseline)[2].strip().splitlines()[-1]))
    med = {k: statistics.median(v) for k, v in rows.items()}
    for k in ("analysis_first_s", "analysis_second_s", "analysis_first_cpu_s", "analysis_second_cpu_s"):
        med[k] = statistics.median(r[k] for r in ratios)
    first_over_second = statistics.median(r["analysis_first_s"] / r["analysis_second_s"] for r in ratios)
    first_over_second_cpu = statistics.median(r["analysis_first_cpu_s"] / r["analysis_second_cpu_s"] for r in ratios)
    out.update({
        "medians": med, "per_run": rows, "ratio_runs": ratios,
        "process_over_pass": med["process_s"] / med["pass_s"],
        "first_over_second": first_over_second, "first_over_second_cpu": first_over_second_cpu,
        "process_target_met": med["process_s"] <= 1.0, "process_cpu_within_target": med["process_cpu_s"] <= 1.0,
        "first_over_second_target_met": first_over_second <= 2.0,
        "import_cpu_s": statistics.median(r["import_cpu_s"] for r in ratios),
        "imported": ratios[-1]["imported"], "package": ratios[-1]["package"],
        "load_average_at_end": list(os.getloadavg()),
    })
    if baseline:
        bmed = {k: statistics.median(v) for k, v in base_rows.items()}
        for k in ("analysis_first_s", "analysis_second_s", "analysis_first_cpu_s", "analysis_second_cpu_s", "import_cpu_s"):
            bmed[k] = statistics.median(r[k] for r in base_ratios)
        out["baseline"] = {
            "path": str(Path(baseline).resolve()), "commit": _git_commit(baseline), "medians": bmed,
            "per_run": base_rows, "ratio_runs": base_ratios, "imported": base_ratios[-1]["imported"],
            "package": base_ratios[-1]["package"],
            "first_over_second": statistics.median(r["analysis_first_s"] / r["analysis_second_s"] for r in base_ratios),
            "first_over_second_cpu": statistics.median(r["analysis_first_cpu_s"] / r["analysis_second_cpu_s"]
                                                       for r in base_ratios),
            # per round, ours over the baseline's (the same load on both), then the median
            "process_over_baseline": statistics.median(a / b for a, b in zip(rows["process_s"], base_rows["process_s"])),
            "process_cpu_over_baseline": statistics.median(a / b for a, b in zip(rows["process_cpu_s"],
                                                                                 base_rows["process_cpu_s"])),
        }
    return out


def first_call_times(cache_dir: str) -> dict:
    """The probe above in a fresh process whose numba cache is ``cache_dir`` (and the total wall time)."""
    import os

    env = {**os.environ, "NUMBA_CACHE_DIR": cache_dir}
    t0 = time.perf_counter()
    out = subprocess.run([sys.executable, "-c", _FIRST_CALLS_PROBE], check=True, capture_output=True, text=True, env=env)
    rec = json.loads(out.stdout.strip().splitlines()[-1])
    rec["process_s"] = time.perf_counter() - t0
    rec["analysis_first_over_second"] = rec["analysis_first_s"] / rec["analysis_second_s"]
    rec["step_first_over_next_median"] = rec["step_first_s"] / rec["step_next_50_median_s"]
    rec["run_first_over_second"] = rec["run_first_s"] / rec["run_second_s"]
    return rec


def first_calls(warm_repeats: int) -> dict:
    """``cold``: an empty numba cache (a new temporary directory); ``warm``: the same directory
    afterwards, ``warm_repeats`` processes, the median of each figure."""
    import tempfile

    import os

    with tempfile.TemporaryDirectory(prefix="hybobs-numba-") as tmp:
        cold = first_call_times(tmp)
        # the cold process ran its kernels as Python and started the background compilation
        # (hybobs_opt._numba_cache): wait for it (its lock file goes) before the warm runs
        t0 = time.perf_counter()
        lock = os.path.join(tmp, "hybobs-warm-up.lock")
        while os.path.exists(lock) and time.perf_counter() - t0 < 600:
            time.sleep(0.5)
        cold["background_compile_wait_s"] = time.perf_counter() - t0
        warm_runs = [first_call_times(tmp) for _ in range(warm_repeats)]
    warm = {k: statistics.median(r[k] for r in warm_runs) for k in warm_runs[0] if k not in ("numba_cache_dir", "kernels_compiled")}
    warm["kernels_compiled"] = warm_runs[-1].get("kernels_compiled")
    return {"cold": cold, "warm": warm, "warm_runs": warm_runs, "target_first_over_second_at_most": 2.0,
            "warm_target_met": {k: warm[k] <= 2.0 for k in ("analysis_first_over_second", "step_first_over_next_median",
                                                            "run_first_over_second")},
            "cold_target_met": {k: cold[k] <= 2.0 for k in ("analysis_first_over_second", "step_first_over_next_median",
                                                            "run_first_over_second")}}


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_startup")
    parser.add_argument("--quick", action="store_true", help="3 repeats instead of 5")
    parser.add_argument("--no-first-calls", action="store_true", help="skip the first-call measurement (minutes cold)")
    parser.add_argument("--only-first-analysis", action="store_true",
                        help="only issue 39's two figures (first_analysis), kept with the rest of the last record")
    parser.add_argument("--baseline", metavar="PATH",
                        help="a checkout of another commit: first_analysis runs it too, interleaved (A/B)")
    args = parser.parse_args(argv)
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    if args.only_first_analysis:
        path = out_dir / "startup.json"
        record = json.loads(path.read_text()) if path.exists() else {}
        record["first_analysis"] = fa = first_analysis(3 if args.quick else 7, args.baseline)
        out_dir.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(record, indent=2))
        print(json.dumps({k: fa[k] for k in ("medians", "process_over_pass", "first_over_second", "first_over_second_cpu",
                                             "process_target_met", "process_cpu_within_target",
                                             "first_over_second_target_met", "imported",
                                             "load_average_at_start", "load_average_at_end")}, indent=2))
        if "baseline" in fa:
            print(json.dumps({k: v for k, v in fa["baseline"].items() if k not in ("per_run", "ratio_runs")}, indent=2))
        return 0
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
    record["first_analysis"] = first_analysis(3 if args.quick else 7, args.baseline)
    if not args.no_first_calls:
        record["first_calls"] = first_calls(repeats)
        record["load_average_at_end"] = list(__import__("os").getloadavg())
        fc = record["first_calls"]
        print(json.dumps({k: {q: v for q, v in fc[k].items() if q != "numba_cache_dir"} for k in ("cold", "warm")},
                         indent=2))
    out_dir.mkdir(parents=True, exist_ok=True)
    (out_dir / "startup.json").write_text(json.dumps(record, indent=2))
    print(json.dumps({k: {"median_s": v["median_s"], "heavy": v["heavy_modules_imported"]} for k, v in record["commands"].items()}, indent=2))
    ok = all(r.get("target_met", True) and r.get("no_solver_imported", True) for r in record["commands"].values())
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())

"""Issue 20: the lookup-table observer (paper 002, Algorithm 4.1) exported as C99, against the numba
kernel and the Python ``step()`` in the same run.

Run ``python -m benchmarks.bench_export`` (full, about 3 minutes) or ``--quick`` (smoke test, results
in ``benchmarks/results/quick/``).  Writes ``benchmarks/results/export.json``:

* per system -- model (16) at T = 3 and T = 5, model (17) at T = 5 -- the exported tables' bytes
  (flash), the state struct's bytes (RAM), the worst-case multiply-adds of one step and their parts,
  for ``double`` and ``float`` (or why ``float`` is refused), and the compile time of
  ``cc -std=c99 -O2``;
* on the bench scenario of ``hybobs bench`` (3,000 samples of 1 ms, noise-free): the time of every
  step of the C code (``clock_gettime`` inside the generated driver), of the numba kernel
  (``_lookup_kernels.advance`` timed by the same clock inside a compiled loop; steps whose ``B~_T``
  test needs LPs add the Python decision, timed by ``perf_counter_ns``) and of
  ``LookupObserver.step()`` (``perf_counter``), each replayed ``repeats`` times.  Per step the
  fastest of the repeats (interrupts and page faults removed), then the median and the maximum
  over the scenario; also the maximum over every repeat.  Each repeat of the Python observer starts
  from a new one, without the cuts its ``B~_T`` LPs learnt in an earlier repeat (the C code learns
  none);
* whether the C answers equal the Python observer's (flags, modes, estimates) and the LP counts.
"""

from __future__ import annotations

import argparse
import ctypes
import json
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from ._machine import git_state, json_default, machine, versions

RESULTS = Path(__file__).resolve().parent / "results"
CFLAGS = ["-std=c99", "-O2"]
SYSTEMS = (("powertrain3", 3), ("powertrain3", 5), ("powertrain5", 5))
CLOCK_MONOTONIC = 1  # Linux


def _stats(ns: np.ndarray) -> dict:
    """``ns``: (steps, repeats) nanoseconds.  Per step the fastest repeat; median / p99 / max over steps."""
    best = ns.min(axis=1)
    return {"median_step_s": float(np.median(best)) * 1e-9, "p99_step_s": float(np.percentile(best, 99)) * 1e-9,
            "max_step_s": float(best.max()) * 1e-9, "max_step_s_any_repeat": float(ns.max()) * 1e-9,
            "mean_step_s": float(best.mean()) * 1e-9, "repeats": int(ns.shape[1])}


def _numba_timed_loop():
    """A compiled loop over :func:`_lookup_kernels.advance` timing each call with ``clock_gettime``."""
    from numba import njit

    from hybobs_opt.observers import _lookup_kernels as K

    libc = ctypes.CDLL(None)
    clock = libc.clock_gettime
    clock.argtypes = [ctypes.c_int, ctypes.c_void_p]
    clock.restype = ctypes.c_int

    @njit
    def loop(U, Y, start, ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
             table, offset, mthr, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
             mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, in_A, in_b, x_lo, x_hi,
             ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, x_c, survivors, ts, ns, codes):
        for t in range(start, U.shape[0]):
            clock(CLOCK_MONOTONIC, ts.ctypes.data)
            a = ts[0] * 1000000000 + ts[1]
            code = K.advance(U[t], Y[t], ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
                             table, offset, mthr, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
                             mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, in_A, in_b, x_lo, x_hi,
                             ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, x_c, survivors)
            clock(CLOCK_MONOTONIC, ts.ctypes.data)
            ns[t] = ts[0] * 1000000000 + ts[1] - a
            codes[t] = code
            if code == K.CANDIDATE_CODE:
                return t
        return U.shape[0]

    return loop


def time_numba(make, U, Y, repeats: int, loop) -> tuple[np.ndarray, int]:
    """Per step nanoseconds of the kernel (+ the Python LP decision of candidate steps), ``(N, repeats)``."""
    from hybobs_opt.observers import _lookup_kernels as K

    N = U.shape[0]
    out = np.empty((N, repeats), dtype=np.int64)
    ts = np.zeros(2, dtype=np.int64)
    candidates = 0
    for r in range(repeats):
        obs = make()  # a new observer: no cuts learnt by an earlier repeat's B~_T LPs
        ns = np.zeros(N, dtype=np.int64)
        codes = np.zeros(N, dtype=np.int64)
        t = 0
        while t < N:
            t = loop(U, Y, t, obs._ints, obs._reals, obs._Ybuf, obs._Ubuf, obs._xcur, obs._meta, obs._uprev, obs._z,
                     obs._xs0, obs._xnew, *obs._tables, ts, ns, codes)
            if t < N:
                t0 = time.perf_counter_ns()
                obs._decide_candidate()
                ns[t] += time.perf_counter_ns() - t0
                candidates += r == 0
                t += 1
        out[:, r] = ns
        assert codes.min() >= 0 and codes.max() <= K.CANDIDATE_CODE
    return out, candidates


def time_python_step(make, U, Y, repeats: int) -> np.ndarray:
    out = np.empty((U.shape[0], repeats), dtype=np.int64)
    for r in range(repeats):
        obs = make()
        for k in range(U.shape[0]):
            t0 = time.perf_counter_ns()
            obs.step(U[k], Y[k])
            out[k, r] = time.perf_counter_ns() - t0
    return out


def compile_driver(cc: str, export) -> tuple[Path, float]:
    exe = export.directory / f"{export.name}_driver"
    t0 = time.perf_counter()
    subprocess.run([cc, *CFLAGS, str(export.source), str(export.driver), "-lm", "-o", str(exe)], check=True,
                   capture_output=True, text=True)
    return exe, time.perf_counter() - t0


def run_driver(exe: Path, system, U, Y, work: Path, repeats: int) -> dict:
    log = work / "log.csv"
    with log.open("w") as fh:
        fh.write(",".join(["t", *system.input_names, *system.output_names]) + "\n")
        for k in range(U.shape[0]):
            fh.write(",".join(repr(float(v)) for v in (k, *U[k], *Y[k])) + "\n")
    r = subprocess.run([str(exe), str(log), str(work / "out.csv"), str(work / "times.csv"), str(repeats)],
                       capture_output=True, text=True, check=True)
    counters = {}
    for line in r.stdout.splitlines():
        w = line.split()
        counters.update({w[i]: int(w[i + 1]) for i in range(0, len(w) - 1, 2)})
    rows = [line.split(",") for line in (work / "out.csv").read_text().splitlines()[1:]]
    n = system.n
    return {"x": np.array([[float(v) for v in row[1 : 1 + n]] for row in rows]),
            "mode": np.array([int(row[1 + n]) for row in rows]), "flags": np.array([row[2 + n] for row in rows]),
            "ns": np.loadtxt(work / "times.csv", delimiter=",", ndmin=2).astype(np.int64), "counters": counters}


def main(argv: list[str] | None = None) -> int:
    from hybobs_opt.errors import ModelError
    from hybobs_opt.observers.c_export import export_lookup_c
    from hybobs_opt.observers.lookup import LookupObserver
    from hybobs_opt.studies.paper002_powertrain.bench import bench_trace

    parser = argparse.ArgumentParser(prog="python -m benchmarks.bench_export", description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="600 samples, 2 repeats, model (16) at T = 3 only; "
                        "results in results/quick/")
    args = parser.parse_args(argv)
    cc = shutil.which("cc")
    if cc is None:
        print("[bench_export] no C compiler 'cc' on PATH", file=sys.stderr)
        return 1
    out_dir = RESULTS / "quick" if args.quick else RESULTS
    out_dir.mkdir(parents=True, exist_ok=True)
    steps, repeats = (600, 2) if args.quick else (3000, 5)
    systems = SYSTEMS[:1] if args.quick else SYSTEMS
    t_start = time.perf_counter()
    host = machine()
    loop = _numba_timed_loop()
    results = {}
    with tempfile.TemporaryDirectory(prefix="hybobs-bench-export-") as tmp:
        for example, T in systems:
            key = f"{'model16' if example == 'powertrain3' else 'model17'}_T{T}"
            print(f"[bench_export] {key}: tables and export ({time.perf_counter() - t_start:.0f} s)", file=sys.stderr, flush=True)
            plant, trace, y, analysis = bench_trace(example, T, steps, 0.0)
            obs = LookupObserver(analysis)
            U, Y = trace.u, y
            rec: dict = {"example": example, "horizon": T, "steps": steps, "n_states": plant.n}
            for precision in ("double", "float32"):
                work = Path(tmp) / f"{key}_{precision}"
                try:
                    export = export_lookup_c(obs, work, float32=precision == "float32")
                except ModelError as exc:
                    rec[precision] = {"refused": str(exc)}
                    continue
                exe, compile_s = compile_driver(cc, export)
                rec[precision] = {"table_bytes": export.table_bytes, "state_bytes": export.state_bytes,
                                  "max_ops": export.max_ops, "ops": export.ops, "sizes": export.sizes,
                                  "float32_rounding": export.float32_rounding, "source_bytes": export.source.stat().st_size,
                                  "compile_s": compile_s}
                if precision == "double":
                    double_exe, double_work = exe, work
            # timing, in one run: the C driver, the numba kernel, Python step()
            print(f"[bench_export] {key}: timing ({time.perf_counter() - t_start:.0f} s)", file=sys.stderr, flush=True)
            ref = obs.run(U, Y)
            python_btilde = {k: v for k, v in obs.stats().items() if k.startswith("n_btilde")}
            c = run_driver(double_exe, plant, U, Y, double_work, repeats)
            def make():
                return LookupObserver(analysis)

            numba_ns, candidates = time_numba(make, U, Y, repeats, loop)
            python_ns = time_python_step(make, U, Y, max(2, repeats - 2))
            rel = np.abs(c["x"] - ref.x_hat) / np.maximum(1.0, np.abs(ref.x_hat))
            rec["timing"] = {"c": _stats(c["ns"]), "numba_kernel": _stats(numba_ns), "python_step": _stats(python_ns)}
            rec["timing"]["numba_candidate_steps_with_python_lps"] = int(candidates)
            rec["timing"]["c_speedup_over_numba_median"] = rec["timing"]["numba_kernel"]["median_step_s"] / rec["timing"]["c"]["median_step_s"]
            rec["timing"]["c_speedup_over_python_step_median"] = rec["timing"]["python_step"]["median_step_s"] / rec["timing"]["c"]["median_step_s"]
            rec["agreement"] = {"flags_equal": bool(np.array_equal(c["flags"], ref.flags)),
                                "n_flags_different": int(np.count_nonzero(c["flags"] != ref.flags)),
                                "modes_equal": bool(np.array_equal(c["mode"], ref.mode)),
                                "max_relative_error": float(rel.max()), "bitwise_equal": bool(np.array_equal(c["x"], ref.x_hat)),
                                "flag_counts": ref.flag_counts(), "c_counters": c["counters"],
                                "python_btilde": python_btilde}
            results[key] = rec
    record = {
        "benchmark": "export",
        "issue": 20,
        "quick": args.quick,
        "created": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "machine": host,
        "versions": versions(("hybobs_opt", "numpy", "numba")),
        "compiler": subprocess.run([cc, "--version"], capture_output=True, text=True).stdout.splitlines()[0],
        "cflags": CFLAGS,
        "git": git_state("hybobs_opt/observers"),
        "scenario": "bench_trace(example, T, steps, 0.0): the torque profile of 'hybobs bench' through the backlash, noise-free",
        "results": results,
        "seconds": time.perf_counter() - t_start,
    }
    import os

    record["machine"]["load_average_at_end"] = list(os.getloadavg()) if hasattr(os, "getloadavg") else None
    path = out_dir / "export.json"
    path.write_text(json.dumps(record, indent=1, default=json_default) + "\n")
    print(f"[bench_export] wrote {path} in {record['seconds']:.0f} s", file=sys.stderr)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())

"""The same answers under numerically different set-ups of one machine (CI's reproducibility job).

Algorithm 3.1 (paper 002) decides pair sets from floating-point values compared with tolerances;
if those values depended on the CPU, a pair list, an LP count or a point label would differ
between an Intel and an AMD machine.  Their sources of difference can all be reached on one
machine, by environment variables read at start-up:

* OpenBLAS's kernels (``OPENBLAS_CORETYPE``: SkylakeX, Haswell, or the generic Prescott) and its
  thread count (``OPENBLAS_NUM_THREADS`` 1 and 2): other summation orders and FMA use;
* NumPy's SIMD dispatch (``NPY_DISABLE_CPU_FEATURES``: AVX-512, AVX2 and FMA3 off);
* numba compiled for a generic x86-64 (``NUMBA_CPU_NAME=generic``, in a cache of its own);
* the kernels run as plain Python (``HYBOBS_KERNELS=python``, the first process of a fresh install).

Each set-up runs the reference computations in a child process: the pair lists (sha256 of
``[[i, j], ...]`` for the pieces, the thin and the same-state pairs) and LP counts of
``analyse_observability`` on model (17) at T = 5, 6, 7 (grouped) and T = 5 pair by pair, on
model (16) at T = 5 pair by pair, the labels of 200 states (``classify_many``), and the flags and
estimates (bit for bit) of the lookup observer on 3,000 samples of the backlash torque profile
of model (16), noise-free and with output noise; the machine
as it is also runs model (17) at T = 8 (grouped).  Every set-up must give the same answers as
the first, and the first the answers recorded in ``tests/reproducibility_reference.json``
(written with ``--record``; the counts of ``benchmarks/results/regions.json`` and the README
are these).  A difference is printed and the exit status is 1.

Run: ``.venv/bin/python scripts/check_reproducible.py [--record] [--setups NAME ...]``.
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
REFERENCE = ROOT / "tests" / "reproducibility_reference.json"

#: (model, horizon, grouped pair tests) of the reference computations; the long ones on the machine as it is only.
CASES = [("powertrain5", 5, True), ("powertrain5", 6, True), ("powertrain5", 7, True), ("powertrain5", 5, False),
         ("powertrain3", 5, False)]
LONG_CASES = [("powertrain5", 8, True)]


def digest(pairs) -> str:
    """sha256 of ``[[i, j], ...]`` as compact JSON (the digests of ``benchmarks/results/regions.json``)."""
    return hashlib.sha256(json.dumps([[int(i), int(j)] for i, j in pairs], separators=(",", ":")).encode()).hexdigest()


def child(cases) -> dict:
    """The reference computations in this process (the set-up is its environment)."""
    import numpy as np

    from hybobs_opt.regions import analyse_observability
    from hybobs_opt.studies import get_example

    out = {}
    for name, T, grouped in cases:
        a = analyse_observability(get_example(name).build(), T, group_tests=grouped)
        key = f"{name}_T{T}_{'grouped' if grouped else 'pair_by_pair'}"
        out[key] = {"n_regions": len(a.regions), "n_pair_lps": int(a.n_pair_lps), "n_pieces": len(a.pairs),
                    "sha256_pairs": digest((p.i, p.j) for p in a.pairs),
                    "sha256_thin": digest(a.stats["pairs_dropped_thin"]),
                    "sha256_same": digest(a.stats["pairs_dropped_same_state"]),
                    "n_thin": len(a.stats["pairs_dropped_thin"]), "n_same": len(a.stats["pairs_dropped_same_state"])}
    a = analyse_observability(get_example("powertrain3").build(), 5)
    rng = np.random.default_rng(20261206)
    n = a.system.n
    centre, half = a.enumeration.centre[:n], a.enumeration.scale[:n]  # the state box
    X = centre + half * rng.uniform(-1.0, 1.0, size=(200, n))
    labels = [str(v) for v in a.classify_many(X)]
    out["powertrain3_T5_labels"] = {"sha256": hashlib.sha256(",".join(labels).encode()).hexdigest(),
                                    "counts": {k: labels.count(k) for k in sorted(set(labels))}}
    # the lookup observer (Algorithm 4.1) on the backlash scenario, noise-free and with output noise
    # (from a fixed state: the scenario's steady state is a LAPACK solve, input data, not the observer)
    from hybobs_opt import LookupObserver, simulate_pwa
    from hybobs_opt.studies.paper002_powertrain.systems import backlash_torque_profile

    plant = get_example("powertrain3").build()
    U = backlash_torque_profile(np.arange(3000) * plant.Ts)[:, None]
    trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    obs = LookupObserver(analyse_observability(plant, 3))
    noisy = trace.y + 0.01 * np.random.default_rng(7).standard_normal(trace.y.shape)
    for name, Y in (("clean", trace.y), ("noisy", noisy)):
        run = obs.run(trace.u, Y)
        flags = [str(f) for f in run.flags]
        out[f"powertrain3_T3_lookup_{name}"] = {
            "flags_sha256": hashlib.sha256(",".join(flags).encode()).hexdigest(),
            "estimates_sha256": hashlib.sha256(np.ascontiguousarray(run.x_hat, dtype=float).tobytes()).hexdigest(),
            "counts": {k: flags.count(k) for k in sorted(set(flags))}}
    # the MIQP moving-horizon observer (eq. 10) with its uniqueness program, on 400 samples of the same
    # data around the first backlash crossing: its flags (the estimates are solver optima, equal to the
    # solvers' accuracy only, so not compared bit for bit)
    from hybobs_opt import MHEObserver

    for name, Y in (("clean", trace.y), ("noisy", noisy)):
        run = MHEObserver(plant, 3).run(trace.u[800:1200], Y[800:1200])
        flags = [str(f) for f in run.flags]
        out[f"powertrain3_T3_miqp_{name}"] = {"flags_sha256": hashlib.sha256(",".join(flags).encode()).hexdigest(),
                                               "counts": {k: flags.count(k) for k in sorted(set(flags))}}
    return out


def _cpu_features() -> set[str]:
    code = "import numpy._core._multiarray_umath as m; print(' '.join(k for k, v in m.__cpu_features__.items() if v))"
    res = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return set(res.stdout.split())


def setups(tmp: str) -> dict[str, dict[str, str]]:
    """Name -> environment changes of every set-up (the first is the machine as it is)."""
    present = _cpu_features()
    off = [f for f in ("AVX512F", "AVX512CD", "AVX512_SKX", "AVX512_CLX", "AVX512_CNL", "AVX512_ICL", "AVX512_SPR",
                       "AVX512_KNL", "AVX512_KNM", "AVX2", "FMA3") if f in present]
    out = {"as_is": {},
           "openblas_haswell": {"OPENBLAS_CORETYPE": "Haswell"},
           "openblas_prescott_1_thread": {"OPENBLAS_CORETYPE": "Prescott", "OPENBLAS_NUM_THREADS": "1"},
           "openblas_1_thread": {"OPENBLAS_NUM_THREADS": "1"},
           "numba_generic_cpu": {"NUMBA_CPU_NAME": "generic", "NUMBA_CACHE_DIR": os.path.join(tmp, "numba-generic"),
                                 "HYBOBS_KERNELS": "compiled"},
           "python_kernels": {"HYBOBS_KERNELS": "python"}}
    if off:
        out["numpy_without_" + "_".join(f.lower() for f in off if f in ("AVX2", "FMA3")) + "_avx512"] = \
            {"NPY_DISABLE_CPU_FEATURES": " ".join(off)}
    return out


def run_setup(env_changes: dict[str, str], cases) -> dict:
    env = {**os.environ, **env_changes}
    spec = json.dumps([list(c) for c in cases])
    res = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--child", spec], env=env, capture_output=True,
                         text=True, cwd=str(ROOT))
    if res.returncode != 0:
        raise RuntimeError(f"set-up {env_changes} failed:\n{res.stderr[-3000:]}")
    return json.loads(res.stdout.strip().splitlines()[-1])


def differences(a: dict, b: dict) -> list[str]:
    out = []
    for key in sorted(set(a) | set(b)):
        if a.get(key) != b.get(key):
            out.append(f"{key}: {a.get(key)} != {b.get(key)}")
    return out


def main(argv=None) -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--child", help=argparse.SUPPRESS)
    p.add_argument("--record", action="store_true", help="write the first set-up's answers as the reference")
    p.add_argument("--setups", nargs="*", help="only these set-ups (names as printed)")
    args = p.parse_args(argv)
    if args.child:
        print(json.dumps(child([tuple(c) for c in json.loads(args.child)])))
        return 0
    reference = json.loads(REFERENCE.read_text()) if REFERENCE.exists() else None
    failures = []
    with tempfile.TemporaryDirectory(prefix="hybobs-repro-") as tmp:
        plan = setups(tmp)
        if args.setups:
            plan = {k: v for k, v in plan.items() if k in args.setups or k == "as_is"}
        first = None
        for name, env_changes in plan.items():
            cases = CASES + (LONG_CASES if name == "as_is" else [])
            t0 = time.perf_counter()
            got = run_setup(env_changes, cases)
            print(f"{name:45s} {time.perf_counter() - t0:6.1f} s  {env_changes}", flush=True)
            if first is None:
                first = got
                if args.record:
                    REFERENCE.write_text(json.dumps(got, indent=1, sort_keys=True) + "\n")
                    print(f"recorded {REFERENCE.relative_to(ROOT)}")
                elif reference is not None:
                    common = {k: reference[k] for k in got if k in reference}
                    diff = differences(common, {k: got[k] for k in common})
                    failures += [f"as_is vs recorded reference: {d}" for d in diff]
                continue
            diff = differences({k: first[k] for k in got}, got)
            failures += [f"{name} vs as_is: {d}" for d in diff]
    for f in failures:
        print("DIFFERENT", f)
    print("reproducible: " + ("no, " + str(len(failures)) + " differences" if failures else "yes, every set-up gave the same answers"))
    return 1 if failures else 0


if __name__ == "__main__":
    sys.exit(main())

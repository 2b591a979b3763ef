"""Compile or load every numba kernel of the package once (see :mod:`hybobs_opt._numba_cache`).

``python -m hybobs_opt._warm_up`` after an install (or :func:`hybobs_opt.warm_up` in a service's
start-up) fills the user's kernel cache, so no later process compiles anything.
"""

from __future__ import annotations

import os
import time

from ._environment import BACKGROUND_ENV, KERNELS_ENV
from ._numba_cache import NUMBA_CACHE_ENV, cache_directory, kernels_compiled, record_warm_kernels, tier_up

__all__ = ["warm_up"]


def warm_up() -> dict:
    """Compile (empty cache) or load (cache present) every kernel of the package, on a small system.

    Runs Algorithm 3.1 and the lookup observer (``step`` and ``run``, with ``B~_T`` LPs) on a
    dead-zone spring (two states, three modes; Nordin & Gutman, Automatica 38(10), 2002), so the
    kernels get exactly the argument types the package uses.  Call it once after installing (or in
    a service's start-up); the cache is then warm for every later process.

    When this process already runs some kernels as plain Python (``HYBOBS_KERNELS=auto`` found
    their cache empty: see :func:`hybobs_opt._numba_cache.finalize_kernels`), the compilation runs
    in a child process (``python -m hybobs_opt._warm_up``) and fills the cache for the next
    processes; this one keeps its Python kernels.

    Returns
    -------
    dict
        Seconds per phase (``import``, ``system``, ``analysis``, ``lookup_kernels``, ``observer``, ``polytope``),
        ``cache_dir`` and ``kernels_compiled`` (per kernel module).

    See Also
    --------
    hybobs_opt.regions.analyse_observability, hybobs_opt.observers.LookupObserver : what it runs.

    Examples
    --------
    Run once after installing (``make install`` does): later processes load the compiled kernels.

    >>> from hybobs_opt import warm_up
    >>> report = warm_up()
    >>> sorted(report["kernels_compiled"])
    ['hybobs_opt.geometry._lp_kernels', ...]
    >>> "analysis" in report and "observer" in report
    True
    """
    import numpy as np

    tier_up(background=False)  # tiered kernel modules load their compiled kernels (or stay Python: compiled below)
    if not all(kernels_compiled().values()) or os.environ.get(KERNELS_ENV, "auto").strip().lower() == "python":
        import subprocess
        import sys

        t0 = time.perf_counter()
        env = {**os.environ, KERNELS_ENV: "compiled", NUMBA_CACHE_ENV: cache_directory()}
        subprocess.run([sys.executable, "-m", "hybobs_opt._warm_up"], env=env, check=True, stdout=subprocess.DEVNULL)
        return {"cache_dir": cache_directory(), "child_process": time.perf_counter() - t0,
                "kernels_compiled": kernels_compiled()}
    t0 = time.perf_counter()
    before = os.environ.get(KERNELS_ENV)
    os.environ[KERNELS_ENV] = "compiled"  # the kernel modules imported here compile (or load)
    # the lookup kernels compile at import (their signatures are declared): a child process does it
    # on the second core while this one compiles the geometry kernels on first use below
    lookup_child = _start_lookup_child()
    try:
        from .geometry import _lp_kernels, _reproducible, _vertex_kernels  # noqa: F401
        from .geometry.polytope import Polytope
        from .regions import analyse_observability
        from .sim import simulate_pwa
        from .systems.pwa import PWAMode, PWASystem
    finally:  # this process's later children choose for themselves
        _restore(before)

    out: dict = {"cache_dir": cache_directory(), "import": time.perf_counter() - t0}
    t0 = time.perf_counter()
    Ts, k, c, delta = 0.05, 4.0, 0.5, 0.1
    A_free = np.array([[1.0, -Ts], [0.0, 1.0 - c * Ts]])
    A_contact = np.array([[1.0, -Ts], [k * Ts, 1.0 - c * Ts]])
    B, C = np.array([[Ts], [0.0]]), np.array([[0.0, 1.0]])
    modes = (PWAMode(A_contact, B, np.array([0.0, -k * Ts * delta]), C,
                     Polytope(np.array([[-1.0, 0.0, 0.0]]), np.array([-delta])), name="push"),
             PWAMode(A_free, B, np.zeros(2), C, Polytope(np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]),
                                                         np.array([delta, delta])), name="free"),
             PWAMode(A_contact, B, np.array([0.0, k * Ts * delta]), C,
                     Polytope(np.array([[1.0, 0.0, 0.0]]), np.array([-delta])), name="pull"))
    plant = PWASystem(modes, Polytope.from_box([-1.0, -3.0], [1.0, 3.0]), Polytope.from_box([-1.0], [1.0]),
                      ("x1", "x2"), ("u",), ("y",), name="warm_up_deadzone_spring")
    out["system"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    analysis = analyse_observability(plant, 3)
    out["analysis"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    if lookup_child is not None:
        lookup_child.wait()  # its cache entries are written: the import below loads them
    os.environ[KERNELS_ENV] = "compiled"
    try:
        from .observers import _lookup_kernels  # noqa: F401
        from .observers.lookup import LookupObserver
    finally:
        _restore(before)
    out["lookup_kernels"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    U = (0.8 * np.sin(np.arange(300) * 0.05))[:, None]
    Y = simulate_pwa(plant, np.zeros(2), U).y
    obs = LookupObserver(analysis)
    obs.run(U, Y)
    obs.reset()
    for t in range(U.shape[0]):
        obs.step(U[t], Y[t])
    obs.step([np.nan], [0.0])
    out["observer"] = time.perf_counter() - t0
    t0 = time.perf_counter()
    # the vertex kernels (H/V conversions, redundancy, exact volume, checked by numpy)
    box = Polytope.from_box([-1.0, -2.0, -0.5], [1.0, 2.0, 0.5])
    Polytope(np.vstack([box.A, [[1.0, 1.0, 1.0]]]), np.concatenate([box.b, [1.5]])).remove_redundant().volume("exact")
    Polytope.from_vertices(box.vertices())
    out["polytope"] = time.perf_counter() - t0
    out["kernels_compiled"] = kernels_compiled()
    record_warm_kernels()  # the next processes may start their geometry kernels tiered
    return out


def _restore(before: str | None) -> None:
    if before is None:
        os.environ.pop(KERNELS_ENV, None)
    else:
        os.environ[KERNELS_ENV] = before


def _start_lookup_child():
    """``import hybobs_opt.observers._lookup_kernels`` in a child process (None if it cannot start)."""
    import subprocess
    import sys

    if "hybobs_opt.observers._lookup_kernels" in sys.modules:
        return None
    env = {**os.environ, KERNELS_ENV: "compiled", BACKGROUND_ENV: "0", NUMBA_CACHE_ENV: cache_directory()}
    try:
        return subprocess.Popen([sys.executable, "-c", "import hybobs_opt.observers._lookup_kernels"], env=env,
                                stdout=subprocess.DEVNULL)
    except OSError:
        return None  # the import below compiles them in this process


if __name__ == "__main__":
    import json
    import sys

    # ``--lock PATH``: the lock file of the background compilation that started this process
    # (:func:`hybobs_opt._numba_cache.start_background_warm_up`), removed when it is done
    lock = sys.argv[sys.argv.index("--lock") + 1] if "--lock" in sys.argv[1:-1] else None
    os.environ[KERNELS_ENV] = "compiled"
    try:
        print(json.dumps(warm_up(), indent=2))
    finally:
        if lock and os.path.exists(lock):
            os.remove(lock)

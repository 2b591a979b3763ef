"""Python-mode kernels against compiled ones, and the background warm-up (issue 19).

The numba kernels of :mod:`hybobs_opt.geometry._lp_kernels`,
:mod:`hybobs_opt.geometry._vertex_kernels` and :mod:`hybobs_opt.observers._lookup_kernels` run
either compiled (numba's cache holds them, or ``HYBOBS_KERNELS=compiled``) or as plain Python
(cache empty or stale, or ``HYBOBS_KERNELS=python``), in which case one detached background
process compiles them into the cache (:func:`hybobs_opt._numba_cache.finalize_kernels`).  These
tests check that the choice never changes an answer and that the machinery around it holds:

* Python mode (a child process with an empty numba cache and no background compilation) gives
  the same analyses (pieces of ``B_T``, LP counts, group statistics), the same lookup-observer
  trace and the same polytope vertices / exact volume / redundancy removal as the compiled
  kernels of this process (whose cache is warm);
* bad samples (wrong dtype, dimension, length, layout, read-only, NaN, lists) never crash in
  Python mode and get the same flags and reasons as compiled: the observer relies on the
  dispatcher's ``TypeError`` to take its checked path, so the Python wrapper
  (:func:`~hybobs_opt._numba_cache._typed_python`) must refuse exactly what numba refuses;
* the background warm-up starts once per process, honours a fresh lock file and ignores a stale
  one; a bad ``HYBOBS_KERNELS`` value is an error naming the variable;
* (slow) end to end, the background process really fills the cache and records it, after which a
  fresh process starts the geometry kernel modules tiered and loads them all compiled;
* tiered kernels switch from Python to compiled in the middle of an analysis and give the same answers.

Every child gets ``NUMBA_CACHE_DIR`` set to an empty pytest ``tmp_path`` and
``HYBOBS_BACKGROUND_WARM_UP=0`` (except the end-to-end test), so nothing is compiled and the
user's cache is never touched.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
GEOMETRY_KERNEL_MODULES = ("hybobs_opt.geometry._lp_kernels", "hybobs_opt.geometry._reproducible",
                           "hybobs_opt.geometry._vertex_kernels")  # tiered (hybobs_opt._numba_cache)
KERNEL_MODULES = (*GEOMETRY_KERNEL_MODULES, "hybobs_opt.observers._lookup_kernels")

# The same computation runs in the child (Python kernels) and in this process (compiled kernels):
# ``results()`` returns a JSON-able dict.
PROBE = r'''
import json
import numpy as np
from hybobs_opt import LookupObserver, analyse_observability, get_example, simulate_pwa
from hybobs_opt.geometry.polytope import Polytope


def _analysis(name, T):
    an = analyse_observability(get_example(name).build(), T)
    return {"pieces": [[int(p.i), int(p.j)] for p in an.pairs], "n_pair_lps": int(an.n_pair_lps),
            "ruled_out": [list(map(int, q)) for q in an.stats.get("pairs_ruled_out_by_group", ())]}


def _trace():
    an = analyse_observability(get_example("powertrain3").build(), 3)
    tr = simulate_pwa(an.system, np.array([0.06, 39.0, 3.25]), np.full((260, 1), 40.0))
    return an, np.ascontiguousarray(tr.u), np.ascontiguousarray(tr.y)


def _bad_samples():
    an, U, Y = _trace()
    obs = LookupObserver(an)
    ro = U[40].copy()
    ro.flags.writeable = False
    # strided view of the right length; with p = 1 numpy still calls it contiguous (one element)
    strided = np.repeat(Y[41], 2)[::2]
    variants = {
        "good": (U[30], Y[30]),
        "int": (U[31].astype(np.int64), Y[31].astype(np.int64)),
        "u_2d": (U[32][None, :], Y[32]),
        "u_wrong_length": (np.zeros(U.shape[1] + 1), Y[33]),
        "u_nan": (np.full(U.shape[1], np.nan), Y[34]),
        "lists": (U[35].tolist(), Y[35].tolist()),
        "y_strided": (U[41], strided),
        "u_read_only": (ro, Y[40]),
    }
    out = []
    for k in range(30):  # past the warm-up, so the variants meet a running observer
        obs.step(U[k], Y[k])
    for i, (name, (u, y)) in enumerate(variants.items()):
        for kind, (uu, yy) in (("variant", (u, y)), ("next", (U[50 + i], Y[50 + i]))):
            e = obs.step(uu, yy)
            out.append({"name": name, "kind": kind, "flag": e.flag, "reason": e.info.get("reason"),
                        "mode": int(e.mode), "x": np.asarray(e.x, float).tolist()})
    return out


def _polytope():
    rng = np.random.default_rng(7)
    A = rng.normal(size=(8, 3))
    A /= np.linalg.norm(A, axis=1, keepdims=True)
    A = np.vstack([np.eye(3), -np.eye(3), A])  # a box [-1, 1]^3 cut by 8 random half-spaces
    b = np.concatenate([np.ones(6), rng.uniform(0.5, 1.2, size=8)])
    P = Polytope(np.vstack([A, A[:3]]), np.concatenate([b, b[:3] + 0.5]))  # 3 redundant rows
    R = P.remove_redundant()
    V = np.asarray(P.vertices())
    return {"vertices": sorted(map(list, np.round(V, 10).tolist())), "n_vertices": int(V.shape[0]),
            "volume": float(P.volume("exact").value),
            "rows": sorted(map(list, np.round(np.column_stack([R.A, R.b]), 10).tolist()))}


def results():
    an, U, Y = _trace()
    tr = LookupObserver(an).run(U, Y)
    return {"p3_T4": _analysis("powertrain3", 4), "p5_T5": _analysis("powertrain5", 5),
            "run": {"flags": [str(f) for f in tr.flags], "modes": np.asarray(tr.mode).astype(int).tolist(),
                    "x_hat": np.asarray(tr.x_hat, float).tolist()},
            "bad": _bad_samples(), "polytope": _polytope()}
'''

CHILD = PROBE + r'''
import hybobs_opt._numba_cache as nc
import hybobs_opt.observers._lookup_kernels, hybobs_opt.geometry._vertex_kernels, hybobs_opt.geometry._lp_kernels, hybobs_opt.geometry._reproducible
out = results()
out["compiled"] = nc.kernels_compiled()
print(json.dumps(out))
'''


def _env(tmp_path: Path, background: bool = False, **extra: str) -> dict:
    env = {**os.environ, "NUMBA_CACHE_DIR": str(tmp_path)}
    env.pop("HYBOBS_KERNELS", None)
    env.pop("HYBOBS_BACKGROUND_WARM_UP", None)
    if not background:
        env["HYBOBS_BACKGROUND_WARM_UP"] = "0"
    env.update(extra)
    return env


def _child(code: str, env: dict, check: bool = True, timeout: float = 300) -> subprocess.CompletedProcess:
    proc = subprocess.run([sys.executable, "-c", code], env=env, cwd=REPO, capture_output=True, text=True,
                          timeout=timeout)
    if check:
        assert proc.returncode == 0, proc.stderr
    return proc


@pytest.fixture(scope="module")
def python_mode(tmp_path_factory) -> dict:
    """``results()`` in a child whose numba cache is empty (Python kernels, no background compile)."""
    cache = tmp_path_factory.mktemp("numba-empty")
    out = json.loads(_child(CHILD, _env(cache)).stdout.strip().splitlines()[-1])
    assert not any(cache.rglob("*.nbi")), "the Python-mode child compiled something"
    return out


@pytest.fixture(scope="module")
def compiled_mode() -> dict:
    """``results()`` in this process, whose kernels are compiled (warm cache; tiered modules loaded first)."""
    from hybobs_opt import _numba_cache as nc

    nc.tier_up()
    ns: dict = {}
    exec(compile(PROBE, "<kernel-modes-probe>", "exec"), ns)
    out = ns["results"]()

    out["compiled"] = nc.kernels_compiled()
    return out


@pytest.mark.slow
# ------------------------------------------------------------------ 1. same answers
def test_python_mode_child_runs_every_kernel_module_as_python(python_mode, compiled_mode):
    assert set(python_mode["compiled"]) == set(KERNEL_MODULES)
    assert not any(python_mode["compiled"].values())
    # the comparison is only meaningful if this process really runs compiled kernels
    assert compiled_mode["compiled"] and all(compiled_mode["compiled"].values())


def test_forced_python_mode_ignores_the_cache(tmp_path):
    code = ("import json, hybobs_opt._numba_cache as nc\n"
            + "".join(f"import {m}\n" for m in KERNEL_MODULES)
            + "print(json.dumps(nc.kernels_compiled()))")
    # HYBOBS_KERNELS=python with the process's own (warm) cache, not the empty one
    env = {**os.environ, "HYBOBS_KERNELS": "python", "HYBOBS_BACKGROUND_WARM_UP": "0"}
    out = json.loads(_child(code, env).stdout.strip().splitlines()[-1])
    assert out == {m: False for m in KERNEL_MODULES}


def test_an_unwritable_cache_compiles_in_the_foreground(tmp_path):
    """No background compile can fill an unwritable cache, so Python kernels would stay forever:
    the module compiles instead (numba falls back on its own cache locations), as before."""
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")
    code = "import json, hybobs_opt._numba_cache as nc\nimport hybobs_opt.geometry._lp_kernels\nprint(json.dumps(nc.kernels_compiled()))"
    out = json.loads(_child(code, _env(blocker / "cache")).stdout.strip().splitlines()[-1])
    assert out == {"hybobs_opt.geometry._lp_kernels": True}


@pytest.mark.parametrize("key", ["p3_T4", "p5_T5"])
def test_analysis_same_in_python_and_compiled(python_mode, compiled_mode, key):
    py, nb = python_mode[key], compiled_mode[key]
    assert nb["pieces"], "an analysis without pieces would compare nothing"
    assert py["pieces"] == nb["pieces"]
    assert py["n_pair_lps"] == nb["n_pair_lps"]
    assert py["ruled_out"] == nb["ruled_out"]


def test_lookup_observer_run_same_in_python_and_compiled(python_mode, compiled_mode):
    py, nb = python_mode["run"], compiled_mode["run"]
    assert py["flags"] == nb["flags"]
    assert py["modes"] == nb["modes"]
    # Exactly equal, not just close: the Python kernels run the same float64 operations in the
    # same order as the compiled ones (numba compiles without fastmath), and the JSON round trip of
    # a float64 is exact.  Any difference would be a real divergence, so the stronger check holds.
    assert np.array_equal(np.array(py["x_hat"]), np.array(nb["x_hat"]))
    assert len(set(nb["flags"])) > 1  # the trace exercises more than one branch


def test_polytope_kernels_same_in_python_and_compiled(python_mode, compiled_mode):
    py, nb = python_mode["polytope"], compiled_mode["polytope"]
    assert nb["n_vertices"] >= 4
    assert py["n_vertices"] == nb["n_vertices"]
    np.testing.assert_allclose(np.array(py["vertices"]), np.array(nb["vertices"]), rtol=0, atol=1e-9)
    assert py["volume"] == pytest.approx(nb["volume"], rel=1e-12)
    assert len(py["rows"]) == len(nb["rows"]) <= 14  # the three looser copies are gone in both
    np.testing.assert_allclose(np.array(py["rows"]), np.array(nb["rows"]), rtol=0, atol=1e-9)


# ------------------------------------------------------------------ 2. bad samples
def test_bad_samples_same_flags_and_reasons_in_python_mode(python_mode, compiled_mode):
    py, nb = python_mode["bad"], compiled_mode["bad"]
    assert [(r["name"], r["kind"]) for r in py] == [(r["name"], r["kind"]) for r in nb]
    for a, b in zip(py, nb):
        assert (a["flag"], a["reason"], a["mode"]) == (b["flag"], b["reason"], b["mode"]), (a["name"], a["kind"])
        assert np.array_equal(np.array(a["x"]), np.array(b["x"])), (a["name"], a["kind"])
    variant = {r["name"]: r for r in nb if r["kind"] == "variant"}
    for name in ("u_wrong_length", "u_nan"):  # refused samples: a fallback step with its reason
        assert variant[name]["flag"] == "fallback" and variant[name]["reason"], name
    # a (1, 1) ``u`` for m = 1, ints, lists and a read-only ``u`` are valid samples (converted)
    for name in ("int", "u_2d", "lists", "u_read_only", "y_strided"):
        assert variant[name]["flag"] != "fallback", name


# ------------------------------------------------------------------ 3. _typed_python
# numba's dispatcher with an explicit ``int64`` scalar in the signature converts a bool or a float
# argument (``True``, ``1.0``) instead of refusing it; ``_typed_python`` accepts them as well.
_STEP_CASES = {
    "valid": lambda u, y, ro, F, I: (u, y, 1, F, I),
    "u_int64": lambda u, y, ro, F, I: (u.astype(np.int64), y, 1, F, I),
    "u_2d": lambda u, y, ro, F, I: (u[None, :].copy(), y, 1, F, I),
    # numpy calls every array of one element contiguous whatever its stride, so a strided ``u`` has
    # two elements here (m = 1): both refuse it on its layout before looking at its length
    "u_non_contiguous": lambda u, y, ro, F, I: (np.repeat(u, 4)[::2], y, 1, F, I),
    "u_read_only": lambda u, y, ro, F, I: (ro, y, 1, F, I),
    "good_bool": lambda u, y, ro, F, I: (u, y, True, F, I),
    "good_float": lambda u, y, ro, F, I: (u, y, 1.0, F, I),
    "F_int64": lambda u, y, ro, F, I: (u, y, 1, F.astype(np.int64), I),
    "wrong_arity": lambda u, y, ro, F, I: (u, y, 1, F),
}
#: What numba's dispatcher does with each case on this machine (checked by the test as well).
_NUMBA_REFUSES = {"valid": False, "u_int64": True, "u_2d": True, "u_non_contiguous": True, "u_read_only": True,
                  "good_bool": False, "good_float": False, "F_int64": True, "wrong_arity": True}


@pytest.fixture(scope="module")
def packed_tables():
    from hybobs_opt import LookupObserver, analyse_observability, get_example

    obs = LookupObserver(analyse_observability(get_example("powertrain3").build(), 3))
    return obs._F.copy(), obs._I.copy(), obs.m, obs.p


@pytest.mark.parametrize("case", list(_STEP_CASES))
def test_typed_python_refuses_what_numba_refuses(packed_tables, case):
    from hybobs_opt._numba_cache import _typed_python
    from hybobs_opt.observers import _lookup_kernels as K

    assert hasattr(K.step_packed, "py_func"), "this process should run the compiled kernels"
    py_func = K.step_packed.py_func
    w = _typed_python(py_func, py_func._hybobs_kernel[0])
    F0, I0, m, p = packed_tables

    def args():  # fresh copies: the kernel advances the observer state kept in F and I
        u = np.full(m, 40.0)
        ro = u.copy()
        ro.flags.writeable = False
        return _STEP_CASES[case](u, np.zeros(p), ro, F0.copy(), I0.copy())

    def refused(fn) -> bool:
        try:
            fn(*args())
        except TypeError:
            return True
        return False

    numba_refuses = refused(K.step_packed)
    assert numba_refuses == _NUMBA_REFUSES[case]  # numba does what this test assumes
    assert refused(w) == numba_refuses


def test_typed_python_computes_what_numba_computes():
    from hybobs_opt import LookupObserver, analyse_observability, get_example
    from hybobs_opt._numba_cache import _typed_python
    from hybobs_opt.observers import _lookup_kernels as K

    w = _typed_python(K.step_packed.py_func, K.step_packed.py_func._hybobs_kernel[0])
    obs = LookupObserver(analyse_observability(get_example("powertrain3").build(), 3))
    Fa, Ia, Fb, Ib = obs._F.copy(), obs._I.copy(), obs._F.copy(), obs._I.copy()
    for k in range(12):
        u, y = np.array([40.0 + k]), np.array([300.0 - k])
        assert K.step_packed(u, y, 1, Fa, Ia) == w(u, y, 1, Fb, Ib)
    assert np.array_equal(Fa, Fb) and np.array_equal(Ia, Ib)


# ------------------------------------------------------------------ 4. background warm-up
def test_background_warm_up_starts_once_and_respects_its_lock(monkeypatch, tmp_path):
    from hybobs_opt import _numba_cache as nc

    calls = []

    class Recorder:
        pid = os.getpid()  # a process that runs: the lock names it

        def __init__(self, argv, **kwargs):
            calls.append((list(argv), kwargs))

    monkeypatch.setattr(subprocess, "Popen", Recorder)
    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    monkeypatch.setattr(nc, "_background_started", False)
    lock = tmp_path / "hybobs-warm-up.lock"

    assert nc.start_background_warm_up() is True
    assert len(calls) == 1
    argv, kwargs = calls[0]
    assert argv == [sys.executable, "-m", "hybobs_opt._warm_up", "--lock", str(lock)]
    assert kwargs["env"]["HYBOBS_KERNELS"] == "compiled"
    assert not any(k.startswith("HYBOBS_") and k not in ("HYBOBS_KERNELS", "HYBOBS_CACHE_DIR", "HYBOBS_NO_CACHE",
                                                          "HYBOBS_BACKGROUND_WARM_UP") for k in kwargs["env"])
    assert kwargs["env"]["NUMBA_CACHE_DIR"] == str(tmp_path)
    assert lock.exists()

    assert nc.start_background_warm_up() is False  # once per process
    assert len(calls) == 1

    monkeypatch.setattr(nc, "_background_started", False)  # another process, same fresh lock
    assert nc.start_background_warm_up() is False
    assert len(calls) == 1

    old = time.time() - nc.WARM_UP_LOCK_SECONDS - 60  # a stale lock: its compilation died
    os.utime(lock, (old, old))
    monkeypatch.setattr(nc, "_background_started", False)
    assert nc.start_background_warm_up() is True
    assert len(calls) == 2
    assert time.time() - lock.stat().st_mtime < nc.WARM_UP_LOCK_SECONDS  # the lock was renewed

    # a fresh lock whose compiling process died (killed mid-compilation): stale at once
    def running(pid: int) -> bool:
        try:
            os.kill(pid, 0)
        except ProcessLookupError:
            return False
        except OSError:
            return True
        return True

    dead = next(pid for pid in range(4_000_000, 3_000_000, -1) if not running(pid))
    lock.write_text(str(dead))
    monkeypatch.setattr(nc, "_background_started", False)
    assert nc.start_background_warm_up() is True
    assert len(calls) == 3


# ------------------------------------------------------------------ 5. bad HYBOBS_KERNELS
def test_bad_kernels_value_is_an_error_naming_the_variable(tmp_path):
    proc = _child("import hybobs_opt.geometry._lp_kernels", _env(tmp_path, HYBOBS_KERNELS="bogus"), check=False)
    assert proc.returncode != 0
    assert "HYBOBS_KERNELS" in proc.stderr


# ------------------------------------------------------------------ 6. end to end (slow)
@pytest.mark.slow
def test_background_warm_up_fills_the_cache_end_to_end(tmp_path):
    env = _env(tmp_path, background=True)
    lock = tmp_path / "hybobs-warm-up.lock"
    code = ("import json, numpy as np, hybobs_opt._numba_cache as nc, hybobs_opt.geometry._lp_kernels as K\n"
            "import os\nimported = os.path.exists(os.environ['NUMBA_CACHE_DIR'] + '/hybobs-warm-up.lock')\n"
            "K.min_row_slack(np.eye(2), np.ones(2), np.zeros(2))\n"
            "print(json.dumps([imported, nc.kernels_compiled()]))")
    imported, out = json.loads(_child(code, env).stdout.strip().splitlines()[-1])
    assert imported is False, "importing a kernel module started the background compilation"
    assert out == {"hybobs_opt.geometry._lp_kernels": False}
    assert lock.exists() or any(tmp_path.rglob("*.nbi")), "the first kernel call started no background compilation"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and (lock.exists() or not any(tmp_path.rglob("*.nbi"))):
        time.sleep(1.0)
    assert not lock.exists(), "the background compilation did not finish within 240 s"
    assert any(tmp_path.rglob("*.nbi"))
    assert (tmp_path / "hybobs-kernels.json").exists(), "the warm-up recorded no kernel module as cached"
    code = ("import json, sys, hybobs_opt._numba_cache as nc\n" + "".join(f"import {m}\n" for m in GEOMETRY_KERNEL_MODULES)
            + "before = ['numba' in sys.modules, nc.kernels_compiled()]\n"
            + "import hybobs_opt.observers._lookup_kernels\n"
            + "print(json.dumps([before, nc.tier_up()]))")
    before, out = json.loads(_child(code, _env(tmp_path)).stdout.strip().splitlines()[-1])
    # the geometry modules start tiered (Python, numba not imported); the lookup kernels compile at import
    assert before == [False, {m: False for m in GEOMETRY_KERNEL_MODULES}]
    assert out == {m: True for m in KERNEL_MODULES}


# ------------------------------------------------------------------ 7. tiers
TIERED_CHILD = PROBE + r'''
import sys
import hybobs_opt._numba_cache as nc
import hybobs_opt.geometry._vertex_kernels, hybobs_opt.geometry._lp_kernels, hybobs_opt.geometry._reproducible
out = {"compiled_at_start": nc.kernels_compiled()}
out["p3_T4"] = _analysis("powertrain3", 4)
out["work_after_p3_T4"] = nc._TIER.work
out["compiled_after_p3_T4"] = nc.kernels_compiled()
out["polytope"] = _polytope()
print(json.dumps(out))
'''


def test_tiered_kernels_switch_mid_analysis_with_the_same_answers(python_mode):
    """A warm cache (this process's, recorded by the warm-up): the geometry kernels start as Python
    without importing numba and switch to the compiled ones inside the first analysis (the work
    threshold lowered to 3,000 so that the switch falls in the middle of it); the answers equal the
    Python-mode child's, which never switched."""
    from hybobs_opt import _numba_cache as nc

    nc.record_warm_kernels()  # this process's compiled kernels are in its cache: say so for the child
    code = "import hybobs_opt.defaults as d\nd.KERNEL_TIER_UP_WORK = 3000\n" + TIERED_CHILD
    env = {**os.environ, "HYBOBS_BACKGROUND_WARM_UP": "0"}
    env.pop("HYBOBS_KERNELS", None)
    out = json.loads(_child(code, env).stdout.strip().splitlines()[-1])
    assert {m: out["compiled_at_start"][m] for m in GEOMETRY_KERNEL_MODULES} == {m: False for m in GEOMETRY_KERNEL_MODULES}
    assert out["work_after_p3_T4"] >= 3000
    assert out["compiled_after_p3_T4"] == {m: True for m in KERNEL_MODULES}
    for key in ("p3_T4", "polytope"):
        assert out[key] == python_mode[key], key
    # below the threshold (the default), a small analysis never imports numba
    code = ("import json, sys\nfrom hybobs_opt import analyse_observability, get_example\n"
            "import hybobs_opt._numba_cache as nc\n"
            "analyse_observability(get_example('powertrain3').build(), 3)\n"
            "print(json.dumps(['numba' in sys.modules, nc.kernels_compiled()]))")
    numba_imported, compiled = json.loads(_child(code, env).stdout.strip().splitlines()[-1])
    assert numba_imported is False
    assert compiled == {m: False for m in GEOMETRY_KERNEL_MODULES}

"""Where numba caches the package's kernels (hybobs_opt._numba_cache, issue 19).

Each case runs a fresh interpreter (numba reads its configuration once per process): the default
directory is the user's (``$HYBOBS_CACHE_DIR/numba``, else ``$XDG_CACHE_HOME/hybobs_opt/numba``),
a ``NUMBA_CACHE_DIR`` the user set is left alone, and a directory that cannot be created costs
nothing but the cache.  The kernel compiled is the smallest of ``geometry/_lp_kernels.py``
(a second or two cold); no timing is asserted."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

from hybobs_opt._numba_cache import configure, numba_cache_dir

_PROBE = r"""
import json, os, sys
import numpy as np
import hybobs_opt
env_after_import = os.environ.get("NUMBA_CACHE_DIR")
numba_before = "numba" in sys.modules
from hybobs_opt.geometry import _lp_kernels as K
import numba.core.config as config
A = np.array([[1.0, 0.0], [0.0, 1.0]])
value = K.support_upper_bound(A, np.ones(2), np.array([1.0, 1.0]), np.array([1.0, 1.0]), 1.0)
print(json.dumps({"env": env_after_import, "config": config.CACHE_DIR, "numba_at_import": numba_before,
                  "value": float(value)}))
"""


def _run(env_extra: dict, drop=("NUMBA_CACHE_DIR", "HYBOBS_CACHE_DIR", "XDG_CACHE_HOME")) -> dict:
    env = {k: v for k, v in os.environ.items() if k not in drop}
    # these cases are about where compiled kernels go: compile even into an empty cache (with the
    # default "auto" an empty cache runs the kernels as Python; tests/unit/test_kernel_modes.py)
    env["HYBOBS_KERNELS"] = "compiled"
    env.update(env_extra)
    out = subprocess.run([sys.executable, "-c", _PROBE], capture_output=True, text=True, env=env, timeout=600)
    assert out.returncode == 0, out.stderr[-2000:]
    return json.loads(out.stdout.strip().splitlines()[-1])


def _cached_files(directory: Path) -> list[str]:
    return sorted(p.name for p in directory.rglob("*.nbi")) if directory.exists() else []


def test_kernels_are_cached_in_the_hybobs_cache_directory(tmp_path):
    rec = _run({"HYBOBS_CACHE_DIR": str(tmp_path / "hyb")})
    target = tmp_path / "hyb" / "numba"
    assert rec["config"] == str(target)
    assert rec["env"] is None  # the process environment is left alone: numba's config carries the directory
    assert rec["numba_at_import"] is False  # import hybobs_opt imports no numba
    assert rec["value"] == pytest.approx(2.0)
    assert any(name.startswith("_lp_kernels.support_upper_bound") for name in _cached_files(target))


def test_xdg_cache_home_is_honoured(tmp_path):
    rec = _run({"XDG_CACHE_HOME": str(tmp_path / "xdg")})
    target = tmp_path / "xdg" / "hybobs_opt" / "numba"
    assert rec["config"] == str(target)
    assert any(name.startswith("_lp_kernels.support_upper_bound") for name in _cached_files(target))


def test_a_user_numba_cache_dir_is_respected(tmp_path):
    mine = tmp_path / "mine"
    rec = _run({"NUMBA_CACHE_DIR": str(mine), "HYBOBS_CACHE_DIR": str(tmp_path / "hyb")})
    assert rec["env"] == rec["config"] == str(mine)
    assert any(name.startswith("_lp_kernels.support_upper_bound") for name in _cached_files(mine))
    assert not (tmp_path / "hyb" / "numba").exists()


def test_an_unwritable_cache_directory_does_not_crash(tmp_path):
    blocker = tmp_path / "a-file"
    blocker.write_text("not a directory")  # a directory under a file cannot be created, even by root
    rec = _run({"HYBOBS_CACHE_DIR": str(blocker / "cache")})
    assert rec["config"] == str(blocker / "cache" / "numba")
    assert rec["value"] == pytest.approx(2.0)  # numba fell back to its own locations and ran the kernel


def test_configure_keeps_what_is_set(monkeypatch, tmp_path):
    monkeypatch.setenv("NUMBA_CACHE_DIR", "")
    assert configure() == ""  # set, even empty: numba's own choice, left alone
    monkeypatch.delenv("NUMBA_CACHE_DIR")
    monkeypatch.setenv("HYBOBS_CACHE_DIR", str(tmp_path))
    assert numba_cache_dir() == str(tmp_path / "numba")
    monkeypatch.delenv("HYBOBS_CACHE_DIR")
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "x"))
    assert numba_cache_dir() == str(tmp_path / "x" / "hybobs_opt" / "numba")


def test_the_numba_directory_sits_in_the_result_cache_directory(monkeypatch, tmp_path):
    from hybobs_opt.cache import default_cache_dir

    for env in ({"HYBOBS_CACHE_DIR": str(tmp_path / "h")}, {"XDG_CACHE_HOME": str(tmp_path / "x")}, {}):
        for key in ("HYBOBS_CACHE_DIR", "XDG_CACHE_HOME"):
            monkeypatch.delenv(key, raising=False)
        for key, value in env.items():
            monkeypatch.setenv(key, value)
        assert Path(numba_cache_dir()) == default_cache_dir() / "numba"


def test_warm_up_runs_every_phase():
    """Both ways of warming up: in this process when its kernels are compiled (tiered ones loaded first), else (an empty or
    stale cache made this process take Python kernels: a fresh install, an unpacked sdist) in a
    child process, after which the cache holds every kernel for the next processes."""
    import hybobs_opt
    from hybobs_opt import _numba_cache
    from hybobs_opt.geometry import _lp_kernels, _reproducible, _vertex_kernels  # noqa: F401
    from hybobs_opt.observers import _lookup_kernels  # noqa: F401

    kernels = ("hybobs_opt.geometry._lp_kernels", "hybobs_opt.geometry._reproducible", "hybobs_opt.geometry._vertex_kernels",
               "hybobs_opt.observers._lookup_kernels")
    _numba_cache.tier_up()  # as warm_up() does first: tiered modules load their compiled kernels from a warm cache
    in_process = all(_numba_cache.kernels_compiled()[m] for m in kernels) and os.environ.get("HYBOBS_KERNELS") != "python"
    out = hybobs_opt.warm_up()
    if in_process:
        assert set(out) == {"cache_dir", "import", "system", "analysis", "lookup_kernels", "observer", "polytope", "kernels_compiled"}
        assert {m: out["kernels_compiled"][m] for m in kernels} == {m: True for m in kernels}
    else:
        assert set(out) == {"cache_dir", "child_process", "kernels_compiled"}
        # the child compiled every kernel module into the cache (numba's index files)
        cached = _cached_files(Path(os.environ.get("NUMBA_CACHE_DIR") or _numba_cache.numba_cache_dir()))
        for name in ("_lp_kernels.support_upper_bound", "_reproducible._matmul_kernel", "_vertex_kernels.points_to_box",
                     "_lookup_kernels."):
            assert any(f.startswith(name) for f in cached), name
    assert "HYBOBS_KERNELS" not in os.environ or os.environ["HYBOBS_KERNELS"] != "compiled"  # no side effect left
    assert out["cache_dir"] == (os.environ["NUMBA_CACHE_DIR"] if "NUMBA_CACHE_DIR" in os.environ else
                                _numba_cache.numba_cache_dir())

"""Cache directories are data that another user may have planted: the kernel cache (numba's pickled
index files) is read only from a directory this user owns and nobody else can write, and the
result cache reads only entries this toolbox wrote (a MAC under a private key), and clears only its
own files.  Oracles: a marker file a planted pickle would create, the answers recomputed without a
cache, the files left in the directory.
"""

from __future__ import annotations

import json
import os
import pickle
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from hybobs_opt import cached_analysis, get_example, use_cache
from hybobs_opt.cache import ResultCache
from hybobs_opt.regions import analyse_observability, save_analysis

REPO = Path(__file__).resolve().parents[2]


class _Planted:
    def __init__(self, marker: str):
        self.marker = marker

    def __reduce__(self):
        return (os.system, (f"touch {self.marker}",))


def _index_files() -> list[tuple[str, str]]:
    """``(directory relative to the cache root, index file name)`` of every compiled kernel of this process."""
    import importlib

    from numba.core import config
    from numba.core.caching import FunctionCache
    from numba.core.dispatcher import Dispatcher

    from hybobs_opt._numba_cache import tier_up

    tier_up()  # the geometry kernel modules start tiered: their dispatchers exist after this
    out = []
    for module in ("hybobs_opt.geometry._lp_kernels", "hybobs_opt.geometry._reproducible",
                   "hybobs_opt.geometry._vertex_kernels", "hybobs_opt.observers._lookup_kernels"):
        for value in vars(importlib.import_module(module)).values():
            if isinstance(value, Dispatcher):
                fc = FunctionCache(value.py_func)
                out.append((os.path.relpath(fc._cache_path, config.CACHE_DIR), fc._cache_file._index_name))
    return out


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="no user ids")
def test_a_planted_kernel_index_in_a_group_writable_cache_is_never_loaded(tmp_path):
    cache = tmp_path / "numba"
    cache.mkdir()
    marker = tmp_path / "PWNED"
    # at the path of every kernel's index file numba would read, a pickle that runs a command
    planted = 0
    for rel, index_name in _index_files():
        (cache / rel).mkdir(parents=True, exist_ok=True)
        (cache / rel / index_name).write_bytes(pickle.dumps(_Planted(str(marker))))
        planted += 1
    assert planted >= 10
    os.chmod(cache, 0o775)  # writable by the group: another user could have put them there
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "HYBOBS_KERNELS": "auto", "PYTHONPATH": str(REPO)}
    code = ("import warnings, json\nwarnings.simplefilter('always')\n"
            "import hybobs_opt._numba_cache as nc, hybobs_opt.geometry._lp_kernels, hybobs_opt.observers._lookup_kernels\n"
            "from hybobs_opt import analyse_observability, get_example\n"
            "analyse_observability(get_example('powertrain3').build(), 3)\n"
            "print(json.dumps(nc.kernels_compiled()))")
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr
    assert not marker.exists()
    assert "writable by its group" in r.stderr and "not read" in r.stderr
    assert set(json.loads(r.stdout.strip().splitlines()[-1]).values()) == {False}  # Python kernels
    assert not (cache / "hybobs-warm-up.lock").exists()  # no background compilation into it
    # positive control: the planted files are where numba looks -- its own loader runs them
    probe = ("import numba.core.caching as c, hybobs_opt.geometry._lp_kernels as m\n"
             "fn = next(v for v in vars(m).values() if callable(v) and hasattr(v, '_hybobs_kernel'))\n"
             "c.FunctionCache(fn)._cache_file._load_index()")
    env_probe = {**env, "HYBOBS_KERNELS": "python"}
    subprocess.run([sys.executable, "-c", probe], env=env_probe, capture_output=True, text=True, timeout=300)
    assert marker.exists()


@pytest.fixture(scope="module")
def plant():
    return get_example("powertrain3").build()


def test_an_entry_rewritten_with_its_checksum_recomputed_is_not_read(tmp_path, plant):
    """The campaign's attack: the cached analysis replaced by another one, sealed with a valid
    checksum (here: that of another horizon's analysis, an honest file of the wrong content)."""
    cache = ResultCache(tmp_path)
    with use_cache(cache):
        good = cached_analysis(plant, 3)
    (entry,) = tmp_path.glob("analysis-*.json")
    other = tmp_path / "other.json"
    save_analysis(analyse_observability(plant, 4), other)  # sealed, checksum valid, not this entry
    entry.write_bytes(other.read_bytes())
    with use_cache(cache):
        again = cached_analysis(plant, 3)
    assert cache.events[-1]["outcome"] == "refused" and "MAC" in cache.events[-1]["reason"]
    assert again.T == 3 and [(p.i, p.j) for p in again.pairs] == [(p.i, p.j) for p in good.pairs]


@pytest.mark.skipif(not hasattr(os, "getuid"), reason="no user ids")
def test_a_cache_directory_others_can_write_is_not_used(tmp_path, plant):
    shared = tmp_path / "shared"
    shared.mkdir()
    os.chmod(shared, 0o777)
    messages = []
    cache = ResultCache(shared, log=messages.append)
    with use_cache(cache):
        cached_analysis(plant, 3)
    assert list(shared.iterdir()) == [] and any("writable by its group and others" in m for m in messages)


def test_clear_removes_only_the_toolbox_files(tmp_path, plant):
    cache = ResultCache(tmp_path)
    with use_cache(cache):
        cached_analysis(plant, 3)
    mine = {"notes.json", "results.npz", "analysis-final.json", "data.json.tmp"}
    for name in mine:
        (tmp_path / name).write_text("user data")
    files, _ = cache.clear()
    assert files == 2  # the entry and its MAC
    assert {p.name for p in tmp_path.iterdir()} == mine | {".hybobs-cache-key"}
    np.testing.assert_equal(sorted(p.read_text() for p in tmp_path.iterdir() if p.name in mine), ["user data"] * 4)


def _damaged_kernel_cache(tmp_path: Path, pattern: str, what: str) -> Path:
    """A copy of this process's numba cache in ``tmp_path`` with every data file matching
    ``pattern`` cut to 100 bytes (skips the test when the cache holds none)."""
    import shutil

    from hybobs_opt._numba_cache import NUMBA_CACHE_ENV, numba_cache_dir

    source = Path(os.environ.get(NUMBA_CACHE_ENV) or numba_cache_dir())
    if not source.is_dir() or not any(source.glob(pattern)):
        pytest.skip(f"no compiled {what} in the cache to damage (run python -m hybobs_opt._warm_up)")
    cache = tmp_path / "numba"
    shutil.copytree(source, cache)
    damaged = list(cache.glob(pattern))
    for f in damaged:
        f.write_bytes(f.read_bytes()[:100])
    assert damaged
    return cache


def test_a_truncated_kernel_cache_does_not_break_the_import(tmp_path):
    """Every data file of the lookup kernels cut to 100 bytes: the import warns, removes them and
    runs the kernels as Python, and the observer gives the same estimates (the answers do not depend
    on the kernels' mode: tests/unit/test_kernel_modes.py)."""
    cache = _damaged_kernel_cache(tmp_path, "observers_*/_lookup_kernels.*.nbc", "lookup kernels")
    code = ("import json, warnings\nwarnings.simplefilter('always')\n"
            "import numpy as np\nfrom hybobs_opt import LookupObserver, analyse_observability, get_example, simulate_pwa\n"
            "an = analyse_observability(get_example('powertrain3').build(), 3)\n"
            "tr = simulate_pwa(an.system, np.array([0.06, 39.0, 3.25]), np.full((40, 1), 40.0))\n"
            "run = LookupObserver(an).run(tr.u, tr.y)\n"
            "import hybobs_opt._numba_cache as nc\n"
            "print(json.dumps({'flags': [str(f) for f in run.flags], 'compiled': nc.kernels_compiled()}))")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "HYBOBS_BACKGROUND_WARM_UP": "0", "PYTHONPATH": str(REPO)}
    r = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert r.returncode == 0, r.stderr[-2000:]
    out = json.loads(r.stdout.strip().splitlines()[-1])
    assert out["compiled"]["hybobs_opt.observers._lookup_kernels"] is False and "damaged cache files removed" in r.stderr
    import numpy as np

    from hybobs_opt import LookupObserver, simulate_pwa

    an = analyse_observability(get_example("powertrain3").build(), 3)
    tr = simulate_pwa(an.system, np.array([0.06, 39.0, 3.25]), np.full((40, 1), 40.0))
    assert out["flags"] == [str(f) for f in LookupObserver(an).run(tr.u, tr.y).flags]


def test_a_damaged_entry_of_a_lazily_compiled_kernel_is_compiled_again(tmp_path):
    """The geometry kernels load from the cache at their first call, not at import: every data
    file of the LP kernels cut to 100 bytes (the others compile the same way) made Algorithm 3.1 die with an ``UnpicklingError`` from inside numba.
    Now the analysis runs (one warning), gives the pieces of this process, and the next process
    loads the repaired entries without a warning."""
    cache = _damaged_kernel_cache(tmp_path, "geometry_*/_lp_kernels.*.nbc", "LP kernels")
    code = ("import json\nfrom hybobs_opt import analyse_observability, get_example\n"
            "an = analyse_observability(get_example('powertrain3').build(), 4)\n"
            "print(json.dumps([[int(p.i), int(p.j)] for p in an.pairs]))")
    env = {**os.environ, "NUMBA_CACHE_DIR": str(cache), "HYBOBS_BACKGROUND_WARM_UP": "0", "PYTHONPATH": str(REPO),
           "PYTHONWARNINGS": "always"}
    expected = [[int(p.i), int(p.j)] for p in analyse_observability(get_example("powertrain3").build(), 4).pairs]
    first = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert first.returncode == 0, first.stderr[-2000:]
    assert json.loads(first.stdout.strip().splitlines()[-1]) == expected
    assert first.stderr.count("could not be loaded") == 1, first.stderr[-2000:]
    second = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=600)
    assert second.returncode == 0 and "could not be loaded" not in second.stderr, second.stderr[-2000:]
    assert json.loads(second.stdout.strip().splitlines()[-1]) == expected

"""Shared test set-up: ``tests/`` is importable (``import canonical``, ``import exact_oracle``)
from the test modules in its sub-folders."""

import atexit
import os
import shutil
import sys
import tempfile
from pathlib import Path

_TESTS = str(Path(__file__).resolve().parent)
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

# numba's compiled kernels stay in the user's cache across sessions (hybobs_opt._numba_cache; compiling
# them all takes minutes): fixed here, before HYBOBS_CACHE_DIR below would move them to a new directory.
if "NUMBA_CACHE_DIR" not in os.environ:
    from hybobs_opt._numba_cache import numba_cache_dir

    os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()

# The CLI's cache of analyses (hybobs_opt.cache) lives in a directory of this test session, never in
# the user's ~/.cache: the CLI tests run through it (a second run of a system loads what the first
# stored, so the suite checks cached answers too); the cache's own tests use their own directories.
if "HYBOBS_CACHE_DIR" not in os.environ:
    _CACHE = tempfile.mkdtemp(prefix="hybobs-test-cache-")
    os.environ["HYBOBS_CACHE_DIR"] = _CACHE
    atexit.register(shutil.rmtree, _CACHE, True)


def pytest_collection_modifyitems(session, config, items):
    """Run the files that hold long checks (marked ``slow``) first: with ``pytest -n 2`` a
    minute-long test that starts last keeps one worker busy while the other idles.  A file moves
    as a whole, its tests in their order, so that its module-scoped fixtures (a built report, a
    simulated bench) are set up once rather than again for the tests left behind.  Stable, so
    every xdist worker sees the same order."""
    slow_files = {item.nodeid.split("::")[0] for item in items if item.get_closest_marker("slow") is not None}
    items.sort(key=lambda item: item.nodeid.split("::")[0] not in slow_files)

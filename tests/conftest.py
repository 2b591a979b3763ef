"""Shared test set-up: ``tests/`` is importable (``import canonical``, ``import exact_oracle``)
from the test modules in its sub-folders."""

import sys
from pathlib import Path

_TESTS = str(Path(__file__).resolve().parent)
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)


def pytest_collection_modifyitems(session, config, items):
    """Run the long checks (marked ``slow``) first: with ``pytest -n 2`` a minute-long test that
    starts last keeps one worker busy while the other idles.  Stable, so every xdist worker sees
    the same order."""
    items.sort(key=lambda item: item.get_closest_marker("slow") is None)

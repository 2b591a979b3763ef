"""Shared test set-up: ``tests/`` is importable (``import canonical``, ``import exact_oracle``)
from the test modules in its sub-folders."""

import sys
from pathlib import Path

_TESTS = str(Path(__file__).resolve().parent)
if _TESTS not in sys.path:
    sys.path.insert(0, _TESTS)

"""Every benchmark module imports (benchmarks run outside the suite, so an API change could break them unseen)."""

import importlib

import pytest

from benchmarks.run_all import bench_modules


@pytest.mark.parametrize("name", bench_modules())
def test_benchmark_module_imports_and_has_main(name):
    module = importlib.import_module(name)
    assert callable(getattr(module, "main", None))

"""Set-up of the docstrings' Examples when pytest collects this package (``make doctest``).

Only ``pytest --doctest-modules hybobs_opt`` loads this file; ``make test`` collects ``tests/``.
The examples draw with matplotlib's Agg backend and never touch the user's cache of analyses
(``~/.cache/hybobs_opt``): ``HYBOBS_CACHE_DIR`` points to a directory of this session.  The numba
kernels keep their compiled code in the user's cache across sessions, as in ``tests/conftest.py``.
A module that imports an optional extra (``dask``, ``yaml``, ``cdd``, ...) which is not installed
is not collected, so the other modules' examples still run.
"""

from __future__ import annotations

import atexit
import importlib
import importlib.util
import os
import shutil
import tempfile
from pathlib import Path

os.environ.setdefault("MPLBACKEND", "Agg")
if "NUMBA_CACHE_DIR" not in os.environ:
    from hybobs_opt._numba_cache import numba_cache_dir

    os.environ["NUMBA_CACHE_DIR"] = numba_cache_dir()
if "HYBOBS_CACHE_DIR" not in os.environ:
    _CACHE = tempfile.mkdtemp(prefix="hybobs-doctest-cache-")
    os.environ["HYBOBS_CACHE_DIR"] = _CACHE
    atexit.register(shutil.rmtree, _CACHE, True)

_PACKAGE = Path(__file__).resolve().parent

#: doctest name -> the optional package its example runs (skipped, with the reason, without it)
NEEDS_EXTRA = {
    "hybobs_opt.executor.DaskExecutor": "distributed",
}


def _missing_extra(path: Path) -> bool:
    """Whether importing the module at ``path`` fails for want of a package that is not installed."""
    name = ".".join(("hybobs_opt", *path.relative_to(_PACKAGE).with_suffix("").parts))
    if name.endswith(".__init__"):
        name = name[: -len(".__init__")]
    try:
        importlib.import_module(name)
    except ModuleNotFoundError as exc:
        return not (exc.name or "").startswith("hybobs_opt")
    return False


def pytest_ignore_collect(collection_path: Path, config) -> bool | None:
    if (collection_path.suffix == ".py" and collection_path.name not in ("conftest.py", "__main__.py")
            and _missing_extra(collection_path)):
        return True
    return None


def pytest_collection_modifyitems(session, config, items) -> None:
    import pytest

    for item in items:
        module = NEEDS_EXTRA.get(item.name)
        if module is not None and importlib.util.find_spec(module) is None:
            item.add_marker(pytest.mark.skip(reason=f"needs the optional package {module!r}"))

"""Where numba keeps the package's compiled kernels, and warming them up (issue 19).

The kernels (``geometry/_lp_kernels.py``, ``geometry/_vertex_kernels.py``,
``observers/_lookup_kernels.py``) are ``@njit(cache=True)``: compiled once, then loaded from
disk.  numba writes that cache next to the source by default, which a wheel in a read-only
``site-packages`` cannot do; :func:`configure` (run by ``import hybobs_opt``, without importing
numba) points it at the user's cache instead:

    ``$NUMBA_CACHE_DIR`` if the user set it (even empty: then numba's own choice), else
    ``$HYBOBS_CACHE_DIR/numba``, else ``$XDG_CACHE_HOME/hybobs_opt/numba``, else
    ``~/.cache/hybobs_opt/numba`` -- the directory of :class:`hybobs_opt.cache.ResultCache`
    plus ``numba``.

It does so by setting ``NUMBA_CACHE_DIR`` in ``os.environ`` (numba's documented switch; it
reaches the worker processes too) and, when numba is already imported, its ``config.CACHE_DIR``.
A directory that cannot be created or written costs nothing: numba then falls back to its own
locations (next to the source if writable, else its per-user directory) and runs the same code.
numba keys every entry by a hash of the kernel's source file, so an edited checkout never loads a
stale kernel.

Measured in fresh processes (``benchmarks/bench_startup.py``, ``first_calls``): with an empty
cache the kernels compile on first use (tens of seconds on this machine); with the cache present
the first kernel call of a process still pays numba's one-time set-up of its compiler tables
(0.4-0.6 s here) and a few milliseconds per kernel loaded.  :func:`prepare_target` does that
set-up when a kernel module is imported, so the first call costs what the next ones do; a
background thread was measured too and gains nothing (the set-up holds the GIL).
:func:`hybobs_opt.warm_up` (:mod:`hybobs_opt._warm_up`) compiles or loads every kernel once: after an
install, ``python -m hybobs_opt._warm_up``, or in a service's start-up.
"""

from __future__ import annotations

import os
import sys

#: numba's environment variable for its cache directory.
NUMBA_CACHE_ENV = "NUMBA_CACHE_DIR"

__all__ = ["NUMBA_CACHE_ENV", "configure", "numba_cache_dir", "prepare_target"]


def numba_cache_dir() -> str:
    """The package's numba cache: ``numba`` inside :func:`hybobs_opt.cache.default_cache_dir`'s directory."""
    if os.environ.get("HYBOBS_CACHE_DIR"):
        base = os.path.expanduser(os.environ["HYBOBS_CACHE_DIR"])
    else:
        base = os.path.join(os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache"),
                            "hybobs_opt")
    return os.path.join(base, "numba")


def configure() -> str:
    """Point numba's cache at :func:`numba_cache_dir` unless the user chose one; returns the directory in force.

    Cheap (no numba import, nothing created): numba creates the directory on first use, and
    skips it silently when it cannot write there.
    """
    if NUMBA_CACHE_ENV in os.environ:
        return os.environ[NUMBA_CACHE_ENV]
    path = numba_cache_dir()
    os.environ[NUMBA_CACHE_ENV] = path
    config = sys.modules.get("numba.core.config")
    if config is not None and not getattr(config, "CACHE_DIR", ""):
        config.CACHE_DIR = path
    return path


_prepared = False


def prepare_target() -> None:
    """numba's one-time set-up of its CPU target (typing and lowering tables), once per process.

    Loading a cached kernel does it anyway on the first call; the kernel modules call this at
    import so that the first call of an analysis or an observer costs what the second does.
    """
    global _prepared
    if _prepared:
        return
    from numba.core.registry import cpu_target

    cpu_target.typing_context.refresh()
    cpu_target.target_context.refresh()
    _prepared = True

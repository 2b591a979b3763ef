"""The environment variables the toolbox reads: all of them, here, each with what it changes.

==============================  ==================================================================
variable                        effect
==============================  ==================================================================
``HYBOBS_CACHE_DIR``            the cache directory (results and compiled kernels); default
                                ``$XDG_CACHE_HOME/hybobs_opt``, else ``~/.cache/hybobs_opt``
``HYBOBS_NO_CACHE``             ``1`` / ``true`` / ``yes``: the CLI neither reads nor writes the
                                result cache (like ``--no-cache``)
``HYBOBS_KERNELS``              ``auto`` (default: compiled when cached, the geometry kernels
                                after enough work), ``compiled`` or ``python``: how the numba
                                kernels run (:mod:`hybobs_opt._numba_cache`)
``HYBOBS_BACKGROUND_WARM_UP``   ``0``: ``auto`` never starts the background compilation
==============================  ==================================================================

The toolbox never writes one of them into the user's environment; a child process it starts gets
its settings in its own environment or on its command line.  numba's own ``NUMBA_CACHE_DIR`` is
honoured when the user sets it.
"""

from __future__ import annotations

import os
from pathlib import Path

__all__ = ["BACKGROUND_ENV", "CACHE_DIR_ENV", "KERNELS_ENV", "KERNEL_MODES", "NO_CACHE_ENV", "background_warm_up_allowed",
           "cache_root", "kernels_mode", "result_cache_switched_off"]

CACHE_DIR_ENV = "HYBOBS_CACHE_DIR"
NO_CACHE_ENV = "HYBOBS_NO_CACHE"
KERNELS_ENV = "HYBOBS_KERNELS"
BACKGROUND_ENV = "HYBOBS_BACKGROUND_WARM_UP"
#: The values of ``HYBOBS_KERNELS``.
KERNEL_MODES = ("auto", "compiled", "python")


def cache_root() -> Path:
    """``$HYBOBS_CACHE_DIR``, else ``$XDG_CACHE_HOME/hybobs_opt``, else ``~/.cache/hybobs_opt``."""
    if os.environ.get(CACHE_DIR_ENV):
        return Path(os.environ[CACHE_DIR_ENV]).expanduser()
    base = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    return Path(base) / "hybobs_opt"


def result_cache_switched_off() -> bool:
    """``HYBOBS_NO_CACHE`` is ``1``, ``true`` or ``yes`` (any case, surrounding blanks ignored)."""
    return os.environ.get(NO_CACHE_ENV, "").strip().lower() in ("1", "true", "yes")


def kernels_mode() -> str:
    """``HYBOBS_KERNELS`` (default ``auto``).

    Raises
    ------
    ModelError
        A value outside :data:`KERNEL_MODES`.
    """
    mode = os.environ.get(KERNELS_ENV, "auto").strip().lower() or "auto"
    if mode not in KERNEL_MODES:
        from .errors import ModelError

        raise ModelError(KERNELS_ENV, "'auto', 'compiled' or 'python'", repr(os.environ[KERNELS_ENV]))
    return mode


def background_warm_up_allowed() -> bool:
    """``HYBOBS_BACKGROUND_WARM_UP`` is not ``0``."""
    return os.environ.get(BACKGROUND_ENV, "1").strip() != "0"

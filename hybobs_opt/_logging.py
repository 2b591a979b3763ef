"""The package's loggers and the ``verbose=`` switch of its solver-facing entry points.

Every module logs to ``logging.getLogger(__name__)``, children of the ``"hybobs_opt"`` logger,
which carries only a :class:`logging.NullHandler` (the library convention: the application
decides where records go).  What is logged:

* ``INFO``: the phases of the long computations (mode enumeration and pair tests of
  :func:`~hybobs_opt.regions.analyse_observability`, the region designs of
  :func:`~hybobs_opt.lmi.synthesize_switched`, :func:`~hybobs_opt.lmi.diagnose`), an LMI solve
  that Clarabel could not decide alone, an MHE window that is not certified;
* ``DEBUG``: every LMI solve (problem size, solver, status, seconds) and every MHE window
  (backend, status, seconds).

``verbose=True`` (or a logging level such as ``logging.DEBUG``) on those entry points, or the
CLI's ``-v`` / ``-vv``, attaches a handler writing to standard error for the duration of the
call (:func:`verbose_logging`); nothing is ever written to standard output.
"""

from __future__ import annotations

import functools
import inspect
import logging
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from contextvars import ContextVar
from typing import IO, Any, TypeVar

from .errors import ModelError

#: Name of the package's root logger.
LOGGER_NAME = "hybobs_opt"
#: Format of the records :func:`verbose_logging` writes.
LOG_FORMAT = "hybobs %(levelname)s %(name)s: %(message)s"

_ACTIVE: ContextVar[bool] = ContextVar("hybobs_opt_verbose_active", default=False)

F = TypeVar("F", bound=Callable[..., Any])


def verbose_level(verbose: bool | int | None) -> int | None:
    """The logging level ``verbose`` asks for: ``None`` (off) for ``False``/``None``/``0``, ``INFO`` for ``True``, else the level itself.

    Parameters
    ----------
    verbose : bool, int or None
        ``True`` (INFO), ``False``/``None``/``0`` (off), or a positive logging level
        (``logging.DEBUG`` = 10, ``logging.INFO`` = 20, ...).

    Returns
    -------
    int or None
        The level, or ``None`` for off.

    Raises
    ------
    ModelError
        Anything else (a negative number, a string, a float).

    See Also
    --------
    verbose_logging : Uses the level.

    Examples
    --------
    >>> import logging
    >>> from hybobs_opt._logging import verbose_level
    >>> verbose_level(True) == logging.INFO, verbose_level(False), verbose_level(logging.DEBUG)
    (True, None, 10)
    """
    if verbose is None or verbose is False:
        return None
    if verbose is True:
        return logging.INFO
    if isinstance(verbose, int) and not isinstance(verbose, bool) and verbose >= 0:
        return None if verbose == 0 else int(verbose)
    raise ModelError("verbose", "True, False or a logging level (logging.INFO, logging.DEBUG, ...)", repr(verbose))


@contextmanager
def verbose_logging(verbose: bool | int | None, stream: IO[str] | None = None) -> Iterator[None]:
    """Write the package's log records of level ``verbose`` and above to standard error inside the block.

    A no-op when ``verbose`` is off, and inside another active block (no line twice).  The
    ``"hybobs_opt"`` logger's level is lowered for the block when needed and restored after.

    Parameters
    ----------
    verbose : bool, int or None
        See :func:`verbose_level`.
    stream : file-like, optional
        Where the records go (default: ``sys.stderr`` at the time of the call).

    Yields
    ------
    None

    Raises
    ------
    ModelError
        ``verbose`` is not a level (:func:`verbose_level`).

    See Also
    --------
    verbose_level : How ``verbose`` is read.

    Examples
    --------
    >>> import io, logging
    >>> from hybobs_opt._logging import verbose_logging
    >>> buf = io.StringIO()
    >>> with verbose_logging(True, stream=buf):
    ...     logging.getLogger("hybobs_opt.demo").info("solving")
    ...     logging.getLogger("hybobs_opt.demo").debug("details")
    >>> buf.getvalue()
    'hybobs INFO hybobs_opt.demo: solving\\n'
    """
    level = verbose_level(verbose)
    if level is None or _ACTIVE.get():
        yield
        return
    logger = logging.getLogger(LOGGER_NAME)
    handler = logging.StreamHandler(sys.stderr if stream is None else stream)
    handler.setLevel(level)
    handler.setFormatter(logging.Formatter(LOG_FORMAT))
    old_level = logger.level
    if old_level == logging.NOTSET or old_level > level:
        logger.setLevel(level)
    logger.addHandler(handler)
    token = _ACTIVE.set(True)
    try:
        yield
    finally:
        _ACTIVE.reset(token)
        logger.removeHandler(handler)
        logger.setLevel(old_level)


def with_verbose(fn: F) -> F:
    """Run ``fn`` inside :func:`verbose_logging` of its keyword argument ``verbose``.

    ``fn`` declares ``verbose`` itself (keyword-only, with its default), so its signature and
    docstring say so; the body does not need to read it.
    """
    default = inspect.signature(fn).parameters["verbose"].default

    @functools.wraps(fn)
    def wrapper(*args, **kwargs):
        with verbose_logging(kwargs.get("verbose", default)):
            return fn(*args, **kwargs)

    return wrapper  # type: ignore[return-value]

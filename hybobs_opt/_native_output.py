"""What compiled solvers write straight to the process's stdout and stderr, captured.

Some solvers print from C or C++ before any option can silence them: HiGHS 1.16 prints a two-line
banner to file descriptor 1 the first time a ``highspy.Highs`` object is built, and CasADi's plugins
may print when they are loaded or first run.  Such text bypasses :data:`sys.stdout`, so neither
Python's redirection nor the solver's own ``output_flag`` / ``print_level`` options catch it, and it
would corrupt ``hybobs ... --json`` (stdout must be one JSON document) and clutter notebooks.

Every place of the package that builds a solver object does so inside
:func:`captured_native_output`: for its duration file descriptors 1 and 2 point to a scratch file
and :data:`sys.stdout` / :data:`sys.stderr` to a string buffer (CasADi's plugins print through
Python's streams), the C library's stdio buffers are flushed before the descriptors are restored,
and what was captured is passed to the ``hybobs_opt.solvers`` logger at DEBUG level.

File descriptors are per process: while the context is active, text any other thread writes to
fd 1 or 2 is captured too (and logged); the contexts themselves are serialised by a lock and nest.
"""

from __future__ import annotations

import contextlib
import ctypes
import io
import logging
import os
import sys
import tempfile
import threading
from collections.abc import Iterator

_LOG = logging.getLogger("hybobs_opt.solvers")
_LOCK = threading.RLock()
_DEPTH = 0
_SCRATCH = None
_SCRATCH_PID = None  # a forked worker shares the parent's file offset: it opens its own file
_LIBC = None


def _fflush_all() -> None:
    """Flush every C stdio stream (``fflush(NULL)``): text a solver printf'ed but the C library still
    buffers (stdout is fully buffered when it is a pipe) must land in the scratch file, not later."""
    global _LIBC
    try:
        if _LIBC is None:
            _LIBC = ctypes.CDLL(None) if os.name != "nt" else ctypes.cdll.msvcrt
        _LIBC.fflush(None)
    except (OSError, AttributeError):  # no C library to flush through: nothing buffered we can reach
        pass


def _flush_python_streams() -> None:
    for stream in (sys.stdout, sys.stderr):
        try:
            if stream is not None:
                stream.flush()
        except (OSError, ValueError):
            pass


def _valid_fd(fd: int) -> bool:
    try:
        os.fstat(fd)
    except OSError:
        return False
    return True


@contextlib.contextmanager
def captured_native_output(what: str = "solver") -> Iterator[None]:
    """Capture what native code writes to file descriptors 1 and 2 inside the block.

    Parameters
    ----------
    what : str
        What is being built or run (``"highspy.Highs"``, ``"casadi conic 'daqp'"``): it prefixes the
        captured text in the DEBUG log record.

    Yields
    ------
    None
        The block runs with fds 1 and 2 redirected; they are restored (and the captured text logged)
        when it exits, also on an exception.

    Examples
    --------
    >>> import os
    >>> from hybobs_opt._native_output import captured_native_output
    >>> with captured_native_output("demo"):
    ...     _ = os.write(1, b"a banner on fd 1\\n")
    >>> print("only this reaches stdout")
    only this reaches stdout
    """
    global _DEPTH, _SCRATCH, _SCRATCH_PID
    with _LOCK:
        if _DEPTH > 0:  # an outer context already captures
            _DEPTH += 1
            try:
                yield
            finally:
                _DEPTH -= 1
            return
        fds = [fd for fd in (1, 2) if _valid_fd(fd)]
        if _SCRATCH is None or _SCRATCH_PID != os.getpid():
            _SCRATCH, _SCRATCH_PID = tempfile.TemporaryFile(), os.getpid()
        _flush_python_streams()
        _fflush_all()
        saved = {fd: os.dup(fd) for fd in fds}
        for fd in fds:
            os.dup2(_SCRATCH.fileno(), fd)
        streams = sys.stdout, sys.stderr
        sys.stdout = sys.stderr = python_text = io.StringIO()
        _DEPTH = 1
        try:
            yield
        finally:
            _DEPTH = 0
            sys.stdout, sys.stderr = streams
            _fflush_all()
            for fd, copy in saved.items():
                os.dup2(copy, fd)
                os.close(copy)
            text = python_text.getvalue()
            size = os.lseek(_SCRATCH.fileno(), 0, os.SEEK_END)
            if size:
                os.lseek(_SCRATCH.fileno(), 0, os.SEEK_SET)
                text += os.read(_SCRATCH.fileno(), min(size, 65536)).decode("utf-8", "replace")
                os.ftruncate(_SCRATCH.fileno(), 0)
                os.lseek(_SCRATCH.fileno(), 0, os.SEEK_SET)
            if text.strip():
                _LOG.debug("%s wrote to stdout/stderr: %s", what, text.strip())

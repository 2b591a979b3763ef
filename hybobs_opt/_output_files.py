"""Output files opened without following a symbolic link.

Every file the toolbox writes goes through :func:`open_output`: ``O_NOFOLLOW`` makes the open fail
when the last component of the path is a symbolic link, so a link planted at an output path (or
in an output directory) is never written through, whatever the caller checked before.  The CLI
checks its output paths before any work (``--force`` to replace a file); this is the last line.
"""

from __future__ import annotations

import errno
import os
from pathlib import Path
from typing import IO

from .errors import ModelError

__all__ = ["open_output", "write_output_text"]


def open_output(path: str | Path, *, exclusive: bool = False, newline: str | None = None,
                encoding: str = "utf-8") -> IO[str]:
    """``path`` opened for writing text, created (mode 0644 before the umask) or truncated.

    Parameters
    ----------
    path : str or Path
        The file to write.
    exclusive : bool, default False
        Fail when the file exists (``O_EXCL``) instead of truncating it.
    newline, encoding : str, optional
        As for :func:`open`.

    Raises
    ------
    ModelError
        When ``path`` is a symbolic link (named as the field), or ``exclusive`` and it exists.
    """
    flags = os.O_WRONLY | os.O_CREAT | (os.O_EXCL if exclusive else os.O_TRUNC) | getattr(os, "O_NOFOLLOW", 0)
    try:
        fd = os.open(path, flags, 0o644)
    except OSError as exc:
        if exc.errno == errno.ELOOP:
            raise ModelError(str(path), "a path that is not a symbolic link (an output file is never written "
                             "through one)", "a symbolic link") from None
        if exc.errno == errno.EEXIST and exclusive:
            raise ModelError(str(path), "a new file", "an existing file") from None
        raise
    return os.fdopen(fd, "w", newline=newline, encoding=encoding)


def write_output_text(path: str | Path, text: str, **kwargs) -> None:
    """Write ``text`` to ``path`` through :func:`open_output` (same keywords)."""
    with open_output(path, **kwargs) as fh:
        fh.write(text)

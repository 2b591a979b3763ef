"""Which directories the toolbox may read code-bearing or result files from.

The threat model (``docs/security.rst``): the toolbox trusts the user's command line and their own
Python; it does not trust any file it reads, any cache directory or any name inside a model.  A
cache directory is used only when this user owns it and nobody else can write to it: a kernel cache
holds pickled numba indexes (loading one runs code), a result cache holds answers.
"""

from __future__ import annotations

import os
import stat

__all__ = ["untrusted_directory"]


def untrusted_directory(path) -> str | None:
    """Why the directory ``path`` cannot be trusted, or ``None`` (trusted, or not there yet: the
    toolbox creates it with the user's permissions).

    Trusted means: a directory (after symbolic links) owned by this user and writable by neither
    its group nor others.  On systems without user ids (Windows) every directory is trusted.
    """
    if not hasattr(os, "getuid") or path is None or str(path) == "":
        return None
    try:
        st = os.stat(path)
    except (FileNotFoundError, NotADirectoryError):
        return None  # not there (yet): whoever creates it decides
    except OSError as exc:
        return f"cannot be inspected ({exc.strerror or exc})"
    if not stat.S_ISDIR(st.st_mode):
        return "is not a directory"
    if st.st_uid != os.getuid():
        return f"is owned by user id {st.st_uid}, not by this user ({os.getuid()})"
    if st.st_mode & 0o022:
        who = " and ".join(w for w, bit in (("its group", 0o020), ("others", 0o002)) if st.st_mode & bit)
        return f"is writable by {who} (mode {stat.filemode(st.st_mode)})"
    return None

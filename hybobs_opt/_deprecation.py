"""The one way a documented name is retired: a ``FutureWarning`` that names the new spelling and the
release that removes the old one.

Before 1.0 the contract is the documented public API, the CLI with its JSON fields and the
model-file format; a documented name that changes keeps working for one release through
:func:`warn_renamed`, and nothing else serves it (no import aliases, no silent second names).
"""

from __future__ import annotations

import warnings

__all__ = ["REMOVAL_VERSION", "warn_renamed"]

#: The release that removes the names deprecated in this one.
REMOVAL_VERSION = "0.2.0"


def warn_renamed(old: str, new: str, *, stacklevel: int = 3) -> None:
    """Warn that ``old`` is the deprecated spelling of ``new`` (``FutureWarning``: shown to users by default).

    Parameters
    ----------
    old, new : str
        The old and the new name as the user writes them (``"reset(mode=...)"``, ``"--save"``).
    stacklevel : int
        Frames up to the caller's line (3: the caller of the function that calls this one).
    """
    warnings.warn(f"{old} is deprecated and goes in hybobs_opt {REMOVAL_VERSION}: use {new}", FutureWarning,
                  stacklevel=stacklevel)

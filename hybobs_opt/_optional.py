"""Optional packages of the ``interop`` extra (python-control, pandas), imported only when used.

``import hybobs_opt`` imports neither: a bridge method imports its package on its first call,
and a missing package is a :class:`~hybobs_opt.errors.ModelError` naming the package and the
extra that installs it (``pip install 'hybobs_opt[interop]'``).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from .errors import ModelError

#: The extra that installs python-control and pandas.
INTEROP_EXTRA = "interop"


def require(module: str, purpose: str, extra: str = INTEROP_EXTRA) -> ModuleType:
    """The module ``module`` (``"control"``, ``"pandas"``), or a ModelError naming the extra.

    Parameters
    ----------
    module : str
        Import name of the optional package.
    purpose : str
        What it is needed for (completes "installed to ...").
    extra : str, default "interop"
        The optional-dependency group of hybobs_opt that installs it.

    Returns
    -------
    module
        The imported package.

    Raises
    ------
    ModelError
        The package is not installed (``field`` is its name).
    """
    try:
        return importlib.import_module(module)
    except ImportError as exc:
        raise ModelError(module, f"installed to {purpose} (pip install 'hybobs_opt[{extra}]')",
                         f"not installed ({type(exc).__name__}: {exc})") from None

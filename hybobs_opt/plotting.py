"""The one place that chooses matplotlib's backend (DESIGN.md: "plotting, the only place that
calls ``matplotlib.use``").

Every figure function of the package gets ``pyplot`` from :func:`pyplot`.  Figures are written
to files, so without a backend chosen by the user the non-interactive ``Agg`` is selected (no
window opens on a desktop, nothing fails on a headless machine).  A backend the user or a
notebook has already chosen (``MPLBACKEND``, ``matplotlib.use``, ``%matplotlib inline``) is kept,
so figures still display inline in Jupyter.  A leaf module (it imports nothing of the package),
so figure functions of any tier may use it.
"""

from __future__ import annotations

import os
import sys


def pyplot():
    """``matplotlib.pyplot``, with ``Agg`` selected unless a backend was chosen already."""
    import matplotlib

    chosen = "matplotlib.pyplot" in sys.modules or os.environ.get("MPLBACKEND") or "ipykernel" in sys.modules
    if not chosen:
        matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def quantity_label(name: str, unit: str | None = None) -> str:
    """The axis label of a quantity: ``"omega_m [rad/s]"``, or ``name`` alone without a unit.

    Parameters
    ----------
    name : str
        The quantity (a state name, ``"t"``, ``"|error theta|"``).
    unit : str, optional
        Its unit; ``None`` or ``""`` for a dimensionless or unknown unit (no brackets).

    Returns
    -------
    str
    """
    return f"{name} [{unit}]" if unit else name


def save_figure(fig, path, title: str = "", dpi: int = 110):
    """Give ``fig`` its title, lay it out, write it to ``path`` (parents created) and close it; returns ``path``."""
    from pathlib import Path

    path = Path(path)
    if title:
        fig.suptitle(title, fontsize=10)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=dpi)
    pyplot().close(fig)
    return path

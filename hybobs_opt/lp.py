"""The one small LP layer every linear program of the toolbox goes through.

It solves ``min c'z  s.t.  A_ub z <= b_ub, A_eq z == b_eq, lo <= z <= hi`` with HiGHS (through
:func:`scipy.optimize.linprog`), checks the status and turns it into one of three outcomes:
an optimal point, a certified "infeasible"/"unbounded" answer, or a :class:`SolverError` that
names the problem and the solver.  The ``regions`` package adds a fast dense path (DAQP) in front
of this robust one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import linprog

from .errors import SolverError


@dataclass(frozen=True)
class LPResult:
    """Outcome of one LP: ``status`` is ``"optimal"``, ``"infeasible"`` or ``"unbounded"``."""

    status: str
    x: np.ndarray | None
    objective: float | None
    solver: str = "highs"

    @property
    def optimal(self) -> bool:
        return self.status == "optimal"


def solve_lp(
    c: np.ndarray,
    A_ub: np.ndarray | None = None,
    b_ub: np.ndarray | None = None,
    A_eq: np.ndarray | None = None,
    b_eq: np.ndarray | None = None,
    bounds: list[tuple[float | None, float | None]] | tuple | None = None,
    *,
    problem: str = "LP",
) -> LPResult:
    """Solve one LP with HiGHS and check its status.

    Parameters
    ----------
    c, A_ub, b_ub, A_eq, b_eq, bounds
        As in :func:`scipy.optimize.linprog`; ``bounds=None`` means free variables (unlike
        linprog's default of ``z >= 0``).
    problem
        A short name of the problem for error messages (e.g. ``"Chebyshev ball of guard 2"``).

    Returns
    -------
    LPResult
        Optimal point, or a status of ``"infeasible"`` / ``"unbounded"``.

    Raises
    ------
    SolverError
        If HiGHS hits an iteration limit or reports a numerical failure.
    """
    c = np.asarray(c, dtype=float)
    if bounds is None:
        bounds = (None, None)
    res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds, method="highs")
    if res.status == 0:
        return LPResult("optimal", np.asarray(res.x, dtype=float), float(res.fun))
    if res.status == 2:
        return LPResult("infeasible", None, None)
    if res.status == 3:
        return LPResult("unbounded", None, None)
    raise SolverError(
        problem,
        "HiGHS (scipy.optimize.linprog)",
        f"{res.status}: {res.message}",
        hint="rescale the data to the state/input bounds, or check for huge/small coefficients",
    )

"""Solver backends of the moving-horizon problem (10) of paper 002, one module per solver family,
all behind the one signature of :class:`~hybobs_opt.mhe.backends.base.Backend`.

=====================  =========================================================================
module                 backends
=====================  =========================================================================
``daqp_backend``       ``"daqp"``: the ``daqp`` package's branch-and-bound (MIQP, default norm 2)
``highs_backend``      ``"highs"``: HiGHS through ``highspy`` (MILP, default norms 1 / inf)
``casadi_backend``     ``"casadi-daqp"``, ``"bonmin"`` (MIQP); ``"cbc"``, ``"casadi-highs"`` (MILP)
=====================  =========================================================================

:func:`miqp_backend` and :func:`milp_backend` build the one a solver name asks for.
"""

from __future__ import annotations

import sys

import numpy as np

from ...errors import ModelError, SolverError
from ..mld import MLDEncoding
from .base import Backend, BackendOutcome, quiet_stdout
from .casadi_backend import BonminBackend, CasadiDaqpBackend, CasadiMilpBackend
from .daqp_backend import DAQP_INF, DaqpBackend, daqp_flag
from .highs_backend import HIGHS_BASE_OPTIONS, HighspyBackend

__all__ = ["Backend", "BackendOutcome", "BonminBackend", "CasadiDaqpBackend", "CasadiMilpBackend", "DAQP_INF",
           "DaqpBackend", "HIGHS_BASE_OPTIONS", "HighspyBackend", "MIQP_SOLVERS", "MILP_SOLVERS", "daqp_flag",
           "miqp_backend", "milp_backend", "quiet_stdout"]

#: Solvers of the MIQP (norm 2) and of the MILP (norms 1 / inf); the first one is the default.
MIQP_SOLVERS = ("daqp", "casadi-daqp", "bonmin")
#: ``"sequences"`` is no MILP backend: the exact mode-prefix branch and bound of tiny LPs of
#: :mod:`hybobs_opt.mhe.sequence_lp`, which the observer runs itself.
MILP_SOLVERS = ("highs", "cbc", "casadi-highs", "sequences")


def miqp_backend(solver: str, H: np.ndarray, A: np.ndarray, lb: np.ndarray, ub: np.ndarray, discrete: np.ndarray,
                 eq_rows: np.ndarray, enc: MLDEncoding, options: dict) -> Backend:
    """The MIQP ``min 0.5 v'Hv + f'v, lo <= A v <= hi, lb <= v <= ub`` on the named solver.

    Parameters
    ----------
    solver : {"daqp", "casadi-daqp", "bonmin"}
        The solver (:data:`MIQP_SOLVERS`).
    H : (nv, nv) ndarray
        Positive definite Hessian.
    A : (nr, nv) ndarray
        Constraint rows.
    lb, ub : (nv,) ndarray
        Variable bounds.
    discrete : (nv,) bool ndarray
        Binary variables.
    eq_rows : (nr,) bool ndarray
        Equality rows.
    enc : MLDEncoding
        The window's encoding (used by ``"casadi-daqp"``).
    options : dict
        The solver's options.

    Returns
    -------
    Backend
        The program built on the solver, ready to ``solve(f, lo, hi)`` per window.

    Raises
    ------
    ModelError
        If ``solver`` is not one of :data:`MIQP_SOLVERS`.

    See Also
    --------
    milp_backend : The same for the MILPs.
    MIQP_SOLVERS : The solver names.

    Examples
    --------
    >>> import numpy as np

    A two-variable MIQP: ``v = [x, b]`` with ``b`` binary, ``min 0.5 |v|^2 - 1.3 x - 0.4 b``
    subject to ``x - b <= 0.5``; the optimum is ``b = 1, x = 1.3``.

    >>> H = np.eye(2)
    >>> A = np.array([[1.0, -1.0]])
    >>> lb, ub = np.array([-2.0, 0.0]), np.array([2.0, 1.0])
    >>> discrete = np.array([False, True])
    >>> f = np.array([-1.3, -0.4])
    >>> lo, hi = np.array([-1e30]), np.array([0.5])
    >>> from hybobs_opt.mhe.backends import miqp_backend
    >>> backend = miqp_backend("daqp", H, A, lb, ub, discrete, np.array([False]), None, {})
    >>> out = backend.solve(f, lo, hi)
    >>> out.status, np.round(out.v, 6)
    ('optimal', array([1.3, 1. ]))
    >>> miqp_backend("gurobi", H, A, lb, ub, discrete, np.array([False]), None, {})  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    hybobs_opt.errors.ModelError: solver: expected one of ('daqp', 'casadi-daqp', 'bonmin'), got 'gurobi'
    """
    if solver == "daqp":
        return DaqpBackend(H, A, lb, ub, discrete, eq_rows, options)
    if solver == "casadi-daqp":
        return CasadiDaqpBackend(H, A, lb, ub, discrete, enc, eq_rows, options)
    if solver == "bonmin":
        return BonminBackend(H, A, lb, ub, discrete, options)
    raise ModelError("solver", f"one of {MIQP_SOLVERS}", repr(solver))


def milp_backend(solver: str, c: np.ndarray, A: np.ndarray, lb: np.ndarray, ub: np.ndarray, discrete: np.ndarray,
                 options: dict, *, problem: str = "MILP of eq. (10)") -> Backend:
    """The MILP ``min c'v, lo <= A v <= hi, lb <= v <= ub`` on the named solver.

    Parameters
    ----------
    solver : {"highs", "cbc", "casadi-highs"}
        The solver (:data:`MILP_SOLVERS`).
    c : (nv,) ndarray
        Cost vector.
    A : (nr, nv) ndarray
        Constraint rows.
    lb, ub : (nv,) ndarray
        Variable bounds.
    discrete : (nv,) bool ndarray
        Integer variables.
    options : dict
        The solver's options.
    problem : str, default "MILP of eq. (10)"
        Name of the problem in a :class:`SolverError`.

    Returns
    -------
    Backend
        The program built on the solver, ready to ``solve(None, lo, hi)`` per window.

    Raises
    ------
    SolverError
        ``"casadi-highs"`` in a process that has loaded ``highspy`` (see
        :class:`~hybobs_opt.mhe.backends.highs_backend.HighspyBackend`).

    See Also
    --------
    miqp_backend : The same for the MIQP.
    MILP_SOLVERS : The solver names.

    Examples
    --------
    >>> import numpy as np

    A two-variable MILP: ``min -x - b`` over ``x + b <= 1.5``, ``0 <= x <= 1``, ``b`` binary:
    the optimum is ``b = 1, x = 0.5``.

    >>> c = np.array([-1.0, -1.0])
    >>> A = np.array([[1.0, 1.0]])
    >>> lb, ub = np.array([0.0, 0.0]), np.array([1.0, 1.0])
    >>> discrete = np.array([False, True])
    >>> lo, hi = np.array([-1e30]), np.array([1.5])
    >>> from hybobs_opt.mhe.backends import milp_backend
    >>> out = milp_backend("highs", c, A, lb, ub, discrete, {}).solve(None, lo, hi)
    >>> out.status, np.round(out.v, 6)
    ('optimal', array([0.5, 1. ]))
    """
    if solver == "highs":
        return HighspyBackend(c, A, lb, ub, discrete, options)
    if solver == "casadi-highs" and "highspy" in sys.modules:
        raise SolverError(problem, "casadi-highs", "highspy already loaded",
                          hint="solver='highs' (highspy and CasADi's HiGHS plugin share the soname "
                               "libhighs.so.1 with different versions: one process cannot use both)")
    if solver in ("cbc", "casadi-highs"):
        return CasadiMilpBackend(solver.replace("casadi-", ""), c, A, lb, ub, discrete, options)
    raise ModelError("solver", f"one of {MILP_SOLVERS}", repr(solver))

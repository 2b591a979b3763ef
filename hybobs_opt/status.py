"""One status vocabulary for every solver answer, one map per solver adapter, one acceptance policy.

Every solve of the toolbox (HiGHS through :func:`scipy.optimize.linprog` or ``highspy``, DAQP,
cvxpy/Clarabel, CasADi's ``conic``/``nlpsol`` plugins) reports its outcome as a :class:`Status`.
The members are string-valued (:class:`enum.StrEnum`), so ``Status.OPTIMAL == "optimal"`` and
``json.dumps(Status.OPTIMAL)`` gives ``'"optimal"'``: saved results and ``--json`` output keep the
strings they always had.

Each adapter translates its solver's raw answer with :func:`map_status` and one table of this
module (the tables live here, not next to the adapters, so that the test feeding every raw status
of every solver has one place to look and the adapters in ``mhe/`` and ``lmi/`` share them):

=========================  ======================================================================
table                      raw values
=========================  ======================================================================
:data:`CVXPY_STATUS`       every status string of ``cvxpy.settings`` (and the package's own
                           ``"solver_error"`` for a solver that raised)
:data:`LINPROG_STATUS`     the integer ``status`` of :func:`scipy.optimize.linprog` (0-4)
:data:`DAQP_STATUS`        DAQP's exit flags (``daqp.solve`` and CasADi's ``conic("daqp")``
                           ``return_status``), from DAQP's ``include/constants.h``
:data:`HIGHS_MODEL_STATUS` the *names* of ``highspy.HighsModelStatus`` members (use
                           :func:`highs_status` on the member itself)
:data:`CASADI_HIGHS_STATUS` the ``return_status`` strings of CasADi's ``conic("highs")``
                           (HiGHS's ``modelStatusToString``)
:data:`CASADI_CBC_STATUS`  ``(return_status, secondary_return_status)`` pairs of CasADi's
                           ``conic("cbc")``
:data:`CASADI_BONMIN_STATUS` the ``return_status`` strings of CasADi's ``nlpsol("bonmin")``
=========================  ======================================================================

The one policy for inaccurate answers: :func:`is_optimal` is true for :attr:`Status.OPTIMAL` only.
"Optimal but inaccurate", "soft optimal", limits, incumbents and unknown answers are never
accepted as optimal; a caller that wants to use such a point must verify it itself and report
it under its own (weaker) status.  :func:`is_infeasible` is likewise true for
:attr:`Status.INFEASIBLE` only, and a caller still needs a certificate before it raises
:class:`~hybobs_opt.errors.InfeasibleError` (DESIGN.md, "One result protocol").
"""

from __future__ import annotations

import enum
from collections.abc import Hashable, Mapping
from typing import Any

__all__ = [
    "Status",
    "map_status",
    "is_optimal",
    "is_infeasible",
    "highs_status",
    "CVXPY_STATUS",
    "LINPROG_STATUS",
    "DAQP_STATUS",
    "DAQP_EXIT_FLAGS",
    "HIGHS_MODEL_STATUS",
    "CASADI_HIGHS_STATUS",
    "CASADI_CBC_STATUS",
    "CASADI_BONMIN_STATUS",
    "STATUS_TABLES",
]


class Status(enum.StrEnum):
    """Outcome of one solve; the values are the strings the toolbox has always written to JSON.

    See Also
    --------
    is_optimal : the one acceptance policy.
    map_status : a solver's raw answer in this vocabulary.

    Examples
    --------
    >>> from hybobs_opt import Status, is_optimal
    >>> Status.OPTIMAL.value
    'optimal'
    >>> Status("optimal_inaccurate") is Status.OPTIMAL_INACCURATE
    True
    >>> is_optimal(Status.OPTIMAL), is_optimal(Status.OPTIMAL_INACCURATE)
    (True, False)
    """

    OPTIMAL = "optimal"
    OPTIMAL_INACCURATE = "optimal_inaccurate"
    INFEASIBLE = "infeasible"
    INFEASIBLE_INACCURATE = "infeasible_inaccurate"
    UNBOUNDED = "unbounded"
    UNBOUNDED_INACCURATE = "unbounded_inaccurate"
    INFEASIBLE_OR_UNBOUNDED = "infeasible_or_unbounded"
    #: an iteration, time, node, solution-count or user limit stopped the solver
    LIMIT = "limit"
    #: a feasible point that is not proven optimal (e.g. a MILP incumbent)
    FEASIBLE = "feasible"
    #: the moving-horizon window's answer could not be certified
    NOT_CERTIFIED = "not certified"
    #: the incumbent was proven optimal by a cutoff that left no better point
    INCUMBENT_OPTIMAL = "incumbent optimal"
    SOLVER_ERROR = "solver_error"
    UNKNOWN = "unknown"
    #: the solver said optimal but the point failed the package's numpy re-check (an LMI point
    #: whose matrix is not negative semidefinite, say): never accepted
    RECHECK_FAILED = "optimal (numpy re-check failed)"

    def __repr__(self) -> str:
        # Messages format statuses with ``!r`` (``SolverError``, the MHE's "solver status 'x'"):
        # they keep reading ``'optimal'`` as they did when statuses were plain strings.
        return repr(self.value)


def map_status(table: Mapping[Any, Status], raw: Any, *, solver: str) -> Status:
    """Translate a solver's raw answer through one adapter table.

    Parameters
    ----------
    table : mapping
        One of the tables of this module (raw value -> :class:`Status`).
    raw : object
        What the solver returned (an int exit flag, a status string, a tuple of them).
    solver : str
        Name of the solver, for the reader of a traceback (the lookup itself never fails).

    Returns
    -------
    Status
        ``table[raw]``, or :attr:`Status.UNKNOWN` for anything the table does not list
        (including unhashable or ``None`` values): an unlisted answer is never an exception and
        never accepted.

    See Also
    --------
    Status : the vocabulary.
    is_optimal : the acceptance policy applied to the mapped status.

    Examples
    --------
    ``scipy.optimize.linprog``'s integer status through its adapter table; an unknown raw value is
    ``unknown``, never optimal:

    >>> from hybobs_opt import Status, map_status
    >>> from hybobs_opt.status import LINPROG_STATUS
    >>> map_status(LINPROG_STATUS, 0, solver="linprog") is Status.OPTIMAL
    True
    >>> map_status(LINPROG_STATUS, 2, solver="linprog").value
    'infeasible'
    >>> map_status(LINPROG_STATUS, 99, solver="linprog").value
    'unknown'
    """
    del solver  # kept in the signature so every call site names the solver it translates
    if isinstance(raw, Status):
        return raw
    if not isinstance(raw, Hashable):
        return Status.UNKNOWN
    try:
        return table.get(raw, Status.UNKNOWN)
    except TypeError:  # a hashable-looking object whose hash raises
        return Status.UNKNOWN


def is_optimal(status: Any) -> bool:
    """The one acceptance policy: true for :attr:`Status.OPTIMAL` only.

    Inaccurate, soft-optimal, limit, incumbent and unknown answers are never optimal.

    Parameters
    ----------
    status : Status or str
        A status (a plain string compares equal to its :class:`Status`).

    Returns
    -------
    bool
        Whether ``status`` is :attr:`Status.OPTIMAL` (or its string ``"optimal"``).

    See Also
    --------
    is_infeasible : the other status a caller may act on.
    map_status : a solver's raw answer in the one vocabulary.

    Examples
    --------
    >>> from hybobs_opt import Status, is_optimal
    >>> is_optimal(Status.OPTIMAL), is_optimal("optimal")
    (True, True)
    >>> is_optimal(Status.OPTIMAL_INACCURATE), is_optimal(Status.LIMIT)
    (False, False)
    """
    return status == Status.OPTIMAL


def is_infeasible(status: Any) -> bool:
    """True for :attr:`Status.INFEASIBLE` only (the caller must still hold a certificate).

    Parameters
    ----------
    status : Status or str
        A status (a plain string compares equal to its :class:`Status`).

    Returns
    -------
    bool
        Whether ``status`` is :attr:`Status.INFEASIBLE`; ``"infeasible_inaccurate"`` is not.

    See Also
    --------
    is_optimal : the acceptance policy for optimal answers.
    hybobs_opt.InfeasibleError : raised with a certificate that proves the infeasibility.

    Examples
    --------
    >>> from hybobs_opt import Status, is_infeasible
    >>> is_infeasible(Status.INFEASIBLE), is_infeasible(Status.INFEASIBLE_INACCURATE)
    (True, False)
    """
    return status == Status.INFEASIBLE


# ------------------------------------------------------------------------------------ cvxpy
#: cvxpy's status strings (``cvxpy.settings``); ``"solver_error"`` is also what
#: :func:`hybobs_opt.lmi.solve.solve_problem` reports when the solver raised.
CVXPY_STATUS: dict[str, Status] = {
    "optimal": Status.OPTIMAL,
    "optimal_inaccurate": Status.OPTIMAL_INACCURATE,
    "infeasible": Status.INFEASIBLE,
    "infeasible_inaccurate": Status.INFEASIBLE_INACCURATE,
    "unbounded": Status.UNBOUNDED,
    "unbounded_inaccurate": Status.UNBOUNDED_INACCURATE,
    "infeasible_or_unbounded": Status.INFEASIBLE_OR_UNBOUNDED,
    "user_limit": Status.LIMIT,
    "solver_error": Status.SOLVER_ERROR,
}

# ----------------------------------------------------------------------- scipy linprog (HiGHS)
#: :func:`scipy.optimize.linprog`'s documented integer ``status``.
LINPROG_STATUS: dict[int, Status] = {
    0: Status.OPTIMAL,  # optimization terminated successfully
    1: Status.LIMIT,  # iteration or time limit reached
    2: Status.INFEASIBLE,  # problem appears to be infeasible
    3: Status.UNBOUNDED,  # problem appears to be unbounded
    4: Status.SOLVER_ERROR,  # numerical difficulties encountered
}

# ------------------------------------------------------------------------------------- DAQP
#: DAQP's exit flags by name (``include/constants.h`` of DAQP 0.6-0.11; -7 and -8 are newer).
DAQP_EXIT_FLAGS: dict[str, int] = {
    "SOFT_OPTIMAL": 2,
    "OPTIMAL": 1,
    "INFEASIBLE": -1,
    "CYCLE": -2,
    "UNBOUNDED": -3,
    "ITERLIMIT": -4,
    "NONCONVEX": -5,
    "OVERDETERMINED_INITIAL": -6,
    "TIMELIMIT": -7,
    "UNSUPPORTED": -8,
}

#: DAQP exit flag -> status.  "Soft optimal" (2) is optimal only for the problem with its soft
#: constraints relaxed, so it is not optimal for ours; cycling stops before optimality is proven.
DAQP_STATUS: dict[int, Status] = {
    2: Status.OPTIMAL_INACCURATE,
    1: Status.OPTIMAL,
    -1: Status.INFEASIBLE,
    -2: Status.LIMIT,
    -3: Status.UNBOUNDED,
    -4: Status.LIMIT,
    -5: Status.SOLVER_ERROR,
    -6: Status.SOLVER_ERROR,
    -7: Status.LIMIT,
    -8: Status.SOLVER_ERROR,
}

# ----------------------------------------------------------------------------------- HiGHS
#: ``highspy.HighsModelStatus`` member *name* -> status (every member of highspy 1.15).
HIGHS_MODEL_STATUS: dict[str, Status] = {
    "kNotset": Status.UNKNOWN,
    "kLoadError": Status.SOLVER_ERROR,
    "kModelError": Status.SOLVER_ERROR,
    "kPresolveError": Status.SOLVER_ERROR,
    "kSolveError": Status.SOLVER_ERROR,
    "kPostsolveError": Status.SOLVER_ERROR,
    "kModelEmpty": Status.SOLVER_ERROR,  # our models always have variables: an empty one is a bug
    "kOptimal": Status.OPTIMAL,
    "kInfeasible": Status.INFEASIBLE,
    "kUnboundedOrInfeasible": Status.INFEASIBLE_OR_UNBOUNDED,
    "kUnbounded": Status.UNBOUNDED,
    "kObjectiveBound": Status.LIMIT,
    "kObjectiveTarget": Status.LIMIT,
    "kTimeLimit": Status.LIMIT,
    "kIterationLimit": Status.LIMIT,
    "kUnknown": Status.UNKNOWN,
    "kSolutionLimit": Status.LIMIT,
    "kInterrupt": Status.LIMIT,
    "kMemoryLimit": Status.LIMIT,
    "kHighsInterrupt": Status.LIMIT,
}

#: CasADi's ``conic("highs")`` ``return_status`` (``Highs::modelStatusToString``) -> status.
CASADI_HIGHS_STATUS: dict[str, Status] = {
    "Not Set": Status.UNKNOWN,
    "Load error": Status.SOLVER_ERROR,
    "Model error": Status.SOLVER_ERROR,
    "Presolve error": Status.SOLVER_ERROR,
    "Solve error": Status.SOLVER_ERROR,
    "Postsolve error": Status.SOLVER_ERROR,
    "Empty": Status.SOLVER_ERROR,
    "Optimal": Status.OPTIMAL,
    "Infeasible": Status.INFEASIBLE,
    "Primal infeasible or unbounded": Status.INFEASIBLE_OR_UNBOUNDED,
    "Unbounded": Status.UNBOUNDED,
    "Bound on objective reached": Status.LIMIT,
    "Target for objective reached": Status.LIMIT,
    "Time limit reached": Status.LIMIT,
    "Iteration limit reached": Status.LIMIT,
    "Unknown": Status.UNKNOWN,
    "Solution limit reached": Status.LIMIT,
    "Interrupted by user": Status.LIMIT,
    "Memory limit reached": Status.LIMIT,
    "Interrupted by HiGHS": Status.LIMIT,
}


def highs_status(model_status: Any) -> Status:
    """Map a ``highspy.HighsModelStatus`` member (pybind11 enums do not compare equal to ints)."""
    return map_status(HIGHS_MODEL_STATUS, getattr(model_status, "name", None), solver="highspy")


# ------------------------------------------------------------------------------ CasADi CBC
_CBC_STOPPED = "stopped - on maxnodes, maxsols, maxtime"

#: CasADi's ``conic("cbc")`` ``(return_status, secondary_return_status)`` -> status (the strings
#: of CasADi's ``cbc_interface.cpp``).  Secondary status 1 means "infeasible" only when no cutoff
#: was given to CBC (with one it also means "nothing better than the cutoff").  CasADi prints
#: CBC's secondary statuses 7 (unbounded relaxation) and 8 (iteration limit) as ``"unknown"``,
#: which stays :attr:`Status.UNKNOWN`.
CASADI_CBC_STATUS: dict[tuple[str, str], Status] = {
    ("finished", "search completed with solution"): Status.OPTIMAL,
    ("finished", "linear relaxation not feasible (or worse than cutoff)"): Status.INFEASIBLE,
    ("finished", "stopped on gap"): Status.FEASIBLE,
    **{(primary, secondary): Status.LIMIT for primary in ("finished", _CBC_STOPPED, "stopped by event handler")
       for secondary in ("stopped on nodes", "stopped on time", "stopped on user event", "stopped on solutions")},
    (_CBC_STOPPED, "stopped on gap"): Status.FEASIBLE,
    ("difficulties so run was abandoned", "unset"): Status.SOLVER_ERROR,
    ("before branchAndBound", "unset"): Status.SOLVER_ERROR,
}

# --------------------------------------------------------------------------- CasADi Bonmin
#: CasADi's ``nlpsol("bonmin")`` ``return_status`` (``TMINLP::SolverReturn``) -> status.  Bonmin's
#: B-BB is exact for a convex MIQP, so ``SUCCESS`` is an optimum of our (convex) windows.
CASADI_BONMIN_STATUS: dict[str, Status] = {
    "SUCCESS": Status.OPTIMAL,
    "INFEASIBLE": Status.INFEASIBLE,
    "CONTINUOUS_UNBOUNDED": Status.UNBOUNDED,
    "LIMIT_EXCEEDED": Status.LIMIT,
    "USER_INTERRUPT": Status.LIMIT,
    "MINLP_ERROR": Status.SOLVER_ERROR,
    "Unknown": Status.UNKNOWN,
    "Unset": Status.UNKNOWN,
}

#: Every adapter table by solver name (what the status test iterates over).
STATUS_TABLES: dict[str, Mapping[Any, Status]] = {
    "cvxpy": CVXPY_STATUS,
    "linprog": LINPROG_STATUS,
    "daqp": DAQP_STATUS,
    "highspy": HIGHS_MODEL_STATUS,
    "casadi-highs": CASADI_HIGHS_STATUS,
    "cbc": CASADI_CBC_STATUS,
    "bonmin": CASADI_BONMIN_STATUS,
}

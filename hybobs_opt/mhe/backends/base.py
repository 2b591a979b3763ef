"""The one signature every moving-horizon backend implements, and what a solve returns.

A backend holds one mixed-integer program of the MLD encoding of eq. (10), paper 002 (Bemporad,
Ferrari-Trecate & Morari, 2000), set up once; each window only changes the linear term and the
bounds.  Every backend has

``solve(f, lo, hi, centre=None, *, cutoff=None, target=None, start=None, col_bounds=None) -> BackendOutcome``

* ``f`` -- linear term of the objective.  MIQP backends (norm 2): the term in the displacement
  ``d = v - centre`` (``H centre + g``).  MILP backends (norms 1, inf): ``None``, the cost vector
  given at construction.
* ``lo, hi`` -- row bounds (the window data ``U_t, Y_t`` enter only here).
* ``centre`` -- MIQP: the point the displacement is measured from (the warm start); MILP: unused.
* ``cutoff`` -- an upper bound on the objective (an incumbent's value): only points below it are
  searched for, so "infeasible" means none exists.  Honoured only where
  :attr:`Backend.cutoff_applied` is true; elsewhere ignored.
* ``target`` -- stop at the first point below it (HiGHS's ``objective_target``); such a point
  comes back as :attr:`~hybobs_opt.status.Status.FEASIBLE`, to be verified by the caller.
* ``start`` -- a MIP start (HiGHS).
* ``col_bounds`` -- ``(index, lower, upper)``: column bounds for this solve only.

The raw solver status is translated by the solver's table of :mod:`hybobs_opt.status`; only a raw
status that maps to :attr:`~hybobs_opt.status.Status.OPTIMAL` (and a finite point) gives an
optimal outcome.
"""

from __future__ import annotations

import sys
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any, Protocol, runtime_checkable

import numpy as np

from ...status import Status

__all__ = ["Backend", "BackendOutcome", "quiet_stdout"]


@dataclass(frozen=True, eq=False)
class BackendOutcome:
    """Result of one backend solve.

    Parameters
    ----------
    status : Status
        ``OPTIMAL`` (a finite point the solver proved optimal), ``INFEASIBLE`` (proven; with a
        cutoff: nothing below it), ``FEASIBLE`` (a point below ``target``, not proven optimal) or
        ``NOT_CERTIFIED`` (anything else: limit, numerical failure, unknown answer).
    v : array or None
        The solver's point (all columns of the program), ``None`` unless optimal or feasible.
    detail : dict
        The solver's raw answer: ``status`` (raw status), node and iteration counts, objective.
    solver_status : Status
        The raw status through the solver's table of :mod:`hybobs_opt.status` (e.g. ``LIMIT``).
    seconds : float
        Wall time of the solve.

    See Also
    --------
    Backend : Its ``solve`` returns one.

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
    >>> out = miqp_backend("daqp", H, A, lb, ub, discrete, np.array([False]), None, {}).solve(f, lo, hi)
    >>> out.status, out.solver_status, np.round(out.v, 6)
    ('optimal', 'optimal', array([1.3, 1. ]))
    >>> sorted(out.to_dict())  # doctest: +ELLIPSIS
    ['detail', 'seconds', 'solver_status', 'status']
    """

    status: Status
    v: np.ndarray | None
    detail: dict = field(default_factory=dict)
    solver_status: Status = Status.UNKNOWN
    seconds: float = float("nan")

    def __post_init__(self):
        object.__setattr__(self, "status", Status(self.status))

    @property
    def residuals(self) -> dict[str, float]:
        """No point has been checked at this level (the window result carries the residuals)."""
        return {}

    def to_dict(self) -> dict[str, Any]:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"status": self.status, "solver_status": self.solver_status, "seconds": self.seconds,
                "detail": dict(self.detail)}


@runtime_checkable
class Backend(Protocol):
    """One mixed-integer program of eq. (10), built once and re-solved (module docstring).

    Attributes
    ----------
    name : str
        The solver's name as :data:`hybobs_opt.mhe.SOLVERS` spells it.
    cutoff_applied : bool
        Whether ``cutoff`` prunes the search (then an "infeasible" answer under a cutoff proves
        that nothing beats it).
    abs_subopt : float
        Absolute suboptimality the solver allows on its objective (DAQP's ``abs_subopt``).

    See Also
    --------
    miqp_backend : A backend for the MIQP of norm 2.
    milp_backend : A backend for the MILPs of norms 1 and inf.
    BackendOutcome : What ``solve`` returns.

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
    >>> from hybobs_opt.mhe.backends import Backend, miqp_backend
    >>> backend = miqp_backend("daqp", H, A, lb, ub, discrete, np.array([False]), None, {})
    >>> isinstance(backend, Backend), backend.name
    (True, 'daqp')
    >>> out = backend.solve(f, lo, hi)
    >>> out.status, np.round(out.v, 6)
    ('optimal', array([1.3, 1. ]))
    """

    name: str
    cutoff_applied: bool
    abs_subopt: float

    def solve(self, f: np.ndarray | None, lo: np.ndarray, hi: np.ndarray, centre: np.ndarray | None = None, *,
              cutoff: float | None = None, target: float | None = None, start: np.ndarray | None = None,
              col_bounds: tuple | None = None) -> BackendOutcome:
        """Solve the program with linear term ``f`` (MIQP) and row bounds ``lo, hi``.

        Returns
        -------
        BackendOutcome
            The status, the solver's point (when optimal or feasible) and its raw answer.
        """
        ...


class _Null:
    """A write-only sink: CasADi prints its plugins' messages through Python's ``sys.stdout``."""

    def write(self, s: str) -> int:
        return len(s)

    def flush(self) -> None:
        pass


_NULL = _Null()


@contextmanager
def quiet_stdout():
    """Silence CasADi plugins that print through ``sys.stdout``.

    Returns
    -------
    context manager
        ``sys.stdout`` is a sink inside the ``with`` block and restored on exit.

    See Also
    --------
    BonminBackend : Solves under it.

    Examples
    --------
    >>> from hybobs_opt.mhe.backends import quiet_stdout
    >>> with quiet_stdout():
    ...     print("not shown")
    ...
    >>> print("shown")
    shown
    """
    old = sys.stdout
    sys.stdout = _NULL
    try:
        yield
    finally:
        sys.stdout = old


def with_col_bounds(lb: np.ndarray, ub: np.ndarray, col_bounds: tuple | None,
                    inf: float = np.inf) -> tuple[np.ndarray, np.ndarray]:
    """Variable bounds of one solve: ``lb, ub`` with ``col_bounds = (index, lower, upper)`` applied
    (copies; the backend's own bounds stay as they are), clipped to ``[-inf, inf]``."""
    if col_bounds is None:
        return lb, ub
    idx, cl, cu = col_bounds
    lb, ub = lb.copy(), ub.copy()
    lb[idx], ub[idx] = np.maximum(cl, -inf), np.minimum(cu, inf)
    return lb, ub

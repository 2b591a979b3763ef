"""HiGHS through its own Python API (``highspy``): the default MILP solver of eq. (10), norms 1 / inf.

The model is passed once; each window changes the row bounds only (paper 002, Section 4.1:
"Variations of (10) include the use of 1- or inf-norms").  Model statuses go through
:func:`hybobs_opt.status.highs_status`.
"""

from __future__ import annotations

import time

import numpy as np

from ..._native_output import captured_native_output
from ...errors import ModelError
from ...status import Status, highs_status
from ...tolerances import MHE_MILP_FEASIBILITY_TOL
from .base import BackendOutcome

__all__ = ["HighspyBackend", "HIGHS_BASE_OPTIONS"]

#: Options of every MHE MILP solved by HiGHS (highspy or CasADi's plugin): a zero gap (the answer
#: is certified optimal), and no feasibility-jump heuristic, which costs ~14 ms per call on these
#: tiny MILPs.
HIGHS_BASE_OPTIONS = {"output_flag": False, "mip_rel_gap": 0.0, "mip_abs_gap": 0.0,
                      "mip_heuristic_run_feasibility_jump": False,
                      "primal_feasibility_tolerance": MHE_MILP_FEASIBILITY_TOL,
                      "mip_feasibility_tolerance": MHE_MILP_FEASIBILITY_TOL}


class HighspyBackend:
    """HiGHS through ``highspy``, model passed once, row bounds changed per step.

    CasADi's ``conic("highs")`` plugin is not the default: it loads CasADi's ``libhighs.so.1``
    (HiGHS 1.13), the ``highspy`` package (a project dependency, also imported by cvxpy) loads its
    own ``libhighs.so.1`` (1.15) under the same soname, and whichever comes second runs on the
    other's library: heap corruption ("corrupted double-linked list") in the first MILP solve.

    Parameters
    ----------
    c : (nc,) array
        Cost vector.
    A : (nr, nc) array
        Rows ``lo <= A v <= hi``.
    lb, ub : (nc,) arrays
        Column bounds.
    discrete : (nc,) bool array
        Integer columns.
    options : dict
        HiGHS options overriding :data:`HIGHS_BASE_OPTIONS`.

    See Also
    --------
    milp_backend : Returns one for ``"highs"``.
    CasadiMilpBackend : CBC through CasADi.

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
    >>> from hybobs_opt.mhe.backends import HighspyBackend
    >>> out = HighspyBackend(c, A, lb, ub, discrete, {}).solve(None, lo, hi)
    >>> out.status, np.round(out.v, 6)
    ('optimal', array([0.5, 1. ]))
    """

    name = "highs"
    cutoff_applied = True
    abs_subopt = 0.0

    def __init__(self, c, A, lb, ub, discrete, options: dict):
        import highspy

        self._hs = highspy
        with captured_native_output("highspy.Highs"):
            h = highspy.Highs()
        for key, value in {**HIGHS_BASE_OPTIONS, **options}.items():
            if h.setOptionValue(key, value) != highspy.HighsStatus.kOk:
                raise ModelError(f"solver_options[{key!r}]", "a HiGHS option name and a valid value", repr(value))
        inf = highspy.kHighsInf
        lp = highspy.HighsLp()
        nr, nc = A.shape
        lp.num_col_, lp.num_row_ = nc, nr
        lp.col_cost_ = np.asarray(c, dtype=float)
        self._col_lower, self._col_upper = np.maximum(lb, -inf), np.minimum(ub, inf)
        lp.col_lower_ = self._col_lower
        lp.col_upper_ = self._col_upper
        lp.row_lower_ = np.full(nr, -inf)
        lp.row_upper_ = np.full(nr, inf)
        cols = [np.nonzero(A[:, j])[0] for j in range(nc)]
        lp.a_matrix_.format_ = highspy.MatrixFormat.kColwise
        lp.a_matrix_.start_ = np.concatenate([[0], np.cumsum([len(r) for r in cols])]).astype(np.int32)
        lp.a_matrix_.index_ = np.concatenate(cols).astype(np.int32)
        lp.a_matrix_.value_ = np.concatenate([A[r, j] for j, r in enumerate(cols)])
        lp.integrality_ = [highspy.HighsVarType.kInteger if d else highspy.HighsVarType.kContinuous for d in discrete]
        if h.passModel(lp) != highspy.HighsStatus.kOk:
            raise ModelError("MILP of eq. (10)", "a model HiGHS accepts", "passModel failed")
        self._h, self._rows, self._inf = h, np.arange(nr, dtype=np.int32), inf
        self._cols = np.arange(nc, dtype=np.int32)
        self._changed: np.ndarray | None = None  # columns whose bounds the last solve replaced
        self._n_cuts = 0  # rows added by add_cut, after the model's own

    def add_cut(self, index: np.ndarray, coef: np.ndarray, lower: float) -> None:
        """Add the row ``coef @ v[index] >= lower``; it stays until :meth:`drop_cuts` (the row
        bounds that :meth:`solve` sets are those of the model's own rows)."""
        idx = np.asarray(self._cols[index], dtype=np.int32).reshape(-1)
        self._h.addRow(float(lower), self._inf, len(idx), idx, np.asarray(coef, dtype=float).reshape(-1))
        self._n_cuts += 1

    def drop_cuts(self) -> None:
        """Remove every row added by :meth:`add_cut`."""
        k = self._n_cuts
        if k:
            self._h.deleteRows(k, np.arange(self._rows.size, self._rows.size + k, dtype=np.int32))
        self._n_cuts = 0

    def row_duals(self) -> np.ndarray:
        """HiGHS's row duals of the last solve (an LP: no integer columns, or all of them fixed),
        model rows first.

        Returns
        -------
        ndarray
            HiGHS's row duals of the last solve (an LP: no integer columns, or all of them
            fixed), model rows first.
        """
        return np.asarray(self._h.getSolution().row_dual, dtype=float)[: self._rows.size]

    def solve(self, f, lo, hi, centre=None, *, cutoff: float | None = None, target: float | None = None,
              start: np.ndarray | None = None, col_bounds: tuple | None = None) -> BackendOutcome:
        """Solve with row bounds ``lo, hi`` (``f`` and ``centre`` must be ``None``: the cost is fixed).

        ``cutoff`` (HiGHS ``objective_bound``): only points of objective below it are searched
        for, and "infeasible" then means that none exists.  ``target`` (``objective_target``):
        stop at the first incumbent below it; such a point comes back with status
        ``FEASIBLE`` (not claimed optimal), to be verified by the caller.  ``col_bounds`` =
        ``(index, lower, upper)`` replaces some column bounds for this solve.

        Parameters
        ----------
        f : (nv,) ndarray or None
            Must be ``None`` (the cost is fixed at construction).
        lo, hi : (nr,) ndarray
            Row bounds of ``lo <= A v <= hi``.
        centre : (nv,) ndarray, optional
            Must be ``None``.
        cutoff : float, optional
            HiGHS ``objective_bound``.
        target : float, optional
            HiGHS ``objective_target``.
        start : (nv,) ndarray, optional
            MIP start passed to HiGHS.
        col_bounds : (index, lower, upper), optional
            Column bounds for this solve only (the backend's own bounds are kept).

        Returns
        -------
        BackendOutcome
            The status, the solver's point (when optimal or feasible) and its raw answer.

        Raises
        ------
        ModelError
            If ``f`` or ``centre`` is not ``None``.
        """
        if f is not None or centre is not None:
            raise ModelError("f, centre", "None for a MILP backend (its cost is fixed at construction)")
        t0 = time.perf_counter()
        h, hs = self._h, self._hs
        h.changeRowsBounds(self._rows.size, self._rows, np.maximum(lo, -self._inf), np.minimum(hi, self._inf))
        if self._changed is not None:  # the bounds of a previous solve's col_bounds do not persist
            idx = self._changed
            h.changeColsBounds(len(idx), idx, self._col_lower[idx], self._col_upper[idx])
            self._changed = None
        if col_bounds is not None:
            idx, cl, cu = col_bounds
            idx = np.asarray(self._cols[idx], dtype=np.int32).reshape(-1)
            h.changeColsBounds(len(idx), idx, np.broadcast_to(np.asarray(cl, dtype=float), idx.shape).copy(),
                               np.broadcast_to(np.asarray(cu, dtype=float), idx.shape).copy())
            self._changed = idx
        h.setOptionValue("objective_bound", self._inf if cutoff is None else float(cutoff))
        h.setOptionValue("objective_target", -self._inf if target is None else float(target))
        if start is not None:
            sol = hs.HighsSolution()
            sol.col_value = list(start)
            h.setSolution(sol)
        h.run()
        model_status = h.getModelStatus()
        mapped = highs_status(model_status)
        info = h.getInfo()
        detail = {"status": h.modelStatusToString(model_status), "objective": float(info.objective_function_value),
                  "dual_bound": float(info.mip_dual_bound), "nodes": int(info.mip_node_count)}
        sol = h.getSolution()
        x = np.array(sol.col_value, dtype=float) if sol.value_valid else None
        finite = x is not None and x.size == len(self._cols) and bool(np.all(np.isfinite(x)))
        seconds = time.perf_counter() - t0
        if mapped == Status.OPTIMAL:
            if finite:
                return BackendOutcome(Status.OPTIMAL, x, detail, mapped, seconds)
            detail["status"] += " with a NaN/Inf or missing point"
        elif mapped == Status.INFEASIBLE:
            return BackendOutcome(Status.INFEASIBLE, None, detail, mapped, seconds)
        elif target is not None and finite:
            return BackendOutcome(Status.FEASIBLE, x, detail, mapped, seconds)
        return BackendOutcome(Status.NOT_CERTIFIED, None, detail, mapped, seconds)

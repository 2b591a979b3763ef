"""Moving-horizon observer of eq. (10), paper 002 (Bemporad, Ferrari-Trecate & Morari, 2000).

At time ``t`` the observer solves

``min over x(t-T+1)  ||Y_t - Y^_t||``  subject to the PWA dynamics of eq. (1) over the window,

posed on the mixed-logical-dynamical encoding of :mod:`hybobs_opt.mhe.mld`: with the 2-norm
squared it is a mixed-integer quadratic program (MIQP), with the 1- or inf-norm a mixed-integer
linear program (MILP, "Variations of (10) include the use of 1- or inf-norms", Section 4.1).  The
minimiser's window-start state is propagated through the window to give ``x^(t)``.

For noisy data three optional terms follow the moving-horizon estimator of Ferrari-Trecate,
Mignone & Morari (2002), "Moving horizon estimation for hybrid systems", IEEE TAC 47(10):

* an output weight ``W_y``: the cost is ``sum_k ||W_y (y(k) - y^(k))||``;
* state disturbances ``x(k + 1) = f_i(x(k), u(k)) + w(k)`` penalised by ``||W_w w(k)||``;
* an arrival cost ``||W_a (x(t-T+1) - x_bar)||`` where ``x_bar`` is the previous window's estimate
  of the new window-start state (or the ``x0`` of :meth:`MHEObserver.reset` for the first window).

Flags (the runtime contract of :mod:`hybobs_opt.contract`):

* ``observable`` -- the window-start state is *unique*: a certified global optimum of (10) (see
  below) and no other admissible window-start state at least ``delta`` away (inf-norm, in units
  of the half-widths of ``X``, :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_DELTA`) reaches a
  cost within ``epsilon`` of it (:data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_COST_RTOL` times
  one sample's squared weighted output half-range, with the floor
  :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_COST_ATOL`; norms 1 / inf: the square roots),
  proven by a second, separated mixed-integer program (Notes of :class:`MHEObserver`); ``x`` is
  the minimiser propagated to ``t``.  As Section 4.1 of paper 002 explains, a single minimiser
  cannot tell whether ``x(t-T+1)`` is observable: this second program is what does.  With an
  ``analysis`` (:class:`~hybobs_opt.regions.ObservabilityAnalysis`) its point query at the
  estimate decides instead (Definition 2.2: distinguishable for *every* input sequence, a
  stronger statement than the data-based one).  With ``check_uniqueness=False`` and no analysis
  the flag has the old meaning: a certified optimum only, not a unique one.
* ``unobservable`` -- either the solver certified that the window has *no* model trajectory in
  ``X`` (infeasible), or the optimum is not unique: ``info["alternative"]`` holds another
  window-start state (``x_start``, ``cost``, ``modes``, ``distance``) at least ``delta`` away
  whose cost is within ``epsilon`` of the optimum, re-checked in numpy (or the analysis says the
  estimate is unobservable).  The data cannot tell the state: open-loop prediction is used.
* ``fallback`` -- a bad sample, an input outside ``U`` (where the big-M constants are not valid),
  a solve that was not certified (iteration/time limit, numerical failure, failed
  verification, solver exception), or a uniqueness answer that was not certified:
  open-loop prediction, ``info["reason"]`` says why.  Never an exception in the loop.
* ``warming_up`` -- fewer than ``T`` samples so far.

Certified optimum: either the solver's status says optimal and the answer passes a numpy re-check
(finite, integral binaries, one mode per step, every constraint row within tolerance), or a warm
start of zero cost (the cost is nonnegative).  ``info["certified_optimum"]`` says whether the
step had one (the old meaning of ``observable``), ``info["cost"]`` is its cost,
``info["gap_bound"]`` an upper bound on ``cost - optimum`` and ``info["solved_by"]`` says how it
was certified; ``info["uniqueness"]`` reports the uniqueness test (``status``, ``decided_by``,
``separated_cost``, ``separated_cost_bound``, ``threshold = J* + epsilon``, ``seconds``).

Solvers.  Norm 2: ``"daqp"`` (default) is DAQP's branch-and-bound on its persistent workspace
(:class:`daqp.Model`, set up once, re-solved with new linear term and bounds each step);
``"casadi-daqp"`` is the same solver through CasADi's ``conic("daqp", {"discrete": ...})`` plugin
(see the Notes of :class:`MHEObserver` for why it is not the default); ``"bonmin"`` is CasADi's
``nlpsol("bonmin")``.  Norms 1 and inf: ``"highs"`` (default) is HiGHS through ``highspy`` (model
passed once, row bounds changed each step); ``"cbc"`` and ``"casadi-highs"`` go through CasADi's
``conic`` with ``discrete`` variables (CasADi's HiGHS plugin and highspy cannot share a process,
see :class:`_HighspyBackend`).  Every problem is built once, with the window data ``U_t, Y_t``
and the arrival prior entering only the linear term and the constraint bounds.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import solve_triangular

from ..errors import ModelError, SolverError
from ..contract import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP, Estimate, Observer
from ..systems.pwa import PWASystem
from ..tolerances import (
    MEMBERSHIP_RTOL,
    MHE_ABS_SUBOPT,
    MHE_BINARY_PROX_WEIGHT,
    MHE_DAQP_CYCLE_TOL,
    MHE_FEASIBILITY_TOL,
    MHE_INTEGRALITY_TOL,
    MHE_MILP_FEASIBILITY_TOL,
    MHE_POLISH_SKIP_TOL,
    MHE_PROX_WEIGHT,
    MHE_UNIQUENESS_COST_ATOL,
    MHE_UNIQUENESS_COST_RTOL,
    MHE_UNIQUENESS_DELTA,
    MHE_UNIQUENESS_PROX_WEIGHT,
    MHE_ZERO_COST_RTOL,
)
from .mld import BigMConstants, MLDEncoding, encode_mld

NORMS = ("2", "1", "inf")
#: Solvers per norm; the first one is the default.
SOLVERS = {"2": ("daqp", "casadi-daqp", "bonmin"), "1": ("highs", "cbc", "casadi-highs"),
           "inf": ("highs", "cbc", "casadi-highs")}

#: Proximal-point passes per window (norm 2): a pass is repeated, centred at its minimiser, only
#: when the minimiser moved away from the warm start (cold starts, mode switches); on noise-free
#: data a second pass always lands on the zero-cost sequence in the tests, a third is a margin.
DEFAULT_PROX_PASSES = 3

#: Largest number of solves of the separated MIQP per window (norm 2): the first, plus the parts
#: searched again after a point within the proximal bias of the threshold (see
#: :meth:`MHEObserver._uniqueness`); beyond it the step is a fallback.
UNIQUENESS_MAX_SOLVES = 128

#: DAQP's value for an infinite bound.
_DAQP_INF = 1e30
_DAQP_OPTIMAL, _DAQP_INFEASIBLE, _DAQP_CYCLING, _DAQP_ITERLIMIT = 1, -1, -2, -4


class _Null:
    """A write-only sink: CasADi prints its plugins' messages through Python's ``sys.stdout``."""

    def write(self, s: str) -> int:
        return len(s)

    def flush(self) -> None:
        pass


_NULL = _Null()


@dataclass
class _Outcome:
    """Result of one solve: ``status`` is ``"optimal"``, ``"infeasible"`` or ``"not certified"``."""

    status: str
    v: np.ndarray | None
    detail: dict


# ------------------------------------------------------------------------------------ weights
def _weight(W, dim: int, name: str) -> np.ndarray | None:
    """``None`` or a ``(dim, dim)`` weight matrix from a scalar, a vector (diagonal) or a matrix."""
    if W is None:
        return None
    try:
        arr = np.asarray(W, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(name, f"a scalar, a length-{dim} vector or a ({dim}, {dim}) matrix", repr(W)) from None
    if arr.ndim == 0:
        arr = np.full(dim, float(arr))
    if arr.ndim == 1:
        if arr.size != dim:
            raise ModelError(name, f"a length-{dim} vector (diagonal weight)", f"length {arr.size}")
        arr = np.diag(arr)
    if arr.shape != (dim, dim):
        raise ModelError(name, f"a ({dim}, {dim}) matrix", f"shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ModelError(name, "finite entries", "NaN or Inf")
    if not np.any(arr):
        raise ModelError(name, "a non-zero weight (use None to drop the term)", "all zeros")
    return arr


@dataclass(frozen=True, eq=False)
class _Residual:
    """Stacked weighted residual ``r = R v + SY Y + SU U + SX x_bar + r0`` and its blocks."""

    R: np.ndarray
    SY: np.ndarray
    SU: np.ndarray
    SX: np.ndarray
    r0: np.ndarray
    blocks: tuple[tuple[str, slice], ...]

    def offset(self, Y: np.ndarray, U: np.ndarray, xbar: np.ndarray) -> np.ndarray:
        return self.SY @ Y + self.SU @ U + self.SX @ xbar + self.r0


def _residual(enc: MLDEncoding, Wy: np.ndarray, Ww: np.ndarray | None, Wa: np.ndarray | None) -> _Residual:
    sysm, T = enc.system, enc.T
    n, m, p = sysm.n, sysm.m, sysm.p
    hx, cx = enc.x_scale
    nv = enc.n_vars
    Wyb = np.kron(np.eye(T), Wy)
    R = [-Wyb @ enc.Ymap]
    SY = [Wyb]
    SU = [-Wyb @ enc.YU]
    SX = [np.zeros((T * p, n))]
    r0 = [-Wyb @ enc.Yoff]
    blocks = [("output", slice(0, T * p))]
    row = T * p
    if Ww is not None and T > 1:
        Rw = np.zeros(((T - 1) * n, nv))
        Rw[:, enc.slices["omega"]] = np.kron(np.eye(T - 1), Ww @ np.diag(hx))
        R.append(Rw)
        SY.append(np.zeros(((T - 1) * n, T * p)))
        SU.append(np.zeros(((T - 1) * n, T * m)))
        SX.append(np.zeros(((T - 1) * n, n)))
        r0.append(np.zeros((T - 1) * n))
        blocks.append(("disturbance", slice(row, row + (T - 1) * n)))
        row += (T - 1) * n
    if Wa is not None:
        Ra = np.zeros((n, nv))
        Ra[:, enc.slices["xi0"]] = Wa @ np.diag(hx)
        R.append(Ra)
        SY.append(np.zeros((n, T * p)))
        SU.append(np.zeros((n, T * m)))
        SX.append(-Wa)
        r0.append(Wa @ cx)
        blocks.append(("arrival", slice(row, row + n)))
    return _Residual(np.vstack(R), np.vstack(SY), np.vstack(SU), np.vstack(SX), np.concatenate(r0), tuple(blocks))


# ------------------------------------------------------------------------------------ backends
class _DaqpBackend:
    """DAQP's branch-and-bound on a persistent workspace (H factorised once at setup)."""

    name = "daqp"

    def __init__(self, H, A, lb, ub, discrete, eq_rows, options: dict):
        import daqp

        self._nv = H.shape[0]
        sense = np.zeros(self._nv + A.shape[0], dtype=np.int32)
        sense[: self._nv][discrete] = 16  # DAQP's BINARY flag
        sense[self._nv:][eq_rows] = 5  # DAQP's equality flag (one mode per step)
        self._sense = sense
        self._lb, self._ub = np.maximum(lb, -_DAQP_INF), np.minimum(ub, _DAQP_INF)
        self._model = daqp.Model()
        self._A = np.ascontiguousarray(A)
        self._H = np.ascontiguousarray(H)
        L = np.linalg.cholesky(self._H)
        self._Linv = solve_triangular(L, np.eye(L.shape[0]), lower=True)
        self._ready = False
        # eps_prox = 0: the Hessian is positive definite by construction (the proximal term), and
        # DAQP's automatic proximal iterations do not certify branch-and-bound nodes.  cycle_tol:
        # DAQP's default (10 iterations without progress) stops the branch-and-bound with exit -2
        # on degenerate big-M vertices (see MHE_DAQP_CYCLE_TOL)
        self._settings = {"abs_subopt": MHE_ABS_SUBOPT, "eps_prox": 0.0, "cycle_tol": MHE_DAQP_CYCLE_TOL, **options}

    def probe(self) -> bool:
        """Set the workspace up now (zero linear term, the variable bounds); ``False`` if DAQP
        refuses the Hessian (exit -5: its factorisation does not find it positive definite)."""
        import daqp

        nr = self._A.shape[0]
        self._model.settings = self._settings
        flag = self._model.setup(self._H, np.zeros(self._nv), self._A,
                                 np.concatenate([self._ub, np.full(nr, _DAQP_INF)]),
                                 np.concatenate([self._lb, np.full(nr, -_DAQP_INF)]), self._sense)
        flag = flag[0] if isinstance(flag, tuple) else flag
        if flag < 0:
            self._model = daqp.Model()
            return False
        self._model.settings = self._settings
        self._ready = True
        return True

    def solve(self, f, lo, hi, centre, cutoff: float | None = None, ub: np.ndarray | None = None) -> _Outcome:
        """Solve in the displacement ``d = v - centre`` from the warm start.

        ``f`` is the linear term of the objective in ``d`` (``H centre + g``) and ``cutoff`` an
        upper bound of ``0.5 d'Hd + f'd`` (an incumbent's value).  Working relative to the warm
        start keeps the objective values near zero: in absolute form they sit on a constant of
        the order of the output energy, and cost differences of 1e-10 between mode sequences
        drown in the rounding of the active-set updates.  ``ub`` replaces the variable upper
        bounds of this solve (e.g. to fix binaries to zero).
        """
        ubv = self._ub if ub is None else np.minimum(ub, _DAQP_INF)
        bu = np.concatenate([ubv - centre, np.minimum(hi - self._A @ centre, _DAQP_INF)])
        bl = np.concatenate([self._lb - centre, np.maximum(lo - self._A @ centre, -_DAQP_INF)])
        warm = self._ready
        if not self._ready:
            # the settings go in before the setup too: the factorisation of H at setup uses
            # zero_tol (pivots below it count as singular) and, without eps_prox = 0, DAQP would
            # silently switch a nearly singular H to proximal iterations
            self._model.settings = self._settings
            flag = self._model.setup(self._H, f, self._A, bu, bl, self._sense)
            flag = flag[0] if isinstance(flag, tuple) else flag
            if flag < 0:
                return _Outcome("not certified", None, {"status": f"daqp setup failed ({flag})"})
            self._model.settings = self._settings
            self._ready = True
        else:
            # the sense flags are not passed: DAQP then reuses the previous solve's working set
            self._model.update(f=f, bupper=bu, blower=bl)
        # an incumbent prunes every node that cannot beat it: DAQP bounds the objective of its
        # least-distance form 0.5 ||u||^2, which is the QP objective plus 0.5 f' H^-1 f
        bound = _DAQP_INF
        if cutoff is not None:
            w = self._Linv @ f
            bound = float(cutoff + 0.5 * w @ w)
        self._model.settings = {"fval_bound": bound}
        x, fval, flag, info = self._model.solve()
        detail = {"status": int(flag), "nodes": int(info.get("nodes", -1)), "iterations": int(info.get("iterations", -1))}
        if flag in (_DAQP_CYCLING, _DAQP_ITERLIMIT) and warm:
            # the state kept from the previous solves can lead the active-set iterations into a
            # cycle (seen on the ill-conditioned uniqueness MIQP, 1 window in 40 of 4-mode
            # systems; an update with the sense flags does not clear it): once more on a
            # workspace set up afresh, the only case where the workspace is rebuilt
            self._model = type(self._model)()
            self._model.settings = self._settings
            setup = self._model.setup(self._H, f, self._A, bu, bl, self._sense)
            if (setup[0] if isinstance(setup, tuple) else setup) < 0:
                self._ready = False
                return _Outcome("not certified", None, {**detail, "status": f"daqp setup failed ({setup})"})
            self._model.settings = {**self._settings, "fval_bound": bound}
            x, fval, flag, info = self._model.solve()
            detail = {"status": int(flag), "nodes": int(info.get("nodes", -1)),
                      "iterations": int(info.get("iterations", -1)), "cold_retry": True}
        if flag == _DAQP_OPTIMAL:
            x = np.array(x, dtype=float)
            lam = np.asarray(info.get("lam", ()), dtype=float)
            if not (np.all(np.isfinite(x)) and np.isfinite(fval) and np.all(np.isfinite(lam))):
                detail["status"] = f"{int(flag)} with a NaN/Inf point, objective or multiplier"
                return _Outcome("not certified", None, detail)
            return _Outcome("optimal", centre + x, detail)
        if flag == _DAQP_INFEASIBLE:
            return _Outcome("infeasible", None, detail)
        return _Outcome("not certified", None, detail)


class _CasadiDaqpBackend:
    """DAQP through CasADi's ``conic`` plugin with ``discrete`` variables.

    CasADi 3.8.2 bundles an older DAQP whose branch-and-bound returns NaN (with "success") when
    equality rows are present, so the one-hot rows ``sum_i delta[k, i] = 1`` are eliminated
    (``delta[k, s-1] = 1 - sum_{i < s-1} delta[k, i]``, with ``sum_{i < s-1} delta[k, i] <= 1``).
    """

    name = "casadi-daqp"

    def __init__(self, H, A, lb, ub, discrete, enc: MLDEncoding, eq_rows: np.ndarray, options: dict):
        import casadi as ca

        nv, T, s = H.shape[0], enc.T, enc.system.n_modes
        dl = enc.slices["delta"]
        last = [dl.start + k * s + s - 1 for k in range(T)]
        keep = np.setdiff1d(np.arange(nv), last)
        P = np.zeros((nv, keep.size))
        P[keep, np.arange(keep.size)] = 1.0
        p0 = np.zeros(nv)
        col = {j: c for c, j in enumerate(keep)}
        rows = []
        for k in range(T):
            p0[last[k]] = 1.0
            r = np.zeros(keep.size)
            for i in range(s - 1):
                P[last[k], col[dl.start + k * s + i]] = -1.0
                r[col[dl.start + k * s + i]] = 1.0
            if s > 1:
                rows.append(r)
        self._P, self._p0, self._H = P, p0, H
        self._Hw = P.T @ H @ P
        ineq = ~eq_rows
        self._ineq = ineq
        Aw = A[ineq] @ P
        self._a0 = A[ineq] @ p0
        self._extra = len(rows)
        if rows:
            Aw = np.vstack([Aw, np.array(rows)])
        self._Aw = ca.DM(Aw)
        self._Hdm = ca.DM(self._Hw)
        self._lbw, self._ubw = lb[keep], ub[keep]
        opts = {"discrete": [bool(d) for d in discrete[keep]], "error_on_fail": False, "daqp": dict(options)}
        self._solver = ca.conic("mhe_daqp", "daqp", {"h": self._Hdm.sparsity(), "a": self._Aw.sparsity()}, opts)

    def solve(self, f, lo, hi, centre, cutoff: float | None = None) -> _Outcome:
        g = f - self._H @ centre  # back from the displacement form of _DaqpBackend.solve
        gw = self._P.T @ (g + self._H @ self._p0)
        lo_w = np.concatenate([lo[self._ineq] - self._a0, np.full(self._extra, -np.inf)])
        hi_w = np.concatenate([hi[self._ineq] - self._a0, np.ones(self._extra)])
        old = sys.stdout
        sys.stdout = _NULL
        try:
            r = self._solver(h=self._Hdm, g=gw, a=self._Aw, lba=lo_w, uba=hi_w, lbx=self._lbw, ubx=self._ubw)
        finally:
            sys.stdout = old
        st = self._solver.stats()
        detail = {"status": int(st.get("return_status", 0)), "nodes": int(st.get("bnb_nodecount", -1))}
        w = np.array(r["x"], dtype=float).reshape(-1)
        if st.get("return_status") == _DAQP_OPTIMAL and np.all(np.isfinite(w)):
            return _Outcome("optimal", self._P @ w + self._p0, detail)
        if st.get("return_status") == _DAQP_INFEASIBLE:
            return _Outcome("infeasible", None, detail)
        return _Outcome("not certified", None, detail)


class _BonminBackend:
    """Bonmin (CasADi ``nlpsol``) on the same MIQP; the linear term is the NLP parameter."""

    name = "bonmin"

    def __init__(self, H, A, lb, ub, discrete, options: dict):
        import casadi as ca

        nv = H.shape[0]
        x = ca.SX.sym("v", nv)
        gp = ca.SX.sym("g", nv)
        f = 0.5 * ca.mtimes([x.T, ca.DM(H), x]) + ca.dot(gp, x)
        con = ca.mtimes(ca.DM(A), x)
        quiet = {"print_level": 0, "bb_log_level": 0, "nlp_log_level": 0, "lp_log_level": 0,
                 "milp_log_level": 0, "fp_log_level": 0, "oa_log_level": 0}
        opts = {"discrete": [bool(d) for d in discrete], "print_time": False, "error_on_fail": False,
                "bonmin": {**quiet, **options}}
        self._solver = ca.nlpsol("mhe_bonmin", "bonmin", {"x": x, "p": gp, "f": f, "g": con}, opts)
        self._lb, self._ub, self._H = lb, ub, H

    def solve(self, f, lo, hi, centre, cutoff: float | None = None) -> _Outcome:
        g = f - self._H @ centre  # back from the displacement form of _DaqpBackend.solve
        old = sys.stdout
        sys.stdout = _NULL
        try:
            r = self._solver(x0=np.clip(centre, self._lb, self._ub), p=g, lbg=lo, ubg=hi, lbx=self._lb, ubx=self._ub)
        finally:
            sys.stdout = old
        st = self._solver.stats()
        status = str(st.get("return_status", ""))
        detail = {"status": status}
        if status == "SUCCESS":
            return _Outcome("optimal", np.array(r["x"], dtype=float).reshape(-1), detail)
        if status == "INFEASIBLE":
            return _Outcome("infeasible", None, detail)
        return _Outcome("not certified", None, detail)


class _HighspyBackend:
    """HiGHS through its own Python API (``highspy``), model passed once, row bounds changed per step.

    CasADi's ``conic("highs")`` plugin is not the default: it loads CasADi's ``libhighs.so.1``
    (HiGHS 1.13), the ``highspy`` package (a project dependency, also imported by cvxpy) loads its
    own ``libhighs.so.1`` (1.15) under the same soname, and whichever comes second runs on the
    other's library: heap corruption ("corrupted double-linked list") in the first MILP solve.
    """

    name = "highs"

    def __init__(self, c, A, lb, ub, discrete, options: dict):
        import highspy

        self._hs = highspy
        h = highspy.Highs()
        base = {"output_flag": False, "mip_rel_gap": 0.0, "mip_abs_gap": 0.0,
                # the feasibility-jump heuristic costs ~14 ms per call on these tiny MILPs
                "mip_heuristic_run_feasibility_jump": False,
                "primal_feasibility_tolerance": MHE_MILP_FEASIBILITY_TOL,
                "mip_feasibility_tolerance": MHE_MILP_FEASIBILITY_TOL}
        for key, value in {**base, **options}.items():
            if h.setOptionValue(key, value) != highspy.HighsStatus.kOk:
                raise ModelError(f"solver_options[{key!r}]", "a HiGHS option name and a valid value", repr(value))
        inf = highspy.kHighsInf
        lp = highspy.HighsLp()
        nr, nc = A.shape
        lp.num_col_, lp.num_row_ = nc, nr
        lp.col_cost_ = np.asarray(c, dtype=float)
        lp.col_lower_ = np.maximum(lb, -inf)
        lp.col_upper_ = np.minimum(ub, inf)
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

    def solve(self, lo, hi, start: np.ndarray | None = None, cutoff: float | None = None,
              target: float | None = None, col_bounds: tuple | None = None) -> _Outcome:
        """Solve with row bounds ``lo, hi``.

        ``cutoff`` (HiGHS ``objective_bound``): only points of objective below it are searched
        for, and "infeasible" then means that none exists.  ``target`` (``objective_target``):
        stop at the first incumbent below it; such a point comes back with status
        ``"feasible"`` (not claimed optimal), to be verified by the caller.  ``col_bounds`` =
        ``(index, lower, upper)`` replaces some column bounds for this solve.
        """
        h, hs = self._h, self._hs
        h.changeRowsBounds(self._rows.size, self._rows, np.maximum(lo, -self._inf), np.minimum(hi, self._inf))
        if col_bounds is not None:
            idx, cl, cu = col_bounds
            h.changeColsBounds(len(idx), np.asarray(idx, dtype=np.int32), np.asarray(cl, dtype=float),
                               np.asarray(cu, dtype=float))
        h.setOptionValue("objective_bound", self._inf if cutoff is None else float(cutoff))
        h.setOptionValue("objective_target", -self._inf if target is None else float(target))
        if start is not None:
            sol = hs.HighsSolution()
            sol.col_value = list(start)
            h.setSolution(sol)
        h.run()
        status = h.getModelStatus()
        info = h.getInfo()
        detail = {"status": h.modelStatusToString(status), "objective": float(info.objective_function_value),
                  "dual_bound": float(info.mip_dual_bound), "nodes": int(info.mip_node_count)}
        sol = h.getSolution()
        x = np.array(sol.col_value, dtype=float) if sol.value_valid else None
        finite = x is not None and x.size == len(self._cols) and bool(np.all(np.isfinite(x)))
        if status == hs.HighsModelStatus.kOptimal:
            if finite:
                return _Outcome("optimal", x, detail)
            detail["status"] += " with a NaN/Inf or missing point"
        elif status == hs.HighsModelStatus.kInfeasible:
            return _Outcome("infeasible", None, detail)
        elif target is not None and finite:
            return _Outcome("feasible", x, detail)
        return _Outcome("not certified", None, detail)


class _MilpBackend:
    """CBC or HiGHS through CasADi's ``conic`` with ``discrete`` variables (norms 1 and inf).

    ``"casadi-highs"`` cannot share a process with the ``highspy`` package (see
    :class:`_HighspyBackend`); the observer refuses it when highspy is already imported.
    """

    def __init__(self, plugin: str, c, A, lb, ub, discrete, options: dict):
        import casadi as ca

        self.name = plugin
        self._A = ca.sparsify(ca.DM(A))
        nx = A.shape[1]
        if plugin == "highs":
            # HiGHS's feasibility-jump heuristic costs ~14 ms per call on these tiny MILPs
            base = {"output_flag": False, "mip_rel_gap": 0.0, "mip_abs_gap": 0.0,
                    "mip_heuristic_run_feasibility_jump": False,
                    "primal_feasibility_tolerance": MHE_MILP_FEASIBILITY_TOL,
                    "mip_feasibility_tolerance": MHE_MILP_FEASIBILITY_TOL}
            opts = {"discrete": [bool(d) for d in discrete], "error_on_fail": False, "highs": {**base, **options}}
        else:
            base = {"loglevel": 0, "allowableGap": 0.0, "ratioGap": 0.0}
            opts = {"discrete": [bool(d) for d in discrete], "error_on_fail": False, "cbc": {**base, **options}}
        self._solver = ca.conic(f"mhe_{plugin}", plugin, {"a": self._A.sparsity(), "h": ca.Sparsity(nx, nx)}, opts)
        self._c, self._lb, self._ub = c, lb, ub

    def solve(self, lo, hi, start: np.ndarray | None = None) -> _Outcome:
        old = sys.stdout
        sys.stdout = _NULL
        try:
            r = self._solver(g=self._c, a=self._A, lba=lo, uba=hi, lbx=self._lb, ubx=self._ub)
        finally:
            sys.stdout = old
        st = self._solver.stats()
        status = str(st.get("return_status", ""))
        secondary = str(st.get("secondary_return_status", ""))
        detail = {"status": status if not secondary else f"{status}: {secondary}", "objective": float(r["cost"])}
        x = np.array(r["x"], dtype=float).reshape(-1)
        if self.name == "highs":
            optimal, infeasible = status == "Optimal", status == "Infeasible"
        else:
            optimal = bool(st.get("success")) and "completed" in secondary and "solution" in secondary
            infeasible = "infeasible" in secondary.lower()
        if optimal and np.all(np.isfinite(x)):
            return _Outcome("optimal", x, detail)
        if infeasible:
            return _Outcome("infeasible", None, detail)
        return _Outcome("not certified", None, detail)


# ------------------------------------------------------------------------------------ observer
class MHEObserver(Observer):
    """Moving-horizon observer (10) of paper 002 on the runtime observer contract.

    Parameters
    ----------
    system : PWASystem
        The model (eq. 1) with bounded ``X`` and ``U`` (eq. 2).
    T : int
        Window length (``T >= 1``); the paper uses ``T = 3`` for model (16).
    norm : {"2", "1", "inf"}
        ``"2"``: ``||.||_2^2`` of eq. (10) (MIQP); ``"1"`` / ``"inf"``: the MILP variants.
    solver : str, optional
        ``"daqp"`` (default for norm 2), ``"casadi-daqp"``, ``"bonmin"``; ``"highs"`` (default for
        norms 1/inf, via highspy), ``"cbc"`` or ``"casadi-highs"`` (refused when highspy is loaded).
    output_weight, disturbance_weight, arrival_weight : scalar, vector or matrix, optional
        ``W_y`` (default identity: the paper's cost), ``W_w`` (adds disturbances ``w(k)``),
        ``W_a`` (adds the arrival cost); see the module docstring.
    x0 : (n,) array, optional
        Initial guess (open-loop prediction and first arrival prior); default the centre of ``X``.
    solver_options : dict, optional
        Passed to the solver (DAQP settings, HiGHS/CBC/Bonmin options), e.g.
        ``{"iter_limit": 1}`` or ``{"time_limit": 1e-6}``; they override the defaults, which for
        DAQP are ``abs_subopt = MHE_ABS_SUBOPT``, ``eps_prox = 0`` and ``cycle_tol =``
        :data:`~hybobs_opt.tolerances.MHE_DAQP_CYCLE_TOL` (1000 iterations without progress
        before DAQP gives up with exit -2, "cycling"; DAQP's own default of 10 ends the
        branch-and-bound on degenerate big-M vertices of 4-mode systems at T = 4-5 with noisy
        data).  With the DAQP solver they apply to the uniqueness MIQP too.
    polish : bool
        Norm 2: re-solve the continuous QP of the optimal mode sequence exactly (removes the
        proximal term's bias from the estimate; see Notes).
    prox_weight : float
        Proximal weight ``eps`` of the MIQP (scaled units), default
        :data:`~hybobs_opt.tolerances.MHE_PROX_WEIGHT`.
    binary_prox_weight : float
        Proximal weight of the binaries, default :data:`~hybobs_opt.tolerances.MHE_BINARY_PROX_WEIGHT`.
    zero_cost_certificate : bool
        Accept a warm start of zero cost as the optimum without branch-and-bound (the cost is
        nonnegative).  ``False`` runs the branch-and-bound at every step (the warm start is then
        only its incumbent), e.g. to time it.
    prox_passes : int
        Largest number of proximal-point passes per window (norm 2; see Notes).
    big_m : BigMConstants, optional
        Precomputed constants (share them between observers of the same system).
    check_uniqueness : bool
        ``True`` (default): flag ``observable`` only when the window-start state is unique (the
        separated program, see Notes).  ``False``: no second program; ``observable`` then means
        only "certified optimum" (the flag's old meaning), unless ``analysis`` decides.
    uniqueness_delta : float
        Separation ``delta`` of an alternative window-start state (inf-norm, units of the
        half-widths of ``X``), default :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_DELTA`.
    analysis : ObservabilityAnalysis, optional
        A saved analysis of Algorithm 3.1 for this system and ``T``
        (:func:`hybobs_opt.regions.analyse_observability`).  Its point query
        ``classify(x(t-T+1))`` at the estimate decides the flag: ``"observable"`` /
        ``"unobservable"`` answer Definition 2.2, i.e. for every input sequence, which is
        stronger than the data-based question of the separated program (an ``unobservable``
        state may still be unique for the input actually applied).  For noisy data it
        classifies the estimate, not the data.  When it answers ``"infeasible"`` (the estimate
        lies outside ``X*_T``) the separated program decides (``fallback`` if
        ``check_uniqueness=False``).

    Notes
    -----
    Uniqueness (the flag ``observable``).  After the optimum ``J*`` with window-start state
    ``xi0*`` (scaled), a second mixed-integer program on the same MLD rows asks for the least
    cost of a window-start state with ``||xi0 - xi0*||_inf >= delta``: ``2 n`` direction
    binaries with ``sum = 1`` and big-M rows choose the coordinate and side (the box of ``X``
    bounds ``M``).  It is built once at construction and re-solved per step:

    1. a cheap sufficient test for an *alternative* first: when the optimal mode sequence's own
       least-squares map has a direction whose cost over ``delta`` is below ``epsilon`` (the
       backlash of model (16)), the QP of that sequence with the separation row, one per
       admissible direction; it can never prove uniqueness, which needs every mode sequence;
    2. the norm-2 MIQP (DAQP, its own workspace, proximal weight
       :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_PROX_WEIGHT`) with the objective cutoff
       ``J* + epsilon`` widened by the proximal term's largest value over the box (and
       ``abs_subopt``): "infeasible" (every node pruned) proves that each separated state costs
       more than ``J* + epsilon``, so the state is unique; a returned point is re-checked in
       numpy and the QP of its mode sequence and direction re-solved exactly: at most
       ``J* + epsilon`` makes it an ``alternative``; above (within the proximal bias of the
       threshold) that combination is excluded exactly and the rest searched again, by bounds
       on the binaries only, in ``T + 1`` disjoint parts (at most ``UNIQUENESS_MAX_SOLVES``
       solves, else "not certified").  DAQP's settings are applied before its setup, with
       ``zero_tol`` below the proximal weight: otherwise DAQP treats the nearly singular Hessian
       as singular and silently switches to proximal iterations, whose answers were measured
       to be wrong by 1e-11 of the output scale, ten times epsilon;
    3. norms 1 / inf: the same MIQP is a sufficient bound, since ``J_1 >= ||r||_2`` and
       ``J_inf >= ||r||_2 / sqrt(N)`` (``N`` residual entries): if no separated state has
       ``||r||_2^2 <= thr^2`` (``N thr^2``) the state is unique without the MILP.  Otherwise the
       separated MILP (HiGHS with ``objective_bound`` and ``objective_target`` at
       ``J* + epsilon``) decides: "infeasible", or an optimum whose dual bound exceeds the
       threshold, proves uniqueness; a verified point below it is an alternative.

    A DAQP solve that ends in cycling (exit -2) or at its iteration limit after warm-started
    solves is repeated once on a workspace set up afresh (the only rebuild, never a per-step
    one): the state kept from earlier solves was seen to cycle where a fresh one does not.

    Every point a solver returns passes the same check as the optimum's before it is trusted:
    finite point (and, for DAQP, finite objective and multipliers), integral binaries, one mode
    per step and one direction, every MLD row within tolerance, the separation satisfied; the
    alternative reported is then a model trajectory rebuilt from its window-start state and
    modes, re-checked and costed in numpy.  With an arrival cost the prior is part of the cost:
    "unique" then refers to the regularised problem.

    Warm start and certification, every step (every norm):

    1. The warm start is the previous window's solution shifted by one sample (its last state
       propagated through the model, the new last mode from the guards); after a reset, the model
       simulated from ``x0``.  The problem of its mode sequence is solved exactly (a QP or LP in
       the window-start state and the disturbances, :meth:`_polish`); after a reset every
       constant mode sequence is tried too.  The best of these is the incumbent.
    2. If the incumbent's cost is zero (to :data:`~hybobs_opt.tolerances.MHE_ZERO_COST_RTOL`) it
       is optimal, the cost being nonnegative (``solved_by = "warm start"``, unless
       ``zero_cost_certificate=False``).  On noise-free data this is nearly every step.
    3. Otherwise the MIQP/MILP is solved with the incumbent as warm start (DAQP: proximal centre
       and objective cutoff; HiGHS: MIP start).  ``solved_by`` is ``"branch-and-bound"`` when the
       solver's point is returned and ``"branch-and-bound (incumbent)"`` when the solver proves
       that nothing beats the incumbent.

    DAQP needs a positive-definite Hessian; eq. (10) has none in the binaries and the big-M
    copies.  The MIQP therefore minimises ``J / J_s + eps ||v - v_bar||^2`` with ``v_bar`` the
    incumbent (or warm start), solved in the displacement ``v - v_bar`` so that the objective
    values stay near zero (cost differences of 1e-10 of the output energy separate the mode
    sequences of model (16)).  The returned point's cost exceeds the optimum by at most
    ``gap_bound = J_s (abs_subopt + sum_j eps_j R_j)``, ``R_j`` the largest ``(v_j - v_bar_j)^2``
    over the variable bounds; it is reported, and it is what "certified" means for the MIQP.
    When the minimiser moved away from the centre the MIQP is solved again centred at it
    (proximal-point passes, at most ``prox_passes``).  With ``polish`` the continuous part is
    then re-solved exactly for the optimal mode sequence, so the estimate carries no proximal
    bias.

    ``"casadi-daqp"`` uses the DAQP copy bundled in CasADi 3.8.2, whose branch-and-bound returns
    NaN with a success status when the problem has equality rows, and wrong points or false
    "infeasible" answers with small curvature on the binaries (found on this encoding); the one-hot
    rows are eliminated for it, and its answers are verified like every other solver's.
    ``"daqp"`` (the ``daqp`` Python package, a newer DAQP) is the default for that reason.
    """

    name = "mhe"

    def __init__(self, system: PWASystem, T: int, norm: str = "2", solver: str | None = None, output_weight=None,
                 disturbance_weight=None, arrival_weight=None, *, x0=None, solver_options: dict | None = None,
                 polish: bool = True, prox_weight: float = MHE_PROX_WEIGHT,
                 binary_prox_weight: float = MHE_BINARY_PROX_WEIGHT, zero_cost_certificate: bool = True,
                 prox_passes: int = DEFAULT_PROX_PASSES, big_m: BigMConstants | None = None,
                 check_uniqueness: bool = True, uniqueness_delta: float = MHE_UNIQUENESS_DELTA, analysis=None):
        if not isinstance(system, PWASystem):
            raise ModelError("system", "a PWASystem", type(system).__name__)
        if isinstance(T, bool) or not isinstance(T, (int, np.integer)) or T < 1:
            raise ModelError("T", "an integer horizon T >= 1", repr(T))
        norm = str(norm).lower()
        if norm not in NORMS:
            raise ModelError("norm", f"one of {NORMS}", repr(norm))
        solver = SOLVERS[norm][0] if solver is None else str(solver).lower()
        if solver not in SOLVERS[norm]:
            raise ModelError("solver", f"one of {SOLVERS[norm]} for norm {norm!r}", repr(solver))
        if solver_options is not None and not isinstance(solver_options, dict):
            raise ModelError("solver_options", "a dict of solver options", type(solver_options).__name__)
        for label, w in (("prox_weight", prox_weight), ("binary_prox_weight", binary_prox_weight)):
            if not (isinstance(w, (int, float, np.floating)) and np.isfinite(w) and w > 0):
                raise ModelError(label, "a positive finite weight", repr(w))
        self.binary_prox_weight = float(binary_prox_weight)
        if isinstance(prox_passes, bool) or not isinstance(prox_passes, (int, np.integer)) or prox_passes < 1:
            raise ModelError("prox_passes", "an integer >= 1", repr(prox_passes))
        self.prox_passes = int(prox_passes)
        self.zero_cost_certificate = bool(zero_cost_certificate)
        if not isinstance(check_uniqueness, (bool, np.bool_)):
            raise ModelError("check_uniqueness", "True or False", repr(check_uniqueness))
        self.check_uniqueness = bool(check_uniqueness)
        if not (isinstance(uniqueness_delta, (int, float, np.floating)) and not isinstance(uniqueness_delta, bool)
                and np.isfinite(uniqueness_delta) and uniqueness_delta > 0):
            raise ModelError("uniqueness_delta", "a positive finite separation (units of the half-widths of X)",
                             repr(uniqueness_delta))
        self.uniqueness_delta = float(uniqueness_delta)
        if analysis is not None:
            if not callable(getattr(analysis, "classify", None)):
                raise ModelError("analysis", "an ObservabilityAnalysis (hybobs_opt.regions) with classify(x)",
                                 type(analysis).__name__)
            if getattr(analysis, "T", None) != int(T) or not _same_pwa(getattr(analysis, "system", None), system):
                raise ModelError("analysis", f"an analysis of this system at T = {int(T)}",
                                 f"T = {getattr(analysis, 'T', None)} of {getattr(analysis, 'system', None)!r}")
        self.analysis = analysis
        self.system = system
        self.T = int(T)
        self.norm = norm
        self.solver = solver
        self.polish = bool(polish)
        self.prox_weight = float(prox_weight)
        self.n, self.m, self.p = system.n, system.m, system.p
        self.state_names = system.state_names
        self.name = f"mhe-{'miqp' if norm == '2' else 'milp'}-{norm}"
        self._Wy = _weight(np.eye(self.p) if output_weight is None else output_weight, self.p, "output_weight")
        self._Ww = _weight(disturbance_weight, self.n, "disturbance_weight")
        self._Wa = _weight(arrival_weight, self.n, "arrival_weight")
        self.enc = encode_mld(system, self.T, disturbances=self._Ww is not None and self.T > 1, big_m=big_m)
        self._theta_idx = np.r_[self.enc.slices["xi0"], self.enc.slices["omega"]]
        self._res = _residual(self.enc, self._Wy, self._Ww, self._Wa)
        self._build(dict(solver_options or {}))
        self._G_all = np.vstack([md.guard.A for md in system.modes])
        self._g_all = np.concatenate([md.guard.b + MEMBERSHIP_RTOL * (1.0 + np.abs(md.guard.b)) for md in system.modes])
        self._g_starts = np.cumsum([0] + [md.guard.A.shape[0] for md in system.modes[:-1]])
        self._X = system.state_bounds
        Ub = system.input_bounds
        self._U_A = None if Ub is None else Ub.A
        self._U_b = None if Ub is None else Ub.b + MEMBERSHIP_RTOL * (1.0 + np.abs(Ub.b))
        m0 = system.modes[0]
        self._common_out = all(np.array_equal(md.C, m0.C) and np.array_equal(md.D, m0.D) and np.array_equal(md.c, m0.c)
                               for md in system.modes)
        self._Cs = np.array([md.C for md in system.modes])
        self._Ds = np.array([md.D for md in system.modes])
        self._cs = np.array([md.c for md in system.modes])
        self._Xb_tol = self._X.b + MEMBERSHIP_RTOL * (1.0 + np.abs(self._X.b))
        half, centre = system.scales()
        self._hx, self._cx = half[: self.n], centre[: self.n]
        self._x_default = centre[: self.n].copy()
        self._build_uniqueness(dict(solver_options or {}))
        self.reset(x0)

    # ------------------------------------------------------------------ offline
    def _build(self, options: dict) -> None:
        enc, res = self.enc, self._res
        nv = enc.n_vars
        RtR = res.R.T @ res.R
        self._eq_rows = enc.lo == enc.hi
        if self.norm == "2":
            diag = np.diag(RtR)
            self._Js = float(diag.max()) if diag.max() > 0 else 1.0
            self._zero_cost = MHE_ZERO_COST_RTOL * self._Js
            # proximal weights: continuous variables and binaries (see Notes of the class)
            self._eps = np.where(enc.discrete, self.binary_prox_weight, self.prox_weight)
            self._H = 2.0 * RtR / self._Js + 2.0 * np.diag(self._eps)
            args = (self._H, enc.A, enc.lb, enc.ub, enc.discrete)
            if self.solver == "daqp":
                self._backend = _DaqpBackend(*args, self._eq_rows, options)
            elif self.solver == "casadi-daqp":
                self._backend = _CasadiDaqpBackend(*args, enc, self._eq_rows, options)
            else:
                self._backend = _BonminBackend(*args, options)
            return
        # MILP: slacks e >= |r| / js (norm 1: one per residual entry; inf: one per block)
        js = float(np.max(np.abs(res.R))) or 1.0
        self._Js = js
        nr = res.R.shape[0]
        if self.norm == "1":
            ns = nr
            E = np.eye(nr)
        else:
            ns = len(res.blocks)
            E = np.zeros((nr, ns))
            for b, (_, sl) in enumerate(res.blocks):
                E[sl, b] = 1.0
        Rs = res.R / js
        A = np.vstack([np.hstack([enc.A, np.zeros((enc.n_constraints, ns))]),
                       np.hstack([Rs, -E]), np.hstack([-Rs, -E])])
        self._nslack = ns
        self._zero_cost = np.sqrt(MHE_ZERO_COST_RTOL) * js
        c = np.concatenate([np.zeros(nv), np.ones(ns)])
        lb = np.concatenate([enc.lb, np.zeros(ns)])
        ub = np.concatenate([enc.ub, np.full(ns, np.inf)])
        disc = np.concatenate([enc.discrete, np.zeros(ns, dtype=bool)])
        self._milp = (c, A, lb, ub, disc)
        if self.solver == "highs":
            self._backend = _HighspyBackend(c, A, lb, ub, disc, options)
            return
        if self.solver == "casadi-highs" and "highspy" in sys.modules:
            raise SolverError(f"MHE observer (norm {self.norm})", "casadi-highs", "highspy already loaded",
                              hint="solver='highs' (highspy and CasADi's HiGHS plugin share the soname "
                                   "libhighs.so.1 with different versions: one process cannot use both)")
        self._backend = _MilpBackend(self.solver.replace("casadi-", ""), c, A, lb, ub, disc, options)

    # ------------------------------------------------------------------ state
    def reset(self, x0: np.ndarray | None = None, **kwargs: Any) -> None:
        """Clear the window; ``x0`` (default: centre of ``X``) seeds prediction and the first prior."""
        x0 = self._x_default if x0 is None else x0
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape != (self.n,) or not np.all(np.isfinite(x0)):
            raise ModelError("x0", f"a finite state of length {self.n}", f"{x0.tolist()}")
        self._x = x0.copy()
        self._mode = -1
        self._start = x0.copy()  # estimate of the state at the first sample of the coming window
        self._prev: tuple[np.ndarray, np.ndarray, np.ndarray] | None = None  # (states, modes, last u)
        self._Y = np.zeros((self.T, self.p))
        self._U = np.zeros((self.T, self.m))
        self._count = 0
        self._u_prev: np.ndarray | None = None

    # ------------------------------------------------------------------ model helpers
    def _mode_at(self, x: np.ndarray, u: np.ndarray) -> int:
        """First mode whose guard contains ``(x, u)`` (``-1`` if none); the domain is not checked."""
        viol = self._G_all @ np.concatenate([x, u]) - self._g_all
        hit = np.nonzero(np.maximum.reduceat(viol, self._g_starts) <= 0.0)[0]
        return int(hit[0]) if hit.size else -1

    def _in_X(self, x: np.ndarray) -> bool:
        return bool((self._X.A @ x <= self._Xb_tol).all())

    def _f(self, x: np.ndarray, u: np.ndarray, q: int) -> np.ndarray:
        md = self.system.modes[q]
        return md.A @ x + md.B @ u + md.a

    def _open_loop(self, u: np.ndarray | None) -> tuple[np.ndarray, int, bool]:
        """``f_pwa(x(t-1), u(t-1))``; keeps the estimate if it has left ``X x U`` (never raises)."""
        if u is None:
            return self._x, self._mode, False
        q = self._mode_at(self._x, u) if self._in_X(self._x) else -1
        if q < 0:
            return self._x, self._mode, False
        return self._f(self._x, u, q), q, True

    def _feasible(self, X: np.ndarray, modes: np.ndarray, U: np.ndarray) -> bool:
        """Whether every ``(X[k], U[k])`` lies in ``X`` and in the guard of ``modes[k]``."""
        viol = np.concatenate([X, U], axis=1) @ self._G_all.T - self._g_all
        per_mode = np.maximum.reduceat(viol, self._g_starts, axis=1)
        return bool((per_mode[np.arange(self.T), modes] <= 0.0).all() and (X @ self._X.A.T <= self._Xb_tol).all())

    def _simulate(self, x_start: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Window states and modes simulated from ``x_start`` through the guards (a warm start).

        Where the trajectory leaves every guard the previous mode is kept, so this never fails.
        """
        X = np.empty((self.T, self.n))
        modes = np.zeros(self.T, dtype=int)
        x, last = np.asarray(x_start, dtype=float), 0
        for k in range(self.T):
            q = self._mode_at(x, U[k])
            q = last if q < 0 else q
            X[k], modes[k], last = x, q, q
            if k < self.T - 1:
                x = self._f(x, U[k], q)
        return X, modes

    def _shifted(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The previous window's trajectory shifted by one sample and extended by the model."""
        Xp, mp, u_last = self._prev
        X = np.empty_like(Xp)
        modes = np.empty_like(mp)
        X[:-1], modes[:-1] = Xp[1:], mp[1:]
        X[-1] = self._f(Xp[-1], u_last, int(mp[-1]))
        q = self._mode_at(X[-1], U[-1])
        modes[-1] = mp[-1] if q < 0 else q
        return X, modes

    # ------------------------------------------------------------------ one solve
    def solve_window(self, U: np.ndarray, Y: np.ndarray, x_start: np.ndarray | None = None,
                     uniqueness: bool = False) -> dict:
        """Solve eq. (10) on one window (no observer state is changed).

        Parameters
        ----------
        U : (T, m) array
        Y : (T, p) array
        x_start : (n,) array, optional
            Warm start and arrival prior for the window-start state (default: centre of ``X``);
            the warm-start mode sequence is simulated from it through the guards.
        uniqueness : bool
            Also run the separated program of the observer's flag on an optimal answer (needs
            ``check_uniqueness=True`` at construction; a saved ``analysis`` is not consulted):
            ``out["uniqueness"]`` (and ``out["alternative"]`` when one is found), as in
            :meth:`step`'s ``info``.

        Returns
        -------
        dict
            ``status`` (``"optimal"``, ``"infeasible"``, ``"not certified"``), and when optimal:
            ``x_start`` (window-start estimate), ``states`` (``(T, n)``), ``modes``, ``w``
            (``(T - 1, n)`` disturbances), ``cost`` and ``gap_bound`` (original units), plus the
            solver's details.
        """
        U = np.asarray(U, dtype=float).reshape(self.T, self.m)
        Y = np.asarray(Y, dtype=float).reshape(self.T, self.p)
        xs = self._x_default if x_start is None else np.asarray(x_start, dtype=float).reshape(self.n)
        Xg, mg = self._simulate(xs, U)
        out = self._solve(U, Y, xs, Xg, mg, cold=True)
        if uniqueness and out["status"] == "optimal":
            if not self.check_uniqueness:
                raise ModelError("uniqueness", "False for an observer built with check_uniqueness=False", "True")
            uq = self._uniqueness(U, Y, xs, out)
            if uq["status"] == "alternative":
                out["alternative"] = uq.pop("alternative")
            out["uniqueness"] = uq
        return out

    def _solve(self, U: np.ndarray, Y: np.ndarray, x_start: np.ndarray, Xg: np.ndarray, mg: np.ndarray,
               cold: bool = False) -> dict:
        """Certified solve of one window; ``(Xg, mg)`` is the warm start (states and modes).

        Norm 2, warm start first: the QP of the warm start's mode sequence is solved exactly
        (:meth:`_polish`).  Its cost is an upper bound of (10); when it is zero (to
        :data:`~hybobs_opt.tolerances.MHE_ZERO_COST_RTOL`) it is also the optimum, since the cost
        is a sum of squares, and no branch-and-bound is needed (``info["solved_by"]``).  Otherwise
        it is the incumbent of the branch-and-bound: the proximal term is centred at it and its
        objective prunes every node that cannot beat it.  When the minimiser moved away from the
        centre the MIQP is solved again centred at the new minimiser (proximal-point passes).  The
        lowest-cost certified point is returned.
        """
        enc, res = self.enc, self._res
        Uf, Yf = U.reshape(-1), Y.reshape(-1)
        lo, hi = enc.bounds(Uf)
        rp = res.offset(Yf, Uf, x_start)
        best, Wg = None, None
        Wzero = np.zeros((max(self.T - 1, 0), self.n))
        candidates = [mg] + ([np.full(self.T, q) for q in range(self.system.n_modes)] if cold else [])
        if self._feasible(Xg, mg, U):
            # the warm start itself (a trajectory of the model) may already fit the data exactly
            cost = self._cost(Xg, mg, U, Y, Wzero, x_start)
            if cost <= self._zero_cost:
                best = {"status": "optimal", "solver": self.solver, "solved_by": "warm start", "polished": False,
                        "x_start": Xg[0].copy(), "states": Xg, "modes": mg.copy(), "w": Wzero, "cost": cost,
                        "gap_bound": np.inf, "passes": 0}
                candidates = []
        # candidate incumbents, solved exactly with their modes fixed: the warm start's mode
        # sequence; after a reset (no previous window) also every constant sequence, since a
        # cold guess is often in the wrong mode
        seen = set()
        for seq in candidates:
            key = tuple(int(q) for q in seq)
            if key in seen:
                continue
            seen.add(key)
            pol = self._polish(seq, U, Y, x_start, Xg[0], np.zeros((max(self.T - 1, 0), self.n)))
            if pol is None:
                continue
            x0i, Wi, Xi = pol
            cost = self._cost(Xi, seq, U, Y, Wi, x_start)
            if best is None or cost < best["cost"]:
                best = {"status": "optimal", "solver": self.solver, "solved_by": "warm start", "polished": True,
                        "x_start": x0i, "states": Xi, "modes": np.array(seq, dtype=int), "w": Wi,
                        "cost": cost, "gap_bound": np.inf, "passes": 0}
            if best["cost"] <= self._zero_cost:
                break
        if best is not None:
            Xg, mg, Wg = best["states"], best["modes"], best["w"]
            if best["cost"] <= self._zero_cost and self.zero_cost_certificate:
                best["gap_bound"] = best["cost"]  # the optimum is >= 0
                return best
        passes = self.prox_passes if self.norm == "2" else 1
        info = None
        for k in range(passes):
            info = self._solve_once(U, Y, x_start, Xg, mg, Wg, lo, hi, rp, incumbent=best)
            if info["status"] == "incumbent optimal":
                best["gap_bound"] = min(best["gap_bound"], info["gap_bound"])
                best["solved_by"] = "branch-and-bound (incumbent)"
                best["passes"] = k + 1
                break
            if info["status"] != "optimal":
                break
            info["passes"] = k + 1
            moved = info.pop("moved")
            if best is None or info["cost"] < best["cost"]:
                gap = info["gap_bound"] if best is None else min(info["gap_bound"], best["gap_bound"])
                best = {**info, "gap_bound": gap}
            else:  # the branch-and-bound found nothing better than the incumbent: it certifies it
                best["gap_bound"] = min(best["gap_bound"], info["gap_bound"])
                best["passes"] = k + 1
                if best["solved_by"] == "warm start":
                    best["solved_by"] = "branch-and-bound (incumbent)"
            if not moved:
                break
            Xg, mg, Wg = info["states"], info["modes"], info["w"]
        if best is None or not np.isfinite(best["gap_bound"]):
            # no certified branch-and-bound: an incumbent alone is not an optimum
            return info if info is not None and info["status"] != "optimal" else {
                "status": "not certified", "solver": self.solver, "reason": "no certified solve"}
        return best

    def _solve_once(self, U, Y, x_start, Xg, mg, Wg, lo, hi, rp, incumbent: dict | None = None) -> dict:
        """One solve of the MIQP/MILP centred at the warm start ``(Xg, mg, Wg)``, verified.

        With an ``incumbent`` (norm 2) its objective is the branch-and-bound's cutoff; if nothing
        beats it the status is ``"incumbent optimal"``.
        """
        enc, res = self.enc, self._res
        Uf = U.reshape(-1)
        vbar = enc.pack(Xg, mg, U, Wg) if self.norm == "2" else None
        try:
            if self.norm == "2":
                # linear term in the displacement d = v - vbar (the proximal term is centred at
                # vbar): H vbar + g = 2 R' (R vbar + rp) / J_s, the residual at the warm start
                f = 2.0 * res.R.T @ (res.R @ vbar + rp) / self._Js
                cutoff = None
                if incumbent is not None:
                    if incumbent["states"] is Xg:  # the centre is the incumbent: d = 0
                        obj = 0.0
                    else:
                        d = enc.pack(incumbent["states"], incumbent["modes"], U,
                                     incumbent["w"] if enc.disturbances else None) - vbar
                        obj = 0.5 * d @ self._H @ d + f @ d
                    cutoff = obj + MHE_ABS_SUBOPT * (1.0 + abs(obj))
                out = self._backend.solve(f, lo, hi, vbar, cutoff=cutoff)
                if out.status == "infeasible" and incumbent is not None:
                    # every node was pruned by the incumbent's objective (the problem is feasible:
                    # the incumbent is a point of it), so the incumbent is optimal
                    return {"status": "incumbent optimal", "gap_bound": self._gap_bound(vbar)}
            else:
                rps = rp / self._Js
                start = None
                if incumbent is not None and self.solver == "highs":
                    # the incumbent as the MIP start, with its slacks
                    vi = enc.pack(incumbent["states"], incumbent["modes"], U, incumbent["w"] if enc.disturbances else None)
                    ri = np.abs(res.R @ vi + rp) / self._Js
                    e = ri if self.norm == "1" else np.array([ri[sl].max() for _, sl in res.blocks])
                    start = np.concatenate([vi, e])
                out = self._backend.solve(np.concatenate([lo, np.full(2 * rps.size, -np.inf)]),
                                          np.concatenate([hi, -rps, rps]), start=start)
                if out.v is not None:
                    out.v = out.v[: enc.n_vars]
        except Exception as exc:  # a crashing solver must not stop the observer loop
            return {"status": "not certified", "reason": f"{type(exc).__name__}: {exc}", "solver": self.solver}
        info = {"status": out.status, "solver": self.solver, "solved_by": "branch-and-bound",
                **{f"solver_{k}": v for k, v in out.detail.items()}}
        if out.status != "optimal":
            info["reason"] = f"solver status {out.detail.get('status')!r}"
            return info
        v = out.v
        viol = enc.violation(v, Uf, bounds=(lo, hi)) if np.isfinite(v).all() else np.inf
        if not (viol <= max(MHE_FEASIBILITY_TOL, MHE_INTEGRALITY_TOL)):
            return {**info, "status": "not certified", "reason": f"solution failed verification (violation {viol:.3g})"}
        v = v.copy()
        v[enc.discrete] = np.round(v[enc.discrete])
        if not (v[enc.discrete].reshape(self.T, -1).sum(axis=1) == 1).all():
            return {**info, "status": "not certified", "reason": "binaries are not one mode per step"}
        modes = enc.modes(v)
        info["polished"] = False
        # The proximal term biases the estimate only where the solution moved away from the warm
        # start; when it did not, the warm start (a trajectory of the model) is a KKT point of
        # (10) to ~eps * tol.  Only the window-start state and the disturbances count: the
        # trajectory is rebuilt from them through the model, the big-M copies (feasible to the
        # solver's tolerance) are not used.
        theta = self._theta_idx
        moved = self.norm != "2" or not (np.array_equal(modes, mg) and np.max(
            np.abs(v[theta] - vbar[theta]), initial=0.0) <= MHE_POLISH_SKIP_TOL)
        if not moved:
            x0, states = Xg[0].copy(), Xg
            W = np.zeros((max(self.T - 1, 0), self.n)) if Wg is None else Wg
        else:
            x0, W = enc.states(v)[0], enc.disturbance(v)
            states = None
            if self.norm == "2" and self.polish:
                pol = self._polish(modes, U, Y, x_start, x0, W)
                if pol is not None:
                    x0, W, states = pol
                    info["polished"] = True
            if states is None:
                states = self._trajectory(x0, modes, U, W)
        info.update(x_start=x0, states=states, modes=modes, w=W, cost=self._cost(states, modes, U, Y, W, x_start),
                    gap_bound=self._gap_bound(vbar), verified_violation=float(viol), moved=bool(moved))
        return info

    def _gap_bound(self, vbar: np.ndarray | None) -> float:
        """Upper bound on ``cost - optimum`` (original units) of an accepted solution."""
        if self.norm != "2":
            return 0.0
        enc = self.enc
        sub = float(self._backend._settings.get("abs_subopt", 0.0)) if self.solver == "daqp" else 0.0
        return float(self._Js * (sub + float(self._eps @ np.maximum((enc.lb - vbar) ** 2, (enc.ub - vbar) ** 2))))

    def _trajectory(self, x0, modes, U, W) -> np.ndarray:
        """Window states of the model from ``x0`` with modes ``modes`` and disturbances ``W``."""
        X = np.empty((self.T, self.n))
        X[0] = x0
        for k in range(self.T - 1):
            X[k + 1] = self._f(X[k], U[k], int(modes[k])) + W[k]
        return X

    def _cost(self, X, modes, U, Y, W, xbar) -> float:
        """Cost of eq. (10) with the optional terms, of a trajectory (original units)."""
        if self._common_out:
            ry = Y - X @ self._Cs[0].T - U @ self._Ds[0].T - self._cs[0]
        else:
            ry = (Y - np.einsum("kpn,kn->kp", self._Cs[modes], X) - np.einsum("kpm,km->kp", self._Ds[modes], U)
                  - self._cs[modes])
        parts = [(ry @ self._Wy.T).reshape(-1)]
        if self._Ww is not None and self.T > 1:
            parts.append((W @ self._Ww.T).reshape(-1))
        if self._Wa is not None:
            parts.append(self._Wa @ (X[0] - xbar))
        if self.norm == "2":
            return float(sum(np.dot(r, r) for r in parts))
        if self.norm == "1":
            return float(sum(np.abs(r).sum() for r in parts))
        return float(sum(np.abs(r).max() for r in parts))

    def _sequence_problem(self, modes, U, Y, xbar):
        """Condensed problem of one mode sequence: residual ``R theta + r`` and rows ``G theta <= g``.

        ``theta = [xi0; omega]`` are the window-start state and the disturbances, scaled by the
        state box; the rows are the guards of the sequence and ``X`` at every window step
        (paper 002, eq. 10 with the modes fixed).
        """
        sysm, T, n = self.system, self.T, self.n
        hx, cx = self._hx, self._cx
        dist = self._Ww is not None and T > 1
        nt = n + (n * (T - 1) if dist else 0)
        Px = np.zeros((n, nt))
        Px[:, :n] = np.diag(hx)
        px = cx.copy()
        Rrows, rvec, Grows, gvec = [], [], [], []
        XA, Xb = self._X.A, self._X.b
        for k in range(T):
            md = sysm.modes[int(modes[k])]
            Rrows.append(-self._Wy @ md.C @ Px)
            rvec.append(self._Wy @ (Y[k] - md.C @ px - md.D @ U[k] - md.c))
            G, g = md.guard.A, md.guard.b
            Grows.append(G[:, :n] @ Px)
            gvec.append(g - G[:, n:] @ U[k] - G[:, :n] @ px)
            Grows.append(XA @ Px)
            gvec.append(Xb - XA @ px)
            if k < T - 1:
                px = md.A @ px + md.B @ U[k] + md.a
                Px = md.A @ Px
                if dist:
                    Px[:, n + k * n: n + (k + 1) * n] += np.diag(hx)
        if dist:
            Rw = np.zeros((n * (T - 1), nt))
            Rw[:, n:] = np.kron(np.eye(T - 1), self._Ww @ np.diag(hx))
            Rrows.append(Rw)
            rvec.append(np.zeros(n * (T - 1)))
        if self._Wa is not None:
            Ra = np.zeros((n, nt))
            Ra[:, :n] = self._Wa @ np.diag(hx)
            Rrows.append(Ra)
            rvec.append(self._Wa @ (cx - xbar))
        G, gg = np.vstack(Grows), np.concatenate(gvec)
        norm = np.max(np.abs(G), axis=1)
        keep = norm > 0
        return np.vstack(Rrows), np.concatenate(rvec), G[keep] / norm[keep, None], gg[keep] / norm[keep], dist

    def _polish(self, modes, U, Y, xbar, x0, W, extra: tuple[np.ndarray, np.ndarray] | None = None,
                problem: tuple | None = None, bound: bool = False):
        """Least-squares problem of the mode sequence ``modes``, warm-started at ``(x0, W)``.

        The QP of eq. (10) with the modes fixed, solved by DAQP (proximal iterations when the
        sequence leaves directions of the state unobserved).  For norm 2 it is exact; for norms
        1 / inf it gives a feasible point of the sequence (an incumbent), optimal when it fits
        the data exactly.  ``extra = (G_e, g_e)`` adds rows ``G_e xi0 <= g_e`` on the scaled
        window-start state (the separation of the uniqueness test); ``problem`` is
        :meth:`_sequence_problem` of the same arguments, when already built.  Returns
        ``(x0, W, states)`` or ``None`` if not certified.

        ``bound=True`` (the uniqueness test): the proximal iterations run to convergence
        (``eta_prox`` 1e-20: DAQP's default stops them early, 30 times above the minimum on a
        sequence of model (16) with an unobserved direction) and a fourth element is returned, a
        lower bound of the least cost of the sequence proven in numpy from the multipliers:
        for every feasible ``theta``, by convexity and ``lam >= 0``,
        ``q(theta) >= q(theta^) - lam' (g - G theta^) - sum_j |rho_j| D_j`` with
        ``rho = H theta^ + f + G' lam`` and ``D_j`` the range of ``theta_j`` over its bounds.
        """
        import daqp

        T, n = self.T, self.n
        hx, cx = self._hx, self._cx
        R, r, G, gg, dist = self._sequence_problem(modes, U, Y, xbar) if problem is None else problem
        if extra is not None:
            Ge = np.zeros((extra[0].shape[0], G.shape[1]))
            Ge[:, :n] = extra[0]
            G, gg = np.vstack([G, Ge]), np.concatenate([gg, extra[1]])
        # a QP for every norm: for norm 2 it is the exact problem; for norms 1 / inf its minimiser
        # is a feasible point (an upper bound, the incumbent) and an exact fit when one exists
        scale = float(np.max(np.einsum("ij,ij->j", R, R))) or 1.0
        H = 2.0 * R.T @ R / scale
        f = 2.0 * R.T @ r / scale
        theta0 = np.concatenate([(x0 - cx) / hx] + ([(W / hx).reshape(-1)] if dist else []))
        settings = {"eta_prox": 1e-20} if bound else {}
        theta, fval, flag, info = daqp.solve(H, f, G, gg, np.full(gg.size, -_DAQP_INF), primal_start=theta0, **settings)
        lam = np.asarray(info.get("lam", ()), dtype=float)
        if flag != _DAQP_OPTIMAL or not (np.all(np.isfinite(theta)) and np.isfinite(fval) and np.all(np.isfinite(lam))):
            return None
        if np.max(G @ theta - gg, initial=0.0) > MHE_FEASIBILITY_TOL:
            return None
        x0p = cx + hx * theta[:n]
        Wp = (theta[n:].reshape(T - 1, n) * hx) if dist else np.zeros((max(T - 1, 0), n))
        states = self._trajectory(x0p, modes, U, Wp)
        if not bound:
            return x0p, Wp, states
        enc = self.enc
        lo_t = np.concatenate([enc.lb[enc.slices["xi0"]]] + ([enc.lb[enc.slices["omega"]]] if dist else []))
        hi_t = np.concatenate([enc.ub[enc.slices["xi0"]]] + ([enc.ub[enc.slices["omega"]]] if dist else []))
        D = np.maximum(np.abs(hi_t - theta), np.abs(theta - lo_t))
        lam = np.maximum(lam, 0.0) if lam.size == gg.size else np.zeros(gg.size)
        rho = H @ theta + f + G.T @ lam
        res = R @ theta + r
        lower = float(res @ res - scale * (lam @ (gg - G @ theta) + np.abs(rho) @ D))
        return x0p, Wp, states, lower

    # ------------------------------------------------------------------ uniqueness
    def _build_uniqueness(self, options: dict) -> None:
        """The separated program: eq. (10) on the same MLD rows plus ``||xi0 - xi0*||_inf >= delta``.

        Direction binaries ``b = (b_1+, b_1-, ..., b_n+, b_n-)`` with ``sum b = 1`` choose the
        coordinate and side of the separation, through the big-M rows
        ``+-(xi0_j - xi0*_j) >= delta - M (1 - b_j+-)`` with ``M = delta + max_j (ub_j - lb_j)``
        (``xi0*`` is clipped to the box of ``X``, so ``M`` is valid wherever ``b = 0``).  The rows'
        matrix is fixed; ``xi0*`` enters only their bounds, so every program is built once here
        and re-solved each step.  Every norm gets the norm-2 MIQP for DAQP (its own workspace,
        proximal weight :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_PROX_WEIGHT`): for norm 2
        it decides, for norms 1 / inf it is a sufficient bound (see :meth:`_uniqueness`); norms
        1 / inf also get the MILP with the slacks of :meth:`_build`, which decides.
        """
        enc, res = self.enc, self._res
        n, nv = self.n, enc.n_vars
        xi = enc.slices["xi0"]
        self._u_lbx, self._u_ubx = enc.lb[xi].copy(), enc.ub[xi].copy()
        delta = self.uniqueness_delta
        M = delta + float(np.max(self._u_ubx - self._u_lbx))
        self._u_M = M
        nb = 2 * n
        self._u_nb = nb
        # output scale of epsilon: one sample's squared weighted half-range of the outputs
        rng = enc.big_m.output_range
        hy = 0.5 * (rng[:, 1] - rng[:, 0])
        Wh = self._Wy * hy[None, :]
        S_y = float(np.max(np.einsum("ij,ij->j", Wh, Wh)))
        eps2 = MHE_UNIQUENESS_COST_RTOL * S_y + MHE_UNIQUENESS_COST_ATOL
        self.uniqueness_epsilon = eps2 if self.norm == "2" else float(np.sqrt(eps2))
        self._u_eps2 = eps2
        self._u_miqp = self._u_milp = None
        if not self.check_uniqueness:
            return
        # separation rows (scaled by 1 / M: largest coefficient one) and the one-hot row of b
        Sx = np.zeros((nb, nv))
        Sb = np.zeros((nb, nb))
        for j in range(n):
            Sx[2 * j, xi.start + j], Sb[2 * j, 2 * j] = 1.0 / M, -1.0
            Sx[2 * j + 1, xi.start + j], Sb[2 * j + 1, 2 * j + 1] = -1.0 / M, -1.0
        one = np.concatenate([np.zeros(nv), np.ones(nb)])[None, :]
        A = np.vstack([np.hstack([enc.A, np.zeros((enc.n_constraints, nb))]), np.hstack([Sx, Sb]), one])
        eq = np.concatenate([self._eq_rows, np.zeros(nb, dtype=bool), [True]])
        RtR = res.R.T @ res.R
        d = np.diag(RtR)
        self._u_Js = self._Js if self.norm == "2" else (float(d.max()) if d.max() > 0 else 1.0)
        H0 = np.zeros((nv + nb, nv + nb))
        H0[:nv, :nv] = 2.0 * RtR / self._u_Js
        lb = np.concatenate([enc.lb, np.zeros(nb)])
        ub = np.concatenate([enc.ub, np.ones(nb)])
        disc = np.concatenate([enc.discrete, np.ones(nb, dtype=bool)])
        self._u_lb, self._u_ub, self._u_disc = lb, ub, disc
        # The DAQP package whatever the observer's solver: casadi-daqp's bundled DAQP mishandles
        # equality rows and Bonmin has no cutoff (see the class Notes); the user's options are
        # passed on only when they are DAQP's.  The proximal weight is the smallest of a ladder
        # from MHE_UNIQUENESS_PROX_WEIGHT whose Hessian DAQP factorises (its own factorisation
        # loses ~nv * 1e-16 on the pivots: 1e-13 passes on model 16, 3e-13 is needed with 46
        # variables), with zero_tol a tenth of it so that the smallest pivots count as nonzero.
        # abs_subopt = 0: there is no incumbent to prune against, only the cutoff, and any
        # suboptimality allowance would widen the band of undecided windows.
        self._u_miqp = None
        for w in MHE_UNIQUENESS_PROX_WEIGHT * np.array([1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0]):
            opts = {"zero_tol": 0.1 * w, "abs_subopt": 0.0, **(options if self.solver == "daqp" else {})}
            backend = _DaqpBackend(H0 + 2.0 * w * np.eye(nv + nb), A, lb, ub, disc, eq, opts)
            if backend.probe():
                self._u_miqp, self.uniqueness_prox_weight = backend, float(w)
                self._u_eps = np.full(nv + nb, float(w))
                break
        if self._u_miqp is None:
            raise SolverError("uniqueness MIQP of the MHE observer", "daqp", "Hessian not factorised (exit -5)",
                              hint="check_uniqueness=False (the flag then only means a certified optimum)")
        if self.norm == "2":
            return
        c, A0, lb0, ub0, disc0 = self._milp
        ns = self._nslack
        A = np.vstack([np.hstack([A0, np.zeros((A0.shape[0], nb))]),
                       np.hstack([Sx, np.zeros((nb, ns)), Sb]),
                       np.concatenate([np.zeros(nv + ns), np.ones(nb)])[None, :]])
        c = np.concatenate([c, np.zeros(nb)])
        lb = np.concatenate([lb0, np.zeros(nb)])
        ub = np.concatenate([ub0, np.ones(nb)])
        disc = np.concatenate([disc0, np.ones(nb, dtype=bool)])
        if self.solver == "highs":
            self._u_milp = _HighspyBackend(c, A, lb, ub, disc, options)
        else:
            self._u_milp = _MilpBackend(self.solver.replace("casadi-", ""), c, A, lb, ub, disc, options)

    def _uniqueness(self, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, opt: dict) -> dict:
        """Is the window-start state of the certified optimum ``opt`` unique (to ``delta``, ``epsilon``)?

        Returns a dict with ``status`` ``"unique"`` (no admissible window-start state at least
        ``delta`` away, inf-norm in units of the half-widths of ``X``, has cost ``<= J* +
        epsilon``), ``"alternative"`` (one has: ``alternative`` holds it, verified in numpy) or
        ``"not certified"`` (``reason``); ``decided_by``, ``separated_cost`` (exact cost of the
        alternative found, else ``None``), ``separated_cost_bound`` (a proven lower bound of the
        separated minimum), ``threshold = J* + epsilon`` and ``seconds``.
        """
        t0 = time.perf_counter()
        try:
            out = self._uniqueness_inner(U, Y, xbar, opt)
        except Exception as exc:  # a crashing solver must not stop the observer loop
            out = {"status": "not certified", "reason": f"{type(exc).__name__}: {exc}"}
        out["seconds"] = time.perf_counter() - t0
        return out

    def _separation_rows(self, xi_s: np.ndarray, j: int, sign: int) -> tuple[np.ndarray, np.ndarray]:
        """``sign (xi0_j - xi_s_j) >= delta`` as a row ``G xi0 <= g``."""
        G = np.zeros((1, self.n))
        G[0, j] = -float(sign)
        return G, np.array([-float(sign) * xi_s[j] - self.uniqueness_delta])

    def _alternative(self, x0, modes, U, Y, xbar, W, xi_s) -> dict | None:
        """A verified alternative: a model trajectory from ``x0`` with ``modes`` (and ``W``) that
        satisfies the MLD rows to :data:`MHE_FEASIBILITY_TOL`, is ``delta`` away from the
        optimum's window-start state (to the same tolerance) and has its exact cost; else ``None``."""
        if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(W))):
            return None
        modes = np.asarray(modes, dtype=int)
        states = self._trajectory(x0, modes, U, W)
        if not np.all(np.isfinite(states)):
            return None
        v = self.enc.pack(states, modes, U, W if self.enc.disturbances else None)
        if not (self.enc.violation(v, U.reshape(-1)) <= MHE_FEASIBILITY_TOL):
            return None
        dist = float(np.max(np.abs((x0 - self._cx) / self._hx - xi_s)))
        if not (dist >= self.uniqueness_delta - MHE_FEASIBILITY_TOL):
            return None
        cost = self._cost(states, modes, U, Y, W, xbar)
        if not np.isfinite(cost):
            return None
        return {"x_start": x0.copy(), "cost": cost, "modes": modes.copy(), "states": states, "w": W,
                "distance": dist}

    def _uniqueness_inner(self, U, Y, xbar, opt) -> dict:
        enc, res = self.enc, self._res
        n, nv, nb, T = self.n, enc.n_vars, self._u_nb, self.T
        delta, eps = self.uniqueness_delta, self.uniqueness_epsilon
        J = float(opt["cost"])
        thr = J + eps
        base = {"delta": delta, "epsilon": eps, "threshold": thr, "separated_cost": None, "separated_cost_bound": None}
        xi_s = np.clip((opt["x_start"] - self._cx) / self._hx, self._u_lbx, self._u_ubx)
        allowed = np.zeros(nb, dtype=bool)
        allowed[0::2] = xi_s + delta <= self._u_ubx
        allowed[1::2] = xi_s - delta >= self._u_lbx
        if not allowed.any():
            return {**base, "status": "unique", "decided_by": "box (no state of X is delta away)",
                    "separated_cost_bound": np.inf}
        # 1. a cheap sufficient test for an alternative (it can never prove uniqueness, which
        #    needs every mode sequence): when the optimal sequence's own least-squares map has a
        #    direction whose cost over delta stays below epsilon (the backlash of model (16)),
        #    one QP per admissible direction along it, with that sequence's guards
        cands: list[dict] = []
        prob = self._sequence_problem(opt["modes"], U, Y, xbar)
        _, sv, Vt = np.linalg.svd(prob[0], full_matrices=True)
        sv = np.concatenate([sv, np.zeros(Vt.shape[0] - sv.size)])
        weak = sv * delta <= np.sqrt(self._u_eps2)
        if weak.any():
            reach = np.max(np.abs(Vt[weak][:, :n]), axis=0)
            order = [k for k in np.argsort(-np.repeat(reach, 2), kind="stable") if allowed[k] and reach[k // 2] > 0]
            for k in order:
                j, sign = int(k // 2), (1 if k % 2 == 0 else -1)
                pol = self._polish(opt["modes"], U, Y, xbar, opt["x_start"], opt["w"],
                                   extra=self._separation_rows(xi_s, j, sign), problem=prob, bound=True)
                alt = None if pol is None else self._alternative(pol[0], opt["modes"], U, Y, xbar, pol[1], xi_s)
                if alt is not None:
                    cands.append(alt)
                    if alt["cost"] <= thr:
                        return {**base, "status": "alternative", "decided_by": "optimal mode sequence",
                                "separated_cost": alt["cost"], "alternative": alt}
        # 2. the separated mixed-integer programs over every mode sequence
        Uf, Yf = U.reshape(-1), Y.reshape(-1)
        lo, hi = enc.bounds(Uf)
        rp = res.offset(Yf, Uf, xbar)
        M = self._u_M
        sep_lo = np.empty(nb)
        sep_lo[0::2] = (xi_s + delta - M) / M
        sep_lo[1::2] = (-xi_s + delta - M) / M
        vstar = enc.pack(opt["states"], opt["modes"], U, opt["w"] if enc.disturbances else None)
        detail: dict = {}
        # 2a. the norm-2 MIQP with a cutoff: for norm 2 the decision; for norms 1 / inf a bound,
        #     since J_1 >= ||r||_2 and J_inf >= ||r||_inf >= ||r||_2 / sqrt(N) (N residual
        #     entries): no separated point with ||r||_2^2 <= thr2 proves J > thr
        nres = res.R.shape[0]
        thr2 = thr if self.norm == "2" else (thr**2 if self.norm == "1" else nres * thr**2)
        lo_u = np.concatenate([lo, sep_lo, [1.0]])
        hi_u = np.concatenate([hi, np.full(nb, np.inf), [1.0]])
        rstar = res.R @ vstar + rp
        Jv = float(rstar @ rstar)
        Js = self._u_Js
        f = np.concatenate([2.0 * res.R.T @ rstar / Js, np.zeros(nb)])
        wbar = np.concatenate([vstar, np.zeros(nb)])
        ub0 = self._u_ub.copy()
        ub0[nv:][~allowed] = 0.0
        cont = ~self._u_disc
        sub = float(self._u_miqp._settings.get("abs_subopt", 0.0))
        dstart, s_modes = enc.slices["delta"].start, self.system.n_modes
        # The proximal term biases the cutoff test by at most its largest value at an integral
        # point (below), so a returned point may cost a little more than thr.  For norm 2 such a
        # point's mode sequence and direction (a "combination") are then excluded *exactly* by
        # the QP of that combination (its minimum is the polished cost, > thr), and the rest is
        # searched again by bounds only, in T + 1 disjoint parts: the other directions, and for
        # k = 0 .. T-1 this direction with the sequence's modes before step k and another mode
        # at step k.
        stack, solves, why, decided = [ub0], 0, None, True
        while stack:
            ub = stack.pop()
            if solves >= UNIQUENESS_MAX_SOLVES:
                why, decided = f"no decision within {UNIQUENESS_MAX_SOLVES} solves of the separated MIQP", False
                break
            # largest proximal term at an integral point of the box: the continuous variables'
            # box ranges around the centre, two binaries per step for the modes (the centre is
            # one-hot) and one direction binary (the centre is zero)
            span = np.maximum((self._u_lb[cont] - wbar[cont]) ** 2, (ub[cont] - wbar[cont]) ** 2)
            bias = float(self._u_eps[cont] @ span)
            bias += float(self.uniqueness_prox_weight * (2 * T + 1))
            out = self._u_miqp.solve(f, lo_u, hi_u, wbar, cutoff=(thr2 - Jv) / Js + bias + sub, ub=ub)
            solves += 1
            detail.update({f"solver_{k}": v for k, v in out.detail.items()})
            if out.status == "infeasible":
                # every node was pruned: each separated point of this part has J2 / Js + prox >
                # cutoff, hence J2 > thr2
                continue
            if out.status != "optimal":
                why, decided = f"solver status {out.detail.get('status')!r}", False
                break
            alt, why, combo, lower = self._verified_separated(out.v, U, Y, xbar, xi_s, allowed, lo, hi, polish=True)
            if alt is not None:
                cands.append(alt)
            if alt is None or alt["cost"] <= thr or self.norm != "2" or lower is None or not lower > thr:
                decided = False
                break
            modes, kd = combo
            if np.any(ub[nv:][np.arange(nb) != kd] > 0):
                child = ub.copy()
                child[nv + kd] = 0.0
                stack.append(child)
            for k in range(T):
                # disjoint parts: the sequence's modes up to step k - 1, another mode at step k
                child = ub.copy()
                child[nv:] = 0.0
                child[nv + kd] = 1.0
                for j in range(k):
                    keep = child[dstart + j * s_modes + int(modes[j])]
                    child[dstart + j * s_modes: dstart + (j + 1) * s_modes] = 0.0
                    child[dstart + j * s_modes + int(modes[j])] = keep
                child[dstart + k * s_modes + int(modes[k])] = 0.0
                stack.append(child)
        detail["solver_solves"] = solves
        if decided:
            by = "branch-and-bound" if self.norm == "2" else "norm-2 bound (MIQP)"
            return {**base, **detail, "status": "unique", "decided_by": by, "separated_cost_bound": thr,
                    "separated_cost": min((c["cost"] for c in cands), default=None)}
        if self.norm != "2" and not any(c["cost"] <= thr for c in cands):
            # 2b. norms 1 / inf: the MILP decides
            rps = rp / self._Js
            lo_m = np.concatenate([lo, np.full(2 * nres, -np.inf), sep_lo, [1.0]])
            hi_m = np.concatenate([hi, -rps, rps, np.full(nb, np.inf), [1.0]])
            ncol = nv + self._nslack
            bound = thr / self._Js
            if self.solver == "highs":
                out = self._u_milp.solve(lo_m, hi_m, cutoff=bound, target=bound,
                                         col_bounds=(ncol + np.arange(nb), np.zeros(nb), allowed.astype(float)))
            else:
                out = self._u_milp.solve(lo_m, hi_m)
            detail = {**detail, **{f"milp_{k}": v for k, v in out.detail.items()}}
            if out.status == "infeasible":
                return {**base, **detail, "status": "unique", "decided_by": "branch-and-bound",
                        "separated_cost_bound": thr}
            if out.status in ("optimal", "feasible"):
                alt, why, _, _ = self._verified_separated(np.concatenate([out.v[:nv], out.v[ncol:]]), U, Y, xbar,
                                                          xi_s, allowed, lo, hi, polish=False)
                if alt is not None:
                    cands.append(alt)
                if out.status == "optimal" and not any(c["cost"] <= thr for c in cands):
                    # a MILP optimum (zero gap, no proximal bias): its bound is the separated
                    # minimum (HiGHS's dual bound, else its optimal objective)
                    lb = self._Js * float(out.detail.get("dual_bound", out.detail.get("objective", -np.inf)))
                    if lb > thr:
                        return {**base, **detail, "status": "unique", "decided_by": "branch-and-bound",
                                "separated_cost": min((c["cost"] for c in cands), default=None),
                                "separated_cost_bound": lb}
            else:
                why = f"MILP status {out.detail.get('status')!r}"
        if cands:
            alt = min(cands, key=lambda c: c["cost"])
            base["separated_cost"] = alt["cost"]
            if alt["cost"] <= thr:
                if alt["cost"] < J - max(opt.get("gap_bound", 0.0), 0.0) - eps:
                    return {**base, **detail, "status": "not certified",
                            "reason": "a separated state beats the certified optimum (optimum not global)"}
                return {**base, **detail, "status": "alternative", "decided_by": "branch-and-bound", "alternative": alt}
        return {**base, **detail, "status": "not certified",
                "reason": why or "separated minimum within the solver's accuracy of J* + epsilon"}

    def _verified_separated(self, w, U, Y, xbar, xi_s, allowed, lo, hi, polish: bool) -> tuple:
        """Check a solver's point ``w = [v; b]`` of the separated program before trusting it.

        Finite, every MLD row within :data:`MHE_FEASIBILITY_TOL`, integral binaries (one mode per
        step, one admissible direction), the chosen separation row satisfied; then the model
        trajectory of its window-start state and modes (and, with ``polish``, the exact QP of
        that sequence and direction), verified by :meth:`_alternative`.  Returns
        ``(alternative or None, reason or None, (modes, direction index) or None, bound)``,
        ``bound`` a proven lower bound of the least cost over that sequence and direction (from
        the exact QP, :meth:`_polish` with ``bound=True``) or ``None``.
        """
        enc, T, nv = self.enc, self.T, self.enc.n_vars
        v, b = w[:nv], w[nv:]
        if not np.all(np.isfinite(w)):
            return None, "separated solution with NaN/Inf", None, None
        viol = enc.violation(v, U.reshape(-1), bounds=(lo, hi))
        bviol = float(np.max(np.abs(b - np.round(b))))
        if not (viol <= max(MHE_FEASIBILITY_TOL, MHE_INTEGRALITY_TOL) and bviol <= MHE_INTEGRALITY_TOL):
            return None, f"separated solution failed verification (violation {max(viol, bviol):.3g})", None, None
        v = v.copy()
        v[enc.discrete] = np.round(v[enc.discrete])
        b = np.round(b)
        if not ((v[enc.discrete].reshape(T, -1).sum(axis=1) == 1).all() and b.sum() == 1 and allowed[b == 1].all()):
            return None, "separated solution: binaries not one-hot", None, None
        k = int(np.argmax(b))
        j, sign = k // 2, (1 if k % 2 == 0 else -1)
        if not (sign * (v[enc.slices["xi0"]][j] - xi_s[j]) >= self.uniqueness_delta - MHE_FEASIBILITY_TOL):
            return None, "separated solution is not delta away", None, None
        modes = enc.modes(v)
        x0, W = enc.states(v)[0], enc.disturbance(v)
        cands = [self._alternative(x0, modes, U, Y, xbar, W, xi_s)]
        exact = None
        if polish:
            # the solver's point carries the (tiny) proximal bias: the exact QP of its sequence
            # and direction, with a lower bound of its minimum proven from the multipliers
            pol = self._polish(modes, U, Y, xbar, x0, W, extra=self._separation_rows(xi_s, j, sign), bound=True)
            if pol is not None:
                cands.append(self._alternative(pol[0], modes, U, Y, xbar, pol[1], xi_s))
                exact = pol[3]
        cands = [c for c in cands if c is not None]
        if not cands:
            return None, "separated solution: no verified model trajectory", (modes, k), exact
        return min(cands, key=lambda c: c["cost"]), None, (modes, k), exact

    def _decide(self, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, info: dict) -> str:
        """Flag of a certified optimum ``info``: the analysis's point query, else the separated program."""
        if self.analysis is not None:
            t0 = time.perf_counter()
            try:
                label = str(self.analysis.classify(info["x_start"]))
            except Exception as exc:  # an LP failure must not stop the observer loop
                label = f"failed ({type(exc).__name__}: {exc})"
            info["analysis_label"] = label
            if label in (OBSERVABLE, UNOBSERVABLE):
                info["uniqueness"] = {"status": "unique" if label == OBSERVABLE else "not unique for every input",
                                      "decided_by": "analysis (Definition 2.2, every input sequence)",
                                      "seconds": time.perf_counter() - t0}
                return label
        if not self.check_uniqueness:
            if self.analysis is not None:
                info["reason"] = f"analysis label {info['analysis_label']!r} at the estimate and check_uniqueness=False"
                return FALLBACK
            return OBSERVABLE
        uq = self._uniqueness(U, Y, xbar, info)
        if uq["status"] == "alternative":
            info["alternative"] = uq.pop("alternative")
        info["uniqueness"] = uq
        if uq["status"] == "unique":
            return OBSERVABLE
        if uq["status"] == "alternative":
            return UNOBSERVABLE
        info["reason"] = f"uniqueness not certified: {uq.get('reason', '?')}"
        return FALLBACK

    # ------------------------------------------------------------------ runtime
    def _in_U(self, U: np.ndarray) -> bool:
        return self._U_A is None or bool((U @ self._U_A.T <= self._U_b).all())

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        x_pred, q_pred, ok_pred = self._open_loop(self._u_prev) if self._count > 0 else (self._x, self._mode, True)
        self._Y[:-1] = self._Y[1:]
        self._Y[-1] = y
        self._U[:-1] = self._U[1:]
        self._U[-1] = u
        self._count += 1
        self._u_prev = u
        if self._count < self.T:
            self._x, self._mode = x_pred, q_pred
            return Estimate(self._x.copy(), self._mode, WARMING_UP, 0.0, {"certified_optimum": False})
        # warm start: the previous window's trajectory shifted by one sample (or, for the first
        # window after a reset, the model simulated from the initial guess)
        if self._prev is not None:
            Xg, mg = self._shifted(self._U)
        else:
            Xg, mg = self._simulate(self._start, self._U)
        if not self._in_U(self._U):
            info = {"status": "not certified", "reason": "input outside U: the big-M constants do not hold there"}
        else:
            info = self._solve(self._U, self._Y, Xg[0], Xg, mg, cold=self._prev is None)
        info["certified_optimum"] = info["status"] == "optimal"
        if info["status"] == "optimal":
            states, modes = info["states"], info["modes"]
            # the optimum fits the data whatever the flag: it warm-starts the next window
            self._prev = (states, modes, self._U[-1].copy())
            flag = self._decide(self._U, self._Y, Xg[0], info)
            if flag == OBSERVABLE:
                self._x, self._mode = states[-1].copy(), int(modes[-1])
                return Estimate(self._x.copy(), self._mode, OBSERVABLE, 0.0, info)
            # not unique (or not certified unique): open-loop prediction
            self._x, self._mode = x_pred, q_pred
            return Estimate(self._x.copy(), self._mode, flag, 0.0, info)
        # no estimate from the data: the warm start (open-loop prediction) carries on
        self._prev = (Xg, mg, self._U[-1].copy())
        self._x, self._mode = x_pred, q_pred
        flag = UNOBSERVABLE if info["status"] == "infeasible" else FALLBACK
        return Estimate(self._x.copy(), self._mode, flag, 0.0, info)

    def _fallback(self, u, reason: str) -> Estimate:
        x_pred, q_pred, _ = self._open_loop(self._u_prev) if self._count > 0 else (self._x, self._mode, True)
        self._x, self._mode = x_pred, q_pred
        # a skipped sample breaks the window: gather T new consecutive samples, starting from the
        # open-loop prediction of the next state
        self._u_prev = u
        self._count = 0
        self._prev = None
        nxt, _, ok = self._open_loop(u)
        self._start = nxt.copy() if ok else self._x.copy()
        return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, {"reason": reason, "certified_optimum": False})


def _same_pwa(a, b) -> bool:
    """Whether two PWA systems have the same modes, guards and bounds (array for array)."""
    if a is b:
        return True
    if not (isinstance(a, PWASystem) and isinstance(b, PWASystem)) or a.n_modes != b.n_modes:
        return False
    if (a.n, a.m, a.p) != (b.n, b.m, b.p):
        return False

    def same(x, y) -> bool:
        return np.shape(x) == np.shape(y) and np.array_equal(x, y)

    for ma, mb in zip(a.modes, b.modes):
        if not all(same(getattr(ma, k), getattr(mb, k)) for k in ("A", "B", "a", "C", "D", "c")):
            return False
        if not (same(ma.guard.A, mb.guard.A) and same(ma.guard.b, mb.guard.b)):
            return False
    for Pa, Pb in ((a.state_bounds, b.state_bounds), (a.input_bounds, b.input_bounds)):
        if (Pa is None) != (Pb is None) or (Pa is not None and not (same(Pa.A, Pb.A) and same(Pa.b, Pb.b))):
            return False
    return True

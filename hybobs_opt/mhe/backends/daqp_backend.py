"""DAQP's branch-and-bound on a persistent workspace (the default MIQP solver of eq. (10), norm 2).

The ``daqp`` package's :class:`daqp.Model` is set up once with the Hessian of the MIQP (factorised
at setup) and re-solved each window with a new linear term and new bounds (paper 002, eq. 10;
Bemporad, Ferrari-Trecate & Morari, 2000).  Exit flags go through
:data:`hybobs_opt.status.DAQP_STATUS`.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.linalg import solve_triangular

from ...status import DAQP_EXIT_FLAGS, DAQP_STATUS, Status, map_status
from ...defaults import MHE_DAQP_CYCLE_TOL
from ...tolerances import MHE_ABS_SUBOPT
from .base import BackendOutcome, with_col_bounds

__all__ = ["DaqpBackend", "DAQP_INF", "daqp_flag"]

#: DAQP's value for an infinite bound.
DAQP_INF = 1e30
_BINARY, _EQUALITY = 16, 5  # DAQP's sense flags
_RETRY_FLAGS = (DAQP_EXIT_FLAGS["CYCLE"], DAQP_EXIT_FLAGS["ITERLIMIT"])


def daqp_flag(raw) -> Status:
    """A DAQP exit flag (``daqp.solve``, ``Model.solve``, ``Model.setup``) in the one vocabulary.

    Parameters
    ----------
    raw : int or tuple
        DAQP's exit flag, or a tuple whose first item is it.

    Returns
    -------
    Status
        ``OPTIMAL``, ``INFEASIBLE``, ``LIMIT`` ... of :mod:`hybobs_opt.status`.

    See Also
    --------
    DaqpBackend : Maps every answer with it.

    Examples
    --------
    >>> from hybobs_opt.mhe.backends import daqp_flag
    >>> daqp_flag(1), daqp_flag(-1)
    ('optimal', 'infeasible')
    >>> daqp_flag((1, "solution"))
    'optimal'
    """
    return map_status(DAQP_STATUS, int(raw[0] if isinstance(raw, tuple) else raw), solver="daqp")


class DaqpBackend:
    """DAQP's branch-and-bound on a persistent workspace (H factorised once at setup).

    Parameters
    ----------
    H : (nv, nv) array
        Positive definite Hessian (the proximal term makes it so).
    A : (nr, nv) array
        Rows ``lo <= A v <= hi``.
    lb, ub : (nv,) arrays
        Variable bounds.
    discrete : (nv,) bool array
        Binary variables.
    eq_rows : (nr,) bool array
        Equality rows (one mode per step).
    options : dict
        DAQP settings; they override ``abs_subopt = MHE_ABS_SUBOPT``, ``eps_prox = 0`` and
        ``cycle_tol = MHE_DAQP_CYCLE_TOL``.

    See Also
    --------
    miqp_backend : Returns one for ``"daqp"``.
    daqp_flag : Its exit flags.

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
    >>> from hybobs_opt.mhe.backends import DaqpBackend
    >>> backend = DaqpBackend(H, A, lb, ub, discrete, np.array([False]), {})
    >>> out = backend.solve(f, lo, hi)
    >>> out.status, np.round(out.v, 6)
    ('optimal', array([1.3, 1. ]))

    Re-solved with another linear term, no new setup:

    >>> np.round(backend.solve(np.array([-0.2, 0.0]), lo, hi).v, 6)
    array([0.2, 0. ])
    """

    name = "daqp"
    cutoff_applied = True

    def __init__(self, H, A, lb, ub, discrete, eq_rows, options: dict):
        import daqp

        self._nv = H.shape[0]
        sense = np.zeros(self._nv + A.shape[0], dtype=np.int32)
        sense[: self._nv][discrete] = _BINARY
        sense[self._nv:][eq_rows] = _EQUALITY
        self._sense = sense
        self._lb, self._ub = np.maximum(lb, -DAQP_INF), np.minimum(ub, DAQP_INF)
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

    def set_hessian(self, H: np.ndarray) -> None:
        """Replace the Hessian (same size, positive definite) for the coming solves.

        DAQP's workspace is updated in place (``Model.update(H=...)`` refactorises it; the
        working set of the previous solve is kept as a warm start): the problem is not rebuilt.
        Used by a time-varying arrival cost (:class:`~hybobs_opt.mhe.arrival.KalmanArrival`).

        Parameters
        ----------
        H : (nv, nv) ndarray
            The new Hessian.
        """
        H = np.ascontiguousarray(H, dtype=float)
        if H.shape != self._H.shape:
            raise ValueError(f"Hessian of shape {H.shape}, expected {self._H.shape}")
        self._H = H
        # the cutoff's L^-1 f is then a triangular solve per use (an explicit inverse per update
        # cost 6 ms of a 30 ms step on the uniqueness MIQP)
        self._L = np.linalg.cholesky(H)
        self._Linv = None
        if self._ready:
            self._model.update(H=self._H)

    @property
    def abs_subopt(self) -> float:
        return float(self._settings.get("abs_subopt", 0.0))

    def probe(self) -> bool:
        """Set the workspace up now (zero linear term, the variable bounds); ``False`` if DAQP
        refuses the Hessian (exit -5: its factorisation does not find it positive definite).

        Returns
        -------
        bool
            ``False`` if DAQP refuses the Hessian (exit -5), else ``True``.
        """
        import daqp

        nr = self._A.shape[0]
        self._model.settings = self._settings
        flag = self._model.setup(self._H, np.zeros(self._nv), self._A,
                                 np.concatenate([self._ub, np.full(nr, DAQP_INF)]),
                                 np.concatenate([self._lb, np.full(nr, -DAQP_INF)]), self._sense)
        flag = flag[0] if isinstance(flag, tuple) else flag
        if flag < 0:
            self._model = daqp.Model()
            return False
        self._model.settings = self._settings
        self._ready = True
        return True

    def solve(self, f, lo, hi, centre=None, *, cutoff: float | None = None, target: float | None = None,
              start: np.ndarray | None = None, col_bounds: tuple | None = None) -> BackendOutcome:
        """Solve in the displacement ``d = v - centre`` from the warm start.

        ``f`` is the linear term of the objective in ``d`` (``H centre + g``) and ``cutoff`` an
        upper bound of ``0.5 d'Hd + f'd`` (an incumbent's value).  Working relative to the warm
        start keeps the objective values near zero: in absolute form they sit on a constant of
        the order of the output energy, and cost differences of 1e-10 between mode sequences
        drown in the rounding of the active-set updates.  ``col_bounds = (index, lower, upper)``
        replaces some variable bounds for this solve (e.g. to fix binaries to zero); ``target``
        and ``start`` are not DAQP's (the centre is its warm start).

        Parameters
        ----------
        f : (nv,) ndarray or None
            Linear term of the objective in ``d = v - centre`` (``H centre + g``).
        lo, hi : (nr,) ndarray
            Row bounds of ``lo <= A v <= hi``.
        centre : (nv,) ndarray, optional
            Warm start the displacement is measured from; ``None`` means zeros.
        cutoff : float, optional
            Upper bound of ``0.5 d'Hd + f'd``; nodes that cannot beat it are pruned.
        target : float, optional
            Not used by DAQP.
        start : (nv,) ndarray, optional
            Not used by DAQP (``centre`` is its warm start).
        col_bounds : (index, lower, upper), optional
            Column bounds for this solve only (the backend's own bounds are kept).

        Returns
        -------
        BackendOutcome
            The status, the solver's point (when optimal or feasible) and its raw answer.
        """
        t0 = time.perf_counter()
        centre = np.zeros(self._nv) if centre is None else centre
        lbv, ubv = with_col_bounds(self._lb, self._ub, col_bounds, DAQP_INF)
        bu = np.concatenate([ubv - centre, np.minimum(hi - self._A @ centre, DAQP_INF)])
        bl = np.concatenate([lbv - centre, np.maximum(lo - self._A @ centre, -DAQP_INF)])
        warm = self._ready
        if not self._ready:
            # the settings go in before the setup too: the factorisation of H at setup uses
            # zero_tol (pivots below it count as singular) and, without eps_prox = 0, DAQP would
            # silently switch a nearly singular H to proximal iterations
            self._model.settings = self._settings
            flag = self._model.setup(self._H, f, self._A, bu, bl, self._sense)
            flag = flag[0] if isinstance(flag, tuple) else flag
            if flag < 0:
                return BackendOutcome(Status.NOT_CERTIFIED, None, {"status": f"daqp setup failed ({flag})"},
                                      daqp_flag(flag), time.perf_counter() - t0)
            self._model.settings = self._settings
            self._ready = True
        else:
            # the sense flags are not passed: DAQP then reuses the previous solve's working set
            self._model.update(f=f, bupper=bu, blower=bl)
        # an incumbent prunes every node that cannot beat it: DAQP bounds the objective of its
        # least-distance form 0.5 ||u||^2, which is the QP objective plus 0.5 f' H^-1 f
        bound = DAQP_INF
        if cutoff is not None:
            w = self._Linv @ f if self._Linv is not None else solve_triangular(self._L, f, lower=True,
                                                                                check_finite=False)
            bound = float(cutoff + 0.5 * w @ w)
        self._model.settings = {"fval_bound": bound}
        x, fval, flag, info = self._model.solve()
        detail = {"status": int(flag), "nodes": int(info.get("nodes", -1)), "iterations": int(info.get("iterations", -1))}
        mapped = daqp_flag(flag)
        if int(flag) in _RETRY_FLAGS and warm:
            # cycling or an iteration limit: the state kept from the previous solves can lead the
            # active-set iterations into a cycle (seen on the ill-conditioned uniqueness MIQP,
            # 1 window in 40 of 4-mode systems; an update with the sense flags does not clear it):
            # once more on a workspace set up afresh, the only case where the workspace is rebuilt
            self._model = type(self._model)()
            self._model.settings = self._settings
            setup = self._model.setup(self._H, f, self._A, bu, bl, self._sense)
            if (setup[0] if isinstance(setup, tuple) else setup) < 0:
                self._ready = False
                return BackendOutcome(Status.NOT_CERTIFIED, None, {**detail, "status": f"daqp setup failed ({setup})"},
                                      daqp_flag(setup), time.perf_counter() - t0)
            self._model.settings = {**self._settings, "fval_bound": bound}
            x, fval, flag, info = self._model.solve()
            detail = {"status": int(flag), "nodes": int(info.get("nodes", -1)),
                      "iterations": int(info.get("iterations", -1)), "cold_retry": True}
            mapped = daqp_flag(flag)
        if mapped == Status.OPTIMAL:
            x = np.array(x, dtype=float)
            lam = np.asarray(info.get("lam", ()), dtype=float)
            if not (np.all(np.isfinite(x)) and np.isfinite(fval) and np.all(np.isfinite(lam))):
                detail["status"] = f"{int(flag)} with a NaN/Inf point, objective or multiplier"
                return BackendOutcome(Status.NOT_CERTIFIED, None, detail, mapped, time.perf_counter() - t0)
            return BackendOutcome(Status.OPTIMAL, centre + x, detail, mapped, time.perf_counter() - t0)
        if mapped == Status.INFEASIBLE:
            return BackendOutcome(Status.INFEASIBLE, None, detail, mapped, time.perf_counter() - t0)
        return BackendOutcome(Status.NOT_CERTIFIED, None, detail, mapped, time.perf_counter() - t0)

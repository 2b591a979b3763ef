"""The CasADi backends of eq. (10), paper 002: ``casadi-daqp`` and ``bonmin`` (norm 2, MIQP),
``cbc`` and ``casadi-highs`` (norms 1 / inf, MILP).

Each is a CasADi function built once (``conic`` with ``discrete`` variables, or ``nlpsol``) and
called with the window's linear term and bounds.  None of them takes a cutoff
(:attr:`~hybobs_opt.mhe.backends.base.Backend.cutoff_applied` is false).  Their statuses go
through :data:`~hybobs_opt.status.DAQP_STATUS`, :data:`~hybobs_opt.status.CASADI_BONMIN_STATUS`,
:data:`~hybobs_opt.status.CASADI_CBC_STATUS` and :data:`~hybobs_opt.status.CASADI_HIGHS_STATUS`.
"""

from __future__ import annotations

import time

import numpy as np

from ..._native_output import captured_native_output
from ...status import CASADI_BONMIN_STATUS, CASADI_CBC_STATUS, CASADI_HIGHS_STATUS, DAQP_STATUS, Status, map_status
from ..mld import MLDEncoding
from .base import BackendOutcome, quiet_stdout, with_col_bounds
from .highs_backend import HIGHS_BASE_OPTIONS

__all__ = ["CasadiDaqpBackend", "BonminBackend", "CasadiMilpBackend"]


def _outcome(mapped: Status, x: np.ndarray | None, detail: dict, t0: float) -> BackendOutcome:
    if mapped == Status.OPTIMAL and x is not None and np.all(np.isfinite(x)):
        return BackendOutcome(Status.OPTIMAL, x, detail, mapped, time.perf_counter() - t0)
    if mapped == Status.INFEASIBLE:
        return BackendOutcome(Status.INFEASIBLE, None, detail, mapped, time.perf_counter() - t0)
    return BackendOutcome(Status.NOT_CERTIFIED, None, detail, mapped, time.perf_counter() - t0)


class CasadiDaqpBackend:
    """DAQP through CasADi's ``conic`` plugin with ``discrete`` variables.

    CasADi 3.8.2 bundles an older DAQP whose branch-and-bound returns NaN (with "success") when
    equality rows are present, so the one-hot rows ``sum_i delta[k, i] = 1`` are eliminated
    (``delta[k, s-1] = 1 - sum_{i < s-1} delta[k, i]``, with ``sum_{i < s-1} delta[k, i] <= 1``).

    Parameters
    ----------
    H : (nv, nv) array
        Positive definite Hessian.
    A : (nr, nv) array
        Rows ``lo <= A v <= hi``.
    lb, ub : (nv,) arrays
        Variable bounds.
    discrete : (nv,) bool array
        Binary variables.
    enc : MLDEncoding
        The encoding the program comes from (locates the mode binaries ``delta``).
    eq_rows : (nr,) bool array
        Equality rows (the one-hot rows, eliminated as above).
    options : dict
        DAQP settings passed to CasADi's plugin.

    See Also
    --------
    miqp_backend : Returns one for ``"casadi-daqp"``.
    DaqpBackend : DAQP through its own package (the default).

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver
    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((3, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> res = MHEObserver(plant, 3, solver="casadi-daqp").solve_window(U, truth.y)
    >>> res.status, res.solver, bool(np.allclose(res.states, truth.x, atol=1e-6))
    ('optimal', 'casadi-daqp', True)
    """

    name = "casadi-daqp"
    cutoff_applied = False
    abs_subopt = 0.0

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
        with captured_native_output("casadi conic 'daqp'"):
            self._solver = ca.conic("mhe_daqp", "daqp", {"h": self._Hdm.sparsity(), "a": self._Aw.sparsity()}, opts)

    def solve(self, f, lo, hi, centre=None, *, cutoff: float | None = None, target: float | None = None,
              start: np.ndarray | None = None, col_bounds: tuple | None = None) -> BackendOutcome:
        """The MIQP with linear term ``f`` in the displacement from ``centre`` (as
        :meth:`~hybobs_opt.mhe.backends.daqp_backend.DaqpBackend.solve`); ``cutoff`` is ignored.

        Parameters
        ----------
        f : (nv,) ndarray or None
            Linear term of the objective in the displacement from ``centre``.
        lo, hi : (nr,) ndarray
            Row bounds of ``lo <= A v <= hi`` (the equality rows are eliminated).
        centre : (nv,) ndarray, optional
            Warm start the displacement is measured from; ``None`` means zeros.
        cutoff : float, optional
            Ignored.
        target : float, optional
            Ignored.
        start : (nv,) ndarray, optional
            Ignored.
        col_bounds : (index, lower, upper), optional
            Not supported: must be ``None`` (``NotImplementedError``).

        Returns
        -------
        BackendOutcome
            The status, the solver's point (when optimal or feasible) and its raw answer.
        """
        t0 = time.perf_counter()
        centre = np.zeros(self._H.shape[0]) if centre is None else centre
        g = f - self._H @ centre  # back from the displacement form
        gw = self._P.T @ (g + self._H @ self._p0)
        lo_w = np.concatenate([lo[self._ineq] - self._a0, np.full(self._extra, -np.inf)])
        hi_w = np.concatenate([hi[self._ineq] - self._a0, np.ones(self._extra)])
        lbw, ubw = self._lbw, self._ubw
        if col_bounds is not None:
            raise NotImplementedError("col_bounds on casadi-daqp (its variables are the reduced ones)")
        with quiet_stdout():
            r = self._solver(h=self._Hdm, g=gw, a=self._Aw, lba=lo_w, uba=hi_w, lbx=lbw, ubx=ubw)
        st = self._solver.stats()
        raw = st.get("return_status", 0)
        detail = {"status": int(raw), "nodes": int(st.get("bnb_nodecount", -1))}
        w = np.array(r["x"], dtype=float).reshape(-1)
        mapped = map_status(DAQP_STATUS, int(raw), solver="casadi-daqp")
        return _outcome(mapped, self._P @ w + self._p0 if np.all(np.isfinite(w)) else None, detail, t0)


class BonminBackend:
    """Bonmin (CasADi ``nlpsol``) on the same MIQP; the linear term is the NLP parameter.

    Parameters
    ----------
    H : (nv, nv) array
        Hessian of the MIQP.
    A : (nr, nv) array
        Rows ``lo <= A v <= hi``.
    lb, ub : (nv,) arrays
        Variable bounds.
    discrete : (nv,) bool array
        Binary variables.
    options : dict
        Bonmin options; they override the quiet log levels.

    See Also
    --------
    miqp_backend : Returns one for ``"bonmin"``.
    DaqpBackend : The default MIQP solver.

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
    >>> from hybobs_opt.mhe.backends import BonminBackend
    >>> out = BonminBackend(H, A, lb, ub, discrete, {}).solve(f, lo, hi)
    >>> out.status, np.round(out.v, 4)
    ('optimal', array([1.3, 1. ]))
    """

    name = "bonmin"
    cutoff_applied = False
    abs_subopt = 0.0

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
        with captured_native_output("casadi nlpsol 'bonmin'"):
            self._solver = ca.nlpsol("mhe_bonmin", "bonmin", {"x": x, "p": gp, "f": f, "g": con}, opts)
        self._lb, self._ub, self._H = lb, ub, H

    def solve(self, f, lo, hi, centre=None, *, cutoff: float | None = None, target: float | None = None,
              start: np.ndarray | None = None, col_bounds: tuple | None = None) -> BackendOutcome:
        """The MIQP with linear term ``f`` in the displacement from ``centre``; ``cutoff`` is ignored.

        Parameters
        ----------
        f : (nv,) ndarray or None
            Linear term of the objective in the displacement from ``centre``.
        lo, hi : (nr,) ndarray
            Row bounds of ``lo <= A v <= hi``.
        centre : (nv,) ndarray, optional
            Warm start (also Bonmin's initial point, clipped to the bounds); ``None`` means zeros.
        cutoff : float, optional
            Ignored.
        target : float, optional
            Ignored.
        start : (nv,) ndarray, optional
            Ignored.
        col_bounds : (index, lower, upper), optional
            Column bounds for this solve only (the backend's own bounds are kept).

        Returns
        -------
        BackendOutcome
            The status, the solver's point (when optimal or feasible) and its raw answer.
        """
        t0 = time.perf_counter()
        centre = np.zeros(self._H.shape[0]) if centre is None else centre
        g = f - self._H @ centre  # back from the displacement form
        lb, ub = with_col_bounds(self._lb, self._ub, col_bounds)
        with quiet_stdout():
            r = self._solver(x0=np.clip(centre, lb, ub), p=g, lbg=lo, ubg=hi, lbx=lb, ubx=ub)
        raw = str(self._solver.stats().get("return_status", ""))
        mapped = map_status(CASADI_BONMIN_STATUS, raw, solver="bonmin")
        return _outcome(mapped, np.array(r["x"], dtype=float).reshape(-1), {"status": raw}, t0)


class CasadiMilpBackend:
    """CBC or HiGHS through CasADi's ``conic`` with ``discrete`` variables (norms 1 and inf).

    ``"casadi-highs"`` cannot share a process with the ``highspy`` package (see
    :class:`~hybobs_opt.mhe.backends.highs_backend.HighspyBackend`); the observer refuses it when
    highspy is already imported.

    Parameters
    ----------
    plugin : {"cbc", "highs"}
        CasADi's plugin name.
    c, A, lb, ub, discrete, options
        As for :class:`~hybobs_opt.mhe.backends.highs_backend.HighspyBackend`.

    See Also
    --------
    milp_backend : Returns one for ``"cbc"`` and ``"casadi-highs"``.
    HighspyBackend : HiGHS through highspy (the default).

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
    >>> from hybobs_opt.mhe.backends import CasadiMilpBackend
    >>> out = CasadiMilpBackend("cbc", c, A, lb, ub, discrete, {}).solve(None, lo, hi)
    >>> out.status, np.round(out.v, 6)
    ('optimal', array([0.5, 1. ]))
    """

    cutoff_applied = False
    abs_subopt = 0.0

    def __init__(self, plugin: str, c, A, lb, ub, discrete, options: dict):
        import casadi as ca

        self.name = plugin
        self._A = ca.sparsify(ca.DM(A))
        nx = A.shape[1]
        if plugin == "highs":
            opts = {"discrete": [bool(d) for d in discrete], "error_on_fail": False,
                    "highs": {**HIGHS_BASE_OPTIONS, **options}}
        else:
            base = {"loglevel": 0, "allowableGap": 0.0, "ratioGap": 0.0}
            opts = {"discrete": [bool(d) for d in discrete], "error_on_fail": False, "cbc": {**base, **options}}
        with captured_native_output(f"casadi conic {plugin!r}"):
            self._solver = ca.conic(f"mhe_{plugin}", plugin, {"a": self._A.sparsity(), "h": ca.Sparsity(nx, nx)}, opts)
        self._c, self._lb, self._ub = c, lb, ub

    def solve(self, f, lo, hi, centre=None, *, cutoff: float | None = None, target: float | None = None,
              start: np.ndarray | None = None, col_bounds: tuple | None = None) -> BackendOutcome:
        """Solve with row bounds ``lo, hi`` (``f`` and ``centre`` unused, ``cutoff``, ``target`` and
        ``start`` ignored: CasADi's plugins are given none).

        Parameters
        ----------
        f : (nv,) ndarray or None
            Unused (the cost is fixed at construction).
        lo, hi : (nr,) ndarray
            Row bounds of ``lo <= A v <= hi``.
        centre : (nv,) ndarray, optional
            Unused.
        cutoff : float, optional
            Ignored.
        target : float, optional
            Ignored.
        start : (nv,) ndarray, optional
            Ignored.
        col_bounds : (index, lower, upper), optional
            Column bounds for this solve only (the backend's own bounds are kept).

        Returns
        -------
        BackendOutcome
            The status, the solver's point (when optimal or feasible) and its raw answer.
        """
        t0 = time.perf_counter()
        lb, ub = with_col_bounds(self._lb, self._ub, col_bounds)
        with quiet_stdout():
            r = self._solver(g=self._c, a=self._A, lba=lo, uba=hi, lbx=lb, ubx=ub)
        st = self._solver.stats()
        status = str(st.get("return_status", ""))
        secondary = str(st.get("secondary_return_status", ""))
        detail = {"status": status if not secondary else f"{status}: {secondary}", "objective": float(r["cost"])}
        if self.name == "highs":
            mapped = map_status(CASADI_HIGHS_STATUS, status, solver="casadi-highs")
        else:
            mapped = map_status(CASADI_CBC_STATUS, (status, secondary), solver="cbc")
        return _outcome(mapped, np.array(r["x"], dtype=float).reshape(-1), detail, t0)

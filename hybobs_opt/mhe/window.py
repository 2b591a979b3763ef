"""The model side of one moving-horizon window (paper 002, eq. 10): the PWA dynamics, their guards
and the cost, evaluated in numpy, and the exact problem of one mode sequence.

A mixed-integer program decides the mode sequence; everything that is then claimed about a
window (the trajectory, its cost, its feasibility, the polished continuous part) is recomputed
here from the model of eq. (1) (Bemporad, Ferrari-Trecate & Morari, 2000), with the optional
terms of Ferrari-Trecate, Mignone & Morari (2002).
"""

from __future__ import annotations

import numpy as np

from ..systems.pwa import PWASystem
from ..status import Status
from ..tolerances import (
    KKT_ACTIVE_MULTIPLIER_RTOL,
    KKT_ACTIVE_SLACK_RTOL,
    MEMBERSHIP_RTOL,
    MHE_CERTIFIED_RTOL,
    MHE_FEASIBILITY_TOL,
)
from .backends.daqp_backend import DAQP_INF, daqp_flag
from .mld import MLDEncoding

#: Mode prefixes whose rows :meth:`WindowModel._mode_rows` keeps (cleared when full): a few dozen
#: are visited at the horizons of the papers; the bound only caps memory on long exotic runs.
MODE_ROWS_CACHE_SIZE = 4096

__all__ = ["WindowModel"]


class WindowModel:
    """PWA model, weights and cost of the window of eq. (10), in numpy.

    Parameters
    ----------
    system : PWASystem
        The model (eq. 1) with bounded ``X`` and ``U`` (eq. 2).
    T : int
        Window length.
    norm : {"2", "1", "inf"}
        Norm of the cost.
    enc : MLDEncoding
        The window's MLD encoding (its variable bounds bound the disturbances).
    Wy, Ww, Wa : arrays or None
        Output, disturbance and arrival weights (``Wy`` required).
    res : StackedResidual, optional
        The stacked residual of the formulation (needed with an ``extension``).
    extension : ExtensionData, optional
        What an ``extend`` callable added (:class:`~hybobs_opt.mhe.formulation.MHEExtension`):
        its cost and rows enter :meth:`cost`, :meth:`feasible` and :meth:`sequence_problem`.

    Attributes
    ----------
    hx, cx : (n,) arrays
        Half-widths and centre of the state box (the scaling of the MLD state variables).
    X : Polytope
        The state bounds.
    """

    def __init__(self, system: PWASystem, T: int, norm: str, enc: MLDEncoding, Wy: np.ndarray,
                 Ww: np.ndarray | None, Wa: np.ndarray | None, res=None, extension=None):
        self.system, self.T, self.norm, self.enc = system, int(T), norm, enc
        self.res, self.extension = res, extension
        self.params: np.ndarray | None = None  # the extension's parameters of the window being solved
        if extension is not None:
            self._setup_extension()
        self.n, self.m, self.p = system.n, system.m, system.p
        self.Wy, self.Ww, self.Wa = Wy, Ww, Wa
        self._G_all = np.vstack([md.guard.A for md in system.modes])
        self._g_all = np.concatenate([md.guard.b + MEMBERSHIP_RTOL * (1.0 + np.abs(md.guard.b)) for md in system.modes])
        self._g_starts = np.cumsum([0] + [md.guard.A.shape[0] for md in system.modes[:-1]])
        self.X = system.state_bounds
        m0 = system.modes[0]
        self._common_out = all(np.array_equal(md.C, m0.C) and np.array_equal(md.D, m0.D) and np.array_equal(md.c, m0.c)
                               for md in system.modes)
        self._Cs = np.array([md.C for md in system.modes])
        self._Ds = np.array([md.D for md in system.modes])
        self._cs = np.array([md.c for md in system.modes])
        self._X_tol = self.X.b + MEMBERSHIP_RTOL * (1.0 + np.abs(self.X.b))
        half, centre = system.scales()
        self.hx, self.cx = half[: self.n], centre[: self.n]

    def mode_at(self, x: np.ndarray, u: np.ndarray) -> int:
        """First mode whose guard contains ``(x, u)`` (``-1`` if none); the domain is not checked."""
        viol = self._G_all @ np.concatenate([x, u]) - self._g_all
        hit = np.nonzero(np.maximum.reduceat(viol, self._g_starts) <= 0.0)[0]
        return int(hit[0]) if hit.size else -1

    def in_X(self, x: np.ndarray) -> bool:
        return bool((self.X.A @ x <= self._X_tol).all())

    def f(self, x: np.ndarray, u: np.ndarray, q: int) -> np.ndarray:
        md = self.system.modes[q]
        return md.A @ x + md.B @ u + md.a

    def feasible(self, X: np.ndarray, modes: np.ndarray, U: np.ndarray) -> bool:
        """Whether every ``(X[k], U[k])`` lies in ``X`` and in the guard of ``modes[k]``."""
        viol = np.concatenate([X, U], axis=1) @ self._G_all.T - self._g_all
        per_mode = np.maximum.reduceat(viol, self._g_starts, axis=1)
        ok = bool((per_mode[np.arange(self.T), modes] <= 0.0).all() and (X @ self.X.A.T <= self._X_tol).all())
        if ok and self.extension is not None and self._ext_A.shape[0]:
            v = self.enc.pack(X, modes, U, None)
            lo, hi = self._ext_bounds(U)
            a = self._ext_A @ v
            ok = bool(np.all(a >= lo - MHE_FEASIBILITY_TOL) and np.all(a <= hi + MHE_FEASIBILITY_TOL))
        return ok

    def simulate(self, x_start: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Window states and modes simulated from ``x_start`` through the guards (a warm start).

        Where the trajectory leaves every guard the previous mode is kept, so this never fails.
        """
        X = np.empty((self.T, self.n))
        modes = np.zeros(self.T, dtype=int)
        x, last = np.asarray(x_start, dtype=float), 0
        for k in range(self.T):
            q = self.mode_at(x, U[k])
            q = last if q < 0 else q
            X[k], modes[k], last = x, q, q
            if k < self.T - 1:
                x = self.f(x, U[k], q)
        return X, modes

    def trajectory(self, x0, modes, U, W) -> np.ndarray:
        """Window states of the model from ``x0`` with modes ``modes`` and disturbances ``W``."""
        X = np.empty((self.T, self.n))
        X[0] = x0
        for k in range(self.T - 1):
            X[k + 1] = self.f(X[k], U[k], int(modes[k])) + W[k]
        return X

    def output_residuals(self, X, modes, U, Y) -> np.ndarray:
        """``y(k) - y^(k)`` of a trajectory, ``(T, p)`` (original units, unweighted)."""
        if self._common_out:
            return Y - X @ self._Cs[0].T - U @ self._Ds[0].T - self._cs[0]
        return (Y - np.einsum("kpn,kn->kp", self._Cs[modes], X) - np.einsum("kpm,km->kp", self._Ds[modes], U)
                - self._cs[modes])

    def cost(self, X, modes, U, Y, W, xbar) -> float:
        """Cost of eq. (10) with the optional terms, of a trajectory (original units)."""
        ry = self.output_residuals(X, modes, U, Y)
        parts = [(ry @ self.Wy.T).reshape(-1)]
        if self.Ww is not None and self.T > 1:
            parts.append((W @ self.Ww.T).reshape(-1))
        if self.Wa is not None:
            parts.append(self.Wa @ (X[0] - xbar))
        extra = 0.0
        ext = self.extension
        if ext is not None and ext.has_cost:
            v = self.enc.pack(X, modes, U, W if self.enc.disturbances else None)
            if ext.residual is not None:
                res = self.res
                sl = ext.residual
                off = res.offset(Y.reshape(-1), U.reshape(-1), xbar, self.params)[sl]
                parts.append(res.R[sl] @ v + off)
            else:
                extra = float(ext.cost_vector @ v) + ext.cost_constant(U, Y, xbar, self.params)
        if self.norm == "2":
            return float(sum(np.dot(r, r) for r in parts))
        if self.norm == "1":
            return float(sum(np.abs(r).sum() for r in parts)) + extra
        return float(sum(np.abs(r).max() for r in parts)) + extra

    def _weight_rows(self, dist: bool, nt: int, xbar) -> tuple[list, list]:
        """The residual rows of the disturbance and arrival-cost terms of eq. (10) in ``theta``
        (the disturbances when ``dist``, the window-start state's distance to ``xbar`` when an
        arrival weight is set), with their offsets."""
        n, T, hx = self.n, self.T, self.hx
        R, r = [], []
        if dist:
            Rw = np.zeros((n * (T - 1), nt))
            Rw[:, n:] = np.kron(np.eye(T - 1), self.Ww @ np.diag(hx))
            R.append(Rw)
            r.append(np.zeros(n * (T - 1)))
        if self.Wa is not None:
            Ra = np.zeros((n, nt))
            Ra[:, :n] = self.Wa @ np.diag(hx)
            R.append(Ra)
            r.append(self.Wa @ (self.cx - xbar))
        return R, r

    def sequence_problem(self, modes, U, Y, xbar):
        """Condensed problem of one mode sequence: residual ``R theta + r`` and rows ``G theta <= g``.

        ``theta = [xi0; omega]`` are the window-start state and the disturbances, scaled by the
        state box; the rows are the guards of the sequence and ``X`` at every window step
        (paper 002, eq. 10 with the modes fixed).  ``modes`` may be a prefix of a sequence
        (fewer than ``T`` steps): the outputs and rows of its steps only, with the disturbance
        and arrival terms of the whole window, so that its least cost is a lower bound of every
        sequence that begins with it (the branch and bound of :mod:`hybobs_opt.mhe.certify`).
        With an extension its residual rows (norm 2) and constraint rows are added, condensed
        through the affine map of the MLD variables in ``theta`` of the sequence; a prefix keeps
        those on the variables it fixes (the lower bound stays valid: the rest are relaxed).
        """
        sysm, T, n = self.system, self.T, self.n
        cx = self.cx
        dist = self.Ww is not None and T > 1
        nt = n + (n * (T - 1) if dist else 0)
        px = cx.copy()
        Rrows, rvec, Grows, gvec = [], [], [], []
        XA, Xb = self.X.A, self.X.b
        step_rows = self._mode_rows(modes, dist, nt)
        for k in range(len(modes)):
            md = sysm.modes[int(modes[k])]
            Ry, Gg, GX = step_rows[k]
            Rrows.append(Ry)
            rvec.append(self.Wy @ (Y[k] - md.C @ px - md.D @ U[k] - md.c))
            G, g = md.guard.A, md.guard.b
            Grows.append(Gg)
            gvec.append(g - G[:, n:] @ U[k] - G[:, :n] @ px)
            Grows.append(GX)
            gvec.append(Xb - XA @ px)
            if k < T - 1:
                px = md.A @ px + md.B @ U[k] + md.a
        weight_R, weight_r = self._weight_rows(dist, nt, xbar)
        static = self._static_rows(modes, dist, nt, step_rows, Grows) if self.extension is None else None
        if static is not None:
            # the rows that depend on the modes alone, stacked and normalised once per prefix; the
            # same expressions as below on the same arrays, so the problem is bit-identical
            R_steps, Gn, gnorm, nz = static
            gg = np.concatenate(gvec)
            if not np.any(gg[~nz] < 0):
                # copies: the solvers take writable buffers (DAQP's wrapper refuses read-only ones)
                R = np.vstack([R_steps, *weight_R]) if weight_R else R_steps.copy()
                return R, np.concatenate(rvec + weight_r), Gn.copy(), gg[nz] / gnorm, dist
        Rrows += weight_R
        rvec += weight_r
        if self.extension is not None:
            self._extension_rows(modes, U, Y, xbar, nt, dist, Rrows, rvec, Grows, gvec)
        G, gg = np.vstack(Grows), np.concatenate(gvec)
        norm = np.max(np.abs(G), axis=1)
        # a row without coefficients is kept only when it cannot hold (0 <= g < 0): it proves the
        # sequence infeasible (an extension's row on the binaries alone)
        bad = (norm == 0) & (gg < 0)
        keep = norm > 0
        norm = np.where(bad, np.abs(gg), norm)
        keep = keep | bad
        return np.vstack(Rrows), np.concatenate(rvec), G[keep] / norm[keep, None], gg[keep] / norm[keep], dist

    def _static_rows(self, modes, dist: bool, nt: int, step_rows: list, Grows: list):
        """``(R of the steps, G normalised, its row norms, rows with coefficients)`` of
        :meth:`sequence_problem` for ``modes``: they depend on the modes alone.  Cached beside
        :meth:`_mode_rows` (the same key)."""
        key = (tuple(int(q) for q in modes), dist, nt, id(self.Wy))
        cache = self.__dict__.setdefault("_static_cache", {})
        hit = cache.get(key)
        if hit is None:
            G = np.vstack(Grows)
            norm = np.max(np.abs(G), axis=1)
            nz = norm > 0
            R_steps = np.vstack([rows[0] for rows in step_rows])
            hit = (R_steps, G[nz] / norm[nz, None], norm[nz], nz)
            for a in hit:
                a.setflags(write=False)  # shared by every window's problem of these modes
            if len(cache) >= MODE_ROWS_CACHE_SIZE:
                cache.clear()
            cache[key] = hit
        return hit

    def _mode_rows(self, modes, dist: bool, nt: int) -> list:
        """Per step of ``modes``, the rows of :meth:`sequence_problem` that depend on the modes only:
        ``(-Wy C Px, G_x Px, X_A Px)`` with ``Px`` the map of ``theta`` to the state at that step.

        Cached per mode prefix (the branch and bound of :mod:`~hybobs_opt.mhe.certify` asks for
        the same prefixes at every window: 72,129 calls for a few dozen prefixes in the report's
        MHE runs); computed by the same expressions as before, so the rows are bit-identical.
        """
        key = (tuple(int(q) for q in modes), dist, nt, id(self.Wy))
        cache = self.__dict__.setdefault("_rows_cache", {})
        hit = cache.get(key)
        if hit is not None:
            return hit
        sysm, T, n, hx = self.system, self.T, self.n, self.hx
        Px = np.zeros((n, nt))
        Px[:, :n] = np.diag(hx)
        XA = self.X.A
        out = []
        for k in range(len(modes)):
            md = sysm.modes[int(modes[k])]
            out.append((-self.Wy @ md.C @ Px, md.guard.A[:, :n] @ Px, XA @ Px))
            if k < T - 1:
                Px = md.A @ Px
                if dist:
                    Px[:, n + k * n: n + (k + 1) * n] += np.diag(hx)
        if len(cache) >= MODE_ROWS_CACHE_SIZE:
            cache.clear()
        cache[key] = out
        return out

    # ------------------------------------------------------------------ extension
    def _setup_extension(self) -> None:
        """Rows of the extension in the MLD encoding and the prefix length each needs."""
        enc, ext = self.enc, self.extension
        T, s, n, p = self.T, self.system.n_modes, self.system.n, self.system.p
        sl = enc.slices
        need = np.zeros(enc.n_vars, dtype=int)  # prefix length that fixes each variable
        for k in range(T):
            need[sl["delta"].start + k * s: sl["delta"].start + (k + 1) * s] = k + 1
            if k < T - 1:
                a = sl["zeta"].start + k * s * n
                need[a:a + s * n] = k + 1
            if sl["zeta_y"].stop > sl["zeta_y"].start:
                a = sl["zeta_y"].start + k * s * p
                need[a:a + s * p] = k + 1
        self._need = need
        self._ext_A = enc.A[ext.rows]
        self._ext_need = np.array([need[np.nonzero(r)[0]].max(initial=0) for r in self._ext_A], dtype=int)
        if ext.residual is not None:
            Rh = self.res.R[ext.residual]
            self._ext_res_need = np.array([need[np.nonzero(r)[0]].max(initial=0) for r in Rh], dtype=int)

    def set_parameters(self, P: np.ndarray | None) -> None:
        """The extension's parameter values of the window being solved (also set in the encoding).

        Parameters
        ----------
        P : (n_P,) ndarray or None
        """
        self.params = None if P is None else np.asarray(P, dtype=float)
        if self.enc.n_params:
            self.enc.set_parameters(P)

    def _ext_bounds(self, U: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        lo, hi = self.enc.bounds(np.asarray(U, dtype=float).reshape(-1))
        return lo[self.extension.rows], hi[self.extension.rows]

    def _vmap(self, modes, U) -> tuple[np.ndarray, np.ndarray]:
        """``v = Pv theta + pv`` for the mode sequence (or prefix) ``modes``: the MLD variables as an
        affine map of ``theta = [xi0; omega]`` (the variables a prefix leaves open are zero)."""
        enc, T, n = self.enc, self.T, self.n
        s, p = self.system.n_modes, self.system.p
        sl = enc.slices
        dist = self.Ww is not None and T > 1
        nt = n + (n * (T - 1) if dist else 0)
        hx, cx = self.hx, self.cx
        Pv, pv = np.zeros((enc.n_vars, nt)), np.zeros(enc.n_vars)
        Pv[sl["xi0"], :n] = np.eye(n)
        if dist:
            Pv[sl["omega"], n:] = np.eye(n * (T - 1))
        Px, px = np.zeros((n, nt)), cx.copy()
        Px[:, :n] = np.diag(hx)
        hy = enc._hy() if sl["zeta_y"].stop > sl["zeta_y"].start else None
        for k in range(len(modes)):
            q = int(modes[k])
            md = self.system.modes[q]
            pv[sl["delta"].start + k * s + q] = 1.0
            if hy is not None:
                a = sl["zeta_y"].start + (k * s + q) * p
                Pv[a:a + p] = (md.C @ Px) / hy[:, None]
                pv[a:a + p] = (md.C @ px + md.D @ U[k] + md.c) / hy
            if k < T - 1:
                SP, sp = md.A @ Px, md.A @ px + md.B @ U[k] + md.a
                a = sl["zeta"].start + (k * s + q) * n
                Pv[a:a + n], pv[a:a + n] = SP / hx[:, None], sp / hx
                Px, px = SP, sp
                if dist:
                    Px = Px.copy()
                    Px[:, n + k * n: n + (k + 1) * n] += np.diag(hx)
        return Pv, pv

    def _extension_rows(self, modes, U, Y, xbar, nt, dist, Rrows, rvec, Grows, gvec) -> None:
        """Append the extension's residual rows (norm 2) and constraint rows that ``modes`` fixes.

        A prefix (fewer than ``T`` modes) keeps only the rows whose variables it fixes: dropping a
        square of the cost or a constraint relaxes the problem, so the prefix's least cost stays a
        lower bound of every completion (:mod:`hybobs_opt.mhe.certify`).
        """
        ext = self.extension
        L = len(modes)
        Pv, pv = self._vmap(modes, U)
        if ext.residual is not None:
            sl = ext.residual
            take = self._ext_res_need <= L
            if take.any():
                Rh = self.res.R[sl][take]
                off = self.res.offset(np.asarray(Y, dtype=float).reshape(-1), np.asarray(U, dtype=float).reshape(-1), xbar,
                                      self.params)[sl][take]
                Rrows.append(Rh @ Pv)
                rvec.append(Rh @ pv + off)
        take = self._ext_need <= L
        if take.any():
            A = self._ext_A[take]
            lo, hi = self._ext_bounds(U)
            lo, hi = lo[take], hi[take]
            AP, ap = A @ Pv, A @ pv
            up, dn = np.isfinite(hi), np.isfinite(lo)
            Grows.append(AP[up])
            gvec.append(hi[up] - ap[up])
            Grows.append(-AP[dn])
            gvec.append(ap[dn] - lo[dn])

    def polish(self, modes, U, Y, xbar, x0, W, extra: tuple[np.ndarray, np.ndarray] | None = None,
                problem: tuple | None = None, bound: bool = False, robust: bool = False):
        """Least-squares problem of the mode sequence ``modes``, warm-started at ``(x0, W)``.

        The QP of eq. (10) with the modes fixed, solved by DAQP (proximal iterations when the
        sequence leaves directions of the state unobserved).  For norm 2 it is exact; for norms
        1 / inf it gives a feasible point of the sequence (an incumbent), optimal when it fits
        the data exactly.  ``extra = (G_e, g_e)`` adds rows ``G_e theta <= g_e`` (``G_e`` with
        ``n`` columns: on the scaled window-start state alone), the separation of the uniqueness
        test; ``problem`` is
        :meth:`sequence_problem` of the same arguments, when already built.  Returns
        ``(x0, W, states)`` or ``None`` if not certified.

        ``bound=True`` (the uniqueness test): the proximal iterations run to convergence
        (``eta_prox`` 1e-20: DAQP's default stops them early, 30 times above the minimum on a
        sequence of model (16) with an unobserved direction) and a fourth element is returned, a
        lower bound of the least cost of the sequence proven in numpy from the multipliers:
        for every feasible ``theta``, by convexity and ``lam >= 0``,
        ``q(theta) >= q(theta^) - lam' (g - G theta^) - sum_j |rho_j| D_j`` with
        ``rho = H theta^ + f + G' lam`` and ``D_j`` the range of ``theta_j`` over its bounds.
        """
        T, n = self.T, self.n
        hx, cx = self.hx, self.cx
        R, r, G, gg, dist = self.sequence_problem(modes, U, Y, xbar) if problem is None else problem
        if extra is not None:
            Ge = np.zeros((extra[0].shape[0], G.shape[1]))
            Ge[:, :extra[0].shape[1]] = extra[0]
            G, gg = np.vstack([G, Ge]), np.concatenate([gg, extra[1]])
        theta0 = np.concatenate([(x0 - cx) / hx] + ([(W / hx).reshape(-1)] if dist else []))
        solved = self.sequence_qp((R, r, G, gg, dist), theta0, bound, robust)
        if solved is None or solved[0] is None:
            return None
        theta, lower = solved
        x0p = cx + hx * theta[:n]
        Wp = (theta[n:].reshape(T - 1, n) * hx) if dist else np.zeros((max(T - 1, 0), n))
        states = self.trajectory(x0p, modes, U, Wp)
        if not bound:
            return x0p, Wp, states
        return x0p, Wp, states, lower

    def sequence_qp(self, problem: tuple, theta0: np.ndarray | None = None, bound: bool = False, robust: bool = False,
                    multipliers: bool = False):
        """The QP of :meth:`sequence_problem`'s ``problem``: ``(theta, lower)``, ``(None, inf)`` or ``None``.

        Parameters
        ----------
        problem : tuple
            ``(R, r, G, g, dist)`` of :meth:`sequence_problem` (of a sequence or a prefix).
        theta0 : array, optional
            DAQP's primal start.
        bound : bool
            Run the proximal iterations to convergence and prove a lower bound (see
            :meth:`polish`); otherwise ``lower`` is ``None``.
        robust : bool
            With ``bound``: when the bound stays weak, prove a second one from Clarabel's answer
            and from the exact KKT solutions of more active sets (the uniqueness test, whose
            decision must not depend on the rounding of one solver's last pivots; a Clarabel
            solve costs milliseconds, so the exact search over mode prefixes does without).

        Returns
        -------
        tuple or None
            ``(theta, lower)``: the minimiser (scaled) and, with ``bound``, a lower bound of
            ``||R theta + r||^2`` over ``G theta <= g`` and the variable bounds, proven in numpy;
            ``(None, inf)``: infeasible, proven by a Farkas vector that re-checks in numpy
            (:meth:`_infeasibility_proven`); ``None``: no certified answer (DAQP and, with
            ``bound``, Clarabel failed, or a point or a verdict did not pass the checks).
            With ``bound`` and ``multipliers`` a third element: multipliers ``lam >= 0`` of the
            rows (cost units) paired with ``theta``, for bounds of the caller's own by weak
            duality (``None`` when infeasible).
        """
        import daqp

        R, r, G, gg, dist = problem
        # a QP for every norm: for norm 2 it is the exact problem; for norms 1 / inf its minimiser
        # is a feasible point (an upper bound, the incumbent) and an exact fit when one exists
        scale = float(np.max(np.einsum("ij,ij->j", R, R))) or 1.0
        H = 2.0 * R.T @ R / scale
        f = 2.0 * R.T @ r / scale
        settings = {"eta_prox": 1e-20} if bound else {}
        start = {} if theta0 is None else {"primal_start": theta0}
        theta, fval, flag, info = daqp.solve(H, f, G, gg, np.full(gg.size, -DAQP_INF), **start, **settings)
        lam = np.asarray(info.get("lam", ()), dtype=float)
        status = daqp_flag(flag)
        if status == Status.INFEASIBLE and self._infeasibility_proven(G, gg, lam, lp=False):
            return (None, np.inf, None) if multipliers and bound else (None, np.inf)
        ok = status == Status.OPTIMAL and np.all(np.isfinite(theta)) and np.isfinite(fval) and np.all(np.isfinite(lam))
        if ok:
            theta = np.asarray(theta, dtype=float)
            ok = np.max(G @ theta - gg, initial=0.0) <= MHE_FEASIBILITY_TOL
        if not ok and bound:
            # DAQP's active set fails on some degenerate prefixes (an "infeasible" exit with
            # multipliers of the wrong sign for rows HiGHS satisfies): the same QP by Clarabel
            # (Clarabel's own interface first, then through cvxpy, which solves the sum of squares as
            # a cone program where the QP form stalls or calls some degenerate prefixes infeasible)
            for conic in (_conic_qp, _cvxpy_qp):
                fallback = conic(R, r, G, gg)
                if fallback is None:
                    continue
                if fallback == "infeasible":
                    if self._infeasibility_proven(G, gg, np.zeros(gg.size)):
                        return (None, np.inf, None) if multipliers else (None, np.inf)
                    continue
                theta, lam = fallback[0], fallback[1] / scale  # multipliers of ||R theta + r||^2 / scale
                ok = np.max(G @ theta - gg, initial=0.0) <= MHE_FEASIBILITY_TOL
                if ok:
                    break
        if not ok:
            return None
        if not bound:
            return theta, None
        enc = self.enc
        lo_t = np.concatenate([enc.lb[enc.slices["xi0"]]] + ([enc.lb[enc.slices["omega"]]] if dist else []))
        hi_t = np.concatenate([enc.ub[enc.slices["xi0"]]] + ([enc.ub[enc.slices["omega"]]] if dist else []))
        lam = np.maximum(lam, 0.0) if lam.size == gg.size else np.zeros(gg.size)

        def proven(theta, lam):
            D = np.maximum(np.abs(hi_t - theta), np.abs(theta - lo_t))
            rho = H @ theta + f + G.T @ lam
            res = R @ theta + r
            cost = float(res @ res)
            return cost, cost - scale * float(lam @ (gg - G @ theta) + np.abs(rho) @ D)

        cost, lower = proven(theta, lam)
        if cost - lower > 0.1 * MHE_CERTIFIED_RTOL * cost:
            # the bound gives away more than a tenth of the gap a window must prove: re-solve
            # exactly on the active set (ill-conditioned problems, e.g. with a Kalman prior)
            theta_p, lam_p = _kkt_polish(H, f, G, gg, theta, lam)
            if theta_p is not theta:
                cost_p, lower_p = proven(theta_p, lam_p)
                if lower_p > lower:
                    theta, lower, lam = theta_p, lower_p, lam_p
        if robust and cost - lower > 0.1 * MHE_CERTIFIED_RTOL * cost:
            # still weak: DAQP's multipliers carry the rounding of its last pivots (the bound of one
            # QP of model (16) was 5.2e-7 with one BLAS and -3.4e-4 with another).  Clarabel's
            # multipliers give a second bound; any (theta, lam >= 0) gives a valid one, so the
            # larger is kept
            conic = _conic_qp(R, r, G, gg)
            if conic is not None and not isinstance(conic, str):
                theta_c, lam_c = np.asarray(conic[0], dtype=float), np.maximum(np.asarray(conic[1], dtype=float) / scale, 0.0)
                if (theta_c.shape == theta.shape and lam_c.shape == gg.shape and np.all(np.isfinite(theta_c))
                        and np.all(np.isfinite(lam_c))):
                    lower = max(lower, proven(theta_c, lam_c)[1])
                    pairs = [(theta, lam), (theta_c, lam_c)]
                else:
                    pairs = [(theta, lam)]
            else:
                pairs = [(theta, lam)]
            # the exact KKT point of each candidate active set: the bound holds at any point with
            # any multipliers >= 0, so these need not meet the other rows
            for th0, lam0 in pairs:
                for act in _active_sets(G, gg, th0, lam0, more=True):
                    solved = _kkt_solve(H, f, G, gg, act)
                    if solved is not None:
                        lower = max(lower, proven(*solved)[1])
        if multipliers:
            return theta, lower, scale * lam
        return theta, lower

    @staticmethod
    def _infeasibility_proven(G: np.ndarray, g: np.ndarray, lam: np.ndarray, lp: bool = True) -> bool:
        """Is ``G theta <= g`` proven infeasible by a Farkas vector ``y >= 0, G'y = 0, g'y < 0`` that
        re-checks in numpy (:func:`~hybobs_opt.geometry.lp.daqp_infeasibility_ok`)?

        Tried in turn: DAQP's multipliers; the non-negative least-squares solution of
        ``[G'; g'] y = [0; -1]`` (microseconds: DAQP's multipliers of an "infeasible" exit fail the
        check on degenerate rows, e.g. the mode prefix (2, 0) of model (16), which would cross the
        whole backlash in one step); with ``lp``, HiGHS's certificate
        (:func:`~hybobs_opt.geometry.lp.solve_lp`).
        """
        from scipy.optimize import nnls

        from ..errors import SolverError
        from ..geometry.lp import daqp_infeasibility_ok, solve_lp

        if daqp_infeasibility_ok(G, g, lam):
            return True
        try:
            y, _ = nnls(np.vstack([G.T, g[None, :]]), np.r_[np.zeros(G.shape[1]), -1.0])
        except (RuntimeError, ValueError):
            y = None
        if y is not None and daqp_infeasibility_ok(G, g, y):
            return True
        if not lp:
            return False
        try:
            return solve_lp(np.zeros(G.shape[1]), G, g, problem="rows of a mode prefix").status == "infeasible"
        except SolverError:
            return False

    def mld_violation(self, states, modes, U, W, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> float:
        """Largest violation of the MLD rows, bounds and integrality at the trajectory ``(states, modes, W)``."""
        v = self.enc.pack(states, modes, U, W if self.enc.disturbances else None)
        return self.enc.violation(v, np.asarray(U).reshape(-1), bounds=bounds)


def _kkt_solve(H: np.ndarray, f: np.ndarray, G: np.ndarray, g: np.ndarray, act: np.ndarray):
    """The KKT system of the QP with the rows ``act`` active, by least squares: ``(theta, lam)``
    with ``lam >= 0`` (zero off ``act``), or ``None`` (a negative or non-finite multiplier).  The
    point need not meet the other rows."""
    nt, na = H.shape[0], int(act.sum())
    Ga = G[act]
    K = np.zeros((nt + na, nt + na))
    K[:nt, :nt], K[:nt, nt:], K[nt:, :nt] = H, Ga.T, Ga
    sol = np.linalg.lstsq(K, np.concatenate([-f, g[act]]), rcond=None)[0]
    tp, lp = sol[:nt], np.zeros(g.size)
    lp[act] = sol[nt:]
    if not (np.all(np.isfinite(sol)) and np.all(lp >= 0.0)):
        return None
    return tp, lp


def _active_sets(G: np.ndarray, g: np.ndarray, theta: np.ndarray, lam: np.ndarray, more: bool) -> list[np.ndarray]:
    """Candidate active sets at a solver's answer: the rows with a positive multiplier (an
    active-set solver's); ``more``: the rows an interior-point solver leaves at its accuracy (met
    to :data:`~hybobs_opt.tolerances.KKT_ACTIVE_SLACK_RTOL` with a positive multiplier, or a
    multiplier within :data:`~hybobs_opt.tolerances.KKT_ACTIVE_MULTIPLIER_RTOL` of the largest: the others are
    ~complementarity / slack, which the bound pays for times the problem's scale), none (the
    unconstrained minimiser), and the rows nearest to the point one and two at a time (an
    ill-conditioned QP leaves both solvers short of the optimum with no row met yet)."""
    out = [lam > 0.0]
    if more:
        slack = g - G @ theta
        met = slack <= KKT_ACTIVE_SLACK_RTOL * (1.0 + np.abs(g))
        out += [met & (lam > 0.0), lam > KKT_ACTIVE_MULTIPLIER_RTOL * float(np.max(lam, initial=0.0)), met,
                np.zeros(g.size, dtype=bool)]
        near = [int(i) for i in np.argsort(slack, kind="stable")[:4]]
        out += [np.isin(np.arange(g.size), [i]) for i in near]
        out += [np.isin(np.arange(g.size), [near[a], near[b]]) for a, b in ((0, 1), (0, 2), (1, 2)) if b < len(near)]
    unique: dict[bytes, np.ndarray] = {}
    for act in out:
        unique.setdefault(act.tobytes(), act)
    return list(unique.values())


def _kkt_polish(H: np.ndarray, f: np.ndarray, G: np.ndarray, g: np.ndarray, theta: np.ndarray,
                lam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The QP's point and multipliers re-solved exactly on the solver's active set, when that is
    still an optimum (multipliers >= 0, rows met); else the solver's own.

    The lower bound of :meth:`WindowModel.sequence_qp` loses ``|H theta + f + G' lam|`` times the
    box: with a strong arrival prior (``arrival_weight="kalman"``) the Hessian spans six decades
    and DAQP's stationarity residual (~1e-9 of it) cost 0.03 of a cost of ~5, more than the
    relative gap 1e-6 the window must prove.  The KKT system of the active rows, solved by least
    squares, brings the residual to rounding; nothing is trusted that the caller does not
    re-check (the bound is recomputed from the polished pair in numpy).
    """
    solved = _kkt_solve(H, f, G, g, lam > 0.0)
    if solved is None or np.max(G @ solved[0] - g, initial=0.0) > MHE_FEASIBILITY_TOL:
        return theta, lam
    return solved


def _conic_qp(R: np.ndarray, r: np.ndarray, G: np.ndarray, g: np.ndarray):
    """``min ||R theta + r||^2 s.t. G theta <= g`` by Clarabel: ``(theta, lam)``, ``"infeasible"`` or ``None``.

    Clarabel's own interface (cvxpy's compilation cost 7 ms per call here), objective
    ``theta' R'R theta + 2 r'R theta``, so ``lam`` are the multipliers of ``||R theta + r||^2``
    (non-negative).  An optimum is returned only with status ``Solved`` and a finite point and
    multipliers; the caller checks the rows at the point and proves its bound itself.
    """
    import clarabel
    from scipy import sparse

    settings = clarabel.DefaultSettings()
    settings.verbose = False
    P = sparse.triu(sparse.csc_matrix(2.0 * R.T @ R), format="csc")
    try:
        solver = clarabel.DefaultSolver(P, 2.0 * R.T @ r, sparse.csc_matrix(G), np.asarray(g, dtype=float),
                                        [clarabel.NonnegativeConeT(G.shape[0])], settings)
        sol = solver.solve()
    except Exception:  # noqa: BLE001  (a crashing solver is an answer of None, never an exception)
        return None
    status = str(sol.status)
    if status in ("PrimalInfeasible", "AlmostPrimalInfeasible"):
        return "infeasible"
    if status != "Solved":
        return None
    x, lam = np.asarray(sol.x, dtype=float), np.asarray(sol.z, dtype=float)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(lam))):
        return None
    return x, np.maximum(lam, 0.0)


def _cvxpy_qp(R: np.ndarray, r: np.ndarray, G: np.ndarray, g: np.ndarray):
    """:func:`_conic_qp` through cvxpy + Clarabel (the sum of squares as a cone program, which
    Clarabel solves where the QP form stalls on some degenerate prefixes of model (16) at T = 10)."""
    import cvxpy as cp

    theta = cp.Variable(R.shape[1])
    rows = G @ theta <= g
    problem = cp.Problem(cp.Minimize(cp.sum_squares(R @ theta + r)), [rows])
    try:
        problem.solve(solver=cp.CLARABEL)
    except cp.error.SolverError:
        return None
    if problem.status == cp.INFEASIBLE:
        return "infeasible"
    if problem.status != cp.OPTIMAL or theta.value is None or rows.dual_value is None:
        return None
    x, lam = np.asarray(theta.value, dtype=float), np.asarray(rows.dual_value, dtype=float).reshape(-1)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(lam))):
        return None
    return x, np.maximum(lam, 0.0)

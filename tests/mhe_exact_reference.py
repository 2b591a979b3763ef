"""Exact reference for one window of the moving-horizon observer (10) of paper 002 (issue 18).

An independent check of :class:`hybobs_opt.mhe.MHEObserver` (2-norm): it shares no code with
``hybobs_opt/mhe``; only the model's matrices are read from the :class:`PWASystem`.  The problem is
the plain eq. (10) of Bemporad, Ferrari-Trecate & Morari (2000):

``min over x(0)  sum_k ||y(k) - C_{q_k} x(k) - D_{q_k} u(k) - c_{q_k}||_2^2``

subject to ``x(k + 1) = A_{q_k} x(k) + B_{q_k} u(k) + a_{q_k}``, ``[x(k); u(k)] in Q_{q_k}`` (the
guard of mode ``q_k``) and ``x(k) in X`` at every window step ``k = 0..T-1``, over every mode
sequence ``q`` (no output weight, no disturbances, no arrival cost: the observer's defaults).
The inputs ``u(k)`` are data; they must lie in ``U`` (checked, an error otherwise, since the
observer refuses such windows too).

Method: depth-first enumeration of the ``s^T`` mode sequences.  A prefix ``q_0..q_{k-1}``
(``k < T``) is tested for feasibility by an LP (scipy ``linprog``, HiGHS: the Chebyshev radius
of its set, rows normalised, unit-box coordinates); an infeasible prefix (radius below
``-RADIUS_TOL``) removes all its completions.  A set without interior (radius within
``RADIUS_TOL`` of 0: the guards of model (16) meet on ``theta = +-alpha``, and a trajectory can
stay on that plane) gets its implicit equalities from the LP's duals and is solved with them as
equalities.  Every remaining full sequence's convex QP in the window-start state is solved by
cvxpy + Clarabel (status checked: optimal or infeasible; ``optimal_inaccurate`` only when the KKT
polish below certifies the point, after one retry on the problem built afresh; anything else
raises).  The QP is posed in the state box's unit coordinates, centred at the unconstrained least-squares point
so that the objective's data are of the size of the residuals.  Clarabel's point is then polished
by a primal-dual active-set iteration on the KKT system in numpy (feasible to 1e-11, multipliers
``>= 0``: the exact optimum of the convex QP); when that fails the Clarabel point is kept and
counted (``n_unpolished``).  The cost is recomputed in numpy by simulating the model from the
window-start state.

Optional ``bound_prune=True`` (for long windows): the prefix QP's certified optimum is a lower
bound of every completion's cost (fewer nonnegative terms, fewer constraints), so a prefix whose
bound exceeds the incumbent by more than ``bound_margin_rtol (1 + incumbent)`` is pruned too; only KKT-certified
bounds prune.  This is an exact branch-and-bound with Clarabel node solves, still independent of
the observer's DAQP.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np
from scipy.optimize import linprog

__all__ = ["ExactWindowResult", "ExactWindowReference", "exact_window_optimum"]

#: Largest violation (unit box coordinates, rows normalised to a largest coefficient of 1) of a
#: polished point.
POLISH_FEAS_TOL = 1e-11
#: An unpolished sequence (Clarabel's point, gap tolerance 1e-8) within this relative distance of
#: the optimum makes the reference uncertain (``n_unpolished_near``).
UNPOLISHED_NEAR = 1e-6
#: A constraint is taken as active when its slack at Clarabel's point is below this.
ACTIVE_TOL = 1e-7


@dataclass
class ExactWindowResult:
    """Optimum of one window by enumeration.

    ``optimum`` is ``inf`` (and ``modes``/``x_start`` ``None``) when no sequence is feasible.
    """

    optimum: float
    modes: tuple[int, ...] | None
    x_start: np.ndarray | None
    states: np.ndarray | None
    n_sequences: int
    n_lp: int = 0
    n_lp_infeasible: int = 0
    n_qp: int = 0
    n_qp_infeasible: int = 0
    n_bound_pruned: int = 0
    n_leaves_pruned: int = 0  # full sequences never solved (infeasible or bound-pruned prefix)
    n_unpolished: int = 0
    n_unpolished_near: int = 0  # of those, within UNPOLISHED_NEAR of the optimum (a warning)
    n_inaccurate_certified: int = 0  # Clarabel 'optimal_inaccurate' whose point the KKT polish certified
    n_fresh: int = 0  # QPs built afresh (implicit equalities, or an inaccurate compiled solve)
    n_degenerate: int = 0  # feasibility LPs that found no interior (implicit equalities)
    max_violation: float = 0.0
    seconds: float = 0.0
    costs: dict = field(default_factory=dict)  # full sequence -> its least cost (feasible ones)

    def to_dict(self) -> dict:
        return {"optimum": self.optimum, "modes": None if self.modes is None else list(self.modes),
                "x_start": None if self.x_start is None else self.x_start.tolist(),
                "n_sequences": self.n_sequences, "n_lp": self.n_lp, "n_lp_infeasible": self.n_lp_infeasible,
                "n_qp": self.n_qp, "n_qp_infeasible": self.n_qp_infeasible, "n_bound_pruned": self.n_bound_pruned,
                "n_leaves_pruned": self.n_leaves_pruned, "n_unpolished": self.n_unpolished, "n_unpolished_near": self.n_unpolished_near, "n_degenerate": self.n_degenerate, "n_fresh": self.n_fresh, "n_inaccurate_certified": self.n_inaccurate_certified,
                "max_violation": self.max_violation, "seconds": self.seconds}


def _box_of(P) -> tuple[np.ndarray, np.ndarray]:
    """Bounding box of a polytope ``{x: A x <= b}`` by 2 n LPs (HiGHS)."""
    n = P.A.shape[1]
    lo, hi = np.empty(n), np.empty(n)
    for j in range(n):
        for sign, out in ((1.0, lo), (-1.0, hi)):
            c = np.zeros(n)
            c[j] = sign
            lp = linprog(c, A_ub=P.A, b_ub=P.b, bounds=[(None, None)] * n, method="highs")
            if lp.status != 0:
                raise ValueError(f"the state set X is not bounded (LP status {lp.status}: {lp.message})")
            out[j] = lp.x[j]
    return lo, hi


class _QP:
    """``min ||A d - r||^2  s.t.  G d <= h`` with fixed shapes, compiled once (cvxpy DPP) for Clarabel."""

    def __init__(self, n: int, n_res: int, n_rows: int, clarabel_options: dict):
        self.d = cp.Variable(n)
        self.A = cp.Parameter((n_res, n))
        self.r = cp.Parameter(n_res)
        self.G = cp.Parameter((n_rows, n))
        self.h = cp.Parameter(n_rows)
        self.prob = cp.Problem(cp.Minimize(cp.sum_squares(self.A @ self.d - self.r)), [self.G @ self.d <= self.h])
        self.n_rows = n_rows
        self.options = clarabel_options

    def solve(self, A, r, G, h):
        """Returns ``d`` or ``None`` (certified infeasible); raises on any other status."""
        self.A.value, self.r.value, self.G.value, self.h.value = A, r, G, h
        with warnings.catch_warnings():  # the status is checked instead ('Solution may be inaccurate')
            warnings.simplefilter("ignore", UserWarning)
            self.prob.solve(solver=cp.CLARABEL, **self.options)
        return _outcome(self.prob, self.d)


def _outcome(prob, var):
    """``(point, inaccurate)`` of a solved problem, ``None`` if infeasible; raises on any other status.

    ``optimal_inaccurate`` is returned with ``inaccurate=True``: the caller accepts it only when
    the KKT polish certifies the point (an independent proof of optimality), else it raises.
    """
    st = prob.status
    if st in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) and var.value is not None:
        return np.asarray(var.value, dtype=float), st == cp.OPTIMAL_INACCURATE
    if st == cp.INFEASIBLE:
        return None
    raise RuntimeError(f"Clarabel status {st!r} on a fixed-sequence QP (only optimal or infeasible accepted)")


def _kkt_polish(A, r, G, h, x, n_eq: int = 0):
    """Primal-dual active-set iteration for ``min ||A x - r||^2, G x <= h`` from Clarabel's ``x``.

    The first ``n_eq`` rows of ``G`` are equalities (always active, multipliers of any sign).
    Returns the KKT point (feasible to :data:`POLISH_FEAS_TOL`, inequality multipliers >= 0) or
    ``None``.
    """
    n = A.shape[1]
    H = 2.0 * A.T @ A
    f = 2.0 * A.T @ r
    # scale the objective to the rows' size (normalised to 1): the KKT matrix of a vertex of a
    # thin sliver is otherwise too ill-conditioned for the least-squares solve (multipliers scaled)
    sH = float(np.max(np.abs(H), initial=0.0)) or 1.0
    H, f = H / sH, f / sH
    slack = h - G @ x
    act = list(range(n_eq)) + [int(i) for i in np.nonzero(slack <= ACTIVE_TOL)[0] if i >= n_eq]
    scale = 1.0 + float(np.max(np.abs(f), initial=0.0))
    for _ in range(4 * G.shape[0] + 10):
        # a linearly independent subset of the active rows (a degenerate vertex has more active
        # rows than it needs); the others are checked by the feasibility test below
        indep: list[int] = []
        for i in act:
            if i < n_eq or np.linalg.matrix_rank(G[indep + [i]], tol=1e-10) == len(indep) + 1:
                indep.append(i)
        act = indep
        Ga = G[act] if act else np.zeros((0, n))
        K = np.block([[H, Ga.T], [Ga, np.zeros((len(act), len(act)))]])
        rhs = np.concatenate([f, h[act]])
        sol = np.linalg.lstsq(K, rhs, rcond=None)[0]
        xs, lam = sol[:n], sol[n:]
        # the least-squares solve must satisfy the KKT equations (a consistent system)
        if np.max(np.abs(K @ sol - rhs), initial=0.0) > 1e-9 * scale:
            return None
        viol = G @ xs - h
        viol[:n_eq] = np.abs(viol[:n_eq])
        lam_in = lam[n_eq:]
        if lam_in.size and lam_in.min() < -1e-12 * scale:
            act.pop(n_eq + int(np.argmin(lam_in)))
            continue
        if viol.max(initial=-np.inf) > POLISH_FEAS_TOL:
            j = int(np.argmax(viol))
            if j in act:
                return None
            act.append(j)
            continue
        return xs
    return None


#: Chebyshev radius (unit-box coordinates, normalised rows) below which a set is empty, and
#: within which of zero it has no interior (some rows are implicit equalities).
RADIUS_TOL = 1e-9


def chebyshev(G, g, n_eq: int = 0):
    """Largest ``t <= 1`` with ``G x + t <= g`` on the inequality rows (the first ``n_eq`` rows are
    equalities ``G x = g``), by HiGHS.  Returns ``(t, duals of the inequality rows)``."""
    n = G.shape[1]
    Gi, gi = G[n_eq:], g[n_eq:]
    kw = {}
    if n_eq:
        kw = {"A_eq": np.hstack([G[:n_eq], np.zeros((n_eq, 1))]), "b_eq": g[:n_eq]}
    lp = linprog(np.r_[np.zeros(n), -1.0], A_ub=np.hstack([Gi, np.ones((Gi.shape[0], 1))]), b_ub=gi,
                 bounds=[(None, None)] * n + [(None, 1.0)], method="highs", **kw)
    if lp.status == 2 and n_eq:
        return -np.inf, None  # the equalities alone are inconsistent
    if lp.status != 0:
        raise RuntimeError(f"HiGHS LP status {lp.status} on a feasibility test: {lp.message}")
    return float(-lp.fun), np.asarray(lp.ineqlin.marginals, dtype=float)


class ExactWindowReference:
    """Exact optimum of eq. (10) (2-norm, no extra terms) of windows of ``system`` with ``T`` samples."""

    def __init__(self, system, T: int, clarabel_options: dict | None = None):
        self.system, self.T = system, int(T)
        self.n, self.m, self.p = system.n, system.m, system.p
        self.s = system.n_modes
        lo, hi = _box_of(system.state_bounds)
        self.cx, self.hx = (lo + hi) / 2.0, (hi - lo) / 2.0
        self.XA, self.Xb = np.asarray(system.state_bounds.A, float), np.asarray(system.state_bounds.b, float)
        self.UP = system.input_bounds
        self.modes = [(np.asarray(md.A, float), np.asarray(md.B, float), np.asarray(md.a, float),
                       np.asarray(md.C, float), np.asarray(md.D, float), np.asarray(md.c, float),
                       np.asarray(md.guard.A, float), np.asarray(md.guard.b, float)) for md in system.modes]
        self.options = dict(clarabel_options or {})
        self._qps: dict[int, _QP] = {}

    def _qp(self, n_res: int, n_rows: int) -> _QP:
        """The compiled QP of these shapes (one per prefix length and row count: no padding rows,
        which were seen to make Clarabel end 'inaccurate')."""
        key = (n_res, n_rows)
        if key not in self._qps:
            self._qps[key] = _QP(self.n, n_res, n_rows, self.options)
        return self._qps[key]

    # -------------------------------------------------------------- numpy model
    def simulate(self, x0, modes, U) -> np.ndarray:
        X = np.empty((len(modes), self.n))
        X[0] = x0
        for k in range(len(modes) - 1):
            A, B, a = self.modes[modes[k]][:3]
            X[k + 1] = A @ X[k] + B @ U[k] + a
        return X

    def cost(self, x0, modes, U, Y) -> float:
        X = self.simulate(x0, modes, U)
        tot = 0.0
        for k, q in enumerate(modes):
            C, D, c = self.modes[q][3:6]
            e = Y[k] - C @ X[k] - D @ U[k] - c
            tot += float(e @ e)
        return tot

    def violation(self, x0, modes, U) -> float:
        """Largest violation of the guards and of ``X`` along the trajectory (original units)."""
        X = self.simulate(x0, modes, U)
        worst = 0.0
        for k, q in enumerate(modes):
            Gq, gq = self.modes[q][6:8]
            worst = max(worst, float(np.max(Gq @ np.concatenate([X[k], U[k]]) - gq, initial=0.0)),
                        float(np.max(self.XA @ X[k] - self.Xb, initial=0.0)))
        return worst

    # -------------------------------------------------------------- the enumeration
    def _step_rows(self, q, k, P, pvec, U, Y):
        """Constraint rows (unit-box coordinates ``xi``) and residual rows of window step ``k`` in mode ``q``."""
        n = self.n
        _, _, _, C, D, c, Gq, gq = self.modes[q]
        G = np.vstack([Gq[:, :n] @ P, self.XA @ P])
        g = np.concatenate([gq - Gq[:, n:] @ U[k] - Gq[:, :n] @ pvec, self.Xb - self.XA @ pvec])
        norm = np.max(np.abs(G), axis=1)
        zero = norm == 0
        if np.any(g[zero] < 0):
            return None  # a row 0 <= negative: infeasible for every state
        G, g = G[~zero] / norm[~zero, None], g[~zero] / norm[~zero]
        Ar = C @ P
        rr = Y[k] - C @ pvec - D @ U[k] - c
        return G, g, Ar, rr

    def _split(self, G, g, res: ExactWindowResult):
        """Feasibility of ``G xi <= g`` by HiGHS: ``None`` if empty, else ``(G, g, n_eq)`` with the
        implicit equalities first (rows that are tight on the whole set, from the duals of the
        Chebyshev LP when the set has no interior; linearly dependent ones dropped)."""
        n_eq = 0
        while True:
            res.n_lp += 1
            t, lam = chebyshev(G, g, n_eq)
            if t < -RADIUS_TOL:
                return None
            if t > RADIUS_TOL or lam is None:
                return G, g, n_eq
            res.n_degenerate += 1
            new = n_eq + np.nonzero(np.abs(lam) > 1e-9)[0]
            if new.size == 0:
                return G, g, n_eq
            rest = np.setdiff1d(np.arange(n_eq, len(g)), new)
            eq = list(range(n_eq))
            for i in new:  # keep a linearly independent set of equality rows
                if np.linalg.matrix_rank(G[eq + [int(i)]], tol=1e-10) == len(eq) + 1:
                    eq.append(int(i))
            dropped = np.setdiff1d(new, eq)  # dependent: consistent (the LP is feasible), implied
            G, g = np.vstack([G[eq], G[rest]]), np.concatenate([g[eq], g[rest]])
            if dropped.size and len(eq) == n_eq:
                return G, g, n_eq
            n_eq = len(eq)
            if n_eq == len(g):
                return G, g, n_eq

    def _solve_qp(self, A, r, split, res: ExactWindowResult):
        """Least cost of the fixed-sequence QP in ``xi``: ``(xi, value, certified)`` or ``None`` (infeasible)."""
        G, g, n_eq = split
        res.n_qp += 1
        xi_ls = np.linalg.lstsq(A, r, rcond=None)[0]  # centre: the unconstrained least-squares point
        r0, h = r - A @ xi_ls, g - G @ xi_ls
        retry = n_eq > 0
        if not retry:
            d = self._qp(A.shape[0], G.shape[0]).solve(A, r0, G, h)
            retry = d is not None and d[1] and _kkt_polish(A, r0, G, h, d[0], n_eq) is None
        if retry:
            # no interior (the implicit equalities as equalities), or the compiled problem ended
            # 'inaccurate' without a KKT point: the problem built afresh in xi, not centred
            res.n_fresh += 1
            xv = cp.Variable(self.n)
            cons = [G[:n_eq] @ xv == g[:n_eq]] if n_eq else []
            if n_eq < len(g):
                cons.append(G[n_eq:] @ xv <= g[n_eq:])
            prob = cp.Problem(cp.Minimize(cp.sum_squares(A @ xv - r)), cons)
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", UserWarning)
                prob.solve(solver=cp.CLARABEL, **self.options)
            d = _outcome(prob, xv)
            if d is not None:
                d = (d[0] - xi_ls, d[1])
        if d is None:
            res.n_qp_infeasible += 1
            return None
        d, inaccurate = d
        pol = _kkt_polish(A, r0, G, h, d, n_eq)
        certified = pol is not None
        if inaccurate:
            if not certified:
                raise RuntimeError("Clarabel status 'optimal_inaccurate' on a fixed-sequence QP and its point is "
                                   "not a KKT point (only optimal or infeasible accepted)")
            res.n_inaccurate_certified += 1
        if not certified:
            res.n_unpolished += 1
            pol = d
        xi = xi_ls + pol
        e = A @ xi - r
        return xi, float(e @ e), certified

    def solve(self, U, Y, *, prune: bool = True, bound_prune: bool = False, bound_margin_rtol: float = 1e-7,
              keep_costs: bool = False) -> ExactWindowResult:
        """The optimum of the window ``(U, Y)`` (``(T, m)``, ``(T, p)``) over every mode sequence.

        ``prune``: LP feasibility of every prefix (else every full sequence's QP is solved);
        ``bound_prune``: also prune prefixes whose certified least cost exceeds the incumbent by
        more than ``bound_margin_rtol * (1 + incumbent)``; ``keep_costs``: record every full
        sequence's least cost in ``costs``.
        """
        t0 = time.perf_counter()
        T, n = self.T, self.n
        U = np.asarray(U, dtype=float).reshape(T, self.m)
        Y = np.asarray(Y, dtype=float).reshape(T, self.p)
        if not np.all(np.isfinite(U)) or not np.all(np.isfinite(Y)):
            raise ValueError("non-finite window data")
        if self.UP is not None and np.any(U @ np.asarray(self.UP.A, float).T > np.asarray(self.UP.b, float) + 1e-9):
            raise ValueError("an input of the window lies outside U")
        res = ExactWindowResult(np.inf, None, None, None, n_sequences=self.s ** T)
        best = {"cost": np.inf, "xi": None, "modes": None}
        unpolished: list[float] = []  # costs of the full sequences whose KKT polish failed
        H = np.diag(self.hx)

        def leaf(modes, G, g, A, r):
            split = self._split(G, g, res)
            if split is None:
                res.n_lp_infeasible += 1
                return
            out = self._solve_qp(A, r, split, res)
            if out is None:
                return
            xi, _, _ = out
            x0 = self.cx + self.hx * xi
            cost = self.cost(x0, modes, U, Y)  # recomputed through the model, original units
            res.max_violation = max(res.max_violation, self.violation(x0, modes, U))
            if keep_costs:
                res.costs[tuple(modes)] = cost
            if not out[2]:
                unpolished.append(cost)
            if cost < best["cost"]:
                best.update(cost=cost, xi=xi, modes=tuple(modes))

        def node(prefix, P, pvec, G, g, A, r):
            k = len(prefix)
            children = []
            for q in range(self.s):
                rows = self._step_rows(q, k, P, pvec, U, Y)
                if rows is None:
                    res.n_leaves_pruned += self.s ** (T - k - 1)
                    continue
                Gc, gc = np.vstack([G, rows[0]]), np.concatenate([g, rows[1]])
                Ac, rc = np.vstack([A, rows[2]]), np.concatenate([r, rows[3]])
                if k + 1 == T:
                    leaf(prefix + [q], Gc, gc, Ac, rc)
                    continue
                split = None
                if prune or bound_prune:
                    split = self._split(Gc, gc, res)
                    if split is None:
                        res.n_lp_infeasible += 1
                        res.n_leaves_pruned += self.s ** (T - k - 1)
                        continue
                lb = -np.inf
                if bound_prune:
                    out = self._solve_qp(Ac, rc, split, res)
                    if out is None:
                        res.n_leaves_pruned += self.s ** (T - k - 1)
                        continue
                    if out[2]:
                        lb = out[1]
                A_q, B_q, a_q = self.modes[q][:3]
                children.append((lb, q, A_q @ P, A_q @ pvec + B_q @ U[k] + a_q, Gc, gc, Ac, rc))
            children.sort(key=lambda c: (c[0], c[1]))  # cheapest bound first: an early incumbent
            for lb, q, Pn, pn, Gc, gc, Ac, rc in children:
                if bound_prune and lb > best["cost"] + bound_margin_rtol * (1.0 + best["cost"]):
                    res.n_bound_pruned += 1
                    res.n_leaves_pruned += self.s ** (T - k - 1)
                    continue
                node(prefix + [q], Pn, pn, Gc, gc, Ac, rc)

        node([], H.copy(), self.cx.copy(), np.zeros((0, n)), np.zeros(0), np.zeros((0, n)), np.zeros(0))
        if best["xi"] is not None:
            x0 = self.cx + self.hx * best["xi"]
            res.optimum, res.modes, res.x_start = best["cost"], best["modes"], x0
            res.states = self.simulate(x0, best["modes"], U)
            # a sequence left at Clarabel's point (accurate to its 1e-8 gap) could only matter
            # if its cost is near the optimum: those are counted, to be read as a warning
            res.n_unpolished_near = sum(c <= res.optimum + UNPOLISHED_NEAR * (1.0 + res.optimum) for c in unpolished)
        res.seconds = time.perf_counter() - t0
        return res


def exact_window_optimum(system, U, Y, **kwargs) -> ExactWindowResult:
    """One-shot :meth:`ExactWindowReference.solve` (``T`` from ``U``)."""
    U = np.asarray(U, dtype=float)
    return ExactWindowReference(system, U.shape[0]).solve(U, Y, **kwargs)


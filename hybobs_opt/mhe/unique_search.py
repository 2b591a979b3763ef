"""Uniqueness of a certified MIQP window decided over mode prefixes (paper 002, Section 4.1).

The flag ``observable`` of :class:`~hybobs_opt.mhe.MHEObserver` needs a proof that no admissible
window trajectory with a state ``delta`` away from the optimum's (``sign (xi_k,j - xi*_k,j) >=
delta``, scaled by the box of ``X``) costs at most ``J* + epsilon``
(:class:`~hybobs_opt.mhe.uniqueness.SeparatedProgram`).  This module proves it by the same branch
and bound over mode prefixes that certifies the optimum (:mod:`hybobs_opt.mhe.certify`), with a
set of open separation directions per node:

* a prefix whose proven lower bound (eq. (10) over its steps) exceeds the threshold closes every
  direction at once;
* a direction on a state the prefix fixes (step ``k`` below the prefix length: the state is an
  affine map of ``theta`` then) is closed when its *direction bound* exceeds the threshold.  With
  the prefix QP's point ``theta^`` and row multipliers ``lam >= 0``, for every feasible ``theta``
  ``J(theta) >= l(theta) = J(theta^) + lam' (G theta^ - g) + rho' z + ||R z||^2``
  (``z = theta - theta^``, ``rho = 2 R' (R theta^ + r) + G' lam``), so the least cost on the
  half-space ``c' theta >= beta`` of the direction is at least the minimum of ``l`` there, in
  closed form when ``R'R`` is positive definite:
  ``l(theta^) - rho' Q^-1 rho / 4 + max(mu, 0)^2 c' Q^-1 c / 4`` with ``Q = R'R`` and
  ``mu = (2 (beta - c' theta^) + c' Q^-1 rho) / c' Q^-1 c``; it is lowered by a rounding allowance
  (:data:`~hybobs_opt.tolerances.MHE_DIRECTION_BOUND_RTOL` of its terms);
* at a full mode sequence, a direction is also closed by :func:`residual_bounds` (no Hessian:
  ``||R theta + r|| >= (beta + z'r - ||e||_1) / ||z||`` for ``R'z ~ c``, valid where ``R'R`` is
  too ill-conditioned for the closed form);
* at a full mode sequence, a direction still open gets the exact QP of that sequence with the
  separation row (its lower bound proven by weak duality,
  :meth:`~hybobs_opt.mhe.window.WindowModel.sequence_qp` with ``robust``): above the threshold it
  closes, a verified trajectory at most ``J* + epsilon`` minus the decision band is an
  alternative, anything else leaves the window undecided.

"Unique" is returned only when every direction of every prefix is closed; an undecided search
(node budget, a QP without certified answer, a separated cost in the band) leaves the decision to
the separated MIQP.  The node QPs are those of :func:`~hybobs_opt.mhe.certify.node_qp`, shared
with the optimum's search of the same window.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ..tolerances import MHE_DIRECTION_BOUND_RTOL, MHE_DIRECTION_COND_MAX
from .certify import node_qp

__all__ = ["UniquenessSearch", "direction_bounds", "residual_bounds", "search_uniqueness"]


@dataclass(frozen=True)
class UniquenessSearch:
    """Result of :func:`search_uniqueness`.

    ``unique``: every direction of every prefix proven above the threshold.  ``alternative``: a
    verified trajectory (the dict of :meth:`SeparatedProgram.alternative`) at most the low edge of
    the decision band, else ``None``.  ``reason`` says why the search is undecided (empty when it
    decided).  ``nodes``: prefix QPs asked (shared with the optimum's search), ``separated_qps``:
    exact QPs of a full sequence with a separation row, ``closed_by_bound``: directions closed by
    their closed-form bound.
    """

    unique: bool
    alternative: dict | None
    reason: str
    nodes: int
    separated_qps: int
    closed_by_bound: int
    seconds: float

    def summary(self) -> dict:
        """The counts, time and reason as a JSON-ready dict (``info["uniqueness"]["prefix_search"]``)."""
        return {"unique": self.unique, "nodes": self.nodes, "separated_qps": self.separated_qps,
                "closed_by_bound": self.closed_by_bound, "seconds": self.seconds, "reason": self.reason}


def direction_bounds(problem: tuple, theta: np.ndarray, lam: np.ndarray, C: np.ndarray, beta: np.ndarray):
    """Proven lower bounds of ``||R theta + r||^2`` over ``G theta <= g`` and ``c_i' theta >= beta_i``,
    one per row ``c_i`` of ``C``, from any ``theta^`` and ``lam >= 0`` (module docstring); ``None``
    when ``R'R`` is singular or ill-conditioned (above
    :data:`~hybobs_opt.tolerances.MHE_DIRECTION_COND_MAX`).

    Parameters
    ----------
    problem : tuple
        ``(R, r, G, g, ...)`` of :meth:`~hybobs_opt.mhe.window.WindowModel.sequence_problem`.
    theta : (nt,) array
        Any point (the prefix QP's minimiser gives the tightest bounds).
    lam : (n_rows,) array
        Multipliers of the rows ``G theta <= g`` in cost units, ``>= 0``.
    C : (nd, nt) array
    beta : (nd,) array
    """
    R, r, G, g = problem[:4]
    Q = R.T @ R
    ev = np.linalg.eigvalsh(Q)
    if not (ev[0] > 0 and ev[-1] <= MHE_DIRECTION_COND_MAX * ev[0]):
        return None
    lam = np.maximum(np.asarray(lam, dtype=float), 0.0)
    L = np.linalg.cholesky(Q)
    res = R @ theta + r
    J = float(res @ res)
    comp = float(lam @ (G @ theta - g))
    rho = 2.0 * R.T @ res + G.T @ lam
    Li_rho = np.linalg.solve(L, rho)
    Li_C = np.linalg.solve(L, C.T)
    quad = float(Li_rho @ Li_rho)  # rho' Q^-1 rho
    gam = np.einsum("ij,ij->j", Li_C, Li_C)  # c' Q^-1 c
    cq = Li_C.T @ Li_rho  # c' Q^-1 rho
    s = beta - C @ theta
    mu = np.maximum((2.0 * s + cq) / gam, 0.0)
    extra = mu * mu * gam / 4.0
    bound = J + comp - quad / 4.0 + extra
    allowance = MHE_DIRECTION_BOUND_RTOL * (abs(J) + abs(comp) + quad / 4.0 + extra)
    return bound - allowance


def residual_bounds(problem: tuple, C: np.ndarray, beta: np.ndarray) -> np.ndarray:
    """Proven lower bounds of ``||R theta + r||^2`` over ``c_i' theta >= beta_i`` and
    ``|theta_j| <= 1`` on the window-start state (``x0`` in the box of ``X``), one per row
    ``c_i`` of ``C``, without the Hessian: for any ``z`` with ``e = R'z - c``,
    ``c' theta = z'(R theta + r) - z'r - e' theta``, so by Cauchy-Schwarz
    ``||R theta + r|| >= (beta + z'r - ||e||_1) / ||z||``; ``z`` solves ``R'z = c`` in least
    squares.  Its error grows with ``cond(R)``, not ``cond(R'R)`` as in
    :func:`direction_bounds`: it closes directions of full sequences whose ``R'R`` is too
    ill-conditioned for the closed form (model (16) at T = 3: ``cond(R'R)`` about 8e7).  The
    guards are relaxed (a lower bound stays one); ``0`` where the bound is not positive and
    ``-inf`` everywhere with disturbance variables (no box bounds them).  Lowered by a rounding
    allowance of :data:`~hybobs_opt.tolerances.MHE_DIRECTION_BOUND_RTOL` of the terms.

    Parameters
    ----------
    problem : tuple
        ``(R, r, G, g, dist)`` of :meth:`~hybobs_opt.mhe.window.WindowModel.sequence_problem`.
    C : (nd, nt) array
    beta : (nd,) array
    """
    R, r = problem[0], problem[1]
    if problem[4] or R.shape[1] != C.shape[1]:
        return np.full(C.shape[0], -np.inf)
    Z = np.linalg.lstsq(R.T, C.T, rcond=None)[0]  # (k, nd)
    E = np.abs(R.T @ Z - C.T).sum(axis=0)
    zr = Z.T @ r
    nz = np.sqrt(np.einsum("ij,ij->j", Z, Z))
    allow = MHE_DIRECTION_BOUND_RTOL * (np.abs(beta) + np.abs(Z).T @ np.abs(r) + (np.abs(R.T) @ np.abs(Z)).sum(axis=0)
                                        + np.abs(C).sum(axis=1) + E)
    with np.errstate(divide="ignore", invalid="ignore"):
        s = (beta + zr - E - allow) / (nz * (1.0 + MHE_DIRECTION_BOUND_RTOL))
    s = np.where((nz > 0) & np.isfinite(s) & (s > 0), s, 0.0)
    return s * s


def _state_maps(model, seq: tuple, U: np.ndarray, nt: int, dist: bool) -> tuple[np.ndarray, np.ndarray]:
    """``x_k = Px[k] theta + px[k]`` (original units) for the steps of the prefix ``seq``."""
    n, T, hx = model.n, model.T, model.hx
    Px = np.zeros((n, nt))
    Px[:, :n] = np.diag(hx)
    px = model.cx.copy()
    Ps, ps = [], []
    for k, q in enumerate(seq):
        Ps.append(Px)
        ps.append(px)
        if k < T - 1:
            md = model.system.modes[int(q)]
            Px = md.A @ Px
            px = md.A @ px + md.B @ U[k] + md.a
            if dist:
                Px = Px.copy()
                Px[:, n + k * n: n + (k + 1) * n] += np.diag(hx)
    return np.array(Ps), np.array(ps)


def search_uniqueness(model, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, xs: np.ndarray, allowed: np.ndarray,
                      delta: float, thr_lo: float, thr_hi: float, *, alternative: Callable, max_nodes: int,
                      deadline: float | None = None) -> UniquenessSearch:
    """Decide the uniqueness of a window's optimum over mode prefixes (module docstring).

    Parameters
    ----------
    model : WindowModel
        Norm 2, no extension.
    U, Y : (T, m), (T, p) arrays
        The window's data.
    xbar : (n,) array
        The arrival prior.
    xs : (T, n) array
        The optimum's scaled window states (the centres of the separation).
    allowed : (2 n T,) bool array
        Directions to separate (``d = 2 (k n + j)``, ``+ 1`` for the minus side).
    delta : float
        The separation (scaled).
    thr_lo, thr_hi : float
        The decision band around ``J* + epsilon``: a separated cost proven above ``thr_hi``
        closes a direction, a verified one at most ``thr_lo`` is an alternative.
    alternative : callable
        ``alternative(x0, modes, W)``: the verified alternative dict of a trajectory, or ``None``.
    max_nodes : int
        Prefix QPs allowed (undecided beyond).
    deadline : float, optional
        ``time.perf_counter()`` after which the search stops undecided.

    Returns
    -------
    UniquenessSearch
        ``unique``, or a verified ``alternative``, or neither with the ``reason``.

    See Also
    --------
    hybobs_opt.mhe.uniqueness.SeparatedProgram.decide : Calls it for norm 2 before the separated MIQP.
    """
    t0 = time.perf_counter()
    T, n = model.T, model.n
    s_modes = model.system.n_modes
    hx, cx = model.hx, model.cx
    dirs0 = np.nonzero(allowed)[0]
    nodes = sep_qps = closed = 0

    def done(unique: bool, reason: str = "", alt=None) -> UniquenessSearch:
        return UniquenessSearch(unique, alt, reason, nodes, sep_qps, closed, time.perf_counter() - t0)

    if dirs0.size == 0:
        return done(True)
    d_k = (dirs0 // 2) // n
    d_j = (dirs0 // 2) % n
    d_sign = np.where(dirs0 % 2 == 0, 1.0, -1.0)
    stack: list[tuple[tuple[int, ...], np.ndarray]] = [((), np.arange(dirs0.size))]
    while stack:
        prefix, open_ = stack.pop()
        for q in range(s_modes):
            seq = prefix + (q,)
            nodes += 1
            if nodes > max_nodes:
                return done(False, f"node budget of {max_nodes} prefix QPs exhausted")
            if deadline is not None and time.perf_counter() > deadline:
                return done(False, "time budget exhausted")
            problem, solved = node_qp(model, seq, U, Y, xbar)
            if solved is None:
                return done(False, f"the QP of the mode prefix {seq} has no certified answer")
            theta, lower, lam = solved
            if theta is None or lower > thr_hi:
                continue  # infeasible, or every direction above the threshold
            L = len(seq)
            fixed = open_[d_k[open_] < L]
            still = open_
            # a prefix with fewer residual rows than unknowns has a singular R'R: no direction bound
            if fixed.size and (L == T or problem[0].shape[0] >= problem[0].shape[1]):
                Ps, ps = _state_maps(model, seq, U, problem[0].shape[1], problem[4])
                k, j, sg = d_k[fixed], d_j[fixed], d_sign[fixed]
                C = sg[:, None] * Ps[k, j, :] / hx[j][:, None]
                beta = delta + sg * (xs[k, j] - (ps[k, j] - cx[j]) / hx[j])
                bounds = direction_bounds(problem, theta, lam, C, beta)
                if L == T:
                    res = residual_bounds(problem, C, beta)
                    bounds = res if bounds is None else np.maximum(bounds, res)
                if bounds is not None:
                    shut = bounds > thr_hi
                    closed += int(shut.sum())
                    still = np.setdiff1d(open_, fixed[shut], assume_unique=True)
                if L == T and still.size:
                    # the exact QP of this sequence with each open direction's row
                    R, r, G, g, dist = problem
                    pos = {int(i): a for a, i in enumerate(fixed)}
                    for i in still:
                        a = pos[int(i)]
                        sep_qps += 1
                        sep = (R, r, np.vstack([G, -C[a][None, :]]), np.concatenate([g, [-beta[a]]]), dist)
                        # the plain bound first; the robust one (Clarabel, more active sets) only
                        # when the plain one does not clear the threshold
                        out = model.sequence_qp(sep, None, bound=True)
                        if out is not None and (out[0] is None or out[1] > thr_hi):
                            continue
                        out = model.sequence_qp(sep, None, bound=True, robust=True)
                        if out is None:
                            return done(False, f"the separated QP of the sequence {seq} has no certified answer")
                        th, low = out
                        if th is None or low > thr_hi:
                            continue
                        x0 = cx + hx * th[:n]
                        W = (th[n:].reshape(T - 1, n) * hx) if dist else np.zeros((max(T - 1, 0), n))
                        alt = alternative(x0, np.asarray(seq, dtype=int), W)
                        if alt is not None and alt["cost"] <= thr_lo:
                            return done(False, "", alt)
                        return done(False, f"separated cost of the sequence {seq} not decided against J* + epsilon "
                                           f"(bound {low:.6g}, threshold band {thr_lo:.6g}..{thr_hi:.6g})", alt)
                    continue
            if L < T:
                stack.append((seq, still))
    return done(True)

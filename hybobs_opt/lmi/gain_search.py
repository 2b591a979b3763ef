"""Local search for the largest decay rate of a constant gain under the exact bound ``||L||_2 <= l``.

The conditions of :mod:`.decay_design` keep the gain bound convex by a sufficient form (``P >= a I``
and a Schur complement), which can exclude most of the ball ``||L||_2 <= l``: when the best ``P``
is ill-conditioned, the rate they prove is a fraction of what a gain in the ball achieves (a third
on the flexible-joint robot).  This module attacks the problem the bound really poses, the
polytopic condition of paper 004 (Section 4's vertex form of Theorem 1) with the exact bound,

.. math::

    \\max_{\\sigma, P, L} \\sigma \\quad\\text{s.t.}\\quad
    P (A_v - L C_v) + (A_v - L C_v)^T P + \\sigma P \\preceq 0 \\;\\; \\forall v, \\quad
    P \\succ 0, \\quad \\|L\\|_2 \\le l ,

over the vertices ``v`` of the Jacobian box.  It is bilinear in ``(P, L)`` and has local optima,
so it is searched locally from several starts, and **what is proven is the rate of the pair
returned**: every pair kept is re-checked in numpy (:func:`.polytopic.vertex_decay`) and its gain's
norm computed; the answer is a lower bound of the problem's optimum, never the optimum itself.

Starts
    The gains of the convex conditions, and gains *screened by eigenvalues*: the points of a Sobol
    sequence on the box ``[-l, l]^{n x p}`` (clipped to the ball), ranked by the eigenvalue bound
    ``min_v -2 max Re eig(A_v - L C_v)`` -- no quadratic certificate at ``L`` proves a larger rate,
    since ``P A_cl + A_cl^T P + sigma P <= 0`` gives ``2 Re(lambda) + sigma <= 0`` on an
    eigenvector -- the best of them improved by Nelder-Mead on that bound.

Each start then goes through three steps, each kept only when its re-checked rate is larger:

1. *certify*: the best ``P`` for the gain, by bisection on ``sigma`` (for a fixed gain the
   condition is an LMI in ``P``; a generalized eigenvalue problem);
2. *convex-concave steps*: ``(P, Y = P L)`` jointly, with the bound written exactly as
   ``[[P S^-2 P, Y], [Y^T, l^2 I]] >= 0`` (``S`` the state scaling, ``L = S P^-1 Y`` in model
   units) and its concave part replaced by the linearisation
   ``P0 S^-2 P + P S^-2 P0 - P0 S^-2 P0 <= P S^-2 P`` at the current ``P0``.  The restriction is
   exact at ``P0``, so the current pair stays feasible and the rate never decreases (a
   convex-concave procedure); each step is solved in the frame where ``P0`` is the identity;
3. *polish*: IPOPT (CasADi) on a smooth form of the same problem (``P = R R^T + eps I``, each
   vertex condition and the bound as equalities with a squared slack factor), time-scaled by the
   current rate; its point is re-certified by step 1 at its gain, since an interior-point
   method on a non-convex problem may stop at a point that is not feasible.

Nothing depends on the clock: the starts, the number of steps and of IPOPT iterations are fixed
(:mod:`hybobs_opt.defaults`), so one input gives one answer; a candidate replaces the best only
when its rate is larger by :data:`~hybobs_opt.tolerances.SEARCH_IMPROVEMENT_RTOL`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from .._native_output import captured_native_output
from ..errors import ModelError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..tolerances import (GAIN_BOUND_RTOL, GAIN_SEARCH_P_FLOOR, GAIN_SEARCH_SOLVER_TOL, GAIN_SEARCH_START_MARGIN,
                          LMI_STRICT_MARGIN, SEARCH_IMPROVEMENT_RTOL)
from .bounds import JacobianBounds
from .lmi_model import box_scaling, lmi_data
from .observer_lmi import bisect_decay
from .polytopic import vertex_decay, vertex_matrices, vertex_slopes
from .solve import POINT_STATUSES, solve_problem

__all__ = ["GainSearchResult", "SearchStart", "decay_gain_search", "eigenvalue_bound", "gain_decay_rate"]


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class SearchStart:
    """What one start of :func:`decay_gain_search` reached (rates of ``V = e'Pe``, 1/s).

    Parameters
    ----------
    source : str
        Where the start came from (``"polytopic condition"``, ``"eigenvalue screen 1"``...).
    eig_bound : float
        The eigenvalue bound at the start's gain (no quadratic certificate at that gain proves more).
    certified, convex_concave, polished : float
        The rate proven after each step (``-inf`` when none).
    steps : int
        Convex-concave steps taken.

    See Also
    --------
    decay_gain_search : Records one per start.
    GainSearchResult : Holds them in ``starts``.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import decay_gain_search
    >>> start = decay_gain_search(pendulum, bounds, 10.0).starts[0]
    >>> start.source
    'eigenvalue screen 1'
    >>> bool(start.polished >= start.convex_concave >= start.certified)
    True
    """

    source: str
    eig_bound: float
    certified: float
    convex_concave: float
    polished: float
    steps: int

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        def num(v):
            return float(v) if np.isfinite(v) else None
        return {"source": self.source, "eig_bound": num(self.eig_bound), "certified": num(self.certified),
                "convex_concave": num(self.convex_concave), "polished": num(self.polished), "steps": self.steps}


@dataclass(frozen=True)
class GainSearchResult:
    """The best pair ``(P, L)`` of :func:`decay_gain_search` and how it was found.

    Parameters
    ----------
    found : bool
        Some start gave a pair that proves a positive rate within the bound.
    sigma : float
        The rate ``(P, L)`` proves on every vertex of the Jacobian box (numpy; ``V' <= -sigma V``).
    L, P : arrays or None
        Gain (``n x p``, outputs in model order) and Lyapunov matrix, model coordinates.
    gain_norm : float or None
        ``||L||_2`` (at most the bound).
    eig_bound : float or None
        The eigenvalue bound at ``L``: no quadratic certificate proves more with this gain.
    source : str
        The start the pair came from.
    starts : tuple of SearchStart
        Every start, in the order tried.
    solves, failed_solves : int
        Conic solves, and those that returned no usable point (counted as "not feasible").
    seconds : float
    gain_bound : float
        The bound on ``||L||_2`` searched under (model units).

    See Also
    --------
    decay_gain_search : Returns one.
    SearchStart : One start of the search.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import decay_gain_search
    >>> result = decay_gain_search(pendulum, bounds, 10.0)
    >>> result.found, result.L.shape, bool(result.gain_norm <= 10.0)
    (True, (2, 1), True)
    >>> bool(result.sigma > 0), len(result.starts) > 0
    (True, True)
    """

    found: bool
    sigma: float
    L: np.ndarray | None
    P: np.ndarray | None
    gain_norm: float | None
    eig_bound: float | None
    source: str
    starts: tuple[SearchStart, ...]
    solves: int
    failed_solves: int
    seconds: float
    gain_bound: float = field(default=float("nan"))

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"found": self.found, "sigma_verified": self.sigma if self.found else None,
                "gain_bound": self.gain_bound, "gain_norm": self.gain_norm, "eig_bound": self.eig_bound,
                "source": self.source, "L": None if self.L is None else self.L.tolist(),
                "starts": [s.to_dict() for s in self.starts], "solves": self.solves,
                "failed_solves": self.failed_solves, "seconds": self.seconds}


# ---------------------------------------------------------------------------- the problem's data
@dataclass(frozen=True)
class _Vertices:
    """The vertex matrices in scaled coordinates ``x = diag(d) x_bar`` and the bound (model units)."""

    As: tuple[np.ndarray, ...]
    Cs: tuple[np.ndarray, ...]
    d: np.ndarray
    bound: float

    @property
    def n(self) -> int:
        return self.As[0].shape[0]

    @property
    def p(self) -> int:
        return self.Cs[0].shape[0]

    def rate(self, P: np.ndarray, Lbar: np.ndarray) -> float:
        """The rate ``(P, Lbar)`` proves on every vertex, ``-inf`` beyond the gain bound or for ``P`` not positive."""
        if not (np.all(np.isfinite(P)) and np.all(np.isfinite(Lbar))):
            return float("-inf")
        if self.norm(Lbar) > self.bound * (1.0 + GAIN_BOUND_RTOL):
            return float("-inf")
        return float(vertex_decay(P, Lbar, list(self.As), list(self.Cs)))

    def norm(self, Lbar: np.ndarray) -> float:
        """``||L||_2`` in model units of a scaled gain."""
        return float(np.linalg.norm(self.d[:, None] * Lbar, 2))

    def clip(self, Lbar: np.ndarray) -> np.ndarray:
        """The gain scaled into the ball (unchanged inside)."""
        norm = self.norm(Lbar)
        return Lbar if norm <= self.bound else Lbar * (self.bound / norm)


def eigenvalue_bound(As, Cs, Ls: np.ndarray) -> np.ndarray:
    """``min_v -2 max Re eig(A_v - L C_v)`` for each gain of the stack ``Ls`` (``(k, n, p)``).

    No quadratic certificate proves a larger rate of ``V`` with that gain: ``P A_cl + A_cl^T P +
    sigma P <= 0`` on an eigenvector of ``A_cl`` with eigenvalue ``lambda`` gives
    ``2 Re(lambda) + sigma <= 0``.
    """
    Ls = np.asarray(Ls, dtype=float)
    A = np.asarray(As, dtype=float)[:, None]  # (vertices, 1, n, n)
    C = np.asarray(Cs, dtype=float)[:, None]
    return (-2.0 * np.linalg.eigvals(A - Ls[None] @ C).real.max(axis=-1)).min(axis=0)


def _frame(P: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(T, T^-1)`` with ``T = P^-1/2``: in ``x = T z`` the Lyapunov matrix ``P`` is the identity."""
    w, U = np.linalg.eigh(0.5 * (P + P.T))
    return U @ np.diag(w ** -0.5) @ U.T, U @ np.diag(w ** 0.5) @ U.T


@dataclass
class _Trial:
    """One solve of a step, in the form :func:`.observer_lmi.bisect_decay` reads."""

    feasible: bool
    status: str


class _Counter:
    def __init__(self):
        self.solves = 0
        self.failed = 0

    def run(self, problem: cp.Problem, accept) -> str:
        self.solves += 1
        out = solve_problem(problem, fallback=False, accept=accept)
        if out.status not in POINT_STATUSES:
            self.failed += out.status != "infeasible"
        return str(out.status)


# ---------------------------------------------------------------------------- step 1: the best P for a gain
class _FixedGain:
    """``P M_v + M_v^T P + sigma P <= -margin I``, ``P >= I`` for the closed-loop matrices ``M_v``."""

    def __init__(self, n: int, nv: int):
        self.P = cp.Variable((n, n), symmetric=True)
        self.sigma = cp.Parameter(nonneg=True)
        self.M = [cp.Parameter((n, n)) for _ in range(nv)]
        cons = []
        for M in self.M:
            B = self.P @ M + M.T @ self.P + self.sigma * self.P
            cons.append(0.5 * (B + B.T) << -LMI_STRICT_MARGIN * np.eye(n))
        cons.append(self.P >> np.eye(n))
        self.problem = cp.Problem(cp.Minimize(0), cons)


def _certify(V: _Vertices, Lbar: np.ndarray, hint: np.ndarray | None, cap: float, counter: _Counter,
             cache: dict) -> tuple[float, np.ndarray | None]:
    """The largest rate of a Lyapunov matrix for the gain ``Lbar`` and that matrix (bisection on sigma)."""
    from ..defaults import GAIN_SEARCH_RTOL

    n = V.n
    usable = hint is not None and np.all(np.isfinite(hint)) and np.linalg.eigvalsh(0.5 * (hint + hint.T)).min() > 0
    start = hint if usable else _lyapunov_hint(V, Lbar)
    T, Ti = _frame(start)
    if "fixed" not in cache:  # one compiled problem per search
        cache["fixed"] = _FixedGain(n, len(V.As))
    lmi = cache["fixed"]
    for par, A, C in zip(lmi.M, V.As, V.Cs):
        par.value = Ti @ (A - Lbar @ C) @ T
    best: list = [V.rate(start, Lbar), start]

    def solve(sig: float) -> _Trial:
        lmi.sigma.value = float(sig)
        point: list = []

        def accept() -> bool:
            Pv = lmi.P.value
            if Pv is None:
                return False
            P = Ti @ (0.5 * (Pv + Pv.T)) @ Ti
            rate = V.rate(0.5 * (P + P.T), Lbar)
            point[:] = [rate, 0.5 * (P + P.T)]
            return rate >= sig
        status = counter.run(lmi.problem, accept)
        if point and point[0] > best[0]:
            best[:] = point
        ok = bool(point) and point[0] >= sig
        return _Trial(ok, status)

    guess = best[0] if np.isfinite(best[0]) and best[0] > 0 else None
    bisect_decay(solve, cap, GAIN_SEARCH_RTOL, guess=guess)
    return (best[0], best[1]) if np.isfinite(best[0]) else (float("-inf"), None)


def _lyapunov_hint(V: _Vertices, Lbar: np.ndarray) -> np.ndarray:
    """A Lyapunov matrix of the first vertex's closed loop (a frame for step 1; the identity when unstable)."""
    from scipy.linalg import solve_continuous_lyapunov

    Acl = V.As[0] - Lbar @ V.Cs[0]
    if np.linalg.eigvals(Acl).real.max() >= 0:
        return np.eye(V.n)
    P = solve_continuous_lyapunov(Acl.T, -np.eye(V.n))
    P = 0.5 * (P + P.T)
    return P if np.all(np.isfinite(P)) and np.linalg.eigvalsh(P).min() > 0 else np.eye(V.n)


# ---------------------------------------------------------------------------- step 2: convex-concave steps
class _ConvexConcave:
    """The vertex LMIs in ``(P, Y)`` with the gain bound linearised at ``P0 = I`` (the frame of the current P)."""

    def __init__(self, n: int, p: int, nv: int, bound: float):
        self.P = cp.Variable((n, n), symmetric=True)
        self.Y = cp.Variable((n, p))
        self.sigma = cp.Parameter(nonneg=True)
        self.A = [cp.Parameter((n, n)) for _ in range(nv)]
        self.C = [cp.Parameter((p, n)) for _ in range(nv)]
        self.W = cp.Parameter((n, n), symmetric=True)  # S^-2 in the frame
        cons = []
        for A, C in zip(self.A, self.C):
            B = self.P @ A + A.T @ self.P - self.Y @ C - C.T @ self.Y.T + self.sigma * self.P
            cons.append(0.5 * (B + B.T) << -LMI_STRICT_MARGIN * np.eye(n))
        lin = self.W @ self.P + self.P @ self.W
        G = cp.bmat([[0.5 * (lin + lin.T) - self.W, self.Y], [self.Y.T, bound ** 2 * np.eye(p)]])
        cons += [0.5 * (G + G.T) >> 0, self.P >> LMI_STRICT_MARGIN * np.eye(n)]
        self.problem = cp.Problem(cp.Minimize(0), cons)


def _convex_concave(V: _Vertices, P: np.ndarray, Lbar: np.ndarray, rate: float, cap: float, counter: _Counter,
                    cache: dict) -> tuple[float, np.ndarray, np.ndarray, int]:
    from ..defaults import GAIN_SEARCH_CCP_STEPS, GAIN_SEARCH_MIN_GAIN, GAIN_SEARCH_RTOL

    if "ccp" not in cache:
        cache["ccp"] = _ConvexConcave(V.n, V.p, len(V.As), V.bound)
    lmi = cache["ccp"]
    steps = 0
    for steps in range(1, GAIN_SEARCH_CCP_STEPS + 1):
        T, Ti = _frame(P)
        for par, A in zip(lmi.A, V.As):
            par.value = Ti @ A @ T
        for par, C in zip(lmi.C, V.Cs):
            par.value = C @ T
        W = Ti @ np.diag(1.0 / V.d ** 2) @ Ti
        lmi.W.value = 0.5 * (W + W.T)
        best: list = [rate, P, Lbar]

        def solve(sig: float) -> _Trial:
            lmi.sigma.value = float(sig)
            point: list = []

            def accept() -> bool:
                Pv, Yv = lmi.P.value, lmi.Y.value
                if Pv is None or Yv is None:
                    return False
                Pm = Ti @ (0.5 * (Pv + Pv.T)) @ Ti
                Pm = 0.5 * (Pm + Pm.T)
                try:
                    Lm = np.linalg.solve(Pm, Ti @ Yv)
                except np.linalg.LinAlgError:
                    return False
                point[:] = [V.rate(Pm, Lm), Pm, Lm]
                return point[0] >= sig
            status = counter.run(lmi.problem, accept)
            if point and point[0] > best[0]:
                best[:] = point
            return _Trial(bool(point) and point[0] >= sig, status)

        bisect_decay(solve, cap, GAIN_SEARCH_RTOL, guess=rate if rate > 0 else None)
        gained = best[0] > rate * (1.0 + GAIN_SEARCH_MIN_GAIN) if rate > 0 else best[0] > rate
        if best[0] > rate:
            rate, P, Lbar = best
        if not gained:
            break
    return rate, P, Lbar, steps


# ---------------------------------------------------------------------------- step 3: IPOPT polish
def _lower(v, m: int):
    import casadi as ca

    M = ca.SX.zeros(m, m)
    k = 0
    for i in range(m):
        for j in range(i + 1):
            M[i, j] = v[k]
            k += 1
    return M


def _tril(M, m: int):
    import casadi as ca

    return ca.vertcat(*[M[i, j] for i in range(m) for j in range(i + 1)])


def _polish(V: _Vertices, P: np.ndarray, Lbar: np.ndarray, rate: float) -> tuple[np.ndarray, np.ndarray] | None:
    """IPOPT's point ``(P, Lbar)`` from ``(P, Lbar)`` (not yet checked), or ``None``.

    In the frame where ``P`` is the identity and with time scaled by ``rho = rate``, the unknowns
    are ``R`` (``P = R R^T + eps I``), ``L``, ``sigma``, one lower-triangular factor ``Q_v`` per
    vertex and ``G`` for the bound: ``-He(P A_cl,v) - sigma P = Q_v Q_v^T``,
    ``l^2 I - L^T S^2 L = G G^T``, ``trace P = n``; IPOPT maximises ``sigma``.
    """
    import casadi as ca

    from ..defaults import GAIN_SEARCH_IPOPT_ITERATIONS

    n, p = V.n, V.p
    rho = rate
    T, Ti = _frame(P)
    As = [Ti @ A @ T / rho for A in V.As]
    Cs = [C @ T for C in V.Cs]
    Lt0 = Ti @ Lbar / rho
    ST = np.diag(V.d) @ T
    bound = V.bound / rho
    nt, pt = n * (n + 1) // 2, p * (p + 1) // 2
    eps = GAIN_SEARCH_P_FLOOR
    r_v = ca.SX.sym("R", nt)
    l_v = ca.SX.sym("L", n * p)
    s_v = ca.SX.sym("sigma")
    q_v = [ca.SX.sym(f"Q{k}", nt) for k in range(len(As))]
    g_v = ca.SX.sym("G", pt)
    R = _lower(r_v, n)
    Pm = R @ R.T + eps * ca.SX.eye(n)
    Lm = ca.reshape(l_v, n, p)
    s0 = 1.0 - GAIN_SEARCH_START_MARGIN
    cons, x0 = [], []
    for A, C, q in zip(As, Cs, q_v):
        Acl = A - Lm @ C
        Q = _lower(q, n)
        cons.append(_tril(-(Pm @ Acl + Acl.T @ Pm) - s_v * Pm - Q @ Q.T, n))
        M0 = -((A - Lt0 @ C) + (A - Lt0 @ C).T) - s0 * np.eye(n)
        try:
            x0.append(np.linalg.cholesky(M0 + 1e-12 * np.eye(n))[np.tril_indices(n)])
        except np.linalg.LinAlgError:
            return None
    K = ST @ Lm
    G = _lower(g_v, p)
    cons.append(_tril(bound ** 2 * ca.SX.eye(p) - K.T @ K - G @ G.T, p))
    cons.append(ca.trace(Pm) - n)
    K0 = ST @ Lt0
    try:
        g0 = np.linalg.cholesky(bound ** 2 * (1 + 1e-9) * np.eye(p) - K0.T @ K0)[np.tril_indices(p)]
    except np.linalg.LinAlgError:
        return None
    x = ca.vertcat(r_v, l_v, s_v, *q_v, g_v)
    init = np.concatenate([np.sqrt(1.0 - eps) * np.eye(n)[np.tril_indices(n)], Lt0.T.ravel(), [s0], *x0, g0])
    with captured_native_output("casadi nlpsol 'ipopt'"):
        solver = ca.nlpsol("gain_search_polish", "ipopt", {"x": x, "f": -s_v, "g": ca.vertcat(*cons)},
                           {"ipopt.print_level": 0, "ipopt.sb": "yes", "print_time": 0,
                            "ipopt.max_iter": GAIN_SEARCH_IPOPT_ITERATIONS, "ipopt.tol": GAIN_SEARCH_SOLVER_TOL})
    try:
        out = solver(x0=init, lbg=0, ubg=0)
    except RuntimeError:
        return None
    xs = np.asarray(out["x"], dtype=float).ravel()
    if not np.all(np.isfinite(xs)):
        return None
    Rv = np.zeros((n, n))
    Rv[np.tril_indices(n)] = xs[:nt]
    Pt = Rv @ Rv.T + eps * np.eye(n)
    Lt = xs[nt:nt + n * p].reshape(p, n).T
    Pn = Ti @ Pt @ Ti
    return 0.5 * (Pn + Pn.T), V.clip(T @ Lt * rho)


# ---------------------------------------------------------------------------- the eigenvalue screen
def _screen(V: _Vertices) -> list[tuple[float, np.ndarray]]:
    """``(eigenvalue bound, scaled gain)`` of the screened starts, best first."""
    from scipy.optimize import minimize
    from scipy.stats import qmc

    from ..defaults import GAIN_SEARCH_SCREEN_EVALUATIONS, GAIN_SEARCH_SCREEN_KEEP, GAIN_SEARCH_SCREEN_SAMPLES

    n, p, bound = V.n, V.p, V.bound
    Si = 1.0 / V.d

    def to_ball(K: np.ndarray) -> np.ndarray:  # model gains, singular values clipped to the bound
        U, s, Vt = np.linalg.svd(K, full_matrices=False)
        return U @ (np.minimum(s, bound)[..., None] * Vt)

    m = int(np.ceil(np.log2(GAIN_SEARCH_SCREEN_SAMPLES)))
    z = qmc.Sobol(n * p, scramble=False).random_base2(m) * 2.0 - 1.0
    K = to_ball(z.reshape(-1, n, p) * bound)
    Lbars = Si[None, :, None] * K
    values = eigenvalue_bound(V.As, V.Cs, Lbars)
    order = np.argsort(-values, kind="stable")[:GAIN_SEARCH_SCREEN_KEEP]
    out = []
    for i in order:
        def neg(v):
            Lb = Si[:, None] * to_ball(V.d[:, None] * v.reshape(n, p))
            return -float(eigenvalue_bound(V.As, V.Cs, Lb[None])[0])
        res = minimize(neg, Lbars[i].ravel(), method="Nelder-Mead",
                       options={"maxfev": GAIN_SEARCH_SCREEN_EVALUATIONS, "xatol": GAIN_SEARCH_SOLVER_TOL, "fatol": GAIN_SEARCH_SOLVER_TOL, "adaptive": True})
        Lb = V.clip(Si[:, None] * to_ball(V.d[:, None] * res.x.reshape(n, p)))
        out.append((float(eigenvalue_bound(V.As, V.Cs, Lb[None])[0]), Lb))
    out.sort(key=lambda t: -t[0])
    return out


# ---------------------------------------------------------------------------- the search
def _problem(system: ScalarNonlinearSystem, bounds: JacobianBounds, bound: float, scaling) -> tuple[_Vertices, np.ndarray]:
    """The scaled vertex matrices with the bound, and the column order of the scaled gains (linear outputs first)."""
    d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
    As, Cs = vertex_matrices(lmi_data(system).scaled(d), vertex_slopes(bounds))
    lin = np.array(system.linear_outputs, dtype=bool)
    cols = np.concatenate([np.nonzero(lin)[0], np.nonzero(~lin)[0]]).astype(int)
    return _Vertices(tuple(As), tuple(Cs), d, bound), cols


def _ceiling(V: _Vertices) -> float:
    """``2 max_v (||A_v|| + ||L|| ||C_v||)`` in the scaled coordinates: no gain in the ball gives a larger rate."""
    return 2.0 * max(np.linalg.norm(A, 2) + V.bound * np.linalg.norm(C, 2) / float(V.d.min()) for A, C in zip(V.As, V.Cs))


def gain_decay_rate(system: ScalarNonlinearSystem, bounds: JacobianBounds, L: np.ndarray, *,
                    scaling: np.ndarray | None = None) -> tuple[float, np.ndarray | None]:
    """The largest decay rate of ``V = e'Pe`` a Lyapunov matrix proves for the given gain on every vertex.

    For a fixed gain the polytopic condition is an LMI in ``P`` (a generalized eigenvalue problem in
    ``sigma``), solved by bisection; the rate returned is the one the returned ``P`` proves in numpy
    (:func:`.polytopic.vertex_decay`), within :data:`~hybobs_opt.defaults.GAIN_SEARCH_RTOL` of the
    bisection's bracket.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    bounds : JacobianBounds
        The Jacobian box of the region.
    L : (n, p) array
        The gain (model units, outputs in model order).
    scaling : (n,) array, optional
        State scaling of the LMIs (default: the box half-widths).

    Returns
    -------
    rate, P
        The proven rate (``-inf`` when no ``P`` was found) and ``P`` in model coordinates (or ``None``).

    See Also
    --------
    decay_gain_search : Searches the gain too.
    PolytopicLMI : The vertex condition.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import gain_decay_rate
    >>> sigma, P = gain_decay_rate(pendulum, bounds, np.array([[2.0], [2.0]]))
    >>> round(sigma, 2), P.shape
    (1.83, (2, 2))

    A zero gain leaves the pendulum's error undamped: no positive rate.

    >>> gain_decay_rate(pendulum, bounds, np.zeros((2, 1)))[0] <= 0
    True
    """
    L = np.asarray(L, dtype=float)
    if L.shape != (system.n, system.p) or not np.all(np.isfinite(L)):
        raise ModelError("L", f"a finite ({system.n}, {system.p}) gain", f"shape {L.shape}")
    norm = float(np.linalg.norm(L, 2))
    V, cols = _problem(system, bounds, max(norm, 1e-300), scaling)
    Lb = L[:, cols] / V.d[:, None]
    rate, P = _certify(V, Lb, None, _ceiling(V), _Counter(), {})
    if P is None or not np.isfinite(rate):
        return float("-inf"), None
    P_model = P / V.d[:, None] / V.d[None, :]
    return float(rate), 0.5 * (P_model + P_model.T)


def decay_gain_search(system: ScalarNonlinearSystem, bounds: JacobianBounds, gain_bound: float, *,
                      starts: tuple[tuple[str, np.ndarray, np.ndarray], ...] = (), screen: bool = True,
                      scaling: np.ndarray | None = None, sigma_cap: float | None = None) -> GainSearchResult:
    """The best pair ``(P, L)`` found for the polytopic condition with ``||L||_2 <= gain_bound`` (see the module).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    bounds : JacobianBounds
        The Jacobian box of the region.
    gain_bound : float
        The bound on ``||L||_2`` (model units), imposed exactly.
    starts : tuple of (source, P, L)
        Certified pairs to start from (model coordinates, outputs in model order), e.g. the
        convex conditions' gains.
    screen : bool, default True
        Also start from the eigenvalue screen's best gains.
    scaling : (n,) array, optional
        State scaling of the conic problems (default: the box half-widths).
    sigma_cap : float, optional
        Upper end of every bisection (default: the eigenvalue bound's ceiling
        ``2 max_v (||A_v|| + l ||C_v||)``, which no gain in the ball exceeds).

    Returns
    -------
    GainSearchResult
        The best pair, proven in numpy, and every start's progress.

    See Also
    --------
    GainSearchResult : What it returns.
    gain_decay_rate : The rate of one given gain.
    decay_optimal_design : Runs this search with ``search_exact_bound=True``.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import decay_gain_search, gain_decay_rate
    >>> result = decay_gain_search(pendulum, bounds, 10.0)
    >>> result.found, bool(np.linalg.norm(result.L, 2) <= 10.0 * (1 + 1e-9))
    (True, True)

    The rate is re-proved for the returned gain:

    >>> bool(gain_decay_rate(pendulum, bounds, result.L)[0] >= 0.99 * result.sigma)
    True
    """
    from ..defaults import GAIN_SEARCH_CERTIFY, GAIN_SEARCH_POLISH_ROUNDS

    if not isinstance(system, ScalarNonlinearSystem):
        raise ModelError("system", "a ScalarNonlinearSystem", type(system).__name__)
    bound = float(gain_bound)
    if not (np.isfinite(bound) and bound > 0):
        raise ModelError("gain_bound", "a positive finite bound on ||L||_2", repr(gain_bound))
    t0 = time.perf_counter()
    V, cols = _problem(system, bounds, bound, scaling)
    d = V.d
    ceiling = _ceiling(V)
    cap = ceiling if sigma_cap is None else min(float(sigma_cap), ceiling)
    counter, cache = _Counter(), {}

    candidates: list[tuple[str, np.ndarray | None, np.ndarray]] = []
    for source, P, L in starts:
        P_s = d[:, None] * np.asarray(P, dtype=float) * d[None, :]
        candidates.append((source, P_s, np.asarray(L, dtype=float)[:, cols] / d[:, None]))
    if screen:
        screened: list[np.ndarray] = []
        for _, Lb in _screen(V):  # distinct local maxima of the eigenvalue bound only
            if len(screened) < GAIN_SEARCH_CERTIFY and all(
                    np.linalg.norm(Lb - other) > SEARCH_IMPROVEMENT_RTOL * max(np.linalg.norm(other), 1.0)
                    for other in screened):
                screened.append(Lb)
        candidates += [(f"eigenvalue screen {k + 1}", None, Lb) for k, Lb in enumerate(screened)]

    best = (float("-inf"), None, None, "")
    record: list[SearchStart] = []
    for source, P, Lb in candidates:
        eig = float(eigenvalue_bound(V.As, V.Cs, Lb[None])[0])
        rate = V.rate(P, Lb) if P is not None else float("-inf")
        if P is None or not rate > 0:
            rate, P = _certify(V, Lb, P, cap, counter, cache)
        certified = rate
        steps = 0
        if P is not None:  # also from a gain no P certifies: the steps move the gain too
            rate, P, Lb, steps = _convex_concave(V, P, Lb, rate, cap, counter, cache)
        after_ccp = rate
        for _ in range(GAIN_SEARCH_POLISH_ROUNDS if P is not None and rate > 0 else 0):
            point = _polish(V, P, Lb, rate)
            if point is None:
                break
            P2, L2 = point
            r2, P2c = _certify(V, L2, P2, cap, counter, cache)
            if P2c is None or not r2 > rate * (1.0 + SEARCH_IMPROVEMENT_RTOL):
                break
            rate, P, Lb = r2, P2c, L2
        record.append(SearchStart(source, eig, certified, after_ccp, rate, steps))
        if rate > 0 and (best[1] is None or rate > best[0] * (1.0 + SEARCH_IMPROVEMENT_RTOL)):
            best = (rate, P, Lb, source)
    rate, P, Lb, source = best
    secs = time.perf_counter() - t0
    if P is None:
        return GainSearchResult(False, float("-inf"), None, None, None, None, "", tuple(record), counter.solves,
                                counter.failed, secs, bound)
    L = np.zeros((V.n, system.p))
    L[:, cols] = d[:, None] * Lb
    P_model = P / d[:, None] / d[None, :]
    return GainSearchResult(True, float(rate), L, 0.5 * (P_model + P_model.T), float(np.linalg.norm(L, 2)),
                            float(eigenvalue_bound(V.As, V.Cs, Lb[None])[0]), source, tuple(record), counter.solves,
                            counter.failed, secs, bound)

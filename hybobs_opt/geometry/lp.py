"""The one small LP layer every linear program of the toolbox goes through.

It solves ``min c'z  s.t.  A_ub z <= b_ub, A_eq z == b_eq, lo <= z <= hi`` with HiGHS (through
:func:`scipy.optimize.linprog`), checks the status and turns it into one of three outcomes:
an optimal point, a certified "infeasible"/"unbounded" answer, or a :class:`SolverError` that
names the problem and the solver.  The ``regions`` package adds a fast dense path (DAQP) in front
of this robust one.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import linprog

from ..errors import ModelError, SolverError
from ..status import DAQP_STATUS, LINPROG_STATUS, Status, is_optimal, map_status
from ..tolerances import LP_POINT_RTOL


@dataclass(frozen=True)
class LPResult:
    """Outcome of one LP (a :class:`~hybobs_opt.results.SolveResult`).

    ``status`` is :attr:`~hybobs_opt.status.Status.OPTIMAL`, ``INFEASIBLE`` or ``UNBOUNDED``
    (equal to the strings ``"optimal"``, ``"infeasible"``, ``"unbounded"``); ``residuals`` holds
    the largest violation of the inequality rows, the equality rows and the variable bounds at
    ``x`` (empty without a point); ``seconds`` the wall time of the solve, retries included.
    """

    status: Status
    x: np.ndarray | None
    objective: float | None
    solver: str = "highs"
    seconds: float = 0.0
    residuals: dict[str, float] = field(default_factory=dict)

    @property
    def optimal(self) -> bool:
        return is_optimal(self.status)

    def to_dict(self) -> dict:
        return {"status": self.status, "x": None if self.x is None else self.x.tolist(), "objective": self.objective,
                "solver": self.solver, "seconds": self.seconds, "residuals": dict(self.residuals)}


def solve_lp(
    c: np.ndarray,
    A_ub: np.ndarray | None = None,
    b_ub: np.ndarray | None = None,
    A_eq: np.ndarray | None = None,
    b_eq: np.ndarray | None = None,
    bounds: list[tuple[float | None, float | None]] | tuple | None = None,
    *,
    problem: str = "LP",
) -> LPResult:
    """Solve one LP with HiGHS and check its status.

    Parameters
    ----------
    c, A_ub, b_ub, A_eq, b_eq, bounds
        As in :func:`scipy.optimize.linprog`; ``bounds=None`` means free variables (unlike
        linprog's default of ``z >= 0``).
    problem
        A short name of the problem for error messages (e.g. ``"Chebyshev ball of guard 2"``).

    Returns
    -------
    LPResult
        Optimal point, or a status of ``"infeasible"`` / ``"unbounded"``.

    Raises
    ------
    SolverError
        If HiGHS hits an iteration limit, reports a numerical failure, or returns an "optimal"
        point that is not finite or violates a constraint by more than
        :data:`~hybobs_opt.tolerances.LP_POINT_RTOL` (checked here, in numpy, before the status
        is trusted).
    """
    c = np.asarray(c, dtype=float)
    if bounds is None:
        bounds = (None, None)
    messages = []
    t0 = time.perf_counter()
    # HiGHS's automatic choice first; on a numerical failure its interior-point and dual simplex
    # solvers are tried before giving up (they fail on different degenerate instances).
    for method in ("highs", "highs-ipm", "highs-ds"):
        res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds, method=method)
        status = map_status(LINPROG_STATUS, res.status, solver=f"linprog/{method}")
        if is_optimal(status):
            x = np.asarray(res.x, dtype=float)
            defect = _point_defect(c, A_ub, b_ub, A_eq, b_eq, bounds, x, res.fun)
            if defect is None:
                return LPResult(Status.OPTIMAL, x, float(res.fun), method, time.perf_counter() - t0,
                                _point_residuals(A_ub, b_ub, A_eq, b_eq, bounds, x))
            messages.append(f"{method}: status optimal but {defect}")
            continue
        if status in (Status.INFEASIBLE, Status.UNBOUNDED):
            return LPResult(status, None, None, method, time.perf_counter() - t0)
        messages.append(f"{method}: {res.status} {res.message}")
    raise SolverError(
        problem,
        "HiGHS (scipy.optimize.linprog: highs, highs-ipm, highs-ds)",
        "; ".join(messages),
        hint="rescale the data to the state/input bounds, or check for huge/small coefficients",
    )


def _bound_pairs(bounds, size: int) -> list:
    if isinstance(bounds, tuple) and len(bounds) == 2 and not isinstance(bounds[0], (tuple, list)):
        return [bounds] * size
    return list(bounds)


def _point_residuals(A_ub, b_ub, A_eq, b_eq, bounds, x: np.ndarray) -> dict[str, float]:
    """Largest violation (absolute, 0 when satisfied) of each constraint family at ``x``."""
    out: dict[str, float] = {}
    for label, A, b, eq in (("inequality", A_ub, b_ub, False), ("equality", A_eq, b_eq, True)):
        if A is None or np.size(A) == 0:
            continue
        r = np.atleast_2d(np.asarray(A, dtype=float)) @ x - np.asarray(b, dtype=float).reshape(-1)
        out[label] = float(np.max(np.abs(r) if eq else np.maximum(r, 0.0), initial=0.0))
    worst = 0.0
    for k, (lo, hi) in enumerate(_bound_pairs(bounds, x.size)):
        if lo is not None:
            worst = max(worst, float(lo - x[k]))
        if hi is not None:
            worst = max(worst, float(x[k] - hi))
    out["bounds"] = worst
    return out


def _point_defect(c, A_ub, b_ub, A_eq, b_eq, bounds, x: np.ndarray, fun) -> str | None:
    """What is wrong with an "optimal" point, or ``None``: finite, every row within tolerance.

    A row ``a'x <= b`` may be violated by at most ``LP_POINT_RTOL (1 + |b| + |a| |x|)``: relative
    to the size of the terms that are summed, so the check is independent of the row's scaling.
    """
    if x.shape != (np.size(c),) or not np.all(np.isfinite(x)) or not np.isfinite(fun):
        return "the returned point or objective is not finite"
    ax = np.abs(x)
    for label, A, b, eq in (("inequality", A_ub, b_ub, False), ("equality", A_eq, b_eq, True)):
        if A is None or np.size(A) == 0:
            continue
        A = np.atleast_2d(np.asarray(A, dtype=float))
        b = np.asarray(b, dtype=float).reshape(-1)
        r = A @ x - b
        allowed = LP_POINT_RTOL * (1.0 + np.abs(b) + np.abs(A) @ ax)
        bad = (np.abs(r) if eq else r) > allowed
        if np.any(bad):
            k = int(np.argmax(np.where(bad, r, -np.inf) if not eq else np.where(bad, np.abs(r), -np.inf)))
            return f"{label} row {k} is violated by {abs(r[k]):.3g} at the returned point"
    if bounds is not None and not (isinstance(bounds, tuple) and len(bounds) == 2 and bounds[0] is None and bounds[1] is None):
        for k, (lo, hi) in enumerate(_bound_pairs(bounds, x.size)):
            tol = LP_POINT_RTOL * (1.0 + ax[k])
            if (lo is not None and x[k] < lo - tol) or (hi is not None and x[k] > hi + tol):
                return f"variable {k} is outside its bounds ({x[k]:.6g} not in [{lo}, {hi}])"
    return None


def row_range(
    A: np.ndarray,
    b: np.ndarray,
    rows: np.ndarray,
    *,
    E: np.ndarray | None = None,
    e: np.ndarray | None = None,
    problem: str = "row range",
    field: str = "polytope",
    labels: Sequence[str] | None = None,
    allow_unbounded: bool = False,
    allow_empty: bool = False,
) -> np.ndarray | None:
    """``[min, max]`` of each ``row . z`` over ``{z : A z <= b, E z = e}``: two LPs per row.

    The one implementation of the interval of a linear functional over a polytope (bounding boxes,
    argument intervals of the sector bounds of paper 004, big-M constants of paper 002's MLD
    form, ...).  Every LP goes through :func:`solve_lp` (status mapped, point re-checked).

    Parameters
    ----------
    A, b : arrays
        Inequalities ``A z <= b`` (``m x d`` and ``m``).
    rows : array
        The functionals, ``k x d`` (a single row ``d`` is read as ``1 x d``).
    E, e : arrays, optional
        Equalities ``E z = e``.
    problem : str
        Name of the LPs in error messages (``"{problem}: min/max of row {label}"``).
    field : str
        The model field an empty set is reported against (``ModelError``).
    labels : sequence of str, optional
        Names of the rows for messages (default ``"0"``, ``"1"``...).
    allow_unbounded : bool
        Report a side on which a row is unbounded as ``-inf`` / ``+inf`` instead of raising.
    allow_empty : bool
        Return ``None`` for an empty set instead of raising.

    Returns
    -------
    array or None
        ``k x 2``: column 0 the minimum, column 1 the maximum (``None``: empty, with
        ``allow_empty``).

    Raises
    ------
    ModelError
        If the set is empty (``field``: "a non-empty set") or a row is unbounded on it
        (``"bounds of {label}"``: "a bounded set"), unless allowed.
    SolverError
        If HiGHS cannot answer an LP (see :func:`solve_lp`).
    """
    A = np.atleast_2d(np.asarray(A, dtype=float))
    b = np.asarray(b, dtype=float).reshape(-1)
    R = np.atleast_2d(np.asarray(rows, dtype=float))
    if R.ndim != 2 or R.shape[1] != A.shape[1]:
        raise ModelError("rows", f"an array of functionals with {A.shape[1]} columns", f"shape {np.shape(rows)}")
    if labels is not None and len(labels) != R.shape[0]:
        raise ModelError("labels", f"{R.shape[0]} row names", f"{len(labels)} names")
    has_eq = E is not None and np.size(E) > 0
    has_ineq = A.shape[0] > 0
    out = np.empty((R.shape[0], 2))
    for i, row in enumerate(R):
        label = str(i) if labels is None else labels[i]
        for col, sign, what in ((0, 1.0, "min"), (1, -1.0, "max")):
            res = solve_lp(sign * row, A if has_ineq else None, b if has_ineq else None, E if has_eq else None,
                           e if has_eq else None,
                           problem=f"{problem}: {what} of row {label}")
            if res.status == Status.INFEASIBLE:
                if allow_empty:
                    return None
                raise ModelError(field, "a non-empty set", "an empty set")
            if res.status == Status.UNBOUNDED:
                if not allow_unbounded:
                    raise ModelError(f"bounds of {label}", "a bounded set", f"unbounded along this row ({what})")
                out[i, col] = -sign * np.inf
                continue
            out[i, col] = sign * res.objective
    return out


# ---------------------------------------------------------------------------------------------
# Fast, certified "maximum slack" LPs (the thousands of tiny LPs of paper 002, Algorithm 3.1)
# ---------------------------------------------------------------------------------------------

import daqp  # noqa: E402

from ._lp_kernels import slack_bounds, slack_lp_data, support_upper_bound  # noqa: E402
from ..tolerances import DAQP_EPS_PROX, NEAR_ACTIVE_TOL, SLACK_CAP, ZERO_ROW_TOL  # noqa: E402


def _daqp_optimal(flag: int) -> bool:
    """DAQP's exit flag through the one status map and the one acceptance policy."""
    return is_optimal(map_status(DAQP_STATUS, int(flag), solver="daqp"))


@dataclass
class LPCounters:
    """How many max-slack LPs ran, and how many needed the robust solver to confirm them."""

    fast: int = 0
    confirmed_by_highs: int = 0

    def reset(self) -> None:
        self.fast = 0
        self.confirmed_by_highs = 0

    @property
    def total(self) -> int:
        return self.fast + self.confirmed_by_highs


#: Process-wide counters (each worker process has its own; executors add them up).
COUNTERS = LPCounters()


@dataclass(frozen=True)
class SlackResult:
    """Largest ``t`` (capped at :data:`~hybobs_opt.tolerances.SLACK_CAP`) with ``G w + |G_k| t <= g``.

    ``lower`` is a slack certified by numpy at the returned point ``w`` (a feasible point proves
    the optimum is at least this); ``upper`` is an upper bound certified from the dual multipliers
    (or ``inf`` when none is available).  ``solver`` is ``"daqp"`` or ``"highs"``; ``lam`` holds
    DAQP's multipliers of the LP's rows when it answered (for callers that read active sets).

    A :class:`~hybobs_opt.results.SolveResult`: ``status`` is ``INFEASIBLE`` when the polytope is
    empty (``lower = upper = -inf``) and ``OPTIMAL`` otherwise (the LP's optimum is certified to lie
    in ``[lower, upper]``, which decides the caller's threshold); ``residuals`` reports that
    bracket's width (the point itself satisfies every row at ``t = lower`` by construction).
    """

    lower: float
    upper: float
    w: np.ndarray | None
    solver: str
    lam: np.ndarray | None = None
    seconds: float = 0.0

    @property
    def status(self) -> Status:
        return Status.INFEASIBLE if self.w is None and self.lower == -np.inf else Status.OPTIMAL

    @property
    def residuals(self) -> dict[str, float]:
        return {} if self.w is None else {"certified_gap": float(self.upper - self.lower)}

    def to_dict(self) -> dict:
        return {"status": self.status, "lower": self.lower, "upper": self.upper, "solver": self.solver,
                "w": None if self.w is None else np.asarray(self.w).tolist(), "seconds": self.seconds,
                "residuals": self.residuals}


def max_slack(G: np.ndarray, g: np.ndarray, *, radius_bound: float, threshold: float, problem: str = "max-slack LP") -> SlackResult:
    """Largest uniform slack of ``G w <= g`` (the Chebyshev radius of the polytope), certified.

    Solves ``max t  s.t.  G_k w + ||G_k|| t <= g_k, t <= SLACK_CAP`` with DAQP (dense active-set,
    about 30 microseconds for 10 variables and 30 rows).  Its answer is accepted only when it is
    *certified* against ``threshold`` with plain arithmetic:

    * the returned point gives the lower bound ``min_k (g_k - G_k w) / ||G_k||``;
    * the dual multipliers ``lambda >= 0, mu >= 0`` give the upper bound
      ``(g' lambda + SLACK_CAP mu + R ||G' lambda||_2) / (n' lambda + mu)``, valid for every
      feasible ``w`` with ``||w||_2 <= R = radius_bound`` (weak duality with the stationarity
      residual bounded by Cauchy-Schwarz).

    If neither bound decides ``slack > threshold``, the multipliers are refined by NNLS, and if
    that does not decide either the LP is re-solved with HiGHS and that answer is returned
    (counted in :data:`COUNTERS`).

    Parameters
    ----------
    G, g : arrays
        Inequalities in *scaled* coordinates (so that feasible points have ``||w|| <= R``).
        Rows with norm below :data:`~hybobs_opt.tolerances.ZERO_ROW_TOL` are constant: they are
        dropped when they hold and make the set empty when they do not.
    radius_bound : float
        ``R`` above.
    threshold : float
        The decision the caller will take (``slack > threshold``).
    problem : str
        Name for error messages.
    """
    G = np.ascontiguousarray(G, dtype=float)
    g = np.ascontiguousarray(g, dtype=float)
    d = G.shape[1]
    A, bu, ok = slack_lp_data(G, g, ZERO_ROW_TOL, SLACK_CAP)
    if not ok:
        return SlackResult(-np.inf, -np.inf, None, "numpy")
    if A.shape[0] == 1:
        return SlackResult(SLACK_CAP, SLACK_CAP, np.zeros(d), "numpy")
    return solve_slack_lp(A, bu, radius_bound, threshold, problem)


def solve_slack_lp(A: np.ndarray, bu: np.ndarray, radius_bound: float, threshold: float, problem: str) -> SlackResult:
    """DAQP on the data of :func:`~hybobs_opt._lp_kernels.slack_lp_data`, certified, HiGHS as the fallback.

    The LP of :func:`max_slack` after its constant rows were handled: ``A`` is ``(k + 1) x (d + 1)``
    (the last row caps ``t``), ``bu`` its right-hand side.  ``threshold`` is the decision the
    caller will take (``slack > threshold``); see :func:`max_slack` for the certificates.
    """
    t0 = time.perf_counter()
    k = A.shape[0] - 1
    d = A.shape[1] - 1
    f = np.zeros(d + 1)
    f[d] = -1.0
    COUNTERS.fast += 1
    H, lower_bounds, sense = np.zeros((d + 1, d + 1)), np.full(k + 1, -1e30), np.zeros(k + 1, dtype=np.int32)
    # DAQP_EPS_PROX first; on the rare cycling exit (0.2 % of model 17's pair LPs) DAQP's own
    # automatic regularisation usually finishes, then NNLS sharpens its multipliers.
    for eps_prox in (DAQP_EPS_PROX, None):
        settings = {} if eps_prox is None else {"eps_prox": eps_prox}
        x, _, flag, info = daqp.solve(H, f, A, bu, lower_bounds, sense, **settings)
        if not _daqp_optimal(flag) or not np.all(np.isfinite(x)):
            continue
        lower, upper = slack_bounds(A, bu, x, info["lam"], radius_bound, SLACK_CAP)
        w = np.asarray(x[:d], dtype=float)
        if lower > threshold or upper <= threshold:
            return SlackResult(lower, upper, w, "daqp", info["lam"], time.perf_counter() - t0)
        # Refine the dual on the rows active at DAQP's point (non-negative least squares on the
        # stationarity conditions): a slack of exactly zero (two regions that only touch) needs
        # multipliers more exact than a proximal solve may return.
        upper = min(upper, _refined_upper_bound(A[:k, :d], bu[:k], w, float(x[d]), radius_bound))
        if upper <= threshold:
            return SlackResult(lower, upper, w, "daqp+nnls", info["lam"], time.perf_counter() - t0)
        break
    # Undecided (or DAQP failed): the robust solver decides.
    COUNTERS.fast -= 1
    COUNTERS.confirmed_by_highs += 1
    res = solve_lp(f, A, bu, problem=problem)
    if res.status == Status.INFEASIBLE:
        return SlackResult(-np.inf, -np.inf, None, "highs", seconds=time.perf_counter() - t0)
    if not is_optimal(res.status):
        raise SolverError(problem, "HiGHS", res.status, hint="the slack LP is capped and cannot be unbounded: check the data for NaN")
    w = res.x[:d]
    # HiGHS's point has passed solve_lp's feasibility check; its certified value is the smallest
    # row slack at that point (the LP's t may exceed it by the solver's primal tolerance).
    slack = float(min(res.x[d], np.min(bu[:k] - A[:k, :d] @ w)))
    return SlackResult(slack, slack, w, "highs", seconds=time.perf_counter() - t0)


def certified_width_below(A: np.ndarray, b: np.ndarray, c: np.ndarray, *, radius_bound: float, width: float,
                          point: np.ndarray | None = None) -> bool:
    """Is the width ``max c'v - min c'v`` of ``{A v <= b}`` certified to be at most ``width``?

    Two DAQP LPs (maximise and minimise ``c'v``); each optimum is bounded from the solver's
    multipliers (:func:`~hybobs_opt._lp_kernels.support_upper_bound`, valid for every feasible
    ``v`` with ``|v| <= radius_bound``), so ``True`` is a certificate.  ``False`` means "not
    certified" (wider, or a solve that did not finish): callers must treat it as the safe answer.
    When DAQP fails (or returns non-finite numbers), HiGHS's duals are used for the same bound.
    With a (nearly) feasible ``point``, the second LP is skipped when the first one's maximiser
    is already more than ``width`` away from it along ``c``.
    """
    d = A.shape[1]
    H = np.zeros((d, d))
    lower = np.full(A.shape[0], -1e30)
    sense = np.zeros(A.shape[0], dtype=np.int32)
    total = 0.0
    for sign in (1.0, -1.0):
        COUNTERS.fast += 1
        v, _, flag, info = daqp.solve(H, -sign * c, A, b, lower, sense, eps_prox=DAQP_EPS_PROX)
        lam = info["lam"]
        if not _daqp_optimal(flag) or not np.all(np.isfinite(v)) or not np.all(np.isfinite(lam)):
            # DAQP failed: HiGHS's duals give the same kind of certificate
            COUNTERS.fast -= 1
            COUNTERS.confirmed_by_highs += 1
            res = linprog(-sign * c, A_ub=A, b_ub=b, bounds=(None, None), method="highs")
            if (not is_optimal(map_status(LINPROG_STATUS, res.status, solver="linprog/highs")) or res.ineqlin is None
                    or not np.all(np.isfinite(res.ineqlin.marginals))):
                return False
            v, lam = np.asarray(res.x, dtype=float), -np.asarray(res.ineqlin.marginals, dtype=float)
        if point is not None and sign > 0 and float(c @ (v - point)) > width:
            return False
        total += support_upper_bound(A, b, sign * c, np.ascontiguousarray(lam, dtype=float), radius_bound)
    return total <= width


def _refined_upper_bound(Gn: np.ndarray, gn: np.ndarray, w: np.ndarray, t_solver: float, radius_bound: float) -> float:
    """Upper bound on the max slack from multipliers fitted by NNLS on the near-active rows.

    Any ``lambda >= 0`` with ``n' lambda = 1`` (rows are unit-norm) bounds the slack of every
    feasible ``w`` (``||w|| <= R``) by ``g' lambda + R ||G' lambda||``: weak duality with the
    stationarity residual bounded by Cauchy-Schwarz.
    """
    from scipy.optimize import nnls

    resid = gn - Gn @ w
    # Active rows are those at the solver's own slack value (its point may violate a row by its
    # primal tolerance, so the smallest residual is not a reliable anchor).
    active = np.nonzero(resid <= t_solver + NEAR_ACTIVE_TOL)[0]
    if active.size == 0:
        return np.inf
    GA = Gn[active]
    M = np.vstack([GA.T, np.ones((1, active.size))])
    rhs = np.zeros(M.shape[0])
    rhs[-1] = 1.0
    try:
        lam, _ = nnls(M, rhs)
    except RuntimeError:  # NNLS iteration limit: no refined bound, the robust solver decides
        return np.inf
    total = lam.sum()
    if total <= 0:
        return np.inf
    lam = lam / total
    return float(gn[active] @ lam + radius_bound * np.linalg.norm(GA.T @ lam))


#: Former private name of :func:`solve_slack_lp` (kept: ``regions`` and ``observers`` import it).
_solve_slack_lp = solve_slack_lp

"""The one small LP layer every linear program of the toolbox goes through.

It solves ``min c'z  s.t.  A_ub z <= b_ub, A_eq z == b_eq, lo <= z <= hi`` with HiGHS (through its
own Python API, ``highspy``, posed as :func:`scipy.optimize.linprog` poses it: the LP layer does not
import ``scipy.optimize``, a quarter of a second of a small analysis), checks the status and turns it
into one of three outcomes:
an optimal point, a certified "infeasible"/"unbounded" answer, or a :class:`SolverError` that
names the problem and the solver.  The ``regions`` package adds a fast dense path (DAQP) in front
of this robust one.
"""

from __future__ import annotations

import time
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from contextvars import ContextVar
from dataclasses import dataclass, field

import numpy as np
from .._native_output import captured_native_output
from ..errors import ModelError, SolverError
from ._reproducible import dot, matmul as mm, nnls, norm
from ..status import DAQP_STATUS, HIGHS_MODEL_STATUS, Status, is_optimal, map_status
from ..defaults import LP_EQUILIBRATION_SWEEPS, WIDTH_WALK_FRACTION, WIDTH_WALK_STEPS
from ..tolerances import (LINPROG_CHECK_TOL, LP_CERTIFICATE_RTOL, LP_DUAL_RTOL, LP_POINT_RTOL, LP_SCALING_NOISE_RTOL, LP_VERTEX_MAX_COND,
                          LP_VERTEX_RTOL)
from ..results import Certificate


@dataclass(frozen=True)
class LPResult:
    """Outcome of one LP (a :class:`~hybobs_opt.results.SolveResult`).

    ``status`` is :attr:`~hybobs_opt.status.Status.OPTIMAL`, ``INFEASIBLE`` or ``UNBOUNDED``
    (equal to the strings ``"optimal"``, ``"infeasible"``, ``"unbounded"``); ``residuals`` holds
    the largest violation of the inequality rows, the equality rows and the variable bounds at
    ``x`` (empty without a point); ``seconds`` the wall time of the solve, retries included.
    ``certificate`` proves an ``INFEASIBLE`` / ``UNBOUNDED`` status (:class:`LPCertificate`,
    ``verify()`` true); ``duals`` holds the multipliers ``lambda >= 0`` of the inequality rows at an
    optimum (``c + A_ub' lambda + A_eq' mu = 0`` up to the bounds' multipliers), checked.

    Parameters
    ----------
    status : Status
        The outcome above.
    x : array or None
        The optimal point (``None`` without one).
    objective : float or None
        ``c'x`` at the optimum.
    solver : str, default "highs"
        The solver's name.
    seconds : float, default 0.0
        Wall time, retries included.
    residuals : dict of str to float, optional
        Largest violation of the inequality rows, the equality rows and the bounds at ``x``.
    certificate : LPCertificate, optional
        Proof of an ``INFEASIBLE`` / ``UNBOUNDED`` status.
    duals : array, optional
        Multipliers ``lambda >= 0`` of the inequality rows at an optimum.

    See Also
    --------
    solve_lp, verified_lp : return it.
    hybobs_opt.SolveResult : the protocol it implements.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import solve_lp
    >>> result = solve_lp(np.array([1.0, 1.0]), bounds=[(1, 2), (0, 3)])   # min x1 + x2 on a box
    >>> result.status.value, result.x, result.objective, result.solver
    ('optimal', array([1., 0.]), 1.0, 'highs')
    >>> result.residuals
    {'bounds': 0.0}
    """

    status: Status
    x: np.ndarray | None
    objective: float | None
    solver: str = "highs"
    seconds: float = 0.0
    residuals: dict[str, float] = field(default_factory=dict)
    certificate: "LPCertificate | None" = None
    duals: np.ndarray | None = None

    @property
    def optimal(self) -> bool:
        return is_optimal(self.status)

    def to_dict(self) -> dict:
        """JSON-ready record of the LP's answer.

        Returns
        -------
        dict
            ``status``, ``x`` (a list, ``None`` without a point), ``objective``, ``solver``, ``seconds``,
            ``residuals`` and ``certificate`` (its record, or ``None``).
        """
        return {"status": self.status, "x": None if self.x is None else self.x.tolist(), "objective": self.objective,
                "solver": self.solver, "seconds": self.seconds, "residuals": dict(self.residuals),
                "certificate": None if self.certificate is None else self.certificate.to_dict()}


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
    """Solve one LP with HiGHS and check its answer in numpy before it is trusted.

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
        Optimal point (with its multipliers), or a status of ``"infeasible"`` / ``"unbounded"``
        with a :class:`LPCertificate` whose ``verify()`` is true.

    Raises
    ------
    SolverError
        If no HiGHS method gives an answer that passes the checks: the solver raised, hit a limit,
        reported a numerical failure, returned an "optimal" point that is not finite, violates a row
        by more than :data:`~hybobs_opt.tolerances.LP_POINT_RTOL` (relative), whose objective is
        not ``c'x`` or whose multipliers do not certify it optimal (:data:`LP_DUAL_RTOL`), or an
        "infeasible" / "unbounded" verdict for which no certificate verifies.  The last exception
        of the solver, if any, is chained.

    See Also
    --------
    verified_lp : DAQP first, this as the fallback.
    row_range : two of these LPs per functional.
    scipy.optimize.linprog : the same LP form.

    Notes
    -----
    The LP is equilibrated first (rows and columns scaled by powers of two, :func:`_equilibrate`),
    so the answer does not depend on the units of the data; every check is done on that exact
    equivalent problem.  HiGHS's automatic choice runs first; on a failed check its interior-point
    and dual simplex solvers are tried (they fail on different degenerate instances).

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import solve_lp
    >>> A_ub, b_ub = np.array([[-1.0, -1.0]]), np.array([-1.0])            # x1 + x2 >= 1
    >>> result = solve_lp(np.array([2.0, 1.0]), A_ub, b_ub, bounds=[(0, None), (0, None)])
    >>> result.status.value, result.x, result.objective
    ('optimal', array([0., 1.]), 1.0)

    An infeasible LP answers with a certificate that re-checks in numpy:

    >>> result = solve_lp(np.array([1.0]), np.array([[1.0], [-1.0]]), np.array([-1.0, 0.0]))
    >>> result.status.value, result.certificate.verify()
    ('infeasible', True)
    """
    c = np.asarray(c, dtype=float).reshape(-1)
    if bounds is None:
        bounds = (None, None)
    t0 = time.perf_counter()
    sc = _equilibrate(c, A_ub, b_ub, A_eq, b_eq, bounds)
    scaled = {LP_EQUILIBRATION_SWEEPS: sc}  # the last attempt's scaling is made when it is reached
    attempts = [(LP_EQUILIBRATION_SWEEPS, method) for method in ("highs", "highs-ipm", "highs-ds")]
    # last: rows to unit norm only.  Column scaling can blow a rounding residue of a restricted row
    # (1e-27 where exact arithmetic gives 0) up or a real entry down below HiGHS's small-value
    # threshold (1e-9), and then every method solves another problem (model 17, T = 8, pair by
    # pair: a row violated by 4.4e-6 at each answer)
    attempts.append((0, "highs-ds"))
    bad_ub = np.nonzero(sc.zero_ub < 0)[0]
    bad_eq = np.nonzero(sc.zero_eq != 0)[0]
    if bad_ub.size or bad_eq.size:  # a constant row 0 <= b < 0 (or 0 = e != 0): infeasible as posed
        n = c.size
        if bad_ub.size:
            cert = LPCertificate("farkas", problem, np.zeros((1, n)), sc.zero_ub[bad_ub[:1]], np.zeros((0, n)), np.zeros(0), c,
                                 y=np.ones(1), w=np.zeros(0))
        else:
            e0 = sc.zero_eq[bad_eq[:1]]
            cert = LPCertificate("farkas", problem, np.zeros((0, n)), np.zeros(0), np.zeros((1, n)), e0, c,
                                 y=np.zeros(0), w=-np.sign(e0))
        return LPResult(Status.INFEASIBLE, None, None, "numpy", time.perf_counter() - t0, certificate=cert)
    messages = []
    last_exc: BaseException | None = None
    for sweeps, method in attempts:
        if sweeps not in scaled:
            scaled[sweeps] = _equilibrate(c, A_ub, b_ub, A_eq, b_eq, bounds, sweeps=sweeps)
        sc = scaled[sweeps]
        sb = sc.bounds()
        try:
            res = _call_highs(sc.c, sc.A, sc.b, sc.E, sc.e, sb, method)
            status = res.status
        except Exception as exc:  # HiGHS (or highspy around it) raised: try the next method
            last_exc = exc
            messages.append(f"{method}: raised {type(exc).__name__}: {exc}")
            continue
        if is_optimal(status):
            z = np.asarray(res.x, dtype=float).reshape(-1) if getattr(res, "x", None) is not None else np.full(c.size, np.nan)
            defect = _optimality_defect(sc, res, z, getattr(res, "fun", None))
            if defect is None:
                x = sc.D * z
                duals = -_marginals(res, "ineqlin", sc.A.shape[0]) * sc.r_ub / sc.cn
                return LPResult(Status.OPTIMAL, x, dot(c, x), method, time.perf_counter() - t0,
                                _point_residuals(A_ub, b_ub, A_eq, b_eq, bounds, x), duals=_full_duals(duals, sc))
            messages.append(f"{method}: status optimal but {defect}")
            continue
        if status in (Status.INFEASIBLE, Status.UNBOUNDED):
            cert = (_farkas if status == Status.INFEASIBLE else _ray)(sc, problem, method)
            if cert is not None:
                return LPResult(status, None, None, method, time.perf_counter() - t0, certificate=cert)
            messages.append(f"{method}: status {status} but no certificate of it verifies")
            continue
        messages.append(f"{method}: {res.status} {res.message}")
    raise SolverError(
        problem,
        "HiGHS (highspy: highs, highs-ipm, highs-ds as scipy.optimize.linprog names them; highs-ds on the rows "
        "scaled to unit norm only)",
        "; ".join(messages),
        hint="rescale the data to the state/input bounds, or check for huge/small coefficients"
             + ("; the solver itself raised (chained below): check the installed highspy" if last_exc is not None else ""),
    ) from last_exc


def _full_duals(duals: np.ndarray, sc: _Scaled) -> np.ndarray:
    """Multipliers ``lambda >= 0`` of every inequality row as the caller passed it (constant rows: 0)."""
    out = np.zeros(sc.zero_ub_mask.size)
    out[~sc.zero_ub_mask] = duals
    return out


@dataclass(frozen=True, eq=False)
class LPCertificate(Certificate):
    """Numpy-checkable evidence for an ``"infeasible"`` or ``"unbounded"`` LP verdict.

    The data are those of the LP as :func:`solve_lp` posed it to HiGHS: rows and columns scaled by
    powers of two (an exact, equivalent problem; see :func:`_equilibrate`), the variable bounds
    written as inequality rows ``A z <= b``, and the equalities ``E z = e``.

    * ``kind = "farkas"`` (infeasible): ``y >= 0`` and free ``w`` with ``A'y + E'w = 0`` and
      ``b'y + e'w < 0`` (a feasible ``z`` would give ``0 <= y'(b - A z) = b'y + e'w < 0``).
    * ``kind = "ray"`` (unbounded): a point ``z0`` satisfying every row and a direction ``d``
      with ``A d <= 0``, ``E d = 0`` and ``c'd < 0``.

    Every condition is checked relative to the sizes of the terms summed (:data:`LP_CERTIFICATE_RTOL`).
    """

    kind: str
    problem: str
    A: np.ndarray = field(repr=False)
    b: np.ndarray = field(repr=False)
    E: np.ndarray = field(repr=False)
    e: np.ndarray = field(repr=False)
    c: np.ndarray = field(repr=False)
    y: np.ndarray | None = field(default=None, repr=False)
    w: np.ndarray | None = field(default=None, repr=False)
    z0: np.ndarray | None = field(default=None, repr=False)
    d: np.ndarray | None = field(default=None, repr=False)

    theorem: str = "Farkas lemma / primal ray (LP theorem of alternatives)"

    def verify(self) -> bool:
        """Re-check the certificate with numpy alone (no solver)."""
        try:
            if self.kind == "farkas":
                return _farkas_ok(self.A, self.b, self.E, self.e, self.y, self.w)
            if self.kind == "ray":
                return _ray_ok(self.A, self.b, self.E, self.e, self.c, self.z0, self.d)
        except (TypeError, ValueError):
            return False
        return False

    @property
    def reason(self) -> str:
        if self.kind == "farkas":
            return f"{self.problem} is infeasible: non-negative multipliers combine its rows into 0 <= b'y + e'w < 0"
        return f"{self.problem} is unbounded: a feasible point and a ray d with A d <= 0, E d = 0, c'd < 0"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "problem": self.problem, "verified": self.verify()}


def _finite(*arrays) -> bool:
    return all(a is not None and np.all(np.isfinite(a)) for a in arrays)


def _farkas_ok(A, b, E, e, y, w) -> bool:
    if not _finite(y, w) or y.shape != (A.shape[0],) or w.shape != (E.shape[0],):
        return False
    if np.any(y < 0.0):
        return False
    r = mm(A.T, y) + mm(E.T, w)
    size = mm(np.abs(A).T, y) + mm(np.abs(E).T, np.abs(w))
    gap = dot(b, y) + dot(e, w)
    gap_size = dot(np.abs(b), y) + dot(np.abs(e), np.abs(w))
    if gap_size == 0.0:
        return False
    return bool(np.all(np.abs(r) <= LP_CERTIFICATE_RTOL * np.max(size, initial=0.0))
                and gap < -LP_CERTIFICATE_RTOL * gap_size)


def _ray_ok(A, b, E, e, c, z0, d) -> bool:
    if not _finite(z0, d) or z0.shape != c.shape or d.shape != c.shape:
        return False
    if _rows_defect(A, b, E, e, z0) is not None:
        return False
    nd = np.abs(d)
    cd = dot(c, d)
    if not cd < -LP_CERTIFICATE_RTOL * dot(np.abs(c), nd):
        return False
    scale = max(float(np.max(nd, initial=0.0)), _TINY)
    return bool(np.all(mm(A, d) <= LP_CERTIFICATE_RTOL * (mm(np.abs(A), nd) + scale))
                and np.all(np.abs(mm(E, d)) <= LP_CERTIFICATE_RTOL * (mm(np.abs(E), nd) + scale)))


_TINY = float(np.finfo(float).tiny)


def _rows_defect(A, b, E, e, z) -> str | None:
    """What row of ``A z <= b, E z = e`` the point violates (relative), or ``None``.

    A row may be violated by at most ``LP_POINT_RTOL (1 + |b_k| + |a_k| |z|)``: the rows are
    equilibrated (unit infinity norm, variables of order one), so the ``1`` is in the units of the
    data, and the other terms are those summed in the row.
    """
    az = np.abs(z)
    for label, M, v, eq in (("inequality", A, b, False), ("equality", E, e, True)):
        if M.shape[0] == 0:
            continue
        r = mm(M, z) - v
        allowed = LP_POINT_RTOL * (1.0 + np.abs(v) + mm(np.abs(M), az))
        excess = (np.abs(r) if eq else r) - allowed
        if np.any(excess > 0):
            k = int(np.argmax(excess))
            return f"{label} row {k} is violated by {abs(r[k]):.3g} (relative to its norm) at the returned point"
    return None


def _pow2_inv(v: np.ndarray) -> np.ndarray:
    """``_pow2(1 / v)``, with 1 where ``v`` is 0 (an all-zero column or cost: nothing to scale)."""
    v = np.asarray(v, dtype=float)
    ok = np.isfinite(v) & (v > 0)
    return np.where(ok, np.exp2(-np.round(np.log2(np.where(ok, v, 1.0)))), 1.0)


@dataclass
class _Scaled:
    """The LP after equilibration: ``x = D z``; rows multiplied by ``r_ub``/``r_eq``; ``c_hat = cn D c``."""

    A: np.ndarray
    b: np.ndarray
    E: np.ndarray
    e: np.ndarray
    c: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    D: np.ndarray
    r_ub: np.ndarray
    r_eq: np.ndarray
    cn: float
    zero_ub: np.ndarray  # right-hand sides of the constant (all-zero) rows: 0 <= b must hold
    zero_eq: np.ndarray
    zero_ub_mask: np.ndarray  # which of the caller's inequality rows are constant

    def bounds(self) -> list:
        return [(None if not np.isfinite(lo) else float(lo), None if not np.isfinite(hi) else float(hi))
                for lo, hi in zip(self.lo, self.hi)]

    def bound_rows(self) -> tuple[np.ndarray, np.ndarray]:
        """The finite variable bounds as rows ``z_j <= hi_j``, ``-z_j <= -lo_j``."""
        n = self.c.size
        I = np.eye(n)
        up, dn = np.isfinite(self.hi), np.isfinite(self.lo)
        return np.vstack([I[up], -I[dn]]), np.concatenate([self.hi[up], -self.lo[dn]])

    def all_rows(self) -> tuple[np.ndarray, np.ndarray]:
        Ab, bb = self.bound_rows()
        return np.vstack([self.A, Ab]), np.concatenate([self.b, bb])


def _equilibrate(c, A_ub, b_ub, A_eq, b_eq, bounds, sweeps: int = LP_EQUILIBRATION_SWEEPS) -> _Scaled:
    """Scale rows and columns of the LP by powers of two so that its entries are about 1 (a few
    geometric-mean sweeps, then every row to unit infinity norm exactly); the cost to unit norm.

    This is what makes the LP layer independent of the units of the data: ``{A x <= b}`` and
    ``{1e-9 A x <= 1e-9 b}`` are the same problem for HiGHS (whose absolute tolerances and small-
    coefficient threshold of 1e-9 otherwise see a different one), and so are states in volts or in
    microvolts.  Constant (all-zero) rows are set aside: they are checked against ``0 <= b``.
    """
    n = c.size
    A = np.zeros((0, n)) if A_ub is None or np.size(A_ub) == 0 else np.atleast_2d(np.asarray(A_ub, dtype=float))
    b = np.zeros(0) if A.shape[0] == 0 else np.asarray(b_ub, dtype=float).reshape(-1)
    E = np.zeros((0, n)) if A_eq is None or np.size(A_eq) == 0 else np.atleast_2d(np.asarray(A_eq, dtype=float))
    e = np.zeros(0) if E.shape[0] == 0 else np.asarray(b_eq, dtype=float).reshape(-1)
    if A.shape[1] != n or E.shape[1] != n or b.shape != (A.shape[0],) or e.shape != (E.shape[0],):
        raise ModelError("LP data", f"constraint matrices with {n} columns and matching right-hand sides",
                         f"A_ub {A.shape}, b_ub {b.shape}, A_eq {E.shape}, b_eq {e.shape}")
    lo = np.full(n, -np.inf)
    hi = np.full(n, np.inf)
    for k, (l, h) in enumerate(_bound_pairs(bounds, n)):
        lo[k] = -np.inf if l is None else float(l)
        hi[k] = np.inf if h is None else float(h)
    zero_ub = np.max(np.abs(A), axis=1, initial=0.0) == 0.0
    zero_eq = np.max(np.abs(E), axis=1, initial=0.0) == 0.0
    const_b, const_e = b[zero_ub], e[zero_eq]
    A, b, E, e = A[~zero_ub], b[~zero_ub], E[~zero_eq], e[~zero_eq]
    r_ub, r_eq, D = np.ones(A.shape[0]), np.ones(E.shape[0]), np.ones(n)
    M = np.vstack([A, E])
    if M.size:
        r = np.ones(M.shape[0])
        absM = np.abs(M)
        # entries at rounding level of their row (a restricted row's 1e-22 where exact arithmetic
        # gives 0) carry no unit: they would drag the geometric mean down
        nz = absM > LP_SCALING_NOISE_RTOL * np.max(absM, axis=1, keepdims=True)
        for _ in range(sweeps):
            # geometric-mean scaling (sqrt of the largest times the smallest non-zero entry): it
            # recovers the units of a matrix that is a diagonal rescaling of a well-scaled one
            # (states in other units), which the max-norm balance does not once a row holds a
            # single variable
            S = absM * r[:, None] * D[None, :]
            big, small = np.max(S, axis=1), np.min(np.where(nz, S, np.inf), axis=1)
            r_next = r * _pow2_inv(np.sqrt(big * np.where(np.isfinite(small), small, big)))
            S = absM * r_next[:, None] * D[None, :]
            big, small = np.max(S, axis=0), np.min(np.where(nz, S, np.inf), axis=0)
            D_next = D * _pow2_inv(np.sqrt(big * np.where(np.isfinite(small), small, big)))
            if np.array_equal(r_next, r) and np.array_equal(D_next, D):
                break  # a fixed point: every further sweep computes these same factors
            r, D = r_next, D_next
        r = r * _pow2_inv(np.max(absM * r[:, None] * D[None, :], axis=1))
        r_ub, r_eq = r[:A.shape[0]], r[A.shape[0]:]
    cs = c * D
    cmax = float(np.max(np.abs(cs), initial=0.0))
    cn = float(_pow2_inv(np.array([cmax]))[0])
    return _Scaled(A * r_ub[:, None] * D[None, :], b * r_ub, E * r_eq[:, None] * D[None, :], e * r_eq, cs * cn,
                   lo / D, hi / D, D, r_ub, r_eq, cn, const_b, const_e, zero_ub)


#: ``method`` of :func:`solve_lp`'s attempts -> HiGHS's ``solver`` option (``None``: HiGHS chooses),
#: the names and meanings of :func:`scipy.optimize.linprog`'s HiGHS methods.
_HIGHS_SOLVER = {"highs": None, "highs-ipm": "ipm", "highs-ds": "simplex"}


@dataclass
class _HighsAnswer:
    """One HiGHS solve: the mapped status, the point and objective (``None`` unless optimal) and the
    multipliers as :func:`scipy.optimize.linprog` reports them (``ineqlin``, ``eqlin``, ``lower``, ``upper``)."""

    status: Status
    message: str
    x: np.ndarray | None = None
    fun: float | None = None
    marginals: dict = field(default_factory=dict)


#: HiGHS's ``simplex_strategy`` value of the dual simplex (``kSimplexStrategyDual``), which scipy sets.
_HIGHS_DUAL_SIMPLEX = 1


def _highs_inf(v: np.ndarray, inf: float) -> np.ndarray:
    """``v`` with its infinite entries as HiGHS's infinity of the same sign."""
    v = np.array(v, dtype=float)
    big = np.isinf(v)
    v[big] = np.where(v[big] > 0, inf, -inf)
    return v


_HIGHS = None  # the highspy module, imported at the first LP (it is not needed to import the package)


def _highspy():
    global _HIGHS
    if _HIGHS is None:
        with captured_native_output("highspy"):  # a HiGHS build may print a banner when loaded
            import highspy

        _HIGHS = highspy
    return _HIGHS


def _call_highs(c, A, b, E, e, bounds, method: str) -> _HighsAnswer:
    """``linprog(c, A_ub=A, b_ub=b, A_eq=E, b_eq=e, bounds=bounds, method=method)`` with HiGHS through highspy.

    The model, options and answer are those of scipy's ``_linprog_highs``: the rows ``A; E`` in
    compressed columns (exact zeros left out), ``-inf <= A z <= b``, ``e <= E z <= e``, infinite
    bounds as HiGHS's infinity, presolve on, dual simplex strategy, ``solver`` from
    :data:`_HIGHS_SOLVER`; row multipliers from the row duals, bound multipliers from the column
    duals of the columns at their lower or upper bound in the basis; an "optimal" point that breaks
    a row or bound by more than :data:`LINPROG_CHECK_TOL` is reported as a numerical failure.
    """
    hs = _highspy()
    n = c.size
    M = np.vstack([A, E]) if E.shape[0] else A
    m, k = M.shape[0], A.shape[0]
    inf = hs.kHighsInf
    lo = np.empty(n)
    hi = np.empty(n)
    for j, (l, h) in enumerate(_bound_pairs(bounds, n)):
        lo[j] = -inf if l is None or l == -np.inf else float(l)
        hi[j] = inf if h is None or h == np.inf else float(h)
    rhs = np.concatenate([b, e]) if E.shape[0] else np.array(b, dtype=float)
    lhs = np.concatenate([np.full(k, -np.inf), e]) if E.shape[0] else np.full(k, -np.inf)
    rhs_h, lhs_h = _highs_inf(rhs, inf), _highs_inf(lhs, inf)
    lp = hs.HighsLp()
    lp.num_col_, lp.num_row_ = n, m
    lp.col_cost_ = np.asarray(c, dtype=float)
    lp.col_lower_, lp.col_upper_ = lo, hi
    lp.row_lower_, lp.row_upper_ = lhs_h, rhs_h
    if m:
        MT = M.T
        nz = MT != 0.0
        lp.a_matrix_.format_ = hs.MatrixFormat.kColwise
        lp.a_matrix_.num_col_, lp.a_matrix_.num_row_ = n, m
        lp.a_matrix_.start_ = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int32)
        lp.a_matrix_.index_ = np.nonzero(nz)[1].astype(np.int32)
        lp.a_matrix_.value_ = MT[nz]
    with captured_native_output("highspy.Highs"):  # a HiGHS build may print a banner from C++ here
        h = hs.Highs()
    h.setOptionValue("output_flag", False)
    h.setOptionValue("log_to_console", False)
    h.setOptionValue("simplex_strategy", _HIGHS_DUAL_SIMPLEX)
    if _HIGHS_SOLVER[method] is not None:
        h.setOptionValue("solver", _HIGHS_SOLVER[method])
    if h.passModel(lp) == hs.HighsStatus.kError:
        return _HighsAnswer(Status.SOLVER_ERROR, "HiGHS refused the model (passModel)")
    if h.run() == hs.HighsStatus.kError:
        ms = h.getModelStatus()
        return _HighsAnswer(map_status(HIGHS_MODEL_STATUS, ms.name, solver=f"highspy/{method}"), h.modelStatusToString(ms))
    ms = h.getModelStatus()
    status = map_status(HIGHS_MODEL_STATUS, ms.name, solver=f"highspy/{method}")
    message = h.modelStatusToString(ms)
    if status != Status.OPTIMAL:
        return _HighsAnswer(status, message)
    sol, basis, info = h.getSolution(), h.getBasis(), h.getInfo()
    x = np.array(sol.col_value, dtype=float)
    fun = float(info.objective_function_value)
    row_value = np.array(sol.row_value, dtype=float)
    slack = rhs_h - row_value
    at_lower, at_upper = hs.HighsBasisStatus.kLower, hs.HighsBasisStatus.kUpper
    col_dual = sol.col_dual
    marg = np.zeros((2, n))
    for j, st in enumerate(basis.col_status):
        if st == at_lower:
            marg[0, j] = col_dual[j]
        elif st == at_upper:
            marg[1, j] = col_dual[j]
    lam = np.array(sol.row_dual, dtype=float)
    tol = LINPROG_CHECK_TOL
    lo_f, hi_f = np.where(lo <= -inf, -np.inf, lo), np.where(hi >= inf, np.inf, hi)
    if (np.isnan(x).any() or np.isnan(fun) or np.isnan(slack).any() or np.any(x < lo_f - tol) or np.any(x > hi_f + tol)
            or np.any(slack[:k] < -tol) or np.any(np.abs(slack[k:]) > tol)):
        return _HighsAnswer(Status.SOLVER_ERROR, f"{message}, but the point breaks a row or bound by more than {tol:.2e}")
    return _HighsAnswer(Status.OPTIMAL, message, x, fun,
                        {"ineqlin": lam[:k], "eqlin": lam[k:], "lower": marg[0], "upper": marg[1]})


def _marginals(res: _HighsAnswer, name: str, size: int) -> np.ndarray | None:
    m = res.marginals.get(name)
    if size == 0:
        return np.zeros(0)
    if m is None:
        return None
    m = np.asarray(m, dtype=float).reshape(-1)
    return m if m.shape == (size,) and np.all(np.isfinite(m)) else None


def _optimality_defect(sc: _Scaled, res, z: np.ndarray, fun) -> str | None:
    """What is wrong with an "optimal" answer (scaled problem), or ``None``.

    Checked: a finite point that satisfies every row and bound (:func:`_rows_defect`), an
    objective equal to ``c'z``, and HiGHS's multipliers as a dual certificate: of the right sign,
    stationary (``c = A'm + E'm_e + m_lo + m_hi``) and with the primal objective equal to the dual
    one, all relative to the sizes of the terms (:data:`LP_DUAL_RTOL`).
    """
    n = sc.c.size
    try:
        fun = float(fun)
    except (TypeError, ValueError):
        return "the returned objective is not a number"
    if z.shape != (n,) or not np.all(np.isfinite(z)) or not np.isfinite(fun):
        return "the returned point or objective is not finite"
    Ab, bb = sc.bound_rows()
    defect = _rows_defect(np.vstack([sc.A, Ab]), np.concatenate([sc.b, bb]), sc.E, sc.e, z)
    if defect is not None:
        return defect
    cz = dot(sc.c, z)
    size = dot(np.abs(sc.c), np.abs(z))
    if abs(cz - fun) > LP_DUAL_RTOL * (1.0 + abs(cz) + size):
        return f"its objective {fun:.9g} is not c'x = {cz:.9g}"
    m_ub, m_eq = _marginals(res, "ineqlin", sc.A.shape[0]), _marginals(res, "eqlin", sc.E.shape[0])
    m_lo, m_hi = _marginals(res, "lower", n), _marginals(res, "upper", n)
    if m_ub is None or m_eq is None or m_lo is None or m_hi is None:
        return "no finite dual multipliers were returned"
    m_lo = np.where(np.isfinite(sc.lo), m_lo, 0.0)
    m_hi = np.where(np.isfinite(sc.hi), m_hi, 0.0)
    dual_size = float(np.max(mm(np.abs(sc.A).T, np.abs(m_ub)) + mm(np.abs(sc.E).T, np.abs(m_eq)) + np.abs(m_lo) + np.abs(m_hi)
                             + np.abs(sc.c), initial=0.0))
    sign = max(float(np.max(m_ub, initial=0.0)), float(np.max(-m_lo, initial=0.0)), float(np.max(m_hi, initial=0.0)))
    if sign > LP_DUAL_RTOL * max(dual_size, 1.0):
        return "a dual multiplier has the wrong sign"
    station = sc.c - mm(sc.A.T, m_ub) - mm(sc.E.T, m_eq) - m_lo - m_hi
    if np.max(np.abs(station), initial=0.0) > LP_DUAL_RTOL * max(dual_size, 1.0):
        return f"the dual multipliers are not stationary (residual {np.max(np.abs(station)):.3g})"
    lo_f = np.where(np.isfinite(sc.lo), sc.lo, 0.0)
    hi_f = np.where(np.isfinite(sc.hi), sc.hi, 0.0)
    dual = dot(sc.b, m_ub) + dot(sc.e, m_eq) + dot(lo_f, m_lo) + dot(hi_f, m_hi)
    gap_size = (1.0 + abs(cz) + size + dot(np.abs(sc.b), np.abs(m_ub)) + dot(np.abs(sc.e), np.abs(m_eq))
                + dot(np.abs(lo_f), np.abs(m_lo)) + dot(np.abs(hi_f), np.abs(m_hi)))
    if abs(cz - dual) > LP_DUAL_RTOL * gap_size:
        return f"the duality gap {cz - dual:.3g} is not zero (the point is not optimal)"
    return None


def _farkas(sc: _Scaled, problem: str, method: str) -> LPCertificate | None:
    """A Farkas certificate of the scaled LP's infeasibility from one auxiliary LP, or ``None``.

    Finds ``y >= 0``, ``w`` free with ``A'y + E'w = 0`` and ``b'y + e'w = -1`` (feasible exactly
    when the LP is infeasible); the answer is only returned when :meth:`LPCertificate.verify` holds.
    """
    A, b = sc.all_rows()
    E, e = sc.E, sc.e
    k, q, n = A.shape[0], E.shape[0], sc.c.size
    M = np.vstack([np.hstack([A.T, E.T]), np.concatenate([b, e])[None, :]])
    rhs = np.zeros(n + 1)
    rhs[-1] = -1.0
    try:
        res = _call_highs(np.zeros(k + q), np.zeros((0, k + q)), np.zeros(0), M, rhs, [(0, None)] * k + [(None, None)] * q,
                          method)
    except Exception:  # a crash of the auxiliary LP certifies nothing
        return None
    if res.status != Status.OPTIMAL or res.x is None:
        return None
    v = np.asarray(res.x, dtype=float)
    cert = LPCertificate("farkas", problem, A, b, E, e, sc.c, y=np.maximum(v[:k], 0.0), w=v[k:])
    return cert if cert.verify() else None


def _ray(sc: _Scaled, problem: str, method: str) -> LPCertificate | None:
    """A certificate of unboundedness (a feasible point and a descent ray, two auxiliary LPs), or ``None``."""
    A, b = sc.all_rows()
    E, e = sc.E, sc.e
    n = sc.c.size
    try:
        feas = _call_highs(np.zeros(n), A, b, E, e, (None, None), method)
        if feas.status != Status.OPTIMAL or feas.x is None:
            return None
        ray = _call_highs(sc.c, A, np.zeros(A.shape[0]), E, np.zeros(E.shape[0]), (-1.0, 1.0), method)
        if ray.status != Status.OPTIMAL or ray.x is None:
            return None
    except Exception:
        return None
    cert = LPCertificate("ray", problem, A, b, E, e, sc.c, z0=np.asarray(feas.x, dtype=float), d=np.asarray(ray.x, dtype=float))
    return cert if cert.verify() else None


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
        r = mm(np.atleast_2d(np.asarray(A, dtype=float)), x) - np.asarray(b, dtype=float).reshape(-1)
        out[label] = float(np.max(np.abs(r) if eq else np.maximum(r, 0.0), initial=0.0))
    worst = 0.0
    for k, (lo, hi) in enumerate(_bound_pairs(bounds, x.size)):
        if lo is not None:
            worst = max(worst, float(lo - x[k]))
        if hi is not None:
            worst = max(worst, float(x[k] - hi))
    out["bounds"] = worst
    return out


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
    """``[min, max]`` of each ``row @ z`` over ``{z : A z <= b, E z = e}``: two LPs per row.

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

    See Also
    --------
    solve_lp : each of its LPs.
    Polytope.bounding_box : the ranges of the coordinates.

    Examples
    --------
    The range of ``z1 + z2`` and ``z1 - z2`` over the square:

    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import row_range
    >>> row_range(A, b, np.array([[1.0, 1.0], [1.0, -1.0]]))
    array([[-2.,  2.],
           [-2.,  2.]])
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

from ._lp_kernels import answer_ok, checked_slack_bounds, slack_lp_data, support_upper_bound, walk_width  # noqa: E402
from ..tolerances import (DAQP_EPS_PROX, DAQP_POINT_RTOL, EXACT_DECISION_MARGIN, HIGHS_DECISION_BAND,  # noqa: E402
                          NEAR_ACTIVE_TOL, SLACK_CAP, ZERO_ROW_TOL)


def _daqp_optimal(flag: int) -> bool:
    """DAQP's exit flag through the one status map and the one acceptance policy (memoised per flag)."""
    flag = int(flag)
    ok = _DAQP_OPTIMAL.get(flag)
    if ok is None:
        ok = _DAQP_OPTIMAL[flag] = is_optimal(map_status(DAQP_STATUS, flag, solver="daqp"))
    return ok


_DAQP_OPTIMAL: dict[int, bool] = {}


@dataclass
class LPCounters:
    """How many certified LPs (:func:`max_slack`, :func:`verified_lp`) ran in a block of
    :func:`counting_lps`: ``fast`` decided by DAQP, ``confirmed_by_highs`` by the robust solver.

    See Also
    --------
    counting_lps : fills one.

    Examples
    --------
    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import counting_lps, max_slack
    >>> with counting_lps() as counts:
    ...     result = max_slack(A, b, radius_bound=10.0, threshold=0.5)
    >>> counts.fast, counts.confirmed_by_highs            # decided by DAQP, none sent to HiGHS
    (1, 0)
    """

    fast: int = 0
    confirmed_by_highs: int = 0

    @property
    def total(self) -> int:
        return self.fast + self.confirmed_by_highs


#: The counters of the innermost :func:`counting_lps` block of this context (outside any block:
#: counters that nobody reads).
_ACTIVE_COUNTERS: ContextVar[LPCounters] = ContextVar("hybobs_lp_counters", default=LPCounters())


@contextmanager
def counting_lps() -> Iterator[LPCounters]:
    """Count the certified LPs solved inside the ``with`` block into new :class:`LPCounters`.

    The caller holds the counts (no process-wide counter to reset or to subtract from); a block
    nested in another adds its counts to the outer block's when it ends.  A worker process counts
    its own task's LPs and returns them with the task's result.

    Yields
    ------
    LPCounters
        The counts of the block, final when the block ends.

    See Also
    --------
    LPCounters : the counts.

    Examples
    --------
    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import certified_width_below, counting_lps, max_slack
    >>> with counting_lps() as counts:
    ...     result = max_slack(A, b, radius_bound=10.0, threshold=0.5)
    ...     narrow = certified_width_below(A, b, np.array([1.0, 0.0]), radius_bound=10.0, width=2.5)
    >>> counts
    LPCounters(fast=3, confirmed_by_highs=0)
    """
    counters = LPCounters()
    token = _ACTIVE_COUNTERS.set(counters)
    try:
        yield counters
    finally:
        _ACTIVE_COUNTERS.reset(token)
        outer = _ACTIVE_COUNTERS.get()
        outer.fast += counters.fast
        outer.confirmed_by_highs += counters.confirmed_by_highs


def _count(fast: int = 0, confirmed: int = 0) -> None:
    counters = _ACTIVE_COUNTERS.get()
    counters.fast += fast
    counters.confirmed_by_highs += confirmed


def highs_lp(c: np.ndarray, A: np.ndarray, b: np.ndarray, *, problem: str, replaces_fast: bool = False) -> LPResult:
    """HiGHS's checked answer to ``min c'x s.t. A x <= b`` (:func:`solve_lp`), counted as one LP
    confirmed by the robust solver; ``replaces_fast``: the LP was counted as DAQP's by
    :func:`verified_lp` and its answer did not decide, so this is the same LP, not another one."""
    _count(fast=-1 if replaces_fast else 0, confirmed=1)
    return solve_lp(c, A, b, problem=problem)


_SLACK_LP_COLUMNS: dict[int, tuple[np.ndarray, np.ndarray]] = {}
_SLACK_LP_ROWS: dict[int, tuple[np.ndarray, np.ndarray]] = {}


def _slack_lp_constants(rows: int, columns: int):
    """``H = 0``, ``f = (0, ..., 0, -1)``, lower bounds ``-1e30`` and senses ``0`` of a slack LP of this
    size, allocated once per size: DAQP reads them and writes none (its bindings copy ``sense``
    before a warm start marks constraints active, and none is given here), and nothing else
    touches them."""
    by_columns = _SLACK_LP_COLUMNS.get(columns)
    if by_columns is None:
        f = np.zeros(columns)
        f[-1] = -1.0
        by_columns = _SLACK_LP_COLUMNS[columns] = (np.zeros((columns, columns)), f)
    by_rows = _SLACK_LP_ROWS.get(rows)
    if by_rows is None:
        by_rows = _SLACK_LP_ROWS[rows] = (np.full(rows, -1e30), np.zeros(rows, dtype=np.int32))
    return by_columns[0], by_columns[1], by_rows[0], by_rows[1]


def _daqp_call(H, f, A, bu, lower, sense, **settings):
    """``daqp.solve``, with an exception of the solver reported as a failed solve (``None``)."""
    try:
        return daqp.solve(H, f, A, bu, lower, sense, **settings)
    except Exception:  # the robust solver decides instead; the caller counts it
        return None


def daqp_answer_ok(A: np.ndarray, b: np.ndarray, x, lam) -> bool:
    """Does a DAQP answer flagged optimal for ``min f'x s.t. A x <= b`` pass the numpy checks?

    The point is finite and satisfies every row to ``DAQP_POINT_RTOL (1 + |b_k| + |a_k| |x|)``,
    and the multipliers are finite and non-negative to ``DAQP_POINT_RTOL`` times their largest
    size.  (The certified bounds computed from them clip them at zero, so they need no
    stationarity check: a poor multiplier only gives a weaker bound, and the caller then asks HiGHS.)
    Two matrix-vector products.
    """
    if lam is None:
        return False
    A, b = np.asarray(A, dtype=float), np.asarray(b, dtype=float)
    x = np.asarray(x, dtype=float)
    lam = np.asarray(lam, dtype=float)
    if A.ndim != 2 or x.shape != (A.shape[1],) or lam.shape != (A.shape[0],) or b.shape != (A.shape[0],):
        return False
    # one compiled loop: in numpy the check costs twice the DAQP solve it checks
    return bool(answer_ok(A, b, x, lam, DAQP_POINT_RTOL))


def daqp_infeasibility_ok(A: np.ndarray, b: np.ndarray, lam) -> bool:
    """Do DAQP's multipliers of an "infeasible" exit prove it (Farkas: ``y >= 0, A'y = 0, b'y < 0``)?"""
    y = np.asarray(lam, dtype=float)
    if y.shape != (A.shape[0],) or not np.all(np.isfinite(y)):
        return False
    y = np.where(y > 0.0, y, 0.0)
    return _farkas_ok(A, b, np.zeros((0, A.shape[1])), np.zeros(0), y, np.zeros(0))


def verified_lp(c: np.ndarray, A: np.ndarray, b: np.ndarray, *, problem: str, eps_prox: float | None = DAQP_EPS_PROX) -> LPResult:
    """Minimise ``c'x`` subject to ``A x <= b`` by DAQP when its answer verifies in numpy, else by HiGHS (:func:`solve_lp`).

    The :class:`LPResult` names the solver that answered (``"daqp"`` or ``"highs"``); at an optimum
    ``x`` is the point and ``duals`` the multipliers ``lambda >= 0`` of the rows.

    DAQP's "optimal" must pass :func:`daqp_answer_ok`, its "infeasible" must come with a Farkas
    certificate in its multipliers (:func:`daqp_infeasibility_ok`); any other exit, an exception
    or a failed check sends the LP to HiGHS, whose answer :func:`solve_lp` checks in turn (a
    :class:`SolverError` when that fails too; ``UNBOUNDED`` is then a certified status too).

    Returns
    -------
    LPResult
        The answer of the solver that answered (``solver`` is ``"daqp"`` or ``"highs"``); at an
        optimum ``x`` and the row multipliers ``duals``.

    See Also
    --------
    solve_lp : the HiGHS path.
    max_slack : the certified slack LP.

    Examples
    --------
    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import verified_lp
    >>> result = verified_lp(np.array([1.0, 1.0]), A, b, problem="corner of the square")
    >>> result.status.value, result.solver, np.round(result.x, 6), round(result.objective, 6)
    ('optimal', 'daqp', array([-1., -1.]), -2.0)
    >>> np.round(result.duals, 6)                  # the rows -z1 <= 1 and -z2 <= 1 are active
    array([0., 0., 1., 1.])
    """
    t0 = time.perf_counter()
    d = A.shape[1]
    _count(fast=1)
    settings = {} if eps_prox is None else {"eps_prox": eps_prox}
    out = _daqp_call(np.zeros((d, d)), c, A, b, np.full(A.shape[0], -1e30), np.zeros(A.shape[0], dtype=np.int32), **settings)
    if out is not None:
        x, _, flag, info = out
        lam = info.get("lam") if isinstance(info, dict) else None
        status = map_status(DAQP_STATUS, int(flag), solver="daqp")
        if is_optimal(status) and lam is not None and daqp_answer_ok(A, b, x, lam):
            x = np.asarray(x, dtype=float)
            return LPResult(Status.OPTIMAL, x, float(dot(c, x)), "daqp", time.perf_counter() - t0,
                            duals=np.asarray(lam, dtype=float))
        if status == Status.INFEASIBLE and lam is not None and daqp_infeasibility_ok(A, b, lam):
            return LPResult(Status.INFEASIBLE, None, None, "daqp", time.perf_counter() - t0)
    return highs_lp(c, A, b, problem=problem, replaces_fast=True)


def chebyshev_lp(A_ub: np.ndarray, b: np.ndarray) -> np.ndarray | None:
    """The optimum ``(z, r)`` of ``max r s.t. A z + |a| r <= b`` (rows ``A_ub = [A, |a|]``), or ``None``.

    DAQP (microseconds) points at the optimal vertex; the answer is that vertex, certified as
    a basis in numpy: the ``n = d + 1`` rows tightest at DAQP's point (larger multiplier first
    among equal slacks), condition number at most LP_VERTEX_MAX_COND, solved as equations for ``(z, r)``; the vertex
    satisfies every row to LP_VERTEX_RTOL of the row's terms, and the multipliers of the basis,
    ``B' lambda = (0, ..., 0, 1)``, are non-negative to LP_VERTEX_RTOL (weak duality: every
    feasible radius is at most ``b_B' lambda = r``).  An exact vertex, so a flat set gets radius
    0 to rounding, not DAQP's ~1e-9.  ``None`` (DAQP failed, an empty or unbounded set, a
    singular or failed basis) sends the caller to :func:`solve_lp`.
    """
    m, n = A_ub.shape
    if m < n:
        return None
    c = np.zeros(n)
    c[-1] = -1.0
    # DAQP's bindings want writeable buffers (a Polytope's arrays are read-only)
    b = np.array(b, dtype=float)
    out = _daqp_call(np.zeros((n, n)), c, A_ub, b, np.full(m, -1e30), np.zeros(m, dtype=np.int32), eps_prox=DAQP_EPS_PROX)
    if out is None:
        return None
    x, _, flag, info = out
    lam = info.get("lam") if isinstance(info, dict) else None
    if lam is None or not is_optimal(map_status(DAQP_STATUS, int(flag), solver="daqp")):
        return None
    x = np.asarray(x, dtype=float)
    lam = np.asarray(lam, dtype=float)
    if x.shape != (n,) or lam.shape != (m,) or not (np.all(np.isfinite(x)) and np.all(np.isfinite(lam))):
        return None
    absA = np.abs(A_ub)
    size = 1.0 + np.abs(b) + absA @ np.abs(x)  # the terms of each row
    basis = np.lexsort((np.arange(m), -lam, (b - A_ub @ x) / size))[:n]
    B = A_ub[basis]
    try:
        if np.linalg.cond(B) > LP_VERTEX_MAX_COND:
            return None
        v = np.linalg.solve(B, b[basis])
        mult = np.linalg.solve(B.T, -c)
    except np.linalg.LinAlgError:
        return None
    if not (np.all(np.isfinite(v)) and np.all(np.isfinite(mult))):
        return None
    if np.any(A_ub @ v - b > LP_VERTEX_RTOL * (1.0 + np.abs(b) + absA @ np.abs(v))):
        return None
    if np.any(mult < -LP_VERTEX_RTOL * max(1.0, float(np.max(np.abs(mult))))):
        return None
    return v


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

    Parameters
    ----------
    lower : float
        Certified lower bound of the slack (``-inf`` for an empty polytope).
    upper : float
        Certified upper bound (``inf`` without multipliers).
    w : array or None
        The point that certifies ``lower`` (``None`` when empty).
    solver : str
        The solver that decided: ``"daqp"``, ``"daqp+nnls"``, ``"highs"``, or ``"numpy"`` when
        the constant rows decide.
    lam : array, optional
        DAQP's multipliers of the LP's rows.
    seconds : float, default 0.0
        Wall time of the solve.

    See Also
    --------
    max_slack, solve_slack_lp : return it.

    Examples
    --------
    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import max_slack
    >>> result = max_slack(A, b, radius_bound=10.0, threshold=0.5)
    >>> round(result.lower, 6), round(result.upper, 6)      # certified from w and from the multipliers
    (1.0, 1.0)
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
        """JSON-ready record of the certified slack.

        Returns
        -------
        dict
            ``status``, ``lower``, ``upper``, ``solver``, ``w`` (a list, or ``None``), ``seconds`` and
            ``residuals``.
        """
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
    (counted by :func:`counting_lps`).

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

    Returns
    -------
    SlackResult
        The certified interval ``[lower, upper]`` of the largest slack, the point ``w`` that proves
        ``lower`` and the solver that answered.

    See Also
    --------
    SlackResult : what it returns.
    solve_slack_lp : the LP after the constant rows are handled.
    certified_width_below : the certified width of a polytope along a direction.

    Examples
    --------
    The Chebyshev radius of the square ``|w_i| <= 1`` is 1, at its centre:

    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import max_slack
    >>> result = max_slack(A, b, radius_bound=10.0, threshold=0.5)
    >>> round(result.lower, 6), round(result.upper, 6), result.w, result.solver
    (1.0, 1.0, array([0., 0.]), 'daqp')
    >>> result.lower > 0.5                            # the decision the caller takes
    True
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


def solve_slack_lp(A: np.ndarray, bu: np.ndarray, radius_bound: float, threshold: float, problem: str, *,
                   tight_attempt: dict | None = None) -> SlackResult:
    """DAQP on the data of :func:`~hybobs_opt.geometry._lp_kernels.slack_lp_data`, certified, HiGHS as the fallback.

    The LP of :func:`max_slack` after its constant rows were handled: ``A`` is ``(k + 1) x (d + 1)``
    (the last row caps ``t``), ``bu`` its right-hand side.  ``threshold`` is the decision the
    caller will take (``slack > threshold``); see :func:`max_slack` for the certificates.

    Parameters
    ----------
    A : (k + 1, d + 1) ndarray
        Constraint matrix over ``(w, t)``; the last row caps ``t``.
    bu : (k + 1,) ndarray
        Right-hand side.
    radius_bound : float
        ``R``: every feasible ``w`` has ``||w||_2 <= R`` (for the dual bound).
    threshold : float
        The caller's decision value (``slack > threshold``).
    problem : str
        Name of the LP for error messages.
    tight_attempt : dict, optional
        DAQP settings of one more attempt when the default ones do not decide ``threshold``,
        before HiGHS (the pair tests of Algorithm 3.1 pass a tight primal tolerance: on a face
        of radius exactly 0 the default leaves rows violated by more than the closed-set
        tolerance).  Its answer is used only when it passes :func:`daqp_answer_ok` and its
        numpy-certified bounds decide; it is returned without multipliers (``solver`` ``"daqp
        (tight)"``), like HiGHS's, so callers take HiGHS's path.

    Returns
    -------
    SlackResult
        Certified lower and upper bounds of the slack, the point and the solver that decided.

    See Also
    --------
    max_slack : builds its data and handles the constant rows.

    Examples
    --------
    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import solve_slack_lp
    >>> from hybobs_opt.geometry._lp_kernels import slack_lp_data
    >>> from hybobs_opt.tolerances import SLACK_CAP, ZERO_ROW_TOL
    >>> data, rhs, ok = slack_lp_data(A, b, ZERO_ROW_TOL, SLACK_CAP)
    >>> data.shape                                     # 4 rows and the cap on t, over (w, t)
    (5, 3)
    >>> result = solve_slack_lp(data, rhs, 10.0, 0.5, "square")
    >>> round(result.lower, 6), round(result.upper, 6)
    (1.0, 1.0)
    """
    t0 = time.perf_counter()
    k = A.shape[0] - 1
    d = A.shape[1] - 1
    _count(fast=1)
    H, f, lower_bounds, sense = _slack_lp_constants(k + 1, d + 1)
    # DAQP_EPS_PROX first; on the rare cycling exit (0.2 % of model 17's pair LPs) DAQP's own
    # automatic regularisation usually finishes, then NNLS sharpens its multipliers.
    for eps_prox in (DAQP_EPS_PROX, None):
        settings = {} if eps_prox is None else {"eps_prox": eps_prox}
        out = _daqp_call(H, f, A, bu, lower_bounds, sense, **settings)
        if out is None:
            break  # DAQP raised: HiGHS decides
        x, _, flag, info = out
        lam = info.get("lam")
        if not _daqp_optimal(flag) or lam is None:
            continue
        # daqp_answer_ok's checks, then the certified bounds, in one compiled call
        ok, lower, upper = checked_slack_bounds(A, bu, np.asarray(x, dtype=float), np.asarray(lam, dtype=float),
                                                DAQP_POINT_RTOL, radius_bound, SLACK_CAP)
        if not ok:
            continue
        w = np.asarray(x[:d], dtype=float)
        if lower > threshold + EXACT_DECISION_MARGIN or upper <= threshold - EXACT_DECISION_MARGIN:
            return SlackResult(lower, upper, w, "daqp", info["lam"], time.perf_counter() - t0)
        if lower > threshold or upper <= threshold:  # decided, but within the margin: exactly
            return _exact_slack(A, bu, x, threshold, SlackResult(lower, upper, w, "daqp", info["lam"], 0.0), t0, info["lam"])
        # Refine the dual on the rows active at DAQP's point (non-negative least squares on the
        # stationarity conditions): a slack of exactly zero (two regions that only touch) needs
        # multipliers more exact than a proximal solve may return.
        upper = min(upper, _refined_upper_bound(A[:k, :d], bu[:k], w, float(x[d]), radius_bound))
        if upper <= threshold - EXACT_DECISION_MARGIN:
            return SlackResult(lower, upper, w, "daqp+nnls", info["lam"], time.perf_counter() - t0)
        if upper <= threshold:
            return _exact_slack(A, bu, x, threshold, SlackResult(lower, upper, w, "daqp+nnls", info["lam"], 0.0), t0, info["lam"])
        break
    if tight_attempt is not None:
        out = _daqp_call(H, f, A, bu, lower_bounds, sense, **tight_attempt)
        if out is not None:
            x, _, flag, info = out
            lam = info.get("lam") if isinstance(info, dict) else None
            ok = False
            if lam is not None and _daqp_optimal(flag):
                ok, lower, upper = checked_slack_bounds(A, bu, np.asarray(x, dtype=float), np.asarray(lam, dtype=float),
                                                        DAQP_POINT_RTOL, radius_bound, SLACK_CAP)
            if ok:
                found = SlackResult(lower, upper, np.asarray(x[:d], dtype=float), "daqp (tight)", None, 0.0)
                if lower > threshold + EXACT_DECISION_MARGIN or upper <= threshold - EXACT_DECISION_MARGIN:
                    return SlackResult(lower, upper, found.w, found.solver, None, time.perf_counter() - t0)
                if lower > threshold or upper <= threshold:
                    return _exact_slack(A, bu, x, threshold, found, t0, lam)
    # Undecided (or DAQP failed): the robust solver decides.
    res = highs_lp(f, A, bu, problem=problem, replaces_fast=True)
    if res.status == Status.INFEASIBLE:
        return SlackResult(-np.inf, -np.inf, None, "highs", seconds=time.perf_counter() - t0)
    if not is_optimal(res.status):
        raise SolverError(problem, "HiGHS", res.status, hint="the slack LP is capped and cannot be unbounded: check the data for NaN")
    w = res.x[:d]
    # HiGHS's point has passed solve_lp's feasibility check; its certified value is the smallest
    # row slack at that point (the LP's t may exceed it by the solver's primal tolerance).
    slack = float(min(res.x[d], np.min(bu[:k] - mm(A[:k, :d], w))))
    found = SlackResult(slack, slack, w, "highs")
    # `slack` is the value of a point of the set, a lower bound on the optimum up to the rounding
    # of its own evaluation: above the threshold by the margin, that point proves "above".  Only
    # "at most the threshold" needs the optimum itself, which HiGHS's point does not prove this close.
    if abs(slack - threshold) <= HIGHS_DECISION_BAND and not slack > threshold + EXACT_DECISION_MARGIN:
        return _exact_slack(A, bu, res.x, threshold, found, t0, res.duals)
    return SlackResult(slack, slack, w, "highs", seconds=time.perf_counter() - t0)


def _exact_slack(A: np.ndarray, bu: np.ndarray, hint: np.ndarray, threshold: float, found: SlackResult,
                 t0: float, duals=None) -> SlackResult:
    """The max-slack LP re-decided in rational arithmetic against ``threshold`` (:mod:`.exact_lp`).

    Returns a result whose ``lower > threshold`` exactly when the exact optimum is; when the exact
    solve cannot settle it, ``found`` (the floating-point answer) as it was, counted in
    :data:`~hybobs_opt.geometry.exact_lp.EXACT` as undecided.
    """
    from fractions import Fraction

    from .exact_lp import EXACT, exact_lp_optimum

    d = A.shape[1] - 1
    cost = np.zeros(d + 1)
    cost[d] = -1.0
    value = exact_lp_optimum(cost, A, bu, np.asarray(hint, dtype=float), duals)
    if value is None:
        EXACT.undecided += 1
        return SlackResult(found.lower, found.upper, found.w, found.solver, found.lam, time.perf_counter() - t0)
    EXACT.decided += 1
    radius = -value
    f = float(radius)
    if radius > Fraction(threshold):
        f = max(f, float(np.nextafter(threshold, np.inf)))
    else:
        f = min(f, threshold)
    return SlackResult(f, f, found.w, found.solver + " (exact)", found.lam, time.perf_counter() - t0)


def width_proven_above(A: np.ndarray, b: np.ndarray, c: np.ndarray, point: np.ndarray, width: float) -> bool:
    """Is the width ``max c'v - min c'v`` of ``{A v <= b}`` proven above ``width`` without an LP?

    Two walks from ``point`` (an interior or nearly feasible point) along ``c`` and ``-c``
    (:func:`~hybobs_opt.geometry._lp_kernels.walk_width_lower_bound`) reach two points of the set,
    each checked with a rounding-error bound; ``True`` when they lie more than ``width +
    EXACT_DECISION_MARGIN`` apart along ``c``.  ``False`` proves nothing: the LPs decide then.
    """
    p = np.ascontiguousarray(point, dtype=float)
    if p.shape != (A.shape[1],) or A.shape[0] == 0:
        return False
    lower = walk_width(np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(b, dtype=float), p,
                       np.ascontiguousarray(c, dtype=float), WIDTH_WALK_STEPS, WIDTH_WALK_FRACTION, width + 2.0 * EXACT_DECISION_MARGIN)
    return bool(lower > width + EXACT_DECISION_MARGIN)


def certified_width_below(A: np.ndarray, b: np.ndarray, c: np.ndarray, *, radius_bound: float, width: float,
                          point: np.ndarray | None = None) -> bool:
    """Is the width ``max c'v - min c'v`` of ``{A v <= b}`` certified to be at most ``width``?

    Two DAQP LPs (maximise and minimise ``c'v``); each optimum is bounded from the solver's
    multipliers (:func:`~hybobs_opt.geometry._lp_kernels.support_upper_bound`, valid for every feasible
    ``v`` with ``|v| <= radius_bound``), so ``True`` is a certificate.  When that bound is within
    ``EXACT_DECISION_MARGIN`` of ``width`` (its own rounding could decide), the width is decided
    in rational arithmetic (:mod:`~hybobs_opt.geometry.exact_lp`) on the LP as posed.  ``False``
    means "not certified" (wider, multipliers too loose to prove it narrower, a solve that did not
    finish, or an exact solve that could not settle it): callers must treat it as the safe answer.
    When DAQP fails (or returns non-finite numbers), HiGHS's duals are used for the same bound.
    With a (nearly) feasible ``point``, two short walks from it along ``c`` and ``-c``
    (:func:`~hybobs_opt.geometry._lp_kernels.walk_width_lower_bound`) first try to reach two
    points of the set, checked with rounding-error bounds, more than ``width +
    EXACT_DECISION_MARGIN`` apart along ``c``: then the width is proven larger and no LP is
    solved (the answer the LPs would give, since their bound is never below the true width); and
    the second LP is skipped when the first one's maximiser is already more than ``width`` away
    from the point along ``c``.

    Parameters
    ----------
    A : (k, d) ndarray
        Constraint rows of ``{A v <= b}``.
    b : (k,) ndarray
        Right-hand side.
    c : (d,) ndarray
        Direction whose width is bounded.
    radius_bound : float
        Bound on ``||v||`` over the feasible set, used by the dual bound.
    width : float
        Width to certify.
    point : (d,) ndarray, optional
        A (nearly) feasible point that allows skipping the second LP.

    Returns
    -------
    bool
        ``True`` when the width is certified to be at most ``width``; ``False`` means "not
        certified" (the safe answer), not "wider".

    See Also
    --------
    max_slack : the certified slack LP.
    row_range : the range of a functional, without a certificate on a threshold.

    Examples
    --------
    The square ``|v_i| <= 1`` has width 2 along ``v1``:

    >>> import numpy as np
    >>> A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)     # the square |z_i| <= 1
    >>> from hybobs_opt.geometry import certified_width_below
    >>> c = np.array([1.0, 0.0])
    >>> certified_width_below(A, b, c, radius_bound=10.0, width=2.5)
    True
    >>> certified_width_below(A, b, c, radius_bound=10.0, width=1.5)
    False
    """
    # one layout for the kernels below (a view such as a slack LP's rows would compile another)
    A, b = np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(b, dtype=float)
    if point is not None and width_proven_above(A, b, c, point, width):
        return False  # two points of the set are proven farther apart than `width`: no LP
    total = 0.0
    points = []
    for sign in (1.0, -1.0):
        # DAQP when its answer verifies, else HiGHS (checked): both give multipliers for the bound
        ans = verified_lp(-sign * c, A, b, problem="width LP (certified_width_below)")
        if ans.status != Status.OPTIMAL:
            return False  # empty or unbounded: not certified (the safe answer)
        v, lam = ans.x, ans.duals
        if point is not None and sign > 0 and dot(c, v - point) > width:
            return False
        points.append((v, lam))
        total += support_upper_bound(A, b, sign * c, np.ascontiguousarray(lam, dtype=float), radius_bound)
    if abs(total - width) > EXACT_DECISION_MARGIN:
        return total <= width
    return _exact_width_below(A, b, c, points, width)  # the certificate is too close to decide: exactly


def _exact_width_below(A: np.ndarray, b: np.ndarray, c: np.ndarray, points: list, width: float) -> bool:
    """``max c'v - min c'v <= width`` over ``{A v <= b}`` decided in rational arithmetic; not certified
    (``False``, the safe answer) when the exact solves cannot settle it (counted)."""
    from fractions import Fraction

    from .exact_lp import EXACT, exact_lp_optimum

    top = exact_lp_optimum(-np.asarray(c, dtype=float), A, b, *points[0])
    bottom = exact_lp_optimum(np.asarray(c, dtype=float), A, b, *points[1])
    if top is None or bottom is None:
        EXACT.undecided += 1
        return False
    EXACT.decided += 1
    return -top - bottom <= Fraction(width)


def _refined_upper_bound(Gn: np.ndarray, gn: np.ndarray, w: np.ndarray, t_solver: float, radius_bound: float) -> float:
    """Upper bound on the max slack from multipliers fitted by NNLS on the near-active rows.

    Any ``lambda >= 0`` with ``n' lambda = 1`` (rows are unit-norm) bounds the slack of every
    feasible ``w`` (``||w|| <= R``) by ``g' lambda + R ||G' lambda||``: weak duality with the
    stationarity residual bounded by Cauchy-Schwarz.
    """
    resid = gn - mm(Gn, w)
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
    return dot(gn[active], lam) + radius_bound * norm(mm(GA.T, lam))


#: Former private name of :func:`solve_slack_lp` (kept: ``regions`` and ``observers`` import it).
_solve_slack_lp = solve_slack_lp

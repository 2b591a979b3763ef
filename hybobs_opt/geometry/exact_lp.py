"""The optimum of a small LP in rational arithmetic, for decisions too close to their threshold.

A decision such as "the Chebyshev radius exceeds ``-CLOSED_SET_TOL``" is taken from floating-point
bounds when they clear the threshold by a margin
(:data:`~hybobs_opt.tolerances.EXACT_DECISION_MARGIN`); inside that band the float values no
longer say on which side the optimum lies, and the LP is re-decided here on its data as posed,
each float read as the rational number it is (``float.as_integer_ratio``).

The method is the textbook one for an LP ``min c'v s.t. A v <= b`` with ``d`` variables: a vertex
is ``d`` linearly independent tight rows (a basis); it is optimal when it satisfies every row and
the multipliers ``y_B`` of ``A_B' y_B = -c`` are non-negative (then ``c'v`` is the optimum by
weak duality: both are checked exactly).  The first basis is taken from a floating-point solution
(the rows the solver's multipliers hold first, then the others by increasing slack); when its multipliers are not all non-negative, primal simplex
pivots with Bland's rule (smallest row index first: no cycling) move to a better vertex; when it
violates rows (rounding put the float point a hair outside), dual simplex pivots, Bland's rule
too, repair it.  A first basis that is neither gets a phase 1: dual simplex on an artificial
cost for which it is dual feasible, until a feasible vertex is reached.  When the pivots run
out or the LP is infeasible or unbounded, the answer is ``None`` and the caller takes the safe
side of its decision.  Every row is scaled by a power of two to integers (the same inequality),
and each basis is solved by fraction-free (Bareiss) elimination: ``d`` x ``d`` integer solves and
one exact pass over the rows per pivot, about a millisecond for the pair sets of Algorithm 3.1
(``d <= 20``, a few hundred rows).
"""

from __future__ import annotations

from dataclasses import dataclass
import math
from fractions import Fraction

import numpy as np

from ..defaults import EXACT_LP_MAX_PIVOTS


@dataclass
class ExactCounters:
    """Decisions re-decided in rational arithmetic, and those it could not settle (safe side taken)."""

    decided: int = 0
    undecided: int = 0

    def reset(self) -> None:
        self.decided = 0
        self.undecided = 0


#: Process-wide counters (each worker process has its own).
EXACT = ExactCounters()


def _integer_rows(A: np.ndarray, b: np.ndarray) -> tuple[list[list[int]], list[int]]:
    """Each row ``A_i v <= b_i`` times the power of two that makes it integer (the same inequality, exactly)."""
    rows, rhs = [], []
    for a_row, b_i in zip(A, b):
        ratios = [float(x).as_integer_ratio() for x in a_row] + [float(b_i).as_integer_ratio()]
        den = max(q for _, q in ratios)  # powers of two: the largest is a multiple of the others
        ints = [p * (den // q) for p, q in ratios]
        rows.append(ints[:-1])
        rhs.append(ints[-1])
    return rows, rhs


def _solve_int(M: list[list[int]], r: list[int]) -> tuple[list[int], int] | None:
    """``M x = r`` over the rationals for an integer square ``M``: ``(p, q)`` with ``x = p / q``, ``q > 0``.

    Fraction-free Gaussian elimination (Bareiss): every intermediate stays an integer; ``None`` if singular.
    """
    n = len(M)
    if n == 0:
        return [], 1
    aug = [row[:] + [r[i]] for i, row in enumerate(M)]
    prev = 1
    for col in range(n):
        piv = next((i for i in range(col, n) if aug[i][col] != 0), None)
        if piv is None:
            return None
        aug[col], aug[piv] = aug[piv], aug[col]
        pc = aug[col]
        p = pc[col]
        for i in range(col + 1, n):
            ri = aug[i]
            f = ri[col]
            for j in range(col + 1, n + 1):
                ri[j] = (ri[j] * p - f * pc[j]) // prev
            ri[col] = 0
        prev = p
    det = aug[n - 1][n - 1]
    # back substitution with the common denominator det: x_i = num_i / det, num_i integers
    num = [0] * n
    for i in range(n - 1, -1, -1):
        acc = aug[i][n] * det
        for j in range(i + 1, n):
            acc -= aug[i][j] * num[j]
        num[i] = acc // aug[i][i]
    if det < 0:
        num, det = [-x for x in num], -det
    return num, det


def _dot_int(a: list[int], b: list[int]) -> int:
    return sum(x * y for x, y in zip(a, b))


def _independent_rows(A: list[list[int]], order, d: int) -> list[int] | None:
    """The first ``d`` rows in ``order`` that are linearly independent (exact), or ``None``.

    Fraction-free elimination: a row is reduced against the echelon rows by integer
    combinations (each divided by the gcd of its entries), which keeps its span membership exact.
    """
    echelon: list[tuple[int, list[int]]] = []  # (pivot column, row reduced)
    chosen = []
    for i in order:
        v = list(A[i])
        for col, row in echelon:
            f = v[col]
            if f:
                p = row[col]
                v = [a * p - f * b for a, b in zip(v, row)]
                g = math.gcd(*v)
                if g > 1:
                    v = [a // g for a in v]
        col = next((j for j, a in enumerate(v) if a), None)
        if col is None:
            continue
        echelon.append((col, v))
        chosen.append(int(i))
        if len(chosen) == d:
            return chosen
    return None


def _rows_above(Af: np.ndarray, absA: np.ndarray, bf: np.ndarray, Ai: list[list[int]], bi: list[int], v: list[int], q: int,
                skip: set) -> list[int]:
    """The rows ``i`` not in ``skip`` with ``A_i v / q > b_i`` (exact), in increasing order.

    ``Ai``, ``bi`` are ``Af``, ``bf`` scaled row by row by powers of two (:func:`_integer_rows`),
    ``v`` integers, ``q > 0``.

    A floating-point pass decides every row whose value clears ``b_i`` by more than a rigorous
    bound on its rounding (the point ``v / q`` correctly rounded, then a dot product of ``d``
    terms: at most ``(d + 2) u sum |A_ij| |x_j|``, taken four times over, plus an absolute term
    for underflow); only the rows inside that bound are compared in integers.
    """
    k, d = Af.shape
    try:
        x = np.array([p / q for p in v], dtype=float)  # int / int: correctly rounded
    except OverflowError:
        x = None
    if x is None or not np.all(np.isfinite(x)):
        return [i for i in range(k) if i not in skip and _dot_int(Ai[i], v) > bi[i] * q]
    with np.errstate(over="ignore", invalid="ignore"):
        val = Af @ x - bf
        err = 4.0 * (d + 2) * _U * (absA @ np.abs(x)) + (d + 1) * _TINY * (1.0 + absA.sum(axis=1))
    certain = val > err
    unsure = ~certain & ~(val < -err)
    out = []
    for i in np.nonzero(certain | unsure)[0]:
        i = int(i)
        if i in skip:
            continue
        if certain[i] or _dot_int(Ai[i], v) > bi[i] * q:
            out.append(i)
    return out


_U = float(np.finfo(float).eps) / 2.0
_TINY = 2.0 ** -1000


def exact_lp_optimum(c, A, b, hint, duals=None) -> Fraction | None:
    """The exact optimum of ``min c'v s.t. A v <= b`` (float data read exactly), or ``None``.

    Parameters
    ----------
    c : (d,) array
        Cost.
    A : (k, d) array
        Rows; the LP must have a vertex optimum (``A`` of rank ``d``, a bounded optimum).
    b : (k,) array
        Right-hand side.
    hint : (d,) array
        A floating-point solution: its tightest rows make the first basis.
    duals : (k,) array, optional
        The solver's multipliers of the rows: rows with positive multipliers are taken first (the
        first basis is then dual feasible as a rule, and dual simplex pivots repair the rows it
        violates by rounding).

    Returns
    -------
    Fraction or None
        The optimal value, proven by an exactly feasible vertex and exactly non-negative
        multipliers; ``None`` when the rows have rank below ``d``, the first basis is neither
        primal nor dual feasible, the LP is infeasible or unbounded along the pivots, or more than
        :data:`~hybobs_opt.defaults.EXACT_LP_MAX_PIVOTS` pivots are needed.
    """
    from ._reproducible import matmul

    A = np.ascontiguousarray(A, dtype=float)
    b = np.ascontiguousarray(b, dtype=float)
    c = np.ascontiguousarray(c, dtype=float)
    k, d = A.shape
    if not (np.all(np.isfinite(A)) and np.all(np.isfinite(b)) and np.all(np.isfinite(c))):
        return None
    slack = b - matmul(A, np.asarray(hint, dtype=float))
    key = np.where(np.isfinite(slack), slack, np.inf)
    if duals is not None and np.shape(duals) == (k,) and np.all(np.isfinite(duals)):
        lam = np.asarray(duals, dtype=float)
        key = np.where(lam > 0.0, -1.0 - lam / (1.0 + float(np.max(lam))), np.abs(key))
    order = np.argsort(key, kind="stable")
    Ai, bi = _integer_rows(A, b)
    cden = max(float(x).as_integer_ratio()[1] for x in c)
    ci = [p * (cden // q) for p, q in (float(x).as_integer_ratio() for x in c)]  # c = ci / cden
    basis = _independent_rows(Ai, order, d)
    absA = np.abs(A)
    zeros, zero_ints = np.zeros(k), [0] * k
    if basis is None:
        return None
    phase_one = None  # the real cost while phase 1 runs on an artificial one
    for _ in range(EXACT_LP_MAX_PIVOTS + 1):
        AB = [Ai[i] for i in basis]
        ABt = [[AB[r][j] for r in range(d)] for j in range(d)]
        sol = _solve_int(AB, [bi[i] for i in basis])
        dual = _solve_int(ABt, [-x for x in ci])  # the multipliers up to a positive factor: their signs count
        if sol is None or dual is None:
            return None
        v, q = sol
        y = dual[0]
        in_basis = set(basis)
        violated = _rows_above(A, absA, b, Ai, bi, v, q, in_basis)
        negative = [r for r in range(d) if y[r] < 0]
        if not violated and not negative and phase_one is None:
            return Fraction(_dot_int(ci, v), q * cden)
        if violated and negative:
            # phase 1: a cost for which this basis is dual feasible (every multiplier 1); dual simplex
            # pivots on it reach a feasible vertex (or prove the LP infeasible), then phase 2 resumes
            if phase_one is not None:
                return None
            phase_one = ci
            ci = [-sum(AB[r][j] for r in range(d)) for j in range(d)]
            continue
        if not violated and phase_one is not None:  # feasible vertex reached: the real cost again
            ci, phase_one = phase_one, None
            continue
        if violated:
            # dual simplex (Bland): the violated row of smallest index enters; the basic row whose
            # multiplier reaches zero first leaves (ties: smallest row index)
            enter = violated[0]
            alpha_sol = _solve_int(ABt, Ai[enter])  # A_enter = sum_r alpha_r A_B[r]
            if alpha_sol is None:
                return None
            alpha = alpha_sol[0]
            best, best_t = None, None
            for r in range(d):
                if alpha[r] > 0:
                    t = Fraction(y[r], alpha[r])  # the positive denominators are common to all r
                    if best_t is None or t < best_t or (t == best_t and basis[r] < basis[best]):
                        best, best_t = r, t
            if best is None:
                return None  # the LP is infeasible
            basis[best] = enter
            continue
        # primal simplex (Bland): the basic row of smallest index with a negative multiplier leaves
        leave = min(negative, key=lambda r: basis[r])
        e = [0] * d
        e[leave] = -1
        step_sol = _solve_int(AB, e)  # move off row `leave`, keep the other basic rows tight
        if step_sol is None:
            return None
        step = step_sol[0]
        best, best_t = None, None
        for i in _rows_above(A, absA, zeros, Ai, zero_ints, step, 1, in_basis):  # the rows with rate > 0
            rate = _dot_int(Ai[i], step)
            t = Fraction(bi[i] * q - _dot_int(Ai[i], v), rate * q)  # up to the common positive factor
            if best_t is None or t < best_t:
                best, best_t = i, t
        if best is None:
            return None  # unbounded along this edge
        basis[leave] = best
    return None


def decide_above(c, A, b, hint, threshold: float, maximise: bool, duals=None) -> bool | None:
    """Is the optimum of ``max c'v`` (``maximise``) or ``min c'v`` over ``{A v <= b}`` above ``threshold``?

    Exact (:func:`exact_lp_optimum`), counted in :data:`EXACT`; ``None`` when it cannot be decided.
    """
    cost = -np.asarray(c, dtype=float) if maximise else np.asarray(c, dtype=float)
    value = exact_lp_optimum(cost, A, b, hint, duals)
    if value is None:
        EXACT.undecided += 1
        return None
    EXACT.decided += 1
    opt = -value if maximise else value
    return opt > Fraction(float(threshold))


__all__ = ["EXACT", "ExactCounters", "decide_above", "exact_lp_optimum"]

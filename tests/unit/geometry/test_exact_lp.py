"""Decisions within rounding of their threshold, re-decided in rational arithmetic.

Oracles share no code with ``hybobs_opt.geometry.exact_lp``: every vertex of a small LP
enumerated and solved with ``fractions`` (Cramer's rule), and boxes whose Chebyshev radius and
widths are known in closed form, evaluated on the floats' exact rational values.
"""

from __future__ import annotations

import itertools
from fractions import Fraction

import numpy as np
import pytest
from scipy.optimize import linprog

from hybobs_opt.geometry.exact_lp import EXACT, decide_above, exact_lp_optimum
from hybobs_opt.geometry.lp import certified_width_below, max_slack
from hybobs_opt.tolerances import CLOSED_SET_TOL, EXACT_DECISION_MARGIN, REGION_SLACK_TOL


def _det(M):
    """Determinant of a small rational matrix by cofactor expansion."""
    if len(M) == 1:
        return M[0][0]
    return sum((-1) ** j * M[0][j] * _det([row[:j] + row[j + 1:] for row in M[1:]]) for j in range(len(M)) if M[0][j])


def _brute_force_optimum(c, A, b):
    """min c'v over {A v <= b} by every vertex (Cramer's rule in rationals); None if no vertex is feasible."""
    d = A.shape[1]
    Af = [[Fraction(float(x)) for x in row] for row in A]
    bf = [Fraction(float(x)) for x in b]
    cf = [Fraction(float(x)) for x in c]
    best = None
    for rows in itertools.combinations(range(A.shape[0]), d):
        M = [Af[i] for i in rows]
        D = _det(M)
        if D == 0:
            continue
        v = []
        for j in range(d):
            Mj = [row[:j] + [bf[i]] + row[j + 1:] for row, i in zip(M, rows)]
            v.append(_det(Mj) / D)
        if all(sum(a * x for a, x in zip(Af[i], v)) <= bf[i] for i in range(A.shape[0])):
            val = sum(a * x for a, x in zip(cf, v))
            best = val if best is None or val < best else best
    return best


@pytest.mark.parametrize("seed", range(25))
def test_exact_optimum_equals_the_vertex_enumeration(seed):
    rng = np.random.default_rng(seed)
    d = int(rng.integers(2, 4))
    A = np.vstack([np.eye(d), -np.eye(d), rng.normal(size=(int(rng.integers(1, 5)), d))])
    b = np.concatenate([np.ones(2 * d), rng.uniform(0.05, 1.5, size=A.shape[0] - 2 * d)])
    c = rng.normal(size=d)
    hint = linprog(c, A_ub=A, b_ub=b, bounds=(None, None), method="highs").x
    if seed % 3 == 0:
        hint = hint + 1e-7 * rng.normal(size=d)  # an inexact hint: the same vertex or a pivot away
    got = exact_lp_optimum(c, A, b, hint)
    want = _brute_force_optimum(c, A, b)
    assert got is not None and got == want


def test_exact_optimum_pivots_from_a_worse_vertex():
    """A hint at a feasible but not optimal vertex: Bland's pivots reach the optimum."""
    A = np.array([[1.0, 0.0], [0.0, 1.0], [-1.0, 0.0], [0.0, -1.0], [1.0, 1.0]])
    b = np.array([1.0, 1.0, 1.0, 1.0, 1.5])
    c = np.array([-1.0, -2.0])  # max x + 2y: the vertex (0.5, 1)
    assert exact_lp_optimum(c, A, b, np.array([-1.0, -1.0])) == Fraction(-5, 2)


def test_an_infeasible_start_or_an_unbounded_lp_is_not_decided():
    A = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert exact_lp_optimum(np.array([1.0, 0.0]), A, np.array([1.0, 1.0]), np.zeros(2)) is None  # unbounded below
    A = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    b = np.array([-1.0, -1.0, 1.0, 1.0])  # x <= -1 and x >= 1: empty
    assert exact_lp_optimum(np.array([0.0, 1.0]), A, b, np.zeros(2)) is None


def _slab_across(threshold_radius: float, steps: int):
    """Upper bounds u of the slab {l <= x <= u} x [-1, 1]: (u - l) / 2 walks across ``threshold_radius``."""
    lo = 0.25
    u0 = lo + 2.0 * threshold_radius
    us = [u0]
    for _ in range(steps):
        us.append(float(np.nextafter(us[-1], np.inf)))
        us.insert(0, float(np.nextafter(us[0], -np.inf)))
    return lo, us


def test_emptiness_at_the_closed_set_tolerance_is_decided_exactly():
    """Chebyshev radii within a few units of rounding of -CLOSED_SET_TOL, on both sides: the answer is
    the exact one ((u - l) / 2 on the floats' rational values), whatever the LP solver's rounding."""
    theta = -CLOSED_SET_TOL
    lo, us = _slab_across(theta, 6)
    EXACT.reset()
    sides = set()
    for u in us:
        G = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
        g = np.array([u, -lo, 1.0, 1.0])
        res = max_slack(G, g, radius_bound=2.0, threshold=theta, problem="slab")
        exact_radius = (Fraction(u) - Fraction(lo)) / 2
        above = exact_radius > Fraction(theta)
        sides.add(above)
        assert (res.lower > theta) == above, (u, float(exact_radius - Fraction(theta)))
    assert sides == {True, False}
    assert EXACT.decided >= len(us) - 2 and EXACT.undecided == 0


def _slab_rows(ub: float, lo: float):
    return np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]), np.array([ub, -lo, 1.0, 1.0])


def test_width_at_twice_the_region_tolerance_is_decided_exactly(monkeypatch):
    """Slab widths within rounding of 2 REGION_SLACK_TOL.  The exact width test gives the closed form
    (u - l on the floats' rational values) on both sides; certified_width_below hands it every
    certificate that lands within EXACT_DECISION_MARGIN of the width, and decides the others in floats."""
    from hybobs_opt.geometry import lp as lp_module

    width = 2.0 * REGION_SLACK_TOL
    lo = 0.125
    us = [lo + width]
    for _ in range(5):
        us.append(float(np.nextafter(us[-1], np.inf)))
        us.insert(0, float(np.nextafter(us[0], -np.inf)))
    c = np.array([1.0, 0.0])
    sides = set()
    for ub in us:
        A, b = _slab_rows(ub, lo)
        exact = Fraction(ub) - Fraction(lo) <= Fraction(width)
        sides.add(exact)
        points = [(np.array([ub, 0.0]), np.array([1.0, 0.0, 0.0, 0.0])), (np.array([lo, 0.0]), np.array([0.0, 1.0, 0.0, 0.0]))]
        assert lp_module._exact_width_below(A, b, c, points, width) == exact, ub
        # a certificate within the margin (the bound's own rounding could decide): the exact answer
        monkeypatch.setattr(lp_module, "support_upper_bound", lambda *args: width / 2)  # the two bounds add to width
        assert certified_width_below(A, b, c, radius_bound=2.0, width=width) == exact
        monkeypatch.undo()
    assert sides == {True, False}
    A, b = _slab_rows(lo + 0.5 * width, lo)
    assert certified_width_below(A, b, c, radius_bound=2.0, width=width)  # clear of the margin: floats


def test_decisions_clear_of_the_margin_need_no_exact_solve():
    EXACT.reset()
    G = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    res = max_slack(G, np.array([0.5, 0.5, 1.0, 1.0]), radius_bound=2.0, threshold=-CLOSED_SET_TOL, problem="box")
    assert res.lower > -CLOSED_SET_TOL + EXACT_DECISION_MARGIN and EXACT.decided == EXACT.undecided == 0


def test_decide_above_counts_what_it_cannot_settle():
    EXACT.reset()
    A = np.array([[1.0, 0.0], [0.0, 1.0]])
    assert decide_above(np.array([1.0, 0.0]), A, np.array([1.0, 1.0]), np.zeros(2), 0.0, maximise=False) is None  # unbounded
    assert EXACT.undecided == 1
    box = np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]])
    assert decide_above(np.array([1.0, 1.0]), box, np.ones(4), np.ones(2), 2.0, maximise=True) is False  # max is 2
    assert decide_above(np.array([1.0, 1.0]), box, np.ones(4), np.ones(2), float(np.nextafter(2.0, 0.0)), maximise=True)
    assert EXACT.decided == 2


def test_float_screen_of_the_row_tests_agrees_with_fractions_at_and_near_ties():
    """The floating-point pass that spares most exact row tests decides every row as Fractions do:
    rows exactly tight, one ulp either side, huge and tiny entries, a point not representable."""
    from hybobs_opt.geometry.exact_lp import _integer_rows, _rows_above

    rng = np.random.default_rng(7)
    for trial in range(40):
        d = int(rng.integers(1, 8))
        A = rng.standard_normal((30, d)) * 10.0 ** rng.integers(-200, 200, size=(30, 1)) if trial % 4 == 0 else rng.standard_normal((30, d))
        p = [int(x) for x in rng.integers(-10**15, 10**15, size=d)]
        q = int(rng.integers(1, 10**12)) * (3 if trial % 2 else 1)
        x = [Fraction(pi, q) for pi in p]
        exact_vals = [sum(Fraction(float(a)) * xi for a, xi in zip(row, x)) for row in A]
        b = np.array([float(v) for v in exact_vals])  # the nearest float: exactly tight or one rounding off
        b[::3] = np.nextafter(b[::3], np.inf)
        b[1::3] = np.nextafter(b[1::3], -np.inf)
        b[2::5] -= np.abs(b[2::5]) + 1.0  # clearly below / above: decided by the float pass
        b[4::5] += np.abs(b[4::5]) + 1.0
        Ai, bi = _integer_rows(A, b)
        skip = {0, 5}
        got = _rows_above(A, np.abs(A), b, Ai, bi, p, q, skip)
        want = [i for i in range(A.shape[0]) if i not in skip and exact_vals[i] > Fraction(float(b[i]))]
        assert got == want

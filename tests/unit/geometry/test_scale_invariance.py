"""Issue 16: the polytope operations do not depend on the units of the data.

``{A z <= b}`` and ``{s A z <= s b}`` are the same set for any ``s > 0`` (and each row may carry
its own ``s``); a state measured in other units (``z' = S z``) maps the set by ``S``.  Before the
LP layer equilibrated its problems, HiGHS saw coefficients of 1e-9 as zeros (its small-value
threshold) and called the square ``|x| <= 1, |y| <= 2`` unbounded when written in units of 1e-9.
"""

import numpy as np
import pytest

from hybobs_opt.geometry.lp import solve_lp
from hybobs_opt.systems import Polytope

I2 = np.eye(2)
SQUARE_A = np.vstack([I2, -I2])  # x <= 1, y <= 2, -x <= 1, -y <= 2
SQUARE_B = np.array([1.0, 2.0, 1.0, 2.0])
SQUARE_LO, SQUARE_HI = np.array([-1.0, -2.0]), np.array([1.0, 2.0])

# a triangle-ish polytope with a slanted row: x + y <= 1, -x + y <= 1, -y <= 0, x - 2y <= 1
POLY_A = np.array([[1.0, 1.0], [-1.0, 1.0], [0.0, -1.0], [1.0, -2.0]])
POLY_B = np.array([1.0, 1.0, 0.0, 1.0])

SCALES = [1e-12, 1e-9, 1e-6, 1.0, 1e6, 1e9, 1e12]


@pytest.mark.parametrize("s", SCALES, ids=lambda s: f"{s:g}")
def test_bounding_box_of_a_uniformly_scaled_square(s):
    lo, hi = Polytope(SQUARE_A * s, SQUARE_B * s).bounding_box()
    np.testing.assert_allclose(lo, SQUARE_LO, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(hi, SQUARE_HI, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("seed", range(4))
def test_bounding_box_with_mixed_row_scalings(seed):
    rng = np.random.default_rng(seed)
    s = 10.0 ** rng.uniform(-11, 11, POLY_A.shape[0])
    s[rng.integers(0, s.size)] = 1e-10  # at least one row far below HiGHS's 1e-9 threshold
    ref_lo, ref_hi = Polytope(POLY_A, POLY_B).bounding_box()
    lo, hi = Polytope(POLY_A * s[:, None], POLY_B * s).bounding_box()
    np.testing.assert_allclose(lo, ref_lo, atol=1e-8)
    np.testing.assert_allclose(hi, ref_hi, atol=1e-8)


@pytest.mark.parametrize("units", [(1e6, 1.0), (1e-6, 1.0), (1e6, 1e-6), (1e9, 1e9)], ids=str)
def test_bounding_box_in_other_units(units):
    """``z' = S z``: the box is mapped by ``S`` (columns scaled, the rows' mixture of units kept)."""
    S = np.array(units)
    lo, hi = Polytope(POLY_A / S[None, :], POLY_B).bounding_box()
    ref_lo, ref_hi = Polytope(POLY_A, POLY_B).bounding_box()
    np.testing.assert_allclose(lo / S, ref_lo, atol=1e-8)
    np.testing.assert_allclose(hi / S, ref_hi, atol=1e-8)


@pytest.mark.parametrize("s", SCALES, ids=lambda s: f"{s:g}")
def test_emptiness_and_chebyshev_ball_scaled(s):
    # x <= 1 and -x <= -1.5 (x >= 1.5): empty, at every scale; the square is not
    empty = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]) * s, np.array([1.0, -1.5, 1.0, 1.0]) * s)
    assert empty.is_empty()
    square = Polytope(SQUARE_A * s, SQUARE_B * s)
    assert not square.is_empty()
    centre, radius = square.chebyshev_ball()
    assert radius == pytest.approx(1.0, rel=1e-7)
    assert abs(centre[0]) <= 1e-7 and abs(centre[1]) <= 1.0 + 1e-7


@pytest.mark.parametrize("s", [1e-12, 1e-10, "mixed"], ids=str)
def test_projection_scaled(s):
    """Proj_x of a 3-d polytope: the same interval whatever the scale of the rows."""
    A = np.array([[1.0, 1.0, 0.0], [-1.0, 1.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0], [1.0, 0.0, 1.0]])
    b = np.array([1.0, 1.0, 0.0, 1.0, 1.0, 1.5])
    r = np.array([1e-10, 1e10, 1e-11, 1.0, 1e-10, 1e9]) if s == "mixed" else np.full(b.size, s)
    ref = Polytope(A, b).project([0])
    got = Polytope(A * r[:, None], b * r).project([0])
    np.testing.assert_allclose(np.array(got.bounding_box()), np.array(ref.bounding_box()), atol=1e-8)
    np.testing.assert_allclose(np.array(ref.bounding_box()), [[-1.0], [1.0]], atol=1e-8)


@pytest.mark.parametrize("s", [1e-9, 1e9], ids=lambda s: f"{s:g}")
def test_solve_lp_objective_and_point_scaled(s):
    """min x + 2y over the shifted triangle: the scaled LP has the same optimum (the value in units of c)."""
    A = np.array([[-1.0, 0.0], [0.0, -1.0], [1.0, 1.0]])
    b = np.array([1.0, 2.0, 3.0])
    res = solve_lp(np.array([1.0, 2.0]) * s, A * s, b * s)
    np.testing.assert_allclose(res.x, [-1.0, -2.0], atol=1e-9)
    assert res.objective == pytest.approx(-5.0 * s, rel=1e-9)
    infeasible = solve_lp(np.zeros(2), np.array([[1.0, 0.0], [-1.0, 0.0]]) * s, np.array([-1.0, -1.0]) * s)
    assert str(infeasible.status) == "infeasible" and infeasible.certificate.verify()


@pytest.mark.parametrize("s", [1e-12, 1e-10, 1e10], ids=lambda s: f"{s:g}")
def test_remove_redundant_scaled(s):
    """A redundant row (x + y <= 10 inside the square) is dropped and the facets kept, at every scale."""
    A = np.vstack([SQUARE_A, [[1.0, 1.0]]])
    b = np.concatenate([SQUARE_B, [10.0]])
    red = Polytope(A * s, b * s).remove_redundant()
    assert red.n_constraints == 4
    lo, hi = red.bounding_box()
    np.testing.assert_allclose(lo, SQUARE_LO, atol=1e-9)
    np.testing.assert_allclose(hi, SQUARE_HI, atol=1e-9)

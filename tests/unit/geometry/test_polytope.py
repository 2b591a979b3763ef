"""The foundation's polytope: membership, boxes, Chebyshev balls, validation."""

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.systems import Polytope


def test_box_membership_vectorised():
    box = Polytope.from_box([-1, 0], [1, 2], ("a", "b"))
    pts = np.array([[0, 1], [1.5, 1], [-1, 0], [0, 2.1]])
    assert box.contains(pts).tolist() == [True, False, True, False]
    assert box.contains(np.array([0.5, 0.5])) is True


def test_bounding_box_of_triangle():
    # x >= 0, y >= 0, x + y <= 3
    tri = Polytope(np.array([[-1, 0], [0, -1], [1, 1]]), np.array([0, 0, 3]))
    lo, hi = tri.bounding_box()
    np.testing.assert_allclose(lo, [0, 0], atol=1e-9)
    np.testing.assert_allclose(hi, [3, 3], atol=1e-9)


def test_chebyshev_ball_of_square():
    sq = Polytope.from_box([0, 0], [2, 2])
    centre, radius = sq.chebyshev_ball()
    np.testing.assert_allclose(centre, [1, 1], atol=1e-7)
    assert radius == pytest.approx(1.0, abs=1e-9)


def test_full_dimension_relative_to_scale():
    thin = Polytope.from_box([0, 0], [1e-3, 1000])  # thin but genuinely 2-D
    flat = Polytope(np.array([[1, 0], [-1, 0], [0, 1], [0, -1]]), np.array([0, 0, 1, 1]))  # x = 0
    assert thin.is_full_dimensional()
    assert not flat.is_full_dimensional()
    assert not flat.is_empty()


def test_empty_and_unbounded_detected():
    empty = Polytope(np.array([[1.0], [-1.0]]), np.array([-1.0, 0.0]))  # x <= -1 and x >= 0
    assert empty.is_empty()
    half = Polytope(np.array([[1.0, 0.0]]), np.array([1.0]))
    assert not half.is_bounded()
    with pytest.raises(ModelError, match="bounded"):
        half.bounding_box()


@pytest.mark.parametrize(
    "A, b, field",
    [
        (np.ones((2, 2)), np.ones(3), "Polytope.b"),
        ([[1.0, np.nan]], [1.0], "Polytope.A"),
        ([[1.0, 0.0]], [np.inf], "Polytope.b"),
        (np.ones((2, 2, 2)), np.ones(2), "Polytope.A"),
    ],
)
def test_bad_input_names_field(A, b, field):
    with pytest.raises(ModelError, match=field.replace(".", r"\.")):
        Polytope(A, b)


def test_box_with_reversed_bounds_names_coordinate():
    with pytest.raises(ModelError, match="omega"):
        Polytope.from_box([0, 5], [1, 4], ("theta", "omega"))

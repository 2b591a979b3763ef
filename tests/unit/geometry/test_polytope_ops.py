"""Polytope geometry for paper 002 (Sections 2-3): projection, redundancy, cuts, unions, volumes.

Every check compares against an independent fact: an analytic shape, a direct LP feasibility
test written here with scipy's ``linprog`` (not the toolbox's LP layer), Monte Carlo samples of
the high-dimensional set, or a volume computed by hand.
"""

from __future__ import annotations

import itertools
import json
import math

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pytest
from matplotlib.figure import Figure
from scipy.optimize import linprog

from hybobs_opt.errors import ModelError
from hybobs_opt.geometry import projection as projection_mod
from hybobs_opt.regions.union import PolytopeUnion
from hybobs_opt.systems import Polytope

# Points closer than this (relative to the set's size) to a boundary are not compared: the
# projection is exact to PROJECTION_HULL_RTOL = 1e-6 there, and membership ties are arbitrary.
BOUNDARY_MARGIN = 1e-5


# ---------------------------------------------------------------------- independent oracles
def in_projection(A, b, coords, p, E=None, e=None) -> bool:
    """Is there ``z`` with ``A z <= b``, ``E z = e`` and ``z[coords] = p``?  (plain linprog)"""
    d = A.shape[1]
    S = np.eye(d)[list(coords)]
    A_eq = S if E is None else np.vstack([S, E])
    b_eq = np.asarray(p, float) if E is None else np.concatenate([p, e])
    res = linprog(np.zeros(d), A_ub=A, b_ub=b, A_eq=A_eq, b_eq=b_eq, bounds=(None, None), method="highs")
    assert res.status in (0, 2), res.message
    return res.status == 0


def margin(P: Polytope, X: np.ndarray) -> np.ndarray:
    """Smallest normalised slack of the rows of ``P`` at each point (negative outside)."""
    n = np.linalg.norm(P.A, axis=1)
    return np.min((P.b[None, :] - X @ P.A.T) / n[None, :], axis=1)


def assert_same_points(V, W, atol=1e-6):
    V, W = np.asarray(V, float), np.asarray(W, float)
    assert V.shape == W.shape, f"{V.shape} != {W.shape}:\n{V}\n{W}"
    for w in W:
        assert np.min(np.linalg.norm(V - w, axis=1)) < atol, f"{w} not among\n{V}"


def random_polytope(rng, d, m, half_width=2.0):
    """``m`` random unit rows with offsets in [0.5, 1.5] (ball of radius 0.5 inside), in a box."""
    A = rng.normal(size=(m, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = rng.uniform(0.5, 1.5, m)
    box = Polytope.from_box(-half_width * np.ones(d), half_width * np.ones(d))
    return Polytope(np.vstack([A, box.A]), np.concatenate([b, box.b]))


def grid(lo, hi, n):
    axes = [np.linspace(lo[i], hi[i], n) for i in range(len(lo))]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, len(lo))


def cross_polytope(d, scale=None):
    A = np.array(list(itertools.product([1.0, -1.0], repeat=d)))
    if scale is not None:
        A = A / np.asarray(scale)[None, :]
    return Polytope(A, np.ones(len(A)))


def unit_simplex(d):
    return Polytope(np.vstack([-np.eye(d), np.ones((1, d))]), np.concatenate([np.zeros(d), [1.0]]))


# ---------------------------------------------------------------------- projections of known shapes
@pytest.mark.parametrize("method", ["hull", "fm"])
def test_projection_of_box_is_rectangle_with_names_in_requested_order(method):
    box = Polytope.from_box([0, 2, -1], [1, 4, 1], ("a", "b", "c"))
    Q = box.project(["c", "a"], method=method)
    assert Q.names == ("c", "a")
    assert_same_points(Q.vertices(), [[-1, 0], [1, 0], [1, 1], [-1, 1]])


@pytest.mark.parametrize("method", ["hull", "fm"])
def test_projection_of_simplex_is_triangle_on_a_grid(method):
    Q = unit_simplex(3).project([0, 1], method=method)
    X = grid([-0.2, -0.2], [1.2, 1.2], 57)
    x, y = X[:, 0], X[:, 1]
    analytic = (x >= 0) & (y >= 0) & (x + y <= 1)
    far = np.minimum(np.minimum(np.abs(x), np.abs(y)), np.abs(x + y - 1) / math.sqrt(2)) > BOUNDARY_MARGIN
    assert far.sum() > 3000
    np.testing.assert_array_equal(Q.contains(X[far]), analytic[far])
    assert_same_points(Q.vertices(), [[0, 0], [1, 0], [0, 1]])


@pytest.mark.parametrize("method", ["hull", "fm"])
def test_projection_of_badly_scaled_cross_polytope_is_a_diamond(method):
    # {sum |z_i / s_i| <= 1} with scales spanning six decades: the projection onto (z1, z3) is
    # the diamond with vertices (+-s1, 0), (0, +-s3) -- exact only if the scaling is relative.
    s = np.array([1e-3, 1.0, 1e3])
    Q = cross_polytope(3, s).project([0, 2], method=method)
    V = Q.vertices()
    assert_same_points(V / s[[0, 2]], [[1, 0], [-1, 0], [0, 1], [0, -1]], atol=1e-6)
    X = grid([-1.2, -1.2], [1.2, 1.2], 41) * s[[0, 2]]
    inside = np.abs(X[:, 0] / s[0]) + np.abs(X[:, 1] / s[2]) <= 1
    far = np.abs(np.abs(X[:, 0] / s[0]) + np.abs(X[:, 1] / s[2]) - 1) > BOUNDARY_MARGIN
    np.testing.assert_array_equal(Q.contains(X[far]), inside[far])


def test_one_dimensional_projection_is_an_interval():
    Q = cross_polytope(3).project([2])
    assert Q.contains(np.array([[-0.999], [0.999], [1.001], [-1.001]])).tolist() == [True, True, False, False]
    assert Q.volume().value == pytest.approx(2.0, abs=1e-9)


# ---------------------------------------------------------------------- random polytopes
def test_projection_of_random_polytope_agrees_with_samples_and_lp_feasibility():
    rng = np.random.default_rng(7)
    P = random_polytope(rng, 5, 16)
    coords = [1, 3]
    Q = P.project(coords)
    # (1) projections of points sampled inside P lie inside Q
    lo, hi = P.bounding_box()
    Z = rng.uniform(lo, hi, size=(200_000, 5))
    Z = Z[P.contains(Z)]
    assert len(Z) > 200
    assert np.all(Q.contains(Z[:, coords]))
    # (2) random 2-D points: Q's membership equals LP feasibility of the fibre
    qlo, qhi = Q.bounding_box()
    pad = 0.2 * (qhi - qlo)
    X = rng.uniform(qlo - pad, qhi + pad, size=(150, 2))
    X = X[np.abs(margin(Q, X)) > BOUNDARY_MARGIN * np.max(qhi - qlo)]
    lp = np.array([in_projection(P.A, P.b, coords, x) for x in X])
    assert 20 < lp.sum() < len(X) - 20
    np.testing.assert_array_equal(Q.contains(X), lp)


def test_fourier_motzkin_and_hull_agree_4d_to_3d():
    rng = np.random.default_rng(11)
    P = random_polytope(rng, 4, 14)
    Qh = P.project([0, 1, 3], method="hull")
    Qf = P.project([0, 1, 3], method="fm")
    assert_same_points(Qh.vertices(), Qf.vertices(), atol=1e-5)
    X = rng.uniform(-2.2, 2.2, size=(4000, 3))
    far = (np.abs(margin(Qh, X)) > BOUNDARY_MARGIN) & (np.abs(margin(Qf, X)) > BOUNDARY_MARGIN)
    np.testing.assert_array_equal(Qh.contains(X[far]), Qf.contains(X[far]))
    for x in X[far][:40]:
        assert Qh.contains(x) == in_projection(P.A, P.b, [0, 1, 3], x)


def test_projection_with_equalities_9d_to_3d():
    """The shape of paper 002's R_ij: 9-D, ~30 rows, 3 equalities (Y(x,U) = Y(x^,U)), onto x."""
    rng = np.random.default_rng(3)
    P = random_polytope(rng, 9, 12)  # 12 random rows + 18 box rows = 30
    E = rng.normal(size=(3, 9))
    e = 0.1 * rng.normal(size=3)
    Q = P.project_with_equalities(E, e, [0, 1, 2])
    assert Q.is_full_dimensional()
    # Points of the 9-D set (convex combinations of LP vertices) project inside Q.
    verts = []
    for _ in range(30):
        res = linprog(rng.normal(size=9), A_ub=P.A, b_ub=P.b, A_eq=E, b_eq=e, bounds=(None, None), method="highs")
        verts.append(res.x)
    W = rng.dirichlet(np.ones(len(verts)), size=500) @ np.array(verts)
    assert np.all(Q.contains(W[:, :3], rtol=1e-7))
    lo, hi = Q.bounding_box()
    X = rng.uniform(lo - 0.2 * (hi - lo), hi + 0.2 * (hi - lo), size=(120, 3))
    X = X[np.abs(margin(Q, X)) > BOUNDARY_MARGIN * np.max(hi - lo)]
    lp = np.array([in_projection(P.A, P.b, [0, 1, 2], x, E, e) for x in X])
    assert 10 < lp.sum() < len(X) - 10
    np.testing.assert_array_equal(Q.contains(X), lp)


def test_hull_dimension_threshold_switches_to_fourier_motzkin(monkeypatch):
    calls = []
    real = projection_mod._fm_image

    def spy(*args):
        calls.append(1)
        return real(*args)

    monkeypatch.setattr(projection_mod, "_fm_image", spy)
    P = cross_polytope(3)
    P.project([0, 1])
    assert not calls
    monkeypatch.setattr(projection_mod, "HULL_PROJECTION_MAX_DIM", 1)
    Q = P.project([0, 1])
    assert calls
    assert_same_points(Q.vertices(), [[1, 0], [-1, 0], [0, 1], [0, -1]])


def test_lower_dimensional_projection_is_returned_with_its_equalities():
    # the segment {z1 = z2, 0 <= z1 <= 1} x [0, 1], written with paired inequalities
    A = np.array([[1, -1, 0], [-1, 1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]], float)
    P = Polytope(A, [0, 0, 1, 0, 1, 0])
    for Q in (P.project([0, 1]), Polytope.from_box([0, 0, 0], [1, 1, 1]).project_with_equalities([[1, -1, 0]], [0], [0, 1])):
        assert Q.contains(np.array([[0.5, 0.5], [0.0, 0.0], [0.5, 0.6], [1.1, 1.1]])).tolist() == [True, True, False, False]
        assert_same_points(Q.vertices(), [[0, 0], [1, 1]])
        assert not Q.is_full_dimensional()


def test_unbounded_projection_uses_fourier_motzkin_and_hull_refuses():
    P = Polytope(np.array([[1.0, 1.0], [0.0, -1.0]]), np.array([1.0, 0.0]))  # x + y <= 1, y >= 0
    Q = P.project([0])
    assert Q.contains(np.array([[-100.0], [0.99], [1.01]])).tolist() == [True, True, False]
    with pytest.raises(ModelError, match="bounded"):
        P.project([0], method="hull")


def test_empty_polytope_projects_to_empty():
    P = Polytope(np.array([[1.0, 0, 0], [-1.0, 0, 0]]), np.array([-1.0, 0.0]))
    assert P.project([1, 2]).is_empty()
    assert Polytope.from_box([0, 0], [1, 1]).project_with_equalities([[1, 0]], [5.0], [1]).is_empty()
    assert P.vertices().shape == (0, 3)


# ---------------------------------------------------------------------- redundancy removal
def test_remove_redundant_drops_known_rows_and_keeps_the_square():
    sq = Polytope.from_box([0, 0], [1, 1])
    extra = np.array([[1, 0], [1, 1], [1, 0], [3, 0], [1, 1], [-1, -1], [0, 0]], float)
    extra_b = np.array([2, 5, 1, 3, 2, 0, 1], float)  # loose, loose, duplicate, scaled duplicate,
    # weakly redundant through (1,1), weakly redundant through (0,0), zero row
    P = Polytope(np.vstack([extra, sq.A]), np.concatenate([extra_b, sq.b]))
    R = P.remove_redundant()
    assert R.n_constraints == 4
    rows = {tuple(np.round(np.append(a, bb), 9)) for a, bb in zip(R.A, R.b)}
    assert rows == {(1, 0, 1), (0, 1, 1), (-1, 0, 0), (0, -1, 0)}
    X = np.random.default_rng(0).uniform(-0.5, 1.5, size=(5000, 2))
    np.testing.assert_array_equal(R.contains(X), sq.contains(X))


def test_remove_redundant_random_set_each_row_checked_independently():
    rng = np.random.default_rng(5)
    s = np.array([1e-2, 1.0, 1e2, 10.0])  # badly scaled coordinates
    P0 = random_polytope(rng, 4, 40)
    P = Polytope(P0.A / s[None, :], P0.b)  # the same set stretched by s
    R = P.remove_redundant()
    assert 4 < R.n_constraints < P.n_constraints
    X = rng.uniform(-2.2, 2.2, size=(20000, 4)) * s
    np.testing.assert_array_equal(R.contains(X), P.contains(X))
    An, bn = R.A, R.b
    for i in range(R.n_constraints):  # every kept row really cuts the set
        others = np.delete(np.arange(R.n_constraints), i)
        res = linprog(-An[i], A_ub=An[others], b_ub=bn[others], bounds=(None, None), method="highs")
        assert res.status == 3 or -res.fun > bn[i] + 1e-9 * (1 + abs(bn[i]))
    for a, bb in zip(P.A, P.b):  # every original row is implied by the kept ones
        res = linprog(-a, A_ub=An, b_ub=bn, bounds=(None, None), method="highs")
        assert -res.fun <= bb + 1e-6 * (1 + abs(bb))


# ---------------------------------------------------------------------- slices and maps
def test_slice_then_project_9d_matches_lp_feasibility_on_a_grid():
    rng = np.random.default_rng(9)
    P0 = random_polytope(rng, 9, 12)
    names = tuple(f"v{i}" for i in range(9))
    P = Polytope(P0.A, P0.b, names)
    cut = P.slice({"v8": 0.3, 5: -0.2})
    assert cut.names == ("v0", "v1", "v2", "v3", "v4", "v6", "v7")
    Q = cut.project(["v0", "v3"])
    assert Q.names == ("v0", "v3")
    X = grid([-2.1, -2.1], [2.1, 2.1], 15)
    X = X[np.abs(margin(Q, X)) > BOUNDARY_MARGIN * 4]
    # the independent oracle works on the 9-D set with the cut as equalities
    E = np.eye(9)[[8, 5]]
    lp = np.array([in_projection(P.A, P.b, [0, 3], x, E, np.array([0.3, -0.2])) for x in X])
    assert 10 < lp.sum() < len(X) - 10
    np.testing.assert_array_equal(Q.contains(X), lp)


def test_slice_rejects_fixing_everything_and_unknown_names():
    box = Polytope.from_box([0, 0], [1, 1], ("a", "b"))
    with pytest.raises(ModelError, match="free"):
        box.slice({"a": 0.5, "b": 0.5})
    with pytest.raises(ModelError, match="coordinate"):
        box.slice({"c": 0.5})
    with pytest.raises(ModelError, match="distinct"):
        box.project(["a", 0])
    with pytest.raises(ModelError, match="method"):
        box.project(["a"], method="magic")


def test_affine_image_invertible_singular_and_preimage():
    sq = Polytope.from_box([0, 0], [1, 1])
    th = 0.3
    M = np.array([[math.cos(th), -math.sin(th)], [math.sin(th), math.cos(th)]]) * np.array([2.0, 0.5])
    v = np.array([5.0, -1.0])
    img = sq.affine_image(M, v)
    corners = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], float)
    assert_same_points(img.vertices(), corners @ M.T + v)
    # singular maps: a 3-D box onto a rectangle, and onto a segment of the line y = 2x
    box = Polytope.from_box([0, 0, 0], [1, 1, 1])
    rect = box.affine_image(np.array([[1, 1, 0], [0, 0, 1]], float))
    assert_same_points(rect.vertices(), [[0, 0], [2, 0], [2, 1], [0, 1]])
    seg = box.affine_image(np.array([[1, 1, 0], [2, 2, 0]], float), np.array([0.0, 1.0]))
    assert seg.contains(np.array([[1, 3], [1, 3.1], [2.1, 5.2]])).tolist() == [True, False, False]
    assert_same_points(seg.vertices(), [[0, 1], [2, 5]])
    # preimage: w in pre  <=>  M w + v in P
    rng = np.random.default_rng(2)
    Mp = rng.normal(size=(3, 2))
    vp = np.array([0.5, 0.5, 0.5])
    pre = box.affine_preimage(Mp, vp)
    W = rng.uniform(-2, 2, size=(5000, 2))
    np.testing.assert_array_equal(pre.contains(W), box.contains(W @ Mp.T + vp))


def test_chebyshev_ball_inside_the_affine_hull():
    # cube [-1,1]^3 cut by x + y + z = 0: a regular hexagon with inradius sqrt(3/2)
    cube = Polytope.from_box(-np.ones(3), np.ones(3))
    E, e = np.array([[1.0, 1.0, 1.0]]), np.array([0.0])
    centre, r = cube.chebyshev_ball_in_subspace(E, e)
    assert r == pytest.approx(math.sqrt(1.5), rel=1e-7)
    np.testing.assert_allclose(centre, 0, atol=1e-7)
    # the same set with the equality as two inequalities has no inscribed ball at all
    flat = cube.intersect(Polytope(np.vstack([E, -E]), np.concatenate([e, -e])))
    assert flat.chebyshev_ball()[1] == pytest.approx(0.0, abs=1e-9)
    assert cube.chebyshev_ball_in_subspace(np.array([[1.0, 0, 0]]), np.array([3.0]))[1] < 0


# ---------------------------------------------------------------------- vertices and volumes
@pytest.mark.parametrize("d", [1, 2, 3, 4])
def test_exact_volume_of_unit_simplex_and_box(d):
    assert unit_simplex(d).volume().value == pytest.approx(1 / math.factorial(d), rel=1e-9)
    widths = np.array([0.5, 3.0, 2.0, 10.0])[:d]
    box = Polytope.from_box(-widths / 2 + 7, widths / 2 + 7)
    vol = box.volume()
    assert vol.method == "exact" and vol.stderr == 0.0
    assert vol.value == pytest.approx(float(np.prod(widths)), rel=1e-9)
    assert len(box.vertices()) == 2**d


def test_cross_polytope_volume_and_vertices():
    P = cross_polytope(3)
    assert P.volume().value == pytest.approx(4 / 3, rel=1e-9)
    assert_same_points(P.vertices(), np.vstack([np.eye(3), -np.eye(3)]))


def test_two_dimensional_vertices_are_counter_clockwise():
    rng = np.random.default_rng(4)
    V = random_polytope(rng, 2, 9).vertices()
    x, y = V[:, 0], V[:, 1]
    assert 0.5 * (np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1))) > 0


def test_monte_carlo_volume_within_four_standard_errors():
    est = unit_simplex(5).volume(n_samples=400_000, rng=1)
    assert est.method == "monte-carlo" and est.n_samples == 400_000
    assert est.stderr > 0
    assert abs(est.value - 1 / 120) < 4 * est.stderr
    # vertex enumeration (and the exact volume) are no longer limited to d <= 4 (issue 19)
    assert_same_points(unit_simplex(5).vertices(), np.vstack([np.zeros(5), np.eye(5)]))
    assert unit_simplex(5).volume("exact").value == pytest.approx(1 / 120, rel=1e-9)


# ---------------------------------------------------------------------- unions
def two_squares_and_cutters():
    A = PolytopeUnion([Polytope.from_box([0, 0], [2, 2]), Polytope.from_box([1, 1], [3, 3])])
    tri = Polytope(np.array([[-1, 0], [0, -1], [1, 1]], float), np.array([-0.5, -0.5, 3.0]))
    B = PolytopeUnion([tri, Polytope.from_box([2.5, 0], [4, 1.5])])
    return A, B


def test_union_difference_agrees_with_pointwise_membership():
    A, B = two_squares_and_cutters()
    D = A.difference(B)
    X = np.random.default_rng(0).uniform(-0.5, 4.5, size=(30000, 2))
    np.testing.assert_array_equal(D.contains(X), A.contains(X) & ~B.contains(X))
    scale = np.array([3.0, 3.0])
    assert all(p.is_full_dimensional(scale) for p in D)
    # by hand: |A| = 7; B removes 2 - 2 * 0.125 (triangle minus its corners outside A) + 0.25
    assert A.volume().value == pytest.approx(7.0, rel=1e-9)
    assert D.volume().value == pytest.approx(5.0, rel=1e-9)
    # the pieces cut from one polytope have disjoint interiors: their volumes add up
    D1 = PolytopeUnion([A[0]]).difference(B)
    assert sum(p.volume().value for p in D1) == pytest.approx(D1.volume().value, rel=1e-9)
    assert D1.volume().value == pytest.approx(4.0 - 1.75, rel=1e-9)  # [0,2]^2 minus tri n [0,2]^2


def test_union_difference_3d_random_and_lower_dimensional_pieces_dropped():
    rng = np.random.default_rng(12)
    A = PolytopeUnion([random_polytope(rng, 3, 6) for _ in range(2)])
    B = PolytopeUnion([random_polytope(rng, 3, 6, half_width=1.0), Polytope.from_box([-3, -3, 0], [3, 3, 0])])
    D = A.difference(B)
    X = rng.uniform(-2.2, 2.2, size=(20000, 3))
    X = X[np.abs(X[:, 2]) > 1e-6]  # the flat piece of B is measure zero: ignored by design
    np.testing.assert_array_equal(D.contains(X), A.contains(X) & ~B.contains(X))
    assert all(p.is_full_dimensional() for p in D)
    assert PolytopeUnion([Polytope.from_box([0, 0, 0], [1, 1, 1])]).difference(
        PolytopeUnion([Polytope.from_box([-1, -1, -1], [2, 2, 2])])
    ).is_empty()


def test_union_queries_cuts_and_json_round_trip():
    names = ("theta", "omega_m", "omega_l")
    U = PolytopeUnion(
        [Polytope.from_box([0, 0, 0], [1, 1, 1], names), Polytope.from_box([2, 0, 0.5], [3, 2, 2], names)]
    )
    assert U.names == names and len(U) == 2
    assert U.contains(np.array([[0.5, 0.5, 0.5], [2.5, 1.5, 1.5], [1.5, 0.5, 0.5]])).tolist() == [True, True, False]
    lo, hi = U.bounding_box()
    np.testing.assert_allclose(lo, [0, 0, 0], atol=1e-9)
    np.testing.assert_allclose(hi, [3, 2, 2], atol=1e-9)
    cut = U.slice({"omega_l": 1.5})  # only the second box reaches omega_l = 1.5
    assert len(cut) == 1 and cut.names == ("theta", "omega_m")
    proj = U.project(["omega_l"])
    assert proj.contains(np.array([[0.2], [1.8], [2.1]])).tolist() == [True, True, False]
    back = PolytopeUnion.from_dict(json.loads(json.dumps(U.to_dict())))
    X = np.random.default_rng(1).uniform(-0.5, 3.5, size=(2000, 3))
    np.testing.assert_array_equal(back.contains(X), U.contains(X))
    assert back.names == names
    assert PolytopeUnion.from_dict({"dim": 2, "pieces": []}).is_empty()
    with pytest.raises(ModelError, match="pieces"):
        PolytopeUnion.from_dict({"dim": 2})
    with pytest.raises(ModelError, match="dimension"):
        PolytopeUnion([Polytope.from_box([0], [1]), Polytope.from_box([0, 0], [1, 1])])


def test_plot_cut_draws_counter_clockwise_polygons_of_the_cut():
    names = ("theta", "omega_m", "omega_l")
    # a tilted 3-D simplex-like piece and a box; cut at omega_l = 0.25, drawn in (theta, omega_m)
    simplex = Polytope(np.vstack([-np.eye(3), np.ones((1, 3))]), [0, 0, 0, 1], names)
    box = Polytope.from_box([2, 0, 0], [3, 1, 1], names)
    away = Polytope.from_box([5, 5, 0.5], [6, 6, 1], names)  # does not reach omega_l = 0.25
    U = PolytopeUnion([simplex, box, away])
    ax = Figure().subplots()
    patches = U.plot_cut(ax, "theta", "omega_m", fixed={"omega_l": 0.25}, facecolor="red")
    assert len(patches) == 2
    tri = patches[0].get_xy()[:-1]  # matplotlib repeats the first vertex to close the path
    assert_same_points(tri, [[0, 0], [0.75, 0], [0, 0.75]])
    for p in patches:
        V = p.get_xy()[:-1]
        assert 0.5 * (np.dot(V[:, 0], np.roll(V[:, 1], -1)) - np.dot(V[:, 1], np.roll(V[:, 0], -1))) > 0
    assert ax.get_xlabel() == "theta"
    with pytest.raises(ModelError):
        U.plot_cut(ax, "theta", "omega_l", fixed={"omega_l": 0.25})

"""Issue 19: vertex enumeration, V -> H, redundancy removal and volume on pycddlib / qhull, checked.

Every library answer is compared with an oracle written here and independent of
``hybobs_opt.geometry``: brute-force vertex enumeration (every d-subset of rows solved with numpy,
the feasible solutions kept), scipy's ``linprog`` for redundancy and hull membership, Monte Carlo
for volumes; and with the hand-written path the library path replaces (forced by making every
library answer fail).  Corrupted library answers (a moved vertex, a missing vertex, a non-vertex,
a row ignored, a facet dropped) must fail the check, be counted as fall-backs and still give the
right answer.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull

from hybobs_opt.errors import ModelError
from hybobs_opt.geometry import _hull_cycle as hcmod
from hybobs_opt.geometry import vertices as vmod
from hybobs_opt.geometry.polytope import Polytope

cdd = pytest.importorskip("cdd", reason="pycddlib (the [cdd] extra, part of [test]) is not installed")

DIMS = [2, 3, 4, 5, 6]


# ---------------------------------------------------------------------- oracles
def brute_force_vertices(A, b, tol=1e-9):
    """Every d-subset of rows solved exactly (numpy), the solutions satisfying all rows, deduplicated."""
    m, d = A.shape
    subsets = np.array(list(itertools.combinations(range(m), d)))
    M = A[subsets]
    ok = np.abs(np.linalg.det(M)) > 1e-12
    X = np.linalg.solve(M[ok], b[subsets[ok]][..., None])[..., 0]
    X = X[np.all(X @ A.T <= b + tol * (1 + np.abs(b)), axis=1)]
    out = []
    for x in X:
        if not out or np.min(np.max(np.abs(np.array(out) - x), axis=1)) > 1e-7:
            out.append(x)
    return np.array(out).reshape(-1, d)


def assert_same_points(V, W, atol=1e-7):
    V, W = np.asarray(V, float), np.asarray(W, float)
    assert V.shape == W.shape, f"{V.shape} != {W.shape}"
    for w in W:
        assert np.min(np.max(np.abs(V - w), axis=1)) < atol, f"{w} not among the points"


def lp_max(c, A, b):
    res = linprog(-c, A_ub=A, b_ub=b, bounds=(None, None), method="highs")
    assert res.status in (0, 3), res.message
    return np.inf if res.status == 3 else -res.fun


def random_polytope(rng, d, m, half_width=2.0):
    """``m`` random unit rows with offsets in [0.5, 1.5] inside the box ``[-2, 2]^d``."""
    A = rng.normal(size=(m, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = rng.uniform(0.5, 1.5, m)
    return np.vstack([A, np.eye(d), -np.eye(d)]), np.concatenate([b, half_width * np.ones(2 * d)])


def rows_for(d):
    return {2: 8, 3: 9, 4: 8, 5: 7, 6: 6}[d]  # brute force: C(m + 2d, d) subsets stays below 40,000


@pytest.fixture
def counters():
    vmod.COUNTERS.reset()
    yield vmod.COUNTERS
    vmod.COUNTERS.reset()


def only(monkeypatch, *sources):
    monkeypatch.setattr(vmod, "library_order", lambda d: sources)


def no_library(monkeypatch):
    def fail(A, b):
        return "library disabled by the test"

    monkeypatch.setitem(vmod._LIBRARIES, "cdd", fail)
    monkeypatch.setitem(vmod._LIBRARIES, "qhull", fail)
    monkeypatch.setattr(vmod, "hull_rows", lambda X, op="hull": None)
    import hybobs_opt.geometry.polytope as pmod

    monkeypatch.setattr(pmod, "hull_rows", lambda X, op="hull": None)


# ---------------------------------------------------------------------- H -> V
@pytest.mark.parametrize("source", ["cdd", "qhull"])
@pytest.mark.parametrize("d", DIMS)
def test_vertices_equal_brute_force_on_random_polytopes(d, source, monkeypatch, counters):
    only(monkeypatch, source)
    rng = np.random.default_rng(100 + d)
    for _ in range(3):
        A, b = random_polytope(rng, d, rows_for(d))
        V = Polytope(A, b).vertices()
        assert_same_points(V, brute_force_vertices(A, b))
    assert counters.accepted[f"vertices:{source}"] == 3 and not counters.fallbacks


@pytest.mark.parametrize("d", DIMS)
def test_vertices_above_four_dimensions_and_of_known_shapes(d, counters):
    box = Polytope.from_box(-np.arange(1, d + 1), np.arange(1, d + 1) * 2.0)
    assert_same_points(box.vertices(), np.array(list(itertools.product(*[(-i, 2.0 * i) for i in range(1, d + 1)]))))
    simplex = Polytope(np.vstack([-np.eye(d), np.ones((1, d))]), np.concatenate([np.zeros(d), [1.0]]))
    assert_same_points(simplex.vertices(), np.vstack([np.zeros(d), np.eye(d)]))
    assert not counters.fallbacks


def test_degenerate_vertices_duplicate_rows_and_the_cross_polytope(counters):
    # the 3-D cross-polytope: 4 rows meet at each of its 6 vertices; every row written twice
    A = np.array(list(itertools.product([1.0, -1.0], repeat=3)))
    P = Polytope(np.vstack([A, A, 3 * A]), np.concatenate([np.ones(8), np.ones(8), 3 * np.ones(8)]))
    assert_same_points(P.vertices(), np.vstack([np.eye(3), -np.eye(3)]))
    # a square pyramid: its apex is on 4 rows
    pyr = Polytope(np.array([[0, 0, -1], [1, 0, 1], [-1, 0, 1], [0, 1, 1], [0, -1, 1]], float), np.array([0, 1, 1, 1, 1.0]))
    assert_same_points(pyr.vertices(), brute_force_vertices(pyr.A, pyr.b))
    assert counters.accepted and not counters.fallbacks


def test_lower_dimensional_empty_and_unbounded_sets(counters):
    # the square {z1 = z2 in [0, 1], z3 in [0, 1]} of R^3 written with paired rows
    A = np.array([[1, -1, 0], [-1, 1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1]], float)
    flat = Polytope(A, [0, 0, 1, 0, 1, 0])
    assert_same_points(flat.vertices(), [[0, 0, 0], [1, 1, 0], [0, 0, 1], [1, 1, 1]])
    assert flat.volume().value == 0.0
    empty = Polytope(np.array([[1.0, 0, 0], [-1.0, 0, 0], [0, 1.0, 0]]), np.array([-1.0, 0.0, 1.0]))
    assert empty.vertices().shape == (0, 3)
    assert empty.remove_redundant().is_empty()
    with pytest.raises(ModelError, match="bounded"):
        Polytope(np.array([[1.0, 1.0], [0.0, -1.0]]), np.array([1.0, 0.0])).vertices()
    with pytest.raises(ModelError, match="bounded"):
        Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, 1.0])).vertices()  # a slab: lines
    with pytest.raises(ModelError, match="bounded"):
        Polytope.from_box([0, 0], [1, 1]).intersect(Polytope(np.zeros((1, 2)), [1.0])).lift(3, [0, 1]).volume("exact")


@pytest.mark.parametrize("s", [1e-12, 1e-6, 1.0, 1e6, 1e12], ids=lambda s: f"{s:g}")
def test_vertices_do_not_depend_on_units(s, counters):
    A, b = random_polytope(np.random.default_rng(3), 3, 6)
    ref = brute_force_vertices(A, b)
    r = 10.0 ** np.random.default_rng(4).uniform(-11, 11, b.size)  # each row in its own units
    assert_same_points(Polytope(A * s * r[:, None], b * s * r).vertices(), ref)
    # coordinates in other units, z' = S z, up to a ratio of 1e6 between them (beyond
    # 1 / FULL_DIMENSION_RTOL = 1e7 the thin coordinates count as fixed, by design)
    S = np.array([min(s, 1 / s) ** 0.25, 1.0, max(s, 1 / s) ** 0.25])
    assert_same_points(Polytope(A / S, b).vertices() / S, ref, atol=1e-7)
    far = Polytope.from_box([1e6, -1e6 - 1, 5e8], [1e6 + 1, -1e6, 5e8 + 1e-3])  # far from the origin
    assert_same_points(far.vertices(), np.array(list(itertools.product([1e6, 1e6 + 1], [-1e6 - 1, -1e6], [5e8, 5e8 + 1e-3]))), atol=1e-8)


# ---------------------------------------------------------------------- corrupted library answers
def corrupt(monkeypatch, how):
    real = vmod._LIBRARIES["cdd"]

    def wrong(A, b):
        raw = real(A, b)
        P = raw.points.copy()
        if how == "moved":
            P[0] += 1e-3
        elif how == "missing":
            P = P[1:]
        elif how == "non-vertex":
            P = np.vstack([P, (P[0] + P[1]) / 2 if len(P) > 1 else P])  # a point that is no vertex
        elif how == "row ignored":
            return real(A[1:], b[1:])  # cdd answering for the set without its first row
        return vmod._Raw(P, raw.rays)

    monkeypatch.setitem(vmod._LIBRARIES, "cdd", wrong)


@pytest.mark.parametrize("how", ["moved", "missing", "non-vertex", "row ignored"])
def test_a_corrupted_cdd_answer_is_caught_and_the_answer_stays_right(how, monkeypatch, counters):
    only(monkeypatch, "cdd")
    corrupt(monkeypatch, how)
    A, b = random_polytope(np.random.default_rng(8), 3, 9)
    A = np.vstack([[[1.0, 1.0, 1.0]], A])  # a first row that cuts the set (a facet)
    b = np.concatenate([[1.0], b])
    P = Polytope(A, b)
    assert_same_points(P.vertices(), brute_force_vertices(A, b))
    assert counters.fallbacks["vertices:cdd"] == 1 and not counters.accepted
    R = P.remove_redundant()
    assert counters.fallbacks["remove_redundant:cdd"] == 1
    assert_same_rows(R, lp_path(P, monkeypatch))
    assert P.volume().value == pytest.approx(ConvexHull(brute_force_vertices(A, b)).volume, rel=1e-9)


def test_without_pycddlib_qhull_answers_alone(monkeypatch, counters):
    monkeypatch.setattr(vmod, "_cdd_state", [None])
    assert vmod.library_order(3) == ("qhull",)
    rng = np.random.default_rng(21)
    for d in (2, 4):
        A, b = random_polytope(rng, d, rows_for(d))
        assert_same_points(Polytope(A, b).vertices(), brute_force_vertices(A, b))
    assert counters.accepted["vertices:qhull"] == 2
    pts = rng.normal(size=(30, 3))
    H = Polytope.from_vertices(pts)
    assert counters.fallbacks == {} and H.contains(pts).all()  # built by the hand-written hull


# ---------------------------------------------------------------------- redundancy removal
def lp_path(P, monkeypatch):
    """The hand-written LP path's answer (every library answer made to fail)."""
    with monkeypatch.context() as mp:
        no_library(mp)
        return P.remove_redundant()


def assert_same_rows(R, Q):
    assert R.n_constraints == Q.n_constraints
    np.testing.assert_array_equal(R.A, Q.A)
    np.testing.assert_array_equal(R.b, Q.b)


@pytest.mark.parametrize("d", DIMS)
def test_remove_redundant_equals_the_lp_oracle_and_the_lp_path(d, monkeypatch, counters):
    rng = np.random.default_rng(200 + d)
    for _ in range(2):
        A, b = random_polytope(rng, d, 5 * d)
        A = np.vstack([A, A[:3], 2.0 * A[3:4]])  # duplicates and a scaled duplicate
        b = np.concatenate([b, b[:3] + [0.0, 0.1, 1e-3], 2.0 * b[3:4]])
        P = Polytope(A, b)
        R = P.remove_redundant()
        assert 0 < R.n_constraints < P.n_constraints
        for i in range(R.n_constraints):  # every kept row cuts the set (linprog over the others)
            others = np.delete(np.arange(R.n_constraints), i)
            assert lp_max(R.A[i], R.A[others], R.b[others]) > R.b[i] + 1e-7
        for a, bb in zip(P.A, P.b):  # every given row is implied by the kept ones
            assert lp_max(a, R.A, R.b) <= bb + 1e-7 * (1 + abs(bb)) * np.linalg.norm(a)
        assert counters.accepted and not counters.fallbacks
        assert_same_rows(R, lp_path(P, monkeypatch))
        counters.reset()


def test_remove_redundant_falls_back_on_flat_and_unbounded_sets(monkeypatch, counters):
    A = np.array([[1, -1, 0], [-1, 1, 0], [1, 0, 0], [-1, 0, 0], [0, 0, 1], [0, 0, -1], [1, 1, 1]], float)
    flat = Polytope(A, [0, 0, 1, 0, 1, 0, 10])
    R = flat.remove_redundant()
    assert R.n_constraints == 6
    assert counters.fallbacks["remove_redundant:cdd"] == 1
    wedge = Polytope(np.array([[1.0, 1.0], [0.0, -1.0], [2.0, 2.0]]), np.array([1.0, 0.0, 5.0]))
    assert wedge.remove_redundant().n_constraints == 2
    assert any("unbounded" in r for r in counters.reasons)


# ---------------------------------------------------------------------- V -> H
def in_hull(points, x):
    """Is ``x`` a convex combination of the points?  (linprog feasibility)"""
    n = points.shape[0]
    res = linprog(np.zeros(n), A_eq=np.vstack([points.T, np.ones((1, n))]), b_eq=np.append(x, 1.0),
                  bounds=(0, None), method="highs")
    return res.status == 0


@pytest.mark.parametrize("d", DIMS)
def test_from_vertices_equals_the_hull_oracle(d, counters):
    rng = np.random.default_rng(300 + d)
    pts = rng.normal(size=(4 * d + 6, d)) * np.logspace(-3, 3, d)  # badly scaled coordinates
    H = Polytope.from_vertices(pts)
    hull = ConvexHull(pts)
    # every facet plane of qhull's (triangulated) hull is one of our rows, and we have no others
    eq = hull.equations / np.linalg.norm(hull.equations[:, :-1], axis=1)[:, None]
    ours = np.hstack([H.A, -H.b[:, None]])
    for plane in eq:
        assert np.min(np.max(np.abs(ours - plane), axis=1)) < 1e-8
    assert H.n_constraints == len(np.unique(np.round(eq, 6), axis=0))
    X = rng.normal(size=(60, d)) * np.logspace(-3, 3, d) * 0.8
    lo, hi = pts.min(axis=0), pts.max(axis=0)
    margin = np.min((H.b[None, :] - X @ H.A.T), axis=1)
    X = X[np.abs(margin) > 1e-6 * np.max(hi - lo)]
    np.testing.assert_array_equal(H.contains(X), [in_hull(pts, x) for x in X])
    source = "qhull"  # qhull first in every dimension
    assert counters.accepted[f"from_vertices:{source}"] == 1 and not counters.fallbacks


def test_from_vertices_corrupted_flat_and_single_point(monkeypatch, counters):
    pts = np.array(list(itertools.product([0.0, 1.0], repeat=3))) + 0.1 * np.random.default_rng(1).normal(size=(8, 3))
    ref = Polytope.from_vertices(pts)
    real = cdd.copy_inequalities

    class Dropped:
        def __init__(self, m):
            self.array, self.lin_set = m.array[1:], m.lin_set

    X = np.random.default_rng(2).uniform(-0.5, 1.5, size=(4000, 3))
    import scipy.spatial

    class Merged:  # qhull's answer with its first simplex dropped: its check must see it
        def __init__(self, Y, qhull_options=None):
            hull = scipy.spatial.ConvexHull(Y, qhull_options=qhull_options)
            self.equations, self.simplices, self.vertices = hull.equations[1:], hull.simplices[1:], hull.vertices

    with monkeypatch.context() as mp:
        mp.setattr(hcmod, "ConvexHull", Merged)
        got = Polytope.from_vertices(pts)  # qhull (first) refused: cddlib answers
        assert counters.fallbacks["from_vertices:qhull"] == 1 and counters.accepted["from_vertices:cdd"] == 1
        np.testing.assert_array_equal(got.contains(X), ref.contains(X))
        mp.setattr(cdd, "copy_inequalities", lambda poly: Dropped(real(poly)))
        counters.reset()
        got = Polytope.from_vertices(pts)  # a facet dropped by "cdd" too: the polar check must see it
        assert counters.fallbacks["from_vertices:cdd"] == 1 and counters.fallbacks["from_vertices:qhull"] == 1
        np.testing.assert_array_equal(got.contains(X), ref.contains(X))  # the hand-written hull
    monkeypatch.undo()
    seg = Polytope.from_vertices([[0, 0, 0], [1, 2, 3], [0.5, 1, 1.5]])  # flat: hand-written hull
    assert seg.contains(np.array([[0.25, 0.5, 0.75], [0.25, 0.5, 0.8], [1.1, 2.2, 3.3]])).tolist() == [True, False, False]
    point = Polytope.from_vertices([[1.0, 2.0]])
    assert point.contains(np.array([[1.0, 2.0], [1.0, 2.001]])).tolist() == [True, False]
    with pytest.raises(ModelError, match="point"):
        Polytope.from_vertices(np.zeros((0, 2)))


# ---------------------------------------------------------------------- volume
@pytest.mark.parametrize("d", [2, 3, 4, 5])
def test_exact_volume_equals_qhull_of_brute_force_vertices_and_monte_carlo(d, counters):
    rng = np.random.default_rng(400 + d)
    A, b = random_polytope(rng, d, rows_for(d))
    P = Polytope(A, b)
    vol = P.volume("exact")
    assert vol.method == "exact"
    assert vol.value == pytest.approx(ConvexHull(brute_force_vertices(A, b)).volume, rel=1e-9)
    Z = rng.uniform(-2, 2, size=(400_000, d))
    p = np.mean(np.all(Z @ A.T <= b, axis=1))
    mc, se = 4.0**d * p, 4.0**d * math.sqrt(p * (1 - p) / Z.shape[0])
    assert abs(vol.value - mc) < 5 * se


@pytest.mark.parametrize("corrupt", ["drop", "double", "flip", "facet"])
def test_hull_check_catches_a_wrong_qhull_triangulation(monkeypatch, corrupt):
    """qhull's triangulation of a box corrupted: the cycle check refuses it; the facets answer."""
    class Liar:
        def __init__(self, Y, qhull_options=None):
            hull = ConvexHull(Y, qhull_options=qhull_options)
            eq, S = hull.equations, hull.simplices.copy()
            if Y.shape[1] == 3:  # only the box's own hull; its facets' 2-D hulls are left alone
                if corrupt == "drop":  # one triangle of a face missing
                    eq, S = eq[1:], S[1:]
                elif corrupt == "double":  # every triangle twice: the boundary covered twice
                    eq, S = np.vstack([eq, eq]), np.vstack([S, S[:, ::-1]])
                elif corrupt == "flip":  # one triangle's vertex replaced by a point off its face
                    S[0, 0] = next(k for k in range(8) if abs(eq[0, :3] @ Y[k] + eq[0, 3]) > 0.1)
                else:  # a whole face missing
                    keep = np.any(np.abs(eq[:, :3] - eq[0, :3]) > 1e-9, axis=1)
                    eq, S = eq[keep], S[keep]
            self.equations, self.simplices, self.vertices = eq, S, hull.vertices

    box = Polytope.from_box([0, 0, 0], [1, 2, 3])
    Y = box.vertices() - box.vertices().mean(axis=0)
    monkeypatch.setattr(hcmod, "ConvexHull", Liar)
    hull = Liar(Y)
    eq = hull.equations
    assert isinstance(hcmod.check_triangulation(Y, Y.mean(axis=0), hull.simplices, eq[:, :-1], -eq[:, -1]), str)
    got = hcmod.checked_hull(Y)
    if corrupt in ("drop", "double"):  # every face's plane still there: the ridge closure proves them
        assert got.how == "facets" and got.volume == pytest.approx(6.0, rel=1e-12) and got.G.shape == (6, 3)
    else:  # a face's plane missing (or a triangle off its plane): refused
        assert isinstance(got, str)
    assert box.volume().value == pytest.approx(6.0, rel=1e-12)  # by the facets' 2-D hulls if need be
    pts = np.vstack([box.vertices(), [[0.5, 1.0, 1.5]]])
    H = Polytope.from_vertices(pts)  # cdd (3-D) answers: the box's 6 rows
    assert H.n_constraints == 6 and H.contains(np.array([[0.5, 1.9, 2.9], [0.5, 2.1, 1.0]])).tolist() == [True, False]


def test_remove_redundant_with_a_caller_scale_decides_as_the_lp_path(monkeypatch, counters):
    """A union passes its box as ``scale``: tolerances are relative to it, not to the piece.

    A slab 2e-5 thin in y with one edge cut 6e-8 deep: relative to the union's box (scale 1) the
    cut is below REDUNDANCY_RTOL, and both paths must drop the row (model (17)'s cut sets had such
    pieces, where the vertex path, judging in the piece's own box, kept it).
    """
    thin = Polytope.from_box([0.0, 0.0, 0.0], [1.0, 2e-5, 1.0])
    cut = np.array([[0.0, 1.0, 1.0]]) / math.sqrt(2)
    P = thin.intersect(Polytope(cut, [(1.0 + 2e-5 - 6e-8) / math.sqrt(2)]))
    scale = np.ones(3)
    R = P.remove_redundant(scale)
    assert counters.accepted["remove_redundant:cdd"] == 1
    assert_same_rows(R, lp_path_scaled(P, scale, monkeypatch))
    assert R.n_constraints == 6
    rng = np.random.default_rng(31)
    for d in (2, 3, 4):
        A, b = random_polytope(rng, d, 4 * d)
        P = Polytope(A, b)
        s = np.full(d, 10.0)
        assert_same_rows(P.remove_redundant(s), lp_path_scaled(P, s, monkeypatch))


def lp_path_scaled(P, scale, monkeypatch):
    with monkeypatch.context() as mp:
        no_library(mp)
        return P.remove_redundant(scale)


# A piece of model (17)'s B_5 cut at omega_m = 90, omega_l = 30 (paper 002), and the union's scale.
MODEL17_PIECE_A = [[-1.8894298371676007e-14, 1.0, 8.802392379036745e-18], [-1.0, -0.0, -0.0], [0.0004804495757086311, -0.9999998845839144, 6.023618435969363e-07], [0.0004268410029399047, -0.9999999089033552, -1.98854803572433e-07], [-0.0267315343086242, -0.9996425661999682, -0.0004060968469219711], [0.00047952138401743423, -0.9999998850294134, 6.34382196182315e-07], [0.0004196716825627809, -0.9999999119377951, -2.847181439997401e-07], [0.0003500415277343855, -0.9999999387346162, -1.3010007414248336e-06], [0.0004114233020837193, -0.9999999153653563, -3.8350484362500153e-07]]
MODEL17_PIECE_B = [0.021264505001729758, 0.05, -0.021186050850984416, -0.02129388404030923, -0.07586346361200332, -0.02118156992932616, -0.021305410899524892, -0.0214420400646655, -0.021318621269549334]
MODEL17_UNION_SCALE = [0.07128140598365582, 0.022390527220415582, 59.148892071161114]


def test_model17_piece_with_the_union_scale_keeps_the_lp_paths_rows(monkeypatch, counters):
    """Judged in the piece's own box (2e-5 thin in theta_cl), the vertex path kept a row the LP path
    drops relative to the union's box; with the caller's scale both give the same rows, bit for bit."""
    P = Polytope(np.array(MODEL17_PIECE_A), np.array(MODEL17_PIECE_B))
    s = np.array(MODEL17_UNION_SCALE)
    R = P.remove_redundant(s)
    assert counters.accepted["remove_redundant:cdd"] + counters.accepted["remove_redundant:qhull"] == 1
    assert_same_rows(R, lp_path_scaled(P, s, monkeypatch))

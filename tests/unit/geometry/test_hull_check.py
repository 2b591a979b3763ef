"""Hulls checked by their triangulation or facets, the Chebyshev LP certified as a basis, 2-D projections by vertices.

Oracles share no code with what they check: planes through every d-subset of the points that
support all of them (brute force), the rows of a known polytope, ``scipy.optimize.linprog``,
closed-form volumes, and brute-force vertices of the source polytope.
"""

from __future__ import annotations

import itertools
import math

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.spatial import ConvexHull

from hybobs_opt.geometry import vertices as vmod
from hybobs_opt.geometry.polytope import Polytope

pytest.importorskip("cdd", reason="pycddlib (the [cdd] extra, part of [test]) is not installed")


@pytest.fixture
def counters():
    vmod.COUNTERS.reset()
    yield vmod.COUNTERS
    vmod.COUNTERS.reset()


def brute_force_facets(X, tol=1e-9):
    """Unit rows ``(a, b)`` of the planes through d affinely independent points that every point satisfies."""
    n, d = X.shape
    subs = np.array(list(itertools.combinations(range(n), d)))
    M = np.concatenate([X[subs], -np.ones((subs.shape[0], d, 1))], axis=2)  # rows (p, -1): a'p - b = 0
    M = np.concatenate([M, np.zeros((subs.shape[0], 1, d + 1))], axis=1)  # square, for a full SVD
    _, s, Vt = np.linalg.svd(M)
    ok = s[:, -2] > 1e-6 * s[:, 0]  # d independent equations: a unique plane
    a, b = Vt[ok, -1, :d], Vt[ok, -1, d]
    nrm = np.linalg.norm(a, axis=1)
    a, b = a / nrm[:, None], b / nrm
    v = X @ a.T - b  # (n, planes)
    below, above = np.all(v <= tol, axis=0), np.all(v >= -tol, axis=0)
    rows = np.vstack([np.hstack([a[below], b[below, None]]), -np.hstack([a[above & ~below], b[above & ~below, None]])])
    out = []
    for r in rows:
        if not out or np.min(np.max(np.abs(np.array(out) - r), axis=1)) > 1e-7:
            out.append(r)
    return np.array(out)


def assert_same_rows(H, R, atol=1e-7):
    ours = np.hstack([H.A, H.b[:, None]])
    assert ours.shape == R.shape, f"{ours.shape} != {R.shape}"
    for r in R:
        assert np.min(np.max(np.abs(ours - r), axis=1)) < atol


def rotation(rng, d):
    return np.linalg.qr(rng.normal(size=(d, d)))[0]


def cube(d):
    return np.array(list(itertools.product([-1.0, 1.0], repeat=d)))


def degenerate_sets(d, rng):
    """Cube vertices (rotated) duplicated, with interior points, points on facets and on ridges, and
    points 1e-9 inside facets; vertices of a cross-polytope with its edge midpoints."""
    Q = rotation(rng, d)
    C = cube(d)
    k = d + 1  # extra points (the brute force grows as C(n, d))
    F = rng.uniform(-1, 1, (k, d))
    F[np.arange(k), np.arange(k) % d] = np.where(np.arange(k) % 2 == 0, 1.0, -1.0)
    near = F.copy()
    near[np.arange(k), np.arange(k) % d] *= 1.0 - 1e-9
    ridge = F.copy()
    ridge[np.arange(k), (np.arange(k) + 1) % d] = 1.0
    E = np.vstack([np.eye(d), -np.eye(d)])
    mids = np.array([(p + q) / 2 for p, q in itertools.combinations(E, 2) if np.any(p + q)])[:2 * d]
    return [np.vstack([C, C[:3], 0.5 * C[:2], F]) @ Q.T,
            np.vstack([C, near, ridge]) @ Q.T,
            np.vstack([E, mids, np.zeros((1, d))]) @ Q.T]


@pytest.mark.parametrize("d", [2, 3, 4])
def test_from_vertices_of_degenerate_sets_equals_brute_force_without_fallback(d, counters):
    rng = np.random.default_rng(3900 + d)
    for X in degenerate_sets(d, rng):
        H = Polytope.from_vertices(X)
        assert_same_rows(H, brute_force_facets(X))
        assert np.all(H.contains(X))
    # a library answer passed its check every time (cddlib's may fail on points 1e-9 inside a facet; qhull's then passes)
    assert sum(counters.accepted.values()) == 3, counters.reasons


@pytest.mark.parametrize("d", [5, 6])
def test_from_vertices_of_symmetric_sets_in_high_dimension(d, counters):
    """The cube's and the cross-polytope's facets (non-simplicial, or 2^d of them) in closed form."""
    rng = np.random.default_rng(40 + d)
    cube_pts, _, cross_pts = degenerate_sets(d, rng)
    H = Polytope.from_vertices(cube_pts @ rotation(rng, d).T)  # any rotation: still a cube
    assert H.n_constraints == 2 * d and np.allclose(H.b, 1.0)
    K = Polytope.from_vertices(cross_pts)  # vertices Q e_i: facets (Q s)' x <= 1, s in {-1, 1}^d
    signs = cube(d)
    assert_same_rows(K, np.hstack([signs @ cross_pts[:d], np.ones((2**d, 1))]) / math.sqrt(d))
    assert not counters.fallbacks, counters.reasons


@pytest.mark.parametrize("d", [3, 6])
def test_exact_volume_of_symmetric_polytopes_in_closed_form(d):
    rng = np.random.default_rng(70 + d)
    Q = rotation(rng, d)
    box = Polytope(np.vstack([Q.T, -Q.T]), np.concatenate([np.full(d, 1.0), np.full(d, 2.0)]))  # 3^d
    assert box.volume("exact").value == pytest.approx(3.0**d, rel=1e-9)
    signs = cube(d)
    cross = Polytope(signs @ Q.T, np.ones(2**d))  # |Q'z|_1 <= 1: volume 2^d / d!
    assert cross.volume("exact").value == pytest.approx(2.0**d / math.factorial(d), rel=1e-9)


def test_exact_volume_answers_where_qhull_triangulation_does_not_close():
    """The 6-D instance of the benchmark whose exact volume raised SolverError (issue 39)."""
    rng = np.random.default_rng(0)
    d = 6
    A = rng.normal(size=(3 * d, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    b = rng.uniform(0.5, 1.5, 3 * d)
    L = rng.normal(size=(d, d))
    L /= np.linalg.norm(L, axis=1)[:, None]
    P = Polytope(np.vstack([A, np.eye(d), -np.eye(d), L]), np.concatenate([b, 2.0 * np.ones(2 * d), 3.0 * np.ones(d)]))
    V = P.vertices()
    assert P.volume("exact").value == pytest.approx(ConvexHull(V).volume, rel=1e-9)


@pytest.mark.parametrize("d", [2, 3, 4, 5, 6])
def test_chebyshev_ball_equals_linprog(d):
    rng = np.random.default_rng(90 + d)
    for _ in range(3):
        A = np.vstack([rng.normal(size=(4 * d, d)), np.eye(d), -np.eye(d)])
        b = np.concatenate([rng.uniform(0.5, 1.5, 4 * d), rng.uniform(0.2, 2.0, 2 * d)])
        norms = np.linalg.norm(A, axis=1)
        c = np.zeros(d + 1)
        c[-1] = -1.0
        ref = linprog(c, A_ub=np.hstack([A, norms[:, None]]), b_ub=b, bounds=[(None, None)] * (d + 1), method="highs")
        centre, r = Polytope(A, b).chebyshev_ball()
        assert r == pytest.approx(-ref.fun, rel=1e-9, abs=1e-12)
        assert np.all(A @ centre + norms * r <= b + 1e-9)


def test_chebyshev_ball_flat_empty_unbounded_and_non_unique_centre():
    box = Polytope.from_box([0.0, 0.0], [1.0, 3.0])  # centres (0.5, y), y in [0.5, 2.5]
    centre, r = box.chebyshev_ball()
    assert r == pytest.approx(0.5, abs=1e-12) and centre[0] == pytest.approx(0.5) and 0.5 - 1e-12 <= centre[1] <= 2.5 + 1e-12
    flat = Polytope(np.array([[1.0, 1.0], [-1.0, -1.0], [1.0, 0.0], [-1.0, 0.0]]), np.array([1.0, -1.0, 1.0, 0.0]))
    assert abs(flat.chebyshev_ball()[1]) <= 1e-12  # exact vertex: no 1e-9 radius of a flat set
    empty = Polytope(np.array([[1.0], [-1.0]]), np.array([0.0, -1.0]))
    assert empty.chebyshev_ball()[1] < 0 or empty.chebyshev_ball()[0] is None
    half = Polytope(np.array([[1.0, 0.0]]), np.array([1.0]))
    assert half.chebyshev_ball()[1] == np.inf
    scaled = Polytope.from_box([0.0, 0.0], [1.0, 100.0]).chebyshev_ball(np.array([1.0, 100.0]))
    assert scaled[1] == pytest.approx(0.5) and np.allclose(scaled[0], [0.5, 50.0])


@pytest.mark.parametrize("d", [3, 4, 5])
def test_projection_to_2d_equals_the_hull_of_projected_brute_force_vertices(d, counters):
    rng = np.random.default_rng(110 + d)
    A = rng.normal(size=(2 * d + 2, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    A = np.vstack([A, np.eye(d), -np.eye(d)])
    b = np.concatenate([rng.uniform(0.5, 1.5, 2 * d + 2), 2.0 * np.ones(2 * d)])
    subs = np.array(list(itertools.combinations(range(A.shape[0]), d)))
    M = A[subs]
    ok = np.abs(np.linalg.det(M)) > 1e-12
    X = np.linalg.solve(M[ok], b[subs[ok]][..., None])[..., 0]
    W = X[np.all(X @ A.T <= b + 1e-9, axis=1)][:, [0, 2]]
    ref = W[ConvexHull(W).vertices]
    Q = Polytope(A, b).project([0, 2])
    got = Q.vertices()
    assert got.shape == ref.shape
    for w in ref:
        assert np.min(np.max(np.abs(got - w), axis=1)) < 1e-7
    assert counters.accepted.get("projection:" + ("cdd" if d <= vmod.CDD_FIRST_MAX_DIM else "qhull")) == 1

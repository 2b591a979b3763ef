"""The compiled 2-D hull, 3-D triangulation check and 3-D facet volume, against independent oracles.

Oracles share no code with what they check: planes (lines) through every d-subset of the points
that support all of them (brute force), vertices by brute force over the rows' d-subsets and
scipy's ``ConvexHull`` volume of those.  Inputs include duplicates, points on facets and ridges,
grid points (non-simplicial facets) and tampered answers the checks must refuse.
"""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from scipy.spatial import ConvexHull

from hybobs_opt.geometry import _vertex_kernels as K
from hybobs_opt.geometry._hull_cycle import _generic, checked_hull
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.tolerances import (
    AFFINE_HULL_RTOL,
    FULL_DIMENSION_RTOL,
    FULL_SIMPLEX_RTOL,
    VERTEX_CHECK_RTOL,
    VERTEX_SAME_RTOL,
    VERTEX_TIGHT_RTOL,
)


def brute_facets(X: np.ndarray) -> np.ndarray:
    """Unit rows ``[a, b]`` of the planes through d affinely independent points supporting all points."""
    n, d = X.shape
    scale = np.abs(X).max()
    rows = []
    for idx in itertools.combinations(range(n), d):
        P = X[list(idx)]
        D = P[1:] - P[0]
        a = np.linalg.svd(D)[2][-1] if d > 1 else np.ones(1)
        if np.linalg.matrix_rank(D, tol=1e-9 * scale) < d - 1:
            continue
        s = X @ a - P[0] @ a
        if s.max() <= 1e-9 * scale:
            rows.append(np.r_[a, P[0] @ a])
        elif s.min() >= -1e-9 * scale:
            rows.append(-np.r_[a, P[0] @ a])
    return _unique_rows(np.array(rows))


def _unique_rows(R: np.ndarray) -> np.ndarray:
    R = R / np.linalg.norm(R[:, :-1], axis=1)[:, None]
    _, first = np.unique(np.round(R, 7), axis=0, return_index=True)
    return R[np.sort(first)][np.lexsort(np.round(R[np.sort(first)], 7).T[::-1])]


def brute_vertices(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    d = A.shape[1]
    out = []
    for idx in itertools.combinations(range(A.shape[0]), d):
        M = A[list(idx)]
        if abs(np.linalg.det(M)) < 1e-12:
            continue
        x = np.linalg.solve(M, b[list(idx)])
        if np.all(A @ x <= b + 1e-9):
            out.append(x)
    V = np.array(out)
    return V[np.unique(np.round(V, 9), axis=0, return_index=True)[1]]


def point_sets(d: int):
    rng = np.random.default_rng(39 + d)
    C = np.array(list(itertools.product([-1.0, 1.0], repeat=d)))
    Q, _ = np.linalg.qr(rng.normal(size=(d, d)))
    on_facets = rng.uniform(-1, 1, (2 * d, d))
    on_facets[np.arange(2 * d), np.arange(2 * d) % d] = np.repeat([1.0, -1.0], d)
    grid = np.array(list(itertools.product([-1.0, -0.5, 0.0, 0.5, 1.0] if d == 2 else [-1.0, 0.0, 1.0], repeat=d)))
    yield "random", rng.uniform(-1, 1, (20, d))
    yield "cube, duplicates, interior, on facets", np.vstack([C, C[:3], 0.3 * C, on_facets]) @ Q.T
    yield "grid", grid
    yield "grid rotated", grid @ Q.T


@pytest.mark.parametrize("d", [2, 3])
def test_from_vertices_matches_brute_force_facets(d):
    for name, X in point_sets(d):
        P = Polytope.from_vertices(X)
        got = _unique_rows(np.hstack([P.A, P.b[:, None]]))
        want = brute_facets(X)
        assert got.shape == want.shape and np.allclose(got, want, atol=1e-6), name


@pytest.mark.parametrize("d", [2, 3])
def test_checked_hull_volume_matches_brute_force(d):
    for name, X in point_sets(d):
        Y = X / np.abs(X).max(axis=0)
        hull = checked_hull(Y)
        assert not isinstance(hull, str), (name, hull)
        if d == 2:  # the compiled path answered, not qhull's fall-back
            code = K.polygon_kernel(Y, FULL_DIMENSION_RTOL, FULL_SIMPLEX_RTOL, VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL)[0]
        else:
            h = ConvexHull(Y)
            code = K.triangulation_kernel(*_tri_args(Y, h.simplices, h.equations[:, :-1], -h.equations[:, -1]))[0]
        assert code == 0, name
        R = brute_facets(Y)
        c = Y.mean(axis=0)
        # the pyramids over the brute-force facets: their areas by scipy's hull of each facet's points
        vol = 0.0
        for r in R:
            on = np.abs(Y @ r[:-1] - r[-1]) <= 1e-6
            Z = Y[on] - Y[on].mean(axis=0)
            B = np.linalg.svd(r[None, :-1])[2][1:].T
            area = ConvexHull(Z @ B).volume if d == 3 else np.ptp(Z @ B)
            vol += (r[-1] - r[:-1] @ c) * area / d
        assert abs(hull.volume - vol) <= 1e-9 * vol, name


def test_polygon_kernel_refuses_a_missing_point():
    """A point outside the answer is caught by the check (the kernel fed the hull of fewer points)."""
    Y = np.array([[0.0, 0.0], [1.0, 0.0], [1.0, 1.0], [0.0, 1.0]])
    code, *_ = K.polygon_kernel(Y, FULL_DIMENSION_RTOL, FULL_SIMPLEX_RTOL, VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL)
    assert code == 0
    collinear = np.array([[0.0, 0.0], [1.0, 1.0], [2.0, 2.0], [0.5, 0.5]])
    code, *_ = K.polygon_kernel(collinear, FULL_DIMENSION_RTOL, FULL_SIMPLEX_RTOL, VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL)
    assert code == 1


def _tri_args(Y, S, G, g):
    n, d = Y.shape
    return (Y, Y.mean(axis=0), np.ascontiguousarray(S, dtype=np.int64), np.ascontiguousarray(G), np.ascontiguousarray(g),
            _generic(d + 1), _generic(n), VERTEX_SAME_RTOL, VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL, FULL_DIMENSION_RTOL,
            FULL_SIMPLEX_RTOL)


def test_triangulation_kernel_refuses_tampered_triangulations():
    Y = np.array(list(itertools.product([-1.0, 1.0], repeat=3)))
    Y = np.vstack([Y, [[0.0, 0.0, 1.0], [1.0, 0.2, 0.1]]])  # points on facets: non-simplicial facets
    h = ConvexHull(Y)
    S, G, g = h.simplices, h.equations[:, :-1], -h.equations[:, -1]
    code, reps, tight, depth, vol = K.triangulation_kernel(*_tri_args(Y, S, G, g))
    assert code == 0 and len(reps) == 6 and abs(vol - 8.0) < 1e-12
    code, *_ = K.triangulation_kernel(*_tri_args(Y, S[1:], G[1:], g[1:]))
    assert code == K.TRI_RIDGE_NOT_TWICE
    code, *_ = K.triangulation_kernel(*_tri_args(Y, np.vstack([S, S[:1]]), np.vstack([G, G[:1]]), np.r_[g, g[:1]]))
    assert code == K.TRI_SIMPLEX_TWICE
    code, *_ = K.triangulation_kernel(*_tri_args(Y, S[:, [1, 0, 2]], G, g))  # same simplices: orientation is geometric
    assert code == 0
    shifted = g.copy()
    shifted[0] -= 0.1
    code, *_ = K.triangulation_kernel(*_tri_args(Y, S, G, shifted))
    assert code in (K.TRI_POINT_VIOLATES, K.TRI_OFF_PLANE)
    # two copies of the boundary (one moved over the other): every ridge four times
    code, *_ = K.triangulation_kernel(*_tri_args(np.vstack([Y, Y]), np.vstack([S, S + len(Y)]), np.vstack([G, G]), np.r_[g, g]))
    assert code != 0


def test_volume_3d_by_facets_matches_qhull_of_brute_force_vertices(monkeypatch):
    import hybobs_opt.geometry.polytope as pmod

    def refuse(*args):
        raise AssertionError("the facet kernel should have answered")

    monkeypatch.setattr(pmod, "checked_hull_volume", refuse)
    monkeypatch.setattr(pmod, "volume_by_facets", refuse)
    rng = np.random.default_rng(7)
    cube = (np.vstack([np.eye(3), -np.eye(3)]), np.ones(6))
    cases = [cube,
             (np.vstack([cube[0], cube[0][:2]]), np.r_[cube[1], 1.0, 1.0]),  # duplicated rows
             (np.vstack([cube[0], [[1.0, 1.0, 1.0]]]), np.r_[cube[1], 2.0]),  # a cut through a vertex: degenerate vertices
             (np.vstack([cube[0], [[1.0, 1.0, 0.0]]]), np.r_[cube[1], 2.0])]  # a row tight on an edge only
    for _ in range(6):
        A = np.vstack([rng.normal(size=(8, 3)), cube[0]])
        cases.append((A, np.ones(14) + rng.uniform(0.0, 0.5, 14)))
    for A, b in cases:
        want = ConvexHull(brute_vertices(A, b)).volume
        assert abs(Polytope(A, b).volume("exact").value - want) <= 1e-9 * want


def test_facet_volume_kernel_checks_euler_and_convexity():
    Y = np.array(list(itertools.product([-1.0, 1.0], repeat=3)))
    A = np.vstack([np.eye(3), -np.eye(3)])
    b = np.ones(6)
    tight = np.abs(b[None, :] - Y @ A.T) <= 1e-12
    args = (FULL_DIMENSION_RTOL, AFFINE_HULL_RTOL, FULL_SIMPLEX_RTOL)
    code, vol = K.facet_volume_3d(Y, A, b, tight, *args)
    assert code == 0 and abs(vol - 8.0) < 1e-12
    wrong = tight.copy()
    wrong[0, :] = False  # a vertex on no facet: V - E + F = 3
    assert K.facet_volume_3d(Y, A, b, wrong, *args)[0] == 3
    inner = np.vstack([Y, [[0.0, 0.0, 1.0]]])  # a point inside the top facet taken as a vertex: not strictly convex
    t2 = np.abs(b[None, :] - inner @ A.T) <= 1e-12
    assert K.facet_volume_3d(inner, A, b, t2, *args)[0] == 2

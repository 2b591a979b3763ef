"""The walks that prove a set wide before any width LP (``_lp_kernels.walk_width_lower_bound``).

The pair tests of Algorithm 3.1 ask, for most pieces of ``B_T``, whether a set is thinner than
``2 REGION_SLACK_TOL`` along one direction; two LPs answered every such question.  Two short
walks from an interior point now answer it first when the set is wide.  What must hold:

* the bound is a lower bound of the true width, which scipy's ``linprog`` (HiGHS through SciPy,
  sharing no code with the walks) computes, on random polytopes, thin slabs and cones;
* an infeasible or non-finite start proves nothing (``-inf``);
* the NumPy twin that runs before the kernels are compiled gives the same bits as the kernel;
* ``certified_width_below`` answers the same with a point (walks first) as without (LPs only),
  on sets on both sides of the threshold.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog

from hybobs_opt._numba_cache import tier_up
from hybobs_opt.geometry import _lp_kernels as K
from hybobs_opt.geometry.lp import certified_width_below, width_proven_above


def _true_width(A, b, c):
    top = linprog(-c, A_ub=A, b_ub=b, bounds=[(None, None)] * A.shape[1], method="highs")
    bottom = linprog(c, A_ub=A, b_ub=b, bounds=[(None, None)] * A.shape[1], method="highs")
    assert top.status == 0 and bottom.status == 0
    return -top.fun - bottom.fun


def _polytope(rng, k, d):
    """Random unit rows around the origin (bounded: the box rows are included)."""
    A = rng.normal(size=(k, d))
    A /= np.linalg.norm(A, axis=1)[:, None]
    A = np.vstack([A, np.eye(d), -np.eye(d)])
    b = np.concatenate([rng.uniform(0.05, 1.0, k), np.ones(2 * d)])
    return A, b


def _slab(rng, d, thickness, n_walls=2):
    """A box cut by ``n_walls`` slabs ``|a_k'v - s_k| <= thickness / 2`` through the origin's neighbourhood."""
    rows, rhs = [np.eye(d), -np.eye(d)], [np.ones(d), np.ones(d)]
    for _ in range(n_walls):
        a = rng.normal(size=d)
        a /= np.linalg.norm(a)
        rows += [a[None, :], -a[None, :]]
        rhs += [np.array([thickness / 2]), np.array([thickness / 2])]
    return np.vstack(rows), np.concatenate(rhs)


@pytest.mark.parametrize("seed", range(30))
def test_walk_bound_is_below_the_linprog_width(seed):
    rng = np.random.default_rng(seed)
    d = int(rng.integers(2, 16))
    A, b = _polytope(rng, int(rng.integers(d + 1, 60)), d)
    c = rng.normal(size=d) * 10.0 ** rng.uniform(-6, 0)
    p = np.zeros(d)  # inside: every b_k > 0
    lower = K.walk_width_lower_bound(A, b, p, c, 8, 0.99, np.inf)
    truth = _true_width(A, b, c)
    assert np.isfinite(lower)
    assert lower <= truth * (1 + 1e-12) + 1e-15
    assert lower >= 0.25 * truth  # eight ratio-test steps reach a good part of the width here


@pytest.mark.parametrize("seed", range(12))
def test_walks_along_a_thin_slab_stay_inside_and_prove_its_long_width(seed):
    rng = np.random.default_rng(100 + seed)
    d = int(rng.integers(4, 12))
    A, b = _slab(rng, d, 1e-7, n_walls=int(rng.integers(1, 4)))
    # the direction along the walls that moves the most: a flat direction of the slab's normals
    normals = A[2 * d::2]
    Q = np.linalg.svd(normals)[2][normals.shape[0]:]  # orthonormal basis of the walls' common directions
    c = Q[0] * 1e-3
    lower = K.walk_width_lower_bound(A, b, np.zeros(d), c, 8, 0.99, np.inf)
    truth = _true_width(A, b, c)
    assert lower <= truth * (1 + 1e-12) + 1e-15
    assert lower > 2e-6  # wide along the walls although the slab is 1e-7 thick
    # and across the walls it proves nothing wider than the slab is
    across = K.walk_width_lower_bound(A, b, np.zeros(d), normals[0], 8, 0.99, np.inf)
    assert across <= 1e-7 * (1 + 1e-9)


def test_an_infeasible_or_non_finite_start_proves_nothing():
    A, b = np.vstack([np.eye(3), -np.eye(3)]), np.ones(6)
    c = np.array([1.0, 0.0, 0.0])
    assert K.walk_width_lower_bound(A, b, np.array([0.0, 2.0, 0.0]), c, 8, 0.99, np.inf) == -np.inf
    assert K.walk_width_lower_bound(A, b, np.array([0.0, np.nan, 0.0]), c, 8, 0.99, np.inf) == -np.inf
    assert K.walk_width_lower_bound(A, b, np.zeros(3), np.array([np.inf, 0.0, 0.0]), 8, 0.99, np.inf) == -np.inf
    assert not width_proven_above(A, b, c, np.array([0.0, 2.0, 0.0]), 1e-6)
    assert not width_proven_above(A, b, c, np.zeros(2), 1e-6)  # a point of the wrong size


def test_a_start_on_the_boundary_is_not_certified_and_one_inside_is():
    # on the row v1 <= 1 the walk along +v1 cannot move, and a point on a row is not certified
    # (its rounding-error bound does not clear the row); a hair inside, the walks span the square
    A, b = np.vstack([np.eye(2), -np.eye(2)]), np.ones(4)
    c = np.array([1.0, 0.0])
    assert K.walk_width_lower_bound(A, b, np.array([1.0, 0.0]), c, 8, 0.99, np.inf) == -np.inf
    lower = K.walk_width_lower_bound(A, b, np.array([1.0 - 1e-3, 0.0]), c, 8, 0.99, np.inf)
    assert 1.97 < lower < 2.0


@pytest.mark.parametrize("seed", range(10))
def test_numpy_twin_gives_the_kernels_bits(seed):
    tier_up()  # the kernel name reaches the compiled kernel (or the plain Python loops without numba's cache)
    rng = np.random.default_rng(200 + seed)
    d = int(rng.integers(2, 14))
    if seed % 2:
        A, b = _slab(rng, d, 1e-7, 2)
        normals = A[2 * d::2]
        c = np.linalg.svd(normals)[2][-1] * 1e-4
    else:
        A, b = _polytope(rng, 40, d)
        c = rng.normal(size=d)
    p = rng.uniform(-1e-8, 1e-8, d)
    for steps, target in ((8, np.inf), (8, 1e-3), (3, np.inf)):
        kernel = K.walk_width_lower_bound(A, b, p, c, steps, 0.99, target)
        twin = K._walk_width_numpy(A, b, p, c, steps, 0.99, target)
        assert np.array_equal(np.float64(kernel), np.float64(twin))


@pytest.mark.parametrize("seed", range(40))
def test_certified_width_below_answers_the_same_with_the_walks(seed):
    """Sets thinner and wider than the threshold: the walks only ever skip LPs whose answer is "no"."""
    rng = np.random.default_rng(300 + seed)
    d = int(rng.integers(3, 10))
    thickness = 10.0 ** rng.uniform(-8, -4)
    A, b = _slab(rng, d, thickness, n_walls=1)
    normal = A[2 * d]
    flat = np.linalg.svd(normal[None, :])[2][1:]
    mix = rng.uniform(0.0, 1.0)
    c = mix * normal + (1 - mix) * 1e-5 * flat[0]  # widths from ~1e-8 to ~1e-5 around 2e-6
    width = 2e-6
    with_point = certified_width_below(A, b, c, radius_bound=2.0 * np.sqrt(d), width=width, point=np.zeros(d))
    without = certified_width_below(A, b, c, radius_bound=2.0 * np.sqrt(d), width=width)
    assert with_point == without
    truth = _true_width(A, b, c)
    if abs(truth - width) > 1e-9:
        assert without == (truth <= width)

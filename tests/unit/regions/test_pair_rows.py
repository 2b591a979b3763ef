"""The rows of the pair sets ``R_ij`` on their output-equality subspaces (``PairAlgebra.restricted_rows``).

Oracles: NumPy's products and least squares on the pair set written out over ``w = (x, x^, U)``
(to rounding: another summation order), and plain Python float loops in the documented order
(bit for bit: the restricted rows are defined as those sums).
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt import get_example
from hybobs_opt._numba_cache import tier_up
from hybobs_opt.geometry._lp_kernels import restricted_region_rows
from hybobs_opt.regions import enumerate_modes
from hybobs_opt.regions.pair_algebra import PairAlgebra, ScaledRows, _scaled_regions, pack_scaled, unpack_scaled


@pytest.fixture(scope="module")
def model17_T5():
    enum = enumerate_modes(get_example("powertrain5").build(), 5)
    return enum, _scaled_regions(enum)


def _python_rows(Hx, HU, N, off):
    """``Hx N[off:off + n] + HU N[2n:]``, each entry summed over the columns in order, every term kept."""
    n, q = Hx.shape[1], N.shape[1]
    G = np.zeros((Hx.shape[0], q))
    for row in range(Hx.shape[0]):
        for c in range(q):
            acc = 0.0
            for t in range(n):
                acc += float(Hx[row, t]) * float(N[off + t, c])
            for t in range(HU.shape[1]):
                acc += float(HU[row, t]) * float(N[2 * n + t, c])
            G[row, c] = acc
    return G


def test_restricted_region_rows_are_the_ordered_sums_bit_for_bit():
    """Skipping the zero coefficients changes no bit: zeros of either sign, cancellations to zero."""
    tier_up()
    rng = np.random.default_rng(3)
    n, mU, q = 3, 5, 4
    Hx = rng.normal(size=(12, n))
    HU = rng.normal(size=(12, mU))
    HU[rng.random(HU.shape) < 0.6] = 0.0
    HU[1, :2] = -0.0
    Hx[2] = 0.0
    N = rng.normal(size=(2 * n + mU, q))
    N[2 * n] = -N[2 * n + 1]  # exact cancellations when both coefficients are equal
    HU[3, :2] = 1.0
    for off in (0, n):
        got = restricted_region_rows(Hx, HU, N, off)
        want = _python_rows(Hx, HU, N, off)
        assert np.array_equal(got, want)
        assert np.array_equal(np.signbit(got), np.signbit(want))


def test_scaled_rows_are_stacked_views_and_pack_round_trip(model17_T5):
    enum, sc = model17_T5
    assert isinstance(sc, ScaledRows) and len(sc) == len(enum.regions)
    for k in (0, len(sc) // 2, len(sc) - 1):
        Hx, HU, h, C, D, f = sc[k]
        a, b = sc.offsets[k], sc.offsets[k + 1]
        assert np.shares_memory(Hx, sc.Hx) and np.array_equal(Hx, sc.Hx[a:b]) and np.array_equal(C, sc.C[k])
        assert Hx.shape[0] == enum.regions[k].H.shape[0]
    back, n = unpack_scaled(pack_scaled(sc, enum.system.n))
    assert n == enum.system.n and len(back) == len(sc)
    for k in range(len(sc)):
        assert all(np.array_equal(x, y) for x, y in zip(back[k], sc[k]))
    # a plain list of tuples (an algebra built by hand) gives the same algebra
    listed = PairAlgebra([sc[k] for k in range(len(sc))], n)
    stacked = PairAlgebra(sc, n)
    js = np.arange(1, len(sc), 7)
    for r1, r2 in zip(listed.restricted_rows(0, js), stacked.restricted_rows(0, js)):
        assert (r1 is None) == (r2 is None)
        if r1 is not None:
            assert np.array_equal(r1.Gv, r2.Gv) and np.array_equal(r1.gv, r2.gv) and r1.radius_bound == r2.radius_bound


@pytest.mark.parametrize("i", [0, 17, 40])
def test_restricted_rows_against_numpy_on_the_full_pair_set(model17_T5, i):
    """Per ``j`` (every output-map class mixed in one call): ``None`` exactly when the output
    equalities have no solution, else ``Gv = [P_i; P_j] N`` and ``gv = h - [P_i; P_j] w0`` with
    ``E w0 = e``, ``E N = 0``, ``N`` orthonormal, and the radius bound ``sqrt(2n + mU) + |w0|``."""
    tier_up()
    enum, sc = model17_T5
    n = enum.system.n
    alg = PairAlgebra(sc, n)
    i = min(i, len(sc) - 1)
    js = np.array([j for j in range(len(sc)) if j != i])
    HxI, HUI, hI, CI, DI, fI = sc[i]
    n_consistent = 0
    for j, rows in zip(js, alg.restricted_rows(i, js)):
        HxJ, HUJ, hJ, CJ, DJ, fJ = sc[j]
        E = np.hstack([CI, -CJ, DI - DJ])
        e = fJ - fI
        w_ls = np.linalg.lstsq(E, e, rcond=None)[0]
        resid = np.linalg.norm(E @ w_ls - e)
        if rows is None:
            assert resid > 1e-9 * (1 + np.linalg.norm(e))
            continue
        n_consistent += 1
        assert resid <= 1e-9 * (1 + np.linalg.norm(e))
        N, w0 = rows.N, rows.w0
        assert np.allclose(N.T @ N, np.eye(N.shape[1]), atol=1e-12)
        assert np.max(np.abs(E @ N), initial=0.0) <= 1e-10
        assert np.allclose(E @ w0, e, atol=1e-10)
        assert np.allclose(w0, w_ls, atol=1e-9)  # the minimum-norm solution
        mU = HUI.shape[1]
        H = np.vstack([np.hstack([HxI, np.zeros_like(HxI), HUI]), np.hstack([np.zeros_like(HxJ), HxJ, HUJ])])
        assert np.allclose(rows.Gv, H @ N, atol=1e-12)
        assert np.allclose(rows.gv, np.concatenate([hI, hJ]) - H @ w0, atol=1e-12)
        assert rows.radius_bound == pytest.approx(np.sqrt(2 * n + mU) + np.linalg.norm(w0), rel=1e-14)
    assert n_consistent > 0


def test_chebyshev_point_witnessed_only_where_the_row_check_passes(model17_T5):
    """The Chebyshev LP's point stands for the set without a second pass over the rows only when
    DAQP's certified lower bound (its smallest row slack) clears ``-CLOSED_SET_TOL``: there the
    row check of ``_witness`` passes, on every pair set of model (17) at ``T = 5``."""
    from hybobs_opt.regions.pair_geometry import _chebyshev, _witness
    from hybobs_opt.tolerances import CLOSED_SET_TOL

    tier_up()
    enum, sc = model17_T5
    alg = PairAlgebra(sc, enum.system.n)
    seen = {True: 0, False: 0}
    for i in range(0, len(sc), 3):
        js = np.arange(i + 1, len(sc))
        for rows in alg.restricted_rows(i, js):
            if rows is None:
                continue
            lp = _chebyshev(rows.Gv, rows.gv, rows.radius_bound, -CLOSED_SET_TOL, "test")
            if lp.centre is None or lp.A.shape[0] <= 1:
                continue
            seen[lp.witnessed] += 1
            if lp.witnessed:
                assert _witness(lp.centre, lp.A, lp.bu) is not None
    assert seen[True] > 100 and seen[False] > 10


def _python_equality_subspace(E, n):
    from hybobs_opt.geometry._reproducible import numerical_rank, svd
    from hybobs_opt.regions.pair_geometry import SubspaceDirections
    from hybobs_opt.tolerances import RANK_RTOL

    U, s, Vt = svd(E, full_matrices=True)
    r = numerical_rank(s, RANK_RTOL)
    N = np.ascontiguousarray(Vt[r:].T)
    return U, s, Vt, r, N, SubspaceDirections.of(N, n, (E, r))


def _equality_cases(sc, n):
    alg = PairAlgebra(sc, n)
    for a in range(alg.C.shape[0]):
        for b in range(0, alg.C.shape[0], 3):
            yield np.hstack([alg.C[a], -alg.C[b], alg.D[a] - alg.D[b]])
    rng = np.random.default_rng(8)
    for p, k in ((3, 2 * n + 4), (2 * n + 6, 2 * n + 4), (1, 2 * n), (4, 2 * n + 1)):
        E = rng.normal(size=(p, k))
        E[-1] = E[0] * 2.0  # rank deficient
        yield E


def test_equality_subspace_in_one_call_is_the_svd_path_bit_for_bit(model17_T5):
    """The compiled equality subspace of a class pair (SVD, rank, nullspace, the projections' ranks
    and thinnest functionals, the same-state rank test) gives the bits of the path through ``svd``:
    every class pair of model (17) at ``T = 5`` and random rank-deficient, tall and wide systems."""
    from hybobs_opt.geometry._reproducible import COMPILED, equality_subspace
    from hybobs_opt.tolerances import RANK_RTOL

    tier_up()
    enum, sc = model17_T5
    n = enum.system.n
    n_same = n_full = 0
    for E in _equality_cases(sc, n):
        got = equality_subspace(E, n, RANK_RTOL)
        if not COMPILED:
            assert got is None
            continue
        U, s, Vt, r, N, full, thin, thin_norm, same, D = got
        U2, s2, Vt2, r2, N2, d2 = _python_equality_subspace(E, n)
        assert np.array_equal(U, U2) and np.array_equal(s, s2) and np.array_equal(Vt, Vt2) and r == r2
        assert np.array_equal(N, N2) and np.array_equal(D, d2.state_difference)
        assert (bool(full[0]), bool(full[1])) == d2.full_rank and bool(same) == d2.same_state_directions
        assert all(np.array_equal(thin[k], d2.thinnest[k]) for k in range(2))
        assert (float(thin_norm[0]), float(thin_norm[1])) == d2.thinnest_norm
        n_same += bool(same)
        n_full += bool(full[0])
    assert not COMPILED or (n_same > 0 and n_full > 0)
    assert equality_subspace(np.array([[1.0, np.nan, 0.0, 0.0]]), 1, RANK_RTOL) is None

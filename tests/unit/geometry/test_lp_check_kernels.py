"""The compiled checks of DAQP answers (issue 19) against their numpy definitions, written out here.

``daqp_answer_ok``, ``min_row_slack`` and ``implicit_row_bounds`` moved from numpy expressions to
numba loops because the numpy versions cost more than the DAQP solves they check.  Each is
compared with the numpy formula it replaced, on random data and on the corruptions the checks
exist for (NaN / Inf entries, negative multipliers, a violated row).
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.geometry._lp_kernels import checked_slack_bounds, implicit_row_bounds, min_row_slack, slack_bounds
from hybobs_opt.geometry.lp import daqp_answer_ok
from hybobs_opt.tolerances import DAQP_POINT_RTOL


def numpy_answer_ok(A, b, x, lam) -> bool:
    x, lam = np.asarray(x, float), np.asarray(lam, float)
    if x.shape != (A.shape[1],) or lam.shape != (A.shape[0],) or not (np.all(np.isfinite(x)) and np.all(np.isfinite(lam))):
        return False
    if np.min(lam, initial=0.0) < -DAQP_POINT_RTOL * max(1.0, float(np.max(np.abs(lam), initial=0.0))):
        return False
    return bool(np.all(A @ x - b <= DAQP_POINT_RTOL * (1.0 + np.abs(b) + np.abs(A) @ np.abs(x))))


def numpy_implicit_row_bounds(G, g, lam, R, relax):
    lam = np.where(np.isfinite(lam), np.maximum(lam, 0.0), 0.0)
    total = float((g + relax) @ lam + R * np.linalg.norm(G.T @ lam))
    with np.errstate(divide="ignore"):
        return np.where(lam > 0.0, max(total, 0.0) / np.where(lam > 0.0, lam, 1.0), np.inf)


def _case(rng, k=30, d=6):
    A = rng.normal(size=(k, d))
    x = rng.normal(size=d)
    b = A @ x + rng.uniform(0.0, 1.0, k)  # x feasible
    lam = np.abs(rng.normal(size=k)) * (rng.random(k) < 0.3)
    return A, b, x, lam


@pytest.mark.parametrize("seed", range(40))
def test_daqp_answer_ok_equals_the_numpy_checks(seed):
    rng = np.random.default_rng(seed)
    A, b, x, lam = _case(rng)
    corruptions = [
        lambda A, b, x, lam: (A, b, x, lam),
        lambda A, b, x, lam: (A, b, x + A[0] * (b[0] - A[0] @ x + 1.0) / (A[0] @ A[0]), lam),  # row 0 violated by 1
        lambda A, b, x, lam: (A, b, np.where(np.arange(x.size) == 2, np.nan, x), lam),
        lambda A, b, x, lam: (A, b, np.where(np.arange(x.size) == 1, np.inf, x), lam),
        lambda A, b, x, lam: (A, b, x, -lam - 1.0),
        lambda A, b, x, lam: (A, b, x, np.where(np.arange(lam.size) == 3, np.nan, lam)),
        lambda A, b, x, lam: (A, b, x, lam - 0.5 * DAQP_POINT_RTOL),  # within the tolerance
        lambda A, b, x, lam: (A, b - 1e-7 * (1 + np.abs(b)), x, lam),  # rows violated by 1e-7: accepted
        lambda A, b, x, lam: (A, b, x[:-1], lam),
    ]
    outcomes = []
    for corrupt in corruptions:
        args = corrupt(A, b, x, lam)
        got, want = daqp_answer_ok(*args), numpy_answer_ok(*args)
        assert got == want, (seed, corruptions.index(corrupt))
        outcomes.append(got)
        # the fused check of the slack LPs: the same verdict, then slack_bounds' bits
        Ac, bc, xc, lc = (np.ascontiguousarray(v, dtype=float) for v in args)
        ok, lower, upper = checked_slack_bounds(Ac, bc, xc, lc, DAQP_POINT_RTOL, 3.0, 5.0)
        assert ok == want
        if ok:
            assert (lower, upper) == slack_bounds(Ac, bc, xc, lc, 3.0, 5.0)
        else:
            assert (lower, upper) == (-np.inf, np.inf)
    assert outcomes[0] and not outcomes[1] and not outcomes[2] and not outcomes[4]


def test_daqp_answer_ok_refuses_missing_multipliers():
    A, b, x, _ = _case(np.random.default_rng(0))
    assert not daqp_answer_ok(A, b, x, None)


@pytest.mark.parametrize("seed", range(20))
def test_min_row_slack_and_implicit_row_bounds_equal_numpy(seed):
    rng = np.random.default_rng(100 + seed)
    A, b, x, lam = _case(rng)
    Acap = np.vstack([np.hstack([A, np.ones((A.shape[0], 1))]), np.eye(1, A.shape[1] + 1, A.shape[1])])
    bcap = np.append(b, 5.0)
    assert min_row_slack(Acap, bcap, x) == pytest.approx(float(np.min(b - A @ x)), rel=1e-12, abs=1e-14)
    lam[rng.integers(0, lam.size)] = np.nan
    for relax in (0.0, 1e-9):
        got = implicit_row_bounds(A, b, lam, 3.0, relax)
        want = numpy_implicit_row_bounds(A, b, lam, 3.0, relax)
        assert np.array_equal(np.isinf(got), np.isinf(want))
        fin = np.isfinite(want)
        assert np.allclose(got[fin], want[fin], rtol=1e-12, atol=0.0)



def test_max_abs_affine_is_the_ordered_numpy_expression_bit_for_bit():
    """The distinct-state check at a point: ``max |M c + c0|`` with the products summed in order
    (the bits of ``matmul``), NaN propagated as NumPy's ``max`` does (a NaN never reads as "apart")."""
    from hybobs_opt._numba_cache import tier_up
    from hybobs_opt.geometry._lp_kernels import max_abs_affine
    from hybobs_opt.geometry._reproducible import matmul

    tier_up()
    rng = np.random.default_rng(41)
    for trial in range(60):
        k, d = (int(v) for v in rng.integers(1, 12, size=2))
        M = rng.normal(size=(k, d)) * 10.0 ** rng.integers(-9, 3, size=(k, d))
        c, c0 = rng.normal(size=d), rng.normal(size=k) * 1e-8
        if trial % 5 == 0:
            c0 = -matmul(M, c)  # the point has x = x^ up to rounding: tiny gaps, decided by their bits
        assert max_abs_affine(M, c, c0) == np.max(np.abs(matmul(M, c) + c0))
    M, c = np.ones((3, 2)), np.array([1.0, np.nan])
    assert np.isnan(max_abs_affine(M, c, np.zeros(3)))
    assert max_abs_affine(np.zeros((0, 2)), np.zeros(2), np.zeros(0)) == -np.inf


@pytest.mark.parametrize("seed", range(10))
def test_slack_lp_rows_against_the_normalised_rows(seed):
    """The slack LP's data: the non-constant rows divided by their norms (``keep`` names them, in
    order), a column of ones for ``t``, the cap row last; a violated constant row: empty."""
    from hybobs_opt.geometry._lp_kernels import slack_lp_data, slack_lp_rows

    rng = np.random.default_rng(300 + seed)
    G, g = rng.normal(size=(25, 4)), rng.normal(size=25)
    G[rng.random(25) < 0.2] = 0.0
    g[np.all(G == 0.0, axis=1)] = np.abs(g[np.all(G == 0.0, axis=1)])  # constant rows that hold
    A, bu, ok, keep = slack_lp_rows(G, g, 1e-12, 7.0)
    nrm = np.linalg.norm(G, axis=1)
    assert ok and keep.tolist() == np.nonzero(nrm > 1e-12)[0].tolist()
    assert np.allclose(A[:-1, :-1], G[keep] / nrm[keep, None], rtol=1e-15, atol=0.0)
    assert np.all(A[:, -1] == 1.0) and np.all(A[-1, :-1] == 0.0) and bu[-1] == 7.0
    assert np.allclose(bu[:-1], g[keep] / nrm[keep], rtol=1e-15, atol=0.0)
    A2, bu2, ok2 = slack_lp_data(G, g, 1e-12, 7.0)
    assert ok2 and np.array_equal(A, A2) and np.array_equal(bu, bu2)
    g[np.nonzero(nrm <= 1e-12)[0][:1]] = -1.0
    if np.any(nrm <= 1e-12):
        assert not slack_lp_rows(G, g, 1e-12, 7.0)[2] and not slack_lp_data(G, g, 1e-12, 7.0)[2]

"""The reproducible linear algebra of the decision paths (``hybobs_opt.geometry._reproducible``).

Oracles: plain Python float loops in the documented order (bit for bit: the products are defined
as those sums), LAPACK through NumPy and SciPy's NNLS (to rounding: another algorithm), and
child processes with other OpenBLAS kernels (bit for bit: the point of the module).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from scipy.optimize import nnls as scipy_nnls

from hybobs_opt._numba_cache import tier_up
from hybobs_opt.defaults import JACOBI_MAX_SWEEPS
from hybobs_opt.geometry import _reproducible as R
from hybobs_opt.tolerances import JACOBI_TOL


def _python_matmul(A, B):
    """``A @ B`` by Python floats (IEEE double, no FMA), each entry summed over the inner index in order."""
    m, k = A.shape
    n = B.shape[1]
    C = [[0.0] * n for _ in range(m)]
    for i in range(m):
        for j in range(n):
            acc = 0.0
            for t in range(k):
                acc += float(A[i, t]) * float(B[t, j])
            C[i][j] = acc
    return np.array(C, dtype=float).reshape(m, n)


@pytest.mark.parametrize("shape", [(1, 1, 1), (3, 7, 2), (9, 19, 9), (19, 9, 1), (4, 0, 3), (0, 3, 2)])
def test_matmul_is_the_ordered_sum_bit_for_bit(shape):
    m, k, n = shape
    rng = np.random.default_rng(sum(shape))
    A = rng.normal(size=(m, k)) * 10.0 ** rng.integers(-8, 8, size=(m, k))
    B = rng.normal(size=(k, n)) * 10.0 ** rng.integers(-8, 8, size=(k, n))
    want = _python_matmul(A, B)
    assert np.array_equal(R.matmul(A, B), want)
    assert np.array_equal(R._matmul_numpy(A, B), want)  # the mirror used while kernels are not compiled
    if m and n:
        assert np.array_equal(R.matmul(A[0], B), want[0])  # vector @ matrix
        assert np.array_equal(R.matmul(A, B[:, 0]), want[:, 0])  # matrix @ vector
        assert R.dot(A[0], B[:, 0]) == want[0, 0]
    assert np.all(np.abs(R.matmul(A, B) - A @ B) <= 1e-13 * (np.abs(A) @ np.abs(B)))


def test_matmul_refuses_what_is_not_a_vector_or_matrix():
    with pytest.raises(ValueError, match="1-D or 2-D"):
        R.matmul(np.zeros((2, 2, 2)), np.zeros(2))
    with pytest.raises(ValueError, match="1-D or 2-D"):
        R.matmul(np.float64(2.0), np.zeros(2))


def test_norms_are_ordered_sums():
    rng = np.random.default_rng(3)
    X = rng.normal(size=(5, 7))
    for row, value in zip(X, R.row_norms(X)):
        acc = 0.0
        for v in row:
            acc += float(v) * float(v)
        assert value == np.sqrt(acc)
        assert R.norm(row) == np.sqrt(acc)


def _graded(rng, m, k):
    """``m x k`` with singular values spread over up to 40 decades (LAPACK's answer as the reference)."""
    p = min(m, k)
    Q1 = np.linalg.qr(rng.normal(size=(m, m)))[0]
    Q2 = np.linalg.qr(rng.normal(size=(k, k)))[0]
    sv = np.sort(10.0 ** (-rng.uniform(0, 40, size=p)))[::-1] * 10.0 ** rng.uniform(-5, 5)
    return (Q1[:, :p] * sv) @ Q2[:, :p].T


@pytest.mark.parametrize("seed", range(40))
def test_svd_against_lapack(seed):
    rng = np.random.default_rng(seed)
    m, k = (int(v) for v in rng.integers(1, 16, size=2))
    A = _graded(rng, m, k) if seed % 2 else rng.normal(size=(m, k))
    if seed % 3 == 0 and m > 2:
        A[-1] = A[0] - A[1]  # an exact dependence
    U, s, Vt = R.svd(A)
    s_ref = np.linalg.svd(A, compute_uv=False)
    p = min(m, k)
    assert U.shape == (m, m) and s.shape == (p,) and Vt.shape == (k, k)
    assert np.all(np.diff(s) <= 0.0) and np.all(s >= 0.0)
    assert np.max(np.abs(s - s_ref)) <= 1e-13 * s_ref[0]
    assert np.max(np.abs(U.T @ U - np.eye(m))) <= 1e-13
    assert np.max(np.abs(Vt @ Vt.T - np.eye(k))) <= 1e-13
    assert np.max(np.abs((U[:, :p] * s) @ Vt[:p] - A)) <= 1e-13 * s_ref[0]
    r = R.numerical_rank(s, 1e-12)
    assert r == int(np.sum(s_ref > 1e-12 * s_ref[0])) or abs(np.log10(s_ref[r - 1 if r else 0] / s_ref[0]) + 12) < 0.5
    if r < k:  # the nullspace basis: A N = 0 to rounding
        assert np.max(np.abs(A @ Vt[r:].T)) <= 1e-12 * s_ref[0]
    Uf, sf, Vtf = R.svd(A, full_matrices=False)
    assert Uf.shape == (m, p) and Vtf.shape == (p, k)
    assert np.array_equal(R.svd(A, compute_uv=False), s)


def test_svd_of_degenerate_matrices():
    for A in (np.zeros((3, 5)), np.zeros((0, 4)), np.ones((4, 1)), np.eye(3)):
        U, s, Vt = R.svd(A)
        m, k = A.shape
        assert U.shape == (m, m) and Vt.shape == (k, k)
        assert np.allclose(U.T @ U, np.eye(m)) and np.allclose(Vt @ Vt.T, np.eye(k))
        assert np.allclose(s, np.linalg.svd(A, compute_uv=False))
    with pytest.raises(ValueError, match="non-finite"):
        R.svd(np.array([[1.0, np.nan]]))


def test_jacobi_and_completion_mirrors_are_the_kernels_bit_for_bit():
    """The NumPy mirrors (used while the kernels are not compiled) and the kernels do the same operations."""
    rng = np.random.default_rng(11)
    for m, k in ((19, 9), (7, 7), (12, 3)):
        A = _graded(rng, m, k)
        W1, V1, W2, V2 = A.copy(), np.eye(k), A.copy(), np.eye(k)
        n1 = R._jacobi_kernel(W1, V1, JACOBI_TOL, 1e-300, JACOBI_MAX_SWEEPS)
        n2 = R._jacobi_numpy(W2, V2, JACOBI_TOL, 1e-300, JACOBI_MAX_SWEEPS)
        assert n1 == n2 and np.array_equal(W1, W2) and np.array_equal(V1, V2)
        Q1 = np.zeros((m, m))
        Q1[:, :2] = np.linalg.qr(rng.normal(size=(m, 2)))[0]
        Q2 = Q1.copy()
        R._complete_kernel(Q1, 2)
        R._complete_numpy(Q2, 2)
        assert np.array_equal(Q1, Q2)
        assert np.allclose(Q1.T @ Q1, np.eye(m), atol=1e-14)


def test_batched_singular_values_are_the_svds_bits():
    """The batch kernel (the rank screen of the pair algebra) and its NumPy mirror give the bits
    of :func:`svd` on each matrix, tall, wide, rank-deficient and graded, and LAPACK's values to
    rounding; ``numerical_ranks`` is ``numerical_rank`` row by row."""
    rng = np.random.default_rng(17)
    for nb, m, k in ((30, 6, 4), (30, 4, 6), (12, 9, 9), (5, 12, 1), (3, 0, 2), (0, 3, 2)):
        M = np.stack([_graded(rng, m, k) for _ in range(nb)]) if m and nb else np.zeros((nb, m, k))
        if nb and k > 1 and m:
            M[::3, :, -1] = 2.0 * M[::3, :, 0]  # rank deficient
            M[1::4] *= 1e-200  # tiny scale: the power-of-two scaling keeps the bits
        S = R.singular_values(M)
        assert S.shape == (nb, min(m, k))
        per = np.array([R.svd(Mk, compute_uv=False) for Mk in M]).reshape(S.shape)
        assert np.array_equal(S, per)
        tall = np.ascontiguousarray(M if m >= k else M.transpose(0, 2, 1))
        if nb and min(m, k):
            assert np.array_equal(R._singular_values_numpy(tall, JACOBI_TOL, JACOBI_MAX_SWEEPS),
                                  R._singular_values_kernel(tall, JACOBI_TOL, JACOBI_MAX_SWEEPS))
            ref = np.linalg.svd(M, compute_uv=False)
            assert np.allclose(S, ref, rtol=1e-12, atol=1e-13 * np.max(ref, axis=1, keepdims=True).max())
        ranks = R.numerical_ranks(S, 1e-9)
        assert ranks.tolist() == [R.numerical_rank(s, 1e-9) for s in S]
    with pytest.raises(ValueError, match="non-finite"):
        R.singular_values(np.array([[[1.0, np.inf]]]))


def test_lstsq_and_nnls_against_numpy_and_scipy():
    rng = np.random.default_rng(5)
    for trial in range(30):
        m, k = (int(v) for v in rng.integers(1, 10, size=2))
        A, b = rng.normal(size=(m, k)), rng.normal(size=m)
        if trial % 4 == 0 and k > 1:
            A[:, -1] = A[:, 0]  # rank-deficient: the minimum-norm solution
        assert np.allclose(R.lstsq(A, b), np.linalg.lstsq(A, b, rcond=None)[0], atol=1e-10)
        x, res = R.nnls(A, b)
        x_ref, res_ref = scipy_nnls(A, b)
        assert np.all(x >= 0.0)
        assert res == pytest.approx(res_ref, rel=1e-9, abs=1e-12)
        # the KKT conditions of the non-negative least-squares problem, checked directly
        grad = A.T @ (A @ x - b)
        assert np.all(grad >= -1e-9 * (1 + np.abs(A).T @ np.abs(b)))
        assert np.all(np.abs(grad[x > 0]) <= 1e-9 * (1 + np.abs(A).T @ np.abs(b))[x > 0])


def _nnls_cases(rng):
    """Random NNLS problems: tall, wide, rank-deficient, and the multiplier fits of the pair tests
    (``[G_A'; 1] lam = e_last``: unit rows with a sum-to-one row)."""
    for trial in range(400):
        m, k = (int(v) for v in rng.integers(1, 16, size=2))
        A, b = rng.normal(size=(m, k)) * 10.0 ** rng.integers(-3, 3), rng.normal(size=m)
        if trial % 3 == 0 and k > 1:
            A[:, -1] = A[:, 0]
        if trial % 4 == 0:
            G = rng.normal(size=(k, m))
            G /= np.linalg.norm(G, axis=1, keepdims=True)
            A, b = np.vstack([G.T, np.ones((1, k))]), np.append(np.zeros(m), 1.0)
        yield np.ascontiguousarray(A), b


def test_compiled_nnls_is_the_numpy_twin_bit_for_bit():
    """The one-call NNLS kernel gives the bits of the NumPy active-set method (every iterate's least
    squares by the reproducible SVD), its status at the iteration limit included; a NaN sends
    :func:`nnls` to the NumPy method, whose answer it returns."""
    tier_up()  # the kernel name reaches the compiled kernel (or the plain Python loops without numba's cache)
    rng = np.random.default_rng(31)
    n_limit = 0
    for A, b in _nnls_cases(rng):
        for limit in (3 * A.shape[1], 1):
            got = R._nnls_kernel(A, b, limit, JACOBI_TOL, JACOBI_MAX_SWEEPS)
            want = R._nnls_python(A, b, limit, JACOBI_TOL, JACOBI_MAX_SWEEPS)
            assert got[2] == want[2] and np.array_equal(got[0], want[0]) and got[1] == want[1]
            n_limit += want[2] == 1
    assert n_limit > 50  # the limit was reached, and reported alike
    with pytest.raises(RuntimeError, match="iteration limit"):
        R.nnls(*next(_nnls_cases(np.random.default_rng(31))), max_iter=0)
    A = np.array([[1.0, np.nan], [0.5, 2.0]])
    assert R._nnls_kernel(A, np.ones(2), 6, JACOBI_TOL, JACOBI_MAX_SWEEPS)[2] == 2
    x, res = R.nnls(A, np.ones(2))
    want = R._nnls_python(A, np.ones(2), 6, JACOBI_TOL, JACOBI_MAX_SWEEPS)
    assert np.array_equal(x, want[0]) and (res == want[1] or (np.isnan(res) and np.isnan(want[1])))
    with pytest.raises(ValueError, match="nnls"):
        R.nnls(np.ones((3, 2)), np.ones(2))


_CHILD = r"""
import hashlib, json, numpy as np
from hybobs_opt.geometry import _reproducible as R
rng = np.random.default_rng(7)
out = []
for m, k in ((9, 19), (19, 9), (6, 6)):
    A = rng.normal(size=(m, k)) * 10.0 ** rng.integers(-6, 6, size=(m, k))
    U, s, Vt = R.svd(A)
    C = R.matmul(A, A.T)
    out.append(hashlib.sha256(U.tobytes() + s.tobytes() + Vt.tobytes() + C.tobytes() + R.lstsq(A, A[:, 0]).tobytes()).hexdigest())
print(json.dumps(out))
"""


def test_same_bits_with_other_blas_kernels_and_thread_counts():
    """What differs between CPUs can be chosen on one: OpenBLAS's kernels and threads, NumPy's SIMD."""
    answers = {}
    for name, env in {"two_threads": {"OPENBLAS_NUM_THREADS": "2"}, "haswell": {"OPENBLAS_CORETYPE": "Haswell"},
                      "prescott_1_thread": {"OPENBLAS_CORETYPE": "Prescott", "OPENBLAS_NUM_THREADS": "1"},
                      "numpy_without_avx2": {"NPY_DISABLE_CPU_FEATURES": "AVX2 FMA3 AVX512F AVX512CD AVX512_SKX"}}.items():
        proc = subprocess.run([sys.executable, "-c", _CHILD], env={**os.environ, **env}, capture_output=True, text=True)
        if name == "numpy_without_avx2" and proc.returncode != 0 and "NPY_DISABLE_CPU_FEATURES" in proc.stderr:
            continue  # a CPU without these features: nothing to disable
        assert proc.returncode == 0, proc.stderr[-2000:]
        answers[name] = json.loads(proc.stdout.strip().splitlines()[-1])
    assert len({json.dumps(v) for v in answers.values()}) == 1, answers


def test_one_call_svd_kernel_is_the_mirror_bit_for_bit():
    """The compiled SVD in one call gives the bits of the NumPy mirror (scaling, Jacobi, sorting with
    ties, completion of a rank-deficient ``U``), graded, tiny, repeated and zero columns included."""
    rng = np.random.default_rng(23)
    cases = [_graded(rng, m, k) for m, k in ((19, 9), (7, 7), (12, 3), (5, 1))]
    twin = _graded(rng, 8, 4)
    twin[:, 2] = twin[:, 0]  # a repeated column: rank deficient
    cases += [twin, np.zeros((4, 3)), 1e-200 * _graded(rng, 6, 4), np.eye(4)[:, [2, 0, 1]]]
    for A in cases:
        A = np.ascontiguousarray(A)
        U1, s1, V1 = R._svd_tall_numpy(A)
        U2, s2, V2, ok = R._svd_tall_kernel(A, JACOBI_TOL, JACOBI_MAX_SWEEPS)
        assert ok and np.array_equal(U1, U2) and np.array_equal(s1, s2) and np.array_equal(V1, V2)
    assert not R._svd_tall_kernel(np.array([[1.0], [np.nan]]), JACOBI_TOL, JACOBI_MAX_SWEEPS)[3]


def test_vector_products_and_norm_kernels_are_the_ordered_sums():
    """matmul's matrix-vector, vector-matrix and vector-vector kernels, and norm, give the bits of the
    2-D kernel / the ordered sum in NumPy on graded data with cancellation; mismatched shapes refuse."""
    rng = np.random.default_rng(29)
    A = _graded(rng, 9, 6)
    x, y = rng.normal(size=6) * 10.0 ** rng.integers(-8, 8, size=6), rng.normal(size=9)
    assert np.array_equal(R.matmul(A, x), R._matmul_numpy(A, x.reshape(-1, 1))[:, 0])
    assert np.array_equal(R.matmul(y, A), R._matmul_numpy(y.reshape(1, -1), A)[0])
    assert R.matmul(x, x[::-1].copy()) == R._matmul_numpy(x.reshape(1, -1), x[::-1].reshape(-1, 1))[0, 0]
    assert isinstance(R.matmul(x, x), np.float64)
    assert R.norm(A) == float(np.sqrt(np.cumsum(np.ravel(A) ** 2)[-1]))
    assert R.norm(np.zeros(0)) == 0.0
    with pytest.raises(ValueError, match="do not match"):
        R.matmul(A, y)


def test_row_norms_kernel_is_the_numpy_twin_bit_for_bit():
    """The compiled row norms (columns outermost) and the NumPy twin give the same bits, on graded
    rows with cancellation-free squares spread over many decades, a zero row and no columns."""
    tier_up()
    rng = np.random.default_rng(31)
    X = _graded(rng, 40, 14) * 10.0 ** rng.integers(-100, 100, size=(40, 1))
    X[3] = 0.0
    for M in (X, np.zeros((3, 0)), np.zeros((0, 4))):
        assert np.array_equal(R.row_norms(M), R._row_norms_numpy(M))
    with pytest.raises(ValueError, match="2-D"):
        R.row_norms(np.ones(3))


def _affine_hull_numpy(E, e, rank_rtol, consistency_rtol, closed_tol):
    """The NumPy operations the affine-hull kernel writes out (row norms, svd, rank, matmul)."""
    nrm = R._row_norms_numpy(E)
    E, e = E / nrm[:, None], e / nrm
    U, s, Vt = R.svd(E, full_matrices=True)
    r = int(np.sum(s > rank_rtol * max(s[0], np.finfo(float).tiny)))
    if r == 0:
        return None
    t0 = R.matmul(Vt[:r].T, R.matmul(U[:, :r].T, e) / s[:r])
    if R.norm(R.matmul(E, t0) - e) > consistency_rtol * (1.0 + R.norm(e)) + closed_tol:
        return "empty"
    return Vt[r:].T, t0


@pytest.mark.parametrize("seed", range(12))
def test_affine_hull_kernel_is_the_numpy_operations_bit_for_bit(seed):
    """One compiled call gives the bits of the NumPy operations it replaces, on tall, wide and
    square row sets, with opposite normals (rank below the row count), consistent and contradicting
    right-hand sides; a zero row or a NaN falls back to NumPy (the same answer)."""
    tier_up()
    rng = np.random.default_rng(100 + seed)
    m, d = int(rng.integers(1, 9)), int(rng.integers(1, 14))
    E = _graded(rng, m, d) + rng.normal(size=(m, d))
    x = rng.normal(size=d)
    e = E @ x
    if m > 1 and seed % 3 == 0:
        E[1], e[1] = -E[0] * (1 + 1e-9), -e[0]  # the opposite normal of row 0: one direction pinned
    if seed % 4 == 1:
        e = e + rng.normal(size=m) * 1e-3  # contradicting rows when they are dependent
    for rtol in (1e-6, 1e-12):
        got = R.affine_hull(E, e, rtol, 1e-9, 1e-9)
        want = _affine_hull_numpy(E, e, rtol, 1e-9, 1e-9)
        if want is None or isinstance(want, str):
            assert got == want
        else:
            assert np.array_equal(got[0], want[0]) and np.array_equal(got[1], want[1])
            assert np.allclose(E @ (got[1] + got[0] @ rng.normal(size=got[0].shape[1])), e, atol=1e-6 * (1 + np.abs(e).max()))
    zero = E.copy()
    zero[0] = 0.0
    with np.errstate(divide="ignore", invalid="ignore"):
        with pytest.raises(ValueError, match="non-finite"):  # 0 / 0 rows: NumPy's svd refuses, as before
            R.affine_hull(zero, e, 1e-6, 1e-9, 1e-9)


@pytest.mark.parametrize("seed", range(12))
def test_span_width_bound_is_the_numpy_operations_bit_for_bit(seed):
    """The compiled bound ``sum |alpha| slack + 2 R |rho|`` gives the bits of lstsq, matmul and norm
    (tall, wide, rank-deficient row sets); no rows bound nothing (``inf``)."""
    tier_up()
    rng = np.random.default_rng(200 + seed)
    k, d = int(rng.integers(3, 30)), int(rng.integers(2, 14))
    G = rng.normal(size=(k, d))
    rows = np.sort(rng.choice(k, size=int(rng.integers(1, min(k, d + 3))), replace=False))
    if rows.size > 1 and seed % 2:
        G[rows[1]] = 3.0 * G[rows[0]]  # dependent rows
    slack = rng.uniform(0, 1e-6, size=rows.size)
    c = rng.normal(size=d) if seed % 3 else G[rows].T @ rng.normal(size=rows.size)
    GK = G[rows]
    alpha = R.lstsq(GK.T, c)
    rho = c - R.matmul(GK.T, alpha)
    want = float(R.matmul(np.abs(alpha), slack) + 2.0 * 5.0 * R.norm(rho))
    assert R.span_width_bound(G, rows, slack, c, 5.0) == want
    assert R.span_width_bound(G, rows[:0], slack[:0], c, 5.0) == np.inf


def test_batched_singular_values_side_by_side_keep_each_matrix_bits():
    """Four matrices run their Jacobi sweeps side by side: one with orthogonal columns (no rotation,
    done after one sweep), graded ones needing many sweeps, a rank-deficient and a zero one in the
    same group of four, and a batch that is not a multiple of four; each gives :func:`svd`'s bits."""
    rng = np.random.default_rng(37)
    m, k = 19, 9
    Q = np.linalg.qr(rng.normal(size=(m, k)))[0] * np.arange(1, k + 1)  # orthogonal columns
    deficient = _graded(rng, m, k)
    deficient[:, 4] = deficient[:, 1] - deficient[:, 2]
    mats = [Q, _graded(rng, m, k), deficient, np.zeros((m, k)), _graded(rng, m, k) * 1e-150,
            _graded(rng, m, k), Q[:, ::-1].copy(), _graded(rng, m, k) * 1e150, _graded(rng, m, k)]
    for count in (9, 8, 7, 6, 5):
        M = np.stack(mats[:count])
        S = R.singular_values(M)
        assert np.array_equal(S, np.array([R.svd(Mk, compute_uv=False) for Mk in M]))
        assert np.array_equal(S, R._singular_values_numpy(M, JACOBI_TOL, JACOBI_MAX_SWEEPS))


@pytest.mark.parametrize("seed", range(10))
def test_subspace_directions_kernel_is_the_svd_path_bit_for_bit(seed):
    """One compiled call gives what the pair tests computed from :func:`svd`, :func:`matmul` and
    :func:`norm` per block of a frame's basis: rank of each block, its thinnest functional and that
    functional's norm, the difference of the two blocks; fewer columns than states too."""
    tier_up()
    rng = np.random.default_rng(300 + seed)
    n = int(rng.integers(1, 6))
    q = int(rng.integers(1, 3 * n + 3))
    N = np.linalg.qr(rng.normal(size=(2 * n + 7, q)))[0] if q <= 2 * n + 7 else rng.normal(size=(2 * n + 7, q))
    if seed % 3 == 0 and q > 1:
        N[:n, -1] = N[:n, 0]  # a block of lower rank
    full, thin, thin_norm, D = R.subspace_directions(N, n, 1e-12)
    for part in range(2):
        P = N[part * n:(part + 1) * n]
        if q < n:
            assert not full[part] and np.array_equal(thin[part], np.zeros(q)) and thin_norm[part] == 0.0
            continue
        U, s, _ = R.svd(P)
        assert bool(full[part]) == bool(s[-1] > 1e-12)
        want = R.matmul(P.T, U[:, -1])
        assert np.array_equal(thin[part], want) and thin_norm[part] == R.norm(want)
    assert np.array_equal(D, N[:n] - N[n:2 * n])

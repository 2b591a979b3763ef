"""Linear algebra that gives the same bits on every x86-64 CPU: products, norms, SVD, least squares, NNLS.

NumPy's ``@``, ``np.linalg`` and SciPy's ``nnls`` run on OpenBLAS / LAPACK, whose kernels are
chosen at run time for the CPU (Haswell, SkylakeX, Zen, ...), use FMA or not, split sums by the
vector width and by the number of threads: the last bits of a product differ between machines.
Algorithm 3.1 takes decisions from those bits (a rank, a flat direction of a nullspace, a
certified width at its threshold), so its pair lists differed between an Intel and an AMD
machine.  The functions here compute every dot product as a left-to-right sum of correctly
rounded products, with no fused multiply-add and no reordering: numba kernels compiled without
``fastmath`` (LLVM neither contracts nor reassociates then), and, while the kernels are not
compiled, NumPy element-wise operations performing the same operations in the same order
(``tests/unit/geometry/test_reproducible.py`` checks the two bit for bit).  The SVD is the
one-sided Jacobi method of Hestenes (Demmel & Veselic, SIAM J. Matrix Anal. Appl. 13(4), 1992),
which needs nothing but such sums, square roots and rotations; its null-space completion is a
fixed Gram-Schmidt sweep over the unit vectors, so a degenerate subspace gets the same basis on
every machine.  They are for the small matrices of the decision paths (tens of rows), not for
speed.
"""

from __future__ import annotations

import math

import numpy as np

from .._numba_cache import finalize_kernels, kernel
from ..defaults import JACOBI_MAX_SWEEPS
from ..tolerances import JACOBI_TOL


@kernel(cache=True)
def _matmul_kernel(A, B):
    """``A @ B`` (2-D, float64) with every entry summed over the inner index from first to last."""
    m, k = A.shape
    n = B.shape[1]
    C = np.zeros((m, n))
    for i in range(m):
        for t in range(k):
            a = A[i, t]
            for j in range(n):
                C[i, j] += a * B[t, j]
    return C


@kernel(cache=True)
def _matvec_kernel(A, b):
    """``A @ b`` (2-D times 1-D): :func:`_matmul_kernel`'s sums, without the reshaping around it."""
    m, k = A.shape
    c = np.zeros(m)
    for i in range(m):
        acc = 0.0
        for t in range(k):
            acc += A[i, t] * b[t]
        c[i] = acc
    return c


@kernel(cache=True)
def _vecmat_kernel(a, B):
    """``a @ B`` (1-D times 2-D): :func:`_matmul_kernel`'s sums."""
    k, n = B.shape
    c = np.zeros(n)
    for t in range(k):
        at = a[t]
        for j in range(n):
            c[j] += at * B[t, j]
    return c


@kernel(cache=True)
def _vecdot_kernel(a, b):
    """``a @ b`` of two vectors: :func:`_matmul_kernel`'s sum."""
    acc = 0.0
    for t in range(a.shape[0]):
        acc += a[t] * b[t]
    return acc


@kernel(cache=True)
def _sumsq_kernel(v):
    """``v[0]^2 + v[1]^2 + ...`` from first to last (:func:`norm`)."""
    acc = 0.0
    for t in range(v.shape[0]):
        acc += v[t] * v[t]
    return acc


@kernel(cache=True)
def _row_norms_kernel(X):
    """``sqrt(X[r, 0]^2 + X[r, 1]^2 + ...)`` of each row, summed first to last (:func:`row_norms`)."""
    k, d = X.shape
    out = np.zeros(k)
    for t in range(d):
        for r in range(k):
            out[r] += X[r, t] * X[r, t]
    for r in range(k):
        out[r] = np.sqrt(out[r])
    return out


def _row_norms_numpy(X: np.ndarray) -> np.ndarray:
    """:func:`_row_norms_kernel` in NumPy (the same sums, rows vectorised)."""
    acc = np.zeros(X.shape[0])
    for t in range(X.shape[1]):
        acc = acc + X[:, t] * X[:, t]
    return np.sqrt(acc)


def _matmul_numpy(A, B):
    """:func:`_matmul_kernel` in NumPy: the same products, added in the same order."""
    C = np.zeros((A.shape[0], B.shape[1]))
    for t in range(A.shape[1]):
        C += A[:, t:t + 1] * B[t:t + 1, :]
    return C


@kernel(cache=True)
def _jacobi_rotation(alpha, beta, gamma, tol, negligible):
    """The rotation ``(rotate, c, s)`` that makes two columns orthogonal, from their squared norms
    ``alpha``, ``beta`` and product ``gamma``; ``rotate`` is False when they already are (to
    ``tol``) or one of them is negligible (Rutishauser's formulas, as LAPACK's ``dgesvj``)."""
    if alpha <= negligible or beta <= negligible or gamma == 0.0 or abs(gamma) <= tol * np.sqrt(alpha) * np.sqrt(beta):
        return False, 1.0, 0.0
    zeta = (beta - alpha) / (2.0 * gamma)
    t = 1.0 / (abs(zeta) + np.sqrt(1.0 + zeta * zeta))
    if zeta < 0.0:
        t = -t
    c = 1.0 / np.sqrt(1.0 + t * t)
    return True, c, c * t


@kernel(cache=True)
def _jacobi_kernel(W, V, tol, negligible, max_sweeps):
    """One-sided Jacobi: rotate the columns of ``W`` (and ``V``) in place until they are orthogonal.

    Cyclic order ``(0, 1), (0, 2), ..., (k-2, k-1)``; a pair with a column whose squared norm is
    at most ``negligible`` is left alone (that column is zero to working precision: its direction
    is rounding, and rotating it against itself never converges).  ``V`` with no rows accumulates
    nothing (singular values only; ``W`` gets the same bits).  Returns the sweeps done.
    """
    m, k = W.shape
    nv = V.shape[0]
    for sweep in range(max_sweeps):
        rotated = False
        for p in range(k - 1):
            for q in range(p + 1, k):
                alpha = 0.0
                beta = 0.0
                gamma = 0.0
                # three sums, each in its own order (the bits of three loops); in one loop their
                # dependency chains overlap
                for i in range(m):
                    wp = W[i, p]
                    wq = W[i, q]
                    alpha += wp * wp
                    beta += wq * wq
                    gamma += wp * wq
                rotate, c, s = _jacobi_rotation(alpha, beta, gamma, tol, negligible)
                if not rotate:
                    continue
                rotated = True
                for i in range(m):
                    wp = W[i, p]
                    wq = W[i, q]
                    W[i, p] = c * wp - s * wq
                    W[i, q] = s * wp + c * wq
                for i in range(nv):
                    vp = V[i, p]
                    vq = V[i, q]
                    V[i, p] = c * vp - s * vq
                    V[i, q] = s * vp + c * vq
        if not rotated:
            return sweep + 1
    return max_sweeps


def _seq_sum(x: np.ndarray) -> float:
    """``x[0] + x[1] + ...`` from first to last, as the kernels' loops add (``+ 0.0``: their sum starts at +0)."""
    return float(np.cumsum(x)[-1]) + 0.0 if x.size else 0.0


def _jacobi_numpy(W, V, tol, negligible, max_sweeps):
    """:func:`_jacobi_kernel` in NumPy: the same operations in the same order (rows vectorised)."""
    k = W.shape[1]
    for sweep in range(max_sweeps):
        rotated = False
        for p in range(k - 1):
            for q in range(p + 1, k):
                wp, wq = W[:, p].copy(), W[:, q].copy()
                alpha, beta, gamma = _seq_sum(wp * wp), _seq_sum(wq * wq), _seq_sum(wp * wq)
                rotate, c, s = _jacobi_rotation(alpha, beta, gamma, tol, negligible)
                if not rotate:
                    continue
                rotated = True
                W[:, p], W[:, q] = c * wp - s * wq, s * wp + c * wq
                vp, vq = V[:, p].copy(), V[:, q].copy()
                V[:, p], V[:, q] = c * vp - s * vq, s * vp + c * vq
        if not rotated:
            return sweep + 1
    return max_sweeps


@kernel(cache=True)
def _complete_kernel(Q, r):
    """Columns ``r..`` of the square ``Q`` filled, in place, with an orthonormal completion of its first ``r``.

    Each new column is the unit vector ``e_t`` farthest from the span so far (the smallest
    ``sum_c Q[t, c]^2``, the first such ``t``), orthogonalised by classical Gram-Schmidt applied
    twice and normalised: a fixed rule, so the completion of a degenerate space is the same on
    every machine (and its residual keeps at least ``sqrt(1 / d)`` of its length).
    """
    d = Q.shape[0]
    v = np.zeros(d)
    coef = np.zeros(d)
    for filled in range(r, d):
        best = 0
        best_w = np.inf
        for t in range(d):
            acc = 0.0
            for c in range(filled):
                acc += Q[t, c] * Q[t, c]
            if acc < best_w:
                best_w = acc
                best = t
        for i in range(d):
            v[i] = 0.0
        v[best] = 1.0
        for _ in range(2):
            for c in range(filled):
                acc = 0.0
                for i in range(d):
                    acc += Q[i, c] * v[i]
                coef[c] = acc
            for i in range(d):
                acc = 0.0
                for c in range(filled):
                    acc += Q[i, c] * coef[c]
                v[i] = v[i] - acc
        nv = 0.0
        for i in range(d):
            nv += v[i] * v[i]
        nv = np.sqrt(nv)
        for i in range(d):
            Q[i, filled] = v[i] / nv
    return d


def _complete_numpy(Q, r):
    """:func:`_complete_kernel` in NumPy: the same operations in the same order."""
    d = Q.shape[0]
    for filled in range(r, d):
        P = Q[:, :filled]
        weight = np.cumsum(P * P, axis=1)[:, -1] + 0.0 if filled else np.zeros(d)
        best = int(np.argmin(weight))
        v = np.zeros(d)
        v[best] = 1.0
        for _ in range(2):
            coef = _matmul_numpy(np.ascontiguousarray(P.T), v.reshape(-1, 1))
            v = v - _matmul_numpy(P, coef)[:, 0]
        Q[:, filled] = v / np.sqrt(_seq_sum(v * v))
    return d


@kernel(cache=True)
def _jacobi_four_kernel(Ws, cut2, tol, max_sweeps):
    """:func:`_jacobi_kernel` without ``V`` on the four matrices ``Ws[0].T, ..., Ws[3].T`` side by side.

    ``Ws[g]`` holds matrix ``g`` transposed (``Ws[g, j]`` is its column ``j``, contiguous).  Each
    matrix gets exactly the operations it gets alone (its rotations, and no sweep after the first
    one without a rotation; the negligible threshold ``cut2[g]`` its own); the twelve column sums
    of a pair ``(p, q)`` run in one loop, so that their dependency chains overlap.
    """
    k = Ws.shape[1]
    m = Ws.shape[2]
    active = np.ones(4, dtype=np.bool_)
    rotated = np.zeros(4, dtype=np.bool_)
    sums = np.zeros((4, 3))
    for sweep in range(max_sweeps):
        for g in range(4):
            rotated[g] = False
        for p in range(k - 1):
            for q in range(p + 1, k):
                a0 = 0.0
                b0 = 0.0
                c0 = 0.0
                a1 = 0.0
                b1 = 0.0
                c1 = 0.0
                a2 = 0.0
                b2 = 0.0
                c2 = 0.0
                a3 = 0.0
                b3 = 0.0
                c3 = 0.0
                for i in range(m):
                    u = Ws[0, p, i]
                    v = Ws[0, q, i]
                    a0 += u * u
                    b0 += v * v
                    c0 += u * v
                    u = Ws[1, p, i]
                    v = Ws[1, q, i]
                    a1 += u * u
                    b1 += v * v
                    c1 += u * v
                    u = Ws[2, p, i]
                    v = Ws[2, q, i]
                    a2 += u * u
                    b2 += v * v
                    c2 += u * v
                    u = Ws[3, p, i]
                    v = Ws[3, q, i]
                    a3 += u * u
                    b3 += v * v
                    c3 += u * v
                sums[0, 0], sums[0, 1], sums[0, 2] = a0, b0, c0
                sums[1, 0], sums[1, 1], sums[1, 2] = a1, b1, c1
                sums[2, 0], sums[2, 1], sums[2, 2] = a2, b2, c2
                sums[3, 0], sums[3, 1], sums[3, 2] = a3, b3, c3
                for g in range(4):
                    if not active[g]:
                        continue
                    rotate, c, s = _jacobi_rotation(sums[g, 0], sums[g, 1], sums[g, 2], tol, cut2[g])
                    if not rotate:
                        continue
                    rotated[g] = True
                    for i in range(m):
                        wp = Ws[g, p, i]
                        wq = Ws[g, q, i]
                        Ws[g, p, i] = c * wp - s * wq
                        Ws[g, q, i] = s * wp + c * wq
        left = False
        for g in range(4):
            if active[g] and not rotated[g]:
                active[g] = False
            left = left or active[g]
        if not left:
            return


@kernel(cache=True)
def _singular_values_kernel(Ms, tol, max_sweeps):
    """Singular values (descending) of each tall matrix ``Ms[b]`` (``m >= k``): the operations of
    :func:`_svd_tall` without its vectors, for a whole batch in one call (four matrices at a
    time side by side, :func:`_jacobi_four_kernel`: the same operations on each)."""
    nb, m, k = Ms.shape
    out = np.zeros((nb, k))
    eps = np.finfo(np.float64).eps
    # the matrices transposed (columns contiguous), padded with zero matrices to a multiple of
    # four: a zero matrix is never rotated, so it drops out after one sweep
    n4 = (nb + 3) // 4 * 4
    Ws = np.zeros((n4, k, m))
    cut2 = np.zeros(n4)
    units = np.empty(nb)
    for b in range(nb):
        big = 0.0
        for i in range(m):
            for j in range(k):
                a = abs(Ms[b, i, j])
                if a > big:
                    big = a
        # any power of two gives the same bits (the scaling is exact); frexp's is one
        unit = math.ldexp(1.0, math.frexp(big)[1]) if big > 0.0 else 1.0
        fro2 = 0.0
        for i in range(m):
            for j in range(k):
                w = Ms[b, i, j] / unit
                Ws[b, j, i] = w
                fro2 += w * w
        cut2[b] = (eps * max(m, k)) ** 2 * fro2
        units[b] = unit
    for b in range(0, n4, 4):
        _jacobi_four_kernel(Ws[b:b + 4], cut2[b:b + 4], tol, max_sweeps)
    for b in range(nb):
        s = np.zeros(k)
        for j in range(k):
            s2 = 0.0
            for i in range(m):
                s2 += Ws[b, j, i] * Ws[b, j, i]
            s[j] = np.sqrt(s2) if s2 > cut2[b] else 0.0
        s = np.sort(s)[::-1]
        for j in range(k):
            out[b, j] = s[j] * units[b]
    return out


@kernel(cache=True)
def _svd_tall_kernel(A, tol, max_sweeps):
    """:func:`_svd_tall_numpy` in one compiled call: the same operations in the same order (the
    scaling's power of two may differ, which changes no bit).  ``ok`` is False for a non-finite entry."""
    m, k = A.shape
    eps = np.finfo(np.float64).eps
    big = 0.0
    ok = True
    for i in range(m):
        for j in range(k):
            a = abs(A[i, j])
            if not np.isfinite(a):
                ok = False
            elif a > big:
                big = a
    U = np.zeros((m, m))
    s = np.zeros(k)
    V = np.eye(k)
    if not ok:
        return U, s, V, False
    unit = math.ldexp(1.0, math.frexp(big)[1]) if big > 0.0 else 1.0
    W = np.empty((m, k))
    fro2 = 0.0
    for i in range(m):
        for j in range(k):
            W[i, j] = A[i, j] / unit
            fro2 += W[i, j] * W[i, j]
    cut2 = (eps * max(m, k)) ** 2 * fro2
    _jacobi_kernel(W, V, tol, cut2, max_sweeps)
    for j in range(k):
        s2 = 0.0
        for i in range(m):
            s2 += W[i, j] * W[i, j]
        s[j] = np.sqrt(s2) if s2 > cut2 else 0.0
    order = np.arange(k)
    for j in range(1, k):  # stable insertion sort, descending
        cur = order[j]
        t = j
        while t > 0 and s[order[t - 1]] < s[cur]:
            order[t] = order[t - 1]
            t -= 1
        order[t] = cur
    s_sorted = np.empty(k)
    V_sorted = np.empty((k, k))
    for j in range(k):
        s_sorted[j] = s[order[j]]
        for i in range(k):
            V_sorted[i, j] = V[i, order[j]]
    r = 0
    while r < k and s_sorted[r] > 0.0:
        c = order[r]
        for i in range(m):
            U[i, r] = W[i, c] / s_sorted[r]
        r += 1
    for j in range(k):
        s_sorted[j] = s_sorted[j] * unit
    _complete_kernel(U, r)
    return U, s_sorted, V_sorted, True


def _singular_values_numpy(Ms, tol, max_sweeps):
    """:func:`_singular_values_kernel` in NumPy, one matrix at a time."""
    return np.array([_svd_tall_numpy(np.ascontiguousarray(M))[1] for M in Ms]).reshape(Ms.shape[0], Ms.shape[2])


@kernel(cache=True)
def _lstsq_columns_kernel(A, cols, p, b, tol, max_sweeps):
    """:func:`lstsq` of ``A[:, cols[:p]]`` and ``b``, the same operations in the same order, in
    ``(x, ok)`` (``x`` of length ``p``; ``ok`` False for a non-finite entry).  The wide case
    (fewer rows than columns) is the SVD of the transpose, as :func:`svd` computes it."""
    m = A.shape[0]
    S = np.empty((m, p))
    for i in range(m):
        for c in range(p):
            S[i, c] = A[i, cols[c]]
    x = np.zeros(p)
    if m == 0 or p == 0:
        return x, True
    if m >= p:
        L, s, Rt, ok = _svd_tall_kernel(S, tol, max_sweeps)  # S = L[:, :p] diag(s) Rt'
    else:
        Rt, s, L, ok = _svd_tall_kernel(np.ascontiguousarray(S.T), tol, max_sweeps)  # S' = Rt[:, :m] diag(s) L'
    if not ok:
        return x, False
    q = s.shape[0]
    cut = np.finfo(np.float64).eps * max(m, p) * s[0]
    r = 0
    for a in range(q):
        if s[a] > cut:
            r += 1
    coef = np.empty(r)
    for a in range(r):
        acc = 0.0
        for t in range(m):
            acc += L[t, a] * b[t]
        coef[a] = acc / s[a]
    for t in range(p):
        acc = 0.0
        for a in range(r):
            acc += Rt[t, a] * coef[a]
        x[t] = acc
    return x, True


@kernel(cache=True)
def _span_width_kernel(G, rows, slack, c, radius_bound, tol, max_sweeps):
    """:func:`span_width_bound` in one call: ``(value, ok)``, ``ok`` False for a non-finite entry."""
    p = rows.shape[0]
    d = G.shape[1]
    GKT = np.empty((d, p))
    for a in range(p):
        for q in range(d):
            GKT[q, a] = G[rows[a], q]
    cols = np.arange(p)
    alpha, ok = _lstsq_columns_kernel(GKT, cols, p, c, tol, max_sweeps)
    if not ok:
        return np.inf, False
    fit = _matvec_kernel(GKT, alpha)
    rho = np.empty(d)
    for q in range(d):
        rho[q] = c[q] - fit[q]
    spread = np.empty(p)
    for a in range(p):
        spread[a] = abs(alpha[a])
    return _vecdot_kernel(spread, slack) + 2.0 * radius_bound * np.sqrt(_sumsq_kernel(rho)), True


@kernel(cache=True)
def _nnls_kernel(A, b, limit, tol_jacobi, max_sweeps):
    """:func:`_nnls_python` in one compiled call: the same operations in the same order.

    Returns ``(x, residual norm, status)``: 0 solved, 1 the iteration limit, 2 a NaN or an
    infinity met on the way (in the data or an iterate), where :func:`nnls` hands the problem to
    :func:`_nnls_python`, whose NumPy reductions decide what a NaN does.
    """
    m, k = A.shape
    eps = np.finfo(np.float64).eps
    big = 0.0
    for i in range(m):
        if not np.isfinite(b[i]):
            return np.zeros(k), 0.0, 2
        for c in range(k):
            if not np.isfinite(A[i, c]):
                return np.zeros(k), 0.0, 2
            if abs(A[i, c]) > big:
                big = abs(A[i, c])
    tol = 10.0 * eps * max(m, k) * max(big, 1.0)
    x = np.zeros(k)
    passive = np.zeros(k, dtype=np.bool_)
    w = np.zeros(k)
    resid = np.empty(m)
    cols = np.empty(k, dtype=np.int64)
    it = 0
    while True:
        for i in range(m):  # w = A' (b - A x)
            acc = 0.0
            for c in range(k):
                acc += A[i, c] * x[c]
            resid[i] = b[i] - acc
        for c in range(k):
            acc = 0.0
            for i in range(m):
                acc += A[i, c] * resid[i]
            w[c] = acc
        j = -1
        best = -np.inf
        for c in range(k):  # the first largest w of an inactive column
            if not passive[c]:
                if not np.isfinite(w[c]):
                    return x, 0.0, 2
                if w[c] > best:
                    best = w[c]
                    j = c
        if j < 0 or not best > tol:
            break
        passive[j] = True
        while True:
            it += 1
            if it > limit:
                return x, 0.0, 1
            p = 0
            for c in range(k):
                if passive[c]:
                    cols[p] = c
                    p += 1
            zp, ok = _lstsq_columns_kernel(A, cols, p, b, tol_jacobi, max_sweeps)
            z = np.zeros(k)
            positive = True
            for t in range(p):
                if not (ok and np.isfinite(zp[t])):
                    return x, 0.0, 2
                z[cols[t]] = zp[t]
                if not zp[t] > 0.0:
                    positive = False
            if positive:
                x = z
                break
            alpha = np.inf
            for t in range(p):
                c = cols[t]
                if z[c] <= 0.0:
                    ratio = x[c] / (x[c] - z[c])
                    if np.isnan(ratio):
                        return x, 0.0, 2
                    if ratio < alpha:
                        alpha = ratio
            for c in range(k):
                x[c] = x[c] + alpha * (z[c] - x[c])
            for c in range(k):
                if passive[c] and x[c] <= tol:
                    passive[c] = False
                if not passive[c]:
                    x[c] = 0.0
    ss = 0.0
    for i in range(m):
        acc = 0.0
        for c in range(k):
            acc += A[i, c] * x[c]
        v = acc - b[i]
        ss += v * v
    return x, np.sqrt(ss), 0


@kernel(cache=True)
def _svd_full_kernel(A, tol, max_sweeps):
    """:func:`svd` of a finite ``A`` with ``min(m, k) > 0`` (``full_matrices=True``) in one call:
    ``(U, s, Vt, ok)``, the wide case by the SVD of the transpose as :func:`svd` computes it."""
    m, k = A.shape
    if m >= k:
        U, s, V, ok = _svd_tall_kernel(A, tol, max_sweeps)
        return U, s, np.ascontiguousarray(V.T), ok
    V, s, U, ok = _svd_tall_kernel(np.ascontiguousarray(A.T), tol, max_sweeps)
    return U, s, np.ascontiguousarray(V.T), ok


@kernel(cache=True)
def _rank_kernel(s, rtol):
    """:func:`numerical_rank` of descending singular values ``s``."""
    if s.shape[0] == 0:
        return 0
    top = rtol * max(s[0], np.finfo(np.float64).tiny)
    r = 0
    for a in range(s.shape[0]):
        if s[a] > top:
            r += 1
    return r


@kernel(cache=True)
def _subspace_directions_kernel(N, n, rank_rtol, tol, max_sweeps):
    """What a basis ``N`` (columns) says of the blocks ``N[:n]`` (``x``) and ``N[n:2n]`` (``x^``).

    Per block ``P``: whether it has rank ``n`` (the smallest singular value of :func:`svd`
    above ``rank_rtol``), the functional ``P' u`` along its last left singular vector ``u`` and
    that functional's norm (zero when ``P`` has fewer than ``n`` columns); and ``N[:n] -
    N[n:2n]``.  Returns ``(full, thin, thin_norm, D, ok)``, ``ok`` False for a non-finite entry.
    """
    q = N.shape[1]
    ok = True
    full = np.zeros(2, dtype=np.bool_)
    thin = np.zeros((2, q))
    thin_norm = np.zeros(2)
    for part in range(2):
        if q < n:
            continue
        P = np.ascontiguousarray(N[part * n:(part + 1) * n])
        Uu, sv, _, ok_part = _svd_full_kernel(P, tol, max_sweeps)
        ok = ok and ok_part
        full[part] = sv[sv.shape[0] - 1] > rank_rtol
        acc2 = 0.0
        for c in range(q):
            acc = 0.0
            for t in range(n):
                acc += P[t, c] * Uu[t, n - 1]
            thin[part, c] = acc
            acc2 += acc * acc
        thin_norm[part] = np.sqrt(acc2)
    D = np.empty((n, q))
    for a in range(n):
        for c in range(q):
            D[a, c] = N[a, c] - N[n + a, c]
    return full, thin, thin_norm, D, ok


@kernel(cache=True)
def _equality_subspace_kernel(E, n, rank_rtol, tol, max_sweeps):
    """The equality subspace ``{w : E w = 0}`` and what it says about two blocks of ``n`` coordinates.

    The bits of :func:`svd` and :func:`numerical_rank` on ``E`` (``E = U diag(s) Vt``, rank ``r``,
    nullspace basis ``N = Vt[r:]'``), and, for the blocks ``w[:n]`` and ``w[n:2n]``: whether
    ``N``'s block has rank ``n`` (its smallest singular value above ``rank_rtol``), the functional
    ``N_block' u`` along the block's last left singular vector ``u`` and its norm, whether
    appending the rows ``[I, -I, 0]`` to ``E`` leaves its numerical rank unchanged, and
    ``N[:n] - N[n:2n]``.  ``ok`` is False for a non-finite entry (nothing else is meaningful then).
    """
    m, k = E.shape
    U, s, Vt, ok = _svd_full_kernel(E, tol, max_sweeps)
    r = _rank_kernel(s, rank_rtol)
    N = np.ascontiguousarray(Vt[r:].T)
    full, thin, thin_norm, D, ok_parts = _subspace_directions_kernel(N, n, rank_rtol, tol, max_sweeps)
    ok = ok and ok_parts
    # [E; I -I 0], the identity's off-diagonal zeros negated as -np.eye gives them
    EJ = np.zeros((m + n, k))
    EJ[:m] = E
    for a in range(n):
        for c in range(n):
            EJ[m + a, n + c] = -0.0
        EJ[m + a, a] = 1.0
        EJ[m + a, n + a] = -1.0
    if m + n >= k:
        _, s2, _, ok2 = _svd_tall_kernel(EJ, tol, max_sweeps)
    else:
        _, s2, _, ok2 = _svd_tall_kernel(np.ascontiguousarray(EJ.T), tol, max_sweeps)
    r2 = _rank_kernel(s2, rank_rtol)
    return U, s, Vt, r, N, full, thin, thin_norm, r2 == r, D, ok and ok2


@kernel(cache=True)
def _affine_hull_kernel(E0, e0, rank_rtol, consistency_rtol, closed_tol, tol, max_sweeps):
    """The affine set ``{s : E s = e}`` of equality rows ``E0 s = e0`` (each row normalised first).

    The operations of :func:`affine_hull` written out: ``E``, ``e`` divided by the row norms
    (:func:`row_norms`), ``E = U diag(s) Vt`` (:func:`svd`), rank ``r`` (singular values above
    ``rank_rtol`` times the largest), ``t0 = Vt[:r]' (U[:, :r]' e / s[:r])`` (:func:`matmul`'s
    sums) and the residual test ``|E t0 - e| > consistency_rtol (1 + |e|) + closed_tol``.
    Returns ``(status, N, t0)``: status 2 with the basis ``N = Vt[r:]'`` and ``t0``, 1 when the
    rows contradict each other, 0 when ``r = 0``, -1 when a row norm is zero or an entry not
    finite (the caller computes in NumPy then).
    """
    m, d = E0.shape
    nrm = _row_norms_kernel(E0)
    for a in range(m):
        if not (nrm[a] > 0.0 and np.isfinite(nrm[a]) and np.isfinite(e0[a])):
            return -1, np.zeros((d, 0)), np.zeros(d)
    E = np.empty((m, d))
    e = np.empty(m)
    for a in range(m):
        for c in range(d):
            E[a, c] = E0[a, c] / nrm[a]
        e[a] = e0[a] / nrm[a]
    U, s, Vt, ok = _svd_full_kernel(E, tol, max_sweeps)
    if not ok:
        return -1, np.zeros((d, 0)), np.zeros(d)
    r = _rank_kernel(s, rank_rtol)
    if r == 0:
        return 0, np.zeros((d, 0)), np.zeros(d)
    coef = _matvec_kernel(np.ascontiguousarray(U[:, :r].T), e)
    for a in range(r):
        coef[a] = coef[a] / s[a]
    t0 = _matvec_kernel(np.ascontiguousarray(Vt[:r].T), coef)
    resid = _matvec_kernel(E, t0)
    for a in range(m):
        resid[a] = resid[a] - e[a]
    if np.sqrt(_sumsq_kernel(resid)) > consistency_rtol * (1.0 + np.sqrt(_sumsq_kernel(e))) + closed_tol:
        return 1, np.zeros((d, 0)), t0
    return 2, np.ascontiguousarray(Vt[r:].T), t0


def _nnls_python(A: np.ndarray, b: np.ndarray, limit: int, tol_jacobi: float, max_sweeps: int):
    """The active-set method of :func:`nnls` in NumPy: ``(x, residual norm, status)``, status 1 at
    the iteration limit (``tol_jacobi`` and ``max_sweeps`` are :func:`svd`'s, which it calls)."""
    m, k = A.shape
    x = np.zeros(k)
    passive = np.zeros(k, dtype=bool)
    At = np.ascontiguousarray(A.T)
    tol = 10.0 * np.finfo(float).eps * max(m, k) * max(float(np.max(np.abs(A), initial=0.0)), 1.0)
    it = 0
    w = matmul(At, b - matmul(A, x))
    while not passive.all() and np.max(np.where(passive, -np.inf, w)) > tol:
        j = int(np.argmax(np.where(passive, -np.inf, w)))
        passive[j] = True
        while True:
            it += 1
            if it > limit:
                return x, 0.0, 1
            idx = np.nonzero(passive)[0]
            z = np.zeros(k)
            z[idx] = lstsq(A[:, idx], b)
            if np.all(z[idx] > 0.0):
                x = z
                break
            neg = idx[z[idx] <= 0.0]
            alpha = float(np.min(x[neg] / (x[neg] - z[neg])))
            x = x + alpha * (z - x)
            passive &= ~((x <= tol) & passive)
            x[~passive] = 0.0
        w = matmul(At, b - matmul(A, x))
    return x, norm(matmul(A, x) - b), 0


# tiered: the NumPy versions run until the process has done enough kernel work (see _numba_cache)
COMPILED = finalize_kernels(globals(), tiered=True, weight=1,
                            python={"_matmul_kernel": _matmul_numpy, "_jacobi_kernel": _jacobi_numpy,
                                    "_complete_kernel": _complete_numpy, "_singular_values_kernel": _singular_values_numpy,
                                    "_nnls_kernel": _nnls_python, "_row_norms_kernel": _row_norms_numpy})
_matmul = _matmul_kernel if COMPILED else _matmul_numpy
_jacobi = _jacobi_kernel if COMPILED else _jacobi_numpy
_complete = _complete_kernel if COMPILED else _complete_numpy
_singular_values = _singular_values_kernel if COMPILED else _singular_values_numpy
_row_norms = _row_norms_kernel if COMPILED else _row_norms_numpy


def subspace_directions(N: np.ndarray, n: int, rank_rtol: float):
    """:func:`_subspace_directions_kernel` of ``N``: ``(full, thin, thin_norm, D)`` with the bits of
    :func:`svd`, :func:`matmul` and :func:`norm`, or ``None`` when the kernels are not compiled in
    this process or ``N`` is not finite (the caller then computes the same from :func:`svd`)."""
    if not COMPILED:
        return None
    N = np.ascontiguousarray(N, dtype=float)
    if N.ndim != 2 or N.shape[0] < 2 * n or N.shape[1] == 0:
        return None
    full, thin, thin_norm, D, ok = _subspace_directions_kernel(N, int(n), float(rank_rtol), JACOBI_TOL, JACOBI_MAX_SWEEPS)
    return (full, thin, thin_norm, D) if ok else None


def equality_subspace(E: np.ndarray, n: int, rank_rtol: float):
    """:func:`_equality_subspace_kernel` of ``E``: ``(U, s, Vt, r, N, full, thin, thin_norm, same, D)``
    with the bits of :func:`svd` and :func:`numerical_rank` and the products written out there, or
    ``None`` when the kernels are not compiled in this process or ``E`` is not finite (the caller
    then computes the same from :func:`svd`)."""
    if not COMPILED:
        return None
    out = _equality_subspace_kernel(np.ascontiguousarray(E, dtype=float), int(n), float(rank_rtol), JACOBI_TOL, JACOBI_MAX_SWEEPS)
    return out[:-1] if out[-1] else None


def span_width_bound(G: np.ndarray, rows: np.ndarray, slack: np.ndarray, c: np.ndarray, radius_bound: float) -> float:
    """``sum_k |alpha_k| slack_k + 2 R |rho|`` for ``c = G[rows]' alpha + rho`` (``alpha`` by :func:`lstsq`).

    The bound of :func:`~hybobs_opt.regions.pair_geometry._tight_width_bound` on the width of
    ``c'v`` when each ``G_k v`` (``k`` in ``rows``) ranges over an interval of length ``slack_k``
    and ``|v| <= R``; ``inf`` when it is not finite.  The bits of :func:`lstsq`, :func:`matmul`
    and :func:`norm`, in one compiled call when the kernels are.
    """
    rows = np.ascontiguousarray(rows, dtype=np.int64)
    if rows.size == 0:
        return np.inf
    G = np.ascontiguousarray(G, dtype=float)
    c = np.ascontiguousarray(c, dtype=float)
    slack = np.ascontiguousarray(slack, dtype=float)
    if COMPILED:
        val, ok = _span_width_kernel(G, rows, slack, c, float(radius_bound), JACOBI_TOL, JACOBI_MAX_SWEEPS)
    else:
        ok = False
    if not ok:
        GK = G[rows]
        alpha = lstsq(GK.T, c)
        rho = c - matmul(GK.T, alpha)
        val = matmul(np.abs(alpha), slack) + 2.0 * radius_bound * norm(rho)
    val = float(val)
    return val if np.isfinite(val) else np.inf


def affine_hull(E: np.ndarray, e: np.ndarray, rank_rtol: float, consistency_rtol: float, closed_tol: float):
    """The affine set ``{s : E s = e}`` after normalising each row: ``(N, t0)`` (``s = t0 + N z``),
    ``"empty"`` when the rows contradict each other (residual above ``consistency_rtol (1 +
    |e|) + closed_tol``), ``None`` when the numerical rank (``rank_rtol``) is 0.

    The bits of :func:`row_norms`, :func:`svd`, the rank and :func:`matmul` on the same data;
    one compiled call (:func:`_affine_hull_kernel`) when the kernels are.
    """
    E = np.ascontiguousarray(E, dtype=float)
    e = np.ascontiguousarray(e, dtype=float)
    if COMPILED and E.ndim == 2 and E.shape[0] > 0 and E.shape[1] > 0:
        status, N, t0 = _affine_hull_kernel(E, e, float(rank_rtol), float(consistency_rtol), float(closed_tol),
                                            JACOBI_TOL, JACOBI_MAX_SWEEPS)
        if status >= 0:
            return (N, t0) if status == 2 else ("empty" if status == 1 else None)
    nrm = row_norms(E)
    E, e = E / nrm[:, None], e / nrm
    U_, s, Vt = svd(E, full_matrices=True)
    r = int(np.sum(s > rank_rtol * max(s[0], np.finfo(float).tiny))) if s.size else 0
    if r == 0:
        return None
    t0 = matmul(Vt[:r].T, matmul(U_[:, :r].T, e) / s[:r])
    if norm(matmul(E, t0) - e) > consistency_rtol * (1.0 + norm(e)) + closed_tol:
        return "empty"
    return Vt[r:].T, t0


def _svd_tall(A: np.ndarray):
    """:func:`_svd_tall_numpy`, compiled in one call when the kernels are."""
    if not COMPILED:
        return _svd_tall_numpy(A)
    U, s, V, ok = _svd_tall_kernel(A, JACOBI_TOL, JACOBI_MAX_SWEEPS)
    if not ok:
        raise ValueError("svd: the matrix has a non-finite entry")
    return U, s, V


def _as2d(a) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    return a if a.ndim == 0 else np.ascontiguousarray(a)


def _ready(a) -> np.ndarray:
    return a if type(a) is np.ndarray and a.dtype == _F8 and a.flags.c_contiguous else _as2d(a)


_F8 = np.dtype(np.float64)


def matmul(a, b) -> np.ndarray:
    """``a @ b`` for 1-D and 2-D float arrays, the same bits on every CPU (see the module docstring)."""
    A, B = _ready(a), _ready(b)
    if COMPILED and 1 <= A.ndim <= 2 and 1 <= B.ndim <= 2:
        if A.shape[-1] != B.shape[0]:
            raise ValueError(f"matmul: shapes {A.shape} and {B.shape} do not match")
        if A.ndim == 2:
            return _matmul_kernel(A, B) if B.ndim == 2 else _matvec_kernel(A, B)
        return _vecmat_kernel(A, B) if B.ndim == 2 else np.float64(_vecdot_kernel(A, B))
    if A.ndim > 2 or B.ndim > 2 or A.ndim == 0 or B.ndim == 0:
        raise ValueError(f"matmul: 1-D or 2-D operands expected, got shapes {A.shape} and {B.shape}")
    C = _matmul(A.reshape(1, -1) if A.ndim == 1 else A, B.reshape(-1, 1) if B.ndim == 1 else B)
    if A.ndim == 1 and B.ndim == 1:
        return C[0, 0]
    if A.ndim == 1:
        return C[0]
    if B.ndim == 1:
        return C[:, 0]
    return C


def dot(a, b) -> float:
    """``a @ b`` of two vectors as a Python float."""
    return float(matmul(np.ravel(a), np.ravel(b)))


def norm(x) -> float:
    """Euclidean norm of a vector (all entries of an array), summed left to right."""
    v = np.ravel(np.asarray(x, dtype=float))
    if COMPILED:
        return float(np.sqrt(_sumsq_kernel(v)))
    return float(np.sqrt(_seq_sum(v * v)))


def row_norms(X) -> np.ndarray:
    """Euclidean norm of each row of a 2-D array."""
    X = _as2d(X)
    if X.ndim != 2:
        raise ValueError(f"row_norms: a 2-D array expected, got shape {X.shape}")
    return _row_norms(X)


def _svd_tall_numpy(A: np.ndarray):
    """SVD of ``A`` (``m >= k``): ``(U m x m, s k, V k x k)`` with ``A = U[:, :k] diag(s) V'``, ``s`` descending.

    ``A`` is scaled by a power of two (exact) so that its largest entry is about 1; singular
    values at most ``eps max(m, k) |A|_F`` -- LAPACK's rank cut-off -- are returned as exactly 0,
    their left vectors taken from the Gram-Schmidt completion (a column of that size carries no
    direction, only rounding).
    """
    m, k = A.shape
    big = float(np.max(np.abs(A), initial=0.0))
    if not np.isfinite(big):
        raise ValueError("svd: the matrix has a non-finite entry")
    unit = float(np.exp2(np.round(np.log2(big)))) if big > 0.0 else 1.0
    W = A / unit
    V = np.eye(k)
    fro2 = float(np.cumsum(np.ravel(W * W))[-1])
    cut2 = (np.finfo(float).eps * max(m, k)) ** 2 * fro2
    _jacobi(W, V, JACOBI_TOL, cut2, JACOBI_MAX_SWEEPS)
    s2 = np.cumsum(W * W, axis=0)[-1] + 0.0
    s = np.where(s2 > cut2, np.sqrt(s2), 0.0)
    order = np.argsort(-s, kind="stable")
    s, W, V = s[order], W[:, order], V[:, order]
    U = np.zeros((m, m))
    r = 0
    while r < k and s[r] > 0.0:
        U[:, r] = W[:, r] / s[r]
        r += 1
    s = s * unit
    _complete(U, r)
    return U, s, V


def svd(a, full_matrices: bool = True, compute_uv: bool = True):
    """``np.linalg.svd`` of a 2-D float array, the same bits on every CPU (one-sided Jacobi).

    Returns ``(U, s, Vt)`` like NumPy (``s`` descending; ``full_matrices=False`` keeps the first
    ``min(m, k)`` columns of ``U`` and rows of ``Vt``), or ``s`` alone with ``compute_uv=False``.
    The signs and, within a repeated singular value, the basis may differ from LAPACK's.
    """
    A = _as2d(a)
    if A.ndim != 2:
        raise ValueError(f"svd: a 2-D array expected, got shape {A.shape}")
    m, k = A.shape
    if min(m, k) == 0:
        s = np.zeros(0)
        if not compute_uv:
            return s
        return np.eye(m)[:, :m if full_matrices else 0], s, np.eye(k)[:k if full_matrices else 0]
    if m >= k:
        U, s, V = _svd_tall(A)
    else:
        V, s, U = _svd_tall(np.ascontiguousarray(A.T))
    if not compute_uv:
        return s
    p = min(m, k)
    if not full_matrices:
        U, V = U[:, :p], V[:, :p]
    return np.ascontiguousarray(U), s, np.ascontiguousarray(V.T)


def singular_values(stack) -> np.ndarray:
    """Singular values (descending) of each matrix of a ``(B, m, k)`` stack, as ``(B, min(m, k))``:
    the bits of :func:`svd` with ``compute_uv=False`` on each, in one call."""
    M = np.asarray(stack, dtype=float)
    if M.ndim != 3:
        raise ValueError(f"singular_values: a (B, m, k) stack expected, got shape {M.shape}")
    if not np.all(np.isfinite(M)):
        raise ValueError("svd: the matrix has a non-finite entry")
    if M.shape[1] < M.shape[2]:
        M = M.transpose(0, 2, 1)
    if M.shape[0] == 0 or M.shape[2] == 0:
        return np.zeros((M.shape[0], M.shape[2]))
    return _singular_values(np.ascontiguousarray(M), JACOBI_TOL, JACOBI_MAX_SWEEPS)


def numerical_ranks(S: np.ndarray, rtol: float) -> np.ndarray:
    """:func:`numerical_rank` of each row of ``S`` (rows of descending singular values)."""
    S = np.asarray(S, dtype=float)
    if S.shape[1] == 0:
        return np.zeros(S.shape[0], dtype=int)
    top = np.maximum(S[:, 0], np.finfo(float).tiny)
    return np.count_nonzero(S > rtol * top[:, None], axis=1)


def numerical_rank(s: np.ndarray, rtol: float) -> int:
    """Singular values above ``rtol`` times the largest (descending ``s``)."""
    if s.size == 0:
        return 0
    return int(np.sum(s > rtol * max(float(s[0]), np.finfo(float).tiny)))


def lstsq(a, b, rcond: float | None = None) -> np.ndarray:
    """Minimum-norm least-squares solution of ``a x = b`` (``b`` a vector), as ``np.linalg.lstsq(a, b, rcond=None)``."""
    A = _as2d(a)
    m, k = A.shape
    U, s, Vt = svd(A, full_matrices=False)
    cut = (np.finfo(float).eps * max(m, k) if rcond is None else rcond) * (float(s[0]) if s.size else 0.0)
    r = int(np.sum(s > cut))
    coef = matmul(np.ascontiguousarray(U[:, :r].T), np.asarray(b, dtype=float)) / s[:r]
    return matmul(np.ascontiguousarray(Vt[:r].T), coef) if r else np.zeros(k)


def pinv(a, rcond: float = 1e-15) -> np.ndarray:
    """Moore-Penrose pseudo-inverse, as ``np.linalg.pinv(a)`` (singular values below ``rcond`` times the largest dropped)."""
    A = _as2d(a)
    U, s, Vt = svd(A, full_matrices=False)
    r = int(np.sum(s > rcond * (float(s[0]) if s.size else 0.0)))
    return matmul(np.ascontiguousarray(Vt[:r].T) / s[:r], np.ascontiguousarray(U[:, :r].T)) if r else np.zeros((A.shape[1], A.shape[0]))


def nnls(a, b, max_iter: int | None = None) -> tuple[np.ndarray, float]:
    """``min |a x - b|, x >= 0`` by the active-set method of Lawson & Hanson (1974, ch. 23), as ``scipy.optimize.nnls``.

    Returns ``(x, residual norm)``; raises ``RuntimeError`` when the iteration limit
    (``3 k`` by default, SciPy's) is reached, as SciPy does.  Compiled in one call when the
    kernels are (the same bits: every sub-problem's least squares is :func:`lstsq`'s).
    """
    A = np.ascontiguousarray(_as2d(a))
    b = np.ascontiguousarray(np.asarray(b, dtype=float))
    if A.ndim != 2 or b.shape != (A.shape[0],):
        raise ValueError(f"nnls: a 2-D matrix and a vector of its rows expected, got shapes {A.shape} and {b.shape}")
    limit = 3 * A.shape[1] if max_iter is None else int(max_iter)
    status = 2
    if COMPILED:
        x, rnorm, status = _nnls_kernel(A, b, limit, JACOBI_TOL, JACOBI_MAX_SWEEPS)
    if status == 2:
        x, rnorm, status = _nnls_python(A, b, limit, JACOBI_TOL, JACOBI_MAX_SWEEPS)
    if status == 1:
        raise RuntimeError("nnls: iteration limit reached")
    return x, float(rnorm)


__all__ = ["COMPILED", "dot", "lstsq", "matmul", "nnls", "norm", "numerical_rank", "pinv", "row_norms", "svd"]

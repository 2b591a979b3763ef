"""Compiled part of the vertex-set check of :mod:`hybobs_opt.geometry.vertices`.

pycddlib answers a 2-D vertex enumeration in some 50 microseconds; the check in numpy took some
thirty array calls (several hundred microseconds), so it would have cost more than the library.
This kernel does the feasibility test, the merging of duplicates, the tight sets and the edge walk
from every simple vertex in one compiled call; degenerate vertices (more than ``d`` tight rows,
rare) are left to numpy.  numba caches it on disk.
"""

from __future__ import annotations

import numpy as np

from .._numba_cache import finalize_kernels as _finalize_kernels
from .._numba_cache import kernel
from ..tolerances import HULL_RAY_WEIGHT_MARGIN


#: Result codes of :func:`check_kernel` (0: passed; the others name the first failure).
OK, INFEASIBLE, NOT_A_VERTEX, SINGULAR, NEARLY_DEPENDENT, INCOMPLETE = 0, 1, 2, 3, 4, 5


@kernel(cache=True)
def _invert(M, out, W):
    """Gauss-Jordan inverse of the small square ``M`` into ``out`` (partial pivoting); False if singular.

    ``W`` is a ``d x d`` workspace (overwritten), allocated once by the caller.
    """
    d = M.shape[0]
    for i in range(d):
        for j in range(d):
            W[i, j] = M[i, j]
    for i in range(d):
        for j in range(d):
            out[i, j] = 1.0 if i == j else 0.0
    for c in range(d):
        p = c
        best = abs(W[c, c])
        for r in range(c + 1, d):
            if abs(W[r, c]) > best:
                best = abs(W[r, c])
                p = r
        if best == 0.0:
            return False
        if p != c:
            for k in range(d):
                W[c, k], W[p, k] = W[p, k], W[c, k]
                out[c, k], out[p, k] = out[p, k], out[c, k]
        piv = W[c, c]
        for k in range(d):
            W[c, k] /= piv
            out[c, k] /= piv
        for r in range(d):
            if r != c:
                f = W[r, c]
                if f != 0.0:
                    for k in range(d):
                        W[r, k] -= f * W[c, k]
                        out[r, k] -= f * out[c, k]
    return True


@kernel(cache=True)
def _key(w, point):
    k = 0.0
    for c in range(point.shape[0]):
        k += w[c] * point[c]
    return k


@kernel(cache=True)
def _find(keys, order, Y, point, tol, w, window):
    """Index of a row of ``Y`` within ``tol`` of ``point`` (infinity norm), or -1.

    ``order`` sorts the candidate rows by their key ``w'y`` (a generic direction: vertices of one
    facet of a box share a coordinate, never a key), ``keys`` holds the sorted keys; points within
    ``tol`` have keys within ``window = tol |w|_1``.
    """
    kp = _key(w, point)
    lo = np.searchsorted(keys, kp - window)
    d = Y.shape[1]
    for a in range(lo, keys.shape[0]):
        if keys[a] > kp + window:
            break
        i = order[a]
        ok = True
        for c in range(d):
            if abs(Y[i, c] - point[c]) > tol:
                ok = False
                break
        if ok:
            return i
    return -1


@kernel(cache=True)
def check_kernel(A, b, Y, check_rtol, tight_rtol, rank_rtol, same_rtol):
    """Check the candidate vertices ``Y`` of ``{y : A y <= b}`` (unit rows, scaled coordinates).

    Returns ``(code, i, j, keep, tight, degenerate, rays)``: ``code`` is :data:`OK` or the first
    failure (``i``, ``j``: the point and the row or edge concerned); ``keep`` marks the points left
    after merging those within ``same_rtol``; ``tight`` (points x rows) the rows with slack at
    most ``tight_rtol (1 + |b_j|)``; ``degenerate`` the kept points with more than ``d`` tight rows
    (not walked here); ``rays`` the unit directions of edges that no row stops.
    """
    n, d = Y.shape
    m = A.shape[0]
    S = np.empty((n, m))
    keep = np.ones(n, dtype=np.bool_)
    tight = np.zeros((n, m), dtype=np.bool_)
    empty_i = np.zeros(0, dtype=np.int64)
    empty_r = np.zeros((0, d))
    for i in range(n):
        for j in range(m):
            s = b[j]
            for c in range(d):
                s -= A[j, c] * Y[i, c]
            S[i, j] = s
            if s < -check_rtol * (1.0 + abs(b[j])):
                return INFEASIBLE, i, j, keep, tight, empty_i, empty_r
    w = np.empty(d)
    wsum = 0.0
    for c in range(d):
        w[c] = 1.0 + 0.6180339887498949 * (c + 1) - np.floor(0.6180339887498949 * (c + 1))  # generic weights
        wsum += w[c]
    window = same_rtol * wsum
    allkeys = np.empty(n)
    for i in range(n):
        allkeys[i] = _key(w, Y[i])
    order = np.argsort(allkeys)
    for a in range(n):
        i = order[a]
        if not keep[i]:
            continue
        for a2 in range(a + 1, n):
            j = order[a2]
            if allkeys[j] - allkeys[i] > window:
                break
            if keep[j]:
                close = True
                for c in range(d):
                    if abs(Y[j, c] - Y[i, c]) > same_rtol:
                        close = False
                        break
                if close:
                    keep[j] = False
    n_keep = 0
    for a in range(n):
        if keep[order[a]]:
            n_keep += 1
    korder = np.empty(n_keep, dtype=np.int64)
    keys = np.empty(n_keep)
    q = 0
    for a in range(n):
        i = order[a]
        if keep[i]:
            korder[q] = i
            keys[q] = allkeys[i]
            q += 1
    count = np.zeros(n, dtype=np.int64)
    n_deg = 0
    for i in range(n):
        if not keep[i]:
            continue
        for j in range(m):
            if S[i, j] <= tight_rtol * (1.0 + abs(b[j])):
                tight[i, j] = True
                count[i] += 1
        if count[i] < d:
            return NOT_A_VERTEX, i, -1, keep, tight, empty_i, empty_r
        if count[i] > d:
            n_deg += 1
    degenerate = np.empty(n_deg, dtype=np.int64)
    rays = np.empty((n * d, d))
    n_rays = 0
    q = 0
    M = np.empty((d, d))
    inv = np.empty((d, d))
    W = np.empty((d, d))
    r = np.empty(d)
    end = np.empty(d)
    pv = np.empty(m)
    At = np.ascontiguousarray(A.T)  # rows' coordinates contiguous over the rows: the products below vectorise
    for i in range(n):
        if not keep[i]:
            continue
        if count[i] > d:
            degenerate[q] = i
            q += 1
            continue
        k = 0
        for j in range(m):
            if tight[i, j]:
                for c in range(d):
                    M[k, c] = A[j, c]
                k += 1
        if not _invert(M, inv, W):
            return SINGULAR, i, -1, keep, tight, empty_i, empty_r
        fro = 0.0
        for u in range(d):
            for v in range(d):
                fro += inv[u, v] * inv[u, v]
        if np.sqrt(fro) * rank_rtol >= 1.0:
            return NEARLY_DEPENDENT, i, -1, keep, tight, empty_i, empty_r
        for e in range(d):  # edge e leaves the e-th tight row: r = -A_T^-1 e_e
            nr = 0.0
            for c in range(d):
                r[c] = -inv[c, e]
                nr += r[c] * r[c]
            nr = np.sqrt(nr)
            for c in range(d):
                r[c] /= nr
            for j in range(m):
                pv[j] = 0.0
            for c in range(d):
                rc = r[c]
                for j in range(m):
                    pv[j] += At[c, j] * rc
            tmin = np.inf  # ratio test over the rows that are not tight and block the edge (branch-free)
            for j in range(m):
                p = pv[j]
                t = S[i, j] / p if (p > check_rtol and not tight[i, j]) else np.inf
                tmin = min(tmin, t)
            if tmin == np.inf:
                for c in range(d):
                    rays[n_rays, c] = r[c]
                n_rays += 1
                continue
            for c in range(d):
                end[c] = Y[i, c] + tmin * r[c]
            if _find(keys, korder, Y, end, same_rtol, w, window) < 0:
                return INCOMPLETE, i, e, keep, tight, empty_i, empty_r
    return OK, -1, -1, keep, tight, degenerate, rays[:n_rays].copy()


@kernel(cache=True)
def _same_row(M, i, j):
    """Are rows ``i`` and ``j`` of ``M`` equal entry for entry?"""
    for c in range(M.shape[1]):
        if M[i, c] != M[j, c]:
            return False
    return True


@kernel(cache=True)
def _box_mid_half(X, full_dimension_rtol):
    """Centre and half-widths of the bounding box of the points ``X`` (rows), as
    :func:`hybobs_opt.geometry._common._unit_box_map`: a width below ``full_dimension_rtol`` times
    the largest takes the largest (2 when all are zero)."""
    n, d = X.shape
    lo = X[0].copy()
    hi = X[0].copy()
    for i in range(1, n):
        for c in range(d):
            if X[i, c] < lo[c]:
                lo[c] = X[i, c]
            if X[i, c] > hi[c]:
                hi[c] = X[i, c]
    ref = 0.0
    for c in range(d):
        if hi[c] - lo[c] > ref:
            ref = hi[c] - lo[c]
    if ref <= 0.0:
        ref = 2.0
    mid = (lo + hi) / 2
    half = np.empty(d)
    for c in range(d):
        w = hi[c] - lo[c]
        half[c] = w / 2 if w > full_dimension_rtol * ref else ref / 2
    return mid, half


@kernel(cache=True)
def scale_to_box(An, bn, X, full_dimension_rtol, zero_row_tol, check_rtol):
    """Coordinates ``y = (z - mid) / half`` of the box of the points ``X``, and the rows in them.

    ``half`` follows :func:`hybobs_opt.geometry._common._unit_box_map` (widths below
    ``full_dimension_rtol`` times the largest take the largest).  Returns ``(mid, half, As, bs,
    live, contradiction, Y)``: the unit rows ``As y <= bs`` of the rows that are not constant
    (``live``), whether a constant row is violated, and the points in ``y``.
    """
    n, d = X.shape
    m = An.shape[0]
    mid, half = _box_mid_half(X, full_dimension_rtol)
    hmax = 0.0
    for c in range(d):
        if half[c] > hmax:
            hmax = half[c]
    As = np.empty((m, d))
    bs = np.empty(m)
    live = np.ones(m, dtype=np.bool_)
    contradiction = False
    q = 0
    for j in range(m):
        s = bn[j]
        nn = 0.0
        for c in range(d):
            a = An[j, c] * half[c]
            As[q, c] = a
            nn += a * a
            s -= An[j, c] * mid[c]
        nn = np.sqrt(nn)
        if nn <= zero_row_tol * hmax:
            live[j] = False
            if s < -check_rtol * (1.0 + abs(s)):
                contradiction = True
            continue
        for c in range(d):
            As[q, c] /= nn
        bs[q] = s / nn
        q += 1
    Y = np.empty((n, d))
    for i in range(n):
        for c in range(d):
            Y[i, c] = (X[i, c] - mid[c]) / half[c]
    return mid, half, As[:q].copy(), bs[:q].copy(), live, contradiction, Y


@kernel(cache=True)
def scale_and_check(An, bn, X, full_dimension_rtol, zero_row_tol, check_rtol, tight_rtol, rank_rtol, same_rtol):
    """:func:`scale_to_box` then :func:`check_kernel` in one call (numba's argument unboxing costs
    about as much as a small check).  Returns both results' fields in one tuple; the check is
    skipped (code :data:`INFEASIBLE`, ``i = j = -1``) when a constant row is violated."""
    mid, half, As, bs, live, contradiction, Y = scale_to_box(An, bn, X, full_dimension_rtol, zero_row_tol, check_rtol)
    if contradiction:
        n, d = X.shape
        return (mid, half, As, bs, live, True, Y, INFEASIBLE, -1, -1, np.ones(n, dtype=np.bool_),
                np.zeros((n, As.shape[0]), dtype=np.bool_), np.zeros(0, dtype=np.int64), np.zeros((0, d)))
    code, i, j, keep, tight, degenerate, rays = check_kernel(As, bs, Y, check_rtol, tight_rtol, rank_rtol, same_rtol)
    return mid, half, As, bs, live, False, Y, code, i, j, keep, tight, degenerate, rays


@kernel(cache=True)
def _affine_rank_at_least(P, k, rank_rtol):
    """Do the rows of ``P`` (points, each minus the first) span at least ``k`` dimensions?"""
    if k <= 0:
        return True
    if P.shape[0] < k:
        return False
    if k == 1 and rank_rtol < 1.0:
        # s[0] > rank_rtol max(s[0], 1) reads s[0] > rank_rtol; the largest singular value lies
        # between the largest row norm and the Frobenius norm, which decide it without an SVD
        # except in the gap between them (2-D facets: one SVD each saved, ~1 us)
        big = 0.0
        fro = 0.0
        for i in range(P.shape[0]):
            r = 0.0
            for c in range(P.shape[1]):
                r += P[i, c] * P[i, c]
            fro += r
            if r > big:
                big = r
        if np.sqrt(big) > rank_rtol:
            return True
        if np.sqrt(fro) <= rank_rtol:
            return False
    s = np.linalg.svd(P, full_matrices=False)[1]
    if s.shape[0] < k:
        return False
    return s[k - 1] > rank_rtol * max(s[0], 1.0)


@kernel(cache=True)
def facet_kernel(A, b, Y, tight, parallel_tol, rank_rtol, redundancy_rtol):
    """The facets of a full-dimensional polytope from its complete, checked vertex set.

    See :func:`hybobs_opt.geometry.redundancy.facets_from_vertices`.  Returns ``(code, row,
    facet)``: code 0 with the mask of rows kept; 1 the vertices are flat; 2 fewer than ``d + 1``
    facets; 3 ``row`` is a facet without a witness of non-redundancy.
    """
    m, d = A.shape
    n = Y.shape[0]
    facet = np.zeros(m, dtype=np.bool_)
    if n <= d:
        return 1, -1, facet
    c = np.zeros(d)
    for i in range(n):
        for k in range(d):
            c[k] += Y[i, k]
    c /= n
    Z = np.empty((n, d))
    for i in range(n):
        for k in range(d):
            Z[i, k] = Y[i, k] - c[k]
    s = np.linalg.svd(Z, full_matrices=False)[1]
    if s[d - 1] <= rank_rtol * s[0]:
        return 1, -1, facet
    # parallel rows on a grid of spacing parallel_tol: the one with the smallest b (then index) stays
    keys = np.empty((m, d), dtype=np.int64)
    for j in range(m):
        for k in range(d):
            keys[j, k] = np.int64(np.round(A[j, k] / parallel_tol))
    cand = np.ones(m, dtype=np.bool_)
    for j in range(m):
        for j2 in range(m):
            if j2 == j or not (b[j2] < b[j] or (b[j2] == b[j] and j2 < j)):
                continue
            if _same_row(keys, j2, j):
                cand[j] = False
                break
    n_f = 0
    for j in range(m):
        if not cand[j]:
            continue
        cnt = 0
        for i in range(n):
            if tight[i, j]:
                cnt += 1
        if cnt < d:
            continue
        if d == 1:
            facet[j] = True
            n_f += 1
            continue
        P = np.empty((cnt, d))
        q = 0
        first = -1
        for i in range(n):
            if tight[i, j]:
                if first < 0:
                    first = i
                for k in range(d):
                    P[q, k] = Y[i, k] - Y[first, k]
                q += 1
        if _affine_rank_at_least(P, d - 1, rank_rtol):
            facet[j] = True
            n_f += 1
    if n_f < d + 1:
        return 2, -1, facet
    z = np.empty(d)
    for j in range(m):
        if not facet[j]:
            continue
        for k in range(d):
            z[k] = 0.0
        cnt = 0
        for i in range(n):
            if tight[i, j]:
                for k in range(d):
                    z[k] += Y[i, k]
                cnt += 1
        tol = redundancy_rtol * (1.0 + abs(b[j]))
        for k in range(d):
            z[k] = z[k] / cnt + 3.0 * tol * A[j, k]
        own = -b[j]
        for k in range(d):
            own += A[j, k] * z[k]
        if own <= tol:
            return 3, j, facet
        for j2 in range(m):
            if j2 == j or not facet[j2]:
                continue
            v = -b[j2]
            for k in range(d):
                v += A[j2, k] * z[k]
            if v > 0.0:
                return 3, j, facet
    return 0, -1, facet


@kernel(cache=True)
def points_to_box(X, full_dimension_rtol):
    """The points ``X`` in the coordinates of their box (:func:`_box_mid_half`, in one call).

    Returns ``(mid, half, Y, c, P)``: ``y = (x - mid) / half``, the centroid ``c`` of ``Y`` and
    ``P = Y - c``.
    """
    n, d = X.shape
    mid, half = _box_mid_half(X, full_dimension_rtol)
    Y = np.empty((n, d))
    c = np.zeros(d)
    for i in range(n):
        for k in range(d):
            Y[i, k] = (X[i, k] - mid[k]) / half[k]
            c[k] += Y[i, k]
    for k in range(d):
        c[k] /= n
    P = np.empty((n, d))
    for i in range(n):
        for k in range(d):
            P[i, k] = Y[i, k] - c[k]
    return mid, half, Y, c, P


@kernel(cache=True)
def cdd_hull_rows(M, zero_row_tol):
    """cddlib's inequality rows ``M = [g | -G]`` (``g - G y >= 0``) as unit rows ``G y <= g``.

    Returns ``(violated, G, g)``: rows of norm at most ``zero_row_tol`` are dropped, and
    ``violated`` is True when one of them reads ``0 <= g`` with ``g < 0``.
    """
    m = M.shape[0]
    d = M.shape[1] - 1
    G = np.empty((m, d))
    g = np.empty(m)
    q = 0
    violated = False
    for j in range(m):
        nn = 0.0
        for k in range(d):
            nn += M[j, k + 1] * M[j, k + 1]
        nn = np.sqrt(nn)
        if not nn > zero_row_tol:
            if M[j, 0] < 0.0:
                violated = True
            continue
        for k in range(d):
            G[q, k] = -M[j, k + 1] / nn
        g[q] = M[j, 0] / nn
        q += 1
    return violated, G[:q].copy(), g[:q].copy()


#: Result codes of :func:`hull_check` before its polar vertex check (0: go on to it).
HULL_OK, HULL_POINT_VIOLATES, HULL_CENTROID_ON_ROW = 0, 1, 2


@kernel(cache=True)
def hull_check(G, g, P, c, full_dimension_rtol, zero_row_tol, check_rtol, tight_rtol, rank_rtol, same_rtol):
    """The check of ``vertices._check_hull`` up to its polar vertex check, then that check, in one call.

    ``{G y <= g}`` (unit rows) against the points ``c + P``: every point must satisfy every row
    to ``check_rtol (1 + |g_j|)`` (else code :data:`HULL_POINT_VIOLATES`), the centroid ``c``
    must lie deeper than ``rank_rtol`` in every row (else :data:`HULL_CENTROID_ON_ROW`); then the
    polar rows ``(p - c)/|p - c| y <= 1/|p - c|`` (points within ``same_rtol`` of ``c`` left out)
    and the candidate polar vertices ``G_j / depth_j`` go through :func:`scale_and_check`.
    Returns ``(hull_code, n_rows)`` followed by :func:`scale_and_check`'s tuple (meaningful when
    ``hull_code`` is :data:`HULL_OK`).
    """
    m, d = G.shape
    n = P.shape[0]
    depth = np.empty(m)
    for j in range(m):
        s = g[j]
        for k in range(d):
            s -= G[j, k] * c[k]
        depth[j] = s
    code0 = HULL_OK
    for i in range(n):
        if code0 != HULL_OK:
            break
        for j in range(m):
            v = -depth[j]
            for k in range(d):
                v += P[i, k] * G[j, k]
            if v > check_rtol * (1.0 + abs(g[j])):
                code0 = HULL_POINT_VIOLATES
                break
    if code0 == HULL_OK:
        for j in range(m):
            if depth[j] <= rank_rtol:
                code0 = HULL_CENTROID_ON_ROW
                break
    Ypol = np.empty((m, d))
    for j in range(m):
        for k in range(d):
            Ypol[j, k] = G[j, k] / depth[j]
    n_live = 0
    pn = np.empty(n)
    for i in range(n):
        s = 0.0
        for k in range(d):
            s += P[i, k] * P[i, k]
        pn[i] = np.sqrt(s)
        if pn[i] > same_rtol:
            n_live += 1
    Apol = np.empty((n_live, d))
    bpol = np.empty(n_live)
    q = 0
    for i in range(n):
        if pn[i] > same_rtol:
            for k in range(d):
                Apol[q, k] = P[i, k] / pn[i]
            bpol[q] = 1.0 / pn[i]
            q += 1
    if code0 != HULL_OK or n_live == 0:
        Ypol = np.zeros((1, d))  # not checked: a placeholder of the right type
        Apol = np.zeros((1, d))
        bpol = np.ones(1)
        if code0 == HULL_OK:
            code0 = HULL_CENTROID_ON_ROW
    return (code0, m) + scale_and_check(Apol, bpol, Ypol, full_dimension_rtol, zero_row_tol, check_rtol,
                                          tight_rtol, rank_rtol, same_rtol)


@kernel(cache=True)
def check_enumeration(An, bn, X, full_dimension_rtol, zero_row_tol, check_rtol, tight_rtol, rank_rtol, same_rtol,
                      parallel_tol, redundancy_rtol, want_facets):
    """:func:`scale_and_check` of a library's vertices, and what ``vertices._try_library`` builds from
    a passed check, in one call (a dozen small numpy operations around the check cost more than the
    check at d = 2).

    Returns :func:`scale_and_check`'s tuple (with ``live`` as the indices of the live rows) followed
    by ``(Yk, Tk, points, fcode, frow, facet)``: the kept vertices, their tight rows and the
    vertices in the given coordinates ``mid + Yk half``, filled when the check passed with simple
    vertices only and no ray (``fast``); then, if ``want_facets``, :func:`facet_kernel` on that
    vertex set (``fcode`` -1 when not decided here).
    """
    (mid, half, As, bs, live, contradiction, Y, code, i, j, keep, tight, degenerate, rays) = scale_and_check(
        An, bn, X, full_dimension_rtol, zero_row_tol, check_rtol, tight_rtol, rank_rtol, same_rtol)
    n_live = 0
    for a in range(live.shape[0]):
        if live[a]:
            n_live += 1
    rows = np.empty(n_live, dtype=np.int64)
    q = 0
    for a in range(live.shape[0]):
        if live[a]:
            rows[q] = a
            q += 1
    d = X.shape[1]
    fcode, frow = -1, -1
    facet = np.zeros(As.shape[0], dtype=np.bool_)
    fast = code == OK and not contradiction and degenerate.shape[0] == 0 and rays.shape[0] == 0
    n_keep = 0
    if fast:
        for a in range(keep.shape[0]):
            if keep[a]:
                n_keep += 1
    Yk = np.empty((n_keep, d))
    Tk = np.empty((n_keep, tight.shape[1]), dtype=np.bool_)
    pts = np.empty((n_keep, d))
    if fast:
        q = 0
        for a in range(keep.shape[0]):
            if keep[a]:
                for c in range(d):
                    Yk[q, c] = Y[a, c]
                    pts[q, c] = mid[c] + Y[a, c] * half[c]
                Tk[q] = tight[a]
                q += 1
        if want_facets:
            fcode, frow, facet = facet_kernel(As, bs, Yk, Tk, parallel_tol, rank_rtol, redundancy_rtol)
    return (fast, mid, half, As, bs, rows, contradiction, Y, code, i, j, keep, tight, degenerate, rays,
            Yk, Tk, pts, fcode, frow, facet)


@kernel(cache=True)
def polygon_kernel(Y, full_dimension_rtol, full_simplex_rtol, check_rtol, tight_rtol):
    """The 2-D hull of the points ``Y`` (monotone chain) and its check, in one compiled call.

    Returns ``(code, V, G, g, tight, area)``.  The chain drops a middle point whose turn is
    below ``full_simplex_rtol`` of its edges' lengths (collinear to rounding); the answer is then
    checked as :func:`hybobs_opt.geometry._hull_cycle._polygon` checks qhull's: every turn
    strictly to the left by that margin, the turns summing to one full turn, every point on the
    inner side of every edge (``check_rtol``).  ``code``: 0 passed, 1 fewer than 3 hull vertices,
    2 two vertices coincide or a turn is not strictly left, 3 winding not one, 4 a point violates
    an edge.
    """
    n = Y.shape[0]
    order = np.argsort(Y[:, 1], kind="mergesort")
    order = order[np.argsort(Y[order, 0], kind="mergesort")]  # lexicographic (x, y)
    H = np.empty(2 * n + 1, dtype=np.int64)
    k = 0
    for rnd in range(2):  # lower chain left to right, then upper chain right to left
        start = k
        for q in range(n):
            i = order[q] if rnd == 0 else order[n - 1 - q]
            while k >= start + 2:
                a, b = H[k - 2], H[k - 1]
                ux, uy = Y[b, 0] - Y[a, 0], Y[b, 1] - Y[a, 1]
                vx, vy = Y[i, 0] - Y[b, 0], Y[i, 1] - Y[b, 1]
                cr = ux * vy - uy * vx
                if cr > full_simplex_rtol * np.sqrt((ux * ux + uy * uy) * (vx * vx + vy * vy)):
                    break
                k -= 1
            H[k] = i
            k += 1
        k -= 1  # the last point of each chain starts the other
        if rnd == 0:
            start = k
    m = k
    V = np.empty((max(m, 0), 2))
    G = np.empty((max(m, 0), 2))
    g = np.empty(max(m, 0))
    tight = np.zeros((max(m, 0), n), dtype=np.bool_)
    if m < 3:
        return 1, V, G, g, tight, 0.0
    for j in range(m):
        V[j, 0] = Y[H[j], 0]
        V[j, 1] = Y[H[j], 1]
    L = np.empty(m)
    for j in range(m):
        nx = j + 1 if j + 1 < m else 0
        ex, ey = V[nx, 0] - V[j, 0], V[nx, 1] - V[j, 1]
        L[j] = np.sqrt(ex * ex + ey * ey)
        if not L[j] > full_dimension_rtol:
            return 2, V, G, g, tight, 0.0
        G[j, 0] = ey / L[j]
        G[j, 1] = -ex / L[j]
        g[j] = G[j, 0] * V[j, 0] + G[j, 1] * V[j, 1]
    turn = 0.0
    area = 0.0
    for j in range(m):
        nx = j + 1 if j + 1 < m else 0
        nn = nx + 1 if nx + 1 < m else 0
        ex, ey = V[nx, 0] - V[j, 0], V[nx, 1] - V[j, 1]
        fx, fy = V[nn, 0] - V[nx, 0], V[nn, 1] - V[nx, 1]
        cr = ex * fy - ey * fx
        if not cr > full_simplex_rtol * L[j] * L[nx]:
            return 2, V, G, g, tight, 0.0
        turn += np.arctan2(cr, ex * fx + ey * fy)
        area += V[j, 0] * V[nx, 1] - V[nx, 0] * V[j, 1]
    if abs(turn - 2.0 * np.pi) > 1.0:
        return 3, V, G, g, tight, 0.0
    for j in range(m):
        for i in range(n):
            s = g[j] - G[j, 0] * Y[i, 0] - G[j, 1] * Y[i, 1]
            if s < -check_rtol:
                return 4, V, G, g, tight, 0.0
            tight[j, i] = s <= tight_rtol
    return 0, V, G, g, tight, 0.5 * area


#: Result codes of :func:`triangulation_kernel` (0: passed).
(TRI_FEW, TRI_NOT_FINITE, TRI_POINT_VIOLATES, TRI_OFF_PLANE, TRI_CENTROID_ON_FACET, TRI_DUPLICATE_FACETS,
 TRI_ALL_DEGENERATE, TRI_KEYS_TOO_LARGE, TRI_SIMPLEX_TWICE, TRI_RIDGE_NOT_TWICE, TRI_NOT_CLOSED, TRI_COVERS_TWICE,
 TRI_UNDECIDED) = range(1, 14)


@kernel(cache=True)
def triangulation_kernel(Y, c, S, G, g, wplane, wpoints, same_rtol, check_rtol, tight_rtol, full_dimension_rtol,
                         full_simplex_rtol):
    """Points 1-4 of :mod:`hybobs_opt.geometry._hull_cycle` (``_facets`` and ``_cycle``) in one compiled call.

    The same decisions as the numpy functions, in the same order: simplices' planes grouped on the
    grid of ``same_rtol`` by the generic key ``wplane`` (the first simplex of each group, groups in
    key order, stands for the facet), the points against the facets, the simplices' vertices on
    their facets, the centroid's depth, no two facets with the same tight points (key
    ``wpoints``); full simplices by Hadamard's bound, every ridge in exactly two simplices with
    opposite orientations (degenerate simplices oriented by their neighbours), one test ray
    meeting one full simplex.  Returns ``(code, reps, tight, depth, volume)``; ``code`` is one of
    the ``TRI_*`` constants or 0.
    """
    n, d = Y.shape
    m = S.shape[0]
    reps = np.empty(0, dtype=np.int64)
    tight = np.zeros((0, n), dtype=np.bool_)
    depth = np.empty(0)
    if d < 2 or m < d + 1 or S.shape[1] != d:
        return TRI_FEW, reps, tight, depth, 0.0
    for j in range(m):
        if not np.isfinite(g[j]):
            return TRI_NOT_FINITE, reps, tight, depth, 0.0
        for k in range(d):
            if not np.isfinite(G[j, k]):
                return TRI_NOT_FINITE, reps, tight, depth, 0.0
    # point 1: the facets
    key = np.empty(m)
    for j in range(m):
        v = 0.0
        for k in range(d):
            v += np.rint(G[j, k] / same_rtol) * wplane[k]
        key[j] = v + np.rint(g[j] / same_rtol) * wplane[d]
    order = np.argsort(key, kind="mergesort")
    group = np.empty(m, dtype=np.int64)
    nf = 0
    for q in range(m):
        if q == 0 or key[order[q]] != key[order[q - 1]]:
            nf += 1
        group[order[q]] = nf - 1
    reps = np.empty(nf, dtype=np.int64)
    f = -1
    for q in range(m):
        if q == 0 or key[order[q]] != key[order[q - 1]]:
            f += 1
            reps[f] = order[q]
    tight = np.empty((nf, n), dtype=np.bool_)
    depth = np.empty(nf)
    for f in range(nf):
        r = reps[f]
        for i in range(n):
            s = g[r]
            for k in range(d):
                s -= G[r, k] * Y[i, k]
            if s < -check_rtol:
                return TRI_POINT_VIOLATES, reps, tight, depth, 0.0
            tight[f, i] = s <= tight_rtol
    for j in range(m):
        r = reps[group[j]]
        for a in range(d):
            s = g[r]
            for k in range(d):
                s -= Y[S[j, a], k] * G[r, k]
            if abs(s) > tight_rtol:
                return TRI_OFF_PLANE, reps, tight, depth, 0.0
    for f in range(nf):
        r = reps[f]
        s = g[r]
        for k in range(d):
            s -= G[r, k] * c[k]
        if s <= full_dimension_rtol:
            return TRI_CENTROID_ON_FACET, reps, tight, depth, 0.0
        depth[f] = s
    tk = np.zeros(nf)
    for f in range(nf):
        for i in range(n):
            if tight[f, i]:
                tk[f] += wpoints[i]
    tk.sort()
    for f in range(1, nf):
        if tk[f] == tk[f - 1]:
            return TRI_DUPLICATE_FACETS, reps, tight, depth, 0.0
    # points 2-4: the cycle
    Ss = np.empty((m, d), dtype=np.int64)
    for j in range(m):
        for a in range(d):
            Ss[j, a] = S[j, a]
        Ss[j].sort()
    W = np.empty((m, d, d))
    det = np.empty(m)
    full = np.zeros(m, dtype=np.bool_)
    orient = np.zeros(m)
    anyfull = False
    for j in range(m):
        had = 1.0
        for a in range(d):
            nn = 0.0
            for k in range(d):
                W[j, a, k] = Y[Ss[j, a], k] - c[k]
                nn += W[j, a, k] * W[j, a, k]
            had *= nn
        det[j] = np.linalg.det(W[j])
        if det[j] * det[j] > full_simplex_rtol * full_simplex_rtol * had:
            full[j] = True
            anyfull = True
            orient[j] = 1.0 if det[j] > 0 else -1.0
    if not anyfull:
        return TRI_ALL_DEGENERATE, reps, tight, depth, 0.0
    if float(n) ** d >= 2.0 ** 62:
        return TRI_KEYS_TOO_LARGE, reps, tight, depth, 0.0
    wts = np.empty(d, dtype=np.int64)
    wts[d - 1] = 1
    for a in range(d - 2, -1, -1):
        wts[a] = wts[a + 1] * n
    sk = np.empty(m, dtype=np.int64)
    for j in range(m):
        v = 0
        for a in range(d):
            v += Ss[j, a] * wts[a]
        sk[j] = v
    sk.sort()
    for j in range(1, m):
        if sk[j] == sk[j - 1]:
            return TRI_SIMPLEX_TWICE, reps, tight, depth, 0.0
    t = m * d
    rk = np.empty(t, dtype=np.int64)
    for j in range(m):
        for kk in range(d):  # ridge kk of simplex j: vertex kk left out
            v = 0
            col = 0
            for a in range(d):
                if a != kk:
                    v += Ss[j, a] * wts[col + 1]
                    col += 1
            rk[j * d + kk] = v
    rorder = np.argsort(rk, kind="mergesort")
    if t % 2:
        return TRI_RIDGE_NOT_TWICE, reps, tight, depth, 0.0
    for q in range(0, t, 2):
        if rk[rorder[q]] != rk[rorder[q + 1]]:
            return TRI_RIDGE_NOT_TWICE, reps, tight, depth, 0.0
        if q + 2 < t and rk[rorder[q + 1]] == rk[rorder[q + 2]]:
            return TRI_RIDGE_NOT_TWICE, reps, tight, depth, 0.0
    h = t // 2
    oa = np.empty(h, dtype=np.int64)
    ob = np.empty(h, dtype=np.int64)
    pa = np.empty(h)
    pb = np.empty(h)
    for q in range(h):
        a_, b_ = rorder[2 * q], rorder[2 * q + 1]
        oa[q], ob[q] = a_ // d, b_ // d
        pa[q] = 1.0 if (a_ % d) % 2 == 0 else -1.0
        pb[q] = 1.0 if (b_ % d) % 2 == 0 else -1.0
    nzero = 0
    for j in range(m):
        if orient[j] == 0.0:
            nzero += 1
    while nzero > 0:  # degenerate simplices take the orientation their neighbours require
        changed = True
        while changed:
            changed = False
            new = orient.copy()
            for q in range(h):
                if orient[oa[q]] != 0.0 and orient[ob[q]] == 0.0:
                    new[ob[q]] = -orient[oa[q]] * pa[q] * pb[q]
                    changed = True
                if orient[ob[q]] != 0.0 and orient[oa[q]] == 0.0:
                    new[oa[q]] = -orient[ob[q]] * pa[q] * pb[q]
                    changed = True
            orient = new
        nzero = 0
        first = -1
        for j in range(m):
            if orient[j] == 0.0:
                nzero += 1
                if first < 0:
                    first = j
        if first >= 0:
            orient[first] = 1.0
            nzero -= 1
    for q in range(h):
        if orient[oa[q]] * pa[q] + orient[ob[q]] * pb[q] != 0.0:
            return TRI_NOT_CLOSED, reps, tight, depth, 0.0
    # point 4: one test ray, through the vertex mean of one of the five largest full simplices
    nfull = 0
    for j in range(m):
        if full[j]:
            nfull += 1
    idx = np.empty(nfull, dtype=np.int64)
    negvol = np.empty(nfull)
    q = 0
    for j in range(m):
        if full[j]:
            idx[q] = j
            negvol[q] = -abs(det[j])
            q += 1
    cand = idx[np.argsort(negvol, kind="mergesort")]
    margin = HULL_RAY_WEIGHT_MARGIN
    covers = 0
    u = np.empty(d)
    for ci in range(min(5, nfull)):
        tt = cand[ci]
        for k in range(d):
            v = 0.0
            for a in range(d):
                v += W[tt, a, k]
            u[k] = v / d
        undecided = False
        cnt = 0
        for q in range(nfull):
            lam = np.linalg.solve(W[idx[q]].T.copy(), u)
            lo = lam.min()
            if lo > -margin and lo <= margin:
                undecided = True
                break
            if lo > margin:
                cnt += 1
        if undecided:
            continue
        covers = cnt
        break
    if covers != 1:
        return (TRI_COVERS_TWICE if covers else TRI_UNDECIDED), reps, tight, depth, 0.0
    vol = 0.0
    for j in range(m):
        if full[j]:
            vol += abs(det[j])
    fact = 1.0
    for a in range(2, d + 1):
        fact *= a
    return 0, reps, tight, depth, vol / fact


@kernel(cache=True)
def facet_volume_3d(Y, A, b, tight, full_dimension_rtol, affine_rtol, full_simplex_rtol):
    """Volume of a 3-polytope from its checked vertices ``Y`` and incidence ``tight`` (n, m), or a code.

    Each facet (a row whose tight vertices span a plane; rows with the same tight vertices once)
    is the convex polygon of its vertices: in coordinates of the row's plane they are taken in
    angular order about their mean, every turn must be strictly to the left (by
    ``full_simplex_rtol`` of the edges' lengths), and its shoelace area times the vertex mean's
    depth, over 3, is its pyramid.  Euler's formula ``V - E + F = 2`` (``E`` half the polygons'
    sides) must hold.  Returns ``(code, volume)``: 0 passed, 1 the vertex mean on a facet, 2 a
    polygon not strictly convex in angular order, 3 Euler's formula fails.
    """
    n = Y.shape[0]
    m = A.shape[0]
    c = np.zeros(3)
    for i in range(n):
        for k in range(3):
            c[k] += Y[i, k]
    for k in range(3):
        c[k] /= n
    used = np.zeros((m, n), dtype=np.bool_)
    nf = 0
    sides = 0
    volume = 0.0
    idx = np.empty(n, dtype=np.int64)
    for j in range(m):
        q = 0
        for i in range(n):
            if tight[i, j]:
                idx[q] = i
                q += 1
        if q < 3:
            continue
        dup = False
        for f in range(nf):
            same = True
            for i in range(n):
                if used[f, i] != tight[i, j]:
                    same = False
                    break
            if same:
                dup = True
                break
        if dup:
            continue
        a0, a1, a2 = A[j, 0], A[j, 1], A[j, 2]
        # an orthonormal basis (e, f) of the row's plane: e across the normal's smallest coordinate
        if abs(a0) <= abs(a1) and abs(a0) <= abs(a2):
            e0, e1, e2 = 0.0, -a2, a1
        elif abs(a1) <= abs(a2):
            e0, e1, e2 = a2, 0.0, -a0
        else:
            e0, e1, e2 = -a1, a0, 0.0
        en = np.sqrt(e0 * e0 + e1 * e1 + e2 * e2)
        e0, e1, e2 = e0 / en, e1 / en, e2 / en
        f0, f1, f2 = a1 * e2 - a2 * e1, a2 * e0 - a0 * e2, a0 * e1 - a1 * e0
        fn = np.sqrt(f0 * f0 + f1 * f1 + f2 * f2)
        f0, f1, f2 = f0 / fn, f1 / fn, f2 / fn
        Z = np.empty((q, 2))
        mz0, mz1 = 0.0, 0.0
        for r in range(q):
            p = idx[r]
            Z[r, 0] = e0 * Y[p, 0] + e1 * Y[p, 1] + e2 * Y[p, 2]
            Z[r, 1] = f0 * Y[p, 0] + f1 * Y[p, 1] + f2 * Y[p, 2]
            mz0 += Z[r, 0]
            mz1 += Z[r, 1]
        mz0 /= q
        mz1 /= q
        s00, s01, s11 = 0.0, 0.0, 0.0
        ang = np.empty(q)
        for r in range(q):
            Z[r, 0] -= mz0
            Z[r, 1] -= mz1
            s00 += Z[r, 0] * Z[r, 0]
            s01 += Z[r, 0] * Z[r, 1]
            s11 += Z[r, 1] * Z[r, 1]
            ang[r] = np.arctan2(Z[r, 1], Z[r, 0])
        # singular values of Z: the square roots of the eigenvalues of Z'Z (a lower-dimensional face: no area)
        tr, disc = s00 + s11, np.sqrt((s00 - s11) * (s00 - s11) + 4.0 * s01 * s01)
        smax, smin = np.sqrt(max(0.5 * (tr + disc), 0.0)), np.sqrt(max(0.5 * (tr - disc), 0.0))
        if smin <= affine_rtol * max(smax, 1.0):
            continue
        depth = b[j] - (A[j, 0] * c[0] + A[j, 1] * c[1] + A[j, 2] * c[2])
        if depth <= full_dimension_rtol:
            return 1, 0.0
        order = np.argsort(ang, kind="mergesort")
        area = 0.0
        for r in range(q):
            u, v, w = order[r], order[(r + 1) % q], order[(r + 2) % q]
            ex, ey = Z[v, 0] - Z[u, 0], Z[v, 1] - Z[u, 1]
            fx, fy = Z[w, 0] - Z[v, 0], Z[w, 1] - Z[v, 1]
            if not ex * fy - ey * fx > full_simplex_rtol * np.sqrt((ex * ex + ey * ey) * (fx * fx + fy * fy)):
                return 2, 0.0
            area += Z[u, 0] * Z[v, 1] - Z[v, 0] * Z[u, 1]
        for i in range(n):
            used[nf, i] = tight[i, j]
        nf += 1
        sides += q
        volume += depth * 0.5 * area / 3.0
    if sides % 2 or n - sides // 2 + nf != 2:
        return 3, 0.0
    return 0, volume


# numba dispatchers when the cache holds them (tiered: after enough kernel work), else plain Python
# in this process (see _numba_cache)
_finalize_kernels(globals(), tiered=True, weight=10)

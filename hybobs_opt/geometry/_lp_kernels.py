"""Compiled helpers of the certified max-slack LPs (:func:`hybobs_opt.geometry.lp.max_slack`).

Algorithm 3.1 of paper 002 solves tens of thousands of LPs with about ten variables each; a
DAQP solve takes some 40 microseconds, and a dozen small numpy calls around it (row
normalisation, building the LP, the two certified bounds) cost more than the solve.  These
loops do that work in one compiled call each.  numba caches them on disk.
"""

from __future__ import annotations

import numpy as np

from .._numba_cache import finalize_kernels as _finalize_kernels
from .._numba_cache import kernel


@kernel(cache=True)
def slack_lp_data(G, g, zero_tol, cap):
    """``max t  s.t.  G_k w / |G_k| + t <= g_k / |G_k|,  t <= cap`` as DAQP data ``(A, bu)``.

    Rows with ``|G_k| <= zero_tol`` are constant: dropped when they hold, and ``ok = False``
    (the set is empty) when one reads ``0 <= g_k < -zero_tol``.
    """
    k, d = G.shape
    norms = np.empty(k)
    keep = 0
    for r in range(k):
        s = 0.0
        for c in range(d):
            s += G[r, c] * G[r, c]
        s = np.sqrt(s)
        norms[r] = s
        if s <= zero_tol:
            if g[r] < -zero_tol:
                return np.zeros((0, d + 1)), np.zeros(0), False
        else:
            keep += 1
    A = np.zeros((keep + 1, d + 1))
    bu = np.empty(keep + 1)
    q = 0
    for r in range(k):
        if norms[r] > zero_tol:
            inv = 1.0 / norms[r]
            for c in range(d):
                A[q, c] = G[r, c] * inv
            A[q, d] = 1.0
            bu[q] = g[r] * inv
            q += 1
    A[keep, d] = 1.0
    bu[keep] = cap
    return A, bu, True


@kernel(cache=True)
def slack_lp_rows(G, g, zero_tol, cap):
    """:func:`slack_lp_data` and the indices of the rows of ``G`` it kept (``keep``), from the same norms."""
    A, bu, ok = slack_lp_data(G, g, zero_tol, cap)
    keep = np.empty(A.shape[0] - 1 if ok else 0, dtype=np.int64)
    if ok:
        q = 0
        for r in range(G.shape[0]):
            s = 0.0
            for c in range(G.shape[1]):
                s += G[r, c] * G[r, c]
            if np.sqrt(s) > zero_tol:
                keep[q] = r
                q += 1
    return A, bu, ok, keep


@kernel(cache=True)
def min_row_slack(A, bu, c):
    """``min_k (bu_k - A_k[:-1] c)`` over the rows but the last of a slack LP's data (``+inf`` if none)."""
    k = A.shape[0] - 1
    d = A.shape[1] - 1
    low = np.inf
    for r in range(k):
        v = bu[r]
        for q in range(d):
            v -= A[r, q] * c[q]
        if v < low:
            low = v
    return low


@kernel(cache=True)
def slack_bounds(A, bu, x, lam, radius_bound, cap):
    """Certified ``(lower, upper)`` bounds on the max slack of the LP ``(A, bu)`` built above.

    The rows may have any norm; only the coefficient 1 of ``t`` in every row is assumed.
    ``lower`` is the smallest row slack at the point ``x[:d]`` (a feasible point's value);
    ``upper = (g' lambda + cap mu + R |G' lambda|) / (1' lambda + mu)`` for the clipped
    multipliers, valid for every feasible ``w`` with ``|w| <= R`` (weak duality, with the
    stationarity residual bounded by Cauchy-Schwarz).  ``upper = inf`` without usable multipliers;
    ``(-inf, inf)`` (nothing certified) when the point or a multiplier is not finite.
    """
    k = A.shape[0] - 1
    d = A.shape[1] - 1
    # A non-finite point or multiplier certifies nothing (every comparison with NaN is false, so
    # the loops below would keep the cap as a "certified" lower bound): undecided.
    for c in range(d + 1):
        if not np.isfinite(x[c]):
            return -np.inf, np.inf
    for r in range(k + 1):
        if not np.isfinite(lam[r]):
            return -np.inf, np.inf
    lower = min(cap, min_row_slack(A, bu, x))
    station = np.zeros(d)
    num = 0.0
    den = 0.0
    for r in range(k):
        lr = lam[r] if lam[r] > 0.0 else 0.0
        if lr > 0.0:
            den += lr
            num += bu[r] * lr
            for c in range(d):
                station[c] += lr * A[r, c]
    mu = lam[k] if lam[k] > 0.0 else 0.0
    den += mu
    num += cap * mu
    if den <= 0.0:
        return lower, np.inf
    return lower, (num + radius_bound * np.sqrt(np.sum(station * station))) / den


@kernel(cache=True)
def answer_ok(A, b, x, lam, rtol):
    """The numpy checks of :func:`hybobs_opt.geometry.lp.daqp_answer_ok` in one compiled loop.

    ``x`` finite and every row ``A_k x - b_k <= rtol (1 + |b_k| + |A_k| |x|)``; ``lam`` finite and
    ``min lam >= -rtol max(1, max |lam|)``.  Shapes are checked by the caller.
    """
    k, d = A.shape
    for c in range(d):
        if not np.isfinite(x[c]):
            return False
    big = 1.0
    low = 0.0
    for r in range(k):
        v = lam[r]
        if not np.isfinite(v):
            return False
        if abs(v) > big:
            big = abs(v)
        if v < low:
            low = v
    if low < -rtol * big:
        return False
    for r in range(k):
        acc = -b[r]
        scale = 1.0 + abs(b[r])
        for c in range(d):
            acc += A[r, c] * x[c]
            scale += abs(A[r, c]) * abs(x[c])
        if not acc <= rtol * scale:
            return False
    return True


@kernel(cache=True)
def implicit_row_bounds(G, g, lam, radius_bound, relax):
    """Slack bounds of the rows of ``{G v <= g + relax}`` from multipliers ``lam`` (see
    :func:`hybobs_opt.regions.pair_geometry._certified_implicit_rows`): ``total / lam_k`` with
    ``total = max(0, (g + relax)' lam + R |G' lam|)`` for ``lam_k > 0``, ``inf`` elsewhere; the
    multipliers are clipped at zero and non-finite ones are dropped."""
    k, d = G.shape
    station = np.zeros(d)
    total = 0.0
    lam_c = np.zeros(k)
    for r in range(k):
        v = lam[r]
        if np.isfinite(v) and v > 0.0:
            lam_c[r] = v
            total += (g[r] + relax) * v
            for q in range(d):
                station[q] += v * G[r, q]
    total += radius_bound * np.sqrt(np.sum(station * station))
    if total < 0.0:
        total = 0.0
    out = np.full(k, np.inf)
    for r in range(k):
        if lam_c[r] > 0.0:
            out[r] = total / lam_c[r]
    return out


@kernel(cache=True)
def _restrict_rows(Hx, HU, h, N, w0, off, base, G, g):
    """Rows ``Hx y + HU U <= h`` of one region (``y`` = ``w[off:off + n]``) written as ``G v <= g``
    into rows ``base...`` of ``G, g``, for ``w = w0 + N v`` (``U`` = ``w[2n:]``)."""
    n = Hx.shape[1]
    mU = HU.shape[1]
    q = N.shape[1]
    for row in range(Hx.shape[0]):
        acc = h[row]
        Grow = G[base + row]
        Grow[:] = 0.0
        # inner loops run along the rows of N (contiguous): LLVM vectorises them
        for t in range(n):
            a = Hx[row, t]
            acc -= a * w0[off + t]
            for c in range(q):
                Grow[c] += a * N[off + t, c]
        for t in range(mU):
            a = HU[row, t]
            acc -= a * w0[2 * n + t]
            for c in range(q):
                Grow[c] += a * N[2 * n + t, c]
        g[base + row] = acc


@kernel(cache=True)
def restricted_pair_rows(HxI, HUI, hI, HxJ, HUJ, hJ, U, s, Vt, r, N, e, consistency_rtol):
    """Constraints of ``R_ij`` restricted to its output-equality subspace ``w = w0 + N v``.

    ``HxI x + HUI U <= hI`` and ``HxJ x^ + HUJ U <= hJ`` are the rows of ``P_i`` and ``P_j``
    over ``w = (x, x^, U)`` (so the rows of ``P_i`` are zero on ``x^`` and those of ``P_j`` on
    ``x``, which the loops skip); the equalities ``E w = e`` are given by the SVD
    ``E = U diag(s) Vt`` of numerical rank ``r``, so ``w0 = Vt[:r]' (U[:, :r]' e / s[:r])``, and
    ``N = Vt[r:]'`` is passed as a contiguous array.

    Returns ``(G, g, w0, consistent)``: ``G v <= g`` in the subspace coordinates ``v``, and
    ``consistent = False`` when ``e`` is not in ``range(E)`` (relative residual above
    ``consistency_rtol``), i.e. the outputs can never be equal.
    """
    p = U.shape[0]
    dim = Vt.shape[0]
    n = HxI.shape[1]
    q = dim - r
    coef = np.zeros(r)
    for a in range(r):
        acc = 0.0
        for b in range(p):
            acc += U[b, a] * e[b]
        coef[a] = acc
    resid2 = 0.0
    enorm2 = 0.0
    for b in range(p):
        acc = e[b]
        for a in range(r):
            acc -= U[b, a] * coef[a]
        resid2 += acc * acc
        enorm2 += e[b] * e[b]
    if np.sqrt(resid2) > consistency_rtol * (1.0 + np.sqrt(enorm2)):
        return np.zeros((0, q)), np.zeros(0), np.zeros(dim), False
    w0 = np.zeros(dim)
    for a in range(r):
        ca = coef[a] / s[a]
        for t in range(dim):
            w0[t] += Vt[a, t] * ca
    nI, nJ = HxI.shape[0], HxJ.shape[0]
    G = np.empty((nI + nJ, q))
    g = np.empty(nI + nJ)
    _restrict_rows(HxI, HUI, hI, N, w0, 0, 0, G, g)
    _restrict_rows(HxJ, HUJ, hJ, N, w0, n, nI, G, g)
    return G, g, w0, True


@kernel(cache=True)
def support_upper_bound(A, b, c, lam, radius_bound):
    """Certified upper bound on ``max c'v`` over ``{A v <= b, |v| <= R}`` from multipliers ``lam``.

    For any ``lam >= 0``: ``c'v = lam'A v + (c - A'lam)'v <= lam'b + R |c - A'lam|`` (weak
    duality, the residual bounded by Cauchy-Schwarz).  ``lam`` is clipped at zero; a non-finite
    multiplier certifies nothing (``inf``).
    """
    k, d = A.shape
    for r in range(k):
        if not np.isfinite(lam[r]):
            return np.inf
    resid = c.copy()
    val = 0.0
    for r in range(k):
        lr = lam[r] if lam[r] > 0.0 else 0.0
        if lr > 0.0:
            val += lr * b[r]
            for q in range(d):
                resid[q] -= lr * A[r, q]
    return val + radius_bound * np.sqrt(np.sum(resid * resid))


# numba dispatchers when the cache holds them, else plain Python in this process (see _numba_cache)
_finalize_kernels(globals(), tiered=True, weight=10)

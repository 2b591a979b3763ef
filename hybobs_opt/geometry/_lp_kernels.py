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
def slack_lp_rows(G, g, zero_tol, cap):
    """:func:`slack_lp_data` and the indices of the rows of ``G`` it kept (``keep``), from the same norms."""
    k, d = G.shape
    norms = np.empty(k)
    keep = np.empty(k, dtype=np.int64)
    n_keep = 0
    for r in range(k):
        s = 0.0
        for c in range(d):
            s += G[r, c] * G[r, c]
        s = np.sqrt(s)
        norms[r] = s
        if s <= zero_tol:
            if g[r] < -zero_tol:
                return np.zeros((0, d + 1)), np.zeros(0), False, np.empty(0, dtype=np.int64)
        else:
            keep[n_keep] = r
            n_keep += 1
    A = np.zeros((n_keep + 1, d + 1))
    bu = np.empty(n_keep + 1)
    for q in range(n_keep):
        r = keep[q]
        inv = 1.0 / norms[r]
        for c in range(d):
            A[q, c] = G[r, c] * inv
        A[q, d] = 1.0
        bu[q] = g[r] * inv
    A[n_keep, d] = 1.0
    bu[n_keep] = cap
    return A, bu, True, keep[:n_keep]


@kernel(cache=True)
def slack_lp_data(G, g, zero_tol, cap):
    """``max t  s.t.  G_k w / |G_k| + t <= g_k / |G_k|,  t <= cap`` as DAQP data ``(A, bu)``.

    Rows with ``|G_k| <= zero_tol`` are constant: dropped when they hold, and ``ok = False``
    (the set is empty) when one reads ``0 <= g_k < -zero_tol``.
    """
    A, bu, ok, _ = slack_lp_rows(G, g, zero_tol, cap)
    return A, bu, ok


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
def max_abs_affine(M, c, c0):
    """``max_k |M_k c + c0_k|`` with each product summed left to right (the bits of
    ``np.max(np.abs(matmul(M, c) + c0))``); ``-inf`` for no rows, NaN when an entry is NaN."""
    out = -np.inf
    for r in range(M.shape[0]):
        acc = 0.0
        for q in range(M.shape[1]):
            acc += M[r, q] * c[q]
        v = abs(acc + c0[r])
        if v > out or v != v:
            out = v
            if v != v:
                return v
    return out


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
def checked_slack_bounds(A, b, x, lam, rtol, radius_bound, cap):
    """:func:`answer_ok` and then :func:`slack_bounds` of a DAQP answer in one call: ``(ok, lower,
    upper)``, ``ok`` False (and nothing certified) when the shapes or the checks fail."""
    if x.shape[0] != A.shape[1] or lam.shape[0] != A.shape[0] or b.shape[0] != A.shape[0]:
        return False, -np.inf, np.inf
    if not answer_ok(A, b, x, lam, rtol):
        return False, -np.inf, np.inf
    lower, upper = slack_bounds(A, b, x, lam, radius_bound, cap)
    return True, lower, upper


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
def restricted_region_rows(Hx, HU, N, off):
    """The left-hand sides of one region's rows ``Hx y + HU U <= h`` (``y`` = ``w[off:off + n]``,
    ``U`` = ``w[2n:]``) for ``w = w0 + N v``: ``Hx N[off:off + n] + HU N[2n:]``, summed over ``t``
    in that order.  They depend on the region and the subspace only, so a region paired with many
    regions of one output-map class shares them."""
    n = Hx.shape[1]
    mU = HU.shape[1]
    q = N.shape[1]
    G = np.zeros((Hx.shape[0], q))
    for row in range(Hx.shape[0]):
        # inner loops run along the rows of N (contiguous): LLVM vectorises them.  A zero
        # coefficient is skipped: its products are zeros, which leave every partial sum's bits
        # as they are (a sum started at +0.0 never becomes -0.0), and a row of HU is zero on the
        # inputs after its step.
        for t in range(n):
            a = Hx[row, t]
            if a != 0.0:
                for c in range(q):
                    G[row, c] += a * N[off + t, c]
        for t in range(mU):
            a = HU[row, t]
            if a != 0.0:
                for c in range(q):
                    G[row, c] += a * N[2 * n + t, c]
    return G


@kernel(cache=True)
def _restrict_rhs(Hx, HU, h, w0, off, base, g):
    """The right-hand sides ``h - Hx w0[off:off + n] - HU w0[2n:]`` of one region's rows into ``g[base:]``."""
    n = Hx.shape[1]
    mU = HU.shape[1]
    for row in range(Hx.shape[0]):
        acc = h[row]
        for t in range(n):
            acc -= Hx[row, t] * w0[off + t]
        for t in range(mU):
            acc -= HU[row, t] * w0[2 * n + t]
        g[base + row] = acc


@kernel(cache=True)
def restricted_pairs_rows(HxI, HUI, hI, fI, GI, Hx, HU, h, F, offsets, js, U, s, Vt, r, N, consistency_rtol):
    """Constraints of the pair sets ``R_ij``, ``j`` in ``js``, restricted to their output-equality subspace ``w = w0 + N v``.

    The regions ``j`` are of one output-map class, so the pairs share the equalities ``E w = e_j``
    (``E = [C_i, -C_j, D_i - D_j]``, ``e_j = f_j - f_i``), given by the SVD ``E = U diag(s) Vt``
    of numerical rank ``r``: ``w0 = Vt[:r]' (U[:, :r]' e_j / s[:r])`` and ``N = Vt[r:]'``
    (contiguous).  ``HxI x + HUI U <= hI`` are the rows of ``P_i`` over ``w = (x, x^, U)`` (zero
    on ``x^``), ``fI`` its output offsets and ``GI`` its :func:`restricted_region_rows` (offset
    0) on ``N``; ``Hx, HU, h, F`` hold every region's rows and output offsets stacked (region
    ``j``'s rows are ``offsets[j]:offsets[j + 1]``, zero on ``x``).

    Returns ``(G, g, W0, consistent, start, w0_norm)``: ``G v <= g`` of the ``t``-th pair are
    the rows ``start[t]:start[t + 1]``, none when ``consistent[t]`` is False (``e_j`` not in
    ``range(E)``: relative residual above ``consistency_rtol``, the outputs can never be equal);
    ``W0[t]`` is its ``w0`` and ``w0_norm[t]`` that vector's norm (the sum of squares left to
    right).
    """
    k = js.shape[0]
    p = U.shape[0]
    dim = Vt.shape[0]
    n = HxI.shape[1]
    q = dim - r
    nI = HxI.shape[0]
    start = np.zeros(k + 1, dtype=np.int64)
    for t in range(k):
        start[t + 1] = start[t] + nI + offsets[js[t] + 1] - offsets[js[t]]
    G = np.empty((start[k], q))
    g = np.empty(start[k])
    W0 = np.zeros((k, dim))
    consistent = np.zeros(k, dtype=np.bool_)
    w0_norm = np.zeros(k)
    e = np.empty(p)
    coef = np.zeros(r)
    end = 0
    for t in range(k):
        j = js[t]
        for b in range(p):
            e[b] = F[j, b] - fI[b]
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
            start[t] = end  # no rows: the pairs after it move up
            continue
        consistent[t] = True
        for a in range(r):
            ca = coef[a] / s[a]
            for c in range(dim):
                W0[t, c] += Vt[a, c] * ca
        lo, hi = offsets[j], offsets[j + 1]
        G[end:end + nI] = GI
        G[end + nI:end + nI + hi - lo] = restricted_region_rows(Hx[lo:hi], HU[lo:hi], N, n)
        w0 = W0[t]
        _restrict_rhs(HxI, HUI, hI, w0, 0, end, g)
        _restrict_rhs(Hx[lo:hi], HU[lo:hi], h[lo:hi], w0, n, end + nI, g)
        acc = 0.0
        for c in range(dim):
            acc += w0[c] * w0[c]
        w0_norm[t] = np.sqrt(acc)
        start[t] = end
        end += nI + hi - lo
    start[k] = end
    return G[:end], g[:end], W0, consistent, start, w0_norm


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


@kernel(cache=True)
def _walk_step(AT, b, c, sign, frac, point, basis, n_basis, rate, slack):
    """One step of a walk of :func:`walk_width_lower_bound` from ``point`` (updated in place).

    The step goes along the part of ``sign * c`` parallel to the rows that stopped the earlier
    steps (``basis[:n_basis]``, orthonormal), ``frac`` of the way to the first row it would
    cross, which then joins the basis (Gram-Schmidt, in the order met).  Returns the new basis
    size, or ``-1`` when the walk is over: that part vanishes, no row stops it (an unbounded
    direction: the point stays) or a row is already violated.  ``AT`` is the rows transposed;
    ``rate`` and ``slack`` are scratch of one entry per row.
    """
    d, k = AT.shape
    cnorm = 0.0
    for q in range(d):
        cnorm += c[q] * c[q]
    cnorm = np.sqrt(cnorm)
    direction = np.empty(d)
    for q in range(d):
        direction[q] = sign * c[q]
    for j in range(n_basis):
        proj = 0.0
        for q in range(d):
            proj += basis[j, q] * direction[q]
        for q in range(d):
            direction[q] -= proj * basis[j, q]
    dnorm = 0.0
    for q in range(d):
        dnorm += direction[q] * direction[q]
    dnorm = np.sqrt(dnorm)
    if not dnorm > 1e-9 * cnorm:
        return -1
    # A_r direction and b_r - A_r point for every row, each row's terms in the order of q
    for r in range(k):
        rate[r] = 0.0
        slack[r] = b[r]
    for q in range(d):
        dq = direction[q]
        pq = point[q]
        for r in range(k):
            rate[r] += AT[q, r] * dq
            slack[r] -= AT[q, r] * pq
    step = np.inf
    block = -1
    for r in range(k):
        if rate[r] > 1e-12 * dnorm:
            if slack[r] < 0.0:
                return -1
            ratio = slack[r] / rate[r]
            if ratio < step:
                step = ratio
                block = r
    if block < 0:
        return -1
    step *= frac
    for q in range(d):
        point[q] += step * direction[q]
    if n_basis >= basis.shape[0]:
        return -1
    for q in range(d):
        basis[n_basis, q] = AT[q, block]
    for j in range(n_basis):
        proj = 0.0
        for q in range(d):
            proj += basis[j, q] * basis[n_basis, q]
        for q in range(d):
            basis[n_basis, q] -= proj * basis[j, q]
    bnorm = 0.0
    for q in range(d):
        bnorm += basis[n_basis, q] * basis[n_basis, q]
    bnorm = np.sqrt(bnorm)
    if not bnorm > 1e-9:
        return -1
    for q in range(d):
        basis[n_basis, q] /= bnorm
    return n_basis + 1


@kernel(cache=True)
def _certified_feasible(AT, b, x, acc, scale):
    """Is ``A x <= b`` certain for the floating-point ``x``: every row's computed ``A_k x - b_k``
    plus its rounding-error bound ``gamma_{d+2} (|A_k| |x| + |b_k|)`` at most zero?  ``AT`` is
    the rows transposed; ``acc``, ``scale`` scratch of one entry per row."""
    d, k = AT.shape
    gamma = (d + 3) * 1.1102230246251565e-16
    for r in range(k):
        acc[r] = -b[r]
        scale[r] = abs(b[r])
    for q in range(d):
        xq = x[q]
        ax = abs(xq)
        for r in range(k):
            acc[r] += AT[q, r] * xq
            scale[r] += abs(AT[q, r]) * ax
    for r in range(k):
        if not acc[r] + gamma * scale[r] * 1.0000001 <= 0.0:
            return False
    return True


@kernel(cache=True)
def _proven_width(AT, b, c, top, bottom, acc, scale):
    """``c'(top - bottom)`` minus its rounding-error bound when both points are certified points of
    ``{A v <= b}`` (:func:`_certified_feasible`, ``AT`` the rows transposed), else ``-inf``: a
    lower bound on the set's width along ``c``."""
    d = AT.shape[0]
    if not (_certified_feasible(AT, b, top, acc, scale) and _certified_feasible(AT, b, bottom, acc, scale)):
        return -np.inf
    width = 0.0
    scale_c = 0.0
    for q in range(d):
        width += c[q] * (top[q] - bottom[q])
        scale_c += abs(c[q]) * (abs(top[q]) + abs(bottom[q]))
    return width - (d + 4) * 1.1102230246251565e-16 * scale_c * 1.0000001


@kernel(cache=True)
def walk_width_lower_bound(A, b, p, c, steps, frac, target):
    """A proven lower bound on the width ``max c'v - min c'v`` of ``{A v <= b}``, with no LP.

    Two walks start from the interior point ``p``, one along ``c`` and one along ``-c``, and
    take their ratio-test steps in turn (:func:`_walk_step`: each ``frac`` of the way to the row
    that stops it, later steps parallel to the rows met), up to ``steps`` each, until their end
    points are more than ``target`` apart along ``c`` (in floating point) or neither can go on.
    The two end points are then checked to satisfy every row with a rounding-error bound, so
    they are points of the set, and ``c'(v+ - v-)`` minus its own rounding-error bound is at
    most the width (:func:`_proven_width`).  Returns ``-inf`` when an end point is not certified
    feasible or a number is not finite.

    The walks are a cheap first try at the two LPs of a width test: a set that they prove wider
    than the threshold needs neither LP, and a set they do not prove wide goes to the LPs.
    The rows are transposed once: every pass over them then runs along contiguous memory, with
    each row's sum in the order of its terms (the bits of one loop per row).
    """
    k, d = A.shape
    for q in range(d):
        if not (np.isfinite(p[q]) and np.isfinite(c[q])):
            return -np.inf
    AT = np.empty((d, k))
    for r in range(k):
        for q in range(d):
            AT[q, r] = A[r, q]
    u = np.empty(k)
    w = np.empty(k)
    top = p.copy()
    bottom = p.copy()
    basis_top = np.zeros((steps, d))
    basis_bottom = np.zeros((steps, d))
    n_top = 0
    n_bottom = 0
    for _ in range(steps):
        if n_top >= 0:
            n_top = _walk_step(AT, b, c, 1.0, frac, top, basis_top, n_top, u, w)
        if n_bottom >= 0:
            n_bottom = _walk_step(AT, b, c, -1.0, frac, bottom, basis_bottom, n_bottom, u, w)
        apart = 0.0
        for q in range(d):
            apart += c[q] * (top[q] - bottom[q])
        if apart > target or (n_top < 0 and n_bottom < 0):
            break
    return _proven_width(AT, b, c, top, bottom, u, w)


def _seq_sum(x: np.ndarray) -> float:
    """``x[0] + x[1] + ...`` from first to last, as the kernels' loops add (``+ 0.0``: their sums start at +0)."""
    return float(np.cumsum(x)[-1]) + 0.0 if x.size else 0.0


def _walk_step_numpy(A, b, c, sign, frac, point, basis, n_basis):
    """:func:`_walk_step` in NumPy: the same operations in the same order (rows vectorised)."""
    k, d = A.shape
    cnorm = np.sqrt(_seq_sum(c * c))
    direction = sign * c
    for j in range(n_basis):
        direction = direction - _seq_sum(basis[j] * direction) * basis[j]
    dnorm = np.sqrt(_seq_sum(direction * direction))
    if not dnorm > 1e-9 * cnorm:
        return -1
    rate = np.zeros(k)
    for q in range(d):
        rate = rate + A[:, q] * direction[q]
    rows = np.nonzero(rate > 1e-12 * dnorm)[0]
    if rows.size == 0:
        return -1
    slack = b[rows].copy()
    for q in range(d):
        slack = slack - A[rows, q] * point[q]
    if np.any(slack < 0.0):
        return -1
    ratio = slack / rate[rows]
    first = int(np.argmin(ratio))
    step, block = ratio[first] * frac, rows[first]
    point[:] = point + step * direction
    if n_basis >= basis.shape[0]:
        return -1
    row = A[block].copy()
    for j in range(n_basis):
        row = row - _seq_sum(basis[j] * row) * basis[j]
    bnorm = np.sqrt(_seq_sum(row * row))
    if not bnorm > 1e-9:
        return -1
    basis[n_basis] = row / bnorm
    return n_basis + 1


def _proven_width_numpy(A, b, c, top, bottom):
    """:func:`_proven_width` in NumPy (the same sums, rows vectorised)."""
    d = A.shape[1]
    gamma = (d + 3) * 1.1102230246251565e-16
    for x in (top, bottom):
        acc, scale = -b, np.abs(b)
        for q in range(d):
            acc = acc + A[:, q] * x[q]
            scale = scale + np.abs(A[:, q]) * abs(x[q])
        if not np.all(acc + gamma * scale * 1.0000001 <= 0.0):
            return -np.inf
    width = _seq_sum(c * (top - bottom))
    scale = _seq_sum(np.abs(c) * (np.abs(top) + np.abs(bottom)))
    return width - (d + 4) * 1.1102230246251565e-16 * scale * 1.0000001


def _walk_width_numpy(A, b, p, c, steps, frac, target):
    """:func:`walk_width_lower_bound` in NumPy: the same operations in the same order, so the same bits."""
    d = A.shape[1]
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(c))):
        return -np.inf
    top, bottom = p.copy(), p.copy()
    basis_top, basis_bottom = np.zeros((steps, d)), np.zeros((steps, d))
    n_top = n_bottom = 0
    for _ in range(steps):
        if n_top >= 0:
            n_top = _walk_step_numpy(A, b, c, 1.0, frac, top, basis_top, n_top)
        if n_bottom >= 0:
            n_bottom = _walk_step_numpy(A, b, c, -1.0, frac, bottom, basis_bottom, n_bottom)
        if _seq_sum(c * (top - bottom)) > target or (n_top < 0 and n_bottom < 0):
            break
    return _proven_width_numpy(A, b, c, top, bottom)


# numba dispatchers when the cache holds them, else plain Python in this process (see _numba_cache);
# tiered, the walk runs as NumPy until the switch (as Python loops it costs milliseconds a call)
COMPILED = _finalize_kernels(globals(), tiered=True, weight=10, python={"walk_width_lower_bound": _walk_width_numpy})
#: What callers use: the kernel (tiered or compiled), or its NumPy twin (same bits) when the
#: kernels stay Python in this process.
walk_width = walk_width_lower_bound if COMPILED else _walk_width_numpy

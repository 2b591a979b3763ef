"""Compiled online kernels of the lookup-table observer (paper 002, Algorithm 4.1).

The tables are built in :mod:`hybobs_opt.observers.lookup`; these functions only evaluate them.
numba compiles them once (cached on disk), so a step costs a few microseconds instead of the
tens of microseconds that a dozen small numpy calls cost.
"""

from __future__ import annotations

import numpy as np
from numba import njit

OBSERVABLE_CODE, UNOBSERVABLE_CODE, FALLBACK_CODE, WARMING_CODE = 0, 1, 2, 3


@njit(cache=True)
def classify_window(z, table, offset, nx, nr, n, pT, mstarts, sx, output_rtol, interior_margin, same_tol, x_out):
    """Index of the unique consistent candidate (eqs. 12-14), or -1 (chi empty or card(chi) > 1).

    Writes the candidate's window-start state into ``x_out``.
    """
    R, d = table.shape
    K = mstarts.shape[0] - 1
    ymax = 1.0
    for c in range(pT):
        if abs(z[c]) > ymax:
            ymax = abs(z[c])
    found = -1
    for k in range(K):
        # output residual of eq. (12)
        ok = True
        for r in range(nx + k * pT, nx + (k + 1) * pT):
            acc = offset[r]
            for c in range(d):
                acc += table[r, c] * z[c]
            if abs(acc) > output_rtol * ymax:
                ok = False
                break
        if not ok:
            continue
        # strict membership [x_k; U] in P_k (eq. 14)
        for r in range(nx + nr + mstarts[k], nx + nr + mstarts[k + 1]):
            acc = offset[r]
            for c in range(d):
                acc += table[r, c] * z[c]
            if acc >= -interior_margin:
                ok = False
                break
        if not ok:
            continue
        if found < 0:
            found = k
            for i in range(n):
                acc = offset[k * n + i]
                for c in range(d):
                    acc += table[k * n + i, c] * z[c]
                x_out[i] = acc
        else:
            # a second candidate: the same state (a shared boundary) or card(chi) > 1
            for i in range(n):
                acc = offset[k * n + i]
                for c in range(d):
                    acc += table[k * n + i, c] * z[c]
                if abs(acc - x_out[i]) > same_tol * sx[i]:
                    return -1
    return found


@njit(cache=True)
def in_union(x, A, b, starts, tol):
    """Is ``x`` in one of the polytopes ``A[starts[k]:starts[k+1]] x <= b + tol``?"""
    P = starts.shape[0] - 1
    for k in range(P):
        inside = True
        for r in range(starts[k], starts[k + 1]):
            acc = -b[r]
            for c in range(x.shape[0]):
                acc += A[r, c] * x[c]
            if acc > tol:
                inside = False
                break
        if inside:
            return True
    return False


@njit(cache=True)
def pwa_step(x, u, mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, x_out):
    """``x_out = f_pwa(x, u)`` (eq. 1 of paper 002); returns the mode, or -1 outside ``X x U``."""
    n = x.shape[0]
    m = u.shape[0]
    M = guard_starts.shape[0] - 1
    for q in range(M):
        inside = True
        for r in range(guard_starts[q], guard_starts[q + 1]):
            acc = -guard_rhs[r]
            for c in range(n):
                acc += guard[r, c] * x[c]
            for c in range(m):
                acc += guard[r, n + c] * u[c]
            if acc > 0.0:
                inside = False
                break
        if inside:
            for i in range(n):
                acc = mode_a[q, i]
                for c in range(n):
                    acc += mode_A[q, i, c] * x[c]
                for c in range(m):
                    acc += mode_B[q, i, c] * u[c]
                x_out[i] = acc
            return q
    for i in range(n):
        x_out[i] = x[i]
    return -1


@njit(cache=True)
def propagate_last(k, x0, z, pT, Pl, Gl, pl, x_out):
    """State at the window's last sample from the window-start state (region ``k``'s affine map)."""
    n = x0.shape[0]
    for i in range(n):
        acc = pl[k, i]
        for c in range(n):
            acc += Pl[k, i, c] * x0[c]
        for c in range(Gl.shape[2]):
            acc += Gl[k, i, c] * z[pT + c]
        x_out[i] = acc


CANDIDATE_CODE = 4

# meta (int64): [count, mode, has_previous_input, previous_input_good, region]


@njit(cache=True)
def advance(u, y, ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
            table, offset, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
            mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts):
    """One step of Algorithm 4.1 on the observer state (buffers, estimate, meta) in place.

    Returns a flag code.  With ``use_btilde`` false (the exact variant) a unique candidate is not
    tested against ``B~_T``: the code is ``CANDIDATE_CODE`` with the window-start state in ``xs0``
    and its region in ``meta[4]``; the caller decides and calls :func:`propagate_last`.
    """
    # ints = [T, nx, nr, pT, use_btilde, sample_ok]; reals = [output_rtol, interior, same_tol, member_tol]
    T, nx, nr, pT, use_btilde = ints[0], ints[1], ints[2], ints[3], ints[4] == 1
    output_rtol, interior_margin, same_tol, member_tol = reals[0], reals[1], reals[2], reals[3]
    n = xcur.shape[0]
    m = Ubuf.shape[1]
    p = Ybuf.shape[1]
    good = ints[5] == 1
    for c in range(m):
        if not np.isfinite(u[c]):
            good = False
    for c in range(p):
        if not np.isfinite(y[c]):
            good = False
    # step 2.1: open-loop prediction x(t) = f_pwa(x(t-1), u(t-1)), used unless reconstructed
    pred_ok = True
    if meta[2] == 1:
        if meta[3] == 1:
            q = pwa_step(xcur, uprev, mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, xnew)
            if q >= 0:
                meta[1] = q
                for i in range(n):
                    xcur[i] = xnew[i]
            else:
                pred_ok = False
        else:
            pred_ok = False
    meta[2] = 1
    meta[3] = 1 if good else 0
    for c in range(m):
        uprev[c] = u[c]
    if not good:
        meta[0] = 0  # a bad sample breaks the window
        return FALLBACK_CODE
    for j in range(T - 1):
        for c in range(p):
            Ybuf[j, c] = Ybuf[j + 1, c]
        for c in range(m):
            Ubuf[j, c] = Ubuf[j + 1, c]
    for c in range(p):
        Ybuf[T - 1, c] = y[c]
    for c in range(m):
        Ubuf[T - 1, c] = u[c]
    if meta[0] < T:
        meta[0] += 1
    if meta[0] < T:
        return WARMING_CODE
    for j in range(T):
        for c in range(p):
            z[j * p + c] = Ybuf[j, c]
        for c in range(m):
            z[pT + j * m + c] = Ubuf[j, c]
    k = classify_window(z, table, offset, nx, nr, n, pT, mstarts, sx, output_rtol, interior_margin, same_tol, xs0)
    if k >= 0:
        meta[4] = k
        if not use_btilde:
            return CANDIDATE_CODE
        if not in_union(xs0, bt_A, bt_b, bt_starts, member_tol):
            propagate_last(k, xs0, z, pT, Pl, Gl, pl, xcur)
            meta[1] = last_mode[k]
            return OBSERVABLE_CODE
    return UNOBSERVABLE_CODE if pred_ok else FALLBACK_CODE


@njit(cache=True)
def run_table(U, Y, ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
              table, offset, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
              mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, xs, modes, flags):
    """:func:`advance` over a recorded trace; fills ``xs``, ``modes``, ``flags``."""
    N = U.shape[0]
    for t in range(N):
        flags[t] = advance(U[t], Y[t], ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
                           table, offset, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
                           mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts)
        for i in range(xcur.shape[0]):
            xs[t, i] = xcur[i]
        modes[t] = meta[1]

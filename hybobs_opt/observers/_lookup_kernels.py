"""Compiled online kernels of the lookup-table observer (paper 002, Algorithm 4.1).

The tables are built in :mod:`hybobs_opt.observers.lookup`; these functions only evaluate them.
numba compiles them once (cached on disk), so a step costs a few microseconds instead of the
tens of microseconds that a dozen small numpy calls cost.
"""

from __future__ import annotations

import numpy as np

from .._numba_cache import finalize_kernels as _finalize_kernels
from .._numba_cache import kernel


OBSERVABLE_CODE, UNOBSERVABLE_CODE, FALLBACK_CODE, WARMING_CODE = 0, 1, 2, 3

# The kernels of one step allocate nothing, so they are compiled without numba's reference
# counting (``_nrt=False``): with it every call between them increfs and decrefs each of its array
# arguments (42 for ``advance``), a quarter of the step's time on model (16).

#: A unique candidate whose ``B~_T`` test (pair LPs, or the exact variant's LPs) is left to the
#: caller: window-start state in ``xs0``, its region in ``meta[4]``.
CANDIDATE_CODE = 4

# Why a step is flagged ``fallback`` (or, for NOTE_*, what else happened); ``meta[5]`` and the
# ``reasons`` array of :func:`run_table`.  The texts are in ``lookup.REASONS``.
REASON_NONE = 0
REASON_NONFINITE = 1  # NaN or Inf in the sample
REASON_INPUT_OUTSIDE_U = 2  # u outside the input set U beyond LOOKUP_INPUT_BOUND_TOL
REASON_PREVIOUS_BAD = 3  # not reconstructed, and the previous sample's input cannot be used to predict
REASON_PREDICTION_OUTSIDE = 4  # not reconstructed, and the open-loop prediction found no mode (X not a box)
REASON_BAD_SHAPE = 5  # wrong length / not numeric (set by the Python layer only)
NOTE_CLIPPED = 6  # unobservable step whose open-loop prediction was clipped to the state bounds

# ints = [T, nx, nr, pT, btilde_mode, sample_ok]
#   btilde_mode: 0 = no B~_T test in the kernel (the caller decides: exact variant),
#                1 = union of polytopes (bt_A, bt_b, bt_starts), 2 = pair pieces screened here
# reals = [output_rtol, same_tol, member_tol, input_tol]
# meta (int64) = [count, mode, has_previous_input, previous_input_good, region, reason, n_survivors]


@kernel(cache=True, inline="always", _nrt=False)
def classify_window(z, table, offset, mthr, nx, nr, n, pT, mstarts, sx, output_rtol, same_tol, x_out, m_last):
    """Index of the unique consistent candidate (eqs. 12-14), or -1 (chi empty or card(chi) > 1).

    A membership row ``r`` of region ``k`` passes when its value (unit row in scaled
    coordinates, ``<= 0`` inside) is below ``mthr[r]``: ``-LOOKUP_INTERIOR_MARGIN`` for the
    rows that involve the state (strict: the guards' boundaries belong to the neighbouring mode
    sequence), ``+LOOKUP_INPUT_BOUND_TOL`` for the rows that only bound the inputs (closed: the
    input set ``U`` has no neighbour).  Writes the candidate's window-start state into ``x_out``.

    ``m_last[k]`` is the membership row that last excluded region ``k``; it is tried first (the
    windows of consecutive samples are close, so it usually excludes again).  Whether a region
    passes does not depend on the order of its rows, so neither does the answer.
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
        # membership [x_k; U] in P_k (eq. 14): strict on state rows, closed on input bounds
        r0 = m_last[k]
        if r0 < mstarts[k + 1]:
            rr = nx + nr + r0
            acc = offset[rr]
            for c in range(d):
                acc += table[rr, c] * z[c]
            if acc >= mthr[r0]:
                continue
        for r in range(mstarts[k], mstarts[k + 1]):
            if r == r0:
                continue
            rr = nx + nr + r
            acc = offset[rr]
            for c in range(d):
                acc += table[rr, c] * z[c]
            if acc >= mthr[r]:
                ok = False
                m_last[k] = r
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


@kernel(cache=True, inline="always", _nrt=False)
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


@kernel(cache=True, inline="always", _nrt=False)
def pair_screen(xs, ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, tol, out, ex_last):
    """Pieces ``Proj_x(R_ij)`` of ``B~_T`` that the scaled state ``xs`` is not excluded from cheaply.

    Per pair ``q``: the rows ``ex_A[ex_starts[q]:ex_starts[q+1]] xs <= ex_b + tol`` (the rows of
    ``R_ij`` that only involve ``x`` once ``x`` is fixed, and the output equalities' consistency
    rows as two inequalities), then the cached cuts ``cut_A[q, c] xs <= cut_b[q, c]`` (valid for
    every point of the piece, from earlier LPs).  Writes the indices of the pairs that pass both
    into ``out`` and returns their number; only those need an LP.  ``ex_last[q]`` is the row that
    last excluded pair ``q``, tried first (as ``m_last`` in :func:`classify_window`; the answer
    does not depend on it).
    """
    P = ex_starts.shape[0] - 1
    n = xs.shape[0]
    cnt = 0
    for q in range(P):
        inside = True
        r0 = ex_last[q]
        if r0 < ex_starts[q + 1]:
            acc = -ex_b[r0]
            for c in range(n):
                acc += ex_A[r0, c] * xs[c]
            if acc > tol:
                continue
        for r in range(ex_starts[q], ex_starts[q + 1]):
            if r == r0:
                continue
            acc = -ex_b[r]
            for c in range(n):
                acc += ex_A[r, c] * xs[c]
            if acc > tol:
                inside = False
                ex_last[q] = r
                break
        if not inside:
            continue
        for k in range(cut_count[q]):
            acc = -cut_b[q, k]
            for c in range(n):
                acc += cut_A[q, k, c] * xs[c]
            if acc > 0.0:
                inside = False
                break
        if inside:
            out[cnt] = q
            cnt += 1
    return cnt


@kernel(cache=True, inline="always", _nrt=False)
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


@kernel(cache=True, inline="always", _nrt=False)
def clip_box(x, lo, hi):
    """Clip ``x`` into ``[lo, hi]`` in place; True if a coordinate moved."""
    moved = False
    for i in range(x.shape[0]):
        if x[i] < lo[i]:
            x[i] = lo[i]
            moved = True
        elif x[i] > hi[i]:
            x[i] = hi[i]
            moved = True
    return moved


@kernel(cache=True, inline="always", _nrt=False)
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


@kernel(cache=True, inline="always", _nrt=False)
def _advance(u, y, state, tables):
    """One step of Algorithm 4.1 on the observer state (buffers, estimate, meta) in place.

    ``state = (ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew)`` and ``tables`` the
    other arrays of :func:`advance`, in its order: two tuples, so that the callers pass four
    arguments (CPython calls a function of more than 30 arguments through a tuple, which numba
    cannot inline) and numba inlines this body into each of them (:func:`step_packed`,
    :func:`run_packed`): one compiled function per call from Python, no call passing 42 arrays.

    Returns a flag code and sets ``meta[5]`` to a reason code (``REASON_*``, ``NOTE_CLIPPED``).

    * A sample is bad (``fallback``, the window restarts) when it holds NaN/Inf or when an input
      lies outside ``U`` (rows ``in_A u <= in_b``, unit in scaled coordinates) by more than
      ``reals[3]``: the model says nothing about such an input, so no window containing it can
      be reconstructed.
    * Step 2.1's open-loop prediction ``f_pwa`` is evaluated at the estimate clipped to the
      state box ``[x_lo, x_hi]`` (and its result clipped again): ``f_pwa`` is only defined on
      ``X x U``, an initial guess or a prediction may leave ``X``, and since the true state lies
      in the box clipping never increases any coordinate's error.
    * ``B~_T`` (``ints[4]``): 1, a union of polytopes tested here; 2, the pair pieces screened
      here (:func:`pair_screen` on the state scaled by ``x_c, sx``): with no survivor the
      candidate is observable, otherwise the code is ``CANDIDATE_CODE`` with the survivors in
      ``survivors[:meta[6]]``; 0 (the exact variant), always ``CANDIDATE_CODE``.  With
      ``CANDIDATE_CODE`` the state is in ``xs0`` and its region in ``meta[4]``; the caller
      decides and calls :func:`propagate_last`.
    """
    ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew = state
    (table, offset, mthr, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode, mode_A, mode_B, mode_a, guard,
     guard_rhs, guard_starts, in_A, in_b, x_lo, x_hi, ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, x_c,
     survivors, ex_last, m_last) = tables
    T, nx, nr, pT, btilde_mode = ints[0], ints[1], ints[2], ints[3], ints[4]
    output_rtol, same_tol, member_tol, input_tol = reals[0], reals[1], reals[2], reals[3]
    n = xcur.shape[0]
    m = Ubuf.shape[1]
    p = Ybuf.shape[1]
    good = ints[5] == 1
    reason = REASON_NONE if good else REASON_BAD_SHAPE
    if good:
        for c in range(m):
            if not np.isfinite(u[c]):
                good = False
        for c in range(p):
            if not np.isfinite(y[c]):
                good = False
        if not good:
            reason = REASON_NONFINITE
    if good:
        for r in range(in_A.shape[0]):
            acc = -in_b[r]
            for c in range(m):
                acc += in_A[r, c] * u[c]
            if acc > input_tol:
                good = False
                reason = REASON_INPUT_OUTSIDE_U
                break
    # step 2.1: open-loop prediction x(t) = f_pwa(x(t-1), u(t-1)), used unless reconstructed
    pred_ok = True
    pred_reason = REASON_NONE
    if meta[2] == 1:
        if meta[3] == 1:
            clipped = clip_box(xcur, x_lo, x_hi)
            q = pwa_step(xcur, uprev, mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, xnew)
            if q >= 0:
                meta[1] = q
                for i in range(n):
                    xcur[i] = xnew[i]
                if clip_box(xcur, x_lo, x_hi):
                    clipped = True
                if clipped:
                    pred_reason = NOTE_CLIPPED
            else:
                pred_ok = False
                pred_reason = REASON_PREDICTION_OUTSIDE
        else:
            pred_ok = False
            pred_reason = REASON_PREVIOUS_BAD
    meta[2] = 1
    meta[3] = 1 if good else 0
    for c in range(m):
        uprev[c] = u[c] if good else np.nan
    if not good:
        meta[0] = 0  # a bad sample breaks the window
        meta[5] = reason
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
    meta[5] = pred_reason
    if meta[0] < T:
        return WARMING_CODE
    for j in range(T):
        for c in range(p):
            z[j * p + c] = Ybuf[j, c]
        for c in range(m):
            z[pT + j * m + c] = Ubuf[j, c]
    k = classify_window(z, table, offset, mthr, nx, nr, n, pT, mstarts, sx, output_rtol, same_tol, xs0, m_last)
    if k >= 0:
        meta[4] = k
        if btilde_mode == 0:
            return CANDIDATE_CODE
        if btilde_mode == 2:
            for i in range(n):
                xnew[i] = (xs0[i] - x_c[i]) / sx[i]
            cnt = pair_screen(xnew, ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, member_tol, survivors, ex_last)
            meta[6] = cnt
            if cnt > 0:
                return CANDIDATE_CODE
            inside = False
        else:
            inside = in_union(xs0, bt_A, bt_b, bt_starts, member_tol)
        if not inside:
            propagate_last(k, xs0, z, pT, Pl, Gl, pl, xcur)
            meta[1] = last_mode[k]
            meta[5] = REASON_NONE
            return OBSERVABLE_CODE
    return UNOBSERVABLE_CODE if pred_ok else FALLBACK_CODE


@kernel(cache=True, _nrt=False)
def advance(u, y, ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
            table, offset, mthr, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
            mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, in_A, in_b, x_lo, x_hi,
            ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, x_c, survivors, ex_last, m_last):
    """:func:`_advance` on separate arrays (the observer's state, then its tables): the flag code."""
    return _advance(u, y, (ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew),
                    (table, offset, mthr, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
                     mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, in_A, in_b, x_lo, x_hi,
                     ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, x_c, survivors, ex_last, m_last))


@kernel(cache=True, _nrt=False)
def run_table(U, Y, start, ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
              table, offset, mthr, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
              mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, in_A, in_b, x_lo, x_hi,
              ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, x_c, survivors, ex_last, m_last, xs, modes, flags, reasons):
    """:func:`advance` over ``U[start:], Y[start:]``; fills ``xs``, ``modes``, ``flags``, ``reasons``.

    Returns the number of rows done: ``U.shape[0]``, or the index of the first step whose code
    is ``CANDIDATE_CODE`` (its flag, estimate and mode are then left to the caller, who resumes
    at the next index).
    """
    N = U.shape[0]
    for t in range(start, N):
        code = advance(U[t], Y[t], ints, reals, Ybuf, Ubuf, xcur, meta, uprev, z, xs0, xnew,
                       table, offset, mthr, mstarts, sx, bt_A, bt_b, bt_starts, Pl, Gl, pl, last_mode,
                       mode_A, mode_B, mode_a, guard, guard_rhs, guard_starts, in_A, in_b, x_lo, x_hi,
                       ex_A, ex_b, ex_starts, cut_A, cut_b, cut_count, x_c, survivors, ex_last, m_last)
        flags[t] = code
        reasons[t] = meta[5]
        if code == CANDIDATE_CODE:
            return t
        for i in range(xcur.shape[0]):
            xs[t, i] = xcur[i]
        modes[t] = meta[1]
    return N


# ---------------------------------------------------------------------------------- packed tables
# The observer's tables and state packed into two contiguous arrays (``lookup.LookupObserver``):
# ``F`` (float64) and ``I`` (int64).  ``I`` starts with a header of 4 ints per segment,
# ``(offset, d0, d1, d2)``: the float segments (offsets into ``F``), then the int segments
# (offsets into ``I``).  A call passes these two arrays instead of ~40 (numba unboxes every
# array argument, a few tens of nanoseconds each); the kernels below cut the views and run
# :func:`_advance` on them, so every flag, mode and estimate is computed by the same operations in
# the same order as with the separate arrays.  The views and every kernel of a step are inlined
# (``inline="always"``) and compiled without reference counting: one compiled function per call
# from Python, no incref/decref per view, no call that passes 42 arrays.
FLOAT_SEGMENTS = ("reals", "table", "offset", "mthr", "sx", "bt_A", "bt_b", "Pl", "Gl", "pl",
                  "mode_A", "mode_B", "mode_a", "guard", "guard_rhs", "in_A", "in_b", "x_lo", "x_hi",
                  "ex_A", "ex_b", "cut_A", "cut_b", "x_c",
                  "Ybuf", "Ubuf", "xcur", "uprev", "z", "xs0", "xnew")
INT_SEGMENTS = ("ints", "meta", "mstarts", "bt_starts", "last_mode", "guard_starts", "ex_starts", "cut_count",
                "survivors", "ex_last", "m_last")
HEADER = 4 * (len(FLOAT_SEGMENTS) + len(INT_SEGMENTS))
#: ``step_packed``'s answer when ``u`` or ``y`` has the wrong length (nothing is changed).
BAD_LENGTH = -1


@kernel(cache=True, inline="always")
def _v1(A, I, k):
    o = I[4 * k]
    return A[o:o + I[4 * k + 1]]


@kernel(cache=True, inline="always")
def _v2(A, I, k):
    o, r, c = I[4 * k], I[4 * k + 1], I[4 * k + 2]
    return A[o:o + r * c].reshape((r, c))


@kernel(cache=True, inline="always")
def _v3(A, I, k):
    o, a, b, c = I[4 * k], I[4 * k + 1], I[4 * k + 2], I[4 * k + 3]
    return A[o:o + a * b * c].reshape((a, b, c))


_NF = len(FLOAT_SEGMENTS)


@kernel(cache=True, inline="always")
def _packed_views(F, I):
    """The views of the packed arrays: ``(state, tables)`` as :func:`_advance` takes them.

    Inlined into the kernels below, which run without reference counting; compiled alone (a call
    from Python) with it, so that the views it returns keep ``F`` and ``I`` alive."""
    state = (_v1(I, I, _NF + 0), _v1(F, I, 0), _v2(F, I, 24), _v2(F, I, 25), _v1(F, I, 26), _v1(I, I, _NF + 1),
             _v1(F, I, 27), _v1(F, I, 28), _v1(F, I, 29), _v1(F, I, 30))
    tables = (_v2(F, I, 1), _v1(F, I, 2), _v1(F, I, 3), _v1(I, I, _NF + 2), _v1(F, I, 4),
              _v2(F, I, 5), _v1(F, I, 6), _v1(I, I, _NF + 3), _v3(F, I, 7), _v3(F, I, 8), _v2(F, I, 9),
              _v1(I, I, _NF + 4), _v3(F, I, 10), _v3(F, I, 11), _v2(F, I, 12), _v2(F, I, 13),
              _v1(F, I, 14), _v1(I, I, _NF + 5), _v2(F, I, 15), _v1(F, I, 16), _v1(F, I, 17),
              _v1(F, I, 18), _v2(F, I, 19), _v1(F, I, 20), _v1(I, I, _NF + 6), _v3(F, I, 21),
              _v2(F, I, 22), _v1(I, I, _NF + 7), _v1(F, I, 23), _v1(I, I, _NF + 8), _v1(I, I, _NF + 9),
              _v1(I, I, _NF + 10))
    return state, tables


@kernel("int64(float64[::1], float64[::1], int64, float64[::1], int64[::1])", cache=True, _nrt=False)
def step_packed(u, y, good, F, I):
    """:func:`_advance` on the packed tables and state; returns ``code | (mode + 1) << 3``.

    ``good = 0`` marks a sample the caller found malformed (``REASON_BAD_SHAPE``); ``u`` and ``y``
    are then NaN vectors of the right lengths.  A ``u`` or ``y`` of the wrong length returns
    :data:`BAD_LENGTH` and leaves the state untouched (the caller builds the reason).  The mode
    part is meaningless with ``CANDIDATE_CODE``, which the caller decides.
    """
    state, tables = _packed_views(F, I)
    ints, Ybuf, Ubuf, meta = state[0], state[2], state[3], state[5]
    if u.shape[0] != Ubuf.shape[1] or y.shape[0] != Ybuf.shape[1]:
        return BAD_LENGTH
    ints[5] = good
    code = _advance(u, y, state, tables)
    ints[5] = 1
    return code | ((meta[1] + 1) << 3)


@kernel("int64(float64[:, ::1], float64[:, ::1], int64, float64[::1], int64[::1], float64[:, ::1], int64[::1], "
      "int64[::1], int64[::1])", cache=True, _nrt=False)
def run_packed(U, Y, start, F, I, xs, modes, flags, reasons):
    """:func:`run_table` on the packed tables and state (same return value), with :func:`_advance` inlined."""
    state, tables = _packed_views(F, I)
    xcur, meta = state[4], state[5]
    N = U.shape[0]
    for t in range(start, N):
        code = _advance(U[t], Y[t], state, tables)
        flags[t] = code
        reasons[t] = meta[5]
        if code == CANDIDATE_CODE:
            return t
        for i in range(xcur.shape[0]):
            xs[t, i] = xcur[i]
        modes[t] = meta[1]
    return N


# numba dispatchers when the cache holds them, else plain Python in this process (see _numba_cache)
_finalize_kernels(globals())

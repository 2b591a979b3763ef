"""Independent oracle for the pair lists of Algorithm 3.1 (paper 002) on model (17).

What it checks
--------------
``analyse_observability`` sorts every tested region pair ``(i, j)`` into one of three lists:
``pairs`` (pieces of B_T), ``pairs_dropped_thin`` and ``pairs_dropped_same_state``, or none
(empty).  Commit 1d5c7e7 changed the pair tests; at T = 9 the lists of the code before
(a0105dd) and after differ.  This script takes the two sets of lists (JSON files written by a
run of each code: ``{"pairs": [[i, j], ...], "thin": [...], "same": [...]}``), finds every pair
whose label differs, and decides each one again with its own LPs, sharing no code with
``hybobs_opt.regions.pair_geometry`` / ``observability`` (only the mode enumeration
``enumerate_modes`` is used, to get the regions ``P_i``):

``R_ab = {(x, x^, U) : H_a [x; U] <= h_a, H_b [x^; U] <= h_b, C_a x + D_a U + f_a = C_b x^ + D_b U + f_b}``

in the coordinates of the definitions (module docstrings of pair_geometry / observability):
scaled ``w = (x, x^, U)`` with ``z = centre + scale * w`` (``enum.scale``, ``enum.centre``), every
row of ``P_a`` and ``P_b`` unit-norm in the scaled ``(x, U)`` space, distances measured inside the
equality subspace (each row renormalised by the norm of its projection on ``ker E``).  The
entry ``(a, b)`` of a list is always the set ``R_ab`` projected on ``x`` (for ``(j, i)`` entries
the code decides ``R_ij`` projected on ``x^``: the same set with the state copies swapped).

Per pair, with scipy.optimize.linprog (HiGHS, feasibility tolerances 1e-10; the LPs are solved in
``ker E`` coordinates ``w = w0 + N v``, with the equalities as rows as the fallback):

0. Outputs that force ``x^ = x`` on the whole equality subspace: "same", before any emptiness
   test (the convention of ``classify_pair``: such pairs are reported without deciding emptiness).
(a) Non-empty: Chebyshev radius ``r`` of the closed set in its equality subspace, solved in both
    formulations, with a certified bracket: lower bound from the LP point projected exactly onto
    ``E w = e`` and its slacks evaluated in rational arithmetic (``fractions``); upper bound from
    the LP's multipliers (weak duality, the residual bounded with ``|w|_inf <= R``, ``R`` read off
    the box rows of the regions), also in rationals.  Empty iff ``r <= -CLOSED_SET_TOL`` (1e-7).
    Rows can be nearly constant in ``ker E`` (norm down to ~1e-6), which limits the float LPs to
    ~1e-8 on the renormalised rows; the bracket says how far that matters.
(b) Full-dimensional projection on ``x``: the implicit equalities of the closed set (one LP that
    maximises the sum of the row slacks capped at 1, then the max slack of every row it left at
    zero, one LP each; max slack <= 1e-8: implicit), its affine hull (``ker E`` cut by them), the
    singular values of the hull's ``x`` part (the "flat" directions are those below 1e-9), the
    Chebyshev radius ``rho`` in the hull, and widths of ``Proj_x`` (two LPs each) along the
    thinnest hull direction and the five state axes, on the closed set and on the set relaxed by
    CLOSED_SET_TOL (the set the code's width certificates use), plus a scan of the flat
    directions on the relaxed set (36 directions when there are 2 of them, 63 when 3).
    ``min width <= width along any u`` and ``min width >= 2 rho sigma_min`` bracket the minimal
    width; thin iff below ``2 REGION_SLACK_TOL`` (2e-6).
(c) Two different states: ``max |x_k - x^_k|`` over the set (10 LPs); same state iff
    ``<= DISTINCT_STATE_TOL`` (1e-5); "forced" when ``x - x^`` does not vary on the set (range
    <= 1e-9).

Label, in the order of the code's tests: (0) -> same; empty -> none; ``Proj_x`` lower-dimensional
(a flat hull direction with closed-set width <= 1e-9) -> thin; ``x - x^`` forced and <= 1e-5 ->
same; min width < 2e-6 -> thin; ``max |x - x^| <= 1e-5`` -> same; else piece.  "Marginal" notes:
a bracket straddles a threshold, a value within 1 % of it, or the closed set and the relaxed set
disagree about thinness.

How to run
----------
::

    .venv/bin/python scripts/check_t9_pair_lists.py --old /tmp/t9/old.json --new /tmp/t9/new.json \
        [--T 9] [--out /tmp/t9/oracle.json] [--sample 20] [--pairs 12,345 678,9]

``--sample K`` also checks K random entries of each list on which both codes agree (a sanity
check of the oracle itself; ``--sample-lists piece`` restricts it to the pieces, ``--only-sample``
skips the differing pairs); ``--pairs a,b ...`` checks only the given pairs.  ``--no-exact``
brackets the radius in floats only.  The report is printed and
written as JSON to ``--out``.  Runtime: about a second per pair (single process).
"""

from __future__ import annotations

import argparse
import json
import random
import sys
import time
from fractions import Fraction

import numpy as np
from scipy.optimize import linprog

CLOSED_SET_TOL = 1e-7       # hybobs_opt.tolerances, restated (not imported: independent oracle)
REGION_SLACK_TOL = 1e-6
DISTINCT_STATE_TOL = 1e-5
IMPLICIT_TOL = 1e-8         # a row whose max slack is below this is an implicit equality
FLAT_TOL = 1e-9             # width below this: lower-dimensional
ZERO_ROW = 1e-10            # a row (unit before restriction) this short in ker E is constant
HIGHS = dict(primal_feasibility_tolerance=1e-10, dual_feasibility_tolerance=1e-10, presolve=True)


# ---------------------------------------------------------------------- exact helpers
def _fr(a):
    return [Fraction(float(v)) for v in np.ravel(a)]


def _exact_solve(M: list[list[Fraction]], b: list[Fraction]) -> list[Fraction]:
    """Gauss-Jordan in rationals (M square, non-singular)."""
    n = len(M)
    A = [row[:] + [b[k]] for k, row in enumerate(M)]
    for c in range(n):
        p = next(r for r in range(c, n) if A[r][c] != 0)
        A[c], A[p] = A[p], A[c]
        piv = A[c][c]
        A[c] = [v / piv for v in A[c]]
        for r in range(n):
            if r != c and A[r][c] != 0:
                fct = A[r][c]
                A[r] = [vr - fct * vc for vr, vc in zip(A[r], A[c])]
    return [A[r][n] for r in range(n)]


def _linprog(c, A_ub, b_ub, A_eq, b_eq, bounds):
    """HiGHS with tight tolerances; on a failure (faces are degenerate LPs) other methods, then
    HiGHS's default tolerances (1e-7), then without presolve."""
    res = None
    for method, opts in (("highs-ds", HIGHS), ("highs-ipm", HIGHS), ("highs-ds", dict(HIGHS, presolve=False)),
                         ("highs-ds", {}), ("highs-ipm", {}), ("highs-ds", {"presolve": False})):
        res = linprog(c, A_ub=A_ub, b_ub=b_ub, A_eq=A_eq, b_eq=b_eq, bounds=bounds, method=method, options=opts)
        if res.status in (0, 2):
            return res
    return res


class PairSetLP:
    """``R_ab`` in scaled coordinates: ``G w <= g`` (unit rows before restriction), ``E w = e``."""

    def __init__(self, enum, a: int, b: int):
        n = enum.system.n
        self.n = n
        sc, ce = np.asarray(enum.scale, float), np.asarray(enum.centre, float)
        sx, su, cx, cu = sc[:n], sc[n:], ce[:n], ce[n:]
        ra, rb = enum.regions[a], enum.regions[b]
        TM = ra.H.shape[1] - n
        d = 2 * n + TM
        rows, rhs = [], []
        for reg, xcols in ((ra, slice(0, n)), (rb, slice(n, 2 * n))):
            Hx = reg.H[:, :n] * sx
            HU = reg.H[:, n:] * su
            h = reg.h - reg.H[:, :n] @ cx - reg.H[:, n:] @ cu
            nr = np.sqrt((Hx ** 2).sum(1) + (HU ** 2).sum(1))
            G = np.zeros((reg.H.shape[0], d))
            G[:, xcols] = Hx / nr[:, None]
            G[:, 2 * n:] = HU / nr[:, None]
            rows.append(G)
            rhs.append(h / nr)
        self.G, self.g = np.vstack(rows), np.concatenate(rhs)
        E = np.zeros((ra.C.shape[0], d))
        E[:, :n] = ra.C * sx
        E[:, n:2 * n] = -rb.C * sx
        E[:, 2 * n:] = (ra.D - rb.D) * su
        e = (rb.f + rb.C @ cx + rb.D @ cu) - (ra.f + ra.C @ cx + ra.D @ cu)
        # independent rows of E (QR with column pivoting on E') and the consistency of the rest
        from scipy.linalg import qr
        U_, s, Vt = np.linalg.svd(E)
        self.E_sv = s
        r = int(np.sum(s > 1e-12 * s[0])) if s.size else 0
        self.rank_E = r
        _, _, piv = qr(E.T, pivoting=True)
        sel = np.sort(piv[:r])
        self.E_full, self.e_full = E, e
        self.E, self.e = E[sel], e[sel]
        self.N = Vt[r:].T                       # ker E (orthonormal)
        w0, *_ = np.linalg.lstsq(E, e, rcond=None)
        self.eq_residual = float(np.linalg.norm(E @ w0 - e))
        self.nu = np.linalg.norm(self.G @ self.N, axis=1)   # row norms inside ker E
        self.d = d
        self.R = self._box_bound()

    def _box_bound(self) -> float:
        """``|w|_inf <= R`` on the set, read off the box rows of the regions (else 10 and flagged)."""
        G, g = self.G, self.g
        ok = True
        for k in range(self.d):
            for sgn in (1.0, -1.0):
                hit = np.nonzero((np.abs(G[:, k] - sgn) < 1e-12) & (np.abs(G).sum(1) < 1 + 1e-12))[0]
                if hit.size == 0 or np.min(g[hit]) > 1 + 1e-9:
                    ok = False
        self.box_from_rows = ok
        return 1.0 + 1e-9 if ok else 10.0

    # ------------------------------------------------------------------ one LP, bracketed
    def lp_max(self, c: np.ndarray, relax: float = 0.0, extra_eq=None, exact: bool = False, with_t=None, form: str = "kerE"):
        """``max c'w`` over ``{G w <= g + relax nu, E w = e [, extra equalities]}``.

        With ``with_t = nu_vec`` the variable ``t`` is appended (``G w + nu_vec t <= g``,
        ``-1 <= t <= 1``) and ``c`` has length ``d + 1``.  Returns ``(value, point, lower, upper)``
        where ``[lower, upper]`` brackets the optimum (``lower`` is attained by a point projected
        onto the equalities, whose largest row violation is returned too, so ``lower`` is a
        value of the set relaxed by that much more); rational arithmetic when ``exact``.
        """
        G, g = self.G, self.g + relax * self.nu
        E, e = self.E, self.e
        if extra_eq is not None:
            E, e = np.vstack([E, extra_eq[0]]), np.concatenate([e, extra_eq[1]])
        if with_t is not None:
            G = np.hstack([G, with_t[:, None]])
            G = np.vstack([G, np.eye(1, G.shape[1], G.shape[1] - 1), -np.eye(1, G.shape[1], G.shape[1] - 1)])
            g = np.concatenate([g, [1.0, 1.0]])
            E = np.hstack([E, np.zeros((E.shape[0], 1))])
        # solved in ker E coordinates w = w0 + N v (the equalities then hold to rounding, so the
        # exact projection below moves the point by ~1e-15 only); full space as a fallback
        _, sE, VtE = np.linalg.svd(E)
        NE = VtE[E.shape[0]:].T
        w0 = np.linalg.lstsq(E, e, rcond=None)[0]
        res = _linprog(-(NE.T @ c), G @ NE, g - G @ w0, None, None, (None, None)) if form == "kerE" else None
        if res is not None and res.status == 0:
            v = w0 + NE @ res.x
            res.fun = -float(c @ v)  # the LP's objective misses the constant c'w0
            y = np.maximum(-res.ineqlin.marginals, 0.0)
            z = np.linalg.lstsq(E.T, c - G.T @ y, rcond=None)[0]
        else:
            res = _linprog(-c, G, g, E, e, (None, None))
            if res.status == 2:
                return -np.inf, None, -np.inf, -np.inf, np.inf
            if res.status != 0:
                raise RuntimeError(f"LP failed: {res.message}")
            v = res.x
            y = np.maximum(-res.ineqlin.marginals, 0.0)
            z = -res.eqlin.marginals
        R = np.full(G.shape[1], self.R)
        if with_t is not None:
            R[-1] = 1.0
        if not exact:
            # float evaluation with a rounding margin (far below every threshold used here)
            vp = v + np.linalg.lstsq(E, e - E @ v, rcond=None)[0] if E.shape[0] else v
            if with_t is not None:  # the radius at the projected point, not the LP's t
                on = with_t > 0
                vp[-1] = min(1.0, float(np.min((g[:-2][on] - G[:-2][on, :-1] @ vp[:-1]) / with_t[on])))
            viol = float(np.max(G @ vp - g, initial=-np.inf))
            lower = float(c @ vp)
            r = c - G.T @ y - E.T @ z
            terms = np.abs(y) @ np.abs(g) + np.abs(z) @ np.abs(e) + np.abs(r) @ R
            upper = float(y @ g + z @ e + np.abs(r) @ R + 1e-14 * (1 + terms))
            return float(-res.fun), vp, lower, upper, max(viol, 0.0)
        # rational: project v exactly onto the equalities, evaluate exactly
        Ef = [_fr(row) for row in E]
        ef = _fr(e)
        vf = _fr(v)
        resid = [ei - sum(a * b for a, b in zip(row, vf)) for row, ei in zip(Ef, ef)]
        if Ef:
            EEt = [[sum(a * b for a, b in zip(r1, r2)) for r2 in Ef] for r1 in Ef]
            lam = _exact_solve(EEt, resid)
            vf = [vk + sum(lam[q] * Ef[q][k] for q in range(len(Ef))) for k, vk in enumerate(vf)]
        Gf = [_fr(row) for row in G]
        gf = _fr(g)
        if with_t is not None:  # the radius at the projected point (exact slacks), not the LP's t
            dd = len(vf) - 1
            vf[dd] = min([Fraction(1)] + [(gf[q] - sum(Gf[q][k] * vf[k] for k in range(dd))) / Gf[q][dd]
                                          for q in range(len(Gf) - 2) if Gf[q][dd] > 0])
        viol = max((sum(a * b for a, b in zip(row, vf)) - gk for row, gk in zip(Gf, gf)), default=Fraction(-1))
        cf = _fr(c)
        lower = sum(a * b for a, b in zip(cf, vf))
        yf, zf = _fr(y), _fr(z)
        Rf = _fr(R)
        r = [cf[k] - sum(yf[q] * Gf[q][k] for q in range(len(Gf)) if yf[q]) - sum(zf[q] * Ef[q][k] for q in range(len(Ef)))
             for k in range(len(cf))]
        upper = sum(a * b for a, b in zip(yf, gf) if a) + sum(a * b for a, b in zip(zf, ef)) + sum(abs(a) * b for a, b in zip(r, Rf))
        return float(-res.fun), np.array([float(t) for t in vf]), float(lower), float(upper), max(float(viol), 0.0)


def oracle(enum, a: int, b: int, exact: bool = True) -> dict:
    P = PairSetLP(enum, a, b)
    n, d = P.n, P.d
    out = {"pair": [a, b], "rank_E": P.rank_E, "E_sv_min_kept": float(P.E_sv[P.rank_E - 1]) if P.rank_E else None,
           "E_sv_first_dropped": float(P.E_sv[P.rank_E]) if P.rank_E < P.E_sv.size else None,
           "eq_residual": P.eq_residual, "box_from_rows": P.box_from_rows}
    # the equality subspace alone forces x = x^ ?  A rank test: the rows x - x^ lie in the row
    # space of E when appending them leaves the numerical rank unchanged (|N_x - N_x^| in
    # LAPACK's basis is about eps / s_min(E) and crosses 1e-12 with the basis when an equality's
    # singular value is small: 1e-7 of the largest on the PWA piston)
    Nd = P.N[:n] - P.N[n:2 * n]
    out["subspace_moves_x_minus_xhat"] = float(np.max(np.abs(Nd), initial=0.0))
    J = np.zeros((n, d))
    J[:, :n], J[:, n:2 * n] = np.eye(n), -np.eye(n)
    s_EJ = np.linalg.svd(np.vstack([P.E_full, J]), compute_uv=False)
    rank_EJ = int(np.sum(s_EJ > 1e-12 * s_EJ[0]))
    out["E_with_x_minus_xhat_sv_at_rank"] = float(s_EJ[P.rank_E] / s_EJ[0]) if P.rank_E < s_EJ.size else None
    w0E_ = np.linalg.lstsq(P.E, P.e, rcond=None)[0]
    out["subspace_forces_same"] = bool(rank_EJ == P.rank_E and np.max(np.abs(w0E_[:n] - w0E_[n:2 * n])) <= DISTINCT_STATE_TOL)
    if out["subspace_forces_same"]:
        # the code's convention (pair_geometry.classify_pair): outputs that force x^ = x make the
        # pair "same state" before (and without) any emptiness test
        out["label"], out["marginal"], out["notes"] = "same", False, ["x = x^ forced by the output equalities"]
        return out
    # constant rows inside ker E
    const = P.nu <= ZERO_ROW
    nu_t = np.where(const, 0.0, P.nu)
    # (a) Chebyshev radius in ker E (rows renormalised by nu), bracketed
    c = np.zeros(d + 1)
    c[-1] = 1.0
    Gs, gs = P.G, P.g
    scale = np.where(const, 1.0, P.nu)
    P.G, P.g = Gs / scale[:, None], gs / scale           # renormalised rows (constant rows as they are)
    P.nu = np.where(const, 0.0, 1.0)
    # both formulations (in ker E coordinates, and in w with the equalities as rows): the rows
    # can be nearly constant in ker E (|G_k N| down to ~1e-6), so the LP's accuracy on the
    # renormalised rows is ~1e-8 at best; the bracket keeps the best certified bounds of the two
    sols = [P.lp_max(c, with_t=P.nu, exact=exact, form=f) for f in ("kerE", "full")]
    lo = max(sv[2] for sv in sols)
    up = min(sv[3] for sv in sols)
    val = min(max(sv[0] for sv in sols), up)
    viol = min(sv[4] for sv in sols)
    out["radius_lp_values"] = [sv[0] for sv in sols]
    out["radius"], out["radius_bracket"], out["radius_point_violation"] = val, [lo, up], viol
    out["min_row_norm_in_kerE"] = float(np.min(np.where(const, np.inf, scale)))
    out["constant_rows_min_rhs"] = float(np.min(P.g[const], initial=np.inf))
    if up <= -CLOSED_SET_TOL:
        out["label"], out["empty"] = "none", True
        out["marginal"] = lo > -CLOSED_SET_TOL or abs(val + CLOSED_SET_TOL) < 0.01 * CLOSED_SET_TOL
        return out
    out["empty"] = False
    out["marginal_empty"] = lo <= -CLOSED_SET_TOL or abs(val + CLOSED_SET_TOL) < 0.01 * CLOSED_SET_TOL
    # work on the closed set itself; if it is infeasible by a hair (radius < 0), relax it just enough
    relax0 = max(0.0, -val) + 1e-11
    out["relax_used"] = relax0
    retries = []

    def robust_max(cvec, relax):
        """``max cvec'w`` and its upper bound; a face LP HiGHS calls infeasible is re-solved with
        the rows relaxed by 1e-10, then 1e-9 more (recorded in ``lp_retries``)."""
        for extra in (0.0, 1e-10, 1e-9):
            val_, _, _, up_, _ = P.lp_max(cvec, relax=relax + extra)
            if np.isfinite(val_):
                if extra:
                    retries.append(extra)
                return val_, up_
        retries.append(float("nan"))
        return float("nan"), float("nan")

    # (b) implicit equalities: max sum of capped slacks, then each remaining row alone
    m = P.G.shape[0]
    nonconst = np.nonzero(~const)[0]
    A_ub = np.hstack([P.G[nonconst], np.eye(nonconst.size)])
    A_ub = np.vstack([A_ub, np.hstack([P.G[const], np.zeros((int(const.sum()), nonconst.size))])])
    b_ub = np.concatenate([P.g[nonconst] + relax0, P.g[const] + relax0])
    A_eq = np.hstack([P.E, np.zeros((P.E.shape[0], nonconst.size))])
    bounds = [(None, None)] * d + [(0.0, 1.0)] * nonconst.size
    cc = np.concatenate([np.zeros(d), -np.ones(nonconst.size)])
    res = _linprog(cc, A_ub, b_ub, A_eq, P.e, bounds)
    tau = res.x[d:] if res.status == 0 else np.zeros(nonconst.size)
    cand = nonconst[tau <= 1e-7]
    implicit, near = [], []
    for k in cand:
        vmax, upk = robust_max(-P.G[k], relax0)
        smax = float(P.g[k] + relax0 + vmax)
        if smax <= IMPLICIT_TOL:
            implicit.append(int(k))
        else:
            near.append((int(k), smax))
    out["n_rows"], out["n_constant_rows"] = m, int(const.sum())
    out["implicit_rows"] = implicit
    out["smallest_nonimplicit_max_slack"] = min((s for _, s in near), default=None)
    # affine hull: ker E cut by the implicit rows (restricted to ker E, their own rank test)
    N = P.N
    w0E = np.linalg.lstsq(P.E, P.e, rcond=None)[0]
    if implicit:
        GKN = P.G[implicit] @ N
        _, sK, VtK = np.linalg.svd(GKN)
        rK = int(np.sum(sK > 1e-7 * sK[0]))
        M = N @ VtK[rK:].T
        sh = np.linalg.lstsq(GKN, P.g[implicit] + relax0 - P.G[implicit] @ w0E, rcond=None)[0]
        wH = w0E + N @ sh
    else:
        rK, M, wH = 0, N, w0E
    out["hull_dim"] = int(M.shape[1])
    out["hull_codim_from_implicit"] = rK
    Mx = M[:n]
    if M.shape[1]:
        Ux, sv, _ = np.linalg.svd(Mx)
    else:
        Ux, sv = np.eye(n), np.zeros(0)
    sv = np.concatenate([sv, np.zeros(max(0, n - sv.size))])
    out["hull_x_singular_values"] = sv.tolist()
    u = Ux[:, -1]
    flat = Ux[:, sv <= 1e-9]                 # directions of x the hull does not move
    # Chebyshev radius inside the hull (rows renormalised in it), non-implicit rows only
    if M.shape[1]:
        rest = np.setdiff1d(nonconst, implicit)
        nuH = np.linalg.norm(P.G[rest] @ M, axis=1)
        live = rest[nuH > ZERO_ROW]
        nuH = nuH[nuH > ZERO_ROW]
        A2 = np.hstack([(P.G[live] @ M) / nuH[:, None], np.ones((live.size, 1))])
        b2 = (P.g[live] + relax0 - P.G[live] @ wH) / nuH
        r2 = _linprog(np.r_[np.zeros(M.shape[1]), -1.0], A2, b2, None, None, [(None, None)] * M.shape[1] + [(-1.0, 1.0)])
        rho = float(-r2.fun) if r2.status == 0 else float("nan")
    else:
        rho = 0.0
    out["hull_radius"] = rho
    out["min_width_lower_bound"] = max(0.0, 2 * rho * float(sv[-1])) if np.isfinite(rho) else 0.0

    def width(cvec, relax):
        hi, hup = robust_max(cvec, relax)
        lo_, lup = robust_max(-cvec, relax)
        return hi + lo_, hup + lup

    cu = np.zeros(d)
    cu[:n] = u
    w_u, w_u_up = width(cu, relax0)
    w_u_rel, _ = width(cu, CLOSED_SET_TOL + relax0)
    axes = []
    for k in range(n):
        ck = np.zeros(d)
        ck[k] = 1.0
        axes.append(width(ck, relax0)[0])
    # the flat directions of the hull (2-3 of them on some faces): the widths of the set relaxed
    # by CLOSED_SET_TOL along them differ (the relaxation opens the face unevenly); scan them
    scan = []
    k_flat = flat.shape[1]
    if k_flat >= 2:
        if k_flat == 2:
            dirs = [np.cos(a_) * flat[:, 0] + np.sin(a_) * flat[:, 1] for a_ in np.linspace(0, np.pi, 36, endpoint=False)]
        else:
            rng = np.random.default_rng(0)
            dirs = [flat[:, q] for q in range(k_flat)] + [flat @ (z / np.linalg.norm(z)) for z in rng.standard_normal((60, k_flat))]
        for dv in dirs:
            cv = np.zeros(d)
            cv[:n] = dv
            scan.append((width(cv, CLOSED_SET_TOL + relax0)[0], dv))
    ax_rel = []
    for k in range(n):
        ck = np.zeros(d)
        ck[k] = 1.0
        ax_rel.append(width(ck, CLOSED_SET_TOL + relax0)[0])
    out["width_axes_relaxed_1e-7"] = ax_rel
    cands = [(w_u_rel, u)] + scan + [(ax_rel[k], np.eye(n)[k]) for k in range(n)]
    best = min(cands, key=lambda t: t[0] if np.isfinite(t[0]) else np.inf)
    out["n_flat_directions"] = k_flat
    out["min_width_relaxed_1e-7"] = float(best[0])
    out["min_width_relaxed_direction"] = np.asarray(best[1]).tolist()
    out["max_width_relaxed_over_flat_scan"] = float(max((t[0] for t in scan), default=w_u_rel))
    out["width_thin_direction"], out["width_thin_direction_upper"] = w_u, w_u_up
    out["width_thin_direction_relaxed_1e-7"] = w_u_rel
    out["thin_direction_u"] = u.tolist()
    out["width_axes"] = axes
    wmin_up = float(np.nanmin([w_u] + axes))
    out["min_width_upper_bound"] = wmin_up
    # (c) distinct states
    maxabs, ranges = 0.0, []
    dist_up = 0.0
    for k in range(n):
        ck = np.zeros(d)
        ck[k], ck[n + k] = 1.0, -1.0
        hi, hup = robust_max(ck, relax0)
        lo_, lup = robust_max(-ck, relax0)
        maxabs = max(maxabs, hi, lo_)
        dist_up = max(dist_up, hup, lup)
        ranges.append(hi + lo_)
    out["max_abs_x_minus_xhat"], out["max_abs_x_minus_xhat_upper"] = maxabs, dist_up
    out["range_x_minus_xhat"] = ranges
    forced_same = max(ranges) <= FLAT_TOL and maxabs <= DISTINCT_STATE_TOL
    out["forced_same"] = forced_same
    thr = 2 * REGION_SLACK_TOL
    out["thin_certifiable_on_relaxed_set"] = bool(out["min_width_relaxed_1e-7"] <= thr)
    if sv[-1] <= 1e-9 and w_u <= FLAT_TOL:
        label = "thin"
    elif forced_same:
        label = "same"
    elif wmin_up < thr:
        label = "thin"
    elif maxabs <= DISTINCT_STATE_TOL:
        label = "same"
    else:
        label = "piece"
    out["label"] = label
    out["lp_retries"] = retries
    notes = []
    if out["min_width_lower_bound"] < thr <= wmin_up and wmin_up < 10 * thr:
        notes.append(f"width undecided: min width in [{out['min_width_lower_bound']:.3g}, {wmin_up:.3g}] vs {thr:g}")
    if abs(wmin_up - thr) < 0.01 * thr or (out["min_width_relaxed_1e-7"] <= thr) != (wmin_up <= thr):
        notes.append(f"width marginal: {wmin_up:.6g} on the closed set, {out['min_width_relaxed_1e-7']:.6g} at best on the set "
                     f"relaxed by CLOSED_SET_TOL (worst flat direction {out['max_width_relaxed_over_flat_scan']:.3g}) vs {thr:g}")
    if abs(maxabs - DISTINCT_STATE_TOL) < 0.01 * DISTINCT_STATE_TOL or (maxabs <= DISTINCT_STATE_TOL) != (dist_up <= DISTINCT_STATE_TOL):
        notes.append(f"distinct marginal: {maxabs:.6g} (upper {dist_up:.6g}) vs {DISTINCT_STATE_TOL:g}")
    if out["marginal_empty"]:
        notes.append(f"emptiness marginal: radius {val:.3g} in [{lo:.3g}, {up:.3g}]")
    out["marginal"] = bool(notes)
    out["notes"] = notes
    return out


def labels_of(lists: dict) -> dict:
    lab = {}
    for key, name in (("pairs", "piece"), ("thin", "thin"), ("same", "same")):
        for p in lists[key]:
            t = tuple(p)
            if t in lab:
                raise ValueError(f"{t} in two lists")
            lab[t] = name
    return lab


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--old", default="/tmp/t9/old.json")
    ap.add_argument("--new", default="/tmp/t9/new.json")
    ap.add_argument("--T", type=int, default=9)
    ap.add_argument("--out", default="/tmp/t9/oracle.json")
    ap.add_argument("--sample", type=int, default=0)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--sample-lists", default="piece,thin,same", help="lists the --sample entries come from")
    ap.add_argument("--only-sample", action="store_true", help="skip the differing pairs")
    ap.add_argument("--pairs", nargs="*", default=None)
    ap.add_argument("--no-exact", action="store_true", help="bracket in floats only (faster)")
    args = ap.parse_args(argv)
    from hybobs_opt.regions import enumerate_modes
    from hybobs_opt.studies.paper002_powertrain.systems import powertrain5

    old, new = json.load(open(args.old)), json.load(open(args.new))
    lo, ln = labels_of(old), labels_of(new)
    t0 = time.perf_counter()
    enum = enumerate_modes(powertrain5(), args.T)
    print(f"enumeration: {len(enum.regions)} regions, {time.perf_counter() - t0:.1f} s", flush=True)
    if args.only_sample:
        todo = []
    elif args.pairs:
        todo = [tuple(int(v) for v in p.split(",")) for p in args.pairs]
    else:
        todo = sorted(k for k in set(lo) | set(ln) if lo.get(k, "none") != ln.get(k, "none"))
    summary = {"sizes_old": {k: len(old[k]) for k in ("pairs", "thin", "same")},
               "sizes_new": {k: len(new[k]) for k in ("pairs", "thin", "same")}, "differing": len(todo)}
    print(json.dumps(summary), flush=True)
    results = []
    for k, (a, b) in enumerate(todo):
        r = oracle(enum, a, b, exact=not args.no_exact)
        r["old"], r["new"] = lo.get((a, b), "none"), ln.get((a, b), "none")
        r["verdict"] = ("both right" if r["label"] == r["old"] == r["new"] else "new right" if r["label"] == r["new"]
                        else "old right" if r["label"] == r["old"] else "neither")
        results.append(r)
        print(f"[{k + 1}/{len(todo)}] ({a},{b}) old={r['old']} new={r['new']} oracle={r['label']} -> {r['verdict']}"
              f"{' MARGINAL' if r.get('marginal') else ''}  radius={r.get('radius', float('nan')):.3g} "
              f"wmin<={r.get('min_width_upper_bound', float('nan')):.3g} wmin>={r.get('min_width_lower_bound', float('nan')):.3g} "
              f"|x-x^|max={r.get('max_abs_x_minus_xhat', float('nan')):.3g} {'; '.join(r.get('notes', []))}", flush=True)
    sample = []
    if args.sample:
        rng = random.Random(args.seed)
        agree = [k for k in set(lo) & set(ln) if lo[k] == ln[k]]
        for name in args.sample_lists.split(","):
            pool = sorted(k for k in agree if lo[k] == name)
            for (a, b) in rng.sample(pool, min(args.sample, len(pool))):
                r = oracle(enum, a, b, exact=False)
                r["old"] = r["new"] = name
                sample.append(r)
                print(f"[sample] ({a},{b}) both={name} oracle={r['label']}{' MARGINAL' if r.get('marginal') else ''}"
                      f"  wmin<={r.get('min_width_upper_bound', float('nan')):.3g} |x-x^|max={r.get('max_abs_x_minus_xhat', float('nan')):.3g}",
                      flush=True)
    counts: dict = {}
    for r in results:
        key = f"old={r['old']} new={r['new']} oracle={r['label']}{' (marginal)' if r.get('marginal') else ''}"
        counts[key] = counts.get(key, 0) + 1
    summary["by_transition"] = counts
    summary["verdicts"] = {v: sum(r["verdict"] == v for r in results) for v in ("new right", "old right", "neither", "both right")}
    summary["sample_agreement"] = {"checked": len(sample), "agree": sum(r["label"] == r["old"] for r in sample),
                                   "disagree": {f"{r['old']}->{r['label']}": sum(1 for q in sample if q["old"] == r["old"] and q["label"] == r["label"])
                                                for r in sample if r["label"] != r["old"]}}
    summary["seconds"] = time.perf_counter() - t0
    print(json.dumps(summary, indent=1))
    json.dump({"summary": summary, "results": results, "sample": sample}, open(args.out, "w"), indent=1, default=float)
    return 0


if __name__ == "__main__":
    sys.exit(main())

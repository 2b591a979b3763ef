"""The lookup-table deadbeat observer, Algorithm 4.1 of paper 002.

Offline (from the saved result of Algorithm 3.1): for every region ``P_i`` with ``i`` in ``I``
the pseudo-inverse ``C_i^+`` of eq. (13), and the region's H-representation rewritten over the
data window ``z = [Y_t; U_t]``.  Because the candidate ``x_i = C_i^+ (Y_t - D_i U_t - f_i)`` is
affine in ``z``, the candidates of eq. (13), their output residuals (the equality of eq. 12) and
the membership tests ``[x_i; U_t] in P_i`` of eq. (14) are *one* matrix product with a
precomputed table followed by reductions: no optimisation solver in the online path.

Online, per step: the set ``chi`` of consistent candidates (eq. 14); if it holds exactly one
state and that state is not in ``B~_T`` (eq. 15), the state at the window start is reconstructed
(flag ``observable``) and propagated to the current time through the region's affine map;
otherwise the observer predicts open loop from its previous estimate (step 2.1, flag
``unobservable``).

When is each variant right?  The ``B~_T`` test (``variant="table"``) is the paper's: it is exact
up to sets of measure zero, needs the projections of ``B~_T`` offline, and costs one more small
matrix product online.  The ``"exact"`` variant asks the data's own question instead -- is any
other mode sequence of ``M \\ I`` consistent with these ``U_t, Y_t`` for a different state? -- with
one small LP per rank-deficient region; it needs no projections and is exact for the data at
hand (including measure-zero cases), but it runs LPs online, so it is the reference, not the
1 ms controller.
"""

from __future__ import annotations

import time
from collections.abc import Sequence

import numpy as np

from ..errors import ModelError
from ..lp import max_slack
from ..systems.polytope import Polytope
from ..tolerances import (
    LOOKUP_INTERIOR_MARGIN,
    LOOKUP_MEMBERSHIP_TOL,
    LOOKUP_OUTPUT_RTOL,
    LOOKUP_SAME_STATE_TOL,
    RANK_RTOL,
    REGION_SLACK_TOL,
)
from . import _lookup_kernels as K
from .base import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP, Estimate, Observer, ObserverTrace

class LookupObserver(Observer):
    """Algorithm 4.1 of paper 002 on the common observer contract.

    Parameters
    ----------
    analysis : ObservabilityAnalysis
        Result of Algorithm 3.1 (``hybobs_opt.regions``), e.g. from ``load_analysis(file)``.
    b_tilde : sequence of Polytope, optional
        H-representations of the pieces of ``B~_T`` (eq. 15) over ``x``.  By default they are
        computed from ``analysis`` by exact projection (offline).
    variant : {"table", "exact"}
        ``"table"``: the paper's test against ``B~_T``; ``"exact"``: LPs on the data (see module).
    output_rtol : float
        Relative tolerance of the output equality of eq. (12) (raise it for noisy data).
    """

    name = "lookup"

    def __init__(self, analysis, *, b_tilde: Sequence[Polytope] | None = None, variant: str = "table",
                 output_rtol: float = LOOKUP_OUTPUT_RTOL):
        if variant not in ("table", "exact"):
            raise ModelError("variant", "'table' or 'exact'", repr(variant))
        if not (np.isfinite(output_rtol) and output_rtol > 0):
            raise ModelError("output_rtol", "a positive tolerance", repr(output_rtol))
        self.analysis = analysis
        self.system = analysis.system
        self.variant = variant
        self.output_rtol = float(output_rtol)
        self.T = analysis.T
        self.n, self.m, self.p = self.system.n, self.system.m, self.system.p
        self.state_names = self.system.state_names
        self.name = "lookup" if variant == "table" else "lookup-exact"
        self._build_tables()
        pieces = list(b_tilde) if b_tilde is not None else (reduced_unobservable_polytopes(analysis) if variant == "table" else [])
        self._build_btilde(pieces)
        self.reset()

    # ------------------------------------------------------------------ offline tables
    def _build_tables(self) -> None:
        an = self.analysis
        n, T, p, m = self.n, self.T, self.p, self.m
        self.I = np.array(an.index_set, dtype=int)
        if self.I.size == 0:
            raise ModelError("analysis", "at least one region with rank C_i = n (the set I of Algorithm 3.1)",
                             "none: no state is observable with this horizon")
        sx = an.enumeration.scale[:n]
        self._sx = sx
        d = p * T + m * T
        blocks_x, blocks_r, blocks_m = [], [], []
        off_x, off_r, off_m = [], [], []
        starts = []
        row = 0
        self._last = []
        for i in self.I:
            reg = an.regions[i]
            Cp = np.linalg.pinv(reg.C)  # eq. (13)
            Q = np.eye(p * T) - reg.C @ Cp  # residual of the output equality (12)
            # x_i = Cp Y - Cp D U - Cp f
            blocks_x.append(np.hstack([Cp, -Cp @ reg.D]))
            off_x.append(-Cp @ reg.f)
            blocks_r.append(np.hstack([Q, -Q @ reg.D]))
            off_r.append(-Q @ reg.f)
            # [x_i; U] in P_i  <=>  Hx (Cp Y - Cp D U - Cp f) + HU U <= h, rows unit in scaled coordinates
            Hx, HU = reg.H[:, :n], reg.H[:, n:]
            norm = np.linalg.norm(reg.H * an.enumeration.scale[None, :], axis=1)
            norm = np.where(norm > 0, norm, 1.0)
            Mi = np.hstack([Hx @ Cp, HU - Hx @ Cp @ reg.D]) / norm[:, None]
            mi = (reg.h + Hx @ Cp @ reg.f) / norm
            blocks_m.append(Mi)
            off_m.append(-mi)
            starts.append(row)
            row += Mi.shape[0]
            self._last.append((reg.Phi_last, reg.Gamma_last, reg.phi_last, reg.sequence[-1]))
        K = self.I.size
        self._K = K
        self._nx, self._nr = K * n, K * p * T
        self._table = np.ascontiguousarray(np.vstack(blocks_x + blocks_r + blocks_m))
        self._offset = np.concatenate(off_x + off_r + off_m)
        self._mstarts = np.array(starts, dtype=int)
        self._d = d

    def _build_btilde(self, pieces: Sequence[Polytope]) -> None:
        sx = self._sx
        rows, rhs, starts = [], [], []
        r = 0
        for k, P in enumerate(pieces):
            if P.dim != self.n:
                raise ModelError(f"b_tilde[{k}]", f"a polytope over the {self.n} states", f"dimension {P.dim}")
            norm = np.linalg.norm(P.A * sx[None, :], axis=1)
            norm = np.where(norm > 0, norm, 1.0)
            rows.append(P.A / norm[:, None])
            rhs.append(P.b / norm)
            starts.append(r)
            r += P.n_constraints
        self.b_tilde = tuple(pieces)
        self._bt_A = np.vstack(rows) if rows else np.zeros((0, self.n))
        self._bt_b = np.concatenate(rhs) if rhs else np.zeros(0)
        self._bt_starts = np.array(starts, dtype=int)

    def _build_kernel_args(self) -> None:
        sysm = self.system
        table, rhs, starts = sysm._mode_table
        self._modeA = np.ascontiguousarray(np.stack([md.A for md in sysm.modes]))
        self._modeB = np.ascontiguousarray(np.stack([md.B for md in sysm.modes]))
        self._modea = np.ascontiguousarray(np.stack([md.a for md in sysm.modes]))
        self._guard = np.ascontiguousarray(table)
        self._guard_rhs = np.ascontiguousarray(rhs)
        self._guard_starts = np.append(starts, table.shape[0]).astype(np.int64)
        self._Pl = np.ascontiguousarray(np.stack([l[0] for l in self._last]))
        self._Gl = np.ascontiguousarray(np.stack([l[1] for l in self._last]))
        self._pl = np.ascontiguousarray(np.stack([l[2] for l in self._last]))
        self._last_mode = np.array([l[3] for l in self._last], dtype=np.int64)
        self._mstarts_k = np.append(self._mstarts, self._table.shape[0] - self._nx - self._nr).astype(np.int64)
        if self.variant != "table":
            self._bt_A, self._bt_b, self._bt_starts = np.zeros((0, self.n)), np.zeros(0), np.zeros(1, dtype=np.int64)
        bt_starts = np.append(self._bt_starts, self._bt_A.shape[0]).astype(np.int64) if len(self._bt_starts) and self._bt_A.shape[0] else np.zeros(1, dtype=np.int64)
        self._bt_starts_k = bt_starts
        self._ints = np.array([self.T, self._nx, self._nr, self.p * self.T, 1 if self.variant == "table" else 0, 1], dtype=np.int64)
        self._ints_bad = self._ints.copy()
        self._ints_bad[5] = 0
        self._reals = np.array([self.output_rtol, LOOKUP_INTERIOR_MARGIN, LOOKUP_SAME_STATE_TOL, LOOKUP_MEMBERSHIP_TOL])
        self._tables = (self._table, self._offset, self._mstarts_k, self._sx, np.ascontiguousarray(self._bt_A),
                        np.ascontiguousarray(self._bt_b), self._bt_starts_k, self._Pl, self._Gl, self._pl, self._last_mode,
                        self._modeA, self._modeB, self._modea, self._guard, self._guard_rhs, self._guard_starts)
        self._nan_u = np.full(self.m, np.nan)
        self._nan_y = np.full(self.p, np.nan)

    # ------------------------------------------------------------------ state
    def reset(self, x0: np.ndarray | None = None, **kwargs) -> None:
        """Clear the window; ``x0`` (default: centre of the state box) seeds open-loop prediction."""
        if not hasattr(self, "_tables"):
            self._build_kernel_args()
        if x0 is None:
            x0 = self.analysis.enumeration.centre[: self.n]
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape != (self.n,) or not np.all(np.isfinite(x0)):
            raise ModelError("x0", f"a finite state of length {self.n}", f"{x0.tolist()}")
        self._xcur = x0.copy()
        self._meta = np.array([0, -1, 0, 0, -1], dtype=np.int64)
        self._Ybuf = np.zeros((self.T, self.p))
        self._Ubuf = np.zeros((self.T, self.m))
        self._uprev = np.zeros(self.m)
        self._z = np.zeros(self.T * (self.p + self.m))
        self._xs0 = np.zeros(self.n)
        self._xnew = np.zeros(self.n)

    def _other_sequence_consistent(self, x: np.ndarray, z: np.ndarray) -> bool:
        """Exact variant: does a rank-deficient region admit another state with these data (an LP each)?"""
        an, n, p, T = self.analysis, self.n, self.p, self.T
        Y, U = z[: p * T], z[p * T :]
        sx, cx = an.enumeration.scale[:n], an.enumeration.centre[:n]
        for j in an.rank_deficient:
            reg = an.regions[j]
            # x~ = cx + sx * v; constraints Hx x~ <= h - HU U; C x~ = Y - D U - f
            E = reg.C * sx[None, :]
            e = Y - reg.D @ U - reg.f - reg.C @ cx
            _, s, Vt = np.linalg.svd(E)
            r = int(np.sum(s > RANK_RTOL * max(s[0], np.finfo(float).tiny))) if s.size else 0
            v0 = Vt[:r].T @ ((np.linalg.svd(E)[0][:, :r].T @ e) / s[:r]) if r else np.zeros(n)
            if np.linalg.norm(E @ v0 - e) > self.output_rtol * max(1.0, np.max(np.abs(Y))):
                continue
            N = Vt[r:].T
            G = reg.H[:, :n] * sx[None, :]
            g = reg.h - reg.H[:, n:] @ U - reg.H[:, :n] @ cx - G @ v0
            norm = np.linalg.norm(G, axis=1)
            norm = np.where(norm > 0, norm, 1.0)
            res = max_slack((G @ N) / norm[:, None], g / norm, radius_bound=np.sqrt(n) + np.linalg.norm(v0),
                            threshold=REGION_SLACK_TOL, problem=f"lookup exact test, region {j}")
            if max(res.lower, res.upper if res.lower <= REGION_SLACK_TOL else res.lower) > REGION_SLACK_TOL:
                return True
        return False

    # ------------------------------------------------------------------ online
    def _advance(self, u: np.ndarray, y: np.ndarray, good: bool) -> int:
        code = K.advance(u, y, self._ints if good else self._ints_bad, self._reals, self._Ybuf, self._Ubuf, self._xcur,
                         self._meta, self._uprev, self._z, self._xs0, self._xnew, *self._tables)
        if code == K.CANDIDATE_CODE:  # exact variant: ask the data with LPs
            if self._other_sequence_consistent(self._xs0, self._z):
                code = K.UNOBSERVABLE_CODE
            else:
                k = int(self._meta[4])
                K.propagate_last(k, self._xs0, self._z, self.p * self.T, self._Pl, self._Gl, self._pl, self._xcur)
                self._meta[1] = self._last_mode[k]
                code = K.OBSERVABLE_CODE
        return code

    def step(self, u, y) -> Estimate:
        """Algorithm 4.1 for one sample (compiled); a bad sample gives a ``fallback`` step."""
        t0 = time.perf_counter()
        reason = ""
        try:
            uu = np.asarray(u, dtype=np.float64).reshape(-1)
            yy = np.asarray(y, dtype=np.float64).reshape(-1)
            if uu.shape[0] != self.m or yy.shape[0] != self.p:
                reason = f"sample of length (u={uu.shape[0]}, y={yy.shape[0]}), expected (u={self.m}, y={self.p})"
        except (TypeError, ValueError) as exc:
            reason = f"sample not numeric ({exc})"
        if reason:
            uu, yy = self._nan_u, self._nan_y
        code = self._advance(uu, yy, not reason)
        if code == K.FALLBACK_CODE and not reason and int(self._meta[3]) == 0:
            reason = "sample with NaN or Inf"
        info = {"reason": reason} if reason else {}
        return Estimate(self._xcur.copy(), int(self._meta[1]), _FLAGS[code], time.perf_counter() - t0, info)

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        return self.step(u, y)

    def _fallback(self, u, reason: str) -> Estimate:
        code = self._advance(self._nan_u, self._nan_y, False)
        return Estimate(self._xcur.copy(), int(self._meta[1]), _FLAGS[code], 0.0, {"reason": reason})

    def run(self, U, Y, x0: np.ndarray | None = None) -> ObserverTrace:
        """Algorithm 4.1 over a recorded trace, from a reset state (compiled loop for ``"table"``).

        Rows with NaN/Inf are bad samples (flag ``fallback``).  ``seconds`` holds the mean time
        per step of the whole run.
        """
        t_start = time.perf_counter()
        U = np.ascontiguousarray(np.asarray(U, dtype=float).reshape(len(U), -1))
        Y = np.ascontiguousarray(np.asarray(Y, dtype=float).reshape(len(Y), -1))
        if U.shape != (Y.shape[0], self.m) or Y.shape[1] != self.p:
            raise ModelError("U, Y", f"arrays of shapes (N, {self.m}) and (N, {self.p})", f"{U.shape} and {Y.shape}")
        self.reset(x0)
        N = U.shape[0]
        xs = np.empty((N, self.n))
        modes = np.empty(N, dtype=np.int64)
        codes = np.empty(N, dtype=np.int64)
        if self.variant == "table":
            K.run_table(U, Y, self._ints, self._reals, self._Ybuf, self._Ubuf, self._xcur, self._meta, self._uprev,
                        self._z, self._xs0, self._xnew, *self._tables, xs, modes, codes)
        else:
            for t in range(N):
                codes[t] = self._advance(U[t], Y[t], True)
                xs[t], modes[t] = self._xcur, self._meta[1]
        per_step = (time.perf_counter() - t_start) / max(N, 1)
        flags = np.array([_FLAGS[c] for c in range(5)], dtype=object)[codes]
        return ObserverTrace(xs, modes, flags, np.full(N, per_step), self.state_names, self.name)


_FLAGS = {K.OBSERVABLE_CODE: OBSERVABLE, K.UNOBSERVABLE_CODE: UNOBSERVABLE, K.FALLBACK_CODE: FALLBACK,
          K.WARMING_CODE: WARMING_UP, K.CANDIDATE_CODE: UNOBSERVABLE}


def reduced_unobservable_polytopes(analysis) -> list[Polytope]:
    """H-representations over ``x`` of the pieces ``Proj_x(R_ij)`` of ``B~_T`` (eq. 15), by exact projection.

    All non-empty ``R_ij`` (``i`` in ``I``, ``j`` not in ``I``) are used, including those whose
    projection is lower-dimensional (returned with their affine hull as paired rows): the data of
    a true state in ``P_j`` can force the candidate of ``P_i`` onto such a flat piece.
    """
    pieces = []
    n = analysis.system.n
    for pair in analysis.reduced_pairs_all_dimensions():
        P = Polytope(pair.G, pair.g)
        pieces.append(P.project_with_equalities(pair.E, pair.e, list(range(n))))
    return pieces

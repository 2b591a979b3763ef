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
    REGION_SLACK_TOL,
)
from .base import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP, Estimate, Observer, ObserverTrace

#: Windows processed per matrix product by :meth:`LookupObserver.run` (bounded memory).
RUN_CHUNK = 16384


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
        if variant == "table":
            pieces = list(b_tilde) if b_tilde is not None else reduced_unobservable_polytopes(analysis)
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

    # ------------------------------------------------------------------ state
    def reset(self, x0: np.ndarray | None = None, **kwargs) -> None:
        """Clear the window; ``x0`` (default: centre of the state box) seeds open-loop prediction."""
        if x0 is None:
            x0 = self.analysis.enumeration.centre[: self.n]
        x0 = np.asarray(x0, dtype=float).reshape(-1)
        if x0.shape != (self.n,) or not np.all(np.isfinite(x0)):
            raise ModelError("x0", f"a finite state of length {self.n}", f"{x0.tolist()}")
        self._x = x0.copy()
        self._mode = -1
        self._Y = np.zeros((self.T, self.p))
        self._U = np.zeros((self.T, self.m))
        self._count = 0
        self._u_prev: np.ndarray | None = None

    # ------------------------------------------------------------------ per-step core
    def _classify_window(self, z: np.ndarray) -> tuple[int, np.ndarray | None]:
        """Index into ``I`` of the unique consistent candidate (or -1), and the window-start state."""
        out = self._table @ z + self._offset
        n, p, T, K = self.n, self.p, self.T, self._K
        xs = out[: self._nx].reshape(K, n)
        res = out[self._nx : self._nx + self._nr].reshape(K, p * T)
        viol = out[self._nx + self._nr :]
        ymax = max(1.0, float(np.max(np.abs(z[: p * T]))))
        ok = np.max(np.abs(res), axis=1) <= self.output_rtol * ymax
        ok &= np.maximum.reduceat(viol, self._mstarts) < -LOOKUP_INTERIOR_MARGIN
        cand = np.nonzero(ok)[0]
        if cand.size == 0:
            return -1, None
        first = xs[cand[0]]
        if cand.size > 1 and np.max(np.abs((xs[cand] - first) / self._sx)) > LOOKUP_SAME_STATE_TOL:
            return -1, None  # card(chi) > 1
        return int(cand[0]), first

    def _in_btilde(self, x: np.ndarray) -> bool:
        if self._bt_A.shape[0] == 0:
            return False
        viol = self._bt_A @ x - self._bt_b
        return bool(np.any(np.maximum.reduceat(viol, self._bt_starts) <= LOOKUP_MEMBERSHIP_TOL))

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
            r = int(np.sum(s > 1e-12 * max(s[0], 1e-300))) if s.size else 0
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

    def _open_loop(self, u: np.ndarray | None) -> tuple[np.ndarray, int, bool]:
        """``f_pwa(x(t-1), u(t-1))``; keeps the estimate if it has left ``X x U`` (never raises)."""
        if u is None:
            return self._x, self._mode, False
        q = int(self.system.modes_of(self._x[None, :], u[None, :])[0])
        if q < 0:
            return self._x, self._mode, False
        mode = self.system.modes[q]
        return mode.A @ self._x + mode.B @ u + mode.a, q, True

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        # open-loop prediction of x(t) from x(t-1), u(t-1)
        x_pred, q_pred, ok_pred = self._open_loop(self._u_prev) if self._count > 0 else (self._x, self._mode, True)
        self._Y[:-1] = self._Y[1:]
        self._Y[-1] = y
        self._U[:-1] = self._U[1:]
        self._U[-1] = u
        self._count += 1
        self._u_prev = u
        if self._count < self.T:
            self._x, self._mode = x_pred, q_pred
            return Estimate(self._x.copy(), self._mode, WARMING_UP, 0.0, {})
        z = np.concatenate([self._Y.reshape(-1), self._U.reshape(-1)])
        k, x_start = self._classify_window(z)
        if k >= 0:
            unobs = self._in_btilde(x_start) if self.variant == "table" else self._other_sequence_consistent(x_start, z)
            if not unobs:
                Pl, Gl, pl, last_mode = self._last[k]
                self._x = Pl @ x_start + Gl @ z[self.p * self.T :] + pl
                self._mode = int(last_mode)
                return Estimate(self._x.copy(), self._mode, OBSERVABLE, 0.0, {"region": int(self.I[k])})
        self._x, self._mode = x_pred, q_pred
        return Estimate(self._x.copy(), self._mode, UNOBSERVABLE if ok_pred else FALLBACK, 0.0, {})

    def _fallback(self, u, reason: str) -> Estimate:
        x_pred, q_pred, _ = self._open_loop(self._u_prev) if self._count > 0 else (self._x, self._mode, True)
        self._x, self._mode = x_pred, q_pred
        self._u_prev = u
        # a bad sample breaks the window: start filling it again
        self._count = 0
        return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, {"reason": reason})

    # ------------------------------------------------------------------ batch
    def run(self, U, Y, x0: np.ndarray | None = None) -> ObserverTrace:
        """Vectorised Algorithm 4.1 over a recorded trace (from a reset state).

        All windows are classified with chunked matrix products (:data:`RUN_CHUNK` windows at a
        time); only the steps that are not reconstructed are propagated open loop in a loop.
        Rows with NaN/Inf are treated as bad samples (flag ``fallback``).
        """
        t_start = time.perf_counter()
        U = np.asarray(U, dtype=float).reshape(len(U), -1)
        Y = np.asarray(Y, dtype=float).reshape(len(Y), -1)
        if U.shape != (Y.shape[0], self.m) or Y.shape[1] != self.p:
            raise ModelError("U, Y", f"arrays of shapes (N, {self.m}) and (N, {self.p})", f"{U.shape} and {Y.shape}")
        self.reset(x0)
        N, T, n, p = U.shape[0], self.T, self.n, self.p
        good = np.all(np.isfinite(U), axis=1) & np.all(np.isfinite(Y), axis=1)
        flags = np.full(N, UNOBSERVABLE, dtype=object)
        flags[: min(T - 1, N)] = WARMING_UP
        xs = np.full((N, n), np.nan)
        modes = np.full(N, -1)
        recon = np.zeros(N, dtype=bool)
        if N >= T:
            W = N - T + 1
            # window k covers samples k .. k+T-1 and estimates the state at k+T-1
            Yw = np.lib.stride_tricks.sliding_window_view(Y, T, axis=0).transpose(0, 2, 1).reshape(W, T * p)
            Uw = np.lib.stride_tricks.sliding_window_view(U, T, axis=0).transpose(0, 2, 1).reshape(W, T * self.m)
            Z = np.hstack([Yw, Uw])
            win_good = np.lib.stride_tricks.sliding_window_view(good, T).all(axis=1)
            for a in range(0, W, RUN_CHUNK):
                b = min(W, a + RUN_CHUNK)
                self._classify_chunk(Z[a:b], win_good[a:b], xs, modes, recon, T - 1 + a)
        flags[recon] = OBSERVABLE
        flags[~good] = FALLBACK
        # open-loop propagation where not reconstructed
        x_prev = self._x.copy()
        q_prev = -1
        for t in range(N):
            if recon[t]:
                x_prev, q_prev = xs[t], modes[t]
                continue
            if t > 0:
                self._x, self._mode = x_prev, q_prev
                x_new, q_new, ok = self._open_loop(U[t - 1] if good[t - 1] else None)
                if not ok and flags[t] == UNOBSERVABLE:
                    flags[t] = FALLBACK
                x_prev, q_prev = x_new, q_new
            xs[t], modes[t] = x_prev, q_prev
        per_step = (time.perf_counter() - t_start) / max(N, 1)
        self._x, self._mode = x_prev.copy(), int(q_prev)
        return ObserverTrace(xs, modes, flags, np.full(N, per_step), self.state_names, self.name)

    def _classify_chunk(self, Z, win_good, xs, modes, recon, t0) -> None:
        n, p, T, K = self.n, self.p, self.T, self._K
        out = Z @ self._table.T + self._offset
        X = out[:, : self._nx].reshape(-1, K, n)
        R = out[:, self._nx : self._nx + self._nr].reshape(-1, K, p * T)
        V = out[:, self._nx + self._nr :]
        ymax = np.maximum(1.0, np.max(np.abs(Z[:, : p * T]), axis=1))
        ok = np.max(np.abs(R), axis=2) <= self.output_rtol * ymax[:, None]
        ok &= np.maximum.reduceat(V, self._mstarts, axis=1) < -LOOKUP_INTERIOR_MARGIN
        ok &= win_good[:, None]
        count = ok.sum(axis=1)
        first = np.argmax(ok, axis=1)
        rows = np.arange(Z.shape[0])
        xstart = X[rows, first]
        unique = count == 1
        multi = np.nonzero(count > 1)[0]
        for w in multi:  # several regions: the same state (a boundary) or card(chi) > 1
            c = np.nonzero(ok[w])[0]
            unique[w] = np.max(np.abs((X[w, c] - X[w, c[0]]) / self._sx)) <= LOOKUP_SAME_STATE_TOL
        sel = np.nonzero(unique)[0]
        if sel.size and self.variant == "table" and self._bt_A.shape[0]:
            viol = xstart[sel] @ self._bt_A.T - self._bt_b
            inside = np.any(np.maximum.reduceat(viol, self._bt_starts, axis=1) <= LOOKUP_MEMBERSHIP_TOL, axis=1)
            sel = sel[~inside]
        elif sel.size and self.variant == "exact":
            sel = np.array([w for w in sel if not self._other_sequence_consistent(xstart[w], Z[w])], dtype=int)
        for w in sel:
            k = first[w]
            Pl, Gl, pl, last_mode = self._last[k]
            t = t0 + w
            xs[t] = Pl @ xstart[w] + Gl @ Z[w, p * T :] + pl
            modes[t] = last_mode
            recon[t] = True


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

"""The 1-norm / inf-norm moving-horizon problem (paper 002, eq. 10) solved exactly without a MIP:
a branch and bound over mode prefixes with one tiny condensed LP per node.

With the mode sequence fixed, eq. (10) in the 1- or inf-norm is a linear program in the scaled
window-start state and disturbances ``theta`` (:meth:`~hybobs_opt.mhe.window.WindowModel.sequence_problem`):

    min ||R_s theta + r_s||   s.t.   G_s theta <= g_s,   lo <= theta <= hi.

``R_s`` and ``G_s`` depend on the mode prefix ``s`` only; ``r_s`` and ``g_s`` are affine in the
window data ``p = [U; Y; x_bar]``.  :class:`SequenceLPSolver` precomputes, once, for every node of
the prefix tree (pruned of the prefixes whose rows no input of ``U`` can meet, proven by a
certified LP), the matrices and these affine maps, so that a step computes every node's offsets with
two matrix-vector products.

Lower bounds are proven in numpy by weak LP duality with *any* multipliers: for ``|mu|_inf <= 1``
(norm 1; the inf-norm: ``||mu_b||_1 <= 1`` per block of the cost, the dual norm) and ``lam >= 0``,
every feasible ``theta`` has

    ||R theta + r|| >= mu'r - lam'g + sum_j min(c_j lo_j, c_j hi_j),   c = R'mu + G'lam,

and with ``mu = 0`` a positive right-hand side proves the node infeasible.  The multipliers are
those of the node's last LP (of an earlier window: a warm start across windows) or, per step,
of its LP solved by HiGHS (a persistent tiny model per node, presolve off); an LP's answer is
used only after its point is checked against the rows and its bound recomputed from its
multipliers.  The optimum of the window is the best leaf; it is certified when every node is
closed with a gap within ``max(MHE_CERTIFIED_RTOL * cost, zero-cost floor)``.

Uniqueness (the flag ``observable``, :mod:`hybobs_opt.mhe.uniqueness`) is decided in the same tree:
every leaf whose bound is at most ``J* + epsilon`` gets the separated LPs
``theta_j >= theta*_j + delta`` / ``theta_j <= theta*_j - delta`` (as column bounds); a verified
point at cost ``<= J* + epsilon`` is an alternative, and a unique window start needs every such
LP closed above the threshold by a proven bound.  The later window states (the reported one
among them) are then separated by the MILP of
:class:`~hybobs_opt.mhe.uniqueness.SeparatedProgram` on HiGHS: a state after the window start is
an affine map of ``theta`` that depends on the mode sequence, not a column bound.
"""

from __future__ import annotations

import time

import numpy as np

from .._native_output import captured_native_output
from ..errors import ModelError, SolverError
from ..status import Status
from ..tolerances import (
    MHE_CERTIFIED_RTOL,
    MHE_FEASIBILITY_TOL,
    MHE_MILP_FEASIBILITY_TOL,
    SEQUENCE_LP_BOUND_RTOL,
    SEQUENCE_LP_DAQP_PROX,
    mhe_decision_band,
)
from .backends.daqp_backend import DAQP_INF
from .result import WindowResult
from .uniqueness import UniquenessOutcome

__all__ = ["INCUMBENT_TRIES", "PREFIX_LP_RETRY", "SequenceLPSolver"]

#: A mode prefix whose LP did not close it (its bound below the cutoff) is branched without an LP
#: in the following windows, and its LP is tried again every this many windows: on model (16)
#: at T = 3 a prefix of one or two samples fits a window of noisy data exactly (3 unknowns, fewer
#: outputs), so its LP costs a solve and never prunes.  Skipping a bound never changes an answer,
#: only which nodes are visited.
PREFIX_LP_RETRY = 16

#: Leaves whose LPs are tried (lowest cheap bound first) for an incumbent before the depth-first
#: search; the search itself closes every node whatever the incumbent, so this only orders work.
INCUMBENT_TRIES = 3


class _Node:
    """One mode prefix: its fixed matrices, affine offsets and the last proven multipliers."""

    __slots__ = ("modes", "R", "G", "blocks", "r_sl", "g_sl", "z_sl", "children", "leaf", "Rinv", "lp",
                 "sep", "fruitless", "ufruitless", "K", "t", "daqp", "null", "index")

    def __init__(self, modes, R, G, blocks):
        self.modes, self.R, self.G, self.blocks = tuple(modes), R, G, blocks
        self.children: list[_Node] = []
        self.leaf = False
        self.Rinv = None
        self.K = self.t = None
        self.null = None  # left null vectors of R scaled into the dual ball (rows)
        self.lp = None
        self.daqp = None
        self.sep: dict = {}
        self.fruitless = 0  # windows since this prefix's LP last closed it (a prefix only)
        self.ufruitless = 0  # windows since this leaf's LP last closed it in the uniqueness test


class SequenceLPSolver:
    """Exact solver of the 1- / inf-norm window problem of eq. (10) (paper 002) by mode-prefix branch and bound.

    Parameters
    ----------
    model : WindowModel
        The window's model, weights and cost (norm ``"1"`` or ``"inf"``).
    zero_cost : float
        The zero-cost floor of the certified gap (original cost units).
    separated : SeparatedProgram
        The observer's separated program: its ``delta``, ``epsilon``, box of ``xi0`` and
        :meth:`~hybobs_opt.mhe.uniqueness.SeparatedProgram.alternative` (the verification of an
        alternative) are reused, no program of it is solved.

    lp : {"daqp", "highs"}
        The LP engine: DAQP's LP mode (``daqp.Model`` per node) with HiGHS as fallback, or
        HiGHS (a persistent ``highspy`` model per node, presolve off) for every LP.

    Attributes
    ----------
    nodes : list
        The mode prefixes kept (depth-first order); ``pruned_offline`` counts those dropped
        because no input of ``U`` meets their rows (a certified LP of
        :func:`~hybobs_opt.geometry.lp.solve_lp` each).
    build_seconds : float
        Time of the precomputation.

    Raises
    ------
    ModelError
        With an extension (``extend``): its rows and parameters are not in the precomputed maps;
        with norm 2; with an unknown ``lp``.
    """

    def __init__(self, model, zero_cost: float, separated, lp: str = "daqp"):
        if model.extension is not None:
            raise ModelError("extend", "None with solver 'sequences' (its per-prefix matrices are precomputed "
                             "from the model alone; use solver 'highs' for an extended problem)", "an extension")
        if model.norm not in ("1", "inf"):
            raise ModelError("norm", "'1' or 'inf' for solver 'sequences'", repr(model.norm))
        import highspy

        if lp not in ("daqp", "highs"):
            raise ModelError("solver_options['lp']", "'daqp' or 'highs' (the LP solver of solver 'sequences')", repr(lp))
        self.lp_engine = lp
        self.lp_solves = self.lp_fallbacks = 0

        self._hs = highspy
        self.model, self.norm, self.zero_cost, self.sep = model, model.norm, float(zero_cost), separated
        sysm, T, n, m, p = model.system, model.T, model.n, model.m, model.p
        self.T, self.n = T, n
        self.dist = model.Ww is not None and T > 1
        self.nt = n + (n * (T - 1) if self.dist else 0)
        self.np_ = T * m + T * p + n
        enc = model.enc
        self.lo = np.concatenate([enc.lb[enc.slices["xi0"]]] + ([enc.lb[enc.slices["omega"]]] if self.dist else []))
        self.hi = np.concatenate([enc.ub[enc.slices["xi0"]]] + ([enc.ub[enc.slices["omega"]]] if self.dist else []))
        t0 = time.perf_counter()
        self.nodes: list[_Node] = []
        Mr, mr, Mg, mg, Mz, mz = [], [], [], [], [], []
        self._rows = [0, 0, 0]
        self.pruned_offline = 0
        self.roots = self._expand((), (Mr, mr, Mg, mg, Mz, mz))
        self.Mr, self.mr = np.vstack(Mr), np.concatenate(mr)
        self.Mg, self.mg = np.vstack(Mg), np.concatenate(mg)
        self.Mz = np.vstack(Mz) if Mz else np.zeros((0, self.np_))
        self.mz = np.concatenate(mz) if mz else np.zeros(0)
        self.leaves = [nd for nd in self.nodes if nd.leaf]
        for i, nd in enumerate(self.nodes):
            nd.index = i
        self._structural_candidates()
        # the last LP's multipliers of every node, stacked like r_all / g_all (dual-feasible as
        # stored), their box terms, and which nodes hold an infeasibility ray (mu = 0)
        self._Wmu, self._Wlam = np.zeros(self._rows[0]), np.zeros(self._rows[1])
        self._Wbox = np.full(len(self.nodes), -np.inf)
        self._Wray = np.zeros(len(self.nodes), dtype=bool)
        self._rstart = np.array([nd.r_sl.start for nd in self.nodes])
        self._gstart = np.array([nd.g_sl.start for nd in self.nodes])
        self._last_alternative = None  # (leaf index, direction) of the last alternative found
        self.build_seconds = time.perf_counter() - t0

    # ------------------------------------------------------------------ offline
    def _prefix_maps(self, modes):
        """``R``, the affine map of ``r`` in ``p``, ``G`` (rows scaled to largest coefficient one), the
        affine map of ``g``, and the theta-free rows' map, of the prefix ``modes`` (as
        :meth:`~hybobs_opt.mhe.window.WindowModel.sequence_problem`, with the data as a parameter)."""
        mdl, sysm, T, n = self.model, self.model.system, self.T, self.n
        m, p, np_ = mdl.m, mdl.p, self.np_
        hx, cx, nt = mdl.hx, mdl.cx, self.nt
        iU, iY, iX = 0, T * m, T * m + T * p
        Px = np.zeros((n, nt))
        Px[:, :n] = np.diag(hx)
        px0, Bpx = cx.copy(), np.zeros((n, np_))
        XA, Xb = mdl.X.A, mdl.X.b
        R, Mr, mr, G, Mg, mg, blocks = [], [], [], [], [], [], []
        for k, q in enumerate(modes):
            md = sysm.modes[int(q)]
            EU = np.zeros((m, np_))
            EU[:, iU + k * m: iU + (k + 1) * m] = np.eye(m)
            EY = np.zeros((p, np_))
            EY[:, iY + k * p: iY + (k + 1) * p] = np.eye(p)
            R.append(-mdl.Wy @ md.C @ Px)
            Mr.append(mdl.Wy @ (EY - md.C @ Bpx - md.D @ EU))
            mr.append(mdl.Wy @ (-md.C @ px0 - md.c))
            blocks += [0] * p
            Ga, gb = md.guard.A, md.guard.b
            G.append(Ga[:, :n] @ Px)
            Mg.append(-Ga[:, n:] @ EU - Ga[:, :n] @ Bpx)
            mg.append(gb - Ga[:, :n] @ px0)
            G.append(XA @ Px)
            Mg.append(-XA @ Bpx)
            mg.append(Xb - XA @ px0)
            if k < T - 1:
                px0 = md.A @ px0 + md.a
                Bpx = md.A @ Bpx + md.B @ EU
                Px = md.A @ Px
                if self.dist:
                    Px[:, n + k * n: n + (k + 1) * n] += np.diag(hx)
        nb = 1
        if self.dist:
            Rw = np.zeros((n * (T - 1), nt))
            Rw[:, n:] = np.kron(np.eye(T - 1), mdl.Ww @ np.diag(hx))
            R.append(Rw)
            Mr.append(np.zeros((n * (T - 1), np_)))
            mr.append(np.zeros(n * (T - 1)))
            blocks += [nb] * (n * (T - 1))
            nb += 1
        if mdl.Wa is not None:
            Ra = np.zeros((n, nt))
            Ra[:, :n] = mdl.Wa @ np.diag(hx)
            R.append(Ra)
            EX = np.zeros((n, np_))
            EX[:, iX:iX + n] = np.eye(n)
            Mr.append(-mdl.Wa @ EX)
            mr.append(mdl.Wa @ cx)
            blocks += [nb] * n
        G, Mg, mg = np.vstack(G), np.vstack(Mg), np.concatenate(mg)
        scale = np.max(np.abs(G), axis=1)
        zero = scale == 0
        Mz, mz = Mg[zero], mg[zero]
        keep = ~zero
        s = scale[keep]
        return (np.vstack(R), np.vstack(Mr), np.concatenate(mr), G[keep] / s[:, None], Mg[keep] / s[:, None],
                mg[keep] / s, Mz, mz, np.asarray(blocks, dtype=int))

    def _possible(self, G, Mg, mg, Mz, mz) -> bool:
        """Whether some input of ``U`` lets the prefix's rows hold (``False`` only when a certified
        LP of :func:`~hybobs_opt.geometry.lp.solve_lp` proves that none does)."""
        from ..geometry.lp import solve_lp

        mdl, T, m, nt = self.model, self.T, self.model.m, self.nt
        Ub = mdl.system.input_bounds
        iU = slice(0, T * m)
        # rows in (theta, U): G theta - Mg_U U <= mg (the guards and X rows see the data only through U)
        A = np.vstack([np.hstack([G, -Mg[:, iU]]), np.hstack([np.zeros((Mz.shape[0], nt)), -Mz[:, iU]])])
        b = np.concatenate([mg, mz])
        if Ub is not None:
            A = np.vstack([A, np.hstack([np.zeros((T * Ub.A.shape[0], nt)), np.kron(np.eye(T), Ub.A)])])
            b = np.concatenate([b, np.tile(Ub.b, T)])
        bounds = [(lo, hi) for lo, hi in zip(self.lo, self.hi)] + [(None, None)] * (T * m)
        try:
            out = solve_lp(np.zeros(A.shape[1]), A, b, bounds=bounds, problem="rows of a mode prefix for every input")
        except SolverError:
            return True
        return out.status != Status.INFEASIBLE

    def _expand(self, prefix, acc) -> list[_Node]:
        out = []
        for q in range(self.model.system.n_modes):
            modes = prefix + (q,)
            R, Mr, mr, G, Mg, mg, Mz, mz, blocks = self._prefix_maps(modes)
            if not self._possible(G, Mg, mg, Mz, mz):
                self.pruned_offline += 1
                continue
            nd = _Node(modes, R, G, blocks)
            a, b, c = self._rows
            nd.r_sl, nd.g_sl, nd.z_sl = slice(a, a + R.shape[0]), slice(b, b + G.shape[0]), slice(c, c + Mz.shape[0])
            self._rows = [a + R.shape[0], b + G.shape[0], c + Mz.shape[0]]
            for lst, val in zip(acc, (Mr, mr, Mg, mg, Mz, mz)):
                lst.append(val)
            self.nodes.append(nd)
            # outputs the sequence cannot reproduce: mu in the left null space of R (R'mu = 0) bounds
            # the cost by |mu'r| with no LP (the backlash sequences of model (16): the engine speed
            # then evolves on its own, and noisy data break that relation)
            u, sv, _ = np.linalg.svd(R)
            rank = int(np.sum(sv > sv.max(initial=0.0) * R.shape[0] * np.finfo(float).eps)) if sv.size else 0
            if rank < R.shape[0]:
                Nl = u[:, rank:].T
                nd.null = Nl / np.array([max(self._dual_norm(nd, row), 1e-300) for row in Nl])[:, None]
            if len(modes) == self.T:
                nd.leaf = True
                if R.shape[0] == R.shape[1] and np.linalg.matrix_rank(R) == R.shape[1]:
                    nd.Rinv = np.linalg.inv(R)
                    # row i of G at the exact fit: multipliers lam = t_i e_i, mu = -t_i (G_i R^-1)'
                    # make c = R'mu + G'lam = 0, so t_i times the row's violation is a bound
                    nd.K = G @ nd.Rinv
                    nd.t = 1.0 / np.maximum([self._dual_norm(nd, row) for row in nd.K], 1e-300)
            else:
                nd.children = self._expand(modes, acc)
            out.append(nd)
        return out

    def _structural_candidates(self) -> None:
        """Multipliers that depend on the node alone, stacked so that one matrix product per step
        gives every node's best bound of them (``c = R'mu + G'lam`` and its box term are fixed):

        * a square full-rank sequence, every row ``i`` of ``G``: ``lam = t_i e_i``,
          ``mu = -t_i (G_i R^-1)'`` (``c ~ 0``; the bound is ``t_i`` times the row's violation at
          the exact fit ``-R^-1 r``);
        * every node whose ``R`` has a left null space, each null vector with both signs (the
          part of the outputs the sequence cannot reproduce).
        """
        shrink = 1.0 - 8 * np.finfo(float).eps  # strictly inside the dual ball despite rounding
        rows_r, tvec, gidx, box, owner = [], [], [], [], []
        nr, ng = self._rows[0], self._rows[1]
        for nd in self.nodes:
            cands = []
            if nd.Rinv is not None:
                for i in range(nd.G.shape[0]):
                    lam = np.zeros(nd.G.shape[0])
                    lam[i] = nd.t[i] * shrink
                    cands.append((-nd.t[i] * shrink * nd.K[i], lam))
            if nd.null is not None:
                for row in nd.null:
                    cands += [(shrink * row, np.zeros(nd.G.shape[0])), (-shrink * row, np.zeros(nd.G.shape[0]))]
            for mu, lam in cands:
                c = nd.R.T @ mu + nd.G.T @ lam
                a = np.zeros(nr)
                a[nd.r_sl] = mu
                rows_r.append(a)
                nz = np.flatnonzero(lam)
                tvec.append(float(lam[nz[0]]) if nz.size else 0.0)  # lam has at most one nonzero
                gidx.append(nd.g_sl.start + int(nz[0]) if nz.size else 0)
                box.append(float(np.minimum(c * self.lo, c * self.hi).sum()))
                owner.append(nd.index)
        self._cand_owner = np.asarray(owner, dtype=int)
        if not owner:
            self._Cr = None
            return
        self._Cr = np.array(rows_r)
        self._aCr = np.abs(self._Cr)
        self._ct, self._cg = np.array(tvec), np.array(gidx, dtype=int)
        self._cbox = np.array(box)
        self._cstarts = np.flatnonzero(np.r_[True, np.diff(self._cand_owner) != 0])
        self._cnodes = self._cand_owner[self._cstarts]
        # the exact fits of the square sequences in one product: theta = -Rinv r, G theta - g
        sq = [nd for nd in self.leaves if nd.Rinv is not None]
        self._sq = sq
        if sq:
            Ri = np.zeros((sum(nd.R.shape[1] for nd in sq), nr))
            Gs = np.zeros((sum(nd.G.shape[0] for nd in sq), Ri.shape[0]))
            gsel, tpos, gpos = [], 0, 0
            self._sq_t, self._sq_g = [], []
            for nd in sq:
                k = nd.R.shape[1]
                Ri[tpos:tpos + k, nd.r_sl] = -nd.Rinv
                Gs[gpos:gpos + nd.G.shape[0], tpos:tpos + k] = nd.G
                gsel.append(np.arange(nd.g_sl.start, nd.g_sl.stop))
                self._sq_t.append(slice(tpos, tpos + k))
                self._sq_g.append(slice(gpos, gpos + nd.G.shape[0]))
                tpos, gpos = tpos + k, gpos + nd.G.shape[0]
            self._Ri, self._Gs = Ri, Gs
            self._gsel = np.concatenate(gsel)
            self._sq_gstart = np.array([sl.start for sl in self._sq_g])
            self._sq_lo = np.concatenate([self.lo for _ in sq])
            self._sq_hi = np.concatenate([self.hi for _ in sq])
            self._sq_tstart = np.array([sl.start for sl in self._sq_t])

    def _cheap_bounds(self, r_all, g_all) -> np.ndarray:
        """Every node's best bound from :meth:`_structural_candidates` and from its last LP's
        multipliers (``-inf`` without one; ``inf`` for a verified infeasibility ray), proven: the
        weak-duality formula of :meth:`_dual_bound` with its rounding allowance."""
        out = np.full(len(self.nodes), -np.inf)
        if self._Cr is not None:
            gl = g_all[self._cg]
            val = self._Cr @ r_all - self._ct * gl + self._cbox
            size = self._aCr @ np.abs(r_all) + self._ct * np.abs(gl) + np.abs(self._cbox)
            out[self._cnodes] = np.maximum.reduceat(val - SEQUENCE_LP_BOUND_RTOL * size, self._cstarts)
        ar, ag = np.abs(r_all), np.abs(g_all)
        val = (np.add.reduceat(self._Wmu * r_all, self._rstart) - np.add.reduceat(self._Wlam * g_all, self._gstart)
               + self._Wbox)
        size = (np.add.reduceat(np.abs(self._Wmu) * ar, self._rstart) + np.add.reduceat(self._Wlam * ag, self._gstart)
                + np.abs(self._Wbox))
        with np.errstate(invalid="ignore"):
            warm = val - SEQUENCE_LP_BOUND_RTOL * size
        warm = np.where(np.isfinite(self._Wbox), warm, -np.inf)
        warm = np.where(self._Wray & (warm > 0), np.inf, warm)
        return np.maximum(out, warm)

    def _store(self, nd, mu, lam) -> None:
        """Keep ``(mu, lam)`` (made dual-feasible) as the node's warm multipliers."""
        lam = np.maximum(lam, 0.0)
        ray = mu is None
        mu = np.zeros(nd.R.shape[0]) if ray else self._into_ball(nd, mu)
        c = nd.R.T @ mu + nd.G.T @ lam
        self._Wmu[nd.r_sl], self._Wlam[nd.g_sl] = mu, lam
        self._Wbox[nd.index] = float(np.minimum(c * self.lo, c * self.hi).sum())
        self._Wray[nd.index] = ray

    def _into_ball(self, nd, mu):
        if self.norm == "1":
            return np.minimum(np.maximum(mu, -1.0), 1.0)
        tot = np.bincount(nd.blocks, weights=np.abs(mu))
        return mu / np.maximum(tot, 1.0)[nd.blocks]

    # ------------------------------------------------------------------ bounds and LPs
    def _dual_bound(self, nd, mu, lam, r, g, lo, hi) -> float:
        """The weak-duality lower bound of the node's LP with the multipliers ``(mu, lam)``, made
        dual-feasible (``lam >= 0``, the dual-norm ball) and proven in numpy, minus rounding."""
        lam = np.maximum(lam, 0.0)
        mu = np.zeros(r.size) if mu is None else self._into_ball(nd, mu)
        c = nd.R.T @ mu + nd.G.T @ lam
        box = np.minimum(c * lo, c * hi)
        ab = np.abs(box)
        val = float(mu @ r - lam @ g + box.sum())
        size = float(np.abs(mu) @ np.abs(r) + lam @ np.abs(g) + ab.sum())
        return val - SEQUENCE_LP_BOUND_RTOL * size

    def _cost(self, nd, theta, r) -> float:
        res = np.abs(nd.R @ theta + r)
        if self.norm == "1":
            return float(res.sum())
        # the blocks (outputs, disturbances, arrival) are contiguous, in that order
        return float(np.maximum.reduceat(res, np.flatnonzero(np.r_[True, np.diff(nd.blocks) != 0])).sum())

    def _lp_model(self, nd):
        """The node's persistent HiGHS LP in ``[theta; e]``: ``R theta - E e <= -r``,
        ``R theta + E e >= -r``, ``G theta <= g``, ``lo <= theta <= hi``, ``e >= 0``."""
        hs = self._hs
        with captured_native_output("highspy.Highs"):
            h = hs.Highs()
        for key, val in (("output_flag", False), ("presolve", "off"),
                         ("primal_feasibility_tolerance", MHE_MILP_FEASIBILITY_TOL),
                         ("dual_feasibility_tolerance", MHE_MILP_FEASIBILITY_TOL)):
            h.setOptionValue(key, val)
        R, G = nd.R, nd.G
        k, nt = R.shape
        E = np.eye(k) if self.norm == "1" else np.eye(int(nd.blocks.max()) + 1)[nd.blocks]
        ne = E.shape[1]
        A = np.block([[R, -E], [R, E], [G, np.zeros((G.shape[0], ne))]])
        inf = hs.kHighsInf
        lp = hs.HighsLp()
        nr, nc = A.shape
        lp.num_col_, lp.num_row_ = nc, nr
        lp.col_cost_ = np.r_[np.zeros(nt), np.ones(ne)]
        lp.col_lower_ = np.r_[self.lo, np.zeros(ne)]
        lp.col_upper_ = np.r_[self.hi, np.full(ne, inf)]
        lp.row_lower_ = np.full(nr, -inf)
        lp.row_upper_ = np.full(nr, inf)
        lp.a_matrix_.format_ = hs.MatrixFormat.kRowwise
        lp.a_matrix_.start_ = np.arange(0, nr * nc + 1, nc).astype(np.int32)
        lp.a_matrix_.index_ = np.tile(np.arange(nc), nr).astype(np.int32)
        lp.a_matrix_.value_ = A.reshape(-1).astype(float)
        # kWarning: HiGHS dropped entries below its small_matrix_value (1e-9; the rotation system's
        # products leave 1e-17 residues).  Harmless: every answer is checked against the exact
        # rows in numpy (feasibility, and the bound from the multipliers by weak duality).
        if h.passModel(lp) not in (hs.HighsStatus.kOk, hs.HighsStatus.kWarning):
            raise SolverError(f"sequence LP of mode prefix {tuple(int(q) for q in nd.modes)} (solver 'sequences')",
                              "highs", "model refused by passModel",
                              hint="MHESettings(solver_options={'lp': 'daqp'}), or solver='highs' (the MILP of eq. (10))")
        nd.lp = (h, np.arange(nr, dtype=np.int32), k, np.arange(nt, dtype=np.int32))
        return nd.lp

    def _daqp_model(self, nd):
        """The node's persistent DAQP LP (``daqp.Model``, proximal point ``eps_prox``) in ``[theta; e]``:
        simple bounds ``lo <= theta <= hi``, ``e >= 0``; rows as in :meth:`_lp_model`."""
        import daqp

        R, G = nd.R, nd.G
        k, nt = R.shape
        E = np.eye(k) if self.norm == "1" else np.eye(int(nd.blocks.max()) + 1)[nd.blocks]
        ne = E.shape[1]
        A = np.ascontiguousarray(np.block([[R, -E], [R, E], [G, np.zeros((G.shape[0], ne))]]))
        nc = nt + ne
        big = DAQP_INF
        bu = np.r_[self.hi, np.full(ne, big), np.zeros(k), np.full(k, big), np.zeros(G.shape[0])]
        bl = np.r_[self.lo, np.zeros(ne), np.full(k, -big), np.zeros(k), np.full(G.shape[0], -big)]
        f = np.r_[np.zeros(nt), np.ones(ne)]
        mdl = daqp.Model()
        mdl.setup(np.zeros((nc, nc)), f, A, bu, bl, np.zeros(bu.size, dtype=np.int32))
        mdl.settings = {**mdl.settings, "eps_prox": SEQUENCE_LP_DAQP_PROX}
        nd.daqp = (mdl, bu, bl, k, nt, nc)
        return nd.daqp

    def _solve_lp(self, nd, r, g, lo, hi, cutoff: float = np.inf, tight: bool = True):
        """The node's LP, checked: ``(bound, theta or None, cost or None, mu, lam)`` with ``bound`` proven
        (``inf`` for an infeasibility proven by a verified ray), or ``None`` (no checked answer).

        DAQP first (``lp="daqp"``); HiGHS when DAQP's answer does not pass the checks or its
        multipliers' bound neither reaches ``cutoff`` nor lies within the certified gap of its
        point's cost (with ``tight=False``, the uniqueness test, a checked point at cost
        ``<= cutoff`` is enough: it shows the node open whatever the bound)."""
        self.lp_solves += 1
        if self.lp_engine == "daqp":
            out = self._solve_daqp(nd, r, g, lo, hi)
            if out is not None and (out[1] is None or out[0] >= cutoff or out[0] >= out[2] - self._gap(out[2])
                                    or (not tight and out[2] <= cutoff)):
                return out
            self.lp_fallbacks += 1
        return self._solve_highs(nd, r, g, lo, hi)

    def _solve_daqp(self, nd, r, g, lo, hi):
        from .backends.daqp_backend import daqp_flag

        mdl, bu, bl, k, nt, nc = nd.daqp if nd.daqp is not None else self._daqp_model(nd)
        bu[:nt], bl[:nt] = hi, lo
        bu[nc:nc + k] = -r
        bl[nc + k:nc + 2 * k] = -r
        bu[nc + 2 * k:] = g
        mdl.update(bupper=bu, blower=bl)
        x, _, flag, info = mdl.solve()
        status = daqp_flag(flag)
        lam_all = np.asarray(info.get("lam", ()), dtype=float)
        if lam_all.size != bu.size or not np.all(np.isfinite(lam_all)):
            return None
        lam_rows = lam_all[nc:]
        if status == Status.INFEASIBLE:
            for cand in (lam_rows[2 * k:], -lam_rows[2 * k:]):
                if self._dual_bound(nd, None, cand, r, g, lo, hi) > 0:
                    return np.inf, None, None, None, cand
            return None
        if status != Status.OPTIMAL:
            return None
        x = np.asarray(x, dtype=float)[:nt]
        if not np.all(np.isfinite(x)):
            return None
        if np.max(nd.G @ x - g, initial=0.0) > MHE_FEASIBILITY_TOL or np.any(x < lo - MHE_FEASIBILITY_TOL) or np.any(
                x > hi + MHE_FEASIBILITY_TOL):
            return None
        x = np.minimum(np.maximum(x, lo), hi)
        mu, lam = lam_rows[:k] + lam_rows[k:2 * k], lam_rows[2 * k:]
        return self._dual_bound(nd, mu, lam, r, g, lo, hi), x, self._cost(nd, x, r), mu, lam

    def _solve_highs(self, nd, r, g, lo, hi):
        hs = self._hs
        h, rows, k, cols = nd.lp if nd.lp is not None else self._lp_model(nd)
        inf = hs.kHighsInf
        ng = g.size
        h.changeRowsBounds(rows.size, rows, np.r_[np.full(k, -inf), -r, np.full(ng, -inf)],
                           np.r_[-r, np.full(k, inf), g])
        h.changeColsBounds(cols.size, cols, lo, hi)
        h.run()
        st = h.getModelStatus()
        if st not in (hs.HighsModelStatus.kOptimal, hs.HighsModelStatus.kInfeasible):
            # HiGHS ends some warm re-solves of a degenerate LP with "unknown": once more from scratch
            h.clearSolver()
            h.run()
            st = h.getModelStatus()
        if st == hs.HighsModelStatus.kInfeasible:
            _, ok, ray = h.getDualRay()
            ray = np.asarray(ray, dtype=float) if ok and len(ray) == rows.size else None
            for cand in ([] if ray is None else [-ray[2 * k:], ray[2 * k:]]):
                if self._dual_bound(nd, None, cand, r, g, lo, hi) > 0:
                    return np.inf, None, None, None, cand
            return None
        if st != hs.HighsModelStatus.kOptimal:
            return None
        sol = h.getSolution()
        x = np.asarray(sol.col_value, dtype=float)[: cols.size]
        y = np.asarray(sol.row_dual, dtype=float)
        if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
            return None
        if np.max(nd.G @ x - g, initial=0.0) > MHE_FEASIBILITY_TOL or np.any(x < lo - MHE_FEASIBILITY_TOL) or np.any(
                x > hi + MHE_FEASIBILITY_TOL):
            return None
        x = np.clip(x, lo, hi)
        mu, lam = -(y[:k] + y[k:2 * k]), -y[2 * k:]
        bound = self._dual_bound(nd, mu, lam, r, g, lo, hi)
        return bound, x, self._cost(nd, x, r), mu, lam

    # ------------------------------------------------------------------ one window
    def solve(self, U, Y, xbar) -> tuple[WindowResult, dict]:
        """The certified optimum of one window of eq. (10) (paper 002) in the 1- / inf-norm.

        Parameters
        ----------
        U : (T, m) ndarray
            Window inputs.
        Y : (T, p) ndarray
            Window outputs.
        xbar : (n,) ndarray
            Arrival prior of the window-start state.

        Returns
        -------
        WindowResult
            ``OPTIMAL`` with the best leaf's trajectory (checked against the MLD rows) and
            ``gap_bound`` (every other node closed by a proven bound within it),
            ``INFEASIBLE`` (every sequence proven infeasible) or ``NOT_CERTIFIED`` (an LP
            without a checked answer; ``reason``).
        dict
            The step's offsets, bounds and LP answers, which :meth:`decide` reuses.
        """
        self.lp_solves = self.lp_fallbacks = 0
        pv = np.concatenate([U.reshape(-1), Y.reshape(-1), xbar])
        r_all = self.Mr @ pv + self.mr
        g_all = self.Mg @ pv + self.mg
        z_ok = (self.Mz @ pv + self.mz) >= 0.0 if self.mz.size else np.zeros(0, dtype=bool)
        lo, hi = self.lo, self.hi
        ctx = {"r": r_all, "g": g_all, "z": z_ok, "cheap": self._cheap_bounds(r_all, g_all), "fits": {},
               "warm": {}, "solved": {}}
        best = (np.inf, None, None)  # cost, node, theta
        # (i) zero-cost fast path: the square full-rank sequences whose exact fit meets their rows
        # (to the LP solver's own tolerance: a fit that needs MHE_FEASIBILITY_TOL of slack in a guard
        # is not claimed, its LP decides the sequence)
        if self._sq:
            th_all = self._Ri @ r_all
            v = self._Gs @ th_all - g_all[self._gsel]
            vmax = np.maximum.reduceat(v, self._sq_gstart)
            out_box = np.maximum(self._sq_lo - th_all, th_all - self._sq_hi)
            bmax = np.maximum.reduceat(out_box, self._sq_tstart)
            for i in np.flatnonzero((vmax <= MHE_MILP_FEASIBILITY_TOL) & (bmax <= MHE_MILP_FEASIBILITY_TOL)):
                nd = self._sq[i]
                if nd.z_sl.stop > nd.z_sl.start and not z_ok[nd.z_sl].all():
                    continue
                th = np.minimum(np.maximum(th_all[self._sq_t[i]], lo), hi)
                c = self._cost(nd, th, r_all[nd.r_sl])
                ctx["fits"][nd.index] = (th, c)
                if c < best[0]:
                    best = (c, nd, th)
            if best[0] <= self.zero_cost:
                ctx["zero_fit"] = True
        failed = []
        if best[0] > self.zero_cost:
            # an incumbent first: the LPs of the leaves in the order of their cheap bounds, until one
            # has a point (then most nodes close on their cheap bounds against it)
            cb = ctx["cheap"]
            cheap = sorted((cb[nd.index], nd.index) for nd in self.leaves if cb[nd.index] < np.inf)
            for _, i in cheap[:INCUMBENT_TRIES]:
                nd = self.nodes[i]
                b = self._node_bound(nd, ctx, lo, hi, cutoff=np.inf)
                if b is not None and b[1] is not None:
                    if b[2] < best[0]:
                        best = (b[2], nd, b[1])
                    break
            # (ii)-(iii) depth-first branch and bound, warm bounds first, the node's LP where they fail
            stack = list(reversed(self.roots))
            while stack:
                nd = stack.pop()
                b = self._node_bound(nd, ctx, lo, hi, cutoff=best[0] - self._gap(best[0]))
                if b is None:
                    failed.append(nd.modes)
                    continue
                bound, th, cost = b
                if th is not None and nd.leaf and cost < best[0]:
                    best = (cost, nd, th)
                if bound >= best[0] - self._gap(best[0]):
                    continue
                if nd.leaf:
                    if th is None or bound < cost - self._gap(cost):
                        failed.append(nd.modes)
                    continue
                stack.extend(reversed(nd.children))
        cost, nd, th = best
        detail = {"sequence_lps": self.lp_solves, "lp_fallbacks": self.lp_fallbacks, "nodes": len(self.nodes)}
        if failed:
            return WindowResult(Status.NOT_CERTIFIED, solver="sequences", solver_detail=detail,
                                reason=f"no checked LP answer for mode prefix(es) {failed[:3]}"), ctx
        if nd is None:
            return WindowResult(Status.INFEASIBLE, solver="sequences", solved_by="prefix search", solver_detail=detail,
                                reason="no mode sequence is feasible (every prefix proven infeasible)"), ctx
        mdl, T, n = self.model, self.T, self.n
        x0 = mdl.cx + mdl.hx * th[:n]
        W = (th[n:].reshape(T - 1, n) * mdl.hx) if self.dist else np.zeros((max(T - 1, 0), n))
        modes = np.array(nd.modes, dtype=int)
        states = mdl.trajectory(x0, modes, U, W)
        v = mdl.enc.pack(states, modes, U, W if mdl.enc.disturbances else None)
        viol = mdl.enc.violation(v, U.reshape(-1))
        if not viol <= MHE_FEASIBILITY_TOL:
            return WindowResult(Status.NOT_CERTIFIED, solver="sequences", solver_detail=detail,
                                reason=f"the best sequence's point failed verification (violation {viol:.3g})"), ctx
        exact = mdl.cost(states, modes, U, Y, W, xbar)
        ctx.update(J=exact, modes=nd.modes, theta=th)
        return WindowResult(Status.OPTIMAL, solver="sequences",
                            solved_by="zero-cost fit" if ctx.get("zero_fit") else "prefix search", polished=False,
                            x_start=x0, states=states, modes=modes, w=W, cost=exact,
                            gap_bound=self._gap(exact), verified_violation=float(viol), passes=0,
                            solver_detail=detail), ctx

    def _gap(self, cost: float) -> float:
        """The certified gap at ``cost``: ``max(MHE_CERTIFIED_RTOL * cost, zero-cost floor)`` (0 at inf)."""
        if cost == np.inf:
            return 0.0
        g = MHE_CERTIFIED_RTOL * cost
        return g if g > self.zero_cost else self.zero_cost

    def _node_bound(self, nd, ctx, lo, hi, cutoff: float, key=None, lp: bool = True, tight: bool = True):
        """``(bound, theta, cost)`` of a node (``theta``/``cost`` only when its LP was solved), or ``None``.

        The stored multipliers of the node (or of ``key``: a separated LP) are tried first; the LP
        is solved only when their bound does not reach ``cutoff``."""
        if nd.z_sl.stop > nd.z_sl.start and not ctx["z"][nd.z_sl].all():
            return np.inf, None, None  # a row without theta-coefficients fails: 0 <= g < 0
        if lp and not nd.leaf and key is None and nd.fruitless and nd.fruitless % PREFIX_LP_RETRY:
            # this prefix's LP did not close it in an earlier window: branch without bounding it
            nd.fruitless += 1
            return -np.inf, None, None
        r, g = ctx["r"][nd.r_sl], ctx["g"][nd.g_sl]
        stored = [] if key is None else [nd.sep.get(key, (None, None))]
        if key is None:
            done = ctx["solved"].get(nd.index)
            if done is not None:  # this node's LP was solved earlier in the step
                return done
            cheap = ctx["cheap"][nd.index]
            if cheap >= cutoff:
                return cheap, None, None
            fit = ctx["fits"].get(nd.index)
            if fit is not None:
                # the exact fit meets the rows: cost ~0 at a point, and 0 is a bound (the cost is a norm)
                return 0.0, fit[0], fit[1]
            if not lp:
                return cheap, None, None
        if key is not None and nd.Rinv is not None:
            th = -nd.Rinv @ r
            if np.all(th >= lo - MHE_MILP_FEASIBILITY_TOL) and np.all(th <= hi + MHE_MILP_FEASIBILITY_TOL) and np.max(
                    nd.G @ th - g, initial=0.0) <= MHE_MILP_FEASIBILITY_TOL:
                th = np.minimum(np.maximum(th, lo), hi)  # the exact fit lies in the separated half-space
                return 0.0, th, self._cost(nd, th, r)
        best = ctx["cheap"][nd.index] if key is None else -np.inf
        for mu, lam in stored:
            if lam is None:
                continue
            b = self._dual_bound(nd, mu, lam, r, g, lo, hi)
            if mu is None and b > 0:
                return np.inf, None, None  # a verified infeasibility ray
            best = max(best, b)
            if b >= cutoff:
                return b, None, None
        if not lp:
            return best, None, None
        out = self._solve_lp(nd, r, g, lo, hi, cutoff, tight)
        if out is None:
            return None
        bound, th, cost, mu, lam = out
        if key is None:
            self._store(nd, mu, lam)
            nd.fruitless = 0 if bound >= cutoff else nd.fruitless + 1
            ctx["solved"][nd.index] = (bound, th, cost)
        else:
            nd.sep[key] = (mu, lam)
        return bound, th, cost

    def _separated_structural(self, nd, ctx, xi_s, delta, dirs, thr):
        """Bounds of a square full-rank sequence's separated LPs (``theta_j`` moved by ``delta`` from
        ``xi_s``, each direction of ``dirs``) from ``mu = s R^-T e_j`` scaled into the dual ball and
        ``lam = 0`` (``None`` for another node): the cost of moving ``theta_j`` away from the exact
        fit, proven by the weak-duality formula of :meth:`_dual_bound`, all directions at once."""
        if nd.Rinv is None:
            return None
        r = ctx["r"][nd.r_sl]
        M = nd.Rinv / np.maximum([self._dual_norm(nd, row) for row in nd.Rinv], 1e-300)[:, None]
        M = M * (1.0 - 8 * np.finfo(float).eps)
        js = np.array([j for j, _ in dirs])
        ss = np.array([s for _, s in dirs], dtype=float)
        MU = ss[:, None] * M[js]  # one multiplier per direction (rows)
        C = MU @ nd.R  # c = R'mu, one row per direction
        LO = np.tile(self.lo, (len(dirs), 1))
        HI = np.tile(self.hi, (len(dirs), 1))
        rows = np.arange(len(dirs))
        LO[rows, js] = np.where(ss > 0, np.maximum(LO[rows, js], xi_s[js] + delta), LO[rows, js])
        HI[rows, js] = np.where(ss < 0, np.minimum(HI[rows, js], xi_s[js] - delta), HI[rows, js])
        box = np.minimum(C * LO, C * HI)
        val = MU @ r + box.sum(axis=1)
        size = np.abs(MU) @ np.abs(r) + np.abs(box).sum(axis=1)
        return val - SEQUENCE_LP_BOUND_RTOL * size

    def _dual_norm(self, nd, mu) -> float:
        """The dual norm of ``mu`` (inf-norm for cost norm 1; the largest block 1-norm for norm inf)."""
        if self.norm == "1":
            return float(np.max(np.abs(mu), initial=0.0))
        return float(np.max(np.bincount(nd.blocks, weights=np.abs(mu)), initial=0.0))

    # ------------------------------------------------------------------ uniqueness
    def decide(self, U, Y, xbar, opt: WindowResult, ctx: dict) -> dict:
        """Is the window-start state unique (no state ``delta`` away with cost ``<= J* + epsilon``)?

        Returns the dict of :meth:`~hybobs_opt.mhe.uniqueness.SeparatedProgram.decide`
        (``status``, ``decided_by``, ``threshold``, ``separated_cost``, ``separated_cost_bound``,
        ``alternative`` when one is found, ``seconds``).
        """
        t0 = time.perf_counter()
        try:
            out = self._decide(U, Y, xbar, opt, ctx)
        except Exception as exc:  # a crashing solver must not stop the observer loop
            out = {"status": UniquenessOutcome.NOT_CERTIFIED, "reason": f"{type(exc).__name__}: {exc}"}
        out["seconds"] = time.perf_counter() - t0
        return out

    def _decide(self, U, Y, xbar, opt, ctx) -> dict:
        sep, n = self.sep, self.n
        delta, eps = sep.delta, sep.epsilon
        thr = float(opt.cost) + eps
        # a cost within the band of thr decides nothing (a fallback): bounds must clear thr_hi,
        # an alternative must cost at most thr_lo
        band = mhe_decision_band(thr, eps)
        thr_lo, thr_hi = thr - band, thr + band
        base = {"delta": delta, "epsilon": eps, "threshold": thr, "decision_band": band, "separated_cost": None,
                "separated_cost_bound": None}
        xs = sep.optimum_states(opt)
        xi_s = xs[0]
        dirs = [(j, s) for j in range(n) for s in (1, -1)
                if (xi_s[j] + delta <= sep._ubx[j] if s > 0 else xi_s[j] - delta >= sep._lbx[j])]
        if not dirs:
            return self._later_states(U, Y, xbar, opt, {**base, "status": UniquenessOutcome.UNIQUE,
                                                         "decided_by": "box (no state of X is delta away)",
                                                         "separated_cost_bound": np.inf})
        lps0 = self.lp_solves
        lowest = np.inf
        stack = list(reversed(self.roots))
        if self._last_alternative is not None:
            # the sequence of the last window's alternative first: an alternative ends the search
            stack.append(self.nodes[self._last_alternative[0]])
            dirs.sort(key=lambda d: d != self._last_alternative[1])
        cheap = ctx["cheap"]
        visited = set()
        while stack:
            nd = stack.pop()
            if nd.index in visited:
                continue
            visited.add(nd.index)
            if cheap[nd.index] > thr_hi:  # closed by a bound of the step's vectorised pass
                lowest = min(lowest, cheap[nd.index])
                continue
            if nd.leaf and nd.ufruitless % PREFIX_LP_RETRY:
                # its own LP stayed within the threshold lately: straight to the separated LPs
                nd.ufruitless += 1
            else:
                b = self._node_bound(nd, ctx, self.lo, self.hi, cutoff=np.nextafter(thr_hi, np.inf), tight=False)
                if b is None:
                    return {**base, "status": UniquenessOutcome.NOT_CERTIFIED,
                            "reason": f"no checked LP answer for mode prefix {nd.modes}"}
                if b[0] > thr_hi:
                    lowest = min(lowest, b[0])
                    nd.ufruitless = 0
                    continue
                if nd.leaf and nd.index not in ctx["fits"] and b[1] is not None:
                    nd.ufruitless += 1
            if not nd.leaf:
                stack.extend(reversed(nd.children))
                continue
            closed = self._separated_structural(nd, ctx, xi_s, delta, dirs, thr_hi)
            for d, (j, s) in enumerate(dirs):
                if closed is not None and closed[d] > thr_hi:
                    lowest = min(lowest, closed[d])
                    continue
                lo, hi = self.lo.copy(), self.hi.copy()
                if s > 0:
                    lo[j] = max(lo[j], xi_s[j] + delta)
                else:
                    hi[j] = min(hi[j], xi_s[j] - delta)
                # a zero-cost fit of a square sequence already in the half-space is an alternative
                bs = self._node_bound(nd, ctx, lo, hi, cutoff=np.nextafter(thr_hi, np.inf), key=(j, s), tight=False)
                if bs is None:
                    return {**base, "status": UniquenessOutcome.NOT_CERTIFIED,
                            "reason": f"no checked separated LP answer for modes {nd.modes}, direction {(j, s)}"}
                bound, th, cost = bs
                if bound <= thr_hi and (th is None or cost > thr_hi) and self.lp_engine == "daqp":
                    # DAQP's proximal multipliers fall short near the threshold: HiGHS decides
                    out = self._solve_highs(nd, ctx["r"][nd.r_sl], ctx["g"][nd.g_sl], lo, hi)
                    if out is not None:
                        bound, th, cost = out[0], out[1], out[2]
                if bound > thr_hi:
                    lowest = min(lowest, bound)
                    continue
                if th is None or cost > thr_hi:
                    return {**base, "status": UniquenessOutcome.NOT_CERTIFIED,
                            "separated_cost_bound": min(lowest, bound),
                            "reason": f"separated LP of modes {nd.modes} closed at {bound:.3g}, within the "
                                      f"threshold {thr:.3g} but without a point below it"}
                mdl, T = self.model, self.T
                x0 = mdl.cx + mdl.hx * th[:n]
                W = (th[n:].reshape(T - 1, n) * mdl.hx) if self.dist else np.zeros((max(T - 1, 0), n))
                alt = sep.alternative(x0, nd.modes, U, Y, xbar, W, xs)
                if alt is not None and alt["cost"] <= thr_lo:
                    self._last_alternative = (nd.index, (j, s))
                    return {**base, "status": UniquenessOutcome.ALTERNATIVE, "decided_by": "sequence LPs",
                            "separated_cost": alt["cost"], "alternative": alt,
                            "sequence_lps": self.lp_solves - lps0}
                if alt is not None and alt["cost"] <= thr_hi:
                    return {**base, "status": UniquenessOutcome.NOT_CERTIFIED, "in_decision_band": True,
                            "separated_cost": alt["cost"],
                            "reason": f"separated cost {alt['cost']:.6g} within the decision band {band:.3g} of "
                                      f"J* + epsilon = {thr:.6g} (decided to the safe side)"}
                return {**base, "status": UniquenessOutcome.NOT_CERTIFIED,
                        "reason": f"the separated LP's point of modes {nd.modes} failed verification"}
        self._last_alternative = None
        return self._later_states(U, Y, xbar, opt, {
            **base, "status": UniquenessOutcome.UNIQUE,
            "decided_by": "sequence LPs (every prefix and direction closed)",
            "separated_cost_bound": lowest, "sequence_lps": self.lp_solves - lps0})

    def _later_states(self, U, Y, xbar, opt, start: dict) -> dict:
        """The window start is unique (``start``): the later window states -- the reported current
        state among them -- are separated by the MILP of :class:`~hybobs_opt.mhe.uniqueness.SeparatedProgram`."""
        if self.T == 1:
            return start
        later = self.sep.decide(U, Y, xbar, opt, steps=range(1, self.T))
        later.pop("seconds", None)
        if later["status"] == UniquenessOutcome.UNIQUE:
            return {**start, "decided_by": f"{start['decided_by']}; later states: {later['decided_by']}",
                    "separated_cost_bound": min(start["separated_cost_bound"], later["separated_cost_bound"])}
        out = {**later, "sequence_lps": start.get("sequence_lps", 0)}
        if later["status"] != UniquenessOutcome.ALTERNATIVE:
            out["reason"] = f"{later.get('reason', '?')} (later window states; the window start is unique)"
        return out

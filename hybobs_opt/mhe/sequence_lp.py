"""The 1-norm / inf-norm moving-horizon problem (paper 002, eq. 10) solved exactly without a MIP:
a branch and bound over mode prefixes with one tiny condensed LP per node.

With the mode sequence fixed, eq. (10) in the 1- or inf-norm is a linear program in the scaled
window-start state and disturbances ``theta`` (:meth:`~hybobs_opt.mhe.window.WindowModel.sequence_problem`):

    min ||R_s theta + r_s||   s.t.   G_s theta <= g_s,   lo <= theta <= hi.

``R_s`` and ``G_s`` depend on the mode prefix ``s`` only; ``r_s`` and ``g_s`` are affine in the
window data ``p = [U; Y; x_bar]``.  A node of the prefix tree holds these matrices and the affine
maps of *its own* sample's rows; a child's matrices are its parent's with one sample's rows
appended, so a prefix costs the rows it adds, not the whole prefix again.  A small tree (at most
:data:`EAGER_MAX_NODES` nodes) is built whole at construction and every node's offsets and cheap
bounds are computed per step in a few vectorised products; a larger one is built lazily: a node
is made when the search first visits it and its offsets are its parent's plus its own rows, so
memory grows with the nodes visited, not with the ``s^T`` mode sequences.  Every node and solver
model is charged against a memory budget *before* it is made
(:data:`~hybobs_opt.limits.MAX_SEQUENCE_TREE_BYTES`, ``MHESettings(solver_options={"memory_budget":
bytes})``); at the budget the solver models not used in the current window are freed, least
recently used first (they hold nearly all the memory), and a window whose own search would still
exceed it is refused with the predicted figure.  Prefixes whose rows no input of ``U`` can meet are dropped from an eager
tree (proven by a certified LP each); in a lazy tree the window's LPs prove them infeasible.

Lower bounds are proven in numpy by weak LP duality with *any* multipliers: for ``|mu|_inf <= 1``
(norm 1; the inf-norm: ``||mu_b||_1 <= 1`` per block of the cost, the dual norm) and ``lam >= 0``,
every feasible ``theta`` has

    ||R theta + r|| >= mu'r - lam'g + sum_j min(c_j lo_j, c_j hi_j),   c = R'mu + G'lam,

and with ``mu = 0`` a positive right-hand side proves the node infeasible.  The multipliers are
those of the node's last LP (of an earlier window: a warm start across windows) or, per step,
of its LP solved by DAQP or HiGHS; an LP's answer is used only after its point is checked against
the rows and its bound recomputed from its multipliers.

The optimum of the window is the best leaf.  Its proven gap is its cost minus the least bound of
the closed nodes (every bound is at least 0: the cost is a norm); a node is closed when its bound
is within ``max(MHE_CERTIFIED_RTOL * J, SEQUENCE_LP_GAP_FLOOR * J_0)`` of the incumbent ``J``
(``J_0`` the zero-cost threshold; the floor is the resolution of the bounds).  The window is a certified
optimum only when that gap is within the same tolerance; a search stopped by its budget
(``certify_max_nodes`` LPs, ``certify_time_budget``) or by an LP without a checked answer
reports its incumbent's cost and proven gap as a gap, not certified.

Uniqueness (the flag ``observable``, :mod:`hybobs_opt.mhe.uniqueness`) is decided in the same tree:
every leaf whose bound is at most ``J* + epsilon`` gets the separated LPs
``theta_j >= theta*_j + delta`` / ``theta_j <= theta*_j - delta`` (as column bounds); a verified
point at cost ``<= J* + epsilon`` is an alternative, and a unique window start needs every such
LP closed above the threshold by a proven bound.  The later window states (the reported one
among them) are separated at the same leaves: a state after the window start is an affine map
``a' theta`` of the sequence, so each of its directions is one more row ``a' theta >= beta`` on
the leaf's LP.  Its bound comes first from multipliers at hand (``mu = R^+' a`` scaled into the
dual ball, the leaf's own, the last separated LP's of that leaf and direction), each with the
best multiplier of the row, found exactly (the weak-duality bound is concave and piecewise
linear in it); a direction still open gets its separated LP (HiGHS, one model per leaf).  Only
directions left undecided (a separated cost in the decision band, an LP without a checked
answer) go to the MILP of :class:`~hybobs_opt.mhe.uniqueness.SeparatedProgram` on HiGHS,
restricted to them.
"""

from __future__ import annotations

import time

import numpy as np

from .._native_output import captured_native_output
from ..errors import ModelError, SolverError
from ..limits import MAX_SEQUENCE_TREE_BYTES
from ..status import Status
from ..tolerances import (
    MHE_CERTIFIED_RTOL,
    MHE_FEASIBILITY_TOL,
    MHE_MILP_FEASIBILITY_TOL,
    SEQUENCE_LP_BOUND_RTOL,
    SEQUENCE_LP_DAQP_PROX,
    SEQUENCE_LP_GAP_FLOOR,
    mhe_decision_band,
)
from .backends.daqp_backend import DAQP_INF
from .result import WindowResult
from .uniqueness import UniquenessOutcome

__all__ = ["EAGER_MAX_NODES", "INCUMBENT_TRIES", "NODE_BYTES", "PREFIX_LP_RETRY", "SequenceLPSolver"]

#: A mode prefix whose LP did not close it (its bound below the cutoff) is branched without an LP
#: in the following windows, and its LP is tried again every this many windows: on model (16)
#: at T = 3 a prefix of one or two samples fits a window of noisy data exactly (3 unknowns, fewer
#: outputs), so its LP costs a solve and never prunes.  Skipping a bound never changes an answer,
#: only which nodes are visited.
PREFIX_LP_RETRY = 16

#: Leaves of an eager tree whose LPs are tried (lowest cheap bound first) for an incumbent before
#: the depth-first search (a lazy tree tries the last window's sequence shifted by one sample, with
#: each last mode); the search itself closes every node whatever the incumbent, so this only
#: orders work.
INCUMBENT_TRIES = 3

#: Prefix trees of at most this many nodes (``s + s^2 + ... + s^T``) are built whole at
#: construction and bounded by vectorised products over all nodes each step (model (16): 39 nodes
#: at T = 3, 363 at T = 5); the per-step products grow with the whole tree (quadratically for the
#: stacked candidate multipliers: 1.7 GB at T = 8), so larger trees are built lazily.
EAGER_MAX_NODES = 400

#: Bytes charged before making a node, beyond its numpy arrays (the Python object and the array
#: headers), and before making each solver model, plus ``per_entry`` per entry of its matrix.
#: Calibrated on model (16) at T = 10 (a leaf's LP has 1183 entries): a fresh ``daqp.Model`` of
#: a leaf takes 44 kB, a fresh ``highspy.Highs`` 68 kB, and over 191 noisy windows the resident
#: set grew by 238 MB for 939 nodes (4.4 MB of arrays), 937 DAQP and 870 HiGHS models: a HiGHS
#: model that has solved keeps its simplex workspace, about 200 kB.  These figures charge 255 MB
#: for that run: the budget errs on the safe side.
NODE_BYTES = {"node": 4096, "daqp": 16384, "highs": 163840, "per_entry": 64}


def _run_highs(h, hs):
    """Run HiGHS (``hs``: the ``highspy`` module) on its model as it stands; returns the model status.

    A status other than optimal or infeasible gets one more run from scratch: HiGHS ends some warm
    re-solves of a degenerate LP with "unknown"."""
    h.run()
    st = h.getModelStatus()
    if st not in (hs.HighsModelStatus.kOptimal, hs.HighsModelStatus.kInfeasible):
        h.clearSolver()
        h.run()
        st = h.getModelStatus()
    return st


def _checked_highs_point(h, G: np.ndarray, g: np.ndarray, lo: np.ndarray, hi: np.ndarray, n_cols: int):
    """``(x, y)``: the first ``n_cols`` entries of an optimal HiGHS point and its row duals, or ``None``
    when either is not finite or the point breaks a row ``G x <= g`` or a bound by more than
    ``MHE_FEASIBILITY_TOL`` (an answer is checked before it is trusted)."""
    sol = h.getSolution()
    x = np.asarray(sol.col_value, dtype=float)[:n_cols]
    y = np.asarray(sol.row_dual, dtype=float)
    if not (np.all(np.isfinite(x)) and np.all(np.isfinite(y))):
        return None
    if (np.max(G @ x - g, initial=0.0) > MHE_FEASIBILITY_TOL or np.any(x < lo - MHE_FEASIBILITY_TOL)
            or np.any(x > hi + MHE_FEASIBILITY_TOL)):
        return None
    return x, y


class _Node:
    """One mode prefix: its matrices, the affine maps of its own sample's rows, the propagation
    state its children start from, and the last proven multipliers."""

    __slots__ = ("modes", "parent", "R", "G", "blocks", "ks", "own", "prop", "children", "leaf", "Rinv", "K", "t",
                 "kbox", "null", "nbox", "lp", "daqp", "sep", "fruitless", "ufruitless", "index", "r_sl", "g_sl",
                 "z_sl", "warm", "rowlp", "pinv")

    def __init__(self, modes, parent, R, G, blocks, ks, own):
        self.modes, self.parent, self.R, self.G, self.blocks = tuple(modes), parent, R, G, blocks
        self.ks = ks  # rows of R from the samples (the rest: disturbance and arrival rows)
        self.own = own  # (Mr, mr, Mg, mg, Mz, mz) of this node's own sample
        self.prop = None  # (Px, px0, Bpx) of the next sample (children only)
        self.children: list[_Node] | None = None  # None: not made yet
        self.leaf = False
        self.Rinv = self.K = self.t = self.kbox = None
        self.null = self.nbox = None  # left null vectors of R scaled into the dual ball (rows), box terms
        self.lp = None
        self.daqp = None
        self.rowlp = None  # a leaf's HiGHS LP with one more row: the separation of a later state
        self.pinv = None  # a leaf's pseudo-inverse of R (the later states' structural multipliers)
        self.sep: dict = {}
        self.fruitless = 0  # windows since this prefix's LP last closed it (a prefix only)
        self.ufruitless = 0  # windows since this leaf's LP last closed it in the uniqueness test
        self.index = -1
        self.r_sl = self.g_sl = self.z_sl = None
        self.warm = None  # (mu, lam, box, ray) of its last LP, dual-feasible


class SequenceLPSolver:
    """Exact solver of the 1- / inf-norm window problem of eq. (10) (paper 002) by mode-prefix branch and bound.

    Parameters
    ----------
    model : WindowModel
        The window's model, weights and cost (norm ``"1"`` or ``"inf"``).
    zero_cost : float
        The zero-cost threshold ``J_0`` (original cost units): the certified gap is
        ``max(MHE_CERTIFIED_RTOL * J, SEQUENCE_LP_GAP_FLOOR * J_0)``.
    separated : SeparatedProgram
        The observer's separated program: its ``delta``, ``epsilon``, box of ``xi0`` and
        :meth:`~hybobs_opt.mhe.uniqueness.SeparatedProgram.alternative` (the verification of an
        alternative) are reused, no program of it is solved.
    lp : {"daqp", "highs"}
        The LP engine: DAQP's LP mode (``daqp.Model`` per node) with HiGHS as fallback, or
        HiGHS (a persistent ``highspy`` model per node, presolve off) for every LP.
    tables : {"auto", "eager", "lazy"}
        ``"auto"``: the whole tree at construction when it has at most :data:`EAGER_MAX_NODES`
        nodes and fits the memory budget, lazily otherwise.
    memory_budget : int, optional
        Bytes the tree and its solver models may take; default
        :data:`~hybobs_opt.limits.MAX_SEQUENCE_TREE_BYTES`.
    max_lps : int, optional
        LPs one window's search may solve before it stops with its gap (``None``: no limit).
    time_budget : float, optional
        Seconds one window's search may take before it stops with its gap.

    Attributes
    ----------
    nodes : list
        The mode prefixes made so far (every one with eager tables); ``pruned_offline`` counts
        those an eager tree dropped because no input of ``U`` meets their rows (a certified LP of
        :func:`~hybobs_opt.geometry.lp.solve_lp` each).
    lazy : bool
        Whether the tree is made on demand.
    tree_bytes : int
        Bytes charged against the memory budget so far.
    models_freed : int
        Solver models freed at the budget (made again when needed).
    build_seconds : float
        Time of the construction.

    Raises
    ------
    ModelError
        With an extension (``extend``): its rows and parameters are not in the maps; with norm 2;
        with an unknown ``lp`` or ``tables``; a memory budget that cannot hold the roots and one
        path to a leaf (``solver_options['memory_budget']``, with the predicted bytes).
    """

    def __init__(self, model, zero_cost: float, separated, lp: str = "daqp", *, tables: str = "auto",
                 memory_budget: int | None = None, max_lps: int | None = None, time_budget: float | None = None):
        if model.extension is not None:
            raise ModelError("extend", "None with solver 'sequences' (its per-prefix matrices are precomputed "
                             "from the model alone; use solver 'highs' for an extended problem)", "an extension")
        if model.norm not in ("1", "inf"):
            raise ModelError("norm", "'1' or 'inf' for solver 'sequences'", repr(model.norm))
        import highspy

        if lp not in ("daqp", "highs"):
            raise ModelError("solver_options['lp']", "'daqp' or 'highs' (the LP solver of solver 'sequences')", repr(lp))
        if tables not in ("auto", "eager", "lazy"):
            raise ModelError("solver_options['tables']", "'auto', 'eager' or 'lazy' (how solver 'sequences' builds "
                             "its prefix tree)", repr(tables))
        if memory_budget is None:
            memory_budget = MAX_SEQUENCE_TREE_BYTES
        if isinstance(memory_budget, bool) or not isinstance(memory_budget, (int, np.integer)) or memory_budget < 1:
            raise ModelError("solver_options['memory_budget']", "a positive number of bytes (int)", repr(memory_budget))
        self.memory_budget = int(memory_budget)
        self.max_lps, self.time_budget = max_lps, time_budget
        self.lp_engine = lp
        self.lp_solves = self.lp_fallbacks = 0

        self._hs = highspy
        self.model, self.norm, self.zero_cost, self.sep = model, model.norm, float(zero_cost), separated
        sysm, T, n, m, p = model.system, model.T, model.n, model.m, model.p
        self.T, self.n, self.s = T, n, sysm.n_modes
        self.dist = model.Ww is not None and T > 1
        self.nt = n + (n * (T - 1) if self.dist else 0)
        self.np_ = T * m + T * p + n
        enc = model.enc
        self.lo = np.concatenate([enc.lb[enc.slices["xi0"]]] + ([enc.lb[enc.slices["omega"]]] if self.dist else []))
        self.hi = np.concatenate([enc.ub[enc.slices["xi0"]]] + ([enc.ub[enc.slices["omega"]]] if self.dist else []))
        t0 = time.perf_counter()
        self._tail()
        self.nodes: list[_Node] = []
        self.tree_bytes = 0
        self._models: dict = {}  # (node index, kind) -> (node, kind, bytes, window last used), oldest first
        self._window = 0
        self.models_freed = 0
        self.pruned_offline = 0
        self._prev_modes = None  # the last window's optimal sequence (the lazy tree's incumbent)
        self._last_alternative = None  # (leaf, direction) of the last alternative found
        total = sum(self.s ** k for k in range(1, T + 1))
        full = sum(self.s ** k * self._node_bytes(k) for k in range(1, T + 1))
        path = sum(self.s * self._node_bytes(k) for k in range(1, T + 1))
        if path > self.memory_budget:
            raise ModelError("solver_options['memory_budget']",
                             f"at least {path:,} bytes: one window's search holds the {self.s} roots and {self.s} "
                             f"children per sample of one path to a leaf (T = {T})", f"{self.memory_budget:,} bytes")
        if tables == "eager" and full > self.memory_budget:
            raise ModelError("solver_options['memory_budget']",
                             f"at least {full:,} bytes for the whole prefix tree ({total:,} nodes; or "
                             "solver_options['tables'] = 'lazy')", f"{self.memory_budget:,} bytes")
        self.lazy = tables == "lazy" or (tables == "auto" and (total > EAGER_MAX_NODES or full > self.memory_budget))
        self.roots = self._kids(None)
        if not self.lazy:
            self._build_all()
        self.build_seconds = time.perf_counter() - t0

    # ------------------------------------------------------------------ the tree
    def _tail(self) -> None:
        """The rows of ``R`` that do not depend on the mode sequence (disturbances, arrival cost),
        their affine map in ``p``, their cost blocks, and the propagation state of the window start."""
        mdl, T, n, nt, np_ = self.model, self.T, self.n, self.nt, self.np_
        hx = mdl.hx
        R, Mr, mr, blocks = [np.zeros((0, nt))], [np.zeros((0, np_))], [np.zeros(0)], []
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
            EX[:, T * mdl.m + T * mdl.p:T * mdl.m + T * mdl.p + n] = np.eye(n)
            Mr.append(-mdl.Wa @ EX)
            mr.append(mdl.Wa @ mdl.cx)
            blocks += [nb] * n
        self._Rt, self._Mrt, self._mrt = np.vstack(R), np.vstack(Mr), np.concatenate(mr)
        self._bt = np.asarray(blocks, dtype=int)
        Px = np.zeros((n, nt))
        Px[:, :n] = np.diag(hx)
        self._prop0 = (Px, mdl.cx.copy(), np.zeros((n, np_)))

    def _node_bytes(self, k: int, q: int | None = None) -> int:
        """Bytes charged for a node of depth ``k`` (its mode ``q``; ``None``: the largest mode), an
        upper bound of its arrays and their objects, before it is made."""
        sysm, n, nt, np_, p = self.model.system, self.n, self.nt, self.np_, self.model.p
        XA = self.model.X.A
        guard = max(md.guard.A.shape[0] for md in sysm.modes) if q is None else sysm.modes[q].guard.A.shape[0]
        gmax = max(md.guard.A.shape[0] for md in sysm.modes)
        own = p + guard + XA.shape[0]
        kr = k * p + self._Rt.shape[0]
        gr = (k - 1) * (gmax + XA.shape[0]) + guard + XA.shape[0]
        floats = (kr * nt + gr * nt + kr + own * (np_ + 1) + n * (nt + np_ + 1) + 3 * kr * kr + 2 * kr + gr
                  + (2 * nt * nt + gr * nt + 2 * gr if kr == nt else 0))
        return 8 * floats + NODE_BYTES["node"]

    def _charge(self, nbytes: int, what: str) -> None:
        """Count ``nbytes`` against the memory budget before they are allocated: when they would
        exceed it, the solver models not used in this window are freed (least recently used
        first; a freed model is made again when its node needs it), and only then is the work
        refused with the bytes it needs."""
        models = self._models
        while self.tree_bytes + nbytes > self.memory_budget and models:
            key, (nd, kind, size, window) = next(iter(models.items()))
            if window == self._window:
                break  # every model left is used by this window's search
            del models[key]
            setattr(nd, kind, None)
            self.tree_bytes -= size
            self.models_freed += 1
        if self.tree_bytes + nbytes > self.memory_budget:
            raise ModelError("solver_options['memory_budget']",
                             f"at least {self.tree_bytes + nbytes:,} bytes to make {what} (the prefix tree holds "
                             f"{len(self.nodes):,} nodes in {self.tree_bytes:,} bytes); raise it with "
                             "MHESettings(solver_options={'memory_budget': bytes}) or use solver='highs'",
                             f"{self.memory_budget:,} bytes")
        self.tree_bytes += nbytes

    def _used(self, nd, kind: str) -> None:
        """Mark the node's solver model as used in this window (the most recently used)."""
        key = (nd.index, kind)
        entry = self._models.pop(key, None)
        if entry is not None:
            self._models[key] = (entry[0], entry[1], entry[2], self._window)

    def _kids(self, parent) -> list[_Node]:
        """The children of ``parent`` (the roots for ``None``), made on first use."""
        if parent is not None and parent.children is not None:
            return parent.children
        k = 0 if parent is None else len(parent.modes)
        out = []
        for q in range(self.s):
            nd = self._make_node(parent, q, k)
            if nd is not None:
                out.append(nd)
        if parent is not None:
            parent.children = out
            if self.lazy:
                parent.prop = None  # the children hold what they need
        return out

    def _make_node(self, parent, q: int, k: int):
        """The prefix ``parent.modes + (q,)``: its sample's rows appended to the parent's, or
        ``None`` when a certified LP proves that no input of ``U`` meets its rows."""
        self._charge(self._node_bytes(k + 1, q), f"mode prefix {(parent.modes if parent else ()) + (q,)}")
        mdl, n, T = self.model, self.n, self.T
        m, p = mdl.m, mdl.p
        iU, iY = 0, T * m
        Px, px0, Bpx = self._prop0 if parent is None else parent.prop
        md = mdl.system.modes[q]
        Wy = mdl.Wy
        Rk = -Wy @ md.C @ Px
        Mrk = -Wy @ md.C @ Bpx
        Mrk[:, iY + k * p: iY + (k + 1) * p] += Wy
        Mrk[:, iU + k * m: iU + (k + 1) * m] -= Wy @ md.D
        mrk = Wy @ (-md.C @ px0 - md.c)
        Ga, gb = md.guard.A, md.guard.b
        XA, Xb = mdl.X.A, mdl.X.b
        Gk = np.vstack([Ga[:, :n] @ Px, XA @ Px])
        Mgk = np.vstack([-Ga[:, :n] @ Bpx, -XA @ Bpx])
        Mgk[: Ga.shape[0], iU + k * m: iU + (k + 1) * m] -= Ga[:, n:]
        mgk = np.concatenate([gb - Ga[:, :n] @ px0, Xb - XA @ px0])
        scale = np.max(np.abs(Gk), axis=1)
        zero = scale == 0
        keep = ~zero
        s = scale[keep]
        own = (Mrk, mrk, Mgk[keep] / s[:, None], mgk[keep] / s, Mgk[zero], mgk[zero])
        Gk = Gk[keep] / s[:, None]
        if parent is None:
            Rs, G = Rk, Gk
        else:
            Rs, G = np.vstack([parent.R[:parent.ks], Rk]), np.vstack([parent.G, Gk])
        R = np.vstack([Rs, self._Rt])
        blocks = np.r_[np.zeros(Rs.shape[0], dtype=int), self._bt]
        nd = _Node(parent.modes + (q,) if parent is not None else (q,), parent, R, G, blocks, Rs.shape[0], own)
        if not self.lazy and not self._possible(nd):
            # the lazy tree leaves such prefixes to the window's LPs (a certified LP per node made
            # costs more than the windows' LPs that prove the prefix infeasible, measured at T = 10)
            self.pruned_offline += 1
            return None
        if k < T - 1:
            Px2 = md.A @ Px
            if self.dist:
                Px2[:, n + k * n: n + (k + 1) * n] += np.diag(mdl.hx)
            Bpx2 = md.A @ Bpx
            Bpx2[:, iU + k * m: iU + (k + 1) * m] += md.B
            nd.prop = (Px2, md.A @ px0 + md.a, Bpx2)
        else:
            nd.leaf = True
        self._multipliers_of(nd)
        nd.index = len(self.nodes)
        self.nodes.append(nd)
        return nd

    def _maps(self, nd):
        """The affine maps ``(Mr, mr, Mg, mg, Mz, mz)`` of the whole prefix (its ancestors' rows
        and its own; ``r`` with the tail rows)."""
        chain = []
        a = nd
        while a is not None:
            chain.append(a.own)
            a = a.parent
        chain.reverse()
        cat = [np.vstack([c[i] for c in chain]) if i % 2 == 0 else np.concatenate([c[i] for c in chain])
               for i in range(6)]
        cat[0], cat[1] = np.vstack([cat[0], self._Mrt]), np.concatenate([cat[1], self._mrt])
        return cat

    def _possible(self, nd) -> bool:
        """Whether some input of ``U`` lets the prefix's rows hold (``False`` only when a certified
        LP of :func:`~hybobs_opt.geometry.lp.solve_lp` proves that none does)."""
        from ..geometry.lp import solve_lp

        _, _, Mg, mg, Mz, mz = self._maps(nd)
        G = nd.G
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

    def _multipliers_of(self, nd) -> None:
        """The node's structural multipliers (they depend on the node alone) and their box terms:

        * outputs the sequence cannot reproduce: ``mu`` in the left null space of ``R``
          (``R'mu = 0``) bounds the cost by ``|mu'r|`` with no LP (the backlash sequences of
          model (16): the engine speed then evolves on its own, and noisy data break that
          relation), each null vector with both signs;
        * a square full-rank sequence, every row ``i`` of ``G``: ``lam = t_i e_i``,
          ``mu = -t_i (G_i R^-1)'`` (``c ~ 0``; the bound is ``t_i`` times the row's violation at
          the exact fit ``-R^-1 r``).
        """
        R, G = nd.R, nd.G
        shrink = 1.0 - 8 * np.finfo(float).eps  # strictly inside the dual ball despite rounding
        u, sv, _ = np.linalg.svd(R)
        rank = int(np.sum(sv > sv.max(initial=0.0) * R.shape[0] * np.finfo(float).eps)) if sv.size else 0
        if rank < R.shape[0]:
            Nl = u[:, rank:].T
            nd.null = shrink * Nl / np.array([max(self._dual_norm(nd, row), 1e-300) for row in Nl])[:, None]
            C = nd.null @ R  # c = R'mu for each null vector (rows; ~0)
            plus, minus = np.minimum(C * self.lo, C * self.hi).sum(axis=1), np.minimum(-C * self.lo, -C * self.hi).sum(axis=1)
            # the box terms with their rounding allowance folded in (r enters through |null| |r|)
            nd.nbox = (plus - SEQUENCE_LP_BOUND_RTOL * np.abs(plus), minus - SEQUENCE_LP_BOUND_RTOL * np.abs(minus),
                       np.abs(nd.null))
        if nd.leaf and R.shape[0] == R.shape[1] and np.linalg.matrix_rank(R) == R.shape[1]:
            nd.Rinv = np.linalg.inv(R)
            nd.K = G @ nd.Rinv
            nd.t = shrink / np.maximum([self._dual_norm(nd, row) for row in nd.K], 1e-300)
            C = -nd.t[:, None] * (nd.K @ R) + nd.t[:, None] * G  # c of each row's candidate (rows)
            nd.kbox = np.minimum(C * self.lo, C * self.hi).sum(axis=1)

    def _build_all(self) -> None:
        """Eager tables: every node made, its maps stacked so that a step computes every node's
        offsets in two products and its cheap bounds in a few more."""
        stack = list(reversed(self.roots))
        while stack:
            nd = stack.pop()
            if not nd.leaf:
                stack.extend(reversed(self._kids(nd)))
        Mr, mr, Mg, mg, Mz, mz = [], [], [], [], [], []
        rows = [0, 0, 0]
        for nd in self.nodes:  # creation order is depth-first order
            maps = self._maps(nd)
            nd.r_sl = slice(rows[0], rows[0] + maps[0].shape[0])
            nd.g_sl = slice(rows[1], rows[1] + maps[2].shape[0])
            nd.z_sl = slice(rows[2], rows[2] + maps[4].shape[0])
            rows = [nd.r_sl.stop, nd.g_sl.stop, nd.z_sl.stop]
            for lst, val in zip((Mr, mr, Mg, mg, Mz, mz), maps):
                lst.append(val)
        self._rows = rows
        self.Mr, self.mr = np.vstack(Mr), np.concatenate(mr)
        self.Mg, self.mg = np.vstack(Mg), np.concatenate(mg)
        self.Mz, self.mz = np.vstack(Mz), np.concatenate(mz)
        self.leaves = [nd for nd in self.nodes if nd.leaf]
        self._structural_candidates()
        # the last LP's multipliers of every node, stacked like r_all / g_all (dual-feasible as
        # stored), their box terms, and which nodes hold an infeasibility ray (mu = 0)
        self._Wmu, self._Wlam = np.zeros(rows[0]), np.zeros(rows[1])
        self._Wbox = np.full(len(self.nodes), -np.inf)
        self._Wray = np.zeros(len(self.nodes), dtype=bool)
        self._rstart = np.array([nd.r_sl.start for nd in self.nodes])
        self._gstart = np.array([nd.g_sl.start for nd in self.nodes])

    def _structural_candidates(self) -> None:
        """Eager tables: the structural multipliers of :meth:`_multipliers_of` of every node,
        stacked so that one matrix product per step gives every node's best bound of them
        (``c = R'mu + G'lam`` and its box term are fixed)."""
        rows_r, tvec, gidx, box, owner = [], [], [], [], []
        nr = self._rows[0]
        for nd in self.nodes:
            cands = []
            if nd.Rinv is not None:
                for i in range(nd.G.shape[0]):
                    lam = np.zeros(nd.G.shape[0])
                    lam[i] = nd.t[i]
                    cands.append((-nd.t[i] * nd.K[i], lam))
            if nd.null is not None:
                for row in nd.null:
                    cands += [(row, np.zeros(nd.G.shape[0])), (-row, np.zeros(nd.G.shape[0]))]
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
        self._sq = []
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
        box = float(np.minimum(c * self.lo, c * self.hi).sum())
        nd.warm = (mu, lam, box, ray)
        if not self.lazy:
            self._Wmu[nd.r_sl], self._Wlam[nd.g_sl] = mu, lam
            self._Wbox[nd.index] = box
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

    def _lp_model(self, nd, row: bool = False):
        """The node's persistent HiGHS LP in ``[theta; e]``: ``R theta - E e <= -r``,
        ``R theta + E e >= -r``, ``G theta <= g``, ``lo <= theta <= hi``, ``e >= 0``; with ``row``,
        one more row ``a' theta >= beta`` (``nd.rowlp``; its coefficients set per direction)."""
        hs = self._hs
        kind = "rowlp" if row else "lp"
        entries = (2 * nd.R.shape[0] + nd.G.shape[0] + row) * (nd.R.shape[0] + nd.R.shape[1])
        size = NODE_BYTES["highs"] + NODE_BYTES["per_entry"] * entries
        self._charge(size, f"the HiGHS LP of mode prefix {nd.modes}")
        self._models[(nd.index, kind)] = (nd, kind, size, self._window)
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
        if row:
            A = np.vstack([A, np.zeros((1, A.shape[1]))])
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
        model = (h, np.arange(nr, dtype=np.int32), k, np.arange(nt, dtype=np.int32))
        setattr(nd, kind, model)
        return model

    def _daqp_model(self, nd):
        """The node's persistent DAQP LP (``daqp.Model``, proximal point ``eps_prox``) in ``[theta; e]``:
        simple bounds ``lo <= theta <= hi``, ``e >= 0``; rows as in :meth:`_lp_model`."""
        import daqp

        R, G = nd.R, nd.G
        entries = (2 * R.shape[0] + G.shape[0]) * (R.shape[0] + R.shape[1])
        size = NODE_BYTES["daqp"] + NODE_BYTES["per_entry"] * entries
        self._charge(size, f"the DAQP LP of mode prefix {nd.modes}")
        self._models[(nd.index, "daqp")] = (nd, "daqp", size, self._window)
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
        self._used(nd, "daqp")
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
        self._used(nd, "lp")
        inf = hs.kHighsInf
        ng = g.size
        h.changeRowsBounds(rows.size, rows, np.r_[np.full(k, -inf), -r, np.full(ng, -inf)],
                           np.r_[-r, np.full(k, inf), g])
        h.changeColsBounds(cols.size, cols, lo, hi)
        st = _run_highs(h, hs)
        if st == hs.HighsModelStatus.kInfeasible:
            _, ok, ray = h.getDualRay()
            ray = np.asarray(ray, dtype=float) if ok and len(ray) == rows.size else None
            for cand in ([] if ray is None else [-ray[2 * k:], ray[2 * k:]]):
                if self._dual_bound(nd, None, cand, r, g, lo, hi) > 0:
                    return np.inf, None, None, None, cand
            return None
        if st != hs.HighsModelStatus.kOptimal:
            return None
        got = _checked_highs_point(h, nd.G, g, lo, hi, cols.size)
        if got is None:
            return None
        x, y = np.clip(got[0], lo, hi), got[1]
        mu, lam = -(y[:k] + y[k:2 * k]), -y[2 * k:]
        bound = self._dual_bound(nd, mu, lam, r, g, lo, hi)
        return bound, x, self._cost(nd, x, r), mu, lam


    # ------------------------------------------------------------------ one window
    def _data(self, nd, ctx):
        """``(r, g, rows_ok)`` of the node in this window: its offsets and whether its rows without
        ``theta`` hold (lazy tables: its parent's plus its own sample's rows, kept for the step)."""
        if not self.lazy:
            z = ctx["z"][nd.z_sl]
            return ctx["r"][nd.r_sl], ctx["g"][nd.g_sl], bool(z.all()) if z.size else True
        got = ctx["data"].get(nd.index)
        if got is not None:
            return got
        pv = ctx["pv"]
        Mr, mr, Mg, mg, Mz, mz = nd.own
        rk, gk = Mr @ pv + mr, Mg @ pv + mg
        ok = bool(np.all(Mz @ pv + mz >= 0.0)) if mz.size else True
        if nd.parent is None:
            rs, g = rk, gk
        else:
            rp, gp, okp = self._data(nd.parent, ctx)
            rs, g, ok = np.concatenate([rp[:nd.parent.ks], rk]), np.concatenate([gp, gk]), ok and okp
        got = (np.concatenate([rs, ctx["r_tail"]]), g, ok)
        ctx["data"][nd.index] = got
        return got

    def _cheap(self, nd, ctx) -> float:
        """The node's best proven bound without an LP in this window: its structural multipliers
        and its last LP's (``-inf`` without any; ``inf`` for a verified infeasibility ray).  Lazy
        tables also record the exact fit of a square full-rank sequence that meets its rows."""
        if not self.lazy:
            return float(ctx["cheap"][nd.index])
        got = ctx["cheap"].get(nd.index)
        if got is not None:
            return got
        r, g, _ = self._data(nd, ctx)
        best = -np.inf
        ar = np.abs(r)
        if nd.null is not None:
            nb_plus, nb_minus, anull = nd.nbox
            v = nd.null @ r
            size = SEQUENCE_LP_BOUND_RTOL * (anull @ ar)
            best = max(best, float((v + nb_plus - size).max()), float((nb_minus - v - size).max()))
        if nd.K is not None:
            Kr = nd.K @ r
            val = -nd.t * (Kr + g) + nd.kbox
            size = nd.t * (np.abs(nd.K) @ ar + np.abs(g)) + np.abs(nd.kbox)
            best = max(best, float(np.max(val - SEQUENCE_LP_BOUND_RTOL * size)))
            th = -nd.Rinv @ r
            if (np.max(nd.G @ th - g, initial=-np.inf) <= MHE_MILP_FEASIBILITY_TOL
                    and np.all(th >= self.lo - MHE_MILP_FEASIBILITY_TOL) and np.all(th <= self.hi + MHE_MILP_FEASIBILITY_TOL)
                    and self._data(nd, ctx)[2]):
                th = np.minimum(np.maximum(th, self.lo), self.hi)
                ctx["fits"][nd.index] = (th, self._cost(nd, th, r))
        if nd.warm is not None:
            mu, lam, box, ray = nd.warm
            val = float(mu @ r - lam @ g + box)
            size = float(np.abs(mu) @ ar + lam @ np.abs(g) + abs(box))
            w = val - SEQUENCE_LP_BOUND_RTOL * size
            best = max(best, np.inf if ray and w > 0 else w)
        ctx["cheap"][nd.index] = best
        return best

    def _allowed(self, cost: float) -> float:
        """The gap a certified optimum of cost ``cost`` may have: ``max(MHE_CERTIFIED_RTOL * cost,
        SEQUENCE_LP_GAP_FLOOR * J_0)`` (0 at ``inf``)."""
        if cost == np.inf:
            return 0.0
        return max(MHE_CERTIFIED_RTOL * cost, SEQUENCE_LP_GAP_FLOOR * self.zero_cost)

    # the name the uniqueness test and the DAQP fallback rule use
    _gap = _allowed

    def _path(self, modes):
        """The leaf of ``modes`` (nodes made on the way), or ``None`` when a prefix of it was dropped."""
        kids = self.roots
        nd = None
        for q in modes:
            nd = next((c for c in kids if c.modes[-1] == q), None)
            if nd is None:
                return None
            if not nd.leaf:
                kids = self._kids(nd)
        return nd

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
            ``gap_bound``, the proven gap (its cost minus the least bound of the closed nodes,
            within ``max(MHE_CERTIFIED_RTOL * cost, SEQUENCE_LP_GAP_FLOOR * J_0)``); ``INFEASIBLE`` (every sequence
            proven infeasible); or ``NOT_CERTIFIED`` (the search stopped by its budget, an LP
            without a checked answer, or a gap above the tolerance; ``reason``, and ``cost`` and
            ``gap_bound`` of the incumbent when there is one).  ``solver_detail`` has
            ``lower_bound`` and ``relative_gap``.
        dict
            The step's offsets, bounds and LP answers, which :meth:`decide` reuses.

        Raises
        ------
        ModelError
            The lazy tree would exceed its memory budget (``solver_options['memory_budget']``),
            with the predicted bytes.
        """
        t_start = time.perf_counter()
        self.lp_solves = self.lp_fallbacks = 0
        self._window += 1
        nodes0 = len(self.nodes)
        pv = np.concatenate([U.reshape(-1), Y.reshape(-1), xbar])
        lo, hi = self.lo, self.hi
        ctx = {"fits": {}, "solved": {}, "pv": pv}
        best = (np.inf, None, None)  # cost, node, theta
        if self.lazy:
            ctx.update(data={}, cheap={}, r_tail=self._Mrt @ pv + self._mrt)
        else:
            r_all = self.Mr @ pv + self.mr
            g_all = self.Mg @ pv + self.mg
            z_ok = (self.Mz @ pv + self.mz) >= 0.0 if self.mz.size else np.zeros(0, dtype=bool)
            ctx.update(r=r_all, g=g_all, z=z_ok, cheap=self._cheap_bounds(r_all, g_all))
            # (i) zero-cost fast path: the square full-rank sequences whose exact fit meets their rows
            # (to the LP solver's own tolerance: a fit that needs MHE_FEASIBILITY_TOL of slack in a
            # guard is not claimed, its LP decides the sequence)
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
        # every cost is >= 0 (a norm): an incumbent within the tolerance of 0 is certified as it is
        if best[0] <= self._allowed(best[0]):
            ctx["zero_fit"] = True
        lowest = np.inf  # least bound (>= 0) of the closed nodes
        failed, stopped = [], None
        if not ctx.get("zero_fit"):
            # an incumbent first (then most nodes close on their cheap bounds against it): eager
            # tables, the leaves' LPs in the order of their cheap bounds until one has a point; lazy,
            # the last window's sequence shifted by one sample (each last mode), else the constant ones
            if self.lazy:
                prev = self._prev_modes
                tries = ([prev[1:] + (q,) for q in range(self.s)] if prev is not None
                         else [(q,) * self.T for q in range(self.s)])
                tries = [nd for nd in map(self._path, tries) if nd is not None]
            else:
                cheap = sorted((ctx["cheap"][nd.index], nd.index) for nd in self.leaves
                               if ctx["cheap"][nd.index] < np.inf)
                tries = [self.nodes[i] for _, i in cheap[:INCUMBENT_TRIES]]
            for nd in tries:
                if not self._data(nd, ctx)[2]:
                    continue
                b = self._node_bound(nd, ctx, lo, hi, cutoff=np.inf)
                if b is not None and b[1] is not None:
                    if b[2] < best[0]:
                        best = (b[2], nd, b[1])
                    if not self.lazy:
                        break
            # (ii)-(iii) depth-first branch and bound, warm bounds first, the node's LP where they fail
            stack = [(nd, 0.0) for nd in reversed(self.roots)]  # (node, its parent's bound)
            deadline = None if self.time_budget is None else t_start + self.time_budget
            while stack:
                if stopped is None and ((self.max_lps is not None and self.lp_solves >= self.max_lps)
                                        or (deadline is not None and time.perf_counter() > deadline)):
                    stopped = (f"{self.lp_solves} LPs (certify_max_nodes = {self.max_lps})"
                               if self.max_lps is not None and self.lp_solves >= self.max_lps
                               else f"{time.perf_counter() - t_start:.3g} s (certify_time_budget = {self.time_budget:g} s)")
                if stopped is not None:
                    lowest = min(lowest, max(stack.pop()[1], 0.0))  # an open node: its parent's bound
                    continue
                if best[0] <= self._allowed(best[0]):
                    lowest = 0.0  # every cost is >= 0: the open nodes close on that bound
                    break
                nd, up = stack.pop()
                b = self._node_bound(nd, ctx, lo, hi, cutoff=best[0] - self._allowed(best[0]))
                if b is None:
                    failed.append(nd.modes)
                    lowest = min(lowest, max(up, 0.0))
                    continue
                bound, th, cost = b
                bound = max(bound, up)  # a child's cost is at least its parent's
                if th is not None and nd.leaf and cost < best[0]:
                    best = (cost, nd, th)
                if bound >= best[0] - self._allowed(best[0]) or nd.leaf:
                    lowest = min(lowest, max(bound, 0.0))
                    continue
                stack.extend((c, bound) for c in reversed(self._kids(nd)))
        else:
            lowest = 0.0
        cost, nd, th = best
        lower = min(lowest, cost)
        gap = max(cost - lower, 0.0) if nd is not None else np.inf
        rel = 0.0 if gap == 0 else (gap / cost if cost > 0 else np.inf)
        detail = {"sequence_lps": self.lp_solves, "lp_fallbacks": self.lp_fallbacks, "nodes": len(self.nodes),
                  "nodes_made": len(self.nodes) - nodes0, "tree_bytes": self.tree_bytes,
                  "models_freed": self.models_freed,
                  "lower_bound": float(lower), "relative_gap": float(rel)}
        if nd is None:
            if not failed and stopped is None:
                return WindowResult(Status.INFEASIBLE, solver="sequences", solved_by="prefix search",
                                    solver_detail=detail,
                                    reason="no mode sequence is feasible (every prefix proven infeasible)"), ctx
            why = (f"stopped after {stopped}" if stopped is not None
                   else f"no checked LP answer for mode prefix(es) {failed[:3]}")
            return WindowResult(Status.NOT_CERTIFIED, solver="sequences", solver_detail=detail,
                                reason=f"{why}, no feasible mode sequence found yet"), ctx
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
        gap = max(exact - lower, 0.0)
        detail["relative_gap"] = float(0.0 if gap == 0 else (gap / exact if exact > 0 else np.inf))
        self._prev_modes = nd.modes
        if failed or stopped is not None or gap > self._allowed(exact):
            why = (f"the search stopped after {stopped}" if stopped is not None
                   else f"no checked LP answer for mode prefix(es) {failed[:3]}" if failed
                   else "the closed nodes' bounds do not reach the tolerance")
            return WindowResult(Status.NOT_CERTIFIED, solver="sequences", solver_detail=detail, cost=exact,
                                gap_bound=gap,
                                reason=f"{why}: best cost {exact:.6g}, proven lower bound {lower:.6g}, relative gap "
                                       f"{detail['relative_gap']:.3g} (certified needs "
                                       f"max({MHE_CERTIFIED_RTOL:g} cost, {SEQUENCE_LP_GAP_FLOOR * self.zero_cost:.3g}))"), ctx
        ctx.update(J=exact, modes=nd.modes, theta=th)
        return WindowResult(Status.OPTIMAL, solver="sequences",
                            solved_by="zero-cost fit" if ctx.get("zero_fit") else "prefix search", polished=False,
                            x_start=x0, states=states, modes=modes, w=W, cost=exact,
                            gap_bound=gap, verified_violation=float(viol), passes=0,
                            solver_detail=detail), ctx

    def _node_bound(self, nd, ctx, lo, hi, cutoff: float, key=None, lp: bool = True, tight: bool = True):
        """``(bound, theta, cost)`` of a node (``theta``/``cost`` only when its LP was solved), or ``None``.

        The stored multipliers of the node (or of ``key``: a separated LP) are tried first; the LP
        is solved only when their bound does not reach ``cutoff``."""
        r, g, rows_ok = self._data(nd, ctx)
        if not rows_ok:
            return np.inf, None, None  # a row without theta-coefficients fails: 0 <= g < 0
        if lp and not nd.leaf and key is None and nd.fruitless and nd.fruitless % PREFIX_LP_RETRY:
            # this prefix's LP did not close it in an earlier window: branch without bounding it
            nd.fruitless += 1
            return -np.inf, None, None
        stored = [] if key is None else [nd.sep.get(key, (None, None))]
        if key is None:
            done = ctx["solved"].get(nd.index)
            if done is not None:  # this node's LP was solved earlier in the step
                return done
            cheap = self._cheap(nd, ctx)
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
        best = self._cheap(nd, ctx) if key is None else -np.inf
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
        r = self._data(nd, ctx)[0]
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
        sep, n, T = self.sep, self.n, self.T
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
        # the later window states (the reported one among them): direction d = 2 (k n + j) (+ 1)
        later = np.flatnonzero(sep.allowed(xs, range(1, T))) if T > 1 else np.zeros(0, dtype=int)
        if not dirs and not later.size:
            return {**base, "status": UniquenessOutcome.UNIQUE, "decided_by": "box (no state of X is delta away)",
                    "separated_cost_bound": np.inf}
        lps0 = self.lp_solves
        counts = {"row_lps": 0, "rows_closed_by_bound": 0}
        undecided = np.zeros(2 * n * T, dtype=bool)  # later directions left to the MILP
        lowest = np.inf
        stack = list(reversed(self.roots))
        if self._last_alternative is not None:
            # the sequence of the last window's alternative first: an alternative ends the search
            stack.append(self._last_alternative[0])
            dirs.sort(key=lambda d: d != self._last_alternative[1])
        visited = set()
        while stack:
            nd = stack.pop()
            if nd.index in visited:
                continue
            visited.add(nd.index)
            cheap = self._cheap(nd, ctx)
            if cheap > thr_hi:  # closed by a bound without an LP
                lowest = min(lowest, cheap)
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
                stack.extend(reversed(self._kids(nd)))
                continue
            closed = self._separated_structural(nd, ctx, xi_s, delta, dirs, thr_hi) if dirs else None
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
                    out = self._solve_highs(nd, *self._data(nd, ctx)[:2], lo, hi)
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
                    self._last_alternative = (nd, (j, s))
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
            if later.size:
                alt, low = self._separate_later(nd, ctx, U, Y, xbar, xs, later, thr_lo, thr_hi, undecided, counts)
                lowest = min(lowest, low)
                if alt is not None:
                    self._last_alternative = (nd, None)
                    return {**base, "status": UniquenessOutcome.ALTERNATIVE, "decided_by": "sequence LPs",
                            "separated_cost": alt["cost"], "alternative": alt,
                            "sequence_lps": self.lp_solves - lps0, **counts}
        self._last_alternative = None
        start = {**base, "status": UniquenessOutcome.UNIQUE,
                 "decided_by": "sequence LPs (every prefix and direction closed)",
                 "separated_cost_bound": lowest, "sequence_lps": self.lp_solves - lps0, **counts}
        if not undecided.any():
            return start
        return self._later_states(U, Y, xbar, opt, start, undecided)

    def _later_states(self, U, Y, xbar, opt, start: dict, undecided: np.ndarray) -> dict:
        """Every sequence LP closed but the later-state directions ``undecided`` (a separated LP
        within the decision band, or without a checked answer): those directions alone are
        separated by the MILP of :class:`~hybobs_opt.mhe.uniqueness.SeparatedProgram` over every
        mode sequence."""
        later = self.sep.decide(U, Y, xbar, opt, steps=range(1, self.T), directions=undecided)
        later.pop("seconds", None)
        extra = {k: start[k] for k in ("sequence_lps", "row_lps", "rows_closed_by_bound")}
        extra["milp_directions"] = int(undecided.sum())
        if later["status"] == UniquenessOutcome.UNIQUE:
            return {**start, **extra, "decided_by": f"{start['decided_by']}; later states: {later['decided_by']}",
                    "separated_cost_bound": min(start["separated_cost_bound"], later["separated_cost_bound"])}
        out = {**later, **extra}
        if later["status"] != UniquenessOutcome.ALTERNATIVE:
            out["reason"] = f"{later.get('reason', '?')} (later window states; the window start is unique)"
        return out

    # ------------------------------------------------------------------ later window states
    def _separate_later(self, nd, ctx, U, Y, xbar, xs, later, thr_lo, thr_hi, undecided, counts):
        """The later-state directions ``later`` at the leaf ``nd`` (its own bound at most the
        threshold): ``(alternative or None, least bound of the closed directions)``.

        The state ``x_k`` of a full sequence is affine in ``theta``, so the direction ``d``
        (step ``k``, coordinate ``j``, side ``s``) is the row ``a_d' theta >= beta_d`` on the
        leaf's LP.  Its bound, by weak duality with any ``(mu, lam)`` and the best multiplier
        ``nu >= 0`` of the row (:meth:`_row_bounds`), comes first from multipliers at hand: the
        structural ``mu = R^+' a_d`` scaled into the dual ball (``R' mu = a_d``: the cost of moving
        the least-squares fit across the row), the leaf's last LP's, and the last separated LP's
        of this leaf and direction (an earlier window).  A direction they leave open gets its
        separated LP (HiGHS, checked); a verified point at most ``thr_lo`` is an alternative, a
        direction neither closed nor so answered is marked in ``undecided`` (left to the MILP)."""
        r, g, _ = self._data(nd, ctx)
        A, beta = self._later_rows(nd, U, xs, later)
        D, kr, ng = later.size, r.size, g.size
        if nd.pinv is None:
            # the pseudo-inverse and, at most, one stored (mu, lam) per later direction
            self._charge(8 * (nd.R.size + 2 * self.n * (self.T - 1) * (kr + ng + 1)) + NODE_BYTES["node"],
                         f"the later-state separation of mode sequence {nd.modes}")
            nd.pinv = np.linalg.pinv(nd.R)
        MU = A @ nd.pinv
        MU = MU * ((1.0 - 8 * np.finfo(float).eps) / np.maximum(self._dual_norms(nd, MU), 1e-300))[:, None]
        best = self._row_bounds(nd, MU, np.zeros((D, ng)), r, g, A, beta)
        if nd.warm is not None and not nd.warm[3]:
            mu, lam = nd.warm[0], nd.warm[1]
            best = np.maximum(best, self._row_bounds(nd, np.tile(mu, (D, 1)), np.tile(lam, (D, 1)), r, g, A, beta))
        have = [i for i, d in enumerate(later) if ("row", int(d)) in nd.sep]
        if have:
            got = [nd.sep[("row", int(later[i]))] for i in have]
            MUs = np.array([np.zeros(kr) if mu is None else mu for mu, _ in got])
            LAMs = np.array([lam for _, lam in got])
            b = self._row_bounds(nd, MUs, LAMs, r, g, A[have], beta[have])
            ray = np.array([mu is None for mu, _ in got])
            b = np.where(ray & (b > 0), np.inf, np.where(ray, -np.inf, b))
            best[have] = np.maximum(best[have], b)
        closed = best > thr_hi
        counts["rows_closed_by_bound"] += int(closed.sum())
        lowest = float(best[closed].min()) if closed.any() else np.inf
        mdl, T, n = self.model, self.T, self.n
        for i in np.flatnonzero(~closed):
            d = int(later[i])
            if undecided[d]:
                continue  # the MILP decides this direction over every sequence anyway
            counts["row_lps"] += 1
            out = self._solve_row_lp(nd, r, g, A[i], beta[i])
            if out is None:
                undecided[d] = True
                continue
            bound, th, cost, mu, lam = out
            nd.sep[("row", d)] = (mu, lam)
            if bound > thr_hi:
                lowest = min(lowest, bound)
                continue
            if th is None or cost > thr_hi:
                undecided[d] = True
                continue
            x0 = mdl.cx + mdl.hx * th[:n]
            W = (th[n:].reshape(T - 1, n) * mdl.hx) if self.dist else np.zeros((max(T - 1, 0), n))
            alt = self.sep.alternative(x0, nd.modes, U, Y, xbar, W, xs)
            if alt is not None and alt["cost"] <= thr_lo:
                return alt, lowest
            undecided[d] = True
        return None, lowest

    def _later_rows(self, nd, U, xs, later):
        """The rows ``a_d' theta >= beta_d`` of the later-state directions ``later`` on the full
        sequence ``nd.modes`` (``sign ((x_k,j - c_j) / h_j - xs_k,j) >= delta``)."""
        from .unique_search import _state_maps

        mdl, n = self.model, self.n
        Ps, ps = _state_maps(mdl, nd.modes, U, self.nt, self.dist)
        k, j = (later // 2) // n, (later // 2) % n
        sg = np.where(later % 2 == 0, 1.0, -1.0)
        hx, cx = mdl.hx, mdl.cx
        A = sg[:, None] * Ps[k, j, :] / hx[j][:, None]
        beta = self.sep.delta + sg * (xs[k, j] - (ps[k, j] - cx[j]) / hx[j])
        return A, beta

    def _dual_norms(self, nd, MU) -> np.ndarray:
        """:meth:`_dual_norm` of each row of ``MU``."""
        aM = np.abs(MU)
        if self.norm == "1":
            return aM.max(axis=1, initial=0.0)
        B = np.zeros((nd.blocks.size, int(nd.blocks.max()) + 1))
        B[np.arange(nd.blocks.size), nd.blocks] = 1.0
        return (aM @ B).max(axis=1, initial=0.0)

    def _row_bounds(self, nd, MU, LAM, r, g, A, beta) -> np.ndarray:
        """Proven lower bounds of the node's LP with one more row ``A[d] theta >= beta[d]``, one
        per row ``d``, from the multipliers ``MU[d], LAM[d]`` (made dual-feasible) and the best
        ``nu >= 0`` of the row: every feasible ``theta`` has

            ||R theta + r|| >= mu'r - lam'g + nu beta + sum_j min(c_j lo_j, c_j hi_j),
            c = R'mu + G'lam - nu a,

        concave and piecewise linear in ``nu``, maximal at ``0`` or a breakpoint ``c0_j / a_j``;
        when the row is out of the box's reach (``beta > max a' theta`` over the box) it grows
        without bound: ``inf``.  Minus the rounding allowance of :meth:`_dual_bound`."""
        LAM = np.maximum(LAM, 0.0)
        if self.norm == "1":
            MU = np.clip(MU, -1.0, 1.0)
        else:
            MU = MU / np.maximum(self._dual_norms(nd, MU), 1.0)[:, None]
        lo, hi = self.lo, self.hi
        C0 = MU @ nd.R + LAM @ nd.G
        base = MU @ r - LAM @ g
        size0 = np.abs(MU) @ np.abs(r) + LAM @ np.abs(g)
        with np.errstate(divide="ignore", invalid="ignore", over="ignore"):
            brk = C0 / A
        brk = np.where(np.isfinite(brk) & (brk > 0), brk, 0.0)
        NU = np.concatenate([np.zeros((A.shape[0], 1)), brk], axis=1)
        C = C0[:, None, :] - NU[:, :, None] * A[:, None, :]
        box = np.minimum(C * lo, C * hi)
        val = base[:, None] + NU * beta[:, None] + box.sum(axis=2)
        size = size0[:, None] + NU * np.abs(beta)[:, None] + np.abs(box).sum(axis=2)
        out = (val - SEQUENCE_LP_BOUND_RTOL * size).max(axis=1)
        reach = np.maximum(A * lo, A * hi)
        far = beta - reach.sum(axis=1) > SEQUENCE_LP_BOUND_RTOL * (np.abs(beta) + np.abs(reach).sum(axis=1))
        out[far] = np.inf
        return out

    def _solve_row_lp(self, nd, r, g, a, beta):
        """The leaf's LP with the row ``a' theta >= beta`` on HiGHS (``nd.rowlp``), checked:
        ``(bound, theta or None, cost or None, mu, lam)`` as :meth:`_solve_lp` (``mu = None``:
        ``lam`` is a verified infeasibility ray), or ``None``."""
        hs = self._hs
        h, rows, k, cols = nd.rowlp if nd.rowlp is not None else self._lp_model(nd, row=True)
        self._used(nd, "rowlp")
        self.lp_solves += 1
        inf = hs.kHighsInf
        ng = g.size
        srow = 2 * k + ng
        for c in range(cols.size):
            h.changeCoeff(srow, c, float(a[c]))
        h.changeRowsBounds(rows.size, rows, np.r_[np.full(k, -inf), -r, np.full(ng, -inf), beta],
                           np.r_[-r, np.full(k, inf), g, inf])
        h.changeColsBounds(cols.size, cols, self.lo, self.hi)
        st = _run_highs(h, hs)
        one = lambda mu, lam: self._row_bounds(nd, mu[None, :], lam[None, :], r, g, a[None, :],  # noqa: E731
                                                np.array([beta]))[0]
        if st == hs.HighsModelStatus.kInfeasible:
            _, ok, ray = h.getDualRay()
            ray = np.asarray(ray, dtype=float) if ok and len(ray) == rows.size else None
            for cand in ([] if ray is None else [-ray[2 * k:srow], ray[2 * k:srow]]):
                if one(np.zeros(k), cand) > 0:  # homogeneous in (lam, nu): a positive value proves it
                    return np.inf, None, None, None, cand
            return None
        if st != hs.HighsModelStatus.kOptimal:
            return None
        lo, hi = self.lo, self.hi
        got = _checked_highs_point(h, nd.G, g, lo, hi, cols.size)
        if got is None or a @ got[0] < beta - MHE_FEASIBILITY_TOL:
            return None
        x, y = np.clip(got[0], lo, hi), got[1]
        mu, lam = -(y[:k] + y[k:2 * k]), -y[2 * k:srow]
        return one(mu, lam), x, self._cost(nd, x, r), mu, lam

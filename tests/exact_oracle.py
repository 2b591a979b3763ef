"""Exact mixed-integer oracle for the observability of PWA systems (paper 002, Definition 2.2).

Independent of the toolbox's algorithms: only numpy / scipy are imported, and only the raw data
of a ``PWASystem`` are read (``modes[i].A .B .a .C .D .c .guard.A .guard.b``, ``state_bounds``,
``input_bounds`` and ``scales()``; the latter is cross-checked against a bounding box computed
here by LPs).

Definition 2.2: ``x`` is observable in ``T`` steps when, for every ``x^`` in ``X`` and every
``U`` in ``U^T`` with both trajectories in the domain (each ``(x(k), u(k))`` in some guard and in
``X x U``, ``k = 0 .. T-1``), ``Y(x, U) = Y(x^, U)`` implies ``x^ = x``.

Coordinates
-----------
Everything is written in coordinates scaled by ``system.scales()`` (the bounding box of
``X x U`` mapped to ``[-1, 1]^(n+m)``); guard and domain rows are normalised to unit length
there, so a margin is a Euclidean distance in scaled coordinates and ``delta`` an inf-norm
distance in scaled state coordinates.  Outputs are divided by their range over ``X x U``.

MILP
----
Each trajectory is the disjunctive ("convex hull") form of the mixed-logical-dynamical model: at
step ``k`` and mode ``i`` a binary ``d[k,i]`` (``sum_i d[k,i] = 1``) and a copy
``w[k,i] = d[k,i] (x(k), u(k))``, bounded by ``d[k,i]`` times the bounding box of the mode's set
``Q_i cap (X x U)`` (the big-M constants, computed once per system by LPs), with the guard rows
``G_i w[k,i] <= g_i d[k,i]``.  Then ``x(k) = sum_i w_x[k,i]``, ``u(k) = sum_i w_u[k,i]``,
``x(k+1) = sum_i A_i w_x[k,i] + B_i w_u[k,i] + a_i d[k,i]`` and
``y(k) = sum_i C_i w_x[k,i] + D_i w_u[k,i] + c_i d[k,i]`` are linear (no product of a binary and
a continuous variable is left, and the relaxation is the tightest possible per step).  The
inf-norm condition ``||x^ - x||_inf >= c`` uses ``2n`` direction binaries.  Every query is a
feasibility MILP (zero objective).

The two-trajectory problem is split by ``x``'s own mode sequence ``sigma``: with ``x`` fixed
there are few of them (usually one), enumerated by a one-trajectory MILP with no-good cuts, each
checked by an LP.  For each ``sigma`` the MILP has the inputs ``U``, ``x``'s rows and outputs
(affine in ``U``) and ``x^``'s disjunctive trajectory: half the binaries, and 10-100 times faster
than the joint MILP on model (16) at ``T = 7``.

Exact step
----------
The output equalities are badly conditioned: in model (17) at ``T = 5`` a displacement of 1e-4
along the least observable direction changes the outputs by ~1e-11 of their range, below any
MILP tolerance.  A MILP solution is therefore only a *candidate* sequence ``sigma^`` for ``x^``.
For fixed sequences the problem is an LP; it is solved with the equalities eliminated exactly
(null space of the output map by SVD, relative rank tolerance ``RANK_RTOL``), maximising the
distance in each signed direction.  If no direction reaches ``c`` the candidate is excluded by a
no-good cut and the MILP is solved again.  A negative MILP answer (infeasible) is a sound
certificate, the MILP being a relaxation of the exact problem, but HiGHS was seen to declare
infeasible some problems with full-dimensional solution sets (in its presolve; about one state in
200 of random PWA systems): every negative answer is confirmed by a second solve with another
setting (looser tolerance, another seed, columns permuted), and a candidate from either goes
through the exact step.

Shortcuts (same answers, fewer solver calls)
--------------------------------------------
- Before the first pair MILP of a sequence ``sigma``, the exact step is run on the candidate
  ``sigma^ = sigma`` (the MILP's usual first answer on observable states: ``x^`` along the least
  observable direction, at the MILP's row tolerance).  If it is rejected, its no-good cut is in the
  MILP from the start, exactly as after the MILP had returned it; if it is accepted the MILPs run
  as without it.  Window queries do the same with ``x``'s own simulated modes.
- ``x``'s own sequences: the modes of a simulation with a constant input (mid, lowest, highest) are
  a first candidate, decided by the same exact LP as the MILP's candidates and cut.
- The MILPs and LPs go to scipy's HiGHS through :func:`_highs_call`, scipy's ``_highs_wrapper``
  without its per-call option validation (cached here) and unused multipliers: the same model
  arrays, options and solver calls, hence the same answers (the public ``milp`` / ``linprog`` are
  used with another scipy version).

Region rows
-----------
- *closed*: ``G w <= g + margin`` (a superset of any boundary convention);
- *open*: ``G w <= g - open_margin`` (strict interiors; both trajectories and the inputs).

Verdicts of :func:`analyse_state` (``thr = delta / 10`` unless given)
----------------------------------------------------------------------
``Verdict.allowed`` is the set of answers consistent with Definition 2.2 under *some* boundary
convention / tolerance within the margins; ``label`` is its element when it has one element,
``"ambiguous"`` otherwise:

- ``{"infeasible"}``: no ``U`` keeps ``x``'s own trajectory in the closed domain;
- ``{"unobservable"}``: the open problem has ``x^`` with ``||x^ - x||_inf >= delta``; the witness
  ``(x^, U)`` is re-simulated in numpy (first guard wins, outputs equal to ``OUTPUT_RTOL`` of the
  output range, every point inside its guard and ``X x U`` by at least ``open_margin / 2``);
- ``{"observable"}``: ``x`` is feasible in the open sense (re-simulated) and the closed problem
  has no ``x^`` with ``||x^ - x||_inf >= thr``;
- ambiguous: ``{"infeasible", "observable"}`` (``x`` feasible only in the closed sense, no
  indistinguishable state at ``>= thr``), ``{"infeasible", "observable", "unobservable"}`` (same,
  with one), ``{"observable", "unobservable"}`` (a closed-sense indistinguishable state at
  ``>= thr``, none at ``>= delta`` in the open sense).  Such states lie within the margins of a
  region boundary or have indistinguishable states only on shared guard faces / in pair sets
  thinner than ``open_margin``.

Every MILP / LP status is checked (only optimal / infeasible are accepted, after retries with
other settings); a witness failing its re-simulation raises :class:`OracleError`.
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field

import numpy as np
from scipy import sparse
from scipy.optimize import Bounds, LinearConstraint, linprog, milp

try:  # scipy's own HiGHS build, called as scipy.optimize.milp / linprog call it (see _highs_call)
    import scipy

    if tuple(scipy.__version__.split(".")[:2]) != ("1", "17"):  # the layout _highs_call was checked against
        raise ImportError(scipy.__version__)
    from scipy.optimize._highspy import _core as _hcore
    from scipy.optimize._highspy import _highs_options as _hopt
    from scipy.optimize._highspy._highs_wrapper import check_option as _check_option
    from scipy.optimize._linprog_highs import _highs_to_scipy_status_message
    from scipy.optimize._linprog_util import _check_result
    from scipy.optimize._milp import _milp_iv
except ImportError:  # another scipy layout: the public milp / linprog are used
    _hcore = None

__all__ = [
    "OracleError",
    "Verdict",
    "analyse_state",
    "analyse_window",
    "classify_state",
    "classify_window",
    "true_window_labels",
    "pair_search_lp",
    "simulate",
    "STATS",
]

#: Defaults of the queries (scaled coordinates): distance of an indistinguishable state that makes
#: ``x`` unobservable; relaxation of every region row for the closed sets; shrinking for the open
#: sets (ten times the toolbox's documented thinness tolerance 1e-6, so that a pair set that the
#: toolbox may legitimately drop as thin never yields an "unobservable" verdict).
DELTA = 1e-4
MARGIN = 1e-7
OPEN_MARGIN = 1e-5

#: ``thr = THR_FACTOR * delta``: the distance below which an indistinguishable state no longer
#: counts against "observable" (closed sets).  At ``delta / 100 = 1e-6`` (ten times ``margin``)
#: the closed problems of model (16) at T = 7 had solution sets only as thick as the relaxation
#: (pair sets on a guard face shared by two regions, where the outputs force ``x^ = x``, widened by
#: ``margin``): HiGHS's answers then changed with its own tolerance, 19 of 300 states.  At
#: ``delta / 10`` none did, on any configuration of the tests.
THR_FACTOR = 0.1

#: Weight of the output-equality rows of the MILP (outputs relative to their range): fewer
#: spurious candidates from the MILP's row tolerance (the exact step decides anyway).  1e4 was
#: faster on model (17) but made HiGHS declare a feasible random-PWA query infeasible.
Y_WEIGHT = 100.0

#: Singular values of the (scaled) output-difference map below this times the largest one are
#: treated as zero in the exact step.
RANK_RTOL = 1e-10

#: Output equality of a verified witness, relative to the output range.
OUTPUT_RTOL = 1e-8

#: HiGHS settings, passed verbatim (scipy warns that they are not its own; silenced locally).
#: Setting 0 answers; setting 1 confirms every negative answer with a looser tolerance (a larger
#: relaxation, so still a sound certificate), another random seed and the columns permuted (so
#: that presolve takes another path; see :func:`_solve`).  HiGHS's default
#: tolerances are kept for setting 0: with tighter ones (mip_feasibility_tolerance 1e-7 / 1e-8)
#: its presolve declared infeasible problems that have full-dimensional solution sets (seen on
#: model (16) and on random PWA systems).  Positive answers are only candidates that the exact step
#: re-solves at 1e-9.  Primal heuristics are off: the hard queries are infeasible ones, where they
#: took most of the time; presolve stays on (switching it off made the confirmations 30x slower).
_NO_HEURISTICS = {"mip_heuristic_effort": 0.0, "mip_heuristic_run_feasibility_jump": False, "mip_heuristic_run_rins": False,
                  "mip_heuristic_run_rens": False, "mip_heuristic_run_root_reduced_cost": False,
                  "mip_heuristic_run_zi_round": False, "mip_heuristic_run_shifting": False}
_SERIAL = {"threads": 1}  # deterministic, and polite on a shared machine
_HIGHS = ({**_SERIAL, **_NO_HEURISTICS},
          {**_SERIAL, **_NO_HEURISTICS, "mip_feasibility_tolerance": 1e-5, "primal_feasibility_tolerance": 1e-6,
           "random_seed": 12345})
#: Retries after a status other than optimal / infeasible without a usable point (time limit, ...).
_RETRIES = ({}, {"mip_feasibility_tolerance": 1e-5, "primal_feasibility_tolerance": 1e-6, "random_seed": 777},
            {"presolve": False}, {"simplex_strategy": 4})
_LP_OPTIONS = {"primal_feasibility_tolerance": 1e-9, "dual_feasibility_tolerance": 1e-9}
_TIME_LIMIT = 60.0
_MAX_CUTS = 400
_BIG = 8.0  # |x^_d - x_d| <= 2 (+ margins) in scaled coordinates and c <= 1
BOX_PAD = 1e-6  # the big-M boxes are padded outward by this (they are bounds, not binding rows)

#: Running counters, for the reports of the tests.
STATS: dict = {"milps": 0, "milp_seconds": 0.0, "lps": 0, "cuts": 0, "confirmations_that_found": 0, "retries": 0,
               "by_kind": {}}


class OracleError(RuntimeError):
    """A solver returned an unexpected status, or an answer that failed verification."""


@dataclass
class Verdict:
    """Answer of :func:`analyse_state` / :func:`analyse_window`.

    ``allowed`` is the set of answers consistent with Definition 2.2 under some boundary
    convention within the margins (one element unless ``label == "ambiguous"``).  ``x_hat`` /
    ``U`` is the verified witness of an ``"unobservable"`` answer (for an ambiguous one, the
    closed-sense witness if any), in original coordinates, and ``distance`` its scaled
    inf-distance from ``x``.
    """

    label: str
    reason: str
    allowed: frozenset = frozenset()
    x_hat: np.ndarray | None = None
    U: np.ndarray | None = None
    distance: float | None = None
    n_milps: int = 0
    n_cuts: int = 0
    seconds: float = 0.0
    milp_seconds: list = field(default_factory=list)


# ---------------------------------------------------------------------------------- system data
class _Data:
    """Scaled, row-normalised raw data of one system (own computation, cached per system)."""

    def __init__(self, system):
        self.system = system
        n, m = int(system.n), int(system.m)
        self.n, self.m, self.q = n, m, len(system.modes)
        half, centre = (np.asarray(v, dtype=float).copy() for v in system.scales())
        self.half, self.centre = half, centre
        SA, Sb = np.asarray(system.state_bounds.A, float), np.asarray(system.state_bounds.b, float)
        if m:
            IA, Ib = np.asarray(system.input_bounds.A, float), np.asarray(system.input_bounds.b, float)
        else:
            IA, Ib = np.zeros((0, 0)), np.zeros(0)
        dom_A = np.vstack([np.hstack([SA, np.zeros((SA.shape[0], m))]), np.hstack([np.zeros((IA.shape[0], n)), IA])])
        dom_b = np.concatenate([Sb, Ib])
        self._check_scales(dom_A, dom_b)
        hx, hu, cx, cu = half[:n], half[n:], centre[:n], centre[n:]
        self.G, self.g, self.raw = [], [], []
        self.Ah, self.Bh, self.ah, self.Ch, self.Dh, self.ch = [], [], [], [], [], []
        spans = []
        for mode in system.modes:
            A, B, a = np.asarray(mode.A, float), np.asarray(mode.B, float).reshape(n, m), np.asarray(mode.a, float)
            C = np.atleast_2d(np.asarray(mode.C, float))
            p = C.shape[0]
            D = np.zeros((p, m)) if mode.D is None else np.asarray(mode.D, float).reshape(p, m)
            c = np.zeros(p) if mode.c is None else np.asarray(mode.c, float).reshape(p)
            self.raw.append((A, B, a, C, D, c))
            spans.append(np.abs(C * hx).sum(1) + np.abs(D * hu).sum(1))
            H = np.vstack([np.asarray(mode.guard.A, float), dom_A])
            h = np.concatenate([np.asarray(mode.guard.b, float), dom_b])
            Hs, hs = H * half[None, :], h - H @ centre
            nrm = np.linalg.norm(Hs, axis=1)
            zero = nrm <= 1e-14
            if np.any(hs[zero] < 0):
                raise OracleError("a guard row without variables is violated: the mode is empty")
            self.G.append(Hs[~zero] / nrm[~zero, None])
            self.g.append(hs[~zero] / nrm[~zero])
            self.Ah.append(A * hx[None, :] / hx[:, None])
            self.Bh.append(B * hu[None, :] / hx[:, None])
            self.ah.append((A @ cx + B @ cu + a - cx) / hx)
        ys = np.max(np.array(spans), axis=0)
        self.p = len(ys)
        self.ys = np.where(ys > 0, ys, 1.0)
        for (A, B, a, C, D, c) in self.raw:
            self.Ch.append(C * hx[None, :] / self.ys[:, None])
            self.Dh.append(D * hu[None, :] / self.ys[:, None])
            self.ch.append((C @ cx + D @ cu + c) / self.ys)
        # rows that involve the state (the others constrain the input alone)
        self.xrow = [np.linalg.norm(G[:, :n], axis=1) > 1e-12 for G in self.G]
        self._boxes: dict[float, list] = {}
        self._models: dict = {}

    def _check_scales(self, dom_A, dom_b):
        d = dom_A.shape[1]
        lo, hi = np.empty(d), np.empty(d)
        for j in range(d):
            e = np.zeros(d)
            e[j] = 1.0
            for sign in (1.0, -1.0):
                r = linprog(sign * e, A_ub=dom_A, b_ub=dom_b, bounds=[(None, None)] * d, method="highs")
                if r.status != 0:
                    raise OracleError(f"bounding box LP of X x U: status {r.status}")
                (lo if sign > 0 else hi)[j] = sign * r.fun
        half = np.where(hi - lo > 0, (hi - lo) / 2, 1.0)
        if not (np.allclose(half, self.half, rtol=1e-9, atol=0)
                and np.allclose((hi + lo) / 2, self.centre, rtol=1e-9, atol=1e-12 * half.max())):
            raise OracleError(f"system.scales() {self.half, self.centre} is not the bounding box of X x U {lo, hi}")

    def boxes(self, mu: float):
        """Per mode: bounding box (lo, hi) of ``{w : G w <= g + mu}`` (scaled), or None if empty."""
        if mu not in self._boxes:
            out = []
            d = self.n + self.m
            for G, g in zip(self.G, self.g):
                lo, hi = np.empty(d), np.empty(d)
                empty = False
                for j in range(d):
                    e = np.zeros(d)
                    e[j] = 1.0
                    for sign in (1.0, -1.0):
                        r = linprog(sign * e, A_ub=G, b_ub=g + mu, bounds=[(None, None)] * d, method="highs")
                        if r.status == 2:
                            empty = True
                            break
                        if r.status != 0:
                            raise OracleError(f"bounding box LP of a guard: status {r.status}")
                        (lo if sign > 0 else hi)[j] = sign * r.fun
                    if empty:
                        break
                out.append(None if empty else (lo - BOX_PAD, hi + BOX_PAD))
            self._boxes[mu] = out
        return self._boxes[mu]


_DATA: dict[int, tuple] = {}


def _data(system) -> _Data:
    hit = _DATA.get(id(system))
    if hit is not None and hit[0] is system:
        return hit[1]
    d = _Data(system)
    _DATA[id(system)] = (system, d)
    return d


# ---------------------------------------------------------------------------------- MILP models
class _Model:
    """A MILP whose matrix is fixed; right-hand sides (and no-good cuts) are supplied per query."""

    def __init__(self, nv):
        self.nv = nv
        self.lb = np.zeros(nv)
        self.ub = np.zeros(nv)
        self.integ = np.zeros(nv)
        self.blocks = []

    def add(self, name, M, lo, hi):
        M = np.atleast_2d(M)
        lo = np.broadcast_to(np.asarray(lo, float), (M.shape[0],)).copy()
        hi = np.broadcast_to(np.asarray(hi, float), (M.shape[0],)).copy()
        self.blocks.append((name, M, lo, hi))

    def finish(self):
        self.A = sparse.csr_array(np.vstack([b[1] for b in self.blocks]))
        self.lo = np.concatenate([b[2] for b in self.blocks])
        self.hi = np.concatenate([b[3] for b in self.blocks])
        self.slices = {}
        r = 0
        for name, M, _, _ in self.blocks:
            self.slices[name] = slice(r, r + M.shape[0])
            r += M.shape[0]
        del self.blocks
        return self


class _Traj:
    """Variable layout of one trajectory (disjunctive form) inside a model."""

    def __init__(self, D: _Data, T: int, base: int):
        self.D, self.T, self.base = D, T, base
        self.nw = D.n + D.m
        self.stride = self.nw + 1
        self.size = T * D.q * self.stride

    def w(self, k, i):
        s = self.base + (k * self.D.q + i) * self.stride
        return np.arange(s, s + self.nw)

    def wx(self, k, i):
        return self.w(k, i)[: self.D.n]

    def wu(self, k, i):
        return self.w(k, i)[self.D.n:]

    def d(self, k, i):
        return self.base + (k * self.D.q + i) * self.stride + self.nw

    def add_to(self, M: _Model, mu: float, tag: str, mu_input: float | None = None):
        """Rows relaxed by ``mu``; rows on the input alone by ``mu_input`` if given (window queries,
        where the inputs are data: shrinking their rows would reject inputs on the bound of U)."""
        D, n, m, q, T = self.D, self.D.n, self.D.m, self.D.q, self.T
        boxes = D.boxes(mu if mu_input is None else max(mu, mu_input))
        nv = M.nv
        for k in range(T):
            row = np.zeros(nv)
            for i in range(q):
                dk = self.d(k, i)
                row[dk] = 1.0
                M.integ[dk] = 1
                if boxes[i] is None:  # the mode's set is empty with this margin
                    M.lb[dk] = M.ub[dk] = 0.0
                    continue
                M.lb[dk], M.ub[dk] = 0.0, 1.0
                lo, hi = boxes[i]
                w = self.w(k, i)
                M.lb[w], M.ub[w] = np.minimum(lo, 0.0), np.maximum(hi, 0.0)
                # guard and domain rows G w <= (g + mu) d; with d = 0 they force w = 0 (bounded set)
                G, g = D.G[i], D.g[i]
                Gm = np.zeros((G.shape[0], nv))
                Gm[:, w] = G
                Gm[:, dk] = -(g + (mu if mu_input is None else np.where(D.xrow[i], mu, mu_input)))
                M.add(f"{tag}guard{k},{i}", Gm, -np.inf, 0.0)
            M.add(f"{tag}onemode{k}", row, 1.0, 1.0)
        for k in range(T - 1):
            E = np.zeros((n, nv))
            for i in range(q):
                E[:, self.wx(k + 1, i)] += np.eye(n)
                E[:, self.wx(k, i)] -= D.Ah[i]
                if m:
                    E[:, self.wu(k, i)] -= D.Bh[i]
                E[:, self.d(k, i)] -= D.ah[i]
            M.add(f"{tag}dyn{k}", E, 0.0, 0.0)

    def x0(self, nv):
        E = np.zeros((self.D.n, nv))
        for i in range(self.D.q):
            E[:, self.wx(0, i)] += np.eye(self.D.n)
        return E

    def u(self, k, nv):
        E = np.zeros((self.D.m, nv))
        for i in range(self.D.q):
            E[:, self.wu(k, i)] += np.eye(self.D.m)
        return E

    def y(self, k, nv):
        E = np.zeros((self.D.p, nv))
        for i in range(self.D.q):
            E[:, self.wx(k, i)] += self.D.Ch[i]
            if self.D.m:
                E[:, self.wu(k, i)] += self.D.Dh[i]
            E[:, self.d(k, i)] += self.D.ch[i]
        return E * Y_WEIGHT

    def modes(self, sol):
        dl = np.array([[sol[self.d(k, i)] for i in range(self.D.q)] for k in range(self.T)])
        if np.max(np.abs(dl - np.round(dl))) > 1e-5:
            raise OracleError(f"MILP returned non-integral mode binaries {dl}")
        return tuple(int(i) for i in np.argmax(dl, axis=1))

    def nogood(self, seq, nv):
        r = np.zeros(nv)
        for k, i in enumerate(seq):
            r[self.d(k, i)] = 1.0
        return r


def _directions(M: _Model, traj: _Traj, base: int):
    """Rows ``s (x^_d - x_d) >= c - BIG (1 - beta_{d,s})`` and ``sum beta >= 1`` (RHS per query)."""
    n, nv = traj.D.n, M.nv
    X0 = traj.x0(nv)
    R = np.zeros((2 * n, nv))
    beta = base + np.arange(2 * n)
    for d in range(n):
        for s_i, s in enumerate((1.0, -1.0)):
            r = 2 * d + s_i
            R[r] = s * X0[d]
            R[r, beta[r]] = -_BIG
    M.integ[beta] = 1
    M.lb[beta], M.ub[beta] = 0.0, 1.0
    M.beta = beta
    M.add("dir", R, -np.inf, np.inf)
    one = np.zeros(nv)
    one[beta] = 1.0
    M.add("dirsum", one, 1.0, np.inf)


def _model(D: _Data, kind: str, T: int, mu: float, mu_input: float | None = None) -> _Model:
    key = (kind, T, mu, mu_input)
    if key in D._models:
        return D._models[key]
    n = D.n
    if kind == "single":  # x's own trajectory, x(0) fixed, U free
        tr = _Traj(D, T, 0)
        M = _Model(tr.size)
        tr.add_to(M, mu, "a")
        M.add("x0", tr.x0(M.nv), 0.0, 0.0)
        M.trajs = (tr,)
    elif kind == "window":  # x^ only, U fixed, outputs equal to given data
        tr = _Traj(D, T, 0)
        M = _Model(tr.size + 2 * n)
        tr.add_to(M, mu, "b", mu_input)
        for k in range(T):
            if D.m:
                M.add(f"u{k}", tr.u(k, M.nv), 0.0, 0.0)
            M.add(f"y{k}", tr.y(k, M.nv), 0.0, 0.0)
        _directions(M, tr, tr.size)
        M.trajs = (tr,)
    else:
        raise ValueError(kind)
    M.finish()
    D._models[key] = M
    return M


def _solve(M: _Model, lo, hi, kind: str, times: list, cuts=(), setting: int = 0):
    """One feasibility MILP; returns the solution or None (infeasible)."""
    c = STATS["by_kind"].setdefault(f"{kind}/s{setting}", [0, 0.0, 0.0])
    A, lo_, hi_ = M.A, lo, hi
    if len(cuts):
        A = sparse.vstack([M.A, sparse.csr_array(np.array([r for r, _ in cuts]))], format="csr")
        lo_ = np.concatenate([lo, np.full(len(cuts), -np.inf)])
        hi_ = np.concatenate([hi, [b for _, b in cuts]])
    lb, ub, integ = M.lb, M.ub, M.integ
    if setting == 1:
        # the confirmation also sees the columns in another order: HiGHS's presolve then takes
        # another path (its false "infeasible" answers came from presolve reductions)
        perm = np.random.default_rng(M.nv).permutation(M.nv)
        A, lb, ub, integ = sparse.csr_array(A[:, perm]), lb[perm], ub[perm], integ[perm]
    messages = []
    for extra in _RETRIES:
        t = time.perf_counter()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", RuntimeWarning)
            res = (milp if _hcore is None else _milp_fast)(
                np.zeros(M.nv), integrality=integ, bounds=Bounds(lb, ub), constraints=LinearConstraint(A, lo_, hi_),
                options={"time_limit": _TIME_LIMIT, **_HIGHS[setting], **extra})
        if res.x is not None and setting == 1:
            xx = np.empty(M.nv)
            xx[perm] = res.x
            res.x = xx
        dt = time.perf_counter() - t
        times.append(dt)
        STATS["milps"] += 1
        STATS["milp_seconds"] += dt
        c[0] += 1
        c[1] += dt
        c[2] = max(c[2], dt)
        if res.status == 0:
            return res.x
        if res.status == 2:
            return None
        if res.x is not None and np.all(np.abs(res.x[M.integ > 0] - np.round(res.x[M.integ > 0])) <= 1e-6):
            # "Solve error" after postsolve: a point violating some row by more than the tolerance.
            # Still a candidate assignment of the binaries; the exact step decides what it is worth.
            STATS["solve_error_candidates"] = STATS.get("solve_error_candidates", 0) + 1
            return res.x
        STATS["retries"] += 1
        key = f"setting{setting}+{sorted(extra)}: status {res.status}"
        STATS.setdefault("retry_reasons", {}).setdefault(key, 0)
        STATS["retry_reasons"][key] += 1
        messages.append(f"{extra}: status {res.status} {res.message}")
    raise OracleError(f"MILP ({kind}) failed with every setting: {messages}")


# ------------------------------------------------------------ scipy's HiGHS without its per-call overhead
# scipy.optimize.milp / linprog(method="highs") validate every option on every call (a new options
# manager per option) and build multipliers that are not used here: on the small problems of the
# tests that was half of the oracle's time.  _highs_call makes the same calls to the same HiGHS
# build (scipy's), with the same model arrays (built by scipy's own input validation for the MILPs,
# as linprog builds them for the LPs) and the same options; an option's validation is cached, the
# decision (set it or skip it) being that of scipy's wrapper.  The status and point returned are
# those of milp / linprog (same status mapping, same check of the LP's point).
_OPTION_DECISIONS: dict = {}


class _Result:
    def __init__(self, status, message, x, fun):
        self.status, self.message, self.x, self.fun = status, message, x, fun


def _option_decision(key, val):
    """scipy's ``_highs_wrapper`` option handling, cached: (set it?, value to set)."""
    k = (key, type(val), repr(val))
    hit = _OPTION_DECISIONS.get(k)
    if hit is not None:
        return hit
    decision = (False, None)
    if val is not None and key not in ("sense",):
        opt_type = _hopt.HighsOptionsManager().get_option_type(key)
        if opt_type != -1:
            ok = True
            if key in ("presolve", "parallel"):
                if isinstance(val, bool):
                    val = "on" if val else "off"
                else:
                    ok = False
            if ok:
                opt_type = _hcore.HighsOptionType(opt_type)
                status, _ = _check_option(_hcore._Highs(), key, val)
                if opt_type == _hcore.HighsOptionType.kBool and not isinstance(val, bool):
                    ok = False
                elif status == 0:
                    decision = (True, val)
    _OPTION_DECISIONS[k] = decision
    return decision


def _highs_call(c, indptr, indices, data, lhs, rhs, lb, ub, integrality, options):
    """scipy's ``_highs_wrapper`` (same HiGHS calls): (HiGHS model status, message, x, row values, objective)."""
    numcol, numrow = c.size, rhs.size
    is_mip = integrality is not None and np.sum(integrality) > 0
    lp = _hcore.HighsLp()
    lp.num_col_ = numcol
    lp.num_row_ = numrow
    lp.a_matrix_.num_col_ = numcol
    lp.a_matrix_.num_row_ = numrow
    lp.a_matrix_.format_ = _hcore.MatrixFormat.kColwise
    lp.col_cost_ = c
    lp.col_lower_ = lb
    lp.col_upper_ = ub
    lp.row_lower_ = lhs
    lp.row_upper_ = rhs
    lp.a_matrix_.start_ = indptr
    lp.a_matrix_.index_ = indices
    lp.a_matrix_.value_ = data
    if integrality.size > 0:
        lp.integrality_ = [_hcore.HighsVarType(i) for i in integrality]
    highs = _hcore._Highs()
    highs_options = _hcore.HighsOptions()
    for key, val in options.items():
        use, v = _option_decision(key, val)
        if use:
            setattr(highs_options, key, v)
    MS = _hcore.HighsModelStatus
    if highs.passOptions(highs_options) == _hcore.HighsStatus.kError:
        st = highs.getModelStatus()
        return st, highs.modelStatusToString(st), None, None, None
    if highs.passModel(lp) == _hcore.HighsStatus.kError:
        st = MS.kModelError
        return st, highs.modelStatusToString(st), None, None, None
    if highs.run() == _hcore.HighsStatus.kError:
        st = highs.getModelStatus()
        return st, highs.modelStatusToString(st), None, None, None
    st = highs.getModelStatus()
    info = highs.getInfo()
    limits = (MS.kTimeLimit, MS.kIterationLimit, MS.kSolutionLimit)
    mip_fail = st not in (MS.kOptimal, *limits) or (st in limits and info.objective_function_value == _hcore.kHighsInf)
    if (is_mip and mip_fail) or (not is_mip and st != MS.kOptimal):
        msg = (f"model_status is {highs.modelStatusToString(st)}; "
               f"primal_status is {highs.solutionStatusToString(info.primal_solution_status)}")
        return st, msg, None, None, None
    sol = highs.getSolution()
    return st, highs.modelStatusToString(st), np.array(sol.col_value), np.asarray(sol.row_value), \
        info.objective_function_value


def _milp_fast(c, *, integrality, bounds, constraints, options):
    """``scipy.optimize.milp`` through :func:`_highs_call` (status, message, x as milp's)."""
    c, integ, lb, ub, indptr, indices, data, b_l, b_u, opts = _milp_iv(c, integrality, bounds, constraints, options)
    st, msg, x, _, fun = _highs_call(c, indptr, indices, data, b_l, b_u, lb, ub, integ, opts)
    status, message = _highs_to_scipy_status_message(st, msg)
    return _Result(status, message, x, fun)


def _replace_inf(x):
    infs = np.isinf(x)
    x[infs] = np.sign(x[infs]) * _hcore.kHighsInf
    return x


_LP_HIGHS_OPTIONS: dict = {}


def _linprog_fast(c, A_ub, b_ub, method: str = "oracle"):
    """``linprog(c, A_ub, b_ub, bounds=(None, None), method=...)`` through :func:`_highs_call`: the
    arrays and options of scipy's ``_linprog_highs``, its status mapping and its final
    ``_check_result``.  ``method="oracle"``: ``"highs"`` with :data:`_LP_OPTIONS` (the oracle's
    LPs); ``"highs"``, ``"highs-ds"``, ``"highs-ipm"``: scipy's methods with their defaults."""
    if method not in _LP_HIGHS_OPTIONS:
        from scipy.optimize._highspy._core import HighsDebugLevel
        from scipy.optimize._highspy._core import simplex_constants as s_c
        tol = _LP_OPTIONS if method == "oracle" else {}
        _LP_HIGHS_OPTIONS[method] = {
            "presolve": True, "sense": None,
            "solver": {"highs-ds": "simplex", "highs-ipm": "ipm"}.get(method), "time_limit": None,
            "highs_debug_level": HighsDebugLevel.kHighsDebugLevelNone,
            "dual_feasibility_tolerance": tol.get("dual_feasibility_tolerance"), "ipm_optimality_tolerance": None,
            "log_to_console": False, "mip_max_nodes": None, "output_flag": False,
            "primal_feasibility_tolerance": tol.get("primal_feasibility_tolerance"),
            "simplex_dual_edge_weight_strategy": None, "simplex_strategy": s_c.SimplexStrategy.kSimplexStrategyDual,
            "ipm_iteration_limit": None, "simplex_iteration_limit": None, "mip_rel_gap": None}
    c = np.array(c, dtype=float).ravel()
    A_ub = np.array(A_ub, dtype=float)
    b_ub = np.array(b_ub, dtype=float).ravel()
    n = c.size
    A = sparse.csc_array(np.vstack((A_ub, np.zeros((0, n)))))
    lhs = _replace_inf(np.concatenate((-np.ones_like(b_ub) * np.inf, np.zeros(0))))
    rhs = _replace_inf(np.concatenate((b_ub, np.zeros(0))))
    bounds = np.column_stack([np.full(n, -np.inf), np.full(n, np.inf)])
    lb, ub = bounds.T.copy()
    st, msg, x, row_value, fun = _highs_call(c, A.indptr, A.indices, A.data, lhs, rhs, _replace_inf(lb), _replace_inf(ub),
                                             np.empty(0).astype(np.uint8), _LP_HIGHS_OPTIONS[method])
    status, message = _highs_to_scipy_status_message(st, msg)
    if x is not None:
        slack = np.array((rhs - row_value)[: b_ub.size])
        con = np.array((rhs - row_value)[b_ub.size:])
    else:
        slack = con = None
    status, message = _check_result(x, fun, status, slack, con, bounds, 1e-9, message, None)
    return _Result(status, message, x, fun)


def linprog_free(c, A_ub, b_ub, method: str):
    """``scipy.optimize.linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=(None, None), method=method)``
    (``method`` one of scipy's HiGHS methods): the same HiGHS calls and answers, without scipy's
    per-call option validation when its layout is the one :func:`_highs_call` was checked against.
    Returns an object with ``status``, ``message``, ``x``, ``fun``."""
    if _hcore is not None:
        return _linprog_fast(c, A_ub, b_ub, method)
    return linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * len(c), method=method)


def _lp(c, A_ub, b_ub, what: str):
    STATS["lps"] += 1
    if _hcore is not None:
        r = _linprog_fast(c, A_ub, b_ub)
    else:
        r = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * len(c), method="highs", options=_LP_OPTIONS)
    if r.status in (0, 2):
        return r
    r = linprog(c, A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * len(c), method="highs-ipm")
    if r.status in (0, 2):
        return r
    raise OracleError(f"LP ({what}) ended with status {r.status}: {r.message}")


# ---------------------------------------------------------------------------------- exact step
def _fixed_mode_maps(D: _Data, seq, X0, x0c, S, s, masks=None):
    """Affine maps in theta of a trajectory with given modes: rows ``R theta <= r`` (slack form
    without margin), outputs ``Y theta + y`` (scaled by the output range)."""
    n, m = D.n, D.m
    X, xc = X0, x0c
    rows, rhs, Ys, ys = [], [], [], []
    for k, i in enumerate(seq):
        Gx, Gu = D.G[i][:, :n], D.G[i][:, n:]
        if masks is not None:
            masks.append(D.xrow[i])
        Sk, sk = S[k], s[k]
        rows.append(Gx @ X + Gu @ Sk)
        rhs.append(D.g[i] - Gx @ xc - Gu @ sk)
        Ys.append(D.Ch[i] @ X + D.Dh[i] @ Sk)
        ys.append(D.Ch[i] @ xc + D.Dh[i] @ sk + D.ch[i])
        X, xc = D.Ah[i] @ X + D.Bh[i] @ Sk, D.Ah[i] @ xc + D.Bh[i] @ sk + D.ah[i]
    return rows, rhs, Ys, ys


def _exact_pair(D: _Data, xs, seq0, seq1, mu: float, c: float, Us=None, Y0=None, prefer=None, only=None,
                mu_input=None):
    """Fixed mode sequences: is there theta with ``s (x^_d - x_d) >= c`` for some signed direction?

    ``theta = (x^, U)`` (scaled) when ``Us is None``, else ``theta = x^`` with ``U = Us`` fixed and
    ``x``'s outputs ``Y0`` (scaled) given (``seq0`` unused).  Output equalities are eliminated
    through the null space of their matrix.  Returns ``(theta, value)`` for the first direction
    reaching ``c`` (``prefer`` first; only the direction ``only`` if given), else ``None``.
    """
    n, m = D.n, D.m
    T = len(seq1)
    free_U = Us is None
    nth = n + T * m if free_U else n
    if free_U:
        S = [np.zeros((m, nth)) for _ in range(T)]
        for k in range(T):
            S[k][:, n + k * m: n + (k + 1) * m] = np.eye(m)
        s = [np.zeros(m) for _ in range(T)]
    else:
        S = [np.zeros((m, nth)) for _ in range(T)]
        s = [np.asarray(Us[k], float) for k in range(T)]
    I1 = np.zeros((n, nth))
    I1[:, :n] = np.eye(n)
    masks = []
    r1, b1, Y1, y1 = _fixed_mode_maps(D, seq1, I1, np.zeros(n), S, s, masks)
    rows, rhs = list(r1), list(b1)
    if free_U:
        r0, b0, Y0m, y0 = _fixed_mode_maps(D, seq0, np.zeros((n, nth)), np.asarray(xs, float), S, s, masks)
        rows += r0
        rhs += b0
        E = np.vstack([a - b for a, b in zip(Y1, Y0m)]) if T else np.zeros((0, nth))
        e = np.concatenate([b - a for a, b in zip(y1, y0)]) if T else np.zeros(0)
    else:
        E = np.vstack(Y1)
        e = np.concatenate([np.asarray(Y0[k], float) - y1[k] for k in range(T)])
    A_ub = np.vstack(rows)
    b_ub = np.concatenate(rhs) + (mu if mu_input is None else np.where(np.concatenate(masks), mu, mu_input))
    # exact elimination of E theta = e
    if E.shape[0]:
        Uu, sv, Vt = np.linalg.svd(E, full_matrices=True)
        r = int(np.sum(sv > RANK_RTOL * max(sv.max(initial=0.0), 1e-300)))
        theta0 = Vt[:r].T @ ((Uu[:, :r].T @ e) / sv[:r]) if r else np.zeros(nth)
        if np.linalg.norm(E @ theta0 - e) > 1e-9 * (1.0 + np.linalg.norm(e)):
            return None  # the outputs cannot be equal with these mode sequences
        N = Vt[r:].T
    else:
        theta0, N = np.zeros(nth), np.eye(nth)
    Ar = A_ub @ N
    br = b_ub - A_ub @ theta0
    const = np.linalg.norm(Ar, axis=1) <= 1e-12
    if np.any(br[const] < -1e-9):
        return None
    Ar, br = Ar[~const], br[~const]
    order = [(d, sg) for d in range(n) for sg in (1.0, -1.0)]
    if only is not None:
        order = [only]
    elif prefer is not None:
        order.remove(prefer)
        order.insert(0, prefer)
    for d, sg in order:
        if N.shape[1] == 0:
            val = sg * (theta0[d] - xs[d])
            if val >= c:
                return theta0, val
            continue
        res = _lp(-sg * N[d], Ar, br, "exact pair")
        if res.status == 2:
            return None  # the fixed-mode set itself is empty
        theta = theta0 + N @ res.x
        val = sg * (theta[d] - xs[d])
        if val >= c:
            return theta, val
    return None


def _nogood_cut(M: _Model, seqs):
    row = np.zeros(M.nv)
    for tr, seq in zip(M.trajs, seqs):
        row += tr.nogood(seq, M.nv)
    return row, float(sum(len(sq) for sq in seqs) - 1)


def _search(D: _Data, M: _Model, lo, hi, kind: str, times: list, exact, counts: dict, precut=None):
    """MILP candidates + exact step + no-good cuts; negative answers confirmed by setting 1.

    ``precut``: a candidate (sequences of ``M.trajs``) tried by the exact step before any MILP.
    If the exact step rejects it, it is excluded by its no-good cut from the start, as it would be
    after a MILP had returned it (the MILP's usual first candidate: ``x^`` following ``x``'s own
    modes, at a distance of the MILP's row tolerance).  If the exact step accepts it, nothing
    changes: the MILPs run as without ``precut`` (same witness).
    """
    cuts, seen = [], set()
    if precut is not None and exact(precut, None) is None:
        seen.add(precut)
        cuts.append(_nogood_cut(M, precut))
        STATS["cuts"] += 1
        STATS["precuts"] = STATS.get("precuts", 0) + 1
        counts["cuts"] = counts.get("cuts", 0) + 1
    for setting in (0, 1):
        while True:
            sol = _solve(M, lo, hi, kind, times, cuts, setting)
            if sol is None:
                break
            seqs = tuple(tr.modes(sol) for tr in M.trajs)
            if seqs in seen:
                raise OracleError(f"{kind}: the MILP returned the excluded sequences {seqs} again")
            seen.add(seqs)
            prefer = None
            if hasattr(M, "beta"):
                b = int(np.argmax(sol[M.beta]))
                prefer = (b // 2, 1.0 if b % 2 == 0 else -1.0)
            found = exact(seqs, prefer)
            if found is not None:
                if setting == 1:
                    STATS["confirmations_that_found"] += 1
                    STATS.setdefault("confirmations_by_kind", {}).setdefault(kind, 0)
                    STATS["confirmations_by_kind"][kind] += 1
                return found
            cuts.append(_nogood_cut(M, seqs))
            STATS["cuts"] += 1
            counts["cuts"] = counts.get("cuts", 0) + 1
            if len(cuts) > _MAX_CUTS:
                raise OracleError(f"{kind}: more than {_MAX_CUTS} no-good cuts")
    return None


# ---------------------------------------------------------------------------------- simulation
def _slack(D: _Data, i: int, x, u, input_rows: bool = True) -> float:
    """Scaled slack ``min(g - G w)`` of ``(x, u)`` in mode ``i``'s guard cap X x U (>= 0: inside);
    ``input_rows=False`` leaves out the rows on the input alone."""
    w = (np.concatenate([x, u]) - D.centre) / D.half
    r = D.g[i] - D.G[i] @ w
    return float(np.min(r if input_rows else r[D.xrow[i]], initial=np.inf))


def simulate(system, x0, U, modes=None, input_rows: bool = True):
    """Trajectory of eq. (1) with the raw matrices, in numpy.

    ``modes=None``: the system's convention, the first guard (cap X x U, closed, exact) that contains
    the point; otherwise the given mode sequence.  Returns ``(X (T+1, n), Y (T, p), modes, slack)``
    where ``slack[k]`` is the scaled slack of step ``k`` in its mode (``-inf`` where no mode contains
    the point; the trajectory then stops); ``input_rows=False``: the slack leaves out the rows on the
    input alone (window queries, where the inputs are data).
    """
    D = _data(system)
    U = np.asarray(U, float).reshape(-1, D.m)
    T = U.shape[0]
    X = np.full((T + 1, D.n), np.nan)
    Y = np.full((T, D.p), np.nan)
    q = np.full(T, -1)
    slack = np.full(T, -np.inf)
    X[0] = np.asarray(x0, float)
    for k in range(T):
        x, u = X[k], U[k]
        if modes is None:
            inside = [i for i in range(D.q) if _slack(D, i, x, u) >= 0.0]
            if not inside:
                break
            i = inside[0]
        else:
            i = int(modes[k])
        q[k] = i
        slack[k] = _slack(D, i, x, u, input_rows)
        A, B, a, C, Dm, c = D.raw[i]
        X[k + 1] = A @ x + B @ u + a
        Y[k] = C @ x + Dm @ u + c
    return X, Y, q, slack


def _dist(D: _Data, a, b) -> float:
    return float(np.max(np.abs((np.asarray(a) - np.asarray(b)) / D.half[: D.n])))


def _verify(D: _Data, x, xh, U, m0, m1, *, strict: bool, margin: float, min_dist: float, what: str, Yx=None):
    """Re-simulate a witness; raise OracleError unless it is what the solver claims.

    strict: both trajectories under the system's own convention (first guard wins) reproduce the
    solver's modes and stay inside by ``margin / 2``; otherwise they follow the given modes and
    stay within ``margin`` (+ solver tolerance) of the closed sets.  ``Yx``: ``x``'s outputs
    given as data (window queries; ``x``'s trajectory is then not checked).
    """
    runs = {}
    for name, z, mm in (("x", x, m0), ("x^", xh, m1)):
        if name == "x" and Yx is not None:
            continue
        # window queries (Yx given): the inputs are data, their own rows are not tested
        run = simulate(D.system, z, U, None if strict else mm, input_rows=Yx is None)
        X_, Y_, q_, s_ = run
        if strict:
            if mm is not None and not np.array_equal(q_, mm):
                raise OracleError(f"{what}: {name}'s modes {q_} under first-guard-wins differ from the solver's {mm}")
            if np.min(s_, initial=np.inf) < 0.5 * margin:
                raise OracleError(f"{what}: {name}'s trajectory is not strictly inside (slack {np.min(s_):.3g})")
        elif np.min(s_, initial=np.inf) < -margin - 1e-6:
            raise OracleError(f"{what}: {name}'s trajectory leaves the closed domain (slack {np.min(s_):.3g})")
        runs[name] = Y_
    Y0 = runs["x"] if Yx is None else Yx
    err = np.max(np.abs(Y0 - runs["x^"]) / D.ys, initial=0.0)
    if not err <= OUTPUT_RTOL:
        raise OracleError(f"{what}: outputs differ by {err:.3g} (relative)")
    dist = _dist(D, x, xh)
    if dist < min_dist * (1 - 1e-6) - 1e-12:
        raise OracleError(f"{what}: witness at distance {dist:.3g} < {min_dist:.3g}")
    return dist


def _random_rollouts(D: _Data, x, T: int, n_samples: int = 32, seed: int = 0) -> bool:
    """True if some random input sequence keeps x's trajectory inside the closed domain for T steps."""
    if D.m == 0:
        return bool(np.all(np.isfinite(simulate(D.system, x, np.zeros((T, 0)))[3])))
    rng = np.random.default_rng(seed)
    lo, hi = D.centre[D.n:] - D.half[D.n:], D.centre[D.n:] + D.half[D.n:]
    candidates = [rng.uniform(lo, hi, size=(T, D.m)) for _ in range(n_samples)]
    candidates += [np.tile(v, (T, 1)) for v in (lo, hi, (lo + hi) / 2)]
    for U in candidates:
        if np.all(np.isfinite(simulate(D.system, x, U)[3])):
            return True
    return False


# ---------------------------------------------------------------------------------- queries
def _rhs(M: _Model, D: _Data, x, c: float):
    lo, hi = M.lo.copy(), M.hi.copy()
    xs = (np.asarray(x, float) - D.centre[: D.n]) / D.half[: D.n]
    if "x0" in M.slices:
        sl = M.slices["x0"]
        lo[sl] = hi[sl] = xs
    if "dir" in M.slices:
        # s (x^_d - x_d) >= c - BIG (1 - beta)  <=>  s x^_d - BIG beta >= c - BIG + s x_d
        lo[M.slices["dir"]] = c - _BIG + np.ravel([[xs[d], -xs[d]] for d in range(D.n)])
    return lo, hi, xs


def _x_maps(D: _Data, seq0, xs):
    """x's trajectory with modes ``seq0`` and x fixed, affine in the scaled inputs ``U`` (T m):
    rows ``R U <= r`` (unit rows, no margin) and outputs ``y_k = Yu_k U + yc_k`` (scaled)."""
    n, m, T = D.n, D.m, len(seq0)
    S = []
    for k in range(T):
        Sk = np.zeros((m, T * m))
        Sk[:, k * m:(k + 1) * m] = np.eye(m)
        S.append(Sk)
    rows, rhs, Yu, yc = _fixed_mode_maps(D, seq0, np.zeros((n, T * m)), np.asarray(xs, float), S, [np.zeros(m)] * T)
    return np.vstack(rows), np.concatenate(rhs), Yu, yc


def _model_pair0(D: _Data, T: int, mu: float, seq0) -> _Model:
    """x's modes fixed to ``seq0``: variables U (scaled), x^'s disjunctive trajectory, directions."""
    key = ("pair0", T, mu, tuple(seq0))
    if key in D._models:
        return D._models[key]
    n, m = D.n, D.m
    nu = T * m
    tr = _Traj(D, T, nu)
    M = _Model(nu + tr.size + 2 * n)
    M.lb[:nu], M.ub[:nu] = -1.0 - BOX_PAD, 1.0 + BOX_PAD
    R, _, Yu, _ = _x_maps(D, seq0, np.zeros(n))
    Rm = np.zeros((R.shape[0], M.nv))
    Rm[:, :nu] = R
    M.add("xrows", Rm, -np.inf, np.inf)
    tr.add_to(M, mu, "b")
    for k in range(T):
        if m:
            L = tr.u(k, M.nv)
            L[:, k * m:(k + 1) * m] -= np.eye(m)
            M.add(f"u{k}", L, 0.0, 0.0)
        Y = tr.y(k, M.nv)
        Y[:, :nu] -= Yu[k] * Y_WEIGHT
        M.add(f"y{k}", Y, 0.0, 0.0)
    _directions(M, tr, nu + tr.size)
    M.trajs = (tr,)
    M.seq0 = tuple(seq0)
    M.finish()
    D._models[key] = M
    return M


def _rhs_pair0(M: _Model, D: _Data, x, c: float, mu: float):
    lo, hi, xs = _rhs(M, D, x, c)
    _, r, _, yc = _x_maps(D, M.seq0, xs)
    hi[M.slices["xrows"]] = r + mu
    for k in range(len(M.seq0)):
        sl = M.slices[f"y{k}"]
        lo[sl] = hi[sl] = yc[k] * Y_WEIGHT
    return lo, hi, xs


def _x_sequences(D: _Data, T: int, x, xs, mu: float, times: list) -> list:
    """Every mode sequence that x's own trajectory can follow (rows relaxed by mu): MILP candidates
    with no-good cuts, each checked by its exact LP (largest common slack of the rows over U); the
    final "no more" answer is confirmed with the second HiGHS setting.  Returns (sequence, slack,
    U scaled) with slack >= -mu."""
    M = _model(D, "single", T, mu)
    lo, hi, _ = _rhs(M, D, x, 0.0)
    tr = M.trajs[0]
    seqs, cuts, seen = [], [], set()
    # a first candidate without a MILP: the modes of a simulation with the mid, lowest or highest
    # constant input (first guard wins), decided by the same exact LP as the MILP's candidates
    if D.m:
        ulo, uhi = D.centre[D.n:] - D.half[D.n:], D.centre[D.n:] + D.half[D.n:]
        trials = [np.tile(v, (T, 1)) for v in (D.centre[D.n:], ulo, uhi)]
    else:
        trials = [np.zeros((T, 0))]
    for U in trials:
        _, _, q_, s_ = simulate(D.system, x, U)
        if np.all(np.isfinite(s_)):
            sq = tuple(int(i) for i in q_)
            seen.add(sq)
            cuts.append((tr.nogood(sq, M.nv), float(T - 1)))
            STATS["x_precuts"] = STATS.get("x_precuts", 0) + 1
            t, Us = _max_slack(D, sq, xs)
            if Us is None or t < -mu:
                STATS["cuts"] += 1
            else:
                seqs.append((sq, t, Us))
            break
    for setting in (0, 1):
        while True:
            sol = _solve(M, lo, hi, "x-sequences", times, cuts, setting)
            if sol is None:
                break
            sq = tr.modes(sol)
            if sq in seen:
                raise OracleError(f"x-sequences: the MILP returned the cut sequence {sq} again")
            seen.add(sq)
            cuts.append((tr.nogood(sq, M.nv), float(T - 1)))
            if len(cuts) > _MAX_CUTS:
                raise OracleError(f"x-sequences: more than {_MAX_CUTS} candidate sequences")
            t, Us = _max_slack(D, sq, xs)
            if Us is None or t < -mu:
                STATS["cuts"] += 1
                continue  # a candidate of the MILP's tolerance only
            if setting == 1:
                STATS["confirmations_that_found"] += 1
                STATS.setdefault("confirmations_by_kind", {}).setdefault("x-sequences", 0)
                STATS["confirmations_by_kind"]["x-sequences"] += 1
            seqs.append((sq, t, Us))
    return seqs


def _max_slack(D: _Data, seq0, xs):
    """Largest common slack of x's rows over U for fixed modes (LP), and its U (scaled)."""
    R, r, _, _ = _x_maps(D, seq0, xs)
    nu = R.shape[1]
    c = np.zeros(nu + 1)
    c[-1] = -1.0
    A = np.hstack([R, np.ones((R.shape[0], 1))])
    A = np.vstack([A, c[None, :] * -1.0])  # t <= 1
    b = np.concatenate([r, [1.0]])
    res = _lp(c, A, b, "max slack")
    if res.status == 2:
        return -np.inf, None
    return -res.fun, res.x[:nu]


def analyse_state(system, T: int, x, *, delta: float = DELTA, margin: float = MARGIN,
                  open_margin: float = OPEN_MARGIN, thr: float | None = None) -> Verdict:
    """Definition 2.2 at one state by MILPs and exact LPs; see the module docstring."""
    t_start = time.perf_counter()
    D = _data(system)
    x = np.asarray(x, float).reshape(D.n)
    xs = (x - D.centre[: D.n]) / D.half[: D.n]
    thr = delta * THR_FACTOR if thr is None else thr
    om = open_margin
    times: list = []
    counts: dict = {}

    def done(label, reason, allowed, **kw):
        return Verdict(label, reason, frozenset(allowed), n_milps=len(times), n_cuts=counts.get("cuts", 0),
                       seconds=time.perf_counter() - t_start, milp_seconds=times, **kw)

    # 1. x's own mode sequences (closed sets); which of them are feasible in the open sense.
    found = _x_sequences(D, T, x, xs, +margin, times)
    if not found:
        if _random_rollouts(D, x, T):
            raise OracleError(f"MILP says x = {x} is infeasible but a random input keeps it inside")
        return done("infeasible", "no U keeps x in the closed domain", {"infeasible"})
    closed_seqs, open_seqs = [], []
    for sq, t, Us in found:
        closed_seqs.append(sq)
        if t >= om:
            U = Us.reshape(T, D.m) * D.half[D.n:] + D.centre[D.n:]
            _verify(D, x, x, U, np.array(sq), np.array(sq), strict=True, margin=om, min_dist=0.0, what="open feasibility")
            open_seqs.append(sq)
    open_feasible = bool(open_seqs)

    def pair(seqs, mu, c, kind):
        for sq in seqs:
            M = _model_pair0(D, T, mu, sq)
            lo, hi, _ = _rhs_pair0(M, D, x, c, mu)

            def exact(found, prefer, sq=sq):
                r = _exact_pair(D, xs, sq, found[0], mu, c, prefer=prefer)
                return None if r is None else (r[0], found[0])

            r = _search(D, M, lo, hi, kind, times, exact, counts, precut=(tuple(sq),))
            if r is not None:
                theta, s1 = r
                xh = theta[: D.n] * D.half[: D.n] + D.centre[: D.n]
                Uw = theta[D.n:].reshape(T, D.m) * D.half[D.n:] + D.centre[D.n:]
                return xh, Uw, np.array(sq), np.array(s1)
        return None

    # 2. an indistinguishable x^ at >= thr, closed sets?
    r = pair(closed_seqs, +margin, thr, "pair-closed")
    if r is None:
        if open_feasible:
            return done("observable", f"no indistinguishable state at >= {thr:g} (closed sets)", {"observable"})
        return done("ambiguous", "x is feasible in the closed sense only, and no indistinguishable state at "
                    f">= {thr:g} exists (closed sets)", {"infeasible", "observable"})
    xhc, Uc, m0c, m1c = r
    dc = _verify(D, x, xhc, Uc, m0c, m1c, strict=False, margin=margin, min_dist=thr, what="closed pair")
    if not open_feasible:
        return done("ambiguous", f"x is feasible in the closed sense only; closed sets admit x^ at {dc:.3g}",
                    {"infeasible", "observable", "unobservable"}, x_hat=xhc, U=Uc, distance=dc)
    # 3. an indistinguishable x^ at >= delta, open sets?  First the pair of sequences just found.
    r = None
    if tuple(m0c) in open_seqs:
        e = _exact_pair(D, xs, tuple(m0c), tuple(m1c), -om, delta)
        if e is not None:
            theta = e[0]
            r = (theta[: D.n] * D.half[: D.n] + D.centre[: D.n],
                 theta[D.n:].reshape(T, D.m) * D.half[D.n:] + D.centre[D.n:], m0c, m1c)
    if r is None:
        r = pair(open_seqs, -om, delta, "pair-open")
    if r is None:
        return done("ambiguous", f"closed sets admit x^ at {dc:.3g} >= {thr:g}, open sets none at >= {delta:g}",
                    {"observable", "unobservable"}, x_hat=xhc, U=Uc, distance=dc)
    xho, Uo, m0o, m1o = r
    do = _verify(D, x, xho, Uo, m0o, m1o, strict=True, margin=om, min_dist=delta, what="open pair")
    return done("unobservable", f"verified witness at scaled distance {do:.3g}", {"unobservable"},
                x_hat=xho, U=Uo, distance=do)


def classify_state(system, T: int, x, **kw) -> str:
    """``"observable"``, ``"unobservable"``, ``"infeasible"`` or ``"ambiguous"`` (Definition 2.2)."""
    return analyse_state(system, T, x, **kw).label


def analyse_window(system, T: int, x, U, *, delta: float = DELTA, margin: float = MARGIN,
                   open_margin: float = OPEN_MARGIN, thr: float | None = None) -> Verdict:
    """Given ``x`` and one input sequence ``U`` (T, m): is there ``x^`` at scaled inf-distance
    ``>= delta`` with ``(x^, U)`` admissible and ``Y(x^, U) = Y(x, U)``?

    ``x``'s trajectory is simulated with the system's convention (first guard wins, closed guards
    relaxed by ``margin`` as a fallback); ``"infeasible"`` if it leaves the domain.  Then as
    :func:`analyse_state` with ``U`` fixed: ``"observable"`` if no ``x^`` at ``>= thr`` exists in the
    closed sense, ``"unobservable"`` if one at ``>= delta`` exists in the open sense (verified),
    ``"ambiguous"`` otherwise, and also when ``x``'s own trajectory passes within ``margin`` of a
    boundary between modes whose dynamics or outputs differ there (its data then depend on the
    convention).
    """
    t_start = time.perf_counter()
    D = _data(system)
    x = np.asarray(x, float).reshape(D.n)
    U = np.asarray(U, float).reshape(T, D.m)
    thr = delta * THR_FACTOR if thr is None else thr
    om = open_margin
    times: list = []
    counts: dict = {}

    def done(label, reason, allowed, **kw):
        return Verdict(label, reason, frozenset(allowed), n_milps=len(times), n_cuts=counts.get("cuts", 0),
                       seconds=time.perf_counter() - t_start, milp_seconds=times, **kw)

    X = np.empty((T + 1, D.n))
    X[0] = x
    Y = np.empty((T, D.p))
    convention_dependent = False
    seq_x = []  # x's own modes: the MILP's usual first (spurious) candidate for x^, tried exactly first
    for k in range(T):
        s = np.array([_slack(D, i, X[k], U[k]) for i in range(D.q)])
        near = np.nonzero(s >= -margin)[0]
        if near.size == 0:
            return done("infeasible", f"x's trajectory leaves the domain at step {k}", {"infeasible"})
        exact_in = np.nonzero(s >= 0.0)[0]
        i = int(exact_in[0]) if exact_in.size else int(near[np.argmax(s[near])])
        seq_x.append(i)
        A, B, a, C, Dm, c = D.raw[i]
        X[k + 1] = A @ X[k] + B @ U[k] + a
        Y[k] = C @ X[k] + Dm @ U[k] + c
        for j in near:
            if j != i:
                A2, B2, a2, C2, D2, c2 = D.raw[j]
                dx = np.max(np.abs(A2 @ X[k] + B2 @ U[k] + a2 - X[k + 1]) / D.half[: D.n])
                dy = np.max(np.abs(C2 @ X[k] + D2 @ U[k] + c2 - Y[k]) / D.ys)
                convention_dependent |= bool(max(dx, dy) > 1e-9)
    Us = (U - D.centre[D.n:]) / D.half[D.n:]
    Ys = Y / D.ys

    def window(mu, c, kind):
        M = _model(D, "window", T, mu, +margin)
        lo, hi, xs = _rhs(M, D, x, c)
        for k in range(T):
            if D.m:
                sl = M.slices[f"u{k}"]
                lo[sl] = hi[sl] = Us[k]
            sl = M.slices[f"y{k}"]
            lo[sl] = hi[sl] = Ys[k] * Y_WEIGHT

        def exact(seqs, prefer):
            r = _exact_pair(D, xs, None, seqs[0], mu, c, Us=Us, Y0=Ys, prefer=prefer, mu_input=+margin)
            return None if r is None else (r[0], seqs)

        r = _search(D, M, lo, hi, kind, times, exact, counts, precut=(tuple(seq_x),))
        if r is None:
            return None
        theta, (s1,) = r
        return theta[: D.n] * D.half[: D.n] + D.centre[: D.n], np.array(s1)

    r = window(+margin, thr, "window-closed")
    if r is None:
        if convention_dependent:
            return done("ambiguous", "x's own data depend on the boundary convention", {"observable", "unobservable"})
        return done("observable", f"no x^ at >= {thr:g} with these inputs (closed sets)", {"observable"})
    xhc, m1c = r
    dc = _verify(D, x, xhc, U, None, m1c, strict=False, margin=margin, min_dist=thr, what="closed window", Yx=Y)
    r = window(-om, delta, "window-open")
    if r is None:
        return done("ambiguous", f"closed sets admit x^ at {dc:.3g} >= {thr:g}, open sets none at >= {delta:g}",
                    {"observable", "unobservable"}, x_hat=xhc, U=U, distance=dc)
    xho, m1o = r
    do = _verify(D, x, xho, U, None, m1o, strict=True, margin=om, min_dist=delta, what="open window", Yx=Y)
    return done("unobservable", f"verified witness at scaled distance {do:.3g}", {"unobservable"},
                x_hat=xho, U=U, distance=do)


def classify_window(system, T: int, x, U, **kw) -> str:
    """``"observable"`` / ``"unobservable"`` / ``"ambiguous"`` (or ``"infeasible"``) for one window."""
    return analyse_window(system, T, x, U, **kw).label


def true_window_labels(system, T: int, X0, U_windows, **kw) -> np.ndarray:
    """:func:`classify_window` for many windows: ``X0`` (N, n), ``U_windows`` (N, T, m) -> (N,) labels."""
    X0 = np.atleast_2d(np.asarray(X0, float))
    Uw = np.asarray(U_windows, float).reshape(X0.shape[0], T, -1)
    return np.array([classify_window(system, T, x, U, **kw) for x, U in zip(X0, Uw)], dtype=object)


# ---------------------------------------------------------------------------------- cross-check
def pair_search_lp(system, T: int, x, c: float, mu: float, *, max_lps: int = 200_000):
    """A MILP-free answer to "is there an ``x^`` at scaled inf-distance ``>= c`` with equal outputs?"

    Depth-first search over joint mode prefixes ``(sigma(0..k), sigma^(0..k))`` of the two
    trajectories, for each of the ``2n`` signed directions: a prefix is extended only when its
    exact LP (equalities eliminated, region rows relaxed by ``mu``) reaches ``c``.  Slow (it
    enumerates), but it shares nothing with the MILPs.  Returns ``(x_hat, U, n_lps)``; ``x_hat``
    is None if no pair of sequences of length ``T`` works.
    """
    D = _data(system)
    n, m, q = D.n, D.m, D.q
    xs = (np.asarray(x, float) - D.centre[:n]) / D.half[:n]
    count = [0]

    def dfs(p0, p1, direction):
        if len(p0) == T:
            return p0, p1
        for i0 in range(q):
            for i1 in range(q):
                count[0] += 1
                if count[0] > max_lps:
                    raise OracleError("pair_search_lp: budget exhausted")
                a, b = p0 + (i0,), p1 + (i1,)
                if _exact_pair(D, xs, a, b, mu, c, only=direction) is not None:
                    found = dfs(a, b, direction)
                    if found is not None:
                        return found
        return None

    for d in range(n):
        for sg in (1.0, -1.0):
            found = dfs((), (), (d, sg))
            if found is not None:
                theta, _ = _exact_pair(D, xs, found[0], found[1], mu, c, only=(d, sg))
                xh = theta[:n] * D.half[:n] + D.centre[:n]
                U = theta[n:].reshape(T, m) * D.half[n:] + D.centre[n:]
                return xh, U, count[0]
    return None, None, count[0]

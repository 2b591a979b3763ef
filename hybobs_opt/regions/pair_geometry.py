"""The geometry of one pair set ``R_ij`` of Algorithm 3.1 (paper 002) on its output-equality subspace.

``R_ij = {(x, x^, U) : (x, U) in P_i, (x^, U) in P_j, equal outputs}`` is handled in scaled
coordinates ``w = (x, x^, U)`` restricted to the equality subspace ``w = w0 + N v``, with the
constraint rows of ``P_i`` and ``P_j`` unit-norm *before* the restriction.  The regions are
taken closed: a state on a guard that two modes share may follow either of them.  That is the
exact reading of Definition 2.2 for PWA maps that are continuous across their guards (the
powertrains' dead zone) and the safe, unobservable side for discontinuous ones.

Three questions decide whether ``Proj_x(R_ij)`` is a piece of ``B_T`` (up to measure zero):

1. **Is the closed set non-empty?**  A Chebyshev LP in the subspace; radius above
   ``-CLOSED_SET_TOL`` (the LPs' own accuracy: a set that needs its rows relaxed by more is
   empty).
2. **Is its projection on ``x`` full-dimensional?**  Face-confined sets -- a pair whose outputs
   can only agree when a trajectory sits exactly on a guard, e.g. ``theta(k) = -alpha`` -- have
   Chebyshev radius 0 in the equality subspace although their ``x``-projection can be
   full-dimensional (every ``x`` has an input sequence that steers it onto the guard).  Their
   affine hull is found from the LP's multipliers: rows with positive multipliers in a
   certificate of radius ``<= 0`` are tight on the whole set (implicit equalities), so they are
   added to the equalities and the LP is solved again in the smaller subspace, until the set
   has a ball of radius above ``REGION_SLACK_TOL`` in it.  The projection is then
   full-dimensional when the subspace's ``x``-part has rank ``n`` and the set is not certified
   thinner than ``2 REGION_SLACK_TOL`` along the direction the subspace pins down most.
3. **Does it hold two different states?**  A pair set in which the outputs force ``x^ = x``
   says nothing about observability (every state is indistinguishable from itself).  It is
   left out when the subspace forces ``x = x^`` or LPs certify ``|x - x^| <= DISTINCT_STATE_TOL``
   on the whole set (scaled).  Before this test, 2,522 of the 4,982 pair sets of model (16) at
   ``T = 7`` were such faces, and interior states were called unobservable.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..errors import SolverError
from ..geometry._lp_kernels import (implicit_row_bounds, max_abs_affine, min_row_slack, slack_lp_data, slack_lp_rows,
                                    support_upper_bound)
from ..geometry._reproducible import (affine_hull, dot, matmul as mm, nnls, norm, numerical_rank, span_width_bound,
                                      subspace_directions, svd)
from ..geometry.exact_lp import decide_above
from ..geometry.lp import certified_width_below, highs_lp, solve_slack_lp, verified_lp, width_proven_above
from ..status import Status
from ..tolerances import (
    BALL_WIDTH_RTOL,
    CLOSED_SET_TOL,
    DISTINCT_STATE_TOL,
    EQUALITY_CONSISTENCY_RTOL,
    EXACT_DECISION_MARGIN,
    HIGHS_DECISION_BAND,
    IMPLICIT_EQUALITY_RANK_RTOL,
    NEAR_ACTIVE_TOL,
    PAIR_LP_PRIMAL_TOL,
    RANK_RTOL,
    REGION_SLACK_TOL,
    SLACK_CAP,
    ZERO_ROW_TOL,
)
from .verdicts import PairVerdict


@dataclass(frozen=True)
class PairClassification:
    """What :func:`classify_pair` found for ``R_ij`` (``verdict``) and for ``R_ji`` (``verdict_ji``).

    A projection that was not asked for is :attr:`PairVerdict.EMPTY <hybobs_opt.regions.PairVerdict.EMPTY>`.
    ``radius`` is the Chebyshev radius of the set inside its affine hull (scaled); ``face`` is
    True when the hull is smaller than the equality subspace (implicit equalities were found).
    """

    verdict: PairVerdict
    verdict_ji: PairVerdict
    radius: float
    face: bool


#: Per process: pair LPs that DAQP decided only with the tight primal tolerance (instead of
#: HiGHS), and how many of them HiGHS could not solve at all (model 16, T = 8).
RESCUED = {"tight_daqp": 0, "highs_failed": 0}

#: DAQP settings of the last attempt before HiGHS (:func:`_slack_lp`): no proximal term, a
#: tight primal tolerance.
_TIGHT = {"primal_tol": PAIR_LP_PRIMAL_TOL}


def _slack_lp(A: np.ndarray, bu: np.ndarray, radius_bound: float, threshold: float, problem: str):
    """:func:`~hybobs_opt.geometry.lp.solve_slack_lp` with one more DAQP attempt before HiGHS.

    The DAQP attempts of ``solve_slack_lp`` run first, unchanged (same calls, same answers).
    When they do not decide ``threshold`` -- on a face of radius exactly 0, DAQP's default
    primal tolerance (1e-6) leaves rows violated by ~2e-7, more than ``CLOSED_SET_TOL``, so
    neither bound decides ``radius > -CLOSED_SET_TOL`` -- DAQP runs once more with a tight primal
    tolerance (``PAIR_LP_PRIMAL_TOL``) and no proximal term; its answer is used when it passes
    :func:`~hybobs_opt.geometry.lp.daqp_answer_ok` and its numpy-certified bounds
    (:func:`~hybobs_opt.geometry._lp_kernels.slack_bounds`) decide.  Only then HiGHS, as before
    (whose slack at its own point was used uncertified).  The answer is returned without
    multipliers, like HiGHS's, so the callers take the same path as with HiGHS's answer.

    This made three things possible: model (16) at ``T = 8``, where HiGHS returned "Not Set" /
    "Solve error" with all three of its methods on one such LP and the analysis stopped; a
    third of the time at ``T = 6`` of model (17) (398 of 9,130 pair LPs went to HiGHS); and
    correct answers where HiGHS's point was poor: its slack there is only a lower bound, yet it
    was used as the radius, and two face pairs of model (17) at ``T = 7`` (radius ~-1e-12) were
    called empty from a point at slack -3.4e-6.  One LP is counted per call, as
    ``solve_slack_lp`` does.
    """
    try:
        res = solve_slack_lp(A, bu, radius_bound, threshold, problem, tight_attempt=_TIGHT)
    except SolverError:
        RESCUED["highs_failed"] += 1
        raise
    if res.solver == "daqp (tight)":
        RESCUED["tight_daqp"] += 1
    return res


@dataclass(frozen=True, slots=True)
class _Chebyshev:
    """A certified Chebyshev LP of ``{Gs s <= gs}`` (:func:`_chebyshev`).

    ``radius``: decided against the LP's threshold, ``-inf`` when a constant row is violated;
    ``centre``: the LP's point; ``A, bu``: the DAQP data; ``lam``: its multipliers (``None`` if
    HiGHS answered); ``keep``: the indices of the rows kept in ``A``; ``witnessed``: the point
    is known to be a point of the closed set (what :func:`_witness` checks), because the LP's
    certified lower bound is its smallest row slack and lies above ``-CLOSED_SET_TOL``.
    """

    radius: float
    centre: np.ndarray | None
    A: np.ndarray
    bu: np.ndarray
    lam: np.ndarray | None
    keep: np.ndarray | None
    witnessed: bool = False


#: Solvers whose ``lower`` is ``min(SLACK_CAP, smallest row slack at w)``, computed at ``w`` itself
#: (:func:`~hybobs_opt.geometry._lp_kernels.slack_bounds`): not HiGHS's, nor an exact re-decision's.
_LOWER_AT_POINT = frozenset({"daqp", "daqp+nnls"})


def _chebyshev(Gs: np.ndarray, gs: np.ndarray, radius_bound: float, threshold: float, problem: str) -> _Chebyshev:
    """Certified Chebyshev LP of ``{Gs s <= gs}`` (rows renormalised, constant rows checked)."""
    A, bu, ok, keep = slack_lp_rows(Gs, gs, ZERO_ROW_TOL, SLACK_CAP)
    if not ok:
        return _Chebyshev(-np.inf, None, A, bu, None, None)
    if A.shape[0] == 1:
        return _Chebyshev(SLACK_CAP, np.zeros(Gs.shape[1]), A, bu, None, keep)
    res = _slack_lp(A, bu, radius_bound, threshold, problem)
    radius = res.lower if res.lower > threshold else res.upper
    # lower = min(SLACK_CAP, the smallest row slack at the point), and SLACK_CAP > 0: above
    # -CLOSED_SET_TOL, the point is in the closed set (no second pass over the rows)
    return _Chebyshev(radius, res.w, A, bu, res.lam, keep, res.solver in _LOWER_AT_POINT and bool(res.lower > -CLOSED_SET_TOL))


def _witness(centre, A: np.ndarray, bu: np.ndarray):
    """``centre`` when it is a point of the closed set ``{A[:-1, :-1] v <= bu[:-1]}`` (to
    CLOSED_SET_TOL), else ``None``: the frame tests use it as a witness (distinct states, widths),
    so a solver's point is checked before it stands for the set."""
    if centre is None or A.shape[0] <= 1:
        return centre
    c = np.asarray(centre, dtype=float)
    if c.shape != (A.shape[1] - 1,) or not np.all(np.isfinite(c)):
        return None
    return c if min_row_slack(A, bu, np.ascontiguousarray(c)) > -CLOSED_SET_TOL else None


def _affine_reduce(Gs: np.ndarray, gs: np.ndarray, lp: _Chebyshev, radius_bound: float, tight: dict | None = None):
    """The implicit equalities certified by the multipliers of a radius-``<= 0`` Chebyshev LP.

    ``lp`` is what :func:`_chebyshev` returned for ``{Gs s <= gs}``.
    Returns ``(M, t0)`` with the affine hull within the current frame ``s = t0 + M t``,
    :attr:`PairVerdict.EMPTY` when the equalities found contradict each other, or ``None`` when no implicit
    equality is certified (the caller then keeps the set: the safe side).  With a dict
    ``tight``, the certified rows (indices into ``A``) and their slack bounds are stored in it
    as ``tight["rows"]``, ``tight["slack"]`` (see :func:`_certified_implicit_rows`).
    """
    A, bu, lam, keep, centre = lp.A, lp.bu, lp.lam, lp.keep, lp.centre
    if keep is None or A.shape[0] <= 1:
        return None
    d = Gs.shape[1]
    G, g = A[:-1, :d], bu[:-1]
    K = np.zeros(0, dtype=int)
    if lam is not None and np.all(np.isfinite(lam)):
        K, beta = _certified_implicit_rows(G, g, np.asarray(lam, dtype=float)[:-1], radius_bound, with_bounds=True)
    if K.size == 0 and centre is not None and np.all(np.isfinite(centre)):
        # DAQP's proximal multipliers too coarse (or HiGHS answered): refit them on the active rows
        resid = g - mm(G, centre)
        active = np.nonzero(resid <= float(np.min(resid)) + NEAR_ACTIVE_TOL)[0]
        lam_fit = _nnls_multipliers(G[active])
        if lam_fit is not None:
            full = np.zeros(G.shape[0])
            full[active] = lam_fit
            K, beta = _certified_implicit_rows(G, g, full, radius_bound, with_bounds=True)
    if K.size == 0 and centre is not None and np.all(np.isfinite(centre)) and \
            float(np.min(g - mm(G, centre), initial=np.inf)) <= 0.0:
        # No ball around the LP's point, so the set has implicit equalities, yet neither DAQP's
        # multipliers nor their refit certify one (model 17, T = 9: 4 faces of radius ~-1e-12,
        # then kept whole and listed as pieces although 2-dimensional): HiGHS's basic dual, once.
        K, beta = _highs_implicit_rows(G, g, A, bu, radius_bound)
    if K.size == 0:
        return None
    if tight is not None:
        tight["rows"], tight["slack"] = K, beta
    # Two tight rows with opposite normals pin one direction, not two: their normals differ by
    # rounding (1e-8), and that sliver of a singular value pins nothing (see the tolerance).
    hull = affine_hull(Gs[keep[K]], gs[keep[K]], IMPLICIT_EQUALITY_RANK_RTOL, EQUALITY_CONSISTENCY_RTOL, CLOSED_SET_TOL)
    return PairVerdict.EMPTY if hull == "empty" else hull


def _highs_implicit_rows(G: np.ndarray, g: np.ndarray, A: np.ndarray, bu: np.ndarray, radius_bound: float):
    """:func:`_certified_implicit_rows` from the duals of the Chebyshev LP ``(A, bu)`` solved by HiGHS
    (a basic solution: its multipliers sit on the rows that are tight), counted as one LP."""
    f = np.zeros(A.shape[1])
    f[-1] = -1.0
    try:
        res = highs_lp(f, A, bu, problem="implicit equalities of a face (HiGHS duals)")
    except SolverError:
        return np.zeros(0, dtype=int), np.zeros(0)
    if res.status != Status.OPTIMAL or res.duals is None or np.asarray(res.duals).shape != (A.shape[0],):
        return np.zeros(0, dtype=int), np.zeros(0)
    return _certified_implicit_rows(G, g, np.asarray(res.duals, dtype=float)[:-1], radius_bound, with_bounds=True)


def _certified_implicit_rows(G: np.ndarray, g: np.ndarray, lam: np.ndarray, radius_bound: float,
                             with_bounds: bool = False):
    """Rows certified by the multipliers ``lam >= 0`` to be tight on the whole set ``{G v <= g}``.

    For every feasible ``v`` (``|v| <= R``): ``sum_k lam_k (g_k - G_k v) <= lam'g + R |G'lam|``
    and every term is non-negative, so the slack of row ``k`` is at most
    ``(lam'g + R |G'lam|) / lam_k``.  Rows where that bound is below ``REGION_SLACK_TOL`` are
    implicit equalities to the region tolerance; no other row is taken.  ``g`` is relaxed by
    ``CLOSED_SET_TOL`` first, the closed set the pair tests decide.  With ``with_bounds``,
    returns ``(rows, bounds)``: the slack bound of each certified row as well.
    """
    # the set reasoned about is the closed one relaxed by CLOSED_SET_TOL (non-empty by the LP
    # that produced lam): an exactly empty set would make every row "tight" vacuously
    bound = implicit_row_bounds(np.ascontiguousarray(G, dtype=float), np.ascontiguousarray(g, dtype=float),
                                np.ascontiguousarray(lam, dtype=float), float(radius_bound), CLOSED_SET_TOL)
    rows = np.nonzero(bound <= REGION_SLACK_TOL)[0]
    return (rows, bound[rows]) if with_bounds else rows


def _tight_width_bound(G: np.ndarray, rows: np.ndarray, slack: np.ndarray, c: np.ndarray, radius_bound: float) -> float:
    """Upper bound on the width ``max c'v - min c'v`` over ``{G v <= g + CLOSED_SET_TOL, |v| <= R}``, no LP.

    ``rows`` are rows certified by :func:`_certified_implicit_rows` on that very set, with
    ``0 <= g_k + CLOSED_SET_TOL - G_k v <= slack_k`` for every point ``v`` of it: each ``G_k v``
    ranges over an interval of length ``slack_k``.  Writing ``c = G_rows' alpha + rho`` (least
    squares), ``c'v = alpha' G_rows v + rho'v`` ranges over at most
    ``sum_k |alpha_k| slack_k + 2 R |rho|`` (Cauchy-Schwarz on the residual).  This proves the
    same statement as the two LPs of :func:`~hybobs_opt.geometry.lp.certified_width_below` when
    ``c`` lies in the span of the implicit equalities just found (the flat direction of a face
    of ``R_ij``: half of the pair LPs of model 17 at ``T = 6`` are such width LPs).
    """
    return span_width_bound(G, rows, slack, c, radius_bound)


def _nnls_multipliers(GA: np.ndarray) -> np.ndarray | None:
    """``lam >= 0``, ``sum lam = 1`` minimising ``|GA' lam|`` (non-negative least squares)."""
    M = np.vstack([GA.T, np.ones((1, GA.shape[0]))])
    rhs = np.zeros(M.shape[0])
    rhs[-1] = 1.0
    try:
        lam, _ = nnls(M, rhs)
    except RuntimeError:
        return None
    return lam if lam.sum() > 0 else None


def _max_abs_certified_below(Gs: np.ndarray, gs: np.ndarray, c: np.ndarray, c0: float, bound: float,
                             radius_bound: float) -> bool:
    """Is ``|c's + c0| <= bound`` certified on ``{Gs s <= gs}`` (two LPs and their multipliers)?

    Each LP is DAQP's when its answer verifies in numpy, HiGHS's otherwise (:func:`verified_lp`).
    A bound within ``EXACT_DECISION_MARGIN`` of ``bound`` is re-decided in rational arithmetic
    (:func:`~hybobs_opt.geometry.exact_lp.decide_above`); undecided, the answer is "not certified".
    """
    for sign in (1.0, -1.0):
        ans = verified_lp(-sign * c, Gs, gs, problem="distinct-state LP")
        if ans.status != Status.OPTIMAL:
            return False
        v = ans.x
        if sign * (mm(c, v) + c0) > bound + EXACT_DECISION_MARGIN and np.all(mm(Gs, v) <= gs + CLOSED_SET_TOL):
            return False  # a (nearly) feasible point already has the two states apart
        top = support_upper_bound(Gs, gs, sign * c, np.ascontiguousarray(ans.duals, dtype=float), radius_bound) + sign * c0
        if top > bound + EXACT_DECISION_MARGIN:
            return False
        if top > bound - EXACT_DECISION_MARGIN and decide_above(sign * c, Gs, gs, v, bound - sign * c0, maximise=True, duals=ans.duals) is not False:
            return False  # above, or undecided: not certified
    return True


@dataclass(frozen=True)
class SubspaceDirections:
    """What a basis ``N`` of an affine frame says before any LP (the same for every region pair of a class).

    ``full_rank[k]``: the projection of the frame on ``x`` (``k = 0``) or ``x^`` (``k = 1``) has
    rank ``n``; ``thinnest[k]``: the functional ``c`` on the frame's coordinates along which
    that projection of a unit ball is thinnest; ``same_state_directions``: the frame moves ``x``
    and ``x^`` together (``N_x = N_x^``).

    With the equalities ``E`` whose nullspace ``N`` spans (and their numerical rank), the last
    is a rank test: the rows ``x - x^`` lie in the row space of ``E`` when appending them leaves
    the rank unchanged.  That decision does not depend on how accurately ``N`` was computed:
    with an equality of singular value 1e-7 (the PWA piston), ``|N_x - N_x^|`` is about
    ``eps / 1e-7`` in LAPACK's basis and 1e-16 in the Jacobi one, on either side of
    ``RANK_RTOL``, while the ranks agree.
    """

    full_rank: tuple[bool, bool]
    thinnest: tuple[np.ndarray, np.ndarray]
    same_state_directions: bool
    #: ``|thinnest[k]|`` (ordered sums), and ``N_x - N_x^`` (how the frame moves the two states apart)
    thinnest_norm: tuple[float, float] = (0.0, 0.0)
    state_difference: np.ndarray | None = None

    @staticmethod
    def of(N: np.ndarray, n: int, equalities: tuple[np.ndarray, int] | None = None) -> "SubspaceDirections":
        fast = subspace_directions(N, n, RANK_RTOL) if equalities is None else None
        if fast is not None:  # one compiled call, the same bits
            full_k, thin_k, thin_norm, D = fast
            same = bool(np.max(np.abs(D), initial=0.0) <= RANK_RTOL)
            return SubspaceDirections((bool(full_k[0]), bool(full_k[1])), (thin_k[0], thin_k[1]), same,
                                      (float(thin_norm[0]), float(thin_norm[1])), D)
        full, thin = [], []
        for part in (slice(0, n), slice(n, 2 * n)):
            P = N[part]
            if P.shape[1] < n:
                full.append(False)
                thin.append(np.zeros(P.shape[1]))
                continue
            Uu, sv, _ = svd(P)
            full.append(bool(sv[-1] > RANK_RTOL))
            thin.append(mm(P.T, Uu[:, -1]))
        if equalities is None:
            same = bool(np.max(np.abs(N[:n] - N[n:2 * n]), initial=0.0) <= RANK_RTOL)
        else:
            E, rank = equalities
            J = np.zeros((n, E.shape[1]))
            J[:, :n], J[:, n:2 * n] = np.eye(n), -np.eye(n)
            same = numerical_rank(svd(np.vstack([E, J]), compute_uv=False), RANK_RTOL) == rank
        return SubspaceDirections((full[0], full[1]), (thin[0], thin[1]), same, (norm(thin[0]), norm(thin[1])),
                                  N[:n] - N[n:2 * n])


class _Frame:
    """An affine frame ``v = s0 + M s`` of the pair set (inside its equality subspace) and its tests."""

    def __init__(self, Gv, gv, N, w0, M, s0, n: int, radius_bound: float, directions: "SubspaceDirections | None" = None,
                 products: tuple | None = None):
        # products: (Gv M, gv - Gv s0, N M) when the caller has them
        self.n, self.R = n, radius_bound
        self.M, self.s0 = M, s0
        if M is None:
            self.Nh, self.wh = N, w0
            self.Gs, self.gs = Gv, gv
        else:
            self.Gs, self.gs, self.Nh = products or (mm(Gv, M), gv - mm(Gv, s0), mm(N, M))
            self.wh = w0 + mm(N, s0)
        self.dim = self.Nh.shape[1]
        self.directions = directions or SubspaceDirections.of(self.Nh, n)
        self._lp = None
        self.centre = None
        #: A certified inner radius of the set in this frame (a ball of it lies in the set), 0 if unknown.
        self.ball = 0.0

    @property
    def lp(self):
        if self._lp is None:
            self._lp = slack_lp_data(self.Gs, self.gs, ZERO_ROW_TOL, SLACK_CAP)[:2]
        return self._lp

    def forces_same_state(self) -> bool:
        """Does the frame itself force ``x = x^`` (to ``DISTINCT_STATE_TOL``)?"""
        n = self.n
        return bool(self.directions.same_state_directions
                    and np.max(np.abs(self.wh[:n] - self.wh[n:2 * n])) <= DISTINCT_STATE_TOL)

    def projection_thin(self, part: int, thin_filter: bool) -> bool:
        """Is the projection on ``x`` (``part = 0``) or ``x^`` (``1``) of the set in this frame lower-dimensional or thin?"""
        if not self.directions.full_rank[part]:
            return True
        A, bu = self.lp
        if not thin_filter or A.shape[0] <= 1:
            return False
        c = self.directions.thinnest[part]
        if self.ball * self.directions.thinnest_norm[part] > REGION_SLACK_TOL * (1.0 + BALL_WIDTH_RTOL):
            # a ball of radius `ball` lies in the set, so its width along c is at least
            # 2 ball |c| > 2 REGION_SLACK_TOL: the width LPs could not certify thinness (no LP)
            return False
        point = self.centre if self.centre is not None and self.centre.size == self.dim else None
        return certified_width_below(A[:-1, :-1], bu[:-1], c, radius_bound=self.R, width=2.0 * REGION_SLACK_TOL, point=point)

    def distinct_states(self) -> bool:
        """Does the set hold a point with ``|x - x^| > DISTINCT_STATE_TOL`` (else certified not)?"""
        n = self.n
        Dm = self.directions.state_difference
        d0 = self.wh[:n] - self.wh[n:2 * n]
        if self.directions.same_state_directions:
            return bool(np.max(np.abs(d0)) > DISTINCT_STATE_TOL)
        if self.centre is not None and self.centre.size == self.dim and \
                max_abs_affine(Dm, np.ascontiguousarray(self.centre, dtype=float), d0) > DISTINCT_STATE_TOL:
            return True
        A, bu = self.lp
        if A.shape[0] <= 1:
            return True  # nothing bounds the frame's directions: the states can differ
        G, g = np.ascontiguousarray(A[:-1, :-1]), bu[:-1]  # one layout for the kernels (see certified_width_below)
        return any(not _max_abs_certified_below(G, g, np.ascontiguousarray(Dm[k]), float(d0[k]), DISTINCT_STATE_TOL, self.R)
                   for k in range(n) if np.max(np.abs(Dm[k])) > RANK_RTOL or abs(d0[k]) > DISTINCT_STATE_TOL)


def classify_pair(Gv: np.ndarray, gv: np.ndarray, N: np.ndarray, w0: np.ndarray, n: int, radius_bound: float,
                  want_ij: bool, want_ji: bool, thin_filter: bool = True, problem: str = "R_ij",
                  directions: SubspaceDirections | None = None) -> PairClassification:
    """Questions 1-3 of the module docstring for one pair set on its equality subspace.

    Parameters
    ----------
    Gv, gv
        ``Gv v <= gv``: the rows of ``P_i`` and ``P_j`` (unit-norm in the scaled ``w`` space)
        restricted to ``w = w0 + N v``.
    N, w0
        Orthonormal basis of the equality subspace and a particular solution (scaled ``w``).
    n
        Number of states: ``w = (x, x^, U)`` with ``x = w[:n]``, ``x^ = w[n:2n]``.
    radius_bound
        Bound on ``|v|`` over the set (for the multiplier certificates).
    want_ij, want_ji
        Which of ``R_ij`` (the projection on ``x``) and ``R_ji`` (on ``x^``) is asked for.
    thin_filter
        Apply the thin-projection test of question 2.
    directions
        :meth:`SubspaceDirections.of` ``(N, n)``, if the caller has it cached.

    Notes
    -----
    The tests that only ever shrink with the affine hull run first, in the equality subspace
    (``x = x^`` forced by the outputs, before any LP; a thin projection), so that only the
    pairs that survive them pay for the hull.  A pair whose outputs force ``x^ = x`` is
    reported as such without deciding whether it is empty.
    """
    parts = [k if want else None for k, want in enumerate((want_ij, want_ji))]
    frame = _Frame(Gv, gv, N, w0, None, None, n, radius_bound, directions)
    if frame.forces_same_state():
        return PairClassification(*[PairVerdict.EMPTY if p is None else PairVerdict.SAME_STATE for p in parts], np.nan, False)
    # -- 1. non-empty (closed, to the region tolerance)?
    lp = _chebyshev(Gv, gv, radius_bound, -CLOSED_SET_TOL, problem)
    if lp.radius <= -CLOSED_SET_TOL:
        return PairClassification(PairVerdict.EMPTY, PairVerdict.EMPTY, lp.radius, False)
    # -- 2. full-dimensional projections: what the equality subspace already decides
    verdicts = _screen_in_subspace(frame, lp, parts, thin_filter)
    if all(v for v in verdicts):
        return PairClassification(*verdicts, lp.radius, False)
    if lp.radius > REGION_SLACK_TOL:  # a ball in the equality subspace: only question 3 is left
        verdicts = _decide_remaining(frame, parts, verdicts, thin_filter, None)
        return PairClassification(verdicts[0], verdicts[1], float(lp.radius), False)
    # a face: add implicit equalities until the set has a ball in its frame (the multipliers of
    # the LP above serve the first reduction: it is the same LP)
    certifier = _ThinCertifier(N, n, radius_bound, lp)
    hull = _reduce_to_hull(Gv, gv, N, radius_bound, problem, lp, parts, verdicts, certifier)
    if isinstance(hull, PairClassification):
        return hull
    frame = hull.frame(Gv, gv, N, w0, n, radius_bound)
    if frame.forces_same_state():
        return PairClassification(*[v or PairVerdict.SAME_STATE for v in verdicts], hull.lp.radius, True)
    # -- 3. (and 2. in the final frame) for the projections still undecided
    verdicts = _decide_remaining(frame, parts, verdicts, thin_filter, certifier)
    return PairClassification(verdicts[0], verdicts[1], float(hull.lp.radius), True)


def _screen_in_subspace(frame: _Frame, lp: _Chebyshev, parts: list, thin_filter: bool) -> list[PairVerdict | None]:
    """Question 2 in the equality subspace, after the Chebyshev LP ``lp`` found the set non-empty.

    With a ball (radius above ``REGION_SLACK_TOL``) each wanted projection gets the thin test; on
    a face only the rank one, since a projection flat in the subspace is flat in any smaller hull.
    Returns the verdicts: ``EMPTY`` for a projection not wanted, ``None`` for one undecided.
    """
    frame.centre = lp.centre if lp.witnessed else _witness(lp.centre, lp.A, lp.bu)
    frame._lp = (lp.A, lp.bu)
    verdicts: list[PairVerdict | None] = [PairVerdict.EMPTY if p is None else None for p in parts]
    if lp.radius > REGION_SLACK_TOL:
        frame.ball = float(lp.radius)  # above the LP's threshold: the certified lower bound (a feasible ball)
        for k, p in enumerate(parts):
            if p is not None and frame.projection_thin(p, thin_filter):
                verdicts[k] = PairVerdict.LOWER_DIMENSIONAL
    else:
        for k, p in enumerate(parts):
            if p is not None and not frame.directions.full_rank[p]:
                verdicts[k] = PairVerdict.LOWER_DIMENSIONAL
    return verdicts


class _ThinCertifier:
    """Confirms on the original pair set that a projection a frame flattens is thin (question 2 on a face).

    What the certificates are measured on is fixed by the first Chebyshev LP ``lp``: its set
    relaxed by ``CLOSED_SET_TOL`` and the implicit equalities its multipliers certify
    (``tight``, filled by the first :func:`_affine_reduce`).  The projections found thin and
    the flat directions already measured are remembered across the frames.
    """

    def __init__(self, N: np.ndarray, n: int, radius_bound: float, lp: _Chebyshev):
        self.N, self.n, self.R = N, n, radius_bound
        A, bu = lp.A, lp.bu
        self.relaxed = (np.ascontiguousarray(A[:-1, :-1]), np.ascontiguousarray(bu[:-1] + CLOSED_SET_TOL)) if A.shape[0] > 1 else None
        #: the first LP's point, where the walks of a width test start (inside the relaxed set, as a rule)
        self.point = lp.centre if lp.centre is not None and np.shape(lp.centre) == (A.shape[1] - 1,) else None
        self.thin_found: set[int] = set()  # projections certified thin (a fact about the set, whatever the frame)
        self.tried: dict[int, list[np.ndarray]] = {}  # flat directions already measured, per projection
        self.tight: dict = {}  # the implicit equalities certified by the first LP, on the set `relaxed`

    def confirmed_thin(self, p: int, NM: np.ndarray) -> bool:
        """Does the frame ``NM`` flatten projection ``p``, and is the original set certified thin there?

        Every flat direction of the frame's projection not measured before is tried, thinnest first,
        until one is certified.  The frames only shrink, so their flat spaces only grow: a direction
        that was too wide stays flat and too wide, while the new ones may be thin (model 17, T = 9:
        five pairs whose first flat direction was 2.2e-6 to 4.2e-6 wide on the relaxed set, and
        whose final hull had three flat directions, were called pieces when only the first one was
        tried; an independent LP oracle, scripts/check_t9_pair_lists.py, found them 2-dimensional).
        """
        if p in self.thin_found:
            return True
        n = self.n
        P = NM[p * n:(p + 1) * n]
        if P.shape[1] == 0:
            Uu, flat = np.eye(n), list(range(n))
        else:
            Uu, sv, _ = svd(P)
            flat = [k for k in range(n - 1, -1, -1) if k >= sv.size or sv[k] <= RANK_RTOL]
        if not flat:
            return False
        seen = self.tried.setdefault(p, [])
        for k in flat:
            u = Uu[:, k]
            if any(abs(dot(u, v)) >= 1.0 - RANK_RTOL for v in seen):
                continue
            seen.append(u)
            if self._width_certified(mm(self.N[p * n:(p + 1) * n].T, u)):  # u'x in the coordinates of the first LP
                self.thin_found.add(p)
                return True
        return False

    def _width_certified(self, c: np.ndarray) -> bool:
        """Is the relaxed set certified thinner than ``2 REGION_SLACK_TOL`` along ``c``?"""
        if self.relaxed is None:
            return False
        if "rows" in self.tight and _tight_width_bound(self.relaxed[0], self.tight["rows"], self.tight["slack"], c, self.R) \
                <= 2.0 * REGION_SLACK_TOL - EXACT_DECISION_MARGIN:
            return True  # certified by the first LP's multipliers, no width LP (see _tight_width_bound)
        if self.point is not None and width_proven_above(self.relaxed[0], self.relaxed[1], c, self.point, 2.0 * REGION_SLACK_TOL):
            return False  # two points of the relaxed set are proven farther apart: no width LP
        return certified_width_below(self.relaxed[0], self.relaxed[1], c, radius_bound=self.R, width=2.0 * REGION_SLACK_TOL)


@dataclass(frozen=True, slots=True)
class _Hull:
    """The frame ``v = s0 + M s`` that :func:`_reduce_to_hull` reached, and the last Chebyshev LP in it."""

    M: np.ndarray
    s0: np.ndarray
    lp: _Chebyshev
    #: ``(Gv M, gv - Gv s0, N M, radius bound in the frame)`` when the reduction computed them
    products: tuple | None = None

    def frame(self, Gv, gv, N, w0, n: int, radius_bound: float) -> _Frame:
        """The :class:`_Frame` of the hull, with the LP's point as its witness and its ball when certified."""
        if self.products is None:
            frame = _Frame(Gv, gv, N, w0, self.M, self.s0, n, radius_bound + norm(self.s0))
        else:
            frame = _Frame(Gv, gv, N, w0, self.M, self.s0, n, self.products[3], products=self.products[:3])
        centre = self.lp.centre
        frame.centre = _witness(centre, self.lp.A, self.lp.bu) if centre is not None and centre.size else centre
        if self.lp.radius > REGION_SLACK_TOL:  # the LP's threshold: then it is its certified lower bound
            frame.ball = float(self.lp.radius)
        return frame


def _reduce_to_hull(Gv: np.ndarray, gv: np.ndarray, N: np.ndarray, radius_bound: float, problem: str, lp: _Chebyshev,
                    parts: list, verdicts: list, certifier: _ThinCertifier) -> "_Hull | PairClassification":
    """The affine hull of a face (question 2): implicit equalities added until the set has a ball in its frame.

    Each frame's implicit equalities come from its Chebyshev LP's multipliers (:func:`_affine_reduce`,
    the first from ``lp``).  The hull only shrinks, so a wanted projection that loses rank on the way
    is lower-dimensional, which ``certifier`` confirms on the original set (the reduction only
    proposes); ``verdicts`` is updated in place.  Returns the hull, or the classification when it is
    decided on the way (empty, or every wanted projection thin).
    """
    M, s0 = np.eye(Gv.shape[1]), np.zeros(Gv.shape[1])
    products = None  # (Gv M, gv - Gv s0, N M, R + |s0|) of the current frame after the first
    for step in range(Gv.shape[1]):
        if lp.radius > REGION_SLACK_TOL:
            break
        # |s| <= |v - s0| <= R + |s0| in the frame's coordinates s (v = s0 + M s); in the first
        # frame (M = I, s0 = 0) the ordered products are Gv + 0.0 and 0, bit for bit, without the sums
        if step == 0:
            red = _affine_reduce(Gv + 0.0, gv - 0.0, lp, radius_bound + 0.0, tight=certifier.tight)
        else:
            red = _affine_reduce(products[0], products[1], lp, products[3])
        if red is None:  # the implicit equalities are not certified: keep the frame (safe side)
            break
        if red is PairVerdict.EMPTY:
            return PairClassification(PairVerdict.EMPTY, PairVerdict.EMPTY, -np.inf, True)
        M2, t0 = red
        s0, M = (s0 + mm(M, t0), mm(M, M2)) if step else (t0 + 0.0, M2 + 0.0)  # M = I, s0 = 0: the same bits
        NM = mm(N, M)
        for k, p in enumerate(parts):
            if p is not None and not verdicts[k] and certifier.confirmed_thin(p, NM):
                verdicts[k] = PairVerdict.LOWER_DIMENSIONAL
        if all(v for v in verdicts):
            return PairClassification(*verdicts, lp.radius, True)
        products = (mm(Gv, M), gv - mm(Gv, s0), NM, radius_bound + norm(s0))
        if M.shape[1] == 0:
            if np.min(products[1], initial=np.inf) < -CLOSED_SET_TOL:
                return PairClassification(PairVerdict.EMPTY, PairVerdict.EMPTY, -np.inf, True)
            lp = replace(lp, radius=0.0, centre=np.zeros(0))
            break
        lp = _chebyshev(products[0], products[1], products[3], REGION_SLACK_TOL, problem + " (affine hull)")
        if lp.radius == -np.inf:
            return PairClassification(PairVerdict.EMPTY, PairVerdict.EMPTY, -np.inf, True)
    return _Hull(M, s0, lp, products)


def _decide_remaining(frame: _Frame, parts: list, verdicts: list, thin_filter: bool,
                      certifier: _ThinCertifier | None) -> list:
    """The projections still undecided: question 2 in ``frame`` when it is a face's hull (``certifier``
    given), then question 3, ``PIECE`` when the set holds two different states, else ``SAME_STATE``."""
    distinct = None
    for k, p in enumerate(parts):
        if verdicts[k]:
            continue
        if certifier is not None and (certifier.confirmed_thin(p, frame.Nh) if not frame.directions.full_rank[p]
                                      else frame.projection_thin(p, thin_filter)):
            verdicts[k] = PairVerdict.LOWER_DIMENSIONAL
            continue
        if distinct is None:
            distinct = frame.distinct_states()
        verdicts[k] = PairVerdict.PIECE if distinct else PairVerdict.SAME_STATE
    return verdicts


def fixed_state_witness(Gv: np.ndarray, gv: np.ndarray, N: np.ndarray, w0: np.ndarray, x_scaled_offset: np.ndarray,
                        n: int, radius_bound: float, problem: str) -> bool:
    """Is there a point of the closed slice ``{v : Gv v <= gv}`` whose state ``x^`` differs from ``x``?

    For the point query: ``w = (x^, U) = w0 + N v`` in scaled coordinates, ``x_scaled_offset``
    the fixed state in the same coordinates.  Rows may be violated by ``CLOSED_SET_TOL`` (the
    closed set to the LPs' accuracy).  "Differs" means by more than ``DISTINCT_STATE_TOL`` in
    one coordinate.  Two LPs per state coordinate at most; DAQP with certified bounds, HiGHS
    when they do not decide.
    """
    A, bu, ok = slack_lp_data(Gv, gv, ZERO_ROW_TOL, SLACK_CAP)
    if not ok:
        return False
    if A.shape[0] > 1:
        res = _slack_lp(A, bu, radius_bound, -CLOSED_SET_TOL, problem)
        if res.lower <= -CLOSED_SET_TOL:
            return False
    Gr, gr = np.ascontiguousarray(A[:-1, :-1]), bu[:-1] + CLOSED_SET_TOL  # one layout for the kernels
    Dm = N[:n]
    d0 = w0[:n] - x_scaled_offset
    if Gr.shape[0] == 0:
        return bool(np.max(np.abs(Dm), initial=0.0) > RANK_RTOL or np.max(np.abs(d0)) > DISTINCT_STATE_TOL)
    for k in range(n):
        c = np.ascontiguousarray(Dm[k])
        if np.max(np.abs(c)) <= RANK_RTOL:
            if abs(d0[k]) > DISTINCT_STATE_TOL:
                return True
            continue
        for sign in (1.0, -1.0):
            # DAQP when its answer verifies in numpy (and its bound decides), else HiGHS (checked)
            ans = verified_lp(-sign * c, Gr, gr, problem=problem + " (distinct state)")
            if ans.status == Status.OPTIMAL and ans.solver == "daqp":
                v = ans.x
                if sign * (mm(c, v) + d0[k]) > DISTINCT_STATE_TOL + EXACT_DECISION_MARGIN and np.all(mm(Gr, v) <= gr + CLOSED_SET_TOL):
                    return True
                top = support_upper_bound(Gr, gr, sign * c, np.ascontiguousarray(ans.duals, dtype=float), radius_bound) + sign * d0[k]
                if top <= DISTINCT_STATE_TOL - EXACT_DECISION_MARGIN:
                    continue
                if top <= DISTINCT_STATE_TOL + EXACT_DECISION_MARGIN:  # too close for floats: exactly
                    above = decide_above(sign * c, Gr, gr, v, DISTINCT_STATE_TOL - sign * d0[k], maximise=True, duals=ans.duals)
                    if above is False:
                        continue
                    return True  # above, or undecided (the unobservable side)
                ans = highs_lp(-sign * c, Gr, gr, problem=problem + " (distinct state)", replaces_fast=True)
            if ans.status == Status.OPTIMAL:
                value = sign * (mm(c, ans.x) + d0[k])
                if abs(value - DISTINCT_STATE_TOL) <= HIGHS_DECISION_BAND:  # HiGHS's point: too close, exactly
                    if decide_above(sign * c, Gr, gr, ans.x, DISTINCT_STATE_TOL - sign * d0[k], maximise=True, duals=ans.duals) is not False:
                        return True
                elif value > DISTINCT_STATE_TOL:
                    return True
    return False


__all__ = ["PairClassification", "SubspaceDirections", "classify_pair", "fixed_state_witness"]

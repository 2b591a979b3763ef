"""Algorithm 3.1 of paper 002: the unobservable set B_T, the reduced set B~_T (15), O_T (9).

Notation: regions ``P_i`` of eq. (4) over ``(x, U)`` with outputs ``Y = C_i x + D_i U + f_i``.

* ``I`` (step 1): regions whose ``C_i`` has full column rank ``n`` (rank test on ``C_i`` scaled
  by the state bounds, relative threshold :data:`~hybobs_opt.tolerances.RANK_RTOL`).
* ``B_T`` (steps 2-3): the projections ``Proj_x(P_i)`` for ``i`` not in ``I`` and
  ``Proj_x(R_ij)`` for ``i`` in ``I``, ``j != i`` with ``R_ij`` non-empty, where
  ``R_ij = {(x, x^, U) : (x, U) in P_i, (x^, U) in P_j, C_i x + D_i U + f_i = C_j x^ + D_j U + f_j}``.
* ``B~_T`` (eq. 15): the ``R_ij`` with ``i`` in ``I`` and ``j`` not in ``I``.

Like the paper, the sets are computed up to sets of zero measure.  A pair set is a piece of
``B_T`` when its closure is non-empty, its projection onto ``x`` is full-dimensional and not
thinner than ``2 REGION_SLACK_TOL`` (scaled), and it holds two different states ``x^ != x``
(:mod:`~hybobs_opt.regions.pair_geometry` decides all three, with the regions taken closed:
exact for PWA maps continuous across their guards, the unobservable side otherwise).  Pairs in
which the outputs force ``x^ = x`` are left out and counted (``n_pairs_dropped_same_state``),
like the thin ones (``n_pairs_dropped_thin``).

LPs.  The width of a face along the direction its implicit equalities flatten is bounded from
the very multipliers that certified those equalities (``pair_geometry._tight_width_bound``, no
LP); the thin test is skipped when a certified Chebyshev ball is already too wide for it, and
its two LPs when two ratio-test walks from the ball's centre prove the set wide
(``geometry.lp.width_proven_above``);
undecided Chebyshev LPs get one more DAQP solve with a tight primal tolerance before HiGHS
(``pair_geometry._slack_lp``).  Grouped pair tests (the default): one test of the pair set of
two mode-sequence prefixes' supersets rules out every pair below them when that set is empty,
thin or same-state (:mod:`~hybobs_opt.regions.pair_groups`); ``group_tests=False`` gives every
pair's own verdict.

Every value a decision compares with a tolerance is computed by
:mod:`~hybobs_opt.geometry._reproducible` (a fixed summation order, no fused multiply-add, a
Jacobi SVD) rather than by OpenBLAS / LAPACK, whose kernels differ between CPUs: the lists and
LP counts are the same on every x86-64 machine (``scripts/check_reproducible.py``).

Known leftover, on the safe side: a face whose projection is thin only along a combination of
the flat directions tried is kept as a piece -- a set of measure zero added to ``B_T``.
"""

from __future__ import annotations

import functools
import logging
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace

import numpy as np

from .._logging import with_verbose
from ..errors import ModelError
from ..geometry._lp_kernels import slack_lp_data
from ..geometry.exact_lp import EXACT
from ..geometry._reproducible import lstsq, matmul as mm, norm, numerical_rank, row_norms, svd
from ..geometry.lp import counting_lps, max_slack, row_range
from ..tolerances import EQUALITY_CONSISTENCY_RTOL, RANK_RTOL, REGION_SLACK_TOL, SLACK_CAP, ZERO_ROW_TOL
from ..status import Status
from .pair_geometry import _slack_lp, classify_pair, fixed_state_witness
from .enumeration import (ModeEnumeration, check_analysis_budget, counted_exactly, enumerate_modes, horizon_scaling,
                          resolve_pair_lp_budget)
from .pair_groups import GroupLevel, GroupLevelRows, group_depths, group_level_data, rule_out_by_groups
from .pair_algebra import PairAlgebra as _PairAlgebra, _scaled_regions, pack_scaled as _pack_scaled, unpack_scaled as _unpack_scaled
from .pair_sets import PairList, PairSet, PairSets, pair_constraints
from .verdicts import PairVerdict, PointClass


#: Below this many candidate pairs (``|I|`` times the number of regions) the pair tests run in the
#: calling process whatever the executor (model 16, T = 5: about 5,000 candidates, 0.1 s serial).
PARALLEL_MIN_PAIRS = 6000
#: Tasks per worker of the grouped pair tests (:func:`_chunks`): their blocks differ in cost by
#: 10 x or more (model 17, T = 9), so the workers take several tasks rather than one each; few,
#: since every task repeats the candidate screens and the group pass of its callers.
GROUPED_TASKS_PER_WORKER = 4


def _rank(M: np.ndarray) -> int:
    if M.size == 0:
        return 0
    return numerical_rank(svd(M, compute_uv=False), RANK_RTOL)


def _nullspace(M: np.ndarray) -> tuple[np.ndarray, int]:
    """Orthonormal basis of ``ker M`` (columns) and ``rank M`` with the relative threshold."""
    if M.shape[0] == 0:
        return np.eye(M.shape[1]), 0
    _, s, Vt = svd(M)
    r = numerical_rank(s, RANK_RTOL)
    return Vt[r:].T, r



@dataclass(eq=False)
class ObservabilityAnalysis:
    """Result of Algorithm 3.1 (paper 002) with the exact point query of Definition 2.2.

    Parameters
    ----------
    enumeration : ModeEnumeration
        The regions ``P_i`` of eq. (4).
    full_rank : tuple of bool
        Membership of each region in ``I`` (step 1).
    pairs : PairSets or tuple of PairSet
        Every non-empty ``R_ij`` (``i`` in ``I``, ``j != i``) found in step 3, in order of
        ``(i, j)``; :func:`analyse_observability` gives the compact :class:`PairSets` (indices and
        radii, each :class:`PairSet` built when read).
    n_pair_lps, n_pairs_tested, n_pairs_skipped_rank : int
        LPs solved for the pair tests, pairs tested, pairs discarded before any LP because the
        projection of their equality subspace onto ``x`` is not full-dimensional.
    seconds : float
        Time of step 1-3 (enumeration excluded; see ``enumeration.seconds``).
    stats : dict
        ``executor``; ``n_pairs_dropped_thin`` and ``pairs_dropped_thin``: the non-empty
        ``R_ij`` left out of ``B_T`` because their projection on ``x`` is certified thinner
        than ``2 REGION_SLACK_TOL`` (see :func:`_pair_lps`); ``pairs_dropped_same_state``
        likewise for the outputs forcing ``x^ = x``; ``pairs_ruled_out_by_group``: pairs left
        out of ``B_T`` by a group test (:mod:`~hybobs_opt.regions.pair_groups`) without a
        verdict of their own (empty, thin or same-state), so the two lists before hold only the
        pairs tested one by one; ``n_group_tests``, ``n_group_lps`` (included in
        ``n_pair_lps``) and ``group_depths`` (the prefix lengths of the groups);
        ``n_decisions_exact``: pair decisions whose floating-point bound lay too close to its
        threshold and were re-decided in rational arithmetic
        (:mod:`~hybobs_opt.geometry.exact_lp`), ``n_decisions_exact_undecided``: those the exact
        solve could not settle, decided on the safe side.  The three lists of pairs are
        :class:`~hybobs_opt.regions.PairList` (sorted ``(i, j)`` tuples held as one
        integer array).
    _pair_cache : dict
        Internal cache of the pair lookups; leave it at its default.
    _xboxes : array or None
        Internal cache of the bounding boxes of ``Proj_x(P_k)``; leave it at its default.

    See Also
    --------
    analyse_observability : computes it.
    save_analysis, load_analysis : to and from a file.
    hybobs_opt.observers.LookupObserver : the deadbeat observer built on it.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> analysis.T, len(analysis.regions), sum(analysis.full_rank)   # regions P_i, of full rank
    (3, 16, 4)
    >>> analysis.status.value                       # every LP of it was certified
    'optimal'
    >>> x = np.array([0.06, 39.0, 3.25])
    >>> analysis.classify(x).value, analysis.is_observable(x)
    ('observable', True)
    """

    enumeration: ModeEnumeration
    full_rank: tuple[bool, ...]
    pairs: PairSets | tuple[PairSet, ...]
    n_pair_lps: int
    n_pairs_tested: int
    n_pairs_skipped_rank: int
    seconds: float
    stats: dict = field(default_factory=dict)
    _pair_cache: dict = field(default_factory=dict, repr=False)
    _xboxes: np.ndarray | None = field(default=None, repr=False)

    # ------------------------------------------------------------------ sets
    @property
    def system(self):
        return self.enumeration.system

    @property
    def T(self) -> int:
        return self.enumeration.T

    @property
    def regions(self):
        return self.enumeration.regions

    @property
    def index_set(self) -> tuple[int, ...]:
        """``I``: indices of the regions with ``rank C_i = n``."""
        return tuple(k for k, ok in enumerate(self.full_rank) if ok)

    @property
    def rank_deficient(self) -> tuple[int, ...]:
        """``M \\ I``."""
        return tuple(k for k, ok in enumerate(self.full_rank) if not ok)

    def _pair_indices(self) -> np.ndarray:
        """``(k, 2)`` array of the pieces' ``(i, j)``, without building their constraints."""
        if isinstance(self.pairs, PairSets):
            return self.pairs.ij.array
        return np.array([(p.i, p.j) for p in self.pairs], dtype=np.int64).reshape(-1, 2)

    @property
    def reduced_pairs(self) -> PairSets | tuple[PairSet, ...]:
        """The ``R_ij`` of ``B~_T`` (eq. 15): ``i`` in ``I``, ``j`` not in ``I``."""
        if isinstance(self.pairs, PairSets):
            return self.pairs.subset(~np.asarray(self.full_rank, dtype=bool)[self._pair_indices()[:, 1]])
        return tuple(p for p in self.pairs if not self.full_rank[p.j])

    def reduced_pairs_all_dimensions(self) -> PairSets:
        """Every non-empty closed ``R_ij`` with ``i`` in ``I``, ``j`` not in ``I``, whatever its dimension.

        Algorithm 3.1 drops pairs whose projection on ``x`` is lower-dimensional (measure zero in
        the state space) and pairs that only touch the regions' boundaries.  The lookup observer
        cannot: the data of a true state in ``P_j`` can force the candidate of ``P_i`` onto
        exactly such a flat set, for a set of true states of positive measure.  So this keeps
        every pair whose *closure* is non-empty: the max-margin LP of :func:`_pair_lps` with the
        threshold ``-REGION_SLACK_TOL`` (a pair is left out only when it is certified empty by
        more than the region tolerance, the safe side for the observer).  No rank screen either.
        Computed on demand (one LP per pair) and cached.

        Returns
        -------
        PairSets
            The pair sets, lower-dimensional ones included.
        """
        if "_reduced_all" not in self._pair_cache:
            algebra = _PairAlgebra(_scaled_regions(self.enumeration), self.system.n)
            found = []
            for i in self.index_set:
                found.extend(_pair_lps(algebra, i, np.array(self.rank_deficient, dtype=int),
                                       np.ones(len(self.rank_deficient), dtype=bool), np.zeros(len(self.rank_deficient), dtype=bool),
                                       thin_filter=False, min_margin=-REGION_SLACK_TOL).found)
            found.sort()
            self._pair_cache["_reduced_all"] = PairSets(self.regions, self.system.n, [t[:2] for t in found], [t[2] for t in found])
        return self._pair_cache["_reduced_all"]

    @property
    def n_unobservable_pieces(self) -> int:
        """Number of polytopes composing ``B_T``: rank-deficient regions plus non-empty pair sets."""
        return len(self.rank_deficient) + len(self.pairs)

    # ------------------------------------------------------------------ point query
    def _region_slack_at(self, k: int, x: np.ndarray) -> float:
        """Largest slack of ``P_k`` at fixed ``x`` over ``U`` (scaled): ``> tol`` iff ``x in int Proj_x P_k``."""
        reg = self.regions[k]
        n = self.system.n
        scale, centre = self.enumeration.scale, self.enumeration.centre
        Hx, HU = reg.H[:, :n], reg.H[:, n:]
        G = HU * scale[None, n:]
        g = reg.h - mm(Hx, x) - mm(HU, centre[n:])
        res = max_slack(G, g, radius_bound=np.sqrt(G.shape[1]), threshold=REGION_SLACK_TOL,
                        problem=f"x in Proj_x(P_{k})")
        return res.lower if res.lower > REGION_SLACK_TOL else res.upper

    def _x_boxes(self) -> np.ndarray:
        """Outer bounding boxes of ``Proj_x(P_k)`` for a cheap pre-filter of point queries (computed once).

        Each side is a certified bound (:func:`_certified_box`, DAQP with HiGHS as the fallback):
        a box may be a little wider than the projection, never narrower, so the pre-filter never
        drops a region that contains the point.  (HiGHS through ``row_range`` cost 5.6 s of a
        7.7 s cut of model 16 at T = 7: 1,674 LPs at 3.4 ms.)
        """
        if self._xboxes is None:
            n = self.system.n
            scale, centre = self.enumeration.scale, self.enumeration.centre
            boxes = np.empty((len(self.regions), 2, n))
            for k, reg in enumerate(self.regions):
                box = _certified_box(reg.H * scale[None, :], reg.h - mm(reg.H, centre), n)
                if box is None:  # a bound the multipliers do not certify: the checked HiGHS path
                    rows = np.eye(n, reg.H.shape[1])
                    boxes[k] = row_range(reg.H, reg.h, rows, problem=f"bounding box of Proj_x(P_{k})", field=f"region {k}").T
                else:
                    boxes[k] = centre[:n] + scale[:n] * box
            self._xboxes = boxes
        return self._xboxes

    def regions_containing(self, x) -> list[int]:
        """Indices ``k`` with ``x`` in the interior of ``Proj_x(P_k)`` (so ``x in X*_T``, eq. 5).

        Parameters
        ----------
        x : (n,) array_like
            A finite state.

        Returns
        -------
        list of int
            The region indices.
        """
        x = self._check_point(x)
        boxes = self._x_boxes()
        span = np.maximum(self.enumeration.scale[: self.system.n], 1e-300)
        near = np.all((x >= boxes[:, 0] - span * REGION_SLACK_TOL) & (x <= boxes[:, 1] + span * REGION_SLACK_TOL), axis=1)
        return [k for k in np.nonzero(near)[0] if self._region_slack_at(int(k), x) > REGION_SLACK_TOL]

    def _pair_witness_at(self, i: int, j: int, x: np.ndarray) -> bool:
        """Does the closed slice of ``R_ij`` at this ``x`` hold a state ``x^ != x`` (see :mod:`.pair_geometry`)?"""
        n = self.system.n
        ri, rj = self.regions[i], self.regions[j]
        scale, centre = horizon_scaling(self.system, self.T, copies_of_x=2)
        G, g, E, e = pair_constraints(ri, rj, n)
        # fix x: variables are (x^, U); unit rows in the scaled space before the projection
        Gv, gv = G[:, n:] * scale[None, n:], g - mm(G[:, :n], x) - mm(G[:, n:], centre[n:])
        inv = 1.0 / np.maximum(row_norms(G * scale[None, :]), np.finfo(float).tiny)
        Gv, gv = Gv * inv[:, None], gv * inv
        Ev, ev = E[:, n:] * scale[None, n:], e - mm(E[:, :n], x) - mm(E[:, n:], centre[n:])
        N, r = _nullspace(Ev)
        w0 = lstsq(Ev, ev)
        if Ev.shape[0] and norm(mm(Ev, w0) - ev) > EQUALITY_CONSISTENCY_RTOL * (1.0 + norm(ev)):
            return False  # the outputs cannot match
        x_scaled = (x - centre[:n]) / scale[:n]
        return fixed_state_witness(mm(Gv, N), gv - mm(Gv, w0), N, w0, x_scaled, n,
                                   radius_bound=np.sqrt(Gv.shape[1]) + norm(w0), problem=f"R_{i},{j} at fixed x")

    def is_observable(self, x) -> bool:
        """Exact test of Definition 2.2 (up to measure zero) at one state, by LPs, without projections.

        ``x`` is observable in ``T`` steps when it lies in ``X*_T`` and for every region ``P_i``
        whose projection contains it, ``i`` is in ``I`` and no ``R_ij`` (``j != i``) has a point
        over this ``x``.  States outside ``X*_T`` are reported not observable.

        Parameters
        ----------
        x : (n,) array_like
            A finite state.

        Returns
        -------
        bool
            Whether ``x`` is in ``O_T``.
        """
        return self.classify(x) == PointClass.OBSERVABLE

    def classify(self, x) -> PointClass:
        """:class:`~hybobs_opt.regions.PointClass`: ``OBSERVABLE``, ``UNOBSERVABLE`` or ``INFEASIBLE`` (``x`` not in ``X*_T``).

        The members equal the strings ``"observable"``, ``"unobservable"`` and ``"infeasible"``.

        Only the pairs that Algorithm 3.1 found non-empty can hold a point indistinguishable from
        ``x`` (an empty ``R_ij`` has no slice at any ``x``), so those are the only LPs solved
        beyond the region-membership ones.

        Parameters
        ----------
        x : (n,) array_like
            A finite state.

        Returns
        -------
        PointClass
            The class of ``x``.

        Raises
        ------
        ModelError
            If ``x`` has the wrong length or a non-finite entry.
        """
        x = self._check_point(x)
        inside = self.regions_containing(x)
        if not inside:
            return PointClass.INFEASIBLE
        if any(not self.full_rank[i] for i in inside):
            return PointClass.UNOBSERVABLE
        by_i = self._pairs_by_i()
        for i in inside:
            for j in by_i.get(i, ()):
                if self._pair_witness_at(i, j, x):
                    return PointClass.UNOBSERVABLE
        return PointClass.OBSERVABLE

    def _pairs_by_i(self) -> dict[int, list[int]]:
        if "_by_i" not in self._pair_cache:
            by_i: dict[int, list[int]] = {}
            for i, j in self._pair_indices().tolist():
                by_i.setdefault(i, []).append(j)
            self._pair_cache["_by_i"] = by_i
        return self._pair_cache["_by_i"]

    def classify_many(self, X: np.ndarray, progress: Callable[[int, int], None] | None = None) -> np.ndarray:
        """Vector of :meth:`classify` labels for the rows of ``X``.

        Parameters
        ----------
        X : (N, n) array_like
            States, one per row.
        progress : callable, optional
            ``progress(done, total)``, called after each state.

        Returns
        -------
        (N,) object ndarray
            The labels (:class:`~hybobs_opt.regions.PointClass` members).
        """
        X = np.atleast_2d(np.asarray(X, dtype=float))
        out = np.empty(X.shape[0], dtype=object)
        for k, x in enumerate(X):
            out[k] = self.classify(x)
            if progress:
                progress(k + 1, X.shape[0])
        return out

    def _check_point(self, x) -> np.ndarray:
        x = np.asarray(x, dtype=float).reshape(-1)
        if x.shape != (self.system.n,) or not np.all(np.isfinite(x)):
            raise ModelError("x", f"a finite state of length {self.system.n}", f"{x.tolist()}")
        return x

    # ------------------------------------------------------------------ sets on cuts
    def cut_sets(self, fixed: dict[str, float] | None = None):
        r"""``X*_T``, ``B_T`` and ``O_T = X*_T \ B_T`` (eqs. 5, 9) as unions of polytopes on a cut.

        Every piece is sliced at ``fixed`` (state name -> value) and projected exactly onto the
        remaining states: ``Proj_x(P_i)`` for ``X*_T`` and for ``i`` not in ``I``, and
        ``Proj_x(R_ij)`` (with its output equalities) for the pairs.  ``fixed=None`` gives the
        sets in the full state space (practical for ``n <= 3``).  ``O_T`` is the region
        difference, exact up to sets of measure zero as in the paper.

        Parameters
        ----------
        fixed : dict of str to float, optional
            Values of the states fixed by the cut, by name (at least one state must stay free);
            ``None`` fixes none.

        Returns
        -------
        (PolytopeUnion, PolytopeUnion, PolytopeUnion)
        """
        from ..geometry.polytope import Polytope
        from .union import PolytopeUnion

        fixed = dict(fixed or {})
        names = self.system.state_names
        T, m = self.T, self.system.m
        for k in fixed:
            if k not in names:
                raise ModelError("fixed", f"state names among {names}", repr(k))
        free = [nm for nm in names if nm not in fixed]
        if not free:
            raise ModelError("fixed", "at least one free state", "all states fixed")
        u_names = tuple(f"u{k}_{j}" for k in range(T) for j in range(m))
        hat = tuple(f"{nm}^" for nm in names)

        def project(P: Polytope, E=None, e=None):
            if E is None:
                Q = P.slice(fixed) if fixed else P
                return Q.project(free)
            cols = [P.names.index(k) for k in fixed]
            keep = [c for c in range(P.dim) if c not in cols]
            values = np.array([fixed[k] for k in fixed])
            Q = P.slice(fixed) if fixed else P
            E2, e2 = E[:, keep], e - (E[:, cols] @ values if cols else 0.0)
            return Q.project_with_equalities(E2, e2, free)

        xstar, bt = [], []
        for k, reg in enumerate(self.regions):
            piece = project(Polytope(reg.H, reg.h, names + u_names))
            if piece.is_empty():
                continue
            xstar.append(piece)
            if not self.full_rank[k]:
                bt.append(piece)
        for pair in self.pairs:
            piece = project(Polytope(pair.G, pair.g, names + hat + u_names), pair.E, pair.e)
            if not piece.is_empty():
                bt.append(piece)
        d = len(free)
        X = PolytopeUnion(tuple(xstar), d, tuple(free))
        B = PolytopeUnion(tuple(bt), d, tuple(free))
        return X, B, X.difference(B)

    # ------------------------------------------------------------------ result protocol
    @property
    def status(self) -> Status:
        """``OPTIMAL``: every LP of the enumeration and of steps 1-3 was certified (status mapped,
        returned point re-checked by :func:`~hybobs_opt.geometry.lp.solve_lp`).  An LP that
        could not be certified raises :class:`~hybobs_opt.errors.SolverError` instead of
        returning an analysis, so no other status is ever held here."""
        return Status.OPTIMAL

    @property
    def residuals(self) -> dict[str, float]:
        """Empty: the analysis returns sets, not a point (each LP's point was checked on its own)."""
        return {}

    @property
    def total_seconds(self) -> float:
        """Enumeration and Algorithm 3.1 together."""
        return self.enumeration.seconds + self.seconds

    def to_dict(self) -> dict:
        """JSON-ready record (:meth:`summary` with the ``status``) of the result protocol.

        Returns
        -------
        dict
            :meth:`summary` with ``status``.
        """
        return {"status": str(self.status), **self.summary()}

    # ------------------------------------------------------------------ summary
    def summary(self) -> dict:
        """The ``hybobs regions --json`` record.

        Returns
        -------
        dict
            Counts of regions, pieces and LPs, and timings.
        """
        enum = self.enumeration
        return {
            "example": self.system.name,
            "horizon": self.T,
            "n_regions": len(self.regions),
            "n_full_rank": len(self.index_set),
            "n_unobservable_pieces": self.n_unobservable_pieces,
            "n_reduced_pieces": len(self.reduced_pairs),
            "n_lps": enum.n_lps + self.n_pair_lps,
            "n_lps_enumeration": enum.n_lps,
            "n_lps_pairs": self.n_pair_lps,
            "n_lps_avoided_by_pruning": enum.n_lps_avoided,
            "n_pairs_tested": self.n_pairs_tested,
            "n_pairs_skipped_rank": self.n_pairs_skipped_rank,
            "n_pairs_dropped_thin": self.stats.get("n_pairs_dropped_thin"),
            "n_pairs_dropped_same_state": self.stats.get("n_pairs_dropped_same_state"),
            "n_pairs_ruled_out_by_group": self.stats.get("n_pairs_ruled_out_by_group"),
            "n_decisions_exact": self.stats.get("n_decisions_exact"),
            "seconds_enumeration": enum.seconds,
            "seconds_algorithm_3_1": self.seconds,
            "seconds": enum.seconds + self.seconds,
            "executor": self.stats.get("executor", "serial"),
        }


def _certified_box(G: np.ndarray, g: np.ndarray, n: int) -> np.ndarray | None:
    """``[lower; upper]`` (2 x n) of the first ``n`` coordinates of ``w`` over ``{G w <= g}``, certified.

    ``G, g`` are a region in scaled coordinates (``w`` in the unit box, so ``|w| <= sqrt(d)``).
    Each side is the weak-duality bound of :func:`~hybobs_opt.geometry._lp_kernels.support_upper_bound`
    from the multipliers of one LP (:func:`~hybobs_opt.geometry.lp.verified_lp`: DAQP when its
    answer verifies, HiGHS otherwise): valid for every point of the set whatever the solver's
    accuracy.  ``None`` when an LP is not optimal.
    """
    from ..geometry._lp_kernels import support_upper_bound
    from ..geometry.lp import verified_lp

    G = np.ascontiguousarray(G, dtype=float)
    g = np.ascontiguousarray(g, dtype=float)
    d = G.shape[1]
    R = float(np.sqrt(d))
    box = np.empty((2, n))
    for k in range(n):
        for side, sign in ((1, 1.0), (0, -1.0)):
            c = np.zeros(d)
            c[k] = sign
            ans = verified_lp(-c, G, g, problem=f"bounding box, coordinate {k}")
            if ans.status != Status.OPTIMAL or ans.duals is None:
                return None
            bound = support_upper_bound(G, g, c, np.ascontiguousarray(ans.duals, dtype=float), R)
            if not np.isfinite(bound):
                return None
            box[side, k] = sign * bound
    return box


@dataclass(frozen=True, slots=True)
class _Candidates:
    """The pairs of Algorithm 3.1, step 3.1, for one ``i`` in ``I`` that pass the rank screen (:func:`_candidates`).

    ``js``: the other regions; ``want_ij[k]`` / ``want_ji[k]``: ``R_ij`` / ``R_ji`` of ``js[k]``
    is still to be decided; ``n_tested``, ``n_skipped_rank``: the pairs screened and those the
    screen discarded.
    """

    js: np.ndarray
    want_ij: np.ndarray
    want_ji: np.ndarray
    n_tested: int
    n_skipped_rank: int


def _candidates(algebra: _PairAlgebra, full_rank, i: int, allowed: np.ndarray | None = None) -> _Candidates:
    r"""The pairs of Algorithm 3.1, step 3.1, for one ``i`` in ``I``, screened before any LP.

    A pair whose output equalities cannot be solved for every ``x`` has a lower-dimensional
    projection (:meth:`~hybobs_opt.regions.pair_algebra.PairAlgebra.screen`).  ``R_ji`` is
    ``R_ij`` with ``x`` and ``x^`` swapped, so for ``j`` also in ``I`` one LP decides both; such
    pairs are handled from ``i`` only for ``j > i``, reporting ``R_ji`` too when its own rank
    screen passes.

    Returns the ``js`` that pass a screen with what is wanted of each; with ``allowed`` (a mask
    over the regions) only those ``j`` are candidates.
    """
    rank_ok = np.asarray(full_rank, dtype=bool)
    take = ~rank_ok | (np.arange(rank_ok.size) > i)
    take[i] = False
    if allowed is not None:
        take &= np.asarray(allowed, dtype=bool)
    js = np.nonzero(take)[0]
    if js.size == 0:
        return _Candidates(js, np.zeros(0, dtype=bool), np.zeros(0, dtype=bool), 0, 0)
    ci, cj = algebra.cls[i], algebra.cls[js]
    ok_ij = algebra.screen(ci, cj)
    sym = rank_ok[js]
    ok_ji = np.zeros(js.size, dtype=bool)
    ok_ji[sym] = algebra.screen_reversed(cj[sym], ci)
    ok = ok_ij | ok_ji
    n_tested = int(js.size + sym.sum())
    n_skipped = int(np.count_nonzero(~ok_ij) + np.count_nonzero(sym & ~ok_ji))
    return _Candidates(js[ok], ok_ij[ok].copy(), ok_ji[ok].copy(), n_tested, n_skipped)


@dataclass(frozen=True, slots=True)
class _PairFindings:
    """What :func:`_pair_lps` decided: ``found`` as ``(i, j, radius)``, the others as ``(i, j)`` pairs."""

    found: list[tuple[int, int, float]]
    dropped_thin: list[tuple[int, int]]
    dropped_same_state: list[tuple[int, int]]


def _pair_lps(algebra: _PairAlgebra, i: int, js: np.ndarray, report_ij: np.ndarray,
              report_ji: np.ndarray, thin_filter: bool = True,
              min_margin: float | None = None) -> _PairFindings:
    """Decide the pair sets ``R_ij``, ``j`` in ``js``, with :func:`~hybobs_opt.regions.pair_geometry.classify_pair`.

    Reports ``(i, j, radius)`` for ``R_ij`` where ``report_ij`` and for ``R_ji`` where ``report_ji``
    (the same LPs decide both); :class:`~hybobs_opt.regions.PairSets` keeps the triples.  A pair
    is reported when its closure is non-empty, its projection on the state is full-dimensional
    (with the thin test when ``thin_filter``) and it holds two different states.

    With ``min_margin`` (``reduced_pairs_all_dimensions``) every pair whose closure is not
    certified empty by more than ``-min_margin`` is reported instead, whatever its dimension.

    Returns the pairs found and, as ``(i, j)`` pairs, the non-empty ones left out because their
    projection is lower-dimensional or thin (``dropped_thin``), and because the outputs force
    ``x^ = x`` on them (``dropped_same_state``).
    """
    out = _PairFindings([], [], [])
    if js.size == 0:
        return out
    n = algebra.n
    for k, (j, rows) in enumerate(zip(js, algebra.restricted_rows(i, js))):
        if rows is None:
            continue  # the outputs can never be equal
        problem = f"R_{i},{j} (Algorithm 3.1, step 3.1.1)"
        if min_margin is not None:
            A, bu, ok = slack_lp_data(rows.Gv, rows.gv, ZERO_ROW_TOL, SLACK_CAP)
            if not ok:
                continue
            if A.shape[0] == 1:
                out.found.append((i, int(j), SLACK_CAP))
                continue
            res = _slack_lp(A, bu, rows.radius_bound, min_margin, problem)
            if res.lower > min_margin:
                out.found.append((i, int(j), float(res.lower)))
            continue
        verdict = classify_pair(rows.Gv, rows.gv, rows.N, rows.w0, n, rows.radius_bound, bool(report_ij[k]),
                                bool(report_ji[k]), thin_filter=thin_filter, problem=problem, directions=rows.directions)
        for v, pair in ((verdict.verdict, (i, int(j))), (verdict.verdict_ji, (int(j), i))):
            if v == PairVerdict.PIECE:
                out.found.append(pair + (verdict.radius,))
            elif v == PairVerdict.LOWER_DIMENSIONAL:
                out.dropped_thin.append(pair)
            elif v == PairVerdict.SAME_STATE:
                out.dropped_same_state.append(pair)
    return out


# ---------------------------------------------------------------------- tasks of the pair tests
@dataclass(frozen=True, slots=True)
class PairTaskData:
    """What every pair-test task of one analysis shares (sent to each worker once where the executor can).

    Parameters
    ----------
    regions : bytes or (list, int)
        The regions' scaled rows and output maps: packed into one buffer
        (:func:`~hybobs_opt.regions.pair_algebra.pack_scaled`) for the worker processes, or
        ``(scaled rows, n)`` in the calling process.
    full_rank : tuple of bool
        Membership of each region in ``I``.
    levels : tuple of GroupLevelRows
        The group tests' prefix lengths, shortest first (empty: pair by pair).
    token : str or None
        Digest of the packed data: a worker keeps the algebras of the last analysis under it.
    """

    regions: bytes | tuple
    full_rank: tuple[bool, ...]
    levels: tuple[GroupLevelRows, ...]
    token: str | None


@dataclass(frozen=True, slots=True)
class PairTask:
    """One task of the pair tests (:func:`_chunks`).

    ``i_list``: the regions of ``I`` whose pairs it tests; ``blocks``: with group tests, the
    blocks ``(a, b)`` of shortest prefixes it takes (the pairs whose caller lies below prefix
    ``a`` and whose other region below prefix ``b``), ``None`` for every pair of ``i_list``;
    ``size``: its estimated size (candidate pairs), for progress reports.
    """

    i_list: list[int]
    blocks: np.ndarray | None
    size: int


def _pair_array(pairs) -> np.ndarray:
    """Ordered pairs ``(i, j)`` as a ``(k, 2)`` int32 array."""
    return np.array(pairs, dtype=np.int32).reshape(-1, 2)


@dataclass(frozen=True, slots=True)
class PairOutcome:
    """What one pair-test task found (:func:`_pairs_task`), or all of them (:meth:`total`).

    ``found``: the pieces' ``(i, j)`` and ``radius`` their radii; ``dropped_thin``,
    ``dropped_same_state``, ``ruled_out_by_group``: ordered pairs ``(i, j)`` (see
    :class:`ObservabilityAnalysis` ``stats``), all as ``(k, 2)`` int32 arrays (a task's
    pickled answer and the merged lists grow by 8 bytes a pair); ``n_lps``: LPs solved (group tests included); ``n_tested``, ``n_skipped_rank``:
    pairs screened and discarded by the rank screen; ``n_group_tests``, ``n_group_lps``: the
    group tests and their LPs; ``n_decisions_exact``, ``n_decisions_exact_undecided``: decisions
    re-made in rational arithmetic, and those it could not settle.
    """

    found: np.ndarray
    radius: np.ndarray
    dropped_thin: np.ndarray
    dropped_same_state: np.ndarray
    ruled_out_by_group: np.ndarray
    n_lps: int
    n_tested: int
    n_skipped_rank: int
    n_group_tests: int
    n_group_lps: int
    n_decisions_exact: int
    n_decisions_exact_undecided: int

    @staticmethod
    def total(outcomes) -> "PairOutcome":
        """The outcomes of all tasks as one: arrays concatenated in task order, counts summed."""
        outcomes = list(outcomes)

        def cat(name: str) -> np.ndarray:
            parts = [getattr(o, name) for o in outcomes]
            return np.concatenate(parts) if parts else _pair_array(())

        def add(name: str) -> int:
            return sum(getattr(o, name) for o in outcomes)

        radius = np.concatenate([o.radius for o in outcomes]) if outcomes else np.zeros(0)
        return PairOutcome(cat("found"), radius, cat("dropped_thin"), cat("dropped_same_state"), cat("ruled_out_by_group"),
                           add("n_lps"), add("n_tested"), add("n_skipped_rank"), add("n_group_tests"),
                           add("n_group_lps"), add("n_decisions_exact"), add("n_decisions_exact_undecided"))


#: Per worker process: the unpacked regions and their pair algebras of the last analysis, keyed
#: by a digest of the packed data (the tasks of one analysis share them; the algebras' SVD
#: caches then fill once per worker instead of once per task).
_WORKER_STATE: dict = {}


def _task_state(data: PairTaskData) -> tuple[_PairAlgebra, list[GroupLevel]]:
    """``(PairAlgebra of the regions, [GroupLevel, ...])`` for a task, rebuilt unless cached under ``data.token``."""
    if data.token is not None and _WORKER_STATE.get("token") == data.token:
        return _WORKER_STATE["state"]
    scaled, n = _unpack_scaled(data.regions) if isinstance(data.regions, bytes) else data.regions
    levels = []
    for level in data.levels:
        sc = _unpack_scaled(level.rows)[0] if isinstance(level.rows, bytes) else level.rows
        levels.append(GroupLevel(level.depth, _PairAlgebra(sc, n), level.index))
    state = (_PairAlgebra(scaled, n), levels)
    if data.token is not None:
        _WORKER_STATE.clear()
        _WORKER_STATE.update(token=data.token, state=state)
    return state


def _group_pass(levels: list[GroupLevel], i_list: list[int], per_i: list[_Candidates]) -> tuple[list[_Candidates], np.ndarray, int, int]:
    """Run the group tests over all the candidate pairs of a task; returns the candidates with the
    wants they decided cleared, the pairs ruled out, the number of group tests and their LPs."""
    caller = np.concatenate([np.full(c.js.size, i, dtype=int) for i, c in zip(i_list, per_i)] + [np.zeros(0, dtype=int)])
    other = np.concatenate([c.js for c in per_i] + [np.zeros(0, dtype=int)])
    want_ij = np.concatenate([c.want_ij for c in per_i] + [np.zeros(0, dtype=bool)])
    want_ji = np.concatenate([c.want_ji for c in per_i] + [np.zeros(0, dtype=bool)])
    with counting_lps() as group:
        ruled, n_group_tests = rule_out_by_groups(levels, caller, other, want_ij, want_ji)
    group_lps = group.total
    offsets = np.cumsum([0] + [c.js.size for c in per_i])
    per_i = [replace(c, want_ij=want_ij[a:b], want_ji=want_ji[a:b]) for c, a, b in zip(per_i, offsets[:-1], offsets[1:])]
    return per_i, ruled, n_group_tests, group_lps


def _pairs_task(task: PairTask, shared: PairTaskData, progress: Callable[[int, int], None] | None = None) -> PairOutcome:
    """The pair tests of one task: a chunk of ``i`` values (and, with group tests, of prefix blocks).

    With group levels (:mod:`~hybobs_opt.regions.pair_groups`), the group tests run first over
    all the chunk's candidate pairs, then every pair they leave undecided is tested on its own.
    """
    with counting_lps() as lps:
        algebra, levels = _task_state(shared)
        rank_ok = np.asarray(shared.full_rank, dtype=bool)
        if task.blocks is None:
            per_i = [_candidates(algebra, rank_ok, i) for i in task.i_list]
        else:  # only the pairs whose two shortest prefixes form a block of this task (see _chunks)
            top = shared.levels[0].index
            per_i = [_candidates(algebra, rank_ok, i, task.blocks[top[i]][top]) for i in task.i_list]
        n_tested = sum(c.n_tested for c in per_i)
        n_skipped = sum(c.n_skipped_rank for c in per_i)
        ruled = _pair_array(())
        n_group_tests = group_lps = 0
        exact0 = (EXACT.decided, EXACT.undecided)
        if levels:
            per_i, ruled, n_group_tests, group_lps = _group_pass(levels, task.i_list, per_i)
        findings = _PairFindings([], [], [])
        for k, (i, c) in enumerate(zip(task.i_list, per_i)):
            keep = c.want_ij | c.want_ji
            f = _pair_lps(algebra, i, c.js[keep], c.want_ij[keep], c.want_ji[keep])
            findings.found.extend(f.found)
            findings.dropped_thin.extend(f.dropped_thin)
            findings.dropped_same_state.extend(f.dropped_same_state)
            if progress:
                progress(k + 1, len(task.i_list))
    return PairOutcome(_pair_array([t[:2] for t in findings.found]), np.array([t[2] for t in findings.found], dtype=float),
                       _pair_array(findings.dropped_thin), _pair_array(findings.dropped_same_state), _pair_array(ruled),
                       n_lps=lps.total, n_tested=n_tested, n_skipped_rank=n_skipped,
                       n_group_tests=n_group_tests, n_group_lps=group_lps,
                       n_decisions_exact=EXACT.decided - exact0[0], n_decisions_exact_undecided=EXACT.undecided - exact0[1])


def _chunks(I: list[int], n_regions: int, n_chunks: int, top_index: np.ndarray | None) -> list[PairTask]:
    """Split the pair tests into ``n_chunks`` tasks, largest first.

    Without group tests, ``I`` is dealt out (``I[c::n_chunks]``).  With them, the candidate pairs
    are cut into blocks by the shortest prefixes of both regions: every group of pairs lies in
    one block (its pairs share both prefixes), so each group is tested once, whatever the split,
    and the LP counts are those of a serial run.  ``blocks[a, b]``: the task takes the pairs
    whose caller lies below prefix ``a`` and whose other region below prefix ``b``.  Blocks go to
    the task with the smallest estimated size (caller regions times other regions), largest
    first; the tasks are returned largest first, so that the workers, which take the next task
    when they finish one, end close together (model 17, T = 9: one prefix held 40 % of the LPs).
    ``size`` counts the candidate pairs ``(i, j)``, ``i`` in ``I``, for progress reports.
    """
    if top_index is None:
        return [PairTask(I[c::n_chunks], None, len(I[c::n_chunks]) * n_regions) for c in range(n_chunks) if I[c::n_chunks]]
    n_top = int(top_index.max()) + 1
    callers = np.bincount(top_index[np.asarray(I, dtype=int)], minlength=n_top)
    below = np.bincount(top_index, minlength=n_top)
    keys = [(int(a), int(b)) for a in np.nonzero(callers)[0] for b in range(n_top)]
    cost = {k: int(callers[k[0]]) * int(below[k[1]]) for k in keys}
    load = [0] * n_chunks
    blocks = [np.zeros((n_top, n_top), dtype=bool) for _ in range(n_chunks)]
    for k in sorted(keys, key=lambda k: (-cost[k], k)):
        c = min(range(n_chunks), key=lambda c: (load[c], c))
        blocks[c][k] = True
        load[c] += cost[k]
    out = []
    I_arr = np.asarray(I, dtype=int)
    for c in sorted(range(n_chunks), key=lambda c: (-load[c], c)):
        mine = I_arr[blocks[c].any(axis=1)[top_index[I_arr]]].tolist()
        if mine:
            out.append(PairTask(mine, blocks[c], load[c]))
    return out


def _enumeration(system_or_enum, T: int | None, executor, progress, max_pair_lps: int | None) -> ModeEnumeration:
    """The regions of eq. (4): enumerated for a system (after the pair-LP budget check), or as given."""
    from ..progress import phase_callback
    from ..systems.pwa import PWASystem

    if isinstance(system_or_enum, PWASystem):
        if T is None:
            raise ModelError("T", "a horizon when a PWASystem is given", "None")
        # at small horizons the prediction counts the regions at T itself: enumerate once, then decide
        exact = counted_exactly(system_or_enum, T)
        resolve_pair_lp_budget(max_pair_lps)
        if not exact:
            check_analysis_budget(system_or_enum, T, max_pair_lps)
        enum = enumerate_modes(system_or_enum, T, executor=executor,
                               progress=phase_callback(progress, "mode enumeration", "prefix", main=False))
        if exact:
            check_analysis_budget(system_or_enum, T, max_pair_lps, enumeration=enum)
        return enum
    if isinstance(system_or_enum, ModeEnumeration):
        return system_or_enum
    raise ModelError("system_or_enum", "a PWASystem or a ModeEnumeration", type(system_or_enum).__name__)


def _task_data(enum: ModeEnumeration, full_rank: tuple[bool, ...], levels: list[GroupLevelRows], parallel: bool) -> PairTaskData:
    """What the tasks share.  Only the scaled rows and output maps travel, packed into one buffer
    (:func:`_pack_scaled`) for the workers: Dask serialises the ~4,000 small arrays of a
    ModeEnumeration one by one (0.9 s for four copies of model 17's at T = 7), and the state maps
    are not needed by the pair tests."""
    n = enum.system.n
    scaled = _scaled_regions(enum)
    if not parallel:
        return PairTaskData((scaled, n), full_rank, tuple(levels), None)
    import hashlib

    payload = _pack_scaled(scaled, n)
    levels = [replace(level, rows=_pack_scaled(level.rows, n)) for level in levels]
    digest = hashlib.blake2b(payload, digest_size=16)
    for level in levels:
        digest.update(level.rows)
        digest.update(np.ascontiguousarray(level.index).tobytes())
    return PairTaskData(payload, full_rank, tuple(levels), digest.hexdigest())


def _run_tasks(executor, parallel: bool, tasks: list[PairTask], data: PairTaskData, progress, n_regions: int,
               n_candidates: int) -> list[PairOutcome]:
    """The tasks' outcomes, in task order: on the executor's workers, or in this process."""
    from ..progress import phase_callback

    pair_progress = phase_callback(progress, "pair tests", "pair")
    if pair_progress is not None:
        pair_progress(0, n_candidates)
    if parallel:
        per_task = [task.size for task in tasks]
        report = None if pair_progress is None else (lambda done, total: pair_progress(sum(per_task[:done]), n_candidates))
        if hasattr(executor, "map_shared"):
            return executor.map_shared(_pairs_task, tasks, data, progress=report)
        # an executor of the user's with map only: the common data travel in every task
        return executor.map(functools.partial(_pairs_task, shared=data), tasks, progress=report)
    # one task in this process: report progress per region of I
    return [_pairs_task(task, data, None if pair_progress is None else
                        (lambda done, total: pair_progress(done * n_regions, n_candidates)))
            for task in tasks]


def _stats(executor_name: str, data: PairTaskData, total: PairOutcome) -> dict:
    """The ``stats`` of :class:`ObservabilityAnalysis` from the tasks' total outcome."""
    return {"executor": executor_name, "n_pairs_dropped_thin": len(total.dropped_thin),
            "pairs_dropped_thin": PairList.sorted(total.dropped_thin), "n_pairs_dropped_same_state": len(total.dropped_same_state),
            "pairs_dropped_same_state": PairList.sorted(total.dropped_same_state),
            "group_depths": tuple(int(level.depth) for level in data.levels),
            "n_group_tests": total.n_group_tests, "n_group_lps": total.n_group_lps,
            "n_pairs_ruled_out_by_group": len(total.ruled_out_by_group),
            "pairs_ruled_out_by_group": PairList.sorted(total.ruled_out_by_group),
            "n_decisions_exact": total.n_decisions_exact, "n_decisions_exact_undecided": total.n_decisions_exact_undecided}


_log = logging.getLogger(__name__)


@with_verbose
def analyse_observability(
    system_or_enum,
    T: int | None = None,
    *,
    executor=None,
    progress: Callable[[int, int], None] | None = None,
    group_tests: bool = True,
    max_pair_lps: int | None = None,
    verbose: bool | int = False,
) -> ObservabilityAnalysis:
    """Run mode enumeration (if needed) and Algorithm 3.1 of paper 002.

    Parameters
    ----------
    system_or_enum : PWASystem or ModeEnumeration
    T : int
        Horizon (required when a system is given).
    executor : Executor, optional
        Serial by default; the pair tests are split by ``i`` (one task per region of ``I``).
    progress : callable or PhaseProgress, optional
        ``progress(done, total)`` over the pair tests (the candidate pairs ``(i, j)``, ``i`` in
        ``I``); a :class:`~hybobs_opt.progress.PhaseProgress` also follows the mode enumeration
        (phase ``"mode enumeration"``, unit ``"prefix"``) and reports the pair tests as phase
        ``"pair tests"``, unit ``"pair"``.
    group_tests : bool
        Rule out families of pairs with one test of their prefixes' supersets first
        (:mod:`~hybobs_opt.regions.pair_groups`; model 17 at T = 8: 3.3 x fewer pair LPs, the
        same pieces).  The pairs a group rules out are not classified one by one: they are
        listed in ``stats["pairs_ruled_out_by_group"]``, not among the thin or same-state ones.
        ``False`` classifies every pair on its own (the full thin / same-state lists).
    max_pair_lps : int, optional
        Budget of predicted pair LPs (:func:`~hybobs_opt.regions.enumeration.predict_analysis_cost`):
        a horizon predicted beyond it is refused before any LP, with the prediction.  Default
        :data:`~hybobs_opt.limits.MAX_PREDICTED_PAIR_LPS` (or the budget the CLI's ``--max-lps``
        set).  Not checked when a ``ModeEnumeration`` is given (its size is known).
    verbose : bool or int, default False
        Log the phases (mode enumeration, pair tests) to standard error: ``True`` at INFO, or a
        logging level (:func:`hybobs_opt._logging.verbose_logging`).

    Returns
    -------
    ObservabilityAnalysis
        The regions of eq. (4), their rank test, the pieces of ``B_T`` and the exact point query
        of Definition 2.2.

    See Also
    --------
    enumerate_modes : its first phase.
    ObservabilityAnalysis : what it returns.
    compute_cut : a plane of its point query.
    hybobs_opt.cached_analysis : the same through the cache.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> analysis = analyse_observability(plant, 3)              # Algorithm 3.1, horizon T = 3
    >>> analysis.summary()["n_regions"], analysis.summary()["n_unobservable_pieces"]
    (16, 12)
    >>> analysis.is_observable(np.array([0.06, 39.0, 3.25]))    # Definition 2.2, decided exactly
    True
    >>> analysis.classify(np.array([0.0, 30.0, 2.5])).value       # in the backlash gap
    'unobservable'
    """
    from ..executor import resolve_executor

    executor = resolve_executor(executor)
    t_enum = time.perf_counter()
    enum = _enumeration(system_or_enum, T, executor, progress, max_pair_lps)
    _log.info("Algorithm 3.1 of paper 002 at T = %d: mode enumeration gave %d regions (%.3g s)", enum.T,
              len(enum.regions), time.perf_counter() - t_enum)
    t0 = time.perf_counter()
    n = enum.system.n
    sx = enum.scale[:n]
    full_rank = tuple(_rank(reg.C * sx[None, :]) == n for reg in enum.regions)
    I = [i for i, ok in enumerate(full_rank) if ok]
    # Few large tasks: each one rebuilds the class-pair algebra, and the interleaved split
    # I[c::n_chunks] already balances the work.
    parallel = executor.n_workers > 1 and len(I) * len(enum.regions) > PARALLEL_MIN_PAIRS
    n_chunks = min(len(I), 2 * executor.n_workers) if parallel else 1
    if not isinstance(group_tests, bool):
        raise ModelError("group_tests", "True or False", repr(group_tests))
    levels = group_level_data(enum, group_depths(enum.T, n, enum.system.p)) if group_tests and I else []
    if parallel and levels:
        n_chunks = GROUPED_TASKS_PER_WORKER * executor.n_workers
    tasks = _chunks(I, len(enum.regions), n_chunks, levels[0].index if levels and parallel else None)
    data = _task_data(enum, full_rank, levels, parallel)
    n_candidates = len(I) * len(enum.regions)  # the pairs (i, j), i in I, the tests go through
    total = PairOutcome.total(_run_tasks(executor, parallel, tasks, data, progress, len(enum.regions), n_candidates))
    order = np.lexsort((total.found[:, 1], total.found[:, 0]))  # same order on every executor
    pairs = PairSets(enum.regions, n, total.found[order], total.radius[order])
    _log.info("pair tests: %d of %d candidate pairs tested with %d LPs (%s), %d pair sets R_ij found (%.3g s)",
              total.n_tested, n_candidates, total.n_lps, executor.name if parallel else "serial", len(pairs),
              time.perf_counter() - t0)
    return ObservabilityAnalysis(enum, full_rank, pairs, total.n_lps, total.n_tested, total.n_skipped_rank,
                                 time.perf_counter() - t0, _stats(executor.name if parallel else "serial", data, total))

"""Recursive set-membership filtering of a PWA system: the states consistent with *every* sample
so far, as a union of polytopes, under bounded output noise.

The windowed observers with radii (:class:`~hybobs_opt.mhe.SetMembershipObserver`, the lookup
table with ``noise_bound``) bound the states consistent with the last ``T`` samples.  Some
quantities are decided only by a longer history: the backlash gap of model (16) of paper 002 is
seen only when the shaft traverses the whole gap, 50-120 samples on the bench scenario, while in
each contact mode the outputs depend on ``theta - alpha`` alone.  A constant unknown parameter
becomes a state of the augmented system (:func:`~hybobs_opt.systems.parameters.augment_parameters`),
and this filter keeps the set of augmented states consistent with the whole record, so the
parameter's interval narrows as the data rule values out and never widens.

The recursion is the set-valued observer of Schweppe ("Recursive state estimation: unknown but
bounded errors and system inputs", IEEE TAC 13(1), 1968) and Shamma & Tu ("Set-valued observers
and optimal disturbance rejection", IEEE TAC 44(2), 1999), over the modes of a PWA system.  With
``S(t)`` the set of states at time ``t`` consistent with the samples before ``t`` (``S(0) = X``):

* **measurement**: for every piece ``P`` of ``S(t)`` and every mode ``q``, the piece
  ``P ∩ {x : (x, u(t)) in the guard of q} ∩ {x : |y(t) - C_q x - D_q u(t) - c_q| <= beta}``;
  the non-empty ones make up the states consistent with the samples up to ``t``;
* **estimate**: the bounding box of their union (LPs), its centre and half-width (``radius``);
* **time update**: each piece mapped by its mode's dynamics ``A_q x + B_q u(t) + a_q`` and cut to
  ``X`` (the model's assumption that the plant stays there): the pieces of ``S(t + 1)``.

Every step keeps the true state whenever the data satisfy the noise bound and the model is
exact: the pieces are only ever intersected with sets the true state satisfies, mapped exactly
(affine images of polytopes), or enlarged.  Enlarged where exact arithmetic would cost too much,
always outward: an emptiness test relaxes every row by ``SET_FILTER_ROW_RTOL`` (a piece is dropped
only when even the relaxed one is empty, and the relaxed one is kept), redundant rows are dropped
(never a facet: the LP of :meth:`~hybobs_opt.geometry.polytope.Polytope.remove_redundant` keeps a
row unless it is implied), and when the union has more than ``max_pieces`` pieces, the two
nearest are replaced by the polytope of all their rows at the larger of the two proven supports
(an outer bound of their union; their common bounding box if an LP fails), widened by the same
relative margin.  What is proven is therefore
an outer bound: the true state lies in the box; the box may be larger than the exact one.
"""

from __future__ import annotations

import time

import numpy as np

from .._native_output import captured_native_output
from .._validate import as_int
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, UNOBSERVABLE, check_reset_keywords,
                        judge_samples_against, noise_bound_vector, radius_tolerance_vector)
from ..errors import ModelError, SolverError
from ..geometry.lp import solve_lp
from ..geometry.polytope import Polytope
from ..defaults import MHE_UNIQUENESS_DELTA, SET_FILTER_MAX_PIECES
from ..tolerances import (SET_FILTER_MIN_NOISE_RTOL, SET_FILTER_REDUNDANCY_RTOL, SET_FILTER_ROW_RTOL,
                          SET_FILTER_UNIT_BOX_MARGIN)

__all__ = ["SetMembershipFilter"]


#: Every this many steps each piece's redundant rows are removed by LPs (in between, only rows
#: implied by the piece's mapped bounding box go, which needs no LP).
REDUNDANCY_PERIOD: int = 10

#: A piece with more rows than this has its redundant rows removed at once.
MAX_ROWS_BEFORE_REDUNDANCY: int = 60


def _row_box(P: Polytope, n: int) -> tuple[np.ndarray, np.ndarray]:
    """An outer box of ``P`` from its single-coordinate rows (``+-e_i' s <= b``), else ``[-inf, inf]``."""
    lo, hi = np.full(n, -np.inf), np.full(n, np.inf)
    A, b = P.A, P.b
    nz = np.count_nonzero(A, axis=1) == 1
    for r in np.nonzero(nz)[0]:
        i = int(np.flatnonzero(A[r])[0])
        v = b[r] / A[r, i]
        if A[r, i] > 0:
            hi[i] = min(hi[i], v)
        else:
            lo[i] = max(lo[i], v)
    return lo, hi


class _PieceLP:
    """One piece ``{s : A s <= b}`` (scaled coordinates, within the relaxed unit box) loaded once in
    HiGHS (``highspy``); its LPs change only the cost or one row bound, so each re-solve starts
    from the previous basis.

    :meth:`upper_bound` returns a bound proven from HiGHS's row duals, whatever their accuracy: for
    any ``y >= 0``, ``c' s = y' A s + (c - A' y)' s <= y' b + |c - A' y|' 1 (1 + margin)`` on the
    piece (every piece lies in the unit box of ``X``, relaxed).  Redundant rows are found by the
    same model; a row wrongly called redundant only enlarges the set, the safe side.
    """

    def __init__(self, A: np.ndarray, b: np.ndarray):
        import highspy

        self._hs = highspy
        self.A, self.b = A, b
        k, n = A.shape
        with captured_native_output("highspy.Highs"):
            h = highspy.Highs()
        h.setOptionValue("output_flag", False)
        inf = highspy.kHighsInf
        lp = highspy.HighsLp()
        lp.num_col_, lp.num_row_ = n, k
        lp.col_cost_ = np.zeros(n)
        lp.col_lower_, lp.col_upper_ = np.full(n, -inf), np.full(n, inf)
        lp.row_lower_, lp.row_upper_ = np.full(k, -inf), np.asarray(b, dtype=float).copy()
        A = np.asarray(A, dtype=float)
        nz = A != 0.0
        lp.a_matrix_.format_ = highspy.MatrixFormat.kRowwise
        lp.a_matrix_.start_ = np.concatenate([[0], np.cumsum(nz.sum(axis=1))]).astype(np.int32)
        lp.a_matrix_.index_ = np.nonzero(nz)[1].astype(np.int32)
        lp.a_matrix_.value_ = A[nz]
        # kWarning: HiGHS dropped matrix entries below its small-value threshold (1e-9); the rows it
        # solves then differ from A by less than that, and the bounds below are proven with A itself
        if h.passModel(lp) not in (highspy.HighsStatus.kOk, highspy.HighsStatus.kWarning):
            raise SolverError("set-membership filter: a piece's LP", "HiGHS", "passModel failed", "report this model")
        self._h, self._n, self._k = h, n, k
        self._cols = np.arange(n, dtype=np.int32)

    def _solve(self, c: np.ndarray):
        h = self._h
        h.changeColsCost(self._n, self._cols, -np.asarray(c, dtype=float))  # HiGHS minimises
        h.run()
        return h.getModelStatus()

    def feasible(self) -> bool | None:
        """True / False when HiGHS says so (False still to be confirmed), None when it cannot tell."""
        st = self._solve(np.zeros(self._n))
        MS = self._hs.HighsModelStatus
        if st == MS.kOptimal:
            return True
        if st == MS.kInfeasible:
            return False
        return None

    def upper_bound(self, c: np.ndarray, active: np.ndarray | None = None) -> float:
        """A proven bound on ``max c' s`` over the piece (rows ``active`` only, default all)."""
        st = self._solve(c)
        if st != self._hs.HighsModelStatus.kOptimal:
            raise SolverError("set-membership filter: the bounding box of a piece", "HiGHS", str(st),
                              "the piece should be non-empty and bounded; report this model")
        y = np.maximum(-np.asarray(self._h.getSolution().row_dual, dtype=float), 0.0)
        A, b = self.A, self.b
        if active is not None:
            y = np.where(active, y, 0.0)
        r = np.asarray(c, dtype=float) - A.T @ y
        return float(y @ b + np.abs(r).sum() * (1.0 + SET_FILTER_UNIT_BOX_MARGIN))

    def box(self) -> tuple[np.ndarray, np.ndarray]:
        """Proven ``(lower, upper)`` of the piece, 2n re-solves."""
        lo, hi = np.empty(self._n), np.empty(self._n)
        for i in range(self._n):
            e = np.zeros(self._n)
            e[i] = 1.0
            hi[i] = self.upper_bound(e)
            lo[i] = -self.upper_bound(-e)
        return lo, hi

    def irredundant(self, rtol: float) -> np.ndarray:
        """Mask of the rows kept: a row goes when the others keep ``a_i' s`` within ``b_i + rtol``."""
        h, inf = self._h, self._hs.kHighsInf
        keep = np.ones(self._k, dtype=bool)
        for i in range(self._k):
            h.changeRowBounds(i, -inf, float(self.b[i]) + 1.0)  # keeps the LP bounded
            st = self._solve(self.A[i])
            value = -h.getInfo().objective_function_value
            if st == self._hs.HighsModelStatus.kOptimal and value <= self.b[i] + rtol * (1.0 + abs(self.b[i])):
                keep[i] = False
                h.changeRowBounds(i, -inf, inf)  # gone for the next rows' tests too
            else:
                h.changeRowBounds(i, -inf, float(self.b[i]))
        return keep


class SetMembershipFilter(Observer):
    """The states consistent with every sample so far under bounded output noise (module docstring).

    Parameters
    ----------
    system : PWASystem
        The model, with bounded ``X`` (for a constant unknown parameter, the augmented system of
        :func:`~hybobs_opt.systems.parameters.augment_parameters`).
    noise_bound : float, sequence or dict
        Bound on each output's noise in the outputs' units (0: noise-free data).
    tolerance : float, sequence or dict, optional
        Largest radius per state for the flag ``observable``; default ``MHE_UNIQUENESS_DELTA``
        times the half-widths of ``X``'s bounding box.
    max_pieces : int, default SET_FILTER_MAX_PIECES
        Largest number of polytopes kept.

    See Also
    --------
    hybobs_opt.mhe.SetMembershipObserver : The same over a moving window.
    NoiseAwareLookupObserver : A lookup observer under bounded noise.

    Notes
    -----
    Flags: ``observable`` -- every radius within the tolerance; ``unobservable`` -- some radius
    beyond it; ``fallback`` -- a bad sample (the set is then predicted through every mode whose
    guard it meets, which keeps the true state), or no state consistent with the record (the data
    contradict the model or the bound: the filter starts again from ``X``, ``info["reason"]``).
    ``info``: ``radius``, ``lower``, ``upper`` (model units), ``tolerance``, ``n_pieces``,
    ``modes`` (the modes of the pieces consistent with the sample).

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import SetMembershipFilter
    >>> obs = SetMembershipFilter(plant, 0.001)            # |output noise| <= 0.001 rad/s
    >>> trace = obs.run(U[:10], truth.y[:10])
    >>> radius = trace.radii()[-1]

    The true state lies within the certified radius of the estimate:

    >>> bool(np.all(np.abs(trace.x_hat[-1] - truth.x[9]) <= radius + 1e-9))
    True
    >>> trace.info[-1]["n_pieces"] >= 1
    True
    """

    name = "set-filter"

    def __init__(self, system, noise_bound, *, tolerance=None, max_pieces: int = SET_FILTER_MAX_PIECES):
        from .._numba_cache import tier_up

        tier_up()  # the compiled kernels now, not in the middle of a run of steps
        from ..systems.pwa import PWASystem

        if not isinstance(system, PWASystem):
            raise ModelError("system", "a PWASystem with bounded X", type(system).__name__)
        max_pieces = as_int(max_pieces, "max_pieces", minimum=1)
        self.system = system
        self.n, self.m, self.p = system.n, system.m, system.p
        self.state_names = tuple(system.state_names)
        self.noise_bound = noise_bound_vector(noise_bound, system.output_names)
        from ..systems.ranges import output_range

        lo_y, hi_y = output_range(system)
        #: the bound the filter uses: never below SET_FILTER_MIN_NOISE_RTOL of each output's range (a
        #: slab thinner than the LP solver's feasibility tolerance would be decided by rounding; a
        #: wider bound only keeps more states)
        self.effective_noise_bound = np.maximum(self.noise_bound, SET_FILTER_MIN_NOISE_RTOL * (hi_y - lo_y))
        half, centre = system.scales()
        self._h, self._c = np.asarray(half[: self.n], float), np.asarray(centre[: self.n], float)
        self.tolerance = radius_tolerance_vector(tolerance, self.state_names, MHE_UNIQUENESS_DELTA * self._h)
        self.max_pieces = int(max_pieces)
        judge_samples_against(self, system, outputs=False)
        # everything below works in scaled state coordinates s = (x - c) / h
        X = system.state_bounds
        self._X = Polytope(X.A * self._h[None, :], X.b - X.A @ self._c)
        self._modes = []
        for md in system.modes:
            G = md.guard.A
            Gx = G[:, : self.n] * self._h[None, :]
            A_s = md.A * self._h[None, :] / self._h[:, None]  # s+ = A_s s + (A c + a - c + B u) / h
            off = (md.A @ self._c + md.a - self._c) / self._h
            self._modes.append((Gx, G[:, self.n:], md.guard.b - G[:, : self.n] @ self._c, md.C * self._h[None, :],
                                md.C @ self._c + md.c, md.D, A_s, off, md.B / self._h[:, None]))
        self.n_lps = 0
        self.reset()

    def reset(self, x0=None, **kwargs) -> None:
        """Start from ``X`` (every state the model allows); ``x0`` is the estimate reported until the first sample."""
        check_reset_keywords(kwargs, type(self).__name__)
        from ..contract import checked_state

        self._set_pieces([self._X])
        self._step_count = 0
        self._x = self._c.copy() if x0 is None else checked_state(x0, self.n)

    def _set_pieces(self, pieces: list[Polytope], boxes: list | None = None) -> None:
        """The pieces of the coming step and an outer box of each: ``boxes`` when known (the
        interval image of the previous boxes), else the pieces' single-coordinate rows."""
        if not pieces:
            pieces, boxes = [self._X], None  # every piece left X: the next sample says whether the data agree
        self._pieces = pieces
        one = np.ones(self.n) * (1.0 + SET_FILTER_UNIT_BOX_MARGIN)
        if boxes is None:
            boxes = [_row_box(P, self.n) for P in pieces]
        self._piece_boxes = [(np.maximum(lo, -one), np.minimum(hi, one)) for lo, hi in boxes]

    # ------------------------------------------------------------------ polytope steps
    def _relaxed(self, A: np.ndarray, b: np.ndarray) -> Polytope:
        norms = np.linalg.norm(A, axis=1)
        keep = norms > 0
        if np.any(~keep & (b < -SET_FILTER_ROW_RTOL)):
            return Polytope.empty(self.n)
        return Polytope(A[keep], b[keep] + SET_FILTER_ROW_RTOL * (norms[keep] + np.abs(b[keep])))

    def _nonempty(self, P: Polytope) -> _PieceLP | None:
        """The piece's LP model when the piece is non-empty; ``None`` when it is empty (HiGHS's
        answer confirmed by :func:`~hybobs_opt.geometry.lp.solve_lp`, which checks it)."""
        self.n_lps += 1
        model = _PieceLP(P.A, P.b)
        if model.feasible():
            return model
        try:
            res = solve_lp(np.zeros(self.n), P.A, P.b, problem="set-membership filter: emptiness of a piece")
        except SolverError:
            return model  # not proven empty: kept (the safe side)
        return None if res.status == "infeasible" else model

    @staticmethod
    def _box_excludes(lo: np.ndarray, hi: np.ndarray, A: np.ndarray, b: np.ndarray) -> bool:
        """Whether some row ``a' s <= b`` fails at every point of the box ``[lo, hi]`` (with the
        relaxation's margin): the piece inside the box then misses the row, no LP needed."""
        with np.errstate(invalid="ignore"):  # 0 * inf: a coordinate the row does not involve
            least = np.where(A > 0, A * lo[None, :], np.where(A < 0, A * hi[None, :], 0.0)).sum(axis=1)
        margin = 2.0 * SET_FILTER_ROW_RTOL * (np.linalg.norm(A, axis=1) + np.abs(b)) + 1e-12
        return bool(np.any(least > b + margin))

    def _measure(self, u: np.ndarray, y: np.ndarray | None) -> list[tuple[Polytope, int]]:
        out = []
        beta = self.effective_noise_bound
        for P, (lo, hi) in zip(self._pieces, self._piece_boxes):
            for q, (Gx, Gu, g, C, cy, D, _, _, _) in enumerate(self._modes):
                rows, rhs = [Gx], [g - Gu @ u]
                if y is not None:
                    yfix = y - cy - D @ u
                    rows += [C, -C]
                    rhs += [yfix + beta, beta - yfix]
                new_A, new_b = np.vstack(rows), np.concatenate(rhs)
                if self._box_excludes(lo, hi, new_A, new_b):
                    continue
                Q = self._relaxed(np.vstack([P.A, new_A]), np.concatenate([P.b, new_b]))
                model = self._nonempty(Q) if Q.A.shape[0] else None
                if model is not None:
                    out.append((Q, q, model))
        return out

    def _box(self, pieces: list[tuple[Polytope, int]]) -> tuple[np.ndarray, np.ndarray, list]:
        lo, hi = np.full(self.n, np.inf), np.full(self.n, -np.inf)
        boxes = []
        kept = []
        for piece in pieces:
            self.n_lps += 2 * self.n
            box = self._piece_box(piece[0], piece[2])
            if box is None:
                continue  # proven empty
            kept.append(piece)
            boxes.append(box)
            lo, hi = np.minimum(lo, box[0]), np.maximum(hi, box[1])
        pieces[:] = kept
        return lo, hi, boxes

    def _piece_box(self, Q: Polytope, model: _PieceLP) -> tuple[np.ndarray, np.ndarray] | None:
        """Proven bounds of a piece: HiGHS's duals, else the checked LPs of
        :meth:`~hybobs_opt.geometry.polytope.Polytope.bounding_box` (``None``: the piece is empty),
        else the unit box of ``X`` (a thin piece no LP resolves: every piece lies in it)."""
        try:
            return model.box()
        except SolverError:
            pass
        try:
            return Q.bounding_box()
        except ModelError:
            return None
        except SolverError:
            one = np.full(self.n, 1.0 + SET_FILTER_UNIT_BOX_MARGIN)
            return -one, one

    def _predict(self, pieces: list[tuple[Polytope, int]], u: np.ndarray, boxes: list | None = None) -> list[Polytope]:
        """The pieces mapped by their modes' dynamics and cut to ``X``; ``boxes`` (the pieces'
        bounding boxes) lets rows implied by the mapped box go without an LP."""
        nxt, nxt_boxes = [], []
        self._step_count += 1
        full_pass = self._step_count % REDUNDANCY_PERIOD == 0
        for k, (Q, q, _) in enumerate(pieces):
            _, _, _, _, _, _, A_s, off, B_s = self._modes[q]
            shift = off + B_s @ u
            img = Q.affine_image(A_s, shift)
            A_all, b_all = np.vstack([img.A, self._X.A]), np.concatenate([img.b, self._X.b])
            lo1 = hi1 = None
            if boxes is not None:
                # the image's bounding box (interval arithmetic on the piece's box) holds the image:
                # its rows join, and every row it implies goes (the set does not change)
                c0, r0 = 0.5 * (boxes[k][0] + boxes[k][1]), 0.5 * (boxes[k][1] - boxes[k][0])
                c1, r1 = A_s @ c0 + shift, np.abs(A_s) @ r0
                lo1, hi1 = c1 - r1, c1 + r1
                most = np.where(A_all > 0, A_all * hi1[None, :], A_all * lo1[None, :]).sum(axis=1)
                keep = most > b_all
                eye = np.eye(self.n)
                A_all = np.vstack([A_all[keep], eye, -eye])
                b_all = np.concatenate([b_all[keep], hi1, -lo1])
            R = self._relaxed(A_all, b_all)
            model = self._nonempty(R) if R.A.shape[0] else None
            if model is None:
                continue
            if full_pass or R.A.shape[0] > MAX_ROWS_BEFORE_REDUNDANCY:
                self.n_lps += R.A.shape[0]
                keep = model.irredundant(SET_FILTER_REDUNDANCY_RTOL)
                R = Polytope(R.A[keep], R.b[keep])
            nxt.append(R)
            nxt_boxes.append((lo1, hi1) if lo1 is not None else _row_box(R, self.n))
        if len(nxt) > self.max_pieces:
            while len(nxt) > self.max_pieces:
                nxt = self._merge_nearest(nxt)
            nxt_boxes = [_row_box(P, self.n) for P in nxt]
        self._next_boxes = nxt_boxes
        return nxt

    def _merge_nearest(self, pieces: list[Polytope]) -> list[Polytope]:
        """The two pieces with the nearest Chebyshev centres replaced by one polytope holding both:
        every row of either, at the larger of its two proven supports (an outer bound of their
        union that keeps both pieces' directions -- the correlations the data taught -- with no
        vertex enumeration, whose hulls of 4-D pieces ran to hundreds of facets)."""
        centres = []
        for P in pieces:
            c, _ = P.chebyshev_ball()
            centres.append(np.zeros(self.n) if c is None else c)
        C = np.array(centres)
        d = np.linalg.norm(C[:, None, :] - C[None, :, :], axis=2) + np.diag(np.full(len(pieces), np.inf))
        i, j = np.unravel_index(int(np.argmin(d)), d.shape)
        P, Q = pieces[i], pieces[j]
        rows = np.vstack([P.A, Q.A])
        try:
            mp, mq = _PieceLP(P.A, P.b), _PieceLP(Q.A, Q.b)
            self.n_lps += rows.shape[0]
            sup_p = np.concatenate([P.b, [mp.upper_bound(a) for a in Q.A]])
            sup_q = np.concatenate([[mq.upper_bound(a) for a in P.A], Q.b])
            merged = self._relaxed(rows, np.maximum(sup_p, sup_q))
        except SolverError:
            a1, b1 = _row_box(P, self.n)
            a2, b2 = _row_box(Q, self.n)
            one = np.ones(self.n)
            box = Polytope.from_box(np.maximum(np.minimum(a1, a2), -one), np.minimum(np.maximum(b1, b2), one))
            merged = self._relaxed(np.vstack([box.A, self._X.A]), np.concatenate([box.b, self._X.b]))
        if merged.A.shape[0] > MAX_ROWS_BEFORE_REDUNDANCY:
            model = _PieceLP(merged.A, merged.b)
            if model.feasible():
                keep = model.irredundant(SET_FILTER_REDUNDANCY_RTOL)
                merged = Polytope(merged.A[keep], merged.b[keep])
        return [R for k, R in enumerate(pieces) if k not in (i, j)] + [merged]

    # ------------------------------------------------------------------ steps
    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        try:
            return self._update(u, y)
        except SolverError as exc:
            # the sample is not used: the set is predicted through every mode, which keeps the true state
            return self._fallback(u, f"an LP of the set update failed ({exc}); the sample was not used")

    def _update(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        t0 = time.perf_counter()
        pieces = self._measure(u, y)
        if not pieces:
            return self._inconsistent()
        lo_s, hi_s, boxes = self._box(pieces)
        if not pieces:
            return self._inconsistent()
        lower, upper = self._c + self._h * lo_s, self._c + self._h * hi_s
        x = 0.5 * (lower + upper)
        radius = 0.5 * (upper - lower)
        modes = sorted({q for _, q, _ in pieces})
        self._x = x
        nxt = self._predict(pieces, u, boxes)
        self._set_pieces(nxt, self._next_boxes if nxt else None)
        flag = OBSERVABLE if np.all(radius <= self.tolerance) else UNOBSERVABLE
        info = {"radius": radius, "lower": lower, "upper": upper, "tolerance": self.tolerance,
                "n_pieces": len(pieces), "modes": modes, "seconds_sets": time.perf_counter() - t0}
        return Estimate(x.copy(), modes[0] if len(modes) == 1 else -1, flag, 0.0, info)

    def _inconsistent(self) -> Estimate:
        reason = ("no state is consistent with the record within the stated noise bound: the data contradict the "
                  "model or the bound; the filter starts again from X")
        self._set_pieces([self._X])
        return Estimate(self._x.copy(), -1, FALLBACK, 0.0, {"reason": reason, "n_pieces": 0})

    def _predict_boxes(self, u: np.ndarray | None) -> None:
        """Without LPs: each piece's outer box mapped through every mode by interval arithmetic, the
        union's box cut to ``X`` as the one piece of the next step (sound, and it keeps the bounds of
        the coordinates the dynamics leave alone, such as a constant parameter)."""
        lo_all, hi_all = np.full(self.n, np.inf), np.full(self.n, -np.inf)
        one = np.ones(self.n)
        for lo, hi in self._piece_boxes:
            lo, hi = np.maximum(lo, -one), np.minimum(hi, one)
            c0, r0 = 0.5 * (lo + hi), 0.5 * (hi - lo)
            for q in range(len(self._modes)):
                _, _, _, _, _, _, A_s, off, B_s = self._modes[q]
                shift = off + (B_s @ u if u is not None else 0.0)
                if u is None:  # the input is unknown: anywhere in U
                    continue
                c1, r1 = A_s @ c0 + shift, np.abs(A_s) @ r0
                lo_all, hi_all = np.minimum(lo_all, c1 - r1), np.maximum(hi_all, c1 + r1)
        if u is None or not np.all(np.isfinite(lo_all)):
            self._set_pieces([self._X])
            return
        lo_all, hi_all = np.maximum(lo_all, -one), np.minimum(hi_all, one)
        if np.any(lo_all > hi_all):
            self._set_pieces([self._X])
            return
        box = Polytope.from_box(lo_all, hi_all)
        self._set_pieces([self._relaxed(np.vstack([box.A, self._X.A]), np.concatenate([box.b, self._X.b]))])

    def _fallback(self, u, reason: str) -> Estimate:
        # a bad sample: no measurement update; the set is predicted through every mode its pieces meet
        if u is not None:
            try:
                pieces = self._measure(np.asarray(u, float), None)
                self._set_pieces(self._predict(pieces, np.asarray(u, float)))
            except SolverError:
                self._predict_boxes(np.asarray(u, float))
        else:
            self._set_pieces([self._X])  # the input is unknown too: every state of X
        return Estimate(self._x.copy(), -1, FALLBACK, 0.0, {"reason": reason})

"""Is the window-start state unique?  The separated program behind the flag ``observable`` of the
moving-horizon observer (paper 002, eq. 10 and Section 4.1).

Section 4.1 of paper 002 (Bemporad, Ferrari-Trecate & Morari, 2000) explains that one minimiser
of (10) cannot tell whether ``x(t-T+1)`` is observable.  :class:`SeparatedProgram` asks the
question that can: after the certified optimum ``J*`` with window-start state ``xi0*`` (scaled),
is there an admissible window trajectory, one of whose states -- the window start, the reported
current state or any between -- is at least ``delta`` away from the optimum's (``||xi_k -
xi_k*||_inf >= delta``, scaled), whose cost is at most ``J* + epsilon``?  Separating the window
start alone is not enough: on ``y = x2`` with a rotation, the mirror state stays within ``delta``
at the window start and is far from the reported state.  It is a second mixed-integer program on
the same MLD rows, built once and re-solved per window; the Notes of :class:`~hybobs_opt.mhe.observer.MHEObserver` describe the
three stages (a QP along weak directions of the optimal sequence, the norm-2 MIQP with a cutoff,
and for norms 1 / inf the MILP).  Every point a solver returns is re-checked in numpy before it
counts as an alternative.
"""

from __future__ import annotations

import enum
import time

import numpy as np

from ..defaults import MHE_CERTIFY_MAX_NODES, MHE_UNIQUENESS_MAX_SOLVES
from ..errors import SolverError
from ..tolerances import (
    MHE_FEASIBILITY_TOL,
    MHE_INTEGRALITY_TOL,
    MHE_UNIQUENESS_COST_ATOL,
    MHE_UNIQUENESS_COST_RTOL,
    MHE_UNIQUENESS_PROX_WEIGHT,
    mhe_decision_band,
)
from .backends import DaqpBackend, milp_backend
from .residual import StackedResidual
from .result import WindowResult
from .window import WindowModel

__all__ = ["SeparatedProgram", "UniquenessOutcome"]


class UniquenessOutcome(enum.StrEnum):
    """Outcome of the uniqueness test behind the flag ``observable``: the ``status`` of
    ``info["uniqueness"]`` (and of :attr:`~hybobs_opt.mhe.WindowResult.uniqueness`).

    The members are string-valued (:class:`enum.StrEnum`): ``UniquenessOutcome.UNIQUE ==
    "unique"``, and ``json.dumps`` writes the plain string, so saved ``info`` and ``--json``
    output keep the text they always had.

    See Also
    --------
    WindowResult.uniqueness : Where the outcome is reported.
    MHEObserver : Flags ``observable`` only on ``UNIQUE``.

    Examples
    --------
    >>> from hybobs_opt.mhe import UniquenessOutcome
    >>> [str(o) for o in UniquenessOutcome]  # doctest: +ELLIPSIS
    ['unique', 'alternative', 'not certified', 'not unique for every input']
    >>> UniquenessOutcome.UNIQUE == "unique"
    True
    """

    #: No admissible window trajectory with a state ``delta`` away from the optimum's costs at
    #: most ``J* + epsilon`` (or the saved analysis says the estimate is observable): ``observable``.
    UNIQUE = "unique"
    #: One does (``info["alternative"]`` holds it, re-checked in numpy): ``unobservable``.
    ALTERNATIVE = "alternative"
    #: Neither was proven (a solver failure, the decision band, the solve limit; ``reason`` says
    #: which): ``fallback``.
    NOT_CERTIFIED = "not certified"
    #: The saved analysis (Definition 2.2) says the estimate is not observable for every input
    #: sequence: ``unobservable``.
    NOT_UNIQUE_FOR_EVERY_INPUT = "not unique for every input"


class SeparatedProgram:
    """The separated program of the uniqueness test, built once for one window problem.

    Parameters
    ----------
    model : WindowModel
        The window's model, weights and cost.
    res : StackedResidual
        The stacked residual of the cost.
    solver : str
        The observer's solver (its options reach the MIQP only when it is ``"daqp"``; norms 1 / inf
        build the MILP on it).
    delta : float
        Separation (inf-norm, units of the half-widths of ``X``).
    Js : float
        Scale of the observer's objective (norm 2) or of its MILP slacks (norms 1 / inf).
    eq_rows : bool array
        Equality rows of the MLD encoding.
    milp_problem : tuple or None
        ``(c, A, lb, ub, discrete)`` of the observer's MILP (norms 1 / inf), with ``nslack`` slacks.
    nslack : int
    options : dict
        The user's solver options.
    build : bool
        ``False``: only ``epsilon`` is computed (the observer's settings have
        ``check_uniqueness=False``); no program is built.
    epsilon : float, optional
        The cost tolerance itself (norm 2), instead of the relative default below: the observer's
        chi-square quantile with ``noise_std``.

    Attributes
    ----------
    epsilon : float
        Cost tolerance: the ``epsilon`` given, else :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_COST_RTOL` times one sample's
        squared weighted output half-range plus :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_COST_ATOL`
        (norms 1 / inf: the square root).
    prox_weight : float
        Proximal weight of the MIQP (the smallest DAQP factorises).
    miqp, milp : Backend or None
        The norm-2 MIQP (DAQP) and, for norms 1 / inf, the MILP.

    See Also
    --------
    MHEObserver : Builds one per observer and runs it on every optimal window.
    UniquenessOutcome : Its outcomes.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> obs = MHEObserver(plant, 3)
    >>> res = obs.solve_window(U[:3], truth.y[:3], uniqueness=True)
    >>> res.uniqueness["status"]
    <UniquenessOutcome.UNIQUE: 'unique'>

    The flag ``observable`` is this program's ``"unique"``:

    >>> obs.run(U, truth.y).flag_counts()["observable"]
    8
    """

    def __init__(self, model: WindowModel, res: StackedResidual, *, solver: str, delta: float, Js: float,
                 eq_rows: np.ndarray, milp_problem: tuple | None, nslack: int, options: dict, build: bool = True,
                 epsilon: float | None = None):
        self.model, self.enc, self._res = model, model.enc, res
        self.n, self.T, self.norm, self.solver = model.n, model.T, model.norm, solver
        self.delta, self._Js, self._eq_rows = float(delta), float(Js), eq_rows
        self._milp_problem, self._nslack = milp_problem, nslack
        self.built = bool(build)
        self.prox_weight: float | None = None
        self._epsilon_given = None if epsilon is None else float(epsilon)
        self._build(dict(options))

    def _build(self, options: dict) -> None:
        """Build the separated program: eq. (10) on the same MLD rows plus ``||xi_k - xi_k*||_inf >= delta``
        at some window step ``k``.

        Direction binaries ``b`` (``2 n T``: a side of each coordinate of each window state, see
        :meth:`direction`) with ``sum b = 1`` choose the step, coordinate and side of the
        separation, through the big-M rows ``+-(xi_k,j - xi_k,j*) >= delta - M (1 - b_kj+-)`` on
        the scaled window states ``xi_k = (Xmap_k v + Xoff_k - c) / h`` (affine in the MLD
        variables ``v``), with ``M = delta + max_j (ub_j - lb_j)`` over the box of ``X`` (every
        window state lies in ``X`` by the MLD's rows, and ``xi_k*`` is clipped to the box, so
        ``M`` is valid wherever ``b = 0``).  The rows' matrix is fixed; the
        optimum's states enter only their bounds, so every program is built once here and
        re-solved each step.  Every norm gets the norm-2 MIQP for DAQP (its own workspace,
        proximal weight :data:`~hybobs_opt.tolerances.MHE_UNIQUENESS_PROX_WEIGHT`): for norm 2
        it decides, for norms 1 / inf it is a sufficient bound (see :meth:`decide`); norms
        1 / inf also get the MILP with the slacks of the MILP of the observer, which decides.
        """
        enc, res = self.enc, self._res
        n, nv = self.n, enc.n_vars
        xi = enc.slices["xi0"]
        self._lbx, self._ubx = enc.lb[xi].copy(), enc.ub[xi].copy()
        delta = self.delta
        # scaled window states xi_k = Smap[k] v + soff[k]
        hx, cx = self.model.hx, self.model.cx
        self._Smap = enc.Xmap / hx[None, :, None]
        self._soff = (enc.Xoff - cx[None, :]) / hx[None, :]
        # every window state lies in X (the MLD's rows; the start by its bounds when X is a box),
        # hence in the box of X: the box's widest range bounds every separation row
        M = delta + float(np.max(self._ubx - self._lbx))
        self._M = M
        nb = 2 * n * self.T
        self._nb = nb
        # output scale of epsilon: one sample's squared weighted half-range of the outputs
        rng = enc.big_m.output_range
        hy = 0.5 * (rng[:, 1] - rng[:, 0])
        Wh = self.model.Wy * hy[None, :]
        S_y = float(np.max(np.einsum("ij,ij->j", Wh, Wh)))
        eps2 = MHE_UNIQUENESS_COST_RTOL * S_y + MHE_UNIQUENESS_COST_ATOL if self._epsilon_given is None else self._epsilon_given
        self.epsilon = eps2 if self.norm == "2" else float(np.sqrt(eps2))
        self._eps2 = eps2
        self.miqp = self.milp = None
        if not self.built:
            return
        # separation rows (scaled by 1 / M: largest coefficient one) and the one-hot row of b
        # direction d = 2 (k n + j) (+1 for the minus side): state k, coordinate j
        rows = self._Smap.reshape(self.T * n, nv) / M
        Sx = np.zeros((nb, nv))
        Sx[0::2], Sx[1::2] = rows, -rows
        Sb = -np.eye(nb)
        one = np.concatenate([np.zeros(nv), np.ones(nb)])[None, :]
        A = np.vstack([np.hstack([enc.A, np.zeros((enc.n_constraints, nb))]), np.hstack([Sx, Sb]), one])
        eq = np.concatenate([self._eq_rows, np.zeros(nb, dtype=bool), [True]])
        RtR = res.R.T @ res.R
        d = np.diag(RtR)
        self._Js2 = self._Js if self.norm == "2" else (float(d.max()) if d.max() > 0 else 1.0)
        H0 = np.zeros((nv + nb, nv + nb))
        H0[:nv, :nv] = 2.0 * RtR / self._Js2
        lb = np.concatenate([enc.lb, np.zeros(nb)])
        ub = np.concatenate([enc.ub, np.ones(nb)])
        disc = np.concatenate([enc.discrete, np.ones(nb, dtype=bool)])
        self._lb, self._ub, self._disc = lb, ub, disc
        # The DAQP package whatever the observer's solver: casadi-daqp's bundled DAQP mishandles
        # equality rows and Bonmin has no cutoff (see the Notes of MHEObserver); the user's options are
        # passed on only when they are DAQP's.  The proximal weight is the smallest of a ladder
        # from MHE_UNIQUENESS_PROX_WEIGHT whose Hessian DAQP factorises (its own factorisation
        # loses ~nv * 1e-16 on the pivots: 1e-13 passes on model 16, 3e-13 is needed with 46
        # variables), with zero_tol a tenth of it so that the smallest pivots count as nonzero.
        # abs_subopt = 0: there is no incumbent to prune against, only the cutoff, and any
        # suboptimality allowance would widen the band of undecided windows.
        self.miqp = None
        for w in MHE_UNIQUENESS_PROX_WEIGHT * np.array([1.0, 3.0, 10.0, 30.0, 100.0, 300.0, 1000.0]):
            opts = {"zero_tol": 0.1 * w, "abs_subopt": 0.0, **(options if self.solver == "daqp" else {})}
            backend = DaqpBackend(H0 + 2.0 * w * np.eye(nv + nb), A, lb, ub, disc, eq, opts)
            if backend.probe():
                self.miqp, self.prox_weight = backend, float(w)
                self._eps = np.full(nv + nb, float(w))
                self._H0 = H0
                break
        if self.miqp is None:
            raise SolverError("uniqueness MIQP of the MHE observer", "daqp", "Hessian not factorised (exit -5)",
                              hint="MHESettings(check_uniqueness=False) (the flag then only means a certified optimum)")
        if self.norm == "2":
            return
        c, A0, lb0, ub0, disc0 = self._milp_problem
        ns = self._nslack
        A = np.vstack([np.hstack([A0, np.zeros((A0.shape[0], nb))]),
                       np.hstack([Sx, np.zeros((nb, ns)), Sb]),
                       np.concatenate([np.zeros(nv + ns), np.ones(nb)])[None, :]])
        c = np.concatenate([c, np.zeros(nb)])
        lb = np.concatenate([lb0, np.zeros(nb)])
        ub = np.concatenate([ub0, np.ones(nb)])
        disc = np.concatenate([disc0, np.ones(nb, dtype=bool)])
        # solver "sequences" leaves the later-state directions its LPs cannot decide to HiGHS's MILP
        solver, opts = ("highs", {}) if self.solver == "sequences" else (self.solver, options)
        self.milp = milp_backend(solver, c, A, lb, ub, disc, opts, problem="uniqueness MILP of the MHE observer")

    def refresh_hessian(self) -> None:
        """Rebuild the MIQP's Hessian from the residual's current rows (a time-varying arrival cost
        changes them in place; :class:`~hybobs_opt.mhe.arrival.KalmanArrival`).  The workspace
        is updated, not rebuilt; ``Js`` (the objective's scale) stays the one of construction."""
        if self.miqp is None:
            return
        nv = self.enc.n_vars
        R = self._res.R
        H0 = self._H0.copy()
        H0[:nv, :nv] = 2.0 * (R.T @ R) / self._Js2
        self._H0 = H0
        self.miqp.set_hessian(H0 + 2.0 * self.prox_weight * np.eye(H0.shape[0]))

    def decide(self, U: np.ndarray, Y: np.ndarray, xbar: np.ndarray, opt: WindowResult, steps=None,
               directions: np.ndarray | None = None) -> dict:
        """Is the window trajectory of the certified optimum ``opt`` unique (to ``delta``, ``epsilon``)?

        Returns a dict with ``status`` (a :class:`UniquenessOutcome`) ``"unique"`` (no admissible
        window trajectory with a state at least ``delta`` away from the optimum's at the same
        step, inf-norm in units of the half-widths of ``X``, has cost ``<= J* + epsilon``: the
        reported current state and the window start are both unique), ``"alternative"`` (one
        has: ``alternative`` holds it, with the ``step`` where it is farthest, verified in numpy)
        or ``"not certified"`` (``reason``); ``decided_by``, ``separated_cost`` (exact cost of
        the alternative found, else ``None``), ``separated_cost_bound`` (a proven lower bound of
        the separated minimum), ``threshold = J* + epsilon``, ``decision_band`` and ``seconds``.

        Parameters
        ----------
        U : (T, m) ndarray
            Window inputs.
        Y : (T, p) ndarray
            Window outputs.
        xbar : (n,) ndarray
            Prior estimate of the window-start state (the arrival-cost term of the cost).
        opt : WindowResult
            The certified optimum of the window problem.
        steps : iterable of int, optional
            Window steps whose states are separated (default every one, ``0 .. T-1``).
        directions : (2 n T,) bool ndarray, optional
            Only these directions (:meth:`direction`) are separated, of those ``steps`` allows
            (solver ``"sequences"`` passes the ones its separated LPs left undecided).

        Returns
        -------
        dict
            ``status`` (a :class:`UniquenessOutcome`) and what supports it (the alternative
            found, the
            solver's answer).
        """
        t0 = time.perf_counter()
        try:
            out = self._decide(U, Y, xbar, opt, steps, directions)
        except Exception as exc:  # a crashing solver must not stop the observer loop
            out = {"status": UniquenessOutcome.NOT_CERTIFIED, "reason": f"{type(exc).__name__}: {exc}"}
        out["seconds"] = time.perf_counter() - t0
        return out

    def separation_rows(self, xs: np.ndarray, direction: int, modes=None, U=None) -> tuple[np.ndarray, np.ndarray]:
        """``sign (xi_k,j - xs_k,j) >= delta`` for the direction ``d = 2 (k n + j) (+1)`` as a row
        ``G theta <= g`` in the variables ``theta = [xi0; omega]`` of one mode sequence.

        Parameters
        ----------
        xs : (T, n) ndarray
            Scaled window states of the optimum (clipped to the box of ``X``).
        direction : int
            Index of the direction.
        modes : (T,) int array_like, optional
            The mode sequence (needed for a state after the window start, an affine map of
            ``theta`` that depends on the modes).
        U : (T, m) ndarray, optional
            Window inputs (with ``modes``).

        Returns
        -------
        G : (1, n) or (1, n_theta) ndarray
            The row (on ``xi0`` alone for the window start).
        g : (1,) ndarray
            Its right-hand side.
        """
        k, j, sign = self.direction(direction)
        if k == 0:
            G = np.zeros((1, self.n))
            G[0, j] = -float(sign)
            return G, np.array([-float(sign) * xs[0, j] - self.delta])
        Pv, pv = self.model._vmap(modes, U)
        a = self._Smap[k, j]
        return (-float(sign) * (a @ Pv))[None, :], np.array([float(sign) * (a @ pv + self._soff[k, j] - xs[k, j]) - self.delta])

    def direction(self, d: int) -> tuple[int, int, int]:
        """``(k, j, sign)`` of direction ``d``: window step, state coordinate, side.

        Returns
        -------
        tuple of three int
            ``(k, j, sign)`` of direction ``d``: window step, state coordinate, side.
        """
        kj, side = divmod(int(d), 2)
        k, j = divmod(kj, self.n)
        return k, j, (1 if side == 0 else -1)

    def scaled_states(self, states: np.ndarray) -> np.ndarray:
        """``(T, n)`` window states scaled by the box of ``X`` (``(x - c) / h``).

        Returns
        -------
        ndarray
            ``(T, n)`` window states scaled by the box of ``X`` (``(x - c) / h``).
        """
        return (np.asarray(states, dtype=float) - self.model.cx) / self.model.hx

    def optimum_states(self, opt: WindowResult) -> np.ndarray:
        """The optimum's scaled window states, clipped to the box of ``X`` (the centres of the separation).

        Returns
        -------
        ndarray
            The optimum's scaled window states, clipped to the box of ``X`` (the centres of the
            separation).
        """
        return np.clip(self.scaled_states(opt.states), self._lbx, self._ubx)

    def allowed(self, xs: np.ndarray, steps=None) -> np.ndarray:
        """Directions that leave room in the box of ``X`` (``xs_k,j +- delta`` inside), on the
        window ``steps`` (default all).

        Returns
        -------
        ndarray
            The directions that leave room in the box of ``X`` on the window ``steps``.
        """
        ok = np.zeros((self.T, self.n, 2), dtype=bool)
        ok[:, :, 0] = xs + self.delta <= self._ubx
        ok[:, :, 1] = xs - self.delta >= self._lbx
        if steps is not None:
            mask = np.zeros(self.T, dtype=bool)
            mask[list(steps)] = True
            ok[~mask] = False
        return ok.reshape(-1)

    def alternative(self, x0, modes, U, Y, xbar, W, xs) -> dict | None:
        """A verified alternative: a model trajectory from ``x0`` with ``modes`` (and ``W``) that
        satisfies the MLD rows to :data:`MHE_FEASIBILITY_TOL`, has a state ``delta`` away from the
        optimum's state at the same step (to the same tolerance) and has its exact cost; else ``None``.

        Parameters
        ----------
        x0 : (n,) ndarray
            Candidate window-start state (unscaled).
        modes : (T,) int array_like
            0-based mode index of each step.
        U : (T, m) ndarray
            Window inputs.
        Y : (T, p) ndarray
            Window outputs.
        xbar : (n,) ndarray
            Prior estimate of the window-start state (arrival cost).
        W : (T - 1, n) ndarray
            Disturbances of the candidate trajectory.
        xs : (T, n) ndarray
            Scaled window states of the optimum.

        Returns
        -------
        dict or None
            ``x_start``, ``cost``, ``modes``, ``states``, ``w``, ``distance`` (the largest inf-norm
            distance of a window state, scaled) and ``step`` (where it is largest) of the verified
            alternative, or ``None``.
        """
        if not (np.all(np.isfinite(x0)) and np.all(np.isfinite(W))):
            return None
        modes = np.asarray(modes, dtype=int)
        states = self.model.trajectory(x0, modes, U, W)
        if not np.all(np.isfinite(states)):
            return None
        v = self.enc.pack(states, modes, U, W if self.enc.disturbances else None)
        if not (self.enc.violation(v, U.reshape(-1)) <= MHE_FEASIBILITY_TOL):
            return None
        gaps = np.max(np.abs(self.scaled_states(states) - xs), axis=1)
        step = int(np.argmax(gaps))
        dist = float(gaps[step])
        if not (dist >= self.delta - MHE_FEASIBILITY_TOL):
            return None
        cost = self.model.cost(states, modes, U, Y, W, xbar)
        if not np.isfinite(cost):
            return None
        return {"x_start": x0.copy(), "cost": cost, "modes": modes.copy(), "states": states, "w": W,
                "distance": dist, "step": step}

    def _decide(self, U, Y, xbar, opt: WindowResult, steps=None, directions=None) -> dict:
        enc, res = self.enc, self._res
        n, nv, nb, T = self.n, enc.n_vars, self._nb, self.T
        delta, eps = self.delta, self.epsilon
        J = float(opt.cost)
        thr = J + eps
        # a cost within the band of thr decides nothing (a fallback); outside it, below is an
        # alternative and every bound is proven above thr_hi
        band = mhe_decision_band(thr, eps)
        thr_lo, thr_hi = thr - band, thr + band
        base = {"delta": delta, "epsilon": eps, "threshold": thr, "decision_band": band, "separated_cost": None,
                "separated_cost_bound": None}
        xs = self.optimum_states(opt)
        allowed = self.allowed(xs, steps)
        if directions is not None:
            allowed &= np.asarray(directions, dtype=bool)
        if not allowed.any():
            return {**base, "status": UniquenessOutcome.UNIQUE, "decided_by": "box (no state of X is delta away)",
                    "separated_cost_bound": np.inf}
        # 1. a cheap sufficient test for an alternative (it can never prove uniqueness, which
        #    needs every mode sequence): when the optimal sequence's own least-squares map has a
        #    direction whose cost over delta stays below epsilon (the backlash of model (16)),
        #    one QP per admissible direction along it, with that sequence's guards
        cands: list[dict] = []
        prob = self.model.sequence_problem(opt.modes, U, Y, xbar)
        _, sv, Vt = np.linalg.svd(prob[0], full_matrices=True)
        sv = np.concatenate([sv, np.zeros(Vt.shape[0] - sv.size)])
        weak = sv * delta <= np.sqrt(self._eps2)
        if weak.any():
            # the window start's directions (d < 2 n) along the weak directions
            reach = np.max(np.abs(Vt[weak][:, :n]), axis=0)
            order = [d for d in np.argsort(-np.repeat(reach, 2), kind="stable") if allowed[d] and reach[d // 2] > 0]
            for d in order:
                pol = self.model.polish(opt.modes, U, Y, xbar, opt.x_start, opt.w,
                                        extra=self.separation_rows(xs, d), problem=prob, bound=True, robust=True)
                alt = None if pol is None else self.alternative(pol[0], opt.modes, U, Y, xbar, pol[1], xs)
                if alt is not None:
                    cands.append(alt)
                    if alt["cost"] <= thr_lo:
                        return {**base, "status": UniquenessOutcome.ALTERNATIVE, "decided_by": "optimal mode sequence",
                                "separated_cost": alt["cost"], "alternative": alt}
        # 2. norm 2: the branch and bound over mode prefixes with per-direction bounds
        #    (:mod:`hybobs_opt.mhe.unique_search`); undecided, the separated MIQP below decides
        prefix = None
        if self.norm == "2" and self.model.extension is None:
            from .unique_search import search_uniqueness

            prefix = search_uniqueness(self.model, U, Y, xbar, xs, allowed, delta, thr_lo, thr_hi,
                                       alternative=lambda x0, modes, W: self.alternative(x0, modes, U, Y, xbar, W, xs),
                                       max_nodes=MHE_CERTIFY_MAX_NODES)
            found = {"prefix_search": prefix.summary()}
            if prefix.unique:
                return {**base, **found, "status": UniquenessOutcome.UNIQUE, "decided_by": "prefix search",
                        "separated_cost_bound": thr_hi,
                        "separated_cost": min((c["cost"] for c in cands), default=None)}
            if prefix.alternative is not None and prefix.alternative["cost"] <= thr_lo:
                J_gap = J - max((opt.gap_bound or 0.0), 0.0) - eps
                if prefix.alternative["cost"] < J_gap:
                    return {**base, **found, "status": UniquenessOutcome.NOT_CERTIFIED, "separated_cost":
                            prefix.alternative["cost"], "reason": "a separated state beats the certified optimum "
                                                                  "(optimum not global)"}
                return {**base, **found, "status": UniquenessOutcome.ALTERNATIVE, "decided_by": "prefix search",
                        "separated_cost": prefix.alternative["cost"], "alternative": prefix.alternative}
        # 3. the separated mixed-integer programs over every mode sequence
        Uf, Yf = U.reshape(-1), Y.reshape(-1)
        lo, hi = enc.bounds(Uf)
        rp = res.offset(Yf, Uf, xbar, self.model.params)
        M = self._M
        sep_lo = np.empty(nb)
        soff = self._soff.reshape(-1)
        sep_lo[0::2] = (xs.reshape(-1) + delta - M - soff) / M
        sep_lo[1::2] = (-xs.reshape(-1) + delta - M + soff) / M
        vstar = enc.pack(opt.states, opt.modes, U, opt.w if enc.disturbances else None)
        detail: dict = {}
        # 2a. the norm-2 MIQP with a cutoff: for norm 2 the decision; for norms 1 / inf a bound,
        #     since J_1 >= ||r||_2 and J_inf >= ||r||_inf >= ||r||_2 / sqrt(N) (N residual
        #     entries): no separated point with ||r||_2^2 <= thr2 proves J > thr
        nres = res.R.shape[0]
        thr2 = thr_hi if self.norm == "2" else (thr_hi**2 if self.norm == "1" else nres * thr_hi**2)
        lo_u = np.concatenate([lo, sep_lo, [1.0]])
        hi_u = np.concatenate([hi, np.full(nb, np.inf), [1.0]])
        rstar = res.R @ vstar + rp
        Jv = float(rstar @ rstar)
        Js = self._Js2
        f = np.concatenate([2.0 * res.R.T @ rstar / Js, np.zeros(nb)])
        wbar = np.concatenate([vstar, np.zeros(nb)])
        ub0 = self._ub.copy()
        ub0[nv:][~allowed] = 0.0
        cont = ~self._disc
        sub = self.miqp.abs_subopt
        dstart, s_modes = enc.slices["delta"].start, self.model.system.n_modes
        # The proximal term biases the cutoff test by at most its largest value at an integral
        # point (below), so a returned point may cost a little more than thr.  For norm 2 such a
        # point's mode sequence and direction (a "combination") are then excluded *exactly* by
        # the QP of that combination (its minimum is the polished cost, > thr), and the rest is
        # searched again by bounds only, in T + 1 disjoint parts: the other directions, and for
        # k = 0 .. T-1 this direction with the sequence's modes before step k and another mode
        # at step k.
        stack, solves, why, decided = [ub0], 0, None, True
        while stack:
            ub = stack.pop()
            if solves >= MHE_UNIQUENESS_MAX_SOLVES:
                why, decided = f"no decision within {MHE_UNIQUENESS_MAX_SOLVES} solves of the separated MIQP", False
                break
            # largest proximal term at an integral point of the box: the continuous variables'
            # box ranges around the centre, two binaries per step for the modes (the centre is
            # one-hot) and one direction binary (the centre is zero)
            span = np.maximum((self._lb[cont] - wbar[cont]) ** 2, (ub[cont] - wbar[cont]) ** 2)
            bias = float(self._eps[cont] @ span)
            bias += float(self.prox_weight * (2 * T + 1))
            out = self.miqp.solve(f, lo_u, hi_u, wbar, cutoff=(thr2 - Jv) / Js + bias + sub,
                                  col_bounds=(slice(None), self._lb, ub))
            solves += 1
            detail.update({f"solver_{k}": v for k, v in out.detail.items()})
            if out.status == "infeasible":
                # every node was pruned: each separated point of this part has J2 / Js + prox >
                # cutoff, hence J2 > thr2
                continue
            if out.status != "optimal":
                why, decided = f"solver status {out.detail.get('status')!r}", False
                break
            alt, why, combo, lower = self.verified(out.v, U, Y, xbar, xs, allowed, lo, hi, polish=True)
            if alt is not None:
                cands.append(alt)
            if alt is None or alt["cost"] <= thr_hi or self.norm != "2" or lower is None or not lower > thr_hi:
                decided = False
                break
            modes, kd = combo
            if np.any(ub[nv:][np.arange(nb) != kd] > 0):
                child = ub.copy()
                child[nv + kd] = 0.0
                stack.append(child)
            for k in range(T):
                # disjoint parts: the sequence's modes up to step k - 1, another mode at step k
                child = ub.copy()
                child[nv:] = 0.0
                child[nv + kd] = 1.0
                for j in range(k):
                    keep = child[dstart + j * s_modes + int(modes[j])]
                    child[dstart + j * s_modes: dstart + (j + 1) * s_modes] = 0.0
                    child[dstart + j * s_modes + int(modes[j])] = keep
                child[dstart + k * s_modes + int(modes[k])] = 0.0
                stack.append(child)
        detail["solver_solves"] = solves
        if prefix is not None:
            detail["prefix_search"] = prefix.summary()
        if decided:
            by = "branch-and-bound" if self.norm == "2" else "norm-2 bound (MIQP)"
            return {**base, **detail, "status": UniquenessOutcome.UNIQUE, "decided_by": by,
                    "separated_cost_bound": thr_hi, "separated_cost": min((c["cost"] for c in cands), default=None)}
        if self.norm != "2" and not any(c["cost"] <= thr_hi for c in cands):
            # 2b. norms 1 / inf: the MILP decides
            rps = rp / self._Js
            lo_m = np.concatenate([lo, np.full(2 * nres, -np.inf), sep_lo, [1.0]])
            hi_m = np.concatenate([hi, -rps, rps, np.full(nb, np.inf), [1.0]])
            ncol = nv + self._nslack
            bound = thr_hi / self._Js
            # the cutoff and the target are HiGHS's (CasADi's plugins take neither)
            out = self.milp.solve(None, lo_m, hi_m, cutoff=bound, target=bound,
                                  col_bounds=(ncol + np.arange(nb), np.zeros(nb), allowed.astype(float)))
            detail = {**detail, **{f"milp_{k}": v for k, v in out.detail.items()}}
            if out.status == "infeasible":
                return {**base, **detail, "status": UniquenessOutcome.UNIQUE, "decided_by": "branch-and-bound",
                        "separated_cost_bound": thr_hi}
            if out.status in ("optimal", "feasible"):
                alt, why, _, _ = self.verified(np.concatenate([out.v[:nv], out.v[ncol:]]), U, Y, xbar,
                                                          xs, allowed, lo, hi, polish=False)
                if alt is not None:
                    cands.append(alt)
                if out.status == "optimal" and not any(c["cost"] <= thr_hi for c in cands):
                    # a MILP optimum (zero gap, no proximal bias): its bound is the separated
                    # minimum (HiGHS's dual bound, else its optimal objective)
                    lb = self._Js * float(out.detail.get("dual_bound", out.detail.get("objective", -np.inf)))
                    if lb > thr_hi:
                        return {**base, **detail, "status": UniquenessOutcome.UNIQUE, "decided_by": "branch-and-bound",
                                "separated_cost": min((c["cost"] for c in cands), default=None),
                                "separated_cost_bound": lb}
            else:
                why = f"MILP status {out.detail.get('status')!r}"
        if cands:
            alt = min(cands, key=lambda c: c["cost"])
            base["separated_cost"] = alt["cost"]
            if alt["cost"] <= thr_lo:
                if alt["cost"] < J - max((opt.gap_bound or 0.0), 0.0) - eps:
                    return {**base, **detail, "status": UniquenessOutcome.NOT_CERTIFIED,
                            "reason": "a separated state beats the certified optimum (optimum not global)"}
                return {**base, **detail, "status": UniquenessOutcome.ALTERNATIVE, "decided_by": "branch-and-bound",
                        "alternative": alt}
            if alt["cost"] <= thr_hi:
                return {**base, **detail, "status": UniquenessOutcome.NOT_CERTIFIED, "in_decision_band": True,
                        "reason": f"separated cost {alt['cost']:.6g} within the decision band {band:.3g} of "
                                  f"J* + epsilon = {thr:.6g} (decided to the safe side)"}
        return {**base, **detail, "status": UniquenessOutcome.NOT_CERTIFIED,
                "reason": why or "separated minimum within the solver's accuracy of J* + epsilon"}

    def verified(self, w, U, Y, xbar, xs, allowed, lo, hi, polish: bool) -> tuple:
        """Check a solver's point ``w = [v; b]`` of the separated program before trusting it.

        Finite, every MLD row within :data:`MHE_FEASIBILITY_TOL`, integral binaries (one mode per
        step, one admissible direction), the chosen separation row satisfied; then the model
        trajectory of its window-start state and modes (and, with ``polish``, the exact QP of
        that sequence and direction), verified by :meth:`alternative`.  Returns
        ``(alternative or None, reason or None, (modes, direction index) or None, bound)``,
        ``bound`` a proven lower bound of the least cost over that sequence and direction (from
        the exact QP, :meth:`~hybobs_opt.mhe.window.WindowModel.polish` with ``bound=True``) or ``None``.

        Parameters
        ----------
        w : ndarray
            The solver's point ``[v; b]``: MLD decision vector and direction binaries.
        U : (T, m) ndarray
            Window inputs.
        Y : (T, p) ndarray
            Window outputs.
        xbar : (n,) ndarray
            Prior estimate of the window-start state (arrival cost).
        xs : (T, n) ndarray
            Scaled window states of the optimum.
        allowed : (2 n T,) bool ndarray
            Admissible separation directions (``+`` and ``-`` per state coordinate and window
            step, interleaved; :meth:`direction`).
        lo, hi : ndarray
            Row bounds of the MLD encoding for ``U`` (:meth:`MLDEncoding.bounds`).
        polish : bool
            Also solve the exact QP of the point's mode sequence and direction.

        Returns
        -------
        tuple
            ``(alternative or None, reason or None, (modes, direction index) or None, bound)``.
        """
        enc, T, nv = self.enc, self.T, self.enc.n_vars
        v, b = w[:nv], w[nv:]
        if not np.all(np.isfinite(w)):
            return None, "separated solution with NaN/Inf", None, None
        viol = enc.violation(v, U.reshape(-1), bounds=(lo, hi))
        bviol = float(np.max(np.abs(b - np.round(b))))
        if not (viol <= max(MHE_FEASIBILITY_TOL, MHE_INTEGRALITY_TOL) and bviol <= MHE_INTEGRALITY_TOL):
            return None, f"separated solution failed verification (violation {max(viol, bviol):.3g})", None, None
        v = v.copy()
        v[enc.discrete] = np.round(v[enc.discrete])
        b = np.round(b)
        if not ((v[enc.discrete].reshape(T, -1).sum(axis=1) == 1).all() and b.sum() == 1 and allowed[b == 1].all()):
            return None, "separated solution: binaries not one-hot", None, None
        d = int(np.argmax(b))
        k, j, sign = self.direction(d)
        if not (sign * (self._Smap[k, j] @ v + self._soff[k, j] - xs[k, j]) >= self.delta - MHE_FEASIBILITY_TOL):
            return None, "separated solution is not delta away", None, None
        modes = enc.modes(v)
        x0, W = enc.states(v)[0], enc.disturbance(v)
        cands = [self.alternative(x0, modes, U, Y, xbar, W, xs)]
        exact = None
        if polish:
            # the solver's point carries the (tiny) proximal bias: the exact QP of its sequence
            # and direction, with a lower bound of its minimum proven from the multipliers
            pol = self.model.polish(modes, U, Y, xbar, x0, W, extra=self.separation_rows(xs, d, modes, U), bound=True,
                                    robust=True)
            if pol is not None:
                cands.append(self.alternative(pol[0], modes, U, Y, xbar, pol[1], xs))
                exact = pol[3]
        cands = [c for c in cands if c is not None]
        if not cands:
            return None, "separated solution: no verified model trajectory", (modes, d), exact
        return min(cands, key=lambda c: c["cost"]), None, (modes, d), exact

"""LMI design of the continuous observer of paper 000 (Balluchi et al.), Sections 3.2-3.3, and its
convergence neighbourhood (eq. 20).  The runtime objects are
:mod:`hybobs_opt.observers.hybrid_observer`.

*Continuous observer* (eq. 15): ``x~' = F_i x~ + B_i u + E_i + G_i (y - D_i u - c_i)``,
``F_i = A_i - G_i C_i``, switched on the location estimate of the location observer (the
constant terms ``E_i`` are added as in footnote 1 of the paper).

*Gain design.*  One Lyapunov matrix ``P`` common to all locations and per-location gains
``G_i = P^{-1} Y_i``:

``F_i' P + P F_i + 2 alpha P <= 0`` (every ``i``),  ``P >= I``,  ``||Y_i|| <= g`` (so ``||G_i|| <= g``),

minimising ``max ||P^{1/2} v||`` over the mismatch inputs ``v`` of eq. (17) (a Schur-complement LMI
per vertex of the operating box; ``v`` is affine in ``(P, Y)`` once multiplied by ``P``).  The
common ``P`` is what makes eq. (20) a bound for *every* time: ``||eps||_P`` decays at rate
``alpha`` whichever gain is switched in, and grows by at most ``||P^{1/2} v||`` while the observer
runs on the wrong location, i.e. at most ``Delta`` after each plant transition.  With plant
transitions at least ``D > Delta`` apart this gives (Proposition 3.3.1 made rigorous)

``||eps(t)||_P <= e^{-alpha t} ||eps(0)||_P + M0_P``,  ``M0_P = sigma (1 - e^{-alpha Delta}) / alpha / (1 - e^{-alpha D})``,

``sigma = sup ||P^{1/2} v||``: the paper's eq. (20) ``n kappa(F) V Delta / (1 - e^{alpha(F) D})``
with ``n kappa(F) V`` replaced by the certified ``sigma`` and ``Delta`` by ``(1 - e^{-alpha
Delta}) / alpha <= Delta``.  (The proof of eq. (20) in the paper bounds the state only at the
detection instants and drops the factor ``n kappa`` on the first term of eq. (26); the printed
formula is reported next to ours for comparison.)
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import as_positive
from ..defaults import HYBRID_OBSERVER_MAX_VERTEX_DIM
from ..errors import InfeasibleError, ModelError, SolverError
from ..lmi.solve import SOLVER, SOLVER_ERROR, checked_lyapunov, solve_problem
from ..status import is_infeasible, is_optimal
from ..systems.hybrid import HybridAutomaton
from ..tolerances import LUENBERGER_LMI_MARGIN
from .location_design import (affine_key, certified_decay, check_observable, distinct_dynamics, jordan_kappa,
                              location_label, spectral_abscissa, sqrt_psd)


@dataclass(frozen=True, eq=False)
class MismatchPair:
    """Plant in location ``plant``, observer still on ``observer`` (an edge ``observer -> plant``):
    the input ``v = W [x; u; 1]`` of eq. (17), with ``W`` for the designed gain.

    See Also
    --------
    ContinuousDesign.pairs : one per edge of the location graph.
    convergence_bound : uses their ``sigma``.

    Examples
    --------
    >>> from hybobs_opt.studies.paper000_driveline.systems import driveline
    >>> plant = driveline(k=1000.0)                 # paper 000's driveline, the softer spring of Fig. 6
    >>> box = dict(state_box=((-0.045, -10.0, -1.0), (0.005, 10.0, 1.0)), input_box=((-10.0,), (0.0,)))
    >>> from hybobs_opt.synthesis import design_continuous_observer
    >>> pair = design_continuous_observer(plant, 10.0, gain_bound=1000.0, **box).pairs[0]
    >>> pair.plant, pair.observer, pair.W.shape      # v = W [x; u; 1] while the observer lags
    (1, 0, (3, 5))
    """

    plant: int
    observer: int
    W: np.ndarray
    sigma: float  # max ||P^{1/2} v|| over the operating box
    V: float  # max ||v|| over the operating box (eq. 19, Euclidean)


@dataclass(frozen=True, eq=False)
class ContinuousDesign:
    """Gains ``G_i`` of the continuous observer (eq. 15 of paper 000) with a common ``P``.

    Parameters
    ----------
    automaton : HybridAutomaton
    G : tuple of arrays
        Gain per distinct dynamics (``group_of[q]`` indexes it).
    group_of : tuple of int
    P : (n, n) array
    decay : float
        Common rate certified with numpy: ``min_i`` of the largest ``alpha`` with
        ``F_i' P + P F_i + 2 alpha P <= 0``.
    requested_decay : float
    cond_P : float
    gain_norms : tuple of float
    spectral_abscissae, jordan_kappas : tuple of float
        ``alpha(F_i)`` and ``kappa(F_i)`` of eq. (20).
    pairs : tuple of MismatchPair
    state_box, input_box : (lo, hi) arrays
        Operating box ``X``, ``U`` of Proposition 3.3.1 used for ``V``.
    status : str
    seconds : float

    See Also
    --------
    design_continuous_observer : computes it.
    convergence_bound : its bound (20).

    Examples
    --------
    >>> from hybobs_opt.studies.paper000_driveline.systems import driveline
    >>> plant = driveline(k=1000.0)                 # paper 000's driveline, the softer spring of Fig. 6
    >>> box = dict(state_box=((-0.045, -10.0, -1.0), (0.005, 10.0, 1.0)), input_box=((-10.0,), (0.0,)))
    >>> from hybobs_opt.synthesis import design_continuous_observer
    >>> design = design_continuous_observer(plant, 10.0, gain_bound=1000.0, **box)
    >>> design.P.shape, design.group_of, len(design.pairs)
    ((3, 3), (0, 1, 2), 4)
    """

    automaton: HybridAutomaton
    G: tuple[np.ndarray, ...]
    group_of: tuple[int, ...]
    P: np.ndarray
    decay: float
    requested_decay: float
    cond_P: float
    gain_norms: tuple[float, ...]
    spectral_abscissae: tuple[float, ...]
    jordan_kappas: tuple[float, ...]
    pairs: tuple[MismatchPair, ...]
    state_box: tuple[np.ndarray, np.ndarray]
    input_box: tuple[np.ndarray, np.ndarray]
    status: str
    seconds: float

    @property
    def sigma(self) -> float:
        """``sup ||P^{1/2} v||`` over all mismatch pairs (0 when every location has equal dynamics)."""
        return max((pr.sigma for pr in self.pairs), default=0.0)

    def gain(self, q: int) -> np.ndarray:
        """The gain ``G`` used in location ``q``.

        Parameters
        ----------
        q : int
            0-based location index.

        Returns
        -------
        ndarray
            ``G_q``.
        """
        return self.G[self.group_of[q]]

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary of the design.

        Returns
        -------
        dict
            The requested and proven decay rates, ``cond_P``, the gains' norms, spectral abscissae and
            Jordan condition numbers, ``sigma``, ``V``, the solver's status and time.
        """
        return {
            "requested_decay": self.requested_decay,
            "decay": self.decay,
            "cond_P": self.cond_P,
            "gain_norms": list(self.gain_norms),
            "spectral_abscissae": list(self.spectral_abscissae),
            "jordan_kappas": list(self.jordan_kappas),
            "sigma": self.sigma,
            "V": max((pr.V for pr in self.pairs), default=0.0),
            "solver_status": self.status,
            "solver_seconds": self.seconds,
        }


class ContinuousObserverLMI:
    """The continuous-observer LMI of the module docstring, compiled once (``alpha`` and the gain
    bound are cvxpy ``Parameter`` objects; :meth:`solve` re-solves for a new decay rate).

    Parameters
    ----------
    automaton : HybridAutomaton
    gain_bound : float, optional
        Bound on ``||G_i||``.
    state_box, input_box : (lo, hi), optional
        Operating box ``X``, ``U`` of Proposition 3.3.1 (default: bounding boxes of the
        automaton's state and input bounds).

    See Also
    --------
    design_continuous_observer : builds one and solves it once.

    Examples
    --------
    >>> from hybobs_opt.studies.paper000_driveline.systems import driveline
    >>> plant = driveline(k=1000.0)                 # paper 000's driveline, the softer spring of Fig. 6
    >>> box = dict(state_box=((-0.045, -10.0, -1.0), (0.005, 10.0, 1.0)), input_box=((-10.0,), (0.0,)))
    >>> from hybobs_opt.synthesis import ContinuousObserverLMI
    >>> lmi = ContinuousObserverLMI(plant, gain_bound=1000.0, **box)
    >>> design = lmi.solve(10.0)                       # re-solve for another decay without rebuilding
    >>> design.status, round(design.decay, 3)
    ('optimal', 10.0)
    """

    def __init__(self, automaton: HybridAutomaton, *, gain_bound: float | None = None,
                 state_box: tuple[Sequence[float], Sequence[float]] | None = None,
                 input_box: tuple[Sequence[float], Sequence[float]] | None = None):
        import cvxpy as cp

        gain_bound = as_positive(gain_bound, "gain_bound", "a positive finite number", allow_none=True)
        self.automaton = aut = automaton
        self.groups = distinct_dynamics(aut)
        check_observable(aut)
        n, m, p = aut.n, aut.m, aut.p
        self.group_of = tuple(next(k for k, g in enumerate(self.groups) if q in g) for q in range(aut.n_locations))
        self.state_box = _box(state_box, aut.state_bounds, n, "state_box")
        if m:
            if input_box is None and aut.input_bounds is None:
                raise ModelError("input_box", "an input box (the automaton has no input bounds)", "None")
            self.input_box = _box(input_box, aut.input_bounds, m, "input_box")
        else:
            self.input_box = (np.zeros(0), np.zeros(0))
        self.gain_bound = gain_bound
        data = [affine_key(aut, g[0]) for g in self.groups]
        self._data = data
        self.scale = max(max(float(np.linalg.norm(d[0], 2)) for d in data), 1.0)

        self.P = cp.Variable((n, n), symmetric=True)
        self.Y = [cp.Variable((n, p)) for _ in self.groups]
        self.gamma = cp.Variable()
        self.alpha = cp.Parameter(nonneg=True)
        I = np.eye(n)
        cons = [self.P >> I, self.P << self.gamma * I]
        for (A, B, E, C, D, c), Y in zip(data, self.Y):
            An = A / self.scale
            M = An.T @ self.P + self.P @ An - C.T @ Y.T - Y @ C + 2 * self.alpha * self.P
            cons.append(0.5 * (M + M.T) << -LUENBERGER_LMI_MARGIN * I)
        if gain_bound is not None:
            self.lmax = cp.Parameter(nonneg=True)
            for Y in self.Y:
                cons.append(cp.bmat([[self.lmax * np.eye(p), Y.T], [Y, self.lmax * I]]) >> 0)
        # mismatch pairs: edge j -> i, different dynamics
        self.pair_index = []
        for e in aut.edges:
            i, j = e.target, e.source
            if self.group_of[i] != self.group_of[j] and (i, j) not in self.pair_index:
                self.pair_index.append((i, j))
        self._vertices = {i: self._box_vertices(i) for i in {i for i, _ in self.pair_index}}
        self.V0 = 1.0
        self.t = cp.Variable(nonneg=True)
        if self.pair_index:
            # normalise v by its size at G = 0 so that t is of order one
            v0 = [np.linalg.norm(self._w_terms(i, j)[0] @ self._vertices[i].T, axis=0) for (i, j) in self.pair_index]
            self.V0 = max((float(x.max()) for x in v0 if x.size), default=0.0) or 1.0
            for (i, j) in self.pair_index:
                Wa, Wc = self._w_terms(i, j)
                Z = self._vertices[i]
                # P v = P (Wa z) - Y_j (Wc z) with Y_j = scale * Y_n: affine in the variables.
                Pv = (self.P @ (Wa @ Z.T) - self.scale * self.Y[self.group_of[j]] @ (Wc @ Z.T)) / self.V0
                for k in range(Z.shape[0]):
                    col = cp.reshape(Pv[:, k], (n, 1), order="F")
                    cons.append(cp.bmat([[cp.reshape(self.t, (1, 1), order="F"), col.T], [col, self.P]]) >> 0)
            objective = self.t
        else:
            objective = self.gamma
        self.problem = cp.Problem(cp.Minimize(objective), cons)

    # ------------------------------------------------------------------ mismatch data
    def _w_terms(self, i: int, j: int) -> tuple[np.ndarray, np.ndarray]:
        """``v = Wa z - G_j Wc z`` with ``z = [x; u; 1]`` (eq. 17 with the output offsets)."""
        Ai, Bi, Ei, Ci, Di, ci = affine_key(self.automaton, i)
        Aj, Bj, Ej, Cj, Dj, cj = affine_key(self.automaton, j)
        Wa = np.hstack([Aj - Ai, Bj - Bi, (Ej - Ei)[:, None]])
        Wc = np.hstack([Cj - Ci, Dj - Di, (cj - ci)[:, None]])
        return Wa, Wc

    def _box_vertices(self, i: int) -> np.ndarray:
        """Corners ``[x; u; 1]`` of the box of ``Inv_i`` intersected with the operating box."""
        aut = self.automaton
        n, m = aut.n, aut.m
        inv = aut.locations[i].invariant
        lo, hi = self.state_box
        ulo, uhi = self.input_box
        from ..geometry.polytope import Polytope

        box = Polytope.from_box(np.concatenate([lo, ulo]), np.concatenate([hi, uhi]))
        region = inv if inv.dim == n + m else inv.lift(n + m, range(n))
        try:
            blo, bhi = region.intersect(box).bounding_box()
        except ModelError:
            return np.zeros((0, n + m + 1))
        d = n + m
        if d > HYBRID_OBSERVER_MAX_VERTEX_DIM:
            raise ModelError("automaton", f"n + m <= {HYBRID_OBSERVER_MAX_VERTEX_DIM} for the vertex bound of V",
                             f"n + m = {d}")
        corners = np.array(list(itertools.product(*zip(blo, bhi))), dtype=float).reshape(-1, d)
        return np.hstack([corners, np.ones((corners.shape[0], 1))])

    # ------------------------------------------------------------------ solve
    def solve(self, decay: float) -> ContinuousDesign:
        """Gains for the decay rate ``decay`` (1/s).

        Returns
        -------
        ContinuousDesign
            The gains and the common ``P`` for ``decay``.

        Raises
        ------
        InfeasibleError
            No common ``P`` meets the decay (with the gain bound); the message names the
            locations that fail on their own, if any.
        SolverError
            Clarabel failed or returned an unusable point.
        """

        decay = as_positive(decay, "decay", "a positive decay rate (1/s)")
        aut = self.automaton
        self.alpha.value = float(decay) / self.scale
        if self.gain_bound is not None:
            self.lmax.value = self.gain_bound / self.scale
        what = f"continuous observer LMI of {aut.name}"
        outcome = solve_problem(self.problem)
        if outcome.status == SOLVER_ERROR:
            raise SolverError(what, SOLVER, "solver error", f"a smaller decay rate ({outcome.message})")
        seconds, status = outcome.seconds, outcome.status
        if is_infeasible(status):
            from ..lmi.farkas import conic_certificate

            cert = conic_certificate(self.problem, f"the {what} at decay rate {decay:g} 1/s")
            if cert is None or not cert.verify():
                raise SolverError(what, SOLVER, f"{status} without a certificate that verifies",
                                  "a smaller decay rate, or rescale the model (the solver's verdict could not be "
                                  "confirmed by a Farkas certificate)")
            raise InfeasibleError(what, cert, self._diagnose(decay))
        if not is_optimal(status) or self.P.value is None:
            # inaccurate answers are not accepted (hybobs_opt.status): the bounds built from P need an optimum
            raise SolverError(what, SOLVER, str(status), "a smaller decay rate, or a larger gain bound")
        P = checked_lyapunov(self.P.value, what)
        G = tuple(self.scale * np.linalg.solve(P, Y.value) for Y in self.Y)
        Ph, _, w = sqrt_psd(P)
        F = [d[0] - Gk @ d[3] for d, Gk in zip(self._data, G)]
        decays = [certified_decay(Fk, P) for Fk in F]
        pairs = []
        for (i, j) in self.pair_index:
            Wa, Wc = self._w_terms(i, j)
            W = Wa - G[self.group_of[j]] @ Wc
            Z = self._vertices[i]
            v = W @ Z.T
            sigma = float(np.max(np.linalg.norm(Ph @ v, axis=0))) if Z.size else 0.0
            V = float(np.max(np.linalg.norm(v, axis=0))) if Z.size else 0.0
            pairs.append(MismatchPair(i, j, W, sigma, V))
        return ContinuousDesign(
            automaton=aut, G=G, group_of=self.group_of, P=P, decay=float(min(decays)), requested_decay=float(decay),
            cond_P=float(w[-1] / w[0]), gain_norms=tuple(float(np.linalg.norm(Gk, 2)) for Gk in G),
            spectral_abscissae=tuple(spectral_abscissa(Fk) for Fk in F), jordan_kappas=tuple(jordan_kappa(Fk) for Fk in F),
            pairs=tuple(pairs), state_box=self.state_box, input_box=self.input_box, status=str(status), seconds=seconds,
        )

    def _diagnose(self, decay: float) -> str:
        """Which locations fail on their own (decay LMI alone, same gain bound)."""
        from .location_design import LuenbergerLMI

        aut = self.automaton
        lmi = LuenbergerLMI(aut.n, aut.p, self.gain_bound)
        bad = []
        for g, (A, B, E, C, D, c) in zip(self.groups, self._data):
            try:
                if lmi.solve(A, C, decay, "decay check") is None:
                    bad.append(location_label(aut, g))
            except SolverError:
                bad.append(location_label(aut, g))
        bound = "" if self.gain_bound is None else f" with ||G_i|| <= {self.gain_bound:g}"
        if bad:
            return f"decay rate {decay:g} 1/s unattainable{bound} for location(s) {', '.join(bad)}"
        return f"no common Lyapunov matrix gives decay rate {decay:g} 1/s{bound} for all locations together"


def design_continuous_observer(automaton: HybridAutomaton, decay: float, *, gain_bound: float | None = None,
                               state_box=None, input_box=None) -> ContinuousDesign:
    """Gains ``G_i`` of eq. (15) (paper 000) for the decay rate ``decay``: see :class:`ContinuousObserverLMI`.

    Parameters
    ----------
    automaton : HybridAutomaton
        Automaton with affine locations.
    decay : float
        Requested common decay rate ``alpha`` (1/time unit).
    gain_bound : float, optional
        Bound on ``||G_i||``; ``None`` for none.
    state_box, input_box : (lo, hi), optional
        Operating box ``X``, ``U`` of Proposition 3.3.1 (default: bounding boxes of the automaton's
        state and input bounds).

    Returns
    -------
    ContinuousDesign
        The gains ``G_i``, the common ``P`` and the decay rate they were proven for.

    See Also
    --------
    ContinuousObserverLMI : the LMI, compiled once.
    convergence_bound : the bound (20) of the design.

    Examples
    --------
    >>> from hybobs_opt.studies.paper000_driveline.systems import driveline
    >>> plant = driveline(k=1000.0)                 # paper 000's driveline, the softer spring of Fig. 6
    >>> box = dict(state_box=((-0.045, -10.0, -1.0), (0.005, 10.0, 1.0)), input_box=((-10.0,), (0.0,)))
    >>> from hybobs_opt.synthesis import design_continuous_observer
    >>> design = design_continuous_observer(plant, 10.0, gain_bound=1000.0, **box)
    >>> design.status, round(design.decay, 3), len(design.G), design.G[0].shape
    ('optimal', 10.0, 3, (3, 1))
    """
    return ContinuousObserverLMI(automaton, gain_bound=gain_bound, state_box=state_box, input_box=input_box).solve(decay)


def _box(box, polytope, dim: int, field: str) -> tuple[np.ndarray, np.ndarray]:
    if box is None:
        lo, hi = polytope.bounding_box()
        return np.asarray(lo, float), np.asarray(hi, float)
    try:
        lo, hi = (np.asarray(b, dtype=float).reshape(-1) for b in box)
    except (TypeError, ValueError):
        raise ModelError(field, "a pair (lower, upper) of arrays", repr(box)) from None
    if lo.shape != (dim,) or hi.shape != (dim,) or not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))) or np.any(lo > hi):
        raise ModelError(field, f"finite bounds lower <= upper of length {dim}", f"{lo.tolist()}, {hi.tolist()}")
    return lo, hi


# ============================================================================ M0 (eq. 20)
@dataclass(frozen=True)
class ConvergenceBound:
    """The convergence neighbourhood of Proposition 3.3.1 (eq. 20 of paper 000) for a design.

    Parameters
    ----------
    delta, dwell_time, decay : float
        ``Delta``, ``D`` and the certified common rate ``alpha``.
    sigma : float
        ``sup ||P^{1/2} v||`` over the mismatch pairs and the operating box.
    M0 : float
        Bound on ``||x~ - x||`` once the transient has died out (Euclidean).
    M0_P : float
        The same in the ``P``-norm.
    M0_per_state : (n,) array
        ``|x~_k - x_k| <= ||P^{-1/2} e_k|| M0_P``.
    transient_factor : float
        ``c = sqrt(lambda_max(P) / lambda_min(P))``: for every ``t >= t0``,
        ``||eps(t)|| <= c e^{-alpha (t - t0)} ||eps(t0)|| + M0``.
    V : float
        ``sup ||v||`` (eq. 19, Euclidean).
    M0_paper : float
        Eq. (20) as printed: ``max_j n kappa(F_j) V_j Delta / (1 - e^{alpha(F_j) D})``.

    See Also
    --------
    convergence_bound : computes it.

    Examples
    --------
    >>> from hybobs_opt.studies.paper000_driveline.systems import driveline
    >>> plant = driveline(k=1000.0)                 # paper 000's driveline, the softer spring of Fig. 6
    >>> box = dict(state_box=((-0.045, -10.0, -1.0), (0.005, 10.0, 1.0)), input_box=((-10.0,), (0.0,)))
    >>> from hybobs_opt.synthesis import convergence_bound, design_continuous_observer
    >>> bound = convergence_bound(design_continuous_observer(plant, 10.0, gain_bound=1000.0, **box), 0.05, 0.15)
    >>> bound.delta, bound.dwell_time, round(bound.decay, 3)
    (0.05, 0.15, 10.0)
    """

    delta: float
    dwell_time: float
    decay: float
    sigma: float
    M0: float
    M0_P: float
    M0_per_state: np.ndarray
    transient_factor: float
    V: float
    M0_paper: float

    def error_bound(self, t: np.ndarray, e0: float, t0: float = 0.0) -> np.ndarray:
        """``c e^{-alpha (t - t0)} e0 + M0`` for ``t >= t0``.

        Parameters
        ----------
        t : array_like
            Times (before ``t0`` the bound is that at ``t0``).
        e0 : float
            ``||eps(t0)||``, the Euclidean error at ``t0``.
        t0 : float, default 0.0
            Initial time.

        Returns
        -------
        ndarray
            The bound on ``||eps(t)||`` at each time of ``t`` (shaped like ``t``).
        """
        t = np.asarray(t, dtype=float)
        return self.transient_factor * np.exp(-self.decay * np.maximum(t - t0, 0.0)) * e0 + self.M0

    def summary(self) -> dict[str, Any]:
        """JSON-ready summary of the bound.

        Returns
        -------
        dict
            ``delta``, ``dwell_time``, ``decay``, ``sigma``, ``M0``, ``M0_P``, ``M0_per_state``,
            ``transient_factor``, ``V`` and ``M0_paper_eq20``.
        """
        return {"delta": self.delta, "dwell_time": self.dwell_time, "decay": self.decay, "sigma": self.sigma,
                "M0": self.M0, "M0_P": self.M0_P, "M0_per_state": self.M0_per_state.tolist(),
                "transient_factor": self.transient_factor, "V": self.V, "M0_paper_eq20": self.M0_paper}


def convergence_bound(design: ContinuousDesign, delta: float, dwell_time: float) -> ConvergenceBound:
    """``M0`` of eq. (20) of paper 000 for the designed gains, delay ``Delta`` and dwell time ``D``.

    Hypotheses (Proposition 3.3.1): plant transitions at least ``D`` apart, the location observer
    identifies each within ``Delta < D``, state and input in the operating box of the design.

    Parameters
    ----------
    design : ContinuousDesign
        The designed gains (positive certified decay).
    delta : float
        Detection delay ``Delta`` of the location observer (time units).
    dwell_time : float
        Minimum time ``D > Delta`` between plant transitions.

    Returns
    -------
    ConvergenceBound
        ``M0`` of eq. (20) and its parts.

    Raises
    ------
    ModelError
        ``Delta >= D`` or non-positive values.

    See Also
    --------
    ConvergenceBound : what it returns.
    design_continuous_observer : the design it bounds.

    Examples
    --------
    The neighbourhood the estimation error enters for detection delay ``Delta = 0.05`` s and dwell
    time ``D = 0.15`` s:

    >>> from hybobs_opt.studies.paper000_driveline.systems import driveline
    >>> plant = driveline(k=1000.0)                 # paper 000's driveline, the softer spring of Fig. 6
    >>> box = dict(state_box=((-0.045, -10.0, -1.0), (0.005, 10.0, 1.0)), input_box=((-10.0,), (0.0,)))
    >>> from hybobs_opt.synthesis import convergence_bound, design_continuous_observer
    >>> design = design_continuous_observer(plant, 10.0, gain_bound=1000.0, **box)
    >>> bound = convergence_bound(design, 0.05, 0.15)
    >>> bound.M0 < bound.M0_paper                      # tighter than the paper's formula
    True
    >>> bound.M0_per_state.shape
    (3,)
    """
    delta = as_positive(delta, "delta", "a positive finite time")
    dwell_time = as_positive(dwell_time, "dwell_time", "a positive finite time")
    if delta >= dwell_time:
        raise ModelError("delta", f"a detection delay below the dwell time D = {dwell_time:g} (Proposition 3.3.1)", repr(delta))
    a = design.decay
    if a <= 0:
        raise ModelError("design", "a design with a positive certified decay", f"decay {a:g}")
    Ph, Pmh, w = sqrt_psd(design.P)
    sigma = design.sigma
    M0_P = sigma * (1.0 - math.exp(-a * delta)) / a / (1.0 - math.exp(-a * dwell_time))
    n = design.automaton.n
    paper = 0.0
    for j in set(pr.observer for pr in design.pairs):
        g = design.group_of[j]
        Vj = max(pr.V for pr in design.pairs if pr.observer == j)
        sa, kap = design.spectral_abscissae[g], design.jordan_kappas[g]
        paper = max(paper, n * kap * Vj * delta / (1.0 - math.exp(sa * dwell_time)) if sa < 0 else math.inf)
    return ConvergenceBound(
        delta=float(delta), dwell_time=float(dwell_time), decay=a, sigma=sigma, M0=M0_P / math.sqrt(w[0]), M0_P=M0_P,
        M0_per_state=np.linalg.norm(Pmh, axis=0) * M0_P, transient_factor=math.sqrt(w[-1] / w[0]),
        V=max((pr.V for pr in design.pairs), default=0.0), M0_paper=paper,
    )


__all__ = [
    "ContinuousDesign",
    "ContinuousObserverLMI",
    "ConvergenceBound",
    "MismatchPair",
    "convergence_bound",
    "design_continuous_observer",
]

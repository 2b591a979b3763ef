"""Continuous observer and the composed hybrid observer of paper 000 (Balluchi et al.), Sections
3.2-3.3, with gains designed by an LMI.  The Fig. 6 scenario of the paper is the study
:mod:`hybobs_opt.studies.paper000_driveline.scenario`.

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

from .._validate import as_instance, as_int, as_positive
from ..errors import InfeasibleError, ModelError, SolverError
from ..lmi.solve import SOLVER_ERROR, checked_lyapunov, solve_problem
from ..status import is_infeasible, is_optimal
from ..systems.hybrid import HybridAutomaton
from ..tolerances import LUENBERGER_LMI_MARGIN
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, ObserverTrace, WARMING_UP, check_reset_keywords,
                        checked_index, initial_mode, initial_state, innovation_excess, judge_samples_against,
                        sample_rows)
from ..defaults import HYBRID_OBSERVER_MAX_VERTEX_DIM, INNOVATION_MARGIN, INNOVATION_PATIENCE, TRANSIENT_FRACTION
from .error_bound import ErrorBound, induced_log_norm
from .location_design import affine_key, sqrt_psd
from .location_logic import IDENTIFIED
from .location_observer import (
    AMBIGUOUS,
    SOLVER,
    LocationObserver,
    ResidualBank,
    certified_decay,
    check_observable,
    detection_delays,
    distinct_dynamics,
    jordan_kappa,
    location_label,
    sampled_observer,
    spectral_abscissa,
)


# ============================================================================ design
@dataclass(frozen=True, eq=False)
class MismatchPair:
    """Plant in location ``plant``, observer still on ``observer`` (an edge ``observer -> plant``):
    the input ``v = W [x; u; 1]`` of eq. (17), with ``W`` for the designed gain."""

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
        """
        return self.G[self.group_of[q]]

    def summary(self) -> dict[str, Any]:
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
    bound are cvxpy ``Parameter``s; :meth:`solve` re-solves for a new decay rate).

    Parameters
    ----------
    automaton : HybridAutomaton
    gain_bound : float, optional
        Bound on ``||G_i||``.
    state_box, input_box : (lo, hi), optional
        Operating box ``X``, ``U`` of Proposition 3.3.1 (default: bounding boxes of the
        automaton's state and input bounds).
    """

    def __init__(self, automaton: HybridAutomaton, *, gain_bound: float | None = None,
                 state_box: tuple[Sequence[float], Sequence[float]] | None = None,
                 input_box: tuple[Sequence[float], Sequence[float]] | None = None):
        import cvxpy as cp

        if gain_bound is not None and not (np.isfinite(gain_bound) and gain_bound > 0):
            raise ModelError("gain_bound", "a positive finite number or None", repr(gain_bound))
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

        Raises
        ------
        InfeasibleError
            No common ``P`` meets the decay (with the gain bound); the message names the
            locations that fail on their own, if any.
        SolverError
            Clarabel failed or returned an unusable point.
        """

        if not (np.isfinite(decay) and decay > 0):
            raise ModelError("decay", "a positive decay rate (1/s)", repr(decay))
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
        from .location_observer import LuenbergerLMI

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
        """
        t = np.asarray(t, dtype=float)
        return self.transient_factor * np.exp(-self.decay * np.maximum(t - t0, 0.0)) * e0 + self.M0

    def summary(self) -> dict[str, Any]:
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

    Raises
    ------
    ModelError
        ``Delta >= D`` or non-positive values.
    """
    for name, value in (("delta", delta), ("dwell_time", dwell_time)):
        if not (np.isfinite(value) and value > 0):
            raise ModelError(name, "a positive finite time", repr(value))
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


# ============================================================================ runtime observers
class ContinuousObserver(Observer):
    """The continuous observer ``H_cntobs`` (eq. 15, Fig. 5 of paper 000) on the observer contract.

    ``step(u, y)`` propagates the estimate over the last sample with the gain of
    :attr:`location` (set it from a location observer, or use :class:`HybridObserver`).

    Parameters
    ----------
    design : ContinuousDesign
    Ts : float
    x0 : array, optional
    location : int
        Initial location used for the gains.
    """

    name = "continuous"

    def __init__(self, design: ContinuousDesign, Ts: float, *, x0: np.ndarray | None = None, location: int = 0):
        as_instance(design, "design", ContinuousDesign, "a ContinuousDesign (design_continuous_observer)")
        Ts = as_positive(Ts, "Ts", "a positive sampling period")
        aut = design.automaton
        what = f"an integer location index in 0..{aut.n_locations - 1}"  # not None: reset(q0=None) restarts here
        location = as_int(location, "location", 0, what)
        if location >= aut.n_locations:
            raise ModelError("location", what, repr(location))
        self.design = design
        self.automaton = aut
        self.Ts = Ts
        self.n, self.m, self.p = aut.n, aut.m, aut.p
        self.state_names = aut.state_names
        judge_samples_against(self, aut)
        self._mats = []
        self._ol = []
        for q in range(aut.n_locations):
            A, B, E, C, D, c = affine_key(aut, q)
            G = design.gain(q)
            self._mats.append(sampled_observer(A, B, E, C, D, c, G, self.Ts))
            self._ol.append(sampled_observer(A, B, E, C, D, c, np.zeros_like(G), self.Ts)[:2])
        P = np.asarray(design.P, dtype=float)
        P_inv = np.linalg.inv(P)
        self._P, self._P_inv_diag = P, np.diag(P_inv)
        # per location: (C, D, c) and sqrt(C_j P^-1 C_j') for the innovation test (INNOVATION_MARGIN)
        self._outputs = []
        for q in range(aut.n_locations):
            _, _, _, C, D, c = affine_key(aut, q)
            self._outputs.append((C, D, c, np.sqrt(np.einsum("ij,jk,ik->i", C, P_inv, C))))
        rng = self.output_range
        width = None if rng is None else rng[1] - rng[0]
        self._innovation_floor = (INNOVATION_MARGIN * width if width is not None and np.all(np.isfinite(width))
                                  else None)
        self._log_rate = [induced_log_norm(mats[0], P) for mats in self._mats]
        self._log_rate_ol = [induced_log_norm(ol[0], P) for ol in self._ol]
        self._bound = ErrorBound(*design.state_box)
        self._loc0 = int(location)
        self._x0 = x0
        self.reset(x0, q0=location)

    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, location: int | None = None,
              **kwargs: Any) -> None:
        """Restart at ``x0`` in location ``q0`` (``location``: its deprecated name; default: the constructor's).

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial estimate (default: the previous one, else the centre of the state bounds).
        q0 : int, optional
            Initial location (default: the constructor's ``location``).
        location : int, optional
            Deprecated name of ``q0`` (a ``FutureWarning``; removed in 0.2.0).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        field = "location" if location is not None else "q0"  # errors name the keyword the caller used
        q0 = initial_mode(q0, location, "location")
        x0 = initial_state(x0, self._x0, self.automaton.state_bounds, self.n)
        loc = self._loc0 if q0 is None else checked_index(q0, self.automaton.n_locations, field, "location index")
        self._x0 = x0
        self.x = x0.copy()
        self.location = loc
        self._u_prev: np.ndarray | None = None
        self._y_prev: np.ndarray | None = None
        self._bound.start(self.x, self._P)
        self._input_unknown = False
        self._contradictions = 0

    def _innovation_excess(self, u: np.ndarray, y: np.ndarray) -> str | None:
        """Why the residual ``y - (C x + D u + c)`` of the current estimate exceeds what the error
        bound allows plus :data:`~hybobs_opt.defaults.INNOVATION_MARGIN` (``None`` if it does not)."""
        if self._innovation_floor is None:
            return None
        C, D, c, C_norms = self._outputs[self.location]
        r = y - (C @ self.x + (D @ u if D is not None and D.size else 0.0) + c)
        allowed = self._bound.output_bound(C_norms) + self._innovation_floor
        return innovation_excess(r, allowed, y, self.output_names)

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        saved = (self.x.copy(), self._bound.save(), self._u_prev, self._y_prev, self._input_unknown)
        est = self._closed_loop_step(u, y)
        why = self._innovation_excess(u, y)
        if why is None:
            self._contradictions = 0
            return est
        self._contradictions += 1
        if self._contradictions <= INNOVATION_PATIENCE:  # one bad sample: undo the step, run it open loop
            self.x, log_b, self._u_prev, self._y_prev, self._input_unknown = saved
            self._bound.restore(log_b)
            return self._fallback(u, why)
        # a persistent contradiction: the bound's hypotheses failed; take the sample, restart the bound
        self._contradictions = 0
        self._bound.start(self.x, self._P)
        return Estimate(est.x, est.mode, self._flag(), 0.0,
                        dict(est.info, error_bound=self.error_bound().tolist(),
                             reason=why + f" on {INNOVATION_PATIENCE + 1} samples: the error bound restarts"))

    def _closed_loop_step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        if self._u_prev is not None and self._y_prev is None:
            # the previous sample was refused: open loop over the interval it leaves without output
            Ad, Bw = self._ol[self.location]
            self.x = Ad @ self.x + Bw @ np.concatenate([self._u_prev, np.zeros(self.p), [1.0]])
            self._bound.contract(self._log_rate_ol[self.location])
        elif self._u_prev is not None:
            Ad, Bw, Bd = self._mats[self.location]
            self.x = Ad @ self.x + Bw @ np.concatenate([self._u_prev, self._y_prev, [1.0]]) + Bd @ (y - self._y_prev)
            self._bound.contract(self._log_rate[self.location])
        if self._input_unknown:  # the last interval ran on a refused sample's input: no bound holds
            self._input_unknown = False
            self._bound.start(self.x, self._P)
        self._u_prev, self._y_prev = u, y
        return Estimate(self.x.copy(), self.location, self._flag(), 0.0, {"error_bound": self.error_bound().tolist()})

    def error_bound(self) -> np.ndarray:
        """Certified bound on ``|x_hat_k - x_k|`` per state (:mod:`~hybobs_opt.observers.error_bound`):
        from the reset, the sampled error map of each step's location contracts the design's
        ``P``-norm.  It assumes the location used is the plant's (for the hybrid observer, add the
        neighbourhood ``M0`` of Proposition 3.3.1 of paper 000)."""
        return self._bound.per_state(self._P_inv_diag)

    def _flag(self) -> str:
        """``observable`` once :meth:`error_bound` is below the convergence fraction of the state box."""
        return OBSERVABLE if self._bound.converged(self._P_inv_diag) else WARMING_UP

    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        if self._u_prev is not None:
            Ad, Bw = self._ol[self.location]
            self.x = Ad @ self.x + Bw @ np.concatenate([self._u_prev, np.zeros(self.p), [1.0]])
            self._bound.contract(self._log_rate_ol[self.location])
        self._input_unknown = u is None and self._u_prev is not None
        if u is not None:
            self._u_prev = u
        self._y_prev = None
        return Estimate(self.x.copy(), self.location, FALLBACK, 0.0, {"reason": reason})

    def run_with_locations(self, U, Y, Q) -> ObserverTrace:
        """Run with a given location sequence (e.g. the true one): ``Q[k]`` is used after sample ``k``.

        Parameters
        ----------
        U : (N, m) array_like
            Inputs.
        Y : (N, p) array_like
            Outputs.
        Q : (N,) int array_like
            Location used for the gains after each sample (``Q[0]`` also at the start).
        """
        U, Y = sample_rows(U, self.m, "U"), sample_rows(Y, self.p, "Y")
        Q = np.asarray(Q, dtype=int).reshape(-1)
        if not (U.shape[0] == Y.shape[0] == Q.shape[0]):
            raise ModelError("U, Y, Q", "the same number of samples", f"{U.shape[0]}, {Y.shape[0]}, {Q.shape[0]}")
        self.reset(q0=int(Q[0]))
        N = U.shape[0]
        xs, modes, flags, secs = np.zeros((N, self.n)), np.zeros(N, int), np.empty(N, dtype=object), np.zeros(N)
        for k in range(N):
            e = self.step(U[k], Y[k])
            xs[k], modes[k], flags[k], secs[k] = e.x, e.mode, e.flag, e.seconds
            self.location = int(Q[k])
        return ObserverTrace(xs, modes, flags, secs, self.state_names, self.name)


@dataclass(frozen=True, eq=False)
class HybridRun:
    """A run of :class:`HybridObserver`: the continuous estimate and the location observer's signals.

    Parameters
    ----------
    x_hat : (N, n) array
        The continuous observer's estimates.
    location : (N,) int array
        Estimated location (``-1`` when ambiguous / none).
    held : (N,) int array
        The location observer's held location.
    status : (N,) object array
        The location observer's status per step.
    residuals : (N, G) array
        ``||r_j||`` per generator.
    sigma : (N, G) bool array
        Decisions of eq. (8).
    consistent : (N, Q) bool array
        Per location: ``sigma`` of its generator and the invariant test.
    generator_states : (N, G, n) array
        States of the residual generators.
    seconds : (N,) array
        Compute time per step.
    trace : ObserverTrace
        The run on the common contract.
    """

    x_hat: np.ndarray
    location: np.ndarray
    held: np.ndarray
    status: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    consistent: np.ndarray
    generator_states: np.ndarray
    seconds: np.ndarray
    trace: ObserverTrace


class HybridObserver(Observer):
    """The hybrid observer of paper 000 (Fig. 3): location observer + continuous observer.

    Per sample: the continuous observer propagates with the location held at the previous sample,
    then the location observer decides; an identified location switches the continuous gain, an
    ambiguous decision keeps it (and is reported with ``mode = -1`` and ``info["candidates"]``).

    Parameters
    ----------
    bank : ResidualBank
    design : ContinuousDesign
        Both for the same automaton.
    Ts : float
    x0 : array, optional
        Initial estimate (generators and continuous observer).
    q0 : int, optional
        Known initial location; otherwise the location observer identifies it and the continuous
        observer starts on the location whose invariant contains ``x0`` (location 0 if none).

    Notes
    -----
    ``info["error_bound"]`` is the continuous observer's contraction since the location in use was
    identified, restarted from the state box at every newly identified location (the first, or a
    switch detected up to ``Delta`` late): the contraction on another location's gain proves
    nothing, and Proposition 3.3.1 bounds the error through a detection delay only by ``M0`` (eq.
    20), 0.55 rad on the driveline's theta.  The flag is ``observable`` once that bound is below
    the convergence fraction.  Its hypothesis is that the identified location is the plant's: in
    the ``Delta`` before a switch is detected the error can exceed it.
    """

    name = "location+continuous"

    def __init__(self, bank: ResidualBank, design: ContinuousDesign, Ts: float, *, x0: np.ndarray | None = None,
                 q0: int | None = None):
        as_instance(bank, "bank", ResidualBank, "a ResidualBank (design_residual_bank)")
        as_instance(design, "design", ContinuousDesign, "a ContinuousDesign (design_continuous_observer)")
        if bank.automaton is not design.automaton:
            raise ModelError("design", "a continuous design for the same automaton as the residual bank", "another automaton")
        self.automaton = aut = bank.automaton
        self.n, self.m, self.p = aut.n, aut.m, aut.p
        self.state_names = aut.state_names
        judge_samples_against(self, aut)
        self.locobs = LocationObserver(bank, Ts, x0=x0, q0=q0)
        self.contobs = ContinuousObserver(design, Ts, x0=self.locobs._x0, location=self._start_location(self.locobs._x0, q0))
        self._q0 = q0
        self._bound_location: int | None = q0  # the identified location the continuous bound started in

    def _start_location(self, x0: np.ndarray, q0: int | None) -> int:
        if q0 is not None:
            return int(q0)
        for q in range(self.automaton.n_locations):
            if self.automaton.locations[q].invariant.dim == self.n and self.automaton.in_invariant(q, x0):
                return q
        return 0

    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, **kwargs: Any) -> None:
        """Restart both observers at ``x0``.

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial estimate (default: the previous one, else the centre of the state bounds).
        q0 : int, optional
            Known initial location (default: the constructor's ``q0``; ``None`` lets the location
            observer identify it).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        self.locobs.reset(x0, q0)
        q = self._q0 if q0 is None else q0
        self.contobs.reset(self.locobs._x0, q0=self._start_location(self.locobs._x0, q))
        self._bound_location = q

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        co = self.contobs
        xc = co._step(u, y)
        if xc.flag == FALLBACK:  # the sample contradicts the continuous estimate's bound: nobody uses it
            loc = self.locobs._fallback(u, xc.info["reason"])
            return Estimate(xc.x, -1, FALLBACK, 0.0, dict(loc.info, generator_x=loc.x, reason=xc.info["reason"]))
        loc = self.locobs._step(u, y)
        identified = loc.info["held"] if loc.info["status"] == IDENTIFIED else None
        if identified is not None and identified != self._bound_location:
            # a newly identified location (the first, or a switch detected up to Delta late): the
            # contraction so far ran on another location's gain and proves nothing; the error is
            # bounded by the state box (Proposition 3.3.1 only bounds it by M0, eq. 20)
            co._bound.start(co.x, co._P)
        self._bound_location = identified
        if loc.info["held"] >= 0:
            co.location = loc.info["held"]
        info = dict(loc.info)
        info["generator_x"] = loc.x
        info["continuous_location"] = xc.mode
        info["error_bound"] = co.error_bound().tolist()
        converged = co._bound.converged(co._P_inv_diag)
        # the location identified is not yet the state: observable once the continuous
        # observer's certified transient since that identification has died out too
        flag = WARMING_UP if loc.flag == OBSERVABLE and not converged else loc.flag
        return Estimate(xc.x, loc.mode, flag, 0.0, info)

    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        xc = self.contobs._fallback(u, reason)
        loc = self.locobs._fallback(u, reason)
        info = dict(loc.info)
        info["generator_x"] = loc.x
        return Estimate(xc.x, -1, FALLBACK, 0.0, info)

    def run_detailed(self, U, Y) -> HybridRun:
        """Run from the reset state, keeping the location observer's signals.

        Parameters
        ----------
        U : (N, m) array_like
            Inputs.
        Y : (N, p) array_like
            Outputs.
        """
        U, Y = sample_rows(U, self.m, "U"), sample_rows(Y, self.p, "Y")
        if U.shape[0] != Y.shape[0]:
            raise ModelError("U, Y", "the same number of samples", f"{U.shape[0]} and {Y.shape[0]}")
        self.reset()
        N, G, Qn = U.shape[0], len(self.locobs.bank.generators), self.automaton.n_locations
        xs, gx = np.full((N, self.n), np.nan), np.full((N, G, self.n), np.nan)
        loc, held = np.full(N, -1), np.full(N, -1)
        status, flags = np.empty(N, dtype=object), np.empty(N, dtype=object)
        res, sig, cons, secs = np.full((N, G), np.nan), np.zeros((N, G), bool), np.zeros((N, Qn), bool), np.zeros(N)
        for k in range(N):
            e = self.step(U[k], Y[k])
            xs[k], loc[k], flags[k], secs[k] = e.x, e.mode, e.flag, e.seconds
            res[k], sig[k], cons[k] = e.info["residuals"], e.info["sigma"], e.info["consistent"]
            held[k], status[k], gx[k] = e.info["held"], e.info["status"], e.info["generator_states"]
        trace = ObserverTrace(xs, loc, flags, secs, self.state_names, self.name)
        return HybridRun(xs, loc, held, status, res, sig, cons, gx, secs, trace)


def summarise_run(aut: HybridAutomaton, trace, bank: ResidualBank, design: ContinuousDesign, bound: ConvergenceBound,
                  run: HybridRun) -> dict[str, Any]:
    """The measured figures of a run against the design's guarantees (JSON-ready).

    ``detection_delays``: one per true location change, from the event time to the first sample
    whose estimate is the new location (``None`` if never before the next change).
    ``max_error_after_convergence``: largest ``||x~ - x||`` after ``t_convergence``, when the
    transient term of the bound is below ``TRANSIENT_FRACTION M0``; ``t_enter_M0`` is the first
    sample after which the measured error stays within ``M0``.  ``entry_mismatch``: ``||x - z_i||`` of the entered
    location's generator at the first sample after each change (the ``Z0`` hypothesis).

    Parameters
    ----------
    aut : HybridAutomaton
        The plant.
    trace : Trace
        The simulated plant trajectory (true state, location and events).
    bank : ResidualBank
        The location observer's design.
    design : ContinuousDesign
        The continuous observer's design.
    bound : ConvergenceBound
        The guarantee the run is compared with.
    run : HybridRun
        The observer's run on ``trace`` (:meth:`HybridObserver.run_detailed`).
    """
    t = trace.t
    err = np.linalg.norm(run.x_hat - trace.x, axis=1)
    e0 = float(err[0])
    ratio = bound.transient_factor * e0 / (TRANSIENT_FRACTION * bound.M0) if bound.M0 > 0 else math.inf
    t_conv = t[0] + (math.log(ratio) / bound.decay if ratio > 1 else 0.0)
    after = t >= t_conv
    inside = err <= bound.M0
    # first sample from which the error stays within M0
    outside = np.nonzero(~inside)[0]
    k_enter = 0 if outside.size == 0 else int(outside[-1]) + 1
    entered = k_enter < t.size
    delays = detection_delays(t, trace.events, run.location)
    wrong = (run.location >= 0) & (run.location != trace.q)
    entry_mismatch = []
    for e in trace.events:
        k = int(np.searchsorted(t, e["t"] - 1e-12))
        if k < t.size:
            g = bank.group_of[int(e["to"])]
            entry_mismatch.append(float(np.linalg.norm(run.generator_states[k, g] - trace.x[k])))
    out = {
        "delta_design": bank.delta,
        "epsilon": bank.epsilon,
        "z0_bound": bank.z0_bound,
        "guaranteed_delays": {g.label: g.guaranteed_delay for g in bank.generators},
        "paper_delays_eq9": {g.label: g.paper_delay for g in bank.generators},
        "location_changes": [{"t": float(e["t"]), "from": aut.locations[int(e["from"])].name,
                              "to": aut.locations[int(e["to"])].name} for e in trace.events],
        "detection_delays": delays,
        "max_detection_delay": max((d for d in delays if d is not None), default=None),
        "all_detected_within_delta": all(d is not None and d <= bank.delta for d in delays),
        "ambiguous_steps": int(np.count_nonzero(run.status == AMBIGUOUS)),
        "no_candidate_steps": int(np.count_nonzero(run.status == "none")),
        "wrong_location_steps": int(np.count_nonzero(wrong)),
        "M0": bound.M0,
        "M0_per_state": bound.M0_per_state.tolist(),
        "M0_paper_eq20": bound.M0_paper,
        "decay_continuous": design.decay,
        "dwell_time": bound.dwell_time,
        "t_convergence": float(t_conv),
        "max_error_after_convergence": float(err[after].max()) if after.any() else None,
        "max_abs_error_after_convergence_per_state": (np.abs(run.x_hat - trace.x)[after].max(axis=0).tolist()
                                                      if after.any() else None),
        "t_enter_M0": float(t[k_enter]) if entered else None,
        "max_error_after_entering_M0": float(err[k_enter:].max()) if entered else None,
        "initial_error": float(err[0]),
        "max_error": float(err.max()),
        "error_bound_holds": bool(np.all(err <= bound.error_bound(t, e0) * (1 + 1e-9))),
        "entry_mismatch": entry_mismatch,
        "z0_hypothesis_holds": all(z <= bank.z0_bound for z in entry_mismatch),
        "median_step_s": float(np.median(run.seconds)),
        "residual_design": bank.summary(),
        "continuous_design": design.summary(),
        "convergence_bound": bound.summary(),
    }
    lo, hi = design.state_box
    ulo, uhi = design.input_box
    out["trajectory_in_X"] = bool(np.all((trace.x >= lo) & (trace.x <= hi)) and np.all((trace.u >= ulo) & (trace.u <= uhi)))
    return out


__all__ = [
    "ContinuousDesign",
    "ContinuousObserver",
    "ContinuousObserverLMI",
    "ConvergenceBound",
    "HybridObserver",
    "HybridRun",
    "MismatchPair",
    "convergence_bound",
    "design_continuous_observer",
    "summarise_run",
]

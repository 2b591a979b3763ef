"""Location observer of paper 000 (Balluchi et al.), Section 3.1: residual-generator bank, threshold
decision and location identification logic, with the generator gains designed by an LMI.

*Residual generators* (eqs. 6-7): one Luenberger observer per distinct affine dynamics of the
automaton, ``z_j' = H_j z_j + B_j u + E_j + L_j (y - D_j u - c_j)`` with ``H_j = A_j - L_j C_j`` and
residual ``r_j = C_j z_j + D_j u + c_j - y``.  The paper writes the triple ``(A_j, B_j, C_j)``; the
constant terms ``E_j`` (and the output offsets ``D_j, c_j``) are part of a location's dynamics here,
as footnote 1 of the paper adds them for the driveline: without ``E_j`` the residual of the true
location would not vanish (eq. 13 needs ``M_ii = 0`` *and* equal constant terms).  Locations
with equal affine data share one generator (the paper's ``N'`` distinct dynamics).

*Decision* (eq. 8): ``sigma_j = ||r_j|| <= epsilon``.

*Gain design* (Proposition 3.1.1): after a change into location ``i``, ``r_i(t) = C_i e^{H_i t}
eps_i(0)`` (eq. 13) with ``||eps_i(0)|| <= Z0``.  The LMI

``H' P + P H + 2 alpha P <= 0``,  ``I <= P <= gamma I``  (``Y = P L``, solved with cvxpy/Clarabel)

gives ``||e^{H t}|| <= sqrt(cond P) e^{-alpha t}`` and, sharper, ``||r(t)|| <= ||C P^{-1/2}||
||P^{1/2}|| e^{-alpha t} Z0``.  The decay ``alpha`` is raised until the bound is below ``epsilon``
at ``t = Delta``; among the gains achieving it the LMI picks the best-conditioned ``P`` (a small
``gamma`` keeps the overshoot, and with it the gain, low).  Every number reported is recomputed
with numpy from the returned ``(P, L)``: the decay is the exact rate this ``P`` certifies for
this ``H``, so the guarantee never rests on the solver's tolerance.  The paper's own quantities,
the spectral abscissa ``alpha(H)`` and the Jordan conditioning ``kappa(H)`` of eqs. (9)-(10), are
reported for the gain found.

*Location identification logic* (the "critical cases" at the end of Section 3.1): a location is a
*candidate* when the residual of its generator is below threshold and the generator's state lies
in the location's invariant, up to the margin the design guarantees after ``Delta`` (so the true
location is always a candidate ``Delta`` after it is entered).  Candidates are restricted to the
current location and its successors in the automaton's graph.  Several candidates (several
``sigma_j`` true; or one ``sigma_j`` shared by several locations that the invariants do not
separate) is reported as *ambiguity* with the candidate set, never resolved by guessing; the
continuous observer then keeps the last identified location.
"""

from __future__ import annotations

import math
import time
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from scipy.linalg import expm

from ..errors import InfeasibleError, ModelError, SolverError
from ..systems.hybrid import HybridAutomaton
from ..tolerances import (
    DELAY_DESIGN_RTOL,
    LOCATION_INVARIANT_RTOL,
    LUENBERGER_LMI_MARGIN,
    MATRIX_EQUAL_RTOL,
    OBSERVABILITY_RTOL,
)
from ..lmi.solve import SOLVER, SOLVER_ERROR, solve_problem
from .base import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP, Estimate, Observer, ObserverTrace, initial_state


#: Numerical guard on the decay-rate search when no ``max_decay`` is given (1/s): far beyond any
#: sampled implementation, it only stops a diverging search.
DECAY_GUARD = 1e7

#: Iterations of the decay fixed point ``alpha <- log(beta(alpha) Z0 / epsilon) / Delta``; the bound
#: ``beta`` hardly moves with ``alpha`` (it tends to ``||C||``), so 2-4 are the rule.
MAX_DECAY_ITERATIONS = 30

# Decision statuses of the identification logic.
IDENTIFIED = "identified"
AMBIGUOUS = "ambiguous"
NO_CANDIDATE = "none"


# ============================================================================ helpers
def location_label(automaton: HybridAutomaton, locations: Sequence[int]) -> str:
    """``"q2"`` or ``"q1/q3"``: the names of the locations sharing a generator."""
    return "/".join(automaton.locations[q].name for q in locations)


def _affine_key(automaton: HybridAutomaton, q: int) -> tuple[np.ndarray, ...]:
    loc = automaton.locations[q]
    if not loc.is_affine:
        raise ModelError(f"locations[{q}] ({loc.name})", "an affine flow and output (paper 000, eqs. 3-4)",
                         "a callable flow or output")
    return (loc.A, loc.B, loc.E, loc.C, loc.D, loc.c)


def _same(a: Sequence[np.ndarray], b: Sequence[np.ndarray]) -> bool:
    return all(np.allclose(x, y, rtol=MATRIX_EQUAL_RTOL, atol=MATRIX_EQUAL_RTOL * (1.0 + np.abs(x).max(initial=0.0)))
               for x, y in zip(a, b))


def distinct_dynamics(automaton: HybridAutomaton) -> tuple[tuple[int, ...], ...]:
    """Groups of locations with equal affine data ``(A, B, E, C, D, c)``: the ``N'`` distinct
    dynamics of Section 3.1 of paper 000 (one residual generator each)."""
    groups: list[list[int]] = []
    keys: list[tuple[np.ndarray, ...]] = []
    for q in range(automaton.n_locations):
        key = _affine_key(automaton, q)
        for g, other in enumerate(keys):
            if _same(key, other):
                groups[g].append(q)
                break
        else:
            groups.append([q])
            keys.append(key)
    return tuple(tuple(g) for g in groups)


def state_scale(automaton: HybridAutomaton) -> np.ndarray:
    """Half-widths of the bounding box of the automaton's state bounds (the scaling of rank tests)."""
    lo, hi = automaton.state_bounds.bounding_box()
    half = (hi - lo) / 2.0
    return np.where(half > 0, half, 1.0)


def check_observable(automaton: HybridAutomaton, locations: Sequence[int] | None = None) -> None:
    """Raise ``ModelError`` naming the first location whose pair ``(A_i, C_i)`` is unobservable.

    Popov-Belevitch-Hautus test in coordinates scaled by the state bounds: ``(A, C)`` is
    unobservable when ``[A - lambda I; C]`` loses rank for an eigenvalue ``lambda`` of ``A``
    (smallest singular value below :data:`OBSERVABILITY_RTOL` times the largest).  Proposition
    3.3.1 of paper 000 assumes "all the couples (A_i, C_i) are observable".
    """
    S = state_scale(automaton)
    qs = range(automaton.n_locations) if locations is None else locations
    for q in qs:
        loc = automaton.locations[q]
        _affine_key(automaton, q)
        As = loc.A * S[None, :] / S[:, None]
        Cs = loc.C * S[None, :]
        row = np.linalg.norm(Cs, axis=1, keepdims=True)
        Cs = Cs / np.where(row > 0, row, 1.0)
        n = As.shape[0]
        for lam in np.linalg.eigvals(As):
            M = np.vstack([As - lam * np.eye(n), Cs])
            s = np.linalg.svd(M, compute_uv=False)
            if s[-1] <= OBSERVABILITY_RTOL * max(s[0], 1.0):
                raise ModelError(
                    f"locations[{q}] ({loc.name})",
                    "an observable pair (A_i, C_i) (paper 000, Proposition 3.3.1)",
                    f"an unobservable pair: [A - lambda I; C] loses rank at lambda = {complex(lam):.6g} "
                    "(no residual generator or continuous observer gain can make this location's error decay)",
                )


def jordan_kappa(M: np.ndarray) -> float:
    """``kappa(M) = ||X|| ||X^{-1}||`` with ``X^{-1} M X`` in Jordan form (eq. 10 of paper 000).

    Computed from the eigenvector matrix; ``inf`` for a defective (non-diagonalisable) matrix,
    where eq. (10) does not hold as printed (Jordan blocks add polynomial factors in ``tau``).
    """
    _, X = np.linalg.eig(M)
    k = float(np.linalg.cond(X))
    return k if np.isfinite(k) and k < 1e12 else math.inf


def spectral_abscissa(M: np.ndarray) -> float:
    """``alpha(M)``: the largest real part of the eigenvalues (Proposition 3.1.2 of paper 000)."""
    return float(np.linalg.eigvals(M).real.max())


def _sqrt_psd(P: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(P^{1/2}, P^{-1/2}, eigenvalues)`` of a symmetric positive definite matrix."""
    w, V = np.linalg.eigh(0.5 * (P + P.T))
    if w[0] <= 0:
        raise SolverError("Lyapunov matrix", SOLVER, "not positive definite", "re-solve with a smaller decay rate")
    return (V * np.sqrt(w)) @ V.T, (V / np.sqrt(w)) @ V.T, w


def certified_decay(H: np.ndarray, P: np.ndarray) -> float:
    """The largest ``alpha`` with ``H' P + P H + 2 alpha P <= 0`` for these matrices (numpy).

    It is the rate certified by ``V = x' P x``: ``||e^{H t} x||_P <= e^{-alpha t} ||x||_P``.
    """
    _, Pmh, _ = _sqrt_psd(P)
    Q = Pmh @ (H.T @ P + P @ H) @ Pmh
    return float(-0.5 * np.linalg.eigvalsh(0.5 * (Q + Q.T)).max())


def sampled_observer(A, B, E, C, D, c, K, Ts: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Exact sampling of the Luenberger observer ``z' = (A - K C) z + (B - K D) u + (E - K c) + K y``.

    The input is held over a sample (zero-order hold, as the plant's input is) and the output is
    interpolated linearly between samples (first-order hold: exact for a piecewise-linear ``y``;
    for the smooth outputs of the driveline its error is ``Ts^2 |y''| / 8``).  Then

    ``z_k = Ad z_{k-1} + Bw [u_{k-1}; y_{k-1}; 1] + Bd (y_k - y_{k-1})``,

    from ``expm`` of one augmented matrix.  ``K = 0`` gives the open-loop prediction.
    """
    n, m, p = A.shape[0], B.shape[1], C.shape[0]
    N = n + m + p + 1 + 2 * p
    M = np.zeros((N, N))
    iu, iy, i1, ir, ix = n, n + m, n + m + p, n + m + p + 1, n + m + 2 * p + 1
    M[:n, :n] = A - K @ C
    M[:n, iu:iy] = B - K @ D
    M[:n, iy:i1] = K
    M[:n, i1] = E - K @ c
    M[:n, ir:ix] = K  # ramp state rho(s) = (s / Ts) dy
    M[ir:ix, ix:] = np.eye(p)  # rho' = dy / Ts, held in the last p states
    Phi = expm(M * Ts)
    return Phi[:n, :n], Phi[:n, iu:ir].copy(), Phi[:n, ix:] / Ts


# ============================================================================ the LMI
class LuenbergerLMI:
    """Decay-rate LMI with a conditioning objective, compiled once with cvxpy ``Parameter``s.

    ``min gamma  s.t.  I <= P <= gamma I,  sym(A' P + P A - C' Y' - Y C) + 2 alpha P <= -margin I``
    (and ``[[l I, Y'], [Y, l I]] >= 0``, i.e. ``||Y|| <= l`` so ``||L|| = ||P^{-1} Y|| <= l``, when a
    gain bound is given).  Time is normalised by ``s = max(||A||, alpha, 1)`` so the data are of
    order one whatever the plant's time scale; ``A``, ``C``, ``alpha`` and ``l`` are parameters, so
    the problem is canonicalised once and re-solved for every generator and every decay rate.
    """

    def __init__(self, n: int, p: int, gain_bound: float | None = None):
        import cvxpy as cp

        self.n, self.p, self.gain_bound = n, p, gain_bound
        self.A = cp.Parameter((n, n))
        self.C = cp.Parameter((p, n))
        self.alpha = cp.Parameter(nonneg=True)
        self.P = cp.Variable((n, n), symmetric=True)
        self.Y = cp.Variable((n, p))
        self.gamma = cp.Variable()
        I = np.eye(n)
        M = self.A.T @ self.P + self.P @ self.A - self.C.T @ self.Y.T - self.Y @ self.C + 2 * self.alpha * self.P
        cons = [self.P >> I, self.P << self.gamma * I, 0.5 * (M + M.T) << -LUENBERGER_LMI_MARGIN * I]
        if gain_bound is not None:
            self.lmax = cp.Parameter(nonneg=True)
            cons.append(cp.bmat([[self.lmax * np.eye(p), self.Y.T], [self.Y, self.lmax * I]]) >> 0)
        self.problem = cp.Problem(cp.Minimize(self.gamma), cons)

    def solve(self, A: np.ndarray, C: np.ndarray, alpha: float, what: str) -> tuple[np.ndarray, np.ndarray, str, float] | None:
        """``(P, L, status, seconds)`` at decay ``alpha``, or ``None`` when the LMI is infeasible.

        Raises
        ------
        SolverError
            On any status other than (inaccurate) optimal or infeasible, or a solver crash.
        """
        import cvxpy as cp

        s = max(float(np.linalg.norm(A, 2)), float(alpha), 1.0)
        self.A.value = A / s
        self.C.value = np.asarray(C, dtype=float)
        self.alpha.value = float(alpha) / s
        if self.gain_bound is not None:
            self.lmax.value = self.gain_bound / s
        outcome = solve_problem(self.problem)
        if outcome.status == SOLVER_ERROR:
            raise SolverError(what, SOLVER, "solver error", f"a smaller decay rate or a larger gain bound ({outcome.message})")
        seconds, status = outcome.seconds, outcome.status
        if status in (cp.INFEASIBLE, cp.INFEASIBLE_INACCURATE):
            return None
        if status not in (cp.OPTIMAL, cp.OPTIMAL_INACCURATE) or self.P.value is None or self.Y.value is None:
            raise SolverError(what, SOLVER, str(status), "a smaller decay rate, or check the model's scaling")
        P = 0.5 * (self.P.value + self.P.value.T)
        L = s * np.linalg.solve(P, self.Y.value)
        return P, L, str(status), seconds


# ============================================================================ design results
@dataclass(frozen=True, eq=False)
class ResidualGenerator:
    """One residual generator (eqs. 6-7 of paper 000) with its designed gain.

    Attributes
    ----------
    locations : tuple of int
        Locations sharing these affine dynamics.
    label : str
        Their names, e.g. ``"q2"``.
    A, B, E, C, D, c : arrays
        The shared affine data.
    L : (n, p) array
        Gain; ``H = A - L C``.
    P : (n, n) array
        Lyapunov matrix returned by the LMI.
    decay : float
        Rate ``alpha`` certified by ``P`` for ``H`` (numpy): ``||e^{H t}||_P <= e^{-alpha t}``.
    cond_P : float
        ``cond(P)``; ``||e^{H t}|| <= sqrt(cond P) e^{-alpha t}``.
    residual_bound : float
        ``beta = ||C P^{-1/2}|| ||P^{1/2}||``: ``||r(t)|| <= beta e^{-alpha t} Z0`` after a change
        into these dynamics (sharper than ``||C|| sqrt(cond P)``, which is ``lmi_bound``).
    lmi_bound : float
        ``||C|| sqrt(cond P)``.
    guaranteed_delay : float
        Time after which ``beta e^{-alpha t} Z0 <= epsilon``: at most the design's ``Delta``.
    spectral_abscissa, jordan_kappa : float
        ``alpha(H)`` and ``kappa(H)`` of eqs. (9)-(10).
    paper_delay : float
        ``log(n ||C|| kappa(H) Z0 / epsilon) / (-alpha(H))``: the delay eq. (9) certifies for this gain.
    paper_condition : bool
        Whether eq. (9) holds with the design's ``Delta``.
    gain_norm : float
        ``||L||``.
    status : str
        cvxpy status of the last solve (an inaccurate optimum is accepted because every bound is
        recomputed from the returned matrices).
    iterations : int
        Solves of the decay search.
    seconds : float
        Total solver time.
    """

    locations: tuple[int, ...]
    label: str
    A: np.ndarray
    B: np.ndarray
    E: np.ndarray
    C: np.ndarray
    D: np.ndarray
    c: np.ndarray
    L: np.ndarray
    P: np.ndarray
    decay: float
    cond_P: float
    residual_bound: float
    lmi_bound: float
    guaranteed_delay: float
    spectral_abscissa: float
    jordan_kappa: float
    paper_delay: float
    paper_condition: bool
    gain_norm: float
    status: str
    iterations: int
    seconds: float

    @property
    def H(self) -> np.ndarray:
        """``H = A - L C`` of eq. (6)."""
        return self.A - self.L @ self.C

    def summary(self) -> dict[str, Any]:
        return {
            "locations": self.label,
            "decay": self.decay,
            "cond_P": self.cond_P,
            "gain_norm": self.gain_norm,
            "residual_bound": self.residual_bound,
            "lmi_bound": self.lmi_bound,
            "guaranteed_delay": self.guaranteed_delay,
            "spectral_abscissa": self.spectral_abscissa,
            "jordan_kappa": self.jordan_kappa,
            "paper_delay_eq9": self.paper_delay,
            "paper_condition_eq9": self.paper_condition,
            "solver_status": self.status,
            "solves": self.iterations,
            "solver_seconds": self.seconds,
        }


@dataclass(frozen=True, eq=False)
class ResidualBank:
    """The designed bank of residual generators (Section 3.1 of paper 000).

    Attributes
    ----------
    automaton : HybridAutomaton
    delta, epsilon, z0_bound : float
        Detection delay ``Delta``, threshold ``epsilon`` of eq. (8) and bound ``Z0`` on
        ``||x - z_i||`` when location ``i`` is entered (Proposition 3.1.1).
    generators : tuple of ResidualGenerator
    group_of : tuple of int
        Generator index of each location.
    invariant_margins : tuple of arrays
        Per location, per row of its invariant: the bound on ``|a_k'(x - z)|`` that holds
        ``Delta`` after the location is entered (``||P^{-1/2} a_k|| ||P^{1/2}|| e^{-alpha Delta} Z0``).
    gain_bound : float or None
    """

    automaton: HybridAutomaton
    delta: float
    epsilon: float
    z0_bound: float
    generators: tuple[ResidualGenerator, ...]
    group_of: tuple[int, ...]
    invariant_margins: tuple[np.ndarray, ...]
    gain_bound: float | None = None
    seconds: float = 0.0

    def summary(self) -> dict[str, Any]:
        return {
            "delta": self.delta,
            "epsilon": self.epsilon,
            "z0_bound": self.z0_bound,
            "gain_bound": self.gain_bound,
            "design_seconds": self.seconds,
            "generators": [g.summary() for g in self.generators],
        }


@dataclass(frozen=True)
class DelayCertificate:
    """Proof that no gain with ``||L|| <= gain_bound`` meets the detection delay ``Delta``.

    With ``eps(0) = Z0 v`` (``v`` the top right singular vector of ``C``), ``||r(0)|| = ||C|| Z0``
    and ``||r'(t)|| <= ||C|| h e^{h t} Z0`` where ``h = ||A|| + gain_bound ||C|| >= ||H||``, so
    ``||r(Delta)|| >= ||C|| Z0 (2 - e^{h Delta})``.  When this exceeds ``epsilon`` the residual of
    eq. (13) cannot be below threshold at ``Delta`` for that initial mismatch, whatever the gain.
    """

    location: str
    A: np.ndarray
    C: np.ndarray
    delta: float
    epsilon: float
    z0_bound: float
    gain_bound: float

    def lower_bound(self) -> float:
        """Guaranteed ``||r(Delta)||`` for the worst initial mismatch of norm ``Z0``."""
        nC = float(np.linalg.norm(self.C, 2))
        h = float(np.linalg.norm(self.A, 2)) + self.gain_bound * nC
        return nC * self.z0_bound * (2.0 - math.exp(min(h * self.delta, 700.0)))

    def verify(self) -> bool:
        """Re-check with numpy that the residual bound exceeds the threshold."""
        return self.lower_bound() > self.epsilon


# ============================================================================ design
def design_residual_bank(
    automaton: HybridAutomaton,
    delta: float,
    epsilon: float,
    z0_bound: float,
    *,
    gain_bound: float | None = None,
    max_decay: float | None = None,
    invariant_rtol: float | None = None,
) -> ResidualBank:
    """Design the residual generators of paper 000 (eqs. 6-8) for a detection delay ``Delta``.

    Implements Proposition 3.1.1 with an LMI in place of the Jordan-form condition (9): for each
    distinct dynamics, the decay rate ``alpha`` is raised (fixed point ``alpha = log(beta Z0 /
    epsilon) / Delta``, a few solves of one compiled problem) until the residual bound ``beta
    e^{-alpha t} Z0`` is below ``epsilon`` at ``t = Delta``; at each ``alpha`` the LMI minimises
    ``cond(P)``.

    Parameters
    ----------
    automaton : HybridAutomaton
        Affine locations; every pair ``(A_i, C_i)`` must be observable.
    delta : float
        Required detection delay ``Delta`` (s).
    epsilon : float
        Threshold of eq. (8) (output units; the Euclidean norm for vector outputs).
    z0_bound : float
        ``Z0``: bound on ``||x - z_i||`` at the instant location ``i`` is entered.
    gain_bound : float, optional
        Bound on ``||L_j||``; with it an impossible ``Delta`` is proven impossible (see
        :class:`DelayCertificate`).
    max_decay : float, optional
        Largest admissible decay rate (1/s), e.g. a fraction of the sampling rate.
    invariant_rtol : float, optional
        Also require the invariant tests to be sharp at ``Delta``: every margin
        ``||P^{-1/2} a_k|| ||P^{1/2}|| e^{-alpha Delta} Z0`` at most ``invariant_rtol`` times the
        row's extent ``||a_k * S||`` over the state scale ``S`` (half-widths of the state bounds).
        Without it the margins are whatever the residual requirement leaves, which can exceed a
        thin invariant (the driveline's shaft enters the backlash by a few mrad).

    Raises
    ------
    ModelError
        Bad arguments, a non-affine location, or an unobservable ``(A_i, C_i)`` (named).
    InfeasibleError
        ``Delta`` is unattainable for a location (named): proven for every gain within
        ``gain_bound`` (``certificate`` is a :class:`DelayCertificate`), or not reached by the LMI
        design within ``gain_bound`` / ``max_decay`` (``certificate`` is ``None``).
    SolverError
        Clarabel failed.
    """
    for name, value in (("delta", delta), ("epsilon", epsilon), ("z0_bound", z0_bound)):
        if not (isinstance(value, (int, float, np.floating)) and np.isfinite(value) and value > 0):
            raise ModelError(name, "a positive finite number", repr(value))
    for name, value in (("gain_bound", gain_bound), ("max_decay", max_decay), ("invariant_rtol", invariant_rtol)):
        if value is not None and not (np.isfinite(value) and value > 0):
            raise ModelError(name, "a positive finite number or None", repr(value))
    t_start = time.perf_counter()
    groups = distinct_dynamics(automaton)
    check_observable(automaton)
    n, p = automaton.n, automaton.p
    lmi = LuenbergerLMI(n, p, gain_bound)
    cap = DECAY_GUARD if max_decay is None else float(max_decay)
    scale = state_scale(automaton)
    gens: list[ResidualGenerator] = []
    solved: list[tuple[np.ndarray, np.ndarray, ResidualGenerator]] = []
    for g in groups:
        A, B, E, C, D, c = _affine_key(automaton, g[0])
        label = location_label(automaton, g)
        # q1 and q3 of the driveline differ only in E: the LMI depends on (A, C) alone.
        reuse = next((gen for (A2, C2, gen) in solved if _same((A, C), (A2, C2))), None)
        if reuse is None:
            rows = None
            if invariant_rtol is not None:
                # every location with these (A, C), so that the reused design serves them all
                same = [q for q in range(automaton.n_locations)
                        if _same((A, C), (automaton.locations[q].A, automaton.locations[q].C))]
                ax = np.vstack([automaton.locations[q].invariant.A[:, :n] for q in same])
                rows = (ax, invariant_rtol * np.linalg.norm(ax * scale[None, :], axis=1))
            P, L, decay, status, iters, secs = _search_decay(lmi, A, C, float(delta), float(epsilon), float(z0_bound),
                                                             gain_bound, cap, label, rows)
        else:
            P, L, decay, status, iters, secs = reuse.P, reuse.L, reuse.decay, reuse.status, 0, 0.0
        gen = _generator(g, label, (A, B, E, C, D, c), P, L, decay, status, iters, secs,
                         float(delta), float(epsilon), float(z0_bound))
        if reuse is None:
            solved.append((A, C, gen))
        gens.append(gen)
    group_of = [0] * automaton.n_locations
    for k, g in enumerate(groups):
        for q in g:
            group_of[q] = k
    margins = tuple(_invariant_margins(automaton, q, gens[group_of[q]], float(delta), float(z0_bound))
                    for q in range(automaton.n_locations))
    return ResidualBank(automaton, float(delta), float(epsilon), float(z0_bound), tuple(gens), tuple(group_of), margins,
                        gain_bound, time.perf_counter() - t_start)


def _search_decay(lmi: LuenbergerLMI, A, C, delta, epsilon, z0, gain_bound, cap, label, rows=None):
    what = f"residual generator LMI of location {label}"
    if gain_bound is not None:
        cert = DelayCertificate(label, np.array(A), np.array(C), delta, epsilon, z0, float(gain_bound))
        if cert.verify():
            raise InfeasibleError(
                f"detection delay Delta = {delta:g} s for location {label}",
                cert,
                f"no gain with ||L|| <= {gain_bound:g} can bring the residual below epsilon = {epsilon:g} within Delta: "
                f"||r(Delta)|| >= {cert.lower_bound():.4g} for an initial mismatch of norm Z0 = {z0:g} (paper 000, eq. 13)",
            )
    nC = float(np.linalg.norm(C, 2))
    # Any bound beta e^{-alpha t} Z0 has beta >= ||C|| (take t = 0), hence this starting rate.
    alpha = max(math.log(nC * z0 / epsilon), 1.0) / delta
    total, last_status = 0.0, ""
    for it in range(1, MAX_DECAY_ITERATIONS + 1):
        if alpha > cap:
            raise InfeasibleError(
                f"detection delay Delta = {delta:g} s for location {label}",
                None,
                f"the LMI design needs a decay rate of at least {alpha:.4g} 1/s, above max_decay = {cap:g} "
                "(sufficient condition of Proposition 3.1.1; raise max_decay or Delta, or lower Z0/epsilon)",
            )
        try:
            out = lmi.solve(A, C, alpha, what)
        except SolverError:
            # Clarabel occasionally stalls on one ill-conditioned instance; a 1 % larger rate is
            # a different instance and still meets the requirement (the bound only improves).
            alpha *= 1.01
            out = lmi.solve(A, C, alpha, what)
        if out is None and gain_bound is None:
            # Without a gain bound the LMI is feasible at every rate for an observable pair:
            # an "infeasible" answer is the solver giving up on cond(P) (about 1e9 and beyond).
            raise SolverError(what, SOLVER, "infeasible at alpha = %.4g 1/s (numerical)" % alpha,
                              "a larger Delta or epsilon, a smaller Z0 or invariant_rtol: the required decay makes "
                              "the Lyapunov matrix too ill-conditioned")
        if out is None:
            bound = f" with ||L|| <= {gain_bound:g}" if gain_bound is not None else ""
            raise InfeasibleError(
                f"detection delay Delta = {delta:g} s for location {label}",
                None,
                f"the decay-rate LMI is infeasible at alpha = {alpha:.4g} 1/s{bound}, the rate the residual bound "
                f"needs for Delta (sufficient condition of Proposition 3.1.1; raise the gain bound or Delta)",
            )
        P, L, last_status, secs = out
        total += secs
        H = A - L @ C
        decay = certified_decay(H, P)
        Ph, Pmh, _ = _sqrt_psd(P)
        beta = float(np.linalg.norm(C @ Pmh, 2) * np.linalg.norm(Ph, 2))
        need = math.log(max(beta * z0 / epsilon, 1.0)) / delta
        if rows is not None:
            ax, resolution = rows
            keep = resolution > 0
            mu = np.linalg.norm(ax[keep] @ Pmh, axis=1) * np.linalg.norm(Ph, 2)
            if mu.size:
                need = max(need, float(np.max(np.log(np.maximum(mu * z0 / resolution[keep], 1.0)))) / delta)
        if decay >= need and decay > 0:
            return P, L, decay, last_status, it, total
        alpha = need * (1.0 + DELAY_DESIGN_RTOL) + max(alpha - decay, 0.0)
    raise SolverError(what, SOLVER, "decay search did not converge", "a larger Delta or epsilon")


def _generator(g, label, data, P, L, decay, status, iters, secs, delta, epsilon, z0) -> ResidualGenerator:
    A, B, E, C, D, c = data
    H = A - L @ C
    Ph, Pmh, w = _sqrt_psd(P)
    beta = float(np.linalg.norm(C @ Pmh, 2) * np.linalg.norm(Ph, 2))
    cond = float(w[-1] / w[0])
    nC = float(np.linalg.norm(C, 2))
    kappa = jordan_kappa(H)
    sa = spectral_abscissa(H)
    n = A.shape[0]
    arg = n * nC * kappa * z0 / epsilon
    paper_delay = math.log(max(arg, 1.0)) / (-sa) if sa < 0 and np.isfinite(arg) else math.inf
    guaranteed = math.log(max(beta * z0 / epsilon, 1.0)) / decay
    return ResidualGenerator(
        locations=tuple(g), label=label, A=A, B=B, E=E, C=C, D=D, c=c, L=L, P=P, decay=decay, cond_P=cond,
        residual_bound=beta, lmi_bound=nC * math.sqrt(cond), guaranteed_delay=guaranteed, spectral_abscissa=sa,
        jordan_kappa=kappa, paper_delay=paper_delay, paper_condition=bool(paper_delay <= delta), gain_norm=float(np.linalg.norm(L, 2)),
        status=status, iterations=iters, seconds=secs,
    )


def _invariant_margins(automaton: HybridAutomaton, q: int, gen: ResidualGenerator, delta: float, z0: float) -> np.ndarray:
    inv = automaton.locations[q].invariant
    n = automaton.n
    Ph, Pmh, _ = _sqrt_psd(gen.P)
    shrink = np.linalg.norm(Ph, 2) * math.exp(-gen.decay * delta) * z0
    ax = inv.A[:, :n]
    return np.linalg.norm(ax @ Pmh, axis=1) * shrink


def prop_3_1_3_matrix(automaton: HybridAutomaton, i: int, j: int) -> np.ndarray:
    """The matrix of Proposition 3.1.3 of paper 000 for the plant in ``i`` and the generator of ``j``.

    From eqs. (11)-(12), ``r_j' = ... + (C_j B_j - C_i B_i) u``, i.e. ``C_ji B_i + C_j B_ji`` with
    ``C_ji = C_j - C_i`` and ``B_ji = B_j - B_i`` (the signs of eq. (11)-(12) made consistent).  When
    it is invertible (and ``D = 0``), an input can hold ``r_j`` at zero while the plant is in ``i``:
    the wrong residual stays below threshold (a sliding motion on ``r_j = 0``).
    """
    li, lj = automaton.locations[i], automaton.locations[j]
    return lj.C @ lj.B - li.C @ li.B


# ============================================================================ identification logic
@dataclass(frozen=True)
class LocationDecision:
    """Output of the location identification logic at one sample.

    Attributes
    ----------
    location : int
        The identified location, ``-1`` when ambiguous or when no location is consistent.
    held : int
        The location the continuous observer uses: the last identified one (``-1`` before any).
    candidates : tuple of int
        The consistent locations among the current one and its successors.
    status : str
        ``"identified"``, ``"ambiguous"`` or ``"none"``.
    """

    location: int
    held: int
    candidates: tuple[int, ...]
    status: str


class LocationLogic:
    """Location identification logic (end of Section 3.1 of paper 000), deterministic.

    At each sample, from the per-location consistency flags (``sigma`` of the location's
    generator and its invariant test):

    1. the candidates are the consistent locations among the current estimate and its successors
       in the automaton's graph (all locations before the first identification);
    2. one candidate: it is the estimate (a change when it differs from the current one);
    3. several candidates -- the paper's two critical cases (several ``sigma_j`` true; one
       ``sigma_j`` shared by locations the invariants do not separate): *ambiguous*, the
       estimate is ``-1`` and the candidates are reported; the held location does not change;
    4. no candidate: a change is under way (every residual of the allowed locations is still
       above threshold); the held location does not change.  After ``stale_steps`` samples
       without a candidate the current location is forgotten and all locations are searched
       (the true one is a candidate ``Delta`` after it is entered, so a longer gap means the
       estimate is stale).

    Parameters
    ----------
    automaton : HybridAutomaton
    stale_steps : int
        Samples without any candidate before the search widens to all locations.
    q0 : int, optional
        Known initial location.
    """

    def __init__(self, automaton: HybridAutomaton, stale_steps: int, q0: int | None = None):
        self.automaton = automaton
        self.stale_steps = max(int(stale_steps), 1)
        self._succ = tuple(tuple(sorted(set(automaton.successors(q)) - {q})) for q in range(automaton.n_locations))
        self.reset(q0)

    def reset(self, q0: int | None = None) -> None:
        if q0 is not None and not (isinstance(q0, (int, np.integer)) and 0 <= q0 < self.automaton.n_locations):
            raise ModelError("q0", f"a location index in 0..{self.automaton.n_locations - 1} or None", repr(q0))
        self.current: int | None = None if q0 is None else int(q0)
        self.held = -1 if q0 is None else int(q0)
        self._none_count = 0

    def update(self, consistent: Sequence[bool]) -> LocationDecision:
        """One sample: ``consistent[q]`` tells whether location ``q`` is consistent with the data."""
        if self.current is None:
            allowed: tuple[int, ...] = tuple(range(self.automaton.n_locations))
        else:
            allowed = (self.current, *self._succ[self.current])
        cands = tuple(q for q in allowed if consistent[q])
        if len(cands) == 1:
            self.current = self.held = cands[0]
            self._none_count = 0
            return LocationDecision(cands[0], self.held, cands, IDENTIFIED)
        if len(cands) > 1:
            self._none_count = 0
            return LocationDecision(-1, self.held, cands, AMBIGUOUS)
        self._none_count += 1
        if self.current is not None and self._none_count >= self.stale_steps:
            self.current = None
        return LocationDecision(-1, self.held, cands, NO_CANDIDATE)


# ============================================================================ runtime observer
@dataclass(frozen=True, eq=False)
class LocationRun:
    """A whole run of the location observer, sample by sample.

    Attributes
    ----------
    residuals : (N, G) array
        ``||r_j||`` per generator.
    sigma : (N, G) bool array
        Decisions of eq. (8).
    consistent : (N, Q) bool array
        Per location: ``sigma`` of its generator and the invariant test.
    location, held : (N,) int arrays
        Estimated location (``-1`` when ambiguous / none) and the held location.
    status : (N,) object array
    n_candidates : (N,) int array
    seconds : (N,) array
        Compute time per step.
    trace : ObserverTrace
    """

    residuals: np.ndarray
    sigma: np.ndarray
    consistent: np.ndarray
    location: np.ndarray
    held: np.ndarray
    status: np.ndarray
    n_candidates: np.ndarray
    seconds: np.ndarray
    trace: ObserverTrace


class LocationObserver(Observer):
    """The location observer ``H_locobs`` of paper 000 (Fig. 4) on the common observer contract.

    ``step(u, y)`` propagates the bank of residual generators over the last sample, evaluates the
    decisions of eq. (8) and the invariant tests, and runs :class:`LocationLogic`.  The returned
    ``Estimate.x`` is the state of the generator of the held location (a fast but high-overshoot
    estimate, which is why the paper adds the continuous observer); ``mode`` is the identified
    location or ``-1``; ``info`` holds residuals, decisions, candidates and status.

    Parameters
    ----------
    bank : ResidualBank
    Ts : float
        Sampling period of the data.
    x0 : array, optional
        Initial state of every generator (default: centre of the state bounds).
    q0 : int, optional
        Known initial location.
    """

    name = "location"

    def __init__(self, bank: ResidualBank, Ts: float, *, x0: np.ndarray | None = None, q0: int | None = None):
        if not (isinstance(Ts, (int, float, np.floating)) and np.isfinite(Ts) and Ts > 0):
            raise ModelError("Ts", "a positive sampling period", repr(Ts))
        self.bank = bank
        self.automaton = aut = bank.automaton
        self.Ts = float(Ts)
        self.n, self.m, self.p = aut.n, aut.m, aut.p
        self.state_names = aut.state_names
        G, n = len(bank.generators), aut.n
        self._G = G
        blocks = [sampled_observer(g.A, g.B, g.E, g.C, g.D, g.c, g.L, self.Ts) for g in bank.generators]
        open_loop = [sampled_observer(g.A, g.B, g.E, g.C, g.D, g.c, np.zeros_like(g.L), self.Ts) for g in bank.generators]
        self._Ad = _block_diag([b[0] for b in blocks])
        self._Bw = np.vstack([b[1] for b in blocks])
        self._Bd = np.vstack([b[2] for b in blocks])
        self._Ad_ol = _block_diag([b[0] for b in open_loop])
        self._Bw_ol = np.vstack([b[1] for b in open_loop])
        self._C = _block_diag([g.C for g in bank.generators])
        self._Dc = np.vstack([g.D for g in bank.generators])
        self._cc = np.concatenate([g.c for g in bank.generators])
        self._p = aut.p
        # Invariant tests on each location's generator state: rows scaled so that the slack is
        # relative (LOCATION_INVARIANT_RTOL * (1 + |b|)) and shifted by the guaranteed margin.
        self._inv = []
        for q, loc in enumerate(aut.locations):
            inv = loc.invariant
            slack = inv.b + bank.invariant_margins[q] + LOCATION_INVARIANT_RTOL * (1.0 + np.abs(inv.b))
            self._inv.append((bank.group_of[q], inv.A[:, :n], inv.A[:, n:], slack))
        stale = int(math.ceil(bank.delta / self.Ts)) + 1
        self.logic = LocationLogic(aut, stale, q0)
        self._q0 = q0
        self._x0 = x0
        self.reset(x0, q0)

    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, **kwargs: Any) -> None:
        """Restart every generator at ``x0`` and the logic at ``q0`` (``None``: unknown)."""
        x0 = initial_state(x0, self._x0, self.automaton.state_bounds, self.n)
        self._x0 = x0
        self._z = np.tile(x0, self._G)
        self.logic.reset(self._q0 if q0 is None else q0)
        self._u_prev: np.ndarray | None = None
        self._y_prev: np.ndarray | None = None
        self._identified = False

    # ------------------------------------------------------------------ one step
    def _propagate(self, u: np.ndarray, y: np.ndarray) -> None:
        if self._u_prev is not None:
            y_prev = y if self._y_prev is None else self._y_prev
            w = np.concatenate([self._u_prev, y_prev, [1.0]])
            self._z = self._Ad @ self._z + self._Bw @ w + self._Bd @ (y - y_prev)
        self._u_prev, self._y_prev = u, y

    def _decide(self, u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, LocationDecision]:
        p, n = self._p, self.n
        r = (self._C @ self._z + self._Dc @ u + self._cc).reshape(self._G, p) - y[None, :]
        res = np.sqrt(np.sum(r * r, axis=1))
        sigma = res <= self.bank.epsilon
        cons = np.zeros(len(self._inv), dtype=bool)
        for q, (g, Ax, Au, slack) in enumerate(self._inv):
            if sigma[g]:
                z = self._z[g * n : (g + 1) * n]
                lhs = Ax @ z + Au @ u if Au.shape[1] else Ax @ z
                cons[q] = bool(np.all(lhs <= slack))
        return res, sigma, cons, self.logic.update(cons)

    def _estimate(self, dec: LocationDecision, res, sigma, cons, reason: str = "") -> Estimate:
        q = dec.held if dec.held >= 0 else 0
        g = self.bank.group_of[q]
        x = self._z[g * self.n : (g + 1) * self.n].copy()
        if dec.status == IDENTIFIED:
            self._identified = True
            flag = OBSERVABLE
        else:
            flag = UNOBSERVABLE if self._identified else WARMING_UP
        info = {"residuals": res, "sigma": sigma, "consistent": cons, "candidates": dec.candidates,
                "status": dec.status, "held": dec.held, "ambiguous": dec.status == AMBIGUOUS,
                "generator_states": self._z.reshape(self._G, self.n).copy()}
        if reason:
            info["reason"] = reason
        return Estimate(x, dec.location, flag, 0.0, info)

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        self._propagate(u, y)
        res, sigma, cons, dec = self._decide(u, y)
        self.last_decision = dec
        return self._estimate(dec, res, sigma, cons)

    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        """Bad sample: every generator predicts open loop over the sample; the logic holds."""
        if self._u_prev is not None:
            w = np.concatenate([self._u_prev, np.zeros(self.p), [1.0]])
            self._z = self._Ad_ol @ self._z + self._Bw_ol @ w
        if u is not None:
            self._u_prev = u
        self._y_prev = None
        held = self.logic.held
        dec = LocationDecision(-1, held, (), NO_CANDIDATE)
        self.last_decision = dec
        est = self._estimate(dec, np.full(self._G, np.nan), np.zeros(self._G, bool), np.zeros(len(self._inv), bool), reason)
        return Estimate(est.x, -1, FALLBACK, 0.0, est.info)

    # ------------------------------------------------------------------ whole runs
    def run_detailed(self, U, Y) -> LocationRun:
        """Run from the reset state over ``(U, Y)`` keeping residuals, decisions and the logic's output."""
        U, Y = _as_samples(U, Y)
        self.reset()
        N = U.shape[0]
        res = np.full((N, self._G), np.nan)
        sig = np.zeros((N, self._G), bool)
        cons = np.zeros((N, self.automaton.n_locations), bool)
        loc, held, ncand = np.full(N, -1), np.full(N, -1), np.zeros(N, int)
        status = np.empty(N, dtype=object)
        xs, flags, secs = np.full((N, self.n), np.nan), np.empty(N, dtype=object), np.zeros(N)
        for k in range(N):
            e = self.step(U[k], Y[k])
            xs[k], loc[k], flags[k], secs[k] = e.x, e.mode, e.flag, e.seconds
            res[k], sig[k], cons[k] = e.info["residuals"], e.info["sigma"], e.info["consistent"]
            held[k], status[k], ncand[k] = e.info["held"], e.info["status"], len(e.info["candidates"])
        tr = ObserverTrace(xs, loc, flags, secs, self.state_names, self.name)
        return LocationRun(res, sig, cons, loc, held, status, ncand, secs, tr)


def _as_samples(U, Y) -> tuple[np.ndarray, np.ndarray]:
    U = np.asarray(U, dtype=float)
    Y = np.asarray(Y, dtype=float)
    U = U.reshape(len(U), -1)
    Y = Y.reshape(len(Y), -1)
    if U.shape[0] != Y.shape[0]:
        raise ModelError("U, Y", "the same number of samples", f"{U.shape[0]} and {Y.shape[0]}")
    return U, Y


def _block_diag(blocks: Sequence[np.ndarray]) -> np.ndarray:
    rows = sum(b.shape[0] for b in blocks)
    cols = sum(b.shape[1] for b in blocks)
    out = np.zeros((rows, cols))
    r = c = 0
    for b in blocks:
        out[r : r + b.shape[0], c : c + b.shape[1]] = b
        r += b.shape[0]
        c += b.shape[1]
    return out


def detection_delays(t: np.ndarray, events: Sequence[dict], location: np.ndarray) -> list[float | None]:
    """Measured delay of each true location change: from the event time to the first sample at which
    the estimate equals the new location (``None`` if it never does before the next change)."""
    t = np.asarray(t, dtype=float)
    location = np.asarray(location)
    out: list[float | None] = []
    times = [float(e["t"]) for e in events]
    for k, e in enumerate(events):
        t_end = times[k + 1] if k + 1 < len(times) else np.inf
        sel = np.nonzero((t >= times[k] - 1e-12) & (t < t_end) & (location == int(e["to"])))[0]
        out.append(float(t[sel[0]] - times[k]) if sel.size else None)
    return out


__all__ = [
    "AMBIGUOUS",
    "DelayCertificate",
    "IDENTIFIED",
    "LocationDecision",
    "LocationLogic",
    "LocationObserver",
    "LocationRun",
    "LuenbergerLMI",
    "NO_CANDIDATE",
    "ResidualBank",
    "ResidualGenerator",
    "certified_decay",
    "check_observable",
    "design_residual_bank",
    "detection_delays",
    "distinct_dynamics",
    "jordan_kappa",
    "prop_3_1_3_matrix",
    "sampled_observer",
    "spectral_abscissa",
]

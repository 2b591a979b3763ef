"""Gains of the periodic observers at the visible events of a constant-drift system (paper 003).

Paper 003 ("Observer design for piecewise affine hybrid systems with constant drift") samples the
system at its visible events (eq. 14, :func:`~hybobs_opt.systems.event_sampled.periodic_system`)
and estimates the queues there with the periodic Luenberger observer (16)::

    x^(t_{j+1}) = A_j x^(t_j) + a_j + L_j (t_{j+1} - t^_{j+1}),   t^_{j+1} = t_j + C_j x^(t_j) + c_j

whose error obeys ``e_{j+1} = (A_j - L_j C_j) e_j``.  This module designs the gains ``L_j``:

* :func:`deadbeat_gains` -- the *sequential* algorithm.  For any gains the set of possible errors
  after a step from a subspace ``S`` contains ``A_j (S cap ker C_j)`` (on ``ker C_j`` the gain
  does nothing), and the choice ``L_j in A_j s + A_j (S cap ker C_j)`` with ``C_j s = 1`` reaches
  exactly that set.  Walking the periods from ``S = R^N`` gives the fastest possible error
  subspaces and, for every step, *linear* conditions on the gain of its phase.  Periodic gains
  meeting all of them (one least-squares solve per phase; the remaining freedom minimises
  ``sum_j |A_j - L_j C_j|_F``) give a deadbeat observer in the minimal number of visible events.
  If the subspaces stop shrinking, no gains of any kind give deadbeat (certificate); if the
  conditions of two periods conflict, no *periodic* gain reaches the minimal time (certificate).
  For the T-junction this reproduces the paper's gains (20a-b) exactly.
* :func:`positive_observer` -- Remark 4.4's positive observers as a linear program (cvxpy,
  Clarabel): gains with ``A_j - L_j C_j >= 0``, ``L_j C_j >= 0`` and a *periodic linear copositive
  Lyapunov function* ``V_j(e) = p_j^T |e|`` with ``p_{j+1}^T (A_j - L_j C_j) <= rho p_j^T``.  The
  product ``p_{j+1}^T L_j`` is bilinear; the change of variables ``Z_j = diag(p_{j+1}) L_j`` makes
  every constraint linear (``diag(p_{j+1}) A_j - Z_j C_j >= 0``, ``Z_j C_j >= 0``,
  ``A_j^T p_{j+1} - C_j^T 1^T Z_j <= rho p_j``), and ``L_j = Z_j / p_{j+1}`` is recovered exactly.
  The rate ``rho`` is found by bisection over re-solves of one compiled problem.  The certificate
  (``p``, ``rho``) comes out of the LP and is re-checked in numpy.

Why the LP is exact here (and how infeasibility is proved).  The matrices ``A_j, C_j`` are
non-negative (Remark 3.1).  Then ``L_j C_j >= 0`` and ``A_j - L_j C_j >= 0`` say exactly that each
entry of ``L_j`` lies in ``[0, U_ji]`` with ``U_ji = min_{k: C_jk > 0} A_jik / C_jk`` (a box), and
the closed loop ``A_j - L_j C_j`` decreases entrywise as ``L_j`` grows.  Products of non-negative
matrices and their spectral radii are monotone, so the corner ``L = U`` is the best positive gain
for every such criterion: a positive observer converges (is deadbeat) iff the monodromy at ``U``
is Schur (nilpotent).  When it is not, a Perron vector ``z >= 0`` with ``Phi(U) z >= r z`` proves
``rho(Phi(L)) >= r`` for every positive gain (:class:`PerronCertificate`).  For the T-junction the
paper's gains (20a-b) *are* this corner.

The runtime object that runs (16) with these gains is :class:`~hybobs_opt.observers.periodic.PeriodicObserver`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_instance
from ..errors import InfeasibleError, ModelError, SolverError
from ..results import Certificate
from ..status import Status, is_optimal
from ..systems.event_sampled import PeriodicSystem
from ..defaults import POSITIVE_LP_KAPPA, POSITIVE_LP_RATE_ATOL
from ..tolerances import (
    DEADBEAT_RTOL,
    GAIN_CONSISTENCY_RTOL,
    PERRON_RTOL,
    POSITIVE_LP_RATE_MARGIN,
    POSITIVITY_RTOL,
    SEQUENTIAL_RANK_RTOL,
)


# ---------------------------------------------------------------------------- properties of gains
def as_periodic_system(ps: PeriodicSystem) -> PeriodicSystem:
    """``ps`` itself if it is a :class:`PeriodicSystem`, else :class:`ModelError` naming the argument ``periodic``."""
    return as_instance(ps, "periodic", PeriodicSystem, "a PeriodicSystem (paper 003, eq. 14; see periodic_system())")


def deadbeat_index(ps: PeriodicSystem, M: np.ndarray, start: int) -> int | None:
    """Smallest ``K`` with ``M_{start+K-1} ... M_start = 0`` (``None`` if none within ``N V + V`` steps).

    A nilpotent monodromy has index at most ``N``, so ``N V + V`` steps from any phase suffice.
    """
    out, scale = np.eye(ps.n), 1.0
    for K in range(1, ps.n * ps.period + ps.period + 1):
        Mj = M[(start - 1 + K - 1) % ps.period]
        out = Mj @ out
        scale *= max(1.0, float(np.linalg.norm(Mj, 2)))
        if np.max(np.abs(out)) <= DEADBEAT_RTOL * scale:
            return K
    return None


def positivity_violation(ps: PeriodicSystem, L: np.ndarray) -> tuple[float, float]:
    """Most negative entries of ``A_j - L_j C_j`` and ``L_j C_j`` over ``j``, relative to ``max|A_j|`` (Remark 4.4)."""
    L = ps.check_gains(L)
    LC = L[:, :, None] * ps.C[:, None, :]
    M = ps.A - LC
    scale = np.maximum(np.abs(ps.A).max(axis=(1, 2)), 1e-300)[:, None, None]
    return float(min(0.0, (M / scale).min())), float(min(0.0, (LC / scale).min()))


@dataclass(frozen=True, eq=False)
class PeriodicGains:
    """Gains ``L_1`` to ``L_V`` of observer (16) with the properties that were checked for them.

    Parameters
    ----------
    L : (V, N) array
        ``L_j`` as rows, phase ``j`` at index ``j - 1``.
    method : str
        ``"sequential deadbeat"``, ``"positive deadbeat"``, ``"positive LP"`` or ``"given"``.
    closed_loop : (V, N, N) array
        ``A_j - L_j C_j`` (the error dynamics of (16)).
    monodromy_radius : float
        Spectral radius of the closed-loop monodromy (same for every starting phase).
    deadbeat_steps : int or None
        Largest number of visible events, over the starting phases, after which the error of (16)
        is exactly zero; ``None`` if the gains are not deadbeat.
    positive : bool
        ``A_j - L_j C_j >= 0`` and ``L_j C_j >= 0`` for every ``j`` (Remark 4.4).
    rate : float or None
        Certified contraction per visible event of the copositive Lyapunov function (LP designs).
    certificate : CopositiveCertificate or None
        The LP's convergence certificate.
    status : str
        The solver status behind the gains (``"optimal"``) or ``"closed form"``.
    seconds : float
        Design time.
    info : dict
        Method details (LP solves and bisection bracket, ...).
    residuals : dict
        Constraint residuals at the returned gains: the most negative entries of
        ``A_j - L_j C_j`` and ``L_j C_j`` relative to ``max|A_j|`` (Remark 4.4), the deadbeat
        conditions' least-squares residual per phase (sequential design) and the numpy re-check of
        the Lyapunov inequalities (LP design).

    See Also
    --------
    deadbeat_gains, positive_deadbeat_gains, positive_observer, analyse_gains : return it.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import periodic_system
    >>> server = periodic_system(get_example("switching_server").build())   # system (14) of paper 003
    >>> from hybobs_opt.synthesis import deadbeat_gains
    >>> gains = deadbeat_gains(server)
    >>> gains.deadbeat_steps, gains.status, gains.closed_loop.shape
    (2, 'closed form', (2, 2, 2))
    """

    L: np.ndarray
    method: str
    closed_loop: np.ndarray
    monodromy_radius: float
    deadbeat_steps: int | None
    positive: bool
    rate: float | None = None
    certificate: Any = None
    status: str = "closed form"
    seconds: float = 0.0
    info: dict = field(default_factory=dict)
    residuals: dict = field(default_factory=dict)

    @property
    def deadbeat(self) -> bool:
        return self.deadbeat_steps is not None

    def to_dict(self) -> dict:
        """JSON-ready summary.

        Returns
        -------
        dict
            ``L``, ``method``, ``deadbeat_steps``, ``monodromy_radius``, ``positive``, ``rate``,
            ``status`` and ``seconds``.
        """
        return {
            "L": self.L.tolist(),
            "method": self.method,
            "deadbeat_steps": self.deadbeat_steps,
            "monodromy_radius": self.monodromy_radius,
            "positive": self.positive,
            "rate": self.rate,
            "status": self.status,
            "seconds": self.seconds,
        }


def analyse_gains(ps: PeriodicSystem, L: ArrayLike, method: str = "given", *, rate: float | None = None,
                  certificate: Any = None, status: str = "closed form", seconds: float = 0.0, info: dict | None = None,
                  residuals: dict | None = None) -> PeriodicGains:
    """Closed loop, monodromy radius, deadbeat index and positivity of given gains (eq. 16, Remark 4.4).

    Parameters
    ----------
    ps : PeriodicSystem
        The event-sampled system (eq. 14).
    L : (V, N) array_like
        The gains ``L_j`` as rows.
    method : str, default "given"
        How the gains were obtained (:attr:`PeriodicGains.method`).
    rate, certificate, status, seconds, info : optional
        What the design proved and how (the fields of :class:`PeriodicGains` of the same names).
    residuals : dict, optional
        The design's own residuals; the positivity residuals of Remark 4.4 are added.

    Returns
    -------
    PeriodicGains
        The gains with the properties checked here in numpy.

    See Also
    --------
    deadbeat_gains, positive_observer : designs that end in this analysis.

    Examples
    --------
    Zero gains (the open-loop predictor): the monodromy radius says how fast the error still decays.

    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import periodic_system
    >>> server = periodic_system(get_example("switching_server").build())   # system (14) of paper 003
    >>> import numpy as np
    >>> from hybobs_opt.synthesis import analyse_gains
    >>> result = analyse_gains(server, np.zeros((2, 2)))
    >>> result.monodromy_radius, result.deadbeat_steps, result.positive
    (0.375, None, True)
    """
    ps = as_periodic_system(ps)
    L = ps.check_gains(L)
    M = ps.closed_loop(L)
    radius = float(np.max(np.abs(np.linalg.eigvals(ps.transition(M, 1, ps.period)))))
    steps = [deadbeat_index(ps, M, s) for s in range(1, ps.period + 1)]
    db = None if any(k is None for k in steps) else max(steps)
    neg_m, neg_lc = positivity_violation(ps, L)
    positive = neg_m >= -POSITIVITY_RTOL and neg_lc >= -POSITIVITY_RTOL
    L = L.copy()
    L.setflags(write=False)
    residuals = dict(residuals or {}, min_closed_loop_rel=neg_m, min_LC_rel=neg_lc)
    return PeriodicGains(L=L, method=method, closed_loop=M, monodromy_radius=radius, deadbeat_steps=db,
                         positive=positive, rate=rate, certificate=certificate, status=status, seconds=seconds,
                         info=dict(info or {}), residuals=residuals)


# ---------------------------------------------------------------------------- sequential deadbeat
def _orth(M: np.ndarray, ref: float) -> np.ndarray:
    """Orthonormal basis of the column space of ``M`` (singular values above ``SEQUENTIAL_RANK_RTOL * ref``)."""
    if M.shape[1] == 0:
        return np.zeros((M.shape[0], 0))
    U, s, _ = np.linalg.svd(M, full_matrices=False)
    r = int(np.sum(s > SEQUENTIAL_RANK_RTOL * max(ref, 1e-300)))
    return U[:, :r]


@dataclass(frozen=True)
class _Step:
    phase: int  # 1-based
    dim_before: int
    dim_after: int
    E: np.ndarray | None  # conditions E L_phase = f (None: no condition)
    f: np.ndarray | None


def _minimal_sequence(A: np.ndarray, C: np.ndarray, start: int) -> tuple[list[_Step], np.ndarray | None]:
    """Fastest error subspaces ``S_{i+1} = A_j (S_i cap ker C_j)`` from ``S_0 = R^N`` at phase ``start``.

    Returns the steps (with the linear conditions each puts on its phase's gain) and, if the
    subspaces stop shrinking before reaching ``{0}``, a basis of the subspace they cycle through.
    """
    V, N = A.shape[0], A.shape[1]
    B = np.eye(N)
    steps: list[_Step] = []
    dims = [N]
    i = 0
    while B.shape[1] > 0:
        j = (start - 1 + i) % V
        nA = float(np.linalg.norm(A[j], 2))
        nC = float(np.linalg.norm(C[j]))
        c = C[j] @ B
        if nC == 0.0 or np.linalg.norm(c) <= SEQUENTIAL_RANK_RTOL * nC:
            K, s1 = B, None
        else:
            s1 = B @ c / float(c @ c)
            _, _, Vt = np.linalg.svd(c[None, :])
            K = B @ Vt[1:].T  # the part of S on which C_j vanishes
        T = _orth(A[j] @ K, nA)
        if s1 is None:
            E = f = None
        else:
            P = np.eye(N) - T @ T.T  # (A_j s1 - L_j) must lie in T = A_j (S cap ker C_j)
            E, f = P, P @ (A[j] @ s1)
        steps.append(_Step(j + 1, B.shape[1], T.shape[1], E, f))
        B = T
        dims.append(B.shape[1])
        i += 1
        if i >= 2 * V and all(dims[-1 - r] == dims[-1 - r - V] for r in range(V)):
            return steps, B  # a whole period without shrinking: S_{i+V} = S_i != {0} forever
    return steps, None


def _propagate_minimal(A: np.ndarray, C: np.ndarray, B: np.ndarray, start: int, steps: int) -> np.ndarray:
    """``steps`` minimal propagations ``S <- A_j (S cap ker C_j)`` of the subspace spanned by ``B``."""
    V = A.shape[0]
    for i in range(steps):
        j = (start - 1 + i) % V
        nC = float(np.linalg.norm(C[j]))
        c = C[j] @ B
        if B.shape[1] and nC > 0.0 and np.linalg.norm(c) > SEQUENTIAL_RANK_RTOL * nC:
            _, _, Vt = np.linalg.svd(c[None, :])
            B = B @ Vt[1:].T
        B = _orth(A[j] @ B, float(np.linalg.norm(A[j], 2)))
    return B


@dataclass(frozen=True, eq=False)
class NoDeadbeatCertificate(Certificate):
    """Proof that no gains (even time-varying ones) make observer (16) deadbeat.

    ``S`` (orthonormal basis ``basis``) at phase ``start`` satisfies ``S subset G(S)``, where ``G`` is
    one period of the minimal propagation ``S <- A_j (S cap ker C_j)``.  Whatever the gains, the
    errors reachable after a step from ``S`` contain ``A_j (S cap ker C_j)`` (``C_j e = 0`` there,
    so the gain has no effect), hence the reachable errors contain ``S`` after every period and
    never vanish.

    See Also
    --------
    deadbeat_gains : raises it in an :class:`~hybobs_opt.InfeasibleError`.

    Examples
    --------
    A queue that is never observed (``C = [1, 0]``, ``A = I``): no gain makes the observer deadbeat.

    >>> from hybobs_opt import InfeasibleError
    >>> from hybobs_opt.systems import PeriodicSystem
    >>> from hybobs_opt.synthesis import deadbeat_gains
    >>> hidden = PeriodicSystem(A=[[[1.0, 0.0], [0.0, 1.0]]], a=[[0.0, 0.0]], C=[[1.0, 0.0]], c=[0.0],
    ...                         event_modes=(1,), segments=((1,),), visible_modes=(1,))
    >>> try:
    ...     deadbeat_gains(hidden)
    ... except InfeasibleError as exc:
    ...     certificate = exc.certificate
    >>> type(certificate).__name__, certificate.verify(), certificate.basis.ravel()
    ('NoDeadbeatCertificate', True, array([0., 1.]))
    """

    A: np.ndarray
    C: np.ndarray
    start: int
    basis: np.ndarray

    @property
    def reason(self) -> str:
        return (f"the {self.basis.shape[1]}-dimensional error subspace at phase {self.start} is mapped into itself over "
                "a period even by the best gains: errors in it never show in the visible event times")

    def verify(self) -> bool:
        """Re-check ``S subset G(S)`` with numpy (rank of ``[G(S), S]`` equals rank of ``G(S)``).

        Returns
        -------
        bool
            Whether the subspace is invariant.
        """
        if self.basis.shape[1] == 0:
            return False
        G = _propagate_minimal(self.A, self.C, self.basis, self.start, self.A.shape[0])
        if G.shape[1] == 0:
            return False
        resid = self.basis - G @ (G.T @ self.basis)
        # a few products of ~1-sized matrices: rounding is far below 1e3 x the rank tolerance, a
        # direction of S outside G(S) leaves a residual of order 1 (the basis is orthonormal)
        return bool(np.linalg.norm(resid) <= 1e3 * SEQUENTIAL_RANK_RTOL * max(1.0, np.linalg.norm(self.basis)))


@dataclass(frozen=True, eq=False)
class DeadbeatConflictCertificate(Certificate):
    """Proof that no *periodic* gain reaches deadbeat in the minimal number of visible events.

    Reaching the fastest error subspaces forces, at every step, linear conditions ``E L_j = f`` on
    the gain of that step's phase (see the module).  For phase ``phase`` the conditions collected
    over the periods (and starting phases ``starts``) have no common solution.  This does not
    exclude periodic deadbeat gains that take more events.

    See Also
    --------
    deadbeat_gains : raises it when the minimal-time conditions conflict.
    NoDeadbeatCertificate : the stronger proof that no gain at all is deadbeat.

    Examples
    --------
    The certificate re-derives the conditions from ``A`` and ``C``; claimed for a system whose
    conditions are consistent (``x+ = 0.5 x`` observed through ``x1``), it does not verify:

    >>> import numpy as np
    >>> from hybobs_opt.synthesis import DeadbeatConflictCertificate
    >>> A, C = np.array([[[0.5, 0.0], [0.0, 0.5]]]), np.array([[1.0, 0.0]])
    >>> DeadbeatConflictCertificate(A, C, starts=(1,), phase=1, residual=0.0).verify()
    False
    """

    A: np.ndarray
    C: np.ndarray
    starts: tuple[int, ...]
    phase: int
    residual: float

    @property
    def reason(self) -> str:
        return (f"the conditions on L_{self.phase} from different periods conflict (least-squares residual "
                f"{self.residual:.3g}): no periodic gain reaches deadbeat in the minimal number of events")

    def verify(self) -> bool:
        """Recompute the conditions with numpy and re-check that they are inconsistent.

        Returns
        -------
        bool
            Whether the conditions are inconsistent.
        """
        E, f = _conditions(self.A, self.C, self.starts)[self.phase - 1]
        if E is None:
            return False
        res = _lstsq_residual(E, f)
        return bool(res > GAIN_CONSISTENCY_RTOL * (1.0 + np.linalg.norm(f)))


def _conditions(A: np.ndarray, C: np.ndarray, starts: tuple[int, ...]) -> list[tuple[np.ndarray | None, np.ndarray | None]]:
    V = A.shape[0]
    rows: list[list[np.ndarray]] = [[] for _ in range(V)]
    rhs: list[list[np.ndarray]] = [[] for _ in range(V)]
    for s in starts:
        steps, _ = _minimal_sequence(A, C, s)
        for st in steps:
            if st.E is not None:
                rows[st.phase - 1].append(st.E)
                rhs[st.phase - 1].append(st.f)
    return [(np.vstack(r), np.concatenate(b)) if r else (None, None) for r, b in zip(rows, rhs)]


def _lstsq_residual(E: np.ndarray, f: np.ndarray) -> float:
    x = np.linalg.lstsq(E, f, rcond=None)[0]
    return float(np.linalg.norm(E @ x - f))


def _solve_phase(A: np.ndarray, C: np.ndarray, E: np.ndarray | None, f: np.ndarray | None) -> np.ndarray:
    """The gain meeting ``E L = f`` that minimises ``|A - L C|_F`` (closed form, see module)."""
    N = A.shape[0]
    nC2 = float(C @ C)
    if E is None:
        L0, Nb = np.zeros(N), np.eye(N)
    else:
        L0 = np.linalg.lstsq(E, f, rcond=None)[0]
        _, s, Vt = np.linalg.svd(E)
        r = int(np.sum(s > SEQUENTIAL_RANK_RTOL * max(s[0], 1e-300))) if s.size else 0
        Nb = Vt[r:].T
    if nC2 == 0.0 or Nb.shape[1] == 0:
        return L0
    R = A - np.outer(L0, C)
    z = Nb.T @ (R @ C) / nC2
    return L0 + Nb @ z


def deadbeat_gains(ps: PeriodicSystem) -> PeriodicGains:
    """Deadbeat gains for observer (16) by the sequential algorithm (paper 003, Section 4.1).

    The paper cites "a simple sequential algorithm" for time-varying deadbeat gains; this is one
    that keeps the gains periodic: see the module docstring.  Among the gains that reach the
    fastest error subspaces, the one minimising ``sum_j |A_j - L_j C_j|_F`` is returned (closed
    form); for the T-junction that is exactly (20a-b).

    Parameters
    ----------
    ps : PeriodicSystem

    Returns
    -------
    PeriodicGains
        ``deadbeat_steps`` is the number of visible events after which the error is zero.

    Raises
    ------
    InfeasibleError
        With a :class:`NoDeadbeatCertificate` (no gains at all are deadbeat) or a
        :class:`DeadbeatConflictCertificate` (no periodic gain is deadbeat in minimal time).

    See Also
    --------
    positive_deadbeat_gains, positive_observer : gains that keep the estimate non-negative.
    PeriodicGains : what it returns.
    hybobs_opt.observers.DriftObserver : the observer (16) that uses them.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import periodic_system
    >>> server = periodic_system(get_example("switching_server").build())   # system (14) of paper 003
    >>> from hybobs_opt.synthesis import deadbeat_gains
    >>> gains = deadbeat_gains(server)
    >>> gains.method, gains.deadbeat_steps, gains.monodromy_radius, gains.positive
    ('sequential deadbeat', 2, 0.0, True)
    >>> gains.L.shape                                 # one gain per phase (visible event)
    (2, 2)
    """
    ps = as_periodic_system(ps)
    t0 = time.perf_counter()
    A, C, V = ps.A, ps.C, ps.period
    seq, stuck = _minimal_sequence(A, C, 1)
    if stuck is not None:
        cert = NoDeadbeatCertificate(A, C, 1 + (len(seq) % V), stuck)
        raise InfeasibleError("deadbeat observer (16)", cert, cert.reason)
    # Fastest from every starting phase if possible, else from one of them.
    candidates = [tuple(range(1, V + 1))] + [(s,) for s in range(1, V + 1)] if V > 1 else [(1,)]
    conflict = None
    for starts in candidates:
        conds = _conditions(A, C, starts)
        bad = [j for j, (E, f) in enumerate(conds, 1)
               if E is not None and _lstsq_residual(E, f) > GAIN_CONSISTENCY_RTOL * (1.0 + np.linalg.norm(f))]
        if bad:
            if conflict is None:
                E, f = conds[bad[0] - 1]
                conflict = DeadbeatConflictCertificate(A, C, starts, bad[0], _lstsq_residual(E, f))
            continue
        L = np.array([_solve_phase(A[j], C[j], *conds[j]) for j in range(V)])
        cres = [0.0 if E is None else float(np.linalg.norm(E @ L[j] - f)) for j, (E, f) in enumerate(conds)]
        res = analyse_gains(ps, L, "sequential deadbeat", status="closed form", seconds=time.perf_counter() - t0,
                            residuals={"deadbeat_conditions": cres},
                            info={"fastest_from_phases": list(starts),
                                  "minimal_events": [len(_minimal_sequence(A, C, s)[0]) for s in starts]})
        if res.deadbeat:
            return res
    if conflict is None:  # consistent conditions whose solution rounds to a non-nilpotent monodromy
        raise SolverError("sequential deadbeat gains", "numpy (closed form)", "not deadbeat after rounding",
                          "rescale the system (queue units) so that the rates are of similar size")
    raise InfeasibleError("minimal-time periodic deadbeat gains (sequential algorithm)", conflict, conflict.reason)


# ---------------------------------------------------------------------------- positive observers
def positive_gain_bounds(ps: PeriodicSystem) -> np.ndarray:
    """The box ``0 <= L_j <= U_j`` of gains with ``A_j - L_j C_j >= 0`` and ``L_j C_j >= 0`` (Remark 4.4).

    ``U_ji = min_{k: C_jk > 0} A_jik / C_jk``; rows with ``C_j = 0`` get ``U_j = 0`` (the gain has
    no effect there).

    Parameters
    ----------
    ps : PeriodicSystem
        The ``V``-periodic system (14) of paper 003.

    Returns
    -------
    (V, N) ndarray
        The upper corner ``U`` of the box, one row per phase.

    Raises
    ------
    ModelError
        If some ``A_j`` or ``C_j`` has a negative entry (then Remark 3.1 does not hold and the box
        argument does not apply).

    See Also
    --------
    positive_deadbeat_gains : the corner of this box.
    PerronCertificate : the box's corner proves when no positive gain converges.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import periodic_system
    >>> server = periodic_system(get_example("switching_server").build())   # system (14) of paper 003
    >>> from hybobs_opt.synthesis import positive_gain_bounds
    >>> positive_gain_bounds(server)              # U_j: 0 <= L_j <= U_j keeps A_j - L_j C_j >= 0
    array([[1., 0.],
           [0., 3.]])
    """
    ps = as_periodic_system(ps)
    for name, arr in (("A", ps.A), ("C", ps.C)):
        if np.any(arr < 0):
            raise ModelError(name, "non-negative matrices (Remark 3.1 of paper 003)", f"min entry {arr.min()}")
    U = np.zeros((ps.period, ps.n))
    for j in range(ps.period):
        pos = ps.C[j] > 0
        if pos.any():
            U[j] = np.min(ps.A[j][:, pos] / ps.C[j][pos][None, :], axis=1)
    return U


@dataclass(frozen=True, eq=False)
class PerronCertificate(Certificate):
    """Proof that no positive gain makes the monodromy's spectral radius smaller than ``threshold``.

    With ``U`` the largest admissible positive gains (:func:`positive_gain_bounds`), every
    positive gain has ``A_j - L_j C_j >= A_j - U_j C_j >= 0`` entrywise, so its monodromy is
    entrywise at least ``Phi(U)`` and has spectral radius at least ``rho(Phi(U))``.  A vector
    ``z >= 0`` with ``Phi(U) z >= r z`` proves ``rho(Phi(U)) >= r`` (Collatz-Wielandt).
    ``threshold = 1``: no convergent positive observer; ``threshold = 0``: no positive deadbeat
    observer (then ``r > 0`` is required: the monodromy at ``U`` is not nilpotent).

    See Also
    --------
    positive_gain_bounds : the largest admissible positive gains it uses.
    positive_observer : raises it in an :class:`~hybobs_opt.InfeasibleError`.

    Examples
    --------
    ``x+ = [[1, 1], [0, 1]] x`` observed through ``x1``: deadbeat gains exist, positive ones do not
    converge.

    >>> from hybobs_opt import InfeasibleError
    >>> from hybobs_opt.systems import PeriodicSystem
    >>> from hybobs_opt.synthesis import positive_observer
    >>> shear = PeriodicSystem(A=[[[1.0, 1.0], [0.0, 1.0]]], a=[[0.0, 0.0]], C=[[1.0, 0.0]], c=[0.0],
    ...                        event_modes=(1,), segments=((1,),), visible_modes=(1,))
    >>> try:
    ...     positive_observer(shear)
    ... except InfeasibleError as exc:
    ...     certificate = exc.certificate
    >>> type(certificate).__name__, round(certificate.r, 6), certificate.verify()
    ('PerronCertificate', 1.0, True)
    """

    A: np.ndarray
    C: np.ndarray
    start: int
    z: np.ndarray
    r: float
    threshold: float

    @property
    def reason(self) -> str:
        if self.threshold >= 1.0:
            what = "no positive gain gives a convergent observer"
        elif self.threshold == 0.0:
            what = "no positive gain gives a deadbeat observer"
        else:
            what = f"no positive gain contracts faster than {self.threshold:.4g} per period"
        return (f"with the largest admissible positive gains the monodromy still has spectral radius >= {self.r:.6g} "
                f"(Perron vector z = {np.round(self.z, 6).tolist()}); every other positive gain gives an entrywise "
                f"larger closed loop, so {what}")

    def verify(self) -> bool:
        """Recompute ``U``, ``Phi(U)`` and the ratio ``min (Phi z)_i / z_i`` in numpy.

        Returns
        -------
        bool
            Whether the ratio is at least ``threshold``.
        """
        A, C = self.A, self.C
        if np.any(A < 0) or np.any(C < 0):
            return False
        V, N = A.shape[0], A.shape[1]
        U = np.zeros((V, N))
        for j in range(V):
            pos = C[j] > 0
            if pos.any():
                U[j] = np.min(A[j][:, pos] / C[j][pos][None, :], axis=1)
        M = A - U[:, :, None] * C[:, None, :]
        if M.min() < -POSITIVITY_RTOL * max(1.0, np.abs(A).max()):
            return False
        Phi = np.eye(N)
        for s in range(V):
            Phi = M[(self.start - 1 + s) % V] @ Phi
        z = np.asarray(self.z, dtype=float)
        if np.any(z < 0) or z.sum() <= 0:
            return False
        w = Phi @ z
        pos = z > 0
        ratio = float(np.min(w[pos] / z[pos]))
        if self.threshold == 0.0:
            return ratio > PERRON_RTOL * max(1.0, np.abs(Phi).max())
        return ratio >= self.threshold * (1.0 - PERRON_RTOL)


def _perron(ps: PeriodicSystem, U: np.ndarray) -> tuple[float, np.ndarray]:
    M = ps.closed_loop(U)
    Phi = ps.transition(M, 1, ps.period)
    w, vecs = np.linalg.eig(Phi)
    k = int(np.argmax(w.real))  # Perron root of a non-negative matrix: real and the largest
    z = np.abs(vecs[:, k].real)
    z = z / z.sum() if z.sum() > 0 else np.full(ps.n, 1.0 / ps.n)
    pos = z > 0
    r = float(np.min((Phi @ z)[pos] / z[pos]))
    return r, z


def positive_deadbeat_gains(ps: PeriodicSystem) -> PeriodicGains:
    """The positive deadbeat observer if one exists: the box corner ``L = U`` (see module).

    Parameters
    ----------
    ps : PeriodicSystem
        The ``V``-periodic system (14) of paper 003.

    Returns
    -------
    PeriodicGains
        The gains ``L = U`` and their analysis.

    Raises
    ------
    InfeasibleError
        With a :class:`PerronCertificate` (``threshold = 0``) when ``Phi(U)`` is not nilpotent.

    See Also
    --------
    positive_gain_bounds : the box whose corner it tries.
    deadbeat_gains : deadbeat without positivity.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import periodic_system
    >>> server = periodic_system(get_example("switching_server").build())   # system (14) of paper 003
    >>> from hybobs_opt.synthesis import positive_deadbeat_gains
    >>> gains = positive_deadbeat_gains(server)
    >>> gains.positive, gains.deadbeat_steps
    (True, 2)
    """
    t0 = time.perf_counter()
    U = positive_gain_bounds(ps)
    res = analyse_gains(ps, U, "positive deadbeat", seconds=time.perf_counter() - t0)
    if res.deadbeat:
        return res
    r, z = _perron(ps, U)
    cert = PerronCertificate(ps.A, ps.C, 1, z, r, 0.0)
    raise InfeasibleError("positive deadbeat observer (16)", cert, cert.reason)


@dataclass(frozen=True, eq=False)
class CopositiveCertificate(Certificate):
    """Convergence certificate of a positive observer: a periodic linear copositive Lyapunov function.

    ``V_j(e) = p_j^T |e|`` with ``p_j > 0`` and ``p_{j+1}^T M_j <= rate p_j^T`` for
    ``M_j = A_j - L_j C_j >= 0``.  Since ``|e_{j+1}| <= M_j |e_j|`` entrywise,
    ``V_{j+1}(e_{j+1}) <= rate V_j(e_j)``: with ``rate < 1`` the error of (16) converges to zero
    geometrically (and ``p`` is a linear copositive Lyapunov function of the lifted system:
    ``p_1^T Phi <= rate^V p_1^T``).

    See Also
    --------
    positive_observer : returns one with its gains.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import periodic_system
    >>> server = periodic_system(get_example("switching_server").build())   # system (14) of paper 003
    >>> from hybobs_opt.synthesis import CopositiveCertificate, positive_observer
    >>> certificate = positive_observer(server).certificate
    >>> isinstance(certificate, CopositiveCertificate), certificate.verify()
    (True, True)
    >>> certificate.rate < 1                       # V_j(e) = p_j' |e| shrinks by this factor per period
    True
    """

    A: np.ndarray
    C: np.ndarray
    L: np.ndarray
    p: np.ndarray
    rate: float

    @property
    def reason(self) -> str:
        return (f"V_j(e) = p_j' |e| with p > 0 decreases by the factor {self.rate:.6g} < 1 at every step of the "
                "positive observer (16) (p_(j+1)' M_j <= rate p_j', M_j = A_j - L_j C_j >= 0): the error converges")

    def check(self) -> dict:
        """The numpy re-check: positivity margins, ``min p`` and the rate recomputed from ``p``.

        Returns
        -------
        dict
            The margins and the recomputed rate.
        """
        V = self.A.shape[0]
        LC = self.L[:, :, None] * self.C[:, None, :]
        M = self.A - LC
        scale = max(1.0, float(np.abs(self.A).max()))
        worst = 0.0
        for j in range(V):
            lhs = self.p[(j + 1) % V] @ M[j]
            worst = max(worst, float(np.max(lhs / self.p[j])))
        return {"min_closed_loop": float(M.min() / scale), "min_LC": float(LC.min() / scale),
                "min_p": float(self.p.min()), "rate": worst}

    def verify(self) -> bool:
        """``M_j >= 0``, ``L_j C_j >= 0``, ``p > 0`` and ``p_{j+1}^T M_j <= rate p_j^T`` with ``rate < 1``.

        Returns
        -------
        bool
            Whether the certificate holds.
        """
        c = self.check()
        return bool(c["min_closed_loop"] >= -POSITIVITY_RTOL and c["min_LC"] >= -POSITIVITY_RTOL and c["min_p"] > 0
                    and c["rate"] <= self.rate * (1.0 + PERRON_RTOL) + PERRON_RTOL and self.rate < 1.0)


class _PositiveLP:
    """The positive-observer LP for one periodic system, compiled once, re-solved for each ``rho``."""

    def __init__(self, ps: PeriodicSystem, kappa: float):
        import cvxpy as cp

        V, N = ps.period, ps.n
        self.p = cp.Variable((V, N))
        self.Z = cp.Variable((V, N))
        self.rho = cp.Parameter(nonneg=True)
        cons = [self.p >= 1.0, self.p <= kappa]
        weight = []
        for j in range(V):
            jn = (j + 1) % V
            A, C = ps.A[j], ps.C[j]
            ZC = cp.reshape(self.Z[j], (N, 1), order="F") @ C.reshape(1, N)
            cons += [cp.diag(self.p[jn]) @ A - ZC >= 0, ZC >= 0,
                     A.T @ self.p[jn] - C * cp.sum(self.Z[j]) <= self.rho * self.p[j]]
            weight.append(float(C.sum()) * cp.sum(self.Z[j]))
        # Larger gains give an entrywise smaller closed loop (see module): push towards the corner U.
        self.problem = cp.Problem(cp.Maximize(sum(weight) - 1e-6 * cp.sum(self.p)), cons)

    def solve(self, rho: float):
        from ..lmi.solve import solve_problem

        self.rho.value = float(rho)
        return solve_problem(self.problem)


def positive_observer(ps: PeriodicSystem, rate: float | None = None, *, kappa: float = POSITIVE_LP_KAPPA) -> PeriodicGains:
    """Positive observer (Remark 4.4) with a copositive Lyapunov certificate, by linear programming.

    Solves the LP of the module docstring with cvxpy and Clarabel: for a requested ``rate`` once,
    otherwise by bisection for the smallest rate in ``[0, 1 - POSITIVE_LP_RATE_MARGIN]`` (to
    ``POSITIVE_LP_RATE_ATOL``).  The gains ``L_j = Z_j / p_{j+1}`` are projected onto the box
    ``[0, U_j]`` (a change of order 1e-9 that makes positivity exact) and the certificate is
    re-checked in numpy at the rate recomputed from ``p``.

    Parameters
    ----------
    ps : PeriodicSystem
    rate : float, optional
        Required contraction of ``V_j(e) = p_j^T |e|`` per visible event, in ``(0, 1)``.
    kappa : float
        Bound ``1 <= p <= kappa`` on the Lyapunov weights (the LP is homogeneous in ``p``).

    Returns
    -------
    PeriodicGains
        With ``certificate`` (:class:`CopositiveCertificate`), ``rate``, and ``status="optimal"``.

    Raises
    ------
    InfeasibleError
        With a :class:`PerronCertificate` when no positive gain reaches the rate (``rate^V`` per
        period; 1 by default: no convergent positive observer).
    SolverError
        If Clarabel fails, or the LP is infeasible only because of ``kappa`` (the message says so).
    ModelError
        For a rate outside ``(0, 1)`` or a periodic system with negative entries.

    See Also
    --------
    CopositiveCertificate : its convergence certificate.
    PerronCertificate : the proof when no positive gain converges.

    Examples
    --------
    The fastest positive observer of the switching server, with a copositive Lyapunov function:

    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.systems import periodic_system
    >>> server = periodic_system(get_example("switching_server").build())   # system (14) of paper 003
    >>> from hybobs_opt.synthesis import positive_observer
    >>> gains = positive_observer(server)
    >>> gains.positive, round(gains.monodromy_radius, 6), gains.certificate.verify()
    (True, 0.0, True)
    """
    ps = as_periodic_system(ps)
    if rate is not None and not (isinstance(rate, (int, float)) and 0.0 < float(rate) < 1.0):
        raise ModelError("rate", "a contraction rate in (0, 1) per visible event", repr(rate))
    if not (np.isfinite(kappa) and kappa > 1.0):
        raise ModelError("kappa", "a bound > 1 on the Lyapunov weights", repr(kappa))
    t0 = time.perf_counter()
    U = positive_gain_bounds(ps)
    lp = _PositiveLP(ps, kappa)
    history: list[tuple[float, str]] = []

    def attempt(rho: float) -> bool:
        out = lp.solve(rho)
        history.append((rho, out.status))
        if is_optimal(out.status):
            return True
        if out.status in (Status.INFEASIBLE, Status.OPTIMAL_INACCURATE, Status.INFEASIBLE_INACCURATE):
            return False  # inaccurate answers are never taken as feasible
        raise SolverError("positive observer LP (Remark 4.4)", "CLARABEL", out.status, "check the periodic system's scaling")

    hi = float(rate) if rate is not None else 1.0 - POSITIVE_LP_RATE_MARGIN
    if not attempt(hi):
        threshold = hi ** ps.period if rate is not None else 1.0
        r, z = _perron(ps, U)
        cert = PerronCertificate(ps.A, ps.C, 1, z, r, threshold)
        if cert.verify():
            raise InfeasibleError("positive observer LP (Remark 4.4)", cert, cert.reason)
        raise SolverError("positive observer LP (Remark 4.4)", "CLARABEL", history[-1][1],
                          f"a positive observer with rate {hi:.4g} may exist (spectral radius at the largest gains "
                          f"{r:.4g}) but needs Lyapunov weights beyond kappa = {kappa:g}; raise kappa")
    best = (lp.p.value.copy(), lp.Z.value.copy(), hi)
    if rate is None:
        lo = 0.0
        while hi - lo > POSITIVE_LP_RATE_ATOL:
            mid = 0.5 * (lo + hi)
            if attempt(mid):
                hi = mid
                best = (lp.p.value.copy(), lp.Z.value.copy(), mid)
            else:
                lo = mid
    p, Z, _ = best
    V = ps.period
    L = np.zeros((V, ps.n))
    for j in range(V):
        L[j] = np.clip(Z[j] / p[(j + 1) % V], 0.0, U[j])
    cert0 = CopositiveCertificate(ps.A, ps.C, L, p, 1.0)
    certified = cert0.check()["rate"]
    cert = CopositiveCertificate(ps.A, ps.C, L, p, certified)
    if not cert.verify():
        raise SolverError("positive observer LP (Remark 4.4)", "CLARABEL", Status.RECHECK_FAILED,
                          f"the recovered gains fail the numpy re-check (rate {certified:.6g}); try another rate")
    return analyse_gains(ps, L, "positive LP", rate=certified, certificate=cert, status=Status.OPTIMAL,
                         seconds=time.perf_counter() - t0, residuals={"lyapunov_recheck": cert.check()},
                         info={"lp_solves": len(history), "bisection": history, "kappa": kappa,
                               "box_corner_U": U.tolist()})


__all__ = [
    "CopositiveCertificate",
    "DeadbeatConflictCertificate",
    "NoDeadbeatCertificate",
    "PeriodicGains",
    "PerronCertificate",
    "analyse_gains",
    "as_periodic_system",
    "deadbeat_gains",
    "deadbeat_index",
    "positive_deadbeat_gains",
    "positive_gain_bounds",
    "positive_observer",
    "positivity_violation",
]

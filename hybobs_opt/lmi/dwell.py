"""The dwell time of a switched-gain observer, eqs. (47)-(48) of paper 004 (Theorem 6).

Theorem 6: if each region ``i`` has ``P_i, L_i`` satisfying its LMI with decay rate ``sigma_i``
(eqs. 52-53) and ``P_i >= P_j exp(-tau sigma_j)`` for every switch ``i -> j`` the observer can make
(eqs. 47-48), switching no faster than ``tau`` keeps the observer globally asymptotically stable.

:func:`dwell_time_fixed` evaluates the smallest ``tau`` for *given* ``P_i``;
:class:`DwellTimeLMI` searches ``tau`` jointly over all ``P_i`` (and ``L_i``): one LMI feasibility
problem, built once with ``mu_j = exp(-tau sigma_j)`` as cvxpy ``Parameter``s, re-solved by
bisection on ``tau``.  :func:`hysteresis_for_dwell` turns ``tau`` into the hysteresis ``epsilon``
of Fig. 1 that enforces it when the scheduling variable moves at most at a given rate.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import weakref

import cvxpy as cp
import numpy as np
from scipy.linalg import eigh

from .._validate import as_positive
from ..errors import ModelError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..defaults import BISECTION_RTOL
from ..tolerances import LMI_STRICT_MARGIN, TAU_RATE_FLOOR
from .bounds import JacobianBounds
from .lmi_model import LMIParameters, box_scaling, lmi_data, lmi_expression
from .schedule import SchedulingRegion
from .solve import POINT_STATUSES, solve_problem


def dwell_time_fixed(P: Sequence[np.ndarray], sigmas: Sequence[float], pairs: Sequence[tuple[int, int]]) -> float:
    """Smallest ``tau`` with ``P_i >= exp(-tau sigma_j) P_j`` for all ``(i, j)`` in ``pairs`` (fixed ``P``).

    ``exp(-tau sigma_j) P_j <= P_i`` holds iff ``exp(-tau sigma_j) <= 1 / lambda_max(P_j, P_i)``
    (generalised eigenvalue), i.e. ``tau >= ln(lambda_max) / sigma_j``.

    Parameters
    ----------
    P : sequence of (n, n) arrays
        The regions' Lyapunov matrices ``P_i`` (positive definite).
    sigmas : sequence of float
        The regions' decay rates ``sigma_i``.
    pairs : sequence of (i, j)
        The switches ``i -> j`` the observer can make (0-based region indices).

    Returns
    -------
    float
        The dwell time; ``inf`` when a needed ``sigma_j`` is not positive.

    See Also
    --------
    DwellTimeLMI : The joint LMI that also chooses the ``P_i``.
    synthesize_switched : Uses both for its dwell time.

    Examples
    --------
    Two Lyapunov matrices a factor ``e`` apart need ``tau = 1 / sigma``:

    >>> import numpy as np
    >>> from hybobs_opt.lmi import dwell_time_fixed
    >>> P = [np.eye(2), np.e * np.eye(2)]
    >>> round(dwell_time_fixed(P, [2.0, 2.0], [(0, 1), (1, 0)]), 6)
    0.5
    """
    tau = 0.0
    for i, j in pairs:
        lam = float(eigh(P[j], P[i], eigvals_only=True).max())
        if lam > 1.0:
            if sigmas[j] <= 0:
                return float("inf")
            tau = max(tau, float(np.log(lam)) / float(sigmas[j]))
    return tau


def hysteresis_for_dwell(tau: float, max_rate: float) -> float:
    """Hysteresis ``epsilon`` of Fig. 1 that enforces a dwell time ``tau`` (paper 004, Section 5).

    With neighbouring regions overlapping by ``2 epsilon`` and the switch made when the scheduling
    variable leaves the current region, a switch back needs a travel of ``2 epsilon``: at a rate of
    at most ``max_rate`` that takes at least ``2 epsilon / max_rate``.  Hence ``epsilon = tau *
    max_rate / 2`` (regions must also be at least ``2 epsilon`` wide between switching points).

    Parameters
    ----------
    tau : float
        Dwell time to enforce (``>= 0``, time units of the system).
    max_rate : float
        Largest ``|ds/dt|`` of the scheduling variable (positive).

    Returns
    -------
    float
        ``epsilon = tau * max_rate / 2``, in units of the scheduling variable.

    See Also
    --------
    dwell_for_hysteresis : The inverse.
    regions_from_switch_points : Builds regions with that overlap.

    Examples
    --------
    A dwell time of 0.1 s for a yaw that turns at most 0.5 rad/s needs regions that overlap by
    ``2 epsilon`` = 0.05 rad:

    >>> from hybobs_opt.lmi import hysteresis_for_dwell
    >>> hysteresis_for_dwell(0.1, 0.5)
    0.025
    """
    max_rate = as_positive(max_rate, "max_rate", "a positive maximum rate of the scheduling variable")
    if not (tau >= 0):
        raise ModelError("tau", "a non-negative dwell time", repr(tau))
    return float(0.5 * tau * max_rate)


def dwell_for_hysteresis(epsilon: float, max_rate: float, regions: Sequence[SchedulingRegion] = ()) -> float:
    """The dwell time a hysteresis ``epsilon`` guarantees (inverse of :func:`hysteresis_for_dwell`).

    Also limited by the narrowest travel between two switching points (a region's width minus the
    two overlaps).

    Parameters
    ----------
    epsilon : float
        Hysteresis (half the overlap of neighbouring regions), in units of the scheduling variable.
    max_rate : float
        Largest ``|ds/dt|`` of the scheduling variable (positive).
    regions : sequence of SchedulingRegion, optional
        The regions in order; with more than two, the interior regions' widths also limit the travel.

    Returns
    -------
    float
        The guaranteed dwell time ``2 epsilon / max_rate`` (shorter when an interior region leaves
        less travel between its two switching points).

    See Also
    --------
    hysteresis_for_dwell : The inverse.
    dwell_time_fixed : The dwell time the Lyapunov matrices need.

    Examples
    --------
    >>> from hybobs_opt.lmi import dwell_for_hysteresis
    >>> dwell_for_hysteresis(0.025, 0.5)
    0.1
    """
    max_rate = as_positive(max_rate, "max_rate", "a positive maximum rate of the scheduling variable")
    travel = 2.0 * epsilon
    if len(regions) > 2:
        # entering an interior region at one switching point and leaving at the next
        travel = min(travel, min(r.width - 2.0 * epsilon for r in regions[1:-1]))
    return float(travel / max_rate)


@dataclass(frozen=True)
class DwellResult:
    """Outcome of the joint dwell-time search.

    Attributes
    ----------
    tau : float
        Smallest dwell time found (within the bisection tolerance) with a feasible joint LMI.
    tau_fixed : float
        The dwell time of eqs. (47)-(48) for the per-region solutions (no joint search).
    P, L : list of arrays
        Lyapunov matrices (model coordinates, one common scaling so (47)-(48) hold between them)
        and gains at ``tau``.
    multipliers : list of float or array
        The S-procedure multipliers of each region's LMI (``nan`` for the polytopic condition).
    solves : int
        Joint LMI solves made.
    min_pair_eig : float
        ``min over pairs of lambda_min(P_i - exp(-tau sigma_j) P_j)`` (numpy re-check, scaled).
    """

    tau: float
    tau_fixed: float
    P: list[np.ndarray]
    L: list[np.ndarray]
    multipliers: list[float]
    solves: int
    min_pair_eig: float
    lmi_max_eig: list[float]


_COMPILED: "weakref.WeakKeyDictionary[ScalarNonlinearSystem, dict]" = weakref.WeakKeyDictionary()


class DwellTimeLMI:
    """Joint LMI over all regions: each region's LMI (sigma_i fixed) plus eqs. (47)-(48).

    The regions' bounds, the ``sigma_i``, the gain bound and ``mu_j = exp(-tau sigma_j)`` are all
    cvxpy ``Parameter``s: :meth:`compiled` returns one problem per system and switching graph,
    re-solved for every ``tau`` of the bisection and every later synthesis with the same graph.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    n_regions : int
    pairs : sequence of (i, j)
        The switches ``i -> j`` the observer can make.
    gain_bound : float, optional
        ``||L_i||_2 <= gain_bound`` in every region (as in :class:`.ObserverLMI`).
    scaling : array, optional
    condition : {"paper", "per_function", "polytopic"}
        The region condition of :mod:`.hierarchy`: the paper's LMI with one S-procedure multiplier,
        one multiplier per function, or the vertex LMIs of the Jacobian box.

    See Also
    --------
    dwell_time_fixed : The dwell time with the ``P_i`` held fixed.
    synthesize_switched : Builds and searches this LMI.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import synthesize_switched, regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> design = synthesize_switched(vehicle, regions)

    The joint search of ``DwellTimeLMI`` gives a dwell time no longer than the fixed-``P`` one:

    >>> design.dwell_solves > 0, bool(design.tau <= design.tau_fixed)
    (True, True)
    """

    def __init__(self, system: ScalarNonlinearSystem, n_regions: int, pairs: Sequence[tuple[int, int]], *,
                 gain_bound: float | None = None, scaling: np.ndarray | None = None, condition: str = "paper"):
        from .hierarchy import CONDITIONS

        if condition not in CONDITIONS:
            raise ModelError("condition", f"one of {CONDITIONS}", repr(condition))
        self.condition = condition
        K = int(n_regions)
        if K < 1:
            raise ModelError("n_regions", "at least one region", repr(n_regions))
        for i, j in pairs:
            if not (0 <= i < K and 0 <= j < K and i != j):
                raise ModelError("pairs", f"pairs of distinct region indices in [0, {K})", f"{(i, j)}")
        self.system, self.pairs, self.K = system, [tuple(p) for p in pairs], K
        self.d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        data = lmi_data(system).scaled(self.d)
        self.data = data
        n = data.n
        self.mu = cp.Parameter(K, nonneg=True, name="mu")
        self.P, self.Yl, self.Yn, self.eps, self.par, cons, objective = [], [], [], [], [], [], 0
        dmax = float(self.d.max())
        self.gamma = None if gain_bound is None else cp.Parameter(nonneg=True, name="gamma", value=(gain_bound / dmax) ** 2)
        n_mult = data.r + data.p_nl
        self.n_vertices = 2 ** n_mult
        self.A_par: list[list[cp.Parameter]] = []
        self.C_par: list[list[cp.Parameter]] = []
        self.sigma_par: list[cp.Parameter] = []
        self.Yall: list = []
        for k in range(K):
            P = cp.Variable((n, n), symmetric=True, name=f"P{k}")
            if condition == "polytopic":
                Yall = cp.Variable((n, data.p_lin + data.p_nl), name=f"Y{k}")
                Yl = Yn = eps = par = None
                As = [cp.Parameter((n, n), name=f"A{k}_{v}") for v in range(self.n_vertices)]
                Cs = [cp.Parameter((data.p_lin + data.p_nl, n), name=f"C{k}_{v}") for v in range(self.n_vertices)]
                self.A_par.append(As)
                self.C_par.append(Cs)
                self.sigma_par.append(cp.Parameter(nonneg=True, name=f"sigma{k}", value=0.0))
                for A, C in zip(As, Cs):
                    B = P @ A + A.T @ P - Yall @ C - C.T @ Yall.T + self.sigma_par[k] * P
                    cons.append(0.5 * (B + B.T) << -LMI_STRICT_MARGIN * np.eye(n))
            else:
                Yl = cp.Variable((n, data.p_lin), name=f"Yl{k}") if data.p_lin else None
                Yn = cp.Variable((n, data.p_nl), name=f"Yn{k}") if data.p_nl else None
                eps = (cp.Variable(n_mult, nonneg=True, name=f"eps{k}") if condition == "per_function" and n_mult > 1
                       else cp.Variable(nonneg=True, name=f"eps{k}"))
                par = LMIParameters.create(data, False)
                B = lmi_expression(data, P, Yl, Yn, eps, par)
                cons.append(B << -LMI_STRICT_MARGIN * np.eye(data.size))
                Ys = [Y for Y in (Yl, Yn) if Y is not None]
                Yall = cp.hstack(Ys) if len(Ys) > 1 else Ys[0]
            self.Yall.append(Yall)
            if self.gamma is None:
                cons.append(P >> np.eye(n))
            else:
                cons.append(P >> np.diag((self.d / dmax) ** 2))
                G = cp.bmat([[P, Yall], [Yall.T, self.gamma * np.eye(Yall.shape[1])]])
                cons.append(0.5 * (G + G.T) >> 0)
            objective = objective + cp.norm(Yall, "fro")
            self.P.append(P)
            self.Yl.append(Yl)
            self.Yn.append(Yn)
            self.eps.append(eps)
            self.par.append(par)
        for i, j in self.pairs:
            cons.append(self.P[i] - self.mu[j] * self.P[j] >> LMI_STRICT_MARGIN * np.eye(n))
        self.problem = cp.Problem(cp.Minimize(objective), cons)
        lin = np.array(system.linear_outputs, dtype=bool)
        self._cols = np.concatenate([np.nonzero(lin)[0], np.nonzero(~lin)[0]]).astype(int)
        self.sectors: list = []
        self.sigmas: list[float] = []

    @classmethod
    def compiled(cls, system: ScalarNonlinearSystem, n_regions: int, pairs: Sequence[tuple[int, int]], *,
                 gain_bound: float | None = None, scaling: np.ndarray | None = None,
                 condition: str = "paper") -> "DwellTimeLMI":
        """The process-wide compiled joint LMI for this system, switching graph and condition.

        Parameters
        ----------
        system : ScalarNonlinearSystem
            The system (the cache key).
        n_regions : int
            Number of regions.
        pairs : sequence of (i, j)
            The switches ``i -> j`` the observer can make.
        gain_bound : float, optional
            ``||L_i||_2 <= gain_bound`` in every region; set on every call when given.
        scaling : (n,) array, optional
            State scaling (default: the box half-widths).
        condition : {"paper", "per_function", "polytopic"}, default "paper"
            The region condition (see :class:`DwellTimeLMI`).

        Returns
        -------
        DwellTimeLMI
            The cached joint LMI (the same object on every call with the same key).
        """
        d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        key = (int(n_regions), tuple(tuple(p) for p in pairs), gain_bound is None, d.tobytes(), condition)
        per = _COMPILED.setdefault(system, {})
        obj = per.get(key)
        if obj is None:
            obj = per[key] = cls(system, n_regions, pairs, gain_bound=gain_bound, scaling=d, condition=condition)
        elif gain_bound is not None:
            obj.gamma.value = (gain_bound / float(obj.d.max())) ** 2
        return obj

    def set_regions(self, bounds: Sequence[JacobianBounds], sigmas: Sequence[float]) -> "DwellTimeLMI":
        """Assign each region's Jacobian bounds and decay rate to the parameters.

        Parameters
        ----------
        bounds : sequence of JacobianBounds
            One per region, in order.
        sigmas : sequence of float
            The decay rate ``sigma_i`` of each region's LMI.

        Returns
        -------
        DwellTimeLMI
            ``self``.
        """
        if len(bounds) != self.K or len(sigmas) != self.K:
            raise ModelError("sigmas", f"{self.K} bounds and decay rates (one per region)", f"{len(bounds)}, {len(sigmas)}")
        self.sigmas = [float(s) for s in sigmas]
        if self.condition == "polytopic":
            from .polytopic import vertex_matrices, vertex_slopes

            self.vertices = [vertex_matrices(self.data, vertex_slopes(b)) for b in bounds]
            for k, (As, Cs) in enumerate(self.vertices):
                for par, A in zip(self.A_par[k], As):
                    par.value = A
                for par, C in zip(self.C_par[k], Cs):
                    par.value = C
                self.sigma_par[k].value = self.sigmas[k]
            self.sectors = [None] * self.K
            return self
        self.sectors = [self.data.sector(b) for b in bounds]
        for par, sec, s in zip(self.par, self.sectors, self.sigmas):
            par.assign(sec, s)
        return self

    def _check(self, tau: float):
        """Numpy re-check of the point the solver returned; ``None`` when it fails."""
        n = self.data.n
        Ps, Ls, eps_l, eigs = [], [], [], []
        for k in range(len(self.P)):
            if self.P[k].value is None or self.Yall[k].value is None:
                return None
            Pb = 0.5 * (self.P[k].value + self.P[k].value.T)
            if self.condition == "polytopic":
                Yb = np.asarray(self.Yall[k].value, dtype=float)
                e = float("nan")
                lmax = max(float(np.linalg.eigvalsh(Pb @ A + A.T @ Pb - Yb @ C - C.T @ Yb.T + self.sigmas[k] * Pb).max())
                           for A, C in zip(*self.vertices[k]))
                e_ok = True
            else:
                if self.eps[k].value is None:
                    return None
                Yl = self.Yl[k].value if self.Yl[k] is not None else np.zeros((n, 0))
                Yn = self.Yn[k].value if self.Yn[k] is not None else np.zeros((n, 0))
                ev = np.asarray(self.eps[k].value, dtype=float).reshape(-1)
                e = float(ev[0]) if ev.size == 1 else ev
                lmax = float(np.linalg.eigvalsh(self.data.matrix(Pb, Yl, Yn, e, self.sectors[k], self.sigmas[k])).max())
                e_ok = bool(np.all(ev > 0))
                Yb = np.hstack([Yl, Yn])
            if lmax > 0 or not e_ok or np.linalg.eigvalsh(Pb).min() <= 0:
                return None
            Ps.append(Pb)
            Lbar = np.linalg.solve(Pb, Yb)
            L = np.zeros((n, self.system.p))
            L[:, self._cols] = self.d[:, None] * Lbar
            Ls.append(L)
            eps_l.append(e)
            eigs.append(lmax)
        pair_min = min((float(np.linalg.eigvalsh(Ps[i] - np.exp(-tau * self.sigmas[j]) * Ps[j]).min()) for i, j in self.pairs),
                       default=float("inf"))
        if pair_min < 0:
            return None
        P_model = [Pb / self.d[:, None] / self.d[None, :] for Pb in Ps]
        return P_model, Ls, eps_l, pair_min, eigs

    def feasible(self, tau: float):
        """Solve at ``tau``; the numpy-checked point or ``None``.

        Parameters
        ----------
        tau : float
            Dwell time (sets ``mu_j = exp(-tau sigma_j)``).

        Returns
        -------
        tuple or None
            ``(P, L, multipliers, min_pair_eig, lmi_max_eig)`` (``P`` and ``L`` in model coordinates,
            one per region) when the point passes the numpy re-check, else ``None``.
        """
        self.mu.value = np.exp(-tau * np.array(self.sigmas))
        accepted: list = []

        def accept() -> bool:
            checked = self._check(tau)
            if checked is not None:
                accepted.append(checked)
            return checked is not None

        out = solve_problem(self.problem, accept=accept)
        if out.status not in POINT_STATUSES:
            return None
        # the chain stops at the first point that passes the re-check: that check is the answer's
        return accepted[-1] if accepted else self._check(tau)

    def search(self, tau_hi: float, rtol: float = BISECTION_RTOL, tau_fixed: float | None = None) -> DwellResult:
        """Bisection on ``tau`` in ``[0, tau_hi]`` (``tau_hi`` must be feasible, e.g. the fixed-P value).

        ``tau_hi`` is doubled (up to 20 times) until the joint LMI is feasible there.

        Parameters
        ----------
        tau_hi : float
            Upper end of the bisection (finite, ``>= 0``).
        rtol : float, default BISECTION_RTOL
            Relative tolerance of the bisection (:data:`~hybobs_opt.defaults.BISECTION_RTOL`).
        tau_fixed : float, optional
            The fixed-``P`` dwell time, stored in the result (default ``tau_hi``).

        Returns
        -------
        DwellResult
            The smallest dwell time the bisection proved feasible, with its Lyapunov matrices
            and the
            solves made.

        Raises
        ------
        ModelError
            If the joint LMI is infeasible at every ``tau`` tried.
        """
        if not (np.isfinite(tau_hi) and tau_hi >= 0):
            raise ModelError("tau_hi", "a finite non-negative dwell time", repr(tau_hi))
        solves = 0
        if not self.pairs:
            sol = self.feasible(0.0)
            solves += 1
            if sol is None:
                raise ModelError("regions", "regions whose joint LMI is feasible", "an infeasible joint LMI")
            return DwellResult(0.0, 0.0, sol[0], sol[1], sol[2], solves, sol[3], sol[4])
        zero = self.feasible(0.0)
        solves += 1
        if zero is not None:
            return DwellResult(0.0, tau_fixed if tau_fixed is not None else tau_hi, zero[0], zero[1], zero[2], solves, zero[3], zero[4])
        hi = max(tau_hi, 1e-6)
        best = self.feasible(hi)
        solves += 1
        tries = 0
        while best is None and tries < 20:
            hi *= 2.0
            best = self.feasible(hi)
            solves += 1
            tries += 1
        if best is None:
            raise ModelError("regions", "a dwell time making the joint LMI (47)-(48) feasible", f"none up to tau = {hi:.4g}")
        lo = 0.0
        # Below tau * max(sigma_j) = TAU_RATE_FLOOR, mu_j = exp(-tau sigma_j) differs from 1 by less
        # than the LMIs' strict margin resolves: the search stops (its tau is still a checked one).
        smax = max(self.sigmas) if self.sigmas else 0.0
        while hi - lo > rtol * hi and hi * smax > TAU_RATE_FLOOR:
            mid = 0.5 * (lo + hi)
            sol = self.feasible(mid)
            solves += 1
            if sol is None:
                lo = mid
            else:
                hi, best = mid, sol
        return DwellResult(hi, tau_fixed if tau_fixed is not None else tau_hi, best[0], best[1], best[2], solves, best[3], best[4])

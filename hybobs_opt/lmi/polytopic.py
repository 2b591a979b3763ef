"""The polytopic observer condition: one quadratic Lyapunov function for every vertex of the Jacobian box.

For ``x' = A x + F f(E x) + ...``, ``y = h(C x)`` the estimation error of the observer (6) obeys,
by the mean-value theorem applied to each scalar function (paper 004, eqs. 4-5),

.. math::

    \\dot e = \\big(A + F \\Theta E - L\\,[C_\\ell;\\ \\mathrm{M} C_n]\\big) e, \\qquad
    \\Theta = \\mathrm{diag}(\\theta_i),\\ \\theta_i \\in [U_i, V_i], \\quad
    \\mathrm{M} = \\mathrm{diag}(\\mu_j),\\ \\mu_j \\in [M_j, N_j],

with slopes ``theta_i(t), mu_j(t)`` that vary in time inside the box of bounds.  The error
dynamics are affine in the slopes, so ``V = e^T P e`` decreases at rate ``sigma`` for every
slope in the box if and only if it does at the ``2^(r + p_n)`` vertices:

.. math::

    P A_v + A_v^T P - Y C_v - C_v^T Y^T + \\sigma P \\preceq 0 \\quad \\text{for every vertex } v, \\qquad Y = P L .

This is the least conservative condition of the hierarchy (:mod:`.hierarchy`) for a constant gain
with a quadratic Lyapunov function: every ``(P, L)`` of LMI (8)/(22)/(23), with one multiplier or one
per function, satisfies it (the sector conditions hold for every slope in the box).

Infeasibility is certified by multipliers ``Z_v >= 0``, ``sum_v tr Z_v = 1``, with
``sum_v Z_v C_v^T = 0`` and ``W = sum_v (A_v Z_v + Z_v A_v^T + sigma Z_v) >= 0``: then
``sum_v <Z_v, B_v(P, Y)> = <W, P> >= 0`` for every ``P > 0`` and every gain, while the strict
``B_v < 0`` forces it to be ``< 0``.  :meth:`PolytopicCertificate.verify` re-checks this in numpy (to
:data:`~hybobs_opt.tolerances.CERTIFICATE_RTOL`: no solution with a larger relative margin).
"""

from __future__ import annotations

import dataclasses
import itertools
import weakref
from dataclasses import dataclass, field
from functools import cached_property

import cvxpy as cp
import numpy as np

from ..defaults import POLYTOPIC_MAX_VERTICES
from ..errors import ModelError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..tolerances import CERTIFICATE_RTOL, GAIN_BOUND_RTOL, LMI_STRICT_MARGIN
from .bounds import JacobianBounds
from .lmi_model import LMIData, box_scaling, lmi_data
from .solve import INFEASIBLE, POINT_STATUSES, solve_checked, solve_problem
from ..results import Certificate


def vertex_slopes(bounds: JacobianBounds) -> np.ndarray:
    """All vertices of the box of slopes: rows ``(theta_1..theta_r, mu_1..mu_pn)``."""
    lo = np.concatenate([bounds.U, bounds.M])
    hi = np.concatenate([bounds.V, bounds.N])
    if lo.size == 0:
        return np.zeros((1, 0))
    return np.array(list(itertools.product(*zip(lo, hi))), dtype=float)


def vertex_matrices(data: LMIData, slopes: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """``A_v = A + F diag(theta) E`` and ``C_v = [C_l; diag(mu) C_n]`` at each vertex (``data``'s coordinates)."""
    r = data.r
    As, Cs = [], []
    for row in slopes:
        th, mu = row[:r], row[r:]
        As.append(data.A + (data.F * th) @ data.E if r else data.A.copy())
        Cs.append(np.vstack([data.C_lin, mu[:, None] * data.C_nl]))
    return As, Cs


def vertex_decay(P: np.ndarray, L: np.ndarray, As: list[np.ndarray], Cs: list[np.ndarray]) -> float:
    """Largest ``sigma`` with ``P A_cl + A_cl^T P + sigma P <= 0`` at every vertex (numpy).

    ``A_cl = A_v - L C_v`` (``L`` with columns in the order of ``C_v``).  This is the decay rate
    of ``V = e^T P e`` that ``(P, L)`` proves for every slope in the box; negative when it proves
    none.
    """
    w, U = np.linalg.eigh(0.5 * (P + P.T))
    if w.min() <= 0:
        return float("-inf")
    Pih = U @ np.diag(w ** -0.5) @ U.T
    out = float("inf")
    for A, C in zip(As, Cs):
        Acl = A - L @ C
        M = Pih @ (P @ Acl + Acl.T @ P) @ Pih
        out = min(out, float(-np.linalg.eigvalsh(0.5 * (M + M.T)).max()))
    return out


# ---------------------------------------------------------------------------- certificate
@dataclass(frozen=True)
class PolytopicCheck:
    """Numbers of the numpy re-check of a polytopic certificate (after ``sum_v tr Z_v = 1``)."""

    ok: bool
    min_eig_Z: float
    min_eig_W: float
    y_residual: float
    messages: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        return {"ok": self.ok, "min_eig_Z": self.min_eig_Z, "min_eig_W": self.min_eig_W,
                "y_residual": self.y_residual, "messages": list(self.messages)}


@dataclass(frozen=True)
class PolytopicCertificate(Certificate):
    """Multipliers ``Z_v`` proving the polytopic condition infeasible (scaled coordinates).

    Parameters
    ----------
    As, Cs : list of arrays
        The vertex matrices the multipliers refer to.
    sigma : float
    Z : list of arrays
        One PSD multiplier per vertex, as found.
    source : str
        ``"Clarabel Farkas ray"`` or ``"alternative SDP"``.

    See Also
    --------
    PolytopicLMI.certify : Builds one from an infeasible solve.
    DualCertificate : The certificate of the paper's LMI.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import PolytopicLMI, jacobian_bounds
    >>> lmi = PolytopicLMI(vehicle)
    >>> sol = lmi.solve(jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140))), 0.0)
    >>> cert = lmi.certify(sol)
    >>> sol.feasible, len(cert.Z) == len(cert.As), cert.verify()
    (False, True, True)
    """

    As: list[np.ndarray] = field(repr=False)
    Cs: list[np.ndarray] = field(repr=False)
    sigma: float
    Z: list[np.ndarray] = field(repr=False)
    source: str

    def _residual(self, Zs) -> np.ndarray:
        return sum(Z @ C.T for Z, C in zip(Zs, self.Cs))

    def projected(self) -> list[np.ndarray]:
        """The ``Z_v`` projected (least squares) onto ``sum_v Z_v C_v^T = 0``.

        Returns
        -------
        list of ndarray
            The ``Z_v`` projected (least squares) onto ``sum_v Z_v C_v^T = 0``.
        """
        Zs = [0.5 * (Z + Z.T) for Z in self.Z]
        n = Zs[0].shape[0]
        p = self.Cs[0].shape[0]
        if p == 0:
            return Zs
        iu = np.triu_indices(n)
        cols = []
        for C in self.Cs:
            for a, b in zip(*iu):
                S = np.zeros((n, n))
                S[a, b] = S[b, a] = 1.0
                cols.append((S @ C.T).ravel())
        M = np.array(cols).T  # (n p) x (vertices * n(n+1)/2)
        z = np.concatenate([Z[iu] for Z in Zs])
        z = z - M.T @ np.linalg.lstsq(M @ M.T, M @ z, rcond=None)[0]
        out, k = [], iu[0].size
        for v in range(len(Zs)):
            Zv = np.zeros((n, n))
            Zv[iu] = z[v * k:(v + 1) * k]
            out.append(Zv + np.triu(Zv, 1).T)
        return out

    def W_of(self, Zs) -> np.ndarray:
        """``W = sum_v (A_v Z_v + Z_v A_v^T + sigma Z_v)``, symmetrised (the re-check needs ``W >= 0``).

        Parameters
        ----------
        Zs : list of (n, n) arrays
            One multiplier per vertex (e.g. :attr:`Z` or :meth:`projected`).

        Returns
        -------
        ndarray
            ``W = sum_v (A_v Z_v + Z_v A_v^T + sigma Z_v)``, symmetrised (the re-check needs
            ``W >= 0``).
        """
        W = sum(A @ Z + Z @ A.T + self.sigma * Z for Z, A in zip(Zs, self.As))
        return 0.5 * (W + W.T)

    def check(self) -> PolytopicCheck:
        """The numpy re-check (computed once per certificate; a modified copy made with
        ``dataclasses.replace`` is re-checked from scratch).

        Returns
        -------
        PolytopicCheck
            The numpy re-check (computed once per certificate; a modified copy made with
            ``dataclasses.replace`` is re-checked from scratch).
        """
        return self._checked

    @cached_property
    def _checked(self) -> PolytopicCheck:
        """Re-check ``Z_v >= 0``, ``sum Z_v C_v^T = 0``, ``W >= 0``, ``sum tr Z_v > 0`` in numpy (cached)."""
        Zraw = [0.5 * (Z + Z.T) for Z in self.Z]
        scale = float(np.sqrt(sum(np.linalg.norm(Z) ** 2 for Z in Zraw))) or 1.0
        cnorm = max(1.0, max(float(np.linalg.norm(C)) for C in self.Cs)) if self.Cs[0].size else 1.0
        y_raw = float(np.abs(self._residual(Zraw)).max()) / (scale * cnorm) if self.Cs[0].size else 0.0
        Zs = self.projected()
        W = self.W_of(Zs)
        t = float(sum(np.trace(Z) for Z in Zs))
        if not np.isfinite(t) or t <= 0:
            res = PolytopicCheck(False, float("nan"), float("nan"), y_raw, (f"sum tr Z_v = {t:.3g} is not positive",))
            return res
        Zs, W = [Z / t for Z in Zs], W / t
        nZ = float(np.sqrt(sum(np.linalg.norm(Z) ** 2 for Z in Zs)))
        opnorm = 2 * max(float(np.linalg.norm(A, 2)) for A in self.As) + self.sigma + 1.0
        tol_Z, tol_W = CERTIFICATE_RTOL * nZ, CERTIFICATE_RTOL * max(1.0, nZ * opnorm)
        ez = min(float(np.linalg.eigvalsh(Z).min()) for Z in Zs)
        ew = float(np.linalg.eigvalsh(W).min())
        msgs = []
        if ez < -tol_Z:
            msgs.append(f"a Z_v is not PSD: min eigenvalue {ez:.3g} (tolerance {tol_Z:.3g})")
        if ew < -tol_W:
            msgs.append(f"W is not PSD: min eigenvalue {ew:.3g} (tolerance {tol_W:.3g})")
        if y_raw > 1e3 * CERTIFICATE_RTOL:
            msgs.append(f"the Z_v do not annihilate the gain: residual {y_raw:.3g}")
        res = PolytopicCheck(not msgs, ez, ew, y_raw, tuple(msgs))
        return res

    def verify(self) -> bool:
        """True when the numpy re-check confirms the certificate (no solver involved).

        Returns
        -------
        bool
            True when the re-check in plain numpy passes (no solver involved).
        """
        return self.check().ok

    #: Which result the certificate stands for (the attribute of every certificate of the package).
    theorem = "polytopic condition (dual certificate)"

    @property
    def reason(self) -> str:
        return (f"PSD multipliers Z_v, one per vertex of the Jacobian box ({self.source}), with sum_v Z_v C_v^T = 0 and "
                f"W = sum_v (A_v Z_v + Z_v A_v^T + sigma Z_v) >= 0, sum_v tr Z_v = 1: sum_v <Z_v, B_v(P, PL)> = <W, P> >= 0 "
                f"for every P > 0 and every gain L, so the strict vertex LMIs B_v < 0 have no common solution")

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"source": self.source, "verified": self.verify(), "check": self.check().to_dict(),
                "vertices": len(self.Z), "sigma": self.sigma, "reason": self.reason}


# ---------------------------------------------------------------------------- the LMI
@dataclass(frozen=True)
class PolytopicSolution:
    """One solve of the polytopic condition (a :class:`~hybobs_opt.results.SolveResult`)."""

    feasible: bool
    status: str
    sigma: float
    bounds: JacobianBounds = field(repr=False)
    L: np.ndarray | None = None
    P: np.ndarray | None = None
    lmi_max_eig: float | None = None
    p_min_eig: float | None = None
    gain_norm: float | None = None
    outcome: object = field(default=None, repr=False)
    farkas: list | None = field(default=None, repr=False)
    P_scaled: np.ndarray | None = field(default=None, repr=False)
    Y_scaled: np.ndarray | None = field(default=None, repr=False)

    @property
    def region(self):
        return self.bounds.region

    @property
    def residuals(self) -> dict[str, float]:
        out = {}
        if self.lmi_max_eig is not None:
            out["lmi_max_eig"] = self.lmi_max_eig
        if self.p_min_eig is not None:
            out["p_min_eig"] = self.p_min_eig
        return out


_COMPILED: "weakref.WeakKeyDictionary[ScalarNonlinearSystem, dict]" = weakref.WeakKeyDictionary()


class PolytopicLMI:
    """The vertex LMIs of one system, compiled once with the vertex matrices as cvxpy ``Parameter`` objects.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    gain_bound : float, optional
        ``||L||_2 <= gain_bound`` by the same sufficient LMI as :class:`.observer_lmi.ObserverLMI`.
    scaling : array, optional
        State scaling (default: the box half-widths).

    Raises
    ------
    ModelError
        More than :data:`~hybobs_opt.defaults.POLYTOPIC_MAX_VERTICES` vertices.

    See Also
    --------
    ObserverLMI : The paper's LMI (one S-procedure multiplier).
    PolytopicCertificate : Its infeasibility certificate.
    condition_hierarchy : Runs both.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import PolytopicLMI, jacobian_bounds
    >>> lmi = PolytopicLMI(vehicle)
    >>> bounds = jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(80)))
    >>> As, Cs = lmi.vertices(bounds)
    >>> len(As), As[0].shape
    (8, (4, 4))
    >>> lmi.solve(bounds, 0.0).feasible
    True
    """

    form = "polytopic"

    def __init__(self, system: ScalarNonlinearSystem, *, gain_bound: float | None = None,
                 scaling: np.ndarray | None = None):
        if not isinstance(system, ScalarNonlinearSystem):
            raise ModelError("system", "a ScalarNonlinearSystem", type(system).__name__)
        self.system = system
        self.data = lmi_data(system)
        self.d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        self.sdata = self.data.scaled(self.d)
        k = self.sdata.r + self.sdata.p_nl
        if 2 ** k > POLYTOPIC_MAX_VERTICES:
            raise ModelError("system",
                             f"at most {POLYTOPIC_MAX_VERTICES} vertices of the Jacobian box for the polytopic condition",
                             f"2^{k} = {2 ** k}")
        self.n_vertices = 2 ** k
        self.gain_bound = None if gain_bound is None else float(gain_bound)
        lin = np.array(system.linear_outputs, dtype=bool)
        self._cols = np.concatenate([np.nonzero(lin)[0], np.nonzero(~lin)[0]]).astype(int)
        self._build()

    @classmethod
    def compiled(cls, system: ScalarNonlinearSystem, *, gain_bound: float | None = None,
                 scaling: np.ndarray | None = None) -> "PolytopicLMI":
        """The process-wide compiled condition for ``system`` (built once, then re-solved).

        Parameters
        ----------
        system : ScalarNonlinearSystem
            The system (the cache key).
        gain_bound : float, optional
            Bound on ``||L||_2`` (model units); set on every call when given.
        scaling : (n,) array, optional
            State scaling (default: the box half-widths).

        Returns
        -------
        PolytopicLMI
            The cached condition (the same object on every call with the same key), its gain
            bound set on every call.
        """
        d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        key = (gain_bound is None, d.tobytes())
        per = _COMPILED.setdefault(system, {})
        obj = per.get(key)
        if obj is None:
            obj = per[key] = cls(system, gain_bound=gain_bound, scaling=d)
        elif gain_bound is not None:
            obj.gain_bound = float(gain_bound)
            obj.gamma.value = (obj.gain_bound / float(obj.d.max())) ** 2
        return obj

    def _build(self) -> None:
        n, p = self.sdata.n, self.system.p
        self.P = cp.Variable((n, n), symmetric=True, name="P")
        self.Y = cp.Variable((n, p), name="Y")
        self.sigma = cp.Parameter(nonneg=True, name="sigma", value=0.0)
        self.A_par = [cp.Parameter((n, n), name=f"A{v}") for v in range(self.n_vertices)]
        self.C_par = [cp.Parameter((p, n), name=f"C{v}") for v in range(self.n_vertices)]
        self.vertex_constraints = []
        for A, C in zip(self.A_par, self.C_par):
            B = self.P @ A + A.T @ self.P - self.Y @ C - C.T @ self.Y.T + self.sigma * self.P
            self.vertex_constraints.append(0.5 * (B + B.T) << -LMI_STRICT_MARGIN * np.eye(n))
        cons = list(self.vertex_constraints)
        if self.gain_bound is None:
            cons.append(self.P >> np.eye(n))
            self.gamma = None
        else:
            dmax = float(self.d.max())
            cons.append(self.P >> np.diag((self.d / dmax) ** 2))
            self.gamma = cp.Parameter(nonneg=True, name="gamma", value=(self.gain_bound / dmax) ** 2)
            G = cp.bmat([[self.P, self.Y], [self.Y.T, self.gamma * np.eye(p)]])
            cons.append(0.5 * (G + G.T) >> 0)
        self.problem = cp.Problem(cp.Minimize(cp.norm(self.Y, "fro")), cons)

    def vertices(self, bounds: JacobianBounds) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """Vertex matrices of ``bounds`` in scaled coordinates (duplicates kept: the problem has fixed size).

        Parameters
        ----------
        bounds : JacobianBounds
            The Jacobian box of the region.

        Returns
        -------
        As, Cs : list of ndarray
            The ``2^k`` vertex matrices ``A_v`` and ``C_v``.
        """
        return vertex_matrices(self.sdata, vertex_slopes(bounds))

    def solve(self, bounds: JacobianBounds, sigma: float = 0.0) -> PolytopicSolution:
        """One feasibility solve; ``feasible`` only for ``optimal`` plus the numpy re-check at every vertex.

        Parameters
        ----------
        bounds : JacobianBounds
            The Jacobian box of the region.
        sigma : float, default 0.0
            Decay rate ``sigma >= 0``.

        Returns
        -------
        PolytopicSolution
            ``feasible`` only for ``optimal`` plus the numpy re-check at every vertex; ``L``, ``P``
            when feasible.
        """
        if not (np.isfinite(sigma) and sigma >= 0):
            raise ModelError("sigma", "a non-negative decay rate", repr(sigma))
        As, Cs = self.vertices(bounds)
        for par, A in zip(self.A_par, As):
            par.value = A
        for par, C in zip(self.C_par, Cs):
            par.value = C
        self.sigma.value = float(sigma)
        out, point = solve_checked(self.problem, lambda: self._read_point(bounds, As, Cs, sigma, None),
                                   solve_problem)
        if point is not None:
            # the chain stopped at the point that passed this re-check: it is the answer's
            return dataclasses.replace(point, status=out.status, outcome=out)
        if out.status == INFEASIBLE:
            duals = [c.dual_value for c in self.vertex_constraints]
            farkas = None if any(z is None for z in duals) else [np.asarray(z, dtype=float) for z in duals]
            return PolytopicSolution(False, out.status, sigma, bounds, outcome=out, farkas=farkas)
        if out.status not in POINT_STATUSES or self.P.value is None:
            return PolytopicSolution(False, out.status, sigma, bounds, outcome=out)
        return self._read_point(bounds, As, Cs, sigma, out)

    def _read_point(self, bounds, As, Cs, sigma: float, out) -> PolytopicSolution:
        """The solver's current point, re-checked at every vertex in numpy."""
        from ..status import Status

        if self.P.value is None or self.Y.value is None:
            return PolytopicSolution(False, Status.RECHECK_FAILED, sigma, bounds, outcome=out)
        Pb = 0.5 * (np.asarray(self.P.value, dtype=float) + np.asarray(self.P.value, dtype=float).T)
        Yb = np.asarray(self.Y.value, dtype=float)
        if not (np.all(np.isfinite(Pb)) and np.all(np.isfinite(Yb))):
            return PolytopicSolution(False, Status.RECHECK_FAILED, sigma, bounds, outcome=out)
        max_eig = max(float(np.linalg.eigvalsh(Pb @ A + A.T @ Pb - Yb @ C - C.T @ Yb.T + sigma * Pb).max())
                      for A, C in zip(As, Cs))
        p_min = float(np.linalg.eigvalsh(Pb).min())
        if p_min <= 0.0:
            return PolytopicSolution(False, Status.RECHECK_FAILED, sigma, bounds, outcome=out, lmi_max_eig=max_eig,
                                     p_min_eig=p_min)
        Lbar = np.linalg.solve(Pb, Yb)
        L = np.zeros((self.sdata.n, self.system.p))
        L[:, self._cols] = self.d[:, None] * Lbar
        gain = float(np.linalg.norm(L, 2))
        ok = max_eig <= 0.0
        if self.gain_bound is not None and gain > self.gain_bound * (1 + GAIN_BOUND_RTOL):
            ok = False
        status = (out.status if out is not None else Status.OPTIMAL) if ok else Status.RECHECK_FAILED
        return PolytopicSolution(ok, status, sigma, bounds, L, Pb / self.d[:, None] / self.d[None, :], max_eig, p_min,
                                 gain, out, P_scaled=Pb, Y_scaled=Yb)

    def certify(self, sol: PolytopicSolution) -> PolytopicCertificate | None:
        """A verified certificate for an infeasible solve, or ``None`` (none found or none checks).

        Parameters
        ----------
        sol : PolytopicSolution
            An infeasible solve of this condition (its ``farkas`` duals are tried first, then the
            alternative SDP).

        Returns
        -------
        PolytopicCertificate or None
            A verified certificate for an infeasible solve, or ``None`` (none found or none checks).
        """
        As, Cs = self.vertices(sol.bounds)
        if sol.farkas is not None:
            cand = PolytopicCertificate(As, Cs, sol.sigma, sol.farkas, "Clarabel Farkas ray")
            if cand.verify():
                return cand
        Zs = self._alternative(As, Cs, sol.sigma)
        if Zs is not None:
            cand = PolytopicCertificate(As, Cs, sol.sigma, Zs, "alternative SDP")
            if cand.verify():
                return cand
        return None

    @staticmethod
    def _alternative(As, Cs, sigma) -> list[np.ndarray] | None:
        n = As[0].shape[0]
        Z = [cp.Variable((n, n), PSD=True) for _ in As]
        W = sum(A @ z + z @ A.T + sigma * z for z, A in zip(Z, As))
        cons = [0.5 * (W + W.T) >> 0, sum(cp.trace(z) for z in Z) == 1]
        if Cs[0].shape[0]:
            cons.append(sum(z @ C.T for z, C in zip(Z, Cs)) == 0)
        prob = cp.Problem(cp.Minimize(0), cons)
        out = solve_problem(prob)
        if out.status not in POINT_STATUSES or any(z.value is None for z in Z):
            return None
        return [np.asarray(z.value, dtype=float) for z in Z]

    def max_decay(self, bounds: JacobianBounds, sigma_cap: float | None = None, rtol: float | None = None,
                  guess: float | None = None, known: float | None = None):
        """Largest decay rate of the polytopic condition (:func:`.observer_lmi.bisect_decay`).

        Parameters
        ----------
        bounds : JacobianBounds
            The Jacobian box of the region.
        sigma_cap : float, optional
            Upper end of the search (default :data:`~hybobs_opt.defaults.SIGMA_CAP`).
        rtol : float, optional
            Relative tolerance of the bisection (default :data:`~hybobs_opt.defaults.BISECTION_RTOL`).
        guess : float, optional
            Starting rate of the bracket search.
        known : float, optional
            A rate believed feasible, tried when it falls inside the final bracket.

        Returns
        -------
        DecayResult
            The largest rate found and the solution there (no error when ``sigma = 0`` is infeasible).
        """
        from ..defaults import BISECTION_RTOL, SIGMA_CAP
        from .observer_lmi import bisect_decay

        return bisect_decay(lambda sig: self.solve(bounds, sig), SIGMA_CAP if sigma_cap is None else sigma_cap,
                            BISECTION_RTOL if rtol is None else rtol, guess, known=known)

"""The observer-design LMIs of paper 004: Theorem 1's (8), Corollary 1.1's (22), Corollary 1.2's (23).

For ``x' = A x + F f(E x) + B u + g(y, u)``, ``y_j = h_j(C_j x)`` and the observer (6) with gain
``L``, Theorem 1 (with the S-procedure multiplier ``eps`` of eq. (21) kept explicit and the change
of variables ``Y = P L``) asks for ``P > 0`` with

.. math::

    \\begin{bmatrix}
      He(PA) - He(Y_\\ell C_\\ell) + \\sigma P + \\epsilon Q & PF + \\epsilon E^T\\tfrac{U+V}{2} & -Y_n + \\epsilon C_n^T\\tfrac{M+N}{2} \\\\
      \\ast & -\\epsilon I & 0 \\\\
      \\ast & 0 & -\\epsilon I
    \\end{bmatrix} \\preceq 0,
    \\qquad Q = -E^T U V E - C_n^T M N C_n ,

where ``C_n`` are the rows of the nonlinear outputs (bounds ``M, N``, eq. 4) and ``C_l`` those of
the linear outputs (``y = C x``), whose error ``C_l e`` is substituted directly as in (23).  The
special cases are exactly the paper's LMIs with ``eps`` absorbed into ``P`` (divide by ``eps``):

* ``A = 0``, no linear outputs: LMI (8) (Box I);
* no ``f`` (``F f(x) = A x``), all outputs nonlinear: LMI (22) (Corollary 1.1);
* all outputs linear: LMI (23) (Corollary 1.2).

Keeping ``eps`` as a variable makes the problem homogeneous, so ``P >= I`` is no loss of generality
and the LMI can be solved with a strict margin (:data:`~hybobs_opt.tolerances.LMI_STRICT_MARGIN`).
The returned ``P`` is divided by ``eps`` so that it satisfies the paper's printed LMI with ``L``.
The decay rate ``sigma`` (``V' <= -sigma V``) enters bilinearly as ``sigma P``: it is a cvxpy
``Parameter`` and its maximum is found by bisection.  An optional bound ``||L||_2 <= l`` on the
gain (noise sensitivity) uses ``P >= alpha I`` and ``[[P, Y], [Y^T, alpha l^2 I]] >= 0``, which
imply ``L^T L <= L^T P L / alpha <= l^2 I`` (sufficient, not necessary).

Everything is solved in coordinates scaled by the half-widths of the operating box (DESIGN.md:
"scale before you solve"); the LMI is invariant under that congruence.  Each :class:`ObserverLMI`
builds its cvxpy problem once, with the region's bounds as ``Parameter``s, and re-solves it.
"""

from __future__ import annotations

import dataclasses
import weakref
from dataclasses import dataclass, field

import cvxpy as cp
import numpy as np

from .._validate import as_positive
from ..errors import ModelError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..defaults import BISECTION_RTOL, SIGMA_CAP
from ..tolerances import GAIN_BOUND_RTOL, LMI_STRICT_MARGIN
from ..status import Status
from .bounds import JacobianBounds, jacobian_bounds
from .lmi_model import (
    LMIParameters,
    box_scaling,
    lmi_data,
    lmi_expression,
    lmi_form,
)
from .schedule import SchedulingRegion
from .solve import INFEASIBLE, POINT_STATUSES, SolveOutcome, solve_checked, solve_problem


#: The S-procedure multiplier layouts of :class:`ObserverLMI`.
MULTIPLIER_MODES = ("single", "per_function")


# ---------------------------------------------------------------------------- results
@dataclass(frozen=True)
class LMISolution:
    """One solve of an observer LMI for one region (a :class:`~hybobs_opt.results.SolveResult`).

    Parameters
    ----------
    feasible : bool
        True only for a point (status ``optimal`` or ``optimal_inaccurate``, see
        :data:`~.solve.POINT_STATUSES`) that passes the numpy re-check (``lmi_max_eig <= 0``, ``P``
        positive definite, the gain bound).
    status : Status
        The cvxpy status in the one vocabulary (``optimal``, ``infeasible``, ``optimal_inaccurate``,
        ``solver_error``...), or :attr:`~hybobs_opt.status.Status.RECHECK_FAILED` when Clarabel said
        optimal but the point failed the numpy re-check.
    form : str
        ``"(8)"``, ``"(22)"`` or ``"(23)"``.
    sigma : float
        Decay rate imposed (``V' <= -sigma V``).
    L, P : arrays or None
        Gain (``n x p``, columns in output order; zero columns for unused outputs) and the
        Lyapunov matrix in the paper's normalisation (the printed LMI holds with ``eps = 1``),
        both in the model's coordinates.
    multiplier : float, array or None
        The S-procedure multiplier ``eps`` at the solver's point (scaled problem); one per
        function for ``multipliers="per_function"``.
    lmi_max_eig : float or None
        Largest eigenvalue of the LMI matrix at the returned point (scaled coordinates, numpy).
    p_min_eig : float or None
        Smallest eigenvalue of the scaled ``P`` (at least 1 by the normalisation).
    gain_norm : float or None
        ``||L||_2``.
    region : SchedulingRegion or None
        The region (``None`` for the whole operating box).
    bounds : JacobianBounds
        The Jacobian bounds the LMI was solved with.
    outcome : SolveOutcome or None
        The solver chain's status and timing.
    farkas : array or None
        For an infeasible solve, the solver's dual of the LMI constraint (checked by
        :func:`.certificates.certify_infeasible`).
    P_scaled, Y_scaled : arrays or None
        ``P`` and ``Y = P L`` at the solver's point in the scaled coordinates (the columns of ``Y``
        in the order linear outputs, then nonlinear ones).

    See Also
    --------
    ObserverLMI.solve : Returns one.
    certify_infeasible : Explains a solve that is not feasible.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import ObserverLMI, jacobian_bounds
    >>> lmi = ObserverLMI(vehicle)
    >>> sol = lmi.solve(jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(80))), 0.0)
    >>> sol.feasible, sol.status, sol.form
    (True, 'optimal', '(23)')
    >>> sol.L.shape, bool(sol.lmi_max_eig <= 0), bool(sol.p_min_eig > 0)
    ((4, 2), True, True)
    """

    feasible: bool
    status: str
    form: str
    sigma: float
    region: SchedulingRegion | None
    bounds: JacobianBounds
    L: np.ndarray | None = None
    P: np.ndarray | None = None
    multiplier: float | np.ndarray | None = None
    lmi_max_eig: float | None = None
    p_min_eig: float | None = None
    gain_norm: float | None = None
    outcome: SolveOutcome | None = None
    farkas: np.ndarray | None = field(default=None, repr=False)
    P_scaled: np.ndarray | None = field(default=None, repr=False)
    Y_scaled: np.ndarray | None = field(default=None, repr=False)

    @property
    def seconds(self) -> float:
        """Wall time of the solve (0 when the solution was not produced by a solve)."""
        return 0.0 if self.outcome is None else self.outcome.seconds

    @property
    def residuals(self) -> dict[str, float]:
        """Constraint residuals at the returned point.

        With a point: the numpy re-check in scaled coordinates, ``lmi_max_eig`` (must be ``<= 0``)
        and ``p_min_eig`` (must be ``> 0``), next to the solver-side violations of
        :attr:`SolveOutcome.residuals` (prefixed ``solver_``); without a point, empty.
        """
        out = {} if self.outcome is None else {f"solver_{k}": v for k, v in self.outcome.residuals.items()}
        if self.lmi_max_eig is not None:
            out["lmi_max_eig"] = self.lmi_max_eig
        if self.p_min_eig is not None:
            out["p_min_eig"] = self.p_min_eig
        return out

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        return {"feasible": self.feasible, "status": self.status, "form": self.form, "sigma": self.sigma,
                "region": None if self.region is None else self.region.to_dict(),
                "L": None if self.L is None else self.L.tolist(), "P": None if self.P is None else self.P.tolist(),
                "multiplier": self.multiplier if np.ndim(self.multiplier) == 0 else np.asarray(self.multiplier).tolist(),
                "lmi_max_eig": self.lmi_max_eig, "p_min_eig": self.p_min_eig,
                "gain_norm": self.gain_norm}


@dataclass(frozen=True)
class DecayResult:
    """Largest decay rate found by bisection and the solution there.

    Attributes
    ----------
    sigma_max : float
        The largest rate whose solve was feasible and passed the numpy re-check.
    capped : bool
        ``sigma_max`` is the cap of the search.
    solution : LMISolution or PolytopicSolution
        The checked solve at ``sigma_max``.
    solves : int
    log : tuple of (sigma, feasible, status)
        Every rate the search tried, in order, with its verdict: each rate accepted passed the
        re-check; a rate the solver could not decide counts as not feasible.
    """

    sigma_max: float
    capped: bool
    solution: LMISolution
    solves: int
    log: tuple[tuple[float, bool, str], ...] = ()

    @property
    def accepted(self) -> list[float]:
        """The rates the search accepted (each passed the numpy re-check)."""
        return [s for s, ok, _ in self.log if ok]

    def to_dict(self) -> dict:
        return {"sigma_max": self.sigma_max, "capped": self.capped, "solves": self.solves,
                "log": [{"sigma": s, "feasible": ok, "status": str(st)} for s, ok, st in self.log]}


def bisect_decay(solve, sigma_cap: float = SIGMA_CAP, rtol: float = BISECTION_RTOL, guess: float | None = None,
                 on_zero_infeasible=None, known: float | None = None) -> DecayResult:
    """Largest decay rate ``sigma`` in ``[0, sigma_cap]`` at which ``solve(sigma)`` is feasible.

    A bracket is found by doubling or halving from ``guess`` (default ``sigma_cap / 8``; a
    neighbouring region's rate is a good guess), then bisected on a geometric scale to ``rtol``.
    In exact arithmetic the LMIs are monotone in ``sigma`` (``sigma P >= 0``); numerically they
    need not be, so nothing is inferred from monotonicity: the reported rate is one whose own
    solve was feasible and passed the numpy re-check, every rate tried is logged, and a rate the
    solver cannot decide counts as not feasible (the rate may be underestimated, never overstated).

    Parameters
    ----------
    solve : callable
        ``solve(sigma)`` returning a solution with ``feasible``, ``status``.
    on_zero_infeasible : callable, optional
        Called with the solution at ``sigma = 0`` when even that is not feasible (it raises the
        error with the certificate); without it the zero-rate solution is returned.
    known : float, optional
        A rate believed feasible (a region grown for it): tried when it falls inside the final
        bracket, so the result is not below it by the bisection's tolerance.
    """
    sigma_cap = as_positive(sigma_cap, "sigma_cap", "a positive upper end of the decay-rate search")
    log: list[tuple[float, bool, str]] = []

    def run(sig: float):
        out = solve(sig)
        log.append((float(sig), bool(out.feasible), str(out.status)))
        return out

    floor = sigma_cap * 1e-6
    g = sigma_cap / 8.0 if guess is None or not (np.isfinite(guess) and guess > floor) else min(float(guess), sigma_cap)
    sol = run(g)
    if sol.feasible:
        lo, best, hi = g, sol, None
        while hi is None:
            if lo >= sigma_cap:
                return DecayResult(sigma_cap, True, best, len(log), tuple(log))
            t = min(2.0 * lo, sigma_cap)
            s = run(t)
            if s.feasible:
                lo, best = t, s
            else:
                hi = t
    else:
        hi, lo, best = g, 0.0, None
        while best is None:
            t = 0.5 * hi
            if t < floor:
                zero = run(0.0)
                if not zero.feasible and on_zero_infeasible is not None:
                    on_zero_infeasible(zero)
                return DecayResult(0.0, False, zero, len(log), tuple(log))
            s = run(t)
            if s.feasible:
                lo, best = t, s
            else:
                hi = t
    while hi - lo > rtol * hi:
        mid = float(np.sqrt(lo * hi))
        s = run(mid)
        if s.feasible:
            lo, best = mid, s
        else:
            hi = mid
    if known is not None and lo < known < hi:
        s = run(float(known))
        if s.feasible:
            lo, best = float(known), s
    return DecayResult(lo, False, best, len(log), tuple(log))


# ---------------------------------------------------------------------------- the compiled LMI
_COMPILED: "weakref.WeakKeyDictionary[ScalarNonlinearSystem, dict]" = weakref.WeakKeyDictionary()


class ObserverLMI:
    """The observer LMI of one system, compiled once and re-solved per region and sigma.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    gain_bound : float, optional
        Require ``||L||_2 <= gain_bound`` (model units); ``None`` for no bound.
    shifted : bool
        Build Theorem 5's transformed LMI instead (functions made monotonic by subtracting their
        lower-bound linear term; see :mod:`.subtraction`).
    scaling : array, optional
        State scaling (default: the box half-widths).
    multipliers : {"single", "per_function"}
        ``"single"``: the paper's one S-procedure multiplier ``eps`` for all functions (eq. 21);
        ``"per_function"``: one multiplier per ``f_i`` and per nonlinear ``h_j`` (each sector
        condition weighed on its own, a weaker requirement; see :mod:`.hierarchy`).

    See Also
    --------
    jacobian_bounds : The bounds a solve takes.
    LMISolution : What a solve returns.
    certify_infeasible : The certificate of an infeasible solve.
    PolytopicLMI : The less conservative vertex condition.

    Examples
    --------
    A constant gain exists for the vehicle on 0-80 deg, where ``V cos`` and ``V sin`` are monotonic;
    none exists on 0-140 deg (paper 004, Theorem 4).

    >>> import math
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import make_region
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import ObserverLMI, jacobian_bounds
    >>> lmi = ObserverLMI(vehicle)
    >>> lmi.form
    '(23)'
    >>> ok = lmi.solve(jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(80))), 0.0)
    >>> ok.feasible, ok.L.shape
    (True, (4, 2))
    >>> bad = lmi.solve(jacobian_bounds(vehicle, make_region(vehicle, "psi", 0.0, math.radians(140))), 0.0)
    >>> bad.feasible, bad.status
    (False, 'infeasible')
    """

    def __init__(self, system: ScalarNonlinearSystem, *, gain_bound: float | None = None, shifted: bool = False,
                 scaling: np.ndarray | None = None, multipliers: str = "single"):
        if multipliers not in MULTIPLIER_MODES:
            raise ModelError("multipliers", f"one of {MULTIPLIER_MODES}", repr(multipliers))
        if shifted and multipliers != "single":
            raise ModelError("multipliers", "'single' for Theorem 5's transformed LMI", repr(multipliers))
        self.multipliers = multipliers
        if not isinstance(system, ScalarNonlinearSystem):
            raise ModelError("system", "a ScalarNonlinearSystem", type(system).__name__)
        gain_bound = as_positive(gain_bound, "gain_bound", "a positive finite bound on ||L||_2", allow_none=True)
        self.system = system
        self.shifted = shifted
        self.gain_bound = None if gain_bound is None else float(gain_bound)
        self.data = lmi_data(system)
        self.d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        if self.d.shape != (system.n,) or not np.all(self.d > 0):
            raise ModelError("scaling", f"{system.n} positive numbers", repr(scaling))
        self.sdata = self.data.scaled(self.d)
        self.form = lmi_form(self.data)
        lin = np.array(system.linear_outputs, dtype=bool)
        self._lin_idx = np.nonzero(lin)[0]
        self._nl_idx = np.nonzero(~lin)[0]
        self._build()
        self._alternative = None

    @classmethod
    def compiled(cls, system: ScalarNonlinearSystem, *, gain_bound: float | None = None, shifted: bool = False,
                 scaling: np.ndarray | None = None, multipliers: str = "single") -> "ObserverLMI":
        """The process-wide compiled LMI for ``system`` (built on first use, then only re-solved).

        Keyed by the system object, ``shifted``, whether there is a gain bound and the scaling;
        the bound itself is a ``Parameter`` and is set on every call.

        Parameters
        ----------
        system : ScalarNonlinearSystem
            The system of eqs. (1)-(3) of paper 004 (the cache key; held weakly).
        gain_bound : float, optional
            Require ``||L||_2 <= gain_bound`` (model units); ``None`` for no bound.
        shifted : bool, default False
            Theorem 5's transformed LMI instead of Theorem 1's.
        scaling : (n,) array, optional
            State scaling (default: the box half-widths).
        multipliers : {"single", "per_function"}, default "single"
            As for :class:`ObserverLMI`.

        Returns
        -------
        ObserverLMI
            The cached problem (the same object on every call with the same key), its gain bound
            set to ``gain_bound``.
        """
        d = box_scaling(system) if scaling is None else np.asarray(scaling, dtype=float)
        key = (bool(shifted), gain_bound is None, d.tobytes(), multipliers)
        per = _COMPILED.setdefault(system, {})
        lmi = per.get(key)
        if lmi is None:
            lmi = per[key] = cls(system, gain_bound=gain_bound, shifted=shifted, scaling=d, multipliers=multipliers)
        elif gain_bound is not None:
            lmi.set_gain_bound(gain_bound)
        return lmi

    # -- construction
    def _build(self) -> None:
        sd, n = self.sdata, self.sdata.n
        self.P = cp.Variable((n, n), symmetric=True, name="P")
        self.Y_lin = cp.Variable((n, sd.p_lin), name="Y_lin") if sd.p_lin else None
        self.Y_nl = cp.Variable((n, sd.p_nl), name="Y_nl") if sd.p_nl else None
        k = sd.r + sd.p_nl
        self.eps = (cp.Variable(k, nonneg=True, name="eps") if self.multipliers == "per_function" and k > 1
                    else cp.Variable(nonneg=True, name="eps"))
        self.par = LMIParameters.create(sd, self.shifted)
        B = lmi_expression(sd, self.P, self.Y_lin, self.Y_nl, self.eps, self.par)
        self.lmi_constraint = B << -LMI_STRICT_MARGIN * np.eye(sd.size)
        cons = [self.lmi_constraint]
        Ys = [Y for Y in (self.Y_lin, self.Y_nl) if Y is not None]
        Yall = cp.hstack(Ys) if len(Ys) > 1 else Ys[0]
        if self.gain_bound is None:
            cons.append(self.P >> np.eye(n))
            self.gamma = None
        else:
            dmax = float(self.d.max())
            cons.append(self.P >> np.diag((self.d / dmax) ** 2))
            self.gamma = cp.Parameter(nonneg=True, name="gamma", value=(self.gain_bound / dmax) ** 2)
            p = Yall.shape[1]
            G = cp.bmat([[self.P, Yall], [Yall.T, self.gamma * np.eye(p)]])
            cons.append(0.5 * (G + G.T) >> 0)
        self.problem = cp.Problem(cp.Minimize(cp.norm(Yall, "fro")), cons)

    def set_gain_bound(self, gain_bound: float) -> None:
        """Change the gain bound without rebuilding (only for an LMI built with a bound).

        Parameters
        ----------
        gain_bound : float
            New bound on ``||L||_2`` (positive, finite, model units).

        Raises
        ------
        ModelError
            If the LMI was built without a gain bound, or the bound is not positive and finite.
        """
        if self.gamma is None:
            raise ModelError("gain_bound", "an ObserverLMI built with gain_bound=...", "one built without")
        gain_bound = as_positive(gain_bound, "gain_bound", "a positive finite bound")
        self.gain_bound = float(gain_bound)
        self.gamma.value = (self.gain_bound / float(self.d.max())) ** 2

    # -- solving
    def bounds(self, region: SchedulingRegion | None = None, **kwargs) -> JacobianBounds:
        """Jacobian bounds of the system over ``region`` (see :func:`.bounds.jacobian_bounds`).

        Parameters
        ----------
        region : SchedulingRegion, optional
            Restrict one coordinate of the operating box (default: the whole box).
        **kwargs
            ``given`` and ``samples`` of :func:`.bounds.jacobian_bounds`.

        Returns
        -------
        JacobianBounds
            Jacobian bounds of the system over ``region`` (see :func:`.bounds.jacobian_bounds`).
        """
        return jacobian_bounds(self.system, region, **kwargs)

    def solve(self, bounds: JacobianBounds, sigma: float = 0.0) -> LMISolution:
        """One feasibility solve at decay rate ``sigma`` with the given bounds.

        The answer is ``feasible`` only when the solver returned a point and numpy confirms it;
        a failed re-check is returned as not feasible (status ``recheck_failed``), never as feasible.

        Parameters
        ----------
        bounds : JacobianBounds
            Bounds ``U, V`` (eq. 5) and ``M, N`` (eq. 4) of the region (:meth:`bounds`).
        sigma : float, default 0.0
            Decay rate ``sigma >= 0`` (``V' <= -sigma V``).

        Returns
        -------
        LMISolution
            The gain ``L`` and ``P`` (in model units) when feasible, else the status and, for an
            infeasible answer, the solver's dual (``farkas``).
        """
        if not (np.isfinite(sigma) and sigma >= 0):
            raise ModelError("sigma", "a non-negative decay rate", repr(sigma))
        s = self.sdata.sector(bounds, self.shifted)
        self.par.assign(s, sigma)
        # An inaccurate point that passes the re-check ends the solver chain (no fallback needed);
        # the point it accepted is the current one, so its re-check is the answer's.
        out, point = solve_checked(self.problem, lambda: self._read_point(bounds, s, sigma, None), solve_problem)
        if point is not None:
            return dataclasses.replace(point, status=out.status, outcome=out)
        region = bounds.region
        if out.status == INFEASIBLE:
            Z = self.lmi_constraint.dual_value
            return LMISolution(False, out.status, self.form, sigma, region, bounds, outcome=out,
                               farkas=None if Z is None else np.asarray(Z, dtype=float))
        if out.status not in POINT_STATUSES or self.P.value is None:
            return LMISolution(False, out.status, self.form, sigma, region, bounds, outcome=out)
        return self._read_point(bounds, s, sigma, out)

    def _read_point(self, bounds: JacobianBounds, s, sigma: float, out) -> LMISolution:
        """The solver's current point, re-checked in numpy (``feasible`` only if it passes)."""
        region = bounds.region
        if self.P.value is None or self.eps.value is None:
            return LMISolution(False, Status.RECHECK_FAILED, self.form, sigma, region, bounds, outcome=out)
        Pb = np.asarray(self.P.value, dtype=float)
        Pb = 0.5 * (Pb + Pb.T)
        n = self.sdata.n
        Yl = np.asarray(self.Y_lin.value, dtype=float) if self.Y_lin is not None else np.zeros((n, 0))
        Yn = np.asarray(self.Y_nl.value, dtype=float) if self.Y_nl is not None else np.zeros((n, 0))
        eps_v = np.asarray(self.eps.value, dtype=float).reshape(-1)
        eps = float(eps_v[0]) if eps_v.size == 1 else eps_v
        if not (np.all(np.isfinite(Pb)) and np.all(np.isfinite(Yl)) and np.all(np.isfinite(Yn)) and np.all(np.isfinite(eps_v))):
            return LMISolution(False, Status.RECHECK_FAILED, self.form, sigma, region, bounds, outcome=out)
        Bm = self.sdata.matrix(Pb, Yl, Yn, eps, s, sigma)
        max_eig = float(np.linalg.eigvalsh(Bm).max())
        p_min = float(np.linalg.eigvalsh(Pb).min())
        ok = max_eig <= 0.0 and p_min > 0.0 and bool(np.all(eps_v > 0.0))
        if p_min <= 0.0:
            return LMISolution(False, Status.RECHECK_FAILED, self.form, sigma, region, bounds, outcome=out,
                               lmi_max_eig=max_eig, p_min_eig=p_min)
        Lbar = np.linalg.solve(Pb, np.hstack([Yl, Yn]))
        L = np.zeros((n, self.system.p))
        L[:, np.concatenate([self._lin_idx, self._nl_idx]).astype(int)] = self.d[:, None] * Lbar
        # The paper's normalisation (eps absorbed into P) exists only for a single multiplier.
        P = Pb / self.d[:, None] / self.d[None, :]
        if eps_v.size == 1:
            P = P / eps if eps > 0 else None
        gain = float(np.linalg.norm(L, 2))
        if self.gain_bound is not None and gain > self.gain_bound * (1 + GAIN_BOUND_RTOL):
            ok = False
        status = (out.status if out is not None else Status.OPTIMAL) if ok else Status.RECHECK_FAILED
        return LMISolution(ok, status, self.form, sigma, region, bounds, L, P, eps, max_eig, p_min, gain, out,
                           P_scaled=Pb, Y_scaled=np.hstack([Yl, Yn]))

    def max_decay(self, bounds: JacobianBounds, sigma_cap: float = SIGMA_CAP, rtol: float = BISECTION_RTOL,
                  guess: float | None = None, known: float | None = None) -> DecayResult:
        """Largest ``sigma`` in ``[0, sigma_cap]`` for which the LMI is feasible (:func:`bisect_decay`).

        Parameters
        ----------
        bounds : JacobianBounds
            Bounds of the region (:meth:`bounds`).
        sigma_cap : float, default SIGMA_CAP
            Upper end of the search (:data:`~hybobs_opt.defaults.SIGMA_CAP`, 100).
        rtol : float, default BISECTION_RTOL
            Relative tolerance of the bisection (:data:`~hybobs_opt.defaults.BISECTION_RTOL`).
        guess : float, optional
            Starting rate of the bracket search (default ``sigma_cap / 8``).
        known : float, optional
            A rate believed feasible, tried when it falls inside the final bracket.

        Returns
        -------
        DecayResult
            The rate found, whether it reached the cap, the solution there and the log of the rates tried.

        Raises
        ------
        InfeasibleError
            Not even ``sigma = 0`` is feasible (no constant gain satisfies this LMI on the region);
            the error carries the certificate.
        SolverError
            The solver could not decide at ``sigma = 0`` and no certificate could be verified.
        """
        from .certificates import certify_infeasible

        return bisect_decay(lambda sig: self.solve(bounds, sig), sigma_cap, rtol, guess,
                            lambda zero: certify_infeasible(self, zero, raise_error=True), known)

    # -- certificates
    def alternative(self):
        """The theorem-of-alternatives SDP for this LMI, built on first use (see certificates).

        Returns
        -------
        object
            The theorem-of-alternatives SDP of this LMI (built on first use).
        """
        if self._alternative is None:
            from .certificates import AlternativeSDP

            self._alternative = AlternativeSDP(self.sdata, self.shifted, per_function=self.eps.size > 1)
        return self._alternative


"""The switched-gain observer of paper 004 (Section 5, Fig. 1) on the common observer contract.

The observer (6), ``x_hat' = A x_hat + F f(E x_hat) + B u + g(y, u) + L_q (y - h(C x_hat))``, uses
the gain ``L_q`` of the region ``q`` it is in.  The hysteresis state machine of Fig. 1: the region
changes only when the *estimated* scheduling variable leaves the current region; since neighbouring
regions overlap by ``2 epsilon``, the switch up happens at ``s_k + epsilon`` and the switch back at
``s_k - epsilon`` (the paper: "The observer gain is switched at ... the estimated yaw angle").

Initial region (Sections 6.2 and 7): from the first ``init_samples`` samples the scheduling
variable is identified by matching the measured output and its slope against the model over a
grid of the coordinate -- the vehicle's heading from the first radar positions ("ad-hoc
computation of the initial direction of the vehicle from the first few samples"), the piston's
position from the pair of sensor readings ("a one-to-one relationship between the position and
the ordered pair").  Until then the observer predicts open loop (flag ``warming_up``).

Between samples the continuous observer is integrated by RK4 (input held, output interpolated
linearly between the two samples), with enough sub-steps for the fastest frozen error dynamics.

The scenarios of ``vehicle_tracking`` and ``magnetic_piston`` are the study
:mod:`hybobs_opt.studies.paper004_nonmonotonic.scenarios`.
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import casadi as ca
import numpy as np
from scipy.linalg import eigh

from .._validate import _short, as_flag, as_int, as_matrix, as_positive
from ..errors import ModelError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..systems.ranges import output_range, state_range
from .error_bound import ErrorBound
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, WARMING_UP, check_reset_keywords, checked_index,
                        checked_state, initial_mode, outside_range)
from ..defaults import STATE_SET_MARGIN, SWITCHED_INIT_GRID
from ..tolerances import RK4_STEP_RADIUS, SWITCHED_INIT_SPREAD_RTOL


class SwitchedGainObserver(Observer):
    """Switched-gain observer (paper 004, Section 5) with the hysteresis state machine of Fig. 1.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    gains : SwitchedDesign or sequence of RegionGain
        One gain per region of one scheduling coordinate (``hybobs_opt.lmi``).  A single region
        gives a constant-gain observer (used outside its region too: ``info["outside"]`` flags it).
    dt : float
        Sampling period of ``step``.
    init_samples : int
        Samples used to select the initial region (``1`` disables the selection: the region of
        the initial estimate is used).
    init_state : {"clip", "identified", "keep"}
        After the selection, move the estimate's scheduling coordinate into the selected region
        (``clip``, the default), onto the identified value, or leave it.
    substeps : int, optional
        RK4 sub-steps per sample (default: from the gains, see :data:`~hybobs_opt.tolerances.RK4_STEP_RADIUS`).
    clip_to_box : bool
        Keep the estimate in the operating box (default).  The Jacobian bounds (4)-(5) behind
        every gain hold only there: a large initial error can otherwise throw the estimate into an
        equivalent state outside the box (the vehicle's ``tan(delta_f)`` repeats every pi).
    periodic : mapping of state name or index to period, optional
        Angle-like coordinates (model units, e.g. ``{"psi": 2 pi}`` for the vehicle's yaw):
        after every RK4 step (and in :meth:`reset`) they are wrapped into
        ``[box_lower_k, box_lower_k + period)`` instead of clipped to the box, so a yaw estimate
        that passes 360 deg reappears near 0 deg instead of sticking at the box's edge.  The
        other coordinates are clipped as before; ``clip_to_box=False`` turns their clipping off
        but not the wrapping.  If the scheduling coordinate is periodic, the state machine
        compares the wrapped value with each region through its image nearest to the region
        (a region ``[-10, 10] deg`` contains ``355 deg``), and the distance to a region is the
        distance along the circle.  ``None`` (default): no coordinate is periodic.
    input_range : (lower, upper), optional
        The inputs' declared range (a scalar-nonlinear model has no input set of its own): a
        sample whose input lies outside it by more than
        :data:`~hybobs_opt.defaults.RANGE_MARGIN` of its width is refused (``fallback``).
        Outputs are always judged against what the model produces on the box.

    See Also
    --------
    hybobs_opt.lmi.synthesize_switched : The design it runs.
    convergence_time : When its error settles.

    Notes
    -----
    Flags: ``warming_up`` while the initial region is selected and until the certified error
    bound of :meth:`error_bound` is below
    :data:`~hybobs_opt.defaults.CONVERGENCE_FRACTION` of the box in every
    coordinate, ``observable`` after; ``fallback`` for a refused sample (open loop: the bound
    grows at the region's open-loop rate, or restarts from the box when the input is unknown).
    Gains without Lyapunov matrices (``P``, ``sigma``) certify nothing: their flag stays
    ``warming_up``.

    Examples
    --------
    >>> import math
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.lmi import regions_from_switch_points, synthesize_switched
    >>> from hybobs_opt.observers import SwitchedGainObserver

    The vehicle of paper 004 with the gains of regions 0-80 deg and 60-140 deg:

    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> design = synthesize_switched(vehicle, regions)
    >>> truth = hy.get_example("vehicle_tracking").simulate(t_final=2.0)
    >>> obs = SwitchedGainObserver(vehicle, design, 0.01)
    >>> trace = obs.run(truth.u, truth.y)
    >>> trace.x_hat.shape, sorted(set(trace.mode.tolist()))
    ((201, 4), [-1, 0])
    >>> bool(np.abs(trace.x_hat[-1, :2] - truth.x[-1, :2]).max() < 1.0)
    True
    """

    name = "switched-gain"

    def __init__(self, system: ScalarNonlinearSystem, gains, dt: float, *, init_samples: int = 5,
                 init_state: str = "clip", substeps: int | None = None, clip_to_box: bool = True,
                 periodic: Mapping[str | int, float] | None = None,
                 input_range: tuple[Sequence[float], Sequence[float]] | None = None):
        if not isinstance(system, ScalarNonlinearSystem):
            raise ModelError("system", "a ScalarNonlinearSystem", type(system).__name__)
        regs, Ls = _region_gains(gains, system.n, system.p)
        dt = as_positive(dt, "dt", "a positive sampling period")
        if not isinstance(init_state, str) or init_state not in ("clip", "identified", "keep"):
            raise ModelError("init_state", "'clip', 'identified' or 'keep'", repr(init_state))
        init_samples = as_int(init_samples, "init_samples", 1)
        substeps = None if substeps is None else as_int(substeps, "substeps", 1)
        clip_to_box = as_flag(clip_to_box, "clip_to_box")
        self.system = system
        self.n, self.m, self.p = system.n, system.m, system.p
        self.state_names = system.state_names
        self.dt = dt
        order = sorted(range(len(regs)), key=lambda i: regs[i].region.lo)
        self.regions = [regs[i].region for i in order]
        self.gains = np.array([Ls[i] for i in order])
        if len({r.coordinate for r in self.regions}) != 1:
            raise ModelError("gains", "regions of one scheduling coordinate", "several coordinates")
        self.k = self.regions[0].coordinate
        self.init_samples = init_samples
        self.init_state = init_state
        self.substeps = substeps if substeps is not None else self._auto_substeps()
        self.clip_to_box = clip_to_box
        self.output_names = system.output_names
        self.output_range = output_range(system)
        self.state_range = state_range(system)
        self.input_names = system.input_names
        self.input_range = _input_range(input_range, self.m)
        self.periodic: dict[int, float] = _periodic_coordinates(periodic, system)
        self._wrap_idx = np.array(sorted(self.periodic), dtype=int)
        self._wrap_lo = np.asarray(system.box_lower, dtype=float)[self._wrap_idx]
        self._wrap_period = np.array([self.periodic[i] for i in self._wrap_idx], dtype=float)
        self._clip_mask = np.ones(self.n, dtype=bool)
        self._clip_mask[self._wrap_idx] = False
        self._setup_error_bound(regs, order)
        self._build_step()
        self.reset()

    def _setup_error_bound(self, regs, order) -> None:
        """The Lyapunov matrices and rates of the design, for the certified error bound behind the flag."""
        Ps, rates = [], []
        for i in order:
            P = getattr(regs[i], "P", None)
            sigma = getattr(regs[i], "sigma_verified", None)
            sigma = getattr(regs[i], "sigma", None) if sigma is None else sigma
            P = None if P is None else np.asarray(P, dtype=float)
            if (P is None or sigma is None or P.shape != (self.n, self.n) or not np.all(np.isfinite(P))
                    or not float(sigma) > 0 or np.linalg.eigvalsh(0.5 * (P + P.T))[0] <= 0):
                Ps = None  # gains without a certificate (a hand-set gain): the flag stays warming_up
                break
            Ps.append(0.5 * (P + P.T))
            rates.append(float(sigma))
        self._lyap = None if Ps is None else (Ps, [np.diag(np.linalg.inv(P)) for P in Ps], rates)
        self._bound = ErrorBound(self.system.box_lower, self.system.box_upper)
        self._open_rates = None if Ps is None else self._open_loop_rates([regs[i] for i in order], Ps)
        self._input_unknown = False
        self._left_box: str | None = None
        self._good_u: np.ndarray | None = None  # the last input whose interval kept the estimate in the box

    def _open_loop_rates(self, regs, Ps) -> list[float] | None:
        """Per region, the largest growth rate of ``||e||_P`` without output correction: the log-norm
        of ``A + F diag(theta) E`` in the ``P``-norm at every vertex of the region's slope box (the
        log-norm is convex in the matrix, so the vertices bound the box).  ``None`` when a known
        term ``g(y, u)`` makes the open-loop error depend on the missing output."""
        from ..lmi.bounds import jacobian_bounds

        sysm = self.system
        if sysm.g is not None:
            return None
        A = np.zeros((self.n, self.n)) if sysm.A is None else np.asarray(sysm.A, dtype=float)
        rates = []
        for reg, P in zip(regs, Ps):
            b = getattr(reg, "bounds", None) or jacobian_bounds(sysm, reg.region)
            thetas = list(itertools.product(*zip(b.U, b.V))) if sysm.r else [()]
            mu = -np.inf
            for th in thetas:
                Av = A + (np.asarray(sysm.F) * np.asarray(th)) @ np.asarray(sysm.E) if sysm.r else A
                S = 0.5 * (Av.T @ P + P @ Av)
                mu = max(mu, float(eigh(S, P, eigvals_only=True)[-1]))
            rates.append(mu)
        return rates

    def error_bound(self) -> np.ndarray | None:
        """Certified bound on ``|x_hat_k - x_k|`` per state, or ``None`` when the gains carry no
        Lyapunov matrices (:mod:`~hybobs_opt.observers.error_bound`).

        From the region selection, the bound is the farthest corner of the box in the region's
        ``P``-norm; each closed-loop sample contracts it by ``exp(-sigma dt / 2)`` (``V' <= -sigma V``,
        paper 004 eqs. 7-10), each region switch multiplies it by ``sqrt(lambda_max(P_i^-1 P_j))``
        and an open-loop sample restarts it from the box.  It holds under the design's hypotheses
        (the plant and the estimate in the box of the region whose gain is used).

        Returns
        -------
        ndarray or None
            Certified bound on ``|x_hat_k - x_k|`` per state, or ``None`` when the gains carry
            no Lyapunov matrices (:mod:`~hybobs_opt.observers.error_bound`).
        """
        if self._lyap is None or self.q is None:
            return None
        return self._bound.per_state(self._lyap[1][self.q])

    def _flag(self) -> str:
        if self._lyap is None or self.q is None:
            return WARMING_UP
        return OBSERVABLE if self._bound.converged(self._lyap[1][self.q]) else WARMING_UP

    def _restart_bound(self) -> None:
        if self._lyap is not None and self.q is not None:
            self._bound.start(self.x, self._lyap[0][self.q])

    def _build_step(self) -> None:
        """One sample of RK4 as a CasADi function, built once (``g(y, u)`` needs the numpy path)."""
        sysm = self.system
        self._step_fn = None
        if sysm.g is not None:
            return
        x = ca.SX.sym("x", self.n)
        u = ca.SX.sym("u", self.m)
        y0 = ca.SX.sym("y0", self.p)
        y1 = ca.SX.sym("y1", self.p)
        L = ca.SX.sym("L", self.n, self.p)
        B = ca.DM(sysm.B)

        def rhs(xx, yy):
            out = sysm.sx_dynamics(xx) + L @ (yy - sysm.sx_output(xx))
            return out + B @ u if self.m else out

        h = self.dt / self.substeps
        xx = x
        for i in range(self.substeps):
            a = i / self.substeps
            ya, ym, yb = (y0 + c * (y1 - y0) for c in (a, a + 0.5 / self.substeps, a + 1.0 / self.substeps))
            k1 = rhs(xx, ya)
            k2 = rhs(xx + 0.5 * h * k1, ym)
            k3 = rhs(xx + 0.5 * h * k2, ym)
            k4 = rhs(xx + h * k3, yb)
            xx = xx + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
        self._step_fn = ca.Function("switched_gain_rk4", [x, u, y0, y1, L], [xx])
        self._zero_L = np.zeros((self.n, self.p))

    # ------------------------------------------------------------------ set-up
    def _auto_substeps(self) -> int:
        sysm = self.system
        centre = 0.5 * (sysm.box_lower + sysm.box_upper)
        rho = 0.0
        for reg, L in zip(self.regions, self.gains):
            for s in np.linspace(reg.lo, reg.hi, 5):
                x = centre.copy()
                x[self.k] = s
                J = sysm.dynamics_jacobian(x) - L @ sysm.output_jacobian(x)
                rho = max(rho, float(np.max(np.abs(np.linalg.eigvals(J)))))
        return max(1, int(math.ceil(self.dt * rho / RK4_STEP_RADIUS)))

    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, region: int | None = None,
              **kwargs: Any) -> None:
        """Restart from ``x0`` (default: the centre of the box); a region index ``q0`` skips the
        selection (``region``: its deprecated name).

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial estimate (default: the centre of the box).
        q0 : int, optional
            Index of the initial region; ``None`` selects it from the first samples (or from ``x0``
            with a single region or ``init_samples <= 1``).
        region : int, optional
            Deprecated name of ``q0`` (a ``FutureWarning``; removed in 0.2.0).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        field = "region" if region is not None else "q0"  # errors name the keyword the caller used
        region = initial_mode(q0, region, "region")
        sysm = self.system
        x = 0.5 * (sysm.box_lower + sysm.box_upper) if x0 is None else checked_state(x0, self.n)
        region = checked_index(region, len(self.regions), field, "region index")
        self.x = self._wrap(x.copy())
        self.q: int | None = None if region is None else int(region)
        if self.q is None and (self.init_samples <= 1 or len(self.regions) == 1):
            self.q = self._region_of(self.x[self.k], 0)[0]
        self._restart_bound()
        self._buf_u: list[np.ndarray] = []
        self._buf_y: list[np.ndarray] = []
        self._prev_u: np.ndarray | None = None
        self._good_u = None
        self._prev_y: np.ndarray | None = None
        self.selected: dict[str, Any] = {}

    # ------------------------------------------------------------------ the state machine (Fig. 1)
    def _image(self, s: float, region) -> float:
        """``s`` itself, or for a periodic scheduling coordinate its image nearest to ``region``'s centre."""
        period = self.periodic.get(self.k)
        if period is None:
            return s
        centre = 0.5 * (region.lo + region.hi)
        return s - period * round((s - centre) / period)

    def _region_of(self, s: float, current: int) -> tuple[int, bool]:
        """Region to use for scheduling value ``s`` from region ``current``: ``(index, outside)``."""
        if self.regions[current].contains(self._image(s, self.regions[current])):
            return current, False
        inside = [i for i, r in enumerate(self.regions) if r.contains(self._image(s, r))]
        if inside:
            return min(inside, key=lambda i: abs(i - current)), False
        dist = []
        for r in self.regions:
            v = self._image(s, r)
            dist.append(min(abs(v - r.lo), abs(v - r.hi)))
        return int(np.argmin(dist)), True

    def select_initial_region(self, Y: np.ndarray, U: np.ndarray | None = None) -> tuple[int, float]:
        """Region and scheduling value identified from the first samples ``Y`` (paper 004, Secs. 6.2, 7).

        Over a grid of the coordinate (other states at the current estimate) the model's output
        and output slope are compared with the samples' first value and fitted slope; each output's
        residual is normalised by its spread over the grid, so an output that does not depend on
        the coordinate (the vehicle's positions) is ignored and one that does (its heading through
        the slope, the piston's position through the value) decides.

        Parameters
        ----------
        Y : (k, p) array_like
            The first output samples, one every ``dt``.
        U : (k, m) array_like, optional
            The matching inputs (the first one is used for the model's slope; ``None`` means zeros).

        Returns
        -------
        region : int
            Index of the region selected.
        s : float
            The scheduling value identified.
        """
        sysm = self.system
        Y = np.asarray(Y, dtype=float).reshape(-1, self.p)
        lo = min(r.lo for r in self.regions)
        hi = max(r.hi for r in self.regions)
        grid = np.linspace(lo, hi, SWITCHED_INIT_GRID)
        X = np.tile(self.x, (grid.size, 1))
        X[:, self.k] = grid
        u0 = np.zeros(self.m) if U is None or len(U) == 0 else np.asarray(U, dtype=float).reshape(-1, self.m)[0]
        y_model = sysm.output(X)
        cost = np.zeros(grid.size)
        if Y.shape[0] >= 2:
            t = self.dt * np.arange(Y.shape[0])
            coef = np.polyfit(t, Y, 1)
            slope, y0 = coef[0], coef[1]
            ydot_model = np.einsum("kij,kj->ki", sysm.output_jacobian(X), sysm.rhs(X, u0))
            cost += _normalised_residual(ydot_model, slope)
        else:
            y0 = Y[0]
        cost += _normalised_residual(y_model, y0)
        j = int(np.argmin(cost))
        s = float(grid[j])
        cands = [i for i, r in enumerate(self.regions) if r.contains(s)] or [self._region_of(s, 0)[0]]
        q = min(cands, key=lambda i: abs(0.5 * (self.regions[i].lo + self.regions[i].hi) - s))
        return q, s

    # ------------------------------------------------------------------ integration
    def _rhs(self, x: np.ndarray, u: np.ndarray, y: np.ndarray | None, L: np.ndarray | None) -> np.ndarray:
        dx = self.system.rhs(x, u)
        if L is not None and y is not None:
            dx = dx + L @ (y - self.system.output(x))
        return dx

    def _integrate(self, x, u, y0, y1, L) -> np.ndarray:
        if self._step_fn is not None:
            if L is None or y0 is None:
                L, y0 = self._zero_L, np.zeros(self.p)
                y1 = y0
            out = np.asarray(self._step_fn(x, u, y0, y1, L), dtype=float).reshape(-1)
            return self._clip(out)
        return self._clip(self._integrate_numpy(x, u, y0, y1, L))

    def _clip(self, x: np.ndarray) -> np.ndarray:
        """Wrap the periodic coordinates, clip the others to the box (if ``clip_to_box``).

        Records in ``_left_box`` why the integrated estimate left the box by more than
        :data:`~hybobs_opt.defaults.STATE_SET_MARGIN` of its width (``None`` if it did not): the
        error bound's hypothesis (estimate and plant in the box) failed on that interval.
        """
        x = self._wrap(x)
        self._left_box = outside_range(x, (self.system.box_lower, self.system.box_upper), STATE_SET_MARGIN,
                                       self.system.state_names, "x")
        if not self.clip_to_box:
            return x
        if self._wrap_idx.size == 0:
            return np.minimum(np.maximum(x, self.system.box_lower), self.system.box_upper)
        clipped = np.minimum(np.maximum(x, self.system.box_lower), self.system.box_upper)
        return np.where(self._clip_mask, clipped, x)

    def _wrap(self, x: np.ndarray) -> np.ndarray:
        """The periodic coordinates of ``x`` moved into ``[box_lower_k, box_lower_k + period)``."""
        if self._wrap_idx.size == 0:
            return x
        x = np.array(x, dtype=float)
        v = x[self._wrap_idx]
        ok = np.isfinite(v)
        w = self._wrap_lo + np.mod(v - self._wrap_lo, self._wrap_period)
        # np.mod of a tiny negative offset rounds to the period itself: that point is the lower end.
        w = np.where(w >= self._wrap_lo + self._wrap_period, self._wrap_lo, w)
        x[self._wrap_idx] = np.where(ok, w, v)
        return x

    def difference(self, x_hat: np.ndarray, x_true: np.ndarray) -> np.ndarray:
        """``x_hat - x_true`` with every periodic coordinate's difference wrapped into
        ``[-period/2, period/2)`` (the error along the circle); rows are samples.

        Parameters
        ----------
        x_hat : (N, n) or (n,) array_like
            Estimates.
        x_true : array_like
            True states, same shape.

        Returns
        -------
        ndarray
            ``x_hat - x_true`` with every periodic coordinate's difference wrapped into
            ``[-period/2, period/2)`` (the error along the circle); rows are samples.
        """
        err = np.asarray(x_hat, dtype=float) - np.asarray(x_true, dtype=float)
        if self._wrap_idx.size == 0:
            return err
        err = np.array(err, dtype=float)
        half = 0.5 * self._wrap_period
        err[..., self._wrap_idx] = np.mod(err[..., self._wrap_idx] + half, self._wrap_period) - half
        return err

    def _integrate_numpy(self, x, u, y0, y1, L) -> np.ndarray:
        h = self.dt / self.substeps
        for i in range(self.substeps):
            a = i / self.substeps
            ya = None if y0 is None else y0 + a * (y1 - y0)
            ym = None if y0 is None else y0 + (a + 0.5 / self.substeps) * (y1 - y0)
            yb = None if y0 is None else y0 + (a + 1.0 / self.substeps) * (y1 - y0)
            k1 = self._rhs(x, u, ya, L)
            k2 = self._rhs(x + 0.5 * h * k1, u, ym, L)
            k3 = self._rhs(x + 0.5 * h * k2, u, ym, L)
            k4 = self._rhs(x + h * k3, u, yb, L)
            x = x + (h / 6.0) * (k1 + 2 * k2 + 2 * k3 + k4)
        return x

    # ------------------------------------------------------------------ contract
    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        if self.q is None:
            if self._prev_u is not None:
                self.x = self._integrate(self.x, self._prev_u, None, None, None)
            self._buf_u.append(u)
            self._buf_y.append(y)
            self._prev_u, self._prev_y = u, y
            if len(self._buf_y) >= self.init_samples:
                q, s = self.select_initial_region(np.array(self._buf_y), np.array(self._buf_u))
                self.q = q
                reg = self.regions[q]
                if self.init_state == "identified":
                    self.x[self.k] = s
                elif self.init_state == "clip":
                    v = self._image(float(self.x[self.k]), reg)
                    self.x[self.k] = min(max(v, reg.lo), reg.hi)
                    self.x = self._wrap(self.x)
                self.selected = {"region": q, "s": s, "samples": len(self._buf_y)}
                self._restart_bound()
            return Estimate(self.x.copy(), -1 if self.q is None else self.q, WARMING_UP, 0.0,
                            {"region": self.q, "selected": dict(self.selected)})
        refused = ""
        if self._prev_u is not None:
            y0 = self._prev_y if self._prev_y is not None else y
            x_before = self.x
            self.x = self._integrate(x_before, self._prev_u, y0, y, self.gains[self.q])
            left = self._left_box
            if left is not None and self._good_u is not None and not np.array_equal(self._prev_u, self._good_u):
                # Did the input throw the estimate out of the box?  With the last input that kept it
                # inside, the interval stays in the box: that input sample is refused, not integrated.
                x_alt = self._integrate(x_before, self._good_u, y0, y, self.gains[self.q])
                if self._left_box is None:
                    self.x = x_alt
                    refused = (f"input u = {self._prev_u.tolist()} refused: it drives the estimate out of the model's "
                               f"state set ({left}); the last plausible input {self._good_u.tolist()} is used")
            if left is None:
                self._good_u = self._prev_u
            if self._lyap is not None:
                self._bound.contract(-0.5 * self._lyap[2][self.q] * self.dt)
            if self._input_unknown:  # the last interval's input was a refused sample's: no bound holds
                self._input_unknown = False
                self._restart_bound()
            elif left is not None:  # the estimate left the box (or an absurd input was refused): no bound holds
                self._restart_bound()
        if not np.all(np.isfinite(self.x)):
            self.x = np.nan_to_num(self.x, nan=0.0, posinf=0.0, neginf=0.0)
            self._prev_u, self._prev_y = u, y
            self._restart_bound()
            return Estimate(self.x.copy(), self.q, FALLBACK, 0.0, {"reason": "estimate became non-finite"})
        q_old = self.q
        self.q, outside = self._region_of(float(self.x[self.k]), self.q)
        if self._lyap is not None and self.q != q_old:
            self._bound.change_metric(self._lyap[0][q_old], self._lyap[0][self.q])
        self._prev_u, self._prev_y = u, y
        bound = self.error_bound()
        info = {"region": self.q, "switched": self.q != q_old, "outside": outside,
                "error_bound": None if bound is None else bound.tolist()}
        if refused:
            return Estimate(self.x.copy(), self.q, FALLBACK, 0.0, dict(info, reason=refused))
        return Estimate(self.x.copy(), self.q, self._flag(), 0.0, info)

    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        uu = u if u is not None else (self._prev_u if self._prev_u is not None else np.zeros(self.m))
        if self._prev_u is not None:
            self.x = self._integrate(self.x, self._prev_u, None, None, None)
        self._prev_u, self._prev_y = uu, None
        if self._open_rates is not None:  # the error grows at most at the open-loop rate
            self._bound.contract(self._open_rates[self.q] * self.dt if self.q is not None else 0.0)
        else:
            self._restart_bound()
        self._input_unknown = u is None  # the next interval runs on the previous input
        return Estimate(self.x.copy(), -1 if self.q is None else self.q, FALLBACK, 0.0, {"reason": reason})


def _region_gains(gains, n: int, p: int) -> tuple[list, list[np.ndarray]]:
    """The regions' gains of a :class:`SwitchedGainObserver`: ``(gain objects, their L as (n, p) arrays)``.

    ``gains`` is a :class:`~hybobs_opt.lmi.SwitchedDesign` or a non-empty sequence of gains, each a
    :class:`~hybobs_opt.lmi.RegionGain` or an object like it (the gains read from a file): a
    ``region`` that is a :class:`~hybobs_opt.lmi.schedule.SchedulingRegion` and a real finite
    ``(n, p)`` gain ``L`` (complex entries are refused, not cast).
    """
    from ..lmi.schedule import SchedulingRegion
    from ..lmi.switched import SwitchedDesign

    what = "a SwitchedDesign or a sequence of RegionGain"
    if isinstance(gains, SwitchedDesign):
        gains = gains.regions
    elif isinstance(getattr(gains, "region", None), SchedulingRegion):
        raise ModelError("gains", what, f"a single {type(gains).__name__} (wrap it in a list)")
    elif isinstance(gains, (str, bytes, Mapping)) or not isinstance(gains, Iterable):
        raise ModelError("gains", what, f"{_short(gains)} of type {type(gains).__name__}")
    regs = list(gains)
    if not regs:
        raise ModelError("gains", "at least one region with its gain", "none")
    Ls = []
    for i, g in enumerate(regs):
        if not isinstance(getattr(g, "region", None), SchedulingRegion):
            raise ModelError(f"gains[{i}]", "a RegionGain (its .region a SchedulingRegion, its .L the gain)",
                             f"{_short(g)} of type {type(g).__name__}")
        Ls.append(as_matrix(getattr(g, "L", None), f"gains[{i}].L", (n, p)))
    return regs, Ls


def _input_range(value, m: int) -> tuple[np.ndarray, np.ndarray] | None:
    """The ``input_range`` keyword: ``(lo, hi)`` over the ``m`` inputs, validated (``None``: not judged)."""
    if value is None:
        return None
    try:
        lo, hi = (np.asarray(v) for v in value)
    except (TypeError, ValueError):
        raise ModelError("input_range", f"(lower, upper) arrays of the {m} inputs", repr(value)) from None
    if lo.dtype.kind not in "biuf" or hi.dtype.kind not in "biuf":
        raise ModelError("input_range", "real (lower, upper) bounds", f"{lo.dtype} and {hi.dtype}")
    lo, hi = lo.astype(float).reshape(-1), hi.astype(float).reshape(-1)
    if lo.shape != (m,) or hi.shape != (m,) or np.any(np.isnan(lo)) or np.any(np.isnan(hi)) or np.any(lo > hi):
        raise ModelError("input_range", f"(lower, upper) of length {m} with lower <= upper", f"{lo.tolist()}, {hi.tolist()}")
    return lo, hi


def _periodic_coordinates(periodic: Mapping[str | int, float] | None,
                          system: ScalarNonlinearSystem) -> dict[int, float]:
    """``{state index: period}`` from the ``periodic`` keyword (names or indices), validated."""
    if periodic is None:
        return {}
    if not isinstance(periodic, Mapping):
        raise ModelError("periodic", "a mapping of state name or index to its period",
                         type(periodic).__name__)
    out: dict[int, float] = {}
    for key, period in periodic.items():
        if isinstance(key, str):
            if key not in system.state_names:
                raise ModelError("periodic", f"state names among {system.state_names}", repr(key))
            k = system.state_names.index(key)
        elif isinstance(key, (int, np.integer)) and not isinstance(key, bool):
            k = int(key)
            if not 0 <= k < system.n:
                raise ModelError("periodic", f"state indices in [0, {system.n})", repr(key))
        else:
            raise ModelError("periodic", "state names (str) or indices (int) as keys", repr(key))
        try:
            value = float(period)
        except (TypeError, ValueError):
            raise ModelError("periodic", f"a positive finite period for {system.state_names[k]!r}",
                             repr(period)) from None
        if not (math.isfinite(value) and value > 0):
            raise ModelError("periodic", f"a positive finite period for {system.state_names[k]!r}", repr(period))
        if k in out:
            raise ModelError("periodic", f"one period per state ({system.state_names[k]!r} given twice)", repr(key))
        out[k] = value
    return out


def _normalised_residual(model: np.ndarray, measured: np.ndarray) -> np.ndarray:
    """Sum over outputs of squared residuals, each divided by ``var(model over the grid) + measured^2``.

    The measured value in the denominator keeps an output from deciding when the model cannot
    reproduce its size anywhere on the grid: the piston's output slope at an estimate that is
    still at rest (velocity ~1e-6 mm/s) varies by 1e-12 of the measured slope over the grid, and
    dividing by that variance alone let rounding pick the far end of the stroke.  An output that
    does not depend on the coordinate (spread below SWITCHED_INIT_SPREAD_RTOL of its size) is ignored.
    """
    out = np.zeros(model.shape[0])
    for j in range(model.shape[1]):
        spread = float(np.var(model[:, j]))
        if spread > SWITCHED_INIT_SPREAD_RTOL * (1.0 + float(np.mean(model[:, j] ** 2))):
            out += (model[:, j] - measured[j]) ** 2 / (spread + float(measured[j]) ** 2)
    return out


def convergence_time(t: np.ndarray, err: np.ndarray, tol: np.ndarray) -> float | None:
    """First time from which ``|err[:, i]| <= tol[i]`` for every later sample (``None`` if never).

    Parameters
    ----------
    t : (N,) ndarray
        Sample times.
    err : (N, n) ndarray
        Errors, one row per sample.
    tol : (n,) ndarray
        Tolerance per column.

    Returns
    -------
    float or None
        The first time from which every state's error stays within its tolerance; ``None`` when
        that never happens.

    See Also
    --------
    SwitchedGainObserver : Whose runs it measures.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.observers import convergence_time
    >>> t = np.arange(5) * 0.5
    >>> err = np.array([[1.0], [0.4], [0.05], [0.2], [0.01]])
    >>> convergence_time(t, err, np.array([0.25]))
    1.0
    >>> convergence_time(t, err, np.array([0.001])) is None
    True
    """
    bad = np.any(np.abs(err) > tol[None, :], axis=1)
    if not bad.any():
        return float(t[0])
    last = int(np.nonzero(bad)[0][-1])
    return None if last == t.size - 1 else float(t[last + 1])

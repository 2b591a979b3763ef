"""Simulation check of a switched-gain noise bound (:mod:`.switched_noise`): plant and switched observer, bounded noise.

The claim of a :class:`~.switched_noise.SwitchedNoiseBound` is an ultimate bound on each error
component of the switched-gain observer of paper 004 (Section 5) for *every* output noise with
``|v_j| <= vbar_j``, provided consecutive gain switches are at least ``dwell`` apart and the plant
state and the estimate stay in the region whose gain is used.  This module measures how close
bounded noises come to it, to show that the bound holds and how far it is from vacuous:

* random noise, piecewise constant and uniform in the box ``[-vbar, vbar]``
  (:func:`.noise_sim.random_noise`);
* for each region and each state ``k``, the sinusoids at the frequency and phases that excite
  ``e_k`` most on a frozen vertex system of that region's gain (:func:`.noise_sim.worst_sinusoids`
  of the region's invariant-ellipsoid design), at a few multiples of that frequency;
* optionally, for each region and state, the sign noise that is the worst bounded noise of the
  same frozen vertex system at regularly spaced instants (:func:`.noise_sim.sign_noise`).

The observer's gain follows the hysteresis state machine of paper 004 Fig. 1 on the *estimated*
scheduling coordinate: it keeps region ``q`` while the estimate's coordinate is inside ``q`` and,
when it leaves, switches to the neighbouring region (a pair of the design) that contains it; the
initial region is the one that contains the initial estimate (the lowest index in an overlap).
Plant and observer are integrated together by the classical fixed-step Runge-Kutta method; the
state machine is evaluated at the start of every step and the gain is held over the step, the
piecewise-constant noises switch on the step grid.

Each run records its switch times, the smallest interval between two switches (a run with an
interval below the dwell time assumed is no test of the bound), and whether the plant or the
estimate took an argument of a nonlinear function out of the interval of the active region's
Jacobian box, or the plant left the operating box, at a step's start (no test either).  Between
two samples the estimate can pass the edge of its region by one step's motion before the switch
at the next sample: that excursion is reported (``step_overshoot``), not counted.

From a zero initial error the bound holds at all times (``U = 0`` at the start, and ``U <= u*``
is kept across switches at least ``dwell`` apart, see :mod:`.switched_noise`), so every sample is
compared with it.  From an initial error ``e0`` every sample is compared with the certified
envelope ``|e_k(t)| <= m_k sqrt(u* + (U_0 - 1)^+ mu' e^{-r t})``, with ``m_k = max_i sqrt(c_i
(P_i^-1)_kk)``, ``U_0 = e0' P_q e0 / c_q`` in the initial region ``q``, ``mu' = max(mu, 1)`` and
``r = alpha - ln(mu') / dwell``: the excess ``D = (U - 1)^+`` decays at rate ``alpha`` between
switches and obeys ``D+ <= mu D- + mu - 1`` at a switch, an affine comparison system whose part
from ``D = 0`` stays below ``u* - 1`` and whose part from ``D_0`` is at most ``D_0 mu^{N(t)}
e^{-alpha t}`` with ``N(t) <= 1 + t / dwell`` switches by ``t`` (the dwell-time argument of
D. Liberzon, *Switching in Systems and Control*, Birkhauser 2003, Sec. 3.2.1).

The certificate is homogeneous in the noise (:meth:`.switched_noise.SwitchedNoiseBound.scaled`): the bound for ``s vbar``
is ``s`` times the bound for ``vbar``, with the same dwell time needed.  The region hypothesis is
not: a noise large enough to push the estimate out of its region (or to make the estimated
scheduling coordinate cross the hysteresis band faster than the dwell time allows) makes every
run no test, so a design is checked at a noise level at which its estimates stay in the regions.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from .noise_sim import Drive, Noise, WorstSinusoid, random_noise, sign_noise, sinusoid_noise, worst_sinusoids
from .switched_noise import SwitchedNoiseBound

__all__ = ["SwitchedNoiseRun", "SwitchedNoiseSimulationCheck", "SwitchedTrajectories", "check_switched_noise_bound",
           "simulate_switched_noisy_observer"]

#: The last Runge-Kutta stage reads the noise this fraction of a step before the step's end (as in
#: :func:`.noise_sim.simulate_noisy_observer`): a piecewise-constant noise that switches on the step
#: grid keeps its value over the whole step.
_STEP_END = 1e-6


# ---------------------------------------------------------------------------- regions
class _Regions:
    """The regions of a switched design: gains, scheduling intervals, argument rows and intervals."""

    def __init__(self, snb: SwitchedNoiseBound):
        design = snb.design
        system = design.system
        self.system = system
        self.k = int(design.coordinate)
        self.lo = np.array([r.region.lo for r in design.regions])
        self.hi = np.array([r.region.hi for r in design.regions])
        self.L = np.array([np.asarray(r.L, dtype=float) for r in design.regions])  # (Q, n, p)
        self.neighbours = [sorted({j for i, j in design.pairs if i == q}) for q in range(len(design.regions))]
        rows, los, his = [], [], []
        for r in design.regions:
            b = r.bounds
            rr = [(system.E[i], bb.interval) for i, bb in enumerate(b.f)]
            rr += [(system.C[j], bb.interval) for j, bb in enumerate(b.h) if bb.method != "linear"]
            rows.append(np.array([row for row, _ in rr]).reshape(len(rr), system.n))
            los.append(np.array([float(iv[0]) for _, iv in rr]))
            his.append(np.array([float(iv[1]) for _, iv in rr]))
        self.rows, self.arg_lo, self.arg_hi = rows, los, his

    def inside(self, q: int, s: np.ndarray) -> np.ndarray:
        return (self.lo[q] <= s) & (s <= self.hi[q])

    def initial(self, s: np.ndarray) -> np.ndarray:
        """Per run: the lowest-index region containing ``s`` (``-1`` when none does)."""
        out = np.full(s.shape, -1, dtype=int)
        for q in reversed(range(self.lo.size)):
            out[self.inside(q, s)] = q
        return out

    def next_region(self, q: np.ndarray, s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The hysteresis of Fig. 1: ``(new regions, runs whose estimate is in no neighbour of q)``.

        A run whose estimate left its region for no neighbouring region switches to the nearest
        region (index) containing the estimate, or keeps its gain when none does; it is flagged.
        """
        new = q.copy()
        lost = np.zeros(q.shape, dtype=bool)
        for r in np.nonzero(~((self.lo[q] <= s) & (s <= self.hi[q])))[0]:
            cands = [j for j in self.neighbours[q[r]] if self.lo[j] <= s[r] <= self.hi[j]]
            if not cands:
                lost[r] = True
                cands = [j for j in range(self.lo.size) if self.lo[j] <= s[r] <= self.hi[j]]
            if cands:
                new[r] = min(cands, key=lambda j: abs(j - q[r]))
        return new, lost

    def excursion(self, q: np.ndarray, X: np.ndarray) -> np.ndarray:
        """Per run: how far an argument ``E_i x`` / ``C_j x`` of ``X`` lies outside region ``q``'s intervals."""
        out = np.zeros(X.shape[0])
        for qq in np.unique(q):
            sel = q == qq
            Z = X[sel] @ self.rows[qq].T  # (r, args)
            over = np.maximum(self.arg_lo[qq][None, :] - Z, Z - self.arg_hi[qq][None, :])
            out[sel] = np.maximum(over.max(axis=1, initial=0.0), 0.0)
        return out


# ---------------------------------------------------------------------------- simulation
@dataclass(frozen=True)
class SwitchedNoiseRun:
    """One simulated run of the switched observer.

    Attributes
    ----------
    family : str
        ``"random"`` or ``"sinusoid"`` (or the caller's label).
    switch_times : tuple of float
        Times at which the gain switched (step starts).
    regions : tuple of int
        The initial region and the region after each switch.
    min_interval : float or None
        Smallest time between two consecutive switches (``None`` with fewer than two switches).
    dwell_violation : bool
        ``min_interval`` is below the dwell time assumed (no test of the bound).
    left_region : bool
        The plant or the estimate left the active region at a step's start, or the plant left the
        operating box, or the estimate left the region for no neighbouring one (no test).
    plant_left_box : bool
        The plant state left the operating box.
    step_overshoot : float
        Largest distance (model units of the arguments) by which the plant or the estimate lay
        outside the previous region at a switch: the motion within the step before the sampled switch.
    max_error : (n,) array
        Largest ``|e_k|`` from the transient time on.
    """

    family: str
    switch_times: tuple
    regions: tuple
    min_interval: float | None
    dwell_violation: bool
    left_region: bool
    plant_left_box: bool
    step_overshoot: float
    max_error: np.ndarray = field(repr=False)

    @property
    def valid(self) -> bool:
        """The run tests the bound: no dwell violation, plant and estimate in the active region."""
        return not (self.dwell_violation or self.left_region)

    def to_dict(self) -> dict:
        return {"family": self.family, "switch_times": list(self.switch_times), "regions": list(self.regions),
                "min_interval": self.min_interval, "dwell_violation": self.dwell_violation,
                "left_region": self.left_region, "plant_left_box": self.plant_left_box,
                "step_overshoot": self.step_overshoot, "max_error": self.max_error.tolist(), "valid": self.valid}


@dataclass(frozen=True)
class SwitchedTrajectories:
    """Runs of :func:`simulate_switched_noisy_observer`.

    Attributes
    ----------
    t : (N + 1,) array
    x, x_hat : (N + 1, R, n) arrays
        Plant states and estimates.
    q : (N + 1, R) int array
        The region whose gain is used from each sample on (decided from the estimate at that sample).
    left : (R,) bool array
        An argument of the plant or the estimate outside the active region's intervals at a
        sample, the plant outside the operating box, or the estimate in no neighbouring region.
    out_box, lost : (R,) bool arrays
        The plant outside the operating box; the estimate left its region for no neighbour.
    overshoot : (R,) array
        Largest excursion outside the previous region at a sampled switch.
    """

    t: np.ndarray
    x: np.ndarray = field(repr=False)
    x_hat: np.ndarray = field(repr=False)
    q: np.ndarray = field(repr=False)
    left: np.ndarray
    out_box: np.ndarray
    lost: np.ndarray
    overshoot: np.ndarray


def simulate_switched_noisy_observer(snb: SwitchedNoiseBound, x0: np.ndarray, x_hat0: np.ndarray, drive: Drive,
                                     noise: Noise, t_final: float, dt: float) -> SwitchedTrajectories:
    """Plant ``x' = A x + F f(E x) + B u`` and observer ``x^' = ... + L_q (y + v - h(C x^))``, hysteresis of Fig. 1.

    Fixed-step classical Runge-Kutta for the joint state of ``R`` runs at once (like
    :func:`.noise_sim.simulate_noisy_observer`), each run with its own gain: at every step's
    start the region ``q`` of each run is updated from its estimate's scheduling coordinate
    (module docstring) and its gain ``L_q`` is held over the step.  The input ``u = drive(t, x)``
    (a feedback of the true state) and the noise are evaluated at every stage, the noise of the
    last stage just before the step's end.

    Parameters
    ----------
    snb : SwitchedNoiseBound
        Its design's regions and gains are used (the system has no ``g(y, u)``).
    x0, x_hat0 : (R, n) arrays
        Initial plant states and estimates; every estimate in some region.
    drive : callable
        ``drive(t, X) -> (R, m)`` inputs for the ``(R, n)`` plant states.
    noise : callable
        ``noise(t) -> (R, p)``, output order.
    t_final, dt : float
        Horizon and step.

    Returns
    -------
    SwitchedTrajectories
    """
    regs = _Regions(snb)
    system = regs.system
    if system.g is not None:
        raise ModelError("system.g", "no g(y, u) term", "a callable")
    X = np.array(x0, dtype=float, ndmin=2)
    Xh = np.array(x_hat0, dtype=float, ndmin=2)
    if X.shape != Xh.shape or X.shape[1] != system.n:
        raise ModelError("x0, x_hat0", f"two (R, {system.n}) arrays of the same shape", f"{X.shape}, {Xh.shape}")
    R = X.shape[0]
    q = regs.initial(Xh[:, regs.k])
    if np.any(q < 0):
        raise ModelError("x_hat0", "initial estimates inside a region of the design",
                         f"{system.state_names[regs.k]} = {Xh[q < 0, regs.k].tolist()}")
    steps = int(math.ceil(t_final / dt - 1e-9))
    t = np.arange(steps + 1) * dt
    xs = np.empty((steps + 1,) + X.shape)
    xhs = np.empty_like(xs)
    qs = np.empty((steps + 1, R), dtype=int)
    lo, hi = system.box_lower, system.box_upper
    left = np.zeros(R, dtype=bool)
    out_box = np.zeros(R, dtype=bool)
    lost = np.zeros(R, dtype=bool)
    overshoot = np.zeros(R)

    def check(i: int, X, Xh, q):
        nonlocal left, out_box
        xs[i], xhs[i], qs[i] = X, Xh, q
        left |= (regs.excursion(q, X) > 0) | (regs.excursion(q, Xh) > 0)
        out_box |= np.any((X < lo - 1e-12) | (X > hi + 1e-12), axis=1)

    def f(tt, X, Xh, v, Lq):
        U = np.asarray(drive(tt, X), dtype=float).reshape(R, system.m)
        Z = np.vstack([X, Xh])  # plant and observer in one evaluation of the model
        Y = system.output(Z)
        D = system.rhs(Z, np.vstack([U, U]))
        return D[:R], D[R:] + np.einsum("rnp,rp->rn", Lq, Y[:R] + v - Y[R:])

    check(0, X, Xh, q)
    end = dt * (1.0 - _STEP_END)
    for i in range(steps):
        ti = t[i]
        Lq = regs.L[q]
        vm = noise(ti + dt / 2)
        k1 = f(ti, X, Xh, noise(ti), Lq)
        k2 = f(ti + dt / 2, X + dt / 2 * k1[0], Xh + dt / 2 * k1[1], vm, Lq)
        k3 = f(ti + dt / 2, X + dt / 2 * k2[0], Xh + dt / 2 * k2[1], vm, Lq)
        k4 = f(ti + dt, X + dt * k3[0], Xh + dt * k3[1], noise(ti + end), Lq)
        X = X + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        Xh = Xh + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        new, gone = regs.next_region(q, Xh[:, regs.k])
        moved = new != q
        if np.any(moved):
            over = np.maximum(regs.excursion(q, X), regs.excursion(q, Xh))
            overshoot[moved] = np.maximum(overshoot[moved], over[moved])
        lost |= gone
        q = new
        check(i + 1, X, Xh, q)
    return SwitchedTrajectories(t, xs, xhs, qs, left | out_box | lost, out_box, lost, overshoot)


# ---------------------------------------------------------------------------- the check
@dataclass(frozen=True)
class SwitchedNoiseSimulationCheck:
    """What bounded noises did to the error of a switched-gain observer with a certified noise bound.

    Attributes
    ----------
    bound : (n,) array
        The certified per-state ultimate bound (``SwitchedNoiseBound.bound``).
    max_error : (n,) array
        Largest ``|e_k|`` over the valid runs from ``t_transient`` on (``nan`` without a valid run).
    ratio : (n,) array
        ``bound / max_error`` per state (at least 1 when the bound holds).
    worst_relative_ratio : float
        ``max_k bound_k / s_k`` over ``max_k max_error_k / s_k`` (``s`` the bound's reference sizes).
    reference : (n,) array
        The sizes ``s``.
    by_family : dict
        Per noise family: its valid runs' ``max_error`` per state (``nan`` without one).
    runs_by_family : dict
        Per noise family: ``(runs, valid runs)``.
    exceeded : int
        Samples of valid runs with ``|e_k|`` above the certified envelope (the bound itself from a
        zero initial error) by more than ``rtol``.
    runs, valid_runs : int
        Runs simulated; runs that test the bound (no dwell violation, never outside the active region).
    switches : int
        Gain switches over all runs.
    switches_valid : int
        Gain switches over the valid runs.
    min_dwell_observed : float or None
        Smallest time between two consecutive switches of any run (``None`` when no run switched twice).
    left_region : int
        Runs in which the plant or the estimate left the active region (no test).
    plant_left_box : int
        Runs whose plant state left the operating box (counted in ``left_region``).
    dwell_violations : int
        Runs with two switches closer than ``dwell`` (no test).
    dwell : float
        The dwell time the bound assumes.
    step_overshoot : float
        Largest excursion outside the previous region at a sampled switch (module docstring).
    max_error_no_test : (n,) array
        Largest ``|e_k|`` of the runs that were no test (``nan`` when every run was valid).
    exceeded_no_test : int
        Their samples above the envelope (not a failure of the bound: its assumptions failed).
    t_transient : float
        Time from which ``max_error`` is taken (0 from a zero initial error).
    t_final, dt : float
    noise_scale : float
        The simulated noise over the declared one (``snb.noise``); the bound is the declared noise's.
    sinusoids : tuple of (int, WorstSinusoid)
        The region and the worst sinusoid each sinusoid family was aimed from.
    run_details : tuple of SwitchedNoiseRun
    seconds : float

    See Also
    --------
    check_switched_noise_bound : Returns one.
    SwitchedNoiseBound : The bound it checks.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import regions_from_switch_points, synthesize_switched
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A scalar plant ``x' = -sin(x) + u``, ``y = x``, with one gain for ``x < 0`` and one for ``x > 0``:

    >>> import casadi as ca

    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> plant = ScalarNonlinearSystem(box=Polytope.from_box([-1.0], [1.0], ("x",)), A=[[0.0]], C=[[1.0]],
    ...                               F=[[-1.0]], E=[[1.0]], f=(sine,), B=[[1.0]], name="scalar")
    >>> regions = regions_from_switch_points(plant, "x", -1.0, 1.0, [0.0], 0.1)
    >>> design = synthesize_switched(plant, regions, gain_bound=10.0, max_rate=2.0, overlap=0.1)
    >>> from hybobs_opt.lmi import check_switched_noise_bound, switched_noise_bound
    >>> snb = switched_noise_bound(design, [0.01])
    >>> def drive(t, X):
    ...     return np.full((X.shape[0], 1), 0.9 * np.cos(2 * t))
    ...
    >>> check = check_switched_noise_bound(snb, drive, np.array([0.0]), t_final=4.0, random_runs=4)
    >>> check.runs, check.valid_runs, check.exceeded, check.switches > 0
    (6, 3, 0, True)
    >>> bool(np.all(check.max_error <= check.bound))
    True
    """

    bound: np.ndarray
    max_error: np.ndarray
    ratio: np.ndarray
    worst_relative_ratio: float
    reference: np.ndarray
    by_family: dict
    runs_by_family: dict
    exceeded: int
    runs: int
    valid_runs: int
    switches: int
    switches_valid: int
    min_dwell_observed: float | None
    left_region: int
    plant_left_box: int
    dwell_violations: int
    dwell: float
    step_overshoot: float
    max_error_no_test: np.ndarray
    exceeded_no_test: int
    t_transient: float
    t_final: float
    dt: float
    noise_scale: float = 1.0
    sinusoids: tuple = ()
    run_details: tuple = field(default=(), repr=False)
    seconds: float = 0.0

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        def arr(a):
            return np.asarray(a, dtype=float).tolist()

        return {"bound": arr(self.bound), "max_error": arr(self.max_error), "ratio": arr(self.ratio),
                "worst_relative_ratio": self.worst_relative_ratio, "reference": arr(self.reference),
                "by_family": {k: arr(v) for k, v in self.by_family.items()},
                "runs_by_family": {k: list(v) for k, v in self.runs_by_family.items()}, "exceeded": self.exceeded,
                "runs": self.runs, "valid_runs": self.valid_runs, "switches": self.switches,
                "switches_valid": self.switches_valid, "min_dwell_observed": self.min_dwell_observed,
                "left_region": self.left_region, "plant_left_box": self.plant_left_box,
                "dwell_violations": self.dwell_violations, "dwell": self.dwell,
                "step_overshoot": self.step_overshoot, "max_error_no_test": arr(self.max_error_no_test),
                "exceeded_no_test": self.exceeded_no_test, "t_transient": self.t_transient,
                "t_final": self.t_final, "dt": self.dt, "noise_scale": self.noise_scale,
                "sinusoids": [{"region": q, **s.to_dict()} for q, s in self.sinusoids],
                "runs_detail": [r.to_dict() for r in self.run_details], "seconds": self.seconds}


def _envelope_data(snb: SwitchedNoiseBound, e0: np.ndarray, q0: int) -> tuple[float, float]:
    """``(D_0 mu' / u*, r)``: ``|e_k(t)| <= bound_k sqrt(1 + D_0 mu' e^{-r t} / u*)`` (module docstring).

    ``bound_k = sqrt(u*) m_k`` with ``m_k = max_i sqrt(c_i (P_i^-1)_kk)``.
    """
    d0 = snb.by_region[q0]
    U0 = float(e0 @ d0.P @ e0) / d0.level
    mu = max(float(snb.jump), 1.0)
    return max(U0 - 1.0, 0.0) * mu / float(snb.level), snb.alpha - math.log(mu) / snb.dwell


def check_switched_noise_bound(snb: SwitchedNoiseBound, drive: Drive, x0, *, e0=None, t_final: float | None = None,
                               dt: float | None = None, random_runs: int = 16, hold_steps: int = 10, seed: int = 0,
                               families=("random", "sinusoid"), sin_factors=(0.8, 1.0, 1.25),
                               noise_scale: float = 1.0, settle: float = 0.01,
                               rtol: float = 1e-6) -> SwitchedNoiseSimulationCheck:
    """Simulate the switched observer of ``snb`` under bounded noises (module docstring) and compare with its bound.

    Parameters
    ----------
    snb : SwitchedNoiseBound
        A certified bound (``snb.holds``; its system has no ``g(y, u)``).
    drive : callable
        ``drive(t, X) -> (R, m)``: the plant's inputs (steer the scheduling coordinate across the
        regions' overlap so that the gain switches; keep the plant in the operating box).
    x0 : (n,) array
        Plant initial state (every run).
    e0 : (n,) array, optional
        Initial error ``x - x^`` (default zero: the bound holds from the start).
    t_final : float, optional
        Horizon (default: the transient time plus the longer of 10 time constants ``1/alpha`` and
        five periods of the slowest worst sinusoid that is not constant).
    dt : float, optional
        Step (default: 0.1 over the largest eigenvalue modulus of the frozen vertex systems of
        every region).
    random_runs : int, default 16
        Runs of random noise.
    hold_steps : int, default 10
        Steps each value of the random noise is held.
    seed : int
        Seed of the first random run (run ``r`` has seed ``seed + r``).
    families : tuple of str
        ``"random"``, ``"sinusoid"`` (per region and state, one run at each of ``sin_factors``
        times the worst frequency of that region's gain; one constant run when that frequency is
        0) and/or ``"sign"`` (per region and state, one run of :func:`.noise_sim.sign_noise`
        aimed at that region's worst vertex, repeated every 10 time constants).
    sin_factors : tuple of float, default (0.8, 1.0, 1.25)
        Frequencies of the sinusoid runs relative to the worst ones.
    noise_scale : float, default 1
        Multiplies the noise amplitudes of the simulation (not the bound): above 1 the noise
        exceeds the declared bound, for which nothing is claimed.
    settle : float, default 0.01
        From an initial error, ``max_error`` is taken from the time the envelope is within this
        fraction of the bound (``t_transient``).
    rtol : float, default 1e-6
        Relative slack of the comparison with the envelope (integration error).

    Returns
    -------
    SwitchedNoiseSimulationCheck

    See Also
    --------
    SwitchedNoiseSimulationCheck : What it returns.
    switched_noise_bound : The bound it checks.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import regions_from_switch_points, synthesize_switched
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A scalar plant ``x' = -sin(x) + u``, ``y = x``, with one gain for ``x < 0`` and one for ``x > 0``:

    >>> import casadi as ca

    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> plant = ScalarNonlinearSystem(box=Polytope.from_box([-1.0], [1.0], ("x",)), A=[[0.0]], C=[[1.0]],
    ...                               F=[[-1.0]], E=[[1.0]], f=(sine,), B=[[1.0]], name="scalar")
    >>> regions = regions_from_switch_points(plant, "x", -1.0, 1.0, [0.0], 0.1)
    >>> design = synthesize_switched(plant, regions, gain_bound=10.0, max_rate=2.0, overlap=0.1)
    >>> from hybobs_opt.lmi import check_switched_noise_bound, switched_noise_bound
    >>> snb = switched_noise_bound(design, [0.01])
    >>> def drive(t, X):
    ...     return np.full((X.shape[0], 1), 0.9 * np.cos(2 * t))
    ...
    >>> check = check_switched_noise_bound(snb, drive, np.array([0.0]), t_final=4.0, random_runs=4)
    >>> check.exceeded, bool(np.all(check.ratio >= 1.0))
    (0, True)
    """
    from .noise_sim import _model_vertices

    t_start = time.perf_counter()
    if not snb.holds:
        raise ModelError("snb", "a certified switched noise bound (snb.holds)",
                         f"dwell {snb.dwell:.4g} s <= {snb.dwell_needed:.4g} s needed")
    design = snb.design
    system = design.system
    n = system.n
    x0 = np.asarray(x0, dtype=float).reshape(n)
    e0 = np.zeros(n) if e0 is None else np.asarray(e0, dtype=float).reshape(n)
    regs = _Regions(snb)
    q0 = int(regs.initial(np.array([x0[regs.k] - e0[regs.k]]))[0])
    if q0 < 0:
        raise ModelError("x0 - e0", "an initial estimate inside a region of the design",
                         f"{system.state_names[regs.k]} = {x0[regs.k] - e0[regs.k]:.6g}")
    excess, rate = _envelope_data(snb, e0, q0)
    if excess > 0:
        # the envelope is within (1 + settle) of the bound once D_0 mu' e^{-r t} / u* <= (1 + settle)^2 - 1
        t_tr = max(math.log(excess / ((1.0 + settle) ** 2 - 1.0)) / rate, 0.0)
    else:
        t_tr = 0.0
    if dt is None:
        fast = max(float(np.abs(np.linalg.eigvals(A)).max()) for d in snb.by_region for A, _ in _model_vertices(d)[0])
        dt = 0.1 / fast
    dt = float(dt)
    sins = [(q, s) for q, d in enumerate(snb.by_region) for s in worst_sinusoids(d)]
    if t_final is None:
        periods = [2 * math.pi / s.omega for _, s in sins if s.omega > 0]
        t_final = t_tr + max(10.0 / snb.alpha, 5 * max(periods, default=0.0))
    t_final = float(t_final)
    vbar = snb.noise * float(noise_scale)
    hold = max(int(hold_steps), 1) * dt
    batches: list[tuple[str, Noise, int]] = []
    if "random" in families and random_runs > 0:
        batches.append(("random", random_noise(vbar, hold, seed + np.arange(random_runs)), int(random_runs)))
    aimed: list[tuple[int, WorstSinusoid]] = []
    if "sinusoid" in families:
        aims = [(s.omega * fct, s.phases) for _, s in sins for fct in (sin_factors if s.omega > 0 else (1.0,))]
        aimed = list(sins)
        batches.append(("sinusoid", sinusoid_noise(vbar, [w for w, _ in aims], np.array([ph for _, ph in aims])),
                        len(aims)))
    if "sign" in families:
        for q, d in enumerate(snb.by_region):
            systems, _ = _model_vertices(d)
            slow = min(float(-np.linalg.eigvals(A).real.max()) for A, _ in systems)
            period = 10.0 / slow if slow > 0 else 10.0 / d.alpha
            own = [s for qq, s in sins if qq == q]
            gen = sign_noise(d, [s.state for s in own], [s.vertex for s in own], period, dt)
            batches.append(("sign", lambda t, gen=gen: gen(t) * float(noise_scale), len(own)))
    unknown = set(families) - {"random", "sinusoid", "sign"}
    if unknown or not batches:
        raise ModelError("families", "'random', 'sinusoid' and/or 'sign' with at least one run", repr(families))
    R = sum(b[2] for b in batches)
    labels = [name for name, _, k in batches for _ in range(k)]

    def noise(t: float) -> np.ndarray:
        return np.vstack([b[1](t) for b in batches])

    X0 = np.tile(x0, (R, 1))
    run = simulate_switched_noisy_observer(snb, X0, X0 - e0[None, :], drive, noise, t_final, dt)
    err = np.abs(run.x - run.x_hat)  # (N + 1, R, n)
    env = np.sqrt(1.0 + excess * np.exp(-rate * run.t))[:, None] * snb.bound[None, :]  # (N + 1, n)
    above = (err > env[:, None, :] * (1 + rtol)).sum(axis=(0, 2))  # per run
    after = run.t >= t_tr
    details = []
    for r in range(R):
        moved = np.nonzero(run.q[1:, r] != run.q[:-1, r])[0] + 1
        times = tuple(float(run.t[i]) for i in moved)
        gaps = np.diff(times)
        min_gap = float(gaps.min()) if gaps.size else None
        details.append(SwitchedNoiseRun(labels[r], times, (int(run.q[0, r]),) + tuple(int(run.q[i, r]) for i in moved),
                                        min_gap, bool(min_gap is not None and min_gap < snb.dwell),
                                        bool(run.left[r]), bool(run.out_box[r]), float(run.overshoot[r]),
                                        err[after, r, :].max(axis=0)))
    valid = np.array([d.valid for d in details])
    nan = np.full(n, np.nan)
    max_err = err[after][:, valid, :].max(axis=(0, 1)) if valid.any() else nan
    no_test = err[after][:, ~valid, :].max(axis=(0, 1)) if (~valid).any() else nan
    by_family, runs_by_family = {}, {}
    for name in dict.fromkeys(labels):
        mine = np.array(labels) == name
        sel = valid & mine
        by_family[name] = err[after][:, sel, :].max(axis=(0, 1)) if sel.any() else nan
        runs_by_family[name] = (int(mine.sum()), int(sel.sum()))
    ref = getattr(snb.by_region[0], "reference", None)
    ref = 0.5 * (system.box_upper - system.box_lower) if ref is None else np.asarray(ref, dtype=float)
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = snb.bound / max_err
        wrr = float(np.max(snb.bound / ref) / np.max(max_err / ref))
    gaps = [d.min_interval for d in details if d.min_interval is not None]
    return SwitchedNoiseSimulationCheck(
        np.array(snb.bound, dtype=float), max_err, ratio, wrr, ref, by_family, runs_by_family,
        int(above[valid].sum()), R,
        int(valid.sum()), sum(len(d.switch_times) for d in details),
        sum(len(d.switch_times) for d, ok in zip(details, valid) if ok), min(gaps) if gaps else None,
        int(sum(d.left_region for d in details)), int(sum(d.plant_left_box for d in details)),
        int(sum(d.dwell_violation for d in details)), float(snb.dwell), float(run.overshoot.max(initial=0.0)),
        no_test, int(above[~valid].sum()), float(t_tr), t_final, dt, float(noise_scale), tuple(aimed), tuple(details),
        time.perf_counter() - t_start)

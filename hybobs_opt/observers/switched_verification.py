"""Checks of a switched-gain design on the system before it is handed over (paper 004, Section 5).

The LMIs behind each region's gain are sufficient conditions on the Jacobian box; two checks on
the system itself say whether the design does what it should:

* **frozen error dynamics** -- for every region, ``J(x) - L_i C(x)`` (``J = A + F diag(f'(E x)) E``,
  ``C = diag(h'(C x)) C``) on a grid of the region (the scheduling coordinate on a line, the other
  states at the centre and the corners of the box); its largest real eigenvalue is reported.  The
  region's LMI implies ``Re lambda <= -sigma_i / 2`` there, so a larger value is a defect of the design;
* **simulation** -- the switched-gain observer (hysteresis, dwell, initial-region selection, the
  periodic coordinates wrapped) run on a scenario (the study's, a user's trace, or a free response
  of the model from the centre of the box) from a set of initial errors, with the convergence time
  of each (the first time after which every state error stays within its tolerance).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from ..defaults import (VERIFY_ERROR_FRACTION, VERIFY_FROZEN_GRID, VERIFY_MAX_CORNERS, VERIFY_N_INITIAL_ERRORS,
                        VERIFY_TOLERANCE_FRACTION)
from ..errors import ModelError
from .switched_gain import SwitchedGainObserver, convergence_time


@dataclass(frozen=True)
class FrozenCheck:
    """Largest real eigenvalue of the frozen error dynamics over one region's grid."""

    region: int
    interval: tuple[float, float]
    max_real_eig: float
    at: np.ndarray
    bound: float
    points: int

    @property
    def ok(self) -> bool:
        """``max Re lambda <= -sigma_i / 2`` (what the region's LMI implies), to rounding."""
        return bool(self.max_real_eig <= self.bound + 1e-9 * (1.0 + abs(self.bound)))

    def to_dict(self) -> dict:
        return {"region": self.region, "interval": list(self.interval), "max_real_eig": self.max_real_eig,
                "at": self.at.tolist(), "lmi_bound": self.bound, "points": self.points, "ok": self.ok}


@dataclass(frozen=True)
class SimulationCheck:
    """The switched observer from several initial errors on one scenario."""

    scenario: str
    t_final: float
    dt: float
    initial_errors: np.ndarray
    convergence_times: list[float | None]
    final_errors: np.ndarray
    tolerance: np.ndarray
    switches: list[int]
    seconds: float

    @property
    def converged(self) -> bool:
        return all(t is not None for t in self.convergence_times)

    @property
    def worst_convergence_time(self) -> float | None:
        return None if not self.converged else max(self.convergence_times)

    def to_dict(self) -> dict:
        return {"scenario": self.scenario, "t_final": self.t_final, "dt": self.dt,
                "initial_errors": self.initial_errors.tolist(), "convergence_times": list(self.convergence_times),
                "converged": self.converged, "worst_convergence_time": self.worst_convergence_time,
                "final_abs_errors": np.abs(self.final_errors).tolist(), "tolerance": self.tolerance.tolist(),
                "switches": self.switches, "seconds": self.seconds}


@dataclass(frozen=True)
class DesignVerification:
    """Both checks of a switched design (``hybobs synth`` JSON field ``verification``)."""

    frozen: list[FrozenCheck]
    simulation: SimulationCheck | None
    seconds: float
    notes: list[str] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return all(f.ok for f in self.frozen) and (self.simulation is None or self.simulation.converged)

    @property
    def max_real_eig(self) -> float:
        return max(f.max_real_eig for f in self.frozen)

    def to_dict(self) -> dict:
        return {"ok": self.ok, "max_real_eig": self.max_real_eig, "frozen": [f.to_dict() for f in self.frozen],
                "simulation": None if self.simulation is None else self.simulation.to_dict(),
                "seconds": self.seconds, "notes": list(self.notes)}


def _half_widths(system) -> np.ndarray:
    d = 0.5 * (system.box_upper - system.box_lower)
    return np.where(d > 0, d, 1.0)


def frozen_checks(design, grid: int = VERIFY_FROZEN_GRID) -> list[FrozenCheck]:
    """The frozen-Jacobian check of every region (module docstring)."""
    system = design.system
    k = design.coordinate
    lo_b, hi_b = system.box_lower, system.box_upper
    centre = 0.5 * (lo_b + hi_b)
    others = [i for i in range(system.n) if i != k]
    combos = [centre]
    for bits in itertools.islice(itertools.product((0, 1), repeat=len(others)), VERIFY_MAX_CORNERS - 1):
        x = centre.copy()
        x[others] = np.where(np.array(bits, dtype=bool), hi_b[others], lo_b[others])
        combos.append(x)
    out = []
    for i, g in enumerate(design.regions):
        X = []
        for s in np.linspace(g.region.lo, g.region.hi, grid):
            for base in combos:
                x = base.copy()
                x[k] = s
                X.append(x)
        X = np.array(X)
        J = system.dynamics_jacobian(X) - np.einsum("ij,kjl->kil", g.L, system.output_jacobian(X))
        re = np.array([np.linalg.eigvals(Jk).real.max() for Jk in J])
        j = int(np.argmax(re))
        out.append(FrozenCheck(i, (g.region.lo, g.region.hi), float(re[j]), X[j], -0.5 * float(g.sigma), X.shape[0]))
    return out


def free_response(system, t_final: float, dt: float):
    """The model from the centre of its box with zero input (a scenario for systems without one)."""
    from ..sim.nonlinear import simulate_nonlinear

    x0 = 0.5 * (system.box_lower + system.box_upper)
    return simulate_nonlinear(system, x0, lambda t: np.zeros(system.m), t_final, dt)


def verify_switched_design(design, scenario=None, *, scenario_name: str | None = None,
                           initial_errors: Sequence[Sequence[float]] | None = None,
                           tolerance: Sequence[float] | None = None, periodic: Mapping[str | int, float] | None = None,
                           t_final: float | None = None, seed: int = 0) -> DesignVerification:
    """Check a :class:`~hybobs_opt.lmi.switched.SwitchedDesign` on its system (module docstring).

    Parameters
    ----------
    design : SwitchedDesign
    scenario : Trace, optional
        True run to observe (``t``, ``x``, ``u``, ``y``); default: :func:`free_response` over
        ``t_final`` (default ``10 / min sigma_i``, at most 60 time units).
    initial_errors : (k, n) array, optional
        Initial estimation errors (default :data:`~hybobs_opt.defaults.VERIFY_N_INITIAL_ERRORS` seeded ones).
    tolerance : (n,) array, optional
        Per-state convergence tolerance (default :data:`~hybobs_opt.defaults.VERIFY_TOLERANCE_FRACTION` of the box
        half-width).
    periodic : mapping, optional
        Periodic coordinates for the observer (``{"psi": 2 pi}``): wrapped, not clipped.
    """
    t0 = time.perf_counter()
    system = design.system
    n = system.n
    notes = []
    frozen = frozen_checks(design)
    d = _half_widths(system)
    if scenario is None:
        sig = min(max(g.sigma, 1e-6) for g in design.regions)
        T = float(min(60.0, 10.0 / sig)) if t_final is None else float(t_final)
        fastest = max(max(g.sigma_max, g.sigma) for g in design.regions)
        dt = float(min(T / 200.0, max(T / 5000.0, 0.1 / fastest)))
        scenario = free_response(system, T, dt)
        scenario_name = scenario_name or f"free response from the centre of the box ({T:.3g} time units)"
    else:
        scenario_name = scenario_name or "given trace"
    t = np.asarray(scenario.t, dtype=float)
    if t.size < 2:
        raise ModelError("scenario", "a trace with at least two samples", f"{t.size}")
    dt = float(t[1] - t[0])
    if initial_errors is None:
        rng = np.random.default_rng(seed)
        E0 = [VERIFY_ERROR_FRACTION * d]
        E0 += [VERIFY_ERROR_FRACTION * d * rng.uniform(-1.0, 1.0, n) for _ in range(VERIFY_N_INITIAL_ERRORS - 1)]
        E0 = np.array(E0)
    else:
        E0 = np.asarray(initial_errors, dtype=float)
        if E0.ndim != 2 or E0.shape[1] != n or not np.all(np.isfinite(E0)):
            raise ModelError("initial_errors", f"finite rows of {n} state errors", f"shape {E0.shape}")
    tol = VERIFY_TOLERANCE_FRACTION * d if tolerance is None else np.asarray(tolerance, dtype=float)
    if tol.shape != (n,) or not np.all(tol > 0):
        raise ModelError("tolerance", f"{n} positive per-state tolerances", repr(tolerance))
    times, finals, switches = [], [], []
    obs = SwitchedGainObserver(system, design.regions, dt, periodic=periodic)  # built once, reset per error
    for e0 in E0:
        x_hat0 = np.clip(scenario.x[0] + e0, system.box_lower, system.box_upper)
        obs.reset(x_hat0)
        ot = obs.run(scenario.u, scenario.y)
        err = obs.difference(ot.x_hat, scenario.x)
        times.append(convergence_time(t, err, tol))
        finals.append(err[-1])
        m = ot.mode
        switches.append(int(np.sum((m[1:] != m[:-1]) & (m[:-1] >= 0))))
    sim = SimulationCheck(scenario_name, float(t[-1] - t[0]), dt, E0, times, np.array(finals), tol, switches,
                          time.perf_counter() - t0)
    if not sim.converged:
        notes.append("the observer did not converge from every initial error on the scenario")
    bad = [f for f in frozen if not f.ok]
    if bad:
        notes.append("frozen error dynamics above the LMI's bound -sigma/2 in regions " + ", ".join(str(f.region) for f in bad))
    return DesignVerification(frozen, sim, time.perf_counter() - t0, notes)

"""Simulation check of a noise-bound design (:mod:`.noise_gain`): plant and observer under bounded noise.

The certified claim of a :class:`~.noise_gain.NoiseBoundDesign` is an ultimate bound on each error
component for *every* output noise with ``|v_j| <= vbar_j``.  This module measures how close
bounded noises come to it, to show that the bound holds and is not vacuous:

* random noise, piecewise constant and uniform in the box ``[-vbar, vbar]``;
* for each state ``k``, the sinusoids ``v_j(t) = vbar_j cos(omega t - phi_j)`` at the frequency
  where the error transfer of a frozen vertex of the Jacobian box,
  ``G_v(s) = (s I - (A_v - L C_v))^{-1} L diag(vbar)``, has the largest
  ``sum_j |G_v,kj(j omega)|`` (the steady amplitude of ``e_k`` when the phases ``phi_j = arg
  G_v,kj`` line the channels up), over every vertex (:func:`worst_sinusoids`);
* for each state ``k``, the sign noise ``v_j(t) = vbar_j sign(g_kj(t_i - t))`` with ``g`` the
  impulse response of the same frozen vertex system: the worst bounded noise of that linear
  system at the instants ``t_i`` (its peak equals the L1 norm of the impulse response, the
  peak-to-peak gain), repeated every few time constants.

Plant and observer are integrated together by the classical fixed-step Runge-Kutta method, with
the piecewise-constant noises switching on the step grid.  The
mean-value argument of the bound needs the plant state *and* the estimate in the region of the
design's Jacobian box: every run records whether either left it (the arguments ``E_i x``, ``C_j x``
of the nonlinear functions, and the plant state in the operating box), and a run that did is no
test of the bound.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from .lmi_model import lmi_data
from .noise_gain import NoiseBoundDesign, _output_order
from .polytopic import vertex_matrices, vertex_slopes

__all__ = ["NoiseRun", "NoiseSimulationCheck", "WorstSinusoid", "check_noise_bound", "random_noise",
           "simulate_noisy_observer", "sign_noise", "sinusoid_noise", "worst_sinusoids"]

Drive = Callable[[float, np.ndarray], np.ndarray]
Noise = Callable[[float], np.ndarray]

#: The last Runge-Kutta stage reads the noise this fraction of a step before the step's end, so a
#: piecewise-constant noise that switches on the step grid keeps its value over the whole step (a
#: switch is read at the next step's start); a smooth noise is read 1e-6 of a step early.
_STEP_END = 1e-6


# ---------------------------------------------------------------------------- frozen vertex systems
def _model_vertices(design: NoiseBoundDesign):
    """``(A_v - L C_v, L_ord diag(vbar_ord))`` of every vertex, model coordinates."""
    system = design.system
    order = _output_order(system)
    As, Cs = vertex_matrices(lmi_data(system), vertex_slopes(design.bounds))
    Lo = design.L[:, order]
    Bn = Lo * design.noise[order][None, :]
    return [(A - Lo @ C, Bn) for A, C in zip(As, Cs)], order


@dataclass(frozen=True)
class WorstSinusoid:
    """The sinusoidal noise that excites one error component most on a frozen vertex system.

    Attributes
    ----------
    state : int
        The error component ``k`` aimed at.
    omega : float
        Frequency (rad per time unit of the model); 0 for a constant noise.
    vertex : int
        Index of the vertex of the Jacobian box (order of :func:`.polytopic.vertex_slopes`).
    amplitude : float
        ``sum_j |G_v,kj(j omega)|``: the steady amplitude of ``e_k`` on that linear system.
    phases : (p,) array
        ``phi_j`` of ``v_j = vbar_j cos(omega t - phi_j)``, output order.
    """

    state: int
    omega: float
    vertex: int
    amplitude: float
    phases: np.ndarray

    def to_dict(self) -> dict:
        return {"state": self.state, "omega": self.omega, "vertex": self.vertex, "amplitude": self.amplitude,
                "phases": self.phases.tolist()}


def _freq_gains(Acl: np.ndarray, Bn: np.ndarray, omegas: np.ndarray) -> np.ndarray:
    """``G(j omega)`` for each ``omega``: ``(len(omegas), n, p)`` complex."""
    n = Acl.shape[0]
    eye = np.eye(n)
    return np.array([np.linalg.solve(1j * w * eye - Acl, Bn) for w in omegas])


def worst_sinusoids(design: NoiseBoundDesign, samples: int = 400) -> tuple[WorstSinusoid, ...]:
    """For each state, the frequency and phases of the sinusoidal noise with the largest steady error.

    The largest ``sum_j |G_v,kj(j omega)|`` over every vertex ``v`` and over ``omega`` on a
    logarithmic grid spanning three decades beyond the vertex systems' eigenvalues (and
    ``omega = 0``), refined by a bounded scalar search in ``log omega`` around the best grid point.

    Parameters
    ----------
    design : NoiseBoundDesign
        A feasible design.
    samples : int, default 400
        Points of the frequency grid.

    Returns
    -------
    tuple of WorstSinusoid
        One per state.
    """
    from scipy.optimize import minimize_scalar

    if not design.feasible:
        raise ModelError("design", "a feasible noise-bound design", f"status {design.status}")
    systems, order = _model_vertices(design)
    mags = np.concatenate([np.abs(np.linalg.eigvals(A)) for A, _ in systems])
    mags = mags[mags > 0]
    lo, hi = (1e-3 * mags.min(), 1e3 * mags.max()) if mags.size else (1e-3, 1e3)
    grid = np.concatenate([[0.0], np.geomspace(lo, hi, samples)])
    out = []
    n = design.system.n
    G = [np.abs(_freq_gains(A, B, grid)).sum(axis=2) for A, B in systems]  # (len(grid), n) per vertex
    for k in range(n):
        best = (-1.0, 0.0, 0)
        for v, g in enumerate(G):
            i = int(np.argmax(g[:, k]))
            w = grid[i]
            if i > 0:
                a = math.log(grid[max(i - 1, 1)])
                b = math.log(grid[min(i + 1, grid.size - 1)])
                A, B = systems[v]
                res = minimize_scalar(lambda s: -np.abs(_freq_gains(A, B, np.array([math.exp(s)]))[0, k]).sum(),
                                      bounds=(a, b), method="bounded", options={"xatol": 1e-6})
                if -res.fun > g[i, k]:
                    w = math.exp(res.x)
            amp = float(np.abs(_freq_gains(*systems[v], np.array([w]))[0, k]).sum())
            if amp > best[0]:
                best = (amp, w, v)
        amp, w, v = best
        Gk = _freq_gains(*systems[v], np.array([w]))[0, k]
        phases = np.zeros(design.system.p)
        phases[order] = np.angle(Gk)
        out.append(WorstSinusoid(k, float(w), int(v), amp, phases))
    return tuple(out)


# ---------------------------------------------------------------------------- noise signals
def random_noise(vbar, hold: float, seeds) -> Noise:
    """Piecewise-constant noise, uniform in ``[-vbar, vbar]``, a new value every ``hold`` time units.

    Parameters
    ----------
    vbar : (p,) array
        Bounds per output.
    hold : float
        Time each value is held.
    seeds : sequence of int
        One seed of :func:`numpy.random.default_rng` per run (rows of the result).

    Returns
    -------
    callable
        ``noise(t) -> (runs, p)`` for non-decreasing ``t`` (the values are drawn in time order).
    """
    vbar = np.asarray(vbar, dtype=float)
    rngs = [np.random.default_rng(int(s)) for s in seeds]
    values: list[np.ndarray] = []

    def noise(t: float) -> np.ndarray:
        i = int(math.floor(t / hold + 1e-9))
        while len(values) <= i:
            values.append(np.array([r.uniform(-1.0, 1.0, size=vbar.size) for r in rngs]) * vbar)
        return values[i]

    return noise


def sinusoid_noise(vbar, omegas, phases) -> Noise:
    """``v_j(t) = vbar_j cos(omega_r t - phi_rj)`` for each run ``r``.

    Parameters
    ----------
    vbar : (p,) array
        Amplitudes (the bounds).
    omegas : (R,) array
        One frequency per run.
    phases : (R, p) array
        Phases per run and output.
    """
    vbar = np.asarray(vbar, dtype=float)
    omegas = np.asarray(omegas, dtype=float).reshape(-1, 1)
    phases = np.asarray(phases, dtype=float).reshape(omegas.shape[0], vbar.size)

    def noise(t: float) -> np.ndarray:
        return vbar[None, :] * np.cos(omegas * t - phases)

    return noise


def sign_noise(design: NoiseBoundDesign, states, vertices, period: float, dt: float) -> Noise:
    """The worst bounded noise of frozen vertex systems at the instants ``period, 2 period, ...``.

    For run ``r`` aimed at state ``k = states[r]`` on vertex ``v = vertices[r]``:
    ``v_j(t) = vbar_j sign(g_kj(t_i - t))`` on ``(t_{i-1}, t_i]``, where ``g(tau) = e^{(A_v - L
    C_v) tau} L`` is the impulse response: it makes ``e_k(t_i)`` of that linear system as large
    as any noise can (the L1 norm of the impulse response over one period).

    Parameters
    ----------
    design : NoiseBoundDesign
        A feasible design.
    states, vertices : sequences of int
        Aimed state and vertex per run.
    period : float
        Time between the aimed instants (several time constants of the error dynamics).
    dt : float
        Step of the tabulated impulse response (the simulation step).
    """
    from scipy.linalg import expm

    systems, order = _model_vertices(design)
    p = design.system.p
    steps = max(int(round(period / dt)), 1)
    table = []
    for k, v in zip(states, vertices):
        Acl, _ = systems[v]
        Lo = design.L[:, order]
        step = expm(Acl * dt)
        g = np.empty((steps + 1, p))
        M = Lo.copy()
        for i in range(steps + 1):
            g[i, order] = M[k]
            M = step @ M
        table.append(np.sign(g))
    table = np.array(table)  # (R, steps + 1, p)
    vbar = design.noise

    def noise(t: float) -> np.ndarray:
        i = int(math.floor(t / dt + 1e-9)) % steps  # steps since the last aimed instant
        tau = steps - i  # time to the next aimed instant, in steps
        return table[:, tau, :] * vbar[None, :]

    return noise


# ---------------------------------------------------------------------------- simulation
@dataclass(frozen=True)
class NoiseRun:
    """One batch of simulated runs: time grid, plant states and estimates.

    Attributes
    ----------
    t : (N + 1,) array
    x, x_hat : (N + 1, R, n) arrays
        Plant states and estimates of the ``R`` runs.
    """

    t: np.ndarray
    x: np.ndarray = field(repr=False)
    x_hat: np.ndarray = field(repr=False)

    @property
    def error(self) -> np.ndarray:
        return self.x - self.x_hat


def simulate_noisy_observer(system, L: np.ndarray, x0: np.ndarray, x_hat0: np.ndarray, drive: Drive, noise: Noise,
                            t_final: float, dt: float) -> NoiseRun:
    """Plant ``x' = A x + F f(E x) + B u`` and observer ``x^' = A x^ + F f(E x^) + B u + L (y + v - h(C x^))``.

    Fixed-step classical Runge-Kutta for the joint state of ``R`` runs at once; the input
    ``u = drive(t, x)`` (a feedback of the true state) and the noise are evaluated at every stage,
    the noise of the last stage just before the step's end (a piecewise-constant noise that
    switches on the step grid is integrated as such).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        Without ``g(y, u)``.
    L : (n, p) array
        The observer gain.
    x0, x_hat0 : (R, n) arrays
        Initial plant states and estimates.
    drive : callable
        ``drive(t, X) -> (R, k)`` inputs for the ``(R, n)`` plant states.
    noise : callable
        ``noise(t) -> (R, p)``.
    t_final, dt : float
        Horizon and step.
    """
    if system.g is not None:
        raise ModelError("system.g", "no g(y, u) term", "a callable")
    X = np.array(x0, dtype=float, ndmin=2)
    Xh = np.array(x_hat0, dtype=float, ndmin=2)
    if X.shape != Xh.shape or X.shape[1] != system.n:
        raise ModelError("x0, x_hat0", f"two (R, {system.n}) arrays of the same shape", f"{X.shape}, {Xh.shape}")
    steps = int(math.ceil(t_final / dt - 1e-9))
    t = np.arange(steps + 1) * dt
    xs = np.empty((steps + 1,) + X.shape)
    xhs = np.empty_like(xs)
    xs[0], xhs[0] = X, Xh
    LT = np.asarray(L, dtype=float).T

    R = X.shape[0]

    def f(tt, X, Xh, v):
        U = np.asarray(drive(tt, X), dtype=float).reshape(R, system.m)
        Z = np.vstack([X, Xh])  # plant and observer in one evaluation of the model
        Y = system.output(Z)
        D = system.rhs(Z, np.vstack([U, U]))
        return D[:R], D[R:] + (Y[:R] + v - Y[R:]) @ LT

    end = dt * (1.0 - _STEP_END)
    for i in range(steps):
        ti = t[i]
        vm = noise(ti + dt / 2)
        k1 = f(ti, X, Xh, noise(ti))
        k2 = f(ti + dt / 2, X + dt / 2 * k1[0], Xh + dt / 2 * k1[1], vm)
        k3 = f(ti + dt / 2, X + dt / 2 * k2[0], Xh + dt / 2 * k2[1], vm)
        k4 = f(ti + dt, X + dt * k3[0], Xh + dt * k3[1], noise(ti + end))
        X = X + dt / 6 * (k1[0] + 2 * k2[0] + 2 * k3[0] + k4[0])
        Xh = Xh + dt / 6 * (k1[1] + 2 * k2[1] + 2 * k3[1] + k4[1])
        xs[i + 1], xhs[i + 1] = X, Xh
    return NoiseRun(t, xs, xhs)


# ---------------------------------------------------------------------------- the check
@dataclass(frozen=True)
class NoiseSimulationCheck:
    """What bounded noises did to the error of a noise-bound design.

    Attributes
    ----------
    bound : (n,) array
        The design's certified per-state ultimate bound.
    max_error : (n,) array
        Largest ``|e_k|`` over every run after the transient.
    ratio : (n,) array
        ``bound / max_error`` per state (at least 1 when the bound holds).
    worst_relative_ratio : float
        The design's worst relative bound over the largest simulated relative error
        (``max_k bound_k / s_k`` over ``max_k max_error_k / s_k``).
    by_family : dict
        Per noise family (``"random"``, ``"sinusoid"``, ``"sign"``): its runs' ``max_error`` per state.
    exceeded : int
        Samples after the transient with ``|e_k| > bound_k (1 + rtol)``.
    envelope_exceeded : int
        Samples at any time above the certified envelope from the run's initial error.
    left_region : int
        Runs in which the plant or the estimate left the region of the Jacobian box (no test).
    plant_left_box : int
        Runs whose plant state left the operating box.
    runs : int
    t_transient : float
        Time from which the ultimate bound is compared (:meth:`~.noise_gain.NoiseBoundDesign.transient_time`
        of the initial error, 1 %).
    sinusoids : tuple of WorstSinusoid
    seconds : float
    """

    bound: np.ndarray
    max_error: np.ndarray
    ratio: np.ndarray
    worst_relative_ratio: float
    by_family: dict
    exceeded: int
    envelope_exceeded: int
    left_region: int
    plant_left_box: int
    runs: int
    t_transient: float
    sinusoids: tuple = ()
    seconds: float = 0.0

    def to_dict(self) -> dict:
        return {"bound": self.bound.tolist(), "max_error": self.max_error.tolist(), "ratio": self.ratio.tolist(),
                "worst_relative_ratio": self.worst_relative_ratio,
                "by_family": {k: v.tolist() for k, v in self.by_family.items()}, "exceeded": self.exceeded,
                "envelope_exceeded": self.envelope_exceeded, "left_region": self.left_region,
                "plant_left_box": self.plant_left_box, "runs": self.runs, "t_transient": self.t_transient,
                "sinusoids": [s.to_dict() for s in self.sinusoids], "seconds": self.seconds}


def _left_region(design: NoiseBoundDesign, run: NoiseRun) -> np.ndarray:
    """Per run: did the plant or the estimate take an argument of a nonlinear function out of its interval?"""
    system, bounds = design.system, design.bounds
    out = np.zeros(run.x.shape[1], dtype=bool)
    rows = [(system.E[i], b.interval) for i, b in enumerate(bounds.f)]
    rows += [(system.C[j], b.interval) for j, b in enumerate(bounds.h) if b.method != "linear"]
    for row, (lo, hi) in rows:
        for X in (run.x, run.x_hat):
            z = X @ row
            out |= np.any((z < lo) | (z > hi), axis=0)
    return out


def check_noise_bound(design: NoiseBoundDesign, drive: Drive, x0, *, e0=None, t_final: float | None = None,
                      dt: float | None = None, random_runs: int = 8, hold_steps: int = 10, seed: int = 0,
                      families=("random", "sinusoid", "sign"), sin_factors=(0.8, 1.0, 1.25),
                      rtol: float = 1e-6) -> NoiseSimulationCheck:
    """Simulate ``design`` under bounded noises (module docstring) and compare the errors with its bound.

    Parameters
    ----------
    design : NoiseBoundDesign
        A feasible design (its ``system`` has no ``g(y, u)``).
    drive : callable
        ``drive(t, X) -> (R, k)``: the plant's inputs (keep the plant in the design's region).
    x0 : (n,) array
        Plant initial state (every run).
    e0 : (n,) array, optional
        Initial error ``x - x^`` (default zero).
    t_final : float, optional
        Horizon (default: the transient time of ``e0`` plus the longer of 10 time constants
        ``1/alpha`` of ``V`` and five periods of the slowest worst sinusoid that is not constant).
    dt : float, optional
        Step (default: 0.1 over the largest eigenvalue modulus of the frozen vertex systems).
    random_runs : int, default 8
        Runs of random noise.
    hold_steps : int, default 10
        Steps each value of the random noise is held (its switches stay on the step grid).
    seed : int
        Seed of the first random run (run ``r`` has seed ``seed + r``).
    families : tuple of str
        Noise families to run: ``"random"``, ``"sinusoid"`` (per state, one run at each of
        ``sin_factors`` times the worst frequency; one constant run when that frequency is 0),
        ``"sign"`` (one run per state).
    sin_factors : tuple of float, default (0.8, 1.0, 1.25)
        Frequencies of the sinusoid runs relative to the worst one.
    rtol : float, default 1e-6
        Relative slack of the comparison with the bound (integration error).

    Returns
    -------
    NoiseSimulationCheck
    """
    t_start = time.perf_counter()
    if not design.feasible:
        raise ModelError("design", "a feasible noise-bound design", f"status {design.status}")
    system = design.system
    n = system.n
    x0 = np.asarray(x0, dtype=float).reshape(n)
    e0 = np.zeros(n) if e0 is None else np.asarray(e0, dtype=float).reshape(n)
    systems, _ = _model_vertices(design)
    fast = max(float(np.abs(np.linalg.eigvals(A)).max()) for A, _ in systems)
    slow = min(float(-np.linalg.eigvals(A).real.max()) for A, _ in systems)
    dt = (0.1 / fast) if dt is None else float(dt)
    sins = worst_sinusoids(design)
    t_tr = design.transient_time(e0, 0.01)
    if t_final is None:
        periods = [2 * math.pi / s.omega for s in sins if s.omega > 0]
        t_final = t_tr + max(10.0 / design.alpha, 5 * max(periods, default=0.0))
    hold = max(int(hold_steps), 1) * dt
    batches: list[tuple[str, Noise, int]] = []
    if "random" in families:
        batches.append(("random", random_noise(design.noise, hold, seed + np.arange(random_runs)), random_runs))
    if "sinusoid" in families:
        aims = [(s.omega * f, s.phases) for s in sins for f in (sin_factors if s.omega > 0 else (1.0,))]
        batches.append(("sinusoid", sinusoid_noise(design.noise, [w for w, _ in aims], np.array([ph for _, ph in aims])),
                        len(aims)))
    if "sign" in families:
        period = 10.0 / max(slow, 1e-12) if slow > 0 else 10.0 / design.alpha
        batches.append(("sign", sign_noise(design, [s.state for s in sins], [s.vertex for s in sins], period, dt), n))
    R = sum(b[2] for b in batches)

    def noise(t: float) -> np.ndarray:
        return np.vstack([b[1](t) for b in batches])

    X0 = np.tile(x0, (R, 1))
    run = simulate_noisy_observer(system, design.L, X0, X0 - e0[None, :], drive, noise, t_final, dt)
    err = np.abs(run.error)  # (N + 1, R, n)
    after = run.t >= t_tr
    env = design.envelope(run.t, e0)  # (N + 1, n)
    left = _left_region(design, run)
    lo, hi = system.box_lower, system.box_upper
    out_box = np.any((run.x < lo - 1e-12) | (run.x > hi + 1e-12), axis=(0, 2))
    valid = ~left
    max_err = err[after][:, valid, :].max(axis=(0, 1)) if np.any(valid) else np.full(n, np.nan)
    by_family, r0 = {}, 0
    for name, _, k in batches:
        sel = np.zeros(R, dtype=bool)
        sel[r0:r0 + k] = True
        sel &= valid
        by_family[name] = err[after][:, sel, :].max(axis=(0, 1)) if np.any(sel) else np.full(n, np.nan)
        r0 += k
    exceeded = int(np.sum(err[after][:, valid, :] > design.bound[None, None, :] * (1 + rtol)))
    env_exc = int(np.sum(err[:, valid, :] > env[:, None, :] * (1 + rtol)))
    ref = design.reference
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = design.bound / max_err
        wrr = float(np.max(design.bound / ref) / np.max(max_err / ref))
    return NoiseSimulationCheck(design.bound.copy(), max_err, ratio, wrr, by_family, exceeded, env_exc,
                                int(left.sum()), int(out_box.sum()), R, float(t_tr), sins,
                                time.perf_counter() - t_start)

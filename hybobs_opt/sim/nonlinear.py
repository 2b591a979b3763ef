"""Simulation of scalar-nonlinear systems (paper 004, eqs. 1-3) with an adaptive ODE solver."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp

from .._validate import as_positive
from ..errors import ModelError
from ..limits import check_samples, sample_count
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from ..tolerances import NONLINEAR_ODE_ATOL, NONLINEAR_ODE_RTOL
from .hybrid import SimulationError
from .trace import Trace

InputFn = Callable[[float], np.ndarray]


def simulate_nonlinear(
    system: ScalarNonlinearSystem,
    x0: Sequence[float],
    u_fn: InputFn | None,
    t_final: float,
    dt: float,
    t0: float = 0.0,
    *,
    breakpoints: Sequence[float] = (),
) -> Trace:
    """Simulate ``x' = A x + F f(E x) + B u + g(y, u)`` (eq. 1, paper 004) and sample it every ``dt``.

    The flow is integrated with ``RK45`` (tolerances
    :data:`~hybobs_opt.tolerances.NONLINEAR_ODE_RTOL` / ``NONLINEAR_ODE_ATOL``), restarted at every
    breakpoint so a piecewise-constant input does not degrade the step control, and read on the
    grid ``t0, t0 + dt, ...`` from the solver's dense output.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    x0 : (n,) array
        Initial state.
    u_fn : callable or None
        ``u_fn(t) -> (m,)`` input; ``None`` for the zero input.
    t_final : float
        Final time (seconds); the last sample is the last grid point not after ``t_final``.
    dt : float
        Sampling period of the returned trace.
    t0 : float
        Initial time.
    breakpoints : sequence of float
        Times where ``u_fn`` is discontinuous.  Between two breakpoints the flow uses the input
        of the open interval, whichever side ``u_fn`` assigns the breakpoint itself to.

    Returns
    -------
    Trace
        ``q = 0`` throughout (one location: the class has no discrete state), ``y = h(C x)``.

    Raises
    ------
    ModelError
        Bad ``x0``, times, or an input of the wrong shape / non-finite.
    SimulationError
        The solver failed or the state became non-finite.

    See Also
    --------
    hybobs_opt.systems.ScalarNonlinearSystem : the system class (eq. 1 of paper 004).
    simulate_system : the same with defaults by name.

    Examples
    --------
    The tracked vehicle of paper 004 (eqs. 56-59) driving straight at 10 m/s for one second:

    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.sim import simulate_nonlinear
    >>> vehicle = get_example("vehicle_tracking").build()
    >>> vehicle.state_names
    ('X', 'Y', 'psi', 'delta_f')
    >>> trace = simulate_nonlinear(vehicle, [0.0, 0.0, 0.0, 0.0], lambda t: [0.0], 1.0, 0.01)
    >>> trace.x.shape, trace.x[-1].round(3)
    ((101, 4), array([10.,  0.,  0.,  0.]))
    """
    if not isinstance(system, ScalarNonlinearSystem):
        raise ModelError("system", "a ScalarNonlinearSystem", type(system).__name__)
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (system.n,):
        raise ModelError("x0", f"a state of length {system.n}", f"shape {x0.shape}")
    if not np.all(np.isfinite(x0)):
        raise ModelError("x0", "finite entries", f"{x0.tolist()}")
    if not (np.isfinite(t0) and np.isfinite(t_final) and t_final > t0):
        raise ModelError("t_final", f"a finite time greater than t0 = {t0}", repr(t_final))
    dt = as_positive(dt, "dt", "a positive sampling period")

    m = system.m
    if u_fn is None:
        zero = np.zeros(m)
        ufn: InputFn = lambda t: zero  # noqa: E731
    elif callable(u_fn):
        def ufn(t: float) -> np.ndarray:
            return np.asarray(u_fn(t), dtype=float).reshape(-1) if m else np.zeros(0)
        probe = np.asarray(u_fn(t0), dtype=float).reshape(-1) if m else np.zeros(0)
        if probe.shape != (m,):
            raise ModelError("u_fn", f"a callable u_fn(t) returning {m} inputs", f"shape {probe.shape}")
    else:
        raise ModelError("u_fn", "a callable u_fn(t) -> (m,) or None", type(u_fn).__name__)

    check_samples(sample_count(t_final, dt, t0), "t_final / dt", f"t_final - t0 = {t_final - t0:g} at dt = {dt:g}")
    # The 1e-9 guards against t_final/dt landing a rounding error short of an integer.
    grid = t0 + dt * np.arange(int(np.floor((t_final - t0) / dt + 1e-9)) + 1)
    stops = [float(t0)] + sorted({float(b) for b in breakpoints if t0 < b < grid[-1]}) + [float(grid[-1])]
    xs = np.full((grid.size, system.n), np.nan)
    x = x0.copy()

    for a, b in zip(stops[:-1], stops[1:]):
        if b <= a:
            continue
        # The solver evaluates the flow at the segment's end points, where a piecewise-constant
        # input already has its next (or previous) value: read u strictly inside the segment.
        lo_t, hi_t = np.nextafter(a, b), np.nextafter(b, a)

        def rhs(t: float, xx: np.ndarray, lo_t=lo_t, hi_t=hi_t) -> np.ndarray:
            return system.rhs(xx, ufn(min(max(t, lo_t), hi_t)))

        sol = solve_ivp(rhs, (a, b), x, method="RK45", rtol=NONLINEAR_ODE_RTOL, atol=NONLINEAR_ODE_ATOL,
                        dense_output=True)
        if sol.status != 0:
            raise SimulationError(f"ODE solver failed on [{a:.6g}, {b:.6g}]: {sol.message}")
        mask = (grid >= a) & (grid <= b)
        xs[mask] = sol.sol(grid[mask]).T
        x = sol.y[:, -1].copy()
        if not np.all(np.isfinite(x)):
            raise SimulationError(f"state became non-finite before t = {b:.6g}")

    us = np.array([ufn(t) for t in grid]).reshape(grid.size, m)
    if not np.all(np.isfinite(us)):
        raise ModelError("u_fn", "finite inputs on the sampling grid", "NaN or Inf")
    ys = system.output(xs)
    return Trace(grid, xs, np.zeros(grid.size, dtype=int), us, ys, system.state_names, system.input_names,
                 system.output_names)

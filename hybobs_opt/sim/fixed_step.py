"""Fixed-step integration for discontinuous right-hand sides (sliding-mode observers).

Adaptive ODE solvers stall on ``sign(.)`` terms (they keep shrinking the step at every sign
change); a fixed step reproduces the chattering of a sampled implementation instead, which is
what the sliding-mode observers of paper 001 are meant to run with.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .._validate import as_positive
from ..errors import ModelError

RHS = Callable[[float, np.ndarray], np.ndarray]

_METHODS = ("euler", "heun", "rk4")


def integrate_fixed_step(rhs: RHS, x0, t0: float, t_final: float, dt: float, method: str = "rk4") -> tuple[np.ndarray, np.ndarray]:
    """Integrate ``x' = rhs(t, x)`` with a fixed step.

    Parameters
    ----------
    rhs : callable
        ``rhs(t, x) -> dx`` (may be discontinuous in ``x``).
    x0 : (n,) array
    t0, t_final, dt : float
        Time span and step.
    method : {"euler", "heun", "rk4"}

    Returns
    -------
    t : (N,) array
    x : (N, n) array

    See Also
    --------
    simulate_hybrid_fixed_step : the same schemes on an automaton.
    scipy.integrate.solve_ivp : adaptive steps for smooth flows.

    Examples
    --------
    ``x' = -x`` from 1 over one second with RK4: the error to ``exp(-1)`` is of order ``dt^4``.

    >>> import numpy as np
    >>> from hybobs_opt.sim import integrate_fixed_step
    >>> t, x = integrate_fixed_step(lambda t, x: -x, np.array([1.0]), 0.0, 1.0, 0.1)
    >>> t.shape, x.shape
    ((11,), (11, 1))
    >>> bool(abs(x[-1, 0] - np.exp(-1.0)) < 1e-6)
    True
    """
    if method not in _METHODS:
        raise ModelError("method", f"one of {_METHODS}", repr(method))
    dt = as_positive(dt, "dt", "a positive step")
    if not (np.isfinite(t_final) and t_final > t0):
        raise ModelError("t_final", f"a finite time greater than t0 = {t0}", repr(t_final))
    n_steps = int(np.floor((t_final - t0) / dt + 1e-9))
    x = np.asarray(x0, dtype=float).copy()
    ts = t0 + dt * np.arange(n_steps + 1)
    xs = np.empty((n_steps + 1, x.size))
    xs[0] = x
    for k in range(n_steps):
        t = ts[k]
        if method == "euler":
            x = x + dt * np.asarray(rhs(t, x), dtype=float)
        elif method == "heun":
            k1 = np.asarray(rhs(t, x), dtype=float)
            k2 = np.asarray(rhs(t + dt, x + dt * k1), dtype=float)
            x = x + 0.5 * dt * (k1 + k2)
        else:
            k1 = np.asarray(rhs(t, x), dtype=float)
            k2 = np.asarray(rhs(t + dt / 2, x + dt / 2 * k1), dtype=float)
            k3 = np.asarray(rhs(t + dt / 2, x + dt / 2 * k2), dtype=float)
            k4 = np.asarray(rhs(t + dt, x + dt * k3), dtype=float)
            x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        xs[k + 1] = x
    return ts, xs


def simulate_hybrid_fixed_step(automaton, x0, t_final: float, *, dt: float, u=None, method: str = "rk4", t0: float = 0.0):
    """Fixed-step simulation of an automaton whose location is a function of the state.

    At every step the location is re-evaluated with ``automaton.location_of(x, u)`` (the
    state-dependent switching of paper 001), so a trajectory that chatters on a switching
    surface is reproduced as a sampled implementation would see it.

    Parameters
    ----------
    automaton : HybridAutomaton
        The automaton; its location is ``location_of(x, u)`` at every step.
    x0 : (n,) array_like
        Initial state.
    t_final : float
        Final time (greater than ``t0``).
    dt : float
        Fixed integration step, also the sample time of the trace.
    u : (m,) array_like or callable, optional
        Constant input, or ``u(t) -> (m,)``; ``None`` means zeros.
    method : {"euler", "heun", "rk4"}, default "rk4"
        Integration scheme (:func:`integrate_fixed_step`).
    t0 : float, default 0.0
        Initial time.

    Returns
    -------
    Trace

    See Also
    --------
    integrate_fixed_step : the integration schemes.
    simulate_hybrid : event location with adaptive steps.

    Examples
    --------
    The triangular system of paper 001 (Example 2), whose location is the sign of ``x2``:

    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.sim import simulate_hybrid_fixed_step
    >>> system = get_example("triangular").build()
    >>> trace = simulate_hybrid_fixed_step(system, [1.0, 0.5, 0.0], 1.0, dt=0.01)
    >>> trace.x.shape, trace.x[-1].round(3)
    ((101, 3), array([1.555, 0.72 , 0.878]))
    """
    from .trace import Trace

    m = automaton.m
    if u is None:
        ufn = lambda t: np.zeros(m)  # noqa: E731
    elif callable(u):
        ufn = lambda t: np.atleast_1d(np.asarray(u(t), dtype=float))  # noqa: E731
    else:
        const = np.atleast_1d(np.asarray(u, dtype=float))
        ufn = lambda t: const  # noqa: E731

    def rhs(t, x):
        uu = ufn(t)
        return automaton.flow(automaton.location_of(x, uu), x, uu)

    ts, xs = integrate_fixed_step(rhs, x0, t0, t_final, dt, method)
    us = np.array([ufn(t) for t in ts]).reshape(ts.size, m)
    qs = np.array([automaton.location_of(xs[k], us[k]) for k in range(ts.size)])
    ys = np.array([automaton.output(qs[k], xs[k], us[k]) for k in range(ts.size)]).reshape(ts.size, automaton.p)
    events = [
        {"t": float(ts[k]), "kind": "location change", "from": int(qs[k - 1]), "to": int(qs[k]), "x": xs[k].tolist()}
        for k in range(1, ts.size)
        if qs[k] != qs[k - 1]
    ]
    return Trace(ts, xs, qs, us, ys, automaton.state_names, automaton.input_names, automaton.output_names,
                 automaton.location_names, events)

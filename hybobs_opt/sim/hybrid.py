"""Continuous simulation of hybrid automata with event location (scipy ``solve_ivp`` events)."""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
from scipy.integrate import solve_ivp

from .._validate import as_positive
from ..errors import HybobsError, ModelError
from ..limits import check_samples, sample_count
from ..systems.hybrid import HybridAutomaton
from ..tolerances import (EVENT_MEMBERSHIP_RTOL, EVENT_OFFSET_RTOL, HYBRID_ENTRY_PROBE, HYBRID_ODE_ATOL,
                          HYBRID_ODE_RTOL, HYBRID_TIME_EPS, SEGMENT_END_RTOL)
from .trace import Trace

InputFn = Callable[[float], np.ndarray]


class SimulationError(HybobsError):
    """The simulation could not continue (Zeno behaviour, state left every invariant).

    Parameters
    ----------
    *args
        The message, as for :class:`HybobsError`.
    **kwargs
        None accepted (:class:`Exception` takes no keyword arguments).

    See Also
    --------
    simulate_hybrid : raises it on a Zeno execution or a state outside every invariant.
    hybobs_opt.HybobsError : the base class.

    Examples
    --------
    >>> from hybobs_opt import HybobsError
    >>> from hybobs_opt.sim import SimulationError
    >>> issubclass(SimulationError, HybobsError)
    True
    >>> try:
    ...     raise SimulationError("more than 1000 events before t = 0.2: Zeno execution?")
    ... except HybobsError as exc:
    ...     print(type(exc).__name__, exc)
    SimulationError more than 1000 events before t = 0.2: Zeno execution?
    """


def _input_fn(automaton: HybridAutomaton, u) -> InputFn:
    if u is None:
        zero = np.zeros(automaton.m)
        return lambda t: zero
    if callable(u):
        return lambda t: np.atleast_1d(np.asarray(u(t), dtype=float))
    const = np.atleast_1d(np.asarray(u, dtype=float))
    if const.shape != (automaton.m,):
        raise ModelError("u", f"a callable u(t) or a constant input of length {automaton.m}", f"shape {const.shape}")
    return lambda t: const


def simulate_hybrid(
    automaton: HybridAutomaton,
    x0: Sequence[float],
    t_final: float,
    *,
    u=None,
    q0: int | None = None,
    dt: float = 1e-3,
    breakpoints: Sequence[float] = (),
    max_events: int = 10_000,
    t0: float = 0.0,
) -> Trace:
    """Simulate ``automaton`` from ``x0`` on ``[t0, t_final]`` and sample the result every ``dt``.

    Between events the location's flow is integrated with an explicit Runge-Kutta method
    (``RK45``, tolerances :data:`~hybobs_opt.tolerances.HYBRID_ODE_RTOL`,
    :data:`~hybobs_opt.tolerances.HYBRID_ODE_ATOL`).  An event is the state leaving
    the current location's invariant (one terminal event function per invariant row,
    ``a_k' z - b_k`` crossing zero upwards); the next location is chosen among the current
    location's successors in the location graph, by edge guard and target invariant, and the
    edge's reset is applied.

    Parameters
    ----------
    automaton : HybridAutomaton
    x0 : (n,) array
        Initial state.
    t_final : float
        Final time (seconds).
    u : callable or array, optional
        Input signal ``u(t)`` or a constant input.
    q0 : int, optional
        Initial location (default: the first whose invariant contains ``x0``).
    dt : float
        Output sampling period.
    breakpoints : sequence of float
        Times where ``u`` is discontinuous (the integration restarts there).
    max_events : int
        Guard against Zeno executions.
    t0 : float
        Initial time (``u`` is evaluated from ``t0``).

    Returns
    -------
    Trace
        Samples on ``t0, t0 + dt, ...``, with ``events`` listing every location change
        (``t``, ``from``, ``to``, ``x``).

    See Also
    --------
    simulate_hybrid_fixed_step : fixed steps, location re-evaluated from the state.
    hybobs_opt.systems.HybridAutomaton : the automaton.

    Examples
    --------
    The driveline of paper 000 under a constant -10 N m torque: the backlash makes it change
    location twice in the first 0.2 s.

    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.sim import simulate_hybrid
    >>> driveline = get_example("driveline").build()
    >>> trace = simulate_hybrid(driveline, [0.025, 0.0, 0.0], 1.0, u=[-10.0])
    >>> trace.x.shape                                    # samples every dt = 1 ms
    (1001, 3)
    >>> [(round(e["t"], 3), e["from"], e["to"]) for e in trace.events[:2]]
    [(0.102, 2, 1), (0.189, 1, 0)]
    """
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (automaton.n,):
        raise ModelError("x0", f"a state of length {automaton.n}", f"shape {x0.shape}")
    if not (np.isfinite(t_final) and t_final > t0):
        raise ModelError("t_final", f"a finite time greater than t0 = {t0}", repr(t_final))
    dt = as_positive(dt, "dt", "a positive sampling period")
    ufn = _input_fn(automaton, u)
    q = automaton.location_of(x0, ufn(t0)) if q0 is None else int(q0)
    if not 0 <= q < automaton.n_locations:
        raise ModelError("q0", f"a location index in 0..{automaton.n_locations - 1}", repr(q0))

    check_samples(sample_count(t_final, dt, t0), "t_final / dt", f"t_final - t0 = {t_final - t0:g} at dt = {dt:g}")
    grid = t0 + dt * np.arange(int(np.floor((t_final - t0) / dt + 1e-9)) + 1)
    stops = sorted({float(b) for b in breakpoints if t0 < b < t_final} | {float(t_final)})
    xs = np.full((grid.size, automaton.n), np.nan)
    qs = np.zeros(grid.size, dtype=int)
    events: list[dict] = []
    t, x = float(t0), x0.copy()
    n_inv = automaton.locations

    while t < t_final - HYBRID_TIME_EPS:
        if len(events) > max_events:
            raise SimulationError(f"more than {max_events} location changes before t = {t:.6g}: Zeno behaviour?")
        t_stop = next(s for s in stops if s > t + HYBRID_TIME_EPS)
        inv = n_inv[q].invariant
        lifted = inv.dim != automaton.n

        # Inside a segment the input is read strictly before its end: at a breakpoint the
        # solver's last stage would otherwise see the next piece of a piecewise-constant input.
        t_last = np.nextafter(t_stop, -np.inf)

        def rhs(tt, xx, q=q, t_last=t_last):
            return automaton.flow(q, xx, ufn(min(tt, t_last)))

        # Every row stays armed.  A row already active at the segment start (the state sits on
        # the face it just entered through) gets its threshold moved outwards by the membership
        # slack, so the start point does not fire at once but a real exit through that same
        # face still does.
        z0 = np.concatenate([x, ufn(t)]) if lifted else x
        active = inv.A @ z0 - inv.b
        offsets = np.where(active > -EVENT_OFFSET_RTOL * (1 + np.abs(inv.b)), EVENT_OFFSET_RTOL * (1 + np.abs(inv.b)), 0.0)
        # A row the state already lies beyond by more than its offset (the jump admits states
        # within EVENT_MEMBERSHIP_RTOL of an invariant) while the flow carries it further out:
        # its event, an upward crossing, would never fire.  The state leaves the location at once
        # (counted as an event, so that a Zeno execution meets max_events).
        outside = np.nonzero(active - offsets > 0.0)[0]
        if outside.size and np.any(inv.A[outside, :automaton.n] @ automaton.flow(q, x, ufn(t)) > 0.0):
            q, x = _jump_recorded(automaton, q, x, ufn(t), t, events)
            continue

        def make_event(k, inv=inv, lifted=lifted, t_last=t_last, offsets=offsets):
            a, b, offset = inv.A[k], inv.b[k], float(offsets[k])

            def ev(tt, xx):
                z = np.concatenate([xx, ufn(min(tt, t_last))]) if lifted else xx
                return float(a @ z - b - offset)

            ev.terminal = True
            ev.direction = 1.0
            return ev

        ev_fns = [make_event(k) for k in range(inv.n_constraints)]
        sol = solve_ivp(rhs, (t, t_stop), x, method="RK45", rtol=HYBRID_ODE_RTOL, atol=HYBRID_ODE_ATOL, events=ev_fns or None, dense_output=True)
        if sol.status == -1:
            raise SimulationError(f"ODE solver failed in location {n_inv[q].name} at t = {t:.6g}: {sol.message}")
        t_end = float(sol.t[-1])
        mask = (grid >= t - HYBRID_TIME_EPS) & (grid <= t_end + HYBRID_TIME_EPS) & np.isnan(xs[:, 0])
        if np.any(mask):
            xs[mask] = sol.sol(grid[mask]).T
            qs[mask] = q
        x = sol.y[:, -1].copy()
        t = t_end
        if sol.status != 1 and not automaton.in_invariant(q, x, ufn(min(t, t_last)), rtol=SEGMENT_END_RTOL):
            raise SimulationError(
                f"state {x.tolist()} at t = {t:.6g} left location {n_inv[q].name!r} without an event: "
                "the invariant is crossed twice within one solver step; reduce the horizon between breakpoints"
            )
        if sol.status == 1:  # an invariant row became active: jump
            q, x = _jump_recorded(automaton, q, x, ufn(t), t, events)

    ys = np.array([automaton.output(qs[k], xs[k], ufn(grid[k])) for k in range(grid.size)]).reshape(grid.size, automaton.p)
    us = np.array([ufn(tk) for tk in grid]).reshape(grid.size, automaton.m)
    return Trace(grid, xs, qs, us, ys, automaton.state_names, automaton.input_names, automaton.output_names,
                 automaton.location_names, events)


def _jump_recorded(automaton: HybridAutomaton, q: int, x: np.ndarray, u: np.ndarray, t: float,
                   events: list[dict]) -> tuple[int, np.ndarray]:
    """:func:`_jump` at time ``t``, the location change appended to ``events``."""
    q_new, x_new = _jump(automaton, q, x, u)
    events.append({"t": t, "kind": "location change", "from": q, "to": q_new, "x": x_new.tolist()})
    return q_new, x_new


def _jump(automaton: HybridAutomaton, q: int, x: np.ndarray, u: np.ndarray) -> tuple[int, np.ndarray]:
    """Pick the successor location of ``q`` at a boundary state ``x`` and apply the edge reset."""
    candidates = []
    for e in automaton.edges:
        if e.source != q:
            continue
        if e.guard is not None and not e.guard.contains(x, EVENT_MEMBERSHIP_RTOL):
            continue
        x_new = x if e.reset is None else e.reset[0] @ x + e.reset[1]
        if automaton.in_invariant(e.target, x_new, u, rtol=EVENT_MEMBERSHIP_RTOL):
            candidates.append((e.target, x_new))
    if not candidates:
        raise SimulationError(
            f"state {x.tolist()} left the invariant of location {automaton.locations[q].name!r} "
            "and no edge of the location graph leads to a location containing it"
        )
    if len(candidates) > 1:
        # Several targets on a shared boundary: take the one the flow moves into.
        def inside_after(target_x):
            target, xn = target_x
            probe = xn + HYBRID_ENTRY_PROBE * automaton.flow(target, xn, u)
            return automaton.in_invariant(target, probe, u, rtol=0.0)
        inside = [c for c in candidates if inside_after(c)]
        candidates = inside or candidates
    return candidates[0]

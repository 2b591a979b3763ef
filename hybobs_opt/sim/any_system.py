"""One entry point that simulates a system of any of the four classes from an initial state under a
constant input (what ``hybobs simulate SYSTEM`` and ``hybobs report SYSTEM`` run for a user's model)."""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np

from ..defaults import SIM_PWA_STEPS, SIM_T_FINAL
from ..errors import ModelError
from ..limits import check_samples
from .constant_drift import simulate_constant_drift
from .hybrid import simulate_hybrid
from .input_table import InputTable, check_sample_times
from .nonlinear import simulate_nonlinear
from .pwa import simulate_pwa
from .trace import Trace


def _assign(values: Mapping[str, float] | None, names, default: np.ndarray, field: str) -> np.ndarray:
    out = np.array(default, dtype=float).reshape(len(names))
    for key, value in (values or {}).items():
        if key not in names:
            raise ModelError(field, f"names among {list(names)}", repr(key))
        if not math.isfinite(float(value)):
            raise ModelError(f"{field}[{key}]", "a finite number", repr(value))
        out[list(names).index(key)] = float(value)
    return out


def _centre(poly, size: int) -> np.ndarray:
    if poly is None or size == 0:
        return np.zeros(size)
    lo, hi = poly.bounding_box()
    return (lo + hi) / 2.0


def simulate_system(system, *, x0: Mapping[str, float] | None = None, u: Mapping[str, float] | None = None,
                    q0: int | None = None, steps: int | None = None, t_final: float | None = None,
                    dt: float | None = None, inputs: InputTable | None = None) -> Trace:
    """Simulate ``system`` from ``x0`` (by state name; others at the centre of the state bounds)
    under the constant input ``u`` (by input name; others at the centre of the input bounds), or
    under the time-varying ``inputs`` (:class:`~hybobs_opt.sim.input_table.InputTable`).

    PWA systems run ``steps`` samples (or ``t_final / Ts``; default :data:`~hybobs_opt.defaults.SIM_PWA_STEPS`) and
    stop where the trajectory leaves ``X x U``; continuous-time systems run to ``t_final``
    (default :data:`~hybobs_opt.defaults.SIM_T_FINAL`) with output sample time ``dt``.  A constant-drift system
    starts in mode ``q0`` (default 1) from ``x0`` (default all ones).

    Parameters
    ----------
    system : PWASystem, HybridAutomaton, ConstantDriftSystem or ScalarNonlinearSystem
        The system to simulate.
    x0 : mapping of str to float, optional
        Initial values by state name; the others start at the centre of the state bounds (all ones
        for a constant-drift system).
    u : mapping of str to float, optional
        Constant input values by input name; the others sit at the centre of the input bounds.
        Refused for a constant-drift system.
    q0 : int, optional
        Initial mode of a constant-drift system (``1..Q``, default 1) or 0-based location of a
        hybrid automaton (default: the location containing ``x0``); not used by other systems.
    steps : int, optional
        Number of samples of a PWA system (refused for other systems).
    t_final : float, optional
        Final time (positive); for a PWA system it needs ``Ts`` and gives ``round(t_final / Ts)``
        samples.
    dt : float, optional
        Output sample time of a continuous-time system (default ``1e-2`` for a hybrid automaton,
        ``t_final / 1000`` for a scalar-nonlinear one, the event times only for a constant-drift one).
    inputs : InputTable, optional
        Time-varying inputs instead of ``u``: a PWA system takes one row per sample (the run has as
        many samples as rows; ``steps`` and ``t_final`` are refused); a continuous-time system holds
        each row from its time to the next one and runs to ``t_final`` (default: the last row's
        time, at most that).  Refused for a constant-drift system (no inputs).

    Returns
    -------
    Trace
        The simulated trajectory.

    Raises
    ------
    ModelError
        On a system of another class, a name that is not one of the system's, or a non-positive or
        misplaced ``steps``, ``t_final`` or ``dt``.

    See Also
    --------
    simulate_pwa, simulate_hybrid, simulate_constant_drift, simulate_nonlinear : what it calls.

    Examples
    --------
    One call for every system class; states and inputs by name, the others at the centre of their
    bounds:

    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.sim import simulate_system
    >>> plant = get_example("powertrain3").build()
    >>> trace = simulate_system(plant, x0={"theta": 0.06, "omega_m": 39.0, "omega_l": 3.25}, u={"T_m": 40.0}, steps=500)
    >>> trace.x.shape
    (500, 3)
    >>> simulate_system(plant, x0={"omega_m": 39.0}, u={"T_m": 40.0}, steps=500).x.shape  # left X x U early
    (82, 3)
    >>> server = simulate_system(get_example("switching_server").build(), t_final=10.0)
    >>> server.events[0]["kind"], server.events[0]["t"]
    ('mode transition', 1.0)
    """
    kind = type(system).__name__
    if inputs is not None:
        _check_inputs(system, kind, inputs, u, steps, t_final)
        if kind != "PWASystem" and t_final is None:
            t_final = float(inputs.t[-1])
    if steps is not None and (kind != "PWASystem" or isinstance(steps, bool) or int(steps) != steps or steps < 1):
        raise ModelError("steps", "a positive number of samples, for a PWA system (others take t_final)", repr(steps))
    if dt is not None and not (math.isfinite(dt) and dt > 0):
        raise ModelError("dt", "a positive finite sample time", repr(dt))
    if t_final is not None and not (math.isfinite(t_final) and t_final > 0):
        raise ModelError("t_final", "a positive finite time", repr(t_final))
    if kind == "ConstantDriftSystem":
        if u:
            raise ModelError("u", "no input (a constant-drift system has none)", f"{dict(u)}")
        xs = _assign(x0, system.state_names, np.ones(system.n_states), "x0")
        return simulate_constant_drift(system, xs, 1 if q0 is None else q0, 0.0, t_final or SIM_T_FINAL, dt)
    if kind not in ("PWASystem", "HybridAutomaton", "ScalarNonlinearSystem"):
        raise ModelError("system", "a PWASystem, HybridAutomaton, ConstantDriftSystem or ScalarNonlinearSystem", kind)
    bounds = system.box if kind == "ScalarNonlinearSystem" else system.state_bounds
    xs = _assign(x0, system.state_names, _centre(bounds, system.n), "x0")
    us = _assign(u, system.input_names, _centre(getattr(system, "input_bounds", None), system.m), "u")
    if kind == "PWASystem":
        if t_final is not None and system.Ts is None:
            raise ModelError("t_final", "steps for a PWA system without a sampling period Ts", repr(t_final))
        if steps is not None:
            check_samples(steps, "steps")
            n = int(steps)
        elif t_final:
            check_samples(t_final / system.Ts, "t_final", f"t_final = {t_final:g} at Ts = {system.Ts:g}")
            n = int(round(t_final / system.Ts))
            if n < 1:
                raise ModelError("t_final", f"at least one sampling period Ts = {system.Ts:g}", repr(t_final))
        else:
            n = SIM_PWA_STEPS
        if inputs is not None:
            return simulate_pwa(system, xs, inputs.U, on_blocked="stop")
        return simulate_pwa(system, xs, np.tile(us, (n, 1)), on_blocked="stop")
    if kind == "HybridAutomaton":
        if t_final is not None and t_final < (dt or 1e-2):
            raise ModelError("t_final", f"at least one sample period dt = {dt or 1e-2:g}", repr(t_final))
        if inputs is not None:
            return simulate_hybrid(system, xs, t_final, u=inputs, q0=q0, dt=dt or 1e-2, breakpoints=inputs.breakpoints)
        return simulate_hybrid(system, xs, t_final or SIM_T_FINAL, u=us, q0=q0, dt=dt or 1e-2)
    horizon = t_final or SIM_T_FINAL
    if dt is not None and horizon < dt:
        raise ModelError("t_final", f"at least one sample period dt = {dt:g}", repr(t_final))
    if inputs is not None:
        return simulate_nonlinear(system, xs, inputs, horizon, dt or horizon / 1000, breakpoints=inputs.breakpoints)
    return simulate_nonlinear(system, xs, (lambda t: us) if system.m else None, horizon, dt or horizon / 1000)


def _check_inputs(system, kind: str, inputs: InputTable, u, steps, t_final) -> None:
    """``ModelError`` unless the input table fits the system and the run's other arguments."""
    if tuple(inputs.names) != tuple(getattr(system, "input_names", ())):
        raise ModelError("inputs", f"a table of the inputs {list(getattr(system, 'input_names', ()))}",
                         f"{list(inputs.names)}")
    if u:
        raise ModelError("u", "no constant input with an input table (the table gives every input)", f"{dict(u)}")
    if kind == "PWASystem":
        check_sample_times(inputs, system.Ts)
        for field, value in (("steps", steps), ("t_final", t_final)):
            if value is not None:
                raise ModelError(field, "no value with an input table (a PWA run has one sample per row)", repr(value))
        return
    if inputs.t is None:
        raise ModelError(f"{inputs.source} header", "a time column t (a continuous-time system holds each row from "
                         "its time to the next)", "no time column")
    last = float(inputs.t[-1])
    if t_final is not None and t_final > last:
        raise ModelError("t_final", f"at most the last time of the input table, {last:g} s (add a row at the final "
                         "time to hold the inputs until then)", repr(t_final))
    if t_final is None and last <= 0:
        raise ModelError(f"{inputs.source} column 't'", "a last time after 0 (the run ends at the last row's time)",
                         repr(last))

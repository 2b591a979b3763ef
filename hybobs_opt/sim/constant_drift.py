"""Exact event-time simulation of constant-drift hybrid systems (paper 003, eq. 3).

The flow in each mode is a straight line (``dx/dt = f_q``), so every event time is computed in
closed form, ``t_{k+1} = t_k + x[k_q] / (-f_q[k_q])``, and no ODE solver or zero-crossing
detection is involved: the only error is floating-point rounding of those sums.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError
from ..limits import MAX_SAMPLES, check_samples, sample_count
from .._validate import as_vector
from ..systems.constant_drift import ConstantDriftSystem
from .trace import Trace


def _scalar(value, field_name: str) -> float:
    if isinstance(value, bool):
        raise ModelError(field_name, "a finite real number", f"{value!r}")
    return float(as_vector(value, field_name, 1)[0])


def simulate_constant_drift(
    system: ConstantDriftSystem,
    x0: ArrayLike,
    q0: int,
    t0: float,
    t_final: float,
    dt: float | None = None,
) -> Trace:
    """Simulate system (3) of paper 003 exactly from ``(x0, q0)`` at ``t0`` up to ``t_final``.

    Implements the flow (3a) and jump (3b) of paper 003 with closed-form event times: in mode
    ``q`` the event happens after ``x[k_q] / (-f_q[k_q])``; there ``x0 += alpha_q`` (eq. 2) and
    ``q -> sigma(q)`` (eq. 1).

    Parameters
    ----------
    system : ConstantDriftSystem
        The hybrid system.
    x0 : (N+1,) array_like
        Initial state ``[x0, x1, ..., xN]``: non-negative, and ``x0 = 0`` unless ``q0`` is a timer
        (setup) mode (Lemma 2.7).  The paper's own convention is ``x0(0) = alpha_Q``, ``q0 = 1``,
        ``t0 = 0`` (Section 2.1).
    q0 : int
        Initial mode, numbered ``1 ... Q`` as in the paper.
    t0, t_final : float
        Start and end time, ``t0 <= t_final``.
    dt : float, optional
        If given, the trace also holds the states on the uniform grid ``t0 + i dt`` between events.

    Returns
    -------
    Trace
        Rows at ``t0``, at every event, at the grid points (if ``dt``) and at ``t_final``.  Each
        event contributes *two* rows at the same time: the state just before the jump (old
        mode) and just after it (new mode), so ``t`` is non-decreasing and linear interpolation
        between consecutive rows reproduces the trajectory exactly.  ``q`` is the mode number,
        ``y`` (one column, ``"y"``) is the output ``h_q`` (eq. 3a: ``q`` in a visible mode, else 0),
        ``u`` is empty.  ``events`` holds one dict per event with keys ``t``, ``k`` (event
        counter, 1-based from ``t0``), ``from_mode``, ``to_mode``, ``x`` (state after the reset),
        ``x_minus`` (state before it), ``visible`` (``from_mode`` in ``V``, Section 2.4),
        ``trigger`` (name of the component that reached 0), ``y`` (output after the event),
        ``kind`` (``"mode transition"``) and ``from``/``to`` (aliases of the mode keys, as in the
        other simulators' event logs).  ``location_names`` is left empty because
        ``Trace`` indexes it by ``q`` from 0 while modes here start at 1; the mode names are in
        ``system.mode_names``.

    Raises
    ------
    ModelError
        If ``system`` is not a ``ConstantDriftSystem``, ``x0``/``q0`` is not a valid state
        (wrong length, NaN/Inf, negative entry, ``x0 != 0`` outside a timer mode), the times are
        not finite or ``t_final < t0``, or ``dt`` is not positive.

    See Also
    --------
    simulate_system : the same with defaults by name.
    hybobs_opt.systems.ConstantDriftSystem : the system class.

    Examples
    --------
    The switching server of paper 003 from the paper's initial state (``x0 = alpha_1``, mode 1):

    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.sim import simulate_constant_drift
    >>> server = get_example("switching_server").build()
    >>> trace = simulate_constant_drift(server, [1.0, 0.0, 0.0], 1, 0.0, 10.0)
    >>> first = trace.events[0]
    >>> first["t"], first["from_mode"], first["to_mode"], first["trigger"]
    (1.0, 1, 2, 'x0')
    >>> [server.mode_names[q - 1] for q in (first["from_mode"], first["to_mode"])]
    ['setup type 1', 'serve type 1']
    """
    if not isinstance(system, ConstantDriftSystem):
        raise ModelError("system", "a ConstantDriftSystem", type(system).__name__)
    x = np.array(system.validate_state(x0, q0, field_name="x0", mode_field="q0"), dtype=float)
    q = int(q0)
    t = _scalar(t0, "t0")
    t_end = _scalar(t_final, "t_final")
    if t_end < t:
        raise ModelError("t_final", f"t_final >= t0 = {t}", f"{t_end}")
    grid = np.zeros(0)
    if dt is not None:
        step = _scalar(dt, "dt")
        if not step > 0:
            raise ModelError("dt", "a positive step", f"{step}")
        check_samples(sample_count(t_end, step, t), "t_final / dt", f"t_final - t0 = {t_end - t:g} at dt = {step:g}")
        m = math.floor((t_end - t) / step)
        grid = t + step * np.arange(1, m + 1)
    gi = 0  # next grid point not yet emitted

    ts: list[float] = [t]
    xs: list[np.ndarray] = [x.copy()]
    qs: list[int] = [q]
    events: list[dict[str, Any]] = []
    f = system.f
    while True:
        if len(ts) > MAX_SAMPLES:  # the events alone (their number is known only by running)
            check_samples(len(ts), "t_final", f"events and grid points up to t = {t:g} of t_final = {t_end:g}")
        ev = system._next_event(x, q)
        t_ev = t + ev.dwell
        stop = min(t_ev, t_end)
        while gi < grid.size and grid[gi] <= t:
            gi += 1
        while gi < grid.size and grid[gi] < stop:
            ts.append(float(grid[gi]))
            xs.append(x + (grid[gi] - t) * f[q - 1])
            qs.append(q)
            gi += 1
        if t_ev > t_end:
            if t_end > t:
                ts.append(t_end)
                xs.append(x + (t_end - t) * f[q - 1])
                qs.append(q)
            break
        ts.extend((t_ev, t_ev))
        xs.extend((np.array(ev.x_minus), np.array(ev.x_plus)))
        qs.extend((q, ev.to_mode))
        y_after = int(system.h[ev.to_mode - 1])
        events.append(
            {
                "t": t_ev,
                "k": len(events) + 1,
                "from_mode": q,
                "to_mode": ev.to_mode,
                "from": q,
                "to": ev.to_mode,
                "x": ev.x_plus,
                "x_minus": ev.x_minus,
                "visible": bool(ev.visible),
                "trigger": system.state_names[int(system.trigger[q - 1])],
                "y": y_after,
                "kind": "mode transition",
            }
        )
        t, x, q = t_ev, np.array(ev.x_plus), ev.to_mode

    q_arr = np.array(qs, dtype=int)
    y = system.h[q_arr - 1].astype(float).reshape(-1, 1)
    return Trace(
        t=np.array(ts),
        x=np.vstack(xs),
        q=q_arr,
        u=np.zeros((len(ts), 0)),
        y=y,
        state_names=system.state_names,
        input_names=(),
        output_names=("y",),
        events=events,
    )


__all__ = ["simulate_constant_drift"]

"""Discrete-time simulation of PWA systems (paper 002, eq. 1), batched over initial states."""

from __future__ import annotations

import numpy as np

from ..errors import ModelError
from ..geometry._reproducible import matmul as mm
from ..systems.pwa import PWASystem
from .trace import Trace


def simulate_pwa_batch(system: PWASystem, X0: np.ndarray, U: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Simulate ``K`` trajectories of eq. (1) at once.

    The time recursion is sequential, but each step is vectorised over the ``K`` trajectories:
    one membership test per mode and one matrix product per mode.

    Parameters
    ----------
    system : PWASystem
    X0 : (K, n) array
        Initial states.
    U : (K, T, m) array
        Input sequences.

    Returns
    -------
    X : (K, T + 1, n) array
        States ``x(0) ... x(T)``; rows after a blocked step are NaN.
    Q : (K, T) int array
        Modes ``i(0) ... i(T-1)``; ``-1`` where ``(x, u)`` left ``X x U`` (the evolution is blocked).
    Y : (K, T, p) array
        Outputs ``y(0) ... y(T-1)``.

    See Also
    --------
    simulate_pwa : one trajectory as a Trace.

    Examples
    --------
    Four initial states, ten steps each, in one call:

    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> from hybobs_opt.sim import simulate_pwa_batch
    >>> X0 = np.array([[0.06, 39.0, 3.25], [0.0, 10.0, 1.0], [-0.06, 5.0, 2.0], [0.01, 0.0, 0.0]])
    >>> X, Q, Y = simulate_pwa_batch(plant, X0, np.full((4, 10, 1), 40.0))
    >>> X.shape, Q.shape, Y.shape
    ((4, 11, 3), (4, 10), (4, 10, 1))
    >>> Q[:, 0]                                    # the mode of each initial state
    array([2, 1, 0, 1])
    """
    X0 = np.asarray(X0, dtype=float)
    U = np.asarray(U, dtype=float)
    if X0.ndim != 2 or X0.shape[1] != system.n:
        raise ModelError("X0", f"an array of shape (K, {system.n})", f"shape {X0.shape}")
    K = X0.shape[0]
    if U.ndim != 3 or U.shape[0] != K or U.shape[2] != system.m:
        raise ModelError("U", f"an array of shape ({K}, T, {system.m})", f"shape {U.shape}")
    T = U.shape[1]
    X = np.full((K, T + 1, system.n), np.nan)
    Y = np.full((K, T, system.p), np.nan)
    Q = np.full((K, T), -1, dtype=int)
    X[:, 0] = X0
    alive = np.ones(K, dtype=bool)
    for t in range(T):
        q = np.full(K, -1, dtype=int)
        q[alive] = system.modes_of(X[alive, t], U[alive, t])
        alive &= q >= 0
        Q[:, t] = q
        for i, mode in enumerate(system.modes):
            sel = q == i
            if not np.any(sel):
                continue
            x, u = X[sel, t], U[sel, t]
            # products in a fixed order (hybobs_opt.geometry._reproducible): the same trajectory on every CPU
            X[sel, t + 1] = mm(x, mode.A.T) + mm(u, mode.B.T) + mode.a
            Y[sel, t] = mm(x, mode.C.T) + mm(u, mode.D.T) + mode.c
    return X, Q, Y


def simulate_pwa(system: PWASystem, x0, U, *, on_blocked: str = "raise") -> Trace:
    """Simulate one trajectory of eq. (1) of paper 002.

    Parameters
    ----------
    system : PWASystem
    x0 : (n,) array
    U : (T, m) array
        Inputs ``u(0) ... u(T-1)`` (for ``m = 1`` a 1-D array is accepted).
    on_blocked : {"raise", "stop"}
        What to do when ``(x(t), u(t))`` leaves ``X x U`` (paper 002: "the evolution is blocked"):
        raise ``ModelError`` naming the time step, or return the trace up to the last valid step.

    Returns
    -------
    Trace
        ``T`` samples ``(t, x(t), i(t), u(t), y(t))`` with ``t = k Ts`` (or ``k`` if ``Ts`` is None).

    See Also
    --------
    simulate_pwa_batch : many initial states at once.
    hybobs_opt.systems.PWASystem : the system class (eq. 1 of paper 002).

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> from hybobs_opt.sim import simulate_pwa
    >>> trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((2000, 1), 40.0))
    >>> trace.x.shape, sorted(set(trace.q.tolist()))     # 2 s at Ts = 1 ms, modes visited
    ((2000, 3), [0, 1, 2])
    >>> trace.x[-1].round(2)                           # twist angle, engine and wheel speeds
    array([-0.05, 20.57,  1.7 ])
    """
    if on_blocked not in ("raise", "stop"):
        raise ModelError("on_blocked", "'raise' or 'stop'", repr(on_blocked))
    U = np.asarray(U, dtype=float)
    if U.ndim == 1 and system.m == 1:
        U = U[:, None]
    if U.ndim != 2 or U.shape[1] != system.m:
        raise ModelError("U", f"an array of shape (T, {system.m})", f"shape {U.shape}")
    if U.shape[0] == 0:
        raise ModelError("U", f"at least one input sample, shape (T >= 1, {system.m})", f"shape {U.shape}")
    x0 = np.asarray(x0, dtype=float)
    if x0.shape != (system.n,):
        raise ModelError("x0", f"a state of length {system.n}", f"shape {x0.shape}")
    X, Q, Y = simulate_pwa_batch(system, x0[None, :], U[None, :, :])
    X, Q, Y = X[0], Q[0], Y[0]
    T = U.shape[0]
    blocked = np.nonzero(Q < 0)[0]
    events = []
    if blocked.size:
        k = int(blocked[0])
        if on_blocked == "raise" or k == 0:  # blocked at once: not even one sample to return
            raise ModelError(
                f"x({k})",
                "a state-input pair inside X x U (paper 002: otherwise the evolution is blocked)",
                f"x={X[k].tolist()}, u={U[k].tolist()}",
            )
        events.append({"t": k, "kind": "blocked", "x": X[k].tolist()})
        T = k
    ts = np.arange(T) * (system.Ts if system.Ts is not None else 1.0)
    events += [
        {"t": float(ts[k]), "kind": "mode change", "from": int(Q[k - 1]), "to": int(Q[k])}
        for k in range(1, T)
        if Q[k] != Q[k - 1]
    ]
    events.sort(key=lambda e: e["t"])
    names = tuple(mode.name for mode in system.modes)
    return Trace(ts, X[:T], Q[:T], U[:T], Y[:T], system.state_names, system.input_names, system.output_names, names, events)

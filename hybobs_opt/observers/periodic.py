"""The periodic observer (16) of paper 003 at the visible events of a constant-drift system.

Its gains ``L_j`` come from :mod:`hybobs_opt.synthesis.periodic_gains` (deadbeat by the
sequential algorithm, or positive with a copositive Lyapunov function); this module runs them on
the observer contract, one step per visible event.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_flag, as_positive
from ..contract import (FALLBACK, OBSERVABLE, WARMING_UP, Estimate, Observer, TimeGuard, check_reset_keywords,
                        checked_state, checked_time, initial_mode)
from ..defaults import TIME_JUMP_FACTOR
from ..errors import ModelError
from ..synthesis.periodic_gains import PeriodicGains, analyse_gains, as_periodic_system
from ..systems.event_sampled import PeriodicSystem

class PeriodicObserver(Observer):
    """The periodic discrete-time observer (16) of paper 003, one step per visible event.

    ``step(u, y)`` takes ``u = [t]``, the time of the new visible event, and ``y = [v]``, the mode
    left at that event (``v`` in ``V``; it fixes the phase).  With the previous event at ``t_j``
    leaving ``v_j`` (phase ``j``)::

        t^ = t_j + C_j x^ + c_j,     x^ <- A_j x^ + a_j + L_j (t - t^)          (16a-b)

    The estimate is the reduced state ``x-bar`` (queues) just after the event.

    Parameters
    ----------
    periodic : PeriodicSystem
    gains : PeriodicGains or (V, N) array
    project : bool
        Return ``max(0, x^)`` (the projection of Remark 4.4) instead of ``x^``; the internal
        recursion is not projected.
    max_time_step : float, optional
        Largest time between events accepted as consistent; default ``TIME_JUMP_FACTOR`` times
        the cycle's total constant time ``sum(|c_j|)`` (a later time stamp is a jump: ``fallback``).

    See Also
    --------
    DriftObserver : The continuous-time observer between the events.
    hybobs_opt.deadbeat_gains : Deadbeat gains for it.

    Notes
    -----
    Bad samples (non-numeric, NaN, a time before the previous event, a ``v`` outside ``V``) give
    a ``fallback`` step without update.  An event of an unexpected phase (a missed event) resets
    the phase and time reference to it without a correction, flagged ``fallback``.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.observers import DriftObserver

    The switching server of paper 003 over 30 s; only "serving type 2" is visible:

    >>> example = hy.get_example("switching_server")
    >>> server = example.build()
    >>> truth = example.simulate(t_final=30.0)
    >>> gains = hy.deadbeat_gains(hy.periodic_system(server))
    >>> from hybobs_opt.observers import PeriodicObserver
    >>> periodic = hy.periodic_system(server)
    >>> obs = PeriodicObserver(periodic, gains)
    >>> visible = [e for e in truth.events if e["from_mode"] in periodic.event_modes]
    >>> obs.reset(np.zeros(periodic.n), t0=visible[0]["t"], q0=int(visible[0]["from_mode"]))
    >>> for e in visible[1:]:
    ...     est = obs.step([e["t"]], [e["from_mode"]])
    ...
    >>> np.round(est.x - np.asarray(visible[-1]["x"])[1:], 9)
    array([0., 0.])
    """

    name = "periodic (16)"
    m = 1
    p = 1

    def __init__(self, periodic: PeriodicSystem, gains: PeriodicGains | ArrayLike, *, project: bool = False,
                 max_time_step: float | None = None):
        self.ps = as_periodic_system(periodic)
        project = as_flag(project, "project")
        max_time_step = as_positive(max_time_step, "max_time_step", "a positive finite time", allow_none=True)
        self.gains = gains if isinstance(gains, PeriodicGains) else analyse_gains(periodic, self.ps.check_gains(gains, "gains"))
        self.L = self.ps.check_gains(self.gains.L, "gains")
        self.project = project
        self.n = self.ps.n
        self.state_names = self.ps.state_names
        if max_time_step is None:
            scale = float(np.sum(np.abs(self.ps.c)))
            max_time_step = TIME_JUMP_FACTOR * scale if scale > 0 else None
        self._guard = TimeGuard(max_time_step)
        self.max_time_step = self._guard.max_step
        self.reset()

    def reset(self, x0: ArrayLike | None = None, *, t0: float = 0.0, q0: int | None = None, mode: int | None = None,
              **kwargs: Any) -> None:
        """Start at a visible event: estimate ``x0`` of ``x-bar`` there, its time ``t0``, and ``q0`` = the mode it left
        (``mode``: its deprecated name).

        Parameters
        ----------
        x0 : (N,) array_like, optional
            Estimate of the queues ``x-bar`` at the start (default: zeros).
        t0 : float, default 0.0
            Time of that visible event.
        q0 : int, optional
            The mode left at that event, one of ``V`` (default ``v_1``).
        mode : int, optional
            Deprecated name of ``q0`` (a ``FutureWarning``; removed in 0.2.0).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.

        Raises
        ------
        ModelError
            For a wrong length / non-finite ``x0`` or ``t0``, or a ``q0`` not in ``V``.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        mode = initial_mode(q0, mode, "mode")
        x = np.zeros(self.n) if x0 is None else checked_state(x0, self.n, what="estimate of the queues")
        t0 = checked_time(t0, "t0")
        if mode is not None and (isinstance(mode, bool) or not isinstance(mode, (int, np.integer))):
            raise ModelError("q0", f"a mode of V = {self.ps.event_modes} (an integer)", repr(mode))
        v = self.ps.event_modes[0] if mode is None else mode
        self._j = self.ps.phase_of(v)
        self._x = x.copy()
        self._t = float(t0)
        self._guard.reset(self._t)
        self._events = 0
        self._refused = 0

    def _estimate(self, flag: str, info: dict) -> Estimate:
        x = np.maximum(self._x, 0.0) if self.project else self._x.copy()
        v = self.ps.event_modes[self._j - 1]
        mode = self.ps.system.successor(v) if self.ps.system is not None else v
        return Estimate(x, mode, flag, 0.0, info)

    def _fallback(self, u, reason: str) -> Estimate:
        # A refused sample may have been an event: the phase and the time reference of (16a) are no
        # longer known, so the next accepted event restarts them (see _step).
        self._refused += 1
        return self._estimate(FALLBACK, {"reason": reason})

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        t, v = float(u[0]), float(y[0])
        if v != round(v) or int(round(v)) not in self.ps.event_modes:
            return self._fallback(u, f"y = {v} is not a mode of V = {self.ps.event_modes}")
        v = int(round(v))
        verdict, why = self._guard.judge(t)
        if verdict == "refused":
            return self._fallback(u, f"event {why}")
        if verdict == "resumed":  # a real gap: the phase and time reference restart at this event
            self._j, self._t, self._events, self._refused = self.ps.phase_of(v), t, 0, 0
            return self._estimate(FALLBACK, {"reason": why})
        if self._refused:  # events may have been missed: (16a) would predict from a stale reference
            k, self._refused = self._refused, 0
            self._j, self._t, self._events = self.ps.phase_of(v), t, 0
            return self._estimate(FALLBACK, {"reason": f"first event after {k} refused sample(s), which may have been "
                                                       "events: the phase and time reference restart here"})
        expected = self.ps.event_modes[self._j % self.ps.period]
        if v != expected:
            self._j, self._t, self._events = self.ps.phase_of(v), t, 0
            return self._estimate(FALLBACK, {"reason": f"event leaving mode {v}, expected {expected}: phase reset"})
        i = self._j - 1
        t_hat = self._t + float(self.ps.C[i] @ self._x) + float(self.ps.c[i])
        self._x = self.ps.A[i] @ self._x + self.ps.a[i] + self.L[i] * (t - t_hat)
        self._t, self._j = t, self.ps.next_phase(self._j)
        self._events += 1
        db = self.gains.deadbeat_steps
        flag = OBSERVABLE if db is not None and self._events >= db else WARMING_UP
        return self._estimate(flag, {"predicted_t": t_hat, "innovation": t - t_hat, "phase": i + 1})


__all__ = ["PeriodicObserver"]

"""The continuous-time observer (18a-e) of paper 003 for constant-drift hybrid systems.

Paper 003 ("Observer design for piecewise affine hybrid systems with constant drift"), Section
4.2: between visible events the observer predicts with the model (3) (flow 18a, jumps 18c); when
a *predicted* visible event has not happened yet it waits in the extra mode ``v + 1/2`` with drift
``[0; L]`` (18b); at an *actual* visible event, seen as a change of the output ``y``, it jumps to
the estimate of the periodic observer (16) (18d if a visible mode is entered, 18e if one is
left)::

    xi = predicted time of this visible event,  x~ = predicted queues at xi,
    x-bar^+ = x~ + L_p (t - xi),   x0^+ = alpha of the mode left,   q^+ = the mode entered.

The prediction ``(xi, x~)`` is ``(t~ + C_p x~_prev + c_p, A_p x~_prev + a_p)`` from the previous
visible event (eq. 14) -- exactly the ``xi`` and ``A_p x~ + a_p`` of (18d-e) -- and, before the
first visible event, the open-loop flow from the initial estimate (the paper's Section 5 run
starts at ``t = 50`` in mode 4, not at a visible event, and quotes this prediction:
``x~(81.7) = [101.7 58.3 15]``).  The gain ``L_p`` is that of the phase *ending* at the event
(``p(y) = sigma_v^{-1}(sigma^{-1}(y))``), so at the visible events the estimate follows (16).

Readings of garbled or implicit points of the extracted text:

* (18e) prints the timer reset as ``alpha_{sigma(y^)}``; the event leaves mode ``y^``, so the
  reset of (2) is ``alpha_{y^}`` (the clearing time of the next setup, 10 s at 79.2 s in Section 5).
* The jump (18c) into a waiting mode does not add ``alpha``: the paper keeps ``x0^`` "constant (at
  zero)" while waiting; the reset is applied at the actual event by (18d-e).
* With a sign-indefinite gain the estimate can leave ``R_+^{N+1}``; a mode whose triggering
  component is already ``<= 0`` is then left at once (its flow set is empty).  The visible-event
  updates stay exactly (16) because they use the formula (14), not the flow.

Runtime contract.  :class:`DriftObserver` is an :class:`~hybobs_opt.contract.Observer`
driven by the output signal: ``step(u, y)`` with ``u = [t]``, the **time stamp** of the sample
(not a time step), and ``y = [h_q]``, the measured output.  Time stamps make the exact event rows
of :func:`~hybobs_opt.sim.constant_drift.simulate_constant_drift` (two rows at the same ``t``,
before and after the jump) give exact event times, and a repeated stamp is harmless; a visible
event is dated at the first sample showing the new output.  :meth:`DriftObserver.observe_events`
is the event-driven API for recorded event logs ``(t, y after the event)``.

The paper's gains (20a-b) and scenarios are the study :mod:`hybobs_opt.studies.paper003_switching.scenarios`.
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_flag, as_positive
from ..errors import ModelError
from ..systems.constant_drift import ConstantDriftSystem
from ..systems.event_sampled import PeriodicSystem, periodic_system
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, ObserverTrace, TimeGuard, WARMING_UP,
                        check_reset_keywords, checked_time, initial_mode)
from ..defaults import TIME_JUMP_FACTOR
from ..synthesis.periodic_gains import PeriodicGains, analyse_gains, deadbeat_gains


@dataclass(frozen=True)
class VisibleEventRecord:
    """What the observer did at one visible event.

    Attributes
    ----------
    t : float
        Time of the actual visible event.
    predicted_t : float
        ``xi``, the time at which the observer expected it.
    x_predicted : (N,) array
        ``x~(xi)``, the predicted queues at ``xi``.
    x_before, x_after : (N+1,) arrays
        Full estimate ``[x0, x1, ..., xN]`` just before and just after the jump.
    mode_left, mode_entered : int
        The event's modes (from the output).
    gain_phase : int
        Phase ``p`` whose gain ``L_p`` was used.
    kind : str
        ``"18d"`` (a visible mode entered), ``"18e"`` (one left) or ``"resync"`` (the event was not
        the predicted one: phase reset without correction).
    waited : bool
        The observer was in a waiting mode (the event came later than predicted).
    """

    t: float
    predicted_t: float
    x_predicted: np.ndarray
    x_before: np.ndarray
    x_after: np.ndarray
    mode_left: int
    mode_entered: int
    gain_phase: int
    kind: str
    waited: bool

    def to_dict(self) -> dict[str, Any]:
        return {"t": self.t, "predicted_t": self.predicted_t, "x_predicted": self.x_predicted.tolist(),
                "x_before": self.x_before.tolist(), "x_after": self.x_after.tolist(), "mode_left": self.mode_left,
                "mode_entered": self.mode_entered, "gain_phase": self.gain_phase, "kind": self.kind,
                "waited": self.waited}


@dataclass(frozen=True, eq=False)
class DriftRun:
    """Result of :meth:`DriftObserver.observe_events`: estimates on a time grid and the event records.

    Parameters
    ----------
    t : (K,) array
        Times of the estimates (the grid and both sides of every event).
    x_hat : (K, N + 1) array
        Estimates ``[x0^, x1^, ..., xN^]``.
    mode : (K,) int array
        The observer's model mode at each time.
    waiting : (K,) bool array
        Whether the observer was in a waiting mode.
    events : list of VisibleEventRecord
        What the observer did at each visible event.
    state_names : tuple of str
        Names of ``x0 ... xN``.

    See Also
    --------
    DriftObserver.observe_events : Returns one.

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
    >>> obs = DriftObserver(server, gains)
    >>> obs.reset(np.array([server.alpha[-1], 0.0, 0.0]), t0=0.0, q0=1)
    >>> run = obs.observe_events(truth.events, t_final=30.0)
    >>> run.x_hat.shape[1], len(run.events) > 0, run.state_names
    (3, True, ('x0', 'x1', 'x2'))
    """

    t: np.ndarray
    x_hat: np.ndarray
    mode: np.ndarray
    waiting: np.ndarray
    events: list[VisibleEventRecord] = field(default_factory=list)
    state_names: tuple[str, ...] = ()


def _as_gains(ps: PeriodicSystem, gains) -> PeriodicGains:
    if gains is None:
        return deadbeat_gains(ps)
    if isinstance(gains, PeriodicGains):
        ps.check_gains(gains.L, "gains")
        return gains
    return analyse_gains(ps, ps.check_gains(gains, "gains"))


class DriftObserver(Observer):
    """Continuous-time observer (18a-e) of paper 003 with waiting modes and optional projection.

    Parameters
    ----------
    system : ConstantDriftSystem
        The plant (3); its outputs ``h_q`` define the visible events.
    gains : PeriodicGains or (V, N) array, optional
        Gains ``L_j`` of (16), phase ``j`` = the step starting at the visible event leaving
        ``v_j``.  Default: :func:`~hybobs_opt.synthesis.periodic_gains.deadbeat_gains`.
    project : bool
        Report ``P_Omega x-bar^ = max(0, x-bar^)`` (Remark 4.4) instead of ``x-bar^``; the
        observer's own state is not projected.
    max_time_step : float, optional
        Largest time between samples accepted as consistent; default ``TIME_JUMP_FACTOR`` times
        the timer cycle ``sum(alpha)`` (a later time stamp is a jump: ``fallback``).

    See Also
    --------
    PeriodicObserver : The discrete-time observer (16) at the visible events.
    DriftRun : What ``observe_events`` returns.

    Notes
    -----
    ``step(u, y)``: ``u = [t]`` is the sample's time stamp (see the module), ``y = [h_q]``.  The
    estimate is the full ``[x0^, x1^, ..., xN^]``; ``Estimate.mode`` is the model mode (in a
    waiting mode ``v + 1/2`` it is ``v``; ``info["waiting"]`` tells), ``info["predicted_t"]`` the
    expected time of the next visible event.  Flags: ``observable`` once the gains are deadbeat
    and enough visible events were processed for the estimate to be exact (``deadbeat_steps + 1``
    counting the first one, which starts from an arbitrary error), ``warming_up`` before (and
    always for non-deadbeat gains, whose estimate converges but is never exact), ``fallback`` for
    a bad sample (non-numeric, NaN, a time stamp going back, an output that no mode has) which is
    answered by open-loop prediction, or for an unexpected visible event (phase resynchronised).

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
    >>> obs = DriftObserver(server, gains)
    >>> obs.reset(np.array([server.alpha[-1], 0.0, 0.0]), t0=0.0, q0=1)
    >>> trace = obs.run_trace(truth)

    Deadbeat gains: the queue estimates are exact after the first visible events:

    >>> bool(np.abs(trace.x_hat[-1] - truth.x[-1]).max() < 1e-9)
    True
    """

    name = "constant-drift (18)"
    m = 1
    p = 1

    def __init__(self, system: ConstantDriftSystem, gains: PeriodicGains | ArrayLike | None = None, *,
                 project: bool = False, max_time_step: float | None = None):
        if not isinstance(system, ConstantDriftSystem):
            raise ModelError("system", "a ConstantDriftSystem (paper 003, eq. 3)", type(system).__name__)
        project = as_flag(project, "project")
        max_time_step = as_positive(max_time_step, "max_time_step", "a positive finite time", allow_none=True)
        self.system = system
        self.periodic = periodic_system(system)
        self.gains = _as_gains(self.periodic, gains)
        self.L = np.array(self.gains.L, dtype=float)
        self.project = project
        self.n = system.n_states
        self.state_names = system.state_names
        self._outputs = {0} | set(system.visible_modes)
        if max_time_step is None:
            scale = float(np.sum(system.alpha))
            max_time_step = TIME_JUMP_FACTOR * scale if scale > 0 else None
        self._guard = TimeGuard(max_time_step)
        self.max_time_step = self._guard.max_step
        self.reset()

    # ------------------------------------------------------------------ set-up
    def reset(self, x0: ArrayLike | None = None, *, t0: float = 0.0, q0: int | None = None, y0: float | None = None,
              mode: int | None = None, **kwargs: Any) -> None:
        """Initialise ``x^(t0) = x0`` in mode ``q0`` (paper: ``x0^(0) = alpha_Q``, ``q^(0) = 1``).

        Parameters
        ----------
        x0 : (N+1,) array_like, optional
            Initial estimate ``[x0, x1, ..., xN]``; default ``[alpha_Q, 0, ..., 0]`` in a timer
            mode, zeros otherwise.
        t0 : float
            Start time.
        q0 : int, default 1
            Initial estimated mode ``q^(t0)``.
        y0 : float, optional
            Output just before ``t0``; by default the first sample's output is taken as the
            reference (no visible event at the first sample).
        mode : int, optional
            Deprecated name of ``q0`` (a ``FutureWarning``; removed in 0.2.0).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.

        Raises
        ------
        ModelError
            If ``(x0, mode)`` is not a state of the system (negative entry, ``x0 != 0`` outside a
            timer mode, wrong length), ``t0`` is not finite or ``y0`` is not an output.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        sysm = self.system
        field = "mode" if mode is not None else "q0"  # errors name the keyword the caller used
        mode = initial_mode(q0, mode, "mode")
        mode = 1 if mode is None else mode
        sysm._check_mode(mode, field)
        if x0 is None:
            x = np.zeros(self.n)
            if sysm.is_timer_mode(mode):
                x[0] = sysm.alpha[sysm.predecessor(mode) - 1]
        else:
            x = np.array(sysm.validate_state(x0, mode, field_name="x0", mode_field=field), dtype=float)
        t0 = checked_time(t0, "t0")
        if y0 is not None and (isinstance(y0, bool) or not isinstance(y0, (int, np.integer)) or y0 not in self._outputs):
            raise ModelError("y0", f"an output of the system, one of {sorted(self._outputs)}", repr(y0))
        self._t = float(t0)
        self._guard.reset(self._t)
        self._x = x
        self._q = int(mode)
        self._waiting = False
        self._y_prev = None if y0 is None else int(y0)
        self._updates = 0
        self.events: list[VisibleEventRecord] = []
        self._predict_from_flow()

    def _predict_from_flow(self) -> None:
        """Prediction of the next visible event by open-loop flow (used only after a reset)."""
        sysm = self.system
        x, q, t = self._x.copy(), self._q, self._t
        for _ in range(sysm.n_modes + 1):
            k = int(sysm.trigger[q - 1])
            dwell = max(0.0, x[k] / -sysm.f[q - 1, k])
            x = x + dwell * sysm.f[q - 1]
            x[k] = 0.0
            t += dwell
            if sysm.is_visible_event(q):
                break
            x[0] += sysm.alpha[q - 1]
            q = sysm.successor(q)
        self._pend_v = q
        self._pend_j = self._gain_phase(q)
        self._xi = t
        self._x_pred = x[1:].copy()

    def _gain_phase(self, v: int) -> int:
        """Phase whose step ends at the visible event leaving ``v`` (``sigma_v^{-1}``, eq. 10)."""
        j = self.periodic.phase_of(v)
        return self.periodic.period if j == 1 else j - 1

    # ------------------------------------------------------------------ flows (18a-c)
    def _advance(self, t_target: float) -> None:
        sysm = self.system
        f = sysm.f
        while self._t < t_target:
            if self._waiting:  # (18b): x-bar^ drifts with L_p, x0^ stays 0
                self._x[1:] += self.L[self._pend_j - 1] * (t_target - self._t)
                self._t = t_target
                return
            q = self._q
            k = int(sysm.trigger[q - 1])
            dwell = max(0.0, self._x[k] / -f[q - 1, k])
            if self._t + dwell > t_target:  # (18a)
                self._x += f[q - 1] * (t_target - self._t)
                self._t = t_target
                return
            self._x += f[q - 1] * dwell
            self._x[k] = 0.0
            self._t += dwell
            if q == self._pend_v:  # predicted visible event not seen: waiting mode q + 1/2
                self._waiting = True
            else:  # (18c)
                self._x[0] += sysm.alpha[q - 1]
                self._q = sysm.successor(q)

    # ------------------------------------------------------------------ visible events (18d-e)
    def _visible_event(self, t: float, y_new: int) -> bool:
        """Jump at a visible event at ``t`` with output ``y_new`` after it; ``False`` for a resync."""
        sysm, ps = self.system, self.periodic
        y_old = self._y_prev
        if y_new != 0:
            v_act = sysm.predecessor(y_new)
        else:
            v_act = int(y_old) if y_old else self._pend_v
        consistent = v_act == self._pend_v and (y_new == 0 or not y_old or y_old == v_act)
        x_before = self._x.copy()
        waited = self._waiting
        if consistent:
            L = self.L[self._pend_j - 1]
            xbar = self._x_pred + L * (t - self._xi)
            kind = "18d" if y_new != 0 else "18e"
        else:
            xbar = self._x[1:].copy()
            kind = "resync"
        self._x = np.concatenate([[sysm.alpha[v_act - 1]], xbar])
        self._q = sysm.successor(v_act)
        self._waiting = False
        self.events.append(VisibleEventRecord(t, self._xi, self._x_pred.copy(), x_before, self._x.copy(), v_act,
                                              self._q, self._pend_j, kind, waited))
        j = ps.phase_of(v_act)  # the step (14) that starts at this event
        self._xi = t + float(ps.C[j - 1] @ xbar) + float(ps.c[j - 1])
        self._x_pred = ps.A[j - 1] @ xbar + ps.a[j - 1]
        self._pend_v = ps.event_modes[j % ps.period]
        self._pend_j = j
        self._updates = self._updates + 1 if consistent else 0
        return consistent

    # ------------------------------------------------------------------ observer contract
    def _estimate(self, flag: str, info: dict) -> Estimate:
        x = self._x.copy()
        if self.project:
            x[1:] = np.maximum(x[1:], 0.0)
        db = self.gains.deadbeat_steps
        if flag == WARMING_UP and db is not None and self._updates >= db + 1:
            flag = OBSERVABLE
        info = dict(info, waiting=self._waiting, observer_mode=self._q + 0.5 if self._waiting else float(self._q),
                    predicted_t=self._xi, y_hat=int(self.system.h[self._q - 1]))
        return Estimate(x, self._q, flag, 0.0, info)

    def _judge_time(self, t: float, y_new: int | None) -> str | None:
        """``None`` when the observer may advance to ``t``; otherwise the reason of a ``fallback`` step.

        A refused time stamp leaves the observer as it was.  After a real gap in the data
        (:class:`~hybobs_opt.contract.TimeGuard`) the time reference restarts at ``t`` from the
        current estimate, with the prediction of the next visible event recomputed and the count
        of consistent events towards ``observable`` reset.
        """
        verdict, why = self._guard.judge(t)
        if verdict == "ok":
            return None
        if verdict == "resumed":
            self._t = float(t)
            self._waiting = False
            self._updates = 0
            self._y_prev = y_new
            self._predict_from_flow()
        return why

    def _fallback(self, u, reason: str) -> Estimate:
        if u is not None and self._judge_time(float(u[0]), None) is None:
            self._advance(float(u[0]))
        return self._estimate(FALLBACK, {"reason": reason})

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        t, yv = float(u[0]), float(y[0])
        if yv != round(yv) or int(round(yv)) not in self._outputs:
            return self._fallback(u, f"y = {yv} is not an output of the system (one of {sorted(self._outputs)})")
        yi = int(round(yv))
        why = self._judge_time(t, yi)
        if why is not None:
            return self._estimate(FALLBACK, {"reason": why})
        self._advance(t)
        if self._y_prev is None:
            self._y_prev = yi
            if yi != int(self.system.h[self._q - 1]):
                return self._estimate(FALLBACK, {"reason": f"initial output mismatch: y = {yi}, y^ = "
                                                           f"{int(self.system.h[self._q - 1])}"})
            return self._estimate(WARMING_UP, {})
        if yi == self._y_prev:
            return self._estimate(WARMING_UP, {})
        ok = self._visible_event(t, yi)
        self._y_prev = yi
        if not ok:
            return self._estimate(FALLBACK, {"reason": "visible event other than the predicted one: phase resynchronised"})
        return self._estimate(WARMING_UP, {"visible_event": True})

    def run_trace(self, trace, t_start: float | None = None) -> ObserverTrace:
        """Run :meth:`step` on the rows of a simulated trace with ``t >= t_start`` (no reset).

        Parameters
        ----------
        trace : Trace
            A simulated trace of the constant-drift system (its times and first output column are used).
        t_start : float, optional
            First time used; ``None`` uses every row.

        Returns
        -------
        ObserverTrace
            The estimates on the rows with ``t >= t_start``.
        """
        keep = np.ones(trace.t.size, dtype=bool) if t_start is None else trace.t >= t_start
        return Observer.run(self, trace.t[keep], trace.y[keep, 0])

    # ------------------------------------------------------------------ event-driven API
    def observe_events(self, events: Iterable, *, t_final: float | None = None,
                       grid: ArrayLike | None = None) -> DriftRun:
        """Run (18) on a recorded log of visible events (continue from the current state; no reset).

        Parameters
        ----------
        events : iterable
            Visible events in time order, each a pair ``(t, y)`` with ``y`` the output *after*
            the event, or an event dict of :func:`~hybobs_opt.sim.constant_drift.simulate_constant_drift`
            (keys ``t``, ``y``; entries with ``visible`` false are skipped).
        t_final : float, optional
            Predict up to this time after the last event.
        grid : array_like, optional
            Times at which to report the estimate (between the events); by default the event
            times (just before and just after each jump) and ``t_final``.

        Returns
        -------
        DriftRun

        Raises
        ------
        ModelError
            For an event that is not a pair/dict, a non-finite or decreasing time, or an output
            no mode has (recorded logs are data, not samples: they are checked up front).
        """
        log: list[tuple[float, int]] = []
        last = self._t
        for i, ev in enumerate(events):
            if isinstance(ev, dict):
                if not ev.get("visible", True):
                    continue
                t, y = ev.get("t"), ev.get("y")
            else:
                try:
                    t, y = ev
                except (TypeError, ValueError):
                    raise ModelError(f"events[{i}]", "a pair (t, y) or an event dict", repr(ev)) from None
            try:
                t, y = float(t), float(y)
            except (TypeError, ValueError):
                raise ModelError(f"events[{i}]", "a numeric time and output", repr(ev)) from None
            if not np.isfinite(t) or t < last:
                raise ModelError(f"events[{i}].t", f"a finite time >= {last}", repr(t))
            if y != round(y) or int(y) not in self._outputs:
                raise ModelError(f"events[{i}].y", f"an output of the system, one of {sorted(self._outputs)}", repr(y))
            log.append((t, int(y)))
            last = t
        if self._y_prev is None:
            self._y_prev = int(self.system.h[self._q - 1])
        ts, xs, qs, ws = [], [], [], []

        def sample(t: float) -> None:
            self._advance(t)
            e = self._estimate(WARMING_UP, {})
            ts.append(t)
            xs.append(e.x)
            qs.append(self._q)
            ws.append(self._waiting)

        grid_arr = np.sort(np.asarray(grid, dtype=float).reshape(-1)) if grid is not None else np.zeros(0)
        gi = 0
        for t, y in log:
            while gi < grid_arr.size and grid_arr[gi] < t:
                if grid_arr[gi] >= self._t:
                    sample(float(grid_arr[gi]))
                gi += 1
            sample(t)
            if y != self._y_prev:
                self._visible_event(t, y)
                self._y_prev = y
                ts.append(t)
                xs.append(self._estimate(WARMING_UP, {}).x)
                qs.append(self._q)
                ws.append(False)
        end = t_final if t_final is not None else (grid_arr[-1] if grid_arr.size else None)
        while gi < grid_arr.size and (end is None or grid_arr[gi] <= end):
            if grid_arr[gi] >= self._t:
                sample(float(grid_arr[gi]))
            gi += 1
        if t_final is not None and t_final >= self._t and (not ts or ts[-1] != t_final):
            sample(float(t_final))
        return DriftRun(np.array(ts), np.array(xs).reshape(-1, self.n), np.array(qs, dtype=int),
                        np.array(ws, dtype=bool), list(self.events), self.state_names)


__all__ = [
    "DriftObserver",
    "DriftRun",
    "VisibleEventRecord",
]

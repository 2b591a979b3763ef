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

Runtime contract.  :class:`DriftObserver` is an :class:`~hybobs_opt.observers.base.Observer`
driven by the output signal: ``step(u, y)`` with ``u = [t]``, the **time stamp** of the sample
(not a time step), and ``y = [h_q]``, the measured output.  Time stamps make the exact event rows
of :func:`~hybobs_opt.sim.constant_drift.simulate_constant_drift` (two rows at the same ``t``,
before and after the jump) give exact event times, and a repeated stamp is harmless; a visible
event is dated at the first sample showing the new output.  :meth:`DriftObserver.observe_events`
is the event-driven API for recorded event logs ``(t, y after the event)``.

Also registers the ``hybobs observe traffic_junction`` and ``hybobs observe switching_server``
scenarios.
"""

from __future__ import annotations

import argparse
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError
from ..systems.constant_drift import ConstantDriftSystem
from ..systems.event_sampled import PeriodicSystem, periodic_system
from .base import FALLBACK, OBSERVABLE, WARMING_UP, Estimate, Observer, ObserverTrace
from .periodic import PeriodicGains, analyse_gains, deadbeat_gains, positive_deadbeat_gains, positive_observer
from .scenarios import register_scenario


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
    """Result of :meth:`DriftObserver.observe_events`: estimates on a time grid and the event records."""

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
        ``v_j``.  Default: :func:`~hybobs_opt.observers.periodic.deadbeat_gains`.
    project : bool
        Report ``P_Omega x-bar^ = max(0, x-bar^)`` (Remark 4.4) instead of ``x-bar^``; the
        observer's own state is not projected.

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
    """

    name = "constant-drift (18)"
    m = 1
    p = 1

    def __init__(self, system: ConstantDriftSystem, gains: PeriodicGains | ArrayLike | None = None, *,
                 project: bool = False):
        if not isinstance(system, ConstantDriftSystem):
            raise ModelError("system", "a ConstantDriftSystem (paper 003, eq. 3)", type(system).__name__)
        self.system = system
        self.periodic = periodic_system(system)
        self.gains = _as_gains(self.periodic, gains)
        self.L = np.array(self.gains.L, dtype=float)
        self.project = bool(project)
        self.n = system.n_states
        self.state_names = system.state_names
        self._outputs = {0} | set(system.visible_modes)
        self.reset()

    # ------------------------------------------------------------------ set-up
    def reset(self, x0: ArrayLike | None = None, *, t0: float = 0.0, mode: int = 1, y0: float | None = None,
              **kwargs: Any) -> None:
        """Initialise ``x^(t0) = x0`` in mode ``mode`` (paper: ``x0^(0) = alpha_Q``, ``q^(0) = 1``).

        Parameters
        ----------
        x0 : (N+1,) array_like, optional
            Initial estimate ``[x0, x1, ..., xN]``; default ``[alpha_Q, 0, ..., 0]`` in a timer
            mode, zeros otherwise.
        t0 : float
            Start time.
        mode : int
            Initial estimated mode ``q^(t0)``.
        y0 : float, optional
            Output just before ``t0``; by default the first sample's output is taken as the
            reference (no visible event at the first sample).

        Raises
        ------
        ModelError
            If ``(x0, mode)`` is not a state of the system (negative entry, ``x0 != 0`` outside a
            timer mode, wrong length), ``t0`` is not finite or ``y0`` is not an output.
        """
        sysm = self.system
        sysm._check_mode(mode, "mode")
        if x0 is None:
            x = np.zeros(self.n)
            if sysm.is_timer_mode(mode):
                x[0] = sysm.alpha[sysm.predecessor(mode) - 1]
        else:
            x = np.array(sysm.validate_state(x0, mode, field_name="x0", mode_field="mode"), dtype=float)
        if not np.isfinite(t0):
            raise ModelError("t0", "a finite time", repr(t0))
        if y0 is not None and y0 not in self._outputs:
            raise ModelError("y0", f"an output of the system, one of {sorted(self._outputs)}", repr(y0))
        self._t = float(t0)
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

    def _fallback(self, u, reason: str) -> Estimate:
        if u is not None and u[0] >= self._t:
            self._advance(float(u[0]))
        return self._estimate(FALLBACK, {"reason": reason})

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        t, yv = float(u[0]), float(y[0])
        if t < self._t:
            return self._estimate(FALLBACK, {"reason": f"time stamp {t} before the previous one {self._t}"})
        if yv != round(yv) or int(round(yv)) not in self._outputs:
            return self._fallback(u, f"y = {yv} is not an output of the system (one of {sorted(self._outputs)})")
        yi = int(round(yv))
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
        """Run :meth:`step` on the rows of a simulated trace with ``t >= t_start`` (no reset)."""
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


# ---------------------------------------------------------------------------- the paper's gains
def junction_paper_gains(lam: Sequence[float], mu: Sequence[float]) -> np.ndarray:
    """Gains (20a-b) of paper 003, Section 5: ``L1 = [0, lam2, lam3]``, ``L2 = [lam1, lam2 lam3 / mu3, 0]``.

    For the 3-flow T-junction with the sensor on lane 1 (phase 1 = serving flow 1, phase 2 = the
    rest of the cycle).
    """
    l1, l2, l3 = (float(v) for v in lam)
    m3 = float(mu[2])
    return np.array([[0.0, l2, l3], [l1, l2 * l3 / m3, 0.0]])


# ---------------------------------------------------------------------------- CLI scenarios
#: Observer kinds of ``hybobs observe traffic_junction|switching_server --observer KIND``;
#: append ``+projection`` for Remark 4.4's projected estimate.
OBSERVER_KINDS = ("paper", "deadbeat", "positive", "positive-deadbeat")

#: The switching-server observer's initial estimate of the buffers ``[x1, x2]`` at ``t = 0`` in mode 1
#: with ``x0^ = alpha_Q`` (the paper's initialisation convention, Section 4.2).  Paper 003 runs no
#: server scenario; empty buffers are chosen here as "no knowledge".
SERVER_ESTIMATE_X_BAR: tuple[float, float] = (0.0, 0.0)


def scenario_gains(kind: str, ps: PeriodicSystem, example: str, params: dict | None = None) -> PeriodicGains:
    """The gains of an observer kind for the scenario of ``example`` (see :data:`OBSERVER_KINDS`)."""
    if kind == "paper":
        if example != "traffic_junction":
            raise ModelError("--observer", "deadbeat, positive or positive-deadbeat (paper 003 prints gains "
                                           "only for the T-junction)", repr(kind))
        p = params or {}
        return analyse_gains(ps, junction_paper_gains(p.get("lam", (1.0, 2.0, 3.0)), p.get("mu", (8.0, 10.0, 12.0))),
                             "paper (20a-b)")
    if kind == "deadbeat":
        return deadbeat_gains(ps)
    if kind == "positive":
        return positive_observer(ps)
    if kind == "positive-deadbeat":
        return positive_deadbeat_gains(ps)
    raise ModelError("--observer", f"one of {OBSERVER_KINDS} (optionally with +projection)", repr(kind))


def run_drift_scenario(example: str, kind: str | None = None, *, project: bool = False) -> dict[str, Any]:
    """Run the observer of ``kind`` on the paper scenario of ``example``; everything the CLI and report need.

    ``traffic_junction``: the true junction of Section 5 (``x(0) = [5, 40, 60, 0]``, see
    :data:`~hybobs_opt.examples.switching.JUNCTION_X0_BAR`), observer from ``t = 50`` with
    ``x^(50) = [0, 70, 20, 30]`` in mode 4; default gains (20a-b).  ``switching_server``: the
    server scenario of Section 2.1, observer from ``t = 0`` with ``x^(0) = [gamma1, 0, 0]`` in
    mode 1; default gains from :func:`~hybobs_opt.observers.periodic.deadbeat_gains`.

    Returns
    -------
    dict
        ``system``, ``trace`` (truth), ``gains``, ``observer``, ``out`` (ObserverTrace on the
        rows from the start time), ``t``, ``x_true`` and ``summary`` (JSON-ready).
    """
    from ..examples.switching import (
        JUNCTION_ESTIMATE_MODE,
        JUNCTION_ESTIMATE_X_BAR,
        JUNCTION_OBSERVER_START,
        switching_server,
        switching_server_scenario,
        traffic_junction,
        traffic_junction_scenario,
    )

    if example == "traffic_junction":
        system = traffic_junction()
        trace = traffic_junction_scenario(system)
        t0, q0 = JUNCTION_OBSERVER_START, JUNCTION_ESTIMATE_MODE
        x0 = np.array([0.0, *JUNCTION_ESTIMATE_X_BAR])
        kind = kind or "paper"
    elif example == "switching_server":
        system = switching_server()
        trace = switching_server_scenario(system)
        t0, q0 = 0.0, 1
        x0 = np.array([system.alpha[-1], *SERVER_ESTIMATE_X_BAR])
        kind = kind or "deadbeat"
    else:
        raise ModelError("example", "traffic_junction or switching_server", repr(example))
    ps = periodic_system(system)
    gains = scenario_gains(kind, ps, example)
    obs = DriftObserver(system, gains, project=project)
    obs.reset(x0, t0=t0, mode=q0)
    keep = trace.t >= t0
    out = obs.run_trace(trace, t0)
    x_true = trace.x[keep]
    t = trace.t[keep]
    err = out.x_hat - x_true
    summary: dict[str, Any] = {
        "example": example,
        "observer": kind + ("+projection" if project else ""),
        "paper": "003",
        "state_names": list(system.state_names),
        "gains": gains.to_dict(),
        "observer_start": t0,
        "x_hat_start": x0.tolist(),
        "mode_start": q0,
        "visible_events": [r.to_dict() for r in obs.events],
        "t_final": float(t[-1]),
        "final_error": err[-1].tolist(),
        "final_abs_error_queues": float(np.max(np.abs(err[-1, 1:]))),
        "min_queue_estimate": float(out.x_hat[:, 1:].min()),
        "nonnegative": bool(out.x_hat[:, 1:].min() >= 0.0),
        "flags": out.flag_counts(),
        **out.timing(),
    }
    exact = [r.t for r in obs.events if np.max(np.abs(r.x_after[1:] - _true_at(trace, r.t)[1:])) <= 1e-6 * (1.0 + np.abs(r.x_after).max())]
    summary["first_exact_visible_event"] = exact[0] if exact else None
    return {"system": system, "trace": trace, "gains": gains, "observer": obs, "out": out, "t": t, "x_true": x_true,
            "summary": summary}


def _true_at(trace, t: float) -> np.ndarray:
    """True state just after time ``t`` (the last row stamped ``t``)."""
    idx = np.nonzero(np.isclose(trace.t, t, rtol=0, atol=1e-12))[0]
    if idx.size:
        return trace.x[idx[-1]]
    return np.array([np.interp(t, trace.t, trace.x[:, i]) for i in range(trace.x.shape[1])])


def plot_drift_run(res: dict[str, Any], path, title: str = "") -> None:
    """Figure 3 of paper 003: true (dashed) and estimated (solid) queues, visible events marked."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    names = res["system"].state_names
    t, xt, xh = res["t"], res["x_true"], res["out"].x_hat
    fig, ax = plt.subplots(figsize=(7.5, 3.6))
    for i in range(1, len(names)):
        line, = ax.plot(t, xh[:, i], lw=1.3, label=f"{names[i]}^")
        ax.plot(t, xt[:, i], "--", lw=1.0, color=line.get_color(), label=f"{names[i]}")
    for r in res["observer"].events:
        ax.axvline(r.t, color="k", lw=0.5, alpha=0.4)
    ax.set_xlabel("t [s]")
    ax.set_ylabel("queue length")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title(title or f"{res['summary']['example']}: observer (18), {res['summary']['observer']}", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _cli_scenario(example: str):
    def scenario(args: argparse.Namespace) -> dict[str, Any]:
        kind = getattr(args, "observer", None)
        project = False
        if kind and kind.endswith("+projection"):
            kind, project = kind[: -len("+projection")], True
        res = run_drift_scenario(example, kind, project=project)
        out = res["summary"]
        if getattr(args, "plot", None):
            plot_drift_run(res, args.plot)
            out["plot"] = args.plot
        return out

    return scenario


for _name in ("traffic_junction", "switching_server"):
    register_scenario(_name, _cli_scenario(_name))


__all__ = [
    "DriftObserver",
    "DriftRun",
    "OBSERVER_KINDS",
    "VisibleEventRecord",
    "junction_paper_gains",
    "plot_drift_run",
    "run_drift_scenario",
    "scenario_gains",
]

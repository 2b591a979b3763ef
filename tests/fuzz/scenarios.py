"""The observers of the shipped examples on their scenarios, built once per process.

Each :class:`Scenario` holds the clean data of one observer kind (``U``, ``Y``, the true states
``X`` and, for the continuous observer, the true location sequence ``Q``), a factory of fresh
observers, how to reset one, and the clean run (flags, estimates, stated error bounds), computed
on first use.  The runs are short prefixes of the paper scenarios where a full one takes longer
than a fuzz example should (the sliding-mode scenarios, 30 000 samples).

``window`` is where faults may be injected: late enough that the clean run has left its
warm-up, early enough that a run restarted by the fault (a Luenberger-type observer restarts its
certified bound after an open-loop step) has as many steps left as the clean run needed from its
start, plus a margin, to reach ``observable`` again.
"""

from __future__ import annotations

import functools
import warnings
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from hybobs_opt.contract import OBSERVABLE

#: Integration error allowed on top of a stated ``error_bound`` (fraction of the state box width):
#: the bounds hold for the sampled error map, the plants are simulated with event location, so
#: the switching instants and the input steps fall between samples.
BOUND_FLOOR_FRACTION = 1e-3

#: Tolerance of an observer without a stated bound: this many times the clean run's largest
#: error on its ``observable`` steps ...
CLEAN_ERROR_FACTOR = 10.0
#: ... plus this fraction of the state box width.
BOX_FLOOR_FRACTION = 0.01


@dataclass(eq=False)
class Scenario:
    """One observer kind on its example's scenario (see the module docstring)."""

    name: str
    make: Callable[[], Any]
    reset: Callable[[Any], None]
    U: np.ndarray
    Y: np.ndarray
    X: np.ndarray
    width: np.ndarray
    stated_bound: bool
    window: tuple[int, int]
    time_input: bool = False  # u = [t]: the event-driven observers of paper 003
    Q: np.ndarray | None = None
    integer_output: bool = False
    _clean: dict | None = field(default=None, repr=False)
    _observer: Any = field(default=None, repr=False)

    @property
    def N(self) -> int:
        return self.Y.shape[0]

    @property
    def m(self) -> int:
        return self.U.shape[1]

    @property
    def p(self) -> int:
        return self.Y.shape[1]

    def observer(self):
        """The scenario's observer (one instance per process, reset before every run)."""
        if self._observer is None:
            self._observer = self.make()
        return self._observer

    def run(self, samples) -> dict:
        """Reset and step through ``samples`` (pairs ``(u, y)``); estimates, flags and stated bounds."""
        obs = self.observer()
        self.reset(obs)
        xs = np.full((self.N, self.X.shape[1]), np.nan)
        flags = np.empty(self.N, dtype=object)
        bounds = np.full((self.N, self.X.shape[1]), np.inf)
        for k, (u, y) in enumerate(samples):
            e = obs.step(u, y)
            if self.Q is not None:
                obs.location = int(self.Q[k])
            x = np.asarray(e.x, dtype=float).reshape(-1)
            if x.shape == (xs.shape[1],):
                xs[k] = x
            flags[k] = e.flag
            b = e.info.get("error_bound") if isinstance(e.info, dict) else None
            if b is not None:
                bounds[k] = np.asarray(b, dtype=float).reshape(-1)
        err = np.abs(xs - self.X)
        err = np.where(np.isfinite(err), err, np.inf)
        return {"x": xs, "flags": flags, "bounds": bounds, "err": err}

    def clean_samples(self):
        return [(self.U[k], self.Y[k]) for k in range(self.N)]

    def clean(self) -> dict:
        if self._clean is None:
            self._clean = self.run(self.clean_samples())
            obs = self._clean["flags"] == OBSERVABLE
            err = self._clean["err"]
            self._clean["max_err_observable"] = err[obs].max(axis=0) if obs.any() else np.zeros(self.X.shape[1])
        return self._clean

    def tolerance(self, run: dict) -> np.ndarray:
        """Per step and state: the largest error an ``observable`` flag may carry in ``run``."""
        if self.stated_bound:
            return run["bounds"] + BOUND_FLOOR_FRACTION * self.width
        c = self.clean()
        tol = CLEAN_ERROR_FACTOR * c["max_err_observable"] + BOX_FLOOR_FRACTION * self.width
        return np.broadcast_to(tol, run["err"].shape)

    def recovery_window(self) -> slice:
        w = max(10, self.N // 50)
        return slice(self.N - w, self.N)


def _width(lo, hi, X) -> np.ndarray:
    lo, hi = np.asarray(lo, dtype=float), np.asarray(hi, dtype=float)
    w = hi - lo
    span = X.max(axis=0) - X.min(axis=0)
    return np.where(np.isfinite(w) & (w > 0), w, np.maximum(span, 1e-6))


def _quiet(fn):
    @functools.wraps(fn)
    def inner(*a, **k):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            return fn(*a, **k)

    return inner


# ---------------------------------------------------------------------------------- the data

@functools.cache
@_quiet
def driveline_data():
    from hybobs_opt.studies.paper000_driveline.scenario import DRIVELINE_X0_GUESS, run_driveline

    res = run_driveline(t_final=4.0)
    return res, np.array(DRIVELINE_X0_GUESS, dtype=float)


@functools.cache
@_quiet
def powertrain_data():
    from hybobs_opt.studies.paper002_powertrain.bench import bench_trace

    plant, trace, y, an = bench_trace("powertrain3", 3, 300, 0.0)
    return plant, trace, np.asarray(y, dtype=float), an


@functools.cache
@_quiet
def sliding_data(name: str):
    from hybobs_opt.studies.paper001_sliding_mode.scenarios import run_scenario

    t_final = {"double_scroll": 3.0, "triangular": 0.8}[name]
    return run_scenario(name, t_final=t_final)


@functools.cache
@_quiet
def switched_data(example: str):
    from hybobs_opt.studies.paper004_nonmonotonic.scenarios import cached_design, run_example

    t_final = {"magnetic_piston": None, "vehicle_tracking": 40.0}[example]
    trace, ot, _ = run_example(example, t_final=t_final)
    return cached_design(example), trace, np.asarray(ot.x_hat[0], dtype=float)


@functools.cache
@_quiet
def drift_data(example: str):
    from hybobs_opt.studies.paper003_switching.scenarios import run_drift_scenario

    return run_drift_scenario(example)


@functools.cache
@_quiet
def periodic_data():
    from hybobs_opt.studies.paper003_switching.comparison import _truth, visible_samples
    from hybobs_opt.systems.event_sampled import periodic_system

    system, trace = _truth("switching_server")
    ps = periodic_system(system)
    t, v, x = visible_samples(trace, ps)
    return system, ps, t, v, x


# ---------------------------------------------------------------------------------- scenarios

def _driveline(kind: str) -> Scenario:
    from hybobs_opt.observers.hybrid_observer import ContinuousObserver, HybridObserver
    from hybobs_opt.observers.location_observer import LocationObserver

    res, x0 = driveline_data()
    tr = res.trace
    Ts = float(tr.t[1] - tr.t[0])
    make = {"hybrid": lambda: HybridObserver(res.bank, res.design, Ts, x0=x0),
            "location": lambda: LocationObserver(res.bank, Ts, x0=x0),
            "continuous": lambda: ContinuousObserver(res.design, Ts, x0=x0)}[kind]
    Q = np.asarray(tr.q, dtype=int) if kind == "continuous" else None
    reset = (lambda o: o.reset(q0=int(Q[0]))) if Q is not None else (lambda o: o.reset())
    lo, hi = res.design.state_box  # the operating box of the design, inside the model's state set
    X = np.asarray(tr.x, dtype=float)
    # the hybrid observer's stated bound is its continuous part's (location assumed right): it does
    # not hold through the location transients (test_bad_samples_regressions), so its tolerance is
    # derived from the clean run
    return Scenario(f"driveline-{kind}", make, reset, np.asarray(tr.u, float).reshape(len(tr.t), -1),
                    np.asarray(tr.y, float).reshape(len(tr.t), -1), X, _width(lo, hi, X), kind != "hybrid",
                    (1000, 2900), Q=Q)


def _powertrain(kind: str) -> Scenario:
    from hybobs_opt.mhe.observer import MHEObserver
    from hybobs_opt.observers.lookup import LookupObserver

    plant, trace, y, an = powertrain_data()
    make = {"lookup": lambda: LookupObserver(an), "miqp": lambda: MHEObserver(plant, 3, analysis=an)}[kind]
    lo, hi = plant.state_bounds.bounding_box()
    X = np.asarray(trace.x, dtype=float)
    N = X.shape[0]
    return Scenario(f"powertrain3-{kind}", make, lambda o: o.reset(), np.asarray(trace.u, float).reshape(N, -1),
                    y.reshape(N, -1), X, _width(lo, hi, X), False, (10, N - 40))


def _sliding(name: str) -> Scenario:
    r = sliding_data(name)
    obs = r.observer
    x0 = np.asarray(r.run.trace.x_hat[0], dtype=float)
    X = np.asarray(r.truth.x, dtype=float)
    N = X.shape[0]
    lo, hi = r.form.automaton.state_bounds.bounding_box()
    window = {"double_scroll": (200, N - 300), "triangular": (6700, N - 300)}[name]

    def make():
        from hybobs_opt.observers.sliding_mode import SlidingModeObserver

        return SlidingModeObserver(r.form, obs.Ts, filter_tau=obs.filter_tau)

    return Scenario(f"sliding-{name}", make, lambda o: o.reset(x0), np.zeros((N, 0)), np.asarray(r.y, float).reshape(N, -1),
                    X, _width(lo, hi, X), False, window)


def _switched(example: str) -> Scenario:
    from hybobs_opt.observers.switched_gain import SwitchedGainObserver
    from hybobs_opt.studies.paper004_nonmonotonic.scenarios import PERIODIC

    design, trace, x0 = switched_data(example)
    dt = float(trace.t[1] - trace.t[0])
    X = np.asarray(trace.x, dtype=float)
    N = X.shape[0]
    U = np.asarray(trace.u, float).reshape(N, -1) if np.size(trace.u) else np.zeros((N, 0))
    sysm = design.system
    window = {"magnetic_piston": (100, 1700), "vehicle_tracking": (100, 1400)}[example]
    return Scenario(example, lambda: SwitchedGainObserver(sysm, design.regions, dt, periodic=PERIODIC.get(example)),
                    lambda o: o.reset(x0), U, np.asarray(trace.y, float).reshape(N, -1), X,
                    _width(sysm.box_lower, sysm.box_upper, X), True, window)


def _drift(example: str) -> Scenario:
    res = drift_data(example)
    obs0 = res["observer"]
    tr = res["trace"]
    keep = tr.t >= res["t"][0]
    t = np.asarray(res["t"], dtype=float)
    X = np.asarray(res["x_true"], dtype=float)
    summ = res["summary"]

    def make():
        from hybobs_opt.observers.drift_observer import DriftObserver

        return DriftObserver(res["system"], res["gains"], project=obs0.project)

    N = t.size
    return Scenario(f"drift-{example}", make,
                    lambda o: o.reset(np.asarray(summ["x_hat_start"], float), t0=float(t[0]), q0=summ["mode_start"]),
                    t.reshape(N, 1), np.asarray(tr.y, float)[keep, :1], X, _width(np.nan, np.nan, X), False,
                    (N // 10, N // 2), time_input=True, integer_output=True)


def _periodic() -> Scenario:
    from hybobs_opt.observers.periodic import PeriodicObserver
    from hybobs_opt.synthesis.periodic_gains import deadbeat_gains

    system, ps, t, v, x = periodic_data()
    N = t.size - 1
    X = np.asarray(x[1:], dtype=float)
    return Scenario("periodic-switching_server", lambda: PeriodicObserver(ps, deadbeat_gains(ps)),
                    lambda o: o.reset(np.zeros(ps.n), t0=float(t[0]), q0=int(v[0])),
                    np.asarray(t[1:], float).reshape(N, 1), np.asarray(v[1:], float).reshape(N, 1), X,
                    _width(np.nan, np.nan, X), False, (3, N - 12), time_input=True, integer_output=True)


BUILDERS: dict[str, Callable[[], Scenario]] = {
    "driveline-hybrid": lambda: _driveline("hybrid"),
    "driveline-location": lambda: _driveline("location"),
    "driveline-continuous": lambda: _driveline("continuous"),
    "powertrain3-lookup": lambda: _powertrain("lookup"),
    "powertrain3-miqp": lambda: _powertrain("miqp"),
    "sliding-double_scroll": lambda: _sliding("double_scroll"),
    "sliding-triangular": lambda: _sliding("triangular"),
    "magnetic_piston": lambda: _switched("magnetic_piston"),
    "vehicle_tracking": lambda: _switched("vehicle_tracking"),
    "drift-traffic_junction": lambda: _drift("traffic_junction"),
    "drift-switching_server": lambda: _drift("switching_server"),
    "periodic-switching_server": _periodic,
}


@functools.cache
def scenario(name: str) -> Scenario:
    return BUILDERS[name]()

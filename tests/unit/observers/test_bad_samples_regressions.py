"""Regression tests of the runtime-observer defects fixed in commit c3f149d (issue 16).

Each test failed on the code before that commit (checked with a worktree of ``c3f149d~1`` on the
``PYTHONPATH``): one bad sample or time stamp in the middle of a paper scenario, then

* the driveline's hybrid, location and continuous observers after ``y = +-1e300`` or
  ``u = 1e300`` end where the clean run ends and flag no wrong estimate ``observable`` (the first
  good sample after a refused one was integrated as a step of the output: the generators were
  kicked by five times the range of omega_l);
* the piston's switched-gain observer after ``y = 1e12`` ends where the clean run ends and flags
  ``observable`` only estimates within 1 % of the operating box (it flagged its initial guess);
* the drift and periodic observers are not disabled by one time stamp ``1e300`` (it became their
  time reference and every later sample was refused as "before the previous one");
* the MHE after ``u = -1e12`` (no input range) ends where the clean run ends;
* ``reset(x0='abc')`` and a complex ``x0`` are ModelErrors in every observer (were a ValueError
  and a silent cast);
* an estimate outside the model's state set is never flagged ``observable`` (a toy observer);
* the oracle: on the clean scenarios every step flagged ``observable`` by the location,
  continuous (on the true location sequence) and switched-gain observers is within its own
  ``info['error_bound']`` of the simulated truth, plus a floor of :data:`INTEGRATION_FLOOR` of the
  box for the integration error (the bound is an independent claim; the hybrid observer's does
  not hold yet: a strict xfail).

The scenarios are those of the fuzz suite (:mod:`fuzz.scenarios`, built once per process).
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from hybobs_opt.contract import FALLBACK, OBSERVABLE, Estimate, Observer
from hybobs_opt.errors import ModelError

from fuzz import scenarios as SC

#: Fraction of the box width allowed on top of a stated error bound (sampled error map vs. the
#: event-located plant: switching instants and input steps fall between samples).
INTEGRATION_FLOOR = 1e-3
#: An ``observable`` estimate is within this fraction of the box (the flag's convergence claim).
OBSERVABLE_FRACTION = 0.01


def run(sc, samples):
    """Estimates, flags and stated bounds of ``sc``'s observer over ``samples`` (fresh reset)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        out = sc.run(samples)
    return out


def faulted(sc, k, *, y=None, u=None):
    samples = sc.clean_samples()
    uk, yk = samples[k]
    if y is not None:
        yk = np.asarray(yk, dtype=float).copy()
        yk[0] = y
    if u is not None:
        uk = np.asarray(uk, dtype=float).copy()
        uk[0] = u
    samples[k] = (uk, yk)
    return samples


def assert_ends_like_clean(sc, out, steps=50, rtol=1e-6):
    clean = sc.clean()
    w = slice(sc.N - steps, sc.N)
    np.testing.assert_array_equal(out["flags"][w], clean["flags"][w])
    np.testing.assert_allclose(out["x"][-1], clean["x"][-1], rtol=rtol, atol=rtol * np.max(sc.width))


def assert_no_wrong_observable(sc, out, fraction=OBSERVABLE_FRACTION):
    """No step flagged observable off the truth by more than ``fraction`` of the box and twice the clean run's error."""
    clean = sc.clean()
    tol = 2.0 * clean["err"] + fraction * sc.width
    bad = np.nonzero((out["flags"] == OBSERVABLE) & (out["err"] > tol).any(axis=1))[0]
    assert bad.size == 0, (f"{bad.size} steps flagged observable with a wrong estimate, first k={bad[0]}: "
                           f"error {out['err'][bad[0]]} > {tol[bad[0]]}")


# ------------------------------------------------------------------ driveline: hybrid, location, continuous

DRIVELINE = ("driveline-hybrid", "driveline-location", "driveline-continuous")
DRIVELINE_FAULT_STEP = 1500  # 1.5 s: every observer out of its warm-up, before the torque step


@pytest.mark.parametrize("fault", ["y=+1e300", "y=-1e300", "u=1e300"])
@pytest.mark.parametrize("name", DRIVELINE)
def test_driveline_observers_recover_from_one_huge_sample(name, fault):
    sc = SC.scenario(name)
    channel, value = fault.split("=")
    out = run(sc, faulted(sc, DRIVELINE_FAULT_STEP, **{channel: float(value)}))
    assert out["flags"][DRIVELINE_FAULT_STEP] != OBSERVABLE
    assert_no_wrong_observable(sc, out)
    assert_ends_like_clean(sc, out)


# ------------------------------------------------------------------ piston: switched gains

def test_piston_recovers_from_one_sensor_fault():
    sc = SC.scenario("magnetic_piston")
    k = 1000
    out = run(sc, faulted(sc, k, y=1e12))
    assert out["flags"][k] == FALLBACK
    assert_ends_like_clean(sc, out)
    observable = out["flags"] == OBSERVABLE
    assert observable[-50:].all()
    # observable means converged: within 1 % of the operating box, not the initial guess
    assert not np.any(observable & (out["err"] > OBSERVABLE_FRACTION * sc.width).any(axis=1))


# ------------------------------------------------------------------ event-driven observers: one clock fault

@pytest.mark.parametrize("name", ["drift-traffic_junction", "drift-switching_server", "periodic-switching_server"])
def test_one_time_stamp_1e300_does_not_disable_the_observer(name):
    sc = SC.scenario(name)
    k = (sc.window[0] + sc.window[1]) // 2
    out = run(sc, faulted(sc, k, u=1e300))
    clean = sc.clean()
    assert out["flags"][k] != OBSERVABLE
    later = out["flags"][k + 1:]
    assert np.count_nonzero(later == FALLBACK) <= 2, "the samples after the fault are refused"
    np.testing.assert_allclose(out["x"][-1], clean["x"][-1], rtol=1e-9, atol=1e-9)
    np.testing.assert_array_equal(out["flags"][-5:], clean["flags"][-5:])


# ------------------------------------------------------------------ MHE: an input fault

def test_mhe_recovers_from_one_input_fault():
    sc = SC.scenario("powertrain3-miqp")
    k = 150
    out = run(sc, faulted(sc, k, u=-1e12))
    assert out["flags"][k] != OBSERVABLE
    assert_no_wrong_observable(sc, out)
    assert_ends_like_clean(sc, out, steps=20)


# ------------------------------------------------------------------ reset(x0=...) in every observer

OBSERVERS = ("powertrain3-lookup", "powertrain3-miqp", "driveline-location", "driveline-hybrid", "driveline-continuous",
             "sliding-double_scroll", "magnetic_piston", "drift-switching_server", "periodic-switching_server")


@pytest.mark.parametrize("x0", ["abc", "complex"])
@pytest.mark.parametrize("name", OBSERVERS)
def test_reset_refuses_a_string_or_complex_state(name, x0):
    sc = SC.scenario(name)
    obs = sc.observer()
    bad = "abc" if x0 == "abc" else sc.X[0].astype(complex) + 1e-3j
    kwargs = {"t0": 0.0} if sc.time_input else {}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # a silent complex cast is a ComplexWarning: an error here
        with pytest.raises(ModelError, match="x0"):
            obs.reset(bad, **kwargs)


# ------------------------------------------------------------------ the state set

class _Toy(Observer):
    """One state in [0, 1]; its _step claims 'observable' for whatever ``y`` says the state is."""

    name = "toy"
    n, m, p = 1, 0, 1
    state_names = ("x",)

    def __init__(self):
        self.state_range = (np.array([0.0]), np.array([1.0]))
        self.reset()

    def reset(self, x0=None, **kwargs):
        self.x = np.array([0.5])

    def _step(self, u, y):
        self.x = np.asarray(y, dtype=float).copy()
        return Estimate(self.x.copy(), 0, OBSERVABLE, 0.0, {})

    def _fallback(self, u, reason):
        return Estimate(self.x.copy(), 0, FALLBACK, 0.0, {"reason": reason})


@pytest.mark.parametrize("x", [-5.0, 1.5, 1e6])
def test_an_estimate_outside_the_state_set_is_never_observable(x):
    e = _Toy().step(np.zeros(0), np.array([x]))
    assert e.flag != OBSERVABLE and "x" in e.info.get("reason", "")


def test_an_estimate_inside_the_state_set_keeps_its_flag():
    assert _Toy().step(np.zeros(0), np.array([0.995])).flag == OBSERVABLE
    assert _Toy().step(np.zeros(0), np.array([1.005])).flag == OBSERVABLE  # within STATE_SET_MARGIN


# ------------------------------------------------------------------ the oracle: stated bounds vs. the truth

def _bound_violations(name):
    sc = SC.scenario(name)
    c = sc.clean()
    observable = c["flags"] == OBSERVABLE
    assert observable.any() and np.all(np.isfinite(c["bounds"][observable]))
    excess = c["err"] - c["bounds"] - INTEGRATION_FLOOR * sc.width
    return np.nonzero(observable & (excess > 0).any(axis=1))[0], c, sc


@pytest.mark.parametrize("name", [
    "driveline-location", "driveline-continuous", "magnetic_piston", "vehicle_tracking",
    # was a strict xfail: HybridObserver kept contracting its bound through a detected switch and
    # flagged observable theta 9.5e-4 rad (1.9 % of the box) off at 2.112 s while its bound said 1e-8
    "driveline-hybrid",
])
def test_observable_steps_are_within_the_stated_error_bound(name):
    bad, c, sc = _bound_violations(name)
    assert bad.size == 0, (f"{bad.size} observable steps outside error_bound + floor, first k={bad[0]}: error "
                           f"{c['err'][bad[0]]}, bound {c['bounds'][bad[0]]}")

"""Ultimate error bound of the switched-gain observer under bounded noise (:mod:`hybobs_opt.lmi.switched_noise`,
:mod:`hybobs_opt.lmi.switched_noise_sim`) on the vehicle tracker with the preset's two regions.

The oracles share no code with the bound:

* the jumps ``mu_ij`` as the largest generalised eigenvalue of ``(P_j / c_j, P_i / c_i)``
  (:func:`scipy.linalg.eigh`), the dwell time needed ``ln(mu) / alpha``, the level
  ``u* = max(1, mu (1 - e^{-alpha tau}) / (1 - mu e^{-alpha tau}))`` and the bound
  ``sqrt(u*) max_i sqrt(c_i (P_i^-1)_kk)`` written out here from the regions' ``P_i, c_i, alpha_i``;
* the simulator: without switching it reproduces :func:`.noise_sim.simulate_noisy_observer`, and
  without noise its gain follows the hysteresis of paper 004 Fig. 1 replayed here on its own trajectory;
* plant and switched observer under bounded noise (random, sinusoids near each region's worst
  frequency, sign noises), the yaw angle swinging from 50 to 90 deg and back across the switching
  band 60-80 deg: the error never leaves the certified bound.

Measured (the numbers behind the assertions):

* at the declared radar noise 0.2 m the preset's gains (``||L||_2`` about 160) turn the noise into
  a yaw-estimate error of about 1 rad: the estimate leaves its region (and the steering estimate
  its +-10 deg box) and the estimated yaw crosses the 20 deg hysteresis band within milliseconds,
  so no run tests the bound there (its yaw bound, 14.4 rad, is vacuous too);
* so the simulation check uses the certificate at 0.02 m (exact by homogeneity,
  :meth:`.switched_noise.SwitchedNoiseBound.scaled`): there 44 of 48 runs are tests, with 88 switches,
  and the bound is 10.4 (X), 12.5 (Y), 11.3 (psi), 12.6 (delta_f) times the largest simulated error
  (random and sinusoidal noises alone: 10.8, 12.9, 14.6, 15.1): not within the 10x asked for, see
  :func:`test_bound_is_within_10x_of_the_largest_simulated_error`;
* noise three times the declared one does not push the error above the declared bound (at most
  0.27 of it at 0.02 m); 15 times the declared 2 mm does (:func:`test_more_noise_than_declared_exceeds_the_bound`).
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
import scipy.linalg

from hybobs_opt import get_example
from hybobs_opt.lmi.noise_sim import random_noise, simulate_noisy_observer
from hybobs_opt.lmi.switched_noise import switched_noise_bound
from hybobs_opt.lmi.switched_noise_sim import check_switched_noise_bound, simulate_switched_noisy_observer
from hybobs_opt.studies.paper004_nonmonotonic.presets import get_preset, preset_design, scaling_for

pytestmark = pytest.mark.slow  # the bound takes about 15 s, the simulation check about 8 s

NOISE = 0.2  # m, radar noise on X and Y (declared)
SCALE = 0.1  # the simulation check runs at 0.02 m (module docstring)
V, L_SUM = 10.0, 1.1 + 1.58  # speed and l_f + l_r of the example
SWING_W = 0.5  # rad/s
PSI0 = math.radians(50.0)
T_FINAL = 13.0  # s: one yaw swing 50 -> 90 -> 50 deg (period 4 pi / SWING_W = 12.6 s), crossing the band twice


def swing_steer() -> float:
    """Steering amplitude of ``delta_f = a sin(w t)`` for a yaw swing of about 40 deg (``psi' = K tan(delta_f)``)."""
    return math.radians(20.0) * SWING_W / (V / L_SUM)


def swing_drive(t, X):
    """Steering rate ``a w cos(w t)``: the yaw goes from 50 deg to about 90 deg and back every 12.6 s."""
    return np.full((X.shape[0], 1), swing_steer() * SWING_W * math.cos(SWING_W * t))


def swing_start() -> np.ndarray:
    """At 10 m/s with yaw 50-90 deg the vehicle stays inside the +-500 m box for the 20 s horizon."""
    return np.array([-450.0, -450.0, PSI0, 0.0])


@pytest.fixture(scope="module")
def vehicle():
    system = get_example("vehicle_tracking").build()
    design = preset_design("vehicle_tracking", system)
    scaling = scaling_for(get_preset("vehicle_tracking"), system)
    snb = switched_noise_bound(design, [NOISE, NOISE], reference=scaling, scaling=scaling)
    return system, design, snb


@pytest.fixture(scope="module")
def swing_check(vehicle):
    _, _, snb = vehicle
    return check_switched_noise_bound(snb.scaled(SCALE), swing_drive, swing_start(), t_final=T_FINAL,
                                      random_runs=16, families=("random", "sinusoid", "sign"))


# ---------------------------------------------------------------------------- (a) the certificate
def expected_level(mu: float, alpha: float, tau: float) -> float:
    q = mu * math.exp(-alpha * tau)
    return max(1.0, mu * (1.0 - math.exp(-alpha * tau)) / (1.0 - q))


def test_bound_holds_and_rechecks_independently(vehicle):
    _, design, snb = vehicle
    assert snb.holds and snb.bound is not None
    assert all(d.verify() for d in snb.by_region)
    assert len(snb.by_region) == len(design.regions) == 2
    # jumps: the largest generalised eigenvalue of (P_j / c_j, P_i / c_i)
    assert set(snb.jumps) == set(design.pairs) == {(0, 1), (1, 0)}
    for (i, j), mu in snb.jumps.items():
        Pi, Pj = snb.by_region[i].P, snb.by_region[j].P
        ci, cj = snb.by_region[i].level, snb.by_region[j].level
        w = scipy.linalg.eigh(0.5 * (Pj + Pj.T) / cj, 0.5 * (Pi + Pi.T) / ci, eigvals_only=True)
        assert mu == pytest.approx(w[-1], rel=1e-9), (i, j)
    alpha = min(d.alpha for d in snb.by_region)
    mu = max(snb.jumps.values())
    assert snb.alpha == pytest.approx(alpha, rel=1e-12) and snb.jump == pytest.approx(mu, rel=1e-12)
    assert mu > 1.0
    assert snb.dwell_needed == pytest.approx(math.log(mu) / alpha, rel=1e-12)
    assert snb.dwell == pytest.approx(design.dwell_guaranteed, rel=1e-12)
    assert snb.dwell > snb.dwell_needed
    assert snb.level == pytest.approx(expected_level(mu, alpha, snb.dwell), rel=1e-12)
    per_region = np.array([np.sqrt(d.level * np.diag(np.linalg.inv(d.P))) for d in snb.by_region])
    main = math.sqrt(snb.level) * per_region.max(axis=0)
    # each state's bound: the main certificate's, or a tighter one chosen for that state, re-checked here
    tighter = {}
    for c in snb.state_certificates:
        assert all(d.verify() for d in c.by_region)
        mus = [scipy.linalg.eigh(0.5 * (c.by_region[j].P + c.by_region[j].P.T) / c.by_region[j].level,
                                 0.5 * (c.by_region[i].P + c.by_region[i].P.T) / c.by_region[i].level,
                                 eigvals_only=True)[-1] for i, j in snb.jumps]
        a = min(d.alpha for d in c.by_region)
        lvl = expected_level(max(mus), a, snb.dwell)
        pr = np.array([np.sqrt(d.level * np.diag(np.linalg.inv(d.P))) for d in c.by_region])
        np.testing.assert_allclose(c.bound, math.sqrt(lvl) * pr.max(axis=0), rtol=1e-9)
        assert max(mus) * math.exp(-a * snb.dwell) < 1.0
        tighter[c.state] = c.bound[c.state]
    for k in range(4):
        assert snb.bound[k] == pytest.approx(min(main[k], tighter.get(k, np.inf)), rel=1e-9)
    np.testing.assert_allclose(snb.noise, [NOISE, NOISE])
    assert json.loads(json.dumps(snb.to_dict()))["holds"] is True


def test_the_certificate_scales_with_the_noise(vehicle):
    _, _, snb = vehicle
    small = snb.scaled(SCALE)
    assert small.holds and all(d.verify() for d in small.by_region)
    np.testing.assert_allclose(small.bound, SCALE * snb.bound, rtol=1e-12)
    np.testing.assert_allclose(small.noise, SCALE * snb.noise, rtol=1e-12)
    assert small.level == snb.level and small.dwell_needed == snb.dwell_needed
    for (i, j), mu in snb.jumps.items():
        Pi, Pj = small.by_region[i].P / small.by_region[i].level, small.by_region[j].P / small.by_region[j].level
        assert scipy.linalg.eigh(Pj, Pi, eigvals_only=True)[-1] == pytest.approx(mu, rel=1e-9)
    with pytest.raises(Exception, match="factor"):
        snb.scaled(0.0)


# ---------------------------------------------------------------------------- (b) the simulator
def test_without_switching_the_simulator_is_the_constant_gain_one(vehicle):
    """Yaw fixed at 30 deg (region 0 only): the same runs as :func:`.noise_sim.simulate_noisy_observer` with ``L_0``."""
    system, design, snb = vehicle
    x0 = np.tile([-450.0, -450.0, math.radians(30.0), 0.0], (3, 1))
    e0 = np.array([0.3, -0.2, 0.02, 0.0])
    dt = 2e-3

    def still(t, X):
        return np.zeros((X.shape[0], 1))

    ours = simulate_switched_noisy_observer(snb, x0, x0 - e0, still, random_noise(snb.noise, 10 * dt, [1, 2, 3]),
                                            1.0, dt)
    ref = simulate_noisy_observer(system, design.regions[0].L, x0, x0 - e0, still,
                                  random_noise(snb.noise, 10 * dt, [1, 2, 3]), 1.0, dt)
    assert np.all(ours.q == 0)
    np.testing.assert_allclose(ours.x, ref.x, rtol=0, atol=1e-9)
    np.testing.assert_allclose(ours.x_hat, ref.x_hat, rtol=0, atol=1e-9)


def test_without_noise_the_gain_follows_the_hysteresis(vehicle):
    """Zero noise, zero error: the region switches up at the first sample with yaw above 80 deg, down below 60 deg."""
    system, design, snb = vehicle
    x0 = swing_start()[None, :]
    run = simulate_switched_noisy_observer(snb, x0, x0, swing_drive, lambda t: np.zeros((1, 2)), 20.0, 5e-3)
    np.testing.assert_array_equal(run.x, run.x_hat)
    psi = run.x_hat[:, 0, 2]
    up, down = design.regions[0].region.hi, design.regions[1].region.lo
    assert (up, down) == pytest.approx((math.radians(80.0), math.radians(60.0)))
    assert psi.min() < down and psi.max() > up
    q, expected = 0, [0]
    for s in psi[1:]:
        if q == 0 and s > up:
            q = 1
        elif q == 1 and s < down:
            q = 0
        expected.append(q)
    np.testing.assert_array_equal(run.q[:, 0], expected)
    assert np.count_nonzero(np.diff(expected)) == 3  # up, down, up within 20 s
    assert not run.left[0] and run.overshoot[0] <= 1e-3


# ---------------------------------------------------------------------------- (c) the bound under noise
def test_bound_holds_under_bounded_noise_with_switches(swing_check, record_property):
    check = swing_check
    record_property("switched_noise_ratio", check.ratio.tolist())  # bound / largest simulated error (junit XML)
    record_property("switched_noise_check", {k: v for k, v in check.to_dict().items() if k != "runs_detail"})
    tested = sum(check.runs_by_family[f][1] for f in ("random", "sinusoid"))
    assert tested >= 20, check.runs_by_family
    assert check.valid_runs >= 20 and check.runs == 48
    assert check.switches_valid > 0
    valid = [r for r in check.run_details if r.valid]
    assert all(len(r.switch_times) >= 2 for r in valid)  # the yaw estimate crossed the band both ways
    assert check.dwell_violations == 0 and check.min_dwell_observed > check.dwell
    assert check.plant_left_box == 0
    assert check.exceeded == 0, "the error of a valid run exceeded the certified bound"
    assert np.all(check.max_error <= check.bound)
    assert check.exceeded_no_test == 0
    # not vacuous: what holds (measured 10.4 - 12.6); the 10x is checked below
    assert np.all(check.ratio >= 1.0) and np.all(check.ratio <= 15.0), check.ratio
    assert json.loads(json.dumps(check.to_dict()))["valid_runs"] == check.valid_runs


@pytest.mark.xfail(strict=True, reason="measured bound / largest simulated error: 10.4 (X), 12.5 (Y), 11.3 (psi), "
                                       "12.6 (delta_f); the switching inflation sqrt(u*) = 1.39 on per-region "
                                       "ellipsoids already 7.5-9x the simulated errors")
def test_bound_is_within_10x_of_the_largest_simulated_error(swing_check):
    assert np.all(swing_check.ratio <= 10.0), swing_check.ratio


def test_an_initial_error_is_compared_with_the_certified_envelope(vehicle):
    """From ``e0`` the error stays below the envelope; ``max_error`` is taken once it is within 1 % of the bound."""
    _, _, snb = vehicle
    small = snb.scaled(SCALE)
    e0 = np.array([0.2, -0.2, 0.01, 0.0])  # larger initial errors take the estimates out of the regions
    check = check_switched_noise_bound(small, swing_drive, swing_start(), e0=e0, t_final=15.0, random_runs=8,
                                       families=("random",))
    d0 = small.by_region[0]
    mu = small.jump
    excess = (float(e0 @ d0.P @ e0) / d0.level - 1.0) * mu / small.level
    assert excess > 0
    rate = small.alpha - math.log(mu) / small.dwell
    assert check.t_transient == pytest.approx(math.log(excess / (1.01 ** 2 - 1.0)) / rate, rel=1e-12)
    assert 0.0 < check.t_transient < 10.0  # 3.9 s
    assert check.valid_runs >= 4 and check.exceeded == 0 and check.switches_valid > 0
    assert np.all(check.max_error <= check.bound)


def test_at_the_declared_noise_the_estimate_leaves_its_region(vehicle, record_property):
    """At 0.2 m no run is a test: the yaw-estimate error exceeds the hysteresis (module docstring).

    If a later design keeps its estimates in the regions at 0.2 m, run the simulation check at 0.2 m.
    """
    _, design, snb = vehicle
    check = check_switched_noise_bound(snb, swing_drive, swing_start(), t_final=6.0, random_runs=8)
    record_property("declared_noise_check", {k: v for k, v in check.to_dict().items() if k != "runs_detail"})
    assert check.valid_runs == 0 and check.left_region == check.runs
    assert check.max_error_no_test[2] > design.overlap  # yaw error (rad) above the hysteresis epsilon
    assert check.min_dwell_observed < check.dwell  # the estimated yaw chatters across the band


def test_more_noise_than_declared_exceeds_the_bound(vehicle):
    """The bound is claimed for the declared noise only, and the check sees a violation when there is one.

    Three times the declared noise stays below the declared bound (measured: at most 0.27 of it,
    module docstring); 15 times the declared 2 mm (the sign noises) takes the error above it.
    """
    _, _, snb = vehicle
    declared = snb.scaled(0.01)  # 2 mm
    check = check_switched_noise_bound(declared, swing_drive, swing_start(), t_final=20.0, families=("sign",),
                                       noise_scale=15.0)
    assert check.valid_runs >= 1 and check.switches_valid > 0
    assert check.exceeded > 0 and np.any(check.max_error > check.bound)


# ---------------------------------------------------------------------------- gains designed for the noise
@pytest.fixture(scope="module")
def designed(vehicle):
    """Gains on the preset's regions that minimise the switched bound, at its gain bound and slowest rate."""
    system, design, _ = vehicle
    scaling = scaling_for(get_preset("vehicle_tracking"), system)
    return switched_noise_bound(design, [NOISE, NOISE], reference=scaling, scaling=scaling, design_gains=True,
                                gain_bound=design.gain_bound, min_decay=min(r.sigma for r in design.regions))


def test_gains_designed_for_the_noise_are_bounded_within_10x_of_the_simulated_error(vehicle, designed,
                                                                                       record_property):
    """Measured: bound (1.30 m, 1.36 m, 2.37 rad, 0.39 rad) at 0.2 m; at 0.02 m 28 of 48 runs are tests,
    56 switches, bound / largest error 3.3 (X), 5.5 (Y), 2.0 (psi), 1.26 (delta_f)."""
    _, design, given = vehicle
    assert designed.holds and designed.gains == "designed" and all(d.verify() for d in designed.by_region)
    assert all(np.linalg.norm(d.L, 2) <= design.gain_bound * (1 + 1e-6) for d in designed.by_region)
    assert designed.alpha >= min(r.sigma for r in design.regions) * (1 - 1e-3)
    assert np.all(designed.bound < given.bound)  # the synthesised gains amplify the noise more on every state
    check = check_switched_noise_bound(designed.scaled(SCALE), swing_drive, swing_start(), t_final=T_FINAL,
                                       random_runs=16, families=("random", "sinusoid", "sign"))
    record_property("designed_switched_noise_ratio", check.ratio.tolist())
    assert check.valid_runs >= 20 and check.switches_valid > 0 and check.dwell_violations == 0
    assert check.exceeded == 0 and np.all(check.max_error <= check.bound)
    assert np.all(check.ratio >= 1.0) and np.all(check.ratio <= 10.0), check.ratio

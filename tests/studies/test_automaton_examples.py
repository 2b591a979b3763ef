"""Physics of the hybrid-automaton examples of papers 000 (driveline) and 001 (sliding-mode examples).

Every expected value here comes from the papers' equations worked by hand or integrated
independently (scipy ``expm`` / ``solve_ivp`` on right-hand sides written out in this file), never
from the code under test.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from scipy.linalg import expm

from hybobs_opt.sim.hybrid import simulate_hybrid
from hybobs_opt.studies import get_example
from hybobs_opt.studies.paper000_driveline.systems import driveline
from hybobs_opt.studies.paper001_sliding_mode.systems import (
    P_DERIVED,
    double_scroll,
    double_scroll_canonical_form,
    switched_unstable,
)

# ------------------------------------------------------------------ paper 001, Example 1


def test_example1_each_subsystem_alone_stays_bounded():
    """Sigma_1 and Sigma_2 alone are centres: circles x1^2 + x2^2 and ellipses 4 x1^2 + x2^2."""
    system = switched_unstable()
    flows = {}
    for loc in system.locations:
        flows.setdefault(loc.name.split("_")[0], loc.A)
    np.testing.assert_array_equal(flows["Sigma1"], [[0.0, -1.0], [1.0, 0.0]])  # paper: x1' = -x2, x2' = x1
    np.testing.assert_array_equal(flows["Sigma2"], [[0.0, -1.0], [4.0, 0.0]])  # paper: x1' = -x2, x2' = 4 x1
    x0 = np.array([1.0, 0.5])
    ts = np.linspace(0.0, 20.0, 401)
    for name, weight in (("Sigma1", 1.0), ("Sigma2", 4.0)):
        X = np.array([expm(flows[name] * t) @ x0 for t in ts])
        invariant = weight * X[:, 0] ** 2 + X[:, 1] ** 2
        np.testing.assert_allclose(invariant, invariant[0], rtol=1e-9)
        # An ellipse with axis ratio 2 keeps the norm within a factor 2 of its start.
        assert np.max(np.linalg.norm(X, axis=1)) <= 2.0 * np.linalg.norm(x0)


def test_example1_switched_system_grows_by_four_per_revolution():
    """Quadrant by quadrant from (1, 0): (0, 2) at pi/4, (-2, 0) at 3pi/4, (0, -4) at pi, (4, 0) at 3pi/2."""
    trace = get_example("switched_unstable").simulate()
    pi = np.pi
    expected = [
        (pi / 4, (0.0, 2.0)),
        (3 * pi / 4, (-2.0, 0.0)),
        (pi, (0.0, -4.0)),
        (3 * pi / 2, (4.0, 0.0)),
        (3 * pi / 2 + pi / 4, (0.0, 8.0)),
        (3 * pi / 2 + 3 * pi / 4, (-8.0, 0.0)),
        (3 * pi / 2 + pi, (0.0, -16.0)),
        (3 * pi, (16.0, 0.0)),
    ]
    assert len(trace.events) >= len(expected)
    for event, (t, x) in zip(trace.events, expected):
        assert event["t"] == pytest.approx(t, rel=1e-7)
        np.testing.assert_allclose(event["x"], x, atol=1e-6 * max(1.0, np.abs(x).max()))
    norms = np.linalg.norm(trace.x, axis=1)
    assert norms[-1] / norms[0] > 10.0  # ~29 at t = 10 s
    # Each subsystem alone would keep the norm within a factor 2: the growth is the switching's.


def test_example1_rule_as_printed_contracts_instead():
    """Printed rule (Sigma_1 where x1 x2 > 0): (0, 1), (-1/2, 0), (0, -1/2), (1/4, 0) at 3pi/2."""
    system = switched_unstable(as_printed=True)
    trace = simulate_hybrid(system, [1.0, 0.0], 3 * np.pi / 2 + 0.1, dt=1e-2)
    pts = [e["x"] for e in trace.events[:4]]
    np.testing.assert_allclose(pts, [(0.0, 1.0), (-0.5, 0.0), (0.0, -0.5), (0.25, 0.0)], atol=1e-7)


# ------------------------------------------------------------------ paper 001, Example 2


def test_triangular_switching_indicator_switches_and_f1_is_reversible():
    trace = get_example("triangular").simulate()
    x2, x3 = trace.x[:, 1], trace.x[:, 2]
    indicator = (x2 >= 0).astype(int)  # S = 1 when sigma(x) = x2 >= 0 (dynamics F2)
    assert np.count_nonzero(np.diff(indicator)) >= 2
    assert indicator[0] == 1 and indicator.min() == 0 and indicator[-1] == 1
    # The automaton's location agrees with the sign of sigma away from the switching surface.
    away = np.abs(x2) > 1e-6
    names = np.array(trace.location_names)[trace.q]
    assert np.all((names[away] == "F2") == (x2[away] >= 0))
    sequence = [(trace.location_names[e["from"]], trace.location_names[e["to"]]) for e in trace.events]
    assert sequence[:2] == [("F2", "F1"), ("F1", "F2")]
    # In F2, x3' = 40 sin(300 x3) - 0.5 locks x3 onto 300 x3 = pi - asin(1/80) + 2 pi j within ms.
    x3_plus = (np.pi - np.arcsin(1.0 / 80.0)) / 300.0
    x3_minus = x3_plus - 2 * np.pi / 300.0
    x_in, x_out = trace.events[0]["x"], trace.events[1]["x"]
    assert x_in[2] == pytest.approx(x3_minus, rel=1e-4)
    # F1 is x2'' = 0.4 - cos(30 x2), time-reversible: it returns to x2 = 0 with x3 reversed.
    assert x_out[2] == pytest.approx(-x_in[2], rel=1e-5)
    assert x3[-1] == pytest.approx(x3_plus, rel=1e-4)


# ------------------------------------------------------------------ paper 001, Example 3


def _chua(t, x):
    """Chua's circuit with alpha = 9, beta = 100/7, diode slopes m0 = -8/7, m1 = -5/7."""
    m0, m1 = -8.0 / 7.0, -5.0 / 7.0
    g = m1 * x[0] + 0.5 * (m0 - m1) * (abs(x[0] + 1.0) - abs(x[0] - 1.0))
    return [9.0 * (x[1] - x[0] - g), x[0] - x[1] + x[2], -100.0 / 7.0 * x[1]]


def test_double_scroll_is_chuas_circuit():
    trace = simulate_hybrid(double_scroll(), [0.1, 0.0, 0.0], 5.0, dt=1e-2)
    ref = solve_ivp(_chua, (0.0, 5.0), [0.1, 0.0, 0.0], method="DOP853", rtol=1e-11, atol=1e-13, t_eval=trace.t)
    np.testing.assert_allclose(trace.x, ref.y.T, atol=1e-5)
    np.testing.assert_allclose(trace.y[:, 0], ref.y[2], atol=1e-5)  # y = x3


def test_double_scroll_visits_both_scrolls():
    trace = get_example("double_scroll").simulate()
    x1 = trace.x[:, 0]
    assert np.count_nonzero(np.diff(np.sign(x1))) >= 4
    assert 0.15 < np.mean(x1 > 0) < 0.85
    names = np.array(trace.location_names)[trace.q]
    assert np.all(x1[names == "q1"] >= 1 - 1e-6) and np.all(x1[names == "q3"] <= -1 + 1e-6)
    assert np.mean(names == "q1") > 0.1 and np.mean(names == "q3") > 0.1
    # Bounded attractor: the classical double scroll stays within |x1| < 3.
    assert np.max(np.abs(x1)) < 3.0


def test_double_scroll_canonical_form():
    """z = T x turns each location into z1' = z2, z2' = z3, z3' = p . z + beta, y = z1, sigma = x1."""
    cf = double_scroll_canonical_form()
    np.testing.assert_allclose(cf.T_inv @ cf.T, np.eye(3), atol=1e-12)
    by_hand = [  # alpha1 = -a1 c1, alpha2 = a1 + 9 + c1, alpha3 = a1 - 1, beta = a3 c1, c1 = -100/7
        (-1800 / 49, -55 / 7, -25 / 7, -2700 / 49),
        (900 / 49, -4.0, 2 / 7, 0.0),
        (-1800 / 49, -55 / 7, -25 / 7, 2700 / 49),
    ]
    np.testing.assert_allclose(P_DERIVED, by_hand, rtol=1e-15)
    system = double_scroll()
    for loc, p in zip(system.locations, by_hand):
        companion = np.array([[0, 1, 0], [0, 0, 1], p[:3]], dtype=float)
        np.testing.assert_allclose(cf.T @ loc.A @ cf.T_inv, companion, atol=1e-12)
        np.testing.assert_allclose(cf.T @ loc.E, [0.0, 0.0, p[3]], atol=1e-12)
        np.testing.assert_allclose(loc.C @ cf.T_inv, [[1.0, 0.0, 0.0]], atol=1e-15)
    x = np.array([0.3, -0.2, 1.7])
    assert cf.sigma @ (cf.T @ x) == pytest.approx(x[0], abs=1e-14)
    # The printed P2 is the canonical form of a1 = 1/7, not of A2 = A_{9/7}.
    printed = double_scroll_canonical_form(printed=True)
    assert printed.P[1][2] == pytest.approx(1 / 7 - 1) and not np.allclose(printed.P[1], by_hand[1])


# ------------------------------------------------------------------ paper 000, driveline

THETA_E0, THETA_1 = 0.025, 0.015  # paper 000, text of Fig. 6
ALPHA, JE, JV, BE, K1 = 1 / 12, 0.30, 140.0, 2.0, 1e4  # the documented Table 1 choices


def _elastic(theta):
    """Elastic torque of Fig. 2 with k = 0 (backlash of half-width theta_1), k1 beyond."""
    if theta > THETA_1:
        return K1 * (theta - THETA_1)
    if theta < -THETA_1:
        return K1 * (theta + THETA_1)
    return 0.0


def _driveline_rhs(u):
    """Eq. (1) of paper 000 written out: torsion rate, crankshaft and wheel torque balances."""

    def rhs(t, x):
        torque = _elastic(x[0] + THETA_E0) - _elastic(THETA_E0)  # T_sm deviation (bsm = 0)
        return [ALPHA * x[1] - x[2], (u - BE * x[1] - ALPHA * torque) / JE, torque / JV]

    return rhs


@pytest.mark.parametrize(
    "x0, u, location",
    [
        ((0.02, 3.0, -0.2), 5.0, "q3"),  # positive contact
        ((-0.025, -1.0, 0.1), -10.0, "q2"),  # inside the gap
        ((-0.06, 2.0, 0.3), 20.0, "q1"),  # negative contact
    ],
)
def test_driveline_discretization_is_exact_over_one_sample(x0, u, location):
    Ts = 1e-3  # the sampling period of paper 002
    system = driveline()
    pwa = system.discretize(Ts)
    x0 = np.array(x0)
    i = pwa.mode_of(x0, [u])
    assert pwa.modes[i].name == location
    ref = solve_ivp(_driveline_rhs(u), (0.0, Ts), x0, method="DOP853", rtol=1e-13, atol=1e-16, dense_output=True)
    # The sample never crosses a threshold (-0.04 or -0.01 rad), so the frozen-location map is exact.
    path = ref.sol(np.linspace(0.0, Ts, 51))[0]
    assert np.all([system.location_names[system.location_of([th, 0.0, 0.0])] == location for th in path])
    scale = np.abs(x0) + np.abs(ref.y[:, -1])
    np.testing.assert_array_less(np.abs(pwa.step(x0, [u]) - ref.y[:, -1]), 1e-9 * scale)
    np.testing.assert_allclose(pwa.output(x0, [u]), [30 / np.pi * x0[1]], rtol=1e-12)  # rpm


def test_driveline_engine_speed_ignores_wheel_side_in_backlash():
    """In q2 no torque crosses the gap: the crankshaft speed cannot depend on torsion or wheel speed."""
    system = driveline()
    u, horizon = -10.0, 0.04
    nominal = np.array([-0.02, -1.5, 0.0])
    perturbed = nominal + np.array([-0.005, 0.0, 0.1])  # wheel-side states only
    runs = [simulate_hybrid(system, x, horizon, u=[u], dt=1e-3) for x in (nominal, perturbed)]
    for run in runs:
        assert set(np.array(run.location_names)[run.q]) == {"q2"}
    assert np.max(np.abs(runs[0].x[:, 2] - runs[1].x[:, 2])) > 0.05  # the wheel side did differ
    np.testing.assert_allclose(runs[1].y, runs[0].y, rtol=1e-9, atol=1e-9)
    # Control: the same perturbation in contact (q3) changes the engine speed.
    contact = [simulate_hybrid(system, x + np.array([0.03, 0.0, 0.0]), horizon, u=[u], dt=1e-3) for x in (nominal, perturbed)]
    for run in contact:
        assert set(np.array(run.location_names)[run.q]) == {"q3"}
    assert np.max(np.abs(contact[0].y - contact[1].y)) > 1.0  # rpm


def test_driveline_torque_step_enters_and_leaves_the_backlash():
    """Fig. 6: the -10 N m step at t = 2 s drops the torsion through -theta_e0 + theta_1 = -0.01 rad."""
    trace = get_example("driveline").simulate(t_final=10.0)
    names = trace.location_names
    sequence = [(names[e["from"]], names[e["to"]]) for e in trace.events]
    assert sequence[:2] == [("q3", "q2"), ("q2", "q3")]
    threshold = -THETA_E0 + THETA_1
    for event in trace.events[:2]:
        assert event["t"] > 2.0
        assert event["x"][0] == pytest.approx(threshold, abs=1e-9)
    before = trace.t < 2.0
    np.testing.assert_allclose(trace.x[before], 0.0, atol=1e-12)  # the operating point is an equilibrium
    # Fig. 6 shows only the residual flags of locations 2 and 3: the far side -0.04 rad is not reached.
    assert -THETA_E0 - THETA_1 < trace.x[:, 0].min() < threshold - 1e-3
    # Afterwards the torque deficit is absorbed by the engine friction: x2 -> u / Be, x1 -> 0.
    assert trace.x[-1, 1] == pytest.approx(-10.0 / BE, rel=1e-2)
    assert trace.x[-1, 2] == pytest.approx(ALPHA * -10.0 / BE, rel=1e-2)
    assert abs(trace.x[-1, 0]) < 1e-3

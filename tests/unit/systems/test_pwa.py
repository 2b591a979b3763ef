"""PWA systems (paper 002, eq. 1) and the powertrain models (16), (17): physics and bad input."""

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.sim import simulate_pwa, simulate_pwa_batch
from hybobs_opt.studies.paper002_powertrain.systems import TABLE1, powertrain3, powertrain5
from hybobs_opt.systems import Polytope, PWAMode, PWASystem


def test_backlash_band_engine_speed_independent_of_shaft_and_wheel():
    """Eq. (18): with |theta| < alpha the engine speed does not depend on theta or omega_l."""
    plant = powertrain3()
    alpha = TABLE1["alpha"]
    T = 5
    U = np.full((1, T, 1), 70.0)
    # Same engine speed, different shaft angles (inside the band) and wheel speeds; short
    # horizon so the shaft stays inside the band (|tau omega_m - omega_l| Ts T << alpha).
    X0 = np.array([[-0.5 * alpha, 30.0, 2.5], [0.0, 30.0, 2.5], [0.4 * alpha, 30.0, 2.4]])
    X, Q, Y = simulate_pwa_batch(plant, X0, np.repeat(U, 3, axis=0))
    assert np.all(Q == 1), "all trajectories must stay in the backlash mode"
    np.testing.assert_allclose(X[0, :, 1], X[1, :, 1], rtol=0, atol=1e-12)
    np.testing.assert_allclose(X[0, :, 1], X[2, :, 1], rtol=0, atol=1e-12)
    # ...and it follows the decoupled engine model (18b) computed by hand
    Jm, bm, Ts = TABLE1["Jm"], TABLE1["beta_m"], 1e-3
    w = 30.0
    for t in range(T):
        w = w + Ts / Jm * (70.0 - bm * w)
    assert X[0, T, 1] == pytest.approx(w, rel=1e-12)
    # The wheel decays on its own, eq. (18c)
    assert X[0, T, 2] == pytest.approx(2.5 * (1 - 1e-3 * TABLE1["beta_l"] / TABLE1["Jl"]) ** T, rel=1e-12)


def test_contact_couples_engine_to_shaft():
    """Out of the band the shaft torque k D_alpha(theta) slows the engine: the engine speed depends on theta."""
    plant = powertrain3()
    x_a = np.array([0.06, 30.0, 2.5])
    x_b = np.array([0.08, 30.0, 2.5])
    da = plant.step(x_a, [70.0])[1] - plant.step(x_b, [70.0])[1]
    tau, k, Jm = TABLE1["gear_ratio"], TABLE1["k"], TABLE1["Jm"]
    assert da == pytest.approx(1e-3 / Jm * tau * k * 0.02, rel=1e-9)


def test_dead_zone_torque_continuous_at_band_edges():
    plant = powertrain3()
    alpha = TABLE1["alpha"]
    for sign in (-1, 1):
        edge = sign * alpha
        inside = plant.step([edge - sign * 1e-12, 50.0, 4.0], [60.0])
        outside = plant.step([edge + sign * 1e-12, 50.0, 4.0], [60.0])
        np.testing.assert_allclose(inside, outside, atol=1e-6)


def test_mode_lookup_and_output():
    plant = powertrain3()
    assert plant.mode_of([-0.1, 10, 0], [10]) == 0
    assert plant.mode_of([0.0, 10, 0], [10]) == 1
    assert plant.mode_of([0.1, 10, 0], [10]) == 2
    assert plant.output([0.1, 123.0, 0], [10])[0] == 123.0
    with pytest.raises(ModelError, match="X x U"):
        plant.mode_of([0.5, 10, 0], [10])  # theta outside [-0.2, 0.2]


def test_gear_ratio_changes_shaft_rate():
    slow, fast = powertrain3(gear_ratio=1 / 12), powertrain3(gear_ratio=1.0)
    x = np.array([0.0, 20.0, 1.0])
    assert slow.step(x, [0])[0] == pytest.approx(1e-3 * (20 / 12 - 1.0))
    assert fast.step(x, [0])[0] == pytest.approx(1e-3 * (20 - 1.0))


def test_powertrain5_clutch_twist_and_dimensions():
    plant = powertrain5()
    assert plant.n == 5 and plant.m == 1 and plant.p == 1 and plant.n_modes == 3
    x = np.array([0.01, 0.0, 100.0, 90.0, 10.0])
    x1 = plant.step(x, [20.0])
    assert x1[0] == pytest.approx(0.01 + 1e-3 * 10.0)  # (17a)


def test_scenario_crosses_backlash_and_stays_in_bounds():
    from hybobs_opt.studies import get_example

    trace = get_example("powertrain3").simulate()
    theta = trace.state("theta")
    assert np.any(theta > TABLE1["alpha"]) and np.any(theta < -TABLE1["alpha"])
    assert set(np.unique(trace.q)) == {0, 1, 2}
    assert np.all(np.abs(theta) <= 0.2)


# ---------------------------------------------------------------- bad input
def _mode(n=1, m=1, **kw):
    data = dict(A=np.eye(n), B=np.zeros((n, m)), a=np.zeros(n), C=np.eye(1, n), guard=Polytope.from_box([-1] * (n + m), [1] * (n + m)))
    data.update(kw)
    return PWAMode(**data)


def _system(*modes, X=None, U=None):
    X = X or Polytope.from_box([-1], [1])
    U = U or Polytope.from_box([-1], [1])
    return PWASystem(modes, X, U)


def test_wrong_matrix_shape_names_field():
    with pytest.raises(ModelError, match=r"modes\[0\]\.A"):
        _system(_mode(A=np.eye(2)))
    with pytest.raises(ModelError, match=r"modes\[1\]\.B"):
        _system(_mode(), _mode(B=np.zeros((2, 1))))


def test_nan_and_inf_entries_name_field():
    with pytest.raises(ModelError, match=r"modes\[0\]\.a"):
        _system(_mode(a=[np.nan]))
    with pytest.raises(ModelError, match=r"modes\[0\]\.C"):
        _system(_mode(C=[[np.inf]]))


def test_empty_or_flat_guard_rejected():
    empty = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([-0.5, -0.5]))
    with pytest.raises(ModelError, match=r"modes\[0\]\.guard"):
        _system(_mode(guard=empty))
    flat = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0]]), np.array([0.0, 0.0]))  # x = 0
    with pytest.raises(ModelError, match=r"modes\[0\]\.guard.*full-dimensional"):
        _system(_mode(guard=flat))


def test_unbounded_state_set_rejected():
    half = Polytope(np.array([[1.0]]), np.array([1.0]))
    with pytest.raises(ModelError, match="state_bounds"):
        _system(_mode(), X=half)


def test_simulation_blocked_outside_state_set():
    plant = powertrain3()
    with pytest.raises(ModelError, match=r"x\(\d+\)"):
        simulate_pwa(plant, [0.19, 590.0, 0.0], np.full(500, 140.0))
    trace = simulate_pwa(plant, [0.19, 590.0, 0.0], np.full(500, 140.0), on_blocked="stop")
    assert trace.n_samples < 500 and trace.events[0]["kind"] == "blocked"

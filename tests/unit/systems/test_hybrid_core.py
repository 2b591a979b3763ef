"""Hybrid automata: validation, exact ZOH discretisation, event location, fixed-step integration."""

import numpy as np
import pytest
from scipy.linalg import expm

from hybobs_opt.errors import ModelError
from hybobs_opt.sim import integrate_fixed_step, simulate_hybrid, simulate_hybrid_fixed_step
from hybobs_opt.systems import Edge, HybridAutomaton, Location, Polytope


def two_location_automaton():
    """1-D: x' = 1 - x while x <= 0.5 ("charge"), then x' = 1 ("ramp") for x >= 0.5."""
    below = Polytope(np.array([[1.0]]), np.array([0.5]))
    above = Polytope(np.array([[-1.0]]), np.array([-0.5]))
    return HybridAutomaton(
        (
            Location("charge", below, A=[[-1.0]], E=[1.0], C=[[1.0]]),
            Location("ramp", above, A=[[0.0]], E=[1.0], C=[[1.0]]),
        ),
        Polytope.from_box([-5], [5], ("x",)),
        edges=(Edge(0, 1),),
        state_names=("x",),
    )


def test_event_time_matches_closed_form():
    aut = two_location_automaton()
    trace = simulate_hybrid(aut, [0.0], 2.0, dt=0.01)
    (event,) = trace.events
    assert event["t"] == pytest.approx(np.log(2.0), abs=1e-8)  # 1 - exp(-t) = 0.5
    assert event["from"] == 0 and event["to"] == 1
    assert trace.x[-1, 0] == pytest.approx(0.5 + 2.0 - np.log(2.0), abs=1e-7)
    assert trace.q[0] == 0 and trace.q[-1] == 1


def test_discretize_is_exact_zoh_per_location():
    A = np.array([[0.0, 1.0], [-4.0, -0.4]])
    B = np.array([[0.0], [1.0]])
    E = np.array([0.0, -0.3])
    aut = HybridAutomaton(
        (Location("only", Polytope.from_box([-10, -10], [10, 10]), A=A, B=B, E=E, C=[[1.0, 0.0]]),),
        Polytope.from_box([-10, -10], [10, 10]),
        input_bounds=Polytope.from_box([-1], [1]),
    )
    Ts = 0.05
    pwa = aut.discretize(Ts)
    x0, u = np.array([0.3, -0.2]), np.array([0.7])
    # Reference: integrate the ODE with the same constant input over one sample.
    trace = simulate_hybrid(aut, x0, Ts, u=u, dt=Ts)
    np.testing.assert_allclose(pwa.step(x0, u), trace.x[-1], rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(pwa.modes[0].A, expm(A * Ts), rtol=1e-12)


def test_discretize_rejects_nonlinear_flow():
    aut = HybridAutomaton(
        (Location("nl", Polytope.from_box([-1], [1]), flow=lambda x, u: -x**3, C=[[1.0]]),),
        Polytope.from_box([-1], [1]),
    )
    with pytest.raises(ModelError, match="affine"):
        aut.discretize(0.1)


def test_fixed_step_rk4_is_fourth_order():
    errs = []
    for dt in (0.1, 0.05):
        t, x = integrate_fixed_step(lambda t, x: -x, [1.0], 0.0, 1.0, dt)
        errs.append(abs(x[-1, 0] - np.exp(-1.0)))
    assert errs[0] / errs[1] == pytest.approx(16.0, rel=0.15)


def test_fixed_step_hybrid_follows_state_dependent_switching():
    aut = two_location_automaton()
    trace = simulate_hybrid_fixed_step(aut, [0.0], 2.0, dt=1e-3)
    switch = [e["t"] for e in trace.events]
    assert len(switch) == 1 and switch[0] == pytest.approx(np.log(2.0), abs=2e-3)


@pytest.mark.parametrize(
    "kwargs, field",
    [
        (dict(A=[[1.0, 2.0]]), r"locations\[0\] \(bad\)\.A"),
        (dict(A=[[np.nan]]), r"locations\[0\] \(bad\)\.A"),
        (dict(A=[[1.0]], E=[1.0, 2.0]), r"locations\[0\] \(bad\)\.E"),
    ],
)
def test_bad_location_data_names_field(kwargs, field):
    with pytest.raises(ModelError, match=field):
        HybridAutomaton((Location("bad", Polytope.from_box([-1], [1]), C=[[1.0]], **kwargs),), Polytope.from_box([-1], [1]))


def test_bad_edge_and_unbounded_bounds():
    inv = Polytope.from_box([-1], [1])
    loc = Location("a", inv, A=[[0.0]], C=[[1.0]])
    with pytest.raises(ModelError, match=r"edges\[0\]\.target"):
        HybridAutomaton((loc,), inv, edges=(Edge(0, 3),))
    with pytest.raises(ModelError, match="state_bounds"):
        HybridAutomaton((loc,), Polytope(np.array([[1.0]]), np.array([1.0])))


def test_exit_through_entry_face_is_located():
    """Regression: a state that enters a location and leaves it through the same face must jump back.

    x' = v, v' = -1 (a ball thrown upwards across x = 0): it enters x >= 0 at t = 0 and must leave
    through x = 0 again at t = 2 v0, returning to the lower location.
    """
    down = Polytope(np.array([[1.0, 0.0]]), np.array([0.0]))
    up = Polytope(np.array([[-1.0, 0.0]]), np.array([0.0]))
    A = np.array([[0.0, 1.0], [0.0, 0.0]])
    aut = HybridAutomaton(
        (Location("below", down, A=A, E=[0.0, 1.0], C=[[1.0, 0.0]]), Location("above", up, A=A, E=[0.0, -1.0], C=[[1.0, 0.0]])),
        Polytope.from_box([-10, -10], [10, 10]),
    )
    trace = simulate_hybrid(aut, [-0.5, 1.0], 4.0, dt=0.01)
    times = [e["t"] for e in trace.events]
    # below: x = -0.5 + t + t^2/2 reaches 0 at t1 = sqrt(2) - 1 with v = sqrt(2); above it returns after 2 sqrt(2)
    t1 = np.sqrt(2.0) - 1.0
    assert times[0] == pytest.approx(t1, abs=1e-7)
    assert times[1] == pytest.approx(t1 + 2 * np.sqrt(2.0), abs=1e-7)
    assert [e["to"] for e in trace.events[:2]] == [1, 0]

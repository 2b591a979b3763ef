"""Scalar-nonlinear systems of paper 004 (Rajamani et al.): model class, simulator and examples.

Physics checks of the vehicle bicycle model (eqs. 56-59) and the magnetic piston (eq. 63), the
CasADi derivatives against finite differences, and ModelError on bad input.  The paper's vehicle
scenario (Sec. 6.2) and piston sensor features (Sec. 7, Fig. 7) are checked in
``tests/studies/test_paper004_nonmonotonic.py``.
"""

from __future__ import annotations

import dataclasses
import math

import casadi as ca
import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.sim import simulate_nonlinear
from hybobs_opt.studies import get_example
from hybobs_opt.studies.paper004_nonmonotonic.systems import magnetic_piston, piston_scenario, vehicle_scenario, vehicle_tracking
from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

V, LF, LR = 10.0, 1.1, 1.58  # paper 004 Sec. 6.1 (V); l_f, l_r are the factory's stated assumption
STROKE = 203.0  # mm, paper 004 Sec. 7


@pytest.fixture(scope="module")
def vehicle():
    return vehicle_tracking(V=V, l_f=LF, l_r=LR)


@pytest.fixture(scope="module")
def vehicle_trace(vehicle):
    return vehicle_scenario(vehicle)


@pytest.fixture(scope="module")
def piston():
    return magnetic_piston()


def _phase_time(trace, phase: str) -> float:
    return next(e["t"] for e in trace.events if e.get("phase") == phase)


# --------------------------------------------------------------------------- vehicle physics
@pytest.mark.parametrize("psi0_deg", [30.0, 135.0, 250.0])
def test_straight_driving_covers_V_t_along_heading(vehicle, psi0_deg):
    psi0 = math.radians(psi0_deg)
    x0 = [3.0, -7.0, psi0, 0.0]
    tr = simulate_nonlinear(vehicle, x0, None, 4.0, 0.05)
    dx = tr.state("X") - x0[0]
    dy = tr.state("Y") - x0[1]
    assert np.allclose(dx, V * tr.t * math.cos(psi0), atol=1e-7)
    assert np.allclose(dy, V * tr.t * math.sin(psi0), atol=1e-7)
    assert np.allclose(tr.state("psi"), psi0, atol=1e-12)
    # outputs are the radar positions (eq. 58)
    assert np.allclose(tr.y, tr.x[:, :2], atol=0)


def test_yaw_rate_in_turn_is_V_over_l_tan_delta(vehicle_trace):
    tr = vehicle_trace
    t2, t3 = _phase_time(tr, "steady turn"), _phase_time(tr, "steer out")
    sel = (tr.t > t2 + 0.05) & (tr.t < t3 - 0.05)
    assert sel.sum() > 100
    psi_rate = np.gradient(tr.state("psi"), tr.t)[sel]
    expected = V / (LF + LR) * np.tan(tr.state("delta_f")[sel])
    assert np.all(expected > 0)  # a left turn
    assert np.allclose(psi_rate, expected, rtol=1e-6, atol=0)
    # the turn radius of a kinematic bicycle at constant steering is V / yaw rate
    speed = np.hypot(np.gradient(tr.state("X"), tr.t), np.gradient(tr.state("Y"), tr.t))[sel]
    assert np.allclose(speed, V, rtol=1e-5)


# --------------------------------------------------------------------------- derivatives
def _fd(fn, z, h=1e-6):
    return (fn(z + h) - fn(z - h)) / (2 * h)


@pytest.mark.parametrize(
    "expr, lo, hi",
    [
        (lambda z: 10.0 * ca.cos(z), 0.0, 2 * math.pi),
        (lambda z: 10.0 * ca.sin(z), 0.0, 2 * math.pi),
        (lambda z: 10.0 / 2.68 * ca.tan(z), -0.17, 0.17),
        (lambda z: ca.exp(-z**2) * ca.sin(3 * z) + ca.atan(z), -2.0, 2.0),
    ],
)
def test_autodiff_matches_finite_differences(expr, lo, hi):
    fn = ScalarFunction("test", expr)
    z = np.linspace(lo, hi, 401)
    assert np.allclose(fn.deriv(z), _fd(fn.value, z), rtol=1e-7, atol=1e-7)
    assert np.allclose(fn.deriv(z), fn.deriv_autodiff(z), rtol=0, atol=0)


def test_vehicle_jacobian_eq59_matches_finite_differences(vehicle):
    rng = np.random.default_rng(0)
    X = np.column_stack([rng.uniform(-50, 50, 20), rng.uniform(-50, 50, 20),
                         rng.uniform(0, 2 * np.pi, 20), rng.uniform(-0.17, 0.17, 20)])
    J = vehicle.dynamics_jacobian(X)
    h = 1e-6
    for k in range(X.shape[0]):
        J_fd = np.column_stack([(vehicle.rhs(X[k] + h * e) - vehicle.rhs(X[k] - h * e)) / (2 * h) for e in np.eye(4)])
        assert np.allclose(J[k], J_fd, rtol=1e-6, atol=1e-6)
    # eq. (59) in closed form at one point
    psi, d = X[0, 2], X[0, 3]
    assert np.allclose(vehicle.f_derivatives(X[0]), [-V * np.sin(psi), V * np.cos(psi), V / (LF + LR) / np.cos(d) ** 2])


def test_piston_sensor_derivatives_match_finite_differences(piston):
    z = np.linspace(0.0, STROKE, 801)
    X = np.column_stack([z, np.zeros_like(z), np.zeros_like(z)])
    dh = piston.h_derivatives(X)
    h = 1e-5
    fd = (piston.h_values(X + [h, 0, 0]) - piston.h_values(X - [h, 0, 0])) / (2 * h)
    assert np.allclose(dh, fd, rtol=1e-6, atol=1e-8)
    J = piston.output_jacobian(X)
    assert J.shape == (z.size, 2, 3)
    assert np.allclose(J[:, :, 0], dh) and np.all(J[:, :, 1:] == 0)


def test_symbolic_dynamics_equal_numeric(vehicle):
    x = ca.SX.sym("x", 4)
    fn = ca.Function("dyn", [x], [vehicle.sx_dynamics(x), vehicle.sx_output(x)])
    x0 = np.array([1.0, 2.0, 0.7, 0.05])
    dx, y = (np.asarray(v).ravel() for v in fn(x0))
    assert np.allclose(dx, vehicle.rhs(x0, [0.0]))
    assert np.allclose(y, vehicle.output(x0))


# --------------------------------------------------------------------------- piston
def test_piston_stroke_follows_triple_integrator(piston):
    tr = piston_scenario(piston)
    z = tr.state("z")
    assert z.min() >= 0.0 and z.max() <= STROKE
    assert z.max() - z.min() > 0.9 * STROKE  # a stroke across the range
    w = 2 * np.pi / tr.t[-1]
    amp, centre = 0.5 * (z.max() - z.min()), 0.5 * (z.max() + z.min())
    assert centre == pytest.approx(0.5 * STROKE, abs=1e-6)
    assert np.allclose(z, centre - amp * np.cos(w * tr.t), atol=1e-5)
    assert np.allclose(tr.state("v"), np.gradient(z, tr.t), atol=1e-3 * amp * w)
    assert np.allclose(tr.state("a"), np.gradient(tr.state("v"), tr.t), atol=1e-3 * amp * w**2)
    assert np.all(tr.q == 0)


def test_registry_entries(vehicle):
    ex = get_example("vehicle_tracking")
    assert ex.kind == "scalar_nonlinear" and ex.paper == "004"
    assert ex.state_names == ("X", "Y", "psi", "delta_f") == vehicle.state_names
    tr = ex.simulate(t_final=6.0)
    assert tr.t[-1] == pytest.approx(6.0) and tr.x.shape[1] == 4
    ex2 = get_example("magnetic_piston")
    assert ex2.build().state_names == ex2.state_names == ("z", "v", "a")
    with pytest.raises(ModelError, match="parameters of example"):
        ex.simulate(wheelbase=3.0)


def test_model_is_frozen_and_read_only(vehicle):
    with pytest.raises(dataclasses.FrozenInstanceError):
        vehicle.F = np.zeros((4, 3))
    with pytest.raises(ValueError):
        vehicle.F[0, 0] = 2.0
    assert vehicle.f_ranges.shape == (3, 2) and np.allclose(vehicle.f_ranges[2], [-math.radians(10), math.radians(10)])


# --------------------------------------------------------------------------- bad input
def _base(**over):
    kw = dict(
        box=Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("p", "q")),
        C=np.array([[1.0, 0.0]]),
        A=np.array([[0.0, 1.0], [0.0, 0.0]]),
        F=np.array([[0.0], [1.0]]),
        E=np.array([[1.0, 0.0]]),
        f=(ScalarFunction("sin", lambda z: ca.sin(z)),),
    )
    kw.update(over)
    return ScalarNonlinearSystem(**kw)


def test_base_system_is_valid():
    s = _base()
    assert (s.n, s.m, s.p, s.r) == (2, 0, 1, 1)
    assert s.state_names == ("p", "q")


@pytest.mark.parametrize(
    "over, field",
    [
        (dict(F=np.zeros((2, 2))), "F"),
        (dict(E=np.zeros((1, 3))), "E"),
        (dict(C=np.zeros((1, 3))), "C"),
        (dict(A=np.zeros((3, 3))), "A"),
        (dict(A=np.array([[0.0, np.nan], [0.0, 0.0]])), "A"),
        (dict(F=np.array([[np.inf], [1.0]])), "F"),
        (dict(B=np.array([[0.0], [np.nan]])), "B"),
        (dict(h=(None, None)), "h"),
        (dict(F=None), "F"),
        (dict(state_names=("a", "b", "c")), "state_names"),
    ],
)
def test_bad_matrices_raise_model_error_naming_field(over, field):
    with pytest.raises(ModelError) as err:
        _base(**over)
    assert err.value.field == field
    assert str(err.value).startswith(f"{field}:")


def test_known_term_g_enters_the_flow():
    # eq. (1): g(y, u) adds to F f(E x); here g = [0, y - u]
    s = _base(B=np.zeros((2, 1)), g=lambda y, u: np.array([0.0, y[0] - u[0]]))
    x = np.array([0.3, -0.2])
    assert np.allclose(s.rhs(x, [0.1]), [-0.2, np.sin(0.3) + 0.3 - 0.1])
    with pytest.raises(ModelError) as err:
        _base(g=lambda y, u: np.zeros(3))
    assert err.value.field == "g"


def test_linear_model_jacobian_is_A(piston):
    assert piston.r == 0 and piston.linear_outputs == (False, False)
    assert np.array_equal(piston.dynamics_jacobian(np.array([10.0, 1.0, 2.0])), piston.A)


def test_lower_bound_above_upper_bound():
    with pytest.raises(ModelError, match=r"bounds of q"):
        Polytope.from_box([-1.0, 2.0], [1.0, 1.0], ("p", "q"))
    with pytest.raises(ModelError, match=r"bounds of z"):
        magnetic_piston(stroke=-5.0)
    with pytest.raises(ModelError, match=r"bounds of delta_f"):
        vehicle_tracking(delta_max_deg=-1.0)
    # an empty polytope handed in directly (rows x <= -1 and -x <= -1)
    empty = Polytope(np.array([[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]), np.array([-1.0, -1.0, 1.0, 1.0]))
    with pytest.raises(ModelError, match=r"^box:"):
        _base(box=empty)


def test_unbounded_box():
    half = Polytope(np.array([[1.0, 0.0], [0.0, 1.0], [0.0, -1.0]]), np.array([1.0, 1.0, 1.0]), ("p", "q"))
    with pytest.raises(ModelError, match=r"^box:.*bounded"):
        _base(box=half)


@pytest.mark.parametrize(
    "over, field",
    [
        (dict(f=(ScalarFunction("log", lambda z: ca.log(z)),)), "f[0] (log)"),
        (dict(f=(ScalarFunction("inverse", lambda z: 1 / z),)), "f[0] (inverse)"),
        (dict(h=(ScalarFunction("sqrt", lambda z: ca.sqrt(z)),)), "h[0] (sqrt)"),
    ],
)
def test_function_non_finite_on_box(over, field):
    with pytest.raises(ModelError) as err:
        _base(**over)
    assert err.value.field == field
    assert field in str(err.value) and "finite" in str(err.value)


def test_function_finite_off_the_box_is_accepted():
    # log is fine when its argument p stays in [1, 3] on the box
    s = _base(f=(ScalarFunction("log", lambda z: ca.log(z)),), E=np.array([[1.0, 0.0]]),
              box=Polytope.from_box([1.0, -1.0], [3.0, 1.0], ("p", "q")))
    assert np.allclose(s.f_values(np.array([2.0, 0.0])), [math.log(2.0)])


def test_wrong_user_derivative_rejected():
    bad = ScalarFunction("sin", lambda z: ca.sin(z), lambda z: -ca.cos(z))
    with pytest.raises(ModelError) as err:
        _base(f=(bad,))
    assert err.value.field == "f[0] (sin).derivative"


def test_scalar_function_needs_symbolic_scalar_expression():
    with pytest.raises(ModelError, match=r"ScalarFunction 'math'\.expr.*casadi functions"):
        ScalarFunction("math", lambda z: math.sin(z))
    with pytest.raises(ModelError, match=r"ScalarFunction 'vec'\.expr.*1x1"):
        ScalarFunction("vec", lambda z: ca.vertcat(z, z))
    w = ca.SX.sym("w")
    with pytest.raises(ModelError, match=r"free symbol"):
        ScalarFunction("free", lambda z: z * w)


def test_simulator_rejects_bad_arguments(vehicle):
    with pytest.raises(ModelError, match=r"^x0:"):
        simulate_nonlinear(vehicle, [0.0, 0.0, 0.0], None, 1.0, 0.1)
    with pytest.raises(ModelError, match=r"^u_fn:"):
        simulate_nonlinear(vehicle, [0.0, 0.0, 0.0, 0.0], lambda t: np.zeros(2), 1.0, 0.1)
    with pytest.raises(ModelError, match=r"^dt:"):
        simulate_nonlinear(vehicle, [0.0, 0.0, 0.0, 0.0], None, 1.0, 0.0)
    with pytest.raises(ModelError, match=r"^t_final:"):
        simulate_nonlinear(vehicle, [0.0, 0.0, 0.0, 0.0], None, -1.0, 0.1)

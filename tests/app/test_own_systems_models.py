"""Three systems from the control literature shipped as model files and builders (``examples/``).

* ``bemporad_morari_rotation``: PWA with an input, Bemporad & Morari, Automatica 35(3), 1999
  (TOML and JSON);
* ``flexible_joint_robot``: non-monotonic scalar-nonlinear system, Spong 1987 / Raghavan & Hedrick,
  Int. J. Control 59(2), 1994 (TOML and YAML);
* ``water_tanks``: two-location hybrid automaton, Lygeros et al., IEEE TAC 48(1), 2003 (TOML).

Every file must build the same system as its builder (``to_dict`` equal) and validate against the
JSON Schema; the dynamics of every file and builder are checked against the published equations
written out below in numpy (the oracle: no toolbox code, the parameters typed in from the papers).
"""

import math
from pathlib import Path

import jsonschema
import numpy as np
import pytest

import hybobs_opt
from hybobs_opt import load_model, resolve_system
from hybobs_opt.systems.fingerprint import system_fingerprint
from hybobs_opt.systems.model_file import read_model_dict

ROOT = Path(__file__).resolve().parents[2]
MODELS = ROOT / "examples" / "models"
BUILDERS = ROOT / "examples" / "builders"

FILES = {
    "bemporad_morari_rotation": ("toml", "json"),
    "flexible_joint_robot": ("toml", "yaml"),
    "water_tanks": ("toml",),
}
ALL_FILES = [(name, MODELS / f"{name}.{ext}") for name, exts in FILES.items() for ext in exts]


def builder(name, **params):
    return resolve_system(f"{BUILDERS / name}.py:build", params)


def sources(name):
    """The system ``name`` from each of its model files and from its builder."""
    return [load_model(MODELS / f"{name}.{ext}") for ext in FILES[name]] + [builder(name)]


# ---------------------------------------------------------------------------------- the oracle
# Bemporad & Morari 1999: x+ = 0.8 R(a) x + [0; 1] u, a = +pi/3 if x1 >= 0 else -pi/3, y = x2
# (y = x2 is the modelling choice of examples/), |x_i| <= 10, |u| <= 1.

def rotation_step(x, u, angle=math.pi / 3):
    a = angle if x[0] >= 0 else -angle
    R = np.array([[math.cos(a), -math.sin(a)], [math.sin(a), math.cos(a)]])
    return 0.8 * R @ x + np.array([0.0, u[0]])


def rotation_output(x, u):
    return np.array([x[1]])


# Flexible-joint robot (Spong 1987; Raghavan & Hedrick 1994): parameters of the observer papers.
JM, JL, MASS, H, K, BF, KTAU, G = 3.7e-3, 9.3e-3, 0.21, 0.15, 0.18, 4.6e-2, 8e-2, 9.81


def robot_rhs(x, u, k_tau=KTAU):
    th_m, om_m, th_l, om_l = x
    return np.array([
        om_m,
        K / JM * (th_l - th_m) - BF / JM * om_m + k_tau / JM * u[0],
        om_l,
        -K / JL * (th_l - th_m) - MASS * G * H / JL * math.sin(th_l),
    ])


def robot_output(x):
    return np.array([x[0], x[1]])


def robot_nonlinearity_derivative(theta_l):
    """d/dtheta_l of the scalar nonlinearity sin(theta_l)."""
    return np.cos(theta_l)


# Water tanks (Lygeros et al. 2003) with w = 0.75, v1 = v2 = 0.5, r1 = r2 = 0.5, y = x1.
W, V1, V2, R1, R2 = 0.75, 0.5, 0.5, 0.5, 0.5


def tank_flow(q, x):
    return np.array([W - V1, -V2]) if q == 0 else np.array([-V1, W - V2])


def tank_invariant(q, x):
    return x[1] >= R2 if q == 0 else x[0] >= R1


def tank_guard(source, x):
    return x[1] <= R2 if source == 0 else x[0] <= R1


# ---------------------------------------------------------------------------------- files = builders

@pytest.mark.parametrize("name,path", ALL_FILES, ids=lambda v: v.name if isinstance(v, Path) else v)
def test_model_file_is_the_builders_system(name, path):
    from_file = load_model(path)
    from_builder = builder(name)
    assert type(from_file) is type(from_builder)
    assert from_file.to_dict() == from_builder.to_dict()


@pytest.mark.parametrize("name,path", ALL_FILES, ids=lambda v: v.name if isinstance(v, Path) else v)
def test_model_file_validates_against_the_schema(name, path):
    schema = hybobs_opt.model_schema()
    jsonschema.Draft202012Validator.check_schema(schema)
    data = read_model_dict(path)
    jsonschema.Draft202012Validator(schema).validate(data)
    assert data["class"] == {"bemporad_morari_rotation": "pwa", "flexible_joint_robot": "scalar_nonlinear",
                             "water_tanks": "hybrid_automaton"}[name]


def test_every_format_is_exercised():
    suffixes = {p.suffix for _, p in ALL_FILES}
    assert suffixes == {".toml", ".json", ".yaml"}
    assert all(p.is_file() for _, p in ALL_FILES)
    assert all((BUILDERS / f"{name}.py").is_file() for name in FILES)


FINGERPRINT_CASES = [pytest.param(name, path, id=path.name) for name, path in ALL_FILES]


@pytest.mark.parametrize("name,path", FINGERPRINT_CASES)
def test_fingerprint_of_file_and_builder(name, path):
    """Saved results are keyed by ``system_fingerprint``: a file and its builder share it (signed
    zeros and set labels do not count: ``x1 <= 0`` reads as ``b = -0.0``, ``from_box`` writes ``0.0``)."""
    assert system_fingerprint(load_model(path)) == system_fingerprint(builder(name))


# ---------------------------------------------------------------------------------- PWA with input

def rotation_points(rng, count=200):
    X = rng.uniform(-10, 10, (count, 2))
    U = rng.uniform(-1, 1, (count, 1))
    X[:10, 0] = 0.0  # on the switching line: the paper's rule a = +pi/3 for x1 >= 0
    X[10:12] = [[10.0, -10.0], [-10.0, 10.0]]  # corners of X
    U[10:12] = [[1.0], [-1.0]]
    return X, U


@pytest.mark.parametrize("index", range(3), ids=["toml", "json", "builder"])
def test_rotation_step_and_output_match_the_published_equations(index):
    system = sources("bemporad_morari_rotation")[index]
    assert (system.n, system.m, system.p, system.n_modes) == (2, 1, 1, 2)
    X, U = rotation_points(np.random.default_rng(11))
    for x, u in zip(X, U):
        np.testing.assert_allclose(system.step(x, u), rotation_step(x, u), rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(system.output(x, u), rotation_output(x, u), rtol=0, atol=0)
    on_line = system.modes_of(X[:10], U[:10])
    assert np.all(on_line == 0) and system.modes[0].name == "right"


def test_rotation_builder_parameters():
    system = builder("bemporad_morari_rotation", angle=math.pi / 4, output_row=(1.0, 0.0))
    X, U = rotation_points(np.random.default_rng(12), 50)
    for x, u in zip(X, U):
        np.testing.assert_allclose(system.step(x, u), rotation_step(x, u, math.pi / 4), rtol=1e-13, atol=1e-13)
        assert system.output(x, u)[0] == x[0]
    assert system.to_dict() != builder("bemporad_morari_rotation").to_dict()


def test_rotation_mirror_symmetry_with_y_equal_x2():
    """(x1, x2) and (-x1, x2) give the same output sequence for every input (oracle and system)."""
    system = load_model(MODELS / "bemporad_morari_rotation.toml")
    rng = np.random.default_rng(13)
    for _ in range(20):
        x = rng.uniform(-5, 5, 2)
        x[0] = abs(x[0]) + 0.1
        a, b = x.copy(), np.array([-x[0], x[1]])
        for u in rng.uniform(-1, 1, (8, 1)):
            assert system.output(a, u)[0] == pytest.approx(system.output(b, u)[0], abs=1e-12)
            oa, ob = rotation_step(a, u), rotation_step(b, u)
            np.testing.assert_allclose(oa, [-ob[0], ob[1]], atol=1e-12)
            if np.max(np.abs(oa)) > 10:  # left X
                break
            a, b = system.step(a, u), system.step(b, u)


# ---------------------------------------------------------------------------------- scalar nonlinear

def robot_points(rng, count=200):
    lo = np.array([-math.pi, -10.0, -math.pi, -10.0])
    return rng.uniform(lo, -lo, (count, 4)), rng.uniform(-1.0, 1.0, (count, 1))


@pytest.mark.parametrize("index", range(3), ids=["toml", "yaml", "builder"])
def test_robot_rhs_and_output_match_the_published_equations(index):
    system = sources("flexible_joint_robot")[index]
    assert (system.n, system.m, system.p, system.r) == (4, 1, 2, 1)
    X, U = robot_points(np.random.default_rng(21))
    want = np.array([robot_rhs(x, u) for x, u in zip(X, U)])
    np.testing.assert_allclose(system.rhs(X, U), want, rtol=1e-12, atol=1e-10)
    for x, u in zip(X[:20], U[:20]):
        np.testing.assert_allclose(system.rhs(x, u), robot_rhs(x, u), rtol=1e-12, atol=1e-10)
        np.testing.assert_allclose(system.output(x), robot_output(x), rtol=0, atol=0)
    np.testing.assert_allclose(system.output(X), X[:, :2], rtol=0, atol=0)
    assert system.linear_outputs == (True, True)


@pytest.mark.parametrize("index", range(3), ids=["toml", "yaml", "builder"])
def test_robot_nonlinearity_is_non_monotonic_on_its_box(index):
    system = sources("flexible_joint_robot")[index]
    # the oracle: d sin(theta_l)/d theta_l = cos(theta_l) takes both signs on [-pi, pi]
    grid = np.linspace(-math.pi, math.pi, 401)
    slopes = robot_nonlinearity_derivative(grid)
    assert slopes.max() > 0.99 and slopes.min() < -0.99
    # the system's argument interval is that box edge, and its derivative agrees with the oracle
    np.testing.assert_allclose(system.f_ranges[0], [-math.pi, math.pi], rtol=1e-12)
    X = np.zeros((grid.size, 4))
    X[:, 2] = grid
    D = system.f_derivatives(X)[:, 0]
    np.testing.assert_allclose(D, slopes, rtol=0, atol=1e-12)
    assert D.max() > 0 and D.min() < 0
    np.testing.assert_allclose(system.f_values(X)[:, 0], np.sin(grid), rtol=0, atol=1e-12)
    # and the Jacobian of the oracle's dynamics in theta_l changes sign of its nonlinear part
    h = 1e-6
    dfdth = []
    for th in grid[::40]:
        x = np.array([0.0, 0.0, th, 0.0])
        e = np.array([0.0, 0.0, h, 0.0])
        dfdth.append((robot_rhs(x + e, [0.0])[3] - robot_rhs(x - e, [0.0])[3]) / (2 * h) + K / JL)
    J = system.dynamics_jacobian(np.column_stack([np.zeros(11), np.zeros(11), grid[::40], np.zeros(11)]))
    np.testing.assert_allclose(J[:, 3, 2] + K / JL, dfdth, rtol=1e-6, atol=1e-6)


def test_robot_builder_parameters():
    system = builder("flexible_joint_robot", k_tau=1.0)
    X, U = robot_points(np.random.default_rng(22), 50)
    want = np.array([robot_rhs(x, u, k_tau=1.0) for x, u in zip(X, U)])
    np.testing.assert_allclose(system.rhs(X, U), want, rtol=1e-12, atol=1e-10)
    small = builder("flexible_joint_robot", angle_bound=math.pi / 4)
    grid = np.linspace(-math.pi / 4, math.pi / 4, 101)
    assert np.all(robot_nonlinearity_derivative(grid) > 0)  # monotonic on the smaller box
    X = np.zeros((grid.size, 4))
    X[:, 2] = grid
    assert np.all(small.f_derivatives(X) > 0)


# ---------------------------------------------------------------------------------- hybrid automaton

@pytest.mark.parametrize("index", range(2), ids=["toml", "builder"])
def test_tank_flows_invariants_and_guards_match_the_published_automaton(index):
    system = sources("water_tanks")[index]
    assert (system.n, system.m, system.p, system.location_names) == (2, 0, 1, ("q1", "q2"))
    assert [(e.source, e.target) for e in system.edges] == [(0, 1), (1, 0)]
    assert all(e.reset is None for e in system.edges)
    assert system.successors(0) == (1,) and system.successors(1) == (0,)
    rng = np.random.default_rng(31)
    X = rng.uniform(0.0, 2.0, (200, 2))
    X[:4] = [[0.5, 0.5], [0.5, 1.5], [1.5, 0.5], [0.0, 2.0]]  # on the thresholds r1, r2
    for x in X:
        for q in (0, 1):
            np.testing.assert_allclose(system.flow(q, x), tank_flow(q, x), rtol=0, atol=1e-15)
            np.testing.assert_allclose(system.flow(q, x, None), tank_flow(q, x), rtol=0, atol=1e-15)
            assert system.output(q, x)[0] == x[0]
            assert system.in_invariant(q, x) == tank_invariant(q, x)
            assert bool(system.edges[q].guard.contains(x)) == tank_guard(q, x)
    # Zeno regime of the paper: max(v1, v2) < w < v1 + v2, total volume decreasing in both locations
    assert max(V1, V2) < W < V1 + V2
    for q in (0, 1):
        assert system.flow(q, X[0]).sum() == pytest.approx(W - V1 - V2)


@pytest.mark.parametrize("index", range(2), ids=["toml", "builder"])
def test_tank_run_stops_at_its_zeno_point_with_the_zeno_message(index):
    """From (1, 1) the total volume falls at v1 + v2 - w = 0.25 and the switching accelerates until
    both levels reach their thresholds: the Zeno time is (2 - r1 - r2) / 0.25 = 4 s (worked by
    hand).  The run stops there and names Zeno behaviour; it used to integrate past it, to a
    negative level, and report an invariant crossed twice at t = 10."""
    from hybobs_opt.sim import simulate_hybrid
    from hybobs_opt.sim.hybrid import SimulationError

    system = sources("water_tanks")[index]
    zeno = (2.0 - R1 - R2) / (V1 + V2 - W)
    with pytest.raises(SimulationError, match="Zeno") as info:
        simulate_hybrid(system, [1.0, 1.0], 10.0)
    stopped = float(str(info.value).split("before t = ")[1].split(":")[0])
    assert abs(stopped - zeno) < 1e-3
    # before it: switches at t_k = 4 - 3 / 2^k (by hand: x2 reaches 0.5 at t = 1, then each stay
    # lasts half the one before), the levels never below their thresholds
    before = simulate_hybrid(system, [1.0, 1.0], zeno - 0.1)
    np.testing.assert_allclose([e["t"] for e in before.events], [zeno - 3.0 / 2**k for k in range(5)], atol=1e-9)
    assert np.all(before.x >= 0.5 - 1e-9)


def test_tank_builder_parameters():
    system = builder("water_tanks", w=0.9, r1=0.25, measured=("x1", "x2"))
    x = np.array([1.0, 0.3])
    np.testing.assert_allclose(system.flow(0, x), [0.9 - V1, -V2])
    np.testing.assert_allclose(system.flow(1, x), [-V1, 0.9 - V2])
    np.testing.assert_allclose(system.output(1, x), x)
    assert system.output_names == ("x1_meas", "x2_meas")
    assert system.in_invariant(1, np.array([0.3, 1.0])) and not system.in_invariant(1, np.array([0.2, 1.0]))

"""python-control in and out: PWAMode / PWASystem / Location ``from_control`` and ``to_control``.

Oracles independent of the code under test: python-control's own ``forced_response`` (the
simulation of a one-mode system) and ``c2d`` (the zero-order hold of a location), and the
shipped PWA examples' matrices read directly from the modes.
"""

from __future__ import annotations

import subprocess
import sys

import numpy as np
import pytest

control = pytest.importorskip("control", reason="python-control (the interop extra) is not installed")

from hybobs_opt import HybridAutomaton, Location, ModelError, PWAMode, PWASystem, Polytope, get_example, list_examples
from hybobs_opt.sim import simulate_pwa

PWA_EXAMPLES = [ex.name for ex in list_examples() if ex.kind == "pwa"]


def test_the_shipped_pwa_examples_are_found():
    assert set(PWA_EXAMPLES) >= {"powertrain3", "powertrain5"}


@pytest.fixture(scope="module", params=PWA_EXAMPLES)
def example_system(request):
    system = get_example(request.param).build()
    assert isinstance(system, PWASystem)
    return system


def _rebuild(system: PWASystem, systems) -> PWASystem:
    return PWASystem.from_control(systems, [m.guard for m in system.modes], system.state_bounds, system.input_bounds,
                                  affine=[m.a for m in system.modes], output_affine=[m.c for m in system.modes],
                                  name=system.name, partition=system.partition)


def test_pwa_system_to_control_and_back_equals_the_original(example_system):
    systems = example_system.to_control(drop_affine=True)
    assert len(systems) == example_system.n_modes
    back = _rebuild(example_system, systems)
    # the names and the sampling time travel on the ss objects (labels, dt), the rest as arguments
    assert back.to_dict() == example_system.to_dict()
    for mode, ss in zip(example_system.modes, systems):
        assert ss.dt == example_system.Ts
        assert ss.name == mode.name
        assert list(ss.state_labels) == list(example_system.state_names)
        assert list(ss.input_labels) == list(example_system.input_names)
        assert list(ss.output_labels) == list(example_system.output_names)


def test_control_to_pwa_system_and_back_gives_equal_matrices(example_system):
    originals = [control.ss(m.A, m.B, m.C, m.D, example_system.Ts) for m in example_system.modes]
    pwa = _rebuild(example_system, originals)
    again = pwa.to_control(drop_affine=True)
    for a, b in zip(originals, again):
        for key in "ABCD":
            np.testing.assert_array_equal(getattr(b, key), getattr(a, key))
        assert b.dt == a.dt
    # the generated labels (y[0], ...) are not names: the outputs get the defaults (the states and
    # inputs are named by the bounds' coordinate names)
    assert pwa.output_names == tuple(f"y{i + 1}" for i in range(example_system.p))
    assert pwa.state_names == example_system.state_names


def test_affine_terms_are_refused_unless_dropped(example_system):
    nonzero = [i for i, m in enumerate(example_system.modes) if np.any(m.a != 0) or np.any(m.c != 0)]
    if not nonzero:
        pytest.skip("no affine term in this example")
    i = nonzero[0]
    with pytest.raises(ModelError) as err:
        example_system.to_control()
    assert err.value.field.startswith(f"modes[{i}].")
    assert "drop_affine" in err.value.expected


def _one_mode() -> PWASystem:
    A = np.array([[0.9, 0.2], [-0.1, 0.7]])
    B = np.array([[0.0], [0.5]])
    C = np.array([[1.0, 0.0]])
    D = np.array([[0.25]])
    sys_ = control.ss(A, B, C, D, 0.05, states=["p", "v"], inputs=["f"], outputs=["y"], name="free")
    X, U = Polytope.from_box([-100, -100], [100, 100]), Polytope.from_box([-1], [1])
    return sys_, PWASystem.from_control([sys_], [X.product(U)], X, U, name="one")


def test_one_mode_simulation_equals_control_forced_response():
    sys_, pwa = _one_mode()
    assert (pwa.Ts, pwa.state_names, pwa.input_names, pwa.output_names) == (0.05, ("p", "v"), ("f",), ("y",))
    assert pwa.modes[0].name == "free"
    N = 60
    u = np.sin(0.3 * np.arange(N))[:, None]
    x0 = np.array([1.0, -0.5])
    trace = simulate_pwa(pwa, x0, u)
    resp = control.forced_response(sys_, T=np.arange(N) * 0.05, U=u.T, X0=x0)
    np.testing.assert_allclose(trace.x, np.asarray(resp.states).T, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(trace.y, np.asarray(resp.outputs).reshape(1, N).T, rtol=1e-12, atol=1e-12)


def test_mode_from_control_with_affine_terms_and_dt_true():
    ss = control.ss([[0.5]], [[1.0]], [[2.0]], [[0.0]], True)
    mode = PWAMode.from_control(ss, Polytope.from_box([-1, -1], [1, 1]), a=[0.25], c=[-1.0])
    np.testing.assert_array_equal(mode.a, [0.25])
    np.testing.assert_array_equal(mode.c, [-1.0])
    assert mode.name == ""  # sys[k] is python-control's generated name, not a name
    back = mode.to_control(drop_affine=True)
    assert back.dt is True
    np.testing.assert_array_equal(back.C, [[2.0]])


def test_continuous_time_system_is_refused_for_a_mode():
    ss = control.ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]])
    with pytest.raises(ModelError) as err:
        PWAMode.from_control(ss, Polytope.from_box([-1, -1], [1, 1]))
    assert err.value.field == "sys.dt"
    assert "c2d" in err.value.expected and "continuous" in err.value.got


def test_unspecified_timebase_is_refused():
    ss = control.ss([[-1.0]], [[1.0]], [[1.0]], [[0.0]], None)
    with pytest.raises(ModelError, match="unspecified timebase"):
        PWAMode.from_control(ss, Polytope.from_box([-1, -1], [1, 1]))


def test_transfer_function_is_refused_with_a_hint():
    with pytest.raises(ModelError) as err:
        PWAMode.from_control(control.tf([1], [1, 0.5], True), Polytope.from_box([-1, -1], [1, 1]))
    assert err.value.field == "sys" and "control.ss(sys)" in err.value.expected


def test_different_sampling_periods_are_refused():
    a = control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], 0.1)
    b = control.ss([[0.8]], [[1.0]], [[1.0]], [[0.0]], 0.2)
    X, U = Polytope.from_box([-1], [1]), Polytope.from_box([-1], [1])
    with pytest.raises(ModelError) as err:
        PWASystem.from_control([a, b], [Polytope.from_box([-1, -1], [0, 1]), Polytope.from_box([0, -1], [1, 1])], X, U)
    assert err.value.field == "systems[*].dt" and "[0.1, 0.2]" in err.value.got


def test_wrong_number_of_guards_or_affine_terms():
    a = control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], 0.1)
    X, U = Polytope.from_box([-1], [1]), Polytope.from_box([-1], [1])
    with pytest.raises(ModelError) as err:
        PWASystem.from_control([a], [X.product(U), X.product(U)], X, U)
    assert err.value.field == "guards"
    with pytest.raises(ModelError) as err:
        PWASystem.from_control([a], [X.product(U)], X, U, affine=[[0.0], [0.0]])
    assert err.value.field == "affine"


def test_location_from_control_discretises_like_c2d():
    A = np.array([[0.0, 1.0], [-2.0, -0.3]])
    B = np.array([[0.0], [1.0]])
    C = np.array([[1.0, 0.0]])
    ss = control.ss(A, B, C, [[0.0]])
    X = Polytope.from_box([-10, -10], [10, 10])
    loc = Location.from_control("only", ss, X)
    ha = HybridAutomaton([loc], X, input_bounds=Polytope.from_box([-1], [1]))
    pwa = ha.discretize(0.1)
    ref = control.c2d(ss, 0.1, "zoh")
    np.testing.assert_allclose(pwa.modes[0].A, ref.A, rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(pwa.modes[0].B, ref.B, rtol=1e-12, atol=1e-14)
    back = ha.locations[0].to_control()
    assert back.dt == 0
    np.testing.assert_array_equal(back.A, A)


def test_location_refuses_discrete_time_and_callable_flows():
    X = Polytope.from_box([-1], [1])
    with pytest.raises(ModelError) as err:
        Location.from_control("d", control.ss([[0.5]], [[1.0]], [[1.0]], [[0.0]], 0.1), X)
    assert err.value.field == "sys.dt" and "discrete" in err.value.got
    loc = Location("f", X, flow=lambda x, u: -x, C=np.array([[1.0]]))
    with pytest.raises(ModelError) as err:
        loc.to_control()
    assert err.value.field == "Location 'f'.flow"
    affine = Location("e", X, A=np.array([[-1.0]]), B=np.array([[1.0]]), E=np.array([0.5]), C=np.array([[1.0]]))
    with pytest.raises(ModelError) as err:
        affine.to_control()
    assert err.value.field == "Location 'e'.E"
    np.testing.assert_array_equal(affine.to_control(drop_affine=True).A, [[-1.0]])


def test_missing_python_control_names_the_extra(monkeypatch):
    monkeypatch.setitem(sys.modules, "control", None)  # import control -> ImportError
    with pytest.raises(ModelError) as err:
        PWAMode.from_control(object(), Polytope.from_box([-1, -1], [1, 1]))
    assert err.value.field == "control"
    assert "pip install 'hybobs_opt[interop]'" in err.value.expected


def test_importing_the_package_imports_neither_control_nor_pandas():
    code = ("import sys, hybobs_opt, hybobs_opt.systems, hybobs_opt.sim, hybobs_opt.contract; "
            "from hybobs_opt import PWASystem, read_log, Trace; "
            "print(sorted(m for m in ('control', 'pandas') if m in sys.modules))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip() == "[]"

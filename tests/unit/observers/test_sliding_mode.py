"""Step-by-step sliding-mode observer of paper 001 (eq. 5) and the canonical form (4) / Theorem 1.

Every expected number is derived here from the models (by hand, with the derivation in a
comment), never taken from the code under test.  The paper's examples (the canonical form of
Example 3, the runs of Examples 1-3 and the filter trade-off) are in
``tests/studies/test_paper001_sliding_mode.py``; ``hybobs observe`` in ``tests/app/test_cli_sliding_mode.py``.
"""

import json

import numpy as np
import pytest

from observer_checks import assert_indicator_window as _assert_indicator_window
from observer_checks import assert_step_by_step as _assert_step_by_step

from hybobs_opt.contract import FALLBACK, OBSERVABLE
from hybobs_opt.errors import ModelError
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.observers.sliding_mode import SlidingModeObserver
from hybobs_opt.studies.paper001_sliding_mode.scenarios import relay_oscillator, run_scenario, summarize
from hybobs_opt.studies.paper001_sliding_mode.systems import double_scroll, switched_unstable, triangular
from hybobs_opt.systems.canonical_form import observability_form, theorem1, theorem1_pairs
from hybobs_opt.systems.hybrid import Edge, HybridAutomaton, Location


# ---------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def ds():
    return run_scenario("double_scroll", t_final=15.0)


# ---------------------------------------------------------------------------------- canonical form
def _companion(last_row):
    n = len(last_row)
    A = np.zeros((n, n))
    A[:-1, 1:] = np.eye(n - 1)
    A[-1] = last_row
    return A


def test_observability_form_undoes_a_change_of_coordinates():
    """A system in form (4), written in random coordinates x = M z, is brought back: T = M^-1."""
    rng = np.random.default_rng(3)
    n = 3
    M = rng.normal(size=(n, n)) + 3 * np.eye(n)
    Minv = np.linalg.inv(M)
    rows = ([-1.0, -2.0, -0.5], [2.0, 0.5, -1.0])
    betas = (0.7, -0.2)
    names = ("a", "b", "c")
    e2 = np.array([[0.0, 1.0, 0.0]])
    locs = []
    for k, (row, beta, sign) in enumerate(zip(rows, betas, (1.0, -1.0))):
        inv = Polytope(sign * e2 @ Minv, np.zeros(1), names)  # sign * z2 <= 0
        locs.append(Location(f"m{k}", inv, A=M @ _companion(row) @ Minv, E=M @ np.array([0, 0, beta]),
                             C=np.eye(1, n) @ Minv))
    a = HybridAutomaton(tuple(locs), Polytope.from_box([-20] * n, [20] * n, names), edges=(Edge(0, 1), Edge(1, 0)),
                        state_names=names)
    form = observability_form(a)
    np.testing.assert_allclose(form.T, Minv, rtol=1e-9, atol=1e-11)
    np.testing.assert_allclose(form.alpha, np.array(rows), rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(form.beta, betas, rtol=1e-9, atol=1e-10)
    np.testing.assert_allclose(form.switching[0].z_row / form.switching[0].z_row[1], [0, 1, 0], atol=1e-10)


def test_theorem1_double_scroll():
    res = theorem1_pairs(double_scroll())
    assert [(r.i, r.j) for r in res] == [(0, 1), (1, 2)]
    for r in res:
        # the alphas differ: M is a plane; both locations share z = T x, so S = R^3: item (iii)
        assert r.M_dim == 2 and not r.M_discrete
        assert r.S_dim == 3 and r.items["iii"] and r.observable
        # common equilibria: A2 is invertible (det A_{9/7} = c1 (9/7 - ... ) != 0) so only x = 0
        # is an equilibrium of q2, and A1 0 + B1 = (27/7, 0, 0) != 0: L is empty
        assert abs(np.linalg.det(double_scroll().locations[1].A)) > 1
        assert r.L_dim == -1


def test_theorem1_example1():
    """Example 1: z = (x1, -x2) in both subsystems; g1 = -z1, g2 = -4 z1 (by hand)."""
    a = switched_unstable()
    form = observability_form(a)
    np.testing.assert_allclose(form.T, [[1, 0], [0, -1]])
    r = theorem1(a, 0, 1)  # Sigma2_I and Sigma1_II
    # M = {z1 = 0}: a line; delta = (3, 0) (or -3), delta . F(v) = 3 v2 vanishes on M only at 0
    assert r.M_dim == 1 and r.nontransverse_dim == 0
    # L = {0}, a point: sigma is constant on it; items (ii) and (iii) apply
    assert r.L_dim == 0 and r.sigma_L_one_sided
    assert r.items == {"i": False, "ii": True, "iii": True}


def test_theorem1_item_i_parallel_dynamics():
    """Same alpha, different beta: g1 - g2 is a nonzero constant, M is empty (discrete): item (i)."""
    names = ("x1", "x2")
    A = _companion([-1.0, -1.0])
    e1 = np.array([[1.0, 0.0]])
    locs = (
        Location("lo", Polytope(e1, np.zeros(1), names), A=A, E=[0, 1.0], C=[[1.0, 0.0]]),
        Location("hi", Polytope(-e1, np.zeros(1), names), A=A, E=[0, -1.0], C=[[1.0, 0.0]]),
    )
    a = HybridAutomaton(locs, Polytope.from_box([-5, -5], [5, 5], names), state_names=names)
    r = theorem1(a, 0, 1)
    assert r.M_dim == -1 and r.M_discrete and r.L_dim == -1
    assert r.items["i"] and r.observable


# ---------------------------------------------------------------------------------- bad input
def _two_location(A0, A1, C=((1.0, 0.0),), E0=(0, 0), E1=(0, 0)):
    names = ("x1", "x2")
    e1 = np.array([[1.0, 0.0]])
    locs = (
        Location("left", Polytope(e1, np.zeros(1), names), A=A0, E=E0, C=C),
        Location("right", Polytope(-e1, np.zeros(1), names), A=A1, E=E1, C=C),
    )
    return HybridAutomaton(locs, Polytope.from_box([-5, -5], [5, 5], names), state_names=names)


def test_unobservable_subsystem_is_rejected():
    # right: x2 never reaches y = x1 (C A = [-1, 0]): rank 1 < 2
    a = _two_location([[0, 1], [-1, 0]], [[-1, 0], [0, -2]])
    with pytest.raises(ModelError, match=r"locations\[1\] \(right\).*Assumption 1b.*rank 1"):
        observability_form(a)


def test_no_common_coordinates_reports_the_transformations():
    # C A = [0, 1] in one location and [0, 2] in the other: no single form (4)
    a = _two_location([[0, 1], [-1, 0]], [[0, 2], [-1, 0]])
    with pytest.raises(ModelError, match="one set of observability coordinates") as info:
        observability_form(a)
    msg = str(info.value)
    assert "left: T = [[1.0, 0.0], [0.0, 1.0]]" in msg and "right: T = [[1.0, 0.0], [0.0, 2.0]]" in msg


def test_callable_flow_not_in_triangular_form_is_rejected():
    names = ("x1", "x2")

    def flow(x, u):
        return np.array([x[1] + x[0] ** 2, -x[0]])

    locs = (Location("only", Polytope.from_box([-5, -5], [5, 5], names), flow=flow, C=[[1.0, 0.0]]),)
    a = HybridAutomaton(locs, Polytope.from_box([-5, -5], [5, 5], names), state_names=names)
    with pytest.raises(ModelError, match=r"triangular form \(4\)"):
        observability_form(a)


def test_several_outputs_are_rejected():
    a = _two_location([[0, 1], [-1, 0]], [[0, 1], [-2, 0]], C=((1.0, 0.0), (0.0, 1.0)))
    with pytest.raises(ModelError, match="one measured output"):
        observability_form(a)


def test_observer_parameters_are_validated():
    form = observability_form(relay_oscillator())
    for kwargs in ({"Ts": 0.0}, {"Ts": float("nan")}, {"Ts": 1e-3, "filter_tau": -1.0}, {"Ts": 1e-3, "gains": [1.0]},
                   {"Ts": 1e-3, "gains": [1.0, -2.0]}, {"Ts": 1e-3, "hold": 0}):
        with pytest.raises(ModelError):
            SlidingModeObserver(form, **kwargs)
    with pytest.raises(ModelError):
        run_scenario("no_such_example")


def test_bad_samples_fall_back_and_recover():
    form = observability_form(relay_oscillator())
    obs = SlidingModeObserver(form, 1e-3)
    obs.reset(np.array([0.5, 0.0]))
    y = 0.5 * np.cos(np.arange(400) * 1e-3)
    for k in range(200):
        est = obs.step([], [y[k]])
    assert est.flag == OBSERVABLE
    for bad in ([np.nan], [1.0, 2.0], "abc", [np.inf]):
        est = obs.step([], bad)
        assert est.flag == FALLBACK and np.all(np.isfinite(est.x)) and est.info["reason"]
    for k in range(200, 400):
        est = obs.step([], [y[k]])
    assert est.flag == OBSERVABLE
    run = obs.run_detailed(None, np.where(np.arange(300) == 150, np.nan, y[:300]))
    assert run.trace.flags[150] == FALLBACK and np.all(np.isfinite(run.trace.x_hat))


def test_step_and_run_agree():
    form = observability_form(relay_oscillator())
    obs = SlidingModeObserver(form, 1e-3)
    y = np.sin(np.arange(300) * 1e-3 + 0.3)
    run = obs.run_detailed(None, y, x0=np.array([1.0, -1.0]))
    obs.reset(np.array([1.0, -1.0]))
    xs = np.array([obs.step(np.zeros(0), [v]).x for v in y])
    np.testing.assert_allclose(xs, run.trace.x_hat, rtol=0, atol=1e-12)


# ---------------------------------------------------------------------------------- gains
def test_gain_rule_from_bounds():
    form = observability_form(double_scroll())
    obs = SlidingModeObserver(form, 1e-3)
    # 1.5 x widths of z2 (2 x 100/7), z3 (2 x 900/7) and f (2 x 16700/49)
    np.testing.assert_allclose(obs.gains.lambdas, 1.5 * np.array([200 / 7, 1800 / 7, 33400 / 49]), rtol=1e-12)


# ---------------------------------------------------------------------------------- a second system
def test_relay_oscillator_converges_with_the_same_code():
    res = run_scenario("relay_oscillator", t_final=10.0)
    h = res.observer.Ts
    # D = (max|v|, max|v'|) over the box |p|, |v| <= 5: v' = -p - 0.5 v +- 1 -> 5 + 2.5 + 1
    band = np.array([1 * h * 5.0, 2 * h * 8.5])
    _assert_step_by_step(res, band, t_limit=1.0)
    # natural frequency ~1 rad/s: v changes sign about every pi s, 3 times in 10 s
    assert res.indicator.true_switches >= 3 and res.indicator.missed_switches == 0
    _assert_indicator_window(res)


# ---------------------------------------------------------------------------------- summary, triangular form
def test_summary_keys(ds):
    s = summarize(ds)
    assert {"convergence_times", "final_error_band", "indicator_mismatch_fraction", "gains", "band"} <= set(s)
    json.dumps(s)


def test_triangular_automaton_is_accepted_as_is():
    form = observability_form(triangular())
    assert form.is_identity and form.alpha is None
    # F1 in [-0.6, 1.4], F2 = -40 cos(.) - 0.5 in [-40.5, 39.5]: the sampled range covers it
    assert form.f_lower <= -40.5 and form.f_upper >= 39.5

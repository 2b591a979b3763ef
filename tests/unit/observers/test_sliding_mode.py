"""Step-by-step sliding-mode observer of paper 001 (eq. 5) and the canonical form (4) / Theorem 1.

Every expected number is derived here from the models (by hand, with the derivation in a
comment), never taken from the code under test.
"""

import json

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.examples.sliding_mode import (
    DOUBLE_SCROLL_C1,
    P_DERIVED,
    double_scroll,
    switched_unstable,
    triangular,
)
from hybobs_opt.observers.base import FALLBACK, OBSERVABLE
from hybobs_opt.observers.sliding_mode import (
    SlidingModeObserver,
    filter_tradeoff,
    relay_oscillator,
    run_scenario,
    summarize,
)
from hybobs_opt.systems.canonical_form import observability_form, theorem1, theorem1_pairs
from hybobs_opt.systems.hybrid import Edge, HybridAutomaton, Location
from hybobs_opt.systems.polytope import Polytope

C1 = DOUBLE_SCROLL_C1  # -100/7

#: Indicator window stated for noise-free runs: S_o may differ from S only within this many
#: samples of a true switch (the auxiliary states lag by about one sample per stage).
WINDOW_SAMPLES = 10


# ---------------------------------------------------------------------------------- fixtures
@pytest.fixture(scope="module")
def tri():
    return run_scenario("triangular")


@pytest.fixture(scope="module")
def ds():
    return run_scenario("double_scroll", t_final=15.0)


def _conv_times(t, err, band):
    """First time after which |err| <= band for good (computed here, independently of the module)."""
    out = []
    for j in range(err.shape[1]):
        bad = np.nonzero(np.abs(err[:, j]) > band[j])[0]
        out.append(t[0] if bad.size == 0 else (t[bad[-1] + 1] if bad[-1] + 1 < t.size else np.inf))
    return np.array(out)


def _assert_step_by_step(res, band, t_limit):
    err = res.run.z_hat - res.z_true
    tc = _conv_times(res.t, err, band)
    assert np.all(np.isfinite(tc)), f"not converged to the band: {tc}"
    assert np.all(np.diff(tc) > 0), f"not step by step (z1, then z2, ...): {tc}"
    assert tc[-1] < t_limit
    # the anti-peaking switches close in order too
    first_closed = [res.t[np.argmax(res.run.sliding[:, j])] for j in range(res.form.n)]
    assert np.all(np.diff(first_closed) > 0)
    return tc


def _assert_indicator_window(res):
    """S_o == S except within WINDOW_SAMPLES samples of a switch of S (after all stages slide)."""
    h = res.observer.Ts
    after = res.t >= res.t_settled
    t, S, So = res.t[after], res.S[after], res.run.mode[after]
    switches = t[1:][np.diff(S) != 0]
    assert switches.size >= 1
    bad = t[So != S]
    for tb in bad:
        assert np.min(np.abs(switches - tb)) <= WINDOW_SAMPLES * h + 1e-12
    assert np.mean(So != S) <= 2 * WINDOW_SAMPLES * switches.size / t.size + 1e-12


# ---------------------------------------------------------------------------------- canonical form
def test_double_scroll_canonical_form_is_the_papers():
    form = observability_form(double_scroll())
    # paper 001, Example 3: z = T x with T = [[0, 0, 1], [0, c1, 0], [c1, -c1, c1]]
    T = np.array([[0, 0, 1], [0, C1, 0], [C1, -C1, C1]])
    np.testing.assert_allclose(form.T, T, rtol=1e-14)
    np.testing.assert_allclose(form.T_inv, [[-1, 1 / C1, 1 / C1], [0, 1 / C1, 0], [1, 0, 0]], rtol=1e-13)
    np.testing.assert_allclose(form.d, 0.0)
    # alpha1 = -a1 c1, alpha2 = a1 + a2 + c1, alpha3 = a1 - 1, beta = a3 c1 (hand-worked: P_DERIVED)
    P = np.column_stack([form.alpha, form.beta])
    np.testing.assert_allclose(P, np.array(P_DERIVED), rtol=1e-12, atol=1e-12)
    # sigma(z) = (z3 + z2)/c1 - z1 switching at -1 and 1
    assert len(form.switching) == 1
    np.testing.assert_allclose(form.switching[0].z_row, [-1, 1 / C1, 1 / C1], rtol=1e-13)
    assert form.switching[0].thresholds == (-1.0, 1.0)
    # ranges over the box |x| <= (3, 1, 5): z1 = x3, z2 = c1 x2, z3 = c1 (x1 - x2 + x3)
    np.testing.assert_allclose(form.z_upper, [5, 100 / 7, 900 / 7], rtol=1e-12)
    # z3' = c1 ((a1 - 1) x1 + (10 + c1) x2 - x3 + a3); outer: (25/7) 3 + 30/7 + 5 + 27/7 = 167/7
    np.testing.assert_allclose([form.f_lower, form.f_upper], [-16700 / 49, 16700 / 49], rtol=1e-12)
    # the mode function in z is the automaton's location of x
    for x, q in (([1.5, 0, 0], 0), ([0.3, 0.2, -1], 1), ([-2, 0.1, 2], 2)):
        assert form.mode_of(form.to_z(x)) == q


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


# ---------------------------------------------------------------------------------- Example 2
def test_example2_converges_step_by_step(tri):
    h = tri.observer.Ts
    assert h == 1e-4
    # band j h D_j: D = (max|x2|, max|x3|, max|F|) over the box (1, 1) and |F2| <= 40 + 0.5
    band = np.array([1 * h * 1.0, 2 * h * 1.0, 3 * h * 40.5])
    # stage 1 must reach its layer before |e1(0)| / ((1.5 - 1) x 2) = 2 s (clipped errors), the
    # stated limit for the last state is 1 s, a third of the run
    assert abs(tri.y[0] - tri.run.z_hat[0, 0]) == pytest.approx(2.0)
    tc = _assert_step_by_step(tri, band, t_limit=1.0)
    assert tc[0] <= 2.0
    # after convergence the error stays within 1 % of each state's range on the trajectory
    late = tri.t >= 1.0
    rng_ = np.ptp(tri.z_true, axis=0)
    assert np.all(np.abs(tri.run.z_hat[late] - tri.z_true[late]).max(axis=0) <= 0.01 * rng_)


def test_example2_indicator(tri):
    assert tri.indicator.true_switches == 2  # F2 -> F1 at 0.95 s, F1 -> F2 at 2.25 s (examples module)
    assert tri.indicator.missed_switches == 0
    _assert_indicator_window(tri)


# ---------------------------------------------------------------------------------- Example 3
def test_example3_converges_step_by_step(ds):
    h = ds.observer.Ts
    # D = (max|z2|, max|z3|, max|z3'|) = (100/7, 900/7, 16700/49) over the box (see above)
    band = np.array([1 * h * 100 / 7, 2 * h * 900 / 7, 3 * h * 16700 / 49])
    _assert_step_by_step(ds, band, t_limit=0.5)
    # in x: x3 = z1, x2 = z2 / c1 and x1 (needs z3): after 1 s every error below 1 % of its range
    late = ds.t >= 1.0
    ex = np.abs(ds.run.trace.x_hat[late] - ds.truth.x[late]).max(axis=0)
    assert np.all(ex <= 0.01 * np.ptp(ds.truth.x, axis=0))


def test_example3_indicator(ds):
    assert ds.indicator.true_switches >= 6
    assert ds.indicator.missed_switches == 0
    _assert_indicator_window(ds)


def test_filter_tradeoff_double_scroll(ds):
    h = ds.observer.Ts
    rows = filter_tradeoff("double_scroll", base=ds, noise_levels=(0.0, 1e-7), filter_steps=(None, 20))
    by = {(r["noise_rel"], r["filter_steps"]): r for r in rows}
    raw, filt = by[(1e-7, None)], by[(1e-7, 20)]
    # noise makes the unfiltered indicator chatter; the filter removes most spurious switches ...
    assert raw["spurious_switches"] >= 10 * max(filt["spurious_switches"], 1)
    # ... at the price of a delay: a first-order lag delays a ramp by its time constant tau
    tau = 20 * h
    assert 0.5 * tau <= filt["delay_median_s"] <= 2 * tau
    assert raw["delay_median_s"] <= 3 * h
    clean, clean_f = by[(0.0, None)], by[(0.0, 20)]
    assert clean["delay_median_s"] <= 3 * h and 0.5 * tau <= clean_f["delay_median_s"] <= 2 * tau
    assert clean_f["spurious_switches"] <= clean["spurious_switches"]


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


def test_example1_observer_tracks_the_unstable_switched_system():
    res = run_scenario("switched_unstable")
    h = res.observer.Ts
    # Example 1 grows 4-fold per revolution: x = (4, 0) at t = 3 pi / 2 (examples module)
    assert np.abs(res.truth.x[-1]).max() > 16
    band = np.array([1 * h * 100.0, 2 * h * 400.0])  # |z2| <= 100, |z2'| = |x1| or 4 |x1| <= 400
    _assert_step_by_step(res, band, t_limit=1.0)


# ---------------------------------------------------------------------------------- CLI
def test_cli_switched_unstable_json(capsys):
    """Example 1 through ``hybobs observe``: both stages converge while the plant's state grows
    4-fold per revolution (Remark 1: the bounded-state assumption concerns the switched system)."""
    from hybobs_opt.cli import main

    assert main(["observe", "switched_unstable", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert out["example"] == "switched_unstable"
    times = [c["t"] for c in out["convergence_times"]]
    assert [c["state"] for c in out["convergence_times"]] == ["z1", "z2"]
    assert all(t is not None and t < 1.0 for t in times)
    Ts = out["Ts"]
    # error band j h D_j with |z2| <= 100 and |z2'| <= 400 on the operating box (see the test above)
    assert out["final_error_band"]["z1"] <= 1 * Ts * 100.0 * 1.01
    assert out["final_error_band"]["z2"] <= 2 * Ts * 400.0 * 1.01


def test_cli_double_scroll_json_with_filter(capsys):
    from hybobs_opt.cli import main

    assert main(["observe", "double_scroll", "--json", "--filter"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [c["state"] for c in out["convergence_times"]] == ["z1", "z2", "z3"]
    times = [c["t"] for c in out["convergence_times"]]
    assert all(t is not None for t in times) and times == sorted(times)
    assert set(out["final_error_band"]) == {"z1", "z2", "z3"}
    assert 0 <= out["indicator_mismatch_fraction"] < 0.01
    f = out["filtered"]
    assert f["filter_tau"] > 0 and {"convergence_times", "final_error_band", "indicator_mismatch_fraction"} <= set(f)


@pytest.mark.slow
def test_cli_triangular_json(capsys):
    from hybobs_opt.cli import main

    assert main(["observe", "triangular", "--json"]) == 0
    out = json.loads(capsys.readouterr().out)
    assert [c["state"] for c in out["convergence_times"]] == ["x1", "x2", "x3"]
    assert out["indicator_mismatch_fraction"] < 0.01 and "filtered" not in out


def test_summary_keys(ds):
    s = summarize(ds)
    assert {"convergence_times", "final_error_band", "indicator_mismatch_fraction", "gains", "band"} <= set(s)
    json.dumps(s)


def test_triangular_automaton_is_accepted_as_is():
    form = observability_form(triangular())
    assert form.is_identity and form.alpha is None
    # F1 in [-0.6, 1.4], F2 = -40 cos(.) - 0.5 in [-40.5, 39.5]: the sampled range covers it
    assert form.f_lower <= -40.5 and form.f_upper >= 39.5

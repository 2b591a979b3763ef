"""The noise-aware lookup observer (issue 18): stated false-alarm rate, stated covariance, no wrong
estimate flagged observable on the noisy bench scenario, bad input.

Oracles: the covariance and the estimate of a single-mode system are computed here from the
stacked observability matrix built from ``A, C`` (no region tables); the false-alarm rate is
checked against the binomial law of the stated probability; on model (16) the true states of the
simulation judge every flagged estimate.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linprog
from scipy.stats import binom

from hybobs_opt.errors import ModelError
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.observers.noise_lookup import NoiseAwareLookupObserver
from hybobs_opt.regions import analyse_observability
from hybobs_opt.systems.pwa import PWAMode, PWASystem

A1 = np.array([[0.9, 0.2], [-0.1, 0.8]])
B1 = np.array([[0.0], [0.1]])
C1 = np.array([[1.0, 0.0]])


def one_mode_system() -> PWASystem:
    """A linear system as a one-mode PWA system: every window has one mode sequence, of full rank."""
    guard = Polytope.from_box([-10, -10, -1], [10, 10, 1])
    mode = PWAMode(A1, B1, np.zeros(2), C1, guard, name="linear")
    return PWASystem((mode,), Polytope.from_box([-10, -10], [10, 10]), Polytope.from_box([-1], [1]))


def simulate(system: PWASystem, x0, U):
    X, Y = [], []
    x = np.asarray(x0, dtype=float)
    for u in U:
        X.append(x)
        Y.append(system.output(x, u))
        x = system.step(x, u)
    return np.array(X), np.array(Y)


@pytest.fixture(scope="module")
def linear_analysis():
    return analyse_observability(one_mode_system(), 4)


def test_one_mode_estimate_and_covariance_equal_the_stacked_least_squares(linear_analysis):
    sigma, T = 0.05, 4
    obs = NoiseAwareLookupObserver(linear_analysis, sigma, false_alarm=1e-3)
    rng = np.random.default_rng(1)
    U = rng.uniform(-1, 1, (40, 1))
    X, Y = simulate(one_mode_system(), [1.0, -0.5], U)
    Yn = Y + rng.normal(0, sigma, Y.shape)
    out = obs.run(U, Yn)
    # the oracle: y(k) = C A^k x0 + sum_j C A^(k-1-j) B u(j), least squares over the window
    O = np.vstack([C1 @ np.linalg.matrix_power(A1, k) for k in range(T)])
    S = sigma ** 2 * np.linalg.inv(O.T @ O)
    cov_now = np.linalg.matrix_power(A1, T - 1) @ S @ np.linalg.matrix_power(A1, T - 1).T
    checked = 0
    for t in range(T - 1, 40):
        if out.flags[t] != "observable":
            continue
        Uw, Yw = U[t - T + 1 : t + 1], Yn[t - T + 1 : t + 1]
        forced = np.array([sum((C1 @ np.linalg.matrix_power(A1, k - 1 - j) @ B1 @ Uw[j]).item() for j in range(k))
                           for k in range(T)])
        x_start = np.linalg.lstsq(O, Yw[:, 0] - forced, rcond=None)[0]
        x_now = np.linalg.matrix_power(A1, T - 1) @ x_start + sum(
            np.linalg.matrix_power(A1, T - 2 - j) @ B1 @ Uw[j] for j in range(T - 1))
        np.testing.assert_allclose(out.x_hat[t], x_now, rtol=1e-9, atol=1e-12)
        np.testing.assert_allclose(out.info[t]["covariance"], cov_now, rtol=1e-9)
        checked += 1
    assert checked >= 30


def test_one_mode_false_alarm_rate_is_the_stated_one(linear_analysis):
    """The true (only) sequence fails the tests at most ``alpha`` of the time, and the residual test
    alone fails ``alpha / 2`` of the time when no membership row binds (state far from X's edges)."""
    alpha, sigma, N = 0.05, 0.05, 4000
    obs = NoiseAwareLookupObserver(linear_analysis, sigma, false_alarm=alpha)
    rng = np.random.default_rng(7)
    U = rng.uniform(-0.5, 0.5, (N, 1))
    X, Y = simulate(one_mode_system(), [0.5, 0.5], U)
    out = obs.run(U, Y + rng.normal(0, sigma, Y.shape))
    judged = out.flags[3:]
    rejected = int(np.count_nonzero(judged == "unobservable"))
    assert set(judged) <= {"observable", "unobservable"}
    n = judged.size
    # binomial 99.9 % bounds around alpha / 2 (membership never binds here) and alpha (the bound)
    assert rejected >= binom.ppf(0.0005, n, alpha / 2)
    assert rejected <= binom.ppf(0.9995, n, alpha)
    e = out.x_hat - X
    obs_idx = np.nonzero(out.flags == "observable")[0]
    nees = np.array([e[k] @ np.linalg.solve(out.info[k]["covariance"], e[k]) for k in obs_idx])
    # normalised estimation error squared: chi-square with n = 2 degrees of freedom on average
    assert abs(nees.mean() - 2.0) < 0.15


@pytest.fixture(scope="module")
def powertrain_scenario():
    from hybobs_opt.studies import get_example
    from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario

    plant = get_example("powertrain3").build()
    trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=3000 * plant.Ts)
    return plant, trace, analyse_observability(plant, 4)


def test_noisy_bench_no_observable_estimate_beyond_five_sigma(powertrain_scenario):
    """Issue 18: at 0.01 rad/s no window flagged observable with an error beyond 5 sigma of its
    stated covariance (Mahalanobis distance), while a share of the windows is still observable."""
    plant, trace, analysis = powertrain_scenario
    sigma = 0.01
    y = trace.y + np.random.default_rng(0).normal(0, sigma, trace.y.shape)
    out = NoiseAwareLookupObserver(analysis, sigma).run(trace.u, y)
    e = out.x_hat - trace.x
    idx = np.nonzero(out.flags == "observable")[0]
    assert idx.size > 300  # 634 of 3,000 when measured
    dist = np.array([np.sqrt(e[k] @ np.linalg.solve(out.info[k]["covariance"], e[k])) for k in idx])
    assert dist.max() <= 5.0
    # every flagged window's mode sequence is the true one
    T = analysis.T
    for k in idx:
        assert out.info[k]["candidates"] == [tuple(int(q) for q in trace.q[k - T + 1 : k + 1])]


def test_rank_deficient_family_decisions_agree_with_an_independent_lp(powertrain_scenario):
    """Each membership LP of a rank-deficient sequence decides like scipy's HiGHS on the same rows
    built here from the region (original coordinates, no scaling)."""
    plant, trace, analysis = powertrain_scenario
    sigma = 0.01
    obs = NoiseAwareLookupObserver(analysis, sigma)
    y = trace.y + np.random.default_rng(3).normal(0, sigma, trace.y.shape)
    T, n = analysis.T, plant.n
    seen = {True: 0, False: 0}
    calls = []
    original = obs._consistent_family

    def spy(seq, v, viol):
        ans = original(seq, v, viol)
        calls.append((seq, v.copy(), viol.copy(), ans))
        return ans

    obs._consistent_family = spy
    obs.run(trace.u[:600], y[:600])
    assert calls
    sample = [c for c in calls if not c[3]][:150] + [c for c in calls if c[3]][:150]
    for seq, v, viol, ans in sample:
        reg = analysis.regions[seq.index]
        x_i = v[:n]
        # the least-squares family of the window: x_i + null(C~) w, in original coordinates
        _, s, Vt = np.linalg.svd(np.tile(1 / sigma, T)[:, None] * reg.C)
        Nn = Vt[int(np.count_nonzero(s > 1e-9 * s[0])):].T
        lo, hi = plant.state_bounds.bounding_box()
        widen = (hi - lo) / 2 * seq.box_margin
        # rows of P_i with their margins: Hx (x_i + N w) <= Hx x_i - viol ; and the widened box
        Hx = reg.H[:, :n]
        G = np.vstack([Hx @ Nn, Nn, -Nn])
        g = np.concatenate([-viol, hi + widen - x_i, x_i - lo + widen])
        res = linprog(np.zeros(Nn.shape[1]), A_ub=G, b_ub=g + 1e-9 * (1 + np.abs(g)), bounds=[(None, None)] * Nn.shape[1],
                      method="highs")
        assert res.status in (0, 2)
        assert (res.status == 0) == ans, (reg.sequence, res.status, ans)
        seen[ans] += 1
    assert seen[True] and seen[False]


def test_bad_samples_fall_back_and_the_run_goes_on(linear_analysis):
    obs = NoiseAwareLookupObserver(linear_analysis, 0.05)
    rng = np.random.default_rng(2)
    U = rng.uniform(-1, 1, (20, 1))
    _, Y = simulate(one_mode_system(), [1.0, -0.5], U)
    for k in range(8):
        assert obs.step(U[k], Y[k]).flag in ("warming_up", "observable", "unobservable")
    assert obs.step(U[8], [np.nan]).flag == "fallback"
    bad = obs.step(U[9], [1.0, 2.0])
    assert bad.flag == "fallback" and "length" in bad.info["reason"]
    fault = obs.step(U[10], [1e12])
    assert fault.flag == "fallback" and "output" in fault.info["reason"]
    outside = obs.step([5.0], Y[10])
    assert outside.flag == "fallback" and "input" in outside.info["reason"]
    # no input to predict with after it; the window refills: T good samples later it reconstructs
    first = obs.step(U[11], Y[11])
    assert first.flag == "fallback" and "previous sample" in first.info["reason"]
    flags = [obs.step(U[k], Y[k]).flag for k in range(12, 20)]
    assert flags[:2] == ["warming_up"] * 2 and "observable" in flags[2:]


def test_construction_errors_name_the_field(linear_analysis):
    with pytest.raises(ModelError, match="noise_std"):
        NoiseAwareLookupObserver(linear_analysis, 0.0)
    with pytest.raises(ModelError, match="noise_std"):
        NoiseAwareLookupObserver(linear_analysis, [0.1, 0.2])
    with pytest.raises(ModelError, match="noise_std"):
        NoiseAwareLookupObserver(linear_analysis, "0.1")
    with pytest.raises(ModelError, match="false_alarm"):
        NoiseAwareLookupObserver(linear_analysis, 0.1, false_alarm=0.7)
    with pytest.raises(ModelError, match="analysis"):
        NoiseAwareLookupObserver(analyse_observability(one_mode_system(), 2), 0.1)  # T p = n: no residual test
    with pytest.raises(ModelError, match="analysis"):
        NoiseAwareLookupObserver(object(), 0.1)

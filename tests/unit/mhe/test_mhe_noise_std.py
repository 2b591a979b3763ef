"""``MHEObserver(noise_std=...)`` (issue 18): ``observable`` means the confidence region of the
window-start state lies within ``delta``, so a flagged estimate is farther than ``delta`` from the
truth only with the stated false-alarm probability.

Oracle: the simulated truth; the default uniqueness epsilon (noise-free meaning) flags estimates
farther than ``delta`` on the same data, which is what ``noise_std`` exists to prevent.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.stats import binom

from hybobs_opt.errors import ModelError
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.mhe import MHEObserver
from hybobs_opt.systems.pwa import PWAMode, PWASystem

A1 = np.array([[0.9, 0.2], [-0.1, 0.8]])


def one_mode_system() -> PWASystem:
    guard = Polytope.from_box([-10, -10, -1], [10, 10, 1])
    mode = PWAMode(A1, np.array([[0.0], [0.1]]), np.zeros(2), np.array([[1.0, 0.0]]), guard, name="linear")
    return PWASystem((mode,), Polytope.from_box([-10, -10], [10, 10]), Polytope.from_box([-1], [1]))


def noisy_run(sigma: float):
    system = one_mode_system()
    rng = np.random.default_rng(4)
    N = 400
    U = rng.uniform(-1, 1, (N, 1))
    X = np.zeros((N, 2))
    x = np.array([2.0, -1.0])
    for k in range(N):
        X[k] = x
        x = system.step(x, U[k])
    Y = X[:, :1] + sigma * rng.standard_normal((N, 1))
    return system, U, X, Y, sigma


def scaled_errors(out, X):
    return np.max(np.abs(out.x_hat - X) / 10.0, axis=1)  # half-widths of X are 10


def test_flagged_estimates_lie_within_delta_but_for_the_false_alarms():
    """A linear window's confidence region has the same size in every window: at sigma = 0.06 it
    fits within delta, and the flagged estimates are farther only at the false-alarm rate."""
    system, U, X, Y, sigma = noisy_run(0.06)
    alpha = 0.01
    obs = MHEObserver(system, 4, noise_std=sigma, false_alarm=alpha)
    out = obs.run(U, Y)
    flagged = out.flags == "observable"
    assert flagged.sum() > 300
    far = int(np.count_nonzero(scaled_errors(out, X)[flagged] > obs.settings.uniqueness_delta))
    assert far <= binom.ppf(0.999, int(flagged.sum()), alpha)


def test_noisier_data_are_not_called_unique_where_the_default_epsilon_does():
    """At sigma = 0.2 the confidence region exceeds delta: noise_std flags nothing observable,
    while the default (noise-free) epsilon calls every optimum unique, 26 of them farther than delta."""
    system, U, X, Y, sigma = noisy_run(0.2)
    noisy = MHEObserver(system, 4, noise_std=sigma, false_alarm=0.01).run(U, Y)
    assert not np.any(noisy.flags == "observable")
    assert set(noisy.flags[3:]) <= {"unobservable"}
    default = MHEObserver(system, 4, fit_tolerance=5 * sigma)
    out = default.run(U, Y)
    flagged = out.flags == "observable"
    assert np.count_nonzero(scaled_errors(out, X)[flagged] > default.settings.uniqueness_delta) > 10


def test_noise_std_sets_the_weight_and_the_chi_square_epsilon():
    from scipy.stats import chi2

    system, sigma = one_mode_system(), 0.05
    obs = MHEObserver(system, 4, noise_std=sigma, false_alarm=0.02)
    assert obs.uniqueness_epsilon == pytest.approx(chi2.isf(0.02, 2))
    np.testing.assert_allclose(obs.fit_tolerance, [5 * sigma])
    np.testing.assert_allclose(obs._Wy, [[1 / sigma]])


def test_noise_std_bad_input_names_the_field():
    system = one_mode_system()
    with pytest.raises(ModelError, match="noise_std"):
        MHEObserver(system, 4, noise_std=-1.0)
    with pytest.raises(ModelError, match="noise_std"):
        MHEObserver(system, 4, noise_std=[0.1, 0.2])
    with pytest.raises(ModelError, match="noise_std"):
        MHEObserver(system, 4, norm="1", noise_std=0.1)
    with pytest.raises(ModelError, match="output_weight"):
        MHEObserver(system, 4, noise_std=0.1, output_weight=2.0)
    with pytest.raises(ModelError, match="false_alarm"):
        MHEObserver(system, 4, noise_std=0.1, false_alarm=0.9)


def test_the_uniqueness_answer_says_whether_it_includes_the_prior():
    """With an arrival cost "unique" is unique given the prior (a weaker claim): info says so."""
    system, U, X, Y, sigma = noisy_run(0.01)
    U, Y = U[:12], Y[:12]
    for weight, expected in ((None, False), (1e-3, True)):
        obs = MHEObserver(system, 4, arrival_weight=weight, fit_tolerance=5 * sigma)
        assert obs.uniqueness_includes_prior is expected
        out = obs.run(U, Y)
        judged = [i for i, f in zip(out.info, out.flags) if "uniqueness" in i]
        assert judged and all(i["uniqueness"]["includes_prior"] is expected for i in judged)

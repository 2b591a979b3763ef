"""The exact-gain-bound search (:mod:`hybobs_opt.lmi.gain_search`) and the fixed-gain noise analysis.

Every rate the search returns is re-proven here on vertex matrices written out by hand from the
system's matrices (no toolbox vertex code), and the eigenvalue bound is checked against numpy's
eigenvalues vertex by vertex.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import _oracles as O

from hybobs_opt.errors import ModelError
from hybobs_opt.lmi import jacobian_bounds, make_region
from hybobs_opt.lmi.gain_search import decay_gain_search, eigenvalue_bound, gain_decay_rate
from hybobs_opt.lmi.noise_gain import noise_optimal_design
from hybobs_opt.systems.resolve import resolve_system

LO, HI = 0.2, math.pi / 2


@pytest.fixture(scope="module")
def pendulum():
    system = O.pendulum("cos")
    return system, jacobian_bounds(system, make_region(system, 0, LO, HI))


@pytest.fixture(scope="module")
def robot():
    system = resolve_system("examples/models/flexible_joint_robot.toml")
    k = list(system.state_names).index("theta_l")
    return system, jacobian_bounds(system, make_region(system, k, float(system.box_lower[k]), float(system.box_upper[k])))


def robot_rate(system, P, L) -> float:
    """The rate ``(P, L)`` proves at cos(theta_l) = -1 and 1 (the robot's two vertices), by hand."""
    A, F, E, C = (np.array(m, dtype=float) for m in (system.A, system.F, system.E, system.C))
    w, U = np.linalg.eigh(P)
    Pih = U @ np.diag(w ** -0.5) @ U.T
    return min(-np.linalg.eigvalsh(Pih @ (P @ Acl + Acl.T @ P) @ Pih).max()
               for Acl in (A + s * F @ E - L @ C for s in (-1.0, 1.0)))


def test_eigenvalue_bound_is_the_smallest_vertex_margin():
    rng = np.random.default_rng(3)
    As = [rng.standard_normal((3, 3)) for _ in range(4)]
    Cs = [rng.standard_normal((2, 3)) for _ in range(4)]
    Ls = rng.standard_normal((5, 3, 2))
    want = [min(-2 * np.linalg.eigvals(A - L @ C).real.max() for A, C in zip(As, Cs)) for L in Ls]
    assert eigenvalue_bound(As, Cs, Ls) == pytest.approx(want, rel=1e-12)


def test_search_pair_proves_its_rate_within_the_bound_and_improves_on_its_start(robot):
    system, bounds = robot
    start_rate, start_P = gain_decay_rate(system, bounds, np.zeros((4, 2)) + np.array([[20.0, 0], [0, 20.0], [0, 0], [0, 0]]))
    res = decay_gain_search(system, bounds, 50.0, screen=False,
                            starts=(("hand-made", start_P, np.array([[20.0, 0], [0, 20.0], [0, 0], [0, 0]])),))
    assert res.found and res.gain_norm <= 50.0 * (1 + 1e-6)
    assert robot_rate(system, res.P, res.L) >= res.sigma * (1 - 1e-9)
    assert res.sigma >= start_rate * (1 - 1e-9) and res.starts[0].polished == pytest.approx(res.sigma)
    # no quadratic certificate at the returned gain proves more than its eigenvalue bound
    assert res.sigma <= res.eig_bound * (1 + 1e-9)


def test_gain_decay_rate_is_proven_and_close_to_the_eigenvalue_bound(robot):
    system, _ = robot
    k = list(system.state_names).index("theta_l")
    bounds = jacobian_bounds(system, make_region(system, k, -0.5, 0.5))  # cos in [0.878, 1]
    L = np.array([[30.0, 1.0], [100.0, 30.0], [2.0, 10.0], [50.0, 40.0]])
    rate, P = gain_decay_rate(system, bounds, L)
    A, F, E, C = (np.array(m, dtype=float) for m in (system.A, system.F, system.E, system.C))
    lo = math.cos(0.5)
    w, U = np.linalg.eigh(P)
    Pih = U @ np.diag(w ** -0.5) @ U.T
    proven = min(-np.linalg.eigvalsh(Pih @ (P @ Acl + Acl.T @ P) @ Pih).max()
                 for Acl in (A + s * F @ E - L @ C for s in (lo, 1.0)))
    eig = min(-2 * np.linalg.eigvals(A + s * F @ E - L @ C).real.max() for s in (lo, 1.0))
    assert proven >= rate * (1 - 1e-9) and 0 < rate <= eig * (1 + 1e-9)
    assert rate >= 0.9 * eig  # two close vertices: a common P nearly reaches the spectral margin
    with pytest.raises(ModelError, match="L"):
        gain_decay_rate(system, bounds, np.ones((4, 3)))


def test_noise_analysis_of_a_given_gain_keeps_it_and_verifies(pendulum):
    system, bounds = pendulum
    designed = noise_optimal_design(system, bounds, [0.01], gain_bound=20.0)
    analysed = noise_optimal_design(system, bounds, [0.01], gain=designed.L)
    assert np.array_equal(analysed.L, designed.L) and analysed.verify()
    # the analysis searches alpha freely for this gain: never a worse bound than the design's own point
    assert analysed.worst_relative <= designed.worst_relative * (1 + 1e-3)
    assert analysed.peak_to_peak_gain == pytest.approx(analysed.bound / 0.01)
    with pytest.raises(ModelError, match="gain_bound"):
        noise_optimal_design(system, bounds, [0.01], gain=designed.L, gain_bound=20.0)
    with pytest.raises(ModelError, match="gain"):
        noise_optimal_design(system, bounds, [0.01], gain=np.full((2, 1), np.nan))

"""The decay-optimal constant gain within a gain bound (:mod:`hybobs_opt.lmi.decay_design`).

The rates are checked with the independent oracle of ``_oracles.py`` (the pendulum's vertex
matrices from closed-form slopes, numpy eigenvalues) and the verdicts against what must hold:
a bound too small for any gain is refused with a certificate that re-checks, a required rate is
met or refused.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import _oracles as O

from hybobs_opt.lmi import condition_hierarchy, jacobian_bounds, make_region
from hybobs_opt.lmi.decay_design import decay_optimal_design
from hybobs_opt.systems.resolve import resolve_system

LO, HI = 0.2, math.pi / 2


@pytest.fixture(scope="module")
def pendulum_cos():
    system = O.pendulum("cos")
    region = make_region(system, 0, LO, HI)
    return system, region, jacobian_bounds(system, region)


@pytest.fixture(scope="module")
def robot():
    system = resolve_system("examples/models/flexible_joint_robot.toml")
    k = list(system.state_names).index("theta_l")
    region = make_region(system, k, float(system.box_lower[k]), float(system.box_upper[k]))
    return system, region, jacobian_bounds(system, region)


def test_best_gain_is_within_the_bound_and_its_rate_holds_on_the_oracle_vertices(pendulum_cos):
    system, region, bounds = pendulum_cos
    design = decay_optimal_design(system, bounds, gain_bound=20.0)
    best = design.best
    assert best is not None and design.met and design.within_bound
    assert np.linalg.norm(best.L, 2) <= 20.0 * (1 + 1e-6)
    oracle_rate = -O.vertex_lyapunov_max_eig(best.P, best.L, "cos", LO, HI)
    assert oracle_rate >= best.sigma_verified * (1 - 1e-6) - 1e-9
    # the rate of the first feasible point of the hierarchy (sigma = 0, no bound) is no design
    first = condition_hierarchy(system, region, bounds=bounds).gain.sigma_verified
    assert best.sigma_verified > 10 * first
    for c in design.by_condition:  # every condition's rate is its own (P, L)'s, on the oracle too
        if c.feasible:
            assert -O.vertex_lyapunov_max_eig(c.P, c.L, "cos", LO, HI) >= c.sigma_verified * (1 - 1e-6) - 1e-9


def test_the_internal_bound_is_raised_only_within_the_users_bound(pendulum_cos):
    system, _, bounds = pendulum_cos
    design = decay_optimal_design(system, bounds, gain_bound=20.0)
    best = design.best
    assert best.internal_gain_bound >= 20.0 and best.method == "bisection"
    untightened = [c for c in design.by_condition if c.feasible and c is not best]
    assert all(c.internal_gain_bound == 20.0 for c in untightened)


def test_the_exact_bound_search_proves_more_than_the_conditions_and_says_how(pendulum_cos):
    system, _, bounds = pendulum_cos
    design = decay_optimal_design(system, bounds, gain_bound=20.0, search_exact_bound=True)
    best = design.best
    convex = max(c.sigma_verified for c in design.by_condition if c.feasible)
    # the conditions' sufficient bound (P >= a I) leaves part of the ball unused; the search does not
    assert best.method == "exact-bound search" and best.condition == "polytopic"
    assert best.sigma_verified > 1.05 * convex
    assert np.linalg.norm(best.L, 2) <= 20.0 * (1 + 1e-6)
    assert -O.vertex_lyapunov_max_eig(best.P, best.L, "cos", LO, HI) >= best.sigma_verified * (1 - 1e-6) - 1e-9
    assert "local search under the exact bound" in design.headline("theta in R")
    assert "a larger rate is not ruled out" in design.headline("theta in R")
    # without the search (the default) the best condition's gain is reported, by bisection
    plain = decay_optimal_design(system, bounds, gain_bound=20.0)
    assert plain.exact_search is None and plain.best.method == "bisection"
    assert plain.best.sigma_verified == pytest.approx(convex)


def test_a_gain_the_lmis_bound_excludes_is_found_by_the_exact_bound_search(robot):
    system, region, bounds = robot
    design = decay_optimal_design(system, bounds, gain_bound=5.0, search_exact_bound=True)
    # every condition with the LMIs' form of the bound is infeasible, with a certificate ...
    assert not any(c.feasible for c in design.by_condition)
    last = design.by_condition[-1]
    assert last.condition == "polytopic" and last.certificate is not None and last.certificate.verify()
    # ... yet a gain in the ball exists: the form is only sufficient
    best = design.best
    assert design.within_bound and best.method == "exact-bound search"
    assert np.linalg.norm(best.L, 2) <= 5.0 * (1 + 1e-6) and best.sigma_verified > 1.0
    assert design.headline("theta_l in R").startswith("FEASIBLE: a constant gain with ||L||_2 <= 5 and decay rate")
    # the rate on the robot's two vertex matrices (cos(theta_l) = -1 and 1), written out here
    A = np.array(system.A, dtype=float)
    F = np.array(system.F, dtype=float)
    E = np.array(system.E, dtype=float)
    C = np.array(system.C, dtype=float)
    w, U = np.linalg.eigh(best.P)
    Pih = U @ np.diag(w ** -0.5) @ U.T
    for slope in (-1.0, 1.0):
        Acl = A + slope * F @ E - best.L @ C
        assert np.linalg.eigvalsh(Pih @ (best.P @ Acl + Acl.T @ best.P) @ Pih).max() <= -best.sigma_verified * (1 - 1e-9)


def test_a_bound_no_gain_meets_is_the_first_line_with_a_certificate(robot):
    system, region, bounds = robot
    design = decay_optimal_design(system, bounds, gain_bound=1.0, search_exact_bound=True)
    assert not design.within_bound and not design.met and design.best is None
    last = design.by_condition[-1]
    assert last.condition == "polytopic" and last.certificate is not None and last.certificate.verify()
    headline = design.headline("theta_l in R")
    assert headline.startswith("NO GAIN FOUND WITHIN ||L||_2 <= 1:")
    assert "found no pair either" in headline and "not ruled out" in headline  # both searches are incomplete


def test_a_required_rate_is_met_or_refused(robot):
    system, _, bounds = robot
    free = decay_optimal_design(system, bounds, gain_bound=50.0)
    rate = free.best.sigma_verified
    assert rate > 0
    above = decay_optimal_design(system, bounds, gain_bound=50.0, min_decay=2 * rate)
    assert above.within_bound and not above.met
    assert above.headline("R").startswith("DECAY NOT MET:") and f"{2 * rate:g}" in above.headline("R")
    below = decay_optimal_design(system, bounds, gain_bound=50.0, min_decay=0.5 * rate)
    assert below.met and below.headline("R").startswith("FEASIBLE:")

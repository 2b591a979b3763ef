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
    assert best.internal_gain_bound >= 20.0
    untightened = [c for c in design.by_condition if c.feasible and c is not best]
    assert all(c.internal_gain_bound == 20.0 for c in untightened)


def test_a_bound_no_gain_meets_is_the_first_line_with_a_certificate(robot):
    system, region, bounds = robot
    design = decay_optimal_design(system, bounds, gain_bound=5.0)
    assert not design.within_bound and not design.met and design.best is None
    last = design.by_condition[-1]
    assert last.condition == "polytopic" and last.certificate is not None and last.certificate.verify()
    assert design.headline("theta_l in R").startswith("NO GAIN FOUND WITHIN ||L||_2 <= 5:")
    assert "not ruled out" in design.headline("theta_l in R")  # the LMI bound on L is only sufficient


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

"""Unknown parameters as constant states (issue 18: the backlash gap alpha of model 16).

Oracles: the factory itself at the parameter's value (the augmented system must step and output
exactly like it), and simulated windows of the original system whose full-rank mode sequence the
lookup observer of the augmented system must invert to the true alpha.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.observers.lookup import LookupObserver
from hybobs_opt.regions import analyse_observability
from hybobs_opt.studies.paper002_powertrain.systems import powertrain3
from hybobs_opt.systems.parameters import augment_parameters


@pytest.fixture(scope="module")
def aug():
    return augment_parameters(lambda alpha: powertrain3(alpha=alpha), {"alpha": (0.02, 0.08)})


def test_augmented_system_steps_like_the_factory_at_each_alpha(aug):
    S = aug.system
    assert S.state_names == ("theta", "omega_m", "omega_l", "alpha") and aug.parameters == ("alpha",)
    rng = np.random.default_rng(0)
    for alpha in (0.02, 0.037, 0.08):
        plant = powertrain3(alpha=alpha)
        for _ in range(200):
            x = np.array([rng.uniform(-0.2, 0.2), rng.uniform(0, 600), rng.uniform(-50, 50)])
            u = np.array([rng.uniform(0, 140)])
            xa = aug.augment_state(x, {"alpha": alpha})
            assert S.mode_of(xa, u) == plant.mode_of(x, u)
            np.testing.assert_allclose(S.step(xa, u), np.append(plant.step(x, u), alpha), rtol=1e-12, atol=1e-12)
            np.testing.assert_allclose(S.output(xa, u), plant.output(x, u), rtol=1e-12, atol=1e-12)


def test_lookup_on_the_augmented_system_recovers_alpha_from_a_fast_traversal(aug):
    """At T = 4 the sequences through the whole gap (contact, backlash, other contact) have rank
    n + 1 = 4: the window determines alpha.  Windows drawn inside those regions, simulated with the
    original model at their alpha, are reconstructed exactly by the augmented lookup observer."""
    an = analyse_observability(aug.system, 4)
    assert an.index_set, "some window must determine alpha"
    obs = LookupObserver(an)
    checked = 0
    for i in an.index_set:
        reg = an.regions[i]
        centre, radius = Polytope(reg.H, reg.h).chebyshev_ball(an.enumeration.scale)
        assert centre is not None and radius > 0
        x0, alpha, U = centre[:3], centre[3], centre[4:].reshape(4, 1)
        plant = powertrain3(alpha=float(alpha))
        x, Y, X = x0.copy(), [], []
        for u in U:
            X.append(x)
            Y.append(plant.output(x, u))
            x = plant.step(x, u)
        assert [plant.mode_of(xk, u) for xk, u in zip(X, U)] == list(reg.sequence)
        obs.reset()
        est = [obs.step(u, y) for u, y in zip(U, Y)][-1]
        assert est.flag == "observable"
        np.testing.assert_allclose(est.x[3], alpha, rtol=1e-7)
        np.testing.assert_allclose(est.x[:3], X[-1], rtol=1e-7, atol=1e-9)
        checked += 1
    assert checked == len(an.index_set)


def test_slow_traversals_leave_alpha_undetermined(aug):
    """Every full-rank sequence at T = 4 holds the whole gap: windows in one contact mode only see
    theta - alpha (rank n = 3 of n + 1)."""
    an = analyse_observability(aug.system, 4)
    for i in an.index_set:
        seq = an.regions[i].sequence
        assert 0 in seq and 2 in seq, seq  # both contact modes (0: theta <= -alpha, 2: theta >= alpha)


def test_parameters_outside_the_affine_terms_and_guards_are_refused():
    with pytest.raises(ModelError, match="changes A of mode"):
        augment_parameters(lambda k: powertrain3(k=k), {"k": (5000.0, 15000.0)})

    def curved(alpha):
        return powertrain3(alpha=alpha ** 2 * 20.0)  # enters quadratically

    with pytest.raises(ModelError, match="not affine"):
        augment_parameters(curved, {"alpha": (0.03, 0.06)})


def test_bad_arguments_name_the_field():
    with pytest.raises(ModelError, match="build"):
        augment_parameters("powertrain3", {"alpha": (0.02, 0.08)})
    with pytest.raises(ModelError, match="parameters"):
        augment_parameters(lambda alpha: powertrain3(alpha=alpha), {})
    with pytest.raises(ModelError, match=r"parameters\['alpha'\]"):
        augment_parameters(lambda alpha: powertrain3(alpha=alpha), {"alpha": (0.08, 0.02)})
    with pytest.raises(ModelError, match="build"):
        augment_parameters(lambda gap: powertrain3(alpha=gap), {"alpha": (0.02, 0.08)})
    with pytest.raises(ModelError, match="params"):
        augment_parameters(lambda alpha: powertrain3(alpha=alpha), {"alpha": (0.02, 0.08)}).augment_state([0, 0, 0], {})


def test_miqp_on_the_augmented_system_estimates_alpha_jointly(aug):
    """The MIQP (10) of the augmented system has alpha as a bounded decision variable: on a window
    through the whole gap its certified optimum returns the true alpha and state."""
    from hybobs_opt.mhe import MHEObserver, MHESettings

    an = analyse_observability(aug.system, 4)
    obs = MHEObserver(aug.system, 4, settings=MHESettings(check_uniqueness=False))
    checked = 0
    for i in an.index_set[:3]:
        reg = an.regions[i]
        centre, _ = Polytope(reg.H, reg.h).chebyshev_ball(an.enumeration.scale)
        x, alpha, U = centre[:3].copy(), float(centre[3]), centre[4:].reshape(4, 1)
        plant = powertrain3(alpha=alpha)
        Y = []
        for u in U:
            Y.append(plant.output(x, u))
            x = plant.step(x, u)
        out = obs.solve_window(U, np.array(Y))
        assert out["status"] == "optimal", out
        np.testing.assert_allclose(out["x_start"][3], alpha, rtol=1e-6)
        np.testing.assert_allclose(out["x_start"][:3], centre[:3], rtol=1e-6, atol=1e-6)
        checked += 1
    assert checked == min(3, len(an.index_set))

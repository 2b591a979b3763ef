"""The backlash gap hidden from the observer (issue 18): the bank of lookup observers.

Oracle: the simulated truth (the hidden gap and the states).  The issue's criterion: the estimate
within 5 % of the truth after the first backlash crossing.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.observers.parameter_bank import ParameterBank
from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario, powertrain3
from hybobs_opt.studies.paper002_powertrain.unknown_gap import first_crossing, run_unknown_gap_study


@pytest.fixture(scope="module")
def study():
    return run_unknown_gap_study(draws=3, steps=1500, grid_step=0.004, seed=5)


def test_gap_estimate_within_five_percent_after_the_first_crossing(study):
    assert study["summary"]["within_5_percent"]
    for d in study["draws"]:
        assert 0.02 <= d["alpha"] <= 0.08
        assert d["max_relative_error_after_first_crossing"] <= 0.05
        lo, hi = d["estimate_spread_after_first_crossing"]
        assert lo <= hi and abs(hi - d["alpha"]) <= 0.05 * d["alpha"]


def test_gap_is_not_claimed_before_the_shaft_crosses_it(study):
    """Before a whole traversal every gap of the grid explains the data: nothing is determined
    and the bank flags no state observable (theta is seen only as theta - alpha)."""
    for d in study["draws"]:
        assert d["determined_from_sample"] >= d["first_crossing_sample"]
        assert d["bank_flags"]["observable"] < d["known_gap_flags"]["observable"]
        # after refinement the flagged states are as exact as the gap estimate allows
        assert d["bank_max_abs_error_flagged"]["theta"] < 1e-4
        assert d["bank_max_abs_error_flagged"]["omega_l"] < 1e-6


def test_bank_before_any_crossing_flags_nothing_observable():
    plant = powertrain3(alpha=0.043, theta_max=0.3)
    trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=0.9)
    assert first_crossing(trace.q) is None
    bank = ParameterBank(lambda alpha: powertrain3(alpha=alpha, theta_max=0.3), "alpha", [0.03, 0.04, 0.05, 0.06], 3)
    out = bank.run(trace.u, trace.y)
    assert not out.determined.any() and np.isnan(out.parameter).all()
    assert "observable" not in set(out.flags)


def test_first_crossing_needs_the_other_contact():
    assert first_crossing(np.array([2, 2, 1, 1, 2, 1, 0, 0])) == 6
    assert first_crossing(np.array([2, 1, 2, 1, 1])) is None


def test_bad_arguments_name_the_field():
    build = lambda alpha: powertrain3(alpha=alpha)  # noqa: E731
    with pytest.raises(ModelError, match="grid"):
        ParameterBank(build, "alpha", [0.03, 0.02, 0.04], 3)
    with pytest.raises(ModelError, match="grid"):
        ParameterBank(build, "alpha", [0.03, 0.04], 3)
    with pytest.raises(ModelError, match="build"):
        ParameterBank("powertrain3", "alpha", [0.03, 0.04, 0.05], 3)
    with pytest.raises(ModelError, match="draws"):
        run_unknown_gap_study(draws=0)
    with pytest.raises(ModelError, match="grid_step"):
        run_unknown_gap_study(draws=1, grid_step=0.5)


@pytest.mark.parametrize("noise", ["uniform", "gaussian"])
def test_the_interval_of_gaps_holds_the_hidden_gap_under_bounded_noise(noise):
    """The set-membership filter on the augmented system (engine speed within 1e-3 rad/s): the
    hidden gap and every true state lie in the reported box at every step, the interval of gaps
    stays the prior [0.02, 0.08] until the shaft has crossed the gap and shrinks to the gap after
    it, and a flagged twist lies within its radius.  Oracle: the simulated truth."""
    from hybobs_opt.studies.paper002_powertrain.unknown_gap import run_gap_interval_study

    out = run_gap_interval_study([0.03, 0.07], steps=300, start=900, noise=noise, seed=2)
    for d in out["draws"]:
        assert d["noise_within_bound"]
        assert d["n_outside_box"] == 0
        assert d["interval_within_1_percent_from_sample"] >= d["first_crossing_sample"] - 2
        lo, hi = d["final_interval"]
        assert lo <= d["alpha"] <= hi and hi - lo <= 0.01 * d["alpha"]
        assert d["n_flagged_observable"] > 0 and d["max_theta_error_over_radius_flagged"] <= 1.0

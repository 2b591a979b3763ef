"""Positive scalar arguments go through one check (``hybobs_opt._validate.as_positive``): a string,
a bool, NaN, zero, a negative number or a one-entry array is a ModelError naming the argument,
never a numpy TypeError or a silent coercion (``True`` taken for 1)."""

from __future__ import annotations

import numpy as np
import pytest

from canonical import deadzone_spring

from hybobs_opt.errors import ModelError

BAD = ["0.1", True, float("nan"), float("inf"), 0.0, -1.0, np.array([0.1])]


def _driveline():
    from hybobs_opt.studies import get_example

    return get_example("driveline").build()


def _calls():
    from hybobs_opt.contract import TimeGuard
    from hybobs_opt.lmi import ObserverLMI, dwell_for_hysteresis, hysteresis_for_dwell
    from hybobs_opt.lmi.observer_lmi import bisect_decay
    from hybobs_opt.observers.kalman import ModeSequenceKalmanFilter
    from hybobs_opt.observers.set_filter import SetMembershipFilter
    from hybobs_opt.sim import simulate_hybrid, simulate_hybrid_fixed_step
    from hybobs_opt.studies import get_example
    from hybobs_opt.synthesis import ContinuousObserverLMI, design_residual_bank

    aut = _driveline()
    x0 = np.zeros(aut.n)
    vehicle = get_example("vehicle_tracking").build()
    return {
        "dt": [lambda v: simulate_hybrid(aut, x0, 0.01, dt=v), lambda v: simulate_hybrid_fixed_step(aut, x0, 0.01, dt=v)],
        "max_time_step": [lambda v: TimeGuard(v)],
        "max_rate": [lambda v: hysteresis_for_dwell(1.0, v), lambda v: dwell_for_hysteresis(0.1, v)],
        "sigma_cap": [lambda v: bisect_decay(lambda s: None, sigma_cap=v)],
        "gain_bound": [lambda v: ObserverLMI(vehicle, gain_bound=v), lambda v: ContinuousObserverLMI(aut, gain_bound=v),
                       lambda v: design_residual_bank(aut, 0.1, 0.01, 1.0, gain_bound=v)],
        "observable_std": [lambda v: ModeSequenceKalmanFilter(deadzone_spring(), 0.01, observable_std=v)],
    }


CASES = [(field, k) for field, n in (("dt", 2), ("max_time_step", 1), ("max_rate", 2), ("sigma_cap", 1),
                                      ("gain_bound", 3), ("observable_std", 1)) for k in range(n)]


@pytest.fixture(scope="module")
def calls():
    return _calls()


@pytest.mark.parametrize("field,k", CASES)
def test_a_bad_positive_argument_is_a_model_error_naming_it(calls, field, k):
    for bad in BAD:
        with pytest.raises(ModelError, match=field):
            calls[field][k](bad)


def test_max_pieces_is_an_integer_of_at_least_one():
    from hybobs_opt.observers.set_filter import SetMembershipFilter

    for bad in (0, 2.0, "3", True, None):
        with pytest.raises(ModelError, match="max_pieces"):
            SetMembershipFilter(deadzone_spring(), 0.01, max_pieces=bad)

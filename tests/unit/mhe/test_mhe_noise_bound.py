"""``MHEObserver(noise_bound=...)``: the moving-horizon estimate with a certified radius.

The oracle of the consistent box is the enumeration of :mod:`test_set_membership` (one scipy LP per
mode sequence, state and side, built from the system matrices): the radius must be, per state,
the distance from the MHE's estimate to the farther side of that box, and the true state must lie
within it.
"""

from __future__ import annotations

import numpy as np
import pytest
from test_set_membership import CASES, oracle_box, output_span

from hybobs_opt import MHEObserver
from hybobs_opt.contract import FALLBACK, OBSERVABLE, WARMING_UP
from hybobs_opt.errors import ModelError


@pytest.mark.parametrize("norm", ["2", "1"])
@pytest.mark.parametrize("case", sorted(CASES))
def test_the_radius_is_the_distance_to_the_farthest_consistent_state(case, norm):
    T, steps = 3, 9
    system, U, trace = CASES[case](T, steps)
    half = system.scales()[0][:system.n]
    beta = 0.01 * output_span(system)
    Y = trace.y + np.random.default_rng(7).uniform(-1, 1, size=trace.y.shape) * beta
    obs = MHEObserver(system, T, norm=norm, noise_bound=beta)
    assert obs.noise_bound.tolist() == np.broadcast_to(beta, (system.p,)).tolist()
    from_optimum = 0
    for k in range(steps):
        est = obs.step(U[k], Y[k])
        if k < T - 1:
            assert est.flag == WARMING_UP
            continue
        lo, hi = oracle_box(system, U[k - T + 1:k + 1], Y[k - T + 1:k + 1], beta)
        assert est.flag != FALLBACK, est.info.get("reason")
        r = np.asarray(est.info["radius"])
        expected = np.maximum(est.x - lo, hi - est.x)
        # the box is the MILPs' widened by their pad (1e-8 of the half-widths)
        assert np.all(np.abs(r - expected) <= 1e-6 * half), (case, k, r, expected)
        assert np.all(np.abs(est.x - trace.x[k]) <= r), (case, k)
        assert (est.flag == OBSERVABLE) == bool(np.all(r <= obs.settings.uniqueness_delta * half))
        from_optimum += est.info["estimate_from"] == "window optimum"
        assert "uniqueness" not in est.info  # the radius decides, not the separated program
    assert from_optimum > 0


def test_the_rotation_system_flags_only_states_within_the_tolerance_of_their_mirror():
    """``y = x2``: the mirror image ``(-x1, x2)`` is always consistent, so a flag needs ``|x1|`` (the
    distance from the truth or from its mirror to ``x^1``) within the tolerance from both."""
    system, U, trace = CASES["rotation"](3, 40)
    half = system.scales()[0][:system.n]
    obs = MHEObserver(system, 3, noise_bound=0.0)
    for k in range(40):
        est = obs.step(U[k], trace.y[k])
        if k < 2:
            continue
        r = est.info["radius"]
        assert r[0] >= abs(est.x[0] - trace.x[k, 0]) and r[0] >= abs(est.x[0] + trace.x[k, 0]) - 1e-9
        if est.flag == OBSERVABLE:
            assert abs(trace.x[k, 0]) <= obs.settings.uniqueness_delta * half[0] + 1e-7


def test_data_beyond_the_bound_are_a_fallback_and_combinations_are_refused():
    system, U, trace = CASES["deadzone_spring"](3, 8)
    obs = MHEObserver(system, 3, noise_bound=1e-4)
    Y = trace.y.copy()
    Y[4] += 0.5  # one sample far beyond the bound: no trajectory fits the windows that hold it
    flags = [obs.step(U[k], Y[k]) for k in range(8)]
    for k in (4, 5, 6):
        assert flags[k].flag == FALLBACK and "contradict" in flags[k].info["reason"], k
    with pytest.raises(ModelError, match="noise_bound"):
        MHEObserver(system, 3, noise_bound=0.1, noise_std=0.1)
    with pytest.raises(ModelError, match="fit_tolerance"):
        MHEObserver(system, 3, noise_bound=0.1, fit_tolerance=0.1)
    with pytest.raises(ModelError, match="noise_bound"):
        MHEObserver(system, 3, noise_bound=-0.1)
    with pytest.raises(ModelError, match="noise_bound"):
        MHEObserver(system, 3, noise_bound={"nosuch": 0.1})

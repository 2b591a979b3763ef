"""The set-membership filter (:class:`hybobs_opt.observers.set_filter.SetMembershipFilter`).

Oracle: started from the whole state set, the filter's set after ``k + 1`` samples is the set of
states consistent with those samples, which the enumeration of ``tests/unit/mhe/test_set_membership.py``
computes independently (every mode sequence of the record, one LP per sequence, state and side,
from the system matrices alone).  The filter's box must hold the oracle's and, while no pieces were
merged, equal it up to 1e-5 of the state box and 1 % of the box's width (the rows' relaxation).  Systems: model (16) of paper 002, a dead-zone spring,
the rotation system with ``y = x2`` (two mirror pieces), noise-free and with uniform noise at
0.1 % and 1 % of the output range.
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.contract import FALLBACK, OBSERVABLE
from hybobs_opt.errors import ModelError
from hybobs_opt.observers import SetMembershipFilter

from tests.unit.mhe.test_set_membership import CASES, oracle_box, output_span, rotation_case


@pytest.mark.parametrize("case", sorted(CASES))
def test_the_box_equals_the_enumeration_of_the_whole_record(case):
    steps = 4
    system, U, trace = CASES[case](3, steps)
    half = system.scales()[0][:system.n]
    rng = np.random.default_rng(7)
    for level in (0.0, 0.001, 0.01):
        beta = level * output_span(system)
        Y = trace.y + rng.uniform(-1, 1, size=trace.y.shape) * beta
        filt = SetMembershipFilter(system, beta)
        for k in range(steps):
            est = filt.step(U[k], Y[k])
            ref = oracle_box(system, U[: k + 1], Y[: k + 1], np.maximum(beta, filt.effective_noise_bound))
            lo, hi = est.info["lower"], est.info["upper"]
            assert np.all(lo <= ref[0] + 1e-9 * half) and np.all(hi >= ref[1] - 1e-9 * half), (case, level, k)
            # equal up to the rows' relaxation (SET_FILTER_ROW_RTOL), which the inverse of a short,
            # badly conditioned record amplifies (model (16): omega_l from three samples of omega_m)
            slack = 1e-5 * half + 1e-2 * (ref[1] - ref[0])
            assert np.all(np.abs(lo - ref[0]) <= slack) and np.all(np.abs(hi - ref[1]) <= slack), \
                (case, level, k, lo - ref[0], hi - ref[1])
            assert np.all(np.abs(est.x - trace.x[k]) <= est.info["radius"])
            assert (est.flag == OBSERVABLE) == bool(np.all(est.info["radius"] <= filt.tolerance))


def test_the_mirror_pieces_are_both_kept():
    """Rotation with ``y = x2``: the state and its mirror image stay consistent with every sample:
    after many samples the box still spans ``[-|x1|, |x1|]`` and the true state is inside."""
    system, U, trace = rotation_case(3, 60)
    filt = SetMembershipFilter(system, 0.0)
    for k in range(60):
        est = filt.step(U[k], trace.y[k])
        assert est.info["lower"][0] <= -abs(trace.x[k, 0]) + 1e-6 and est.info["upper"][0] >= abs(trace.x[k, 0]) - 1e-6
        assert est.info["n_pieces"] <= filt.max_pieces


def test_data_that_break_the_bound_restart_the_filter_and_say_why():
    system, U, trace = CASES["deadzone_spring"](3, 200)
    beta = 0.001 * output_span(system)
    Y = trace.y + np.random.default_rng(3).uniform(-20, 20, size=trace.y.shape) * beta
    filt = SetMembershipFilter(system, beta)
    reasons = [filt.step(U[k], Y[k]).info.get("reason", "") for k in range(200)]
    assert any("contradict the model or the bound" in r for r in reasons)


def test_a_bad_sample_keeps_the_true_state():
    system, U, trace = CASES["model16"](3, 30)
    filt = SetMembershipFilter(system, 0.0)
    for k in range(30):
        y = np.array([np.nan]) if k in (10, 11) else trace.y[k]
        est = filt.step(U[k], y)
        if k in (10, 11):
            assert est.flag == FALLBACK
            continue
        assert np.all(np.abs(est.x - trace.x[k]) <= est.info["radius"]), k


def test_arguments_are_checked():
    system, _, _ = rotation_case(3, 5)
    with pytest.raises(ModelError, match="noise_bound"):
        SetMembershipFilter(system, -1.0)
    with pytest.raises(ModelError, match="max_pieces"):
        SetMembershipFilter(system, 0.1, max_pieces=0)
    with pytest.raises(ModelError, match="system"):
        SetMembershipFilter("rotation", 0.1)
    with pytest.raises(ModelError, match="tolerance"):
        SetMembershipFilter(system, 0.1, tolerance=-1.0)

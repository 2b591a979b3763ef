"""The set-membership observer's certified radii (:mod:`hybobs_opt.mhe.set_membership`).

The oracle is built here from the system matrices alone (no MLD encoding, no HiGHS MILP): every
mode sequence of the window is one polyhedron in the window-start state (guards and X at every
step, each output within the noise bound), and the least / largest value of each state at the
window's last sample over it is one LP (``scipy.optimize.linprog``); the box of the consistent
states is the extreme over the sequences.  Checked on model (16) of paper 002, a dead-zone spring
that is not from the papers and the rotation system with ``y = x2``, at T = 3 and 4, with uniform
noise at 0.1 % and 1 % of the output range (and noise-free).
"""

from __future__ import annotations

import collections
import itertools
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog

from canonical import deadzone_drive, deadzone_spring

from hybobs_opt.contract import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP
from hybobs_opt.errors import ModelError
from hybobs_opt.mhe.set_membership import SetMembershipObserver
from hybobs_opt.sim import simulate_pwa
from hybobs_opt.studies.paper002_powertrain.systems import backlash_torque_profile, powertrain3
from hybobs_opt.systems import load_model

ROTATION = Path(__file__).resolve().parents[3] / "examples/models/bemporad_morari_rotation.toml"


def oracle_box(system, U, Y, beta):
    """``(lower, upper)`` of the states at the last sample consistent with the window, or ``None``
    when no mode sequence is consistent: enumeration, one LP per sequence, state and side."""
    T, n = U.shape[0], system.n
    XA, Xb = system.state_bounds.A, system.state_bounds.b
    lower, upper = np.full(n, np.inf), np.full(n, -np.inf)
    for seq in itertools.product(range(system.n_modes), repeat=T):
        Phi, phi = np.eye(n), np.zeros(n)
        A_rows, b_rows = [], []
        for k, q in enumerate(seq):
            md = system.modes[q]
            G, g = md.guard.A, md.guard.b
            A_rows += [G[:, :n] @ Phi, XA @ Phi, md.C @ Phi, -md.C @ Phi]
            yk = md.C @ phi + md.D @ U[k] + md.c
            b_rows += [g - G[:, n:] @ U[k] - G[:, :n] @ phi, Xb - XA @ phi, Y[k] - yk + beta, -(Y[k] - yk) + beta]
            if k < T - 1:
                Phi, phi = md.A @ Phi, md.A @ phi + md.B @ U[k] + md.a
        widen_by_lps(lower, upper, Phi, phi, np.vstack(A_rows), np.concatenate(b_rows))
    if not np.all(np.isfinite(lower)):
        return None
    return lower, upper


def widen_by_lps(lower, upper, Phi, phi, A_ub, b_ub) -> None:
    """Widen ``[lower, upper]`` (in place) to the least and largest ``Phi v + phi`` over ``A_ub v <= b_ub``
    (one ``scipy.optimize.linprog`` per state and side; nothing when the polyhedron is empty)."""
    nv = A_ub.shape[1]
    for j in range(Phi.shape[0]):
        for sign in (1.0, -1.0):
            res = linprog(sign * Phi[j], A_ub=A_ub, b_ub=b_ub, bounds=[(None, None)] * nv, method="highs")
            if res.status == 2:
                return  # this sequence admits no state
            assert res.status == 0, res.message
            value = sign * res.fun + phi[j]
            if sign > 0:
                lower[j] = min(lower[j], value)
            else:
                upper[j] = max(upper[j], value)


def rotation_case(T, steps):
    system = load_model(ROTATION)
    U = np.random.default_rng(5).uniform(-1, 1, size=(steps, 1))
    return system, U, simulate_pwa(system, np.array([3.0, -2.0]), U)


def spring_case(T, steps):
    system = deadzone_spring()
    U = deadzone_drive(steps)
    return system, U, simulate_pwa(system, np.array([0.3, 0.0]), U)


def powertrain_case(T, steps):
    system = powertrain3()
    start = 990  # the first change of contact (sample 1,014)
    U = backlash_torque_profile(np.arange(start + steps) * system.Ts)[:, None]
    trace = simulate_pwa(system, np.array([0.06, 39.0, 3.25]), U)
    return system, U[start:], type("Tr", (), {"x": trace.x[start:], "y": trace.y[start:]})


CASES = {"rotation": rotation_case, "deadzone_spring": spring_case, "model16": powertrain_case}


def output_span(system):
    from hybobs_opt.systems.ranges import output_range

    lo, hi = output_range(system)
    return hi - lo


@pytest.mark.slow
@pytest.mark.parametrize("T", [3, 4])
@pytest.mark.parametrize("case", sorted(CASES))
def test_radii_equal_the_enumeration_and_hold_the_true_state(case, T):
    """Both ways to the box (sequence by sequence, and the per-state MILPs) against the oracle."""
    steps = 5 + T
    system, U, trace = CASES[case](T, steps)
    half = system.scales()[0][:system.n]
    rng = np.random.default_rng(T)
    paths = collections.Counter()
    for level, max_sequences in itertools.product((0.0, 0.001, 0.01), (None, 0)):
        beta = level * output_span(system)
        Y = trace.y + rng.uniform(-1, 1, size=trace.y.shape) * beta
        obs = SetMembershipObserver(system, T, beta, max_sequences=max_sequences)
        for k in range(steps):
            est = obs.step(U[k], Y[k])
            if k < T - 1:
                assert est.flag == WARMING_UP
                continue
            ref = oracle_box(system, U[k - T + 1:k + 1], Y[k - T + 1:k + 1], beta)
            assert ref is not None  # the true trajectory is consistent
            assert est.flag in (OBSERVABLE, UNOBSERVABLE), est.info.get("reason")
            lo, hi = est.info["lower"], est.info["upper"]
            assert np.all(np.abs(lo - ref[0]) <= 1e-6 * half), (case, T, level, k, lo, ref[0])
            assert np.all(np.abs(hi - ref[1]) <= 1e-6 * half), (case, T, level, k, hi, ref[1])
            assert np.all(np.abs(est.x - trace.x[k]) <= est.info["radius"])  # no slack: the pad is in the radius
            assert (est.flag == OBSERVABLE) == bool(np.all(est.info["radius"] <= obs.tolerance))
            paths[(max_sequences, est.info["box_by"])] += 1
    assert paths[(0, "mode sequences")] == 0 and paths[(0, "per-state MILPs")] > 0
    assert paths[(None, "mode sequences")] > 0, paths  # the default path answers some windows


def test_noise_free_radius_is_zero_exactly_where_the_state_is_unique():
    """Rotation with ``y = x2``: the consistent set is the state and its mirror image, so the box
    is ``[-|x1|, |x1|]`` around ``x1 = 0`` with radius ``|x1|`` (the oracle: the symmetry); the
    deadzone spring outside the dead zone pins the state (radius 0)."""
    system, U, trace = rotation_case(3, 40)
    obs = SetMembershipObserver(system, 3, 0.0)
    for k in range(40):
        est = obs.step(U[k], trace.y[k])
        if k < 2:
            continue
        pad = obs.box_pad
        assert abs(est.info["radius"][0] - abs(trace.x[k, 0]) - pad[0]) <= 1e-9
        assert abs(est.info["radius"][1] - pad[1]) <= 1e-9 and abs(est.x[0]) <= 1e-9
        assert (est.flag == OBSERVABLE) == (abs(trace.x[k, 0]) + pad[0] <= obs.tolerance[0])
    system, U, trace = spring_case(3, 60)
    obs = SetMembershipObserver(system, 3, 0.0)
    run = obs.run(U, trace.y)
    pinned = [k for k in range(2, 60) if np.all(np.abs(trace.x[k - 2:k + 1, 0]) > 0.1 + 1e-3)]
    assert pinned
    for k in pinned:
        assert np.all(run.info[k]["radius"] <= obs.box_pad + 1e-9), (k, run.info[k]["radius"])


def test_data_that_contradict_the_bound_are_a_fallback_and_bad_input_is_refused():
    system, U, trace = spring_case(3, 10)
    obs = SetMembershipObserver(system, 3, 1e-3)
    Y = trace.y.copy()
    Y[5] += 0.5  # far beyond the bound: no model trajectory fits
    flags = [obs.step(U[k], Y[k]) for k in range(8)]
    assert flags[5].flag == FALLBACK and "noise bound" in flags[5].info["reason"]
    assert obs.step([np.nan], [0.0]).flag == FALLBACK
    for bad in (-1.0, np.nan, "x", [1.0, 2.0], True, {"nosuch": 1.0}, 1j, [[1.0], [2.0, 3.0]]):
        with pytest.raises(ModelError, match="noise_bound"):
            SetMembershipObserver(system, 3, bad)
    for bad in (0.0, -1.0, [1.0], {"nosuch": 1.0}):
        with pytest.raises(ModelError, match="tolerance"):
            SetMembershipObserver(system, 3, 0.0, tolerance=bad)
    with pytest.raises(ModelError, match="T"):
        SetMembershipObserver(system, 0, 0.0)
    for bad in (-1, 1.5, True, "3"):
        with pytest.raises(ModelError, match="max_sequences"):
            SetMembershipObserver(system, 3, 0.0, max_sequences=bad)
    obs = SetMembershipObserver(system, 3, {"y": 0.01}, tolerance={"x1": 0.05})
    assert obs.noise_bound.tolist() == [0.01] and obs.tolerance[0] == 0.05

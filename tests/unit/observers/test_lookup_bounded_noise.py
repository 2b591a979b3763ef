"""The lookup observer under bounded output noise (``NoiseAwareLookupObserver(noise_bound=...)``).

Its box is an outer bound of the states consistent with the window: every mode sequence that
passes the necessary tests, each widened by the noise amplified through its inverse map.  The
oracle is the enumeration of ``tests/unit/mhe/test_set_membership.py`` (one LP per mode sequence,
state and side, from the system matrices alone): the table's box must contain the exact one, the
true state must lie within the radius, and noise-free the two boxes agree wherever the table flags
the state observable.  Checked on model (16) of paper 002, a dead-zone spring that is not from the
papers and the rotation system with ``y = x2``, at T = 3 and 4, noise at 0.1 % and 1 % of the
output range (and none).
"""

from __future__ import annotations

import numpy as np
import pytest

from hybobs_opt.contract import FALLBACK, OBSERVABLE, UNOBSERVABLE, WARMING_UP
from hybobs_opt.errors import ModelError
from hybobs_opt.observers import NoiseAwareLookupObserver
from hybobs_opt.regions import analyse_observability

from tests.unit.mhe.test_set_membership import CASES, oracle_box, output_span, rotation_case, spring_case, widen_by_lps


@pytest.mark.slow
@pytest.mark.parametrize("T", [3, 4])
@pytest.mark.parametrize("case", sorted(CASES))
def test_the_box_holds_the_exact_one_and_the_true_state(case, T):
    steps = 6 + T
    system, U, trace = CASES[case](T, steps)
    half = system.scales()[0][:system.n]
    analysis = analyse_observability(system, T)
    rng = np.random.default_rng(100 + T)
    for level in (0.0, 0.001, 0.01):
        beta = level * output_span(system)
        Y = trace.y + rng.uniform(-1, 1, size=trace.y.shape) * beta
        obs = NoiseAwareLookupObserver(analysis, noise_bound=beta)
        for k in range(steps):
            est = obs.step(U[k], Y[k])
            if k < T - 1:
                assert est.flag == WARMING_UP
                continue
            ref = oracle_box(system, U[k - T + 1:k + 1], Y[k - T + 1:k + 1], beta)
            assert est.flag in (OBSERVABLE, UNOBSERVABLE), est.info
            lo, hi = est.info["lower"], est.info["upper"]
            assert np.all(lo <= ref[0] + 1e-9 * half) and np.all(hi >= ref[1] - 1e-9 * half), (case, T, level, k)
            assert np.all(np.abs(est.x - trace.x[k]) <= est.info["radius"]), (case, T, level, k)
            assert (est.flag == OBSERVABLE) == bool(np.all(est.info["radius"] <= obs.tolerance))
            if level == 0.0 and est.flag == OBSERVABLE:  # noise-free: the candidates are the exact points
                assert np.all(np.abs(lo - ref[0]) <= 1e-6 * half) and np.all(np.abs(hi - ref[1]) <= 1e-6 * half)


def test_the_mirror_image_is_never_flagged_away():
    """Rotation with ``y = x2``: the state and its mirror image fit every window equally, so the box
    spans ``[-|x1|, |x1|]`` at least, and a step is flagged exactly when ``|x1|`` is within the
    tolerance (the centre, ``x1 = 0``, is then that close to both)."""
    system, U, trace = rotation_case(3, 200)
    obs = NoiseAwareLookupObserver(analyse_observability(system, 3), noise_bound=0.0)
    tol = obs.tolerance[0]
    for k in range(200):
        est = obs.step(U[k], trace.y[k])
        if k < 2:
            continue
        assert est.info["radius"][0] >= abs(trace.x[k, 0]) - 1e-9 and abs(est.x[0]) <= 1e-9
        if abs(trace.x[k, 0]) > tol:
            assert est.flag == UNOBSERVABLE, k
        elif abs(trace.x[k, 0]) < tol - 1e-6:
            assert est.flag == OBSERVABLE, k


def test_a_bound_the_data_break_is_reported_not_trusted():
    """Noise 20x the stated bound: windows that no mode sequence fits are ``fallback`` with the
    reason, never ``observable``."""
    system, U, trace = spring_case(3, 300)
    beta = 0.001 * output_span(system)
    Y = trace.y + np.random.default_rng(3).uniform(-20, 20, size=trace.y.shape) * beta
    obs = NoiseAwareLookupObserver(analyse_observability(system, 3), noise_bound=beta)
    reasons = [est.info.get("reason", "") for est in (obs.step(U[k], Y[k]) for k in range(300)) if est.flag == FALLBACK]
    assert reasons and all("contradict the model or the bound" in r for r in reasons)


def test_the_noise_model_is_stated_once_and_checked():
    system, _, _ = spring_case(3, 10)
    an = analyse_observability(system, 2)
    with pytest.raises(ModelError, match="exactly one"):
        NoiseAwareLookupObserver(an)
    with pytest.raises(ModelError, match="exactly one"):
        NoiseAwareLookupObserver(an, 0.1, noise_bound=0.1)
    with pytest.raises(ModelError, match="noise_bound"):
        NoiseAwareLookupObserver(an, noise_bound=-0.1)
    with pytest.raises(ModelError, match="tolerance"):
        NoiseAwareLookupObserver(an, 0.1, tolerance=0.5)
    with pytest.raises(ModelError, match="tolerance"):
        NoiseAwareLookupObserver(an, noise_bound=0.1, tolerance={"nope": 1.0})
    with pytest.raises(ModelError, match="T p >= n"):
        NoiseAwareLookupObserver(analyse_observability(system, 1), noise_bound=0.1)
    obs = NoiseAwareLookupObserver(an, noise_bound={"y": 0.1}, tolerance=0.25)  # T p = n: no residual test
    assert obs.name == "lookup-bounded" and np.all(obs.tolerance == 0.25) and obs.stats()["noise"] == "bounded"


def _oracle_box_noisy_inputs(system, U, Y, beta, gamma):
    """The box of the states at the last sample consistent with a window whose inputs are known
    within ``gamma`` too: every mode sequence, the window-start state and the inputs as LP
    variables (``scipy.optimize.linprog``), from the system matrices alone."""
    import itertools

    T, n, m = U.shape[0], system.n, system.m
    nv = n + T * m
    XA, Xb = system.state_bounds.A, system.state_bounds.b
    IA, Ib = system.input_bounds.A, system.input_bounds.b
    lower, upper = np.full(n, np.inf), np.full(n, -np.inf)
    for seq in itertools.product(range(system.n_modes), repeat=T):
        Phi = np.hstack([np.eye(n), np.zeros((n, T * m))])  # x_k = Phi v + phi, v = [x0; u_0..u_T-1]
        phi = np.zeros(n)
        rows, rhs = [], []
        for k, q in enumerate(seq):
            md = system.modes[q]
            Uk = np.zeros((m, nv))
            Uk[:, n + k * m: n + (k + 1) * m] = np.eye(m)
            G = md.guard.A
            rows += [G[:, :n] @ Phi + G[:, n:] @ Uk, XA @ Phi, IA @ Uk, Uk, -Uk, md.C @ Phi + md.D @ Uk,
                     -(md.C @ Phi + md.D @ Uk)]
            yk = md.C @ phi + md.c
            rhs += [md.guard.b - G[:, :n] @ phi, Xb - XA @ phi, Ib, U[k] + gamma, gamma - U[k], Y[k] - yk + beta,
                    beta - (Y[k] - yk)]
            if k < T - 1:
                Phi, phi = md.A @ Phi + md.B @ Uk, md.A @ phi + md.a
        widen_by_lps(lower, upper, Phi, phi, np.vstack(rows), np.concatenate(rhs))
    return lower, upper


def test_measured_inputs_within_their_bound_keep_the_true_state_inside():
    """Input noise (``input_noise_bound``): the dead-zone spring's drive speed measured within 2 %
    of its range, the load speed within 0.1 %: the box holds the enumeration's (inputs as LP
    variables) and the true state, at every step."""
    system, U, trace = spring_case(3, 40)
    half = system.scales()[0][:system.n]
    beta, gamma = 0.001 * output_span(system), np.array([0.04])
    rng = np.random.default_rng(9)
    Y = trace.y + rng.uniform(-1, 1, size=trace.y.shape) * beta
    Um = np.clip(U + rng.uniform(-1, 1, size=U.shape) * gamma, -1.0, 1.0)
    obs = NoiseAwareLookupObserver(analyse_observability(system, 3), noise_bound=beta, input_noise_bound=gamma)
    exact = NoiseAwareLookupObserver(analyse_observability(system, 3), noise_bound=beta)
    wider = 0
    for k in range(40):
        est, naive = obs.step(Um[k], Y[k]), exact.step(Um[k], Y[k])
        if k < 2:
            continue
        assert est.flag in (OBSERVABLE, UNOBSERVABLE), est.info
        assert np.all(np.abs(est.x - trace.x[k]) <= est.info["radius"]), k
        if k % 6 == 0:
            ref = _oracle_box_noisy_inputs(system, Um[k - 2:k + 1], Y[k - 2:k + 1], beta, gamma)
            assert np.all(est.info["lower"] <= ref[0] + 1e-9 * half) and np.all(est.info["upper"] >= ref[1] - 1e-9 * half)
        wider += bool(np.any(est.info["radius"] > naive.info.get("radius", np.zeros(2)) + 1e-12))
    assert wider > 0  # the input noise widens the radii
    with pytest.raises(ModelError, match="input_noise_bound"):
        NoiseAwareLookupObserver(analyse_observability(system, 3), 0.1, input_noise_bound=0.1)

"""The Kalman filter on the true mode sequence (issue 18: the unattainable reference of the noise bench).

Oracle: the Gaussian conditional mean of the whole trajectory, computed here from the stacked
linear model of ``x(0..N-1)`` -- the prior row, one process row per transition and one output row
per sample, each weighted by its inverse covariance -- by solving the normal equations with
numpy.  Its last block is ``x(N-1 | N-1)`` and the same block of the inverse information matrix
is ``P(N-1 | N-1)`` (Rauch, Tung & Striebel 1965; Anderson & Moore 1979, Ch. 7).  It shares no
code with :mod:`hybobs_opt.observers.kalman` (no recursion, no gain, no Joseph form): only the
mode matrices are read from the system.
"""

import numpy as np
import pytest
from scipy import stats

from hybobs_opt.contract import FALLBACK, OBSERVABLE, UNOBSERVABLE
from hybobs_opt.errors import ModelError
from hybobs_opt.observers import ModeSequenceKalmanFilter
from hybobs_opt.systems import Polytope, PWAMode, PWASystem

RTOL = 1e-9


# ---------------------------------------------------------------------------------- oracle
def _matrices(system, q):
    md = system.modes[q]
    n, m, p = system.n, system.m, system.p
    D = np.zeros((p, m)) if md.D is None else np.asarray(md.D).reshape(p, m)
    c = np.zeros(p) if md.c is None else np.asarray(md.c)
    return np.asarray(md.A), np.asarray(md.B).reshape(n, m), np.asarray(md.a), np.asarray(md.C).reshape(p, n), D, c


def batch_posterior(system, modes, U, Y, m0, P0, Q, R, skip=()):
    """Mean and covariance of ``x(N-1)`` given ``y(k)``, ``k`` not in ``skip``, from the stacked model.

    Unknowns ``z = [x(0); ...; x(N-1)]``; rows: ``x(0) = m0 + e0`` (weight ``P0^-1``),
    ``x(k+1) - A x(k) = B u(k) + a + w(k)`` (``Q^-1``), ``C x(k) = y(k) - D u(k) - c + v(k)``
    (``R^-1``).  Normal equations ``(H' W H) z = H' W b`` with the unknowns scaled by the
    prior's standard deviations (exact algebra, it only improves the conditioning).
    """
    n = system.n
    N = len(Y)
    blocks_H, blocks_b, blocks_W = [], [], []
    H0 = np.zeros((n, N * n))
    H0[:, :n] = np.eye(n)
    blocks_H.append(H0), blocks_b.append(np.asarray(m0, float)), blocks_W.append(np.linalg.inv(P0))
    Qi, Ri = np.linalg.inv(Q), np.linalg.inv(R)
    for k in range(N):
        A, B, a, C, D, c = _matrices(system, int(modes[k]))
        if k not in skip:
            Hm = np.zeros((C.shape[0], N * n))
            Hm[:, k * n:(k + 1) * n] = C
            blocks_H.append(Hm), blocks_b.append(Y[k] - D @ U[k] - c), blocks_W.append(Ri)
        if k + 1 < N:
            Hp = np.zeros((n, N * n))
            Hp[:, (k + 1) * n:(k + 2) * n] = np.eye(n)
            Hp[:, k * n:(k + 1) * n] = -A
            blocks_H.append(Hp), blocks_b.append(B @ U[k] + a), blocks_W.append(Qi)
    H, b = np.vstack(blocks_H), np.concatenate(blocks_b)
    W = np.zeros((H.shape[0], H.shape[0]))
    r = 0
    for Wi in blocks_W:
        W[r:r + len(Wi), r:r + len(Wi)] = Wi
        r += len(Wi)
    s = np.tile(np.sqrt(np.diag(P0)), N)  # z = s * zeta
    Hs = H * s
    info = Hs.T @ W @ Hs
    zeta = np.linalg.solve(info, Hs.T @ W @ b)
    cov = np.linalg.inv(info) * np.outer(s, s)
    z = s * zeta
    return z[-n:], cov[-n:, -n:]


def batch_posterior_exact_model(system, modes, U, Y, m0, P0, R):
    """The same without process noise: ``x(k) = Phi_k x(0) + g_k`` exactly, one unknown ``x(0)``."""
    n = system.n
    Phi, g = np.eye(n), np.zeros(n)
    rows, rhs = [], []
    for k in range(len(Y)):
        A, B, a, C, D, c = _matrices(system, int(modes[k]))
        rows.append(C @ Phi)
        rhs.append(Y[k] - D @ U[k] - c - C @ g)
        if k + 1 < len(Y):
            Phi, g = A @ Phi, A @ g + B @ U[k] + a
    Ri, P0i = np.linalg.inv(R), np.linalg.inv(P0)
    info = P0i + sum(Hk.T @ Ri @ Hk for Hk in rows)
    x0 = np.linalg.solve(info, P0i @ m0 + sum(Hk.T @ Ri @ bk for Hk, bk in zip(rows, rhs)))
    cov0 = np.linalg.inv(info)
    return Phi @ x0 + g, Phi @ cov0 @ Phi.T


def _rel(a, b):
    return float(np.max(np.abs(np.asarray(a) - np.asarray(b))) / np.max(np.abs(b)))


def simulate(system, modes, U, x0, Q, R, rng):
    n, N = system.n, len(modes)
    X = np.zeros((N, n))
    Y = np.zeros((N, system.p))
    x = np.array(x0, float)
    Lq = np.linalg.cholesky(Q) if np.any(Q) else np.zeros((n, n))
    Lr = np.linalg.cholesky(R)
    for k in range(N):
        A, B, a, C, D, c = _matrices(system, int(modes[k]))
        X[k] = x
        Y[k] = C @ x + D @ U[k] + c + Lr @ rng.normal(size=system.p)
        x = A @ x + B @ U[k] + a + Lq @ rng.normal(size=n)
    return X, Y


# ---------------------------------------------------------------------------------- systems
def linear_system():
    """One mode, three states, two outputs (one feedthrough), an affine term: x in [-5, 5]^3, u in [-1, 1]."""
    A = np.array([[0.9, 0.2, 0.0], [-0.1, 0.95, 0.1], [0.0, 0.05, 0.8]])
    B = np.array([[0.0], [0.5], [0.2]])
    C = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    guard = Polytope.from_box([-5, -5, -5, -1], [5, 5, 5, 1])
    mode = PWAMode(A, B, np.array([0.01, 0.0, -0.02]), C, guard, D=np.array([[0.0], [0.3]]), c=np.array([0.1, 0.0]))
    return PWASystem((mode,), Polytope.from_box([-5, -5, -5], [5, 5, 5]), Polytope.from_box([-1], [1]))


def two_mode_system():
    """Two modes split at ``x1 = 0``, two states in ``[-20, 20]^2``, mode-dependent output."""
    e = np.array([1.0, 0.0, 0.0])
    left = PWAMode(np.array([[0.8, 0.3], [-0.2, 0.9]]), np.array([[0.0], [1.0]]), np.array([0.1, 0.0]),
                   np.array([[1.0, 0.0]]), Polytope(e[None, :], np.array([0.0])), c=np.array([0.2]))
    right = PWAMode(np.array([[0.95, -0.1], [0.25, 0.7]]), np.array([[0.5], [0.0]]), np.array([0.0, -0.1]),
                    np.array([[0.5, 1.0]]), Polytope(-e[None, :], np.array([0.0])))
    return PWASystem((left, right), Polytope.from_box([-20, -20], [20, 20]), Polytope.from_box([-1], [1]))


@pytest.fixture(scope="module")
def powertrain():
    from hybobs_opt.studies import get_example
    from hybobs_opt.studies.paper002_powertrain.systems import SCENARIO_TORQUES, backlash_scenario

    plant = get_example("powertrain3").build()
    trace = backlash_scenario(plant, SCENARIO_TORQUES["powertrain3"], t_final=1200 * plant.Ts)
    return plant, trace


# ---------------------------------------------------------------------------------- against the oracle
@pytest.mark.parametrize("process", ["diag", "full"])
def test_linear_system_equals_batch_conditional_mean(process):
    sys_ = linear_system()
    rng = np.random.default_rng(1)
    N = 40
    U = rng.uniform(-1, 1, (N, 1))
    if process == "diag":
        process_std = np.array([0.02, 0.05, 0.01])
        Q = np.diag(process_std ** 2)
    else:
        G = rng.normal(size=(3, 3)) * 0.03
        Q = G @ G.T + 1e-4 * np.eye(3)
        process_std = Q
    noise = np.array([0.1, 0.05])
    R = np.diag(noise ** 2)
    modes = np.zeros(N, dtype=int)
    X, Y = simulate(sys_, modes, U, [1.0, -2.0, 0.5], Q, R, rng)
    kf = ModeSequenceKalmanFilter(sys_, noise, process_std=process_std, modes=modes)
    out = kf.run(U, Y)
    # the default prior: centre of the box, diag(half-width^2)
    m0, P0 = np.zeros(3), np.diag([25.0, 25.0, 25.0])
    assert (out.flags != FALLBACK).all()
    for k in (0, 1, 7, N - 1):
        mean, cov = batch_posterior(sys_, modes[:k + 1], U[:k + 1], Y[:k + 1], m0, P0, Q, R)
        assert _rel(out.x_hat[k], mean) < RTOL, k
        assert _rel(out.covariance[k], cov) < RTOL, k
    # the estimate is informative: far better than the prior, close to the truth
    assert np.all(np.abs(out.x_hat[-1] - X[-1]) < 5 * np.sqrt(np.diag(out.covariance[-1])))


def test_linear_system_exact_model_equals_initial_state_least_squares():
    sys_ = linear_system()
    rng = np.random.default_rng(2)
    N = 25
    U = rng.uniform(-1, 1, (N, 1))
    noise = 0.05
    R = np.diag([noise ** 2] * 2)
    modes = np.zeros(N, dtype=int)
    _, Y = simulate(sys_, modes, U, [0.5, 0.5, -1.0], np.zeros((3, 3)), R, rng)
    m0, P0 = np.array([0.2, 0.1, 0.0]), np.diag([4.0, 9.0, 1.0])
    out = ModeSequenceKalmanFilter(sys_, noise, x0=m0, P0=np.diag(P0)).run(U, Y, modes)
    mean, cov = batch_posterior_exact_model(sys_, modes, U, Y, m0, P0, R)
    assert _rel(out.x_hat[-1], mean) < RTOL
    assert _rel(out.covariance[-1], cov) < RTOL


def test_model16_true_modes_equals_batch_conditional_mean(powertrain):
    plant, trace = powertrain
    # 60 samples across the first mode switch of the scenario (positive contact -> backlash)
    switches = np.nonzero(np.diff(trace.q))[0]
    assert switches.size, "the scenario must switch modes"
    first = int(switches[0]) - 30
    sl = slice(first, first + 60)
    modes = trace.q[sl]
    assert len(set(modes.tolist())) >= 2
    U = trace.u[sl]
    sigma = 0.01
    Y = trace.y[sl] + np.random.default_rng(3).normal(0.0, sigma, trace.y[sl].shape)
    process_std = np.array([1e-5, 1e-2, 1e-3])
    kf = ModeSequenceKalmanFilter(plant, sigma, process_std=process_std)
    out = kf.run(U, Y, modes)
    half, centre = plant.scales()
    m0, P0 = centre[:3], np.diag(half[:3] ** 2)
    Q, R = np.diag(process_std ** 2), np.array([[sigma ** 2]])
    assert (out.flags != FALLBACK).all()
    for k in (29, 30, 31, 59):  # before, at and after the switch
        mean, cov = batch_posterior(plant, modes[:k + 1], U[:k + 1], Y[:k + 1], m0, P0, Q, R)
        assert _rel(out.x_hat[k], mean) < RTOL, k
        assert _rel(out.covariance[k], cov) < RTOL, k
        assert np.array_equal(out.info[k]["covariance"], out.covariance[k])
        assert np.array_equal(out.covariance[k], out.covariance[k].T)
        assert out.mode[k] == modes[k]


def test_step_with_mode_equals_run_with_modes(powertrain):
    plant, trace = powertrain
    U, Y, q = trace.u[:50], trace.y[:50] + 0.01, trace.q[:50]
    a = ModeSequenceKalmanFilter(plant, 0.01, modes=q).run(U, Y)
    kf = ModeSequenceKalmanFilter(plant, 0.01)
    steps = [kf.step(U[k], Y[k], mode=int(q[k])) for k in range(50)]
    assert np.array_equal(np.array([e.x for e in steps]), a.x_hat)
    assert np.array_equal(np.array([e.info["covariance"] for e in steps]), a.covariance)


def test_flags_follow_the_stated_threshold(powertrain):
    plant, trace = powertrain
    kf = ModeSequenceKalmanFilter(plant, 0.01, modes=trace.q)
    out = kf.run(trace.u[:400], trace.y[:400])
    half = plant.scales()[0][:3]
    scaled = np.max(out.std() / half, axis=1)
    assert out.flags[0] == UNOBSERVABLE  # the prior, one half-width, is not an estimate
    assert np.array_equal(out.flags == OBSERVABLE, scaled < kf.observable_std)
    assert (out.flags == OBSERVABLE).any()


# ---------------------------------------------------------------------------------- consistency
def test_monte_carlo_nees_is_chi_square():
    """E[e' P^-1 e] = n for a consistent filter: the mean over R runs of the NEES at a step, times
    R, is chi-square with R n degrees of freedom; the 99 % interval is checked at two steps."""
    sys_ = two_mode_system()
    n, runs, N = sys_.n, 300, 30
    rng = np.random.default_rng(7)
    modes = np.array([0] * 8 + [1] * 10 + [0] * 5 + [1] * 7)
    process_std = np.array([0.05, 0.1])
    Q, noise = np.diag(process_std ** 2), 0.2
    R = np.array([[noise ** 2]])
    m0, P0 = np.array([1.0, -1.0]), np.diag([0.5, 2.0])
    kf = ModeSequenceKalmanFilter(sys_, noise, process_std=process_std, x0=m0, P0=np.diag(P0), modes=modes,
                                  judge_ranges=False)
    nees = np.zeros((runs, N))
    for r in range(runs):
        U = rng.uniform(-1, 1, (N, 1))
        x0 = m0 + np.linalg.cholesky(P0) @ rng.normal(size=n)
        X, Y = simulate(sys_, modes, U, x0, Q, R, rng)
        kf.reset()
        out = kf.run(U, Y)
        assert (out.flags != FALLBACK).all()
        nees[r] = out.nees(X)
    lo, hi = stats.chi2.ppf([0.005, 0.995], runs * n) / runs
    for k in (10, N - 1):
        assert lo < nees[:, k].mean() < hi, (k, nees[:, k].mean(), lo, hi)
    # a filter told the wrong noise level is not consistent: the test can fail
    kf_wrong = ModeSequenceKalmanFilter(sys_, noise / 3, process_std=process_std, x0=m0, P0=np.diag(P0), modes=modes,
                                        judge_ranges=False)
    rng = np.random.default_rng(8)
    wrong = []
    for r in range(runs):
        U = rng.uniform(-1, 1, (N, 1))
        X, Y = simulate(sys_, modes, U, m0 + np.linalg.cholesky(P0) @ rng.normal(size=n), Q, R, rng)
        kf_wrong.reset()
        wrong.append(kf_wrong.run(U, Y).nees(X)[-1])
    assert np.mean(wrong) > hi


# ---------------------------------------------------------------------------------- bad samples
def test_nan_output_is_a_time_update_and_the_run_continues():
    sys_ = linear_system()
    rng = np.random.default_rng(4)
    N = 20
    U = rng.uniform(-1, 1, (N, 1))
    process_std, noise = np.array([0.02, 0.05, 0.01]), np.array([0.1, 0.05])
    Q, R = np.diag(process_std ** 2), np.diag(noise ** 2)
    modes = np.zeros(N, dtype=int)
    _, Y = simulate(sys_, modes, U, [1.0, -2.0, 0.5], Q, R, rng)
    Y[5, 1] = np.nan
    out = ModeSequenceKalmanFilter(sys_, noise, process_std=process_std, modes=modes).run(U, Y)
    assert out.flags[5] == FALLBACK
    assert "NaN" in out.info[5]["reason"]
    assert (np.delete(out.flags, 5) != FALLBACK).all()
    # the fallback estimate is the prediction from x(4|4), its covariance A P A' + Q
    A, B, a = _matrices(sys_, 0)[:3]
    assert np.allclose(out.x_hat[5], A @ out.x_hat[4] + B @ U[4] + a, rtol=1e-12, atol=1e-12)
    assert np.allclose(out.covariance[5], A @ out.covariance[4] @ A.T + Q, rtol=1e-12, atol=1e-15)
    # and what follows is the conditional mean given every sample but the refused one
    mean, cov = batch_posterior(sys_, modes, U, Y, np.zeros(3), 25.0 * np.eye(3), Q, R, skip={5})
    assert _rel(out.x_hat[-1], mean) < RTOL
    assert _rel(out.covariance[-1], cov) < RTOL


def test_wrong_length_and_unusable_samples_are_fallback_never_raise():
    sys_ = linear_system()
    kf = ModeSequenceKalmanFilter(sys_, 0.1, process_std=0.01, modes=np.zeros(10, dtype=int))
    good = kf.step([0.1], [0.2, 0.3])
    assert good.flag != FALLBACK
    for u, y in (([0.1], [0.2]), ([0.1], [0.2, 0.3, 0.4]), ([0.1, 0.2], [0.2, 0.3]), ([0.1], "ab"),
                 ([0.1], [1e12, 0.0]), ([np.nan], [0.2, 0.3])):
        e = kf.step(u, y)
        assert e.flag == FALLBACK, (u, y)
        assert isinstance(e.info["reason"], str) and e.info["reason"]
        assert np.all(np.isfinite(e.x)) and e.info["covariance"].shape == (3, 3)
    # a bad mode, and samples beyond the mode sequence
    assert kf.step([0.1], [0.2, 0.3], mode=5).flag == FALLBACK
    assert kf.step([0.1], [0.2, 0.3], mode=1.0).flag == FALLBACK
    kf.step([0.1], [0.2, 0.3])
    e = kf.step([0.1], [0.2, 0.3])
    assert e.flag == FALLBACK and "beyond the mode sequence" in e.info["reason"]
    assert kf.step([0.1], [0.2, 0.3], mode=0).flag != FALLBACK  # an explicit mode still works
    # no mode at all
    e = ModeSequenceKalmanFilter(sys_, 0.1).step([0.1], [0.2, 0.3])
    assert e.flag == FALLBACK and "no mode" in e.info["reason"]


# ---------------------------------------------------------------------------------- construction
@pytest.mark.parametrize("kwargs, field", [
    (dict(noise_std=0.0), "noise_std"),
    (dict(noise_std=-0.1), "noise_std"),
    (dict(noise_std=np.nan), "noise_std"),
    (dict(noise_std=[0.1, 0.1, 0.1]), "noise_std"),
    (dict(noise_std="0.1"), "noise_std"),
    (dict(noise_std=True), "noise_std"),
    (dict(process_std=-1.0), "process_std"),
    (dict(process_std=[0.1, 0.1]), "process_std"),
    (dict(process_std=np.array([[1.0, 0.5, 0], [0.0, 1, 0], [0, 0, 1]])), "process_std"),
    (dict(process_std=-np.eye(3)), "process_std"),
    (dict(x0=[0.0, 0.0]), "x0"),
    (dict(x0=[0.0, np.nan, 0.0]), "x0"),
    (dict(P0=np.zeros((3, 3))), "P0"),
    (dict(P0=[1.0, -1.0, 1.0]), "P0"),
    (dict(P0=np.eye(2)), "P0"),
    (dict(modes=[0, 1]), "modes"),
    (dict(modes=[0.0, 0.0]), "modes"),
    (dict(modes="00"), "modes"),
    (dict(observable_std=0.0), "observable_std"),
])
def test_bad_construction_names_the_field(kwargs, field):
    kw = dict(noise_std=0.1)
    kw.update(kwargs)
    noise = kw.pop("noise_std")
    with pytest.raises(ModelError) as err:
        ModeSequenceKalmanFilter(linear_system(), noise, **kw)
    assert err.value.field == field


def test_bad_system_and_run_lengths():
    with pytest.raises(ModelError) as err:
        ModeSequenceKalmanFilter("plant", 0.1)
    assert err.value.field == "system"
    kf = ModeSequenceKalmanFilter(linear_system(), 0.1)
    with pytest.raises(ModelError) as err:
        kf.run(np.zeros((3, 1)), np.zeros((3, 2)), modes=[0, 0])
    assert err.value.field == "modes"
    with pytest.raises(ModelError) as err:
        kf.run(np.zeros((3, 1)), np.zeros((2, 2)), modes=[0, 0, 0])
    assert err.value.field == "U, Y"

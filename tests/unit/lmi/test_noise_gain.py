"""Noise-to-error bound of the observer (:mod:`hybobs_opt.lmi.noise_gain`, :mod:`hybobs_opt.lmi.noise_sim`).

The oracles share no code with the design:

* a scalar linear plant ``x' = a x``, ``y = x + v``: the error ``e' = (a - l) e - l v + w`` of the
  gain ``l > a`` has the peak ``(l vbar + wbar) / (l - a)`` (constant noise and disturbance reach it),
  and the invariant interval of ``V = p e^2`` at rate ``alpha`` is worked out by hand below;
* the vertex blocks re-checked in their Schur-complement form from vertex matrices written from
  closed-form slopes (``_oracles.py`` for the pendulum, slopes +-1 of ``sin`` for the robot);
* the simulator compared with :func:`scipy.integrate.solve_ivp` on the pendulum's equations written
  by hand; then plant and observer under bounded noise on the pendulum (``y = cos(theta)`` on
  ``[0.2, pi/2]``), the flexible-joint robot and the vehicle tracker (``psi`` in ``[0, 60]`` deg):
  the error stays within the bound and comes within 10x of it.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import _oracles as O

from hybobs_opt import get_example
from hybobs_opt.errors import InfeasibleError, ModelError
from hybobs_opt.lmi import jacobian_bounds, make_region
from hybobs_opt.lmi.noise_gain import NoiseGainLMI, noise_optimal_design, noise_tradeoff
from hybobs_opt.lmi.noise_sim import check_noise_bound, simulate_noisy_observer, sinusoid_noise
from hybobs_opt.studies.paper004_nonmonotonic.presets import get_preset, scaling_for
from hybobs_opt.systems import Polytope, ScalarNonlinearSystem
from hybobs_opt.systems.resolve import resolve_system

LO, HI = 0.2, math.pi / 2

# ---------------------------------------------------------------------------- the scalar oracle
A_SCALAR, L_MAX, VBAR, WBAR = 1.0, 5.0, 0.1, 0.2


def scalar_system() -> ScalarNonlinearSystem:
    return ScalarNonlinearSystem(box=Polytope.from_box([-1.0], [1.0], ("x",)), C=[[1.0]], A=[[A_SCALAR]],
                                 name="scalar")


def scalar_peak(l: float, vbar: float, wbar: float = 0.0) -> float:
    """Largest ``|e|`` of ``e' = (a - l) e - l v + w`` under ``|v| <= vbar``, ``|w| <= wbar`` (``l > a``)."""
    return (l * vbar + wbar) / (l - A_SCALAR)


def scalar_interval(alpha: float, vbar: float, lmax: float) -> float:
    """Smallest invariant-interval bound at rate ``alpha`` over gains ``a < l <= lmax`` (by hand).

    ``V = p e^2``: ``V' + alpha V - mu nu^2 <= 0`` with ``mu = alpha`` holds iff
    ``alpha (2 (l - a) - alpha) p >= (l vbar)^2 p^2``, and on ``V <= 1`` ``|e| <= p^-1/2``, so the
    bound is ``l vbar / sqrt(alpha (2 (l - a) - alpha))``; ``d/dl`` of ``l^2 / (2 (l - a) - alpha)`` is
    negative below ``l = 2 a + alpha``, so the best gain is ``min(lmax, 2 a + alpha)``.
    """
    l = min(lmax, 2 * A_SCALAR + alpha)
    room = 2 * (l - A_SCALAR) - alpha
    return l * vbar / math.sqrt(alpha * room) if room > 0 else float("nan")


@pytest.fixture(scope="module")
def scalar():
    system = scalar_system()
    return system, jacobian_bounds(system)


def test_scalar_bound_is_the_true_peak_error(scalar):
    system, bounds = scalar
    design = noise_optimal_design(system, bounds, [VBAR], gain_bound=L_MAX)
    assert design.feasible and design.verify()
    # the best gain is the largest allowed, its decay rate l - a, its bound the error's own peak
    assert design.L[0, 0] == pytest.approx(L_MAX, rel=1e-5)
    assert design.bound[0] == pytest.approx(scalar_peak(L_MAX, VBAR), rel=1e-4)
    assert design.alpha == pytest.approx(L_MAX - A_SCALAR, rel=2e-2)
    assert design.level == pytest.approx(1.0, rel=1e-4)


def test_scalar_tradeoff_matches_the_closed_form(scalar):
    system, bounds = scalar
    alphas = [0.5, 1.0, 4.0, 6.0, 7.9, 8.1]  # 8.1 > 2 (lmax - a): no gain within the bound decays that fast
    curve = noise_tradeoff(system, bounds, [VBAR], alphas, gain_bound=L_MAX)
    for a, ok, b in zip(alphas, curve.feasible, curve.bound[:, 0]):
        expected = scalar_interval(a, VBAR, L_MAX)
        if math.isnan(expected):
            assert not ok and math.isnan(b)
        else:
            assert ok and b == pytest.approx(expected, rel=1e-4), a
    assert all(d.verify() for d in curve.designs if d.feasible)
    assert json.loads(json.dumps(curve.to_dict()))["feasible"] == [True] * 5 + [False]


def test_scalar_disturbance_per_channel_is_exact_and_pooled_is_not(scalar):
    system, bounds = scalar
    kw = dict(W=[[1.0]], disturbance=[WBAR], gain_bound=L_MAX)
    per = noise_optimal_design(system, bounds, [VBAR], **kw)
    pooled = noise_optimal_design(system, bounds, [VBAR], multipliers="pooled", **kw)
    assert per.verify() and pooled.verify()
    assert per.bound[0] == pytest.approx(scalar_peak(L_MAX, VBAR, WBAR), rel=1e-4)
    # pooled: mu_v = mu_w = alpha / 2 gives sqrt(2 (c_v^2 + c_w^2)) / (l - a), c_v = l vbar, c_w = wbar
    c_v, c_w = L_MAX * VBAR, WBAR
    assert pooled.bound[0] == pytest.approx(math.sqrt(2 * (c_v ** 2 + c_w ** 2)) / (L_MAX - A_SCALAR), rel=1e-4)
    assert pooled.bound[0] > per.bound[0] * 1.05


def test_a_required_rate_is_met_or_refused_with_a_certificate(scalar):
    system, bounds = scalar
    at6 = noise_optimal_design(system, bounds, [VBAR], gain_bound=L_MAX, min_decay=6.0)
    assert at6.alpha >= 6.0 * (1 - 1e-4) and at6.verify()
    assert at6.bound[0] == pytest.approx(scalar_interval(6.0, VBAR, L_MAX), rel=1e-3)
    # 2 (lmax - a) = 8 is the largest decay rate of V = p e^2 with l <= 5: 9 is out of reach
    with pytest.raises(InfeasibleError) as info:
        noise_optimal_design(system, bounds, [VBAR], gain_bound=L_MAX, min_decay=9.0)
    assert info.value.certificate is not None and info.value.certificate.verify()


def test_bad_inputs_are_refused(scalar):
    system, bounds = scalar
    with pytest.raises(ModelError):
        noise_optimal_design(system, bounds, [-0.1])
    with pytest.raises(ModelError):
        noise_optimal_design(system, bounds, [0.1, 0.1])
    with pytest.raises(ModelError):
        noise_optimal_design(system, bounds, [0.1], W=[[1.0]])
    with_g = ScalarNonlinearSystem(box=Polytope.from_box([-1.0], [1.0]), C=[[1.0]], A=[[1.0]],
                                   g=lambda y, u: np.array([0.1 * y[0]]))
    with pytest.raises(ModelError, match="g"):
        NoiseGainLMI(with_g)


# ---------------------------------------------------------------------------- the three systems
def pendulum_drive():
    """The computed torque of ``_oracles.computed_torque``, for a batch of states."""
    r, rd, rdd = O.reference(LO, HI)

    def drive(t, X):
        th, om = X[:, 0], X[:, 1]
        return (rdd(t) + O.G * np.sin(th) + O.DAMPING * om + 25.0 * (r(t) - th) + 10.0 * (rd(t) - om))[:, None]

    return drive, np.array([r(0.0), rd(0.0)])


@pytest.fixture(scope="module")
def pendulum():
    system = O.pendulum("cos", driven=True)
    bounds = jacobian_bounds(system, make_region(system, 0, LO, HI))
    design = noise_optimal_design(system, bounds, [0.01])
    return system, bounds, design


@pytest.fixture(scope="module")
def robot():
    system = resolve_system("examples/models/flexible_joint_robot.toml")
    bounds = jacobian_bounds(system)
    design = noise_optimal_design(system, bounds, [0.01, 0.1])  # rad, rad/s
    return system, bounds, design


def robot_drive(t, X):
    """Motor-angle PD tracking of 1.5 sin(t/2) rad: the state stays inside the operating box."""
    return (3.0 * (1.5 * np.sin(0.5 * t) - X[:, 0]) - 0.3 * X[:, 1])[:, None]


VEHICLE_STEER, VEHICLE_W = math.radians(1.0), 0.5


@pytest.fixture(scope="module")
def vehicle():
    """psi in [0, 60] deg (the paper's first region ends at 80 deg), the preset's scaling, radar noise 0.2 m.

    ``min_decay = 1`` (the preset's rate): the unconstrained optimum (alpha ~ 0.18) settles in about
    90 s, by when the vehicle has left the +-500 m box.
    """
    system = get_example("vehicle_tracking").build()
    scaling = scaling_for(get_preset("vehicle_tracking"), system)
    bounds = jacobian_bounds(system, make_region(system, "psi", 0.0, math.radians(60.0)))
    design = noise_optimal_design(system, bounds, [0.2, 0.2], scaling=scaling, reference=scaling, min_decay=1.0)
    return system, bounds, design


def vehicle_drive(t, X):
    """Steering ``delta_f = 1 deg sin(t/2)``: psi swings by 15 deg about its start."""
    return np.full((X.shape[0], 1), VEHICLE_STEER * VEHICLE_W * math.cos(VEHICLE_W * t))


def vehicle_start(system) -> np.ndarray:
    k = 10.0 / (1.1 + 1.58)  # V / (l_f + l_r) of the example
    return np.array([-450.0, -450.0, math.radians(30.0) - k * VEHICLE_STEER / VEHICLE_W, 0.0])


# ---------------------------------------------------------------------------- (b) the numpy re-check
def schur_rates(P, L, alpha, mu, vbar, As, Cs) -> list[float]:
    """``lambda_max(P^-1/2 S_v P^-1/2)`` with ``S_v = He(P A_cl) + alpha P + sum_j (P L_j vbar_j)(P L_j vbar_j)' / mu_j``.

    The Schur complement of the ``-diag(mu)`` block (model coordinates, output noise only): the
    vertex block is negative semidefinite iff ``S_v`` is (for ``mu > 0``).
    """
    w, U = np.linalg.eigh(P)
    Pih = U @ np.diag(w ** -0.5) @ U.T
    out = []
    for A, C in zip(As, Cs):
        Acl = A - L @ C
        S = P @ Acl + Acl.T @ P + alpha * P
        for j in range(L.shape[1]):
            g = P @ L[:, j] * vbar[j]
            S = S + np.outer(g, g) / mu[j]
        M = Pih @ S @ Pih
        out.append(float(np.linalg.eigvalsh(0.5 * (M + M.T)).max()))
    return out


def robot_vertices(system):
    """``A + F theta E`` for ``theta = cos(theta_l)`` at its extremes -1 and 1; ``C`` (linear outputs)."""
    return [system.A + th * system.F @ system.E for th in (-1.0, 1.0)], [system.C, system.C]


def test_pendulum_design_rechecks_on_the_oracle_vertices(pendulum):
    _, _, design = pendulum
    assert design.feasible and design.verify()
    assert max(design.lmi_max_eig) <= 0.0 and len(design.lmi_max_eig) == 4
    As, Cs = O.vertices("cos", LO, HI)
    rates = schur_rates(design.P, design.L, design.alpha, design.mu, design.noise, As, Cs)
    assert max(rates) <= 1e-9 * design.alpha
    level = float(np.sum(design.mu)) / design.alpha
    assert design.level == pytest.approx(level, rel=1e-12)
    np.testing.assert_allclose(design.bound, np.sqrt(level * np.diag(np.linalg.inv(design.P))), rtol=1e-9)
    assert json.loads(json.dumps(design.to_dict()))["feasible"] is True


def test_robot_design_rechecks_on_the_oracle_vertices(robot):
    system, _, design = robot
    assert design.verify()
    As, Cs = robot_vertices(system)
    rates = schur_rates(design.P, design.L, design.alpha, design.mu, design.noise, As, Cs)
    assert max(rates) <= 1e-9 * design.alpha


def test_mutated_designs_fail_the_recheck(pendulum):
    from dataclasses import replace

    _, _, design = pendulum
    As, Cs = O.vertices("cos", LO, HI)
    bigger_gain = replace(design, L=1.5 * design.L)
    assert not bigger_gain.verify()
    assert max(schur_rates(design.P, 1.5 * design.L, design.alpha, design.mu, design.noise, As, Cs)) > 0
    faster = replace(design, alpha=1.5 * design.alpha)
    assert not faster.verify()
    assert not replace(design, P=2.0 * design.P).verify()  # a smaller ellipsoid: the blocks fail
    assert not replace(design, P=0.5 * design.P).verify()  # a larger one: the stated bound is not P's
    assert not replace(design, bound=0.9 * design.bound).verify()
    assert not replace(design, mu=0.5 * design.mu).verify()
    assert design.verify()


# ---------------------------------------------------------------------------- (c) simulation
def test_simulator_matches_an_independent_integration(pendulum):
    """The fixed-step simulator against solve_ivp on the pendulum written by hand (sinusoidal noise)."""
    system, _, design = pendulum
    L = design.L
    vb, w, ph = 0.01, 2.6, 0.3
    drive, x0 = pendulum_drive()
    u, _ = O.computed_torque(LO, HI)
    e0 = np.array([0.05, 0.2])

    def rhs(t, s):
        x, xh = s[:2], s[2:]
        ut = u(t, x)
        innov = math.cos(x[0]) + vb * math.cos(w * t - ph) - math.cos(xh[0])
        return [x[1], -O.G * math.sin(x[0]) - O.DAMPING * x[1] + ut,
                xh[1] + L[0, 0] * innov, -O.G * math.sin(xh[0]) - O.DAMPING * xh[1] + ut + L[1, 0] * innov]

    T = 3.0
    sol = solve_ivp(rhs, (0, T), np.concatenate([x0, x0 - e0]), method="DOP853", rtol=1e-11, atol=1e-13,
                    dense_output=True)
    run = simulate_noisy_observer(system, L, x0[None], (x0 - e0)[None], drive, sinusoid_noise([vb], [w], [[ph]]),
                                  T, 2e-3)
    ref = sol.sol(run.t)
    np.testing.assert_allclose(run.x[:, 0, :], ref[:2].T, atol=1e-7)
    np.testing.assert_allclose(run.x_hat[:, 0, :], ref[2:].T, atol=1e-7)


def assert_bound_holds_and_is_not_vacuous(design, check, name: str, record, min_runs: int = 20):
    record(f"{name}_ratio", check.ratio.tolist())  # bound / largest simulated error, per state (junit XML)
    record(f"{name}_alpha", design.alpha)
    assert check.runs >= min_runs
    assert check.left_region == 0 and check.plant_left_box == 0, f"{name}: a run left the region; no test"
    assert check.exceeded == 0, f"{name}: the error exceeded the certified bound"
    assert check.envelope_exceeded == 0, f"{name}: the error exceeded the certified envelope"
    assert np.all(check.max_error <= design.bound)
    ratio = float(np.max(check.ratio))
    assert ratio <= 10.0, f"{name}: bound / largest simulated error = {check.ratio} (> 10 for some state)"


def test_pendulum_bound_holds_under_bounded_noise(pendulum, record_property):
    _, _, design = pendulum
    drive, x0 = pendulum_drive()
    check = check_noise_bound(design, drive, x0, e0=np.array([0.05, 0.2]), random_runs=14)
    assert_bound_holds_and_is_not_vacuous(design, check, "pendulum", record_property)


def test_robot_bound_holds_under_bounded_noise(robot, record_property):
    _, _, design = robot
    check = check_noise_bound(design, robot_drive, np.zeros(4), e0=np.array([0.05, 0.0, 0.1, 0.0]), random_runs=12)
    assert_bound_holds_and_is_not_vacuous(design, check, "robot", record_property)


def test_vehicle_bound_holds_under_bounded_noise(vehicle, record_property):
    system, _, design = vehicle
    assert design.alpha >= 1.0 * (1 - 1e-4)
    check = check_noise_bound(design, vehicle_drive, vehicle_start(system), e0=np.array([1.0, -1.0, 0.05, 0.01]),
                              random_runs=8)
    assert_bound_holds_and_is_not_vacuous(design, check, "vehicle", record_property)


def test_pendulum_search_finds_the_smallest_bound_on_the_curve(pendulum):
    system, bounds, design = pendulum
    alphas = design.alpha * np.array([0.25, 0.5, 0.8, 1.0, 1.25, 2.0, 4.0])
    curve = noise_tradeoff(system, bounds, [0.01], alphas)
    assert curve.feasible.all()
    assert np.nanmin(curve.worst_relative) >= design.worst_relative * (1 - 1e-3)
    assert curve.worst_relative[3] == pytest.approx(design.worst_relative, rel=1e-3)


@pytest.mark.slow
@pytest.mark.parametrize("seed", [1, 2, 3])
def test_bounds_hold_over_more_random_seeds(pendulum, robot, vehicle, seed):
    """More random runs (other seeds, slower switching) on the three systems."""
    drive, x0 = pendulum_drive()
    cases = [(pendulum[2], drive, x0, np.array([-0.05, 0.1])),
             (robot[2], robot_drive, np.zeros(4), np.array([-0.05, 0.0, -0.1, 0.0])),
             (vehicle[2], vehicle_drive, vehicle_start(vehicle[0]), np.array([-1.0, 1.0, -0.05, -0.01]))]
    for design, drv, start, e0 in cases:
        for hold_steps in (1, 100):
            check = check_noise_bound(design, drv, start, e0=e0, random_runs=24, seed=100 * seed,
                                      families=("random",), hold_steps=hold_steps)
            assert check.left_region == 0 and check.plant_left_box == 0
            assert check.exceeded == 0 and check.envelope_exceeded == 0


def test_tradeoff_figure_is_written(scalar, tmp_path):
    from hybobs_opt.lmi.plots import plot_noise_tradeoff

    system, bounds = scalar
    curve = noise_tradeoff(system, bounds, [VBAR], [1.0, 4.0, 8.1], gain_bound=L_MAX)
    out = plot_noise_tradeoff(curve, tmp_path / "tradeoff.png", curve.designs[1], ["x"])
    assert out.stat().st_size > 1000 and out.read_bytes()[:4] == b"\x89PNG"

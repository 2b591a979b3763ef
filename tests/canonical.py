"""Canonical small problems with known answers, shared by the test modules (issue 13).

Each builder keeps the random stream the tests were written against: the same seed gives the
same system as before the builders were shared.  The exact observability oracle is
:mod:`exact_oracle` (independent of the package's LP code).
"""

from __future__ import annotations

import numpy as np

from hybobs_opt.systems import Polytope, PWAMode, PWASystem

#: Mirror map of :func:`mirror_system`: x -> (-x1, x2).
MIRROR = np.diag([-1.0, 1.0])


def slab_pwa(seed: int, n: int, n_modes: int, *, blind_probability: float | None = 0.3,
             output_after_dynamics: bool = False) -> PWASystem:
    """Slab guards on ``x[0]``, contractive random dynamics (spectral radius 0.8), one output.

    ``n`` states in ``[-1, 1]^n``, one input in ``[-1, 1]``.  With probability
    ``blind_probability`` one entry of ``C`` of each mode is zeroed (a blind direction); ``None``
    draws no blind direction at all (and consumes no random number for it).
    ``output_after_dynamics`` draws ``C`` after ``B`` and ``a`` (the stream of the 4-mode systems
    of the DAQP cycling tests) instead of before them.
    """
    rng = np.random.default_rng(seed)
    cuts = np.sort(rng.uniform(-0.6, 0.6, n_modes - 1))
    edges = np.concatenate([[-np.inf], cuts, [np.inf]])
    modes = []
    for i in range(n_modes):
        rows, rhs = [], []
        e0 = np.zeros(n + 1)
        e0[0] = 1.0
        if np.isfinite(edges[i]):
            rows.append(-e0)
            rhs.append(-edges[i])
        if np.isfinite(edges[i + 1]):
            rows.append(e0)
            rhs.append(edges[i + 1])
        A = rng.normal(size=(n, n))
        A *= 0.8 / max(1e-9, np.max(np.abs(np.linalg.eigvals(A))))
        if output_after_dynamics:
            B, a, C = rng.normal(size=(n, 1)) * 0.3, rng.normal(size=n) * 0.1, rng.normal(size=(1, n))
        else:
            C = rng.normal(size=(1, n))
        if blind_probability is not None and rng.random() < blind_probability:
            C[0, rng.integers(n)] = 0.0
        if not output_after_dynamics:
            B, a = rng.normal(size=(n, 1)) * 0.3, rng.normal(size=n) * 0.1
        modes.append(PWAMode(A, B, a, C, Polytope(np.array(rows), np.array(rhs)), D=rng.normal(size=(1, 1)) * 0.2,
                             c=rng.normal(size=1) * 0.1))
    return PWASystem(tuple(modes), Polytope.from_box([-1] * n, [1] * n), Polytope.from_box([-1], [1]))


def direction_pwa(seed: int, n_modes: int) -> PWASystem:
    """Contractive PWA system on ``[-1, 1]^2 x [-1, 1]``, guards across a random direction, mode-dependent output."""
    rng = np.random.default_rng(seed)
    d = rng.normal(size=2)
    d /= np.linalg.norm(d, 1)
    cuts = np.sort(rng.uniform(-0.4, 0.4, size=n_modes - 1))
    modes = []
    for i in range(n_modes):
        A = rng.normal(size=(2, 2))
        A *= 0.6 / np.abs(A).sum(axis=1).max()
        rows, rhs = [], []
        if i > 0:
            rows.append(np.r_[-d, 0.0])
            rhs.append(-cuts[i - 1])
        if i < n_modes - 1:
            rows.append(np.r_[d, 0.0])
            rhs.append(cuts[i])
        C = rng.normal(size=(1, 2))
        if rng.random() < 0.4:
            C[0, rng.integers(2)] = 0.0  # sometimes a blind direction
        modes.append(PWAMode(A, rng.uniform(-0.15, 0.15, size=(2, 1)), rng.uniform(-0.15, 0.15, size=2), C,
                             Polytope(np.array(rows), np.array(rhs)), c=rng.uniform(-0.2, 0.2, size=1)))
    return PWASystem(tuple(modes), Polytope.from_box([-1, -1], [1, 1]), Polytope.from_box([-1], [1]))


def mirror_system() -> PWASystem:
    """Two modes split by ``x1 >= 0`` / ``x1 <= 0`` with mirrored dynamics and ``y = |x1| + x2 / 2``.

    Known answer: *no* state with ``x1 != 0`` is observable, for any horizon.  Mode 2 is mode 1
    conjugated by the mirror ``M``: ``A_2 = M A_1 M``, ``B_2 = M B_1``, ``a_2 = M a_1``,
    ``C_2 = C_1 M``.  Hence ``f(M x, u) = M f(x, u)`` and ``h(M x, u) = h(x, u)`` for every input:
    ``x`` and ``M x`` give the same outputs forever, although each mode alone is observable.
    """
    A1 = np.array([[0.6, 0.2], [0.1, 0.6]])
    B1 = np.array([[0.0], [0.3]])
    a1 = np.array([0.15, 0.0])
    C1 = np.array([[1.0, 0.5]])
    right = PWAMode(A1, B1, a1, C1, Polytope(np.array([[-1.0, 0.0, 0.0]]), np.array([0.0])), name="x1>=0")
    left = PWAMode(MIRROR @ A1 @ MIRROR, MIRROR @ B1, MIRROR @ a1, C1 @ MIRROR,
                   Polytope(np.array([[1.0, 0.0, 0.0]]), np.array([0.0])), name="x1<=0")
    return PWASystem((right, left), Polytope.from_box([-1, -1], [1, 1]), Polytope.from_box([-1], [1]))


def rotation_pwa(angle: float) -> PWASystem:
    """Bemporad & Morari (Automatica 35(3), 1999, Sec. 5): ``x+ = 0.8 R(+-angle) x + [0; 1] u`` on
    ``x1 >= 0`` / ``x1 <= 0``, ``y = x2``, ``|x_i| <= 10``, ``|u| <= 1``.

    Known answer: mirror-symmetric like :func:`mirror_system` (``R(-a) M = M R(a)``, ``M B = B``),
    so no state with ``x1 != 0`` is observable at any horizon.
    """
    def rot(a):
        return 0.8 * np.array([[np.cos(a), -np.sin(a)], [np.sin(a), np.cos(a)]])

    B, C = np.array([[0.0], [1.0]]), np.array([[0.0, 1.0]])
    modes = (PWAMode(rot(angle), B, np.zeros(2), C, Polytope(np.array([[-1.0, 0.0, 0.0]]), np.zeros(1)), name="right"),
             PWAMode(rot(-angle), B, np.zeros(2), C, Polytope(np.array([[1.0, 0.0, 0.0]]), np.zeros(1)), name="left"))
    return PWASystem(modes, Polytope.from_box([-10, -10], [10, 10]), Polytope.from_box([-1], [1]),
                     ("x1", "x2"), ("u",), ("y",), name="rotation")


def deadzone_spring(Ts: float = 0.05, k: float = 4.0, c: float = 0.5, delta: float = 0.1) -> PWASystem:
    """A drive and a load coupled by a spring with a dead zone (the dead-zone model of backlash,
    Nordin & Gutman, Automatica 38(10), 2002, Sec. 2), Euler-discretised: ``x1`` the deflection,
    ``x2`` the load speed (the output), ``u`` the drive speed.

    ``x1+ = x1 + Ts (u - x2)``, ``x2+ = x2 + Ts (k dz(x1) - c x2)`` with ``dz(x1) = x1 - delta``
    (mode ``push``, ``x1 >= delta``), ``0`` (``free``, ``|x1| <= delta``), ``x1 + delta`` (``pull``);
    ``|x1| <= 1``, ``|x2| <= 3``, ``|u| <= 1``.  Known structure: in the dead zone the deflection
    never reaches the output, so every window that stays in ``free`` has ``rank C_i = 1 < n`` and
    ``B~_T`` has pieces (40 at T = 3, 96 at T = 4): a system outside the papers whose lookup observer
    decides windows by its ``B~_T`` LPs.
    """
    A_free = np.array([[1.0, -Ts], [0.0, 1.0 - c * Ts]])
    A_contact = np.array([[1.0, -Ts], [k * Ts, 1.0 - c * Ts]])
    B, C = np.array([[Ts], [0.0]]), np.array([[0.0, 1.0]])
    modes = (PWAMode(A_contact, B, np.array([0.0, -k * Ts * delta]), C,
                     Polytope(np.array([[-1.0, 0.0, 0.0]]), np.array([-delta])), name="push"),
             PWAMode(A_free, B, np.zeros(2), C, Polytope(np.array([[1.0, 0.0, 0.0], [-1.0, 0.0, 0.0]]),
                                                         np.array([delta, delta])), name="free"),
             PWAMode(A_contact, B, np.array([0.0, k * Ts * delta]), C,
                     Polytope(np.array([[1.0, 0.0, 0.0]]), np.array([-delta])), name="pull"))
    return PWASystem(modes, Polytope.from_box([-1.0, -3.0], [1.0, 3.0]), Polytope.from_box([-1.0], [1.0]),
                     ("x1", "x2"), ("u",), ("y",), name="deadzone_spring")


def deadzone_drive(steps: int, Ts: float = 0.05) -> np.ndarray:
    """Drive speed of the dead-zone spring's scenario: two sines that cross the dead zone both ways."""
    t = np.arange(steps) * Ts
    return (0.8 * np.sin(0.7 * t) + 0.2 * np.sin(3.1 * t))[:, None]


def dc_motor_friction(Ts: float = 0.01, J: float = 0.01, b: float = 0.1, K: float = 0.5, R: float = 1.0,
                      L: float = 0.05, tau_c: float = 0.05, w0: float = 0.2) -> PWASystem:
    """A DC motor with piecewise-linear friction, angle measured: three states, two inputs.

    States ``theta`` (rad), ``omega`` (rad/s), ``i`` (A); inputs the voltage ``v`` (V) and a load
    torque ``tau_l`` (N m); output ``theta``.  Euler-discretised:
    ``theta+ = theta + Ts omega``, ``omega+ = omega + Ts / J (K i - b omega - f(omega) - tau_l)``,
    ``i+ = i + Ts / L (v - R i - K omega)``, with the friction ``f`` Coulomb's ``tau_c sign(omega)``
    outside ``|omega| <= w0`` and linear inside (three modes: ``reverse``, ``stick``, ``forward``;
    continuous across the guards).  Bounds ``|theta| <= 20``, ``|omega| <= 10``, ``|i| <= 4``,
    ``|v| <= 6``, ``|tau_l| <= 0.1``.  Known structure: the state is observable from the angle in
    every mode (the current reaches it through the speed), with a noise amplification that grows
    as ``1 / Ts^2`` for the current: a system where noise, not ambiguity, limits the estimate.
    """
    a_w = Ts / J
    modes = []
    for name, slope, offset, rows, rhs in (
            ("reverse", 0.0, -tau_c, [[0.0, 1.0, 0.0, 0.0, 0.0]], [-w0]),
            ("stick", tau_c / w0, 0.0, [[0.0, 1.0, 0.0, 0.0, 0.0], [0.0, -1.0, 0.0, 0.0, 0.0]], [w0, w0]),
            ("forward", 0.0, tau_c, [[0.0, -1.0, 0.0, 0.0, 0.0]], [-w0])):
        A = np.array([[1.0, Ts, 0.0],
                      [0.0, 1.0 - a_w * (b + slope), a_w * K],
                      [0.0, -Ts * K / L, 1.0 - Ts * R / L]])
        B = np.array([[0.0, 0.0], [0.0, -a_w], [Ts / L, 0.0]])
        a = np.array([0.0, -a_w * offset, 0.0])
        C = np.array([[1.0, 0.0, 0.0]])
        modes.append(PWAMode(A, B, a, C, Polytope(np.array(rows), np.array(rhs)), name=name))
    return PWASystem(tuple(modes), Polytope.from_box([-20.0, -10.0, -4.0], [20.0, 10.0, 4.0]),
                     Polytope.from_box([-6.0, -0.1], [6.0, 0.1]), ("theta", "omega", "i"), ("v", "tau_l"),
                     ("theta",), name="dc_motor_friction")


def dc_motor_drive(steps: int, Ts: float = 0.01) -> np.ndarray:
    """Voltage and load torque of the DC motor's scenario: the speed reverses through the friction's
    stick band (a slow sine plus a faster one) under a slowly varying load."""
    t = np.arange(steps) * Ts
    v = 1.5 * np.sin(0.8 * t) + 0.5 * np.sin(5.3 * t)
    tau = 0.05 * np.sin(0.3 * t)
    return np.column_stack([v, tau])


def noise_study_case(name: str, steps: int):
    """``(system, U, trace, sigma)``: a noise-free run of ``steps`` samples and a noise level for
    it -- ``"model16"`` (paper 002's backlash scenario, sigma 1e-3 rad/s), ``"deadzone_spring"``
    (sigma 0.03, 0.5 % of the output range) or ``"dc_motor"`` (sigma 1e-3 rad)."""
    from hybobs_opt import get_example, simulate_pwa
    from hybobs_opt.studies.paper002_powertrain.systems import backlash_torque_profile

    if name == "model16":
        system = get_example("powertrain3").build()
        U = backlash_torque_profile(np.arange(steps) * system.Ts)[:, None]
        return system, U, simulate_pwa(system, np.array([0.06, 39.0, 3.25]), U), 1e-3
    if name == "deadzone_spring":
        system = deadzone_spring()
        U = deadzone_drive(steps)
        return system, U, simulate_pwa(system, np.array([0.3, 0.0]), U), 0.03
    if name == "dc_motor":
        system = dc_motor_friction()
        U = dc_motor_drive(steps)
        return system, U, simulate_pwa(system, np.zeros(3), U), 1e-3
    raise ValueError(name)


def saddle_tanh():
    """A saddle with a non-monotonic bounded nonlinearity and a saturating sensor (issue 35's own system).

    ``x1' = x2``, ``x2' = x1 + sin(2 x1) / 2``, ``y = 2 tanh(x1 / 2)`` on ``|x1| <= 2``, ``|x2| <= 3``:
    ``A = [[0, 1], [1, 0]]`` (eigenvalues +-1, a saddle), ``F = [0; 1]``, ``E = [1, 0]``,
    ``f(z) = sin(2 z) / 2`` (slope ``cos(2 z)`` in ``[-1, 1]``: non-monotonic) and
    ``h(z) = 2 tanh(z / 2)`` (slope ``1 - tanh(z / 2)^2`` in ``(0, 1]``: monotonic, nonlinear).
    Known structure: the error dynamics ``[[-l1 mu, 1], [1 + theta - l2 mu, 0]]`` need
    ``l2 mu > 1 + theta`` at every slope, so on ``x1 in [0, 1.5]`` (``theta <= 1``,
    ``mu >= 1 - tanh(0.75)^2 = 0.597``) no gain with ``l2 <= 3.35`` works.
    """
    from hybobs_opt.systems import ScalarFunction, ScalarNonlinearSystem

    box = Polytope.from_box([-2.0, -3.0], [2.0, 3.0], ("x1", "x2"))
    return ScalarNonlinearSystem(
        box=box, A=[[0.0, 1.0], [1.0, 0.0]], F=[[0.0], [1.0]], E=[[1.0, 0.0]],
        f=(ScalarFunction.from_text("sin(2z)/2", "sin(2*z)/2", "cos(2*z)"),),
        C=[[1.0, 0.0]], h=(ScalarFunction.from_text("2 tanh(z/2)", "2*tanh(z/2)", "1 - tanh(z/2)**2"),),
        state_names=("x1", "x2"), output_names=("y",), name="saddle_tanh")

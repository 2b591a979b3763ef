"""The PWA powertrain models with backlash of paper 002 (Section 5): models (16) and (17).

Both are forward-Euler discretisations (``Ts = 1 ms``) of rotating inertias connected by damped
flexibilities, with the shaft torque ``T_w = k D_alpha(theta)`` through the dead-zone operator

``D_alpha(theta) = theta - alpha`` if ``theta > alpha``; ``0`` if ``|theta| <= alpha``;
``theta + alpha`` if ``theta < -alpha``,

which makes them PWA with three modes: negative contact, backlash, positive contact.
"""

from __future__ import annotations

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.limits import check_samples
from hybobs_opt.sim.pwa import simulate_pwa
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.systems.pwa import PWAMode, PWASystem

#: Sampling period of models (16) and (17), paper 002 Section 5.1 ("Ts = 1 ms").
TS = 1e-3

#: Table 1 of paper 002 (model 16).
TABLE1 = {
    "Jm": 0.30,  # moment of inertia of the flywheel, kg m^2
    "Jl": 140.0,  # moment of inertia of the wheels, kg m^2
    "beta_m": 2.0,  # viscous friction of the engine, N m/(rad/s)
    "beta_l": 5.6,  # viscous friction of the wheels, N m/(rad/s)
    "k": 1e4,  # shaft stiffness, N m/rad
    "gear_ratio": 1.0 / 12.0,  # tau
    "alpha": 0.05,  # backlash size, rad
}

#: Table 2 of paper 002 (model 17).
TABLE2 = {
    "Jm": 0.70787,
    "Jc": 0.053937,
    "Jl": 487.15,
    "beta_m": 0.16488,
    "beta_c": 41.0,
    "beta_l": 0.8,
    "k": 54300.0,
    "kc": 2880.0,
    "gear_ratio": 1.0 / 6.9576,
    "alpha": 0.0042,
}

#: Mode names, in mode order (index 0, 1, 2) for both models.
MODE_NAMES = ("negative_contact", "backlash", "positive_contact")


def _guards(n: int, m: int, shaft: int, alpha: float) -> list[Polytope]:
    """``theta <= -alpha``, ``|theta| <= alpha``, ``theta >= alpha`` as polytopes over ``(x, u)``."""
    e = np.zeros(n + m)
    e[shaft] = 1.0
    return [
        Polytope(e[None, :], np.array([-alpha])),
        Polytope(np.vstack([e, -e]), np.array([alpha, alpha])),
        Polytope(-e[None, :], np.array([-alpha])),
    ]


def _check_positive(params: dict, names) -> None:
    for name in names:
        value = params[name]
        if not (isinstance(value, (int, float, np.floating)) and np.isfinite(value) and value > 0):
            raise ModelError(name, "a positive finite number", repr(value))


def powertrain3(gear_ratio: float = TABLE1["gear_ratio"], Ts: float = TS, *, theta_max: float = 0.2,
                **overrides: float) -> PWASystem:
    """Third-order powertrain with backlash, model (16) of paper 002 with Table 1.

    State ``x = [theta, omega_m, omega_l]`` (shaft twist angle, engine speed, wheel speed),
    input ``u = T_m`` (engine torque), output ``y = omega_m``:

    - (16a) ``theta+ = theta + Ts (tau omega_m - omega_l)``
    - (16b) ``omega_m+ = omega_m + Ts/Jm (T_m - tau T_w - beta_m omega_m)``
    - (16c) ``omega_l+ = omega_l + Ts/Jl (T_w - beta_l omega_l)``

    with ``T_w = k D_alpha(theta)``.  Bounds (Section 5.1): ``theta in [-0.2, 0.2]`` rad,
    ``omega_m in [0, 600]`` rad/s, ``omega_l in [-50, 50]`` rad/s, ``T_m in [0, 140]`` N m.

    Parameters
    ----------
    gear_ratio : float
        ``tau``; Table 1 gives 1/12, Figure 5 uses 1/2 and 1.
    Ts : float
        Sampling period (1 ms in the paper).
    theta_max : float, default 0.2
        Bound of the twist angle, ``theta in [-theta_max, theta_max]`` rad (Section 5.1: 0.2).  The
        scenario's torque profile twists the shaft beyond 0.2 rad when ``alpha > 0.055``; the
        unknown-gap study widens it.
    **overrides
        Any other Table 1 entry (``Jm, Jl, beta_m, beta_l, k, alpha``).

    Notes
    -----
    Eq. (18b) of the text reads ``(1 - Ts/Jm) beta_m omega_m``, a typesetting slip for
    ``(1 - Ts beta_m / Jm) omega_m``, which is what (16b) gives with ``T_w = 0``.
    """
    unknown = set(overrides) - set(TABLE1)
    if unknown:
        raise ModelError("powertrain3 parameters", f"names among {sorted(TABLE1)}", f"{sorted(unknown)}")
    p = {**TABLE1, **overrides, "gear_ratio": gear_ratio, "Ts": Ts}
    _check_positive({**p, "theta_max": theta_max}, ["Jm", "Jl", "beta_m", "beta_l", "k", "gear_ratio", "alpha", "Ts", "theta_max"])
    Jm, Jl, bm, bl, k, tau, alpha = (p[s] for s in ("Jm", "Jl", "beta_m", "beta_l", "k", "gear_ratio", "alpha"))
    if not alpha < theta_max:
        raise ModelError("alpha", f"a backlash half-gap below theta_max = {theta_max:g} rad", repr(alpha))
    n, m = 3, 1
    modes = []
    for (name, guard, sign, contact) in zip(MODE_NAMES, _guards(n, m, 0, alpha), (-1.0, 0.0, 1.0), (1.0, 0.0, 1.0)):
        # T_w = contact * k * (theta - sign * alpha)
        A = np.array(
            [
                [1.0, Ts * tau, -Ts],
                [-Ts * tau * contact * k / Jm, 1.0 - Ts * bm / Jm, 0.0],
                [Ts * contact * k / Jl, 0.0, 1.0 - Ts * bl / Jl],
            ]
        )
        a = np.array([0.0, Ts * tau * contact * k * sign * alpha / Jm, -Ts * contact * k * sign * alpha / Jl])
        B = np.array([[0.0], [Ts / Jm], [0.0]])
        C = np.array([[0.0, 1.0, 0.0]])
        modes.append(PWAMode(A, B, a, C, guard, name=name))
    names = ("theta", "omega_m", "omega_l")
    return PWASystem(
        tuple(modes),
        Polytope.from_box([-theta_max, 0.0, -50.0], [theta_max, 600.0, 50.0], names),
        Polytope.from_box([0.0], [140.0], ("T_m",)),
        names,
        ("T_m",),
        ("omega_m",),
        Ts=Ts,
        name=f"powertrain3 (tau={tau:.4g})" + ("" if theta_max == 0.2 else f", |theta| <= {theta_max:g}"),
    )


def powertrain5(gear_ratio: float = TABLE2["gear_ratio"], Ts: float = TS, **overrides: float) -> PWASystem:
    """Fifth-order powertrain with flexible clutch and backlash, model (17) of paper 002 with Table 2.

    State ``x = [theta_mc, theta_cl, omega_m, omega_c, omega_l]``, input ``T_m``, output
    ``omega_m``:

    - (17a) ``theta_mc+ = theta_mc + Ts (omega_m - omega_c)``
    - (17b) ``theta_cl+ = theta_cl + Ts (tau omega_c - omega_l)``
    - (17c) ``omega_m+ = omega_m + Ts/Jm (T_m - kc theta_mc - beta_c (omega_m - omega_c) - beta_m omega_m)``
    - (17d) ``omega_c+ = omega_c + Ts/Jc (kc theta_mc + beta_c (omega_m - omega_c) - tau T_w)``
    - (17e) ``omega_l+ = omega_l + Ts/Jl (T_w - beta_l omega_l)``

    with ``T_w = k D_alpha(theta_cl)``.  Bounds: ``theta_mc in [-0.05, 0.05]``,
    ``theta_cl in [-0.03, 0.03]`` (Section 5.2); ``omega_m in [0, 600]``, ``omega_l in [-50, 50]``,
    ``T_m in [0, 140]`` as in model (16) ("the other variables have the same meaning").

    Notes
    -----
    The paper gives no range for the clutch speed ``omega_c``; it is taken equal to the engine
    speed's range ``[0, 600]`` rad/s, since the clutch turns with the flywheel up to a small twist.
    """
    unknown = set(overrides) - set(TABLE2)
    if unknown:
        raise ModelError("powertrain5 parameters", f"names among {sorted(TABLE2)}", f"{sorted(unknown)}")
    p = {**TABLE2, **overrides, "gear_ratio": gear_ratio, "Ts": Ts}
    _check_positive(p, list(TABLE2) + ["Ts"])
    Jm, Jc, Jl = p["Jm"], p["Jc"], p["Jl"]
    bm, bc, bl = p["beta_m"], p["beta_c"], p["beta_l"]
    k, kc, tau, alpha = p["k"], p["kc"], p["gear_ratio"], p["alpha"]
    n, m = 5, 1
    modes = []
    for (name, guard, sign, contact) in zip(MODE_NAMES, _guards(n, m, 1, alpha), (-1.0, 0.0, 1.0), (1.0, 0.0, 1.0)):
        kw = contact * k
        A = np.array(
            [
                [1.0, 0.0, Ts, -Ts, 0.0],
                [0.0, 1.0, 0.0, Ts * tau, -Ts],
                [-Ts * kc / Jm, 0.0, 1.0 - Ts * (bc + bm) / Jm, Ts * bc / Jm, 0.0],
                [Ts * kc / Jc, -Ts * tau * kw / Jc, Ts * bc / Jc, 1.0 - Ts * bc / Jc, 0.0],
                [0.0, Ts * kw / Jl, 0.0, 0.0, 1.0 - Ts * bl / Jl],
            ]
        )
        a = np.array([0.0, 0.0, 0.0, Ts * tau * kw * sign * alpha / Jc, -Ts * kw * sign * alpha / Jl])
        B = np.array([[0.0], [0.0], [Ts / Jm], [0.0], [0.0]])
        C = np.array([[0.0, 0.0, 1.0, 0.0, 0.0]])
        modes.append(PWAMode(A, B, a, C, guard, name=name))
    names = ("theta_mc", "theta_cl", "omega_m", "omega_c", "omega_l")
    return PWASystem(
        tuple(modes),
        Polytope.from_box([-0.05, -0.03, 0.0, 0.0, -50.0], [0.05, 0.03, 600.0, 600.0, 50.0], names),
        Polytope.from_box([0.0], [140.0], ("T_m",)),
        names,
        ("T_m",),
        ("omega_m",),
        Ts=Ts,
        name=f"powertrain5 (tau={tau:.4g})",
    )


#: Torque levels (N m) of the scenario's three one-second phases, per model.  Chosen so that the
#: trajectory stays inside the paper's state bounds while crossing the backlash repeatedly.
SCENARIO_TORQUES = {"powertrain3": (80.0, 0.0, 50.0), "powertrain5": (30.0, 0.0, 30.0)}


def backlash_torque_profile(t: np.ndarray, levels: tuple[float, float, float] = SCENARIO_TORQUES["powertrain3"]) -> np.ndarray:
    """Engine torque of the observer scenario (paper 002, Section 7, Figs. 7-9).

    The paper does not print its input; this profile makes the shaft traverse the backlash, as its
    figures show: ``levels[0]`` until 1 s (positive contact, steady state), ``levels[1]`` until
    2 s (the wheels drive the engine, the shaft crosses to negative contact and rattles through
    the backlash), then ``levels[2]`` (it crosses back to positive contact after t = 2 s).
    """
    t = np.asarray(t, dtype=float)
    return np.where(t < 1.0, levels[0], np.where(t < 2.0, levels[1], levels[2]))


def steady_state(system: PWASystem, torque: float) -> np.ndarray:
    """Equilibrium of the positive-contact mode for a constant torque (the scenario's initial state).

    Solves ``x = A x + B u + a`` in mode ``positive_contact`` (a linear system, no iteration).
    """
    mode = system.modes[MODE_NAMES.index("positive_contact")]
    u = np.array([torque])
    x = np.linalg.solve(np.eye(system.n) - mode.A, mode.B @ u + mode.a)
    system.mode_of(x, u)  # raises if the equilibrium lies outside X x U
    return x


def backlash_scenario(system: PWASystem, levels: tuple[float, float, float], t_final: float | None = None):
    """Simulate the torque profile :func:`backlash_torque_profile` from the steady state of ``levels[0]``."""
    t_final = 3.0 if t_final is None else float(t_final)
    if not (np.isfinite(t_final) and t_final > 0):
        raise ModelError("t_final", "a positive finite time", repr(t_final))
    check_samples(t_final / system.Ts, "t_final", f"t_final = {t_final:g} s at Ts = {system.Ts:g} s")
    steps = int(round(t_final / system.Ts))
    if steps < 1:
        raise ModelError("t_final", f"at least one sampling period Ts = {system.Ts:g} s", repr(t_final))
    t = np.arange(steps) * system.Ts
    U = backlash_torque_profile(t, levels)[:, None]
    return simulate_pwa(system, steady_state(system, float(U[0, 0])), U)


def _scenario3(system: PWASystem, t_final: float | None = None):
    return backlash_scenario(system, SCENARIO_TORQUES["powertrain3"], t_final)


def _scenario5(system: PWASystem, t_final: float | None = None):
    return backlash_scenario(system, SCENARIO_TORQUES["powertrain5"], t_final)

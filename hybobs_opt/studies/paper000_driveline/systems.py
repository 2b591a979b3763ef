"""The driveline with discontinuous elasticity of paper 000 (Balluchi et al.), Section 2.

A reduced-order powertrain (clutch closed, fixed low gear, small vehicle speed) linearised around
the operating point ``(theta_e0, omega_c0, omega_p0)`` at 2000 rpm in second gear, eq. (1)-(2):

``x' = A x + E T_sm(x) + B u``,  ``y = C x``,

with state ``x = (theta_e - theta_e0, omega_c - omega_c0, omega_p - omega_p0)`` (driveline torsion
angle, crankshaft speed, wheel speed; all deviations from the equilibrium), input ``u`` the engine
torque minus its equilibrium value and output ``y`` the crankshaft speed deviation in rpm.  The
transmitted torque ``T_sm(x) = f(x1) + b_sm (alpha x2 - x3)`` has an elastic part ``f`` whose
coefficient jumps at the torsion ``|theta_e| = theta_1`` (Fig. 2), which gives the hybrid automaton
``H_drvln`` of Fig. 1 with three locations ``q1, q2, q3`` (one per value of the elastic coefficient).
"""

from __future__ import annotations

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.sim.hybrid import simulate_hybrid
from hybobs_opt.sim.trace import Trace
from hybobs_opt.systems.hybrid import Edge, HybridAutomaton, Location
from hybobs_opt.geometry.polytope import Polytope

#: Operating point of Section 2 of paper 000: "2000 rpm (i.e. omega_c0 = (pi/30) 2000 rad/sec)".
OMEGA_C0 = np.pi / 30.0 * 2000.0

#: Parameters of Table 1 of paper 000.  The table lost its numbers in the text; ``theta_1`` and
#: ``theta_e0`` are printed with Fig. 6, the others are chosen as documented in :func:`driveline`.
TABLE1 = {
    "alpha": 1.0 / 12.0,  # transmission ratio (omega_p = alpha omega_c): paper 002, Table 1 (tau)
    "Je": 0.30,  # primary driveline inertia, kg m^2: paper 002, Table 1 (Jm, flywheel)
    "Jv": 140.0,  # secondary driveline inertia, kg m^2: paper 002, Table 1 (Jl, wheels)
    "Be": 2.0,  # primary driveline viscous coefficient, N m/(rad/s): paper 002, Table 1 (beta_m)
    "bsm": 0.0,  # driveline viscous coefficient, N m/(rad/s): model (16) of paper 002 has none
    "k": 0.0,  # low driveline elasticity, N m/rad: 0 = backlash, the dead zone of paper 002
    "k1": 1e4,  # high driveline elasticity, N m/rad: paper 002, Table 1 (shaft stiffness k)
    "theta1": 0.015,  # elasticity discontinuity point, rad: paper 000, text of Fig. 6
    "theta_e0": 0.025,  # equilibrium torsion, rad: paper 000, text of Fig. 6
}

#: Location names, in location order: the paper's ``q1, q2, q3`` (Section 3.3 labels plant
#: locations ``q_i``; ``E1, E2, E3`` of Section 2 are their constant terms).
LOCATION_NAMES = ("q1", "q2", "q3")

#: State names (deviations from the operating point), after the paper's ``theta_e, omega_c, omega_p``.
STATE_NAMES = ("theta_e", "omega_c", "omega_p")

#: Fig. 6 of paper 000: "at time t = 2 a negative step of 10 Nm is applied".
STEP_TIME = 2.0
STEP_TORQUE = -10.0

#: Horizon of the scenario (s): 2 s at the operating point, then the transient after the step.
DEFAULT_T_FINAL = 4.0

#: Engine-torque deviation range, N m: the 140 N m span of paper 002's ``T_m in [0, 140]``
#: (Section 5.1), centred on the equilibrium torque (paper 000 gives no input range).
INPUT_RANGE = (-70.0, 70.0)


def driveline(**params: float) -> HybridAutomaton:
    """The 3-location driveline automaton ``H_drvln`` of paper 000 (Section 2, Fig. 1, eq. (1)-(2)).

    Flow in location ``q_i``: ``x' = A_i x + B u + E_i``, output ``y = C x`` (``C_i = C``,
    ``B_i = B``), where, with the Table 1 symbols,

    - ``A = [[0, alpha, -1], [0, -Be/Je, 0], [0, 0, 0]]``, ``E = [0, -alpha/Je, 1/Jv]'``,
      ``B = [0, 1/Je, 0]'``, ``C = [0, 30/pi, 0]`` (eq. (1)-(2); ``y`` in rpm);
    - ``T_sm(x) = f(x1) + bsm (alpha x2 - x3)``, so ``A_i = A + E [k_i, alpha bsm, -bsm]`` with
      ``k_1 = k_3 = k1`` and ``k_2 = k``;
    - ``f(x1) = k1 x1 + 2 (k1 - k) theta1`` in ``q1`` (``x1 + theta_e0 < -theta1``),
      ``f(x1) = k x1 - (k1 - k)(theta_e0 - theta1)`` in ``q2`` (``|x1 + theta_e0| <= theta1``),
      ``f(x1) = k1 x1`` in ``q3`` (``x1 + theta_e0 > theta1``), hence
      ``E1 = 2 (k1 - k) theta1 E``, ``E2 = -(k1 - k)(theta_e0 - theta1) E``, ``E3 = 0``.

    The printed first row of ``A`` and the factor of ``x2`` in ``T_sm`` are garbled; they are
    rederived from the physics: the torsion rate is ``alpha omega_c - omega_p`` (``alpha`` maps
    crankshaft speed to wheel speed) and ``E`` feeds ``-alpha T_sm`` back to the crankshaft, so
    the power ``T_sm (alpha omega_c)`` leaving the engine is the power reaching the wheels.  The
    piecewise ``f`` is the deviation ``T_el(x1 + theta_e0) - T_el(theta_e0)`` of the symmetric,
    continuous elastic torque of Fig. 2 (slope ``k`` for ``|theta_e| <= theta1``, ``k1`` beyond);
    it reproduces the three printed branches, which checks this reading.

    Parameters
    ----------
    **params : float
        Any entry of :data:`TABLE1`:

        ``alpha`` (1/12)
            Transmission ratio, ``omega_p = alpha omega_c``: the gear ratio ``tau`` of paper 002,
            Table 1 (a low gear, as paper 000 studies "the case of a low gear selection").
        ``Je`` (0.30 kg m^2), ``Jv`` (140 kg m^2)
            Primary (engine side) and secondary (wheel side) inertias: ``Jm`` and ``Jl`` of
            paper 002, Table 1.  They give a first driveline resonance of
            ``sqrt(k1 (1/Jv + alpha^2/Je)) / (2 pi) = 2.8 Hz``, the usual shuffle frequency.
        ``Be`` (2 N m s/rad)
            Engine viscous coefficient: ``beta_m`` of paper 002, Table 1.
        ``bsm`` (0)
            Viscous coefficient of the driveline: model (16) of paper 002 has no shaft damping;
            0 also keeps the gap of ``q2`` free of any transmitted torque.
        ``k`` (0), ``k1`` (1e4 N m/rad)
            Low and high elastic coefficients.  ``k1`` is the shaft stiffness of paper 002,
            Table 1.  ``k = 0`` makes ``q2`` a backlash (the dead zone ``D_alpha`` of paper 002,
            Section 5.1): there the crankshaft speed evolves independently of the torsion and of
            the wheel speed.  Any ``0 <= k < k1`` is accepted.
        ``theta1`` (0.015 rad), ``theta_e0`` (0.025 rad)
            Elasticity discontinuity point and equilibrium torsion, printed with Fig. 6 of paper
            000 ("theta_e0 = 0.025 rad", "theta_1 = 0.015 rad"); the location thresholds in
            ``x1`` are ``-theta_e0 + theta1 = -0.01`` and ``-theta_e0 - theta1 = -0.04`` rad.
            The model assumes ``theta_e0 > theta1`` (Section 2).

    Returns
    -------
    HybridAutomaton
        Locations ``q1`` (negative high-elasticity side), ``q2`` (low elasticity / backlash),
        ``q3`` (positive high-elasticity side, which contains the equilibrium ``x = 0``); edges
        ``q1 <-> q2 <-> q3`` (the torsion is continuous, so ``q1`` and ``q3`` are not adjacent).

    Notes
    -----
    Bounds.  ``X``: twist ``theta_e in [-0.2, 0.2]`` rad, crankshaft speed ``omega_c in [0, 600]``
    rad/s and wheel speed ``omega_p in [-50, 50]`` rad/s (the ranges of paper 002, Section 5.1),
    shifted by the operating point ``(theta_e0, omega_c0, alpha omega_c0)``, ``omega_c0 = 2000
    rpm``.  ``U``: :data:`INPUT_RANGE`.  Row 3 of ``A`` is zero as printed (no road load), so the
    model's only dissipation is ``Be``; the response to a torque step settles to ``x1 = 0``,
    ``x2 = u/Be``.
    """
    unknown = set(params) - set(TABLE1)
    if unknown:
        raise ModelError("driveline parameters", f"names among {sorted(TABLE1)}", f"{sorted(unknown)}")
    p = {**TABLE1, **params}
    for name, value in p.items():
        if not (isinstance(value, (int, float, np.floating, np.integer)) and np.isfinite(value)):
            raise ModelError(name, "a finite number", repr(value))
    for name in ("alpha", "Je", "Jv", "Be", "k1", "theta1", "theta_e0"):
        if p[name] <= 0:
            raise ModelError(name, "a positive number", repr(p[name]))
    for name in ("bsm", "k"):
        if p[name] < 0:
            raise ModelError(name, "a non-negative number", repr(p[name]))
    if p["k"] >= p["k1"]:
        raise ModelError("k", f"a low elasticity below k1 = {p['k1']}", repr(p["k"]))
    if p["theta_e0"] <= p["theta1"]:
        raise ModelError("theta_e0", f"an equilibrium torsion above theta1 = {p['theta1']} (paper 000, Section 2)", repr(p["theta_e0"]))

    alpha, Je, Jv, Be, bsm = p["alpha"], p["Je"], p["Jv"], p["Be"], p["bsm"]
    k, k1, th1, th0 = p["k"], p["k1"], p["theta1"], p["theta_e0"]

    A = np.array([[0.0, alpha, -1.0], [0.0, -Be / Je, 0.0], [0.0, 0.0, 0.0]])
    E = np.array([0.0, -alpha / Je, 1.0 / Jv])
    B = np.array([[0.0], [1.0 / Je], [0.0]])
    C = np.array([[0.0, 30.0 / np.pi, 0.0]])
    stiffness = (k1, k, k1)
    offsets = (2.0 * (k1 - k) * th1, -(k1 - k) * (th0 - th1), 0.0)

    lo_edge, hi_edge = -th0 - th1, -th0 + th1  # x1 thresholds, -0.04 and -0.01 rad by default
    e1 = np.array([[1.0, 0.0, 0.0]])
    invariants = (
        Polytope(e1, np.array([lo_edge]), STATE_NAMES),
        Polytope(np.vstack([e1, -e1]), np.array([hi_edge, -lo_edge]), STATE_NAMES),
        Polytope(-e1, np.array([-hi_edge]), STATE_NAMES),
    )
    locations = []
    for name, inv, ki, ci in zip(LOCATION_NAMES, invariants, stiffness, offsets):
        Ai = A + np.outer(E, [ki, alpha * bsm, -bsm])
        locations.append(Location(name, inv, A=Ai, B=B, E=ci * E, C=C))

    omega_p0 = alpha * OMEGA_C0
    state_bounds = Polytope.from_box(
        [-0.2 - th0, 0.0 - OMEGA_C0, -50.0 - omega_p0],
        [0.2 - th0, 600.0 - OMEGA_C0, 50.0 - omega_p0],
        STATE_NAMES,
    )
    return HybridAutomaton(
        locations=tuple(locations),
        state_bounds=state_bounds,
        edges=(Edge(0, 1), Edge(1, 0), Edge(1, 2), Edge(2, 1)),
        input_bounds=Polytope.from_box([INPUT_RANGE[0]], [INPUT_RANGE[1]], ("u",)),
        state_names=STATE_NAMES,
        input_names=("u",),
        output_names=("y",),
        name="driveline (paper 000)",
    )


def torque_step(t: float, step_time: float = STEP_TIME, step: float = STEP_TORQUE) -> np.ndarray:
    """Engine-torque deviation of Fig. 6 (paper 000): 0 before ``step_time``, ``step`` (-10 N m) after."""
    return np.array([step if t >= step_time else 0.0])


def scenario(system: HybridAutomaton, t_final: float | None = None) -> Trace:
    """Fig. 6 of paper 000: from the equilibrium ``x = 0`` (location ``q3``), a -10 N m step of the
    engine torque at ``t = 2`` s, simulated with event location (:func:`simulate_hybrid`, 1 ms samples).

    With the default parameters the step removes more than the ``alpha k1 (theta_e0 - theta1) =
    8.3`` N m that the engine transmits to the shaft at the operating point, so it unloads the
    shaft: the torsion deviation falls through ``-0.01`` rad into ``q2`` (at about 2.11 s),
    reaches about ``-0.0148`` rad, short of the far side ``-0.04`` rad of the gap, and the
    decelerating wheels bring it back into ``q3`` (at about 2.31 s).  This matches Fig. 6, which
    shows only the residual signals of locations 2 and 3.  The output then settles to the
    viscous balance ``x2 = u/Be = -5`` rad/s.
    """
    t_final = DEFAULT_T_FINAL if t_final is None else float(t_final)
    if not (np.isfinite(t_final) and t_final > 0):
        raise ModelError("t_final", "a positive finite time", repr(t_final))
    return simulate_hybrid(system, np.zeros(system.n), t_final, u=torque_step, breakpoints=(STEP_TIME,), dt=1e-3)

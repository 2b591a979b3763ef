"""Paper 004 (Rajamani, Jeon, Movahedi, Zemouche): the two non-monotonic applications.

* ``vehicle_tracking`` -- Section 6: a tracked vehicle's bicycle model, eqs. (56)-(59), nonlinear
  non-monotonic process dynamics (``V cos psi``, ``V sin psi``) and linear radar outputs.
* ``magnetic_piston`` -- Section 7: piston position of an electro-hydraulic actuator, eq. (63),
  linear process dynamics and two non-monotonic magnetic-sensor outputs.

Both are registered in :mod:`hybobs_opt.studies.registry` (by this study's package) with their simulation scenario.
Where the text extraction of the paper garbled a formula, or the paper gives no number, the
docstrings below say what was assumed and why.
"""

from __future__ import annotations

import math
from dataclasses import replace

import casadi as ca
import numpy as np
from scipy.integrate import quad
from scipy.optimize import brentq

from hybobs_opt.errors import ModelError
from hybobs_opt.sim.nonlinear import simulate_nonlinear
from hybobs_opt.sim.trace import Trace
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.systems.scalar_nonlinear import ScalarFunction, ScalarNonlinearSystem

# ---------------------------------------------------------------------------------------------
# Vehicle tracking, paper 004 Section 6
# ---------------------------------------------------------------------------------------------

#: Paper 004, Sec. 6.1: "V is assumed as 10m/s" (m/s).
VEHICLE_SPEED = 10.0
#: Front / rear axle distances from the c.g. (m).  NOT in paper 004 (eq. (57) uses only their sum);
#: taken from the passenger-car data of Rajamani, *Vehicle Dynamics and Control* (2012), the
#: reference the paper cites for the radar tracking model.
VEHICLE_LF = 1.1
VEHICLE_LR = 1.58
#: Steering range of both observer gains, eqs. (61)-(62): -10 deg <= delta_f <= 10 deg.
VEHICLE_DELTA_MAX_DEG = 10.0
#: Half-width of the relative-position box (m); an assumption wide enough for the scenario.
VEHICLE_POSITION_RANGE = 500.0

#: Scenario, paper 004 Sec. 6.2: the true vehicle starts at (-5, -5) m with a 30 deg yaw angle.
VEHICLE_X0 = (-5.0, -5.0, math.radians(30.0), 0.0)
#: Sec. 6.2 (i): straight driving for 5 s.
VEHICLE_STRAIGHT_S = 5.0
#: Sec. 6.2 (ii): left turn until the yaw angle is 120 deg.
VEHICLE_FINAL_YAW_DEG = 120.0
#: Yaw rate of the turn (deg/s).  NOT in the paper; chosen so the yaw angle leaves the 0-80 deg
#: range of gain L_1 (eq. 61) at t = 5 s + (80 - 30)/5 s = 15 s, which is when Fig. 4 shows the
#: single-gain observer's error growing ("after the first 15 seconds").
VEHICLE_TURN_RATE_DEG_S = 5.0
#: Steering is ramped in and out over this time (s) instead of stepped, so the yaw rate stays
#: continuous; an assumption (the paper does not say how the steering was applied).
VEHICLE_STEER_RAMP_S = 0.5
#: Scenario horizon (s): the turn ends near 23.5 s, followed by (iii) straight driving.
VEHICLE_T_FINAL = 30.0
VEHICLE_DT = 0.01


def vehicle_tracking(
    V: float = VEHICLE_SPEED,
    l_f: float = VEHICLE_LF,
    l_r: float = VEHICLE_LR,
    delta_max_deg: float = VEHICLE_DELTA_MAX_DEG,
    position_range: float = VEHICLE_POSITION_RANGE,
) -> ScalarNonlinearSystem:
    """Bicycle model of a tracked vehicle, eqs. (56)-(59) of paper 004 (Section 6.1).

    States (eq. 56) ``x = [X, Y, psi, delta_f]``: relative longitudinal and lateral position (m),
    yaw angle (rad), front-wheel steering angle (rad).  Dynamics (eq. 57)::

        X'       = V cos(psi)
        Y'       = V sin(psi)
        psi'     = V / (l_f + l_r) * tan(delta_f)
        delta_f' = u

    written as ``x' = F f(E x) + B u`` with ``f_1 = V cos``, ``f_2 = V sin`` acting on
    ``E_1 = E_2 = [0 0 1 0]`` and ``f_3 = V/(l_f + l_r) tan`` acting on ``E_3 = [0 0 0 1]``
    (text after eq. 59), ``F = [I_3; 0]``.  Outputs (eq. 58): the radar measures ``X`` and ``Y``
    (``C = [I_2 0]``, linear outputs).  The derivatives are the paper's Jacobian, eq. (59):
    ``-V sin(psi)``, ``V cos(psi)``, ``V/(l_f + l_r) sec^2(delta_f)`` (the extraction printed the
    last one as "V / l_f + l_r sec^2"; the parenthesisation follows from differentiating (57)).

    The paper's model assumes ``delta_f' = 0``; here the steering rate is the input ``u``
    (rad/s, ``B = e_4``) so the simulation can steer the true vehicle.  An observer built on the
    paper's model simply uses ``u = 0``.

    Parameters
    ----------
    V : float
        Speed at the c.g. (m/s); paper: 10 m/s (Sec. 6.1).
    l_f, l_r : float
        Distances from the c.g. to the front and rear axles (m); not given in the paper
        (defaults from Rajamani 2012, see :data:`VEHICLE_LF`).
    delta_max_deg : float
        Steering bound (deg) of the operating box; paper: 10 deg (eqs. 61-62).
    position_range : float
        The box is ``|X|, |Y| <= position_range`` (m); an assumption.

    Returns
    -------
    ScalarNonlinearSystem
        Operating box: ``X, Y`` in ``[-position_range, position_range]``, ``psi`` in
        ``[0, 2 pi]`` (the "entire operating range 0 < psi < 360 deg" of Sec. 6.1),
        ``delta_f`` in ``[-delta_max, delta_max]``.
    """
    for label, value in (("V", V), ("l_f", l_f), ("l_r", l_r), ("position_range", position_range)):
        if not (np.isfinite(value) and value > 0):
            raise ModelError(label, "a positive finite number", repr(value))
    if not (np.isfinite(delta_max_deg) and delta_max_deg < 90):  # a negative one: "bounds of delta_f" below
        raise ModelError("delta_max_deg", "a steering bound below 90 degrees (tan(delta_f) has a pole at 90)",
                         repr(delta_max_deg))
    d_max = math.radians(delta_max_deg)
    k = V / (l_f + l_r)
    names = ("X", "Y", "psi", "delta_f")
    box = Polytope.from_box([-position_range, -position_range, 0.0, -d_max],
                            [position_range, position_range, 2 * math.pi, d_max], names)
    f = (
        ScalarFunction("V cos(psi)", lambda z: V * ca.cos(z), lambda z: -V * ca.sin(z)),
        ScalarFunction("V sin(psi)", lambda z: V * ca.sin(z), lambda z: V * ca.cos(z)),
        ScalarFunction("V/(l_f+l_r) tan(delta_f)", lambda z: k * ca.tan(z), lambda z: k / ca.cos(z) ** 2),
    )
    F = np.vstack([np.eye(3), np.zeros((1, 3))])
    E = np.array([[0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0]])
    C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    B = np.array([[0.0], [0.0], [0.0], [1.0]])
    return ScalarNonlinearSystem(
        box=box, C=C, h=None, F=F, E=E, f=f, B=B,
        state_names=names, input_names=("delta_f_rate",), output_names=("X_meas", "Y_meas"),
        name="vehicle_tracking",
    )


def vehicle_scenario(system: ScalarNonlinearSystem, t_final: float | None = None) -> Trace:
    """The manoeuvre of paper 004, Section 6.2, simulated on ``system``.

    Constant speed; from ``(X, Y) = (-5, -5)`` m with yaw 30 deg: (i) straight for 5 s, (ii) left
    turn until the yaw angle is 120 deg, (iii) straight with that yaw angle.  The turn's steering
    angle is the one giving a yaw rate of :data:`VEHICLE_TURN_RATE_DEG_S` (solved on the system's
    own yaw equation), ramped in and out over :data:`VEHICLE_STEER_RAMP_S`; the hold time is
    computed so the yaw ends at exactly 120 deg.  ``events`` marks the phase changes.
    """
    t_final = VEHICLE_T_FINAL if t_final is None else float(t_final)
    try:
        i_psi, i_delta = system.state_names.index("psi"), system.state_names.index("delta_f")
    except ValueError:
        raise ModelError("system.state_names", "a vehicle model with states 'psi' and 'delta_f'",
                         f"{system.state_names}") from None
    u0 = np.zeros(system.m)

    def yaw_rate(delta: float) -> float:
        x = np.zeros(system.n)
        x[i_delta] = delta
        return float(system.rhs(x, u0)[i_psi])

    rate = math.radians(VEHICLE_TURN_RATE_DEG_S)
    d_hi = float(system.box_upper[i_delta])
    if yaw_rate(d_hi) < rate:
        raise ModelError("system", f"a steering range reaching a yaw rate of {VEHICLE_TURN_RATE_DEG_S} deg/s",
                         f"{math.degrees(yaw_rate(d_hi)):.4g} deg/s at the steering bound")
    delta_turn = brentq(lambda d: yaw_rate(d) - rate, 0.0, d_hi, xtol=1e-14, rtol=1e-14)
    T = VEHICLE_STEER_RAMP_S
    ramp_yaw = quad(lambda s: yaw_rate(delta_turn * s / T), 0.0, T, epsabs=1e-14, epsrel=1e-13)[0]
    turn = math.radians(VEHICLE_FINAL_YAW_DEG) - VEHICLE_X0[2]
    hold = (turn - 2.0 * ramp_yaw) / rate
    t1 = VEHICLE_STRAIGHT_S
    t2, t3 = t1 + T, t1 + T + hold
    t4 = t3 + T
    steer_rate = delta_turn / T

    def u_fn(t: float) -> np.ndarray:
        if t1 <= t < t2:
            return np.array([steer_rate])
        if t3 <= t < t4:
            return np.array([-steer_rate])
        return np.array([0.0])

    trace = simulate_nonlinear(system, VEHICLE_X0, u_fn, t_final, VEHICLE_DT, breakpoints=(t1, t2, t3, t4))
    events = [
        {"t": t1, "kind": "maneuver", "phase": "steer in", "delta_f": delta_turn},
        {"t": t2, "kind": "maneuver", "phase": "steady turn", "delta_f": delta_turn},
        {"t": t3, "kind": "maneuver", "phase": "steer out", "delta_f": delta_turn},
        {"t": t4, "kind": "maneuver", "phase": "straight", "delta_f": 0.0},
    ]
    return replace(trace, events=[e for e in events if e["t"] <= t_final])


# ---------------------------------------------------------------------------------------------
# Magnetic piston position, paper 004 Section 7
# ---------------------------------------------------------------------------------------------

#: Position range of the actuator (mm), paper 004 Sec. 7: "the position range of 0-203 mm".
PISTON_STROKE_MM = 203.0
#: Velocity / acceleration bounds of the operating box (mm/s, mm/s^2).  NOT in the paper; chosen
#: well above the scenario's stroke (peak 152 mm/s, 238 mm/s^2).
PISTON_V_MAX = 500.0
PISTON_A_MAX = 5000.0

#: Synthetic sensor curves (the measured curves of Fig. 6 are not published as numbers).  In the
#: plane of the two readings the curve ``z -> (y1, y2)`` is a spiral about ``SENSOR_OFFSET_MT``:
#: radius ``rho0 (1 + kappa s)`` growing with ``s = z / stroke`` and angle
#: ``theta0 + turn (s + beta sin(2 pi s) / (2 pi))`` increasing in ``s``.  A strictly growing radius
#: makes the pair one-to-one in position, as the paper states for its sensors (end of Sec. 7).
#: Each reading turns back every half turn of the angle: over the stroke the angle runs from
#: pi/4 to pi/4 + 5 pi, so y1 (cosine) has 5 extrema near angle k pi and y2 (sine) 5 near
#: pi/2 + k pi; together the 10 slope-change points split the stroke into 11 intervals on which
#: both outputs are monotonic -- the counterpart of regions R_1..R_11 of Fig. 7.  ``beta`` makes
#: the spacing of the extrema uneven (closer near the ends of the stroke), as on real field curves.
SENSOR_OFFSET_MT = (0.3, -0.2)
SENSOR_RHO0_MT = 2.0
SENSOR_KAPPA = 1.5
SENSOR_THETA0 = math.pi / 4
SENSOR_TURN = 5 * math.pi
SENSOR_BETA = 0.3

#: Scenario: one full extend-retract cycle z(t) = z_c - A cos(2 pi t / T), 2.5 % margin at each end.
PISTON_PERIOD_S = 4.0
PISTON_MARGIN = 0.025
PISTON_DT = 0.001


def _sensor_angle(z, stroke: float):
    s = z / stroke
    return SENSOR_THETA0 + SENSOR_TURN * (s + SENSOR_BETA * ca.sin(2 * math.pi * s) / (2 * math.pi))


def _sensor_radius(z, stroke: float):
    return SENSOR_RHO0_MT * (1 + SENSOR_KAPPA * z / stroke)


def magnetic_piston(
    stroke: float = PISTON_STROKE_MM,
    v_max: float = PISTON_V_MAX,
    a_max: float = PISTON_A_MAX,
) -> ScalarNonlinearSystem:
    """Piston position estimation with two magnetic sensors, eq. (63) of paper 004 (Section 7).

    States ``x = [z, v, a]``: piston position (mm), velocity (mm/s), acceleration (mm/s^2).
    Dynamics (eq. 63) ``x' = A x + B u`` with the chain of integrators
    ``A = [[0,1,0],[0,0,1],[0,0,0]]``; the paper does not print ``B``: here ``B = e_3`` and ``u``
    is the jerk (mm/s^3), i.e. the model is a constant-acceleration model driven by jerk.
    Outputs (eq. 63) ``y_j = h_j(C_j x)`` with ``C_1 = C_2 = [1 0 0]``: two magnetic field
    readings (mT) that are non-monotonic functions of the position.

    The paper fits polynomials to measured curves (Fig. 6) that are not published.  The curves
    here are synthetic, smooth and of the same character (see :data:`SENSOR_OFFSET_MT`)::

        s      = z / stroke
        theta  = pi/4 + 5 pi (s + 0.3 sin(2 pi s) / (2 pi))
        rho    = 2.0 (1 + 1.5 s)                      [mT]
        h_1(z) =  0.3 + rho cos(theta)                [mT]
        h_2(z) = -0.2 + rho sin(theta)                [mT]

    Each output has 5 interior extrema on ``[0, stroke]``; together they split the stroke into
    11 intervals where both are monotonic (the paper's regions R_1..R_11, Fig. 7), and the
    pair ``(y1, y2)`` determines ``z`` uniquely (as stated at the end of Sec. 7).  Derivatives
    come from CasADi automatic differentiation.

    Parameters
    ----------
    stroke : float
        Position range (mm); paper: 0-203 mm (Sec. 7).
    v_max, a_max : float
        Velocity and acceleration bounds of the operating box (assumed, not in the paper).

    Returns
    -------
    ScalarNonlinearSystem
        Operating box ``0 <= z <= stroke``, ``|v| <= v_max``, ``|a| <= a_max``.
    """
    if not (np.isfinite(stroke) and stroke != 0):
        raise ModelError("stroke", "a finite, non-zero stroke length (mm)", repr(stroke))
    for label, value in (("v_max", v_max), ("a_max", a_max)):
        if not (np.isfinite(value) and value > 0):
            raise ModelError(label, "a positive finite bound of the operating box", repr(value))
    names = ("z", "v", "a")
    box = Polytope.from_box([0.0, -v_max, -a_max], [stroke, v_max, a_max], names)
    h = (
        ScalarFunction("sensor 1", lambda z: SENSOR_OFFSET_MT[0] + _sensor_radius(z, stroke) * ca.cos(_sensor_angle(z, stroke))),
        ScalarFunction("sensor 2", lambda z: SENSOR_OFFSET_MT[1] + _sensor_radius(z, stroke) * ca.sin(_sensor_angle(z, stroke))),
    )
    A = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, 0.0]])
    B = np.array([[0.0], [0.0], [1.0]])
    C = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, 0.0]])
    return ScalarNonlinearSystem(
        box=box, C=C, h=h, A=A, B=B,
        state_names=names, input_names=("jerk",), output_names=("B1", "B2"), name="magnetic_piston",
    )


def piston_scenario(system: ScalarNonlinearSystem, t_final: float | None = None) -> Trace:
    """One extend-retract stroke across the range (the paper shows no scenario; an assumption).

    ``z(t) = z_c - A cos(2 pi t / T)`` with ``T`` = :data:`PISTON_PERIOD_S`, centred in the box's
    position range and leaving :data:`PISTON_MARGIN` of the stroke at each end; the jerk input
    ``u = -A w^3 sin(w t)`` drives the triple integrator of eq. (63) along it from
    ``x0 = [z_c - A, 0, A w^2]``.
    """
    t_final = PISTON_PERIOD_S if t_final is None else float(t_final)
    try:
        i_z = system.state_names.index("z")
    except ValueError:
        raise ModelError("system.state_names", "a piston model with a state 'z'", f"{system.state_names}") from None
    lo, hi = float(system.box_lower[i_z]), float(system.box_upper[i_z])
    zc = 0.5 * (lo + hi)
    amp = 0.5 * (hi - lo) - PISTON_MARGIN * (hi - lo)
    w = 2 * math.pi / PISTON_PERIOD_S
    x0 = [zc - amp, 0.0, amp * w**2]
    return simulate_nonlinear(system, x0, lambda t: np.array([-amp * w**3 * math.sin(w * t)]), t_final, PISTON_DT)

"""Single-link flexible-joint robot: a non-monotonic scalar-nonlinear system (``sin`` of the link angle).

Source
------
M. W. Spong, "Modeling and control of elastic joint robots", ASME J. Dynamic Systems,
Measurement, and Control 109(4):310-319, 1987 (the elastic-joint model, one link); used as the
observer benchmark of S. Raghavan and J. K. Hedrick, "Observer design for a class of nonlinear
systems", Int. J. Control 59(2):515-528, 1994, of R. Rajamani, "Observers for Lipschitz
nonlinear systems", IEEE Trans. Automatic Control 43(3):397-401, 1998, and of A. Zemouche,
M. Boutayeb and G. I. Bara, "Observers for a class of Lipschitz systems with extension to
H-infinity performance analysis", Systems & Control Letters 57(1):18-27, 2008:

    theta_m' = omega_m
    omega_m' = (k/J_m)(theta_l - theta_m) - (B/J_m) omega_m + (K_tau/J_m) u
    theta_l' = omega_l
    omega_l' = -(k/J_l)(theta_l - theta_m) - (m g h/J_l) sin(theta_l)
    y = (theta_m, omega_m)

with motor inertia J_m = 3.7e-3 kg m^2, link inertia J_l = 9.3e-3 kg m^2, link mass m = 0.21 kg,
centre of mass h = 0.15 m, torsional stiffness k = 0.18 N m/rad, viscous friction B = 4.6e-2 N m s/rad,
amplifier gain K_tau = 8e-2 N m/V and g = 9.81 m/s^2.

In the class x' = A x + F f(E x) + B u, y = C x of hybobs_opt: one nonlinearity f_1(z) = sin(z) on
z = theta_l (E_1 = [0 0 1 0]), mixed by F = [0; 0; 0; -m g h/J_l]; its derivative cos(z) takes
both signs on theta_l in [-pi, pi], so the system is non-monotonic there (the case of Rajamani et
al.'s switched-gain observers).

Modelling choices (all keyword parameters of :func:`build`)
-----------------------------------------------------------
* Parameter values as listed above.  The observer papers print the numeric matrices rounded and
  not always consistently with these values (entries -1.25 for -B/J_m, which would need
  B = 4.6e-3, and 3.33 for m g h/J_l, which would need h = 0.015); here every entry is computed
  from the physical parameters: k/J_m = 48.65, B/J_m = 12.43, K_tau/J_m = 21.62, k/J_l = 19.35,
  m g h/J_l = 33.23.
* The input u is the amplifier voltage (motor torque K_tau u), as in the observer papers; pass
  ``k_tau=1.0`` for u = motor torque in N m.
* Outputs: motor angle and motor speed (encoder and tachometer on the motor side), linear.
* Operating box (our choice): theta_m, theta_l in [-pi, pi] rad, omega_m, omega_l in [-10, 10]
  rad/s (``angle_bound``, ``speed_bound``).
* The nonlinearity is written as the pure ``sin(z)`` (name ``"sin(theta_l)"``) and its
  coefficient goes into F, so the derivative bounds of f are those of cos on the box.
"""

from __future__ import annotations

import math

import casadi as ca
import numpy as np

from hybobs_opt import Polytope, ScalarFunction, ScalarNonlinearSystem

STATES = ("theta_m", "omega_m", "theta_l", "omega_l")


def build(J_m: float = 3.7e-3, J_l: float = 9.3e-3, m: float = 0.21, h: float = 0.15, k: float = 0.18,
          B: float = 4.6e-2, k_tau: float = 8e-2, g: float = 9.81, angle_bound: float = math.pi,
          speed_bound: float = 10.0) -> ScalarNonlinearSystem:
    """The single-link flexible-joint robot (see the module docstring for every choice)."""
    A = np.array([
        [0.0, 1.0, 0.0, 0.0],
        [-k / J_m, -B / J_m, k / J_m, 0.0],
        [0.0, 0.0, 0.0, 1.0],
        [k / J_l, 0.0, -k / J_l, 0.0],
    ])
    F = np.array([[0.0], [0.0], [0.0], [-(m * g * h / J_l)]])
    E = np.array([[0.0, 0.0, 1.0, 0.0]])
    Bu = np.array([[0.0], [k_tau / J_m], [0.0], [0.0]])
    C = np.array([[1.0, 0.0, 0.0, 0.0], [0.0, 1.0, 0.0, 0.0]])
    upper = [angle_bound, speed_bound, angle_bound, speed_bound]
    box = Polytope.from_box([-v for v in upper], upper, STATES)
    return ScalarNonlinearSystem(
        box=box, C=C, A=A, F=F, E=E, f=(ScalarFunction("sin(theta_l)", ca.sin),), B=Bu,
        state_names=STATES, input_names=("u",), output_names=("theta_m_meas", "omega_m_meas"),
        name="flexible_joint_robot")

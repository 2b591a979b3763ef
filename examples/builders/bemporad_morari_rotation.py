"""Rotating PWA system with an input: the classic two-mode example of Bemporad & Morari.

Source
------
A. Bemporad and M. Morari, "Control of systems integrating logic, dynamics, and constraints",
Automatica 35(3):407-427, 1999 (the piecewise-affine example of the paper, Section 5; it is also
the PWA example of A. Bemporad, G. Ferrari-Trecate and M. Morari, "Observability and
controllability of piecewise affine and hybrid systems", IEEE Trans. Automatic Control
45(10):1864-1876, 2000, and the ``pwa_sincos`` / ``bm99`` example of the MPT toolbox):

    x(t+1) = 0.8 [[cos a(t), -sin a(t)], [sin a(t), cos a(t)]] x(t) + [0; 1] u(t),
    a(t) = +pi/3 if [1 0] x(t) >= 0,   a(t) = -pi/3 if [1 0] x(t) < 0,
    x(t) in [-10, 10] x [-10, 10],     u(t) in [-1, 1].

Modelling choices (all keyword parameters of :func:`build`)
-----------------------------------------------------------
* Output ``y = x2`` (``output_row=(0.0, 1.0)``).  The 1999 paper is a control paper and weights
  the whole state (MPT writes ``C = I`` with ``|y_i| <= 10``); for an observer problem a single
  measured coordinate is needed, and ``y = x2`` is our choice.  With it the system is mirror
  symmetric: ``(x1, x2)`` and ``(-x1, x2)`` give the same output sequence for every input, so
  no state off the line ``x1 = 0`` is observable at any horizon (a useful exact answer).
  ``output_row=(1.0, 0.0)`` measures ``x1`` instead.
* Bounds: ``|x_i| <= 10`` (``state_bound``) and ``|u| <= 1`` (``input_bound``), as in the paper.
* Guards over ``(x1, x2, u)``: mode ``right`` (``a = +angle``) is ``x1 >= 0``, mode ``left``
  (``a = -angle``) is ``x1 <= 0``.  The paper's strict ``x1 < 0`` cannot be written as a closed
  polytope; on the shared boundary ``x1 = 0`` the first mode (``right``) wins, which is the
  paper's rule ``a = +pi/3 if x1 >= 0``.
* Discrete time with unit steps (no sampling period ``Ts``), no affine terms, ``D = 0``.
* The matrices are computed in double precision (``0.8*cos(pi/3) = 0.40000000000000013``), so
  the model files ``examples/models/bemporad_morari_rotation.{toml,json}`` hold those exact
  doubles and equal this builder bit for bit.
"""

from __future__ import annotations

import math

import numpy as np

from hybobs_opt import Polytope, PWAMode, PWASystem

STATES = ("x1", "x2")
INPUTS = ("u",)


def rotation(angle: float, gain: float = 0.8) -> np.ndarray:
    """``gain * [[cos a, -sin a], [sin a, cos a]]``."""
    return gain * np.array([[math.cos(angle), -math.sin(angle)], [math.sin(angle), math.cos(angle)]])


def build(angle: float = math.pi / 3, gain: float = 0.8, state_bound: float = 10.0, input_bound: float = 1.0,
          output_row: tuple[float, float] = (0.0, 1.0)) -> PWASystem:
    """The Bemporad-Morari rotating PWA system (see the module docstring for every choice)."""
    B = np.array([[0.0], [1.0]])
    C = np.array([list(map(float, output_row))])
    xu = STATES + INPUTS
    right = Polytope(np.array([[-1.0, 0.0, 0.0]]), np.array([0.0]), xu)  # x1 >= 0
    left = Polytope(np.array([[1.0, 0.0, 0.0]]), np.array([0.0]), xu)    # x1 <= 0
    modes = (
        PWAMode(A=rotation(angle, gain), B=B, a=np.zeros(2), C=C, guard=right, name="right"),
        PWAMode(A=rotation(-angle, gain), B=B, a=np.zeros(2), C=C, guard=left, name="left"),
    )
    X = Polytope.from_box([-state_bound, -state_bound], [state_bound, state_bound], STATES)
    U = Polytope.from_box([-input_bound], [input_bound], INPUTS)
    return PWASystem(modes, X, U, STATES, INPUTS, ("y",), name="bemporad_morari_rotation")

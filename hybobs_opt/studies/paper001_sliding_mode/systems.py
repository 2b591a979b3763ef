"""The three examples of paper 001 (Djemai, Manamanni, Barbot): switched systems for sliding-mode observers.

- Example 1 (:func:`switched_unstable`): two marginally stable linear subsystems whose combination,
  switched by the sign of ``x1 x2``, is unstable (Remark 1, Fig. 2-3).
- Example 2 (:func:`triangular`): the third-order triangular system (6) whose last equation switches
  between ``F1`` and ``F2`` with the sign of ``x2`` (Fig. 4-6).
- Example 3 (:func:`double_scroll`): the double-scroll piecewise-affine system with ``A_alpha``,
  ``B_beta`` and ``y = x3`` (Fig. 7-9), and its observability canonical form
  (:func:`double_scroll_canonical_form`).

All three are :class:`~hybobs_opt.systems.hybrid.HybridAutomaton` objects whose locations are the
polyhedral regions of the switching function ``sigma``; the locations are state-dependent (no
input), so every scenario is autonomous.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from hybobs_opt.errors import ModelError
from hybobs_opt.sim.trace import Trace
from hybobs_opt.systems.hybrid import Edge, HybridAutomaton, Location
from hybobs_opt.geometry.polytope import Polytope
from hybobs_opt.sim.hybrid import simulate_hybrid

# ---------------------------------------------------------------------------------- Example 1

#: Example 1, paper 001: ``Sigma_1: x1' = -x2, x2' = x1`` and ``Sigma_2: x1' = -x2, x2' = 4 x1``.
SIGMA1 = np.array([[0.0, -1.0], [1.0, 0.0]])
SIGMA2 = np.array([[0.0, -1.0], [4.0, 0.0]])

#: Quadrants I..IV as sign patterns of ``(x1, x2)``, in the order the flows visit them
#: (both subsystems turn counter-clockwise).
_QUADRANT_SIGNS = ((1.0, 1.0), (-1.0, 1.0), (-1.0, -1.0), (1.0, -1.0))
_QUADRANT_LABELS = ("I", "II", "III", "IV")


def switched_unstable(as_printed: bool = False, bound: float = 100.0) -> HybridAutomaton:
    """Example 1 of paper 001: two stable subsystems, unstable when switched (Remark 1, Fig. 2-3).

    ``Sigma_1: x1' = -x2, x2' = x1`` (a centre, circles ``x1^2 + x2^2 = const``) and
    ``Sigma_2: x1' = -x2, x2' = 4 x1`` (a centre, ellipses ``4 x1^2 + x2^2 = const``, angular
    rate 2).  Both are bounded (marginally stable); the paper switches between them with the sign
    of ``sigma(x) = x1 x2``.  ``x1 x2 > 0`` is a union of two quadrants, not a polytope, so the
    automaton has four locations, one per quadrant, named after the active subsystem and the
    quadrant (``Sigma2_I`` is ``Sigma_2`` in quadrant I).  Both flows turn counter-clockwise, so
    the location graph is the cycle ``I -> II -> III -> IV -> I``.

    The printed rule (``Sigma_1 if x1 x2 > 0``, ``Sigma_2 if x1 x2 <= 0``) does *not* give the
    instability the paper reports: following the conserved quantities from ``(1, 0)``, quadrant I
    on the circle reaches ``(0, 1)``, quadrant II on the ellipse reaches ``(-1/2, 0)``, and every
    revolution shrinks the state by 4.  With the two inequalities exchanged, quadrant I on the
    ellipse reaches ``(0, 2)``, quadrant II on the circle ``(-2, 0)``, quadrant III ``(0, -4)``,
    quadrant IV ``(4, 0)`` at ``t = 3 pi / 2``: the state grows by 4 per revolution, which is the
    unstable switched system of Fig. 3.  The default is therefore the exchanged rule
    (``Sigma_2`` where ``x1 x2 >= 0``, ``Sigma_1`` where ``x1 x2 < 0``); the inequalities were
    most likely swapped in the text.

    Parameters
    ----------
    as_printed : bool
        Use the rule as printed (a stable, contracting switched system) instead of the default.
    bound : float
        Half-width of the operating box ``X = [-bound, bound]^2`` (the paper gives none; 100 holds
        the default scenario, whose state reaches about 30 by ``t = 10``).

    Returns
    -------
    HybridAutomaton
        States ``x1, x2``, no input, output ``y = x1`` (the paper gives no output for this example;
        ``x1`` is the measured state of the canonical form (4)).
    """
    if not (np.isfinite(bound) and bound > 0):
        raise ModelError("bound", "a positive finite half-width", repr(bound))
    names = ("x1", "x2")
    locations = []
    for i, (signs, label) in enumerate(zip(_QUADRANT_SIGNS, _QUADRANT_LABELS)):
        product_positive = signs[0] * signs[1] > 0
        use_sigma2 = product_positive != as_printed
        inv = Polytope(-np.diag(signs), np.zeros(2), names)  # sign_i * x_i >= 0
        A = SIGMA2 if use_sigma2 else SIGMA1
        locations.append(Location(f"Sigma{2 if use_sigma2 else 1}_{label}", inv, A=A, C=np.array([[1.0, 0.0]])))
    return HybridAutomaton(
        locations=tuple(locations),
        state_bounds=Polytope.from_box([-bound, -bound], [bound, bound], names),
        edges=tuple(Edge(i, (i + 1) % 4) for i in range(4)),
        state_names=names,
        output_names=("y",),
        name="switched_unstable (paper 001, Example 1)" + (" [printed rule]" if as_printed else ""),
    )


def sigma_switched_unstable(x) -> float:
    """Switching function of Example 1, ``sigma(x) = x1 x2`` (paper 001)."""
    return float(x[0] * x[1])


def _scenario_switched_unstable(system: HybridAutomaton, t_final: float | None = None) -> Trace:
    """Fig. 3 of paper 001 (x1, x2 of the switched system): from ``x0 = (1, 0)``, 10 s.

    The paper prints neither the initial state nor the horizon; ``(1, 0)`` makes the growth easy
    to check by hand (``x = (4, 0)`` at ``t = 3 pi / 2``, ``(16, 0)`` at ``3 pi``), and 10 s shows
    two revolutions.
    """
    t_final = _horizon(t_final, 10.0)
    return simulate_hybrid(system, np.array([1.0, 0.0]), t_final, dt=1e-2)


# ---------------------------------------------------------------------------------- Example 2


def _F1(x: np.ndarray) -> float:
    return -np.cos(30.0 * x[1]) + 0.4


def _F2(x: np.ndarray) -> float:
    return -40.0 * np.cos(300.0 * x[2] + np.pi / 2.0) - 0.5


def triangular(bound_x1: float = 10.0, bound_x2: float = 1.0, bound_x3: float = 1.0) -> HybridAutomaton:
    """Example 2 of paper 001: the triangular input observer system (6) (Fig. 4-6).

    ``x1' = x2``, ``x2' = x3``, ``x3' = F_i(x)``, ``y = x1``, with

    - ``F1 = -cos(30 x2) + 0.4`` where ``x2 < 0`` (location ``F1``),
    - ``F2 = -40 cos(300 x3 + pi/2) - 0.5`` where ``x2 >= 0`` (location ``F2``),

    i.e. the switching function is ``sigma(x) = x2`` (:func:`sigma_triangular`).  The text reads
    "for i = 1, 2, 3" but defines only two dynamics; two locations are built.  The printed
    functions are used as they stand.  Two consequences worth knowing (derived from them):

    - In ``F1`` the pair ``(x2, x3)`` is a conservative oscillator ``x2'' = 0.4 - cos(30 x2)``
      about ``x2 = -acos(0.4)/30 = -0.0386``; a trajectory that enters ``F1`` at ``x2 = 0`` with
      ``x3 = -v`` leaves it at ``x2 = 0`` with ``x3 = +v`` (time reversibility).
    - In ``F2``, ``x3' = 40 sin(300 x3) - 0.5`` is a fast, stiff scalar flow (slope 12000 1/s)
      that locks ``x3`` within milliseconds onto an equilibrium ``300 x3 = pi - asin(1/80) +
      2 pi j``, e.g. ``x3 = 0.01043`` or ``-0.01051``; ``x2`` then drifts linearly.

    Parameters
    ----------
    bound_x1, bound_x2, bound_x3 : float
        Half-widths of the operating box (the paper gives none; the scenario stays well inside).

    Returns
    -------
    HybridAutomaton
        Locations ``F1`` (``x2 <= 0``) and ``F2`` (``x2 >= 0``), nonlinear flows, ``y = x1``.
    """
    for name, value in (("bound_x1", bound_x1), ("bound_x2", bound_x2), ("bound_x3", bound_x3)):
        if not (np.isfinite(value) and value > 0):
            raise ModelError(name, "a positive finite half-width", repr(value))
    names = ("x1", "x2", "x3")
    e2 = np.array([[0.0, 1.0, 0.0]])
    C = np.array([[1.0, 0.0, 0.0]])

    def flow1(x, u):
        return np.array([x[1], x[2], _F1(x)])

    def flow2(x, u):
        return np.array([x[1], x[2], _F2(x)])

    locations = (
        Location("F1", Polytope(e2, np.zeros(1), names), flow=flow1, C=C),
        Location("F2", Polytope(-e2, np.zeros(1), names), flow=flow2, C=C),
    )
    b = np.array([bound_x1, bound_x2, bound_x3])
    return HybridAutomaton(
        locations=locations,
        state_bounds=Polytope.from_box(-b, b, names),
        edges=(Edge(0, 1), Edge(1, 0)),
        state_names=names,
        output_names=("y",),
        name="triangular (paper 001, Example 2)",
    )


def sigma_triangular(x) -> float:
    """Switching function of Example 2, ``sigma(x) = x2`` (``F1`` if negative, ``F2`` otherwise)."""
    return float(x[1])


#: Initial state of the Example 2 scenario (the paper does not print one).  ``x3 = -0.005`` lies in
#: the basin of the ``F2`` equilibrium ``x3 = -0.0105``, so ``x2`` falls from 0.01 to 0 in about
#: 1 s (switch ``F2 -> F1``); the ``F1`` oscillation returns it to ``x2 = 0`` with ``x3 = +0.0105``
#: (switch ``F1 -> F2``), after which ``x3`` locks onto ``+0.0104`` and ``x2`` grows.
TRIANGULAR_X0 = (0.0, 0.01, -0.005)


def _scenario_triangular(system: HybridAutomaton, t_final: float | None = None) -> Trace:
    """Fig. 4-6 of paper 001: free motion of system (6) from :data:`TRIANGULAR_X0` for 3 s (1 ms samples)."""
    t_final = _horizon(t_final, 3.0)
    return simulate_hybrid(system, np.array(TRIANGULAR_X0), t_final, dt=1e-3)


# ---------------------------------------------------------------------------------- Example 3

#: Entries of ``A_alpha`` and ``B_beta`` in Example 3, paper 001 (Chua's double scroll, with the
#: parameters 9 and 100/7 of the classical circuit):
#: ``A_alpha = [[alpha, 9, 0], [1, -1, 1], [0, -100/7, 0]]``, ``B_beta = [beta, 0, 0]'``.
DOUBLE_SCROLL_A2 = 9.0  # a2 of the canonical-form derivation (row 1, column 2)
DOUBLE_SCROLL_C1 = -100.0 / 7.0  # c1: x3' = c1 x2

#: ``(alpha, beta)`` of the three locations: ``A1 = A_{-18/7}, B1 = B_{27/7}`` for ``x1 >= 1``,
#: ``A2 = A_{9/7}, B2 = B_0`` for ``|x1| < 1``, ``A3 = A_{-18/7}, B3 = B_{-27/7}`` for ``x1 <= -1``.
DOUBLE_SCROLL_ALPHA_BETA = ((-18.0 / 7.0, 27.0 / 7.0), (9.0 / 7.0, 0.0), (-18.0 / 7.0, -27.0 / 7.0))


def A_alpha(alpha: float) -> np.ndarray:
    """``A_alpha`` of Example 3, paper 001."""
    return np.array([[alpha, DOUBLE_SCROLL_A2, 0.0], [1.0, -1.0, 1.0], [0.0, DOUBLE_SCROLL_C1, 0.0]])


def B_beta(beta: float) -> np.ndarray:
    """``B_beta = [beta, 0, 0]'`` of Example 3, paper 001 (a constant drift, there is no input)."""
    return np.array([beta, 0.0, 0.0])


def double_scroll(bounds: tuple[float, float, float] = (3.0, 1.0, 5.0)) -> HybridAutomaton:
    """Example 3 of paper 001: the double-scroll PWA system (Fig. 7), ``y = x3``.

    ``x' = A1 x + B1`` if ``x1 >= 1`` (location ``q1``), ``A2 x + B2`` if ``|x1| < 1`` (``q2``),
    ``A3 x + B3`` if ``x1 <= -1`` (``q3``), with ``A_alpha``, ``B_beta`` and the values of
    :data:`DOUBLE_SCROLL_ALPHA_BETA`; output ``y = C x = x3``.  This is Chua's circuit
    ``x1' = 9 (x2 - x1 - g(x1))``, ``x2' = x1 - x2 + x3``, ``x3' = -(100/7) x2`` with the
    piecewise-linear diode ``g`` of slopes ``-8/7`` (inner) and ``-5/7`` (outer): ``9 (-1 + 8/7) =
    9/7``, ``9 (-1 + 5/7) = -18/7`` and ``9 * 3/7 = 27/7``, which confirms the printed entries.
    The flow is continuous across ``x1 = +-1``; the switching function is ``sigma(x) = x1``.

    Parameters
    ----------
    bounds : (float, float, float)
        Half-widths of the operating box ``X``.  The paper gives none; the attractor lies within
        about ``|x1| <= 2.6``, ``|x2| <= 0.55``, ``|x3| <= 3.8``.

    Returns
    -------
    HybridAutomaton
        Affine in every location, autonomous (no input), so ``discretize(Ts)`` applies.
    """
    b = np.asarray(bounds, dtype=float)
    if b.shape != (3,) or not np.all(np.isfinite(b)) or np.any(b <= 0.0) or b[0] <= 1.0:
        raise ModelError("bounds", "three finite half-widths, the first above 1 (the switching planes)", repr(bounds))
    names = ("x1", "x2", "x3")
    e1 = np.array([[1.0, 0.0, 0.0]])
    invariants = (
        Polytope(-e1, np.array([-1.0]), names),
        Polytope(np.vstack([e1, -e1]), np.array([1.0, 1.0]), names),
        Polytope(e1, np.array([-1.0]), names),
    )
    C = np.array([[0.0, 0.0, 1.0]])
    locations = tuple(
        Location(f"q{i + 1}", inv, A=A_alpha(a), E=B_beta(beta), C=C)
        for i, (inv, (a, beta)) in enumerate(zip(invariants, DOUBLE_SCROLL_ALPHA_BETA))
    )
    return HybridAutomaton(
        locations=locations,
        state_bounds=Polytope.from_box(-b, b, names),
        edges=(Edge(0, 1), Edge(1, 0), Edge(1, 2), Edge(2, 1)),
        state_names=names,
        output_names=("y",),
        name="double_scroll (paper 001, Example 3)",
    )


def sigma_double_scroll(x) -> float:
    """Switching function of Example 3, ``sigma(x) = x1`` (``q1`` if ``>= 1``, ``q3`` if ``<= -1``)."""
    return float(x[0])


@dataclass(frozen=True)
class CanonicalForm:
    """Observability canonical form of Example 3 (paper 001): ``z = T x``.

    In ``z`` the system reads ``z1' = z2``, ``z2' = z3``, ``z3' = P_i(z) = p_i . z + beta_i``
    with ``y = z1`` and ``sigma(z) = s . z`` choosing ``P1`` (``sigma >= 1``), ``P2``
    (``|sigma| < 1``) or ``P3`` (``sigma <= -1``).

    Attributes
    ----------
    T : (3, 3) array
        ``z = T x``.
    T_inv : (3, 3) array
        ``x = T_inv z``.
    P : tuple of three (4,) arrays
        ``(alpha1, alpha2, alpha3, beta)`` of ``P1, P2, P3``.
    sigma : (3,) array
        Coefficients ``s`` of ``sigma(z) = (z3 + z2)/c1 - z1``.
    """

    T: np.ndarray
    T_inv: np.ndarray
    P: tuple[np.ndarray, np.ndarray, np.ndarray]
    sigma: np.ndarray


#: ``P1, P2, P3`` exactly as printed in paper 001 (Example 3), ``(alpha1, alpha2, alpha3, beta)``.
#: Two entries contradict the paper's own formulas, see :func:`double_scroll_canonical_form`.
P_PRINTED = (
    (-1800.0 / 49.0, -55.0 / 7.0, -25.0 / 7.0, 2700.0 / 49.0),
    (100.0 / 49.0, -36.0 / 7.0, -6.0 / 7.0, 0.0),
    (-1800.0 / 49.0, -55.0 / 7.0, -25.0 / 7.0, 2700.0 / 49.0),
)

#: ``P1, P2, P3`` from the paper's formulas ``alpha1 = -a1 c1``, ``alpha2 = a1 + a2 + c1``,
#: ``alpha3 = a1 - 1``, ``beta = a3 c1`` with ``a2 = 9``, ``c1 = -100/7`` and ``(a1, a3)`` from
#: :data:`DOUBLE_SCROLL_ALPHA_BETA` (worked by hand, kept as literals):
#: ``P1``: ``a1 = -18/7, a3 = 27/7`` -> ``(-1800/49, -55/7, -25/7, -2700/49)``;
#: ``P2``: ``a1 = 9/7, a3 = 0`` -> ``(900/49, -4, 2/7, 0)``;
#: ``P3``: ``a1 = -18/7, a3 = -27/7`` -> ``(-1800/49, -55/7, -25/7, 2700/49)``.
P_DERIVED = (
    (-1800.0 / 49.0, -55.0 / 7.0, -25.0 / 7.0, -2700.0 / 49.0),
    (900.0 / 49.0, -4.0, 2.0 / 7.0, 0.0),
    (-1800.0 / 49.0, -55.0 / 7.0, -25.0 / 7.0, 2700.0 / 49.0),
)


def double_scroll_canonical_form(printed: bool = False) -> CanonicalForm:
    """Canonical (observability) form data of Example 3, as given in paper 001.

    The paper writes the system as ``x1' = a1 x1 + a2 x2 + a3``, ``x2' = x1 - x2 + x3``,
    ``x3' = c1 x2`` and uses the diffeomorphism

    ``z = T x`` with ``T = [[0, 0, 1], [0, c1, 0], [c1, -c1, c1]]`` (``z1 = y``, ``z2 = y'``,
    ``z3 = y''``) and ``x = T_inv z``, ``T_inv = [[-1, 1/c1, 1/c1], [0, 1/c1, 0], [1, 0, 0]]``,

    which gives ``z3' = alpha1 z1 + alpha2 z2 + alpha3 z3 + beta`` with ``alpha1 = -a1 c1``,
    ``alpha2 = a1 + a2 + c1``, ``alpha3 = a1 - 1``, ``beta = a3 c1`` (checked by hand) and the
    switching function ``sigma(z) = (z3 + z2)/c1 - z1`` (``= x1``).

    Parameters
    ----------
    printed : bool
        ``False`` (default): ``P1, P2, P3`` of :data:`P_DERIVED`, the paper's formulas applied to
        its own ``A_alpha, B_beta``.  ``True``: :data:`P_PRINTED`, the numbers as printed, which
        disagree in two places: the printed ``P1`` and ``P3`` are identical (``+2700/49``), but
        ``beta = a3 c1`` has opposite signs for ``B1 = 27/7`` and ``B3 = -27/7``, so ``P1``'s
        constant is ``-2700/49``; and the printed ``P2 = (100/49, -36/7, -6/7)`` is what the
        formulas give for ``a1 = 1/7``, not for the printed ``A2 = A_{9/7}`` (``(900/49, -4, 2/7)``).

    Returns
    -------
    CanonicalForm
    """
    c1 = DOUBLE_SCROLL_C1
    T = np.array([[0.0, 0.0, 1.0], [0.0, c1, 0.0], [c1, -c1, c1]])
    T_inv = np.array([[-1.0, 1.0 / c1, 1.0 / c1], [0.0, 1.0 / c1, 0.0], [1.0, 0.0, 0.0]])
    P = tuple(np.array(p) for p in (P_PRINTED if printed else P_DERIVED))
    return CanonicalForm(T=T, T_inv=T_inv, P=P, sigma=np.array([-1.0, 1.0 / c1, 1.0 / c1]))


#: Initial state of the Example 3 scenario.  The paper does not print one; ``(0.1, 0, 0)`` starts
#: near the origin, an unstable equilibrium of ``q2`` (eigenvalues 2.22 and -0.97 +- 2.71i), and
#: the trajectory then alternates between the scrolls around ``x1 = +-1.5`` (in 50 s it spends
#: roughly half of the time on each side of ``x1 = 0``).
DOUBLE_SCROLL_X0 = (0.1, 0.0, 0.0)


def _scenario_double_scroll(system: HybridAutomaton, t_final: float | None = None) -> Trace:
    """Fig. 7 of paper 001 (phase portrait): free motion from :data:`DOUBLE_SCROLL_X0` for 50 s (10 ms samples)."""
    t_final = _horizon(t_final, 50.0)
    return simulate_hybrid(system, np.array(DOUBLE_SCROLL_X0), t_final, dt=1e-2)


# ---------------------------------------------------------------------------------- registry


def _horizon(t_final: float | None, default: float) -> float:
    t_final = default if t_final is None else float(t_final)
    if not (np.isfinite(t_final) and t_final > 0):
        raise ModelError("t_final", "a positive finite time", repr(t_final))
    return t_final

"""The two water tanks with a switched hose: a two-location hybrid automaton (the classic Zeno example).

Source
------
J. Lygeros, K. H. Johansson, S. N. Simic, J. Zhang and S. S. Sastry, "Dynamical properties of
hybrid automata", IEEE Trans. Automatic Control 48(1):2-17, 2003, Section II, the water tank
system (after R. Alur and T. A. Henzinger, "Modularity for timed and hybrid systems", CONCUR 1997).
Two tanks with levels x1, x2 lose water at constant rates v1, v2; a hose delivers water at rate w
into one tank at a time and is switched instantaneously.  To keep x1 >= r1 and x2 >= r2:

    location q1 (hose on tank 1):  x1' = w - v1,  x2' = -v2,      invariant x2 >= r2
    location q2 (hose on tank 2):  x1' = -v1,     x2' = w - v2,   invariant x1 >= r1
    edges: q1 -> q2 with guard x2 <= r2,  q2 -> q1 with guard x1 <= r1,  identity resets.

For max(v1, v2) < w < v1 + v2 the total volume decreases while the switching times accumulate:
the executions are Zeno (the point of the example in the paper).

Modelling choices (all keyword parameters of :func:`build`)
-----------------------------------------------------------
* The paper keeps w, v1, v2, r1, r2 symbolic; the numbers here are ours: w = 0.75, v1 = v2 = 0.5
  (the Zeno regime 0.5 < 0.75 < 1), r1 = r2 = 0.5.
* Output ``y = x1`` (only tank 1 is measured; ``measured=("x1", "x2")`` measures both): the paper
  has no output.  With y = x1 the location is seen in the slope of y (w - v1 or -v1), and x2 only
  through the switching instants (x2 = r2 when q1 -> q2).
* Operating set (ours): both levels in [0, 2] (``level_max``).  The invariants overlap (in the
  region x1 >= r1, x2 >= r2 both locations are possible: the location is memory, not a function of
  the state), so this automaton cannot be handed to ``discretize()`` as a PWA partition.
* Flows are affine with a constant term (``A = 0``, ``E`` the drift), no input; outputs linear.
* Guards are closed (``x2 <= r2``): hybobs_opt polytopes do not distinguish strict inequalities.
"""

from __future__ import annotations

import numpy as np

from hybobs_opt import Edge, HybridAutomaton, Location, Polytope

STATES = ("x1", "x2")


def _half_space(k: int, sign: float, bound: float) -> Polytope:
    """``x_k >= bound`` (``sign = -1``) or ``x_k <= bound`` (``sign = +1``) as one row ``a x <= b``."""
    a = np.zeros((1, 2))
    a[0, k] = sign
    return Polytope(a, np.array([sign * float(bound)]), STATES)


def build(w: float = 0.75, v1: float = 0.5, v2: float = 0.5, r1: float = 0.5, r2: float = 0.5,
          level_max: float = 2.0, measured: tuple[str, ...] = ("x1",)) -> HybridAutomaton:
    """The water-tank automaton of Lygeros et al. (see the module docstring for every choice)."""
    C = np.array([[1.0 if s == name else 0.0 for s in STATES] for name in measured])
    A = np.zeros((2, 2))
    q1 = Location("q1", _half_space(1, -1.0, r2), A=A, E=np.array([w - v1, -v2]), C=C)
    q2 = Location("q2", _half_space(0, -1.0, r1), A=A, E=np.array([-v1, w - v2]), C=C)
    edges = (Edge(0, 1, guard=_half_space(1, 1.0, r2)), Edge(1, 0, guard=_half_space(0, 1.0, r1)))
    X = Polytope.from_box([0.0, 0.0], [level_max, level_max], STATES)
    return HybridAutomaton((q1, q2), X, edges, None, STATES, (), tuple(f"{s}_meas" for s in measured),
                           name="water_tanks")

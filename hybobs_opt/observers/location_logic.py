"""Location identification logic of the location observer of paper 000 (Balluchi et al.), Section 3.1.

*Location identification logic* (the "critical cases" at the end of Section 3.1): a location is a
*candidate* when the residual of its generator is below threshold and the generator's state lies
in the location's invariant, up to the margin the design guarantees after ``Delta`` (so the true
location is always a candidate ``Delta`` after it is entered).  Candidates are restricted to the
current location and its successors in the automaton's graph.  Several candidates (several
``sigma_j`` true; or one ``sigma_j`` shared by several locations that the invariants do not
separate) is reported as *ambiguity* with the candidate set, never resolved by guessing; the
continuous observer then keeps the last identified location.

Proposition 3.1.3 names the input that defeats it: :func:`prop_3_1_3_matrix`.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..systems.hybrid import HybridAutomaton

__all__ = ["AMBIGUOUS", "IDENTIFIED", "NO_CANDIDATE", "LocationDecision", "LocationLogic", "prop_3_1_3_matrix"]

# Decision statuses of the identification logic.
IDENTIFIED = "identified"
AMBIGUOUS = "ambiguous"
NO_CANDIDATE = "none"


# ============================================================================ identification logic
@dataclass(frozen=True)
class LocationDecision:
    """Output of the location identification logic at one sample.

    Attributes
    ----------
    location : int
        The identified location, ``-1`` when ambiguous or when no location is consistent.
    held : int
        The location the continuous observer uses: the last identified one (``-1`` before any).
    candidates : tuple of int
        The consistent locations among the current one and its successors.
    status : str
        ``"identified"``, ``"ambiguous"`` or ``"none"``.
    """

    location: int
    held: int
    candidates: tuple[int, ...]
    status: str


class LocationLogic:
    """Location identification logic (end of Section 3.1 of paper 000), deterministic.

    At each sample, from the per-location consistency flags (``sigma`` of the location's
    generator and its invariant test):

    1. the candidates are the consistent locations among the current estimate and its successors
       in the automaton's graph (all locations before the first identification);
    2. one candidate: it is the estimate (a change when it differs from the current one);
    3. several candidates -- the paper's two critical cases (several ``sigma_j`` true; one
       ``sigma_j`` shared by locations the invariants do not separate): *ambiguous*, the
       estimate is ``-1`` and the candidates are reported; the held location does not change;
    4. no candidate: a change is under way (every residual of the allowed locations is still
       above threshold); the held location does not change.  After ``stale_steps`` samples
       without a candidate the current location is forgotten and all locations are searched
       (the true one is a candidate ``Delta`` after it is entered, so a longer gap means the
       estimate is stale).

    Parameters
    ----------
    automaton : HybridAutomaton
    stale_steps : int
        Samples without any candidate before the search widens to all locations.
    q0 : int, optional
        Known initial location.
    """

    def __init__(self, automaton: HybridAutomaton, stale_steps: int, q0: int | None = None):
        self.automaton = automaton
        self.stale_steps = max(int(stale_steps), 1)
        self._succ = tuple(tuple(sorted(set(automaton.successors(q)) - {q})) for q in range(automaton.n_locations))
        self.reset(q0)

    def reset(self, q0: int | None = None) -> None:
        if q0 is not None and (isinstance(q0, bool) or not (isinstance(q0, (int, np.integer))
                                                            and 0 <= q0 < self.automaton.n_locations)):
            raise ModelError("q0", f"a location index in 0..{self.automaton.n_locations - 1} or None", repr(q0))
        self.current: int | None = None if q0 is None else int(q0)
        self.held = -1 if q0 is None else int(q0)
        self._none_count = 0

    def update(self, consistent: Sequence[bool]) -> LocationDecision:
        """One sample: ``consistent[q]`` tells whether location ``q`` is consistent with the data."""
        if self.current is None:
            allowed: tuple[int, ...] = tuple(range(self.automaton.n_locations))
        else:
            allowed = (self.current, *self._succ[self.current])
        cands = tuple(q for q in allowed if consistent[q])
        if len(cands) == 1:
            self.current = self.held = cands[0]
            self._none_count = 0
            return LocationDecision(cands[0], self.held, cands, IDENTIFIED)
        if len(cands) > 1:
            self._none_count = 0
            return LocationDecision(-1, self.held, cands, AMBIGUOUS)
        self._none_count += 1
        if self.current is not None and self._none_count >= self.stale_steps:
            self.current = None
        return LocationDecision(-1, self.held, cands, NO_CANDIDATE)


def prop_3_1_3_matrix(automaton: HybridAutomaton, i: int, j: int) -> np.ndarray:
    """The matrix of Proposition 3.1.3 of paper 000 for the plant in ``i`` and the generator of ``j``.

    From eqs. (11)-(12), ``r_j' = ... + (C_j B_j - C_i B_i) u``, i.e. ``C_ji B_i + C_j B_ji`` with
    ``C_ji = C_j - C_i`` and ``B_ji = B_j - B_i`` (the signs of eq. (11)-(12) made consistent).  When
    it is invertible (and ``D = 0``), an input can hold ``r_j`` at zero while the plant is in ``i``:
    the wrong residual stays below threshold (a sliding motion on ``r_j = 0``).
    """
    li, lj = automaton.locations[i], automaton.locations[j]
    return lj.C @ lj.B - li.C @ li.B

"""Set difference of two polytopes, as full-dimensional closed pieces.

``R \\ Q`` is written as the pieces ``R ∩ {q_i z >= b_i} ∩ {q_k z <= b_k, k < i}`` for the rows
``q_i z <= b_i`` of ``Q`` (each point of ``R`` outside ``Q`` violates a first row ``i``); the
pieces have disjoint interiors.  Pieces whose Chebyshev radius is at most
:data:`~hybobs_opt.tolerances.FULL_DIMENSION_RTOL` (in coordinates ``z / scale``) are dropped, so
the difference is exact up to sets of zero measure, as the unions of paper 002 need it.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from .polytope import Polytope


def polytope_difference(R: Polytope, Q: Polytope, scale: np.ndarray, *, irredundant: bool = True,
                        interior_test: Callable[[Polytope], bool] | None = None) -> list[Polytope]:
    """Full-dimensional pieces of ``R \\ Q`` (closures), by reversing ``Q``'s rows one at a time.

    Parameters
    ----------
    R : Polytope
        The set to subtract from.
    Q : Polytope
        The set subtracted (same dimension).
    scale : (d,) ndarray
        Per-coordinate scale of the full-dimensionality tests
        (:meth:`Polytope.is_full_dimensional`).
    irredundant : bool, default True
        Remove the redundant rows of each piece (:meth:`Polytope.remove_redundant`).  ``False``
        keeps ``R``'s rows and the reversed and kept rows of ``Q``: the same sets, for a caller that
        only tests them (a partition proof), without the vertex enumeration of each piece.
    interior_test : callable, optional
        ``interior_test(P) -> bool``: whether ``P`` is full-dimensional, for a caller with a
        cheaper certified test of its own sets (the partition proof); default
        ``P.is_full_dimensional(scale)``.

    Returns
    -------
    list of Polytope
        Pieces (irredundant unless asked otherwise) whose union is the closure of ``R \\ Q`` up
        to lower-dimensional sets; ``[R]`` when ``R`` and ``Q`` share no interior.

    See Also
    --------
    Polytope : the pieces.

    Examples
    --------
    The square ``[-1, 1]^2`` minus the centred square of half its side: four pieces, whose areas
    add up to 4 - 1 = 3:

    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope, polytope_difference
    >>> outer = Polytope.from_box([-1.0, -1.0], [1.0, 1.0])
    >>> inner = Polytope.from_box([-0.5, -0.5], [0.5, 0.5])
    >>> pieces = polytope_difference(outer, inner, np.ones(2))
    >>> len(pieces), round(sum(piece.volume().value for piece in pieces), 6)
    (4, 3.0)
    """
    if interior_test is None:
        interior_test = lambda P: P.is_full_dimensional(scale)  # noqa: E731
    if not interior_test(R.intersect(Q)):
        return [R]
    pieces = []
    for i in range(Q.n_constraints):
        A = np.vstack([R.A, -Q.A[i : i + 1], Q.A[:i]])
        b = np.concatenate([R.b, -Q.b[i : i + 1], Q.b[:i]])
        piece = Polytope(A, b, R.names)
        if interior_test(piece):
            pieces.append(piece.remove_redundant(scale) if irredundant else piece)
    return pieces

"""The pieces of ``B_T`` found by Algorithm 3.1 of paper 002, stored compactly.

A piece is a pair set ``R_ij`` (Algorithm 3.1, step 3, of paper 002: ``(x, U)`` in ``P_i``, ``(x^, U)`` in
``P_j``, equal outputs), fully determined by the two regions of eq. (4).  Its constraints
(:func:`pair_constraints`, a few tens of kB at ``T = 10``) are therefore not stored: a
:class:`PairSets` keeps ``(i, j)`` as 32-bit integers and the Chebyshev radius of each piece
(16 bytes a piece) and builds the :class:`PairSet` of a piece when it is read.  The lists of
pairs that the tests left out (thin, same-state, ruled out by a group) are :class:`PairList`:
one integer array, read as ``(i, j)`` tuples.
"""

from __future__ import annotations

from collections.abc import Iterator, Sequence
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError

@dataclass(frozen=True, eq=False)
class PairSet:
    """A non-empty ``R_ij`` with full-dimensional projection, as constraints in original coordinates.

    ``G [x; x^; U] <= g`` and ``E [x; x^; U] = e``; ``slack`` is its Chebyshev radius inside the
    equality subspace, in scaled coordinates.

    Parameters
    ----------
    i, j : int
        Indices of the two regions (``i`` in ``I``, ``j != i``).
    G, g : arrays
        Inequalities over ``[x; x^; U]``.
    E, e : arrays
        Equalities over ``[x; x^; U]`` (equal outputs).
    slack : float
        The Chebyshev radius above.

    See Also
    --------
    ObservabilityAnalysis.pairs : the pair sets of an analysis.
    PairVerdict : what the test of one pair decides.

    Examples
    --------
    At ``T = 4`` the rank test leaves pairs of regions whose outputs can agree; each kept pair set
    ``R_ij`` is a piece of ``B_T``:

    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> analysis = analyse_observability(get_example("powertrain3").build(gear_ratio=1 / 2), 4)
    >>> len(analysis.pairs)
    32
    >>> pair = analysis.pairs[0]
    >>> (pair.i, pair.j), pair.G.shape, pair.E.shape     # G [x; x^; U] <= g, E [x; x^; U] = e
    ((6, 8), (69, 10), (4, 10))
    """

    i: int
    j: int
    G: np.ndarray
    g: np.ndarray
    E: np.ndarray
    e: np.ndarray
    slack: float



def pair_constraints(ri, rj, n: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Constraints of ``R_ij`` over ``(x, x^, U)``: ``G z <= g`` (P_i, P_j) and ``E z = e`` (equal outputs)."""
    kI, kJ = ri.H.shape[0], rj.H.shape[0]
    G = np.zeros((kI + kJ, n + ri.H.shape[1]))
    G[:kI, :n] = ri.H[:, :n]
    G[:kI, 2 * n :] = ri.H[:, n:]
    G[kI:, n:] = rj.H
    g = np.concatenate([ri.h, rj.h])
    E = np.empty((ri.C.shape[0], G.shape[1]))
    E[:, :n] = ri.C
    E[:, n : 2 * n] = -rj.C
    E[:, 2 * n :] = ri.D - rj.D
    e = rj.f - ri.f
    return G, g, E, e


def _index_array(ij, what: str) -> np.ndarray:
    """``ij`` as a read-only ``(k, 2)`` int32 array (region indices are far below 2**31)."""
    a = np.asarray(ij if len(ij) else np.zeros((0, 2)), dtype=np.int64).reshape(-1, 2)
    if a.size and (a.min() < 0 or a.max() > np.iinfo(np.int32).max):
        raise ModelError(what, "region indices in [0, 2**31)", f"values in [{a.min()}, {a.max()}]")
    out = np.ascontiguousarray(a, dtype=np.int32)
    out.flags.writeable = False
    return out


class PairList(Sequence):
    """Ordered pairs ``(i, j)`` of region indices held as one ``(k, 2)`` int32 array.

    Reads like a tuple of ``(int, int)`` tuples (indexing, iteration, ``len``, ``set(...)``,
    ``==`` with another ``PairList`` or any sequence of pairs) at 8 bytes a pair instead of about
    100 for a tuple of two Python integers.

    Parameters
    ----------
    ij : (k, 2) array_like of int
        The pairs, in the order they are to be read.

    See Also
    --------
    PairSets : the pieces of ``B_T``, whose indices are a ``PairList``.
    hybobs_opt.regions.ObservabilityAnalysis : its ``stats`` hold the left-out pair lists as ``PairList``.

    Examples
    --------
    >>> from hybobs_opt.regions import PairList
    >>> pairs = PairList.sorted([[3, 1], [0, 2]])
    >>> list(pairs), pairs[0], len(pairs), pairs == ((0, 2), (3, 1))
    ([(0, 2), (3, 1)], (0, 2), 2, True)
    """

    __slots__ = ("_ij",)

    def __init__(self, ij=()):
        self._ij = _index_array(ij, "pairs")

    @classmethod
    def sorted(cls, ij) -> "PairList":
        """The pairs in lexicographic order of ``(i, j)``.

        Returns
        -------
        PairList
            A new list; ``ij`` is not changed.
        """
        a = _index_array(ij, "pairs")
        return cls(a[np.lexsort((a[:, 1], a[:, 0]))] if a.shape[0] > 1 else a)

    @property
    def array(self) -> np.ndarray:
        """The ``(k, 2)`` int32 array (read-only)."""
        return self._ij

    def __len__(self) -> int:
        return self._ij.shape[0]

    def __getitem__(self, k):
        if isinstance(k, slice):
            return PairList(self._ij[k])
        i, j = self._ij[k]
        return int(i), int(j)

    def __iter__(self) -> Iterator[tuple[int, int]]:
        return iter([tuple(p) for p in self._ij.tolist()])

    def __eq__(self, other) -> bool:
        if isinstance(other, PairList):
            return np.array_equal(self._ij, other._ij)
        if isinstance(other, (tuple, list)):
            return len(other) == len(self) and all(tuple(a) == b for a, b in zip(other, self))
        return NotImplemented

    __hash__ = None

    def __repr__(self) -> str:
        return f"PairList({list(self)!r})" if len(self) <= 6 else f"PairList(<{len(self)} pairs>)"

    def __reduce__(self):
        return PairList, (self._ij,)


class PairSets(Sequence):
    """The pieces ``R_ij`` of ``B_T``: ``(i, j)`` and the radius of each, the constraints built when read.

    ``pairs[k]`` is the :class:`PairSet` of the ``k``-th piece, its ``G, g, E, e`` computed then
    from the two regions (:func:`pair_constraints`, bit for bit what a stored one would hold);
    nothing of it is kept, so an analysis holds 16 bytes a piece whatever the horizon.  Code
    that only needs the indices reads :attr:`ij` and :attr:`slacks` without building any.

    Parameters
    ----------
    regions : sequence of ModeRegion
        The regions of eq. (4) the indices refer to.
    n : int
        State dimension.
    ij : (k, 2) array_like of int
        The pieces' ``(i, j)``.
    slacks : (k,) array_like of float
        Their Chebyshev radii (scaled, see :class:`PairSet`).

    See Also
    --------
    PairSet : one piece, with its constraints.
    PairList : the indices alone.
    hybobs_opt.regions.analyse_observability : the analysis whose ``pairs`` this is.

    Examples
    --------
    >>> from hybobs_opt import get_example
    >>> from hybobs_opt.regions import analyse_observability
    >>> pairs = analyse_observability(get_example("powertrain3").build(gear_ratio=1 / 2), 4).pairs
    >>> len(pairs), pairs.ij[0], pairs[0].G.shape        # indices stored, constraints built on access
    (32, (6, 8), (69, 10))
    """

    __slots__ = ("_regions", "_n", "_ij", "_slacks")

    def __init__(self, regions, n: int, ij=(), slacks=()):
        self._regions = regions
        self._n = int(n)
        self._ij = PairList(ij)
        s = np.array(slacks, dtype=float).reshape(-1)
        if s.shape[0] != len(self._ij):
            raise ModelError("slacks", f"one radius per pair ({len(self._ij)})", f"{s.shape[0]} radii")
        s.flags.writeable = False
        self._slacks = s

    @classmethod
    def from_pairs(cls, regions, n: int, pairs) -> "PairSets":
        """The compact form of pieces given as :class:`PairSet` objects (or anything with ``i, j, slack``).

        Returns
        -------
        PairSets
            The same pieces, in the same order; their constraints are rebuilt from ``regions`` when read.
        """
        pairs = list(pairs)
        return cls(regions, n, [(p.i, p.j) for p in pairs], [p.slack for p in pairs])

    @property
    def ij(self) -> PairList:
        """The ``(i, j)`` of every piece, in order."""
        return self._ij

    @property
    def slacks(self) -> np.ndarray:
        """The radius of every piece, in order (read-only)."""
        return self._slacks

    def subset(self, mask) -> "PairSets":
        """The pieces where the boolean ``mask`` holds, in order.

        Returns
        -------
        PairSets
            A new collection over the same regions.
        """
        mask = np.asarray(mask)
        if mask.dtype != bool or mask.shape != (len(self),):
            raise ModelError("mask", f"a boolean array of {len(self)} entries, one per piece",
                             f"{mask.dtype} array of shape {mask.shape}")
        return PairSets(self._regions, self._n, self._ij.array[mask], self._slacks[mask])

    def __len__(self) -> int:
        return len(self._ij)

    def __getitem__(self, k):
        if isinstance(k, slice):
            return PairSets(self._regions, self._n, self._ij.array[k], self._slacks[k])
        i, j = self._ij[k]
        return PairSet(i, j, *pair_constraints(self._regions[i], self._regions[j], self._n), float(self._slacks[k]))

    def __iter__(self) -> Iterator[PairSet]:
        for k in range(len(self)):
            yield self[k]

    def __repr__(self) -> str:
        return f"PairSets(<{len(self)} pieces>)"


__all__ = ["PairList", "PairSet", "PairSets", "pair_constraints"]

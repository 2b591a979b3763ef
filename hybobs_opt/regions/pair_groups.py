"""Grouped pair tests of Algorithm 3.1 (paper 002): one pair set of two prefix supersets rules out a family of pairs.

The regions below a mode-sequence prefix all lie in its superset
(:class:`~hybobs_opt.regions.enumeration.PrefixSuperset`: the prefix's rows, the domain at the
next step, the input box after it, and the output rows they share).  So the pair set of two
supersets ``A`` and ``B``, ``S_AB = {(x, x^, U) : (x, U) in A, (x^, U) in B, equal shared
outputs}``, contains every ``R_ij`` with ``i`` below ``A`` and ``j`` below ``B``: when
:func:`~hybobs_opt.regions.pair_geometry.classify_pair` finds the projection of ``S_AB`` on
``x`` empty, lower-dimensional (thin, certified) or confined to ``x^ = x``, the projection of
every such ``R_ij`` is too, and none of them is a piece of ``B_T``; likewise on ``x^`` for the
``R_ji``.  Each verdict is a property of the set that subsets inherit (an empty set, a certified
width along a direction, a certified ``|x - x^|`` bound, the rank of an affine hull), so the
pieces found are those of the pair-by-pair tests.  What the groups do not give is the kind of
each pair they rule out (empty, thin or same-state): those pairs are listed apart
(``pairs_ruled_out_by_group``); ``analyse_observability(..., group_tests=False)`` classifies
every pair one by one.

Levels run from the shortest prefix to the longest (``T - 1``: the last mode free, which for
the powertrains changes no output); a group is tested when it holds at least two pairs still
undecided that fall into at least two groups of the next level (else the next level's test is
as cheap and tighter).  The shortest prefix is ``ceil(n / p) - 2`` modes (at least 1): with fewer
shared outputs the sets were never ruled out on model (17).

The LP counts with and without groups are measured in ``benchmarks/results/regions.json``
(``model17_long_horizons``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from .pair_algebra import PairAlgebra, distinct_ints, scaled_rows
from .pair_geometry import classify_pair
from .verdicts import PairVerdict


@dataclass(eq=False)
class GroupLevel:
    """The supersets of one prefix length: their :class:`PairAlgebra` and the superset of each region."""

    depth: int
    algebra: PairAlgebra
    index: np.ndarray


def group_depths(T: int, n: int, p: int) -> list[int]:
    """Prefix lengths of the group tests for horizon ``T``, shortest first (see the module docstring)."""
    shortest = max(1, math.ceil(n / p) - 2)
    return list(range(shortest, T))


@dataclass(frozen=True, slots=True)
class GroupLevelRows:
    """What the pair-test tasks need of one prefix length: the data a :class:`GroupLevel` is built from.

    ``rows`` are the supersets' rows and output maps in scaled coordinates
    (:func:`~hybobs_opt.regions.pair_algebra.scaled_rows`), or those packed into one buffer
    (:func:`~hybobs_opt.regions.pair_algebra.pack_scaled`) for the worker processes;
    ``index[k]`` is the superset of region ``k``.
    """

    depth: int
    rows: list | bytes
    index: np.ndarray


def group_level_data(enum, depths) -> list[GroupLevelRows]:
    """Per prefix length, its :class:`GroupLevelRows` (scaled superset rows, region -> superset).

    Prefix lengths whose regions do not share their leading output rows are skipped.
    """
    from .enumeration import prefix_supersets

    n = enum.system.n
    out = []
    nodes: dict = {}  # the prefix tree's nodes, shared by the depths
    for depth in depths:
        built = prefix_supersets(enum, depth, nodes)
        if built is None:
            continue
        supersets, index = built
        out.append(GroupLevelRows(depth, scaled_rows(supersets, n, enum.scale, enum.centre), index))
    return out


def rule_out_by_groups(levels: list[GroupLevel], caller: np.ndarray, other: np.ndarray, want_ij: np.ndarray,
                       want_ji: np.ndarray) -> tuple[np.ndarray, int]:
    """Run the group tests over the candidate pairs ``(caller[k], other[k])``; clears the wants they decide.

    ``want_ij[k]``: ``R_ij`` (projection on ``x`` of the caller's region) is still to be decided;
    ``want_ji[k]``: ``R_ji`` too (the same set, projected on ``x^``).  Both arrays are updated in
    place.  Returns the ordered pairs ruled out (``(i, j)`` for ``R_ij``, ``(j, i)`` for ``R_ji``)
    as a ``(k, 2)`` int32 array, level by level (per level the ``R_ij``, then the ``R_ji``, in the
    order of the candidates), and the number of groups tested.
    """
    ruled: list[np.ndarray] = []
    n_tests = 0
    for li, level in enumerate(levels):
        live = np.nonzero(want_ij | want_ji)[0]
        if live.size < 2:
            break
        n_sup = len(level.algebra.scaled)
        keys = level.index[caller[live]] * n_sup + level.index[other[live]]
        groups, inverse, counts = np.unique(keys, return_inverse=True, return_counts=True)
        if li + 1 < len(levels):
            nxt = levels[li + 1]
            sub = nxt.index[caller[live]] * len(nxt.algebra.scaled) + nxt.index[other[live]]
            # the distinct (group, subgroup) pairs, each encoded as one integer
            width = np.int64(sub.max()) + 1
            pairs = distinct_ints(inverse.astype(np.int64) * width + sub)
            n_children = np.bincount(pairs // width, minlength=groups.size)
        else:
            n_children = counts
        order = np.argsort(inverse, kind="stable")
        bounds = np.concatenate([[0], np.cumsum(counts)])
        alg = level.algebra
        tested = np.nonzero((counts >= 2) & (n_children >= 2))[0]
        ca, cb = alg.cls[groups[tested] // n_sup], alg.cls[groups[tested] % n_sup]
        screen_a, screen_b = alg.screen_pairs(ca, cb), alg.screen_pairs(cb, ca)
        # the groups of a level hold disjoint members, so what each still wants is known before
        # the first test; the rows of the groups to test are computed in one call per prefix A
        # (the groups are sorted by A)
        starts = bounds[tested]
        any_ij = np.logical_or.reduceat(want_ij[live[order]], starts) if tested.size else np.zeros(0, dtype=bool)
        any_ji = np.logical_or.reduceat(want_ji[live[order]], starts) if tested.size else np.zeros(0, dtype=bool)
        ok_a, ok_b = any_ij & screen_a, any_ji & screen_b
        done_a, done_b = any_ij & ~screen_a, any_ji & ~screen_b  # rank: lower-dimensional, no LP
        need = np.nonzero(ok_a | ok_b)[0]
        a_of, b_of = groups[tested] // n_sup, groups[tested] % n_sup
        batch: dict[int, object] = {}
        n_tests += need.size
        for t in need.tolist():
            a = int(a_of[t])
            if t not in batch:
                lo, hi = np.searchsorted(a_of, a, "left"), np.searchsorted(a_of, a, "right")
                same_a = need[np.searchsorted(need, lo):np.searchsorted(need, hi)]
                batch = dict(zip(same_a.tolist(), alg.restricted_rows(a, b_of[same_a])))
            rows = batch[t]
            if rows is None:  # the shared outputs can never be equal
                done_a[t], done_b[t] = any_ij[t], any_ji[t]
                continue
            verdict = classify_pair(rows.Gv, rows.gv, rows.N, rows.w0, alg.n, rows.radius_bound, bool(ok_a[t]), bool(ok_b[t]),
                                    problem=f"group of pairs below prefixes {a}, {int(b_of[t])} of length {level.depth} "
                                            "(Algorithm 3.1, grouped step 3.1.1)",
                                    directions=rows.directions)
            # a direction not tested here keeps what its rank screen decided
            done_a[t] = done_a[t] or (ok_a[t] and verdict.verdict != PairVerdict.PIECE)
            done_b[t] = done_b[t] or (ok_b[t] and verdict.verdict_ji != PairVerdict.PIECE)
        # every pair still wanted in a group decided here: the groups hold disjoint members
        for done, want, first, second in ((done_a, want_ij, caller, other), (done_b, want_ji, other, caller)):
            decided = np.zeros(groups.size, dtype=bool)
            decided[tested] = done
            hit = live[decided[inverse]]
            hit = hit[want[hit]]
            if hit.size:
                ruled.append(np.stack([first[hit], second[hit]], axis=1))
                want[hit] = False
    return (np.concatenate(ruled).astype(np.int32) if ruled else np.zeros((0, 2), dtype=np.int32)), n_tests


__all__ = ["GroupLevel", "GroupLevelRows", "group_depths", "group_level_data", "rule_out_by_groups"]

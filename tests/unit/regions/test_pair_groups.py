"""Grouped pair tests of Algorithm 3.1 (paper 002): prefix supersets rule out families of pairs.

``analyse_observability(..., group_tests=True)`` tests the pair set of two prefix supersets
(:func:`~hybobs_opt.regions.enumeration.prefix_supersets`) once, and when that set is not a piece
of ``B_T`` it rules out every pair ``(i, j)`` below the two prefixes without their own LPs
(:mod:`~hybobs_opt.regions.pair_groups`).  That is sound only if (a) each superset really contains
its regions, with the same leading output rows, and (b) a ruled-out pair is never a piece.  What
is checked, and why:

* Supersets contain their regions: every row of a superset is implied by each region below it
  (an LP per row with scipy / HiGHS, or the same row with no larger right-hand side in the region),
  the output rows kept are the region's first ``q`` rows bit for bit (``q`` is ``depth`` or
  ``depth + 1``), and the prefix is the region's.  A superset that cut into a region would make a
  group verdict wrong for its pairs.
* The same pieces with and without groups (model 16 at T = 3..6, model 17 at T = 5, 6), no ruled-out
  pair among them, every pair the pair-by-pair run drops as thin or same-state either dropped the
  same way by the grouped run or ruled out by a group (nothing lost), the same pair counts, and on
  model 17 at T = 5 at most 0.6 x the pair LPs (measured 1,481 vs 3,167).
* Ruled-out pairs are not pieces by an independent oracle (``scripts/check_t9_pair_lists.py``: its
  own pair sets and LPs, no code shared with the pair tests): a seeded sample of 30, and (slow) a
  larger sample of the ruled-out pairs that are non-empty (the pair-by-pair run calls them thin or
  same-state), the ones where a wrong group verdict could hide a piece.
* The process executor gives the same pieces, ruled-out pairs and LP counts as the serial run
  (the group tests must not depend on how the ``i`` are split into tasks).
* ``group_tests`` other than a bool is a :class:`~hybobs_opt.errors.ModelError`.
* A direction the rank screen rules out stays ruled out when the group's LP runs for the other
  direction (scripted screens and verdicts: the pass marks the decided pairs after its tests).
"""

import functools
import importlib.util
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import linprog

from hybobs_opt.errors import ModelError
from hybobs_opt.executor import ProcessExecutor, SerialExecutor
from hybobs_opt.regions import analyse_observability
from hybobs_opt.regions.enumeration import enumerate_modes, prefix_supersets
from hybobs_opt.studies import get_example

HERE = Path(__file__).resolve().parent
CASES = [("powertrain3", 3), ("powertrain3", 4), ("powertrain3", 5), ("powertrain3", 6),
         ("powertrain5", 5), ("powertrain5", 6)]


@functools.cache
def system(name: str):
    return get_example(name).build()


@functools.cache
def enumeration(name: str, T: int):
    return enumerate_modes(system(name), T)


@functools.cache
def analysis(name: str, T: int, group_tests: bool):
    return analyse_observability(enumeration(name, T), group_tests=group_tests)


@functools.cache
def pair_oracle():
    spec = importlib.util.spec_from_file_location("check_pair_lists", HERE.parents[2] / "scripts" / "check_t9_pair_lists.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.oracle


def _keys(a):
    return [(p.i, p.j) for p in a.pairs]


# ------------------------------------------------------------------ supersets contain their regions
def _row_implied_by_lp(H, h, a, b) -> bool:
    """max a @ z over {H z <= h} <= b (with a relative slack), by HiGHS."""
    res = linprog(-a, A_ub=H, b_ub=h, bounds=(None, None), method="highs")
    assert res.status == 0, res.message
    return -res.fun <= b + 1e-9 * (1.0 + abs(b))


def _row_implied_by_copy(H, h, a, b) -> bool:
    """The region carries the row itself with a right-hand side no larger: implied, no LP needed."""
    return bool(np.any(np.all(H == a, axis=1) & (h <= b)))


def _check_supersets(enum, depth, regions, lp_only: bool):
    built = prefix_supersets(enum, depth)
    assert built is not None, depth
    sups, index = built
    assert len(index) == len(enum.regions)
    # one superset per distinct prefix, and every superset used
    assert len(sups) == len({r.sequence[:depth] for r in enum.regions})
    assert set(int(t) for t in index) == set(range(len(sups)))
    for k in regions:
        reg, sup = enum.regions[k], sups[index[k]]
        assert tuple(sup.prefix) == tuple(reg.sequence[:depth]), (depth, k)
        q = sup.C.shape[0]
        assert q in (depth, depth + 1), (depth, k, q)
        assert np.array_equal(reg.C[:q], sup.C) and np.array_equal(reg.D[:q], sup.D) and np.array_equal(reg.f[:q], sup.f)
        assert sup.H.shape[1] == reg.H.shape[1]
        for r in range(sup.H.shape[0]):
            a, b = sup.H[r], float(sup.h[r])
            ok = (not lp_only and _row_implied_by_copy(reg.H, reg.h, a, b)) or _row_implied_by_lp(reg.H, reg.h, a, b)
            assert ok, f"depth {depth}, region {k}: superset row {r} cuts into the region"


def test_supersets_contain_their_regions_model16_T4():
    enum = enumeration("powertrain3", 4)
    for depth in range(1, 4):
        _check_supersets(enum, depth, range(len(enum.regions)), lp_only=True)


def test_supersets_contain_their_regions_model17_T5():
    """Every region at every depth (a row the region carries itself needs no LP), and an LP for every
    row on a seeded sample of regions at depths 1, 3, 4 (an LP per row on all 103 regions is ~50 s)."""
    enum = enumeration("powertrain5", 5)
    for depth in range(1, 5):
        _check_supersets(enum, depth, range(len(enum.regions)), lp_only=False)
    sample = np.random.default_rng(0).choice(len(enum.regions), size=12, replace=False)
    for depth in (1, 3, 4):
        _check_supersets(enum, depth, [int(k) for k in sample], lp_only=True)


def test_prefix_supersets_rejects_depth_out_of_range():
    enum = enumeration("powertrain3", 4)
    for depth in (0, 4):
        with pytest.raises(ModelError, match="depth"):
            prefix_supersets(enum, depth)


# ------------------------------------------------------------------ same pieces, fewer LPs
@pytest.mark.parametrize("name,T", CASES)
def test_same_pieces_with_and_without_groups(name, T):
    grouped, single = analysis(name, T, True), analysis(name, T, False)
    assert _keys(grouped) == _keys(single)
    ruled = grouped.stats["pairs_ruled_out_by_group"]
    assert len(ruled) == len(set(ruled)) == grouped.stats["n_pairs_ruled_out_by_group"]
    ruled = set(ruled)
    assert not ruled & set(_keys(grouped))
    g_thin, g_same = set(grouped.stats["pairs_dropped_thin"]), set(grouped.stats["pairs_dropped_same_state"])
    s_thin, s_same = set(single.stats["pairs_dropped_thin"]), set(single.stats["pairs_dropped_same_state"])
    # a ruled-out pair is not also classified one by one
    assert not ruled & (g_thin | g_same)
    # the pairs left to their own tests get the verdict they get pair by pair
    assert g_thin <= s_thin and g_same <= s_same
    # nothing lost: every thin / same-state pair of the pair-by-pair run is accounted for
    assert (s_thin | s_same) - (g_thin | g_same) <= ruled
    assert (grouped.n_pairs_tested, grouped.n_pairs_skipped_rank) == (single.n_pairs_tested, single.n_pairs_skipped_rank)
    # the levels of the module docstring: prefixes of max(1, ceil(n / p) - 2) .. T - 1 modes
    sysm = system(name)
    assert grouped.stats["group_depths"] == tuple(range(max(1, math.ceil(sysm.n / sysm.p) - 2), T))
    assert single.stats["n_pairs_ruled_out_by_group"] == 0 and single.stats["n_group_tests"] == 0
    assert single.stats["group_depths"] == ()
    assert grouped.n_pair_lps <= single.n_pair_lps


def test_fewer_pair_lps_model17_T5():
    grouped, single = analysis("powertrain5", 5, True), analysis("powertrain5", 5, False)
    # measured 1,481 vs 3,167; a margin for solver-version noise
    assert grouped.n_pair_lps <= 0.6 * single.n_pair_lps
    assert grouped.stats["n_group_tests"] > 0 and grouped.stats["n_pairs_ruled_out_by_group"] > 0
    assert 0 < grouped.stats["n_group_lps"] <= grouped.n_pair_lps


# ------------------------------------------------------------------ independent oracle
def test_ruled_out_pairs_are_not_pieces_by_an_independent_oracle():
    enum = enumeration("powertrain5", 5)
    ruled = analysis("powertrain5", 5, True).stats["pairs_ruled_out_by_group"]
    oracle = pair_oracle()
    sample = np.random.default_rng(0).choice(len(ruled), size=30, replace=False)
    labels = {ruled[k]: oracle(enum, *ruled[k], exact=False)["label"] for k in sample}
    assert set(labels.values()) <= {"same", "none", "thin"}, labels


@pytest.mark.slow
def test_non_empty_ruled_out_pairs_are_not_pieces_by_an_independent_oracle():
    """The ruled-out pairs the pair-by-pair run calls thin or same-state (914 of 2,934 at T = 5; the
    rest are empty, decided in ~0.01 s by the oracle): a seeded sample of 60, ~0.5 s each."""
    enum = enumeration("powertrain5", 5)
    single = analysis("powertrain5", 5, False)
    ruled = set(analysis("powertrain5", 5, True).stats["pairs_ruled_out_by_group"])
    non_empty = sorted(ruled & (set(single.stats["pairs_dropped_thin"]) | set(single.stats["pairs_dropped_same_state"])))
    assert len(non_empty) >= 60
    oracle = pair_oracle()
    sample = np.random.default_rng(1).choice(len(non_empty), size=60, replace=False)
    labels = {non_empty[k]: oracle(enum, *non_empty[k], exact=False)["label"] for k in sample}
    assert set(labels.values()) <= {"same", "none", "thin"}, {p: v for p, v in labels.items() if v == "piece"}


# ------------------------------------------------------------------ executors, bad input
@pytest.fixture
def always_parallel(monkeypatch):
    """Send even a small problem to the executor (by default small ones stay in-process)."""
    from hybobs_opt.regions import enumeration as enumeration_module, observability

    monkeypatch.setattr(enumeration_module, "PARALLEL_MIN_SEQUENCES", 0)
    monkeypatch.setattr(observability, "PARALLEL_MIN_PAIRS", 0)


def _serial_and(executor, plant, T):
    """The analysis on the serial executor and on ``executor`` (closed afterwards)."""
    serial = analyse_observability(plant, T, executor=SerialExecutor())
    try:
        return serial, analyse_observability(plant, T, executor=executor)
    finally:
        executor.close()


def test_executors_give_identical_results(always_parallel):
    serial, procs = _serial_and(ProcessExecutor(2), system("powertrain5"), 5)
    assert procs.stats["executor"] == "processes" and serial.stats["executor"] == "serial"
    assert [r.sequence for r in serial.regions] == [r.sequence for r in procs.regions]
    assert _keys(serial) == _keys(procs)
    assert serial.stats["pairs_ruled_out_by_group"] == procs.stats["pairs_ruled_out_by_group"]
    assert serial.stats["n_pairs_ruled_out_by_group"] > 0
    assert serial.stats["pairs_dropped_thin"] == procs.stats["pairs_dropped_thin"]
    assert serial.stats["pairs_dropped_same_state"] == procs.stats["pairs_dropped_same_state"]
    assert serial.n_pair_lps == procs.n_pair_lps
    assert (serial.stats["n_group_tests"], serial.stats["n_group_lps"]) == (procs.stats["n_group_tests"], procs.stats["n_group_lps"])


class _MapOnlyExecutor:
    """A user's executor with ``map`` only (no ``map_shared``): the tasks then carry the common data."""

    name = "map-only"

    def __init__(self):
        self._inner = ProcessExecutor(2)
        self.n_workers = 2
        self.calls = 0

    def map(self, fn, items, progress=None):
        self.calls += 1
        return self._inner.map(fn, items, progress)

    def close(self):
        self._inner.close()


def test_executor_with_map_only_gives_identical_results(always_parallel):
    """The split into blocks, the per-worker state keyed by the data's digest and the shared data
    all take the other path here (``functools.partial``); the answers and LP counts must not move."""
    ex = _MapOnlyExecutor()
    serial, other = _serial_and(ex, system("powertrain5"), 5)
    assert ex.calls >= 1 and other.stats["executor"] == "map-only"
    assert _keys(serial) == _keys(other)
    assert serial.stats["pairs_ruled_out_by_group"] == other.stats["pairs_ruled_out_by_group"]
    assert serial.n_pair_lps == other.n_pair_lps


def _shared_sum(item, shared):
    return item * shared[0] + shared[1]


@pytest.mark.parametrize("make", [SerialExecutor, lambda: ProcessExecutor(2)], ids=["serial", "processes"])
def test_map_shared_passes_the_common_argument_to_every_call(make):
    ex = make()
    try:
        assert ex.map_shared(_shared_sum, range(7), (3, 1)) == [3 * k + 1 for k in range(7)]
    finally:
        getattr(ex, "close", lambda: None)()


@pytest.mark.parametrize("bad", ["yes", 1, None])
def test_group_tests_must_be_a_bool(bad):
    with pytest.raises(ModelError, match="group_tests"):
        analyse_observability(enumeration("powertrain3", 3), group_tests=bad)


def test_distinct_ints_equals_numpy_unique_and_counts_children_as_before():
    """``distinct_ints`` (no numpy.ma import) against ``np.unique``, and the children count of the
    group tests (distinct (group, subgroup) pairs encoded as one integer) against ``np.unique(axis=1)``."""
    from hybobs_opt.regions.pair_algebra import distinct_ints

    rng = np.random.default_rng(3)
    for size in (0, 1, 2, 7, 1000):
        a = rng.integers(0, 9, size=size)
        np.testing.assert_array_equal(distinct_ints(a), np.unique(a))
        inverse, sub = rng.integers(0, 5, size=size), rng.integers(0, 40, size=size)
        width = np.int64(sub.max()) + 1 if size else np.int64(1)
        encoded = distinct_ints(inverse.astype(np.int64) * width + sub)
        expected = np.unique(np.stack([inverse, sub]), axis=1) if size else np.zeros((2, 0), dtype=int)
        np.testing.assert_array_equal(np.bincount(encoded // width, minlength=5), np.bincount(expected[0], minlength=5))


class _ScriptedRows:
    """Rows of a group's pair set; the scripted classify_pair below reads none of them."""

    Gv = gv = N = w0 = directions = None
    radius_bound = 1.0


class _ScriptedAlgebra:
    """The algebra of one level of two supersets: the rank screen passes one direction only."""

    n = 1
    scaled = [None, None]
    cls = np.array([0, 1])

    def __init__(self, screen_ab: bool, screen_ba: bool):
        self.screens = {(0, 1): screen_ab, (1, 0): screen_ba}

    def screen_pairs(self, ca, cb):
        return np.array([self.screens[(int(a), int(b))] for a, b in zip(ca, cb)], dtype=bool)

    def restricted_rows(self, a, bs):
        return [_ScriptedRows() for _ in bs]


@pytest.mark.parametrize("screen_ab, screen_ba", [(False, True), (True, False)])
def test_a_direction_ruled_out_by_rank_stays_ruled_out_when_the_other_is_tested(monkeypatch, screen_ab, screen_ba):
    """One group, both directions wanted: the rank screen rules out one direction (no LP), the group
    LP is run for the other and finds a piece there.  The screened direction's pairs are ruled out,
    the tested direction's stay to be tested one by one."""
    from hybobs_opt.regions import pair_groups
    from hybobs_opt.regions.pair_geometry import PairClassification
    from hybobs_opt.regions.verdicts import PairVerdict

    calls = []

    def classify(*args, **kwargs):
        calls.append(args[6:8])  # (want_ij, want_ji) as tested
        return PairClassification(PairVerdict.PIECE, PairVerdict.PIECE, 1.0, False)

    monkeypatch.setattr(pair_groups, "classify_pair", classify)
    level = pair_groups.GroupLevel(3, _ScriptedAlgebra(screen_ab, screen_ba), np.array([0, 0, 1, 1]))
    caller, other = np.array([0, 1]), np.array([2, 3])
    want_ij, want_ji = np.ones(2, dtype=bool), np.ones(2, dtype=bool)
    ruled, n_tests = pair_groups.rule_out_by_groups([level], caller, other, want_ij, want_ji)
    assert n_tests == 1 and calls == [(screen_ab, screen_ba)]
    if screen_ab:  # R_ij tested (a piece), R_ji lower-dimensional by rank
        assert want_ij.tolist() == [True, True] and want_ji.tolist() == [False, False]
        assert sorted(map(tuple, ruled.tolist())) == [(2, 0), (3, 1)]
    else:
        assert want_ij.tolist() == [False, False] and want_ji.tolist() == [True, True]
        assert sorted(map(tuple, ruled.tolist())) == [(0, 2), (1, 3)]

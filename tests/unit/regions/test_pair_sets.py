"""The compact store of Algorithm 3.1's answers (paper 002): :class:`PairSets` and :class:`PairList`.

An analysis keeps its pieces ``R_ij`` as ``(i, j)`` and a radius and builds each piece's
constraints when it is read; the left-out pairs are integer arrays read as tuples.  What is
checked, and why:

* ``PairList`` reads back exactly the pairs it was given (order, ``int`` items, slicing, pickling,
  ``==`` with tuples), and ``sorted`` is the lexicographic order of Python's ``sorted`` on tuples,
  including adversarial inputs (empty, one pair, repeated first indices, large indices; a negative
  index is refused by name).
* Each piece read from ``PairSets`` holds the constraints of ``R_ij`` (Algorithm 3.1, step 3) written out independently
  here from the two regions (block matrices over ``(x, x^, U)``), bit for bit.
* The lists are the ones recorded with the former tuple-of-``PairSet`` store
  (``tests/reproducibility_reference.json``, model (17) at T = 5, grouped: sha256 of the pieces,
  thin and same-state pairs, and the counts), and a saved and reloaded analysis reads the same
  pieces, radii and constraints.
"""

import hashlib
import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from hybobs_opt.errors import ModelError
from hybobs_opt.regions import analyse_observability, load_analysis, save_analysis
from hybobs_opt.regions.pair_sets import PairList, PairSets
from hybobs_opt.studies import get_example

ROOT = Path(__file__).resolve().parents[3]


def _sha(pairs) -> str:
    return hashlib.sha256(json.dumps([[int(i), int(j)] for i, j in pairs], separators=(",", ":")).encode()).hexdigest()


@pytest.mark.parametrize("pairs", [[], [(4, 1)], [(3, 9), (3, 2), (0, 7), (3, 2 ** 31 - 1), (1, 0)],
                                   [(5, 5), (2, 8), (5, 1), (2, 3)]])
def test_pair_list_round_trip_and_order(pairs):
    plist = PairList(pairs)
    assert list(plist) == [tuple(p) for p in pairs] and len(plist) == len(pairs)
    assert all(type(i) is int and type(j) is int for i, j in plist)
    assert plist == tuple(pairs) and plist == list(pairs) and plist == PairList(np.array(pairs, dtype=np.int64).reshape(-1, 2))
    assert list(PairList.sorted(pairs)) == sorted(pairs)
    assert pickle.loads(pickle.dumps(plist)) == plist
    if pairs:
        assert plist[-1] == tuple(pairs[-1]) and list(plist[1:]) == list(pairs[1:])
        assert set(plist) == set(pairs)
        assert plist != tuple(pairs[:-1])


def test_pair_list_refuses_negative_indices():
    with pytest.raises(ModelError, match="pairs"):
        PairList([(0, -1)])
    with pytest.raises(ModelError, match="pairs"):
        PairList([(0, 2 ** 31)])


def _independent_constraints(ri, rj, n):
    """R_ij over (x, x^, U): [Hx_i 0 HU_i; 0 Hx_j HU_j] z <= [h_i; h_j], [C_i -C_j D_i-D_j] z = f_j - f_i."""
    kI, kJ = ri.H.shape[0], rj.H.shape[0]
    G = np.block([[ri.H[:, :n], np.zeros((kI, n)), ri.H[:, n:]], [np.zeros((kJ, n)), rj.H[:, :n], rj.H[:, n:]]])
    E = np.hstack([ri.C, -rj.C, ri.D - rj.D])
    return G, np.concatenate([ri.h, rj.h]), E, rj.f - ri.f


@pytest.fixture(scope="module")
def model17_T5():
    return analyse_observability(get_example("powertrain5").build(), 5)


def test_pieces_are_the_recorded_lists(model17_T5):
    """The same lists as the former store recorded (model 17, T = 5, grouped)."""
    ref = json.loads((ROOT / "tests" / "reproducibility_reference.json").read_text())["powertrain5_T5_grouped"]
    a = model17_T5
    assert isinstance(a.pairs, PairSets)
    assert (len(a.pairs), a.n_pair_lps) == (ref["n_pieces"], ref["n_pair_lps"])
    assert _sha(a.pairs.ij) == _sha((p.i, p.j) for p in a.pairs) == ref["sha256_pairs"]
    assert _sha(a.stats["pairs_dropped_thin"]) == ref["sha256_thin"]
    assert _sha(a.stats["pairs_dropped_same_state"]) == ref["sha256_same"]
    ruled = a.stats["pairs_ruled_out_by_group"]
    assert list(ruled) == sorted(set(ruled)) and len(ruled) == a.stats["n_pairs_ruled_out_by_group"] > 0
    # 16 bytes a piece, whatever the horizon
    assert a.pairs.ij.array.nbytes + a.pairs.slacks.nbytes == 16 * len(a.pairs)


def test_pieces_hold_the_pair_constraints(model17_T5):
    a = model17_T5
    n = a.system.n
    rng = np.random.default_rng(3)
    for k in sorted(set(rng.choice(len(a.pairs), 25, replace=False).tolist()) | {0, len(a.pairs) - 1}):
        p = a.pairs[k]
        assert (p.i, p.j) == a.pairs.ij[k] and p.slack == a.pairs.slacks[k]
        for got, want in zip((p.G, p.g, p.E, p.e), _independent_constraints(a.regions[p.i], a.regions[p.j], n)):
            assert got.shape == want.shape and np.array_equal(got, want)
    reduced = a.reduced_pairs
    assert [(p.i, p.j) for p in reduced] == [(i, j) for i, j in a.pairs.ij if not a.full_rank[j]]
    assert list(a.pairs[2:5].ij) == list(a.pairs.ij)[2:5]


def test_save_load_keeps_the_pieces(tmp_path, model17_T5):
    a = model17_T5
    path = save_analysis(a, tmp_path / "a.json", example="powertrain5")
    b = load_analysis(path)
    assert b.pairs.ij == a.pairs.ij and np.array_equal(b.pairs.slacks, a.pairs.slacks)
    assert np.array_equal(b.pairs[7].G, a.pairs[7].G) and np.array_equal(b.pairs[7].e, a.pairs[7].e)
    c = pickle.loads(pickle.dumps(a.pairs))
    assert c.ij == a.pairs.ij and np.array_equal(c[3].g, a.pairs[3].g)


def test_subset_takes_one_boolean_per_piece(model17_T5):
    pairs = model17_T5.pairs
    keep = np.arange(len(pairs)) % 3 == 0
    sub = pairs.subset(keep)
    assert list(sub.ij) == [p for p, k in zip(pairs.ij, keep) if k]
    assert np.array_equal(sub.slacks, pairs.slacks[keep])
    with pytest.raises(ModelError, match="mask"):
        pairs.subset(keep[:-1])
    with pytest.raises(ModelError, match="mask"):
        pairs.subset(keep.astype(int))  # indices are not a mask

"""The linear algebra shared by the pair tests of Algorithm 3.1 (paper 002), eq. (4) regions in scaled coordinates.

The regions' rows and output maps in scaled coordinates (:func:`scaled_rows`), packed for the
workers (:func:`pack_scaled`), and :class:`PairAlgebra`: the rank screen and the nullspace of the
output equalities of ``R_ij``, computed once per pair of output-map classes.
"""

from __future__ import annotations

import pickle
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from ..geometry._lp_kernels import restricted_pairs_rows, restricted_region_rows
from ..geometry._reproducible import (equality_subspace, matmul as mm, numerical_rank, numerical_ranks, row_norms, singular_values,
                                      svd)
from ..tolerances import EQUALITY_CONSISTENCY_RTOL, RANK_RTOL
from .pair_geometry import SubspaceDirections


def scaled_rows(regions, n: int, scale: np.ndarray, centre: np.ndarray):
    """Per region (anything with ``H, h, C, D, f`` over ``(x, U)``), its rows and output map in scaled coordinates."""
    sx, su = scale[:n], scale[n:]
    cx, cu = centre[:n], centre[n:]
    regions = list(regions)
    if not regions:
        return []
    # Every quantity is computed row by row (each row's sums in the same order), so the regions'
    # rows are stacked and each product is one call instead of one per region: the same bits.
    H = np.vstack([reg.H for reg in regions])
    C = np.vstack([reg.C for reg in regions])
    D = np.vstack([reg.D for reg in regions])
    h = np.concatenate([reg.h for reg in regions]) - mm(H[:, :n], cx) - mm(H[:, n:], cu)
    f = np.concatenate([reg.f for reg in regions]) + mm(C, cx) + mm(D, cu)
    Hx, HU = H[:, :n] * sx, H[:, n:] * su
    # Unit rows in the scaled space, so that after restriction to an equality subspace the
    # margin of the max-margin LP is a distance to every original constraint.
    inv = 1.0 / np.maximum(row_norms(np.hstack([Hx, HU])), np.finfo(float).tiny)
    Hx, HU, h = Hx * inv[:, None], HU * inv[:, None], h * inv
    Cs, Ds = C * sx, D * su
    rows = np.cumsum([0] + [reg.H.shape[0] for reg in regions])
    outs = np.cumsum([0] + [reg.C.shape[0] for reg in regions])
    if len({reg.C.shape[0] for reg in regions}) == 1:
        k, p = len(regions), regions[0].C.shape[0]
        return ScaledRows(rows, Hx, HU, h, Cs.reshape(k, p, -1), Ds.reshape(k, p, -1), f.reshape(k, p))
    return [(Hx[a:b], HU[a:b], h[a:b], Cs[p:q], Ds[p:q], f[p:q])
            for a, b, p, q in zip(rows[:-1], rows[1:], outs[:-1], outs[1:])]


class ScaledRows(Sequence):
    """The scaled rows and output maps of many regions (:func:`scaled_rows`), stacked.

    Item ``k`` is ``(Hx, HU, h, C, D, f)`` of region ``k`` (views); the stacked arrays are
    attributes: region ``k``'s rows are ``offsets[k]:offsets[k + 1]`` of ``Hx, HU, h``, its
    output map ``C[k], D[k], f[k]`` (every region has as many outputs).  The pair tests pass the
    stacks to one compiled call for many regions (:meth:`PairAlgebra.restricted_rows`).
    """

    def __init__(self, offsets, Hx, HU, h, C, D, f):
        self.offsets = np.asarray(offsets, dtype=np.int64)
        self.Hx, self.HU, self.h, self.C, self.D, self.f = Hx, HU, h, C, D, f
        self._items = [(Hx[a:b], HU[a:b], h[a:b], C[k], D[k], f[k])
                       for k, (a, b) in enumerate(zip(self.offsets[:-1].tolist(), self.offsets[1:].tolist()))]

    @staticmethod
    def of(scaled) -> "ScaledRows":
        """``scaled`` as stacked rows: itself if it is, else its tuples stacked (one per region)."""
        if isinstance(scaled, ScaledRows):
            return scaled
        return ScaledRows(np.cumsum([0] + [t[0].shape[0] for t in scaled]), np.vstack([t[0] for t in scaled]),
                          np.vstack([t[1] for t in scaled]), np.concatenate([t[2] for t in scaled]),
                          np.stack([t[3] for t in scaled]), np.stack([t[4] for t in scaled]), np.stack([t[5] for t in scaled]))

    def __len__(self) -> int:
        return len(self._items)

    def __getitem__(self, k):
        return self._items[k]


def _scaled_regions(enum):
    """Per region of an enumeration, the constraint rows and output maps in scaled coordinates (computed once per task)."""
    return scaled_rows(enum.regions, enum.system.n, enum.scale, enum.centre)


@dataclass(frozen=True, slots=True)
class RestrictedPair:
    """The rows of one pair set ``R_ij`` on its output-equality subspace (:meth:`PairAlgebra.restricted_rows`).

    ``Gv v <= gv`` on ``w = w0 + N v`` (scaled ``w = (x, x^, U)``); ``directions`` is the
    :class:`~hybobs_opt.regions.pair_geometry.SubspaceDirections` of ``N``; ``radius_bound``
    bounds ``|v|`` over the set (the scaled variables lie in the unit box).
    """

    Gv: np.ndarray
    gv: np.ndarray
    w0: np.ndarray
    N: np.ndarray
    directions: SubspaceDirections
    radius_bound: float


def distinct_ints(a: np.ndarray) -> np.ndarray:
    """The sorted distinct values of an integer array: ``np.unique`` without its masked-array check,
    whose first call in a process imports ``numpy.ma`` (14 ms, a seventh of a small analysis)."""
    s = np.sort(np.asarray(a).ravel())
    if s.size < 2:
        return s
    keep = np.empty(s.size, dtype=bool)
    keep[0] = True
    np.not_equal(s[1:], s[:-1], out=keep[1:])
    return s[keep]


def _batched_rank(M: np.ndarray) -> np.ndarray:
    return numerical_ranks(singular_values(M), RANK_RTOL)


class PairAlgebra:
    """The linear algebra of the pair tests, shared by the regions with the same output map.

    The rank screen and the nullspace of the output equalities of ``R_ij`` depend on ``(C_i,
    D_i, C_j, D_j)`` only, and mode sequences through modes with the same linear part share
    them bit for bit (model 17, T = 7: 354 regions, 32 distinct ``(C, D)``).  Both are
    computed once per pair of such classes, in batches, instead of once per pair of regions.
    """

    def __init__(self, scaled, n: int):
        self.scaled = scaled
        self.n = n
        index: dict[bytes, int] = {}
        self.cls = np.empty(len(scaled), dtype=int)
        reps = []
        for k, (_, _, _, C, D, _) in enumerate(scaled):
            key = C.tobytes() + D.tobytes()
            if key not in index:
                index[key] = len(reps)
                reps.append(k)
            self.cls[k] = index[key]
        self.C = np.stack([scaled[k][3] for k in reps])
        self.D = np.stack([scaled[k][4] for k in reps])
        stacked = ScaledRows.of(scaled)
        self._stacked = (stacked.Hx, stacked.HU, stacked.h, stacked.f, stacked.offsets)
        n_cls = len(reps)
        self._screened = np.zeros((n_cls, n_cls), dtype=bool)
        self._screen = np.zeros((n_cls, n_cls), dtype=bool)
        self._svd: dict[tuple[int, int], tuple] = {}  # see equality_svd
        # P_i's rows on the subspace of each class of j, for the last i (see restricted_rows)
        self._rows_i: tuple[int, dict[int, np.ndarray]] = (-1, {})

    def screen(self, a: int, bs: np.ndarray) -> np.ndarray:
        r"""For classes ``a`` (of ``i``) and ``bs`` (of ``j``): can ``Proj_x(R_ij)`` be full-dimensional?

        Only if ``range(C_i) \subseteq range([C_j, D_j - D_i])`` (the output equalities must be
        solvable for every ``x``), i.e. ``rank [C_i, C_j, D_j - D_i] = rank [C_j, D_j - D_i]``.
        """
        fresh = ~self._screened[a, bs]
        if fresh.any():
            new = distinct_ints(bs[fresh])
            Ca, Da = self.C[a], self.D[a]
            Mj = np.concatenate([self.C[new], self.D[new] - Da], axis=2)
            with_ci = np.concatenate([np.broadcast_to(Ca, (new.size,) + Ca.shape), Mj], axis=2)
            self._screen[a, new] = _batched_rank(Mj) == _batched_rank(with_ci)
            self._screened[a, new] = True
        return self._screen[a, bs]

    def screen_pairs(self, as_: np.ndarray, bs: np.ndarray) -> np.ndarray:
        """:meth:`screen` elementwise for the class pairs ``(as_[k], bs[k])``, in one batch per class of ``as_``."""
        as_, bs = np.asarray(as_, dtype=int), np.asarray(bs, dtype=int)
        for a in distinct_ints(as_):
            self.screen(int(a), distinct_ints(bs[as_ == a]))
        return self._screen[as_, bs]

    def screen_reversed(self, as_: np.ndarray, b: int) -> np.ndarray:
        """:meth:`screen` for the pairs ``(a, b)``, ``a`` in ``as_`` (``R_ji`` of a pair found from ``i``)."""
        fresh = ~self._screened[as_, b]
        if fresh.any():
            # one batch for the column: the matrices :meth:`screen` would build for each (a, b),
            # each SVD computed on its own, so the bits do not depend on the batch
            new = distinct_ints(as_[fresh])
            Cb, Db = self.C[b], self.D[b]
            Mj = np.concatenate([np.broadcast_to(Cb, (new.size,) + Cb.shape), Db - self.D[new]], axis=2)
            with_ci = np.concatenate([self.C[new], Mj], axis=2)
            self._screen[new, b] = _batched_rank(Mj) == _batched_rank(with_ci)
            self._screened[new, b] = True
        return self._screen[as_, b]

    def equality_svd(self, a: int, bs: np.ndarray) -> list[tuple]:
        """``(U, s, Vt, rank, N, directions)`` for ``E = [C_i, -C_j, D_i - D_j]`` (scaled), per class in ``bs``.

        ``E = U diag(s) Vt`` with numerical rank ``rank`` and nullspace basis ``N = Vt[rank:]'``;
        ``directions`` is :class:`~hybobs_opt.regions.pair_geometry.SubspaceDirections` of ``N``
        (ranks and thinnest functionals of the projections on ``x`` and ``x^``, and whether the
        subspace moves them together), shared by every region pair of the two classes.
        """
        a = int(a)
        found = [self._svd.get((a, b)) for b in np.asarray(bs).tolist()]
        if None not in found:
            return found
        new = [b for b in distinct_ints(bs) if (a, int(b)) not in self._svd]
        if new:
            Ca, Da = self.C[a], self.D[a]
            E = np.concatenate([np.broadcast_to(Ca, (len(new),) + Ca.shape), -self.C[new], Da - self.D[new]], axis=2)
            for k, b in enumerate(new):
                fast = equality_subspace(E[k], self.n, RANK_RTOL)  # one compiled call, the same bits
                if fast is not None:
                    U_, S_, Vt, r, N, full, thin, thin_norm, same, D = fast
                    directions = SubspaceDirections((bool(full[0]), bool(full[1])), (thin[0], thin[1]), bool(same),
                                                    (float(thin_norm[0]), float(thin_norm[1])), D)
                else:
                    U_, S_, Vt = svd(E[k], full_matrices=True)
                    r = numerical_rank(S_, RANK_RTOL)
                    N = np.ascontiguousarray(Vt[r:].T)
                    directions = SubspaceDirections.of(N, self.n, (E[k], r))
                self._svd[(a, int(b))] = (U_, S_, Vt, int(r), N, directions)
        return [self._svd[(a, int(b))] for b in bs]

    def restricted_rows(self, i: int, js) -> list[RestrictedPair | None]:
        """The rows of ``R_ij`` on its output-equality subspace, per ``j`` in ``js`` (scaled ``w = (x, x^, U)``).

        ``None`` where the output equalities ``C_i x - C_j x^ + (D_i - D_j) U = f_j - f_i`` have
        no solution, else a :class:`RestrictedPair`.  The subspace depends on the classes of ``i``
        and ``j`` only: ``P_i``'s rows on it are computed once per class of ``j`` (and kept for
        the next call with the same ``i``: the group tests ask for one ``j`` at a time), and the
        pairs of one class in one compiled call
        (:func:`~hybobs_opt.geometry._lp_kernels.restricted_pairs_rows`).
        """
        js = np.asarray(js, dtype=int)
        if js.size == 0:
            return []
        HxI, HUI, hI, _, _, fI = self.scaled[i]
        radius0 = np.sqrt(2 * HxI.shape[1] + HUI.shape[1])
        Hx, HU, h, F, offsets = self._stacked
        out: list[RestrictedPair | None] = [None] * js.size
        if self._rows_i[0] != i:
            self._rows_i = (i, {})
        rows_i = self._rows_i[1]
        cls_js = self.cls[js]
        classes = distinct_ints(cls_js) if js.size > 1 else cls_js
        for cj, (U_, S_, Vt, r, N, directions) in zip(classes.tolist(), self.equality_svd(self.cls[i], classes)):
            where = np.nonzero(cls_js == cj)[0] if classes.size > 1 else np.arange(js.size)
            GI = rows_i.get(cj)
            if GI is None:
                GI = rows_i[cj] = restricted_region_rows(HxI, HUI, N, 0)
            G, g, W0, consistent, start, w0_norm = restricted_pairs_rows(
                HxI, HUI, hI, fI, GI, Hx, HU, h, F, offsets, js[where], U_, S_, Vt, r, N, EQUALITY_CONSISTENCY_RTOL)
            bounds = start.tolist()
            for t, k in enumerate(where.tolist()):
                if consistent[t]:
                    a, b = bounds[t], bounds[t + 1]
                    out[k] = RestrictedPair(G[a:b], g[a:b], W0[t], N, directions, radius0 + w0_norm[t])
        return out


def pack_scaled(scaled, n: int) -> bytes:
    """What the pair tests need of an enumeration, as one pickle of eight arrays.

    :func:`scaled_rows` stacked over the regions (rows with offsets; output maps stacked): the
    tasks of :func:`~hybobs_opt.regions.observability.analyse_observability` receive this
    instead of the pickled :class:`ModeEnumeration` (its state maps, ``Phi``/``Gamma`` of every
    step, are not needed here), and rebuild nothing but views.
    """
    s = ScaledRows.of(scaled)
    return pickle.dumps((n, s.offsets, s.Hx, s.HU, s.h, s.C, s.D, s.f), protocol=pickle.HIGHEST_PROTOCOL)


def unpack_scaled(payload: bytes):
    n, rows, Hx, HU, h, C, D, f = pickle.loads(payload)
    return ScaledRows(rows, Hx, HU, h, C, D, f), n

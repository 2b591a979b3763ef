"""Affine images and projections of H-polytopes: iterative convex hull and Fourier-Motzkin.

The sets ``Proj_x(R_ij)`` of paper 002 (Algorithm 3.1, step 3.1.1) are projections of 9-D to
17-D polytopes onto the 3-5 state coordinates.  Small target dimensions use the iterative hull
(support LPs along the facet normals of a growing qhull hull: about one LP per facet and vertex
of the image), larger ones Fourier-Motzkin elimination with redundancy removal after each step.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from . import _spatial
from ..defaults import HULL_MAX_SUPPORT_LPS
from ..errors import ModelError, SolverError
from ..tolerances import (
    AFFINE_HULL_RTOL,
    PROJECTION_HULL_RTOL,
    RANK_RTOL,
    ZERO_ROW_TOL,
)
from ._common import _box, _lp, _nullspace, _row_normalised, _unit_box_map, _unit_rows
from .redundancy import irredundant

ConvexHull = QhullError = None  # scipy.spatial's, bound at their first use (_spatial.bind)

#: Target dimension up to which :meth:`Polytope.project` (``method="auto"``) uses the iterative
#: convex-hull method; above it, Fourier-Motzkin elimination.  Qhull's cost grows quickly with the
#: dimension, while the hull method needs only ~(facets + vertices) LPs; set this module attribute
#: (or pass ``hull_max_dim``) to move the switch.
HULL_PROJECTION_MAX_DIM: int = 5


@dataclass(frozen=True)
class _Image:
    """H-representation ``H x <= h`` of an image, plus its vertices when the hull method ran."""

    H: np.ndarray
    h: np.ndarray
    points: np.ndarray | None


def _point_image(c: np.ndarray) -> _Image:
    k = c.size
    return _Image(np.vstack([np.eye(k), -np.eye(k)]), np.concatenate([c, -c]), c[None, :].copy())


def image_of(A, b, E, e, M, v, method: str, hull_max_dim: int | None) -> _Image | None:
    """``{M z + v : A z <= b, E z = e}`` or ``None`` when empty.

    Scales ``z`` by its bounding box, eliminates the equalities by an orthonormal null-space
    parametrisation ``y = y0 + N w`` and hands the full-dimensional polytope in ``w`` and the map
    ``w -> x`` to :func:`_linear_image`.
    """
    d = A.shape[1]
    A, b = _row_normalised(A, b)
    if E is not None and E.shape[0]:
        E, e = _row_normalised(E, e)
    box = _box(A, b, E, e)
    if box is None:
        return None
    mid, half = _unit_box_map(*box)
    Ay = A * half
    by = b - A @ mid
    if E is not None and E.shape[0]:
        ns = _nullspace(E * half, e - E @ mid)
        if ns is None:
            return None
        y0, N = ns
    else:
        y0, N = np.zeros(d), np.eye(d)
    Aw, bw = _unit_rows(Ay @ N, by - Ay @ y0)
    Mh = M * half
    L = Mh @ N
    c = M @ mid + v + Mh @ y0
    return _linear_image(Aw, bw, L, c, method, HULL_PROJECTION_MAX_DIM if hull_max_dim is None else hull_max_dim)


def _linear_image(Aw, bw, L, c, method: str, hull_max_dim: int) -> _Image:
    """``{L w + c : Aw w <= bw}`` for a non-empty source polytope."""
    k, r = L.shape
    if r == 0 or not np.any(L):
        return _point_image(c)
    U, s, Vt = np.linalg.svd(L, full_matrices=True)
    rank = int(np.sum(s > RANK_RTOL * s[0]))
    if rank < k:
        # The image lies in c + range(L): project onto range coordinates, then embed.
        Ur, Up = U[:, :rank], U[:, rank:]
        sub = _linear_image(Aw, bw, s[:rank, None] * Vt[:rank], np.zeros(rank), method, hull_max_dim)
        H = sub.H @ Ur.T
        eq = Up.T @ c
        pts = None if sub.points is None else c + sub.points @ Ur.T
        return _Image(
            np.vstack([H, Up.T, -Up.T]),
            np.concatenate([sub.h + H @ c, eq, -eq]),
            pts,
        )
    # Image bounding box (2k LPs): fixes the target scaling and gives the first support points.
    lo, hi = np.full(k, -np.inf), np.full(k, np.inf)
    pts = []
    for i in range(k):
        for sign, out in ((1.0, hi), (-1.0, lo)):
            res = _lp(-sign * L[i], Aw, bw, problem=f"bounding box of the image, coordinate {i + 1}")
            if res.status == "infeasible":
                raise SolverError("bounding box of the image", "HiGHS (solve_lp)", "infeasible", hint="the source was found non-empty; rescale the data")
            if res.status == "optimal":
                x = L @ res.x + c
                out[i] = x[i]
                pts.append(x)
    bounded = bool(np.all(np.isfinite(lo)) and np.all(np.isfinite(hi)))
    if method == "hull" and not bounded:
        raise ModelError("polytope", "a bounded image for method='hull' (use 'fm' or 'auto')", "an unbounded image")
    use_hull = method == "hull" or (method == "auto" and bounded and k <= hull_max_dim)
    mid, half = _unit_box_map(lo, hi)
    Ls = L / half[:, None]
    cs = (c - mid) / half
    if use_hull:
        G, g, P = _iterative_hull(_Support(Aw, bw, Ls, cs), [(p - mid) / half for p in pts], k)
        points = mid + P * half
    else:
        G, g = _fm_image(Aw, bw, Ls, cs)
        points = None
    H = G / half
    H, h = _unit_rows(H, g + H @ mid) if H.shape[0] else (H, g)
    return _Image(H, h, points)


class _Support:
    """Support function ``d -> (max d'y, argmax y)`` of ``{Ls w + cs : A w <= b}``, one LP each."""

    def __init__(self, A, b, Ls, cs):
        self.A, self.b, self.Ls, self.cs = A, b, Ls, cs
        self.n_lp = 0

    def __call__(self, direction: np.ndarray) -> tuple[float, np.ndarray]:
        self.n_lp += 1
        if self.n_lp > HULL_MAX_SUPPORT_LPS:
            raise SolverError(
                "iterative-hull projection",
                "HiGHS + qhull",
                f"no convergence after {HULL_MAX_SUPPORT_LPS} support LPs",
                hint="use method='fm', or rescale the data",
            )
        res = _lp(-(self.Ls.T @ direction), self.A, self.b, problem="support function of a projection")
        if res.status != "optimal":
            raise SolverError(
                "support function of a projection",
                "HiGHS (solve_lp)",
                res.status,
                hint="the image was found non-empty and bounded before; rescale the data",
            )
        y = self.Ls @ res.x + self.cs
        return float(direction @ y), y


def _dedupe_points(pts: list[np.ndarray]) -> list[np.ndarray]:
    kept: list[np.ndarray] = []
    for p in pts:
        if not kept or np.min(np.linalg.norm(np.array(kept) - p, axis=1)) > PROJECTION_HULL_RTOL:
            kept.append(p)
    return kept


def _match_planes(planes: np.ndarray, known: np.ndarray) -> np.ndarray:
    """Index into ``known`` of the plane equal to each row of ``planes`` (``-1`` if none).

    Planes are rows ``(normal, offset)``; equal means within PROJECTION_HULL_RTOL in both.
    """
    out = np.full(planes.shape[0], -1)
    if known.shape[0] == 0 or planes.shape[0] == 0:
        return out
    for start in range(0, planes.shape[0], _MATCH_CHUNK):
        block = planes[start : start + _MATCH_CHUNK]
        dist = np.max(np.abs(block[:, None, :] - known[None, :, :]), axis=2)
        j = np.argmin(dist, axis=1)
        hit = dist[np.arange(block.shape[0]), j] <= PROJECTION_HULL_RTOL
        out[start : start + _MATCH_CHUNK] = np.where(hit, j, -1)
    return out


_MATCH_CHUNK = 2048  # planes compared per vectorised block (bounds the memory of the distance array)


def _iterative_hull(support: Callable[[np.ndarray], tuple[float, np.ndarray]], pts: list[np.ndarray], k: int):
    """Hull of a convex set known by its support function, in coordinates scaled to ``[-1, 1]^k``.

    Returns ``(G, g, V)``: the set is ``{y : G y <= g}`` and ``V`` its vertices.
    """
    pts = _dedupe_points(pts)
    while True:
        P = np.array(pts)
        p0 = P.mean(axis=0)
        _, sv, Vt = np.linalg.svd(P - p0, full_matrices=True)
        rank = int(np.sum(sv > AFFINE_HULL_RTOL))
        if rank == k:
            break
        grew = False
        for n in Vt[rank:]:
            for sign in (1.0, -1.0):
                val, y = support(sign * n)
                if val > sign * (n @ p0) + PROJECTION_HULL_RTOL:
                    pts.append(y)
                    grew = True
        if not grew:
            break
        pts = _dedupe_points(pts)
    if rank < k:
        # Flat image: recurse inside its affine hull p0 + span(B'), return the normals as equalities.
        B, Nn = Vt[:rank], Vt[rank:]
        if rank == 0:
            G, g, V = np.zeros((0, k)), np.zeros(0), p0[None, :]
        else:

            def sub(dt: np.ndarray) -> tuple[float, np.ndarray]:
                val, y = support(B.T @ dt)
                return val - (B.T @ dt) @ p0, (y - p0) @ B.T

            Gt, gt, Vt_ = _iterative_hull(sub, [(p - p0) @ B.T for p in pts], rank)
            G = Gt @ B
            g = gt + G @ p0
            V = p0 + Vt_ @ B
        eq = Nn @ p0
        return np.vstack([G, Nn, -Nn]), np.concatenate([g, eq, -eq]), V
    if k == 1:
        hi, y_hi = support(np.array([1.0]))
        neg_lo, y_lo = support(np.array([-1.0]))
        return np.array([[1.0], [-1.0]]), np.array([hi, neg_lo]), np.array([y_lo, y_hi])
    confirmed = np.zeros((0, k + 1))  # rows (normal, offset) proved to support the image
    while True:
        hull = _convex_hull(np.array(pts))
        planes = np.hstack([hull.equations[:, :-1], -hull.equations[:, -1:]])
        match = _match_planes(planes, confirmed)
        todo = planes[match < 0]
        if todo.shape[0]:
            # coplanar simplices of one facet: test the plane once
            _, first = np.unique(np.round(todo / PROJECTION_HULL_RTOL), axis=0, return_index=True)
            todo = todo[np.sort(first)]
        new: list[np.ndarray] = []
        found = []
        for plane in todo:
            n, h = plane[:-1], plane[-1]
            # a facet that already sees a point found in this round will not survive the rebuild
            if new and np.max(np.array(new) @ n) > h + PROJECTION_HULL_RTOL:
                continue
            val, y = support(n)
            if val > h + PROJECTION_HULL_RTOL:
                new.append(y)
            else:
                found.append(np.append(n, max(val, h)))
        if found:
            confirmed = np.vstack([confirmed, np.array(found)])
        if not new:
            break
        pts = _dedupe_points(pts + new)
    used = np.unique(_match_planes(planes, confirmed))
    final = confirmed[used[used >= 0]]
    return final[:, :-1], final[:, -1], hull.points[hull.vertices]


def _convex_hull(points: np.ndarray) -> ConvexHull:
    """qhull with its default (merged-facet) options, retried with joggled input ("QJ").

    From 5-D up, near-coplanar support points can make qhull's facet merging fail with a
    "dupridge" topology error; joggling by ~1e-11 (relative) avoids it, and the joggled facets of
    one true facet are merged again by the PROJECTION_HULL_RTOL plane comparison.
    """
    _spatial.bind(globals())
    try:
        return ConvexHull(points)
    except QhullError:
        pass
    try:
        return ConvexHull(points, qhull_options="QJ")
    except QhullError as exc:
        raise SolverError("iterative-hull projection", "qhull", str(exc).splitlines()[0], hint="use method='fm'") from None


def _fm_image(Aw, bw, Ls, cs) -> tuple[np.ndarray, np.ndarray]:
    """``{Ls w + cs : Aw w <= bw}`` by Fourier-Motzkin (``Ls`` of full row rank ``k``).

    ``Ls`` is completed by an orthonormal basis of its null space to an invertible ``T``; in
    ``u = T w + (cs, 0)`` the image is the projection onto the first ``k`` coordinates, and the
    others are eliminated one at a time (cheapest first).  After each step, rows built from more
    than ``s + 1`` rows of the starting system (``s`` = variables eliminated so far) are dropped
    (Chernikov's rule: such rows are always redundant), then the LP redundancy removal of
    :func:`irredundant` runs, with its qhull polar prefilter.
    """
    k, r = Ls.shape
    _, _, Vt = np.linalg.svd(Ls, full_matrices=True)
    T = np.vstack([Ls, Vt[k:]])
    Au = np.linalg.solve(T.T, Aw.T).T
    bu = bw + Au @ np.concatenate([cs, np.zeros(r - k)])
    Au, bu, nz = _unit_rows_mask(Au, bu)
    keep = irredundant(Au, bu, polar_prefilter=True)
    Au, bu = Au[keep], bu[keep]
    anc = np.eye(Au.shape[0], dtype=bool)  # ancestors of each row among the starting rows
    labels = list(range(r))
    eliminated = 0
    while len(labels) > k:
        best, cost = -1, None
        for j, lab in enumerate(labels):
            if lab < k:
                continue
            npos = int(np.sum(Au[:, j] > ZERO_ROW_TOL))
            nneg = int(np.sum(Au[:, j] < -ZERO_ROW_TOL))
            cj = npos * nneg - npos - nneg
            if cost is None or cj < cost:
                best, cost = j, cj
        Au, bu, anc = _fm_step(Au, bu, best, anc)
        labels.pop(best)
        eliminated += 1
        few = anc.sum(axis=1) <= eliminated + 1
        Au, bu, anc = Au[few], bu[few], anc[few]
        Au, bu, nz = _unit_rows_mask(Au, bu)
        anc = anc[nz]
        keep = irredundant(Au, bu, polar_prefilter=True)
        Au, bu, anc = Au[keep], bu[keep], anc[keep]
    return Au, bu


def _unit_rows_mask(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    norms = np.linalg.norm(A, axis=1)
    keep = norms > ZERO_ROW_TOL
    return A[keep] / norms[keep, None], b[keep] / norms[keep], keep


def _fm_step(A: np.ndarray, b: np.ndarray, j: int, anc: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Eliminate column ``j``: rows without it, plus every positive/negative pair combined.

    Pairs are combined as ``|a_nj| row_p + a_pj row_n`` (products, no division), so small
    pivots cannot blow up the coefficients.  ``anc`` (rows x starting rows, bool) is carried
    along: a combined row's ancestors are the union of its parents'.
    """
    a = A[:, j]
    pos = np.nonzero(a > ZERO_ROW_TOL)[0]
    neg = np.nonzero(a < -ZERO_ROW_TOL)[0]
    zer = np.nonzero(np.abs(a) <= ZERO_ROW_TOL)[0]
    wp = a[pos][:, None]
    wn = -a[neg][None, :]
    n_new = pos.size * neg.size
    newA = (A[pos][:, None, :] * wn[..., None] + A[neg][None, :, :] * wp[..., None]).reshape(n_new, A.shape[1])
    newb = (b[pos][:, None] * wn + b[neg][None, :] * wp).reshape(n_new)
    newanc = (anc[pos][:, None, :] | anc[neg][None, :, :]).reshape(n_new, anc.shape[1])
    A2 = np.vstack([A[zer], newA])
    b2 = np.concatenate([b[zer], newb])
    return np.delete(A2, j, axis=1), b2, np.vstack([anc[zer], newanc])


#: Old private name (kept for scripts that reached it).
_image_of = image_of

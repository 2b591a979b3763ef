"""Redundancy removal for H-polytopes: the rows of ``{A z <= b}`` that are facets.

One LP per row decides whether a row is implied by the others, accelerated by grouping parallel
rows, ray-shooting certificates of non-redundancy from the Chebyshev centre, an optional qhull
prefilter on the polar points (Fourier-Motzkin's thousands of rows) and Clarkson's algorithm
(LPs over the rows already proved to be facets); and, faster, from a checked vertex set
(:func:`facets_from_vertices`, the library path of :meth:`Polytope.remove_redundant`).  Used by
:meth:`hybobs_opt.geometry.polytope.Polytope.remove_redundant` and the projections of
:mod:`hybobs_opt.geometry.projection`.
"""

from __future__ import annotations

import numpy as np

from . import _spatial
from ..errors import SolverError
from ..tolerances import (
    FULL_DIMENSION_RTOL,
    PARALLEL_ROW_TOL,
    RAY_TIE_RTOL,
    REDUNDANCY_RTOL,
    VERTEX_RANK_RTOL,
    ZERO_ROW_TOL,
)
from ._common import _lp
from ._vertex_kernels import facet_kernel
from .lp import solve_lp

ConvexHull = QhullError = None  # scipy.spatial's, bound at their first use (_spatial.bind)

#: Largest dimension in which Fourier-Motzkin's redundancy removal first drops rows by one qhull
#: call on the polar points (thousands of rows in < 1 s up to 6-D; qhull slows sharply beyond).
FM_QHULL_MAX_DIM: int = 6


def irredundant(A: np.ndarray, b: np.ndarray, polar_prefilter: bool = False) -> np.ndarray:
    """Mask of the rows of the non-empty ``{A z <= b}`` (unit rows, unit-box scaled) that are kept.

    A row is dropped when its maximum over the other kept rows exceeds ``b_i`` by at most
    ``REDUNDANCY_RTOL (1 + |b_i|)``; one LP per row decides, with these accelerations:

    * parallel rows are grouped without LPs (the tightest is kept: no duplicates survive);
    * rows certified non-redundant by ray shooting from the Chebyshev centre skip their LP (the
      certificate is a point beyond the row, inside all others, by more than the tolerance);
    * with ``polar_prefilter`` (used by Fourier-Motzkin on thousands of rows), rows whose polar
      points ``a_i / (b_i - a_i c)`` are not vertices of their convex hull are dropped first by a
      single qhull call (exact up to qhull's roundoff, far below REDUNDANCY_RTOL);
    * the LPs use only the rows already proved non-redundant (Clarkson's algorithm): if the
      optimum violates another row, the ray from the centre to it names one more facet, which is
      added and the LP repeated.  LPs stay the size of the output, not of the input.
    """
    k, d = A.shape
    active = np.zeros(k, dtype=bool)
    if k == 0:
        return active
    # Parallel rows: group on a grid of spacing PARALLEL_ROW_TOL, keep the smallest b per group.
    keys = np.round(A / PARALLEL_ROW_TOL).astype(np.int64)
    order = np.lexsort(np.vstack([b, keys.T[::-1]]))
    first = np.ones(k, dtype=bool)
    first[1:] = np.any(keys[order][1:] != keys[order][:-1], axis=1)
    active[order[first]] = True
    certified = np.zeros(k, dtype=bool)
    centre = None
    if active.sum() > d + 1:
        certified, centre = _prefilter(A, b, active, polar_prefilter)
    tol = REDUNDANCY_RTOL * (1.0 + np.abs(b))
    for i in np.nonzero(active & ~certified)[0]:
        if centre is not None and _clarkson_test(A, b, i, active, certified, centre, tol):
            continue
        active[i] = False
        # The copy of row i relaxed by 1 (the size of the unit box) keeps the LP bounded.
        res = _redundancy_lp(A, b, i, active)
        if -res.objective > b[i] + tol[i]:
            active[i] = True
    return active


def _redundancy_lp(A: np.ndarray, b: np.ndarray, i: int, rows: np.ndarray):
    """``max a_i z`` over ``rows`` and ``a_i z <= b_i + 1`` (the relaxed copy keeps it bounded)."""
    res = _lp(-A[i], np.vstack([A[rows], A[i]]), np.concatenate([b[rows], [b[i] + 1.0]]), problem=f"redundancy test of row {i}")
    if res.status != "optimal":
        raise SolverError(
            f"redundancy test of row {i}",
            "HiGHS (solve_lp)",
            res.status,
            hint="the set was found non-empty before; rescale the data (huge/small coefficients)",
        )
    return res


def _clarkson_test(A, b, i, active, facets, centre, tol) -> bool:
    """Decide row ``i`` with LPs over the known facets only; updates ``active`` and ``facets``.

    Returns False when a tie of the ray test leaves the question open (the caller then runs the
    LP over all active rows).
    """
    beta = b - A @ centre
    while not facets[i]:
        rows = facets.copy()
        rows[i] = False
        res = _redundancy_lp(A, b, i, rows)
        if -res.objective <= b[i] + tol[i]:
            active[i] = False  # redundant already with respect to a subset of the other rows
            return True
        z = res.x
        others = active.copy()
        others[i] = False
        if not np.any(A[others] @ z - b[others] > tol[others]):
            facets[i] = True  # z is inside all other rows and beyond row i
            return True
        # The first row crossed on the way from the centre to z is a facet (if the crossing is unique).
        idx = np.nonzero(active)[0]
        proj = A[idx] @ (z - centre)
        with np.errstate(divide="ignore"):
            t = np.where(proj > ZERO_ROW_TOL, beta[idx] / np.where(proj > ZERO_ROW_TOL, proj, 1.0), np.inf)
        two = np.argsort(t)[:2]
        if t[two[1]] - t[two[0]] <= RAY_TIE_RTOL * t[two[0]] or facets[idx[two[0]]]:
            return False  # a tie, or LP noise pointing back at a known facet: let the full LP decide
        facets[idx[two[0]]] = True
    return True


def _prefilter(A: np.ndarray, b: np.ndarray, active: np.ndarray, polar: bool) -> tuple[np.ndarray, np.ndarray | None]:
    """Cheap redundancy facts before the per-row LPs; updates ``active`` in place.

    Returns the mask of rows certified non-redundant and the interior point used (the Chebyshev
    centre), or ``None`` when the Chebyshev radius is not above FULL_DIMENSION_RTOL (then nothing
    is done: the per-row LPs decide).
    """
    k, d = A.shape
    certified = np.zeros(k, dtype=bool)
    idx = np.nonzero(active)[0]
    Aa, ba = A[idx], b[idx]
    c_lp = np.zeros(d + 1)
    c_lp[-1] = -1.0
    bounds = [(None, None)] * d + [(None, 1.0)]  # radius capped: the set may be unbounded
    res = solve_lp(c_lp, np.hstack([Aa, np.ones((idx.size, 1))]), ba, bounds=bounds, problem="Chebyshev centre for redundancy removal")
    if res.status != "optimal" or res.x[-1] <= FULL_DIMENSION_RTOL:
        return certified, None
    centre = res.x[:d]
    beta = ba - Aa @ centre  # >= radius > 0
    if polar and d <= FM_QHULL_MAX_DIM and d >= 2:
        polar_pts = np.vstack([Aa / beta[:, None], np.zeros((1, d))])
        _spatial.bind(globals())
        try:
            hull = ConvexHull(polar_pts)
        except QhullError:
            pass  # the set contains a line: the polar points are flat; the LPs decide
        else:
            vert = np.zeros(idx.size + 1, dtype=bool)
            vert[hull.vertices] = True
            active[idx[~vert[:-1]]] = False
            keep = vert[:-1]
            idx, Aa, ba, beta = idx[keep], Aa[keep], ba[keep], beta[keep]
    if idx.size < 2:
        return certified, centre
    # Ray shooting: along each row normal and along random directions from the centre.  The
    # first row hit is a facet if the ray can go on, past it by more than the tolerance, before
    # hitting the second row.
    rng = np.random.default_rng(0)
    n_rays = max(_RAY_BUDGET // idx.size, 1)
    normals = Aa if idx.size <= n_rays else Aa[rng.choice(idx.size, n_rays, replace=False)]
    n_random = min(_RAYS_PER_ROW * idx.size, n_rays - normals.shape[0])
    dirs = np.vstack([normals, rng.normal(size=(n_random, d))])
    proj = dirs @ Aa.T  # (n_dirs, n_rows)
    with np.errstate(divide="ignore"):
        t = np.where(proj > ZERO_ROW_TOL, beta[None, :] / np.where(proj > ZERO_ROW_TOL, proj, 1.0), np.inf)
    two = np.argpartition(t, 1, axis=1)[:, :2]
    rows_n = np.arange(t.shape[0])
    t1, t2 = t[rows_n, two[:, 0]], t[rows_n, two[:, 1]]
    swap = t2 < t1
    first_row = np.where(swap, two[:, 1], two[:, 0])
    t_first, t_second = np.minimum(t1, t2), np.maximum(t1, t2)
    excess = (np.minimum(t_second, t_first + _RAY_CAP) - t_first) * proj[rows_n, first_row]
    ok = np.isfinite(t_first) & (excess > REDUNDANCY_RTOL * (1.0 + np.abs(ba[first_row])))
    certified[idx[first_row[ok]]] = True
    return certified, centre


_RAYS_PER_ROW = 20  # random rays per row for the non-redundancy certificates (cheap numpy work)
_RAY_BUDGET = 4_000_000  # cap on rays x rows (~32 MB per array) for sets with thousands of rows
_RAY_CAP = 1.0  # the LP test relaxes a row by 1 in unit-box coordinates: same cap for the rays


def facets_from_vertices(A: np.ndarray, b: np.ndarray, Y: np.ndarray, tight: np.ndarray) -> np.ndarray | str:
    """Mask of the rows of ``{A y <= b}`` to keep, decided from its checked vertex set, or why not.

    ``A`` holds unit rows in coordinates scaled to the vertices' box, ``Y`` the complete vertex
    set of the (bounded) polytope and ``tight`` its vertex-row incidence, as the verified
    enumeration of :func:`hybobs_opt.geometry.vertices.enumerate_vertices` returns them.  Parallel
    rows are grouped first as in :func:`irredundant` (the tightest kept).  A row is kept when it is a facet: its
    tight vertices span an affine space of dimension ``d - 1``; every other row is implied, since
    a full-dimensional polytope is the intersection of its facets' halfspaces and the vertex set is
    complete.  Each kept row must also carry a certificate of non-redundancy checked in numpy: the
    centroid of its facet pushed out by ``3 REDUNDANCY_RTOL (1 + |b_i|)`` satisfies every other
    kept row and violates this one by more than REDUNDANCY_RTOL (1 + |b_i|), the tolerance of the
    LP test of :func:`irredundant`.  A row without one (a near-duplicate, a facet thinner than the
    tolerance) makes the answer a string, and the caller decides by LPs instead.

    The work runs in one compiled call (:func:`hybobs_opt.geometry._vertex_kernels.facet_kernel`).

    Returns
    -------
    (m,) bool array or str
        The rows kept, or the reason the vertex set does not decide.
    """
    code, row, facet = facet_kernel(np.ascontiguousarray(A, dtype=float), np.ascontiguousarray(b, dtype=float),
                                    np.ascontiguousarray(Y, dtype=float), np.ascontiguousarray(tight),
                                    PARALLEL_ROW_TOL, VERTEX_RANK_RTOL, REDUNDANCY_RTOL)
    return facet_verdict(code, row, facet, A.shape[1])


def facet_verdict(code: int, row: int, facet: np.ndarray, d: int) -> np.ndarray | str:
    """:func:`facets_from_vertices`'s answer from :func:`~hybobs_opt.geometry._vertex_kernels.facet_kernel`'s result."""
    if code == 1:
        return "the vertices span less than the whole space: the set is not full-dimensional"
    if code == 2:
        return f"only {int(facet.sum())} facets found in dimension {d}"
    if code == 3:
        return f"row {row} is a facet without a checked witness of non-redundancy"
    return facet


#: Old private name (kept for scripts that reached it).
_irredundant = irredundant

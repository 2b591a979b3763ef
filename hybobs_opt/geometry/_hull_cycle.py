"""The check of a triangulated convex hull: its simplices form the whole boundary, each once.

qhull's ``ConvexHull`` answers with simplices (its facets triangulated, option ``Qt``).  A list
of simplices with vertices among the points ``Y`` is accepted as the boundary of ``conv(Y)`` when

1. the simplices' planes, merged into facets, support the points: every point on the inner side
   to VERTEX_CHECK_RTOL, each simplex's vertices on its facet's plane to VERTEX_TIGHT_RTOL, the
   centroid ``c`` strictly inside (by FULL_DIMENSION_RTOL), no two facets with the same tight
   points; so each simplex lies in a face of ``conv(Y)``;
2. a simplex is *full* when its determinant about ``c`` is far from rounding
   (:data:`~hybobs_opt.tolerances.FULL_SIMPLEX_RTOL` of Hadamard's bound); its sign is its orientation as seen from
   ``c``.  Qhull's triangulation of a non-simplicial facet also holds flat simplices (zero
   volume); they are given the orientations their neighbours require;
3. no simplex is listed twice, every ridge (``d - 1`` of the vertices of a simplex) is a ridge of
   exactly two simplices, and these induce opposite orientations on it (integer decisions on
   vertex indices, not tolerances): the simplices form an oriented (d-1)-cycle;
4. the ray from ``c`` through one test point (the vertex mean of a large full simplex) meets
   exactly one full simplex, each decided with a margin on its barycentric weights.

By 3 the radial map of the cycle onto the sphere about ``c`` has a constant degree ``k``; by 1
and 2 every full simplex counts +1 where it covers (flat ones cover nothing open), and by 4
``k = 1``.  So every ray from ``c`` meets the simplices once: every boundary point of
``conv(Y)`` lies in a simplex, hence every facet of ``conv(Y)`` holds a full simplex whose plane is
that facet's (none missing, and by 1 each listed plane is a facet, once), and the sum of the full
simplices' pyramid volumes about ``c`` is the volume of ``conv(Y)``.  The cost is linear in the
simplices (a few numpy products and one sort of the ridges), not in subsets of the points on a
facet, so degenerate point sets (duplicates, points on facets, non-simplicial facets) are checked
as fast as general ones.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from . import _spatial
from ..tolerances import (
    AFFINE_HULL_RTOL,
    FULL_DIMENSION_RTOL,
    FULL_SIMPLEX_RTOL,
    HULL_RAY_WEIGHT_MARGIN,
    VERTEX_CHECK_RTOL,
    VERTEX_SAME_RTOL,
    VERTEX_TIGHT_RTOL,
)
from . import _vertex_kernels as _K
from ._vertex_kernels import polygon_kernel, triangulation_kernel

ConvexHull = QhullError = None  # scipy.spatial's, bound at their first use (_spatial.bind)

#: The kernel's answers that refuse the hull outright (the numpy path's messages, :func:`_facets`).
_FACET_REASONS = {
    _K.TRI_FEW: "fewer than d + 1 simplices",
    _K.TRI_NOT_FINITE: "a plane is not finite",
    _K.TRI_POINT_VIOLATES: "a point violates a facet's plane",
    _K.TRI_OFF_PLANE: "a simplex's vertex is off its facet's plane",
    _K.TRI_CENTROID_ON_FACET: "the centroid lies on a facet's plane",
    _K.TRI_DUPLICATE_FACETS: "duplicate facets",
}


def _generic(n: int) -> np.ndarray:
    """``n`` fixed weights in [1, 2), the same on every machine (PCG64 with a fixed seed is
    specified bit for bit, and a longer draw keeps the prefix): a key ``r @ w`` of integer rows
    collides for distinct rows only by accident, and every use refuses, never accepts, on one."""
    w = _WEIGHTS[0]
    if n > w.size:
        w = _WEIGHTS[0] = 1.0 + np.random.Generator(np.random.PCG64(39)).random(2 * n)
    return w[:n]


_WEIGHTS = [1.0 + np.random.Generator(np.random.PCG64(39)).random(1024)]


def _propagate(orient, oa, ob, pa, pb):
    """Orientations of the degenerate simplices (0 in ``orient``) that make every ridge cancel.

    A degenerate simplex covers no open set; it is given the orientation its neighbours across
    a ridge require (any consistent choice where none is fixed), so that the chain is a cycle.
    """
    orient = orient.copy()
    while np.any(orient == 0):
        changed = True
        while changed:
            fa = (orient[oa] != 0) & (orient[ob] == 0)
            fb = (orient[ob] != 0) & (orient[oa] == 0)
            orient[ob[fa]] = -orient[oa[fa]] * pa[fa] * pb[fa]
            orient[oa[fb]] = -orient[ob[fb]] * pa[fb] * pb[fb]
            changed = bool(fa.any() or fb.any())
        free = np.nonzero(orient == 0)[0]
        if free.size:
            orient[free[0]] = 1.0
    return orient


def _cover_count(W: np.ndarray, full: np.ndarray) -> int:
    """How many full simplices (vertices ``W`` about the centroid) the ray through a test point meets.

    The test point is the vertex mean of a full simplex (barycentric weights ``1/d`` in it); a
    simplex contains its ray when every weight is above ``+margin``, misses it when one is below
    ``-margin``; otherwise the next candidate is tried.  Returns ``0`` when no candidate is decided.
    """
    d = W.shape[1]
    margin = HULL_RAY_WEIGHT_MARGIN
    idx = np.nonzero(full)[0]
    vol = np.abs(np.linalg.det(W[idx]))
    for t in idx[np.argsort(-vol, kind="stable")][:5]:
        u = W[t].mean(axis=0)
        try:
            lam = np.linalg.solve(np.transpose(W[idx], (0, 2, 1)), np.broadcast_to(u, (idx.size, d))[..., None])[..., 0]
        except np.linalg.LinAlgError:
            return 0
        lo = lam.min(axis=1)
        if np.any((lo > -margin) & (lo <= margin)):
            continue
        return int(np.count_nonzero(lo > margin))
    return 0


@dataclass(slots=True)
class CheckedHull:
    """The checked facets of ``conv(Y)`` and its volume (see the module docstring).

    Attributes
    ----------
    G, g : (k, d), (k,) arrays
        One unit row ``G y <= g`` per facet.
    tight : (k, n) bool array
        The points on each facet (slack at most VERTEX_TIGHT_RTOL).
    volume : float
        The volume of ``conv(Y)``.
    how : str
        ``"simplices"`` (qhull's triangulation passed) or ``"facets"`` (the ridge closure).
    """

    G: np.ndarray
    g: np.ndarray
    tight: np.ndarray
    volume: float
    how: str


def checked_hull(Y: np.ndarray, options: str | None = None) -> CheckedHull | str:
    """Facets and volume of ``conv(Y)`` from qhull, checked; or why not.

    qhull's triangulation is checked as a cycle (points 1-4 of the module docstring).  When it
    does not close up (qhull triangulates each non-simplicial facet on its own, and in 5-6 D the
    pieces need not match), the facets are checked one level down instead: each facet's points,
    in coordinates of its plane, have their own checked hull (this function in ``d - 1``), each
    ridge found there must lie on a second facet (so the facets are closed under adjacency, and
    the facet graph of a polytope being connected, none is missing), and the volume is the sum of
    the pyramids over the facets, ``depth * area / d``.  In 2-D the hull is a monotone chain and
    in 3-D qhull's triangulation is checked, both in one compiled call each
    (:func:`~hybobs_opt.geometry._vertex_kernels.polygon_kernel`,
    :func:`~hybobs_opt.geometry._vertex_kernels.triangulation_kernel`: the same checks as
    :func:`_polygon`, :func:`_facets` and :func:`_cycle`, which answer where the kernel does not).

    Parameters
    ----------
    Y : (n, d) array
        The points (about the box ``[-1, 1]^d``; the tolerances are absolute in these units).
    options : str, optional
        qhull options (``None``: scipy's defaults).
    """
    n, d = Y.shape
    if d == 1:
        lo, hi = float(Y[:, 0].min()), float(Y[:, 0].max())
        if hi - lo <= FULL_DIMENSION_RTOL:
            return "flat: the points coincide"
        G, g = np.array([[1.0], [-1.0]]), np.array([hi, -lo])
        tight = g[:, None] - G @ Y.T <= VERTEX_TIGHT_RTOL
        return CheckedHull(G, g, tight, hi - lo, "simplices")
    if n <= d:
        return "fewer than d + 1 points: not full-dimensional"
    if d == 2:
        code, _, G, g, tight, area = polygon_kernel(np.ascontiguousarray(Y, dtype=float), FULL_DIMENSION_RTOL,
                                                    FULL_SIMPLEX_RTOL, VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL)
        if code == 0:
            return CheckedHull(G, g, tight, area, "simplices")
        return _polygon(Y)
    _spatial.bind(globals())
    try:
        with np.errstate(all="ignore"):
            hull = ConvexHull(Y, qhull_options=options)
    except (QhullError, ValueError) as exc:
        return f"qhull: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
    eq = hull.equations
    S, G, g = hull.simplices, np.ascontiguousarray(eq[:, :-1]), -eq[:, -1]
    c = Y.mean(axis=0)
    if d >= 3:  # the same checks in one compiled call (numpy's ~50 small calls cost 3 x qhull's hull here)
        try:
            code, reps, tight, depth, volume = triangulation_kernel(
                np.ascontiguousarray(Y, dtype=float), c, np.ascontiguousarray(S, dtype=np.int64), G, g,
                _generic(d + 1), _generic(n), VERTEX_SAME_RTOL, VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL,
                FULL_DIMENSION_RTOL, FULL_SIMPLEX_RTOL)
        except (ValueError, ZeroDivisionError, np.linalg.LinAlgError):  # a singular full simplex: not expected
            code = _K.TRI_UNDECIDED
            reps = None
        if code == 0:
            return CheckedHull(G[reps], g[reps], tight, volume, "simplices")
        if code in _FACET_REASONS:
            return _FACET_REASONS[code]
        if code != _K.TRI_KEYS_TOO_LARGE and reps is not None:
            return _ridge_closure(Y, G[reps], g[reps], tight, depth)
    facets = _facets(Y, c, S, G, g)
    if isinstance(facets, str):
        return facets
    reps, tight, depth = facets
    cycle = _cycle(Y, c, S)
    if not isinstance(cycle, str):
        return CheckedHull(G[reps], g[reps], tight, cycle, "simplices")
    return _ridge_closure(Y, G[reps], g[reps], tight, depth)


def _polygon(Y: np.ndarray) -> CheckedHull | str:
    """The 2-D case of :func:`checked_hull`: qhull's counter-clockwise hull vertices, checked.

    Every point on the inner side of every edge (VERTEX_CHECK_RTOL), every turn strictly to the
    left (the sine of the angle between consecutive edges above FULL_SIMPLEX_RTOL, so the
    vertices are distinct and no two edges collinear) and the turns summing to one full turn
    (winding number 1): the polygon is then convex, its vertices are points of ``Y`` and every
    point lies in it, so it is ``conv(Y)``, one row per edge.
    """
    _spatial.bind(globals())
    try:
        with np.errstate(all="ignore"):
            hull = ConvexHull(Y)
    except (QhullError, ValueError) as exc:
        return f"qhull: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
    V = Y[hull.vertices]
    k = V.shape[0]
    if k < 3:
        return "fewer than 3 hull vertices"
    nxt = np.arange(1, k + 1)
    nxt[-1] = 0
    E = V[nxt] - V  # edge j from vertex j to vertex j + 1
    L = np.sqrt(E[:, 0] * E[:, 0] + E[:, 1] * E[:, 1])
    F = E[nxt]
    cross = E[:, 0] * F[:, 1] - E[:, 1] * F[:, 0]
    if not (L.min() > FULL_DIMENSION_RTOL and np.all(cross > FULL_SIMPLEX_RTOL * L * L[nxt])):
        return "two hull vertices coincide, or a turn of the hull is not strictly to the left"
    if abs(float(np.arctan2(cross, E[:, 0] * F[:, 0] + E[:, 1] * F[:, 1]).sum()) - 2.0 * np.pi) > 1.0:
        return "the hull winds more than once"
    G = np.empty((k, 2))  # outward normals of a counter-clockwise polygon
    G[:, 0] = E[:, 1] / L
    G[:, 1] = -E[:, 0] / L
    g = G[:, 0] * V[:, 0] + G[:, 1] * V[:, 1]
    slack = g[:, None] - G @ Y.T
    if slack.min() < -VERTEX_CHECK_RTOL:
        return "a point violates an edge"
    area = 0.5 * float(np.sum(V[:, 0] * V[nxt, 1] - V[nxt, 0] * V[:, 1]))
    return CheckedHull(G, g, slack <= VERTEX_TIGHT_RTOL, area, "simplices")


def _ridge_closure(Y, G, g, tight, depth) -> CheckedHull | str:
    """The facet-level check and volume of :func:`checked_hull` (its docstring)."""
    n, d = Y.shape
    volume = 0.0
    for f in range(G.shape[0]):
        idx = np.nonzero(tight[f])[0]
        # an orthonormal basis of the facet's plane: the last d - 1 right singular vectors of its normal
        B = np.linalg.svd(G[f][None, :])[2][1:].T  # (d, d - 1)
        Z = (Y[idx] - Y[idx].mean(axis=0)) @ B
        sub = checked_hull(Z)
        if isinstance(sub, str):
            return f"facet {f}: {sub}"
        for r in range(sub.G.shape[0]):
            pts = idx[sub.tight[r]]
            others = np.all(tight[:, pts], axis=1)
            others[f] = False
            if not others.any():
                return f"a ridge of facet {f} lies on no other facet: a facet is missing"
        volume += depth[f] * sub.volume / d
    return CheckedHull(G, g, tight, volume, "facets")


def check_triangulation(Y: np.ndarray, c: np.ndarray, S: np.ndarray, G: np.ndarray, g: np.ndarray) -> str | tuple:
    """Check simplices ``S`` with planes ``G y <= g`` as the boundary of ``conv(Y)`` (points 1-4).

    Returns why not, or ``(rows, volume)``: one simplex per facet (its plane is the facet's) and
    the volume of ``conv(Y)``.
    """
    facets = _facets(Y, c, S, G, g)
    if isinstance(facets, str):
        return facets
    volume = _cycle(Y, c, S)
    return volume if isinstance(volume, str) else (facets[0], volume)


def _facets(Y: np.ndarray, c: np.ndarray, S: np.ndarray, G: np.ndarray, g: np.ndarray) -> str | tuple:
    """Point 1: the simplices' planes merged into facets that support the points.

    Parameters
    ----------
    Y : (n, d) array
        The points, scaled to about the box ``[-1, 1]^d``.
    c : (d,) array
        Their centroid.
    S : (m, d) int array
        The simplices.
    G, g : (m, d), (m,) arrays
        Each simplex's plane, unit rows, the points on the side ``G y <= g``.

    Returns
    -------
    str or tuple
        Why not, or ``(reps, tight, depth)``: one simplex per facet (the first of those whose planes
        agree on the grid of VERTEX_SAME_RTOL, whose plane stands for the facet), the points on
        each facet, and the centroid's distance to each.
    """
    n, d = Y.shape
    m = S.shape[0]
    if d < 2 or m < d + 1 or S.shape[1] != d:
        return "fewer than d + 1 simplices"
    if not (np.all(np.isfinite(G)) and np.all(np.isfinite(g))):
        return "a plane is not finite"
    # the simplices of one facet: equal planes on the grid of VERTEX_SAME_RTOL (a generic linear key of
    # the grid rows, a 1-D sort); each simplex's vertices must lie on its group's first plane
    key = np.round(np.hstack([G, g[:, None]]) / VERTEX_SAME_RTOL) @ _generic(d + 1)
    _, reps, group = np.unique(key, return_index=True, return_inverse=True)
    rep = reps[group.ravel()]
    Gr, gr = G[reps], g[reps]
    slack = gr[:, None] - Gr @ Y.T  # (facets, n)
    if np.any(slack < -VERTEX_CHECK_RTOL):
        return "a point violates a facet's plane"
    if np.any(np.abs(g[rep][:, None] - np.einsum("mkd,md->mk", Y[S], G[rep])) > VERTEX_TIGHT_RTOL):
        return "a simplex's vertex is off its facet's plane"
    if np.any(gr - Gr @ c <= FULL_DIMENSION_RTOL):
        return "the centroid lies on a facet's plane"
    tight = slack <= VERTEX_TIGHT_RTOL
    # two facets with the same tight points are one: a generic key of each tight set (equal sets, equal
    # keys; distinct sets colliding would only refuse the answer)
    if np.unique(tight @ _generic(n)).size != reps.size:
        return "duplicate facets"
    return reps, tight, gr - Gr @ c


def _cycle(Y: np.ndarray, c: np.ndarray, S: np.ndarray) -> str | float:
    """Points 2-4: the simplices close up and cover the boundary once; their volume, or why not."""
    n, d = Y.shape
    m = S.shape[0]
    Ss = np.sort(S, axis=1)  # orientations are taken relative to the sorted vertex order
    W = Y[Ss] - c  # (m, d, d): the simplices' vertices about the centroid
    det = np.linalg.det(W)
    # a full simplex: |det| (d! times its pyramid's volume, >= depth (d-1)! area) above FULL_SIMPLEX_RTOL
    # times Hadamard's bound, so that rounding cannot flip its sign, the orientation
    full = det * det > FULL_SIMPLEX_RTOL**2 * np.prod(np.einsum("mkd,mkd->mk", W, W), axis=1)
    if not full.any():
        return "every simplex is degenerate"
    orient = np.where(full, np.sign(det), 0.0)
    keep, pos = _ridge_layout(d)
    R = Ss[:, keep].reshape(m * d, d - 1)  # ridge k of simplex i (vertex k left out) is row i d + k
    if float(n) ** d < 2.0**62:  # one integer per sorted simplex / ridge: 1-D sorts, not sorts of rows
        weights = np.int64(n) ** np.arange(d - 1, -1, -1, dtype=np.int64)
        sk = np.sort(Ss @ weights)
        if np.any(sk[1:] == sk[:-1]):
            return "a simplex listed twice"
        rk = R @ weights[1:]
        order = np.argsort(rk, kind="stable")
        rs = rk[order]
        same = lambda i, j: rs[i] == rs[j]  # noqa: E731
    else:
        if np.unique(Ss, axis=0).shape[0] != m:
            return "a simplex listed twice"
        order = np.lexsort(R.T[::-1])
        rs = R[order]
        same = lambda i, j: np.all(rs[i] == rs[j], axis=1)  # noqa: E731
    t = m * d
    ev, od = np.arange(0, t, 2), np.arange(1, t, 2)
    # every ridge exactly twice: sorted, the incidences pair up (2k, 2k + 1) and no pair equals the next
    if t % 2 or not np.all(same(ev, od)) or np.any(same(od[:-1], ev[1:])):
        return "a ridge not shared by exactly two simplices"
    a_, b_ = order[0::2], order[1::2]  # the two incidences of each ridge
    oa, ob, pa, pb = a_ // d, b_ // d, pos[a_ % d], pos[b_ % d]
    if not full.all():
        orient = _propagate(orient, oa, ob, pa, pb)
    if np.any(orient[oa] * pa + orient[ob] * pb != 0):
        return "the simplices do not close up (two simplices on a ridge with the same orientation)"
    covers = _cover_count(W, full)
    if covers != 1:
        return ("the simplices cover the boundary more than once" if covers else
                "no point of the boundary is decided to be covered once")
    return float(np.abs(det[full]).sum()) / math.factorial(d)


_LAYOUTS: dict = {}


def _ridge_layout(d: int) -> tuple[np.ndarray, np.ndarray]:
    """The columns of each ridge of a sorted simplex (vertex ``k`` left out) and its sign ``(-1)^k``."""
    if d not in _LAYOUTS:
        keep = np.array([[j for j in range(d) if j != k] for k in range(d)], dtype=np.int64)
        _LAYOUTS[d] = (keep, np.where(np.arange(d) % 2 == 0, 1.0, -1.0))
    return _LAYOUTS[d]


def volume_by_facets(Y: np.ndarray, A: np.ndarray, b: np.ndarray, tight: np.ndarray) -> float | str:
    """Volume of a polytope ``{A y <= b}`` from its checked vertices ``Y`` and their incidence.

    The pyramids from the vertex mean ``c`` over the facets partition the polytope, so the volume
    is ``sum depth_F area_F / d``; a facet is a row whose tight vertices span ``d - 1`` dimensions
    (rows with the same tight vertices counted once), and its area is the volume of the checked
    hull (:func:`checked_hull`) of those vertices in coordinates of its plane.  The vertex set
    being complete (checked by the edge walk of :mod:`~hybobs_opt.geometry.vertices`), so is each
    facet's.  One (d-1)-dimensional hull per facet instead of one d-dimensional hull of all the
    vertices, whose triangulation qhull does not close up in 5-6 D.

    Parameters
    ----------
    Y : (n, d) array
        The vertices, scaled to about the box ``[-1, 1]^d``.
    A, b : (m, d), (m,) arrays
        Unit rows in the same coordinates.
    tight : (n, m) bool array
        Which rows are tight at each vertex.

    Returns
    -------
    float or str
        The volume, or why it could not be checked.
    """
    n, d = Y.shape
    c = Y.mean(axis=0)
    depth = b - A @ c
    volume = 0.0
    seen = set()
    for j in range(A.shape[0]):
        idx = np.nonzero(tight[:, j])[0]
        if idx.size < d:
            continue
        key = idx.tobytes()
        if key in seen:
            continue
        seen.add(key)
        B = np.linalg.svd(A[j][None, :])[2][1:].T  # an orthonormal basis of the row's plane
        Z = (Y[idx] - Y[idx].mean(axis=0)) @ B
        sv = np.linalg.svd(Z, compute_uv=False)
        if sv[-1] <= AFFINE_HULL_RTOL * max(sv[0], 1.0):
            continue  # a face of lower dimension: no area
        if depth[j] <= FULL_DIMENSION_RTOL:
            return f"the vertex mean lies on facet {j}"
        sub = checked_hull(Z)
        if isinstance(sub, str):
            return f"facet {j}: {sub}"
        volume += depth[j] * sub.volume / d
    return volume

"""Vertex enumeration (H -> V) and convex hulls (V -> H) on pycddlib and qhull, every answer checked.

The libraries the field uses answer in floating point (cddlib's double description with its
absolute zero of 1e-7, qhull's halfspace intersection), so nothing they return is used unchecked
(DESIGN.md).  Both are handed unit rows (the units of each row removed), and their answer is
checked in coordinates scaled so that the returned vertices' box is ``[-1, 1]^d``, with the named
relative tolerances of :mod:`hybobs_opt.tolerances`:

1. every point satisfies every row to VERTEX_CHECK_RTOL;
2. every point is a vertex: its tight rows (slack <= VERTEX_TIGHT_RTOL) have rank ``d``, with
   their smallest singular value above VERTEX_RANK_RTOL; points within VERTEX_SAME_RTOL of each
   other are one vertex;
3. no vertex is missing: every edge of the polytope leaving a returned vertex is walked (the
   ``d`` edge directions of a simple vertex are the columns of ``-A_T^-1``; at a degenerate
   vertex, the extreme rays of its cone of feasible directions, from the (d-1)-subsets of its
   tight rows) and the ratio test must end it on a returned vertex.  The graph of a polytope is
   connected (Balinski), so a vertex set closed under its edges is all of them.  An edge that no
   row stops is a recession direction: a certificate that the set is unbounded.

An empty answer is accepted only with an infeasibility certificate of the LP layer
(:func:`~hybobs_opt.geometry.lp.solve_lp`).  The check costs a few numpy products of size
(vertices x d) x rows and one k-d tree; an answer that fails it goes to the next path (the other
library, then the library in the scaled coordinates, then the caller's hand-written path), and
every fall-back is counted in :data:`COUNTERS` and logged on the ``hybobs_opt.geometry.vertices``
logger.

Which library answers first depends on the dimension (:data:`CDD_FIRST_MAX_DIM`): cddlib is the
fastest on small problems, qhull's halfspace intersection (on an interior point from cddlib's LP)
from 4-D up (measured in ``benchmarks/bench_polytope.py``).  Without pycddlib (the optional extra
``[cdd]``) qhull answers alone, with the interior point from the LP layer.
"""

from __future__ import annotations

import logging
import math
import warnings
from collections import Counter
from dataclasses import dataclass, field
from itertools import combinations

import numpy as np

from . import _spatial
from ..defaults import VERTEX_DEGENERATE_MAX_SUBSETS
from ..tolerances import (
    FULL_DIMENSION_RTOL,
    PARALLEL_ROW_TOL,
    REDUNDANCY_RTOL,
    VERTEX_CHECK_RTOL,
    VERTEX_RANK_RTOL,
    VERTEX_SAME_RTOL,
    VERTEX_TIGHT_RTOL,
    ZERO_ROW_TOL,
)
from . import _vertex_kernels as _K
from ._common import _unit_box_map
from ._hull_cycle import checked_hull
from ._vertex_kernels import (
    cdd_hull_rows,
    check_enumeration,
    hull_check,
    points_to_box,
)

HalfspaceIntersection = QhullError = cKDTree = None  # scipy.spatial's, bound at their first use (_spatial.bind)

log = logging.getLogger(__name__)

#: Dimensions up to which cddlib enumerates vertices first (qhull second); above it qhull first.
#: Measured on random polytopes (benchmarks/bench_polytope.py): cddlib 0.06-0.2 ms at d = 2-3,
#: below qhull's 0.08-0.1 ms plus the interior point; at d = 6 qhull is 3-6 x faster than cddlib.
CDD_FIRST_MAX_DIM: int = 3

_cdd_state: list = []  # [module or None], filled on first use


def cdd_module():
    """The ``cdd`` module of pycddlib >= 3 (``pycddlib`` or ``pycddlib-standalone``), or ``None``.

    ``None`` when it is not installed or is an older pycddlib without the 3.x functions; the
    geometry then uses qhull and the hand-written paths only.
    """
    if not _cdd_state:
        try:
            import cdd  # noqa: PLC0415 (optional dependency, imported on first use)
        except ImportError:
            cdd = None
        if cdd is not None and not all(hasattr(cdd, f) for f in ("matrix_from_array", "polyhedron_from_matrix",
                                                                  "copy_generators", "copy_inequalities",
                                                                  "linprog_from_array")):
            log.info("pycddlib found but without the 3.x API: not used")
            cdd = None
        _cdd_state.append(cdd)
    return _cdd_state[0]


@dataclass
class LibraryCounters:
    """How often a library answer was accepted, and how often (and why) another path answered.

    ``accepted[op]`` counts accepted answers per operation and library (``"vertices:cdd"``),
    ``fallbacks[op]`` answers that failed their check or could not be had (each logged with its
    reason), ``reasons`` the last :data:`_MAX_REASONS` reasons.
    """

    accepted: Counter = field(default_factory=Counter)
    fallbacks: Counter = field(default_factory=Counter)
    reasons: list = field(default_factory=list)

    def accept(self, op: str, source: str) -> None:
        self.accepted[f"{op}:{source}"] += 1

    def fallback(self, op: str, source: str, reason: str) -> None:
        self.fallbacks[f"{op}:{source}"] += 1
        self.reasons.append(f"{op} ({source}): {reason}")
        del self.reasons[:-_MAX_REASONS]
        log.info("geometry %s: the %s answer was not used: %s", op, source, reason)

    def reset(self) -> None:
        self.accepted.clear()
        self.fallbacks.clear()
        self.reasons.clear()

    def snapshot(self) -> dict:
        return {"accepted": dict(self.accepted), "fallbacks": dict(self.fallbacks), "reasons": list(self.reasons)}


_MAX_REASONS = 50

#: Process-wide counters of the library paths (each worker process has its own).
COUNTERS = LibraryCounters()


# ---------------------------------------------------------------------------------------------
# The check
# ---------------------------------------------------------------------------------------------
@dataclass(slots=True)
class CheckedVertices:
    """A vertex set that passed the check, in the scaled coordinates of the check.

    Attributes
    ----------
    Y : (n, d) array
        The vertices (duplicates merged), scaled coordinates.
    tight : (n, m) bool array
        Which rows are tight at each vertex.
    rays : (k, d) array
        Unit recession directions found by the edge walk (``k > 0``: the set is unbounded).
    """

    Y: np.ndarray
    tight: np.ndarray
    rays: np.ndarray


def _finish_check(A, b, Y, code, i, j, keep, T, deg, rays) -> CheckedVertices | str:
    """The kernel's verdict as a reason, or the degenerate vertices' edges walked and the result."""
    d = A.shape[1]
    if code != _K.OK:
        return _KERNEL_REASONS[code].format(i=i, j=j, d=d)
    if deg.size:
        reason = _walk_degenerate(A, b, Y, keep, T, deg, d)
        if isinstance(reason, str):
            return reason
        if reason.shape[0]:
            rays = np.vstack([rays, reason])
    if rays.shape[0] and np.any(rays @ A.T > VERTEX_CHECK_RTOL):
        return "an unblocked edge is not a recession direction"
    return CheckedVertices(Y[keep], T[keep], rays)


_KERNEL_REASONS = {
    _K.INFEASIBLE: "point {i} violates row {j}",
    _K.NOT_A_VERTEX: "point {i} is tight on fewer than {d} rows: not a vertex",
    _K.SINGULAR: "the tight rows of vertex {i} are singular",
    _K.NEARLY_DEPENDENT: "the tight rows of vertex {i} are nearly dependent",
    _K.INCOMPLETE: "incomplete: edge {j} from vertex {i} ends at a point that is not in the set",
}


def _walk_degenerate(A, b, Y, keep, T, deg, d) -> np.ndarray | str:
    """Walk the edges of the degenerate vertices ``deg``; their rays, or why the set fails."""
    S = b[None, :] - Y[deg] @ A.T
    ev, er = [], []
    for k, v in enumerate(deg):
        dirs = _cone_edges(A[T[v]], d)
        if isinstance(dirs, str):
            return f"vertex {v}: {dirs}"
        ev.append(np.full(dirs.shape[0], k))
        er.append(dirs)
    EV = np.concatenate(ev)
    ER = np.concatenate(er)
    ER /= np.linalg.norm(ER, axis=1)[:, None]
    P = ER @ A.T
    blocking = (P > VERTEX_CHECK_RTOL) & ~T[deg][EV]
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(blocking, S[EV] / np.where(blocking, P, 1.0), np.inf)
    step = t.min(axis=1)
    ray = ~np.isfinite(step)
    ends = Y[deg][EV[~ray]] + step[~ray, None] * ER[~ray]
    if ends.shape[0]:
        _spatial.bind(globals())
        dist, _ = cKDTree(Y[keep]).query(ends, k=1, p=np.inf, distance_upper_bound=VERTEX_SAME_RTOL)
        missing = ~np.isfinite(dist)
        if missing.any():
            return f"incomplete: an edge from vertex {deg[EV[~ray][int(np.argmax(missing))]]} ends at a point that is not in the set"
    return ER[ray]


def _cone_edges(AT: np.ndarray, d: int) -> np.ndarray | str:
    """Unit extreme rays of ``{r : AT r <= 0}`` (a degenerate vertex's tight rows ``AT``)."""
    t = AT.shape[0]
    if d == 1:
        cand = np.array([[1.0], [-1.0]])
    else:
        n_sub = math.comb(t, d - 1)
        if n_sub > VERTEX_DEGENERATE_MAX_SUBSETS:
            return f"degenerate with {t} tight rows ({n_sub} subsets to try)"
        sub = np.array(list(combinations(range(t), d - 1)))
        _, s, Vt = np.linalg.svd(AT[sub], full_matrices=True)
        ok = s[:, -1] > VERTEX_RANK_RTOL * s[:, 0]
        null = Vt[ok, -1, :]
        cand = np.vstack([null, -null])
    P = cand @ AT.T
    cand = cand[np.all(P <= VERTEX_CHECK_RTOL, axis=1)]
    if cand.shape[0] < d:
        return "fewer than d edge directions"
    _, first = np.unique(np.round(cand / VERTEX_SAME_RTOL), axis=0, return_index=True)
    return cand[np.sort(first)]


# ---------------------------------------------------------------------------------------------
# Scaling
# ---------------------------------------------------------------------------------------------
@dataclass(slots=True)
class ScaledRows:
    """Unit rows of ``{z : A z <= b}`` in coordinates ``y = (z - mid) / half``.

    ``rows`` indexes the rows kept (the others are constant: ``0 <= b``); ``contradiction`` is
    True when a constant row reads ``0 <= b`` with ``b`` negative beyond VERTEX_CHECK_RTOL.
    """

    A: np.ndarray
    b: np.ndarray
    mid: np.ndarray
    half: np.ndarray
    rows: np.ndarray
    contradiction: bool


def scale_rows(An: np.ndarray, bn: np.ndarray, mid: np.ndarray, half: np.ndarray) -> ScaledRows:
    """Rows of unit norm ``(An, bn)`` written in ``y = (z - mid) / half`` and set to unit norm again."""
    As = An * half
    bs = bn - An @ mid
    norms = np.sqrt(np.einsum("ij,ij->i", As, As))
    live = norms > ZERO_ROW_TOL * float(half.max())
    if live.all():  # the usual case: no constant rows
        return ScaledRows(As / norms[:, None], bs / norms, mid, half, np.arange(An.shape[0]), False)
    contradiction = bool(np.any(~live & (bs < -VERTEX_CHECK_RTOL * (1.0 + np.abs(bs)))))
    rows = np.nonzero(live)[0]
    return ScaledRows(As[rows] / norms[rows, None], bs[rows] / norms[rows], mid, half, rows, contradiction)


# ---------------------------------------------------------------------------------------------
# The libraries
# ---------------------------------------------------------------------------------------------
@dataclass(slots=True)
class _Raw:
    """A library's answer in the coordinates it was given: points, rays, lines (unchecked)."""

    points: np.ndarray
    rays: np.ndarray


_NO_RAYS = {d: np.zeros((0, d)) for d in range(1, 17)}


def _cdd_generators(A: np.ndarray, b: np.ndarray) -> _Raw:
    cdd = cdd_module()
    d = A.shape[1]
    # pycddlib reads a nested list 4-6 x faster than a numpy array (15 us against 63 us at 12 x 3)
    M = np.empty((A.shape[0], d + 1))
    M[:, 0] = b
    np.negative(A, out=M[:, 1:])
    mat = cdd.matrix_from_array(M.tolist(), rep_type=cdd.RepType.INEQUALITY)
    gen = cdd.copy_generators(cdd.polyhedron_from_matrix(mat))
    G = np.asarray(gen.array, dtype=float).reshape(-1, d + 1)
    if not gen.lin_set and G.shape[0] and bool((G[:, 0] == 1.0).all()):  # the usual case: vertices only
        return _Raw(np.ascontiguousarray(G[:, 1:]), _NO_RAYS[d] if d in _NO_RAYS else np.zeros((0, d)))
    lines = np.zeros(G.shape[0], dtype=bool)
    lines[list(gen.lin_set)] = True
    is_point = (G[:, 0] != 0.0) & ~lines
    pts = G[is_point, 1:] / G[is_point, :1]
    R = G[~is_point, 1:]
    R = np.vstack([R, -G[lines, 1:]])  # a line is two rays
    return _Raw(pts, R)


def interior_point(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, float] | None:
    """A Chebyshev centre of ``{A z <= b}`` (unit rows) and its radius, checked; ``None`` if none.

    cddlib's LP when pycddlib is there (tens of microseconds), the LP layer otherwise; the
    answer is used only if every row holds at the centre with the returned slack, up to
    VERTEX_CHECK_RTOL, and the radius is positive.  The radius is capped at 1e6 times the
    largest ``|b|`` (the set may be unbounded).
    """
    m, d = A.shape
    cap = 1e6 * (1.0 + float(np.max(np.abs(b)))) if m else 1.0
    cdd = cdd_module()
    x = None
    if cdd is not None:
        arr = np.zeros((m + 2, d + 2))
        arr[:m, 0] = b
        arr[:m, 1 : d + 1] = -A
        arr[:m, -1] = -1.0
        arr[m, 0] = cap
        arr[m, -1] = -1.0
        arr[m + 1, -1] = 1.0  # objective: maximise the radius
        lp = cdd.linprog_from_array(arr.tolist(), obj_type=cdd.LPObjType.MAX)
        cdd.linprog_solve(lp)
        if lp.status == cdd.LPStatusType.OPTIMAL:
            x = np.asarray(lp.primal_solution, dtype=float)
    if x is None:
        from .lp import solve_lp  # noqa: PLC0415

        c = np.zeros(d + 1)
        c[-1] = -1.0
        res = solve_lp(c, np.hstack([A, np.ones((m, 1))]), b, bounds=[(None, None)] * d + [(None, cap)],
                       problem="interior point for vertex enumeration")
        if not res.optimal:
            return None
        x = res.x
    centre, r = x[:d], float(x[-1])
    if not (np.all(np.isfinite(x)) and r > 0.0):
        return None
    slack = b - A @ centre
    if np.any(slack < r - VERTEX_CHECK_RTOL * (1.0 + np.abs(b))):
        return None
    return centre, r


def _qhull_points(A: np.ndarray, b: np.ndarray) -> _Raw | str:
    ip = interior_point(A, b)
    if ip is None:
        return "no interior point (empty or flat set)"
    centre, r = ip
    _spatial.bind(globals())
    try:
        # qhull divides by each row's slack at the centre: its warnings are the check's business
        with warnings.catch_warnings(), np.errstate(all="ignore"):
            warnings.simplefilter("ignore", RuntimeWarning)
            hs = HalfspaceIntersection(np.hstack([A, -b[:, None]]), centre)
    except (QhullError, ValueError, RuntimeWarning) as exc:
        return f"qhull: {str(exc).splitlines()[0] if str(exc) else type(exc).__name__}"
    return _Raw(np.asarray(hs.intersections, dtype=float), np.zeros((0, A.shape[1])))


_LIBRARIES = {"cdd": _cdd_generators, "qhull": _qhull_points}


def library_order(d: int) -> tuple[str, ...]:
    """Libraries to try for vertex enumeration in dimension ``d``, first to last."""
    if cdd_module() is None:
        return ("qhull",)
    return ("cdd", "qhull") if d <= CDD_FIRST_MAX_DIM else ("qhull", "cdd")


# ---------------------------------------------------------------------------------------------
# H -> V
# ---------------------------------------------------------------------------------------------
@dataclass(slots=True)
class VertexEnumeration:
    """Checked answer of :func:`enumerate_vertices`.

    Attributes
    ----------
    status : str
        ``"bounded"`` (``points`` are all the vertices), ``"empty"`` (certified by an LP) or
        ``"unbounded"`` (``rays`` holds recession directions, each checked).
    points : (n, d) array
        Vertices in the original coordinates (``n = 0`` unless bounded).
    rays : (k, d) array
        Unit recession directions in the original coordinates (unbounded only).
    scaled : ScaledRows or None
        The scaled rows of the check (bounded only).
    checked : CheckedVertices or None
        The check's vertex set and incidence (bounded only).
    source : str
        The library that answered.
    rows : (m',) int array
        Indices of the given rows that are not all-zero; ``scaled.rows`` indexes into these.
    facets : tuple or None
        ``(code, row, mask)`` of :func:`~hybobs_opt.geometry._vertex_kernels.facet_kernel` on
        ``scaled`` and ``checked``, when :func:`enumerate_vertices` was asked for it and decided
        it in the check's compiled call (see
        :func:`~hybobs_opt.geometry.redundancy.facet_verdict`); ``None`` otherwise.
    """

    status: str
    points: np.ndarray
    rays: np.ndarray
    scaled: ScaledRows | None
    checked: CheckedVertices | None
    source: str
    rows: np.ndarray | None = None
    facets: tuple | None = None

    def row_indices(self) -> np.ndarray:
        """Indices into the given rows of the rows of ``scaled`` (and of ``checked.tight``'s columns)."""
        return self.rows[self.scaled.rows]


def enumerate_vertices(A: np.ndarray, b: np.ndarray, op: str = "vertices", facets: bool = False) -> VertexEnumeration | None:
    """All vertices of ``{z : A z <= b}`` from pycddlib or qhull, checked; ``None`` if no library passed.

    Parameters
    ----------
    A : (m, d) array
        Constraint rows (any units; they are normalised).
    b : (m,) array
        Right-hand side.
    op : str
        Name of the calling operation in :data:`COUNTERS` and the log.
    facets : bool
        Also run the facet decision of :func:`~hybobs_opt.geometry.redundancy.facets_from_vertices`
        in the check's compiled call (``VertexEnumeration.facets``; for ``remove_redundant``).

    Returns
    -------
    VertexEnumeration or None
        ``None`` when every library answer failed its check (each failure counted and logged):
        the caller then runs its hand-written path.
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    m, d = A.shape
    norms = np.sqrt(np.einsum("ij,ij->i", A, A))
    const = norms == 0.0
    if const.any():
        if np.any(const & (b < 0.0)):
            return _empty(d, "rows")
        live = np.nonzero(~const)[0]
        A, b, norms = A[live], b[live], norms[live]
    else:
        live = np.arange(m)
    An, bn = A / norms[:, None], b / norms
    if An.shape[0] == 0:
        return VertexEnumeration("unbounded", np.zeros((0, d)), np.eye(d), None, None, "rows", live)
    order = library_order(d)
    for source in order:
        out = _try_library(source, An, bn, op, None, facets)
        if out is not None:
            COUNTERS.accept(op, source)
            out.rows = live
            return out
    # Every library failed in the given units: once more in coordinates scaled by the LP bounding box.
    from ._common import _box  # noqa: PLC0415

    box = _box(An, bn)
    if box is None or not (np.all(np.isfinite(box[0])) and np.all(np.isfinite(box[1]))):
        return None  # empty or unbounded by the LPs: the caller's path reports it
    mid, half = _unit_box_map(*box)
    if _near_unit(mid, half):
        return None
    for source in order:
        out = _try_library(source, An, bn, op, (mid, half), facets)
        if out is not None:
            COUNTERS.accept(op, source)
            out.rows = live
            return out
    return None


def _empty(d: int, source: str) -> VertexEnumeration:
    return VertexEnumeration("empty", np.zeros((0, d)), np.zeros((0, d)), None, None, source)


def _try_library(source: str, An: np.ndarray, bn: np.ndarray, op: str, scaling, facets: bool = False) -> VertexEnumeration | None:
    """One library on the unit rows, then (if its answer fails) on rows rescaled by that answer's box.

    ``scaling`` is ``(mid, half)`` to hand the library the rows in ``(z - mid) / half`` from the
    start (and not retry), or ``None`` for the given units.
    """
    d = An.shape[1]
    mid, half = (None, None) if scaling is None else scaling  # (set before the second attempt)
    for attempt in range(1 if scaling is not None else 2):
        sc = scale_rows(An, bn, mid, half) if attempt or scaling is not None else None
        try:
            raw = _LIBRARIES[source](An, bn) if sc is None else _LIBRARIES[source](sc.A, sc.b)
        except (ValueError, RuntimeError, MemoryError) as exc:  # a library error is a failed answer
            raw = f"{type(exc).__name__}: {exc}"
        if isinstance(raw, str):
            COUNTERS.fallback(op, source, raw)
            return None
        pts, rays = (raw.points, raw.rays) if sc is None else (mid + raw.points * half, raw.rays * half)
        if rays.shape[0]:
            ok = _check_rays(An, rays)
            if ok is not None:
                return VertexEnumeration("unbounded", np.zeros((0, d)), ok, None, None, source)
            COUNTERS.fallback(op, source, "a returned ray is not a recession direction")
            return None
        if pts.shape[0] == 0:
            if _certified_empty(An, bn):
                return _empty(d, source)
            COUNTERS.fallback(op, source, "no vertex returned, but the set is not empty")
            return None
        if not np.isfinite(pts).all():
            COUNTERS.fallback(op, source, "a point is not finite")
            return None
        # the check, the kept vertices and (for remove_redundant) the facets: one compiled call
        (fast, new_mid, new_half, As, bs, rows, contradiction, Ys, code, i, j, keep, T, deg, kr, Yk, Tk, zk, fcode, frow,
         fmask) = check_enumeration(An, bn, np.ascontiguousarray(pts, dtype=float), FULL_DIMENSION_RTOL, ZERO_ROW_TOL,
                                    VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL, VERTEX_RANK_RTOL, VERTEX_SAME_RTOL,
                                    PARALLEL_ROW_TOL, REDUNDANCY_RTOL, facets)
        sc = ScaledRows(As, bs, new_mid, new_half, rows, contradiction)
        if fast:  # the usual case (simple vertices, no ray): _finish_check's result without its steps
            return VertexEnumeration("bounded", zk, np.zeros((0, d)), sc, CheckedVertices(Yk, Tk, kr), source,
                                     facets=None if fcode < 0 else (fcode, frow, fmask))
        checked = None if contradiction else _finish_check(As, bs, Ys, code, i, j, keep, T, deg, kr)
        if isinstance(checked, CheckedVertices):
            if checked.rays.shape[0]:
                return VertexEnumeration("unbounded", np.zeros((0, d)), _unit(checked.rays * new_half), None, None, source)
            return VertexEnumeration("bounded", new_mid + checked.Y * new_half, np.zeros((0, d)), sc, checked, source)
        reason = "a constant row is violated" if checked is None else checked
        if attempt == 0 and not _near_unit(new_mid, new_half):
            log.debug("geometry %s: %s answer failed its check in the given units (%s); retrying scaled", op, source, reason)
            mid, half = new_mid, new_half
            continue
        COUNTERS.fallback(op, source, reason)
        return None
    return None


def _near_unit(mid: np.ndarray, half: np.ndarray) -> bool:
    """Is ``z -> (z - mid) / half`` close to the identity (nothing gained by rescaling)?"""
    return bool(np.all(np.abs(np.log(half)) < 1.0) and np.all(np.abs(mid) <= 2.0 * half))


def _unit(R: np.ndarray) -> np.ndarray:
    return R / np.linalg.norm(R, axis=1)[:, None]


def _check_rays(An: np.ndarray, R: np.ndarray) -> np.ndarray | None:
    """Unit rays if each is a recession direction of ``{An z <= b}`` (unit rows) to VERTEX_CHECK_RTOL."""
    norms = np.linalg.norm(R, axis=1)
    if np.any(~np.isfinite(norms)) or np.any(norms == 0.0):
        return None
    U = R / norms[:, None]
    if np.any(U @ An.T > VERTEX_CHECK_RTOL):
        return None
    return U


def _certified_empty(An: np.ndarray, bn: np.ndarray) -> bool:
    """True when the LP layer proves ``{An z <= bn}`` empty (a checked Farkas certificate)."""
    from .lp import solve_lp  # noqa: PLC0415

    res = solve_lp(np.zeros(An.shape[1]), An, bn, problem="emptiness test of a vertex enumeration")
    return res.status == "infeasible"


# ---------------------------------------------------------------------------------------------
# V -> H
# ---------------------------------------------------------------------------------------------
@dataclass(slots=True)
class HullRows:
    """Checked facets ``H z <= h`` (unit rows) of the convex hull of a point set."""

    H: np.ndarray
    h: np.ndarray
    source: str
    volume: float | None = None


def hull_rows(points: np.ndarray, op: str = "hull") -> HullRows | None:
    """Facets of ``conv(points)`` from pycddlib or qhull, checked; ``None`` if no answer passed.

    The points are scaled to their box.  cddlib's inequalities are accepted when every point
    satisfies every row (to VERTEX_CHECK_RTOL) and the rows pass the vertex check in the polar
    set about the points' centroid ``c``, ``{y : (p - c)' y <= 1 for all points p}``, whose
    vertices are the facets ``a / (h - a'c)`` of the hull: each row is then a facet, and none is
    missing.  qhull's triangulated hull is checked by
    :func:`~hybobs_opt.geometry._hull_cycle.checked_hull` (its simplices close up into the
    boundary, covering it once, or its facets are closed under adjacency), whose cost grows with
    the simplices and facets, not with subsets of the points on a facet as the polar check's
    does at a degenerate polar vertex.  qhull answers first in every dimension (cddlib's V -> H
    is 5-10 x slower from 4-D, grows with the points, and on degenerate sets in 3-D its polar
    check walks thousands of subsets or fails: benchmarks/bench_polytope.py), cddlib second.
    A hull that is not full-dimensional is left to the caller.

    Parameters
    ----------
    points : (n, d) array
        The points (finite).
    op : str
        Name of the calling operation in :data:`COUNTERS` and the log.
    """
    X = np.asarray(points, dtype=float)
    n, d = X.shape
    if n <= d:
        COUNTERS.fallback(op, "cdd" if cdd_module() is not None else "qhull", "fewer than d + 1 points: not full-dimensional")
        return None
    # the box, the scaled points, their centroid and the points about it: one compiled call
    mid, half, Y, c, P = points_to_box(np.ascontiguousarray(X), FULL_DIMENSION_RTOL)
    order = ("qhull",) if cdd_module() is None else ("qhull", "cdd")
    for source in order:
        volume = None
        if source == "cdd":
            rows = _cdd_hull(Y)
            if isinstance(rows, str):
                COUNTERS.fallback(op, source, rows)
                continue
            G, g = rows
            reason = _check_hull(G, g, P, c)
        else:
            checked = checked_hull(Y)
            reason = checked if isinstance(checked, str) else None
            if reason is None:
                G, g, volume = checked.G, checked.g, checked.volume * float(np.prod(half))
        if reason is not None:
            COUNTERS.fallback(op, source, reason)
            continue
        H = G / half  # back to z: G (z - mid) / half <= g
        h = g + H @ mid
        hn = np.sqrt(np.einsum("ij,ij->i", H, H))
        COUNTERS.accept(op, source)
        return HullRows(H / hn[:, None], h / hn, source, volume)
    return None


def _cdd_hull(Y: np.ndarray) -> tuple[np.ndarray, np.ndarray] | str:
    """cddlib's facets ``G y <= g`` (unit rows) of the points ``Y``, unchecked, or why none."""
    cdd = cdd_module()
    n, d = Y.shape
    try:
        mat = cdd.matrix_from_array(np.hstack([np.ones((n, 1)), Y]).tolist(), rep_type=cdd.RepType.GENERATOR)
        ineq = cdd.copy_inequalities(cdd.polyhedron_from_matrix(mat))
    except (ValueError, RuntimeError, MemoryError) as exc:
        return f"{type(exc).__name__}: {exc}"
    M = np.asarray(ineq.array, dtype=float).reshape(-1, d + 1)
    if ineq.lin_set or M.shape[0] == 0:
        return "equalities: the points are not full-dimensional"
    violated, G, g = cdd_hull_rows(M, ZERO_ROW_TOL)  # cdd's rows read g - G y >= 0; unit rows, zero rows dropped
    if violated:
        return "a constant row is violated"
    return G, g


def _check_hull(G: np.ndarray, g: np.ndarray, P: np.ndarray, c: np.ndarray) -> str | None:
    """``None`` when ``{G y <= g}`` is exactly the hull of the points ``c + P`` (scaled), else why not."""
    # the rows against the points, the centroid's depth, and the polar rows in the coordinates of
    # the candidate polar vertices' box, checked: one compiled call (numpy's ~15 small array
    # operations around it cost ~50 us at d = 2, five times the check itself)
    (hcode, _, _, _, As, bs, _, contradiction, Ys, code, i, j, keep, T, deg, rays) = hull_check(
        np.ascontiguousarray(G, dtype=float), np.ascontiguousarray(g, dtype=float), P, c, FULL_DIMENSION_RTOL,
        ZERO_ROW_TOL, VERTEX_CHECK_RTOL, VERTEX_TIGHT_RTOL, VERTEX_RANK_RTOL, VERTEX_SAME_RTOL)
    if hcode == _K.HULL_POINT_VIOLATES:
        return "a point violates a returned row"
    if hcode == _K.HULL_CENTROID_ON_ROW:
        return "the centroid lies on a returned row"
    if contradiction:
        return "polar check: a constant row is violated"
    checked = _finish_check(As, bs, Ys, code, i, j, keep, T, deg, rays)
    if isinstance(checked, str):
        return f"polar check: {checked}"
    if checked.rays.shape[0]:
        return "polar check: unbounded polar (the centroid is not interior)"
    if checked.Y.shape[0] != G.shape[0]:
        return "duplicate facets"
    return None

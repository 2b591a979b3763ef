"""A small H-polytope type ``{z : A z <= b}`` with coordinate names, and its geometry.

Used for guards, invariants and state/input bounds, and for the sets of paper 002 (Sections 2-3):
the unobservable set ``B_T`` is a union of projections ``Proj_x(R_ij)`` of higher-dimensional
polytopes (e.g. 9-D -> 3-D, 17-D -> 5-D), cut at fixed coordinates for figures.  The class
offers redundancy removal (:mod:`~hybobs_opt.geometry.redundancy`), affine images and preimages,
slices, exact projections (:mod:`~hybobs_opt.geometry.projection`: iterative hull for small target
dimensions, Fourier-Motzkin otherwise), vertices and volumes (:mod:`~hybobs_opt.geometry.volume`).  Unions and
set differences live in :mod:`hybobs_opt.regions.union`.

Every LP goes through :func:`hybobs_opt.geometry.lp.solve_lp`; tolerances are the named, relative ones of
:mod:`hybobs_opt.tolerances`, applied in coordinates scaled by the bounding box.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from .._validate import as_int, as_items, as_matrix, as_names, as_vector
from ..defaults import EXACT_VOLUME_MAX_DIM
from ..errors import ModelError, SolverError
from ..tolerances import (
    AFFINE_HULL_RTOL,
    FULL_DIMENSION_RTOL,
    FULL_SIMPLEX_RTOL,
    MEMBERSHIP_RTOL,
    RANK_RTOL,
    ZERO_ROW_TOL,
)
from ._common import (
    _box,
    _check_method,
    _lp,
    _nullspace,
    _positive_scale,
    resolve_coordinate,
    _resolve_list,
    _unit_box_map,
    _row_normalised,
    _unit_rows,
)
from .lp import chebyshev_lp, row_range, solve_lp
from . import projection as _projection
from .projection import _iterative_hull, image_of
from .redundancy import facet_verdict, facets_from_vertices, irredundant
from .vertices import COUNTERS as LIBRARY_COUNTERS
from .vertices import enumerate_vertices, hull_rows
from ._hull_cycle import volume_by_facets
from ._vertex_kernels import facet_volume_3d
from .volume import VolumeEstimate, checked_hull_volume, monte_carlo_volume


#: Largest dimension in which :meth:`Polytope.remove_redundant` decides the facets from the
#: checked vertex set (measured in 2-6 D, benchmarks/bench_polytope.py); above it the LPs decide,
#: since the number of vertices can grow exponentially with the dimension, one LP per row cannot.
LIBRARY_REDUNDANCY_MAX_DIM: int = 6

#: Largest source dimension in which ``project(..., method="auto")`` onto 2 coordinates takes the
#: checked vertices, projected, and their checked 2-D hull (no LPs: 1-3 x the cost of cddlib's or
#: qhull's vertices plus a 2-D hull at d = 3-6, against 30-180 x for the LP hull,
#: benchmarks/bench_polytope.py); above it the vertex count can grow too fast and the LP hull
#: (about one LP per facet and vertex of the image) answers.
VERTEX_PROJECTION_MAX_DIM: int = 6

#: From this dimension the exact volume is summed over the facets, one checked (d-1)-dimensional
#: hull each (:func:`~hybobs_opt.geometry._hull_cycle.volume_by_facets`), instead of one hull of all
#: the vertices: qhull's d-dimensional triangulation of a polytope's vertices does not close up in
#: 6-D (3 of 12 random instances), and costs less below (benchmarks/bench_polytope.py).
FACET_VOLUME_MIN_DIM: int = 6


def _check_polytope(value, field: str) -> None:
    if not isinstance(value, Polytope):
        raise ModelError(field, "a Polytope", type(value).__name__)


@dataclass(frozen=True, eq=False)
class Polytope:
    """H-representation ``{z in R^d : A z <= b}``.

    Parameters
    ----------
    A : (k, d) array
        Constraint matrix.
    b : (k,) array
        Right-hand side.
    names : sequence of str, optional
        Names of the ``d`` coordinates (``z1 ... zd`` by default).

    See Also
    --------
    polytope_difference : the pieces of a difference of polytopes.
    row_range : the interval of linear functionals over a polytope.
    monte_carlo_volume : the volume of a union of polytopes.

    Notes
    -----
    Strict and non-strict inequalities are not distinguished: the paper's regions are "not
    necessarily closed" (paper 002, eq. 1), and membership ties are broken by mode order.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.geometry import Polytope
    >>> square = Polytope.from_box([-1.0, -1.0], [1.0, 1.0])
    >>> square
    Polytope(dim=2, n_constraints=4, names=('z1', 'z2'))
    >>> square.contains(np.array([0.5, -0.5])), square.contains(np.array([1.5, 0.0]))
    (True, False)
    >>> half = square.intersect(Polytope(np.array([[1.0, 1.0]]), np.array([0.0])))  # z1 + z2 <= 0
    >>> volume = half.volume()                       # a VolumeEstimate, exact in 2-D
    >>> round(volume.value, 6), volume.method, half.is_bounded(), half.is_empty()
    (2.0, 'exact', True, False)
    >>> sorted(half.vertices().round(6).tolist())    # the triangle's corners
    [[-1.0, -1.0], [-1.0, 1.0], [1.0, -1.0]]
    """

    A: np.ndarray
    b: np.ndarray
    names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        A = as_matrix(self.A, "Polytope.A", (None, None))
        b = as_vector(self.b, "Polytope.b", A.shape[0])
        if A.shape[1] == 0:
            raise ModelError("Polytope.A", "at least one column (dimension >= 1)", f"shape {A.shape}")
        object.__setattr__(self, "A", A)
        object.__setattr__(self, "b", b)
        object.__setattr__(self, "names", as_names(self.names, "Polytope.names", A.shape[1], "z"))

    # ------------------------------------------------------------------ constructors
    @classmethod
    def from_box(cls, lower: Sequence[float], upper: Sequence[float], names: Sequence[str] | None = None) -> "Polytope":
        """Axis-aligned box ``lower <= z <= upper``; raises if a lower bound exceeds its upper bound.

        Parameters
        ----------
        lower, upper : sequence of float
            Bounds of each coordinate (same length ``d``).
        names : sequence of str, optional
            Coordinate names (``z1 ... zd`` by default).

        Returns
        -------
        Polytope
            The box as ``2 d`` rows.
        """
        lo = as_vector(lower, "lower", None)
        hi = as_vector(upper, "upper", lo.size)
        names = as_names(names, "names", lo.size, "z")
        bad = np.nonzero(lo > hi)[0]
        if bad.size:
            i = int(bad[0])
            raise ModelError(f"bounds of {names[i]}", "lower <= upper", f"[{lo[i]}, {hi[i]}]")
        d = lo.size
        A = np.vstack([np.eye(d), -np.eye(d)])
        b = np.concatenate([hi, -lo])
        return cls(A, b, names)

    @classmethod
    def empty(cls, dim: int, names: Sequence[str] | None = None) -> "Polytope":
        """The empty set of ``R^dim``, written as the rows ``z1 <= -1`` and ``-z1 <= 0``.

        Parameters
        ----------
        dim : int
            Dimension ``d >= 1``.
        names : sequence of str, optional
            Coordinate names (``z1 ... zd`` by default).

        Returns
        -------
        Polytope
            An empty polytope of dimension ``dim``.
        """
        dim = as_int(dim, "dim", 1, "a dimension (an integer >= 1)")
        A = np.zeros((2, dim))
        A[0, 0], A[1, 0] = 1.0, -1.0
        return cls(A, np.array([-1.0, 0.0]), as_names(names, "names", dim, "z"))

    @classmethod
    def whole_space(cls, dim: int, names: Sequence[str] | None = None) -> "Polytope":
        """The unconstrained set ``R^dim`` (no rows).

        Parameters
        ----------
        dim : int
            Dimension ``d >= 1``.
        names : sequence of str, optional
            Coordinate names (``z1 ... zd`` by default).

        Returns
        -------
        Polytope
            ``R^dim`` with no rows.
        """
        dim = as_int(dim, "dim", 1, "a dimension (an integer >= 1)")
        return cls(np.zeros((0, dim)), np.zeros(0), as_names(names, "names", dim, "z"))

    @classmethod
    def from_vertices(cls, points: np.ndarray, names: Sequence[str] | None = None) -> "Polytope":
        """The convex hull of a finite point set, as its facets (V -> H).

        qhull answers first; its triangulated hull is used only when it passes its check (every
        point inside every facet, the simplices closing up into the boundary and covering it once,
        or else each facet's own hull one dimension down with every ridge on a second facet: each
        row a facet, none missing; :func:`hybobs_opt.geometry._hull_cycle.checked_hull`), at a
        cost that grows with the simplices, not with the points on a facet, so duplicated points,
        points on facets and non-simplicial facets are as fast as general points.  pycddlib
        answers second, its rows checked as vertices of the polar set
        (:func:`hybobs_opt.geometry.vertices.hull_rows`).  Otherwise (or for a flat point set)
        the hull is built by the iterative-hull method of :meth:`project`, whose support
        function over points is exact (no LPs).

        Parameters
        ----------
        points : (n, d) array_like
            The points (``n >= 1``, finite); points inside the hull are allowed.
        names : sequence of str, optional
            Coordinate names (``z1 ... zd`` by default).

        Returns
        -------
        Polytope
            Unit rows, one per facet; a lower-dimensional hull carries its affine hull as paired
            rows ``N z <= n, -N z <= -n``.
        """
        X = as_matrix(points, "points", (None, None))
        if X.shape[0] == 0:
            raise ModelError("points", "at least one point", "none")
        if not np.all(np.isfinite(X)):
            raise ModelError("points", "finite coordinates", "a NaN or infinite entry")
        d = X.shape[1]
        names = as_names(names, "names", d, "z")
        hull = hull_rows(X, op="from_vertices")
        if hull is not None:
            if cls is Polytope:  # checked unit rows (finite, float, (k, d) and (k,)) and validated names
                hull.H.setflags(write=False)  # read-only, as the validation leaves them
                hull.h.setflags(write=False)
                out = object.__new__(cls)
                object.__setattr__(out, "A", hull.H)
                object.__setattr__(out, "b", hull.h)
                object.__setattr__(out, "names", names)
                return out
            return cls(hull.H, hull.h, names)
        mid, half = _unit_box_map(X.min(axis=0), X.max(axis=0))
        Y = (X - mid) / half

        def support(direction: np.ndarray) -> tuple[float, np.ndarray]:
            vals = Y @ direction
            k = int(np.argmax(vals))
            return float(vals[k]), Y[k]

        start = [Y[int(np.argmax(Y[:, i]))] for i in range(d)] + [Y[int(np.argmin(Y[:, i]))] for i in range(d)]
        G, g, _ = _iterative_hull(support, start, d)
        H = G / half
        H, h = _unit_rows(H, g + H @ mid) if H.shape[0] else (H, g)
        return cls(H, h, names)

    # ------------------------------------------------------------------ basic queries
    @property
    def dim(self) -> int:
        return self.A.shape[1]

    @property
    def n_constraints(self) -> int:
        return self.A.shape[0]

    def contains(self, points: np.ndarray, rtol: float = MEMBERSHIP_RTOL) -> np.ndarray | bool:
        """Membership of one point ``(d,)`` (returns bool) or many points ``(N, d)`` (returns array).

        A point is inside when ``A z <= b + rtol * (1 + |b|)`` row-wise.

        Parameters
        ----------
        points : (d,) or (N, d) array_like
            One point or one point per row.
        rtol : float, default MEMBERSHIP_RTOL
            Relative slack of each row (:data:`~hybobs_opt.tolerances.MEMBERSHIP_RTOL`).

        Returns
        -------
        bool or (N,) bool ndarray
            Whether the point (each point) satisfies ``A z <= b``.
        """
        z = np.asarray(points, dtype=float)
        single = z.ndim == 1
        Z = z.reshape(1, -1) if single else z
        if Z.shape[1] != self.dim:
            raise ModelError("points", f"points of dimension {self.dim}", f"shape {z.shape}")
        slack = self.b + rtol * (1.0 + np.abs(self.b))
        inside = np.all(Z @ self.A.T <= slack, axis=1)
        return bool(inside[0]) if single else inside

    def normalized(self) -> "Polytope":
        """Rows scaled to unit 2-norm; all-zero rows are dropped (or flagged if they make the set empty).

        Returns
        -------
        Polytope
            The same set with unit-norm rows.
        """
        norms = np.linalg.norm(self.A, axis=1)
        zero = norms <= ZERO_ROW_TOL
        if np.any(zero & (self.b < 0)):
            # 0 <= negative: the set is empty; keep one infeasible row so emptiness is preserved.
            return Polytope(np.vstack([np.eye(1, self.dim), -np.eye(1, self.dim)]), np.array([-1.0, 0.0]), self.names)
        keep = ~zero
        return Polytope(self.A[keep] / norms[keep, None], self.b[keep] / norms[keep], self.names)

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        """Tightest axis-aligned box ``(lower, upper)`` by 2d LPs.

        Returns
        -------
        lower, upper : (d,) ndarray
            The smallest box containing the polytope.

        Raises
        ------
        ModelError
            If the polytope is empty or unbounded in some coordinate (named in the message).
        """
        r = row_range(self.A, self.b, np.eye(self.dim), problem="bounding box", field="polytope", labels=self.names)
        return r[:, 0].copy(), r[:, 1].copy()

    def is_bounded(self) -> bool:
        """True when every coordinate is bounded above and below (and the set is non-empty).

        Returns
        -------
        bool
            Whether the set is non-empty and bounded.
        """
        try:
            self.bounding_box()
        except ModelError:
            return False
        return True

    def chebyshev_ball(self, scale: np.ndarray | None = None) -> tuple[np.ndarray | None, float]:
        """Centre and radius of the largest inscribed ball, optionally in coordinates ``z / scale``.

        Returns ``(None, -inf)`` for an empty polytope and ``radius = inf`` when unbounded.  One LP
        (:func:`~hybobs_opt.geometry.lp.chebyshev_lp`: DAQP, its optimum accepted with its
        multipliers as a dual certificate checked in numpy); any other answer goes to the
        certified HiGHS path (:func:`~hybobs_opt.geometry.lp.solve_lp`).

        Parameters
        ----------
        scale : (d,) array_like, optional
            Per-coordinate scale; the ball is the largest one in ``z / scale``, its centre returned in
            ``z``.  ``None`` means the unscaled coordinates.

        Returns
        -------
        centre : (d,) ndarray or None
            Centre of the ball (``None`` when empty or unbounded).
        radius : float
            Radius in the scaled coordinates (``-inf`` empty, ``inf`` unbounded).
        """
        A = self.A if scale is None else self.A * np.asarray(scale, dtype=float)[None, :]
        norms = np.sqrt(np.einsum("ij,ij->i", A, A))
        d = self.dim
        A_ub = np.empty((A.shape[0], d + 1))
        A_ub[:, :d] = A
        A_ub[:, d] = norms
        fast = chebyshev_lp(A_ub, self.b)
        if fast is not None:
            centre = fast[:d] if scale is None else fast[:d] * np.asarray(scale, dtype=float)
            return centre, float(fast[d])
        c = np.zeros(d + 1)
        c[-1] = -1.0
        res = solve_lp(c, A_ub, self.b, bounds=[(None, None)] * d + [(None, None)], problem="Chebyshev ball")
        if res.status == "infeasible":
            return None, -np.inf
        if res.status == "unbounded":
            return None, np.inf
        centre = res.x[:d] if scale is None else res.x[:d] * np.asarray(scale, dtype=float)
        return centre, float(res.x[-1])

    def is_empty(self) -> bool:
        """True when no point satisfies ``A z <= b``.

        Returns
        -------
        bool
            Whether the set is empty (decided by a certified LP).
        """
        res = solve_lp(np.zeros(self.dim), self.A, self.b, problem="emptiness test")
        return res.status == "infeasible"

    def is_full_dimensional(self, scale: np.ndarray | None = None, rtol: float = FULL_DIMENSION_RTOL) -> bool:
        """True when the Chebyshev radius in coordinates ``z / scale`` exceeds ``rtol``.

        ``scale`` defaults to the bounding-box widths, so the test is relative to the set's size
        in every coordinate (DESIGN.md: tolerances are relative).

        Parameters
        ----------
        scale : (d,) array_like, optional
            Per-coordinate scale; ``None`` uses the bounding-box widths (or no scaling when the set is
            unbounded or empty).
        rtol : float, default FULL_DIMENSION_RTOL
            Smallest radius counted as full-dimensional
            (:data:`~hybobs_opt.tolerances.FULL_DIMENSION_RTOL`).

        Returns
        -------
        bool
            Whether the set has an interior of radius above ``rtol`` (scaled coordinates).
        """
        if scale is None:
            try:
                lo, hi = self.bounding_box()
            except ModelError:
                _, r = self.chebyshev_ball()
                return r > rtol
            scale = np.where(hi - lo > 0, hi - lo, 1.0)
        _, r = self.chebyshev_ball(scale)
        return r > rtol

    # ------------------------------------------------------------------ combinations
    def intersect(self, other: "Polytope") -> "Polytope":
        """Intersection with a polytope of the same dimension.

        Parameters
        ----------
        other : Polytope
            Polytope of the same dimension; the result keeps this polytope's names.

        Returns
        -------
        Polytope
            The rows of both sets.
        """
        _check_polytope(other, "other")
        if other.dim != self.dim:
            raise ModelError("other", f"a polytope of dimension {self.dim}", f"dimension {other.dim}")
        return Polytope(np.vstack([self.A, other.A]), np.concatenate([self.b, other.b]), self.names)

    def product(self, other: "Polytope") -> "Polytope":
        """Cartesian product ``self x other`` (coordinates concatenated).

        Parameters
        ----------
        other : Polytope
            The second factor; names are concatenated (dropped if they collide).

        Returns
        -------
        Polytope
            The product, of dimension ``self.dim + other.dim``.
        """
        _check_polytope(other, "other")
        A = np.block(
            [
                [self.A, np.zeros((self.n_constraints, other.dim))],
                [np.zeros((other.n_constraints, self.dim)), other.A],
            ]
        )
        names = self.names + other.names
        if len(set(names)) != len(names):
            names = ()
        return Polytope(A, np.concatenate([self.b, other.b]), names)

    def lift(self, dim: int, coords: Sequence[int], names: Sequence[str] | None = None) -> "Polytope":
        """Embed into ``R^dim``: the constraint acts on ``coords`` of the larger space only.

        Parameters
        ----------
        dim : int
            Dimension of the larger space (at least this polytope's).
        coords : sequence of int
            Distinct 0-based indices in ``R^dim`` of this polytope's coordinates, in order.
        names : sequence of str, optional
            Names of the ``dim`` coordinates (``z1 ...`` by default).

        Returns
        -------
        Polytope
            The set ``{z in R^dim : z[coords] in self}``.
        """
        dim = as_int(dim, "dim", self.dim, f"a dimension (an integer >= {self.dim}, this polytope's)")
        coords = [as_int(c, f"coords[{i}]", 0, f"a coordinate index in 0..{dim - 1}")
                  for i, c in enumerate(as_items(coords, "coords", (int, np.integer), "coordinate indices"))]
        if len(coords) != self.dim:
            raise ModelError("coords", f"{self.dim} coordinate indices", f"{len(coords)}")
        for i, c in enumerate(coords):
            if c >= dim or coords.index(c) != i:
                raise ModelError(f"coords[{i}]", f"distinct coordinate indices in 0..{dim - 1}", repr(c))
        A = np.zeros((self.n_constraints, dim))
        A[:, coords] = self.A
        return Polytope(A, self.b.copy(), as_names(names, "names", dim, "z"))

    # ------------------------------------------------------------------ coordinates, cuts, maps
    def index_of(self, coord: int | str) -> int:
        """Index of a coordinate given by its index or its name.

        Parameters
        ----------
        coord : int or str
            0-based index or name of the coordinate.

        Returns
        -------
        int
            The coordinate's index.

        Raises
        ------
        ModelError
            If the name is unknown or the index is out of range.
        """
        return resolve_coordinate(coord, self.names)

    def slice(self, fixed: Mapping[int | str, float]) -> "Polytope":
        """Cut at fixed coordinates: ``{z_free : (z_free, z_fixed) in P}``.

        Used to draw 2-D figures of higher-dimensional sets, e.g. the powertrain's unobservable
        set cut at ``omega_l = 25`` (paper 002, Section 6).

        Parameters
        ----------
        fixed : mapping of int or str to float
            Coordinates (by index or name) and the values they are fixed at.

        Returns
        -------
        Polytope
            A polytope in the remaining coordinates, in their original order, names kept.
        """
        idx: dict[int, float] = {}
        for key, val in fixed.items():
            i = resolve_coordinate(key, self.names)
            if i in idx:
                raise ModelError("fixed", "each coordinate fixed once", f"{self.names[i]} twice")
            value = float(val)
            if not np.isfinite(value):
                raise ModelError(f"fixed[{self.names[i]}]", "a finite value", str(value))
            idx[i] = value
        keep = [i for i in range(self.dim) if i not in idx]
        if not keep:
            raise ModelError("fixed", "at least one coordinate left free", f"all {self.dim} fixed")
        cols = list(idx)
        b = self.b - self.A[:, cols] @ np.array([idx[i] for i in cols])
        return Polytope(self.A[:, keep], b, tuple(self.names[i] for i in keep))

    def affine_preimage(self, M: np.ndarray, v: np.ndarray | None = None, names: Sequence[str] | None = None) -> "Polytope":
        """Preimage ``{w : M w + v in P}`` under an affine map.

        Parameters
        ----------
        M : (d, k) array
            Linear part; ``d`` is the dimension of this polytope, ``k`` that of the result.
        v : (d,) array, optional
            Offset (zero by default).
        names : sequence of str, optional
            Names of the ``k`` coordinates of the result.

        Returns
        -------
        Polytope
            ``{w in R^k : (A M) w <= b - A v}`` -- exact, no LP needed.
        """
        M = as_matrix(M, "M", (self.dim, None))
        v = np.zeros(self.dim) if v is None else as_vector(v, "v", self.dim)
        return Polytope(self.A @ M, self.b - self.A @ v, tuple(names) if names else ())

    def affine_image(
        self,
        M: np.ndarray,
        v: np.ndarray | None = None,
        names: Sequence[str] | None = None,
        method: str = "auto",
        hull_max_dim: int | None = None,
    ) -> "Polytope":
        """Image ``{M z + v : z in P}`` under an affine map.

        Parameters
        ----------
        M : (k, d) array
            Linear part.
        v : (k,) array, optional
            Offset (zero by default).
        names : sequence of str, optional
            Names of the ``k`` coordinates of the result.
        method, hull_max_dim
            As in :meth:`project` (used only when ``M`` is not square and invertible).

        Returns
        -------
        Polytope
            For square invertible ``M``: ``{x : A M^{-1} (x - v) <= b}`` directly.  Otherwise the
            projection onto ``x`` of the graph ``{(x, z) : x = M z + v, z in P}``; the graph's
            equality is eliminated by parametrising it with ``z`` (scaled), and the image may be
            lower-dimensional (then returned with its equalities as paired inequalities).
        """
        M = as_matrix(M, "M", (None, self.dim))
        k = M.shape[0]
        v = np.zeros(k) if v is None else as_vector(v, "v", k)
        out_names = tuple(names) if names else ()
        _check_method(method)
        if method == "vertices":
            V = self.vertices()
            if V.shape[0] == 0:
                return Polytope.empty(k, out_names)
            return Polytope.from_vertices(V @ M.T + v, out_names)
        if k == self.dim:
            sv = np.linalg.svd(M, compute_uv=False)
            if sv[0] > 0 and sv[-1] > RANK_RTOL * sv[0]:
                H = np.linalg.solve(M.T, self.A.T).T
                H, h = _unit_rows(H, self.b + H @ v)
                return Polytope(H, h, out_names)
        img = image_of(self.A, self.b, None, None, M, v, method, hull_max_dim)
        if img is None:
            return Polytope.empty(k, out_names)
        return Polytope(img.H, img.h, out_names)

    # ------------------------------------------------------------------ redundancy, projection
    def remove_redundant(self, scale: np.ndarray | None = None) -> "Polytope":
        """Drop every row implied by the others (one LP per row).

        Rows are normalised; parallel duplicates are removed first without LPs (the tightest is
        kept); then each remaining row ``a_i z <= b_i`` is dropped when ``max a_i z`` over the
        other kept rows (and ``a_i z <= b_i + 1``, which keeps the LP bounded) does not exceed
        ``b_i`` by more than ``REDUNDANCY_RTOL``.  The tests run in coordinates scaled so the
        bounding box is ``[-1, 1]^d`` (or by ``scale`` when given), so the tolerance is relative.
        Rows proved to be facets by ray shooting from the Chebyshev centre skip their LP, and the
        LPs use only rows already proved to be facets (Clarkson's algorithm), so they stay small.

        Parameters
        ----------
        scale : (d,) array, optional
            Use coordinates ``z / scale`` instead of the bounding box (saves its ``2 d`` LPs when
            the caller knows the size of the set, e.g. a union's bounding box).

        Returns
        -------
        Polytope
            Same set, a subset of the (normalised) rows; :meth:`empty` if the set is empty.

        Notes
        -----
        First, the library path: the vertices from pycddlib or qhull, checked complete
        (:func:`hybobs_opt.geometry.vertices.enumerate_vertices`), decide the facets, each kept row
        with a checked witness point (:func:`hybobs_opt.geometry.redundancy.facets_from_vertices`).
        Unbounded or flat sets, and answers that fail a check, go to the LP path above (counted in
        :data:`hybobs_opt.geometry.vertices.COUNTERS`), and so does every set of dimension above
        :data:`LIBRARY_REDUNDANCY_MAX_DIM`.  ``scale`` applies to the LP path; the
        library path measures in the box of the vertices.
        """
        if self.n_constraints == 0:
            return self
        if self.dim <= LIBRARY_REDUNDANCY_MAX_DIM:
            kept = self._facets_by_vertices(None if scale is None else _positive_scale(scale, self.dim))
            if isinstance(kept, Polytope):
                return kept
        if scale is None:
            box = _box(self.A, self.b)
            if box is None:
                return Polytope.empty(self.dim, self.names)
            mid, half = _unit_box_map(*box)
        else:
            half = _positive_scale(scale, self.dim)
            mid = np.zeros(self.dim)
            if self.is_empty():
                return Polytope.empty(self.dim, self.names)
        An, bn = _row_normalised(self.A, self.b)  # unit rows first: ZERO_ROW_TOL then judges the box scaling only
        As = An * half
        bs = bn - An @ mid
        norms = np.linalg.norm(As, axis=1)
        rows = np.nonzero(norms > ZERO_ROW_TOL)[0]  # zero rows read 0 <= b_i, true on a non-empty set
        keep = irredundant(As[rows] / norms[rows, None], bs[rows] / norms[rows])
        rows = rows[keep]
        A, b = _unit_rows(An[rows], bn[rows])
        return Polytope(A, b, self.names)

    def _facets_by_vertices(self, scale: np.ndarray | None) -> "Polytope | None":
        """:meth:`remove_redundant` from a checked vertex set, or ``None`` (the LP path decides).

        The facets are decided in the coordinates the LP path would use: ``z / scale`` when the
        caller gives ``scale`` (a union's box: its tolerance is relative to that), else the box of
        the vertices (the LP path's bounding box, up to the LPs' accuracy).
        """
        enum = enumerate_vertices(self.A, self.b, op="remove_redundant", facets=scale is None)
        if enum is None:
            return None
        if enum.status == "empty":
            return Polytope.empty(self.dim, self.names)
        if enum.status != "bounded":
            LIBRARY_COUNTERS.fallback("remove_redundant", enum.source, "unbounded set (decided by LPs)")
            return None
        sc, chk = enum.scaled, enum.checked
        if scale is None and enum.facets is not None:  # decided in the check's compiled call
            keep = facet_verdict(*enum.facets, self.dim)
        elif scale is None:
            keep = facets_from_vertices(sc.A, sc.b, chk.Y, chk.tight)
        else:
            An, bn = _row_normalised(self.A[enum.row_indices()], self.b[enum.row_indices()])
            As = An * scale
            norms = np.sqrt(np.einsum("ij,ij->i", As, As))
            keep = facets_from_vertices(As / norms[:, None], bn / norms, enum.points / scale, chk.tight)
        if isinstance(keep, str):
            LIBRARY_COUNTERS.fallback("remove_redundant", enum.source, keep)
            return None
        rows = np.sort(enum.row_indices()[keep])
        An, bn = _row_normalised(self.A[rows], self.b[rows])  # row by row: the LP path's arithmetic
        A, b = _unit_rows(An, bn)
        out = object.__new__(Polytope)  # rows of this (validated) polytope: no second validation
        object.__setattr__(out, "A", A)
        object.__setattr__(out, "b", b)
        object.__setattr__(out, "names", self.names)
        return out

    def project(
        self,
        coords: Sequence[int | str],
        method: str = "auto",
        hull_max_dim: int | None = None,
    ) -> "Polytope":
        """Exact projection ``Proj_coords(P) = {z_S : exists z_rest, z in P}``.

        Computes the ``Proj_x(P_i)`` and ``Proj_x(R_ij)`` of Algorithm 3.1 (paper 002,
        Section 3, eq. (5)).  Equivalent to :meth:`project_with_equalities` with no equalities.

        Parameters
        ----------
        coords : sequence of int or str
            Target coordinates (indices or names), in the order wanted in the result.
        method : {"auto", "hull", "fm", "vertices"}
            ``"hull"``: iterative convex hull of support points (bounded images only);
            ``"fm"``: Fourier-Motzkin elimination with LP redundancy removal after each step;
            ``"auto"``: for a 2-D target (with ``hull_max_dim >= 2``) of a bounded set of dimension
            at most :data:`VERTEX_PROJECTION_MAX_DIM` (6), ``"vertices"`` (when the library vertex
            enumeration passes its check); otherwise ``"hull"`` when the target dimension is
            ``<= hull_max_dim`` and the image is bounded, ``"fm"`` otherwise;
            ``"vertices"`` (bounded sets of small dimension): the checked vertices of
            :meth:`vertices`, projected, and the checked hull of :meth:`from_vertices` -- exact,
            no LPs, but the vertex count grows quickly with the source dimension.
        hull_max_dim : int, optional
            Threshold of ``"auto"`` (default: :data:`hybobs_opt.geometry.projection.HULL_PROJECTION_MAX_DIM`).

        Returns
        -------
        Polytope
            The projection, names of the chosen coordinates kept.  An empty polytope gives
            :meth:`empty`.  A lower-dimensional projection is returned as a polytope whose
            affine hull ``N x = n`` appears as paired rows ``N x <= n, -N x <= -n``.

        Notes
        -----
        Hull method: LPs maximise along ``+-e_i`` (the image's bounding box, which also fixes the
        scaling), the affine hull of the support points is checked (directions normal to it are
        probed; if none moves, the image is flat and the method recurses inside its affine hull),
        then qhull builds the hull of the points and each facet is pushed by one LP along its
        outward normal; a point beyond the facet by more than ``PROJECTION_HULL_RTOL`` (scaled
        coordinates) is added and the hull rebuilt, until no facet moves.  Cost: about one LP per
        facet and per vertex of the image, independent of the source dimension.  A 1-D target is
        an interval from two LPs.
        """
        return self.project_with_equalities(np.zeros((0, self.dim)), np.zeros(0), coords, method, hull_max_dim)

    def project_with_equalities(
        self,
        E: np.ndarray,
        e: np.ndarray,
        coords: Sequence[int | str],
        method: str = "auto",
        hull_max_dim: int | None = None,
    ) -> "Polytope":
        """Projection of ``{z : A z <= b, E z = e}`` onto ``coords``.

        The sets ``R_ij`` of paper 002 (Algorithm 3.1, step 3.1.1) carry the indistinguishability
        equalities ``Y(x, U) = Y(x_hat, U)``.  Passing them as paired inequalities makes the set
        flat, so Chebyshev and full-dimension tests degenerate; here they are eliminated first:
        coordinates are scaled by the bounding box, ``E`` is factorised by SVD, and ``z = z0 + N w``
        with ``N`` an orthonormal basis of its null space; then the full-dimensional polytope in
        ``w`` is projected through the affine map ``w -> z_coords``.

        Parameters
        ----------
        E : (m, d) array
            Equality rows (``m = 0`` allowed).
        e : (m,) array
            Equality right-hand side.
        coords, method, hull_max_dim
            As in :meth:`project`.

        Returns
        -------
        Polytope
            The projection (see :meth:`project`); :meth:`empty` when the set is empty or the
            equalities are inconsistent.
        """
        d = self.dim
        E = as_matrix(E, "E", (None, d)) if np.size(E) else np.zeros((0, d))
        e = as_vector(e, "e", E.shape[0]) if np.size(e) else np.zeros(0)
        if E.shape[0] != e.shape[0]:
            raise ModelError("e", f"a vector of length {E.shape[0]}", f"length {e.shape[0]}")
        idx = _resolve_list(coords, self.names)
        _check_method(method)
        S = np.eye(d)[idx]
        names = tuple(self.names[i] for i in idx)
        if method == "vertices":
            src = self if E.shape[0] == 0 else Polytope(np.vstack([self.A, E, -E]), np.concatenate([self.b, e, -e]))
            V = src.vertices()
            if V.shape[0] == 0:
                return Polytope.empty(len(idx), names)
            return Polytope.from_vertices(V[:, idx], names)
        hull_dim = _projection.HULL_PROJECTION_MAX_DIM if hull_max_dim is None else hull_max_dim
        if method == "auto" and E.shape[0] == 0 and len(idx) == 2 <= hull_dim and d <= VERTEX_PROJECTION_MAX_DIM:
            enum = enumerate_vertices(self.A, self.b, op="projection")
            if enum is not None and enum.status == "empty":
                return Polytope.empty(len(idx), names)
            if enum is not None and enum.status == "bounded":
                return Polytope.from_vertices(enum.points[:, idx], names)
        img = image_of(self.A, self.b, E, e, S, np.zeros(len(idx)), method, hull_max_dim)
        if img is None:
            return Polytope.empty(len(idx), names)
        return Polytope(img.H, img.h, names)

    def vertices(self) -> np.ndarray:
        """Vertices of a bounded polytope, in any dimension.

        pycddlib or qhull enumerate them (:func:`hybobs_opt.geometry.vertices.enumerate_vertices`);
        their answer is used only after a check in numpy: every vertex satisfies every row and
        is a vertex, and every edge walked from a vertex ends on one of them, so none is missing
        (an empty answer needs the LP layer's certificate).  If no library answer passes, the
        iterative-hull machinery of :meth:`project` (identity map) computes them from LP support
        points (counted in :data:`hybobs_opt.geometry.vertices.COUNTERS`).

        Returns
        -------
        (n_v, d) array
            The vertices; counter-clockwise for ``d = 2``; ``(0, d)`` for an empty set.  A
            lower-dimensional polytope returns the vertices of its relative hull.

        Raises
        ------
        ModelError
            If the polytope is unbounded.
        """
        d = self.dim
        enum = enumerate_vertices(self.A, self.b, op="vertices")
        if enum is not None and enum.status == "unbounded":
            raise ModelError("polytope", "a bounded polytope for vertex enumeration", "an unbounded set")
        if enum is not None:
            V = enum.points
        else:
            img = image_of(self.A, self.b, None, None, np.eye(d), np.zeros(d), "hull", d)
            if img is None:
                return np.zeros((0, d))
            V = np.asarray(img.points, dtype=float)
        if d == 2 and len(V) > 2:
            c = V.sum(axis=0) / V.shape[0]
            V = V[np.argsort(np.arctan2(V[:, 1] - c[1], V[:, 0] - c[0]))]
        return V

    def volume(self, method: str = "auto", n_samples: int = 200_000, rng: np.random.Generator | int | None = None) -> VolumeEstimate:
        """Lebesgue volume.

        Parameters
        ----------
        method : {"auto", "exact", "monte-carlo"}
            ``"exact"``: the checked vertices, then qhull's hull of them checked as a closed
            triangulation covering the boundary once (the sum of its simplices' pyramids), or,
            from FACET_VOLUME_MIN_DIM (6-D) up, the sum over the facets of ``depth * area / d``
            with each facet's area from its own checked hull (any dimension; the cost grows
            steeply from 5-D); in 2-D the shoelace area of the checked vertices in angular order,
            in 3-D each facet the polygon of its checked vertices in angular order, checked
            strictly convex, with Euler's formula ``V - E + F = 2`` over the facets (qhull's hull
            when that check fails);
            ``"monte-carlo"``: hit-and-miss with ``n_samples`` uniform points in the bounding box;
            ``"auto"``: exact when ``d <= EXACT_VOLUME_MAX_DIM`` (4).
        n_samples : int
            Monte Carlo sample size.
        rng : numpy Generator or seed, optional
            Random source of the Monte Carlo method.

        Returns
        -------
        VolumeEstimate
            ``value`` and ``stderr`` (``0`` when exact; ``V_box sqrt(p (1 - p) / n)`` for Monte
            Carlo with hit fraction ``p``).  Empty or lower-dimensional sets have volume 0.

        Raises
        ------
        ModelError
            For an unbounded polytope or an unknown ``method``.
        """
        if method not in ("auto", "exact", "monte-carlo"):
            raise ModelError("method", "'auto', 'exact' or 'monte-carlo'", repr(method))
        d = self.dim
        if method == "auto":
            method = "exact" if d <= EXACT_VOLUME_MAX_DIM else "monte-carlo"
        if method == "exact":
            return VolumeEstimate(self._exact_volume(), 0.0, "exact")
        box = _box(self.A, self.b)
        if box is None:
            return VolumeEstimate(0.0, 0.0, "monte-carlo", int(n_samples))
        lo, hi = box
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ModelError("polytope", "a bounded set for the volume", "an unbounded set")
        value, stderr = monte_carlo_volume(self.contains, lo, hi, n_samples, rng)
        return VolumeEstimate(value, stderr, "monte-carlo", int(n_samples))

    def _exact_volume(self) -> float:
        """The exact volume of :meth:`volume` (its docstring): checked vertices, then checked hulls."""
        d = self.dim
        enum = enumerate_vertices(self.A, self.b, op="volume")
        if enum is not None and enum.status == "unbounded":
            raise ModelError("polytope", "a bounded set for the volume", "an unbounded set")
        V = enum.points if enum is not None else self.vertices()
        if len(V) <= d:
            return 0.0
        lo, hi = V.min(axis=0), V.max(axis=0)
        if d == 1:
            return float(hi[0] - lo[0])
        if d == 2 and enum is not None and enum.status == "bounded":
            # the checked vertices of a polygon in angular order about their mean: the shoelace area
            P = V - V.mean(axis=0)
            P = P[np.argsort(np.arctan2(P[:, 1], P[:, 0]))]
            Q = np.roll(P, -1, axis=0)
            return float(0.5 * np.sum(P[:, 0] * Q[:, 1] - Q[:, 0] * P[:, 1]))
        half = np.where(hi > lo, (hi - lo) / 2, 1.0)
        Y = (V - (lo + hi) / 2) / half
        sv = np.linalg.svd(Y - Y.mean(axis=0), compute_uv=False)
        if np.sum(sv > AFFINE_HULL_RTOL) < d:
            return 0.0
        by_facets = enum is not None and enum.status == "bounded"
        if by_facets and d == 3:
            # each facet the polygon of its checked vertices, in angular order (as in 2-D), checked
            # strictly convex, with Euler's formula over them: one compiled call instead of qhull's hull
            code, v = facet_volume_3d(np.ascontiguousarray(enum.checked.Y, dtype=float),
                                      np.ascontiguousarray(enum.scaled.A, dtype=float),
                                      np.ascontiguousarray(enum.scaled.b, dtype=float),
                                      np.ascontiguousarray(enum.checked.tight), FULL_DIMENSION_RTOL,
                                      AFFINE_HULL_RTOL, FULL_SIMPLEX_RTOL)
            if code == 0:
                return float(v * np.prod(enum.scaled.half))

        def facets() -> float | str:
            v = volume_by_facets(enum.checked.Y, enum.scaled.A, enum.scaled.b, enum.checked.tight)
            return v if isinstance(v, str) else float(v * np.prod(enum.scaled.half))

        if by_facets and d >= FACET_VOLUME_MIN_DIM:
            v = facets()
            if not isinstance(v, str):
                return v
        try:
            return float(checked_hull_volume(Y) * np.prod(half))
        except SolverError:
            if not by_facets or d >= FACET_VOLUME_MIN_DIM:
                raise
            v = facets()
            if isinstance(v, str):
                raise
            return v

    def chebyshev_ball_in_subspace(
        self, E: np.ndarray, e: np.ndarray, scale: np.ndarray | None = None
    ) -> tuple[np.ndarray | None, float]:
        """Largest ball of ``{z : A z <= b, E z = e}`` inside the affine hull ``E z = e``.

        The plain :meth:`chebyshev_ball` of a set with equalities written as paired inequalities
        has radius 0; here ``E z = e`` is parametrised as ``z = z0 + N w`` (SVD, ``N``
        orthonormal in the coordinates ``z / scale``), and the ball is the Chebyshev ball of the
        polytope in ``w``: its radius is measured inside the subspace.

        Parameters
        ----------
        E : (m, d) array
            Equality rows.
        e : (m,) array
            Right-hand side.
        scale : (d,) array, optional
            Measure distances in coordinates ``z / scale`` (as in :meth:`chebyshev_ball`).

        Returns
        -------
        centre : (d,) array or None
            Centre in the original coordinates (``None`` if empty or unbounded).
        radius : float
            ``-inf`` for inconsistent equalities, ``inf`` when unbounded inside the subspace, ``<= 0``
            when there is no relative interior; ``0`` when the equalities leave a single point.
        """
        d = self.dim
        E = as_matrix(E, "E", (None, d))
        e = as_vector(e, "e", E.shape[0])
        s = np.ones(d) if scale is None else _positive_scale(scale, d)
        As = self.A * s
        ns = _nullspace(E * s, e)
        if ns is None:
            return None, -np.inf
        y0, N = ns
        Aw = As @ N
        bw = self.b - As @ y0
        if N.shape[1] == 0:
            ok = np.all(bw >= -MEMBERSHIP_RTOL * (1.0 + np.abs(self.b)))
            return (s * y0, 0.0) if ok else (None, -np.inf)
        k = N.shape[1]
        c = np.zeros(k + 1)
        c[-1] = -1.0
        A_ub = np.hstack([Aw, np.linalg.norm(Aw, axis=1)[:, None]])
        res = _lp(c, A_ub, bw, problem="Chebyshev ball inside the affine hull")
        if res.status == "infeasible":
            return None, -np.inf
        if res.status == "unbounded":
            return None, np.inf
        return s * (y0 + N @ res.x[:k]), float(res.x[-1])

    def __repr__(self) -> str:
        return f"Polytope(dim={self.dim}, n_constraints={self.n_constraints}, names={self.names})"

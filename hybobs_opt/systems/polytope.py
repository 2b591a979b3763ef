"""A small H-polytope type ``{z : A z <= b}`` with coordinate names, and its geometry.

Used for guards, invariants and state/input bounds, and for the sets of paper 002 (Sections 2-3):
the unobservable set ``B_T`` is a union of projections ``Proj_x(R_ij)`` of higher-dimensional
polytopes (e.g. 9-D -> 3-D, 17-D -> 5-D), cut at fixed coordinates for figures.  This module
provides redundancy removal, affine images and preimages, slices, exact projections (iterative
hull for small target dimensions, Fourier-Motzkin otherwise), vertices and volumes.  Unions and
set differences live in :mod:`hybobs_opt.regions.union`.

Every LP goes through :func:`hybobs_opt.lp.solve_lp`; tolerances are the named, relative ones of
:mod:`hybobs_opt.tolerances`, applied in coordinates scaled by the bounding box.
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import ConvexHull, QhullError

from ..errors import ModelError, SolverError
from ..lp import row_range, solve_lp
from ..tolerances import (
    AFFINE_HULL_RTOL,
    EQUALITY_CONSISTENCY_RTOL,
    FULL_DIMENSION_RTOL,
    MEMBERSHIP_RTOL,
    PARALLEL_ROW_TOL,
    PROJECTION_HULL_RTOL,
    RANK_RTOL,
    RAY_TIE_RTOL,
    REDUNDANCY_RTOL,
    ZERO_ROW_TOL,
)
from ._validate import as_matrix, as_names, as_vector

#: Target dimension up to which :meth:`Polytope.project` (``method="auto"``) uses the iterative
#: convex-hull method; above it, Fourier-Motzkin elimination.  Qhull's cost grows quickly with the
#: dimension, while the hull method needs only ~(facets + vertices) LPs; set this module attribute
#: (or pass ``hull_max_dim``) to move the switch.
HULL_PROJECTION_MAX_DIM: int = 5

#: Largest dimension for which :meth:`Polytope.vertices` and the exact :meth:`Polytope.volume`
#: (qhull on the vertices) are offered; above it the volume is estimated by Monte Carlo.
VERTEX_MAX_DIM: int = 4

#: Safety cap on the support LPs of one iterative-hull projection; reaching it means the hull
#: does not converge (numerical trouble), which raises :class:`SolverError`.
HULL_MAX_SUPPORT_LPS: int = 20000

#: Largest dimension in which Fourier-Motzkin's redundancy removal first drops rows by one qhull
#: call on the polar points (thousands of rows in < 1 s up to 6-D; qhull slows sharply beyond).
FM_QHULL_MAX_DIM: int = 6

_METHODS = ("auto", "hull", "fm")


@dataclass(frozen=True)
class VolumeEstimate:
    """Volume of a polytope or union of polytopes.

    Attributes
    ----------
    value : float
        The volume (exact, or the Monte Carlo estimate).
    stderr : float
        Standard error of ``value``: ``0.0`` for the exact method.
    method : str
        ``"exact"`` (convex hull of the vertices) or ``"monte-carlo"`` (hit-and-miss in the
        bounding box).
    n_samples : int
        Number of Monte Carlo samples (``0`` for the exact method).
    """

    value: float
    stderr: float
    method: str
    n_samples: int = 0


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

    Notes
    -----
    Strict and non-strict inequalities are not distinguished: the paper's regions are "not
    necessarily closed" (paper 002, eq. 1), and membership ties are broken by mode order.
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
        """Axis-aligned box ``lower <= z <= upper``; raises if a lower bound exceeds its upper bound."""
        lo = as_vector(lower, "lower", None)
        hi = as_vector(upper, "upper", lo.size)
        bad = np.nonzero(lo > hi)[0]
        if bad.size:
            i = int(bad[0])
            label = names[i] if names else f"z{i + 1}"
            raise ModelError(f"bounds of {label}", "lower <= upper", f"[{lo[i]}, {hi[i]}]")
        d = lo.size
        A = np.vstack([np.eye(d), -np.eye(d)])
        b = np.concatenate([hi, -lo])
        return cls(A, b, tuple(names) if names else ())

    @classmethod
    def empty(cls, dim: int, names: Sequence[str] | None = None) -> "Polytope":
        """The empty set of ``R^dim``, written as the rows ``z1 <= -1`` and ``-z1 <= 0``."""
        A = np.zeros((2, dim))
        A[0, 0], A[1, 0] = 1.0, -1.0
        return cls(A, np.array([-1.0, 0.0]), tuple(names) if names else ())

    @classmethod
    def whole_space(cls, dim: int, names: Sequence[str] | None = None) -> "Polytope":
        """The unconstrained set ``R^dim`` (no rows)."""
        return cls(np.zeros((0, dim)), np.zeros(0), tuple(names) if names else ())

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
        """Rows scaled to unit 2-norm; all-zero rows are dropped (or flagged if they make the set empty)."""
        norms = np.linalg.norm(self.A, axis=1)
        zero = norms <= ZERO_ROW_TOL
        if np.any(zero & (self.b < 0)):
            # 0 <= negative: the set is empty; keep one infeasible row so emptiness is preserved.
            return Polytope(np.vstack([np.eye(1, self.dim), -np.eye(1, self.dim)]), np.array([-1.0, 0.0]), self.names)
        keep = ~zero
        return Polytope(self.A[keep] / norms[keep, None], self.b[keep] / norms[keep], self.names)

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        """Tightest axis-aligned box ``(lower, upper)`` by 2d LPs.

        Raises
        ------
        ModelError
            If the polytope is empty or unbounded in some coordinate (named in the message).
        """
        r = row_range(self.A, self.b, np.eye(self.dim), problem="bounding box", field="polytope", labels=self.names)
        return r[:, 0].copy(), r[:, 1].copy()

    def is_bounded(self) -> bool:
        """True when every coordinate is bounded above and below (and the set is non-empty)."""
        try:
            self.bounding_box()
        except ModelError:
            return False
        return True

    def chebyshev_ball(self, scale: np.ndarray | None = None) -> tuple[np.ndarray | None, float]:
        """Centre and radius of the largest inscribed ball, optionally in coordinates ``z / scale``.

        Returns ``(None, -inf)`` for an empty polytope and ``radius = inf`` when unbounded.
        """
        A = self.A if scale is None else self.A * np.asarray(scale, dtype=float)[None, :]
        norms = np.linalg.norm(A, axis=1)
        d = self.dim
        c = np.zeros(d + 1)
        c[-1] = -1.0
        A_ub = np.hstack([A, norms[:, None]])
        res = solve_lp(c, A_ub, self.b, bounds=[(None, None)] * d + [(None, None)], problem="Chebyshev ball")
        if res.status == "infeasible":
            return None, -np.inf
        if res.status == "unbounded":
            return None, np.inf
        centre = res.x[:d] if scale is None else res.x[:d] * np.asarray(scale, dtype=float)
        return centre, float(res.x[-1])

    def is_empty(self) -> bool:
        """True when no point satisfies ``A z <= b``."""
        res = solve_lp(np.zeros(self.dim), self.A, self.b, problem="emptiness test")
        return res.status == "infeasible"

    def is_full_dimensional(self, scale: np.ndarray | None = None, rtol: float = FULL_DIMENSION_RTOL) -> bool:
        """True when the Chebyshev radius in coordinates ``z / scale`` exceeds ``rtol``.

        ``scale`` defaults to the bounding-box widths, so the test is relative to the set's size
        in every coordinate (DESIGN.md: tolerances are relative).
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
        """Intersection with a polytope of the same dimension."""
        if other.dim != self.dim:
            raise ModelError("other", f"a polytope of dimension {self.dim}", f"dimension {other.dim}")
        return Polytope(np.vstack([self.A, other.A]), np.concatenate([self.b, other.b]), self.names)

    def product(self, other: "Polytope") -> "Polytope":
        """Cartesian product ``self x other`` (coordinates concatenated)."""
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
        """Embed into ``R^dim``: the constraint acts on ``coords`` of the larger space only."""
        coords = list(coords)
        if len(coords) != self.dim:
            raise ModelError("coords", f"{self.dim} coordinate indices", f"{len(coords)}")
        A = np.zeros((self.n_constraints, dim))
        A[:, coords] = self.A
        return Polytope(A, self.b.copy(), tuple(names) if names else ())

    # ------------------------------------------------------------------ coordinates, cuts, maps
    def index_of(self, coord: int | str) -> int:
        """Index of a coordinate given by its index or its name.

        Raises
        ------
        ModelError
            If the name is unknown or the index is out of range.
        """
        return _resolve(coord, self.names)

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
            i = _resolve(key, self.names)
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
        if k == self.dim:
            sv = np.linalg.svd(M, compute_uv=False)
            if sv[0] > 0 and sv[-1] > RANK_RTOL * sv[0]:
                H = np.linalg.solve(M.T, self.A.T).T
                H, h = _unit_rows(H, self.b + H @ v)
                return Polytope(H, h, out_names)
        img = _image_of(self.A, self.b, None, None, M, v, method, hull_max_dim)
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
        """
        if self.n_constraints == 0:
            return self
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
        As = self.A * half
        bs = self.b - self.A @ mid
        norms = np.linalg.norm(As, axis=1)
        rows = np.nonzero(norms > ZERO_ROW_TOL)[0]  # zero rows read 0 <= b_i, true on a non-empty set
        keep = _irredundant(As[rows] / norms[rows, None], bs[rows] / norms[rows])
        rows = rows[keep]
        A, b = _unit_rows(self.A[rows], self.b[rows])
        return Polytope(A, b, self.names)

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
        method : {"auto", "hull", "fm"}
            ``"hull"``: iterative convex hull of support points (bounded images only);
            ``"fm"``: Fourier-Motzkin elimination with LP redundancy removal after each step;
            ``"auto"``: ``"hull"`` when the target dimension is ``<= hull_max_dim`` and the image
            is bounded, ``"fm"`` otherwise.
        hull_max_dim : int, optional
            Threshold of ``"auto"`` (default: module constant ``HULL_PROJECTION_MAX_DIM`` = 4).

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
        img = _image_of(self.A, self.b, E, e, S, np.zeros(len(idx)), method, hull_max_dim)
        if img is None:
            return Polytope.empty(len(idx), names)
        return Polytope(img.H, img.h, names)

    def vertices(self) -> np.ndarray:
        """Vertices of a bounded polytope of dimension ``<= VERTEX_MAX_DIM`` (4).

        Computed with the iterative-hull machinery of :meth:`project` (identity map): LP support
        points whose hull is the polytope, reduced to the hull's vertices.

        Returns
        -------
        (n_v, d) array
            The vertices; counter-clockwise for ``d = 2``; ``(0, d)`` for an empty set.  A
            lower-dimensional polytope returns the vertices of its relative hull.

        Raises
        ------
        ModelError
            If ``d > VERTEX_MAX_DIM`` or the polytope is unbounded.
        """
        d = self.dim
        if d > VERTEX_MAX_DIM:
            raise ModelError("polytope", f"dimension <= {VERTEX_MAX_DIM} for vertex enumeration", f"dimension {d}")
        img = _image_of(self.A, self.b, None, None, np.eye(d), np.zeros(d), "hull", d)
        if img is None:
            return np.zeros((0, d))
        V = np.asarray(img.points, dtype=float)
        if d == 2 and len(V) > 2:
            c = V.mean(axis=0)
            V = V[np.argsort(np.arctan2(V[:, 1] - c[1], V[:, 0] - c[0]))]
        return V

    def volume(self, method: str = "auto", n_samples: int = 200_000, rng: np.random.Generator | int | None = None) -> VolumeEstimate:
        """Lebesgue volume.

        Parameters
        ----------
        method : {"auto", "exact", "monte-carlo"}
            ``"exact"``: qhull volume of the vertices (``d <= VERTEX_MAX_DIM``);
            ``"monte-carlo"``: hit-and-miss with ``n_samples`` uniform points in the bounding box;
            ``"auto"``: exact when possible.
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
            method = "exact" if d <= VERTEX_MAX_DIM else "monte-carlo"
        if method == "exact":
            V = self.vertices()
            if len(V) <= d:
                return VolumeEstimate(0.0, 0.0, "exact")
            lo, hi = V.min(axis=0), V.max(axis=0)
            half = np.where(hi > lo, (hi - lo) / 2, 1.0)
            Y = (V - (lo + hi) / 2) / half
            if d == 1:
                return VolumeEstimate(float(hi[0] - lo[0]), 0.0, "exact")
            sv = np.linalg.svd(Y - Y.mean(axis=0), compute_uv=False)
            if np.sum(sv > AFFINE_HULL_RTOL) < d:
                return VolumeEstimate(0.0, 0.0, "exact")
            return VolumeEstimate(float(ConvexHull(Y).volume * np.prod(half)), 0.0, "exact")
        box = _box(self.A, self.b)
        if box is None:
            return VolumeEstimate(0.0, 0.0, "monte-carlo", int(n_samples))
        lo, hi = box
        if not (np.all(np.isfinite(lo)) and np.all(np.isfinite(hi))):
            raise ModelError("polytope", "a bounded set for the volume", "an unbounded set")
        value, stderr = monte_carlo_volume(self.contains, lo, hi, n_samples, rng)
        return VolumeEstimate(value, stderr, "monte-carlo", int(n_samples))

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


# ====================================================================== module helpers
def _resolve(coord: int | str, names: tuple[str, ...]) -> int:
    """Index of ``coord`` (an index or a name) among ``names``."""
    if isinstance(coord, str):
        try:
            return names.index(coord)
        except ValueError:
            raise ModelError("coordinate", f"one of {names}", repr(coord)) from None
    if isinstance(coord, numbers.Integral) and not isinstance(coord, bool):
        i = int(coord)
        if 0 <= i < len(names):
            return i
        raise ModelError("coordinate", f"an index in [0, {len(names) - 1}]", str(i))
    raise ModelError("coordinate", "an int index or a str name", type(coord).__name__)


def _resolve_list(coords: Sequence[int | str], names: tuple[str, ...]) -> list[int]:
    if isinstance(coords, (str, numbers.Integral)):
        coords = [coords]
    idx = [_resolve(c, names) for c in coords]
    if not idx:
        raise ModelError("coords", "at least one coordinate", "none")
    if len(set(idx)) != len(idx):
        raise ModelError("coords", "distinct coordinates", str([names[i] for i in idx]))
    return idx


def _check_method(method: str) -> None:
    if method not in _METHODS:
        raise ModelError("method", f"one of {_METHODS}", repr(method))


def _positive_scale(scale: np.ndarray, d: int) -> np.ndarray:
    s = as_vector(scale, "scale", d)
    if np.any(s <= 0):
        raise ModelError("scale", "positive entries", str(s))
    return np.array(s)


def _lp(c, A, b, E=None, e=None, *, problem: str):
    """:func:`solve_lp` with empty constraint blocks passed as ``None``."""
    A_ub = A if A is not None and A.shape[0] else None
    b_ub = b if A_ub is not None else None
    A_eq = E if E is not None and E.shape[0] else None
    b_eq = e if A_eq is not None else None
    return solve_lp(c, A_ub, b_ub, A_eq, b_eq, problem=problem)


def _unit_rows(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rows scaled to unit norm; zero rows dropped (callers only use this on non-empty sets)."""
    norms = np.linalg.norm(A, axis=1)
    keep = norms > ZERO_ROW_TOL
    return A[keep] / norms[keep, None], b[keep] / norms[keep]


def _box(A: np.ndarray, b: np.ndarray, E: np.ndarray | None = None, e: np.ndarray | None = None):
    """Bounding box ``(lo, hi)`` with ``+-inf`` where unbounded, or ``None`` when empty (2d LPs)."""
    d = A.shape[1]
    lo = np.full(d, -np.inf)
    hi = np.full(d, np.inf)
    for i in range(d):
        for sign, out in ((1.0, lo), (-1.0, hi)):
            c = np.zeros(d)
            c[i] = sign
            res = _lp(c, A, b, E, e, problem=f"bounding box, coordinate {i + 1}")
            if res.status == "infeasible":
                return None
            if res.status == "optimal":
                out[i] = sign * res.objective
    return lo, hi


def _unit_box_map(lo: np.ndarray, hi: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(mid, half)`` with ``z = mid + half * y`` mapping the box onto ``[-1, 1]^d``.

    Unbounded coordinates and coordinates whose width is below ``FULL_DIMENSION_RTOL`` times the
    largest width (fixed by the constraints) get the largest half-width as their scale, so no
    coordinate is blown up by dividing by LP noise.
    """
    finite = np.isfinite(lo) & np.isfinite(hi)
    width = np.where(finite, hi - lo, 0.0)
    ref = float(width.max()) if np.any(width > 0) else 2.0
    thick = finite & (width > FULL_DIMENSION_RTOL * ref)
    half = np.where(thick, width / 2, ref / 2)
    mid = np.where(finite, (np.where(finite, lo, 0) + np.where(finite, hi, 0)) / 2, 0.0)
    mid = np.where(~finite & np.isfinite(lo), lo, mid)
    mid = np.where(~finite & np.isfinite(hi), hi, mid)
    return mid, half


def _nullspace(E: np.ndarray, e: np.ndarray) -> tuple[np.ndarray, np.ndarray] | None:
    """``(y0, N)`` with ``{y : E y = e} = {y0 + N w}``, ``N`` orthonormal (SVD); ``None`` if inconsistent."""
    d = E.shape[1]
    if E.shape[0] == 0:
        return np.zeros(d), np.eye(d)
    U, s, Vt = np.linalg.svd(E, full_matrices=True)
    r = int(np.sum(s > RANK_RTOL * s[0])) if s.size and s[0] > 0 else 0
    y0 = Vt[:r].T @ ((U[:, :r].T @ e) / s[:r])
    if np.linalg.norm(E @ y0 - e) > EQUALITY_CONSISTENCY_RTOL * (1.0 + np.linalg.norm(e)):
        return None
    return y0, Vt[r:].T


def _irredundant(A: np.ndarray, b: np.ndarray, polar_prefilter: bool = False) -> np.ndarray:
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


@dataclass(frozen=True)
class _Image:
    """H-representation ``H x <= h`` of an image, plus its vertices when the hull method ran."""

    H: np.ndarray
    h: np.ndarray
    points: np.ndarray | None


def _point_image(c: np.ndarray) -> _Image:
    k = c.size
    return _Image(np.vstack([np.eye(k), -np.eye(k)]), np.concatenate([c, -c]), c[None, :].copy())


def _image_of(A, b, E, e, M, v, method: str, hull_max_dim: int | None) -> _Image | None:
    """``{M z + v : A z <= b, E z = e}`` or ``None`` when empty.

    Scales ``z`` by its bounding box, eliminates the equalities by an orthonormal null-space
    parametrisation ``y = y0 + N w`` and hands the full-dimensional polytope in ``w`` and the map
    ``w -> x`` to :func:`_linear_image`.
    """
    d = A.shape[1]
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
    :func:`_irredundant` runs, with its qhull polar prefilter.
    """
    k, r = Ls.shape
    _, _, Vt = np.linalg.svd(Ls, full_matrices=True)
    T = np.vstack([Ls, Vt[k:]])
    Au = np.linalg.solve(T.T, Aw.T).T
    bu = bw + Au @ np.concatenate([cs, np.zeros(r - k)])
    Au, bu, nz = _unit_rows_mask(Au, bu)
    keep = _irredundant(Au, bu, polar_prefilter=True)
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
        keep = _irredundant(Au, bu, polar_prefilter=True)
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


def monte_carlo_volume(
    contains: Callable[[np.ndarray], np.ndarray],
    lo: np.ndarray,
    hi: np.ndarray,
    n_samples: int,
    rng: np.random.Generator | int | None = None,
) -> tuple[float, float]:
    """Hit-and-miss volume of a set inside the box ``[lo, hi]``.

    Parameters
    ----------
    contains : callable
        Vectorised membership ``(N, d) -> (N,) bool``.
    lo, hi : (d,) arrays
        A box containing the set.
    n_samples : int
        Number of uniform samples.
    rng : numpy Generator or seed, optional

    Returns
    -------
    value, stderr : float
        ``p V_box`` and ``V_box sqrt(p (1 - p) / n)`` with ``p`` the hit fraction.
    """
    if n_samples < 1:
        raise ModelError("n_samples", "a positive integer", str(n_samples))
    gen = np.random.default_rng(rng)
    lo = np.asarray(lo, dtype=float)
    width = np.asarray(hi, dtype=float) - lo
    hits, done = 0, 0
    while done < n_samples:
        m = min(_MC_BATCH, n_samples - done)
        hits += int(np.count_nonzero(contains(lo + width * gen.random((m, lo.size)))))
        done += m
    p = hits / n_samples
    vbox = float(np.prod(width))
    return p * vbox, vbox * float(np.sqrt(p * (1.0 - p) / n_samples))


_MC_BATCH = 65536  # samples per vectorised membership call: bounded memory, negligible overhead

"""Finite unions of polytopes: the sets ``X*_T``, ``B_T`` and ``O_T`` of paper 002.

``X*_T`` (eq. (5)) and the unobservable set ``B_T`` (Algorithm 3.1) are unions of projections of
polytopes, and the observable set is the difference ``O_T = X*_T \\ B_T`` (eq. (9)).  A
:class:`PolytopeUnion` holds such a union (pieces of one dimension, with coordinate names) and
provides membership, cuts, projections, differences, volumes, 2-D drawings of cuts and a JSON-ready
dictionary form.

All pieces are closed polytopes; like the paper ("up to a set of zero measure"), differences are
computed for closures and lower-dimensional pieces are dropped.
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ..defaults import EXACT_VOLUME_MAX_DIM
from ..errors import ModelError
from ..geometry.difference import polytope_difference
from ..geometry._common import resolve_coordinate
from .._validate import as_names
from ..geometry.polytope import Polytope
from ..geometry.volume import VolumeEstimate, monte_carlo_volume
from ..tolerances import FULL_DIMENSION_RTOL, MEMBERSHIP_RTOL


@dataclass(frozen=True, eq=False)
class PolytopeUnion:
    """A finite union of closed polytopes of one dimension.

    Parameters
    ----------
    pieces : sequence of Polytope
        The pieces (any number, possibly overlapping, possibly empty).
    dim : int, optional
        Dimension; required when ``pieces`` is empty, otherwise checked against the pieces.
    names : sequence of str, optional
        Coordinate names (default: the first piece's names, or ``z1 ... zd``).

    Notes
    -----
    Behaves as a sequence of its pieces (``len``, iteration, indexing).
    """

    pieces: tuple[Polytope, ...]
    dim: int | None = None
    names: tuple[str, ...] = field(default=())

    def __post_init__(self) -> None:
        pieces = tuple(self.pieces)
        for i, p in enumerate(pieces):
            if not isinstance(p, Polytope):
                raise ModelError(f"pieces[{i}]", "a Polytope", type(p).__name__)
        dims = {p.dim for p in pieces}
        if len(dims) > 1:
            raise ModelError("pieces", "polytopes of one dimension", f"dimensions {sorted(dims)}")
        if self.dim is None and not pieces:
            raise ModelError("dim", "the dimension of an empty union", "None")
        dim = int(self.dim) if self.dim is not None else pieces[0].dim
        if dim < 1:
            raise ModelError("dim", "a dimension >= 1", str(dim))
        if pieces and pieces[0].dim != dim:
            raise ModelError("pieces", f"polytopes of dimension {dim}", f"dimension {pieces[0].dim}")
        names = self.names if self.names else (pieces[0].names if pieces else ())
        object.__setattr__(self, "pieces", pieces)
        object.__setattr__(self, "dim", dim)
        object.__setattr__(self, "names", as_names(names, "PolytopeUnion.names", dim, "z"))

    # ------------------------------------------------------------------ sequence protocol
    def __len__(self) -> int:
        return len(self.pieces)

    def __iter__(self) -> Iterator[Polytope]:
        return iter(self.pieces)

    def __getitem__(self, i: int) -> Polytope:
        return self.pieces[i]

    def __repr__(self) -> str:
        return f"PolytopeUnion(n_pieces={len(self)}, dim={self.dim}, names={self.names})"

    def _new(self, pieces: Sequence[Polytope], names: Sequence[str] | None = None) -> "PolytopeUnion":
        names = tuple(names) if names is not None else self.names
        return PolytopeUnion(tuple(pieces), len(names), names)

    # ------------------------------------------------------------------ queries
    def contains(self, points: np.ndarray, rtol: float = MEMBERSHIP_RTOL) -> np.ndarray | bool:
        """Membership in any piece, for one point ``(d,)`` (bool) or many ``(N, d)`` (array)."""
        z = np.asarray(points, dtype=float)
        single = z.ndim == 1
        Z = z.reshape(1, -1) if single else z
        if Z.ndim != 2 or Z.shape[1] != self.dim:
            raise ModelError("points", f"points of dimension {self.dim}", f"shape {z.shape}")
        inside = np.zeros(Z.shape[0], dtype=bool)
        for p in self.pieces:
            todo = ~inside
            if not np.any(todo):
                break
            inside[todo] = p.contains(Z[todo], rtol)
        return bool(inside[0]) if single else inside

    def is_empty(self) -> bool:
        """True when no piece holds a point (an LP per piece)."""
        return all(p.is_empty() for p in self.pieces)

    def bounding_box(self) -> tuple[np.ndarray, np.ndarray]:
        """Smallest box ``(lower, upper)`` containing every non-empty piece.

        Raises
        ------
        ModelError
            If the union is empty or a piece is unbounded.
        """
        lo = np.full(self.dim, np.inf)
        hi = np.full(self.dim, -np.inf)
        for p in self.pieces:
            if p.is_empty():
                continue
            plo, phi = p.bounding_box()
            lo, hi = np.minimum(lo, plo), np.maximum(hi, phi)
        if not np.all(np.isfinite(lo)):
            raise ModelError("union", "a non-empty set", "an empty set")
        return lo, hi

    def _scale(self) -> np.ndarray | None:
        """Bounding-box widths (the relative scale of every tolerance), ``None`` if unavailable."""
        try:
            lo, hi = self.bounding_box()
        except ModelError:
            return None
        width = hi - lo
        ref = float(width.max()) if np.any(width > 0) else 1.0
        return np.where(width > FULL_DIMENSION_RTOL * ref, width, ref)

    # ------------------------------------------------------------------ transformations
    def slice(self, fixed: Mapping[int | str, float]) -> "PolytopeUnion":
        """Cut every piece at fixed coordinates (see :meth:`Polytope.slice`); empty cuts dropped."""
        idx = {self._index(k): v for k, v in fixed.items()}
        out = []
        for p in self.pieces:
            q = p.slice(idx)
            if not q.is_empty():
                out.append(q)
        keep = [i for i in range(self.dim) if i not in idx]
        return self._new(out, [self.names[i] for i in keep])

    def project(self, coords: Sequence[int | str], method: str = "auto") -> "PolytopeUnion":
        """Project piece by piece (see :meth:`Polytope.project`); empty pieces dropped.

        The projection of a union is the union of the projections (paper 002, eq. (5)).
        """
        if isinstance(coords, (str, int)):
            coords = [coords]
        idx = [self._index(c) for c in coords]
        out = [q for q in (p.project(idx, method=method) for p in self.pieces if not p.is_empty()) if not q.is_empty()]
        return self._new(out, [self.names[i] for i in idx])

    def difference(self, other: "PolytopeUnion") -> "PolytopeUnion":
        """Set difference ``self \\ other`` as a union of full-dimensional polytopes.

        Implements ``O_T = X*_T \\ B_T`` (paper 002, eq. (9)) with the region-difference
        algorithm: for a piece ``R`` and a piece ``Q = {q_i z <= h_i}`` of ``other`` (redundant rows
        removed), ``R \\ Q`` is the union over ``i`` of ``R and {q_i z >= h_i} and {q_j z <= h_j,
        j < i}``; this is applied for every piece of ``other`` in turn and every piece of
        ``self``.  Pieces whose Chebyshev radius, relative to the bounding box of ``self``, is
        not above ``FULL_DIMENSION_RTOL`` are dropped, and ``R`` is kept whole when ``R and Q``
        is not full-dimensional.

        Returns
        -------
        PolytopeUnion
            Full-dimensional pieces with pairwise disjoint interiors within each piece of
            ``self`` (pieces from different, overlapping pieces of ``self`` may overlap).  Exact
            up to the boundaries (a set of zero measure).
        """
        if not isinstance(other, PolytopeUnion):
            raise ModelError("other", "a PolytopeUnion", type(other).__name__)
        if other.dim != self.dim:
            raise ModelError("other", f"a union of dimension {self.dim}", f"dimension {other.dim}")
        scale = self._scale()
        if scale is None:
            return self._new([])
        cutters = [q.remove_redundant(scale) for q in other.pieces if q.is_full_dimensional(scale)]
        out: list[Polytope] = []
        for p in self.pieces:
            if not p.is_full_dimensional(scale):
                continue
            current = [p.remove_redundant(scale)]
            for q in cutters:
                current = [piece for r in current for piece in polytope_difference(r, q, scale)]
                if not current:
                    break
            out.extend(current)
        return self._new(out)

    # ------------------------------------------------------------------ measures
    def volume(self, method: str = "auto", n_samples: int = 200_000, rng: np.random.Generator | int | None = None) -> VolumeEstimate:
        """Volume of the union (overlaps counted once).

        Parameters
        ----------
        method : {"auto", "exact", "monte-carlo"}
            ``"exact"`` (dimension ``<= EXACT_VOLUME_MAX_DIM``): the union is made disjoint,
            ``P_1, P_2 \\ P_1, P_3 \\ (P_1 u P_2), ...`` by :meth:`difference`, and the exact piece
            volumes are summed.  ``"monte-carlo"``: hit-and-miss in the union's bounding box.
            ``"auto"``: exact when the dimension allows.
        n_samples, rng
            Monte Carlo sample size and random source.

        Returns
        -------
        VolumeEstimate
        """
        if method not in ("auto", "exact", "monte-carlo"):
            raise ModelError("method", "'auto', 'exact' or 'monte-carlo'", repr(method))
        if method == "auto":
            method = "exact" if self.dim <= EXACT_VOLUME_MAX_DIM else "monte-carlo"
        pieces = [p for p in self.pieces if not p.is_empty()]
        if not pieces:
            return VolumeEstimate(0.0, 0.0, method, 0 if method == "exact" else int(n_samples))
        if method == "exact":
            total = 0.0
            for i, p in enumerate(pieces):
                fresh = self._new([p]).difference(self._new(pieces[:i])) if i else self._new([p])
                total += sum(q.volume("exact").value for q in fresh)
            return VolumeEstimate(total, 0.0, "exact")
        lo, hi = self.bounding_box()
        value, stderr = monte_carlo_volume(self.contains, lo, hi, n_samples, rng)
        return VolumeEstimate(value, stderr, "monte-carlo", int(n_samples))

    # ------------------------------------------------------------------ drawing and saving
    def plot_cut(
        self,
        ax: Any,
        x_coord: int | str,
        y_coord: int | str,
        fixed: Mapping[int | str, float] | None = None,
        **style: Any,
    ) -> list[Any]:
        """Draw the 2-D cut of every piece as a filled polygon.

        Each piece is sliced at ``fixed`` (paper 002, Section 6: e.g. ``omega_l = 25``), projected
        onto ``(x_coord, y_coord)`` and drawn from its counter-clockwise vertices.  Pieces whose
        cut is empty or not 2-D are skipped.

        Parameters
        ----------
        ax : matplotlib Axes
            Where to draw (any backend; tests use Agg).
        x_coord, y_coord : int or str
            The two coordinates of the drawing (indices or names of this union's coordinates).
        fixed : mapping, optional
            Coordinates fixed before projecting; the rest are projected out.
        **style
            Passed to :class:`matplotlib.patches.Polygon` (defaults: translucent face, edge).

        Returns
        -------
        list of matplotlib.patches.Polygon
            The patches added, one per drawn piece.
        """
        from matplotlib.patches import Polygon as _MplPolygon

        ix, iy = self._index(x_coord), self._index(y_coord)
        if ix == iy:
            raise ModelError("y_coord", "a coordinate different from x_coord", self.names[iy])
        fixed_idx = {self._index(k): float(v) for k, v in (fixed or {}).items()}
        if ix in fixed_idx or iy in fixed_idx:
            raise ModelError("fixed", "not to fix the plotted coordinates", str(sorted(self.names[i] for i in fixed_idx)))
        remaining = [i for i in range(self.dim) if i not in fixed_idx]
        px, py = remaining.index(ix), remaining.index(iy)
        opts = {"facecolor": "tab:blue", "edgecolor": "black", "alpha": 0.4, "linewidth": 0.8}
        opts.update(style)
        patches = []
        for p in self.pieces:
            cut = p.slice(fixed_idx) if fixed_idx else p
            if cut.is_empty():
                continue
            V = cut.project([px, py]).vertices()
            if len(V) < 3 or _signed_area(V) <= 0.0:
                continue
            patch = _MplPolygon(V, closed=True, **opts)
            ax.add_patch(patch)
            patches.append(patch)
        ax.autoscale_view()
        if not ax.get_xlabel():
            ax.set_xlabel(self.names[ix])
        if not ax.get_ylabel():
            ax.set_ylabel(self.names[iy])
        return patches

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready form: ``{"dim", "names", "pieces": [{"A", "b", "names"}, ...]}`` (plain lists)."""
        return {
            "dim": int(self.dim),
            "names": list(self.names),
            "pieces": [{"A": p.A.tolist(), "b": p.b.tolist(), "names": list(p.names)} for p in self.pieces],
        }

    @classmethod
    def from_dict(cls, data: Mapping[str, Any]) -> "PolytopeUnion":
        """Inverse of :meth:`to_dict`; raises ``ModelError`` naming a missing or malformed field."""
        for key in ("dim", "pieces"):
            if key not in data:
                raise ModelError(f"union dict[{key!r}]", "present", "missing")
        pieces = []
        for i, item in enumerate(data["pieces"]):
            if not isinstance(item, Mapping) or "A" not in item or "b" not in item:
                raise ModelError(f"union dict['pieces'][{i}]", "a mapping with 'A' and 'b'", type(item).__name__)
            A = np.array(item["A"], dtype=float).reshape(len(item["b"]), int(data["dim"]))
            pieces.append(Polytope(A, item["b"], tuple(item.get("names", ()))))
        return cls(tuple(pieces), int(data["dim"]), tuple(data.get("names", ())))

    # ------------------------------------------------------------------ helpers
    def _index(self, coord: int | str) -> int:
        return resolve_coordinate(coord, self.names)


def _signed_area(V: np.ndarray) -> float:
    """Shoelace area, positive for counter-clockwise vertices."""
    x, y = V[:, 0], V[:, 1]
    return 0.5 * float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))

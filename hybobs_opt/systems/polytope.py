"""A small H-polytope type ``{z : A z <= b}`` with coordinate names.

Used for guards, invariants and state/input bounds.  The ``regions`` package builds the heavy
geometry (projection, redundancy removal, unions) on top of this type.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelError
from ..lp import solve_lp
from ..tolerances import FULL_DIMENSION_RTOL, MEMBERSHIP_RTOL, ZERO_ROW_TOL
from ._validate import as_matrix, as_names, as_vector


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
        d = self.dim
        lo = np.empty(d)
        hi = np.empty(d)
        for i in range(d):
            for sign, out in ((1.0, lo), (-1.0, hi)):
                c = np.zeros(d)
                c[i] = sign
                res = solve_lp(c, self.A, self.b, problem=f"bounding box of {self.names[i]}")
                if res.status == "infeasible":
                    raise ModelError("polytope", "a non-empty set", "an empty set")
                if res.status == "unbounded":
                    raise ModelError(f"bounds of {self.names[i]}", "a bounded set", "unbounded in this coordinate")
                out[i] = sign * res.objective
        return lo, hi

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

    def __repr__(self) -> str:
        return f"Polytope(dim={self.dim}, n_constraints={self.n_constraints}, names={self.names})"

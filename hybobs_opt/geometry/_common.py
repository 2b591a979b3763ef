"""Helpers shared by the polytope modules: coordinate names, LP wrapper, bounding boxes, scalings.

Not public: :mod:`hybobs_opt.geometry.polytope`, :mod:`~hybobs_opt.geometry.redundancy` and
:mod:`~hybobs_opt.geometry.projection` all work in coordinates scaled by the bounding box
(DESIGN.md: tolerances are relative), which these functions compute.
"""

from __future__ import annotations

import numbers
from collections.abc import Sequence

import numpy as np

from .._validate import as_vector
from ..errors import ModelError
from ..tolerances import (
    EQUALITY_CONSISTENCY_RTOL,
    FULL_DIMENSION_RTOL,
    RANK_RTOL,
    ZERO_ROW_TOL,
)
from .lp import row_range, solve_lp

_METHODS = ("auto", "hull", "fm", "vertices")


def resolve_coordinate(coord: int | str, names: tuple[str, ...]) -> int:
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
    norms = np.sqrt(np.add.reduce(A * A, axis=1))  # np.linalg.norm(A, axis=1)'s arithmetic, without its wrapper
    keep = norms > ZERO_ROW_TOL
    if keep.all():
        return A / norms[:, None], b / norms
    return A[keep] / norms[keep, None], b[keep] / norms[keep]


def _row_normalised(A: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every row of ``[A | b]`` divided by ``||A_i||`` (exactly-zero rows kept as they are).

    The same set, with the units of each row removed: the absolute thresholds applied afterwards
    (ZERO_ROW_TOL, the scaled-coordinate tolerances) then judge the geometry, not the scale in which
    a row happened to be written (rows given in units of 1e-10 are not zero rows).
    """
    A = np.asarray(A, dtype=float)
    b = np.asarray(b, dtype=float)
    if A.shape[0] == 0:
        return A, b
    norms = np.sqrt(np.add.reduce(A * A, axis=1))  # np.linalg.norm(A, axis=1)'s arithmetic, without its wrapper
    pos = norms > 0.0
    inv = 1.0 / norms if pos.all() else np.where(pos, 1.0 / np.where(pos, norms, 1.0), 1.0)
    return A * inv[:, None], b * inv


def _box(A: np.ndarray, b: np.ndarray, E: np.ndarray | None = None, e: np.ndarray | None = None):
    """Bounding box ``(lo, hi)`` with ``+-inf`` where unbounded, or ``None`` when empty (2d LPs)."""
    r = row_range(A, b, np.eye(A.shape[1]), E=E, e=e, problem="bounding box", allow_unbounded=True, allow_empty=True)
    return None if r is None else (r[:, 0].copy(), r[:, 1].copy())


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


_resolve = resolve_coordinate  # old private name

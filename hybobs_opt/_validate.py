"""Shape and finiteness checks shared by every model dataclass.

Each function converts its input to a float numpy array, checks it, and raises a
:class:`~hybobs_opt.errors.ModelError` that names the field and the expected shape.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from .errors import ModelError


def _describe(arr: np.ndarray) -> str:
    return f"shape {arr.shape}"


def as_matrix(value, field: str, shape: tuple[int | None, int | None]) -> np.ndarray:
    """Return ``value`` as a finite, read-only float matrix of ``shape`` (``None`` = any size)."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(field, "a numeric matrix", f"{type(value).__name__} ({exc})") from None
    if arr.ndim == 1 and shape[1] == 1:
        arr = arr.reshape(-1, 1)
    if arr.ndim != 2:
        raise ModelError(field, f"a 2-D matrix of shape {_fmt(shape)}", f"{arr.ndim}-D array")
    for axis, want in enumerate(shape):
        if want is not None and arr.shape[axis] != want:
            raise ModelError(field, f"shape {_fmt(shape)}", _describe(arr))
    check_finite(arr, field)
    arr.setflags(write=False)
    return arr


def as_vector(value, field: str, size: int | None) -> np.ndarray:
    """Return ``value`` as a finite, read-only 1-D float vector of length ``size``."""
    try:
        arr = np.array(value, dtype=float)
    except (TypeError, ValueError) as exc:
        raise ModelError(field, "a numeric vector", f"{type(value).__name__} ({exc})") from None
    if arr.ndim == 0:
        arr = arr.reshape(1)
    if arr.ndim == 2 and 1 in arr.shape:
        arr = arr.reshape(-1)
    if arr.ndim != 1:
        raise ModelError(field, f"a vector of length {size}", _describe(arr))
    if size is not None and arr.shape[0] != size:
        raise ModelError(field, f"a vector of length {size}", f"length {arr.shape[0]}")
    check_finite(arr, field)
    arr.setflags(write=False)
    return arr


def check_finite(arr: np.ndarray, field: str) -> None:
    """Raise ``ModelError`` if ``arr`` holds NaN or Inf."""
    if not np.all(np.isfinite(arr)):
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ModelError(field, "finite entries", f"{arr[tuple(bad)]} at index {tuple(int(i) for i in bad)}")


def as_names(value: Sequence[str] | None, field: str, size: int, default_prefix: str) -> tuple[str, ...]:
    """Return a tuple of ``size`` distinct identifier-like names (``x1, x2, ...`` by default)."""
    if value is None or len(value) == 0:
        return tuple(f"{default_prefix}{i + 1}" for i in range(size))
    names = tuple(str(v) for v in value)
    if len(names) != size:
        raise ModelError(field, f"{size} names", f"{len(names)} names {names}")
    if len(set(names)) != len(names):
        raise ModelError(field, "distinct names", f"{names}")
    return names


def _fmt(shape: tuple[int | None, int | None]) -> str:
    return "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"

"""Type, shape and finiteness checks shared by every model dataclass.

Each function checks its input *before* it is used and raises a
:class:`~hybobs_opt.errors.ModelError` that names the field and what was expected.  Nothing is
coerced silently: complex entries are refused (``float()`` would drop the imaginary
part), and so are booleans, strings and ``None`` where numbers are expected; names must be
non-empty strings, distinct, and given as a list (a plain string is not split into characters);
an integer is an ``int``, not ``2.0``, ``"2"`` or ``True``.
"""

from __future__ import annotations

import functools
import math
import numbers
import unicodedata
from collections.abc import Callable, Iterable, Mapping, Sequence

import numpy as np

from .errors import ModelError


def _describe(arr: np.ndarray) -> str:
    return f"shape {arr.shape}"


def _short(value, limit: int = 60) -> str:
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def real_array(value, field: str, what: str = "numbers") -> np.ndarray:
    """``value`` as a new float array, refusing what a float conversion would change or invent.

    Refused: ``None``, strings and bytes (``np.array("1", dtype=float)`` reads them), complex
    entries (the imaginary part would be dropped), booleans, ragged nested lists and entries
    that are not real numbers (``None`` inside a list, objects).  Finiteness is not checked here.
    """
    if value is None or isinstance(value, (str, bytes)):
        raise ModelError(field, what, _short(value))
    try:
        arr = np.asarray(value)
    except (TypeError, ValueError) as exc:  # ragged nested lists, objects numpy cannot read
        raise ModelError(field, what, f"{type(value).__name__} ({exc})") from None
    kind = arr.dtype.kind
    if kind == "c":
        raise ModelError(field, f"{what} with real entries", f"complex entries (dtype {arr.dtype}; the imaginary part "
                         "would be dropped)")
    if kind == "b":
        raise ModelError(field, what, f"booleans ({_short(arr.tolist())})")
    if kind == "O":
        for v in arr.flat:
            if isinstance(v, (bool, np.bool_)) or not isinstance(v, numbers.Real):
                raise ModelError(field, what, f"an entry {_short(v)} of type {type(v).__name__}")
    elif kind not in "iuf":
        raise ModelError(field, what, f"entries of dtype {arr.dtype} ({_short(value)})")
    try:
        return np.array(arr, dtype=float)
    except (TypeError, ValueError, OverflowError) as exc:
        raise ModelError(field, what, f"{type(value).__name__} ({exc})") from None


def as_matrix(value, field: str, shape: tuple[int | None, int | None]) -> np.ndarray:
    """Return ``value`` as a finite, read-only float matrix of ``shape`` (``None`` = any size)."""
    arr = real_array(value, field, f"a numeric matrix of shape {_fmt(shape)}")
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
    arr = real_array(value, field, "a numeric vector" + ("" if size is None else f" of length {size}"))
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
    if not np.isfinite(arr).all():  # (the method: np.all's wrapper cost ~5 us per call, cold)
        bad = np.argwhere(~np.isfinite(arr))[0]
        raise ModelError(field, "finite entries", f"{arr[tuple(bad)]} at index {tuple(int(i) for i in bad)}")


def as_real(value, field: str, what: str = "a real number") -> float:
    """A real scalar (``int``, ``float``, numpy real): not a bool, string, complex or ``None``; may be inf/NaN."""
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ModelError(field, what, f"{_short(value)} of type {type(value).__name__}")
    return float(value)


def as_int(value, field: str, minimum: int | None = None, what: str | None = None) -> int:
    """An integer (``int`` or numpy integer; not a bool, ``2.0`` or ``"2"``), at least ``minimum``."""
    what = what or ("an integer" if minimum is None else f"an integer >= {minimum}")
    if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
        raise ModelError(field, what, f"{_short(value)} of type {type(value).__name__}")
    if minimum is not None and int(value) < minimum:
        raise ModelError(field, what, repr(int(value)))
    return int(value)


def as_positive(value, field: str, what: str = "a positive finite number", allow_none: bool = False) -> float | None:
    """A positive finite real scalar as a ``float`` (``None`` passes if ``allow_none``).

    Parameters
    ----------
    value
        The argument: an ``int``, ``float`` or numpy integer/floating scalar.
    field : str
        Name of the argument, for the message.
    what : str
        What was expected, for the message (e.g. ``"a positive sampling period"``).
    allow_none : bool
        Let ``None`` through (returned as ``None``).

    Returns
    -------
    float or None

    Raises
    ------
    ModelError
        ``value`` is a bool, a string, a complex number, an array or list (even of one entry),
        ``None`` (unless ``allow_none``) or any other non-real object, or is NaN, infinite, zero
        or negative.  Nothing is converted first: ``float(0.1 + 0j)`` or ``np.array([0.1])`` is
        not taken for ``0.1``.
    """
    if value is None and allow_none:
        return None
    if value is None or isinstance(value, (bool, np.bool_)) or not isinstance(value, numbers.Real):
        raise ModelError(field, what + (" or None" if allow_none else ""), f"{_short(value)} of type {type(value).__name__}")
    out = float(value)
    if not (math.isfinite(out) and out > 0):
        raise ModelError(field, what + (" or None" if allow_none else ""), repr(value))
    return out


def as_flag(value, field: str) -> bool:
    """A boolean switch as a ``bool``: ``True``, ``False`` or a numpy bool, nothing else.

    Parameters
    ----------
    value
        The argument.
    field : str
        Name of the argument, for the message.

    Returns
    -------
    bool

    Raises
    ------
    ModelError
        ``value`` is not a ``bool``/``numpy.bool_``: ``"no"``, ``0``, ``1``, ``None`` and arrays are
        refused (``bool("no")`` is ``True``).
    """
    if not isinstance(value, (bool, np.bool_)):
        raise ModelError(field, "True or False", f"{_short(value)} of type {type(value).__name__}")
    return bool(value)


def as_instance(value, field: str, cls: type | tuple[type, ...], what: str | None = None):
    """``value`` itself if it is an instance of ``cls``, else :class:`ModelError` naming the class.

    Parameters
    ----------
    value
        The argument (a design object, an analysis, a system).
    field : str
        Name of the argument, for the message.
    cls : type or tuple of types
        The class(es) expected; import them lazily in the caller where a module-level import
        would be circular.
    what : str, optional
        What was expected, for the message (default: ``"an instance of <class name>"``).

    Returns
    -------
    object
        ``value``, unchanged.

    Raises
    ------
    ModelError
        ``value`` is not an instance of ``cls``.
    """
    if not isinstance(value, cls):
        names = " or ".join(c.__name__ for c in (cls if isinstance(cls, tuple) else (cls,)))
        raise ModelError(field, what or f"an instance of {names}", f"{_short(value)} of type {type(value).__name__}")
    return value


def as_text(value, field: str, allow_empty: bool = False) -> str:
    """A string (non-empty unless ``allow_empty``; whitespace alone counts as empty)."""
    if not isinstance(value, str):
        raise ModelError(field, "a string" if allow_empty else "a non-empty string",
                         f"{_short(value)} of type {type(value).__name__}")
    if not allow_empty and not value.strip():
        raise ModelError(field, "a non-empty string", repr(value))
    return str(value)


def names_or_default(value, field: str, defaults: tuple[str, ...]) -> tuple[str, ...]:
    """``len(defaults)`` distinct non-empty names from a list or tuple, or ``defaults`` for ``None``/empty.

    A plain string is refused (it is not split into characters), and so is any entry that is
    not a string (``None``, ints: they are not turned into ``"None"``, ``"1"``).
    """
    size = len(defaults)
    if value is None:
        return defaults
    if isinstance(value, (str, bytes)):
        raise ModelError(field, f"a list of {size} names", f"the single string {_short(value)} (write [{_short(value)}])")
    if isinstance(value, np.ndarray) and value.ndim == 1:
        value = value.tolist()
    if not isinstance(value, Sequence):
        raise ModelError(field, f"a list or tuple of {size} names", f"{_short(value)} of type {type(value).__name__}")
    if len(value) == 0:
        return defaults
    names = tuple(as_text(v, f"{field}[{i}]") for i, v in enumerate(value))
    if len(names) != size:
        raise ModelError(field, f"{size} names", f"{len(names)} names {names}")
    if len(set(names)) != len(names):
        dup = next(nm for nm in names if names.count(nm) > 1)
        raise ModelError(field, "distinct names", f"{names} ({dup!r} twice)")
    keys = [name_key(nm) for nm in names]
    if len(set(keys)) != len(keys):
        a, b = next((x, y) for i, x in enumerate(names) for y in names[i + 1:] if name_key(x) == name_key(y))
        raise ModelError(field, "distinct names (compared after NFKC normalisation, as Python reads identifiers "
                         "and a model file stores them)", f"{a!r} and {b!r}")
    return names


def name_key(name: str) -> str:
    """``name`` normalised to NFKC: two names with the same key are one identifier in an
    expression and in a model file (``x`` and ``𝐱``)."""
    return unicodedata.normalize("NFKC", name)


def as_names(value: Sequence[str] | None, field: str, size: int, default_prefix: str) -> tuple[str, ...]:
    """Return a tuple of ``size`` distinct non-empty names (``x1, x2, ...`` by default)."""
    if value is None or (type(value) is tuple and not value):  # the defaults (every Polytope(A, b) asks)
        return _default_names(default_prefix, size)
    return names_or_default(value, field, _default_names(default_prefix, size))


@functools.lru_cache(maxsize=256)
def _default_names(prefix: str, size: int) -> tuple[str, ...]:
    """``(prefix1, ..., prefix<size>)``, built once per prefix and size (an immutable tuple)."""
    return tuple(f"{prefix}{i + 1}" for i in range(size))


def as_items(value, field: str, cls: type | tuple[type, ...], what: str) -> tuple:
    """``value`` (a list, tuple or other iterable) as a tuple whose every item is a ``cls``."""
    single = cls if isinstance(cls, tuple) else (cls,)
    if isinstance(value, single) and not isinstance(value, (list, tuple)):
        raise ModelError(field, f"a sequence of {what}", f"a single {type(value).__name__} (wrap it in a tuple)")
    if isinstance(value, (str, bytes, Mapping)) or not isinstance(value, Iterable):
        raise ModelError(field, f"a sequence (list or tuple) of {what}", f"{_short(value)} of type {type(value).__name__}")
    items = tuple(value)
    for i, item in enumerate(items):
        if not isinstance(item, single):
            raise ModelError(f"{field}[{i}]", what, f"{_short(item)} of type {type(item).__name__}")
    return items


def probe_callable(fn: Callable, args: tuple, field: str, size: int | None, what: str, at: str,
                   flat: bool = False) -> np.ndarray:
    """Call ``fn(*args)`` once and check it returns ``size`` finite real numbers.

    ``what`` describes the callable (``"flow(x, u) -> dx"``), ``at`` the probe point (for the
    message).  A callable that raises, returns ``None``, complex numbers, another length or
    NaN/Inf there is refused at construction instead of failing in the first simulation step.
    ``flat`` requires the shape ``(size,)`` itself (not ``(size, 1)``), for callers that stack
    the values without reshaping them.
    """
    try:
        out = fn(*args)
    except Exception as exc:
        raise ModelError(field, f"a callable {what} that can be evaluated at {at}", f"{type(exc).__name__}: {exc}") from None
    try:
        vec = as_vector(out, field, size)
    except ModelError as exc:
        raise ModelError(field, f"{what} returning {exc.expected} (evaluated at {at})", exc.got) from None
    if flat and np.shape(out) != vec.shape:
        raise ModelError(field, f"{what} returning a flat vector of shape {vec.shape} (evaluated at {at})",
                         f"shape {np.shape(out)}")
    return vec


def _fmt(shape: tuple[int | None, int | None]) -> str:
    return "(" + ", ".join("any" if s is None else str(s) for s in shape) + ")"

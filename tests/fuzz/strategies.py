"""Strategies of bad values shared by the fuzz families.

The constructor family draws from tables of garbage per kind of field (matrices, vectors, names,
text, polytopes, callables, integers, reals), each entry a value that no valid input can be; the
sample family draws sample faults; the file family byte- and JSON-level corruptions.  Strategies
draw indices and labels only (no built object), so they can be defined at import time, and the
object a label stands for is built when the input is tried.
"""

from __future__ import annotations

import math

import numpy as np
from hypothesis import strategies as st

# ---------------------------------------------------------------------------------- garbage tables


def _raise(*_):
    raise RuntimeError("boom")


def _const(value):
    return lambda *args: value


def real_garbage(positive: bool = True) -> list[tuple[str, object]]:
    """Values that are not a (positive) finite real number."""
    out = [("nan", math.nan), ("inf", math.inf), ("-inf", -math.inf), ("str", "0.1"), ("bytes", b"1"),
           ("complex", 0.1 + 0.1j), ("complex-zero-imag", complex(0.1, 0.0)), ("bool", True), ("list", [0.1]),
           ("array2", np.array([0.1, 0.2])), ("dict", {"v": 0.1}), ("object", object())]
    if positive:
        out += [("zero", 0.0), ("negative", -0.1)]
    return out


def int_garbage(low: int = 0, high: int | None = None) -> list[tuple[str, object]]:
    """Values that are not an integer in ``[low, high]``."""
    out = [("float", 1.5), ("float-integral", 1.0), ("str", "1"), ("bool", True), ("complex", 1j), ("list", [1]),
           ("nan", math.nan), ("below", low - 1), ("none-object", object())]
    if high is not None:
        out.append(("above", high + 1))
    return out


def array_garbage(value: np.ndarray) -> list[tuple[str, object]]:
    """Values that are not ``value``'s shape of finite reals (``value`` a valid numeric array)."""
    a = np.asarray(value, dtype=float)
    out = [("str", "1.0"), ("bytes", b"1"), ("dict", {"A": 1.0}), ("object", object()), ("3d", np.ones((2, 2, 2)))]
    if a.size:
        def at0(v, dtype=float):
            b = a.astype(dtype).copy()
            b.reshape(-1)[0] = v
            return b

        out += [("nan-entry", at0(np.nan)), ("inf-entry", at0(np.inf)), ("-inf-entry", at0(-np.inf)),
                ("complex-entry", at0(1 + 1j, complex)), ("complex-dtype", a.astype(complex)),
                ("bool-dtype", a.astype(bool)), ("str-entries", a.astype(str).tolist()),
                ("none-entry", np.where(np.ones(a.shape, bool), None, None).tolist() if a.ndim else None),
                ("empty", np.zeros((0, 0))), ("empty-list", [])]
    if a.ndim == 2:
        out += [("extra-column", np.hstack([a, np.ones((a.shape[0], 1))])),
                ("ragged", [[1.0] * (a.shape[1] + 1)] + [[1.0] * a.shape[1]] * max(a.shape[0] - 1, 1))]
        if a.shape[1] >= 1 and a.size:
            out.append(("one-column-less", a[:, :-1]))
    if a.ndim == 1:
        out += [("long", np.append(a, 1.0)), ("2d", np.ones((2, a.size + 1))), ("ragged", [[1.0], [1.0, 2.0]])]
        if a.size >= 1:
            out.append(("short", a[:-1]))
    return out


def names_garbage(size: int) -> list[tuple[str, object]]:
    """Values that are not ``size`` distinct non-empty names."""
    good = [f"n{i}" for i in range(size)]
    out = [("int", 3), ("float", 1.5), ("none-entry", [None] + good[1:]), ("int-entries", list(range(size))),
           ("empty-string", [""] + good[1:]), ("blank", ["   "] + good[1:]), ("bytes-entries", [g.encode() for g in good]),
           ("plain-string", "".join(good) if size != 1 else "ab"), ("too-many", good + ["extra"]), ("nested", [[g] for g in good]),
           ("bool", True)]
    if size > 1:
        out += [("duplicates", [good[0]] * size), ("too-few", good[:-1])]
    return out


def text_garbage() -> list[tuple[str, object]]:
    """Values that are not text."""
    return [("int", 5), ("float", 1.5), ("bytes", b"x"), ("list", ["a"]), ("bool", True)]


def callable_garbage(size: int) -> list[tuple[str, object]]:
    """Values that are not a callable returning ``size`` finite reals."""
    return [("int", 5), ("str", "x[0]"), ("long", _const(np.zeros(size + 1))), ("short", _const(np.zeros(max(size - 1, 0)))),
            ("nan", _const(np.full(size, np.nan))), ("inf", _const(np.full(size, np.inf))), ("None", _const(None)),
            ("raises", _raise), ("complex", _const(np.ones(size) * 1j)), ("str-result", _const("0")),
            ("wrong-arity", lambda x: np.zeros(size))]


JUNK = [("int", 5), ("str", "junk"), ("bytes", b"x"), ("object", object()), ("complex", 1.5j), ("list-of-str", ["a", "b"])]

# ---------------------------------------------------------------------------------- sample faults

#: Output faults: the label and ``(y, y_max) -> bad y`` (``y`` the clean sample, ``y_max`` the
#: largest |y| of the run per output).
Y_FAULTS = ("nan", "+inf", "-inf", "+1e300", "-1e300", "+1e12", "-1e12", "10x", "long", "short", "str", "None", "complex",
            "empty", "nested")
#: Input faults (systems with inputs).
U_FAULTS = ("nan", "+inf", "+1e300", "-1e300", "+1e12", "-1e12", "10x", "long", "short", "str", "None", "complex")
#: Time-stamp faults of the event-driven observers (``u = [t]``).
T_FAULTS = ("+1e300", "-1e9", "nan", "+inf", "+1e12", "back")
#: Output faults of an integer-valued output (the visible mode of paper 003).
INT_Y_FAULTS = ("half", "not-an-output")


def fault(kinds: tuple[str, ...]) -> st.SearchStrategy:
    """One fault: ``(where in the window in [0, 1), kind, output/input index draw)``."""
    return st.tuples(st.floats(0.0, 1.0, exclude_max=True, allow_nan=False), st.sampled_from(kinds), st.integers(0, 7))


def faults(kinds: tuple[str, ...], most: int = 3) -> st.SearchStrategy:
    """One to ``most`` faults, at drawn steps (possibly the same or neighbouring steps)."""
    return st.lists(fault(kinds), min_size=1, max_size=most)


def bad_vector(kind: str, v: np.ndarray, vmax: np.ndarray, j: int):
    """The bad sample ``kind`` made from the clean sample ``v`` (entry ``j`` for scalar faults)."""
    v = np.asarray(v, dtype=float).reshape(-1).copy()
    if kind == "long":
        return np.append(v, 0.0)
    if kind == "short":
        return v[:-1]
    if kind == "str":
        return "abc"
    if kind == "None":
        return None
    if kind == "empty":
        return np.zeros(0)
    if kind == "nested":
        return [v.tolist()]
    if kind == "complex":
        return v.astype(complex) + 1e-3j
    if not v.size:
        return v
    j = j % v.size
    value = {"nan": np.nan, "+inf": np.inf, "-inf": -np.inf, "+1e300": 1e300, "-1e300": -1e300, "+1e12": 1e12,
             "-1e12": -1e12, "10x": 10.0 * float(vmax[j]) + 1.0, "half": v[j] + 0.5, "not-an-output": 99.0}[kind]
    v[j] = value
    return v


# ---------------------------------------------------------------------------------- file corruptions

#: Byte-level corruptions of a saved file.
BYTE_FAULTS = ("truncate", "flip", "garbage", "empty", "nul", "latin1", "bom")
#: JSON-level edits (the file stays JSON).
JSON_FAULTS = ("number", "type", "missing", "extra-key", "null", "nan-number", "swap-list", "toplevel-list", "deep")


def byte_fault() -> st.SearchStrategy:
    return st.tuples(st.sampled_from(BYTE_FAULTS), st.floats(0.0, 1.0, exclude_max=True, allow_nan=False),
                     st.integers(1, 255), st.integers(1, 64))


def json_fault() -> st.SearchStrategy:
    return st.tuples(st.sampled_from(JSON_FAULTS), st.floats(0.0, 1.0, exclude_max=True, allow_nan=False),
                     st.sampled_from((-1.0, 1e-12, 1e-3, 0.5, 2.0, 1e300)), st.booleans())

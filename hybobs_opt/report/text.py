"""Values written as a reader reads them: the report's words for flags, numbers and matrices.

The report's text and tables show no Python spellings: a flag is "yes"/"no" (or a word of the
sentence), a missing value "n/a", a number has at most four significant digits, a matrix is a
small HTML table (``<table class='matrix'>``), a vector a parenthesised list.
"""

from __future__ import annotations

import html
import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from ..errors import ModelError

#: Significant digits of the numbers of the report.
DIGITS = 4


def yes_no(flag: Any) -> str:
    """``"yes"`` or ``"no"`` for a boolean (numpy's included); ``"n/a"`` for ``None``.

    Parameters
    ----------
    flag : bool, numpy.bool_ or None

    Returns
    -------
    str

    Examples
    --------
    >>> yes_no(True), yes_no(False), yes_no(None)
    ('yes', 'no', 'n/a')
    """
    if flag is None:
        return "n/a"
    if not isinstance(flag, (bool, np.bool_)):
        raise ModelError("flag", "a boolean or None", repr(flag))
    return "yes" if flag else "no"


def num(value: Any, digits: int = DIGITS, missing: str = "n/a") -> str:
    """A number with at most ``digits`` significant digits; ``missing`` for ``None`` or NaN.

    Integers are written in full; infinities as ``inf`` / ``-inf``; a boolean is refused (it is a
    flag: :func:`yes_no`).

    Parameters
    ----------
    value : int, float, numpy scalar or None
    digits : int, default 4
    missing : str, default "n/a"
        What a missing value reads as.

    Returns
    -------
    str

    Examples
    --------
    >>> num(3.14159265), num(1234567), num(2.5e-7), num(None), num(float("inf"))
    ('3.142', '1234567', '2.5e-07', 'n/a', 'inf')
    """
    if value is None:
        return missing
    if isinstance(value, (bool, np.bool_)):
        raise ModelError("value", "a number (a flag reads yes/no)", repr(value))
    if isinstance(value, (int, np.integer)):
        return str(int(value))
    if not isinstance(value, (float, np.floating)):
        raise ModelError("value", "a number or None", repr(value))
    v = float(value)
    if math.isnan(v):
        return missing
    if math.isinf(v):
        return "inf" if v > 0 else "-inf"
    return f"{v:.{digits}g}"


def _numbers(field: str, values: Any) -> np.ndarray:
    """``values`` as a float array; a :class:`~hybobs_opt.errors.ModelError` naming ``field`` if not numeric."""
    arr = np.asarray(values)
    if arr.dtype.kind not in "iuf":
        raise ModelError(field, "an array of numbers", f"dtype {arr.dtype}")
    return arr.astype(float)


def vector(values: Sequence[Any] | np.ndarray, digits: int = DIGITS) -> str:
    """A vector as ``(v1, v2, ...)`` with :func:`num`'s rounding.

    Examples
    --------
    >>> vector([1.0, 2.123456, -0.5])
    '(1, 2.123, -0.5)'
    """
    arr = _numbers("values", values).ravel()
    return "(" + ", ".join(num(v, digits) for v in arr) + ")"


def matrix_table(matrix: Sequence[Sequence[Any]] | np.ndarray, digits: int = DIGITS,
                 row_labels: Sequence[str] | None = None, col_labels: Sequence[str] | None = None) -> str:
    """A matrix as a small HTML table (``class='matrix'``), entries rounded by :func:`num`.

    Parameters
    ----------
    matrix : array_like, 1-D (one row) or 2-D
    digits : int, default 4
    row_labels, col_labels : sequence of str, optional
        Labels written before each row / above each column (escaped).

    Returns
    -------
    str

    Examples
    --------
    >>> matrix_table([[1.0, 0.5], [0.0, 2.0]])
    "<table class='matrix'><tr><td>1</td><td>0.5</td></tr><tr><td>0</td><td>2</td></tr></table>"
    """
    M = np.atleast_2d(_numbers("matrix", matrix))
    if M.ndim != 2:
        raise ModelError("matrix", "a 1-D or 2-D array", f"shape {M.shape}")
    if row_labels is not None and len(row_labels) != M.shape[0]:
        raise ModelError("row_labels", f"{M.shape[0]} labels", str(len(row_labels)))
    if col_labels is not None and len(col_labels) != M.shape[1]:
        raise ModelError("col_labels", f"{M.shape[1]} labels", str(len(col_labels)))
    head = ""
    if col_labels is not None:
        head = ("<tr>" + ("<td></td>" if row_labels is not None else "")
                + "".join(f"<td><i>{html.escape(c)}</i></td>" for c in col_labels) + "</tr>")
    rows = "".join(
        "<tr>" + (f"<td><i>{html.escape(row_labels[i])}</i></td>" if row_labels is not None else "")
        + "".join(f"<td>{num(v, digits)}</td>" for v in M[i]) + "</tr>"
        for i in range(M.shape[0]))
    return f"<table class='matrix'>{head}{rows}</table>"

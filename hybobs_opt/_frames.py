"""pandas DataFrames of per-sample arrays: one row per sample, one column per named signal.

The ``to_pandas`` methods of traces, logs and results build their frames here.  A name may be
given twice (an output that is also a state, as in a log) only with the same values: it becomes
one column, as :func:`~hybobs_opt.sim.log.read_log` reads a repeated column as one signal.
pandas is imported on use (the ``interop`` extra).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from ._optional import require
from .errors import ModelError


def frame(columns: Sequence[tuple[str, Any]], what: str):
    """A DataFrame with the given ``(name, values)`` columns, in order, a repeated name once.

    Parameters
    ----------
    columns : sequence of (str, array_like)
        Column name and its per-sample values (all of one length).
    what : str
        What is converted (for errors), e.g. ``"Trace"``.

    Returns
    -------
    pandas.DataFrame
        One row per sample, a default ``RangeIndex``.

    Raises
    ------
    ModelError
        A name given twice with different values, or pandas is not installed.
    """
    pd = require("pandas", f"convert a {what} to a pandas DataFrame")
    data: dict[str, np.ndarray] = {}
    for name, values in columns:
        values = np.asarray(values)
        if name in data:
            if not np.array_equal(data[name], values, equal_nan=values.dtype.kind == "f"):
                raise ModelError(f"{what} column {name!r}", "a name given twice (e.g. an output that is also a state) "
                                 "to hold the same values", "two different signals")
            continue
        data[name] = values
    return pd.DataFrame(data)

"""Time-varying inputs from a CSV file: a table of input values held between its rows.

The file has a header row and one row per input change:

* one column per input of the system, named as the system names its inputs (all of them, in any
  order; every cell a finite number);
* ``t`` (or ``time``): the time in seconds at which the row's values start.  Required for a
  continuous-time system (hybrid automaton, scalar-nonlinear system): the times start at 0 and
  increase strictly, and each row's values hold until the next row's time (zero-order hold; the
  last row's values until the end of the run).  Optional for a PWA system, which takes one row
  per sample; when given, the times must be ``0, Ts, 2 Ts, ...``.
"""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .._numbers import is_decimal
from ..errors import ModelError
from ..limits import MAX_SAMPLES
from ..tolerances import INPUT_TABLE_TIME_RTOL

#: Names of the time column.
TIME_COLUMNS = ("t", "time")


@dataclass(frozen=True, eq=False)
class InputTable:
    """Input values held between the rows of a table (zero-order hold).

    Parameters
    ----------
    names : tuple of str
        The inputs, in the system's order.
    U : (N, m) ndarray
        One row of input values per change.
    t : (N,) ndarray or None
        The time each row starts at (strictly increasing, from 0); ``None``: one row per sample of
        a discrete-time system.
    source : str
        Where the table came from (for messages).

    Examples
    --------
    >>> import numpy as np
    >>> table = InputTable(("u",), np.array([[0.0], [2.0]]), np.array([0.0, 0.1]))
    >>> float(table(0.05)[0]), float(table(0.1)[0]), float(table(5.0)[0])
    (0.0, 2.0, 2.0)

    See Also
    --------
    read_input_table : reads one from a CSV file.
    hybobs_opt.sim.any_system.simulate_system : runs a system on it (``inputs=``).
    """

    names: tuple[str, ...]
    U: np.ndarray
    t: np.ndarray | None
    source: str = "inputs"

    @property
    def n_rows(self) -> int:
        """The number of rows."""
        return int(self.U.shape[0])

    @property
    def breakpoints(self) -> tuple[float, ...]:
        """The times where the input changes (every row's time after the first)."""
        return () if self.t is None else tuple(float(v) for v in self.t[1:])

    def __call__(self, t: float) -> np.ndarray:
        """The input at time ``t``: the row of the last time not after ``t`` (the first row before it)."""
        if self.t is None:
            raise ModelError(self.source, "a time column t for a continuous-time run", "no time column")
        k = int(np.searchsorted(self.t, t, side="right")) - 1
        return self.U[min(max(k, 0), self.n_rows - 1)].copy()


def read_input_table(path: str | Path, system) -> InputTable:
    """Read the inputs of ``system`` from the CSV file ``path`` (the format of the module docstring).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    system : object
        Anything with ``input_names`` (a system class of :mod:`hybobs_opt.systems`).

    Returns
    -------
    InputTable
        The table; its times are checked against the system's class by
        :func:`~hybobs_opt.sim.any_system.simulate_system`.

    Raises
    ------
    ModelError
        The file is unreadable or empty, a column is missing, unknown or repeated, a row has too few
        or too many cells, a cell is not a finite number, the times do not start at 0 or do not
        increase, or there are more than :data:`~hybobs_opt.limits.MAX_SAMPLES` rows; the message
        names the file, the line and the column.

    See Also
    --------
    InputTable : what it returns.
    hybobs_opt.sim.any_system.simulate_system : runs a system on the table (``inputs=``).
    hybobs_opt.read_log : reads a whole log (inputs and outputs) instead.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt import get_example
    >>> plant = get_example("powertrain3").build()                 # one input, T_m
    >>> path = Path(tempfile.mkdtemp()) / "torque.csv"
    >>> _ = path.write_text("t,T_m\\n0,40\\n0.01,-20\\n")
    >>> table = read_input_table(path, plant)
    >>> table.n_rows, table.U[:, 0].tolist(), table.t.tolist()
    (2, [40.0, -20.0], [0.0, 0.01])
    """
    path = Path(path)
    names = tuple(getattr(system, "input_names", ()))
    if not names:
        raise ModelError(str(path), "no input table (the system has no inputs)", "a file")
    try:
        with path.open(newline="", encoding="utf-8-sig") as fh:
            rows = [(k, row) for k, row in enumerate(csv.reader(fh), start=1) if any(cell.strip() for cell in row)]
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ModelError(str(path), "a readable CSV file of inputs", f"{type(exc).__name__}: {exc}") from None
    if not rows:
        raise ModelError(str(path), f"a header row naming the inputs {list(names)} (and optionally t), then one row "
                         "per input change", "an empty file")
    header = [h.strip() for h in rows[0][1]]
    repeated = sorted({h for h in header if header.count(h) > 1})
    if repeated:
        raise ModelError(f"{path} header", "each column once", f"{repeated} repeated")
    times = [h for h in header if h in TIME_COLUMNS]
    if len(times) > 1:
        raise ModelError(f"{path} header", "one time column (t or time)", f"{times}")
    unknown = [h for h in header if h not in names and h not in TIME_COLUMNS]
    if unknown:
        raise ModelError(f"{path} header", f"the input columns {list(names)} and an optional time column t",
                         f"unknown {unknown}")
    missing = [nm for nm in names if nm not in header]
    if missing:
        raise ModelError(f"{path} header", f"every input column {list(names)}", f"missing {missing}")
    data = rows[1:]
    if not data:
        raise ModelError(str(path), "at least one row of inputs after the header", "none")
    if len(data) > MAX_SAMPLES:
        raise ModelError(str(path), f"at most {MAX_SAMPLES:,} rows (hybobs_opt.limits.MAX_SAMPLES)", f"{len(data):,} rows")
    values = np.empty((len(data), len(header)))
    for r, (line, row) in enumerate(data):
        if len(row) != len(header):
            raise ModelError(f"{path} line {line}", f"{len(header)} cells (one per column of the header)",
                             f"{len(row)} cells")
        for c, cell in enumerate(row):
            text = cell.strip(" \t")
            value = float(text) if is_decimal(text) else math.nan  # the number grammar of every file read
            if not math.isfinite(value):
                raise ModelError(f"{path} line {line} column {header[c]!r}",
                                 "a finite number in ASCII decimal digits (such as -1.5e-3)", repr(cell.strip()))
            values[r, c] = value
    U = values[:, [header.index(nm) for nm in names]]
    t = None
    if times:
        t = values[:, header.index(times[0])]
        if t[0] != 0:
            raise ModelError(f"{path} line {data[0][0]} column {times[0]!r}", "times starting at 0", repr(float(t[0])))
        steps = np.diff(t)
        if np.any(steps <= 0):
            i = int(np.argmax(steps <= 0)) + 1
            raise ModelError(f"{path} line {data[i][0]} column {times[0]!r}", "strictly increasing times",
                             f"{float(t[i])!r} after {float(t[i - 1])!r}")
    return InputTable(names, U, t, str(path))


def check_sample_times(table: InputTable, Ts: float | None) -> None:
    """``ModelError`` unless the table's times (if any) are ``0, Ts, 2 Ts, ...`` (a PWA run: one row per sample)."""
    if table.t is None:
        return
    if Ts is None:
        raise ModelError(f"{table.source} column 't'", "no time column for a PWA system without a sampling period Ts "
                         "(one row per sample)", "a time column")
    expected = Ts * np.arange(table.n_rows)
    bad = np.flatnonzero(~np.isclose(table.t, expected, rtol=INPUT_TABLE_TIME_RTOL, atol=INPUT_TABLE_TIME_RTOL * 1e-3 * Ts))
    if bad.size:
        k = int(bad[0])
        raise ModelError(f"{table.source} row {k + 1} column 't'", f"the time of sample {k}, {k} x Ts = {expected[k]:g} s "
                         "(a PWA system takes one row per sample)", repr(float(table.t[k])))

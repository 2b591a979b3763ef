"""Recorded data: a CSV log of a plant's inputs and outputs, read against the plant's names.

A log is a CSV file with a header row.  Its columns are named by the system: every input name and
every output name must be there; a time column (``t`` or ``time``) is optional; the state names
are optional too (all of them or none): a simulated or instrumented log that holds the true state
lets the observers' estimates be checked, and so is a column of the true mode (``q`` or ``mode``).
The CSV that ``hybobs simulate --out`` writes is a log.  A column may appear twice only with the
same values (a trace's output that is also a state).  Any other column, a missing one, a
non-numeric cell or a NaN/Inf is a :class:`~hybobs_opt.errors.ModelError` naming the file, the
line and the column:
a log is input data and is checked before any observer sees it (the observers themselves never
raise on a bad sample; a file is not a sample).

:func:`write_estimates` writes an observer's run in the same style (one row per sample: time,
estimate per state, mode, flag), numbers with 17 significant digits so that reading the file back
gives the same doubles.
"""

from __future__ import annotations

import csv
import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .._numbers import parse_decimal
from ..errors import ModelError
from .._output_files import open_output

#: Accepted names of the optional time column.
TIME_COLUMNS = ("t", "time")
#: Accepted names of the optional column of the true mode (``hybobs simulate --out`` writes ``q``).
MODE_COLUMNS = ("q", "mode")


@dataclass(frozen=True, eq=False)
class SignalLog:
    """The samples of a log, as arrays in the system's order.

    Parameters
    ----------
    path : str
    U : (N, m) array
        Inputs, columns in the order of ``system.input_names``.
    Y : (N, p) array
        Outputs, in the order of ``system.output_names``.
    t : (N,) array or None
        The time column when the log has one.
    X : (N, n) array or None
        The true states when the log has the state columns.
    Q : (N,) int array or None
        The true mode when the log has a ``q`` or ``mode`` column.

    See Also
    --------
    read_log : reads one from a CSV file.
    hybobs_opt.observe_log : runs observers on one.

    Examples
    --------
    A log read from CSV holds the inputs, outputs, times and (when the file has them) the true
    states and modes as arrays:

    >>> import numpy as np, tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt import get_example, read_log, simulate_pwa
    >>> plant = get_example("powertrain3").build()
    >>> trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((50, 1), 40.0))
    >>> folder = Path(tempfile.mkdtemp())
    >>> trace.to_csv(folder / "log.csv")         # columns t, states, q, inputs, outputs

    >>> log = read_log(folder / "log.csv", plant)
    >>> log.n_samples, log.U.shape, log.Y.shape, log.X.shape
    (50, (50, 1), (50, 1), (50, 3))
    >>> log.t[:3]
    array([0.   , 0.001, 0.002])
    """

    path: str
    U: np.ndarray
    Y: np.ndarray
    t: np.ndarray | None
    X: np.ndarray | None
    Q: np.ndarray | None = None

    @property
    def n_samples(self) -> int:
        return self.U.shape[0]

    def to_pandas(self, system) -> Any:
        """The log as a pandas DataFrame that :func:`read_log` reads back to the same arrays.

        Parameters
        ----------
        system : object
            The system the log was read for (its ``input_names``, ``output_names`` and
            ``state_names`` name the columns).

        Returns
        -------
        pandas.DataFrame
            Columns, in order: ``t`` (when the log has times), the inputs, the outputs, the
            states (when the log has them; a state that is also an output is one column) and
            ``q`` (when the log has the true mode); a default ``RangeIndex``.

        Raises
        ------
        ModelError
            The system's names do not fit the arrays, or pandas is not installed (the
            ``interop`` extra).

        See Also
        --------
        read_log : The way back.

        Examples
        --------
        >>> import numpy as np
        >>> from types import SimpleNamespace
        >>> from hybobs_opt.sim.log import SignalLog
        >>> system = SimpleNamespace(input_names=("u",), output_names=("y",), state_names=("x",))
        >>> log = SignalLog("mem", np.array([[1.0], [0.0]]), np.array([[0.5], [0.25]]), np.array([0.0, 0.1]), None)
        >>> log.to_pandas(system).to_dict("list")
        {'t': [0.0, 0.1], 'u': [1.0, 0.0], 'y': [0.5, 0.25]}
        """
        from .._frames import frame

        names = {"input_names": (tuple(system.input_names), self.U), "output_names": (tuple(system.output_names), self.Y)}
        if self.X is not None:
            names["state_names"] = (tuple(system.state_names), self.X)
        for key, (nm, arr) in names.items():
            if len(nm) != arr.shape[1]:
                raise ModelError(f"system.{key}", f"{arr.shape[1]} names (the log's columns)", f"{len(nm)}")
        columns = [] if self.t is None else [("t", self.t)]
        for nm, arr in names.values():
            columns += list(zip(nm, arr.T))
        if self.Q is not None:
            columns.append(("q", self.Q))
        return frame(columns, "SignalLog")


def read_log(path: str | Path | Any, system) -> SignalLog:
    """Read a log of ``system`` (anything with ``input_names``, ``output_names``, ``state_names``): a CSV file or a pandas DataFrame.

    A DataFrame is judged exactly like the file: its column names are the header (the same
    required, optional and refused columns), every cell must be a finite number in a numeric
    column (a text, boolean or date column is refused, not converted), and errors name the row
    by its position (``DataFrame row 0`` is the first).  Its index is not read: a named index
    (``df.set_index("t")``) is refused so that a time column is not dropped unseen; use
    ``df.reset_index()``.

    Parameters
    ----------
    path : str, Path or pandas.DataFrame
        The CSV file, or a DataFrame with one column per signal and one row per sample.
    system : object
        Any object with ``input_names``, ``output_names`` and ``state_names`` (a system class of
        :mod:`hybobs_opt.systems`).

    Returns
    -------
    SignalLog
        The columns as arrays in the system's order (``path`` is ``"DataFrame"`` for a DataFrame).

    Raises
    ------
    ModelError
        The file is unreadable or empty, a column is missing, unknown or repeated, or a cell is
        not a finite number; the message names the file (or ``DataFrame``), the line (row) and
        the column.

    See Also
    --------
    SignalLog : what it returns.
    write_estimates : the observers' estimates back to CSV.
    hybobs_opt.observe_log : the observers on the log.
    hybobs_opt.sim.trace.Trace.to_pandas : a simulated trace as a DataFrame this function reads.
    SignalLog.to_pandas : the way back.

    Examples
    --------
    >>> import numpy as np, tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt import get_example, read_log, simulate_pwa
    >>> plant = get_example("powertrain3").build()
    >>> trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((50, 1), 40.0))
    >>> folder = Path(tempfile.mkdtemp())
    >>> trace.to_csv(folder / "log.csv")         # columns t, states, q, inputs, outputs

    >>> (folder / "log.csv").read_text().splitlines()[0]
    't,theta,omega_m,omega_l,q,T_m,omega_m'
    >>> log = read_log(folder / "log.csv", plant)
    >>> log.U[:2, 0], log.Y[:2, 0]
    (array([40., 40.]), array([39.     , 38.84555556]))

    A DataFrame with the same columns reads the same way:

    >>> log_df = read_log(trace.to_pandas(), plant)
    >>> bool((log_df.U == log.U).all() and (log_df.Y == log.Y).all())
    True
    """
    inputs, outputs, states = tuple(system.input_names), tuple(system.output_names), tuple(system.state_names)
    if _is_dataframe(path):
        label = "DataFrame"
        header, data = _frame_table(path, inputs, outputs, states)

        def where(i: int) -> str:
            return f"DataFrame row {i}"
    else:
        path = Path(path)
        label = str(path)
        header, data, lines = _csv_table(path, inputs, outputs, states)

        def where(i: int) -> str:
            return f"{path} line {lines[i]}"
    names = _check_header(label, header, inputs, outputs, states)
    needed, times, modes, state_cols, extra_states = names
    if data.shape[0] == 0:
        raise ModelError(label, "at least one sample after the header", "none")
    for name in sorted({h for h in header if header.count(h) > 1}):
        cols = [c for c, h in enumerate(header) if h == name]
        differ = np.flatnonzero(np.any(data[:, cols] != data[:, cols[:1]], axis=1))
        if differ.size:
            raise ModelError(f"{where(int(differ[0]))} column {name!r}", "a column that appears twice to "
                             "hold the same values (one signal)", "two different values")

    def columns(names):
        return data[:, [header.index(nm) for nm in names]] if names else np.zeros((data.shape[0], 0))

    t = data[:, header.index(times[0])] if times else None
    if t is not None and np.any(np.diff(t) <= 0):
        i = int(np.argmax(np.diff(t) <= 0)) + 1
        raise ModelError(f"{where(i)} column {times[0]!r}", "strictly increasing times",
                         f"{t[i]!r} after {t[i - 1]!r}")
    X = columns(states) if extra_states or (states and len(state_cols) == len(states)) else None
    Q = None
    if modes:
        q = data[:, header.index(modes[0])]
        bad = np.flatnonzero(q != np.round(q))
        if bad.size:
            raise ModelError(f"{where(int(bad[0]))} column {modes[0]!r}", "an integer mode", repr(float(q[bad[0]])))
        Q = q.astype(int)
    return SignalLog(label, columns(inputs), columns(outputs), t, X, Q)


def _csv_table(path: Path, inputs, outputs, states) -> tuple[list[str], np.ndarray, np.ndarray]:
    """``(header, data, line of each row)`` of a CSV log (the header checked before the rows are read)."""
    try:
        # utf-8-sig: a byte-order mark (spreadsheets write one) is not part of the first column's name
        with path.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            # blank lines are skipped; each row keeps the line it ends on, for the messages
            first = next((r for r in reader if any(cell.strip() for cell in r)), None)
            if first is None:
                raise ModelError(str(path), "a header row naming the columns, then one row per sample", "an empty file")
            header = [h.strip() for h in first]
            _check_header(str(path), header, inputs, outputs, states)
            data, lines = _read_rows(path, reader, header)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ModelError(str(path), "a readable CSV log", f"{type(exc).__name__}: {exc}") from None
    return header, data, lines


def _is_dataframe(value: Any) -> bool:
    """Whether ``value`` is a pandas DataFrame (without importing pandas when it is not loaded)."""
    pd = sys.modules.get("pandas")
    return pd is not None and isinstance(value, pd.DataFrame)


def _frame_table(df, inputs, outputs, states) -> tuple[list[str], np.ndarray]:
    """``(header, data)`` of a DataFrame log: string column names, numeric finite cells, no named index."""
    import pandas as pd

    header = list(df.columns)
    bad = [c for c in header if not isinstance(c, str)]
    if bad:
        raise ModelError("DataFrame columns", "column names that are strings (the system's signal names)",
                         f"{bad[0]!r} of type {type(bad[0]).__name__}")
    if not header:
        raise ModelError("DataFrame", "a column per signal, then one row per sample", "no columns")
    if any(nm is not None for nm in df.index.names):
        raise ModelError("DataFrame index", "an unnamed index (the time as a column t or time: df.reset_index())",
                         f"an index named {[nm for nm in df.index.names]}")
    _check_header("DataFrame", header, inputs, outputs, states)
    data = np.empty((len(df), len(header)))
    for c, name in enumerate(header):
        col = df.iloc[:, c]
        dtype = col.dtype
        if pd.api.types.is_bool_dtype(dtype) or not pd.api.types.is_numeric_dtype(dtype) \
                or pd.api.types.is_complex_dtype(dtype):
            raise ModelError(f"DataFrame column {name!r}", "a numeric column (int or float)", f"dtype {dtype}")
        values = col.to_numpy(dtype=float, na_value=np.nan)
        finite = np.isfinite(values)
        if not finite.all():
            i = int(np.argmin(finite))
            raise ModelError(f"DataFrame row {i} column {name!r}", "a finite number", repr(col.iloc[i]))
        data[:, c] = values
    return header, data


def _check_header(path: str, header: list[str], inputs, outputs, states) -> tuple:
    """The header's columns checked against the system's names: ``(needed, times, modes,
    state_cols, extra_states)``."""
    needed = list(dict.fromkeys(inputs + outputs))
    missing = [nm for nm in needed if nm not in header]
    if missing:
        raise ModelError(f"{path} header", f"the input and output columns {needed} (optional: "
                         f"{' or '.join(TIME_COLUMNS)}, the states {list(states)})", f"missing {missing}")
    times = [h for h in header if h in TIME_COLUMNS and h not in needed]
    if len(times) > 1:
        raise ModelError(f"{path} header", "one time column", f"{times}")
    modes = [h for h in header if h in MODE_COLUMNS and h not in needed and h not in states]
    if len(modes) > 1:
        raise ModelError(f"{path} header", "one mode column", f"{modes}")
    allowed = set(needed) | set(times) | set(states) | set(modes)
    unknown = [h for h in header if h not in allowed]
    if unknown:
        raise ModelError(f"{path} header", f"only the columns {needed}, an optional time column "
                         f"({', '.join(TIME_COLUMNS)}), mode column ({', '.join(MODE_COLUMNS)}) and the states "
                         f"{list(states)}", f"unknown {unknown}")
    state_cols = [s for s in states if s in header]
    extra_states = [s for s in state_cols if s not in needed]
    if extra_states and len(state_cols) != len(states):
        raise ModelError(f"{path} header", f"all the state columns {list(states)} or none",
                         f"only {state_cols}")
    return needed, times, modes, state_cols, extra_states


#: Rows parsed into one block of the streamed log before the next block is allocated.
LOG_BLOCK_ROWS = 65536


def _read_rows(path: Path, reader, header: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """The data rows after the header, parsed as they are read (a log is never held as text):
    ``(data (N, columns), line of each row)``.  Blocks of :data:`LOG_BLOCK_ROWS` rows are joined
    at the end, so the peak is about twice the array (8 bytes per cell, fewer than the cell's text)."""
    ncol = len(header)
    blocks, line_blocks = [], []
    block, line_block, n = np.empty((LOG_BLOCK_ROWS, ncol)), np.empty(LOG_BLOCK_ROWS, dtype=np.int64), 0
    for row in reader:
        if not any(cell.strip() for cell in row):
            continue
        k = reader.line_num
        if len(row) != ncol:
            raise ModelError(f"{path} line {k}", f"{ncol} cells (one per column of the header)", f"{len(row)}")
        for c, cell in enumerate(row):
            block[n, c] = parse_decimal(cell, f"{path} line {k} column {header[c]!r}")
        line_block[n] = k
        n += 1
        if n == LOG_BLOCK_ROWS:
            blocks.append(block)
            line_blocks.append(line_block)
            block, line_block, n = np.empty((LOG_BLOCK_ROWS, ncol)), np.empty(LOG_BLOCK_ROWS, dtype=np.int64), 0
    blocks.append(block[:n])
    line_blocks.append(line_block[:n])
    if len(blocks) == 1:
        return blocks[0].copy(), line_blocks[0].copy()
    return np.concatenate(blocks), np.concatenate(line_blocks)


def write_estimates(path: str | Path, trace, t: np.ndarray | None = None) -> Path:
    """Write an :class:`~hybobs_opt.contract.ObserverTrace` as CSV: ``[t,] states..., mode, flag``,
    and ``radius_<state>`` per state when the observer states certified radii (the
    set-membership observer; empty where a step has none).

    Parameters
    ----------
    path : str or Path
        Output CSV file.
    trace : ObserverTrace
        The observer's run.
    t : (N,) ndarray, optional
        Sample times, written as a first column ``t`` when given.

    Returns
    -------
    Path
        ``path``.

    See Also
    --------
    read_log : reads the log the estimates come from.
    hybobs_opt.observe_log : the estimates.

    Examples
    --------
    >>> import numpy as np, tempfile
    >>> from pathlib import Path
    >>> from hybobs_opt import get_example, read_log, simulate_pwa
    >>> plant = get_example("powertrain3").build()
    >>> trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((50, 1), 40.0))
    >>> folder = Path(tempfile.mkdtemp())
    >>> trace.to_csv(folder / "log.csv")         # columns t, states, q, inputs, outputs

    >>> from hybobs_opt import observe_log, write_estimates
    >>> log = read_log(folder / "log.csv", plant)
    >>> trace, summary = observe_log(plant, log, ["lookup"], 3)["lookup"]
    >>> path = write_estimates(folder / "estimates.csv", trace, log.t)
    >>> path.read_text().splitlines()[0]
    't,theta,omega_m,omega_l,mode,flag'
    >>> path.read_text().splitlines()[3].split(",")[-2:]
    ['2', 'observable']
    """
    path = Path(path)
    names = list(trace.state_names) or [f"x{i + 1}" for i in range(trace.x_hat.shape[1])]
    infos = list(trace.info) if len(trace.info) == trace.n_steps else [{}] * trace.n_steps
    radii = any(isinstance(inf, dict) and "radius" in inf for inf in infos)
    with open_output(path, newline="") as fh:
        w = csv.writer(fh)
        w.writerow((["t"] if t is not None else []) + names + ["mode", "flag"]
                   + ([f"radius_{nm}" for nm in names] if radii else []))
        for k in range(trace.n_steps):
            head = [repr(float(t[k]))] if t is not None else []
            tail = []
            if radii:
                r = infos[k].get("radius") if isinstance(infos[k], dict) else None
                tail = [repr(float(v)) for v in r] if r is not None else [""] * len(names)
            w.writerow(head + [repr(float(v)) for v in trace.x_hat[k]] + [int(trace.mode[k]), str(trace.flags[k])] + tail)
    return path

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
from dataclasses import dataclass
from pathlib import Path

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


def read_log(path: str | Path, system) -> SignalLog:
    """Read a CSV log of ``system`` (anything with ``input_names``, ``output_names``, ``state_names``).

    Parameters
    ----------
    path : str or Path
        The CSV file.
    system : object
        Any object with ``input_names``, ``output_names`` and ``state_names`` (a system class of
        :mod:`hybobs_opt.systems`).

    Returns
    -------
    SignalLog
        The columns as arrays in the system's order.

    Raises
    ------
    ModelError
        The file is unreadable or empty, a column is missing, unknown or repeated, or a cell is
        not a finite number; the message names the file, the line and the column.
    """
    path = Path(path)
    inputs, outputs, states = tuple(system.input_names), tuple(system.output_names), tuple(system.state_names)
    try:
        # utf-8-sig: a byte-order mark (spreadsheets write one) is not part of the first column's name
        with path.open(newline="", encoding="utf-8-sig") as fh:
            reader = csv.reader(fh)
            # blank lines are skipped; each row keeps the line it ends on, for the messages
            first = next((r for r in reader if any(cell.strip() for cell in r)), None)
            if first is None:
                raise ModelError(str(path), "a header row naming the columns, then one row per sample", "an empty file")
            header = [h.strip() for h in first]
            names = _check_header(path, header, inputs, outputs, states)
            data, lines = _read_rows(path, reader, header)
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise ModelError(str(path), "a readable CSV log", f"{type(exc).__name__}: {exc}") from None
    needed, times, modes, state_cols, extra_states = names
    if data.shape[0] == 0:
        raise ModelError(str(path), "at least one sample after the header", "none")
    for name in sorted({h for h in header if header.count(h) > 1}):
        cols = [c for c, h in enumerate(header) if h == name]
        differ = np.flatnonzero(np.any(data[:, cols] != data[:, cols[:1]], axis=1))
        if differ.size:
            raise ModelError(f"{path} line {lines[int(differ[0])]} column {name!r}", "a column that appears twice to "
                             "hold the same values (one signal)", "two different values")

    def columns(names):
        return data[:, [header.index(nm) for nm in names]] if names else np.zeros((data.shape[0], 0))

    t = data[:, header.index(times[0])] if times else None
    if t is not None and np.any(np.diff(t) <= 0):
        i = int(np.argmax(np.diff(t) <= 0)) + 1
        raise ModelError(f"{path} line {lines[i]} column {times[0]!r}", "strictly increasing times",
                         f"{t[i]!r} after {t[i - 1]!r}")
    X = columns(states) if extra_states or (states and len(state_cols) == len(states)) else None
    Q = None
    if modes:
        q = data[:, header.index(modes[0])]
        bad = np.flatnonzero(q != np.round(q))
        if bad.size:
            raise ModelError(f"{path} line {lines[int(bad[0])]} column {modes[0]!r}", "an integer mode", repr(float(q[bad[0]])))
        Q = q.astype(int)
    return SignalLog(str(path), columns(inputs), columns(outputs), t, X, Q)


def _check_header(path: Path, header: list[str], inputs, outputs, states) -> tuple:
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

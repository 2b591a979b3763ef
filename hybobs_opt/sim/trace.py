"""The one trace type every simulator returns: samples of ``(t, x, q, u, y)``."""

from __future__ import annotations

import csv
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from ..errors import ModelError
from .._output_files import open_output


@dataclass(frozen=True, eq=False)
class Trace:
    """A sampled trajectory of a hybrid system.

    Parameters
    ----------
    t : (N,) array
        Sample times (seconds, or sample index times ``Ts`` for discrete systems).
    x : (N, n) array
        States.
    q : (N,) int array
        Discrete state: PWA mode index, automaton location index, or constant-drift mode.
    u : (N, m) array
        Inputs applied at ``t`` (``m = 0`` for autonomous systems).
    y : (N, p) array
        Outputs at ``t``.
    state_names, input_names, output_names : tuple of str
        Column names (used in CSV headers and CLI options).
    location_names : tuple of str
        Optional names of the discrete states, indexed by ``q``.
    events : list of dict
        Optional event log (time, kind, from, to, ...), e.g. guard crossings or served-queue switches.

    See Also
    --------
    simulate_system : a trace of any system class.
    Trace.to_csv : the trace as a CSV file.

    Examples
    --------
    Every simulator returns one; the arrays are indexed by sample:

    >>> import numpy as np
    >>> from hybobs_opt import get_example
    >>> plant = get_example("powertrain3").build()             # model (16) of paper 002
    >>> from hybobs_opt.sim import simulate_pwa
    >>> trace = simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((100, 1), 40.0))
    >>> trace.t.shape, trace.x.shape, trace.q.shape, trace.u.shape, trace.y.shape
    ((100,), (100, 3), (100,), (100, 1), (100, 1))
    >>> trace.state_names, trace.input_names, trace.output_names
    (('theta', 'omega_m', 'omega_l'), ('T_m',), ('omega_m',))
    >>> trace.location_names[trace.q[0]]                     # the mode at t = 0
    'positive_contact'
    """

    t: np.ndarray
    x: np.ndarray
    q: np.ndarray
    u: np.ndarray
    y: np.ndarray
    state_names: tuple[str, ...]
    input_names: tuple[str, ...] = ()
    output_names: tuple[str, ...] = ()
    location_names: tuple[str, ...] = ()
    events: list[dict[str, Any]] = field(default_factory=list)

    def __post_init__(self) -> None:
        t = np.asarray(self.t, dtype=float).reshape(-1)
        N = t.size
        x = np.asarray(self.x, dtype=float).reshape(N, -1)
        u = np.asarray(self.u, dtype=float).reshape(N, -1) if np.size(self.u) else np.zeros((N, 0))
        y = np.asarray(self.y, dtype=float).reshape(N, -1) if np.size(self.y) else np.zeros((N, 0))
        q = np.asarray(self.q).reshape(-1).astype(int)
        if q.size != N:
            raise ModelError("Trace.q", f"{N} entries", f"{q.size}")
        if len(self.state_names) != x.shape[1]:
            raise ModelError("Trace.state_names", f"{x.shape[1]} names", f"{len(self.state_names)}")
        for name, arr in (("t", t), ("x", x), ("q", q), ("u", u), ("y", y)):
            object.__setattr__(self, name, arr)

    @property
    def n_samples(self) -> int:
        return self.t.size

    def state(self, name: str) -> np.ndarray:
        """Column of the state called ``name``.

        Parameters
        ----------
        name : str
            One of :attr:`state_names`.

        Returns
        -------
        (N,) ndarray
            The column of ``x``.

        Raises
        ------
        ModelError
            If ``name`` is not a state name.
        """
        try:
            return self.x[:, self.state_names.index(name)]
        except ValueError:
            raise ModelError("state name", f"one of {self.state_names}", repr(name)) from None

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready dictionary with the arrays as nested lists (the ``--json`` contract).

        Returns
        -------
        dict
            ``t``, ``x``, ``q``, ``u``, ``y`` as lists, the four name tuples as lists and the events.
        """
        return {
            "t": self.t.tolist(),
            "x": self.x.tolist(),
            "q": self.q.tolist(),
            "u": self.u.tolist(),
            "y": self.y.tolist(),
            "state_names": list(self.state_names),
            "input_names": list(self.input_names),
            "output_names": list(self.output_names),
            "location_names": list(self.location_names),
            "events": [_jsonable(e) for e in self.events],
        }

    def to_pandas(self) -> Any:
        """The trace as a pandas DataFrame, one row per sample, the columns of :meth:`to_csv`.

        The frame is a log of the system: :func:`~hybobs_opt.sim.log.read_log` reads it back
        (inputs, outputs, time, true states and modes).  A name shared by an output and a state
        (an output that is a state) is one column, as in a log.

        Returns
        -------
        pandas.DataFrame
            Columns, in order: ``t`` (sample times), one per state (``state_names``), ``q``
            (discrete state), one per input (``input_names``), one per output (``output_names``);
            a default ``RangeIndex``.

        Raises
        ------
        ModelError
            An output and a state of the same name hold different values, or pandas is not
            installed (the ``interop`` extra).

        See Also
        --------
        hybobs_opt.sim.log.read_log : Reads the frame as a log.
        Trace.to_csv : The same columns in a CSV file.

        Examples
        --------
        >>> from hybobs_opt import Trace
        >>> tr = Trace([0.0, 0.1], [[1.0], [0.5]], [0, 1], [[2.0], [0.0]], [[1.0], [0.5]], ("x",), ("u",), ("y",))
        >>> df = tr.to_pandas()
        >>> list(df.columns), df["x"].tolist(), df["q"].tolist()
        (['t', 'x', 'q', 'u', 'y'], [1.0, 0.5], [0, 1])
        """
        from .._frames import frame

        columns = [("t", self.t), *zip(self.state_names, self.x.T), ("q", self.q), *zip(self.input_names, self.u.T),
                   *zip(self.output_names, self.y.T)]
        return frame(columns, "Trace")

    def to_csv(self, path: str | Path) -> None:
        """Write one row per sample with columns ``t, <states>, q, <inputs>, <outputs>``.

        Parameters
        ----------
        path : str or Path
            Output CSV file (overwritten).
        """
        header = ["t", *self.state_names, "q", *self.input_names, *self.output_names]
        with open_output(path, newline="") as fh:
            w = csv.writer(fh)
            w.writerow(header)
            for k in range(self.n_samples):
                w.writerow([self.t[k], *self.x[k], int(self.q[k]), *self.u[k], *self.y[k]])


def _jsonable(value: Any) -> Any:
    if isinstance(value, dict):
        return {k: _jsonable(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    return value

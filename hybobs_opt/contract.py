"""The runtime observer contract shared by every observer of the toolbox.

An observer has ``reset(...)``, ``step(u, y) -> Estimate`` and ``run(U, Y) -> ObserverTrace``.
A runtime observer never raises on a bad sample (NaN, wrong length): it falls back to open-loop
prediction and flags the step (DESIGN.md, "Conventions").

The contract sits in the core below both :mod:`hybobs_opt.mhe` and :mod:`hybobs_opt.observers`
(DESIGN.md draws ``mhe -> observers``): the moving-horizon observer implements it without
importing the package of the other runtime observers.

The initial mode or location of every ``reset()`` is the keyword ``q0``.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from ._validate import as_positive
from .defaults import RANGE_MARGIN, STATE_SET_MARGIN, TIME_JUMP_FACTOR
from .errors import ModelError
from .tolerances import RANGE_ABS_RTOL

#: Flags an estimate can carry.
OBSERVABLE = "observable"  #: reconstructed from the data (e.g. a unique consistent state)
UNOBSERVABLE = "unobservable"  #: the data admit several states: open-loop prediction used
FALLBACK = "fallback"  #: bad sample or failed computation: open-loop prediction used
WARMING_UP = "warming_up"  #: not enough samples yet for the horizon
FLAGS = (OBSERVABLE, UNOBSERVABLE, FALLBACK, WARMING_UP)


@dataclass(frozen=True)
class Estimate:
    """One step's result.

    Parameters
    ----------
    x : (n,) array
        State estimate at the current time.
    mode : int
        Estimated mode or location (``-1`` when unknown).
    flag : str
        One of :data:`FLAGS`.
    seconds : float
        Compute time of the step.
    info : dict
        Observer-specific details (e.g. the number of candidates, the solver status).

    See Also
    --------
    Observer.step : Returns one.
    ObserverTrace : The estimates of a run.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> obs = LookupObserver(hy.analyse_observability(plant, 3))
    >>> obs.reset()
    >>> for u, y in zip(U[:3], truth.y[:3]):
    ...     est = obs.step(u, y)
    ...
    >>> est.flag, est.mode, est.x.shape
    ('observable', 2, (3,))
    >>> bool(np.allclose(est.x, truth.x[2], atol=1e-6))
    True
    """

    x: np.ndarray
    mode: int
    flag: str
    seconds: float
    info: dict = field(default_factory=dict)


_new_object = object.__new__
_set_attribute = object.__setattr__
_perf_counter = time.perf_counter


def timed_estimate(x: np.ndarray, mode: int, flag: str, info: dict, t0: float) -> Estimate:
    """The :class:`Estimate` of a step that started at ``time.perf_counter() == t0``.

    ``seconds`` is taken after everything else is built, so it covers the whole step but the
    return.  Equal to ``Estimate(x, mode, flag, seconds, info)``, made without the frozen
    dataclass's per-field ``__setattr__`` (1-2 us of a step that is otherwise a few microseconds:
    the compiled observers' hot path).
    """
    est = _new_object(Estimate)
    fields = {"x": x, "mode": mode, "flag": flag, "seconds": 0.0, "info": info}
    fields["seconds"] = _perf_counter() - t0
    _set_attribute(est, "__dict__", fields)
    return est


@dataclass(frozen=True, eq=False)
class ObserverTrace:
    """The estimates of a whole run: ``x_hat[k]`` is the estimate after the ``k``-th sample.

    ``info[k]`` is the ``Estimate.info`` of step ``k`` (solver status, candidates, reasons) when
    the run kept it (:meth:`Observer.run` does); empty for vectorised runs that have none.

    Parameters
    ----------
    x_hat : (N, n) array
        The estimates.
    mode : (N,) int array
        Estimated mode or location per step (``-1`` when unknown).
    flags : (N,) object array
        One of :data:`FLAGS` per step.
    seconds : (N,) array
        Compute time per step.
    state_names : tuple of str
        Names of the states.
    observer : str
        Name of the observer.
    info : tuple of dict
        ``Estimate.info`` per step (or empty).

    See Also
    --------
    Observer.run : Returns one.
    plot_observer_run : Draws runs against the truth.
    summarise : The record of one run in a comparison.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver
    >>> trace = LookupObserver(hy.analyse_observability(plant, 3)).run(U, truth.y)
    >>> trace.n_steps, trace.state_names
    (40, ('theta', 'omega_m', 'omega_l'))
    >>> trace.flag_counts()
    {'observable': 38, 'unobservable': 0, 'fallback': 0, 'warming_up': 2}
    >>> float(np.abs(trace.errors(truth.x)[2:]).max()) < 1e-6
    True
    >>> sorted(trace.timing())  # doctest: +ELLIPSIS
    ['max_step_s', 'median_step_s', 'p95_step_s']
    """

    x_hat: np.ndarray
    mode: np.ndarray
    flags: np.ndarray
    seconds: np.ndarray
    state_names: tuple[str, ...] = ()
    observer: str = ""
    info: tuple[dict, ...] = ()

    @property
    def n_steps(self) -> int:
        return self.x_hat.shape[0]

    def errors(self, x_true: np.ndarray) -> np.ndarray:
        """``x_hat - x_true`` (shapes must agree).

        Parameters
        ----------
        x_true : (N, n) array_like
            The true states, one row per step.

        Returns
        -------
        (N, n) ndarray
            ``x_hat - x_true``.

        Raises
        ------
        ModelError
            If the shapes differ.
        """
        x_true = np.asarray(x_true, dtype=float)
        if x_true.shape != self.x_hat.shape:
            raise ModelError("x_true", f"shape {self.x_hat.shape}", f"shape {x_true.shape}")
        return self.x_hat - x_true

    def to_pandas(self, t: np.ndarray | None = None) -> Any:
        """The run as a pandas DataFrame, one row per step: the columns :func:`~hybobs_opt.sim.log.write_estimates` writes, and the step times.

        Parameters
        ----------
        t : (N,) array_like, optional
            Sample times, a first column ``t`` when given (e.g. the log's ``log.t``).

        Returns
        -------
        pandas.DataFrame
            Columns, in order: ``t`` (when given), one per state with the estimate (named by
            ``state_names``, else ``x1, x2, ...``), ``mode`` (estimated mode, ``-1`` unknown),
            ``flag`` (one of :data:`FLAGS`), ``seconds`` (compute time of the step) and, when
            some step states a certified radius, ``radius_<state>`` per state (``nan`` where a
            step states none); a default ``RangeIndex``.

        Raises
        ------
        ModelError
            ``t`` does not have one entry per step, or pandas is not installed (the ``interop``
            extra).

        See Also
        --------
        hybobs_opt.sim.log.write_estimates : The same columns (without ``seconds``) in a CSV file.
        hybobs_opt.sim.trace.Trace.to_pandas : The simulated truth to compare with.

        Examples
        --------
        >>> import numpy as np
        >>> from hybobs_opt import ObserverTrace
        >>> run = ObserverTrace(np.array([[0.0], [1.0]]), np.array([-1, 0]), np.array(["warming_up", "observable"]),
        ...                     np.array([1e-3, 2e-3]), ("x",), "demo")
        >>> run.to_pandas(t=[0.0, 0.1]).to_dict("list")
        {'t': [0.0, 0.1], 'x': [0.0, 1.0], 'mode': [-1, 0], 'flag': ['warming_up', 'observable'], 'seconds': [0.001, 0.002]}
        """
        from ._frames import frame

        N, n = self.x_hat.shape
        names = list(self.state_names) or [f"x{i + 1}" for i in range(n)]
        columns = []
        if t is not None:
            t = np.asarray(t, dtype=float).reshape(-1)
            if t.size != N:
                raise ModelError("t", f"one time per step ({N})", f"{t.size}")
            columns.append(("t", t))
        columns += list(zip(names, self.x_hat.T))
        columns += [("mode", np.asarray(self.mode, dtype=int)), ("flag", np.asarray(self.flags, dtype=object)),
                    ("seconds", np.asarray(self.seconds, dtype=float))]
        R = self.radii() if len(self.info) == N else None
        if R is not None:
            columns += [(f"radius_{nm}", R[:, i]) for i, nm in enumerate(names)]
        return frame(columns, "ObserverTrace")

    def flag_counts(self) -> dict[str, int]:
        """How many steps have each flag.

        Returns
        -------
        dict of str to int
            The number of steps with each flag (``observable``, ``unobservable``, ``fallback``,
            ``warming_up``).
        """
        return {f: int(np.count_nonzero(self.flags == f)) for f in FLAGS}

    def radii(self) -> np.ndarray | None:
        """The certified radius each step states (``info["radius"]``), ``(N, n)`` with ``nan`` rows
        where a step states none; ``None`` when no step states one.

        Returns
        -------
        ndarray or None
            The certified radius each step states (``info["radius"]``), ``(N, n)`` with ``nan``
            rows where a step states none; ``None`` when no step states one.
        """
        n = self.x_hat.shape[1]
        if not any(isinstance(inf, dict) and "radius" in inf for inf in self.info):
            return None
        return np.array([np.asarray(inf["radius"], dtype=float).reshape(n) if isinstance(inf, dict) and "radius" in inf
                         else np.full(n, np.nan) for inf in self.info]).reshape(len(self.info), n)

    def n_outside_radius(self, x_true: np.ndarray) -> int:
        """Steps stating a radius whose true state lies outside it (to the rounding allowance
        :data:`~hybobs_opt.tolerances.RADIUS_CHECK_RTOL` / ``RADIUS_CHECK_ATOL``); 0 without radii.

        Returns
        -------
        int
            Steps stating a radius whose true state lies outside it (0 when none states one).
        """
        from .tolerances import RADIUS_CHECK_ATOL, RADIUS_CHECK_RTOL

        R = self.radii()
        if R is None:
            return 0
        err = np.abs(self.errors(x_true))
        has = np.all(np.isfinite(R), axis=1)
        return int(np.count_nonzero(np.any(err[has] > R[has] * (1 + RADIUS_CHECK_RTOL) + RADIUS_CHECK_ATOL, axis=1)))

    def timing(self) -> dict[str, float]:
        """Median, 95th percentile and maximum per-step compute time (seconds).

        Returns
        -------
        dict
            Median, 95th percentile and maximum per-step compute time (seconds).
        """
        s = self.seconds[np.isfinite(self.seconds)]
        if s.size == 0:
            return {"median_step_s": float("nan"), "p95_step_s": float("nan"), "max_step_s": float("nan")}
        return {"median_step_s": float(np.median(s)), "p95_step_s": float(np.percentile(s, 95)), "max_step_s": float(s.max())}


def innovation_excess(r: np.ndarray, allowed: np.ndarray, y: np.ndarray, names=(), what: str = "") -> str | None:
    """Why an output residual ``r`` exceeds ``allowed`` (the error bound's share plus
    :data:`~hybobs_opt.defaults.INNOVATION_MARGIN`) in some output, or ``None``; ``what`` names whose residual it is."""
    bad = np.nonzero(~(np.abs(r) <= allowed))[0]
    if not bad.size:
        return None
    j = int(bad[0])
    name = names[j] if j < len(names) else f"y[{j}]"
    return (f"output {name} = {y[j]:.6g} contradicts the model: residual {r[j]:.3g}{what} exceeds the certified "
            f"error bound's {allowed[j]:.3g}")


def outside_range(v: np.ndarray, rng, margin: float, names=(), label: str = "y") -> str | None:
    """Why ``v`` lies outside ``rng = (lo, hi)`` by more than ``margin`` of its width, else ``None``.

    A side that is infinite is not judged; the width of a half-bounded coordinate is taken as
    ``1 + |finite bound|`` so a margin stays finite.
    """
    lo, hi = rng
    width = hi - lo
    finite = np.isfinite(width)
    scale = np.where(finite, width, 1.0 + np.where(np.isfinite(lo), np.abs(lo), np.where(np.isfinite(hi), np.abs(hi), 0.0)))
    big = np.maximum(np.where(np.isfinite(lo), np.abs(lo), 0.0), np.where(np.isfinite(hi), np.abs(hi), 0.0))
    pad = margin * scale + RANGE_ABS_RTOL * (1.0 + big)
    with np.errstate(invalid="ignore"):
        bad = np.nonzero((v < lo - pad) | (v > hi + pad))[0]
    if not bad.size:
        return None
    j = int(bad[0])
    name = names[j] if j < len(names) else f"{label}[{j}]"
    return f"{name} = {v[j]:.6g} outside the model's range [{lo[j]:.6g}, {hi[j]:.6g}] by more than {margin:g} of its width"


class TimeGuard:
    """Judges the time stamps of an event-driven observer: order, and jumps beyond ``max_step``.

    :meth:`judge` returns ``("ok", None)`` for a plausible time stamp, ``("refused", reason)`` for
    one before the previous accepted time stamp or more than ``max_step`` after it, and
    ``("resumed", reason)`` when a time stamp follows a refused jump within ``max_step`` of it:
    two consecutive consistent samples after a gap are a real gap in the data (the observer
    restarts its time reference there), one alone is a clock fault.  ``max_step=None`` judges
    the order only.
    """

    def __init__(self, max_step: float | None):
        max_step = as_positive(max_step, "max_time_step", "a positive finite time", allow_none=True)
        self.max_step = None if max_step is None else float(max_step)
        self.reset(0.0)

    def reset(self, t0: float) -> None:
        self.t = float(t0)
        self._jump: float | None = None

    def judge(self, t: float) -> tuple[str, str | None]:
        if not np.isfinite(t):
            return "refused", f"time stamp {t} is not finite"
        if t < self.t:
            return "refused", f"time stamp {t:.9g} before the previous one {self.t:.9g}"
        if self.max_step is None or t - self.t <= self.max_step:
            self.t, self._jump = float(t), None
            return "ok", None
        if self._jump is not None and 0.0 <= t - self._jump <= self.max_step:
            gap = t - self.t
            self.t, self._jump = float(t), None
            return "resumed", f"data resumed after a gap of {gap:.6g} (more than {self.max_step:.6g}): time reference restarted"
        self._jump = float(t)
        return "refused", (f"time stamp {t:.9g} jumps {t - self.t:.6g} after the previous one {self.t:.9g}, more than "
                           f"the plausible {self.max_step:.6g} ({TIME_JUMP_FACTOR:g} x the model's time scale)")


def judge_samples_against(observer: "Observer", system: Any, *, inputs: bool = True, outputs: bool = True,
                          states: bool = True) -> None:
    """Give ``observer`` the ranges of ``system`` (:mod:`hybobs_opt.systems.ranges`) and its signal
    names, so that :meth:`Observer.step` judges samples and estimates against the model."""
    from .systems.ranges import input_range, output_range, state_range

    observer.input_names = tuple(getattr(system, "input_names", ()))
    observer.output_names = tuple(getattr(system, "output_names", ()))
    observer.input_range = input_range(system) if inputs else None
    observer.output_range = output_range(system) if outputs else None
    observer.state_range = state_range(system) if states else None


def trace_length(U, Y) -> int:
    """The number of samples of a recorded trace ``U, Y`` (sequences of rows of the same length),
    else a :class:`ModelError` naming ``U, Y``."""
    try:
        nu, ny = len(U), len(Y)
    except TypeError:
        raise ModelError("U, Y", "sequences of samples (one row per step)",
                         f"{type(U).__name__} and {type(Y).__name__}") from None
    if nu != ny:
        raise ModelError("U, Y", "the same number of samples", f"{nu} and {ny}")
    return nu


def noise_std_vector(value, p: int, field: str = "noise_std") -> np.ndarray:
    """Output-noise standard deviations as a ``(p,)`` array: a positive finite scalar (every output)
    or one per output, in output units; anything else is a :class:`ModelError` naming ``field``."""
    if value is None or isinstance(value, (str, bytes, bool)):
        raise ModelError(field, f"a positive finite output-noise standard deviation (scalar or length {p})", repr(value))
    arr = np.asarray(value)
    if arr.dtype.kind not in "iuf" or arr.shape not in ((), (p,)):
        raise ModelError(field, f"a positive finite output-noise standard deviation (scalar or length {p})",
                         f"{arr.dtype} array of shape {arr.shape}")
    arr = np.broadcast_to(arr.astype(float), (p,)).copy()
    if not np.all(np.isfinite(arr) & (arr > 0)):
        raise ModelError(field, "positive finite standard deviations (in output units)", repr(arr.tolist()))
    return arr


def noise_bound_vector(value, output_names, field: str = "noise_bound") -> np.ndarray:
    """The bound on each output's noise as a ``(p,)`` array of finite values ``>= 0``.

    Parameters
    ----------
    value : float, sequence of p floats, or dict of output name to float
        One bound for every output, one per output, or by name (outputs not named: 0).
    output_names : sequence of str
        The model's output names.
    field : str
        Name of the argument in error messages.

    Returns
    -------
    (p,) ndarray
        The bound of each output, in output order.

    See Also
    --------
    radius_tolerance_vector : The same for the radius per state.
    SetMembershipObserver : Takes a noise bound.

    Examples
    --------
    >>> from hybobs_opt.observers import noise_bound_vector
    >>> noise_bound_vector(0.1, ("y1", "y2"))
    array([0.1, 0.1])
    >>> noise_bound_vector({"y2": 0.5}, ("y1", "y2"))
    array([0. , 0.5])
    >>> noise_bound_vector(-1.0, ("y1",))  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    hybobs_opt.errors.ModelError: noise_bound: expected 1 finite bounds >= 0 ...
    """
    names = tuple(output_names)
    p = len(names)
    if isinstance(value, dict):
        unknown = [k for k in value if k not in names]
        if unknown:
            raise ModelError(field, f"output names among {list(names)}", repr(unknown[0]))
        value = [value.get(nm, 0.0) for nm in names]
    if isinstance(value, (bool, np.bool_)) or isinstance(value, (str, bytes)):
        raise ModelError(field, "a bound >= 0 per output (a number, p numbers or a dict by output name)", repr(value))
    try:
        complex_input = np.iscomplexobj(np.asarray(value))
    except (TypeError, ValueError):
        complex_input = False  # ragged or non-numeric: refused below
    if complex_input:
        raise ModelError(field, "real bounds", repr(value))
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(field, "a bound >= 0 per output (a number, p numbers or a dict by output name)", repr(value)) from None
    arr = np.broadcast_to(arr, (p,)).copy() if arr.ndim == 0 else arr
    if arr.shape != (p,) or not np.all(np.isfinite(arr)) or np.any(arr < 0):
        raise ModelError(field, f"{p} finite bounds >= 0 (outputs {list(names)}), in the outputs' units", repr(value))
    return arr


def radius_tolerance_vector(value, state_names, default: np.ndarray, field: str = "tolerance") -> np.ndarray:
    """The largest radius per state for the flag ``observable`` as a ``(n,)`` array of finite values ``> 0``.

    Parameters
    ----------
    value : None, float, sequence of n floats, or dict of state name to float
        ``None``: ``default``; one radius for every state, one per state, or by name (states not
        named: their ``default``), in the states' units.
    state_names : sequence of str
        The model's state names.
    default : (n,) ndarray
        The radii used where ``value`` names none.
    field : str
        Name of the argument in error messages.

    Returns
    -------
    (n,) ndarray
        The largest radius of each state, in state order.

    See Also
    --------
    noise_bound_vector : The same for the output noise.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.observers import radius_tolerance_vector
    >>> default = np.array([0.1, 1.0])
    >>> radius_tolerance_vector(None, ("x1", "x2"), default)
    array([0.1, 1. ])
    >>> radius_tolerance_vector({"x2": 0.5}, ("x1", "x2"), default)
    array([0.1, 0.5])
    >>> radius_tolerance_vector(0.0, ("x1", "x2"), default)  # doctest: +ELLIPSIS
    Traceback (most recent call last):
        ...
    hybobs_opt.errors.ModelError: tolerance: expected 2 finite radii > 0 (states ['x1', 'x2']), got 0.0
    """
    names = tuple(state_names)
    n = len(names)
    if value is None:
        return np.asarray(default, dtype=float).copy()
    if isinstance(value, dict):
        unknown = [k for k in value if k not in names]
        if unknown:
            raise ModelError(field, f"state names among {list(names)}", repr(unknown[0]))
        value = [value.get(nm, d) for nm, d in zip(names, default)]
    if isinstance(value, (bool, np.bool_, str, bytes)):
        raise ModelError(field, "a radius > 0 per state (a number, n numbers or a dict by state name)", repr(value))
    try:
        arr = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(field, "a radius > 0 per state", repr(value)) from None
    arr = np.broadcast_to(arr, (n,)).copy() if arr.ndim == 0 else arr
    if arr.shape != (n,) or not np.all(np.isfinite(arr)) or np.any(arr <= 0):
        raise ModelError(field, f"{n} finite radii > 0 (states {list(names)})", repr(value))
    return arr


def false_alarm_probability(value, field: str = "false_alarm") -> float:
    """A statistical test's false-alarm probability, in ``(0, 0.5)``, else a :class:`ModelError` naming ``field``."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) \
            or not (0.0 < float(value) < 0.5):
        raise ModelError(field, "a probability in (0, 0.5)", repr(value))
    return float(value)


def sample_rows(X, width: int, field: str) -> np.ndarray:
    """A recorded trace as a float ``(N, width)`` array for a vectorised run: a row that is not
    ``width`` real numbers (a string, a wrong length, a complex value) becomes a NaN row, which every
    observer flags ``fallback`` like any bad sample.  Only something that is not a sequence of
    rows is refused (:class:`ModelError`)."""
    try:
        N = len(X)
    except TypeError:
        raise ModelError(field, "a sequence of samples (one row per step)", type(X).__name__) from None
    try:
        arr = np.asarray(X)
    except (TypeError, ValueError):
        arr = None
    if arr is not None and arr.dtype.kind in "biuf":
        if arr.size != N * width:
            raise ModelError(field, f"{N} rows of {width} values", f"an array of shape {arr.shape}")
        return np.ascontiguousarray(arr.astype(float).reshape(N, width))
    out = np.full((N, width), np.nan)
    for k in range(N):
        try:  # the finite check is the observer's: NaN/inf entries of a well-formed row stay
            r = np.atleast_1d(np.asarray(X[k]))
        except (TypeError, ValueError):
            continue
        if r.dtype.kind in "biuf" and r.size == width:
            out[k] = r.astype(float).reshape(-1)
    return out


def checked_index(value, count: int, field: str, what: str = "index") -> int | None:
    """``value`` as an integer in ``0..count-1`` (``None`` passes), or :class:`ModelError`: a float,
    a bool, a string or a sequence is not an index."""
    if value is None:
        return None
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or not 0 <= int(value) < count:
        raise ModelError(field, f"an integer {what} in 0..{count - 1} or None", repr(value))
    return int(value)


def checked_time(value, field: str) -> float:
    """``value`` as a finite real time, or :class:`ModelError` (nothing coerced: no strings, bools, sequences)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)) or not np.isfinite(value):
        raise ModelError(field, "a finite real time", repr(value))
    return float(value)


def checked_state(x0, n: int, field: str = "x0", what: str = "state") -> np.ndarray:
    """``x0`` as a finite real ``(n,)`` array, or :class:`ModelError` naming ``field`` (nothing coerced:
    a string, a boolean, a complex value, a wrong length or a NaN is refused)."""
    arr = np.asarray(x0) if not isinstance(x0, (str, bytes)) else None
    if arr is None or arr.dtype.kind not in "iuf":  # booleans are no state either
        got = type(x0).__name__ if arr is None else f"an array of {arr.dtype}"
        raise ModelError(field, f"a finite real {what} of length {n}", got)
    arr = arr.astype(float).reshape(-1)
    if arr.shape != (n,) or not np.all(np.isfinite(arr)):
        raise ModelError(field, f"a finite real {what} of length {n}", f"{arr.tolist()}")
    return arr


class Observer(ABC):
    """Base class: subclasses implement :meth:`reset` and :meth:`_step`; :meth:`step` times it
    and turns any exception on a sample into a flagged open-loop step.

    Samples are judged against the model (:mod:`hybobs_opt.systems.ranges`): an observer that sets
    ``output_range`` or ``input_range = (lo, hi)`` (arrays over the outputs / inputs: what the
    model can produce) has samples outside them by more than :data:`~hybobs_opt.defaults.RANGE_MARGIN` refused like NaN
    samples, and one that sets ``state_range`` never flags ``observable`` an estimate outside the
    state set by more than :data:`~hybobs_opt.defaults.STATE_SET_MARGIN` (the step is flagged ``fallback`` with the
    reason in ``info``).

    See Also
    --------
    Estimate : What ``step`` returns.
    ObserverTrace : What ``run`` returns.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import LookupObserver, Observer
    >>> obs = LookupObserver(hy.analyse_observability(plant, 3))
    >>> isinstance(obs, Observer)
    True
    >>> obs.reset()
    >>> [obs.step(u, y).flag for u, y in zip(U[:4], truth.y[:4])]
    ['warming_up', 'warming_up', 'observable', 'observable']

    A bad sample is flagged, never raised:

    >>> obs.step(U[4], np.array([np.nan])).flag
    'fallback'
    """

    name = "observer"
    n: int
    state_names: tuple[str, ...] = ()
    input_range: tuple[np.ndarray, np.ndarray] | None = None
    output_range: tuple[np.ndarray, np.ndarray] | None = None
    state_range: tuple[np.ndarray, np.ndarray] | None = None

    @abstractmethod
    def reset(self, x0: np.ndarray | None = None, **kwargs: Any) -> None:
        """Forget the past; ``x0`` is the initial guess used for open-loop prediction.

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial estimate; ``None`` keeps each observer's default (its previous or constructor value,
            else the centre of the state bounds).
        **kwargs
            The other keywords of :data:`RESET_KEYWORDS` (the initial mode or location ``q0``, the
            time ``t0`` ...): each observer uses those it needs and ignores the others, and refuses
            any keyword outside them (:func:`check_reset_keywords`).
        """

    @abstractmethod
    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        """One step with a validated sample."""

    @abstractmethod
    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        """Open-loop step used when the sample is bad."""

    def _validate_sample(self, u, y) -> tuple[np.ndarray, np.ndarray] | str:
        checked = real_sample_pair(u, y, self.m, self.p)
        if isinstance(checked, str):
            return checked
        uu, yy = checked
        if not (np.all(np.isfinite(uu)) and np.all(np.isfinite(yy))):
            return NONFINITE_SAMPLE
        for rng, v, names, label in ((self.input_range, uu, getattr(self, "input_names", ()), "u"),
                                     (self.output_range, yy, getattr(self, "output_names", ()), "y")):
            if rng is not None:
                why = outside_range(v, rng, RANGE_MARGIN, names, label)
                if why is not None:
                    return ("input " if label == "u" else "output ") + why
        return uu, yy

    def step(self, u, y) -> Estimate:
        """Process one sample ``(u(t), y(t))`` and return the estimate of ``x(t)``.

        Parameters
        ----------
        u : (m,) array_like
            Input sample.
        y : (p,) array_like
            Output sample.

        Returns
        -------
        Estimate
            The estimate, its mode, flag, compute time and details; a bad sample gives a flagged
            open-loop step, never an exception.
        """
        t0 = time.perf_counter()
        checked = self._validate_sample(u, y)
        if isinstance(checked, str):
            est = self._fallback(self._usable_input(u), checked)
        else:
            est = self._step(*checked)
        est = self._judge_estimate(est)
        return Estimate(est.x, est.mode, est.flag, time.perf_counter() - t0, est.info)

    def _usable_input(self, u) -> np.ndarray | None:
        """The input of a refused sample if open-loop prediction may still use it (numeric, finite, of
        the right length and inside ``input_range``), else ``None``."""
        uu = _safe_input(u, self.m)
        if uu is not None and self.input_range is not None and outside_range(uu, self.input_range, RANGE_MARGIN) is not None:
            return None
        return uu

    def _judge_estimate(self, est: Estimate) -> Estimate:
        """``est`` with ``observable`` withdrawn (flag ``fallback``) when it lies outside the state set."""
        if est.flag != OBSERVABLE or self.state_range is None:
            return est
        why = outside_range(np.asarray(est.x, dtype=float).reshape(-1), self.state_range, STATE_SET_MARGIN,
                            self.state_names, "x")
        if why is None:
            return est
        return Estimate(est.x, est.mode, FALLBACK, est.seconds, dict(est.info, reason="estimate " + why))

    def run(self, U, Y) -> ObserverTrace:
        """Run :meth:`step` over a recorded trace (subclasses may vectorise this).

        The rows go to :meth:`step` as they are, so a malformed row (a string, a wrong length) is a
        ``fallback`` step like any bad sample; only traces of different lengths are refused.

        Parameters
        ----------
        U : sequence of (m,) samples
            Inputs, one row per step.
        Y : sequence of (p,) samples
            Outputs, one row per step (same number as ``U``).

        Returns
        -------
        ObserverTrace
            The estimates of every step.

        Raises
        ------
        ModelError
            If ``U`` and ``Y`` are not sequences of the same length.
        """
        N = trace_length(U, Y)
        xs = np.full((N, self.n), np.nan)
        modes = np.full(N, -1)
        flags = np.empty(N, dtype=object)
        secs = np.zeros(N)
        infos = []
        for k in range(N):
            e = self.step(U[k], Y[k])
            xs[k], modes[k], flags[k], secs[k] = e.x, e.mode, e.flag, e.seconds
            infos.append(e.info)
        return ObserverTrace(xs, modes, flags, secs, self.state_names, self.name, tuple(infos))


def initial_state(x0, fallback, state_bounds, n: int) -> np.ndarray:
    """``x0``, else ``fallback``, else the centre of ``state_bounds``, checked to be a finite ``(n,)`` state."""
    if x0 is None:
        x0 = fallback
    if x0 is None:
        lo, hi = state_bounds.bounding_box()
        x0 = (lo + hi) / 2.0
    return checked_state(x0, n)


def real_sample(v) -> np.ndarray:
    """One sample ``v`` as a flat float array, refusing what would be coerced: a complex value (its
    imaginary part would be dropped), a string or any non-numeric object.

    Raises
    ------
    TypeError
        ``v`` is not real numbers (the observers turn this into a ``fallback`` step with its reason).
    """
    if isinstance(v, (str, bytes)):
        raise TypeError(f"a string {v!r:.40} is no sample")
    arr = np.asarray(v)
    if arr.dtype.kind not in "biuf":
        what = "complex" if arr.dtype.kind == "c" else str(arr.dtype)
        raise TypeError(f"values of type {what}, expected real numbers")
    return np.atleast_1d(arr.astype(float)).reshape(-1)


#: The reason of a ``fallback`` step whose sample holds NaN or Inf (the compiled lookup kernel gives the same).
NONFINITE_SAMPLE = "sample with NaN or Inf"


def real_sample_pair(u, y, m: int, p: int) -> tuple[np.ndarray, np.ndarray] | str:
    """``(u, y)`` as flat float arrays of lengths ``m`` and ``p`` (:func:`real_sample`), or the reason
    why the pair is no sample (not real numbers, wrong length): the first check of every observer's
    ``step``, before the model judges the values."""
    try:
        uu, yy = real_sample(u), real_sample(y)
    except (TypeError, ValueError) as exc:
        return f"sample not numeric ({exc})"
    if uu.size != m or yy.size != p:
        return f"sample of length (u={uu.size}, y={yy.size}), expected (u={m}, y={p})"
    return uu, yy


def _safe_input(u, m: int) -> np.ndarray | None:
    """The input if it is usable for open-loop prediction, else ``None``."""
    try:
        uu = real_sample(u)
    except (TypeError, ValueError):
        return None
    return uu if uu.size == m and np.all(np.isfinite(uu)) else None


#: The keywords of :meth:`Observer.reset` across the observers: one call resets any observer, so an
#: observer ignores those it has no use for and refuses every other (a misspelt ``qo=`` is an error,
#: not a silent default).
RESET_KEYWORDS = ("q0", "t0", "y0", "P0", "k0")


def check_reset_keywords(kwargs: dict, observer: str) -> None:
    """Refuse ``reset()`` keywords outside :data:`RESET_KEYWORDS` (the ones left in ``**kwargs``).

    Raises
    ------
    ModelError
        A keyword no observer's ``reset`` takes; the message names it and the observer.
    """
    unknown = sorted(k for k in kwargs if k not in RESET_KEYWORDS)
    if unknown:
        from .errors import ModelError

        raise ModelError(f"reset({unknown[0]}=...)", f"x0 and the keywords {', '.join(RESET_KEYWORDS)} of the observers' "
                         f"reset ({observer} uses those it needs)", f"the keyword {unknown[0]!r}")


def initial_mode(q0, old_value, old_name: str):
    """The initial mode of a ``reset()``: ``q0``, or the value of its deprecated keyword ``old_name``.

    Every observer takes the initial mode or location as ``q0``; the keywords some observers used
    before (``mode``, ``location``, ``region``) still work for one release, with a ``FutureWarning``
    (:func:`hybobs_opt._deprecation.warn_renamed`).  Both given and different is an error.

    Raises
    ------
    ModelError
        ``q0`` and ``old_name`` are both given with different values.
    """
    if old_value is None:
        return q0
    from ._deprecation import warn_renamed

    warn_renamed(f"reset({old_name}=...)", "reset(q0=...)", stacklevel=4)
    if q0 is not None and q0 != old_value:
        from .errors import ModelError

        raise ModelError("q0", f"one initial mode (q0 and its old name {old_name!r} disagree)", f"q0={q0!r}, {old_name}={old_value!r}")
    return old_value

"""The runtime observer contract shared by every observer of the toolbox.

An observer has ``reset(...)``, ``step(u, y) -> Estimate`` and ``run(U, Y) -> ObserverTrace``.
A runtime observer never raises on a bad sample (NaN, wrong length): it falls back to open-loop
prediction and flags the step (DESIGN.md, "Conventions").

The contract sits in the core below both :mod:`hybobs_opt.mhe` and :mod:`hybobs_opt.observers`
(DESIGN.md draws ``mhe -> observers``): the moving-horizon observer implements it without
importing the package of the other runtime observers.  :mod:`hybobs_opt.observers.base` is the
same module under its old name.

The initial mode or location of every ``reset()`` is the keyword ``q0``.
"""

from __future__ import annotations

import time
from abc import ABC, abstractmethod
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .errors import ModelError

#: Flags an estimate can carry.
OBSERVABLE = "observable"  #: reconstructed from the data (e.g. a unique consistent state)
UNOBSERVABLE = "unobservable"  #: the data admit several states: open-loop prediction used
FALLBACK = "fallback"  #: bad sample or failed computation: open-loop prediction used
WARMING_UP = "warming_up"  #: not enough samples yet for the horizon
FLAGS = (OBSERVABLE, UNOBSERVABLE, FALLBACK, WARMING_UP)


@dataclass(frozen=True)
class Estimate:
    """One step's result.

    Attributes
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
    """

    x: np.ndarray
    mode: int
    flag: str
    seconds: float
    info: dict = field(default_factory=dict)


@dataclass(frozen=True, eq=False)
class ObserverTrace:
    """The estimates of a whole run: ``x_hat[k]`` is the estimate after the ``k``-th sample.

    ``info[k]`` is the ``Estimate.info`` of step ``k`` (solver status, candidates, reasons) when
    the run kept it (:meth:`Observer.run` does); empty for vectorised runs that have none.
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
        """``x_hat - x_true`` (shapes must agree)."""
        x_true = np.asarray(x_true, dtype=float)
        if x_true.shape != self.x_hat.shape:
            raise ModelError("x_true", f"shape {self.x_hat.shape}", f"shape {x_true.shape}")
        return self.x_hat - x_true

    def flag_counts(self) -> dict[str, int]:
        return {f: int(np.count_nonzero(self.flags == f)) for f in FLAGS}

    def timing(self) -> dict[str, float]:
        """Median, 95th percentile and maximum per-step compute time (seconds)."""
        s = self.seconds[np.isfinite(self.seconds)]
        if s.size == 0:
            return {"median_step_s": float("nan"), "p95_step_s": float("nan"), "max_step_s": float("nan")}
        return {"median_step_s": float(np.median(s)), "p95_step_s": float(np.percentile(s, 95)), "max_step_s": float(s.max())}


#: A sample whose output lies outside the range the model can produce (``output_range`` of an
#: observer) by more than this fraction of the range's width is not used: it is flagged
#: ``fallback`` and the step is open loop.  Half the width leaves room for sensor noise and offsets
#: while a sensor fault (``y = 1e12``) never enters the state.
OUTPUT_RANGE_MARGIN: float = 0.5


class Observer(ABC):
    """Base class: subclasses implement :meth:`reset` and :meth:`_step`; :meth:`step` times it
    and turns any exception on a sample into a flagged open-loop step.

    An observer that sets ``output_range = (lo, hi)`` (arrays over the outputs: what the model can
    produce on its state set) has samples outside it by more than :data:`OUTPUT_RANGE_MARGIN`
    refused like NaN samples."""

    name = "observer"
    n: int
    state_names: tuple[str, ...] = ()

    @abstractmethod
    def reset(self, x0: np.ndarray | None = None, **kwargs: Any) -> None:
        """Forget the past; ``x0`` is the initial guess used for open-loop prediction."""

    @abstractmethod
    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        """One step with a validated sample."""

    @abstractmethod
    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        """Open-loop step used when the sample is bad."""

    def _validate_sample(self, u, y) -> tuple[np.ndarray, np.ndarray] | str:
        try:
            uu = np.atleast_1d(np.asarray(u, dtype=float)).reshape(-1)
            yy = np.atleast_1d(np.asarray(y, dtype=float)).reshape(-1)
        except (TypeError, ValueError) as exc:
            return f"sample not numeric ({exc})"
        if uu.size != self.m or yy.size != self.p:
            return f"sample of length (u={uu.size}, y={yy.size}), expected (u={self.m}, y={self.p})"
        if not (np.all(np.isfinite(uu)) and np.all(np.isfinite(yy))):
            return "sample with NaN or Inf"
        rng = getattr(self, "output_range", None)
        if rng is not None:
            lo, hi = rng
            pad = OUTPUT_RANGE_MARGIN * (hi - lo) + 1e-9 * (1.0 + np.maximum(np.abs(lo), np.abs(hi)))
            bad = np.nonzero((yy < lo - pad) | (yy > hi + pad))[0]
            if bad.size:
                j = int(bad[0])
                names = getattr(self, "output_names", ())
                label = names[j] if j < len(names) else f"y[{j}]"
                return (f"output {label} = {yy[j]:.6g} outside the model's range [{lo[j]:.6g}, {hi[j]:.6g}] "
                        f"by more than {OUTPUT_RANGE_MARGIN:g} of its width")
        return uu, yy

    def step(self, u, y) -> Estimate:
        """Process one sample ``(u(t), y(t))`` and return the estimate of ``x(t)``."""
        t0 = time.perf_counter()
        checked = self._validate_sample(u, y)
        if isinstance(checked, str):
            est = self._fallback(_safe_input(u, self.m), checked)
        else:
            est = self._step(*checked)
        return Estimate(est.x, est.mode, est.flag, time.perf_counter() - t0, est.info)

    def run(self, U, Y) -> ObserverTrace:
        """Run :meth:`step` over a recorded trace (subclasses may vectorise this)."""
        U = np.asarray(U, dtype=float).reshape(len(U), -1)
        Y = np.asarray(Y, dtype=float).reshape(len(Y), -1)
        if U.shape[0] != Y.shape[0]:
            raise ModelError("U, Y", "the same number of samples", f"{U.shape[0]} and {Y.shape[0]}")
        N = U.shape[0]
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
    x0 = np.asarray(x0, dtype=float).reshape(-1)
    if x0.shape != (n,) or not np.all(np.isfinite(x0)):
        raise ModelError("x0", f"a finite state of length {n}", f"{x0.tolist()}")
    return x0


def _safe_input(u, m: int) -> np.ndarray | None:
    """The input if it is usable for open-loop prediction, else ``None``."""
    try:
        uu = np.atleast_1d(np.asarray(u, dtype=float)).reshape(-1)
    except (TypeError, ValueError):
        return None
    return uu if uu.size == m and np.all(np.isfinite(uu)) else None


def initial_mode(q0, old_value, old_name: str):
    """The initial mode of a ``reset()``: ``q0``, or the value of its older keyword ``old_name``.

    Every observer takes the initial mode or location as ``q0``; the keywords some observers used
    before (``mode``, ``location``, ``region``) keep working.  Both given and different is an error.

    Raises
    ------
    ModelError
        ``q0`` and ``old_name`` are both given with different values.
    """
    if old_value is None:
        return q0
    if q0 is not None and q0 != old_value:
        from .errors import ModelError

        raise ModelError("q0", f"one initial mode (q0 and its old name {old_name!r} disagree)", f"q0={q0!r}, {old_name}={old_value!r}")
    return old_value

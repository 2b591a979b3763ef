"""A Kalman filter told the true mode sequence: the unattainable reference of a noise benchmark.

A hybrid observer on noisy data must find the mode sequence *and* filter the noise; a filter that
is given the true mode sequence only has to do the latter.  For a PWA system (paper 002, eq. 1)
with the mode sequence ``q(0), q(1), ...`` known, the system is linear time-varying and affine,

    x(k+1) = A_q x(k) + B_q u(k) + a_q + w(k),    y(k) = C_q x(k) + D_q u(k) + c_q + v(k),

with ``q = q(k)``, ``w ~ N(0, Q)``, ``v ~ N(0, R)`` independent and white, and ``x(0) ~ N(x0, P0)``.
The Kalman filter (Kalman 1960; Anderson & Moore, *Optimal Filtering*, 1979, Ch. 3) gives the
conditional mean and covariance of ``x(k)`` given ``y(0..k)``; with Gaussian noise it is the
minimum-variance estimator, so no observer of the same data does better on average: run on the
true mode sequence, it is the unattainable reference of the noise studies.

Convention.  Each :meth:`ModeSequenceKalmanFilter.step` with sample ``k`` does the *measurement
update* with ``y(k)`` (mode ``q(k)``), returns ``x(k|k)`` and its covariance ``P(k|k)``, then
does the *time update* to ``x(k+1|k)``, ``P(k+1|k)`` with ``u(k)`` and the same mode ``q(k)``.
The covariance update is the Joseph form ``(I - K C) P (I - K C)' + K R K'`` (symmetric and
positive semidefinite in floating point for any gain), symmetrised after every update.

Flags (:mod:`hybobs_opt.contract`): ``observable`` when the largest standard deviation of the
estimate, in units of the state box's half-widths, is below ``observable_std``
(:data:`~hybobs_opt.defaults.KALMAN_OBSERVABLE_STD`): the data pin the state down to a small fraction of its range.
Otherwise ``unobservable``.  A bad sample (not numeric, wrong length, NaN or Inf, outside the
model's ranges, or no valid mode) gives ``fallback`` with the reason in ``info["reason"]`` and a
time update only (the returned estimate is then the prediction ``x(k|k-1)``); it never raises.
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike

from .._validate import as_positive
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, ObserverTrace, UNOBSERVABLE, check_reset_keywords,
                        checked_state, judge_samples_against, noise_std_vector, trace_length)
from ..defaults import KALMAN_OBSERVABLE_STD
from ..errors import ModelError
from ..systems.pwa import PWASystem


@dataclass(frozen=True, eq=False)
class KalmanTrace(ObserverTrace):
    """:class:`~hybobs_opt.contract.ObserverTrace` of :meth:`ModeSequenceKalmanFilter.run` with the covariances.

    Parameters
    ----------
    x_hat, mode, flags, seconds, state_names, observer, info
        As for :class:`~hybobs_opt.contract.ObserverTrace`.
    covariance : (N, n, n) array
        ``covariance[k]`` is the covariance of ``x_hat[k]``: ``P(k|k)`` after a measurement
        update, ``P(k|k-1)`` at a ``fallback`` step (the same as ``info[k]["covariance"]``).

    See Also
    --------
    ModeSequenceKalmanFilter.run : Returns one.
    ObserverTrace : The common fields.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import ModeSequenceKalmanFilter
    >>> kf = ModeSequenceKalmanFilter(plant, 0.01, modes=truth.q)
    >>> trace = kf.run(U, truth.y + 0.01 * np.random.default_rng(0).standard_normal(truth.y.shape))
    >>> trace.covariance.shape, trace.std().shape
    ((40, 3, 3), (40, 3))
    >>> bool(np.isfinite(trace.nees(truth.x)).all())
    True
    """

    covariance: np.ndarray | None = None

    def std(self) -> np.ndarray:
        """``(N, n)`` standard deviations of the estimates (square roots of the covariances' diagonals).

        Returns
        -------
        ndarray
            ``(N, n)`` standard deviations of the estimates (square roots of the covariances'
            diagonals).
        """
        return np.sqrt(np.maximum(np.diagonal(self.covariance, axis1=1, axis2=2), 0.0))

    def nees(self, x_true: ArrayLike) -> np.ndarray:
        """``(N,)`` normalised estimation error squared ``e' P^-1 e`` with ``e = x_hat - x_true``.

        For a consistent filter its mean over runs is ``n`` (Bar-Shalom, Li & Kirubarajan,
        *Estimation with Applications to Tracking and Navigation*, 2001, Sec. 5.4).

        Returns
        -------
        ndarray
            ``(N,)`` normalised estimation error squared ``e' P^-1 e`` with ``e = x_hat - x_true``.
        """
        e = self.errors(x_true)
        return np.einsum("ki,ki->k", e, np.linalg.solve(self.covariance, e[:, :, None])[:, :, 0])


def _covariance(value, n: int, field: str, *, positive: bool) -> np.ndarray:
    """A scalar or ``(n,)`` standard deviation, or an ``(n, n)`` covariance, as an ``(n, n)`` covariance."""
    if value is None or isinstance(value, (str, bytes, bool)):
        raise ModelError(field, f"a standard deviation (scalar or length {n}) or an ({n}, {n}) covariance", repr(value))
    arr = np.asarray(value)
    if arr.dtype.kind not in "iuf":
        raise ModelError(field, "real numbers", f"an array of {arr.dtype}")
    arr = arr.astype(float)
    sign = "positive" if positive else "non-negative"
    if arr.ndim == 0 or arr.shape == (n,):
        if not (np.all(np.isfinite(arr)) and np.all(arr > 0 if positive else arr >= 0)):
            raise ModelError(field, f"{sign} finite standard deviations", repr(arr.tolist()))
        return np.diag(np.broadcast_to(arr, (n,)) ** 2)
    if arr.shape == (n, n):
        if not np.all(np.isfinite(arr)):
            raise ModelError(field, f"a finite ({n}, {n}) covariance", "non-finite entries")
        if not np.allclose(arr, arr.T, rtol=1e-12, atol=1e-14 * (1.0 + np.abs(arr).max())):
            raise ModelError(field, f"a symmetric ({n}, {n}) covariance", "an asymmetric matrix")
        arr = (arr + arr.T) / 2.0
        lam = np.linalg.eigvalsh(arr)
        floor = 1e-12 * max(1.0, float(np.abs(lam).max()))
        if (positive and lam.min() <= 0) or lam.min() < -floor:
            raise ModelError(field, f"a {sign}-definite covariance", f"smallest eigenvalue {lam.min():.3g}")
        return arr
    raise ModelError(field, f"a standard deviation (scalar or length {n}) or an ({n}, {n}) covariance",
                     f"shape {arr.shape}")


def _prior_covariance(value, n: int) -> np.ndarray:
    """``P0``: an ``(n,)`` vector of variances or an ``(n, n)`` positive-definite covariance."""
    arr = None if value is None or isinstance(value, (str, bytes, bool)) else np.asarray(value)
    if arr is not None and arr.dtype.kind in "iuf" and arr.shape == (n,):
        if not np.all(np.isfinite(arr) & (arr > 0)):
            raise ModelError("P0", "positive finite prior variances", repr(arr.tolist()))
        return np.diag(arr.astype(float))
    if arr is None or arr.shape != (n, n):
        raise ModelError("P0", f"prior variances (length {n}) or an ({n}, {n}) covariance",
                         repr(value) if arr is None else f"shape {arr.shape}")
    return _covariance(arr, n, "P0", positive=True)


class ModeSequenceKalmanFilter(Observer):
    """Time-varying Kalman filter of a PWA system (paper 002, eq. 1) told its true mode sequence.

    The measurement update with ``y(k)`` and the time update with ``u(k)`` both use mode
    ``q(k)``; the estimate returned by :meth:`step` for sample ``k`` is ``x(k|k)`` (module
    docstring).  Joseph-form covariance update, symmetrised.

    Parameters
    ----------
    system : PWASystem
        The plant; only its modes' ``A, B, a, C, D, c`` and its state box are used (not the guards).
    noise_std : float or (p,) array_like
        Standard deviation of the output noise ``v``, in output units (``R = diag(noise_std^2)``).
    process_std : float, (n,) array_like or (n, n) array_like, optional
        Process noise ``w``: a standard deviation per state (``Q = diag(process_std^2)``) or the
        covariance ``Q`` itself; ``0`` (default) for an exact model.
    x0 : (n,) array_like, optional
        Prior mean of ``x(0)``; default the centre of the state box (``system.scales()``, else
        ``system.state_bounds.bounding_box()``).
    P0 : (n,) array_like or (n, n) array_like, optional
        Prior covariance of ``x(0)`` (a vector is its diagonal of variances); default
        ``diag(half-width^2)`` of the state box.
    modes : (N,) array_like of int, optional
        The true mode sequence; step ``k`` uses ``modes[k]`` unless ``step(..., mode=q)`` says
        otherwise.
    observable_std : float, optional
        Threshold of the ``observable`` flag, a fraction of the state box's half-widths
        (default :data:`~hybobs_opt.defaults.KALMAN_OBSERVABLE_STD`).
    judge_ranges : bool, optional
        Judge samples against the model's input and output ranges and the estimate against its
        state set (:func:`~hybobs_opt.contract.judge_samples_against`; default ``True``).

    Raises
    ------
    ModelError
        Naming the field: ``system``, ``noise_std``, ``process_std``, ``x0``, ``P0``, ``modes``,
        ``observable_std``.

    See Also
    --------
    KalmanTrace : What ``run`` returns.
    hybobs_opt.mhe.MHEObserver : Estimates the modes too.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> trace = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), np.full((40, 1), 40.0))
    >>> y_noisy = trace.y + 0.01 * np.random.default_rng(0).standard_normal(trace.y.shape)
    >>> kf = ModeSequenceKalmanFilter(plant, 0.01, modes=trace.q)
    >>> out = kf.run(trace.u, y_noisy)
    >>> out.covariance[-1].shape, out.flag_counts()["observable"] > 0
    ((3, 3), True)
    """

    name = "kalman (true modes)"

    def __init__(self, system: PWASystem, noise_std, *, process_std=0.0, x0: ArrayLike | None = None,
                 P0: ArrayLike | None = None, modes: ArrayLike | None = None,
                 observable_std: float = KALMAN_OBSERVABLE_STD, judge_ranges: bool = True):
        if not isinstance(system, PWASystem):
            raise ModelError("system", "a PWASystem", type(system).__name__)
        self.system = system
        self.n, self.m, self.p = system.n, system.m, system.p
        self.state_names = tuple(system.state_names)
        self._A = np.array([md.A for md in system.modes])
        self._B = np.array([md.B.reshape(self.n, self.m) for md in system.modes])
        self._a = np.array([md.a for md in system.modes])
        self._C = np.array([md.C.reshape(self.p, self.n) for md in system.modes])
        self._D = np.array([(np.zeros((self.p, self.m)) if md.D is None else md.D.reshape(self.p, self.m)) for md in system.modes])
        self._c = np.array([(np.zeros(self.p) if md.c is None else md.c) for md in system.modes])
        self.noise_std = noise_std_vector(noise_std, self.p)
        self.R = np.diag(self.noise_std ** 2)
        self.Q = _covariance(process_std, self.n, "process_std", positive=False)
        observable_std = as_positive(observable_std, "observable_std", "a positive finite fraction of the state half-widths")
        self.observable_std = float(observable_std)
        if hasattr(system, "scales"):
            half, centre = (np.asarray(v, dtype=float)[: self.n] for v in system.scales())
        else:
            lo, hi = system.state_bounds.bounding_box()
            half, centre = (hi - lo) / 2.0, (hi + lo) / 2.0
        self.half_widths = np.where(half > 0, half, 1.0)
        self.x0 = centre.copy() if x0 is None else checked_state(x0, self.n, "x0")
        self.P0 = np.diag(self.half_widths ** 2) if P0 is None else _prior_covariance(P0, self.n)
        self.modes = None if modes is None else self._mode_sequence(modes, "modes")
        if judge_ranges:
            judge_samples_against(self, system)
        self.reset()

    # ------------------------------------------------------------------ contract
    def _mode_sequence(self, modes, field: str) -> np.ndarray:
        if isinstance(modes, (str, bytes)):
            raise ModelError(field, "a sequence of integer mode indices", repr(modes))
        arr = np.asarray(modes)
        if arr.ndim != 1 or arr.dtype.kind not in "iu":
            raise ModelError(field, f"a 1-D sequence of integer mode indices in 0..{len(self.system.modes) - 1}",
                             f"{arr.dtype} array of shape {arr.shape}")
        if arr.size and (arr.min() < 0 or arr.max() >= len(self.system.modes)):
            raise ModelError(field, f"mode indices in 0..{len(self.system.modes) - 1}",
                             f"values from {int(arr.min())} to {int(arr.max())}")
        return arr.astype(int)

    def reset(self, x0: ArrayLike | None = None, *, P0: ArrayLike | None = None, q0: int | None = None, k0: int = 0,
              **kwargs: Any) -> None:
        """Restart from the prior ``N(x0, P0)`` at sample index ``k0`` of the mode sequence.

        Parameters
        ----------
        x0 : (n,) array_like, optional
            Prior mean (default: the constructor's).
        P0 : (n, n) array_like, optional
            Prior covariance (default: the constructor's).
        q0 : int, optional
            Ignored (the mode of every step comes from the mode sequence); accepted for the contract.
        k0 : int, optional
            Index into the constructor's ``modes`` of the next sample (default 0).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        self._x = self.x0.copy() if x0 is None else checked_state(x0, self.n, "x0")
        self._P = self.P0.copy() if P0 is None else _prior_covariance(P0, self.n)
        self._k = int(k0)
        self._last_u = np.zeros(self.m)
        self._last_mode: int | None = None

    def _resolve_mode(self, mode) -> tuple[int | None, str | None]:
        if mode is None:
            if self.modes is None:
                return None, "no mode given (neither modes= at construction nor step(..., mode=q))"
            if not 0 <= self._k < len(self.modes):
                return None, f"sample {self._k} beyond the mode sequence of {len(self.modes)} samples"
            return int(self.modes[self._k]), None
        if isinstance(mode, bool) or not isinstance(mode, (int, np.integer)) or not 0 <= int(mode) < len(self.system.modes):
            return None, f"mode {mode!r:.40} is not an index in 0..{len(self.system.modes) - 1}"
        return int(mode), None

    def step(self, u, y, mode: int | None = None) -> Estimate:
        """Process sample ``k``: measurement update with ``y(k)``, return ``x(k|k)``, time update with ``u(k)``.

        Parameters
        ----------
        u : (m,) array_like
            Input ``u(k)``.
        y : (p,) array_like
            Output ``y(k)``.
        mode : int, optional
            The true mode ``q(k)``; default ``modes[k]`` of the constructor.

        Returns
        -------
        Estimate
            ``x(k|k)`` with ``info["covariance"] = P(k|k)``, ``info["mode"]``, ``info["innovation"]``
            and ``info["max_scaled_std"]``; at a bad sample the prediction ``x(k|k-1)``, flag
            ``fallback`` and ``info["reason"]``.  Never raises on a bad sample.
        """
        t0 = time.perf_counter()
        q, why = self._resolve_mode(mode)
        checked = self._validate_sample(u, y)
        if isinstance(checked, str):
            why = checked if why is None else f"{why}; {checked}"
        if why is not None:
            est = self._fallback(self._usable_input(u), why, q)
        else:
            est = self._update(*checked, q)
        self._k += 1
        est = self._judge_estimate(est)
        return Estimate(est.x, est.mode, est.flag, time.perf_counter() - t0, est.info)

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:  # contract hook (step() does not use it)
        q, why = self._resolve_mode(None)
        return self._fallback(u, why, None) if why is not None else self._update(u, y, q)

    def _scaled_std(self, P: np.ndarray) -> float:
        return float(np.max(np.sqrt(np.maximum(np.diag(P), 0.0)) / self.half_widths))

    def _update(self, u: np.ndarray, y: np.ndarray, q: int) -> Estimate:
        C, D, c = self._C[q], self._D[q], self._c[q]
        x, P = self._x, self._P
        r = y - (C @ x + D @ u + c)
        S = C @ P @ C.T + self.R
        S = (S + S.T) / 2.0
        K = np.linalg.solve(S, C @ P).T  # P C' S^-1 (S and P symmetric)
        x = x + K @ r
        IKC = np.eye(self.n) - K @ C
        P = IKC @ P @ IKC.T + K @ self.R @ K.T
        P = (P + P.T) / 2.0
        std = self._scaled_std(P)
        info = {"covariance": P.copy(), "mode": q, "innovation": r, "innovation_covariance": S,
                "max_scaled_std": std, "k": self._k}
        flag = OBSERVABLE if std < self.observable_std else UNOBSERVABLE
        self._time_update(x, P, u, q)
        return Estimate(x.copy(), q, flag, 0.0, info)

    def _time_update(self, x: np.ndarray, P: np.ndarray, u: np.ndarray, q: int) -> None:
        A = self._A[q]
        self._x = A @ x + self._B[q] @ u + self._a[q]
        P = A @ P @ A.T + self.Q
        self._P = (P + P.T) / 2.0
        self._last_u, self._last_mode = u, q

    def _fallback(self, u: np.ndarray | None, reason: str, q: int | None = None) -> Estimate:
        x, P = self._x.copy(), self._P.copy()
        info = {"covariance": P.copy(), "mode": -1 if q is None else q, "reason": reason,
                "max_scaled_std": self._scaled_std(P), "k": self._k}
        qq = q if q is not None else self._last_mode
        if qq is None:
            info["time_update"] = "none (no mode known yet): the prediction is held"
        else:
            if u is None:
                u = self._last_u
                info["time_update"] = f"mode {qq} with the last usable input (this sample's is unusable)"
            else:
                info["time_update"] = f"mode {qq}" + ("" if q is not None else " (the previous step's)")
            self._time_update(x, P, u, qq)
        return Estimate(x, -1 if q is None else q, FALLBACK, 0.0, info)

    def run(self, U, Y, modes: ArrayLike | None = None) -> KalmanTrace:
        """Run :meth:`step` over a recorded trace from the current state (call :meth:`reset` first to restart).

        Parameters
        ----------
        U : sequence of (m,) samples
        Y : sequence of (p,) samples
            Same number of rows as ``U``.
        modes : (N,) array_like of int, optional
            The true mode of every sample; default the constructor's ``modes`` from the current
            sample index.

        Returns
        -------
        KalmanTrace
            The estimates ``x(k|k)`` and their covariances.

        Raises
        ------
        ModelError
            If ``U``, ``Y`` (and ``modes``) are not sequences of the same length, or ``modes`` is
            not a sequence of mode indices.
        """
        nu = trace_length(U, Y)
        seq = None if modes is None else self._mode_sequence(modes, "modes")
        if seq is not None and len(seq) != nu:
            raise ModelError("modes", f"one mode per sample ({nu})", f"{len(seq)} modes")
        N = nu
        xs = np.full((N, self.n), np.nan)
        qs = np.full(N, -1)
        flags = np.empty(N, dtype=object)
        secs = np.zeros(N)
        covs = np.full((N, self.n, self.n), np.nan)
        infos = []
        for k in range(N):
            e = self.step(U[k], Y[k], None if seq is None else int(seq[k]))
            xs[k], qs[k], flags[k], secs[k], covs[k] = e.x, e.mode, e.flag, e.seconds, e.info["covariance"]
            infos.append(e.info)
        return KalmanTrace(xs, qs, flags, secs, self.state_names, self.name, tuple(infos), covs)

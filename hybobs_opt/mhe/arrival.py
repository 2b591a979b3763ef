"""The time-varying arrival cost of the moving-horizon observer (a Kalman filter run behind the
window) and the consistency test of the declared noise level on its innovations.

The constant weight certified for every mode sequence (an LMI) is
:func:`hybobs_opt.synthesis.arrival_weight.certified_arrival_prior`.
"""

from __future__ import annotations

import numpy as np

from ..defaults import CONSISTENCY_FALSE_ALARM, CONSISTENCY_WINDOW
from ..systems.pwa import PWASystem

__all__ = ["KalmanArrival", "NoiseConsistencyTest"]


class KalmanArrival:
    """The arrival cost of the moving-horizon observer by the filtering update (time-varying).

    Rao, Rawlings & Lee (2001) give the arrival cost that makes a moving-horizon estimate of a
    linear-Gaussian model equal the Kalman filter: the prior of the window-start state
    ``x(t-T+1)`` is the filter's one-step prediction ``x^(t-T+1 | t-T)`` from the data *before*
    the window, weighted by the inverse of its covariance ``P``.  This filter runs ``T - 1``
    samples behind the observer along the mode sequence the observer estimated (the mode of the
    sample leaving the window, from the window's certified optimum), with ``R = diag(noise_std^2)``
    and process noise ``Q``:

    ``x+ = A_q (x + K (y - C_q x - D_q u - c_q)) + B_q u + a_q``,
    ``P+ = A_q (P - K C_q P) A_q' + Q``, ``K = P C_q' (C_q P C_q' + R)^-1``.

    The prior is thus statistically consistent with the window's own data (no sample enters both),
    unlike the previous window's smoothed estimate.  It is exact for the linear model of the
    modes it is told; the modes are the observer's estimates, and the weight is the filter's
    information, not a bound that holds under every mode sequence (that is
    :func:`certified_arrival_prior`).

    Parameters
    ----------
    system : PWASystem
        The model (eq. 1 of paper 002).
    noise_std : (p,) array
        Output noise standard deviations.
    disturbance_cov : (n, n) array or None
        ``Q`` (``None``: no process noise).
    initial_std : (n,) array
        Standard deviation of the first prior's error (the ``x0`` of a reset).
    min_std : (n,) array
        Floor of the prior's standard deviations (keeps the weight's conditioning, and the
        observer's Hessian factorisable, after long observable stretches).

    See Also
    --------
    MHEObserver : Uses it with ``arrival_weight="kalman"``.
    hybobs_opt.observers.ModeSequenceKalmanFilter : The same filter told the true modes.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import KalmanArrival
    >>> arrival = KalmanArrival(plant, np.array([0.01]), None, np.array([0.1, 10.0, 1.0]),
    ...                         np.full(3, 1e-6))
    >>> arrival.reset(truth.x[0])
    >>> np.round(arrival.std(), 3)
    array([ 0.1, 10. ,  1. ])
    >>> arrival.advance(U[0], truth.y[0], int(truth.q[0]))
    >>> arrival.weight().shape, np.round(arrival.std(), 3)
    ((3, 3), array([0.1  , 0.278, 1.   ]))
    """

    def __init__(self, system: PWASystem, noise_std: np.ndarray, disturbance_cov: np.ndarray | None,
                 initial_std: np.ndarray, min_std: np.ndarray):
        self.system = system
        self.R = np.diag(np.asarray(noise_std, dtype=float) ** 2)
        self.Q = None if disturbance_cov is None else np.asarray(disturbance_cov, dtype=float)
        self.P0 = np.diag(np.asarray(initial_std, dtype=float) ** 2)
        self._floor = np.diag(np.asarray(min_std, dtype=float) ** 2)
        self.x = np.zeros(system.n)
        self.P = self.P0.copy()
        self.consistency = NoiseConsistencyTest(system.p)

    def reset(self, x0: np.ndarray) -> None:
        """Start again from ``x0`` with the initial covariance."""
        self.x = np.asarray(x0, dtype=float).copy()
        self.P = self.P0.copy()
        self.consistency.reset()

    def advance(self, u: np.ndarray, y: np.ndarray, q: int) -> None:
        """Take the sample ``(u, y)`` in mode ``q`` and predict the next state (Joseph form).

        Every sample is taken, however large its innovation: a filter that refuses samples once
        its prior is wrong keeps it wrong.  Measured on the noisy bench at 0.001 rad/s: gating
        innovations at 5 sigma put 6 start-up estimates beyond 5 sigma of their covariance
        instead of 2, and with the mode of the filter's own estimate for unanswered windows it
        let the prior drift 0.035 rad from the twist through a long backlash stay while stating
        a standard deviation of 2.4e-4.  Outliers are the window's business: a certified optimum
        that misses a sample by more than the fit tolerance is ``fallback``.
        """
        md = self.system.modes[int(q)]
        C, P = md.C, self.P
        S = C @ P @ C.T + self.R
        K = np.linalg.solve(S, C @ P).T
        nu = y - C @ self.x - md.D @ u - md.c
        self.consistency.add(float(nu @ np.linalg.solve(S, nu)))
        x = self.x + K @ nu
        IKC = np.eye(P.shape[0]) - K @ C
        Pf = IKC @ P @ IKC.T + K @ self.R @ K.T
        self.x = md.A @ x + md.B @ u + md.a
        Pn = md.A @ Pf @ md.A.T
        if self.Q is not None:
            Pn = Pn + self.Q
        self.P = 0.5 * (Pn + Pn.T)

    def weight(self) -> np.ndarray:
        """``W_a`` with ``W_a' W_a = (P + floor)^-1`` (symmetric square root).

        Returns
        -------
        ndarray
            ``W_a`` with ``W_a' W_a = (P + floor)^-1`` (symmetric square root).
        """
        w, V = np.linalg.eigh(self.P + self._floor)
        return (V / np.sqrt(w)) @ V.T

    def std(self) -> np.ndarray:
        """Standard deviations of the prior (the diagonal of ``P``, square-rooted).

        Returns
        -------
        ndarray
            Standard deviations of the prior (the diagonal of ``P``, square-rooted).
        """
        return np.sqrt(np.diag(self.P))


class NoiseConsistencyTest:
    """Do the filter's innovations agree with the stated noise level?

    With the right model, modes and noise level, the normalised innovation squared of the filter,
    ``nis(k) = nu(k)' S(k)^-1 nu(k)`` (``nu = y - C x^-``, ``S = C P C' + R``), is chi-square with
    ``p`` degrees of freedom, independently from sample to sample; the sum over the last
    ``window`` samples is chi-square with ``window p`` (Bar-Shalom, Li & Kirubarajan, "Estimation
    with applications to tracking and navigation", Wiley 2001, Section 5.4: the NIS test of filter
    consistency).  The test rejects the stated noise level when that sum exceeds its ``1 -
    false_alarm`` quantile; with fewer samples since a reset it tests the ones it has.  A rejection
    says that the data contradict the stated noise level, the model or the modes the filter was
    given -- it cannot say which -- and the observer withdraws its ``observable`` flags while it
    lasts: its covariance is only as good as the noise level it was computed from.

    Parameters
    ----------
    p : int
        Outputs per sample.
    window : int, default CONSISTENCY_WINDOW
        Samples summed.
    false_alarm : float, default CONSISTENCY_FALSE_ALARM
        Probability that the test rejects a correct noise level (per test).
    """

    def __init__(self, p: int, window: int = CONSISTENCY_WINDOW, false_alarm: float = CONSISTENCY_FALSE_ALARM):
        from collections import deque

        from scipy.stats import chi2

        self.p, self.window, self.false_alarm = int(p), int(window), float(false_alarm)
        self._values: deque = deque(maxlen=self.window)
        self._quantiles = [float(chi2.isf(self.false_alarm, k * self.p)) for k in range(1, self.window + 1)]

    def reset(self) -> None:
        self._values.clear()

    def add(self, nis: float) -> None:
        """One sample's normalised innovation squared (a non-finite one counts as a rejection)."""
        self._values.append(nis if np.isfinite(nis) else np.inf)

    def result(self) -> dict:
        """``consistent`` (None before the first sample), the sum, its threshold and the sample count."""
        k = len(self._values)
        if k == 0:
            return {"consistent": None, "samples": 0}
        total = float(sum(self._values))
        threshold = self._quantiles[k - 1]
        return {"consistent": bool(total <= threshold), "nis_sum": total, "threshold": threshold, "samples": k,
                "false_alarm": self.false_alarm}

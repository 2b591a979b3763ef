"""Step-by-step sliding-mode observer for hybrid systems in triangular form (paper 001, eq. 5).

Paper 001 (Djemai, Manamanni, Barbot) estimates the state of a switched system in the canonical
form (4), ``z1' = z2, ..., z_n' = f_q(z)``, ``y = z1``, with the observer (5)::

    zh1' = zh2 + lambda_1 sign(y - zh1)
    zh_j' = zh_{j+1} + E_{j-1} lambda_j sign(zt_j - zh_j)              (1 < j < n)
    zh_n' = f_q(y, zt_2, ..., zt_n) + E_{n-1} lambda_n sign(zt_n - zh_n)
    zt_{j+1} = zh_{j+1} + E_j {lambda_j sign(zt_j - zh_j)}_eq          (auxiliary states, zt_1 = y)

where ``{.}_eq`` is the equivalent value of the injection once stage ``j`` slides, the
anti-peaking switch ``E_j`` is 1 only when every stage ``1..j`` slides, and the mode ``q`` of
``f_q`` is chosen by the switching function evaluated on the auxiliary states (the estimated
switching indicator ``S_o`` of Figs. 5, 6, 9).

Sampled implementation (one Euler step per output sample, step ``h``; the fixed-step scheme of
:mod:`hybobs_opt.sim.fixed_step`, which the paper's discontinuous right-hand side needs):

- ``sign`` is discretised *implicitly*: ``lambda sign_h(e) = e / h`` when ``|e| <= h lambda``
  (the boundary layer a sampled sign cannot resolve) and ``lambda sign(e)`` outside.  Inside the
  layer the injection *is* the equivalent value, so no filter is needed to extract it, and the
  estimate does not chatter.  The explicit sampled sign was tried and rejected: its equivalent
  value must then be extracted with a low-pass filter whose lag, inside the next stage's relay
  loop, keeps that stage from ever sliding (measured on Example 2: stage 2 never slid for filter
  time constants of 5 to 100 samples).
- The equivalent value of stage ``j`` at sample ``k`` was produced by the previous estimate of
  the next state, so the auxiliary state is ``zt_{j+1}(k) = zh_{j+1}(k-1) + w_j(k)``: this makes
  ``zt_{j+1}`` the backward difference of ``zt_j`` (a one-sample-consistent equivalent value;
  with ``zh_{j+1}(k)`` instead, the stage-2 loop has a pole on the unit circle and oscillates).
- A stage slides (``E_j = 1``) after :data:`~hybobs_opt.defaults.SMO_SLIDING_HOLD` samples in
  its layer.  The estimate is clipped to the range of the canonical states (the model's operating
  box), which is what makes the explicit gain rule below valid.
- Optional first-order low-pass filter (time constant ``tau``) of the auxiliary states used for
  the switching decision only (``f_q`` still gets the raw ones): fewer spurious switches of
  ``S_o`` under noise, at the price of a delay (the trade-off of Figs. 5-6 and 9).  Every
  coordinate is filtered, ``y`` included, so that ``sigma`` sees one consistently delayed state:
  in Example 3 ``sigma(z) = (z2 + z3)/c1 - z1`` mixes all three, and filtering only ``zt_2,
  zt_3`` (as the paper does for Example 2, where ``sigma = x2``) would make ``sigma`` wrong by
  up to 0.4 for a 0.1 s filter.

Gains: :mod:`hybobs_opt.synthesis.sliding_mode_gains` (an explicit rule from the state and
derivative ranges).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import as_int, as_positive, as_vector
from ..errors import ModelError
from ..systems.canonical_form import ObservabilityForm, observability_form
from ..synthesis.sliding_mode_gains import GainRule, design_gains
from ..defaults import SMO_SLIDING_HOLD
from ..contract import FALLBACK, OBSERVABLE, WARMING_UP, Estimate, Observer, ObserverTrace, checked_state, judge_samples_against, sample_rows, check_reset_keywords

__all__ = ["IndicatorMetrics", "SlidingModeObserver", "SlidingModeRun", "convergence_times", "indicator_metrics"]


# ---------------------------------------------------------------------------------- observer
@dataclass(frozen=True, eq=False)
class SlidingModeRun:
    """Everything recorded by :meth:`SlidingModeObserver.run_detailed` (sample ``k`` in row ``k``).

    Attributes
    ----------
    trace : ObserverTrace
        The common contract: estimates of ``x`` (original coordinates), modes, flags, seconds.
    z_hat : (N, n) array
        Estimate in canonical coordinates (the state of eq. 5).
    z_tilde : (N, n) array
        Auxiliary states ``zt`` (``zt_1 = y``).
    z_switch : (N, n) array
        The states the switching decision used (``z_tilde``, or its low-pass filtered version).
    sliding : (N, n) bool array
        ``E_1 .. E_n`` (``E_n``: the last stage slides too).
    mode : (N,) int array
        Estimated switching indicator ``S_o``.
    """

    trace: ObserverTrace
    z_hat: np.ndarray
    z_tilde: np.ndarray
    z_switch: np.ndarray
    sliding: np.ndarray
    mode: np.ndarray


class SlidingModeObserver(Observer):
    """The step-by-step sliding-mode observer (5) of paper 001 on the common observer contract.

    Parameters
    ----------
    system : ObservabilityForm or HybridAutomaton
        A system in (or brought into, by :func:`observability_form`) the canonical form (4).
    Ts : float
        Sample period ``h`` (one Euler step of the observer per sample).
    gains : GainRule or sequence of float, optional
        Default: :func:`design_gains` (the explicit rule of the module).
    filter_tau : float, optional
        Time constant of the low-pass filter of the auxiliary states used for the switching
        decision; ``None`` (default) switches on the raw auxiliary states.
    hold : int
        Samples in the boundary layer before a stage's ``E_j`` closes.

    See Also
    --------
    hybobs_opt.observability_form : The canonical form (4) it needs.
    ObserverTrace : What ``run`` returns.

    Notes
    -----
    The estimate returned for sample ``k`` is the observer state ``x_hat(t_k)`` of eq. (5) (the
    quantity plotted in the paper's Figs. 4 and 8), integrated up to ``t_k``; ``y_k`` enters the
    auxiliary states (``info["z_tilde"]``), the mode ``S_o`` and the injections of the next step.
    ``step(u, y)`` takes ``u`` of length 0 (the system is autonomous).  A bad sample (NaN, wrong
    length) or a failing model evaluation gives an open-loop step flagged ``fallback``; all
    anti-peaking switches then reopen and the stages slide again one by one.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.observers import SlidingModeObserver

    Example 1 of paper 001 (two centres switched into an unstable system), 2 s, y = x1:

    >>> example = hy.get_example("switched_unstable")
    >>> truth = example.simulate(t_final=2.0)
    >>> form = hy.observability_form(example.build())
    >>> obs = SlidingModeObserver(form, 0.01)
    >>> trace = obs.run(None, truth.y)
    >>> trace.flag_counts()
    {'observable': 199, 'unobservable': 0, 'fallback': 0, 'warming_up': 2}
    >>> bool(np.abs(trace.x_hat[-1] - truth.x[-1]).max() < 0.05)
    True
    """

    name = "sliding-mode"

    def __init__(self, system, Ts: float, *, gains=None, filter_tau: float | None = None, hold: int = SMO_SLIDING_HOLD):
        form = system if isinstance(system, ObservabilityForm) else observability_form(system)
        Ts = as_positive(Ts, "Ts", "a positive finite sample period")
        filter_tau = as_positive(filter_tau, "filter_tau", "a positive time constant", allow_none=True)
        hold = as_int(hold, "hold", 1, "a number of samples >= 1 (an integer)")
        if gains is None:
            gains = design_gains(form)
        elif not isinstance(gains, GainRule):
            lam = as_vector(gains, "gains", form.n)  # complex gains refused, not cast
            if np.any(lam <= 0):
                raise ModelError("gains", f"{form.n} positive finite gains", repr(gains))
            gains = GainRule(np.array(lam), np.full(form.n, np.nan), float("nan"), "user-supplied gains")
        self.form = form
        self.gains = gains
        self.Ts = Ts
        self.filter_tau = filter_tau
        self.hold = hold
        a = form.automaton
        self.n, self.m, self.p = form.n, a.m, 1
        self.state_names = tuple(a.state_names)
        if self.filter_tau is not None:
            self.name = f"sliding-mode (filter {self.filter_tau:g} s)"
        # plain-Python copies: the per-sample loop on n <= 4 states is faster on floats than numpy
        self._lam = [float(v) for v in gains.lambdas]
        self._lo = [float(v) for v in form.z_lower]
        self._hi = [float(v) for v in form.z_upper]
        self._alpha = None if form.alpha is None else [[float(v) for v in row] for row in form.alpha]
        self._beta = None if form.beta is None else [float(v) for v in form.beta]
        self._G = [[float(v) for v in row] for row in form.invariant_G]
        self._g = [float(v) for v in form.invariant_g]
        self._starts = list(form.invariant_starts)
        self._flows = [loc.flow for loc in a.locations]
        self._u0 = np.zeros(a.m)
        self._a_filter = 0.0 if self.filter_tau is None else 1.0 - math.exp(-self.Ts / self.filter_tau)
        judge_samples_against(self, a)
        self.reset()

    # ------------------------------------------------------------------ state
    def reset(self, x0: np.ndarray | None = None, **kwargs: Any) -> None:
        """Start from ``x0`` (original coordinates; default: the centre of the operating box).

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial estimate in the original coordinates (default: the centre of the operating box).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        if x0 is None:
            z0 = 0.5 * (self.form.z_lower + self.form.z_upper)
        else:
            z0 = self.form.to_z(checked_state(x0, self.n))
        self._zh = [min(max(float(v), lo), hi) for v, lo, hi in zip(z0, self._lo, self._hi)]
        self._zprev = list(self._zh)
        self._count = [0] * self.n
        self._zf: list[float] | None = None

    # ------------------------------------------------------------------ model pieces
    def _mode(self, z: list[float]) -> int:
        G, g, st = self._G, self._g, self._starts
        best, best_v = 0, math.inf
        for q in range(len(st) - 1):
            worst = -math.inf
            for r in range(st[q], st[q + 1]):
                v = sum(a * b for a, b in zip(G[r], z)) - g[r]
                if v > worst:
                    worst = v
            if worst <= 0.0:
                return q
            if worst < best_v:
                best, best_v = q, worst
        return best

    def _f(self, q: int, z: list[float]) -> float:
        if self._alpha is not None:
            return sum(a * b for a, b in zip(self._alpha[q], z)) + self._beta[q]
        # identity coordinates (checked by observability_form): the flow takes z as x
        v = float(np.asarray(self._flows[q](np.array(z), self._u0), dtype=float).reshape(-1)[-1])
        if not math.isfinite(v):
            raise FloatingPointError(f"f_{q} is not finite at {z}")
        return v

    # ------------------------------------------------------------------ one sample
    def _advance(self, y: float) -> tuple[list[float], list[float], list[float], list[bool], int]:
        """Eq. (5) for one sample; returns ``(zh, zt, z_switch, E, q)`` at this sample."""
        n, h, lam = self.n, self.Ts, self._lam
        zh, zprev, count = self._zh, self._zprev, self._count
        zt = [0.0] * n
        zt[0] = y
        inj = [0.0] * n
        E = [False] * n
        active = True  # E_0 = 1: the first stage always injects
        for j in range(n):
            if active:
                e = zt[j] - zh[j]
                if abs(e) <= h * lam[j]:
                    w = e / h  # implicit sign: the equivalent value inside the boundary layer
                    count[j] += 1
                else:
                    w = lam[j] if e > 0.0 else -lam[j]
                    count[j] = 0
            else:
                w = 0.0
                count[j] = 0
            inj[j] = w
            E[j] = active and count[j] >= self.hold
            if j + 1 < n:
                zt[j + 1] = zprev[j + 1] + w if E[j] else zh[j + 1]
            active = E[j]
        if self.filter_tau is None:
            zs = zt
        else:
            if self._zf is None:
                self._zf = list(zt)
            a = self._a_filter
            zf = self._zf
            for j in range(n):
                zf[j] += a * (zt[j] - zf[j])
            zs = list(zf)
        q = self._mode(zs)
        fv = self._f(q, zt)
        new = [zh[j] + h * (zh[j + 1] + inj[j]) for j in range(n - 1)]
        new.append(zh[n - 1] + h * (fv + inj[n - 1]))
        self._zprev = zh
        self._zh = [min(max(v, lo), hi) for v, lo, hi in zip(new, self._lo, self._hi)]
        return zh, zt, zs, E, q

    def _open_loop(self) -> tuple[list[float], int]:
        """Open-loop Euler step of the model from the current estimate (no data)."""
        n, h, zh = self.n, self.Ts, self._zh
        q = self._mode(zh)
        try:
            fv = self._f(q, zh)
        except (FloatingPointError, ArithmeticError, ValueError, TypeError):
            fv = 0.0
        new = [zh[j] + h * zh[j + 1] for j in range(n - 1)]
        new.append(zh[n - 1] + h * fv)
        self._count = [0] * n
        self._zf = None
        self._zprev = zh
        self._zh = [min(max(v, lo), hi) for v, lo, hi in zip(new, self._lo, self._hi)]
        return zh, q

    def _x(self, z: list[float]) -> np.ndarray:
        return self.form.to_x(np.array(z))

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        try:
            zh, zt, zs, E, q = self._advance(float(y[0]))
        except (FloatingPointError, ArithmeticError, ValueError, TypeError) as exc:
            return self._fallback(u, f"model evaluation failed ({exc})")
        flag = OBSERVABLE if E[-1] else WARMING_UP
        return Estimate(self._x(zh), q, flag, 0.0, {"z_hat": list(zh), "z_tilde": zt, "z_switch": zs, "E": E})

    def _fallback(self, u, reason: str) -> Estimate:
        zh, q = self._open_loop()
        return Estimate(self._x(zh), q, FALLBACK, 0.0, {"reason": reason, "z_hat": list(zh)})

    # ------------------------------------------------------------------ whole runs
    def run_detailed(self, U, Y, x0: np.ndarray | None = None) -> SlidingModeRun:
        """Reset to ``x0`` and run eq. (5) over a recorded output (rows with NaN/Inf: fallback steps).

        Parameters
        ----------
        U : (N, 0) array or None
            Inputs (the system is autonomous; only the number of rows is used).
        Y : (N,) or (N, 1) array
            Output samples, one every ``Ts``.
        x0 : (n,) array, optional
            Initial estimate (original coordinates).

        Returns
        -------
        SlidingModeRun
            The estimates (canonical and model coordinates), the sliding indicators and the
            estimated
            mode per sample, with the common trace.
        """
        Y = sample_rows(Y, 1, "Y")
        if U is not None and len(U) != Y.shape[0]:
            raise ModelError("U, Y", "the same number of samples", f"{len(U)} and {Y.shape[0]}")
        self.reset(x0)
        N, n = Y.shape[0], self.n
        Zh, Zt, Zs = np.empty((N, n)), np.empty((N, n)), np.empty((N, n))
        Es = np.zeros((N, n), dtype=bool)
        modes = np.empty(N, dtype=int)
        flags = np.empty(N, dtype=object)
        secs = np.empty(N)
        clock = time.perf_counter
        for k in range(N):
            t0 = clock()
            y = float(Y[k, 0])
            ok = math.isfinite(y)
            if ok:
                try:
                    zh, zt, zs, E, q = self._advance(y)
                except (FloatingPointError, ArithmeticError, ValueError, TypeError):
                    ok = False
            if ok:
                Zh[k], Zt[k], Zs[k], Es[k], modes[k] = zh, zt, zs, E, q
                flags[k] = OBSERVABLE if E[-1] else WARMING_UP
            else:
                zh, q = self._open_loop()
                Zh[k], Zt[k], Zs[k], modes[k] = zh, zh, zh, q
                flags[k] = FALLBACK
            secs[k] = clock() - t0
        X = self.form.to_x(Zh)
        trace = ObserverTrace(X, modes, flags, secs, self.state_names, self.name)
        return SlidingModeRun(trace, Zh, Zt, Zs, Es, modes)

    def run(self, U, Y, x0: np.ndarray | None = None) -> ObserverTrace:
        """:meth:`run_detailed`, returning only the common :class:`ObserverTrace`.

        Parameters
        ----------
        U : (N, 0) array or None
            Inputs (the system is autonomous; only the number of rows is used).
        Y : (N,) or (N, 1) array
            Output samples, one every ``Ts``.
        x0 : (n,) array, optional
            Initial estimate (original coordinates).

        Returns
        -------
        ObserverTrace
            The common trace of :meth:`run_detailed`.
        """
        return self.run_detailed(U, Y, x0).trace


# ---------------------------------------------------------------------------------- metrics
def convergence_times(t: np.ndarray, err: np.ndarray, band) -> np.ndarray:
    """Per column of ``err``: the first time after which ``|err| <= band`` at every later sample.

    ``nan`` when the error is outside the band at the last sample.
    """
    t = np.asarray(t, dtype=float)
    err = np.abs(np.asarray(err, dtype=float)).reshape(t.size, -1)
    band = np.broadcast_to(np.asarray(band, dtype=float), (err.shape[1],))
    out = np.full(err.shape[1], np.nan)
    for j in range(err.shape[1]):
        bad = np.nonzero(~(err[:, j] <= band[j]))[0]
        if bad.size == 0:
            out[j] = t[0]
        elif bad[-1] < t.size - 1:
            out[j] = t[bad[-1] + 1]
    return out


@dataclass(frozen=True)
class IndicatorMetrics:
    """Agreement of the estimated switching indicator ``S_o`` with the true ``S`` (Figs. 5, 6, 9).

    Attributes
    ----------
    mismatch_fraction : float
        Share of samples with ``S_o != S``.
    true_switches, estimated_switches : int
    spurious_switches : int
        Switches of ``S_o`` after which ``S_o != S`` (early or chattering commutations).
    missed_switches : int
        Switches of ``S`` that ``S_o`` did not follow before ``S`` switched again.
    delay_median, delay_max : float
        Time from a switch of ``S`` until ``S_o`` agrees again (seconds; ``nan`` without switches).
    window : float
        Largest distance from a mismatched sample to the nearest switch of ``S`` (seconds): ``S_o``
        agrees with ``S`` except within this window around the switches (``inf`` if a mismatch
        happens with no switch at all, ``0`` without mismatch).
    """

    mismatch_fraction: float
    true_switches: int
    estimated_switches: int
    spurious_switches: int
    missed_switches: int
    delay_median: float
    delay_max: float
    window: float

    def to_dict(self) -> dict:
        return {k: _json_float(v) for k, v in self.__dict__.items()}


def indicator_metrics(t: np.ndarray, S: np.ndarray, So: np.ndarray) -> IndicatorMetrics:
    """Compare the estimated indicator ``So`` with the true ``S`` on the samples ``t``."""
    t = np.asarray(t, dtype=float)
    S = np.asarray(S).astype(int)
    So = np.asarray(So).astype(int)
    if not (t.shape == S.shape == So.shape):
        raise ModelError("t, S, So", "three arrays of the same length", f"{t.shape}, {S.shape}, {So.shape}")
    mism = So != S
    ks = np.nonzero(np.diff(S))[0] + 1
    ko = np.nonzero(np.diff(So))[0] + 1
    spurious = int(np.count_nonzero(So[ko] != S[ko])) if ko.size else 0
    delays, missed = [], 0
    ends = list(ks[1:]) + [t.size]
    for k, end in zip(ks, ends):
        agree = np.nonzero(~mism[k:end])[0]
        if agree.size:
            delays.append(t[k + agree[0]] - t[k])
        else:
            missed += 1
    if not mism.any():
        window = 0.0
    elif ks.size == 0:
        window = math.inf
    else:
        tm = t[mism]
        ts = t[ks]
        idx = np.clip(np.searchsorted(ts, tm), 1, ts.size) - 1
        d1 = np.abs(tm - ts[idx])
        d2 = np.abs(tm - ts[np.minimum(idx + 1, ts.size - 1)])
        window = float(np.max(np.minimum(d1, d2)))
    return IndicatorMetrics(
        float(np.mean(mism)) if mism.size else 0.0, int(ks.size), int(ko.size), spurious, missed,
        float(np.median(delays)) if delays else math.nan, float(np.max(delays)) if delays else math.nan, window,
    )


def _json_float(v):
    if isinstance(v, (float, np.floating)):
        return None if not math.isfinite(float(v)) else float(v)
    return v

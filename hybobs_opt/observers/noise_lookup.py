"""A lookup-table observer for noisy outputs: Algorithm 4.1 of paper 002 with statistical tests.

Paper 002 assumes noise-free outputs and says so (Section 8): with noise "there is no theoretical
guarantee that the set chi defined in (14) will be non-empty even if the true states are
observable".  Its lookup observer (:class:`~hybobs_opt.observers.lookup.LookupObserver`) then
fails in two ways: with ``T p = n`` every window fits some region exactly, so the noise reaches
the estimate through ``C_i^-1`` with nothing to say it is large, and with ``T p > n`` the exact
output equality (12) rejects every noisy window.  This observer keeps the algorithm's structure
(candidates per region, membership, uniqueness) and replaces each exact test by a test at a
stated false-alarm probability, for outputs ``y(k) = C_i x(k) + D_i u(k) + c_i + v(k)`` with
``v(k)`` white Gaussian noise of known standard deviations ``sigma`` (per output) and inputs
known exactly.

For every mode sequence ``i`` of the analysis (regions ``P_i`` of eq. 4, the set ``I`` of
full-rank sequences *and* the rank-deficient ones) and the window ``z = [Y_t; U_t]``, with the
whitened output map ``C~_i = W C_i`` (``W = diag(1/sigma)`` per sample) of rank ``r_i``:

1. **Least squares** (eq. 13 weighted): ``x_i = C~_i^+ W (Y_t - D_i U_t - f_i)``; when
   ``r_i = n`` its error is Gaussian with covariance ``S_i = (C~_i' C~_i)^-1`` if ``i`` is the
   true sequence.
2. **Residual test** (eq. 12 with noise): ``rho_i = ||(I - C~_i C~_i^+) W (Y_t - D_i U_t - f_i)||^2``
   is chi-square with ``T p - r_i`` degrees of freedom under the true sequence; it passes when
   ``rho_i <= chi2_{T p - r_i}^-1(1 - alpha / 2)``.
3. **Membership with a margin** (eq. 14 with noise): row ``h' [x; U] <= h0`` of ``P_i`` passes
   when ``h' [x_i; U_t] - h0 <= kappa_i s_r`` where ``s_r = ||C~_i^+' h_x||`` is the standard
   deviation of the row's value at ``x_i`` and ``kappa_i = Phi^-1(1 - alpha / (2 R_i))`` splits
   the other half of ``alpha`` over the ``R_i`` rows that involve the state (a union bound).
   Rows that only bound the inputs are noise-free and tested closed.  For a rank-deficient
   sequence the least-squares solutions form an affine set ``x_i + N_i w``; it passes when some
   ``w`` satisfies every row with its margin, decided by one certified LP
   (:func:`hybobs_opt.geometry.lp.max_slack`), after the residual test.

By construction the true mode sequence fails steps 2-3 with probability at most ``alpha``
(Bonferroni).  The flag is ``observable`` only when **exactly one** sequence passes and it has
``r_i = n``; the estimate is its ``x_i`` propagated to the current time through the region's
affine map (``Phi_last, Gamma_last, phi_last``), and ``info["covariance"]`` is
``Phi_last S_i Phi_last'``, the covariance of that estimate's error *if the passing sequence is the
true one* -- which the test cannot prove: what it proves is that every other sequence of the model
was rejected at false-alarm ``alpha`` each.  Several passing sequences, or one rank-deficient
sequence, leave the state undetermined: ``unobservable``, open-loop prediction (step 2.1 of
Algorithm 4.1), ``info["candidates"]`` says which passed.  No passing sequence means the window
contradicts the model at that level (a fault, a model error or a false alarm): also
``unobservable``, with that reason.  Bad samples (NaN, wrong length, input outside ``U``) are
``fallback``; fewer than ``T`` samples ``warming_up``.

Its answers are compared with the Kalman filter on the true mode sequence in the noise study of
paper 002 (``benchmarks/bench_noise.py``).

**Bounded noise** (``noise_bound=beta``: ``|v_j(k)| <= beta_j`` per output, and optionally
``input_noise_bound=gamma`` on measured inputs; ``T p >= n``).  The same tables with the weights
``W = diag(1 / beta)``; every quantity the tables compute is affine in the window's data
``z = [Y_t; U_t]``, and vanishes (residual) or holds (membership) at the true data ``z_true``, so
each statistical test becomes the condition the true mode sequence meets whatever the noise,
``|z - z_true| <= zb = [beta, ..., gamma, ...]``:

* residual: each row ``r' z + r_0`` of the whitened residual satisfies ``|r' z + r_0| <= |r|' zb``;
* membership: each row of ``P_i`` at ``(x_i, U_t)``, ``m' z + m_0 <= |m|' zb`` (a rank-deficient
  sequence: the same margins in the LP over its affine set).

Every mode sequence consistent with the window passes; a passing sequence of full rank puts the
current state within ``|Phi_last X_z + [0, Gamma_last]| zb`` of its ``x_i`` propagated to the
current time (``x_i = X_z z + x_0``), and a rank-deficient one anywhere in the state box.  The estimate is the centre of the smallest box
holding all of these (cut to ``X``), ``info["radius"]`` its half-width per state: an outer bound of
the set-membership box of :class:`~hybobs_opt.mhe.SetMembershipObserver` (the tests check that it
holds the exact box, and equals it noise-free wherever it flags), for the cost of the table's
matrix-vector product.  ``observable`` means every radius is within ``tolerance``; no passing
sequence proves that the window contradicts the model or the bound: ``fallback`` with that reason.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
from scipy.stats import chi2, norm

from .._validate import as_instance
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, UNOBSERVABLE, WARMING_UP, check_reset_keywords,
                        checked_state, false_alarm_probability, judge_samples_against, noise_bound_vector,
                        noise_std_vector, radius_tolerance_vector)
from ..errors import ModelError, SolverError
from ..geometry.lp import max_slack
from ..defaults import MHE_UNIQUENESS_DELTA, NOISE_LOOKUP_FALSE_ALARM
from ..tolerances import (BOUNDED_RESIDUAL_RTOL, LOOKUP_INPUT_BOUND_TOL, LOOKUP_MEMBERSHIP_TOL, RANK_RTOL,
                          SET_MEMBERSHIP_BOX_RTOL, ZERO_ROW_TOL)
from .lookup import input_bound_rows

__all__ = ["NoiseAwareLookupObserver"]


@dataclass(frozen=True, eq=False)
class _Sequence:
    """Offline data of one mode sequence (scaled and whitened; see the module docstring)."""

    index: int  # index in analysis.regions
    threshold: float  # chi-square quantile of the residual test
    rows: slice  # its rows in the stacked table: [x_i (n) | residual (pT) | membership (k)]
    n_member: int
    member_tol: np.ndarray  # allowed value of each membership row (original units)
    box_margin: float  # largest membership margin in units of the row norms (scaled)
    null: np.ndarray | None  # (n, n - r) null-space basis of C~_i in scaled state coordinates
    covariance_last: np.ndarray | None  # Phi_last S_i Phi_last' (full rank only)
    last: tuple  # (Phi_last, Gamma_last, phi_last, last mode)
    residual_tol: np.ndarray | None = None  # bounded noise: largest |whitened residual| per row
    amplification_last: np.ndarray | None = None  # bounded noise: |Phi_last C~_i^+| (w beta), full rank only


class NoiseAwareLookupObserver(Observer):
    """Lookup-table observer for noisy outputs: white Gaussian noise of stated standard deviations,
    or noise within stated bounds (see the module docstring).

    Parameters
    ----------
    analysis : ObservabilityAnalysis
        Result of Algorithm 3.1 at horizon ``T`` (``hybobs_opt.regions``): ``T p > n`` with
        ``noise_std`` (the residual test needs more output samples than states), ``T p >= n`` with
        ``noise_bound``.
    noise_std : float or (p,) array_like, optional
        Standard deviation of the output noise of each output, in output units (Gaussian noise).
    noise_bound : float, sequence or dict, optional
        Bound on each output's noise, in output units (bounded noise; 0 for noise-free data):
        every estimate then carries a certified radius.  Exactly one of ``noise_std`` and
        ``noise_bound`` is given.
    input_noise_bound : float, sequence or dict, optional
        With ``noise_bound``: a bound on each measured input's noise, in input units (default 0:
        the inputs are known exactly).
    false_alarm : float, default NOISE_LOOKUP_FALSE_ALARM
        Probability that the true mode sequence fails the tests of one window, in (0, 0.5)
        (Gaussian noise only).
    tolerance : float, sequence or dict, optional
        Bounded noise: the largest radius per state for the flag ``observable``, in the states'
        units; default ``MHE_UNIQUENESS_DELTA`` times the half-widths of the state box.

    Attributes
    ----------
    n_sequences : int
        Mode sequences tested per window.
    table_seconds : float
        Time to build the tables.

    See Also
    --------
    LookupObserver : The noise-free observer.
    hybobs_opt.mhe.SetMembershipObserver : Exact radii under bounded noise.

    Examples
    --------
    >>> from hybobs_opt.regions import analyse_observability
    >>> from hybobs_opt.studies import get_example
    >>> plant = get_example("powertrain3").build()
    >>> obs = NoiseAwareLookupObserver(analyse_observability(plant, 4), noise_std=0.01)
    >>> obs.n_sequences
    35
    """

    name = "lookup-noise"

    def __init__(self, analysis, noise_std=None, *, noise_bound=None, input_noise_bound=None,
                 false_alarm: float = NOISE_LOOKUP_FALSE_ALARM, tolerance=None):
        from .._numba_cache import tier_up

        tier_up()  # the compiled kernels now, not in the middle of a run of steps
        from ..regions.observability import ObservabilityAnalysis  # lazy: regions sits beside observers

        as_instance(analysis, "analysis", ObservabilityAnalysis,
                    "an ObservabilityAnalysis (Algorithm 3.1, hybobs_opt.regions; e.g. load_analysis(file))")
        system = analysis.system
        self.analysis, self.system, self.T = analysis, system, analysis.T
        self.n, self.m, self.p = system.n, system.m, system.p
        if (noise_std is None) == (noise_bound is None):
            raise ModelError("noise_std / noise_bound", "exactly one: the standard deviations of Gaussian output noise, "
                             "or a bound on each output's noise", f"noise_std={noise_std!r}, noise_bound={noise_bound!r}")
        self.bounded = noise_bound is not None
        if self.bounded:
            if self.T * self.p < self.n:
                raise ModelError("analysis", f"a horizon T with T p >= n = {self.n} (eq. 8)", f"T = {self.T}, p = {self.p}")
            self.noise_bound = noise_bound_vector(noise_bound, system.output_names)
            self.input_noise_bound = noise_bound_vector(0.0 if input_noise_bound is None else input_noise_bound,
                                                        system.input_names, "input_noise_bound")
            self.noise_std = None
            self.name = "lookup-bounded"
            half = system.scales()[0][: self.n]
            self.tolerance = radius_tolerance_vector(tolerance, system.state_names, MHE_UNIQUENESS_DELTA * half)
            #: widening of each side of the box (model units): rounding of the table's arithmetic
            self.box_pad = SET_MEMBERSHIP_BOX_RTOL * half
        else:
            for key, value in (("tolerance", tolerance), ("input_noise_bound", input_noise_bound)):
                if value is not None:
                    raise ModelError(key, "no value with noise_std (it belongs to noise_bound, bounded noise)", repr(value))
            if self.T * self.p <= self.n:
                raise ModelError("analysis", f"a horizon T with T p > n = {self.n} (the residual test needs more output "
                                 f"samples than states; T >= {self.n // self.p + 1} here)", f"T = {self.T}, p = {self.p}")
            self.noise_std = noise_std_vector(noise_std, self.p)
            self.noise_bound = None
        self.false_alarm = false_alarm_probability(false_alarm)
        self.state_names = system.state_names
        # bounded noise may push an output beyond the model's range: judge the inputs and the estimate only
        judge_samples_against(self, system, outputs=not self.bounded)
        t0 = time.perf_counter()
        self._build_tables()
        self.table_seconds = time.perf_counter() - t0
        self.n_lps = 0
        self.reset()

    # ------------------------------------------------------------------ offline tables
    def _build_tables(self) -> None:
        an, n, T, p, m = self.analysis, self.n, self.T, self.p, self.m
        scale, centre = an.enumeration.scale, an.enumeration.centre
        self._sx, self._cx = scale[:n], centre[:n]
        if self.bounded:
            # any positive weights give a left inverse of C_i; 1 / beta makes the whitened noise |e| <= 1
            beta = self.noise_bound
            unit = np.where(beta > 0, beta, beta.max() if beta.max() > 0 else 1.0)
            w = np.tile(1.0 / unit, T)
            # bounds of the noise on z = [Y; U] in its own units: every margin below is |row| @ zb
            zb = np.concatenate([np.tile(beta, T), np.tile(self.input_noise_bound, T)])
        else:
            w = np.tile(1.0 / self.noise_std, T)  # whitening of the stacked outputs
        I = set(an.index_set)
        blocks, offsets, seqs = [], [], []
        row = 0
        for idx, reg in enumerate(an.regions):
            Cw = w[:, None] * reg.C
            Cs = Cw * self._sx[None, :]  # scaled state coordinates: conditioning of the rank test
            U_, s, Vt = np.linalg.svd(Cs, full_matrices=True)
            r = int(np.count_nonzero(s > RANK_RTOL * max(s[0] if s.size else 0.0, 1.0)))
            if (r == n) != (idx in I):
                raise ModelError("analysis", f"regions whose rank of C_i agrees with the set I (region {idx})",
                                 f"rank {r} of the whitened C_i against membership in I = {idx in I}")
            Cp = np.linalg.pinv(Cw, rcond=RANK_RTOL * (s[0] if s.size else 1.0))  # x = Cp W (Y - D U - f)
            Q = np.eye(p * T) - Cw @ Cp
            # x_i, and the whitened residual, affine in z = [Y; U]
            Xz = np.hstack([Cp * w[None, :], -Cp @ (w[:, None] * reg.D)])
            x0 = -Cp @ (w * reg.f)
            Rz = np.hstack([Q * w[None, :], -Q @ (w[:, None] * reg.D)])
            r0 = -Q @ (w * reg.f)
            Hx, HU = reg.H[:, :n], reg.H[:, n:]
            Mz = np.hstack([Hx @ Xz[:, : p * T], Hx @ Xz[:, p * T :] + HU])
            m0 = Hx @ x0 - reg.h
            # each row's noise standard deviation at x_i (bounded: the largest deviation of its value);
            # rows without it are input bounds (closed)
            s_row = np.abs(Mz) @ zb if self.bounded else np.linalg.norm(Hx @ Cp, axis=1)
            row_norm = np.linalg.norm(reg.H * scale[None, :], axis=1)
            row_norm = np.where(row_norm > 0, row_norm, 1.0)
            state_rows = np.linalg.norm(Hx * self._sx[None, :], axis=1) > ZERO_ROW_TOL * row_norm
            R = int(np.count_nonzero(state_rows))
            alpha = self.false_alarm
            if self.bounded:  # the margins are the noise's largest effect: no quantile
                kappa, threshold = 1.0, np.inf
            else:
                kappa = float(norm.isf(alpha / (2 * R))) if R else 0.0
                threshold = float(chi2.isf(alpha / 2 if R else alpha, p * T - r))
            closed = input_bound_rows(reg.H, reg.h, self.system, T, scale, centre) | ~state_rows
            if self.bounded:  # every row's largest change under the noise (input rows: the input noise)
                tol = s_row + LOOKUP_INPUT_BOUND_TOL * row_norm
            else:
                tol = np.where(closed, LOOKUP_INPUT_BOUND_TOL * row_norm, kappa * s_row + LOOKUP_INPUT_BOUND_TOL * row_norm)
            null = None if r == n else Vt[r:].T
            cov_last = None
            if r == n:
                S = Cp @ Cp.T
                cov_last = reg.Phi_last @ S @ reg.Phi_last.T
                cov_last = (cov_last + cov_last.T) / 2
            k = reg.H.shape[0]
            box_margin = float(np.max(tol / row_norm)) if k else 0.0
            res_tol = amp_last = None
            if self.bounded:
                # the residual of the true sequence at the true data is 0: |Rz z| = |Rz (z - z_true)| <= |Rz| zb
                res_tol = np.abs(Rz) @ zb
                if r == n:  # x_true(t) - x_i(t) = -(Phi_last Xz + [0, Gamma_last]) (z - z_true)
                    amp_last = np.abs(reg.Phi_last @ Xz + np.hstack([np.zeros((n, p * T)), reg.Gamma_last])) @ zb
            seqs.append(_Sequence(idx, threshold, slice(row, row + n + p * T + k), k, tol, box_margin, null, cov_last,
                                  (reg.Phi_last, reg.Gamma_last, reg.phi_last, reg.sequence[-1]), res_tol, amp_last))
            blocks += [Xz, Rz, Mz]
            offsets += [x0, r0, m0]
            row += n + p * T + k
        self._seqs = tuple(seqs)
        # index arrays of the vectorised tests (one reduceat per test)
        self._res_idx = np.concatenate([np.arange(q.rows.start + n, q.rows.start + n + p * T) for q in seqs])
        self._res_starts = np.arange(len(seqs)) * (p * T)
        self._mem_idx = np.concatenate([np.arange(q.rows.start + n + p * T, q.rows.stop) for q in seqs])
        self._mem_starts = np.cumsum([0] + [q.n_member for q in seqs[:-1]])
        self._mem_tol = np.concatenate([q.member_tol for q in seqs])
        self._thresholds = np.array([q.threshold for q in seqs])
        if self.bounded:
            self._res_tol = np.concatenate([q.residual_tol for q in seqs])
        self.n_sequences = len(seqs)
        self._table = np.ascontiguousarray(np.vstack(blocks))
        self._offset = np.concatenate(offsets)
        lo, hi = self.system.state_bounds.bounding_box()
        self._x_lo, self._x_hi = lo, hi
        if m and self.system.input_bounds is not None:
            IA, Ib = self.system.input_bounds.A, self.system.input_bounds.b
            inrm = np.linalg.norm(IA * scale[None, n : n + m], axis=1)
            self._in_A, self._in_b = IA, Ib + LOOKUP_INPUT_BOUND_TOL * np.where(inrm > 0, inrm, 1.0)
            if self.bounded:  # a measured input may lie outside U by its noise
                self._in_b = self._in_b + np.abs(IA) @ self.input_noise_bound
        else:
            self._in_A, self._in_b = None, None

    # ------------------------------------------------------------------ state
    def reset(self, x0: np.ndarray | None = None, **kwargs) -> None:
        """Clear the window; ``x0`` (default: centre of the state box) seeds open-loop prediction.

        Parameters
        ----------
        x0 : (n,) array, optional
            Seed of open-loop prediction.
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        if x0 is None:
            x0 = self.analysis.enumeration.centre[: self.n]
        self._x = checked_state(x0, self.n).copy()
        self._Y = np.zeros((self.T, self.p))
        self._U = np.zeros((self.T, self.m))
        self._count = 0  # consecutive good samples in the window
        self._uprev: np.ndarray | None = None
        self._mode = -1
        self._started = False  # a sample was processed since the reset

    # ------------------------------------------------------------------ online
    def _predict(self, u_prev: np.ndarray | None) -> tuple[bool, str]:
        """Open-loop prediction ``x <- f_q(x, u_prev)`` (step 2.1 of Algorithm 4.1)."""
        if u_prev is None:
            if not self._started:  # the first sample: the seed is the estimate
                return True, ""
            return False, "no open-loop prediction: the previous sample was bad"
        x = np.clip(self._x, self._x_lo, self._x_hi)
        q = int(self.system.modes_of(x[None, :], u_prev[None, :])[0])
        if q < 0:
            return False, "no open-loop prediction: the estimate lies in no mode's region of X x U"
        md = self.system.modes[q]
        self._x = md.A @ x + md.B @ u_prev + md.a
        self._mode = q
        return True, ""

    def _consistent_family(self, seq: _Sequence, v: np.ndarray, viol: np.ndarray) -> bool:
        """Does some point ``x_i + N_i w`` of a rank-deficient sequence meet every row with its margin?

        One certified LP (:func:`hybobs_opt.geometry.lp.max_slack`: DAQP with both bounds checked, HiGHS
        when they do not decide) over ``w`` in scaled coordinates.  Besides the rows of ``P_i`` it
        bounds ``x_i + N_i w`` by the state box widened by the largest margin of the rows, so the
        LP's radius bound holds whatever rows the region kept.
        """
        n = self.n
        reg = self.analysis.regions[seq.index]
        N = seq.null
        xs = (v[:n] - self._cx) / self._sx
        G = np.vstack([(reg.H[:, :n] * self._sx[None, :]) @ N, N, -N])
        widen = 1.0 + seq.box_margin
        g = np.concatenate([-viol, widen - xs, widen + xs])
        radius = float(np.sqrt(n) * widen + np.linalg.norm(xs))
        self.n_lps += 1
        res = max_slack(G, g, radius_bound=radius, threshold=-LOOKUP_MEMBERSHIP_TOL,
                        problem=f"noise-aware lookup: membership of the rank-deficient mode sequence {reg.sequence}")
        return bool(res.lower > -LOOKUP_MEMBERSHIP_TOL)

    def _test_window(self, z: np.ndarray) -> tuple[np.ndarray, list[int], np.ndarray]:
        """Steps 1-3 of the module docstring for every sequence: the table's values at ``z``, the
        indices of the passing sequences and every sequence's residual ``rho_i``."""
        vals = self._table @ z + self._offset
        if self.bounded:
            # rho_i: the largest excess of a residual row over its bound, in whitened units; rounding
            # of the table's arithmetic is allowed for relative to the data (more candidates, never fewer)
            res = vals[self._res_idx]
            slack = BOUNDED_RESIDUAL_RTOL * (1.0 + float(np.max(np.abs(res), initial=0.0)))
            rho = np.maximum.reduceat(np.abs(res) - self._res_tol, self._res_starts)
            fits = rho <= slack
        else:
            r2 = vals[self._res_idx] ** 2
            rho = np.add.reduceat(r2, self._res_starts)
            fits = rho <= self._thresholds
        viol = vals[self._mem_idx] - self._mem_tol
        worst = np.maximum.reduceat(viol, self._mem_starts)
        passed = []
        for k in np.nonzero(fits)[0]:
            seq = self._seqs[k]
            if worst[k] <= 0.0:
                passed.append(int(k))
            elif seq.null is not None:
                a = self._mem_starts[k]
                if self._consistent_family(seq, vals[seq.rows], viol[a : a + seq.n_member]):
                    passed.append(int(k))
        return vals, passed, rho

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        if self._in_A is not None and np.any(self._in_A @ u > self._in_b):
            return self._fallback(None, "input outside the input set U: the model does not cover it")
        u_prev, self._uprev = self._uprev, u.copy()
        ok, why = self._predict(u_prev)  # x(t) from x(t-1): the estimate unless the window decides
        self._started = True
        self._Y = np.roll(self._Y, -1, axis=0)
        self._U = np.roll(self._U, -1, axis=0)
        self._Y[-1], self._U[-1] = y, u
        self._count = min(self._count + 1, self.T)
        if self._count < self.T:
            return Estimate(self._x.copy(), self._mode, WARMING_UP if ok else FALLBACK, 0.0,
                            {} if ok else {"reason": why})
        z = np.concatenate([self._Y.reshape(-1), self._U.reshape(-1)])
        try:
            vals, passed_idx, rho = self._test_window(z)
        except SolverError as exc:
            info = {"reason": f"membership LP failed: {exc}"}
            return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, info)
        passed = [self._seqs[k] for k in passed_idx]
        residuals = {s.index: float(rho[k]) for k, s in zip(passed_idx, passed)}
        cands = [self.analysis.regions[s.index].sequence for s in passed]
        if self.bounded:
            return self._bounded_estimate(vals, passed, cands, ok, why)
        if len(passed) == 1 and passed[0].null is None:
            seq = passed[0]
            x_start = vals[seq.rows][: self.n]
            Pl, Gl, pl, qlast = seq.last
            self._x = Pl @ x_start + Gl @ self._U.reshape(-1) + pl
            self._mode = int(qlast)
            info = {"candidates": cands, "residual": residuals[seq.index], "residual_threshold": seq.threshold,
                    "covariance": seq.covariance_last.copy(), "x_start": x_start}
            return Estimate(self._x.copy(), self._mode, OBSERVABLE, 0.0, info)
        if not passed:
            note = (f"no mode sequence passes the tests at false-alarm {self.false_alarm:g}: the window contradicts the "
                    "model (a fault, a model error, or a false alarm)")
        elif len(passed) == 1:
            note = "the only passing mode sequence is rank-deficient: the data do not determine the state"
        else:
            note = f"{len(passed)} mode sequences pass the tests: the data do not tell the state"
        info = {"candidates": cands, "note": note}
        if not ok:
            info["reason"] = why
        return Estimate(self._x.copy(), self._mode, UNOBSERVABLE if ok else FALLBACK, 0.0, info)

    def _bounded_estimate(self, vals: np.ndarray, passed: list, cands: list, ok: bool, why: str) -> Estimate:
        """The box of the current states every passing sequence allows (bounded noise), its centre and radius."""
        if not passed:
            info = {"candidates": [], "reason": "no mode sequence fits the window within the stated noise bound (each "
                    "violates a necessary condition): the data contradict the model or the bound"}
            if not ok:
                info["reason"] += f"; {why}"
            return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, info)
        lo_x, hi_x = self._x_lo, self._x_hi
        lower, upper = np.full(self.n, np.inf), np.full(self.n, -np.inf)
        Uw = self._U.reshape(-1)
        modes = set()
        for seq in passed:
            Pl, Gl, pl, qlast = seq.last
            modes.add(int(qlast))
            if seq.null is not None:  # the data leave a direction free: only the state box bounds it
                lower, upper = np.minimum(lower, lo_x), np.maximum(upper, hi_x)
                continue
            x_last = Pl @ vals[seq.rows][: self.n] + Gl @ Uw + pl
            lower = np.minimum(lower, x_last - seq.amplification_last)
            upper = np.maximum(upper, x_last + seq.amplification_last)
        # the plant stays in X (the model's assumption): the box is cut to it
        lower = np.maximum(lower, lo_x) - self.box_pad
        upper = np.minimum(upper, hi_x) + self.box_pad
        upper = np.maximum(upper, lower)
        x = 0.5 * (lower + upper)
        radius = 0.5 * (upper - lower)
        self._x = x
        self._mode = modes.pop() if len(modes) == 1 else -1
        flag = OBSERVABLE if np.all(radius <= self.tolerance) else UNOBSERVABLE
        info = {"radius": radius, "lower": lower, "upper": upper, "tolerance": self.tolerance, "candidates": cands}
        if not ok:
            info["note"] = why
        return Estimate(x.copy(), self._mode, flag, 0.0, info)

    def _fallback(self, u, reason: str) -> Estimate:
        # a bad sample breaks the window: the next T samples rebuild it
        self._count = 0
        ok, why = self._predict(self._uprev)
        self._started = True
        self._uprev = None if u is None else np.asarray(u, dtype=float)
        return Estimate(self._x.copy(), self._mode, FALLBACK, 0.0, {"reason": reason if ok else f"{reason}; {why}"})

    def stats(self) -> dict:
        """Offline time, sequences tested per window and the LPs solved so far.

        Returns
        -------
        dict
            Offline time, sequences tested per window and the LPs solved so far.
        """
        return {"table_seconds": self.table_seconds, "n_sequences": self.n_sequences,
                "n_full_rank": int(sum(s.null is None for s in self._seqs)), "n_lps": self.n_lps,
                "false_alarm": None if self.bounded else self.false_alarm,
                "noise": "bounded" if self.bounded else "gaussian"}

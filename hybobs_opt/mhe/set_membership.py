"""Set-membership state estimation of a PWA system under bounded output noise: every estimate
with a certified radius.

The user states a bound ``beta_i`` on the noise of each output (``|y_i(k) - y^_i(k)| <= beta_i``,
in the model's units).  The states consistent with a window of ``T`` samples are then

    S_t = { x(t) : a trajectory x(t-T+1), ..., x(t) of the model in X, with modes whose guards
            hold, and |y(k) - C_i x(k) - D_i u(k) - c_i| <= beta for every sample of the window },

the set of feasible states of the PWA set-membership problem (Bemporad, Mignone & Morari,
"Moving horizon estimation for hybrid systems and fault detection", ACC 1999, whose MLD
encoding of the trajectories the moving-horizon observer of paper 002 uses too; Alessandri,
Baglietto & Battistelli, "Receding-horizon estimation for switching discrete-time linear
systems", IEEE TAC 50(11), 2005, for the bounded-noise view).  :class:`SetMembershipObserver`
computes the bounding box of ``S_t`` exactly: for each state coordinate, the least and the
largest value over ``S_t`` are two mixed-integer linear programs on the MLD rows of the window
(:func:`~hybobs_opt.mhe.mld.encode_mld`) with the outputs bounded by ``beta``, solved to a zero
gap by HiGHS.  The estimate is the centre of the box and its radius the half-width per state:
whenever the data satisfy the noise bound and the model is exact, the true state lies in
``S_t``, hence within the radius of the estimate.  ``observable`` means every radius is within
the tolerance (default ``delta`` of the state box's half-widths, as the MHE's uniqueness test).
Noise-free (``beta = 0``), the radius is zero exactly where the state is unique.
"""

from __future__ import annotations

import time
from collections import deque

import numpy as np

from ..errors import ModelError
from ..status import Status
from ..defaults import MHE_UNIQUENESS_DELTA, SET_MEMBERSHIP_SEQUENCES_PER_STATE
from ..tolerances import MHE_FEASIBILITY_TOL, MHE_INTEGRALITY_TOL, SET_MEMBERSHIP_BOUND_RTOL, SET_MEMBERSHIP_BOX_RTOL
from .backends.highs_backend import HighspyBackend
from .mld import encode_mld
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, UNOBSERVABLE, WARMING_UP, check_reset_keywords,
                        judge_samples_against, noise_bound_vector, radius_tolerance_vector)

__all__ = ["SetMembershipObserver", "noise_bound_vector"]


class SetMembershipObserver(Observer):
    """Bounding box of the states consistent with the last ``T`` samples under bounded output
    noise (module docstring): the estimate is its centre, ``info["radius"]`` its half-width per
    state, certified by mixed-integer programs solved to a zero gap.

    Parameters
    ----------
    system : PWASystem
        The model, with bounded ``X`` and ``U``.
    T : int
        Window length (``T >= 1``).
    noise_bound : float, sequence or dict
        Bound on each output's noise in the outputs' units (:func:`noise_bound_vector`); 0 for
        noise-free data.
    tolerance : float, sequence or dict, optional
        Largest radius per state for the flag ``observable``, in the states' units (a number, n
        numbers or a dict by state name); default ``MHE_UNIQUENESS_DELTA`` times the half-widths
        of ``X``'s bounding box.
    x0 : (n,) array, optional
        Initial guess for the first ``T - 1`` samples and open-loop prediction.
    max_sequences : int, optional
        Windows with at most this many feasible mode sequences are bounded sequence by sequence
        (one feasibility MILP each, then 2n LPs); others by the 2n per-state MILPs.  Default
        :data:`~hybobs_opt.defaults.SET_MEMBERSHIP_SEQUENCES_PER_STATE` times ``n``; 0 uses the
        per-state MILPs only.  Both give the same box (to HiGHS's tolerances); only the time differs.

    See Also
    --------
    hybobs_opt.observers.SetMembershipFilter : The recursive set over all samples so far.
    MHEObserver : The least-squares estimate of the same window.
    hybobs_opt.observers.NoiseAwareLookupObserver : The lookup observer under bounded noise.

    Notes
    -----
    Flags: ``observable`` -- every radius within the tolerance; ``unobservable`` -- some radius
    beyond it (the estimate is still the centre of the box, and the radius says how far off it
    can be); ``fallback`` -- a bad sample, no state consistent with the window (the data
    contradict the model or the stated bound: ``info["reason"]`` says so), or a program without
    a checked answer; ``warming_up`` -- fewer than ``T`` samples.  ``info`` holds ``radius``,
    ``lower`` and ``upper`` (the box, model units), ``tolerance`` and ``mode_sequences`` (the
    distinct mode sequences of the extreme points), and ``box_by`` (``"mode sequences"`` or
    ``"per-state MILPs"``).

    Each bound of the per-state MILPs is HiGHS's dual bound of its MILP (zero gap), whose extreme point is re-checked in
    numpy: MLD rows and output bounds within :data:`~hybobs_opt.tolerances.MHE_FEASIBILITY_TOL`,
    binaries integral, and its value within the reported bound.  The MILPs hold their rows to
    HiGHS's feasibility tolerance, so each side of the box is widened by ``box_pad``
    (:data:`~hybobs_opt.tolerances.SET_MEMBERSHIP_BOX_RTOL` of the state box's half-widths):
    noise-free, a unique state has a radius of ``box_pad``, not 0.  Sequence by sequence, each
    LP's bound is proven by weak duality from HiGHS's row duals and the LP's point is checked the
    same way; HiGHS's "infeasible" on the last feasibility MILP (all sequences found so far cut
    off) is its proof that no other sequence fits, as its dual bounds are for the MILPs.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.mhe import MHEObserver

    The powertrain of paper 002 (model (16)), 10 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((10, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.mhe import SetMembershipObserver
    >>> obs = SetMembershipObserver(plant, 3, 0.001)        # |output noise| <= 0.001 rad/s
    >>> trace = obs.run(U[:5], truth.y[:5])
    >>> trace.flag_counts()
    {'observable': 3, 'unobservable': 0, 'fallback': 0, 'warming_up': 2}
    >>> radius = trace.info[-1]["radius"]
    >>> bool(np.all(np.abs(trace.x_hat[-1] - truth.x[4]) <= np.asarray(radius) + 1e-9))
    True
    """

    name = "set-membership"

    def __init__(self, system, T: int, noise_bound, *, tolerance=None, x0=None, max_sequences: int | None = None):
        from ..systems.pwa import PWASystem

        if not isinstance(system, PWASystem):
            raise ModelError("system", "a PWASystem with bounded X and U", type(system).__name__)
        if isinstance(T, bool) or not isinstance(T, (int, np.integer)) or T < 1:
            raise ModelError("T", "a window length T >= 1 (an integer)", repr(T))
        from ..limits import MAX_HORIZON

        if T > MAX_HORIZON:
            raise ModelError("T", f"a window length T <= {MAX_HORIZON} (hybobs_opt.limits.MAX_HORIZON)", repr(T))
        self.system, self.T = system, int(T)
        self.n, self.m, self.p = system.n, system.m, system.p
        self.state_names = tuple(system.state_names)
        self.noise_bound = noise_bound_vector(noise_bound, system.output_names)
        self.enc = encode_mld(system, self.T)
        half, centre = system.scales()
        self.tolerance = radius_tolerance_vector(tolerance, self.state_names, MHE_UNIQUENESS_DELTA * half[:self.n])
        #: widening of each side of the box (model units): the MILPs' feasibility tolerance
        self.box_pad = SET_MEMBERSHIP_BOX_RTOL * half[:self.n]
        # the data enter through the row bounds only (outputs within the stated bound): judge the
        # inputs and the estimate against the model, not the outputs, which the noise may push out
        judge_samples_against(self, system, outputs=False)
        enc = self.enc
        A = np.vstack([enc.A, enc.Ymap])
        last = enc.Xmap[self.T - 1]  # x(t) = last v + Xoff[T-1]
        self._last, self._last_off = last, enc.Xoff[self.T - 1]
        self._A = A
        self._programs, self._lps = [], []
        continuous = np.zeros_like(enc.discrete)
        for j in range(self.n):
            pair, lps = [], []
            for sign in (1.0, -1.0):  # minimise x_j, then -x_j (the largest x_j)
                c = sign * last[j]
                pair.append(HighspyBackend(c, A, enc.lb, enc.ub, enc.discrete, {}))
                lps.append(HighspyBackend(c, A, enc.lb, enc.ub, continuous, {}))
            self._programs.append(pair)
            self._lps.append(lps)
        self._feasibility = HighspyBackend(np.zeros(A.shape[1]), A, enc.lb, enc.ub, enc.discrete, {})
        self._delta = np.flatnonzero(enc.discrete)
        if max_sequences is None:
            max_sequences = max(1, int(SET_MEMBERSHIP_SEQUENCES_PER_STATE * self.n))
        if isinstance(max_sequences, bool) or not isinstance(max_sequences, (int, np.integer)) or max_sequences < 0:
            raise ModelError("max_sequences", "a number of mode sequences >= 0 (0: the per-state MILPs only)",
                             repr(max_sequences))
        self.max_sequences = int(max_sequences)
        self._x_default = centre[:self.n].copy()
        self.reset(x0)

    def reset(self, x0=None, **kwargs) -> None:
        """Forget the window; ``x0`` is the guess of the first ``T - 1`` samples."""
        check_reset_keywords(kwargs, type(self).__name__)
        from ..contract import checked_state

        if x0 is not None:
            self._x_default = checked_state(x0, self.n)
        self._x = self._x_default.copy()
        self._U: deque = deque(maxlen=self.T)
        self._Y: deque = deque(maxlen=self.T)

    def _predict(self, u: np.ndarray | None) -> np.ndarray:
        try:
            nxt = np.asarray(self.system.step(self._x, u), dtype=float) if u is not None else self._x
        except Exception:  # outside every guard: keep the last estimate
            nxt = self._x
        return nxt if np.all(np.isfinite(nxt)) else self._x

    def _fallback(self, u, reason: str) -> Estimate:
        self._U.clear()
        self._Y.clear()
        self._x = self._predict(u)
        return Estimate(self._x.copy(), -1, FALLBACK, 0.0, {"reason": reason})

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        self._U.append(u)
        self._Y.append(y)
        if len(self._U) < self.T:
            self._x = self._predict(u)
            return Estimate(self._x.copy(), -1, WARMING_UP, 0.0, {})
        box = self.consistent_box(np.array(self._U), np.array(self._Y))
        if box["status"] != "ok":
            self._x = self._predict(u)
            return Estimate(self._x.copy(), -1, FALLBACK, 0.0, {"reason": box["reason"], **box})
        lower, upper = box["lower"], box["upper"]
        x = 0.5 * (lower + upper)
        radius = 0.5 * (upper - lower)
        flag = OBSERVABLE if np.all(radius <= self.tolerance) else UNOBSERVABLE
        self._x = x
        seqs = box["mode_sequences"]
        mode = seqs[0][-1] if len({s[-1] for s in seqs}) == 1 else -1
        info = {"radius": radius, "lower": lower, "upper": upper, "tolerance": self.tolerance,
                "mode_sequences": seqs, "box_by": box["box_by"], "seconds_programs": box["seconds"]}
        return Estimate(x.copy(), int(mode), flag, 0.0, info)

    def consistent_box(self, U: np.ndarray, Y: np.ndarray) -> dict:
        """The bounding box of the states at the window's last sample consistent with ``(U, Y)``.

        Parameters
        ----------
        U : (T, m) ndarray
            Window inputs.
        Y : (T, p) ndarray
            Window outputs.

        Returns
        -------
        dict
            ``status`` ``"ok"`` with ``lower``, ``upper`` ((n,) arrays, model units) and
            ``mode_sequences``; ``"inconsistent"`` (no model trajectory within the noise bound,
            proven by HiGHS) or ``"not certified"``, with ``reason``; ``seconds``.
        """
        t0 = time.perf_counter()
        enc, T = self.enc, self.T
        Uf = np.asarray(U, dtype=float).reshape(-1)
        Yf = np.asarray(Y, dtype=float).reshape(-1)
        lo, hi = enc.bounds(Uf)
        beta = np.tile(self.noise_bound, T)
        yfix = Yf - enc.YU @ Uf - enc.Yoff
        lo_all = np.concatenate([lo, yfix - beta])
        hi_all = np.concatenate([hi, yfix + beta])
        by_sequences = self._box_by_sequences(Uf, Yf, lo, hi, beta, lo_all, hi_all)
        if by_sequences is not None:
            by_sequences["seconds"] = time.perf_counter() - t0
            return by_sequences
        lower, upper = np.empty(self.n), np.empty(self.n)
        seqs: list[tuple[int, ...]] = []
        for j in range(self.n):
            for side, backend in zip((0, 1), self._programs[j]):
                out = backend.solve(None, lo_all, hi_all)
                if out.status == Status.INFEASIBLE:
                    return {"status": "inconsistent", "seconds": time.perf_counter() - t0,
                            "reason": "no model trajectory fits the window within the stated noise bound (HiGHS "
                                      "proved the MILP infeasible): the data contradict the model or the bound"}
                if out.status != Status.OPTIMAL:
                    return {"status": "not certified", "seconds": time.perf_counter() - t0,
                            "reason": f"MILP of the {'least' if side == 0 else 'largest'} {self.state_names[j]} on "
                                      f"HiGHS: status {out.detail.get('status')!r}"}
                v = out.v
                why = self._check_point(v, Uf, Yf, lo, hi, beta)
                value = float(self._last[j] @ v + self._last_off[j])
                bound = float(out.detail.get("dual_bound", np.nan))
                if side == 1:
                    bound = -bound
                bound = bound + self._last_off[j] if np.isfinite(bound) else np.nan
                slack = SET_MEMBERSHIP_BOUND_RTOL * (1.0 + abs(value))
                if why is None and not np.isfinite(bound):
                    why = "no finite dual bound"
                if why is None and (bound < value - slack if side == 0 else bound > value + slack):
                    why = f"dual bound {bound:.9g} on the wrong side of the point's value {value:.9g}"
                if why is not None:
                    return {"status": "not certified", "seconds": time.perf_counter() - t0,
                            "reason": f"MILP of the {'least' if side == 0 else 'largest'} {self.state_names[j]}: {why}"}
                # the box: the proven bound, never a point inside it
                if side == 0:
                    lower[j] = min(bound, value)
                else:
                    upper[j] = max(bound, value)
                seq = tuple(int(q) for q in enc.modes(v))
                if seq not in seqs:
                    seqs.append(seq)
        return {"status": "ok", "lower": lower - self.box_pad, "upper": upper + self.box_pad, "mode_sequences": seqs,
                "box_by": "per-state MILPs", "seconds": time.perf_counter() - t0}

    def _box_by_sequences(self, Uf, Yf, lo, hi, beta, lo_all, hi_all) -> dict | None:
        """The box as the union of the boxes of the window's feasible mode sequences: each is found
        by a feasibility MILP that excludes the ones before (no-good cuts on the mode binaries)
        and bounded by 2n LPs with its binaries fixed, each LP bound proven by weak duality from
        HiGHS's row duals (:meth:`_dual_bound`).  ``None`` -- more than :attr:`max_sequences`
        sequences, or an answer this path cannot certify: the per-state MILPs decide.  The last
        feasibility MILP, infeasible, is HiGHS's proof that no other sequence fits."""
        delta = self._delta
        lower, upper = np.full(self.n, np.inf), np.full(self.n, -np.inf)
        seqs: list[tuple[int, ...]] = []
        feas = self._feasibility
        try:
            while True:
                out = feas.solve(None, lo_all, hi_all)
                if out.status == Status.INFEASIBLE:
                    break
                if out.status != Status.OPTIMAL or len(seqs) == self.max_sequences:
                    return None
                if self._check_point(out.v, Uf, Yf, lo, hi, beta) is not None:
                    return None
                d = np.round(out.v[delta])
                col_lo, col_hi = self.enc.lb.astype(float), self.enc.ub.astype(float)  # this sequence's columns
                col_lo[delta] = col_hi[delta] = d
                for j in range(self.n):
                    for side in (0, 1):
                        lp = self._lps[j][side]
                        res = lp.solve(None, lo_all, hi_all, col_bounds=(delta, d, d))
                        if res.status != Status.OPTIMAL or self._check_point(res.v, Uf, Yf, lo, hi, beta) is not None:
                            return None  # the MILP's point has these modes: the LP must be feasible
                        sign = 1.0 if side == 0 else -1.0
                        value = float(self._last[j] @ res.v)
                        bound = sign * self._dual_bound(sign * self._last[j], lp.row_duals(), lo_all, hi_all,
                                                        col_lo, col_hi)
                        slack = SET_MEMBERSHIP_BOUND_RTOL * (1.0 + abs(value))
                        if not np.isfinite(bound) or (bound < value - slack if side == 0 else bound > value + slack):
                            return None
                        if side == 0:
                            lower[j] = min(lower[j], min(bound, value) + self._last_off[j])
                        else:
                            upper[j] = max(upper[j], max(bound, value) + self._last_off[j])
                seqs.append(tuple(int(q) for q in self.enc.modes(out.v)))
                ones = d > 0.5
                feas.add_cut(delta, np.where(ones, -1.0, 1.0), 1.0 - float(ones.sum()))
        finally:
            feas.drop_cuts()
        if not seqs:
            return {"status": "inconsistent", "reason": "no model trajectory fits the window within the stated noise "
                                                        "bound (HiGHS proved the MILP infeasible): the data contradict "
                                                        "the model or the bound"}
        return {"status": "ok", "lower": lower - self.box_pad, "upper": upper + self.box_pad, "mode_sequences": seqs,
                "box_by": "mode sequences"}

    def _dual_bound(self, c, y, lo_all, hi_all, col_lo, col_hi) -> float:
        """A lower bound on ``c @ v`` over the LP's set, proven by weak duality for any row
        multipliers ``y``: ``c v = y (A v) + (c - A' y) v``, each term bounded below over its row
        or column interval (``col_lo``, ``col_hi``: the mode binaries fixed); a multiplier facing
        an infinite row bound is dropped."""
        y = np.where((y > 0) & ~np.isfinite(lo_all) | (y < 0) & ~np.isfinite(hi_all), 0.0, y)
        rows = np.where(y > 0, y * np.where(np.isfinite(lo_all), lo_all, 0.0),
                        y * np.where(np.isfinite(hi_all), hi_all, 0.0))
        r = c - self._A.T @ y
        cols = np.minimum(r * col_lo, r * col_hi)
        return float(rows.sum() + cols.sum())

    def _check_point(self, v, Uf, Yf, lo, hi, beta) -> str | None:
        """Why the MILP point ``v`` is not a trajectory of the window within the noise bound (``None``: it is)."""
        enc = self.enc
        if not np.all(np.isfinite(v)):
            return "point with NaN/Inf"
        d = v[enc.discrete]
        if np.max(np.abs(d - np.round(d)), initial=0.0) > MHE_INTEGRALITY_TOL:
            return "fractional binaries"
        w = v.copy()
        w[enc.discrete] = np.round(d)
        rows = enc.A @ w
        scale = 1.0 + np.abs(lo[np.isfinite(lo)]).max(initial=0.0) + np.abs(hi[np.isfinite(hi)]).max(initial=0.0)
        viol = max(np.max(lo - rows, initial=0.0), np.max(rows - hi, initial=0.0),
                   np.max(enc.lb - w, initial=0.0), np.max(w - enc.ub, initial=0.0))
        if viol > MHE_FEASIBILITY_TOL * scale:
            return f"MLD rows violated by {viol:.3g}"
        res = np.abs(Yf - enc.outputs(w, Uf).reshape(-1))
        over = np.max(res - beta, initial=0.0)
        if over > MHE_FEASIBILITY_TOL * (1.0 + np.abs(Yf).max(initial=0.0)):
            return f"outputs beyond the noise bound by {over:.3g}"
        return None

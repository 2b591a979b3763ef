"""Continuous observer and the composed hybrid observer of paper 000 (Balluchi et al.), Sections
3.2-3.3, run on the observer contract.  Their gains come from
:mod:`hybobs_opt.synthesis.continuous_design` (an LMI with a common Lyapunov matrix), the location
observer's generators from :mod:`hybobs_opt.synthesis.location_design`.  The Fig. 6 scenario of the
paper is the study :mod:`hybobs_opt.studies.paper000_driveline.scenario`.

*Continuous observer* (eq. 15): ``x~' = F_i x~ + B_i u + E_i + G_i (y - D_i u - c_i)``,
``F_i = A_i - G_i C_i``, switched on the location estimate of the location observer (the
constant terms ``E_i`` are added as in footnote 1 of the paper).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from .._validate import as_instance, as_int, as_positive
from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, ObserverTrace, WARMING_UP, check_reset_keywords,
                        checked_index, initial_mode, initial_state, innovation_excess, judge_samples_against,
                        sample_rows)
from ..defaults import INNOVATION_MARGIN, INNOVATION_PATIENCE, TRANSIENT_FRACTION
from ..errors import ModelError
from ..synthesis.continuous_design import ContinuousDesign, ConvergenceBound
from ..synthesis.location_design import ResidualBank, affine_key, sampled_observer
from ..systems.hybrid import HybridAutomaton
from .error_bound import ErrorBound, induced_log_norm
from .location_logic import AMBIGUOUS, IDENTIFIED
from .location_observer import LocationObserver, detection_delays


class ContinuousObserver(Observer):
    """The continuous observer ``H_cntobs`` (eq. 15, Fig. 5 of paper 000) on the observer contract.

    ``step(u, y)`` propagates the estimate over the last sample with the gain of
    :attr:`location` (set it from a location observer, or use :class:`HybridObserver`).

    Parameters
    ----------
    design : ContinuousDesign
    Ts : float
    x0 : array, optional
    location : int
        Initial location used for the gains.

    See Also
    --------
    HybridObserver : Sets its location from a location observer.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.studies.paper000_driveline import scenario as paper

    The driveline of paper 000 with its low elasticity, 0.2 s of the Fig. 6 scenario, and the
    paper's designs (residual generators, continuous observer):

    >>> example = hy.get_example("driveline")
    >>> aut = example.build(k=paper.DRIVELINE_K_LOW)
    >>> truth = example.simulate(t_final=0.2, k=paper.DRIVELINE_K_LOW)
    >>> bank = hy.design_residual_bank(aut, paper.DRIVELINE_DELTA, paper.DRIVELINE_EPSILON,
    ...                                paper.DRIVELINE_Z0, invariant_rtol=paper.DRIVELINE_INVARIANT_RTOL)
    >>> design = hy.design_continuous_observer(aut, paper.DRIVELINE_DECAY,
    ...                                        gain_bound=paper.DRIVELINE_GAIN_BOUND,
    ...                                        state_box=paper.DRIVELINE_X, input_box=paper.DRIVELINE_U)
    >>> from hybobs_opt.observers import ContinuousObserver
    >>> obs = ContinuousObserver(design, float(truth.t[1] - truth.t[0]),
    ...                          x0=np.array(paper.DRIVELINE_X0_GUESS))

    Told the true locations, its error decays at the designed rate:

    >>> trace = obs.run_with_locations(truth.u, truth.y, truth.q)
    >>> bool(np.linalg.norm(trace.x_hat[-1] - truth.x[-1]) < np.linalg.norm(trace.x_hat[0] - truth.x[0]))
    True
    """

    name = "continuous"

    def __init__(self, design: ContinuousDesign, Ts: float, *, x0: np.ndarray | None = None, location: int = 0):
        as_instance(design, "design", ContinuousDesign, "a ContinuousDesign (design_continuous_observer)")
        Ts = as_positive(Ts, "Ts", "a positive sampling period")
        aut = design.automaton
        what = f"an integer location index in 0..{aut.n_locations - 1}"  # not None: reset(q0=None) restarts here
        location = as_int(location, "location", 0, what)
        if location >= aut.n_locations:
            raise ModelError("location", what, repr(location))
        self.design = design
        self.automaton = aut
        self.Ts = Ts
        self.n, self.m, self.p = aut.n, aut.m, aut.p
        self.state_names = aut.state_names
        judge_samples_against(self, aut)
        self._mats = []
        self._ol = []
        for q in range(aut.n_locations):
            A, B, E, C, D, c = affine_key(aut, q)
            G = design.gain(q)
            self._mats.append(sampled_observer(A, B, E, C, D, c, G, self.Ts))
            self._ol.append(sampled_observer(A, B, E, C, D, c, np.zeros_like(G), self.Ts)[:2])
        P = np.asarray(design.P, dtype=float)
        P_inv = np.linalg.inv(P)
        self._P, self._P_inv_diag = P, np.diag(P_inv)
        # per location: (C, D, c) and sqrt(C_j P^-1 C_j') for the innovation test (INNOVATION_MARGIN)
        self._outputs = []
        for q in range(aut.n_locations):
            _, _, _, C, D, c = affine_key(aut, q)
            self._outputs.append((C, D, c, np.sqrt(np.einsum("ij,jk,ik->i", C, P_inv, C))))
        rng = self.output_range
        width = None if rng is None else rng[1] - rng[0]
        self._innovation_floor = (INNOVATION_MARGIN * width if width is not None and np.all(np.isfinite(width))
                                  else None)
        self._log_rate = [induced_log_norm(mats[0], P) for mats in self._mats]
        self._log_rate_ol = [induced_log_norm(ol[0], P) for ol in self._ol]
        self._bound = ErrorBound(*design.state_box)
        self._loc0 = int(location)
        self._x0 = x0
        self.reset(x0, q0=location)

    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, location: int | None = None,
              **kwargs: Any) -> None:
        """Restart at ``x0`` in location ``q0`` (``location``: its deprecated name; default: the constructor's).

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial estimate (default: the previous one, else the centre of the state bounds).
        q0 : int, optional
            Initial location (default: the constructor's ``location``).
        location : int, optional
            Deprecated name of ``q0`` (a ``FutureWarning``; removed in 0.2.0).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        field = "location" if location is not None else "q0"  # errors name the keyword the caller used
        q0 = initial_mode(q0, location, "location")
        x0 = initial_state(x0, self._x0, self.automaton.state_bounds, self.n)
        loc = self._loc0 if q0 is None else checked_index(q0, self.automaton.n_locations, field, "location index")
        self._x0 = x0
        self.x = x0.copy()
        self.location = loc
        self._u_prev: np.ndarray | None = None
        self._y_prev: np.ndarray | None = None
        self._bound.start(self.x, self._P)
        self._input_unknown = False
        self._contradictions = 0

    def _innovation_excess(self, u: np.ndarray, y: np.ndarray) -> str | None:
        """Why the residual ``y - (C x + D u + c)`` of the current estimate exceeds what the error
        bound allows plus :data:`~hybobs_opt.defaults.INNOVATION_MARGIN` (``None`` if it does not)."""
        if self._innovation_floor is None:
            return None
        C, D, c, C_norms = self._outputs[self.location]
        r = y - (C @ self.x + (D @ u if D is not None and D.size else 0.0) + c)
        allowed = self._bound.output_bound(C_norms) + self._innovation_floor
        return innovation_excess(r, allowed, y, self.output_names)

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        saved = (self.x.copy(), self._bound.save(), self._u_prev, self._y_prev, self._input_unknown)
        est = self._closed_loop_step(u, y)
        why = self._innovation_excess(u, y)
        if why is None:
            self._contradictions = 0
            return est
        self._contradictions += 1
        if self._contradictions <= INNOVATION_PATIENCE:  # one bad sample: undo the step, run it open loop
            self.x, log_b, self._u_prev, self._y_prev, self._input_unknown = saved
            self._bound.restore(log_b)
            return self._fallback(u, why)
        # a persistent contradiction: the bound's hypotheses failed; take the sample, restart the bound
        self._contradictions = 0
        self._bound.start(self.x, self._P)
        return Estimate(est.x, est.mode, self._flag(), 0.0,
                        dict(est.info, error_bound=self.error_bound().tolist(),
                             reason=why + f" on {INNOVATION_PATIENCE + 1} samples: the error bound restarts"))

    def _closed_loop_step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        if self._u_prev is not None and self._y_prev is None:
            # the previous sample was refused: open loop over the interval it leaves without output
            Ad, Bw = self._ol[self.location]
            self.x = Ad @ self.x + Bw @ np.concatenate([self._u_prev, np.zeros(self.p), [1.0]])
            self._bound.contract(self._log_rate_ol[self.location])
        elif self._u_prev is not None:
            Ad, Bw, Bd = self._mats[self.location]
            self.x = Ad @ self.x + Bw @ np.concatenate([self._u_prev, self._y_prev, [1.0]]) + Bd @ (y - self._y_prev)
            self._bound.contract(self._log_rate[self.location])
        if self._input_unknown:  # the last interval ran on a refused sample's input: no bound holds
            self._input_unknown = False
            self._bound.start(self.x, self._P)
        self._u_prev, self._y_prev = u, y
        return Estimate(self.x.copy(), self.location, self._flag(), 0.0, {"error_bound": self.error_bound().tolist()})

    def error_bound(self) -> np.ndarray:
        """Certified bound on ``|x_hat_k - x_k|`` per state (:mod:`~hybobs_opt.observers.error_bound`):
        from the reset, the sampled error map of each step's location contracts the design's
        ``P``-norm.  It assumes the location used is the plant's (for the hybrid observer, add the
        neighbourhood ``M0`` of Proposition 3.3.1 of paper 000).

        Returns
        -------
        ndarray
            Certified bound on ``|x_hat_k - x_k|`` per state
            (:mod:`~hybobs_opt.observers.error_bound`): from the reset, the sampled error map of
            each step's location contracts the design's ``P``-norm.  It assumes the location
            used is the plant's (for the hybrid observer, add the neighbourhood ``M0`` of
            Proposition 3.3.1 of paper 000).
        """
        return self._bound.per_state(self._P_inv_diag)

    def _flag(self) -> str:
        """``observable`` once :meth:`error_bound` is below the convergence fraction of the state box."""
        return OBSERVABLE if self._bound.converged(self._P_inv_diag) else WARMING_UP

    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        if self._u_prev is not None:
            Ad, Bw = self._ol[self.location]
            self.x = Ad @ self.x + Bw @ np.concatenate([self._u_prev, np.zeros(self.p), [1.0]])
            self._bound.contract(self._log_rate_ol[self.location])
        self._input_unknown = u is None and self._u_prev is not None
        if u is not None:
            self._u_prev = u
        self._y_prev = None
        return Estimate(self.x.copy(), self.location, FALLBACK, 0.0, {"reason": reason})

    def run_with_locations(self, U, Y, Q) -> ObserverTrace:
        """Run with a given location sequence (e.g. the true one): ``Q[k]`` is used after sample ``k``.

        Parameters
        ----------
        U : (N, m) array_like
            Inputs.
        Y : (N, p) array_like
            Outputs.
        Q : (N,) int array_like
            Location used for the gains after each sample (``Q[0]`` also at the start).

        Returns
        -------
        ObserverTrace
            The estimates of the run.
        """
        U, Y = sample_rows(U, self.m, "U"), sample_rows(Y, self.p, "Y")
        Q = np.asarray(Q, dtype=int).reshape(-1)
        if not (U.shape[0] == Y.shape[0] == Q.shape[0]):
            raise ModelError("U, Y, Q", "the same number of samples", f"{U.shape[0]}, {Y.shape[0]}, {Q.shape[0]}")
        self.reset(q0=int(Q[0]))
        N = U.shape[0]
        xs, modes, flags, secs = np.zeros((N, self.n)), np.zeros(N, int), np.empty(N, dtype=object), np.zeros(N)
        for k in range(N):
            e = self.step(U[k], Y[k])
            xs[k], modes[k], flags[k], secs[k] = e.x, e.mode, e.flag, e.seconds
            self.location = int(Q[k])
        return ObserverTrace(xs, modes, flags, secs, self.state_names, self.name)


@dataclass(frozen=True, eq=False)
class HybridRun:
    """A run of :class:`HybridObserver`: the continuous estimate and the location observer's signals.

    Parameters
    ----------
    x_hat : (N, n) array
        The continuous observer's estimates.
    location : (N,) int array
        Estimated location (``-1`` when ambiguous / none).
    held : (N,) int array
        The location observer's held location.
    status : (N,) object array
        The location observer's status per step.
    residuals : (N, G) array
        ``||r_j||`` per generator.
    sigma : (N, G) bool array
        Decisions of eq. (8).
    consistent : (N, Q) bool array
        Per location: ``sigma`` of its generator and the invariant test.
    generator_states : (N, G, n) array
        States of the residual generators.
    seconds : (N,) array
        Compute time per step.
    trace : ObserverTrace
        The run on the common contract.

    See Also
    --------
    HybridObserver.run_detailed : Returns one.
    summarise_run : Measures it against the design's bound.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.studies.paper000_driveline import scenario as paper

    The driveline of paper 000 with its low elasticity, 0.2 s of the Fig. 6 scenario, and the
    paper's designs (residual generators, continuous observer):

    >>> example = hy.get_example("driveline")
    >>> aut = example.build(k=paper.DRIVELINE_K_LOW)
    >>> truth = example.simulate(t_final=0.2, k=paper.DRIVELINE_K_LOW)
    >>> bank = hy.design_residual_bank(aut, paper.DRIVELINE_DELTA, paper.DRIVELINE_EPSILON,
    ...                                paper.DRIVELINE_Z0, invariant_rtol=paper.DRIVELINE_INVARIANT_RTOL)
    >>> design = hy.design_continuous_observer(aut, paper.DRIVELINE_DECAY,
    ...                                        gain_bound=paper.DRIVELINE_GAIN_BOUND,
    ...                                        state_box=paper.DRIVELINE_X, input_box=paper.DRIVELINE_U)
    >>> from hybobs_opt.observers import HybridObserver
    >>> obs = HybridObserver(bank, design, float(truth.t[1] - truth.t[0]),
    ...                      x0=np.array(paper.DRIVELINE_X0_GUESS))
    >>> run = obs.run_detailed(truth.u, truth.y)
    >>> run.location.shape, run.residuals.shape[0] == run.x_hat.shape[0]
    ((201,), True)
    >>> run.trace.n_steps
    201
    """

    x_hat: np.ndarray
    location: np.ndarray
    held: np.ndarray
    status: np.ndarray
    residuals: np.ndarray
    sigma: np.ndarray
    consistent: np.ndarray
    generator_states: np.ndarray
    seconds: np.ndarray
    trace: ObserverTrace


class HybridObserver(Observer):
    """The hybrid observer of paper 000 (Fig. 3): location observer + continuous observer.

    Per sample: the continuous observer propagates with the location held at the previous sample,
    then the location observer decides; an identified location switches the continuous gain, an
    ambiguous decision keeps it (and is reported with ``mode = -1`` and ``info["candidates"]``).

    Parameters
    ----------
    bank : ResidualBank
    design : ContinuousDesign
        Both for the same automaton.
    Ts : float
    x0 : array, optional
        Initial estimate (generators and continuous observer).
    q0 : int, optional
        Known initial location; otherwise the location observer identifies it and the continuous
        observer starts on the location whose invariant contains ``x0`` (location 0 if none).

    See Also
    --------
    LocationObserver : Its discrete part.
    ContinuousObserver : Its continuous part.
    HybridRun : What ``run_detailed`` returns.

    Notes
    -----
    ``info["error_bound"]`` is the continuous observer's contraction since the location in use was
    identified, restarted from the state box at every newly identified location (the first, or a
    switch detected up to ``Delta`` late): the contraction on another location's gain proves
    nothing, and Proposition 3.3.1 bounds the error through a detection delay only by ``M0`` (eq.
    20), 0.55 rad on the driveline's theta.  The flag is ``observable`` once that bound is below
    the convergence fraction.  Its hypothesis is that the identified location is the plant's: in
    the ``Delta`` before a switch is detected the error can exceed it.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.studies.paper000_driveline import scenario as paper

    The driveline of paper 000 with its low elasticity, 0.2 s of the Fig. 6 scenario, and the
    paper's designs (residual generators, continuous observer):

    >>> example = hy.get_example("driveline")
    >>> aut = example.build(k=paper.DRIVELINE_K_LOW)
    >>> truth = example.simulate(t_final=0.2, k=paper.DRIVELINE_K_LOW)
    >>> bank = hy.design_residual_bank(aut, paper.DRIVELINE_DELTA, paper.DRIVELINE_EPSILON,
    ...                                paper.DRIVELINE_Z0, invariant_rtol=paper.DRIVELINE_INVARIANT_RTOL)
    >>> design = hy.design_continuous_observer(aut, paper.DRIVELINE_DECAY,
    ...                                        gain_bound=paper.DRIVELINE_GAIN_BOUND,
    ...                                        state_box=paper.DRIVELINE_X, input_box=paper.DRIVELINE_U)
    >>> from hybobs_opt.observers import HybridObserver
    >>> obs = HybridObserver(bank, design, float(truth.t[1] - truth.t[0]),
    ...                      x0=np.array(paper.DRIVELINE_X0_GUESS))
    >>> run = obs.run_detailed(truth.u, truth.y)
    >>> run.x_hat.shape, int(run.location[-1]) == int(truth.q[-1])
    ((201, 3), True)
    >>> bool(np.linalg.norm(run.x_hat[-1] - truth.x[-1]) < np.linalg.norm(run.x_hat[0] - truth.x[0]))
    True
    """

    name = "location+continuous"

    def __init__(self, bank: ResidualBank, design: ContinuousDesign, Ts: float, *, x0: np.ndarray | None = None,
                 q0: int | None = None):
        as_instance(bank, "bank", ResidualBank, "a ResidualBank (design_residual_bank)")
        as_instance(design, "design", ContinuousDesign, "a ContinuousDesign (design_continuous_observer)")
        if bank.automaton is not design.automaton:
            raise ModelError("design", "a continuous design for the same automaton as the residual bank", "another automaton")
        self.automaton = aut = bank.automaton
        self.n, self.m, self.p = aut.n, aut.m, aut.p
        self.state_names = aut.state_names
        judge_samples_against(self, aut)
        self.locobs = LocationObserver(bank, Ts, x0=x0, q0=q0)
        self.contobs = ContinuousObserver(design, Ts, x0=self.locobs._x0, location=self._start_location(self.locobs._x0, q0))
        self._q0 = q0
        self._bound_location: int | None = q0  # the identified location the continuous bound started in

    def _start_location(self, x0: np.ndarray, q0: int | None) -> int:
        if q0 is not None:
            return int(q0)
        for q in range(self.automaton.n_locations):
            if self.automaton.locations[q].invariant.dim == self.n and self.automaton.in_invariant(q, x0):
                return q
        return 0

    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, **kwargs: Any) -> None:
        """Restart both observers at ``x0``.

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial estimate (default: the previous one, else the centre of the state bounds).
        q0 : int, optional
            Known initial location (default: the constructor's ``q0``; ``None`` lets the location
            observer identify it).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        self.locobs.reset(x0, q0)
        q = self._q0 if q0 is None else q0
        self.contobs.reset(self.locobs._x0, q0=self._start_location(self.locobs._x0, q))
        self._bound_location = q

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        co = self.contobs
        xc = co._step(u, y)
        if xc.flag == FALLBACK:  # the sample contradicts the continuous estimate's bound: nobody uses it
            loc = self.locobs._fallback(u, xc.info["reason"])
            return Estimate(xc.x, -1, FALLBACK, 0.0, dict(loc.info, generator_x=loc.x, reason=xc.info["reason"]))
        loc = self.locobs._step(u, y)
        identified = loc.info["held"] if loc.info["status"] == IDENTIFIED else None
        if identified is not None and identified != self._bound_location:
            # a newly identified location (the first, or a switch detected up to Delta late): the
            # contraction so far ran on another location's gain and proves nothing; the error is
            # bounded by the state box (Proposition 3.3.1 only bounds it by M0, eq. 20)
            co._bound.start(co.x, co._P)
        self._bound_location = identified
        if loc.info["held"] >= 0:
            co.location = loc.info["held"]
        info = dict(loc.info)
        info["generator_x"] = loc.x
        info["continuous_location"] = xc.mode
        info["error_bound"] = co.error_bound().tolist()
        converged = co._bound.converged(co._P_inv_diag)
        # the location identified is not yet the state: observable once the continuous
        # observer's certified transient since that identification has died out too
        flag = WARMING_UP if loc.flag == OBSERVABLE and not converged else loc.flag
        return Estimate(xc.x, loc.mode, flag, 0.0, info)

    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        xc = self.contobs._fallback(u, reason)
        loc = self.locobs._fallback(u, reason)
        info = dict(loc.info)
        info["generator_x"] = loc.x
        return Estimate(xc.x, -1, FALLBACK, 0.0, info)

    def run_detailed(self, U, Y) -> HybridRun:
        """Run from the reset state, keeping the location observer's signals.

        Parameters
        ----------
        U : (N, m) array_like
            Inputs.
        Y : (N, p) array_like
            Outputs.

        Returns
        -------
        HybridRun
            The continuous estimates with the location observer's signals.
        """
        U, Y = sample_rows(U, self.m, "U"), sample_rows(Y, self.p, "Y")
        if U.shape[0] != Y.shape[0]:
            raise ModelError("U, Y", "the same number of samples", f"{U.shape[0]} and {Y.shape[0]}")
        self.reset()
        N, G, Qn = U.shape[0], len(self.locobs.bank.generators), self.automaton.n_locations
        xs, gx = np.full((N, self.n), np.nan), np.full((N, G, self.n), np.nan)
        loc, held = np.full(N, -1), np.full(N, -1)
        status, flags = np.empty(N, dtype=object), np.empty(N, dtype=object)
        res, sig, cons, secs = np.full((N, G), np.nan), np.zeros((N, G), bool), np.zeros((N, Qn), bool), np.zeros(N)
        for k in range(N):
            e = self.step(U[k], Y[k])
            xs[k], loc[k], flags[k], secs[k] = e.x, e.mode, e.flag, e.seconds
            res[k], sig[k], cons[k] = e.info["residuals"], e.info["sigma"], e.info["consistent"]
            held[k], status[k], gx[k] = e.info["held"], e.info["status"], e.info["generator_states"]
        trace = ObserverTrace(xs, loc, flags, secs, self.state_names, self.name)
        return HybridRun(xs, loc, held, status, res, sig, cons, gx, secs, trace)


def summarise_run(aut: HybridAutomaton, trace, bank: ResidualBank, design: ContinuousDesign, bound: ConvergenceBound,
                  run: HybridRun) -> dict[str, Any]:
    """The measured figures of a run against the design's guarantees (JSON-ready).

    ``detection_delays``: one per true location change, from the event time to the first sample
    whose estimate is the new location (``None`` if never before the next change).
    ``max_error_after_convergence``: largest ``||x~ - x||`` after ``t_convergence``, when the
    transient term of the bound is below ``TRANSIENT_FRACTION M0``; ``t_enter_M0`` is the first
    sample after which the measured error stays within ``M0``.  ``entry_mismatch``: ``||x - z_i||`` of the entered
    location's generator at the first sample after each change (the ``Z0`` hypothesis).

    Parameters
    ----------
    aut : HybridAutomaton
        The plant.
    trace : Trace
        The simulated plant trajectory (true state, location and events).
    bank : ResidualBank
        The location observer's design.
    design : ContinuousDesign
        The continuous observer's design.
    bound : ConvergenceBound
        The guarantee the run is compared with.
    run : HybridRun
        The observer's run on ``trace`` (:meth:`HybridObserver.run_detailed`).

    Returns
    -------
    dict
        JSON-ready: detection delays, convergence times, errors after convergence against the
        bound ``M0`` and the design's figures.

    See Also
    --------
    HybridObserver.run_detailed : The run.
    hybobs_opt.synthesis.convergence_bound : The bound ``M0`` (Prop. 3.3.1 of paper 000).

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy
    >>> from hybobs_opt.studies.paper000_driveline import scenario as paper

    The driveline of paper 000 with its low elasticity, 0.2 s of the Fig. 6 scenario, and the
    paper's designs (residual generators, continuous observer):

    >>> example = hy.get_example("driveline")
    >>> aut = example.build(k=paper.DRIVELINE_K_LOW)
    >>> truth = example.simulate(t_final=0.2, k=paper.DRIVELINE_K_LOW)
    >>> bank = hy.design_residual_bank(aut, paper.DRIVELINE_DELTA, paper.DRIVELINE_EPSILON,
    ...                                paper.DRIVELINE_Z0, invariant_rtol=paper.DRIVELINE_INVARIANT_RTOL)
    >>> design = hy.design_continuous_observer(aut, paper.DRIVELINE_DECAY,
    ...                                        gain_bound=paper.DRIVELINE_GAIN_BOUND,
    ...                                        state_box=paper.DRIVELINE_X, input_box=paper.DRIVELINE_U)
    >>> from hybobs_opt.observers import HybridObserver, summarise_run
    >>> from hybobs_opt.synthesis import convergence_bound
    >>> bound = convergence_bound(design, paper.DRIVELINE_DELTA, paper.DRIVELINE_DWELL)
    >>> run = HybridObserver(bank, design, float(truth.t[1] - truth.t[0]),
    ...                      x0=np.array(paper.DRIVELINE_X0_GUESS)).run_detailed(truth.u, truth.y)
    >>> summary = summarise_run(aut, truth, bank, design, bound, run)
    >>> "detection_delays" in summary, "M0" in summary
    (True, True)
    """
    t = trace.t
    err = np.linalg.norm(run.x_hat - trace.x, axis=1)
    e0 = float(err[0])
    ratio = bound.transient_factor * e0 / (TRANSIENT_FRACTION * bound.M0) if bound.M0 > 0 else math.inf
    t_conv = t[0] + (math.log(ratio) / bound.decay if ratio > 1 else 0.0)
    after = t >= t_conv
    inside = err <= bound.M0
    # first sample from which the error stays within M0
    outside = np.nonzero(~inside)[0]
    k_enter = 0 if outside.size == 0 else int(outside[-1]) + 1
    entered = k_enter < t.size
    delays = detection_delays(t, trace.events, run.location)
    wrong = (run.location >= 0) & (run.location != trace.q)
    entry_mismatch = []
    for e in trace.events:
        k = int(np.searchsorted(t, e["t"] - 1e-12))
        if k < t.size:
            g = bank.group_of[int(e["to"])]
            entry_mismatch.append(float(np.linalg.norm(run.generator_states[k, g] - trace.x[k])))
    out = {
        "delta_design": bank.delta,
        "epsilon": bank.epsilon,
        "z0_bound": bank.z0_bound,
        "guaranteed_delays": {g.label: g.guaranteed_delay for g in bank.generators},
        "paper_delays_eq9": {g.label: g.paper_delay for g in bank.generators},
        "location_changes": [{"t": float(e["t"]), "from": aut.locations[int(e["from"])].name,
                              "to": aut.locations[int(e["to"])].name} for e in trace.events],
        "detection_delays": delays,
        "max_detection_delay": max((d for d in delays if d is not None), default=None),
        "all_detected_within_delta": all(d is not None and d <= bank.delta for d in delays),
        "ambiguous_steps": int(np.count_nonzero(run.status == AMBIGUOUS)),
        "no_candidate_steps": int(np.count_nonzero(run.status == "none")),
        "wrong_location_steps": int(np.count_nonzero(wrong)),
        "M0": bound.M0,
        "M0_per_state": bound.M0_per_state.tolist(),
        "M0_paper_eq20": bound.M0_paper,
        "decay_continuous": design.decay,
        "dwell_time": bound.dwell_time,
        "t_convergence": float(t_conv),
        "max_error_after_convergence": float(err[after].max()) if after.any() else None,
        "max_abs_error_after_convergence_per_state": (np.abs(run.x_hat - trace.x)[after].max(axis=0).tolist()
                                                      if after.any() else None),
        "t_enter_M0": float(t[k_enter]) if entered else None,
        "max_error_after_entering_M0": float(err[k_enter:].max()) if entered else None,
        "initial_error": float(err[0]),
        "max_error": float(err.max()),
        "error_bound_holds": bool(np.all(err <= bound.error_bound(t, e0) * (1 + 1e-9))),
        "entry_mismatch": entry_mismatch,
        "z0_hypothesis_holds": all(z <= bank.z0_bound for z in entry_mismatch),
        "median_step_s": float(np.median(run.seconds)),
        "residual_design": bank.summary(),
        "continuous_design": design.summary(),
        "convergence_bound": bound.summary(),
    }
    lo, hi = design.state_box
    ulo, uhi = design.input_box
    out["trajectory_in_X"] = bool(np.all((trace.x >= lo) & (trace.x <= hi)) and np.all((trace.u >= ulo) & (trace.u <= uhi)))
    return out


__all__ = ["ContinuousObserver", "HybridObserver", "HybridRun", "summarise_run"]

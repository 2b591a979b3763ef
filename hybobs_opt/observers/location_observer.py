"""Location observer of paper 000 (Balluchi et al.), Section 3.1: the runtime object ``H_locobs``
(Fig. 4) on the observer contract of :mod:`hybobs_opt.contract`.

The module holds the runtime object (:class:`LocationObserver`, :class:`LocationRun`,
:func:`detection_delays`).  Its two other concepts live next to it:

* :mod:`hybobs_opt.synthesis.location_design` -- the LMI design of the residual-generator bank
  (eqs. 6-8, Proposition 3.1.1: :class:`LuenbergerLMI`, :class:`ResidualGenerator`,
  :class:`ResidualBank`, :func:`design_residual_bank`, :class:`DelayCertificate`, the decay search);
* :mod:`hybobs_opt.observers.location_logic` -- the location identification logic (the "critical
  cases" at the end of Section 3.1: :class:`LocationDecision`, :class:`LocationLogic`,
  :func:`prop_3_1_3_matrix`).

"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from ..contract import (Estimate, FALLBACK, OBSERVABLE, Observer, ObserverTrace, UNOBSERVABLE, WARMING_UP,
                        check_reset_keywords, initial_state, innovation_excess, judge_samples_against, sample_rows)
from ..defaults import CONVERGENCE_FRACTION, INNOVATION_MARGIN, INNOVATION_PATIENCE
from .error_bound import LOG_FLOAT_MAX, induced_log_norm
from .._validate import as_instance, as_positive
from ..errors import ModelError
from ..tolerances import LOCATION_INVARIANT_RTOL
from ..synthesis.location_design import ResidualBank, sampled_observer
from .location_logic import AMBIGUOUS, IDENTIFIED, NO_CANDIDATE, LocationDecision, LocationLogic


# ============================================================================ runtime observer
@dataclass(frozen=True, eq=False)
class LocationRun:
    """A whole run of the location observer, sample by sample.

    Attributes
    ----------
    residuals : (N, G) array
        ``||r_j||`` per generator.
    sigma : (N, G) bool array
        Decisions of eq. (8).
    consistent : (N, Q) bool array
        Per location: ``sigma`` of its generator and the invariant test.
    location, held : (N,) int arrays
        Estimated location (``-1`` when ambiguous / none) and the held location.
    status : (N,) object array
    n_candidates : (N,) int array
    seconds : (N,) array
        Compute time per step.
    trace : ObserverTrace
    """

    residuals: np.ndarray
    sigma: np.ndarray
    consistent: np.ndarray
    location: np.ndarray
    held: np.ndarray
    status: np.ndarray
    n_candidates: np.ndarray
    seconds: np.ndarray
    trace: ObserverTrace


class LocationObserver(Observer):
    """The location observer ``H_locobs`` of paper 000 (Fig. 4) on the common observer contract.

    ``step(u, y)`` propagates the bank of residual generators over the last sample, evaluates the
    decisions of eq. (8) and the invariant tests, and runs :class:`LocationLogic`.  The returned
    ``Estimate.x`` is the state of the generator of the held location (a fast but high-overshoot
    estimate, which is why the paper adds the continuous observer); ``mode`` is the identified
    location or ``-1``; ``info`` holds residuals, decisions, candidates and status.

    Parameters
    ----------
    bank : ResidualBank
    Ts : float
        Sampling period of the data.
    x0 : array, optional
        Initial state of every generator (default: centre of the state bounds).
    q0 : int, optional
        Known initial location.

    See Also
    --------
    HybridObserver : Adds the continuous observer.
    detection_delays : How fast it identifies each change.

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
    >>> from hybobs_opt.observers import LocationObserver
    >>> Ts = float(truth.t[1] - truth.t[0])
    >>> obs = LocationObserver(bank, Ts, x0=np.array(paper.DRIVELINE_X0_GUESS))
    >>> trace = obs.run(truth.u, truth.y)

    The location is identified after a few samples (``mode`` is -1 while ambiguous):

    >>> int(trace.mode[0]), int(trace.mode[-1]) == int(truth.q[-1])
    (-1, True)
    """

    name = "location"

    def __init__(self, bank: ResidualBank, Ts: float, *, x0: np.ndarray | None = None, q0: int | None = None):
        as_instance(bank, "bank", ResidualBank, "a ResidualBank (design_residual_bank)")
        Ts = as_positive(Ts, "Ts", "a positive sampling period")
        self.bank = bank
        self.automaton = aut = bank.automaton
        self.Ts = Ts
        self.n, self.m, self.p = aut.n, aut.m, aut.p
        self.state_names = aut.state_names
        judge_samples_against(self, aut)
        G, n = len(bank.generators), aut.n
        self._G = G
        blocks = [sampled_observer(g.A, g.B, g.E, g.C, g.D, g.c, g.L, self.Ts) for g in bank.generators]
        open_loop = [sampled_observer(g.A, g.B, g.E, g.C, g.D, g.c, np.zeros_like(g.L), self.Ts) for g in bank.generators]
        self._Ad = _block_diag([b[0] for b in blocks])
        self._Bw = np.vstack([b[1] for b in blocks])
        self._Bd = np.vstack([b[2] for b in blocks])
        self._Ad_ol = _block_diag([b[0] for b in open_loop])
        self._Bw_ol = np.vstack([b[1] for b in open_loop])
        self._C = _block_diag([g.C for g in bank.generators])
        self._Dc = np.vstack([g.D for g in bank.generators])
        self._cc = np.concatenate([g.c for g in bank.generators])
        self._p = aut.p
        # Invariant tests on each location's generator state: rows scaled so that the slack is
        # relative (LOCATION_INVARIANT_RTOL * (1 + |b|)) and shifted by the guaranteed margin.
        self._inv = []
        for q, loc in enumerate(aut.locations):
            inv = loc.invariant
            slack = inv.b + bank.invariant_margins[q] + LOCATION_INVARIANT_RTOL * (1.0 + np.abs(inv.b))
            self._inv.append((bank.group_of[q], inv.A[:, :n], inv.A[:, n:], slack))
        # the certified state-error bound of each generator once its dynamics are the plant's:
        # ||x - z_g||_P <= sqrt(lambda_max(P_g)) Z0 exp(-alpha_g t) from entry (Proposition 3.1.1)
        self._gen_bound0 = [math.sqrt(float(np.linalg.eigvalsh(g.P)[-1])) * bank.z0_bound for g in bank.generators]
        self._gen_P_inv_diag = [np.diag(np.linalg.inv(g.P)) for g in bank.generators]
        self._gen_decay = [float(g.decay) for g in bank.generators]
        self._gen_log_open = [induced_log_norm(b[0], g.P) for b, g in zip(open_loop, bank.generators)]
        # sqrt(C_j P_g^-1 C_j') per generator and the floor of the innovation test (INNOVATION_MARGIN)
        self._gen_C_norms = [np.sqrt(np.einsum("ij,jk,ik->i", g.C, np.linalg.inv(g.P), g.C)) for g in bank.generators]
        rng = self.output_range
        width = None if rng is None else rng[1] - rng[0]
        self._innovation_floor = (INNOVATION_MARGIN * width if width is not None and np.all(np.isfinite(width))
                                  else None)
        lo, hi = aut.state_bounds.bounding_box()
        self._converged_tol = CONVERGENCE_FRACTION * (hi - lo)
        stale = int(math.ceil(bank.delta / self.Ts)) + 1
        self.logic = LocationLogic(aut, stale, q0)
        self._q0 = q0
        self._x0 = x0
        self.reset(x0, q0)

    def reset(self, x0: np.ndarray | None = None, q0: int | None = None, **kwargs: Any) -> None:
        """Restart every generator at ``x0`` and the logic at ``q0`` (``None``: unknown).

        Parameters
        ----------
        x0 : (n,) array, optional
            Initial state of every generator (default: the previous one, else the centre of the state
            bounds).
        q0 : int, optional
            Known initial location (default: the constructor's ``q0``).
        **kwargs
            The other keywords of :data:`~hybobs_opt.contract.RESET_KEYWORDS` (one call resets any
            observer): those this observer has no use for are ignored; any other is refused.
        """
        check_reset_keywords(kwargs, type(self).__name__)
        x0 = initial_state(x0, self._x0, self.automaton.state_bounds, self.n)
        self._x0 = x0
        self._z = np.tile(x0, self._G)
        self.logic.reset(self._q0 if q0 is None else q0)
        self._u_prev: np.ndarray | None = None
        self._y_prev: np.ndarray | None = None
        self._identified = False
        self._bound_group, self._log_bound = -1, math.inf
        self._input_unknown = False
        self._contradictions = 0

    # ------------------------------------------------------------------ one step
    def _innovation_excess(self, u: np.ndarray, y: np.ndarray) -> str | None:
        """Why the residual of the generator whose error bound is tracked (the identified location's)
        exceeds what that bound allows plus :data:`~hybobs_opt.defaults.INNOVATION_MARGIN` (``None``:
        it does not, or no bound is tracked)."""
        g = self._bound_group
        if g < 0 or self._innovation_floor is None:
            return None
        gen, n = self.bank.generators[g], self.n
        r = y - (gen.C @ self._z[g * n : (g + 1) * n] + (gen.D @ u if gen.D.size else 0.0) + gen.c)
        allowed = math.exp(min(self._log_bound, LOG_FLOAT_MAX)) * self._gen_C_norms[g] + self._innovation_floor
        return innovation_excess(r, allowed, y, self.output_names, " of the identified location's generator")

    def _propagate(self, u: np.ndarray, y: np.ndarray) -> None:
        if self._u_prev is not None and self._y_prev is None:
            # the previous sample was refused: no output over the last interval, so no correction
            # (holding y at its new value over it would feed the gain a step the plant never made)
            w = np.concatenate([self._u_prev, np.zeros(self.p), [1.0]])
            self._z = self._Ad_ol @ self._z + self._Bw_ol @ w
            if self._bound_group >= 0:
                self._log_bound += self._gen_log_open[self._bound_group]
        elif self._u_prev is not None:
            w = np.concatenate([self._u_prev, self._y_prev, [1.0]])
            self._z = self._Ad @ self._z + self._Bw @ w + self._Bd @ (y - self._y_prev)
        if self._input_unknown:  # the last interval ran on a refused sample's input: the error is
            self._input_unknown = False  # bounded again only by Z0 (the bank's hypothesis) at re-entry
            self._bound_group, self._log_bound = -1, math.inf
        self._u_prev, self._y_prev = u, y

    def _decide(self, u: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, LocationDecision]:
        p, n = self._p, self.n
        r = (self._C @ self._z + self._Dc @ u + self._cc).reshape(self._G, p) - y[None, :]
        res = np.sqrt(np.sum(r * r, axis=1))
        sigma = res <= self.bank.epsilon
        cons = np.zeros(len(self._inv), dtype=bool)
        for q, (g, Ax, Au, slack) in enumerate(self._inv):
            if sigma[g]:
                z = self._z[g * n : (g + 1) * n]
                lhs = Ax @ z + Au @ u if Au.shape[1] else Ax @ z
                cons[q] = bool(np.all(lhs <= slack))
        return res, sigma, cons, self.logic.update(cons)

    def _estimate(self, dec: LocationDecision, res, sigma, cons, reason: str = "") -> Estimate:
        q = dec.held if dec.held >= 0 else 0
        g = self.bank.group_of[q]
        x = self._z[g * self.n : (g + 1) * self.n].copy()
        bound = self.error_bound(g)
        if dec.status == IDENTIFIED:
            self._identified = True
            # the location is known; the state once the generator's certified transient has died out
            flag = OBSERVABLE if np.all(bound <= self._converged_tol) else WARMING_UP
        else:
            flag = UNOBSERVABLE if self._identified else WARMING_UP
        info = {"residuals": res, "sigma": sigma, "consistent": cons, "candidates": dec.candidates,
                "status": dec.status, "held": dec.held, "ambiguous": dec.status == AMBIGUOUS,
                "generator_states": self._z.reshape(self._G, self.n).copy(), "error_bound": bound.tolist()}
        if reason:
            info["reason"] = reason
        return Estimate(x, dec.location, flag, 0.0, info)

    def error_bound(self, g: int) -> np.ndarray:
        """Certified bound on ``|z_g,k - x_k|`` per state while generator ``g``'s dynamics have been
        the identified ones for the steps counted: ``Z0`` at entry into them (the bank's design
        hypothesis, Proposition 3.1.1 of paper 000), contracting at the generator's certified rate.

        Parameters
        ----------
        g : int
            Index of the generator (a group of locations with equal dynamics, ``bank.group_of``).

        Returns
        -------
        (n,) ndarray
            The bound per state.
        """
        log_b = self._log_bound if g == self._bound_group else math.log(self._gen_bound0[g])
        return math.exp(min(log_b, LOG_FLOAT_MAX)) * np.sqrt(self._gen_P_inv_diag[g])

    def _step(self, u: np.ndarray, y: np.ndarray) -> Estimate:
        saved = (self._z.copy(), self._u_prev, self._y_prev, self._input_unknown, self._bound_group, self._log_bound)
        self._propagate(u, y)
        why = self._innovation_excess(u, y)
        if why is not None:
            self._contradictions += 1
            if self._contradictions <= INNOVATION_PATIENCE:  # one bad sample: undo the step, run it open loop
                self._z, self._u_prev, self._y_prev, self._input_unknown, self._bound_group, self._log_bound = saved
                return self._fallback(u, why)
            # a persistent contradiction: the bound's hypothesis failed; it holds again only from re-entry
            self._bound_group, self._log_bound = -1, math.inf
        self._contradictions = 0
        res, sigma, cons, dec = self._decide(u, y)
        if dec.status == IDENTIFIED:
            g = self.bank.group_of[dec.held]
            if g == self._bound_group:
                self._log_bound -= self._gen_decay[g] * self.Ts
            else:
                self._bound_group, self._log_bound = g, math.log(self._gen_bound0[g])
        else:  # the location is no longer identified: the bound holds again only from the next entry (Z0)
            self._bound_group, self._log_bound = -1, math.inf
        self.last_decision = dec
        return self._estimate(dec, res, sigma, cons)

    def _fallback(self, u: np.ndarray | None, reason: str) -> Estimate:
        """Bad sample: every generator predicts open loop over the sample; the logic holds."""
        if self._u_prev is not None:
            w = np.concatenate([self._u_prev, np.zeros(self.p), [1.0]])
            self._z = self._Ad_ol @ self._z + self._Bw_ol @ w
        self._input_unknown = u is None and self._u_prev is not None
        if u is not None:
            self._u_prev = u
        self._y_prev = None
        if self._bound_group >= 0:  # an open-loop step: the generator's error is not corrected
            self._log_bound += self._gen_log_open[self._bound_group]
        held = self.logic.held
        dec = LocationDecision(-1, held, (), NO_CANDIDATE)
        self.last_decision = dec
        est = self._estimate(dec, np.full(self._G, np.nan), np.zeros(self._G, bool), np.zeros(len(self._inv), bool), reason)
        return Estimate(est.x, -1, FALLBACK, 0.0, est.info)

    # ------------------------------------------------------------------ whole runs
    def run_detailed(self, U, Y) -> LocationRun:
        """Run from the reset state over ``(U, Y)`` keeping residuals, decisions and the logic's output.

        Parameters
        ----------
        U : (N, m) array_like
            Inputs.
        Y : (N, p) array_like
            Outputs.

        Returns
        -------
        LocationRun
            The residuals, decisions and the logic's output per sample.
        """
        U, Y = sample_rows(U, self.m, "U"), sample_rows(Y, self.p, "Y")
        if U.shape[0] != Y.shape[0]:
            raise ModelError("U, Y", "the same number of samples", f"{U.shape[0]} and {Y.shape[0]}")
        self.reset()
        N = U.shape[0]
        res = np.full((N, self._G), np.nan)
        sig = np.zeros((N, self._G), bool)
        cons = np.zeros((N, self.automaton.n_locations), bool)
        loc, held, ncand = np.full(N, -1), np.full(N, -1), np.zeros(N, int)
        status = np.empty(N, dtype=object)
        xs, flags, secs = np.full((N, self.n), np.nan), np.empty(N, dtype=object), np.zeros(N)
        for k in range(N):
            e = self.step(U[k], Y[k])
            xs[k], loc[k], flags[k], secs[k] = e.x, e.mode, e.flag, e.seconds
            res[k], sig[k], cons[k] = e.info["residuals"], e.info["sigma"], e.info["consistent"]
            held[k], status[k], ncand[k] = e.info["held"], e.info["status"], len(e.info["candidates"])
        tr = ObserverTrace(xs, loc, flags, secs, self.state_names, self.name)
        return LocationRun(res, sig, cons, loc, held, status, ncand, secs, tr)



def _block_diag(blocks: Sequence[np.ndarray]) -> np.ndarray:
    rows = sum(b.shape[0] for b in blocks)
    cols = sum(b.shape[1] for b in blocks)
    out = np.zeros((rows, cols))
    r = c = 0
    for b in blocks:
        out[r : r + b.shape[0], c : c + b.shape[1]] = b
        r += b.shape[0]
        c += b.shape[1]
    return out


def detection_delays(t: np.ndarray, events: Sequence[dict], location: np.ndarray) -> list[float | None]:
    """Measured delay of each true location change: from the event time to the first sample at which
    the estimate equals the new location (``None`` if it never does before the next change).

    Parameters
    ----------
    t : (N,) array_like
        Sample times.
    events : sequence of dict
        The true location changes, each with the time ``"t"`` and the new location ``"to"``
        (:attr:`Trace.events`).
    location : (N,) int array_like
        The estimated location at each sample (``-1`` when unknown).

    Returns
    -------
    list of float or None
        One delay per true location change, ``None`` where the estimate never reached the new
        location before the next change.

    See Also
    --------
    LocationObserver : The estimates it measures.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.observers import detection_delays
    >>> t = np.arange(6) * 0.1
    >>> events = [{"t": 0.15, "to": 1}]
    >>> detection_delays(t, events, np.array([0, 0, 0, 0, 1, 1]))
    [0.25]
    """
    t = np.asarray(t, dtype=float)
    location = np.asarray(location)
    out: list[float | None] = []
    times = [float(e["t"]) for e in events]
    for k, e in enumerate(events):
        t_end = times[k + 1] if k + 1 < len(times) else np.inf
        sel = np.nonzero((t >= times[k] - 1e-12) & (t < t_end) & (location == int(e["to"])))[0]
        out.append(float(t[sel[0]] - times[k]) if sel.size else None)
    return out


__all__ = ["LocationObserver", "LocationRun", "detection_delays"]

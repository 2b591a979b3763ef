"""A bank of lookup observers over a grid of an unknown parameter (e.g. the backlash gap of paper 002).

Paper 002 assumes the backlash gap ``alpha`` known (Section 8).  A window of ``T`` samples cannot
tell it: inside one contact mode the outputs of model (16) depend on ``theta - alpha`` only, and
the windows that do determine it must hold a whole traversal of the gap (Algorithm 3.1 on the
system augmented with ``alpha``, :func:`hybobs_opt.systems.parameters.augment_parameters`: at
``T = 4`` only the sequences contact, backlash, other contact have rank ``n + 1``), which on the
bench scenario lasts 50-120 samples.  What does tell it is *memory*: a lookup observer built for a
wrong ``alpha_g`` reconstructs self-consistent states in each contact phase (``theta`` shifted by
``alpha_g - alpha``), but its open-loop prediction through the gap lands on the other side with a
``theta`` off by about ``2 (alpha - alpha_g)`` from its own reconstruction there.

The bank runs one :class:`~hybobs_opt.observers.lookup.LookupObserver` (Algorithm 4.1, exact
tests) per grid value and scores each by its *innovations*: at every step it flags
``observable``, the reconstruction minus the one-step model prediction from its previous
estimate, ``d(t) = x^(t) - f(x^(t-1), u(t-1))``, in units of the state box's half-widths; the
score is the running sum of ``||d||^2``.  On noise-free data the member at the true value scores
zero; the parameter estimate is the vertex of the parabola through the lowest score and its two
neighbours on the grid (the score grows quadratically with the error), and the state estimate is
that member's.  The parameter counts as *determined* once some member's score is positive and the
lowest one is unique; until then every grid value explains the data and the bank's flag is never
``observable``.  What is proven is consistency with the data on the grid, not identifiability in
the sense of Definition 2.2.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from ..contract import FALLBACK, OBSERVABLE, UNOBSERVABLE, ObserverTrace, sample_rows
from ..errors import ModelError
from ..tolerances import BANK_SCORE_ATOL

__all__ = ["ParameterBank", "ParameterBankTrace"]



@dataclass(frozen=True, eq=False)
class ParameterBankTrace(ObserverTrace):
    """The bank's run: the estimates of the best member per step, and the parameter per step.

    Parameters
    ----------
    x_hat, mode, flags, seconds, state_names, observer, info
        As for :class:`~hybobs_opt.contract.ObserverTrace`: the state estimate of the member with
        the lowest score at each step, flagged ``observable`` only where that member is and the
        parameter is determined.
    parameter : (N,) array
        The parameter estimate after each sample (NaN while undetermined).
    determined : (N,) bool array
        Whether the scores single out one grid value after each sample.
    scores : (N, K) array
        Each member's running score.
    grid : (K,) array
        The grid of parameter values.

    See Also
    --------
    ParameterBank.run : Returns one.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import ParameterBank
    >>> example = hy.get_example("powertrain3")
    >>> bank = ParameterBank(lambda gear_ratio: example.build(gear_ratio=gear_ratio), "gear_ratio",
    ...                      [1 / 14, 1 / 12, 1 / 10], 3)
    >>> out = bank.run(U, truth.y)
    >>> out.scores.shape, np.round(out.grid, 4)
    ((40, 3), array([0.0714, 0.0833, 0.1   ]))
    """

    parameter: np.ndarray | None = None
    determined: np.ndarray | None = None
    scores: np.ndarray | None = None
    grid: np.ndarray | None = None


class ParameterBank:
    """Lookup observers of ``build(**{name: value})`` for every ``value`` of ``grid`` (module docstring).

    Parameters
    ----------
    build : callable
        ``build(**{name: value}) -> PWASystem``.
    name : str
        The parameter's keyword of ``build``.
    grid : sequence of float
        At least three increasing values.
    T : int
        Horizon of each member's regions analysis (Algorithm 3.1) and lookup observer.
    progress : callable, optional
        ``progress(done, total)`` while the members are built.

    Attributes
    ----------
    members : tuple of LookupObserver
        One per grid value.
    build_seconds : float
        Time to build them (analyses from the active cache when there is one).
    refined_value : float or None
        The parameter value of the refining observer of the last :meth:`run` (``None`` without one).

    See Also
    --------
    ParameterBankTrace : What ``run`` returns.
    LookupObserver : One member.

    Examples
    --------
    >>> import numpy as np
    >>> import hybobs_opt as hy

    The powertrain of paper 002 (model (16)), 40 samples of 40 N m engine torque:

    >>> plant = hy.get_example("powertrain3").build(gear_ratio=1 / 12)
    >>> U = np.full((40, 1), 40.0)
    >>> truth = hy.simulate_pwa(plant, np.array([0.06, 39.0, 3.25]), U)
    >>> from hybobs_opt.observers import ParameterBank
    >>> example = hy.get_example("powertrain3")
    >>> bank = ParameterBank(lambda gear_ratio: example.build(gear_ratio=gear_ratio), "gear_ratio",
    ...                      [1 / 14, 1 / 12, 1 / 10], 3)
    >>> out = bank.run(U, truth.y)
    >>> bool(out.determined[-1]), round(float(out.parameter[-1]), 4)
    (True, 0.0845)
    """

    name = "lookup-bank"

    def __init__(self, build: Callable, name: str, grid: Sequence[float], T: int, *,
                 progress: Callable[[int, int], None] | None = None):
        from ..cache import cached_analysis
        from ..systems.pwa import PWASystem
        from .lookup import LookupObserver

        if not callable(build):
            raise ModelError("build", "a callable build(**{name: value}) -> PWASystem", type(build).__name__)
        if not isinstance(name, str) or not name:
            raise ModelError("name", "the parameter's keyword of build", repr(name))
        try:
            values = np.asarray(grid, dtype=float).reshape(-1)
        except (TypeError, ValueError):
            raise ModelError("grid", "a sequence of increasing numbers", repr(grid)) from None
        if values.size < 3 or not np.all(np.isfinite(values)) or not np.all(np.diff(values) > 0):
            raise ModelError("grid", "at least three increasing finite values", repr(grid))
        t0 = time.perf_counter()
        members = []
        for k, v in enumerate(values):
            system = build(**{name: float(v)})
            if not isinstance(system, PWASystem):
                raise ModelError("build", "a factory returning a PWASystem", type(system).__name__)
            members.append(LookupObserver(cached_analysis(system, T)))
            if progress:
                progress(k + 1, values.size)
        self.members = tuple(members)
        self._build = build
        self.refined_value: float | None = None
        self.grid, self.parameter_name, self.T = values, name, int(T)
        first = members[0].system
        self.n, self.m, self.p = first.n, first.m, first.p
        self.state_names = first.state_names
        half, _ = first.scales()
        self._half = np.asarray(half[: self.n], dtype=float)
        self.build_seconds = time.perf_counter() - t0

    def _innovations(self, k: int, x_hat: np.ndarray, flags: np.ndarray, U: np.ndarray) -> np.ndarray:
        """``||d(t)||^2`` of member ``k`` per step (zero where it does not reconstruct)."""
        system = self.members[k].system
        N = x_hat.shape[0]
        out = np.zeros(N)
        # the previous estimate must descend from a reconstruction (not from the seed of a reset,
        # nor across a fallback step): only then does the prediction carry the member's model
        anchored = np.zeros(N, dtype=bool)
        seen = False
        for t in range(N):
            if flags[t] == FALLBACK or not np.isfinite(x_hat[t]).all():
                seen = False
            elif flags[t] == OBSERVABLE:
                seen = True
            anchored[t] = seen
        idx = np.nonzero((flags == OBSERVABLE) & np.append(False, anchored[:-1]))[0]
        if not idx.size:
            return out
        xp, up = x_hat[idx - 1], U[idx - 1]
        lo, hi = system.state_bounds.bounding_box()
        xp = np.clip(xp, lo, hi)
        q = system.modes_of(xp, up)
        pred = np.full_like(xp, np.nan)
        for i, md in enumerate(system.modes):
            sel = q == i
            if sel.any():
                pred[sel] = xp[sel] @ md.A.T + up[sel] @ md.B.reshape(self.n, -1).T + md.a
        d = (x_hat[idx] - pred) / self._half
        # a prediction outside every mode's region cannot be compared: the largest possible jump
        out[idx] = np.where(np.isfinite(d).all(axis=1), np.sum(d * d, axis=1), 4.0 * self.n)
        return out

    def run(self, U, Y, *, refine: bool = True) -> ParameterBankTrace:
        """Every member over a recorded trace (batch), then the scores and the estimates per step.

        Parameters
        ----------
        U : (N, m) array_like
            Inputs.
        Y : (N, p) array_like
            Outputs.
        refine : bool, default True
            From the first sample at which the parameter is determined, take the state estimates
            (and flags) of one more lookup observer built at the parameter estimate of that sample,
            instead of the nearest grid member's (whose state is off by its grid offset: ``theta``
            by ``alpha_g - alpha`` on model 16).

        Returns
        -------
        ParameterBankTrace
            The best member's estimates, the parameter estimate and the scores per step.
        """
        t0 = time.perf_counter()
        U, Y = sample_rows(U, self.m, "U"), sample_rows(Y, self.p, "Y")
        if U.shape[0] != Y.shape[0]:
            raise ModelError("U, Y", "the same number of samples", f"{U.shape[0]} and {Y.shape[0]}")
        N = U.shape[0]
        runs = [obs.run(U, Y) for obs in self.members]
        scores = np.cumsum(np.column_stack([self._innovations(k, r.x_hat, r.flags, U) for k, r in enumerate(runs)]), axis=0)
        best = np.argmin(scores, axis=1)
        lowest = scores[np.arange(N), best]
        ties = np.count_nonzero(scores <= lowest[:, None] + BANK_SCORE_ATOL, axis=1)
        determined = (scores.max(axis=1) > BANK_SCORE_ATOL) & (ties == 1)
        param = np.full(N, np.nan)
        for t in np.nonzero(determined)[0]:
            param[t] = self._vertex(scores[t], int(best[t]))
        xs = np.stack([runs[int(b)].x_hat[t] for t, b in enumerate(best)])
        modes = np.array([runs[int(b)].mode[t] for t, b in enumerate(best)])
        member_flags = np.array([runs[int(b)].flags[t] for t, b in enumerate(best)], dtype=object)
        flags = member_flags.copy()
        flags[(member_flags == OBSERVABLE) & ~determined] = UNOBSERVABLE
        self.refined_value = None
        det = np.nonzero(determined)[0]
        if refine and det.size:
            from ..cache import cached_analysis
            from .lookup import LookupObserver

            t_d = int(det[0])
            self.refined_value = float(param[t_d])
            ref = LookupObserver(cached_analysis(self._build(**{self.parameter_name: self.refined_value}), self.T)).run(U, Y)
            xs[t_d:], modes[t_d:] = ref.x_hat[t_d:], ref.mode[t_d:]
            flags[t_d:] = np.where(determined[t_d:] | (ref.flags[t_d:] != OBSERVABLE), ref.flags[t_d:], UNOBSERVABLE)
        per_step = (time.perf_counter() - t0) / max(N, 1)
        info = tuple({} if f != FALLBACK else {"reason": "the best member fell back"} for f in flags)
        return ParameterBankTrace(xs, modes, flags, np.full(N, per_step), self.state_names, self.name, info,
                                  parameter=param, determined=determined, scores=scores, grid=self.grid)

    def _vertex(self, score: np.ndarray, k: int) -> float:
        """The vertex of the parabola through the scores at ``k - 1, k, k + 1`` (at an end of the
        grid the three values nearest it), clamped to those three values."""
        g = self.grid
        a = min(max(k - 1, 0), g.size - 3)
        x, y = g[a : a + 3], score[a : a + 3]
        c2, c1, _ = np.polyfit(x, y, 2)
        if not c2 > 0:
            return float(g[k])
        return float(np.clip(-c1 / (2 * c2), x[0], x[2]))

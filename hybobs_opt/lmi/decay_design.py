"""The decay-optimal constant gain within a gain bound, over every condition of the hierarchy (paper 004).

A condition of :mod:`.hierarchy` that is feasible at ``sigma = 0`` proves convergence, at a rate
that may be useless (the first feasible solution is any point of the LMI's feasible set).  Here
each condition -- the paper's LMI (8)/(22)/(23), the same with one multiplier per function, the
polytopic condition -- is solved for its *largest* decay rate ``sigma`` (``V' <= -sigma V`` with
``V = e' P e``, so the error norm decays at ``sigma / 2``) with ``||L||_2 <= gain_bound``, by the
bisection of :func:`.observer_lmi.bisect_decay` on one compiled problem, each search started
from the previous condition's rate (the conditions are nested: a later one's rate is at least
an earlier one's).  The LMIs bound ``||L||_2`` sufficiently, not exactly (``P >= alpha I`` and a
Schur complement), which can exclude most of the ball: the best condition is re-solved with a
raised internal bound while the returned gain's own norm stays within the user's
(:func:`_tighten`), and on request the polytopic condition is then searched under the exact bound (:func:`.gain_search.decay_gain_search`, local
search from the best condition's gain and from gains screened by eigenvalues).  Every rate
reported is not the solver's: it is the one the returned ``(P, L)`` proves on every vertex of the
Jacobian box, recomputed in numpy (:func:`.hierarchy.verified_rate`), and the search's rate is a
lower bound of the best rate in the ball, not the best rate.

What is proven, and its first line:

* no condition is feasible with the LMIs' bound on the gain even at ``sigma = 0`` -- the polytopic
  condition, the weakest, is infeasible in that form, with a Farkas certificate re-checked in
  numpy -- and the exact-bound search found no pair either.  The LMIs' form (``P >= a I``,
  ``[[P, Y], [Y', a l^2 I]] >= 0``) is sufficient for ``||L||_2 <= gain_bound``, not necessary,
  and the search is local, so this proves that the design finds no gain within the bound, not
  that none exists;
* a required rate ``min_decay`` is not reached: the largest certified rate within the bound is
  below it (the search's bracket says where it stopped; the claim is about the conditions, not
  about every gain);
* otherwise the best gain, its condition and its certified rate.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import HybobsError, InfeasibleError, SolverError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from .bounds import JacobianBounds
from .gain_search import GainSearchResult, decay_gain_search
from .hierarchy import CONDITIONS, condition_name, design_lmi, verified_rate
from .observer_lmi import DecayResult

__all__ = ["ConditionDecay", "DecayDesign", "decay_optimal_design"]


@dataclass(frozen=True)
class ConditionDecay:
    """The largest decay rate of one condition within the gain bound.

    Parameters
    ----------
    condition : str
        ``"paper"``, ``"per_function"`` or ``"polytopic"``.
    feasible : bool
        Some gain within the bound satisfies the condition (at ``sigma = 0`` at least).
    sigma_lmi : float or None
        The largest rate the bisection accepted (each accepted solve passed its own re-check).
    sigma_verified : float or None
        The rate the returned ``(P, L)`` proves on every vertex of the Jacobian box (numpy).
    L, P : arrays or None
        The gain and Lyapunov matrix at ``sigma_lmi`` (model coordinates).
    search : DecayResult or None
        The bisection (rates tried, verdicts).
    reason : str
        Why the condition gave no gain (empty when it did).
    certificate : object or None
        A verified Farkas certificate of infeasibility within the bound at ``sigma = 0``, when one was found.
    internal_gain_bound : float or None
        The bound the LMI was last solved with: at least the user's, raised while the returned
        gain's own norm stays within the user's (the LMI's bound is sufficient, not necessary).
    method : str
        ``"bisection"`` (the condition's LMI with its sufficient gain bound) or ``"exact-bound search"``
        (the polytopic condition with ``||L||_2 <= gain_bound`` exactly, :mod:`.gain_search`).

    See Also
    --------
    decay_optimal_design : Returns one per condition in a DecayDesign.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import decay_optimal_design
    >>> design = decay_optimal_design(pendulum, bounds, gain_bound=10.0)
    >>> [(c.condition, c.feasible, round(c.sigma_verified, 2)) for c in design.by_condition]
    [('paper', True, 3.56), ('per_function', True, 4.23), ('polytopic', True, 3.56)]
    """

    condition: str
    feasible: bool
    sigma_lmi: float | None = None
    sigma_verified: float | None = None
    L: np.ndarray | None = None
    P: np.ndarray | None = None
    search: DecayResult | None = field(default=None, repr=False)
    reason: str = ""
    certificate: object | None = field(default=None, repr=False)
    internal_gain_bound: float | None = None
    method: str = "bisection"

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        out = {"condition": self.condition, "feasible": self.feasible, "sigma_lmi": self.sigma_lmi,
               "sigma_verified": self.sigma_verified, "reason": self.reason or None,
               "internal_gain_bound": self.internal_gain_bound, "method": self.method}
        if self.feasible:
            out.update(L=self.L.tolist(), gain_norm=float(np.linalg.norm(self.L, 2)),
                       capped=bool(self.search is not None and self.search.capped),
                       solves=None if self.search is None else self.search.solves)
        if self.certificate is not None:
            out["certificate"] = self.certificate.to_dict()
        return out


@dataclass(frozen=True)
class DecayDesign:
    """The decay-optimal constant gain within a gain bound (:func:`decay_optimal_design`).

    Parameters
    ----------
    gain_bound : float or None
        Bound on ``||L||_2`` (``None``: none).
    min_decay : float or None
        The rate the gain must reach (``None``: no requirement).
    by_condition : tuple of ConditionDecay
        One per condition searched, in the order of the hierarchy.
    form : str
        The paper's LMI of the system (``"(8)"``, ``"(22)"`` or ``"(23)"``), for the texts.
    seconds : float
        Wall time of the searches.
    exact_search : GainSearchResult or None
        The exact-bound search of the polytopic condition (with a gain bound only).

    See Also
    --------
    decay_optimal_design : Returns one.
    ConditionDecay : One condition's rate.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import decay_optimal_design
    >>> design = decay_optimal_design(pendulum, bounds, gain_bound=10.0)
    >>> best = design.best
    >>> best.condition, round(best.sigma_verified, 2), bool(np.linalg.norm(best.L, 2) <= 10.0)
    ('per_function', 4.23, True)
    >>> print(design.headline("theta in [-1, 1]"))  # doctest: +ELLIPSIS
    FEASIBLE: a constant gain with ||L||_2 <= 10 and decay rate 4.232 1/s of V = ...
    """

    gain_bound: float | None
    min_decay: float | None
    by_condition: tuple[ConditionDecay, ...]
    form: str
    seconds: float
    exact_search: GainSearchResult | None = field(default=None, repr=False)

    @property
    def exact_bound_gain(self) -> ConditionDecay | None:
        """The exact-bound search's pair as a polytopic-condition result, or ``None`` when it found none."""
        found = self.exact_search
        if found is None or not found.found:
            return None
        return ConditionDecay("polytopic", True, None, found.sigma, found.L, found.P, method="exact-bound search")

    @property
    def best(self) -> ConditionDecay | None:
        """The gain with the largest verified rate, or ``None``.

        The conditions' gains first (the first of equals); the search's pair replaces them only when
        its rate is larger by :data:`~hybobs_opt.tolerances.SEARCH_IMPROVEMENT_RTOL`.
        """
        from ..tolerances import SEARCH_IMPROVEMENT_RTOL

        found = [c for c in self.by_condition if c.feasible and c.sigma_verified is not None]
        best = max(found, key=lambda c: c.sigma_verified, default=None)
        exact = self.exact_bound_gain
        if exact is not None and (best is None or exact.sigma_verified > best.sigma_verified
                                  * (1.0 + SEARCH_IMPROVEMENT_RTOL)):
            return exact
        return best

    @property
    def within_bound(self) -> bool:
        """Some condition, or the exact-bound search, has a gain within the bound."""
        return any(c.feasible for c in self.by_condition) or self.exact_bound_gain is not None

    @property
    def met(self) -> bool:
        """A gain within the bound whose verified rate reaches ``min_decay`` (any positive rate without one)."""
        best = self.best
        if best is None:
            return False
        return best.sigma_verified >= (self.min_decay if self.min_decay is not None else 0.0) and best.sigma_verified > 0

    def _bound_text(self) -> str:
        return "" if self.gain_bound is None else f" with ||L||_2 <= {self.gain_bound:g}"

    def headline(self, where: str) -> str:
        """The first line of a verdict: what this search proved on ``where``.

        Returns
        -------
        str
            The first line of a verdict: what this search proved on ``where``.
        """
        best = self.best
        if not self.within_bound:
            last = self.by_condition[-1] if self.by_condition else None
            bound = "" if self.gain_bound is None else f" WITHIN ||L||_2 <= {self.gain_bound:g}"
            searched = "" if self.exact_search is None else (
                f"; the local search of the polytopic condition under the exact bound "
                f"({len(self.exact_search.starts)} starts) found no pair either")
            if last is not None and last.certificate is not None:
                weakest = condition_name(last.condition, self.form)
                return (f"NO GAIN FOUND{bound}: {weakest}, with the LMIs' bound on the gain (P >= a I and "
                        f"[[P, Y], [Y', a l^2 I]] >= 0, sufficient for ||L||_2 <= {self.gain_bound:g}), is infeasible "
                        f"at decay rate 0 on {where}, and so is every condition before it (certificate re-checked in "
                        f"numpy){searched}; a gain within the bound that this form excludes is not ruled out.")
            return (f"UNDECIDED{bound}: no solve found a constant gain{self._bound_text()} on {where} and no "
                    "certificate of infeasibility was verified; nothing is claimed.")
        rate = best.sigma_verified if best is not None else 0.0
        if not self.met:
            need = f"the required {self.min_decay:g} 1/s" if self.min_decay is not None else "a positive rate"
            return (f"DECAY NOT MET: the largest decay rate proven for a constant gain{self._bound_text()} on {where} "
                    f"is {rate:.4g} 1/s ({condition_name(best.condition, self.form) if best else 'no condition'}), "
                    f"below {need}.")
        bound = "" if self.gain_bound is None else f" with ||L||_2 <= {self.gain_bound:g} and"
        capped = " at least" if best.search is not None and best.search.capped else ""
        need = "" if self.min_decay is None else f" (required: {self.min_decay:g} 1/s)"
        how = condition_name(best.condition, self.form)
        if best.method != "bisection":
            how += ", gain found by the local search under the exact bound; a larger rate is not ruled out"
        return (f"FEASIBLE: a constant gain{bound or ' with'} decay rate{capped} {rate:.4g} 1/s{need} of V = e'Pe, "
                f"proven on every vertex of the Jacobian box on {where} ({how}).")

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        best = self.best
        return {"gain_bound": self.gain_bound, "min_decay": self.min_decay, "within_bound": self.within_bound,
                "met": self.met, "best_condition": None if best is None else best.condition,
                "best_method": None if best is None else best.method,
                "sigma_verified": None if best is None else best.sigma_verified,
                "conditions": [c.to_dict() for c in self.by_condition],
                "exact_bound_search": None if self.exact_search is None else self.exact_search.to_dict(),
                "seconds": self.seconds}


def decay_optimal_design(system: ScalarNonlinearSystem, bounds: JacobianBounds, *, gain_bound: float | None = None,
                         min_decay: float | None = None, sigma_cap: float | None = None,
                         scaling: np.ndarray | None = None, conditions: tuple[str, ...] = CONDITIONS,
                         search_exact_bound: bool = False) -> DecayDesign:
    """The largest certified decay rate of each condition within ``||L||_2 <= gain_bound`` (see the module).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    bounds : JacobianBounds
        The Jacobian box of the region (:func:`.bounds.jacobian_bounds`).
    gain_bound : float, optional
        Bound on ``||L||_2`` (the LMIs' sufficient form, :class:`.observer_lmi.ObserverLMI`).
    min_decay : float, optional
        The decay rate the gain must reach (:attr:`DecayDesign.met`).
    sigma_cap : float, optional
        Upper end of each condition's bisection (default :data:`~hybobs_opt.defaults.SIGMA_CAP`); the
        exact-bound search is bounded by the gain bound itself.
    scaling : (n,) array, optional
        State scaling of the LMIs (default: the box half-widths).
    conditions : tuple of str
        The conditions searched, in the order of the hierarchy.
    search_exact_bound : bool, default False
        With a gain bound, also search the polytopic condition under the exact bound
        (:func:`.gain_search.decay_gain_search`, a few seconds on four states and eight vertices).  Off
        by default: the search is local, and on an ill-conditioned problem the local optimum it
        reaches can depend on floating-point details (on the flexible-joint robot the rate differs
        by up to 3 % between OpenBLAS kernel types), while the conditions' answers are reproducible.

    Returns
    -------
    DecayDesign
        Every condition's best gain or the reason it has none, and the best of them.

    Raises
    ------
    SolverError
        A solve failed in a way no fallback solver could decide (the message names the problem).

    See Also
    --------
    DecayDesign : What it returns.
    decay_gain_search : The search under the exact gain bound.
    noise_optimal_design : The gain that minimises the error bound under noise instead.

    Examples
    --------
    >>> import numpy as np
    >>> from hybobs_opt.lmi import jacobian_bounds
    >>> from hybobs_opt.systems import Polytope, ScalarFunction, ScalarNonlinearSystem

    A pendulum ``theta' = omega, omega' = -sin(theta)`` with ``theta`` measured:

    >>> box = Polytope.from_box([-1.0, -1.0], [1.0, 1.0], ("theta", "omega"))
    >>> import casadi as ca
    >>> sine = ScalarFunction("sin", ca.sin, ca.cos)       # CasADi expressions
    >>> pendulum = ScalarNonlinearSystem(box=box, A=[[0.0, 1.0], [0.0, 0.0]], C=[[1.0, 0.0]],
    ...                                  F=[[0.0], [-1.0]], E=[[1.0, 0.0]], f=(sine,), name="pendulum")
    >>> bounds = jacobian_bounds(pendulum)
    >>> from hybobs_opt.lmi import decay_optimal_design
    >>> design = decay_optimal_design(pendulum, bounds, gain_bound=10.0, min_decay=1.0)
    >>> design.met, design.best.condition, design.best.L.shape
    (True, 'per_function', (2, 1))
    """
    from ..defaults import SIGMA_CAP
    from .farkas import verified_farkas

    cap = SIGMA_CAP if sigma_cap is None else float(sigma_cap)
    t0 = time.perf_counter()
    out: list[ConditionDecay] = []
    guess = None
    form = design_lmi(system, "paper", scaling=scaling).form
    for key in conditions:
        try:
            lmi = design_lmi(system, key, gain_bound=gain_bound, scaling=scaling)
        except HybobsError as exc:  # the polytopic condition beyond its vertex limit
            out.append(ConditionDecay(key, False, reason=f"not built: {exc}"))
            continue
        try:
            bisection = lmi.max_decay(bounds, cap, guess=guess, known=guess)
        except InfeasibleError as exc:
            cert = exc.certificate if exc.certificate is not None and exc.certificate.verify() else None
            out.append(ConditionDecay(key, False, reason=str(exc), certificate=cert))
            continue
        except SolverError as exc:  # neither a checked point nor a verified certificate at rate 0
            out.append(ConditionDecay(key, False, reason=f"not decided: {exc}"))
            continue
        sol = bisection.solution
        if not sol.feasible:
            what = f"the {key} condition{'' if gain_bound is None else f' with ||L||_2 <= {gain_bound:g}'} at decay rate 0"
            lmi.solve(bounds, 0.0)
            out.append(ConditionDecay(key, False, reason=f"{what} is not feasible ({sol.status})",
                                      certificate=verified_farkas(lmi, what), search=bisection))
            continue
        rate = float(verified_rate(system, bounds, sol.P, sol.L))
        out.append(ConditionDecay(key, True, float(bisection.sigma_max), rate, sol.L, sol.P, bisection,
                                  internal_gain_bound=gain_bound))
        guess = max(float(bisection.sigma_max), guess or 0.0) or None
    found = [k for k, c in enumerate(out) if c.feasible]
    if gain_bound is not None and found:
        # only the best condition is re-solved with a raised internal bound (each re-solve is a search)
        k = max(found, key=lambda i: out[i].sigma_verified)
        c = out[k]
        bisection, rate, internal = _tighten(system, bounds, c.condition, c.search, c.sigma_verified,
                                             float(gain_bound), cap, scaling)
        sol = bisection.solution
        out[k] = ConditionDecay(c.condition, True, float(bisection.sigma_max), rate, sol.L, sol.P, bisection,
                                internal_gain_bound=internal)
    searched = None
    if gain_bound is not None and search_exact_bound and "polytopic" in conditions and not any(
            c.condition == "polytopic" and c.reason.startswith("not built") for c in out):
        found = [c for c in out if c.feasible]
        top = max(found, key=lambda c: c.sigma_verified, default=None)
        starts = () if top is None else ((f"{top.condition} condition", top.P, top.L),)
        # no cap: under a gain bound the eigenvalue ceiling bounds every rate (see decay_gain_search)
        searched = decay_gain_search(system, bounds, float(gain_bound), starts=starts, scaling=scaling)
    return DecayDesign(None if gain_bound is None else float(gain_bound), None if min_decay is None else float(min_decay),
                       tuple(out), form, time.perf_counter() - t0, searched)


def _tighten(system, bounds, key: str, search: DecayResult, rate: float, gain_bound: float, cap: float, scaling):
    """``(search, verified rate, internal bound)`` after raising the LMI's internal gain bound.

    The LMIs impose ``||L||_2 <= b`` sufficiently (``P >= alpha I`` and a Schur complement), so the
    gain they return often has a norm well below ``b``.  The internal bound ``b`` is therefore raised
    -- scaled by ``gain_bound / ||L||`` while the returned gain stays within the user's bound, bisected
    back (geometric mean) once it does not -- and a re-solve is kept only when its gain's norm is
    within ``gain_bound`` (numpy) and its verified rate is larger.  At most
    :data:`~hybobs_opt.defaults.GAIN_BOUND_TIGHTENING_STEPS` re-solves.
    """
    from ..defaults import GAIN_BOUND_TIGHT_FRACTION, GAIN_BOUND_TIGHTENING_STEPS
    from ..tolerances import GAIN_BOUND_RTOL

    lo, hi = gain_bound, None  # internal bounds known to give a gain within / beyond the user's
    best, best_rate, best_internal = search, rate, gain_bound
    norm = float(np.linalg.norm(search.solution.L, 2))
    for _ in range(GAIN_BOUND_TIGHTENING_STEPS):
        if norm >= GAIN_BOUND_TIGHT_FRACTION * gain_bound:
            break
        trial = lo * gain_bound / max(norm, 1e-12 * gain_bound) if hi is None else float(np.sqrt(lo * hi))
        lmi = design_lmi(system, key, gain_bound=trial, scaling=scaling)
        try:
            s2 = lmi.max_decay(bounds, cap, guess=best.sigma_max or None, known=best.sigma_max or None)
        except HybobsError:
            break
        if not s2.solution.feasible:
            break
        n2 = float(np.linalg.norm(s2.solution.L, 2))
        if n2 > gain_bound * (1.0 + GAIN_BOUND_RTOL):
            hi = trial
            continue
        lo, norm = trial, n2
        r2 = float(verified_rate(system, bounds, s2.solution.P, s2.solution.L))
        if r2 > best_rate:
            best, best_rate, best_internal = s2, r2, trial
    design_lmi(system, key, gain_bound=gain_bound, scaling=scaling)  # the compiled problem back at the user's bound
    return best, best_rate, best_internal


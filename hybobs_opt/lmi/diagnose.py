"""Does a constant observer gain exist on a range, and if not, what is proven and what to do (paper 004).

:func:`diagnose` answers, for one system and one range of a scheduling coordinate: the Jacobian
bounds and monotonicity of every function (eqs. 4-5); the hierarchy of sufficient conditions of
:mod:`.hierarchy` at ``sigma = 0`` without a gain bound (the paper's LMI (8)/(22)/(23), the same with
one multiplier per function, the polytopic condition), each feasible with its gain and re-checked
decay rate or infeasible with a certificate re-checked in numpy; the paper LMI's structural reason
(Theorems 2-4); the results that hold for every gain (:mod:`.impossibility`: undetectable points of
the range, mirror states the outputs cannot tell apart); Theorem 5's check that subtracting a linear
term changes nothing; and the remedy: the monotonic pieces and a set of regions on which switched
gains exist.  The verdict names exactly what was proven: "no constant gain exists" is said only
when an undetectable point lies in the range.
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass, field

import numpy as np

from .._logging import with_verbose
from ..defaults import SIGMA_CAP
from ..errors import HybobsError, InfeasibleError, SolverError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from .bounds import JacobianBounds, jacobian_bounds, monotonic_pieces
from .certificates import InfeasibilityCertificate
from .decay_design import DecayDesign, decay_optimal_design
from .noise_gain import NoiseBoundDesign, noise_optimal_design
from .hierarchy import HierarchyResult, condition_hierarchy
from .impossibility import OutputSymmetry, UndetectablePoint, output_symmetries, undetectable_points
from .observer_lmi import DecayResult, LMISolution, ObserverLMI
from .solve import SOLVER
from .schedule import SchedulingRegion, coordinate_index, make_region
from .subtraction import SubtractionCheck, theorem5_check
from .switched import grow_regions


@dataclass
class Diagnosis:
    """Everything :func:`diagnose` found (``to_dict`` is the JSON of ``hybobs diagnose``).

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system diagnosed.
    region : SchedulingRegion
        The range diagnosed.
    unit : str
        Display unit of the scheduling coordinate.
    factor : float
        Model units per display unit (:meth:`show` divides by it).
    bounds : JacobianBounds
        Bounds (4)-(5) on the region.
    feasible : bool
        Some condition of the hierarchy is feasible on the region (a constant gain exists).
    solution : LMISolution
        The solve of the paper's LMI (8)/(22)/(23).
    certificate : InfeasibilityCertificate or None
        Why the paper's LMI is infeasible, when it is.
    decay : DecayResult or None
        The bisection of the best condition's LMI within the gain bound (the recommended gain,
        ``design.best``, may come from the exact-bound search of :mod:`.gain_search` instead).
    theorem5 : SubtractionCheck
        Theorem 5's transformed LMI on the region.
    breakpoints : array
        Where the functions of the coordinate change direction (:func:`.bounds.monotonic_pieces`).
    pieces : list of SchedulingRegion
        The monotonic pieces between them.
    suggested : list of SchedulingRegion or None
        Switching regions grown when no constant gain exists (:func:`.switched.grow_regions`).
    suggest_error : str
        Why the decay search or the region growing failed (empty otherwise).
    gain_bound : float or None
        Bound on ``||L||_2`` used for the design and the regions.
    min_decay : float
        Decay rate the suggested regions must admit.
    overlap : float
        Hysteresis of the suggested regions (model units).
    next_steps : list of str
        The advice, the verdict first.
    seconds : float
        Wall time of the diagnosis.
    hierarchy : HierarchyResult, optional
        All conditions of :mod:`.hierarchy` on the region.
    undetectable : list of UndetectablePoint, optional
        Points of the range where the linearisation is not detectable.
    symmetries : list of OutputSymmetry, optional
        Mirror maps the outputs cannot detect.
    design_condition : str, optional
        The condition of the recommended gain: the one with the largest verified decay rate within
        the gain bound (:mod:`.decay_design`).
    sigma_verified : float, optional
        Decay rate the recommended ``(P, L)`` proves on every vertex of the Jacobian box.
    design : DecayDesign, optional
        The decay-optimal search of every condition within the gain bound (when a constant gain exists).
    required_decay : float, optional
        The decay rate the constant gain was required to reach (``None``: any positive rate).
    noise_design : NoiseBoundDesign, optional
        With a stated output-noise bound: the gain with the smallest certified ultimate error bound
        (:mod:`.noise_gain`) within the gain bound and at the required rate.
    noise_error : str
        Why no noise design was found (empty otherwise).

    See Also
    --------
    diagnose : Returns one.
    plot_jacobian_bounds : Draws the derivatives, pieces and suggested regions.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import diagnose
    >>> diag = diagnose(vehicle, "psi", 0.0, math.radians(140), unit="deg", factor=math.pi / 180,
    ...                 suggest=False)
    >>> diag.feasible, diag.certificate.verify()
    (False, True)
    >>> [diag.interval_text(p) for p in diag.pieces]
    ['[0, 90] deg', '[90, 140] deg']
    >>> print(diag.verdict)  # doctest: +ELLIPSIS
    No constant gain satisfies LMI (23) of Corollary 1.2 (one S-procedure ...
    """

    system: ScalarNonlinearSystem = field(repr=False)
    region: SchedulingRegion
    unit: str
    factor: float
    bounds: JacobianBounds
    feasible: bool
    solution: LMISolution
    certificate: InfeasibilityCertificate | None
    decay: DecayResult | None
    theorem5: SubtractionCheck
    breakpoints: np.ndarray
    pieces: list[SchedulingRegion]
    suggested: list[SchedulingRegion] | None
    suggest_error: str
    gain_bound: float | None
    min_decay: float
    overlap: float
    next_steps: list[str]
    seconds: float
    hierarchy: HierarchyResult | None = None
    undetectable: list[UndetectablePoint] = field(default_factory=list)
    symmetries: list[OutputSymmetry] = field(default_factory=list)
    design_condition: str | None = None
    sigma_verified: float | None = None
    design: DecayDesign | None = None
    required_decay: float | None = None
    noise_design: NoiseBoundDesign | None = None
    noise_error: str = ""

    @property
    def gain_accepted(self) -> bool:
        """A constant gain exists within the gain bound and reaches the required decay rate."""
        return self.feasible and self.design is not None and self.design.met

    @property
    def paper_lmi_feasible(self) -> bool:
        """The paper's LMI (8)/(22)/(23) alone is feasible (``feasible`` is the whole hierarchy's)."""
        return bool(self.solution.feasible)

    @property
    def verdict(self) -> str:
        """What is proven on the range, in one paragraph (the first of :attr:`next_steps`)."""
        where = f"{self.region.name} in {self.interval_text(self.region)}"
        parts = []
        if self.design is not None:
            parts.append(self.design.headline(where))
        inside = [p for p in self.undetectable if self.region.lo - 1e-12 <= p.s <= self.region.hi + 1e-12]
        if inside:
            p = inside[0]
            parts.append(f"No observer gain (constant, switched or time-varying) satisfies a quadratic Lyapunov "
                         f"condition on {where}. Proof: {p.claim}")
        if self.hierarchy is not None:
            parts.append(self.hierarchy.claim(where, with_gain=self.design is None))
        for sym in self.symmetries:
            parts.append(sym.claim)
        nd = self.noise_design
        if nd is not None and nd.feasible:
            names = self.system.state_names
            bound = ", ".join(f"|e_{nm}| <= {b:.4g}" for nm, b in zip(names, nd.bound))
            parts.append(f"Under output noise |v| <= {np.round(nd.noise, 6).tolist()}: a gain with ||L||_2 = "
                         f"{nd.gain_norm:.4g} and decay rate {nd.alpha:.4g} 1/s of V (without noise) drives the "
                         f"error into {bound} and keeps it there (an invariant ellipsoid, re-checked in numpy, "
                         f"while the state and the estimate stay on {where}).")
        elif self.noise_error:
            parts.append(f"No certified error bound under the stated noise: {self.noise_error}")
        return " ".join(parts)

    def show(self, value: float) -> float:
        """A value in model units converted to the display unit (``value / factor``).

        Parameters
        ----------
        value : float
            Value in model units.

        Returns
        -------
        float
            A value in model units converted to the display unit (``value / factor``).
        """
        return value / self.factor

    def interval_text(self, r: SchedulingRegion) -> str:
        """``"[lo, hi] unit"`` of a region, in the display unit.

        Parameters
        ----------
        r : SchedulingRegion
            The region.

        Returns
        -------
        str
            ``"[lo, hi] unit"`` of a region, in the display unit.
        """
        return f"[{self.show(r.lo):.4g}, {self.show(r.hi):.4g}] {self.unit}".strip()

    def to_dict(self) -> dict:
        """The record in plain JSON types (the ``--json`` output and saved files).

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        out = {
            "system": self.system.name,
            "coordinate": self.region.name,
            "range": [self.show(self.region.lo), self.show(self.region.hi)],
            "unit": self.unit,
            "lmi": self.solution.form,
            "feasible": self.feasible,
            "paper_lmi_feasible": self.paper_lmi_feasible,
            "feasible_condition": None if self.hierarchy is None else self.hierarchy.feasible_condition,
            "strongest_infeasible": None if self.hierarchy is None else self.hierarchy.strongest_infeasible,
            "verdict": self.verdict,
            "gain_accepted": self.gain_accepted,
            "required_decay": self.required_decay,
            "decay_design": None if self.design is None else self.design.to_dict(),
            "noise_design": None if self.noise_design is None else self.noise_design.to_dict(),
            "noise_error": self.noise_error or None,
            "hierarchy": None if self.hierarchy is None else self.hierarchy.to_dict(),
            "undetectable_points": [p.to_dict() for p in self.undetectable],
            "indistinguishable": [q.to_dict() for q in self.symmetries],
            "status": self.solution.status,
            "bounds": self.bounds.to_dict(),
            "nonmonotonic": [b.name for b in self.bounds.nonmonotonic],
            "theorem5": self.theorem5.to_dict(),
            "slope_changes": [self.show(b) for b in self.breakpoints],
            "monotonic_pieces": [[self.show(p.lo), self.show(p.hi)] for p in self.pieces],
            "suggested_regions": None if self.suggested is None else [[self.show(r.lo), self.show(r.hi)] for r in self.suggested],
            "suggest_error": self.suggest_error or None,
            "next_steps": self.next_steps,
            "seconds": self.seconds,
        }
        if self.certificate is not None:
            out["certificate"] = self.certificate.to_dict()
        if self.feasible:
            best = None if self.design is None else self.design.best
            if best is not None:
                L, P = best.L, best.P
                sigma = best.sigma_lmi if best.sigma_lmi is not None else best.sigma_verified
                method = best.method
            else:
                g = self.hierarchy.gain
                L, P, sigma, method = g.L, g.P, 0.0, "feasibility"
            out["gain"] = {"L": L.tolist(), "P": P.tolist(), "sigma": sigma, "condition": self.design_condition,
                           "method": method, "sigma_max": None if self.decay is None else self.decay.sigma_max,
                           "sigma_verified": self.sigma_verified,
                           "decay_search": None if self.decay is None else self.decay.to_dict(),
                           "gain_bound": self.gain_bound}
        return out


_log = logging.getLogger(__name__)


@with_verbose
def diagnose(
    system: ScalarNonlinearSystem,
    coordinate: int | str,
    lo: float | None = None,
    hi: float | None = None,
    *,
    unit: str = "",
    factor: float = 1.0,
    gain_bound: float | None = None,
    min_decay: float = 1.0,
    overlap: float = 0.0,
    sigma_cap: float = SIGMA_CAP,
    scaling: np.ndarray | None = None,
    suggest: bool = True,
    condition: str = "paper",
    required_decay: float | None = None,
    noise_bound=None,
    exact_bound_search: bool = False,
    verbose: bool | int = False,
) -> Diagnosis:
    """Diagnose the constant-gain observer LMI of ``system`` on ``coordinate`` in ``[lo, hi]``.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    coordinate : int or str
        Scheduling state.
    lo, hi : float, optional
        Range in model units (default: the operating box).
    unit, factor : str, float
        Display unit and model units per display unit (for the texts only).
    gain_bound, min_decay, overlap, sigma_cap, scaling
        Used for the gain when one exists and for the suggested regions when none does.
    suggest : bool
        Grow switching regions when the range is infeasible.
    condition : {"paper", "per_function", "polytopic"}
        The region condition (:mod:`.hierarchy`) the suggested regions are grown with.
    required_decay : float, optional
        Decay rate the constant gain must reach; a gain within the bound that does not reach it is
        refused (the verdict's first line says so) and switching regions are suggested instead.
    noise_bound : float, sequence or dict, optional
        Bound on each output's noise, in the outputs' units
        (:func:`~hybobs_opt.contract.noise_bound_vector`): when a gain within the bound exists, the
        gain with the smallest certified ultimate error bound is designed too (:mod:`.noise_gain`).
    exact_bound_search : bool, default False
        With a gain bound, also search the polytopic condition under the exact bound
        (:func:`.gain_search.decay_gain_search`); see :func:`.decay_design.decay_optimal_design`.
    verbose : bool or int, default False
        Log the progress (and every LMI solve at DEBUG) to standard error: ``True`` at INFO, or a
        logging level (:func:`hybobs_opt._logging.verbose_logging`).

    Returns
    -------
    Diagnosis
        The verdict on the range: the gain (or the re-checked infeasibility certificate), the
        condition hierarchy, the Theorem 5 check, the monotonic pieces, the suggested switching
        regions and the next steps.

    Raises
    ------
    ModelError
        Bad range (empty, reversed, outside the box) or bounds that are not finite.
    SolverError
        The solver could not decide and no certificate was verified.

    See Also
    --------
    Diagnosis : What it returns.
    condition_hierarchy : The three conditions it runs.
    grow_regions : How the suggested regions are grown.
    design_switched : The switched design the diagnosis points to.

    Examples
    --------
    No constant gain for the vehicle on 0-140 deg (paper 004, Theorem 4); the diagnosis says why
    (a re-checked certificate, Theorem 5's shifted LMI) and where the functions change direction:

    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import diagnose
    >>> diag = diagnose(vehicle, "psi", 0.0, math.radians(140), unit="deg", factor=math.pi / 180,
    ...                 suggest=False)
    >>> diag.feasible, diag.certificate.theorem, diag.theorem5.shifted_feasible
    (False, 'Theorem 4', False)
    >>> [diag.interval_text(p) for p in diag.pieces]
    ['[0, 90] deg', '[90, 140] deg']

    With ``suggest=True`` (the default) it also grows switching regions (``diag.suggested``).
    """
    t0 = time.perf_counter()
    k = coordinate_index(system, coordinate)
    lo = float(system.box_lower[k]) if lo is None else float(lo)
    hi = float(system.box_upper[k]) if hi is None else float(hi)
    region = make_region(system, k, lo, hi)
    _log.info("diagnose: the constant-gain observer LMI of %s on %s in [%.6g, %.6g]", system.name, region.name, lo, hi)
    bounds = jacobian_bounds(system, region)
    lmi = ObserverLMI.compiled(system, scaling=scaling)
    hier = condition_hierarchy(system, region, bounds=bounds, scaling=lmi.d,
                               region_text=f"{region.name} in [{lo / factor:.4g}, {hi / factor:.4g}] {unit}".strip())
    _log.info("diagnose: condition hierarchy decided (feasible condition: %s) after %.3g s", hier.feasible_condition,
              time.perf_counter() - t0)
    paper = hier.get("paper")
    sol = paper.solution if paper.solution is not None else lmi.solve(bounds, 0.0)
    cert = paper.certificate if isinstance(paper.certificate, InfeasibilityCertificate) else None
    if paper.skipped and str(paper.status) != "infeasible" and not hier.feasible and hier.strongest_infeasible is None:
        raise SolverError(f"observer LMI {lmi.form} on {region.name} in [{lo:.6g}, {hi:.6g}]", SOLVER, sol.status,
                          paper.skipped)
    undetectable = undetectable_points(system, k, lo, hi)
    symmetries = output_symmetries(system)
    t5 = theorem5_check(system, region, bounds=bounds, original=lmi)
    breakpoints, pieces = monotonic_pieces(system, k, lo, hi)
    suggested, suggest_error = None, ""
    decay, design_key, rate, design = None, hier.feasible_condition, None, None
    if hier.feasible:
        design = decay_optimal_design(system, bounds, gain_bound=gain_bound, min_decay=required_decay,
                                      sigma_cap=sigma_cap, scaling=lmi.d, search_exact_bound=exact_bound_search)
        best = design.best
        if best is not None:
            conditions = [c for c in design.by_condition if c.feasible]
            decay = max(conditions, key=lambda c: c.sigma_verified).search if conditions else None
            design_key, rate = best.condition, best.sigma_verified
        else:
            rate = hier.gain.sigma_verified
            suggest_error = next((c.reason for c in reversed(design.by_condition) if c.reason), "")
    noise_design, noise_error = None, ""
    if noise_bound is not None and design is not None and design.met:
        from ..contract import noise_bound_vector

        vbar = noise_bound_vector(noise_bound, system.output_names)
        try:
            noise_design = noise_optimal_design(system, bounds, vbar, gain_bound=gain_bound, min_decay=required_decay,
                                                scaling=lmi.d)
        except HybobsError as exc:
            noise_error = str(exc)
    elif noise_bound is not None:
        noise_error = "no constant gain within the requirements on the range (see the verdict)"
    if required_decay is not None:
        min_decay = float(required_decay)  # the suggested regions must meet the requirement too
    if suggest and (not hier.feasible or not design.met):
        _log.info("diagnose: growing switching regions on [%.6g, %.6g]", lo, hi)
        try:
            suggested = grow_regions(system, k, lo, hi, overlap=overlap, min_decay=min_decay, gain_bound=gain_bound,
                                     scaling=lmi.d, condition=condition)
        except (InfeasibleError, HybobsError) as exc:
            suggest_error = str(exc)
    d = Diagnosis(system, region, unit, factor, bounds, hier.feasible, sol, cert, decay, t5, breakpoints, pieces,
                  suggested, suggest_error, gain_bound, min_decay, overlap, [], 0.0, hier, undetectable, symmetries,
                  design_key, rate, design, required_decay, noise_design, noise_error)
    d.next_steps = _next_steps(d)
    d.seconds = time.perf_counter() - t0
    _log.info("diagnose: done in %.3g s (a constant gain %s)", d.seconds, "exists" if hier.feasible else "does not exist")
    return d


def _next_steps(d: Diagnosis) -> list[str]:
    u = f" {d.unit}" if d.unit else ""
    name = d.region.name
    steps = [d.verdict]
    if d.gain_accepted:
        cond = d.design_condition
        best = d.design.best
        how = ("by bisection on its LMI" if best.method == "bisection" else
               "at the gain of the local search under the exact gain bound")
        steps.append(f"Design with the {cond} condition ({how}): decay rate {d.sigma_verified:.4g} 1/s"
                     + (f" with ||L||_2 <= {d.gain_bound:g}" if d.gain_bound is not None else "")
                     + ", proven by the returned P and L on every vertex of the Jacobian box.")
        steps.append("Synthesise it with `hybobs synth` over this range; no switching is needed.")
        return steps
    if d.feasible:
        what = ("a larger gain bound" if not d.design.within_bound else
                "a lower required decay rate or a larger gain bound")
        steps.append(f"A constant gain exists on the range without these requirements; either accept {what}, or "
                     "switch gains between regions on which the requirements are met.")
        if d.gain_bound is not None and d.design.exact_search is None:
            steps.append("The conditions bound the gain through a sufficient LMI form; the local search under the "
                         "exact bound (--exact-bound-search, or exact_bound_search=True) may find a gain they exclude.")
    if d.certificate is not None:
        nm = ", ".join(b.name for b in d.bounds.nonmonotonic)
        steps.append(f"Why the paper's LMI fails ({d.certificate.theorem}): "
                     + (f"{nm} {'is' if len(d.bounds.nonmonotonic) == 1 else 'are'} non-monotonic there. " if nm else
                        "no function is non-monotonic there; the certificate is the solver's dual multiplier. ")
                     + d.certificate.reason)
    if d.theorem5.equivalent and not d.theorem5.shifted_feasible:
        steps.append("Subtracting a linear term to make the functions monotonic does not help (Theorem 5): the "
                     "transformed LMI is infeasible too.")
    steps.append("Switch gains (paper 004, Section 5): use one gain per region on which the functions are monotonic "
                 "enough, with hysteresis between neighbouring regions.")
    if len(d.breakpoints):
        steps.append(f"The functions change direction at {name} = "
                     + ", ".join(f"{d.show(b):.4g}" for b in d.breakpoints) + f"{u}; the monotonic pieces are "
                     + ", ".join(d.interval_text(p) for p in d.pieces) + ".")
    if d.suggested:
        steps.append(f"Regions with a gain of decay rate >= {d.min_decay:g} 1/s"
                     + (f" and ||L||_2 <= {d.gain_bound:g}" if d.gain_bound is not None else "")
                     + f" (neighbours overlap by 2 epsilon = {2 * d.show(d.overlap):.4g}{u}): "
                     + ", ".join(d.interval_text(r) for r in d.suggested) + ".")
        sw = [0.5 * (a.hi + b.lo) for a, b in zip(d.suggested[:-1], d.suggested[1:])]
        if sw:
            steps.append(f"Switch where {name} leaves a region; the nominal switching points are "
                         + ", ".join(f"{d.show(s):.4g}" for s in sw) + f"{u} (+- epsilon).")
        steps.append("Then compute the gains, the dwell time tau and the hysteresis with `hybobs synth`.")
    elif d.suggest_error:
        steps.append(f"Automatic regions failed: {d.suggest_error}")
    return steps

"""Does a constant observer gain exist on a range, and if not, why and what to do (paper 004).

:func:`diagnose` answers, for one system and one range of a scheduling coordinate: the Jacobian
bounds and monotonicity of every function (eqs. 4-5), the verdict of the observer LMI
(8)/(22)/(23) at ``sigma = 0`` (no gain bound: infeasibility there rules out every constant gain
and every decay rate), the certificate when it is infeasible (structural reason + verified dual
multiplier, Theorems 2-4), Theorem 5's check that subtracting a linear term changes nothing, and
the remedy: the monotonic pieces and a set of regions on which switched gains exist.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from ..errors import HybobsError, InfeasibleError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from .bounds import JacobianBounds, jacobian_bounds, monotonic_pieces
from .certificates import InfeasibilityCertificate, certify_infeasible
from .observer_lmi import LMI_NAMES, SIGMA_CAP, DecayResult, LMISolution, ObserverLMI
from .schedule import SchedulingRegion, coordinate_index, make_region
from .subtraction import SubtractionCheck, theorem5_check
from .switched import grow_regions


@dataclass
class Diagnosis:
    """Everything :func:`diagnose` found (``to_dict`` is the JSON of ``hybobs diagnose``)."""

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

    def show(self, value: float) -> float:
        return value / self.factor

    def interval_text(self, r: SchedulingRegion) -> str:
        return f"[{self.show(r.lo):.4g}, {self.show(r.hi):.4g}] {self.unit}".strip()

    def to_dict(self) -> dict:
        out = {
            "system": self.system.name,
            "coordinate": self.region.name,
            "range": [self.show(self.region.lo), self.show(self.region.hi)],
            "unit": self.unit,
            "lmi": self.solution.form,
            "feasible": self.feasible,
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
            sol = self.decay.solution if self.decay is not None else self.solution
            out["gain"] = {"L": sol.L.tolist(), "P": sol.P.tolist(), "sigma": sol.sigma,
                           "sigma_max": None if self.decay is None else self.decay.sigma_max,
                           "gain_bound": self.gain_bound}
        return out


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

    Raises
    ------
    ModelError
        Bad range (empty, reversed, outside the box) or bounds that are not finite.
    SolverError
        The solver could not decide and no certificate was verified.
    """
    t0 = time.perf_counter()
    k = coordinate_index(system, coordinate)
    lo = float(system.box_lower[k]) if lo is None else float(lo)
    hi = float(system.box_upper[k]) if hi is None else float(hi)
    region = make_region(system, k, lo, hi)
    bounds = jacobian_bounds(system, region)
    lmi = ObserverLMI.compiled(system, scaling=scaling)
    sol = lmi.solve(bounds, 0.0)
    cert = None
    decay = None
    if not sol.feasible:
        cert = certify_infeasible(lmi, sol, region_text=f"{region.name} in [{lo / factor:.4g}, {hi / factor:.4g}] {unit}".strip())
    t5 = theorem5_check(system, region, bounds=bounds, original=lmi)
    breakpoints, pieces = monotonic_pieces(system, k, lo, hi)
    suggested, suggest_error = None, ""
    if sol.feasible:
        try:
            design_lmi = ObserverLMI.compiled(system, gain_bound=gain_bound, scaling=lmi.d) if gain_bound is not None else lmi
            decay = design_lmi.max_decay(bounds, sigma_cap)
        except HybobsError as exc:
            suggest_error = f"no gain within the bound ||L|| <= {gain_bound:g}: {exc}"
    elif suggest:
        try:
            suggested = grow_regions(system, k, lo, hi, overlap=overlap, min_decay=min_decay, gain_bound=gain_bound,
                                     scaling=lmi.d)
        except (InfeasibleError, HybobsError) as exc:
            suggest_error = str(exc)
    d = Diagnosis(system, region, unit, factor, bounds, sol.feasible, sol, cert, decay, t5, breakpoints, pieces,
                  suggested, suggest_error, gain_bound, min_decay, overlap, [], 0.0)
    d.next_steps = _next_steps(d)
    d.seconds = time.perf_counter() - t0
    return d


def _next_steps(d: Diagnosis) -> list[str]:
    u = f" {d.unit}" if d.unit else ""
    name = d.region.name
    lmi_name = LMI_NAMES.get(d.solution.form, d.solution.form)
    steps = []
    if d.feasible:
        if d.decay is not None:
            steps.append(f"A constant gain exists on {name} in {d.interval_text(d.region)}: {lmi_name} is feasible, "
                         f"largest decay rate {d.decay.sigma_max:.4g} 1/s"
                         + (f" with ||L||_2 <= {d.gain_bound:g}" if d.gain_bound is not None else "") + ".")
        else:
            steps.append(f"A constant gain exists on {name} in {d.interval_text(d.region)} ({lmi_name} is feasible)"
                         + (f", but not within the gain bound: {d.suggest_error}" if d.suggest_error else "") + ".")
        steps.append("Synthesise it with `hybobs synth` over this range; no switching is needed.")
        return steps
    nm = ", ".join(b.name for b in d.bounds.nonmonotonic) or "no function"
    steps.append(f"No constant gain exists on {name} in {d.interval_text(d.region)}: {nm} "
                 f"{'is' if len(d.bounds.nonmonotonic) == 1 else 'are'} non-monotonic there "
                 f"({d.certificate.theorem if d.certificate else 'see the certificate'}).")
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

"""Switched-gain synthesis (paper 004, Section 5): one gain per region, then the joint dwell time.

For each region of the scheduling coordinate the observer LMI (8)/(22)/(23) is solved with the
region's Jacobian bounds: the largest decay rate ``sigma_max`` (bisection, with an optional gain
bound), then a design rate ``sigma_i = decay_fraction * sigma_max``.  The dwell time ``tau`` of
eqs. (47)-(48) is then searched jointly over all ``P_i`` (:class:`.dwell.DwellTimeLMI`), which
also returns the final ``P_i, L_i``; the hysteresis ``epsilon`` that enforces ``tau`` for a given
maximum rate of the scheduling variable comes from :func:`.dwell.hysteresis_for_dwell`.

:func:`grow_regions` builds the regions automatically: starting at the lower end of the range,
each region is grown (bisection on its upper end, one LMI re-solve per step) as far as a gain with
decay rate ``min_decay`` exists, and the next one starts ``2 epsilon`` below its end.
"""

from __future__ import annotations

import logging
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from .._logging import with_verbose
from ..defaults import SIGMA_CAP
from ..errors import HybobsError, InfeasibleError, ModelError, SolverError
from ..systems.scalar_nonlinear import ScalarNonlinearSystem
from .bounds import JacobianBounds, jacobian_bounds
from .dwell import DwellTimeLMI, dwell_for_hysteresis, dwell_time_fixed, hysteresis_for_dwell
from .observer_lmi import ObserverLMI
from .schedule import SchedulingRegion, adjacent_pairs, coordinate_index, make_region
from .solve import COUNTERS, SOLVER


@dataclass(frozen=True)
class RegionGain:
    """The design of one region.

    Parameters
    ----------
    region : SchedulingRegion
    L : (n, p) array
        Observer gain (model units).
    P : (n, n) array
        Lyapunov matrix (model coordinates; all regions share one scaling, so eqs. (47)-(48)
        hold between them).
    sigma : float
        Design decay rate (``V' <= -sigma V`` inside the region).
    sigma_max : float
        Largest rate found for the region (with the gain bound); ``capped`` when it hit the cap.
        Every rate the search accepted passed the numpy re-check (``decay_log``).
    multiplier : float
        The S-procedure multiplier of the region's LMI at ``P`` (the paper absorbs it into ``P``).
    lmi_max_eig : float
        Largest eigenvalue of the region's LMI at the returned point (numpy, scaled; <= 0).
    bounds : JacobianBounds
    sigma_verified : float or None
        Decay rate ``(P, L)`` proves on every vertex of the region's Jacobian box, recomputed in
        numpy (:func:`.hierarchy.verified_rate`); at least ``sigma`` for a sound design.
    decay_log : tuple of (sigma, feasible, status)
        Every rate the decay search tried.
    capped : bool
        ``sigma_max`` is the cap of the decay search.

    See Also
    --------
    SwitchedDesign : Holds one per region.
    SwitchedGainObserver : Runs the gains.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import synthesize_switched, regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> gain = synthesize_switched(vehicle, regions).regions[0]
    >>> gain.L.shape, gain.P.shape
    ((4, 2), (4, 4))
    >>> bool(gain.sigma > 0), bool(gain.lmi_max_eig <= 0), round(gain.gain_norm, 1) > 0
    (True, True, True)
    """

    region: SchedulingRegion
    L: np.ndarray
    P: np.ndarray
    sigma: float
    sigma_max: float
    capped: bool
    multiplier: float
    lmi_max_eig: float
    bounds: JacobianBounds = field(repr=False)
    sigma_verified: float | None = None
    decay_log: tuple = ()

    @property
    def gain_norm(self) -> float:
        return float(np.linalg.norm(self.L, 2))


@dataclass(frozen=True)
class SwitchedDesign:
    """A switched-gain observer design: gains per region, dwell time and hysteresis.

    Parameters
    ----------
    system : ScalarNonlinearSystem
    coordinate : int
        Index of the scheduling state.
    regions : tuple of RegionGain
    pairs : list of (i, j)
        The switches the observer can make (overlapping regions).
    tau : float
        Dwell time of eqs. (47)-(48), searched jointly over the ``P_i``.
    tau_fixed : float
        The dwell time for the per-region ``P_i`` (no joint search), for comparison.
    overlap : float or None
        Hysteresis ``epsilon`` the regions were built with (half the overlap of neighbours).
    max_rate : float or None
        Maximum rate of the scheduling variable (model units per second).
    epsilon_required : float or None
        ``tau * max_rate / 2``: the hysteresis that enforces ``tau`` at ``max_rate``.
    dwell_guaranteed : float or None
        Dwell time the regions' overlap guarantees at ``max_rate``.
    gain_bound : float or None
    solves : int
        LMI solves of the synthesis (including the dwell search).
    seconds : float
    dwell_solves : int
        Joint LMI solves of the dwell-time search.
    min_pair_eig : float
        ``min over pairs of lambda_min(P_i - exp(-tau sigma_j) P_j)`` at ``tau`` (numpy re-check).
    solver_counts : dict
        Solver statuses, undecided solves and rescues counted during the synthesis.
    accepted_unenforced_dwell : bool
        The design was accepted although the hysteresis does not enforce ``tau``.
    verification : DesignVerification or None
        The check of :func:`~hybobs_opt.observers.switched_verification.verify_switched_design`, when run.
    dwell_attempts : list of dict
        The attempts of :func:`.auto_design.design_switched` (overlap, design-rate fraction, result).

    See Also
    --------
    synthesize_switched : Builds one.
    SwitchedGainObserver : Runs it.
    switched_noise_bound : Its certified error bound under bounded noise.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import synthesize_switched, regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> design = synthesize_switched(vehicle, regions)
    >>> design.coordinate_name, len(design.regions), design.pairs
    ('psi', 2, [(0, 1), (1, 0)])
    >>> bool(design.tau > 0)
    True
    """

    system: ScalarNonlinearSystem = field(repr=False)
    coordinate: int
    regions: tuple[RegionGain, ...]
    pairs: list[tuple[int, int]]
    tau: float
    tau_fixed: float
    overlap: float | None
    max_rate: float | None
    epsilon_required: float | None
    dwell_guaranteed: float | None
    gain_bound: float | None
    solves: int
    seconds: float
    dwell_solves: int = 0
    min_pair_eig: float = float("nan")
    solver_counts: dict = field(default_factory=dict)
    accepted_unenforced_dwell: bool = False
    verification: object | None = field(default=None, repr=False)
    dwell_attempts: list = field(default_factory=list)

    @property
    def dwell_enforced(self) -> bool | None:
        """Whether the overlap enforces ``tau`` at ``max_rate`` (``None`` without a rate)."""
        if self.dwell_guaranteed is None:
            return None
        return bool(self.dwell_guaranteed >= self.tau)

    @property
    def coordinate_name(self) -> str:
        return self.system.state_names[self.coordinate]

    @property
    def warnings(self) -> list[str]:
        """What the design does not guarantee (``hybobs synth --json`` field ``warnings``)."""
        out = []
        if self.dwell_enforced is False:
            out.append(dwell_warning_text(self))
        return out

    def to_dict(self, unit: str = "", factor: float = 1.0) -> dict:
        """The JSON of ``hybobs synth``; intervals also in display units (``value / factor``).

        Parameters
        ----------
        unit : str, optional
            Display unit of the scheduling coordinate (for the texts).
        factor : float, default 1.0
            Model units per display unit.

        Returns
        -------
        dict
            The record in plain JSON types (numbers, strings, lists, dicts).
        """
        regs = []
        for g in self.regions:
            regs.append({
                "index": g.region.index, "coordinate": g.region.name,
                "interval": [g.region.lo / factor, g.region.hi / factor], "unit": unit,
                "interval_model": [g.region.lo, g.region.hi],
                "L": g.L.tolist(), "P": g.P.tolist(), "sigma": g.sigma, "sigma_max": g.sigma_max,
                "sigma_max_capped": g.capped, "gain_norm": g.gain_norm, "multiplier": g.multiplier,
                "lmi_max_eig": g.lmi_max_eig, "sigma_verified": g.sigma_verified,
                "decay_search": [{"sigma": a, "feasible": b, "status": c} for a, b, c in g.decay_log],
                "monotonicity": {b.name: b.monotonicity for b in (*g.bounds.f, *g.bounds.h) if b.method != "linear"},
            })
        return {
            "system": self.system.name, "coordinate": self.coordinate_name, "unit": unit,
            "state_names": list(self.system.state_names), "output_names": list(self.system.output_names),
            "regions": regs, "pairs": [list(p) for p in self.pairs],
            "tau": self.tau, "tau_fixed_P": self.tau_fixed,
            "epsilon": None if self.overlap is None else self.overlap / factor,
            "max_rate": None if self.max_rate is None else self.max_rate / factor,
            "epsilon_required": None if self.epsilon_required is None else self.epsilon_required / factor,
            "dwell_guaranteed": self.dwell_guaranteed, "dwell_enforced": self.dwell_enforced,
            "gain_bound": self.gain_bound, "solves": self.solves, "dwell_solves": self.dwell_solves,
            "min_pair_eig": self.min_pair_eig, "seconds": self.seconds, "warnings": self.warnings,
            "solver_counts": dict(self.solver_counts), "accepted_unenforced_dwell": self.accepted_unenforced_dwell,
            "dwell_attempts": list(self.dwell_attempts),
            "verification": None if self.verification is None else self.verification.to_dict(),
        }


class DwellTimeWarning(UserWarning):
    """A switched design whose hysteresis does not enforce its dwell time (Theorem 6 not guaranteed).

    Parameters
    ----------
    *args
        The message (one of :attr:`SwitchedDesign.warnings`), as for :class:`UserWarning`.
    **kwargs
        None accepted (:class:`Warning` takes no keyword arguments).

    See Also
    --------
    DwellTimeError : Raised instead unless the caller accepts the design.
    SwitchedDesign.warnings : The texts of the warnings.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import synthesize_switched, regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> import warnings
    >>> from hybobs_opt.lmi import DwellTimeWarning
    >>> with warnings.catch_warnings(record=True) as caught:
    ...     warnings.simplefilter("always")
    ...     design = synthesize_switched(vehicle, regions, overlap=math.radians(10), max_rate=100.0,
    ...                                  accept_unenforced_dwell=True)
    ...
    >>> any(issubclass(w.category, DwellTimeWarning) for w in caught), design.dwell_enforced
    (True, False)
    """


class DwellTimeError(HybobsError):
    """A switched design whose hysteresis does not enforce its dwell time, not accepted by the caller.

    ``design`` is the design that was rejected (pass ``accept_unenforced_dwell=True`` to get it).

    Parameters
    ----------
    design : SwitchedDesign
        The rejected design; the message says which overlap would enforce its dwell time.

    See Also
    --------
    DwellTimeWarning : The warning given instead when the caller accepts such a design.
    synthesize_switched : Raises it.
    hysteresis_for_dwell : The overlap a dwell time needs.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import synthesize_switched, regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> from hybobs_opt.lmi import DwellTimeError
    >>> try:
    ...     synthesize_switched(vehicle, regions, overlap=math.radians(10), max_rate=100.0)
    ... except DwellTimeError as err:
    ...     print(type(err.design).__name__, err.design.dwell_enforced)
    ...
    SwitchedDesign False
    """

    def __init__(self, design: "SwitchedDesign"):
        self.design = design
        super().__init__(dwell_warning_text(design) + "; pass accept_unenforced_dwell=True "
                         "(hybobs synth --accept-unenforced-dwell) to accept a design without that guarantee")


def dwell_warning_text(design: "SwitchedDesign") -> str:
    return (f"the hysteresis does not enforce the dwell time: at the maximum rate {design.max_rate:.4g} of "
            f"{design.coordinate_name} the overlap of {design.overlap:.4g} guarantees a dwell of "
            f"{design.dwell_guaranteed:.4g} s < tau = {design.tau:.4g} s, so Theorem 6 does not guarantee convergence; "
            f"widen the overlap to epsilon >= {design.epsilon_required:.4g} or lower the rate bound")


def grow_regions(
    system: ScalarNonlinearSystem,
    coordinate: int | str,
    lo: float,
    hi: float,
    *,
    overlap: float,
    min_decay: float,
    gain_bound: float | None = None,
    scaling: np.ndarray | None = None,
    resolution: float | None = None,
    lmi: ObserverLMI | None = None,
    condition: str = "paper",
) -> list[SchedulingRegion]:
    """Cover ``[lo, hi]`` with regions on which a gain of decay rate ``min_decay`` exists.

    Greedy from ``lo``: each region's upper end is the largest (to ``resolution``) for which the
    region condition (``condition`` of :mod:`.hierarchy`: ``"paper"``, ``"per_function"`` or
    ``"polytopic"``) is feasible at ``sigma = min_decay`` (with the gain bound); the next region
    starts ``2 * overlap`` below it, so neighbours overlap by twice the hysteresis.

    Parameters
    ----------
    system : ScalarNonlinearSystem
        The system of eqs. (1)-(3) of paper 004.
    coordinate : int or str
        The scheduling state (index or name).
    lo, hi : float
        The range to cover, in model units.
    overlap : float
        The hysteresis ``epsilon >= 0`` (model units).
    min_decay : float
        Decay rate each region must admit (``>= 0``).
    gain_bound : float, optional
        Bound on ``||L||_2``; ``None`` for none.
    scaling : (n,) array, optional
        State scaling of the LMIs (default: the box half-widths).
    resolution : float, optional
        Resolution of each region's upper end (default ``(hi - lo) / 400``).
    lmi : ObserverLMI or PolytopicLMI, optional
        A compiled condition to reuse (default: :func:`.hierarchy.design_lmi` of ``condition``).
    condition : {"paper", "per_function", "polytopic"}, default "paper"
        The region condition.

    Returns
    -------
    list of SchedulingRegion
        Regions covering ``[lo, hi]`` in order, neighbours overlapping by ``2 * overlap``, each with a
        gain of decay rate ``min_decay``.

    Raises
    ------
    InfeasibleError
        Even the narrowest region at some point admits no such gain (carries the certificate).
    ModelError
        Bad range, overlap or rate.

    See Also
    --------
    regions_from_switch_points : Regions around given switching points instead.
    synthesize_switched : The gains on the regions.
    design_switched : Settings, regions and gains in one call.

    Examples
    --------
    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import grow_regions
    >>> regions = grow_regions(vehicle, "psi", 0.0, math.radians(140), overlap=math.radians(5),
    ...                        min_decay=0.5, resolution=math.radians(2))
    >>> len(regions) >= 2, round(regions[0].lo, 6), round(regions[-1].hi, 6) == round(math.radians(140), 6)
    (True, 0.0, True)
    """
    k = coordinate_index(system, coordinate)
    if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
        raise ModelError("range", "finite lo < hi (a non-empty range)", f"[{lo}, {hi}]")
    if not (np.isfinite(overlap) and overlap >= 0):
        raise ModelError("overlap", "a non-negative hysteresis width", repr(overlap))
    if not (np.isfinite(min_decay) and min_decay >= 0):
        raise ModelError("min_decay", "a non-negative decay rate", repr(min_decay))
    res = (hi - lo) / 400.0 if resolution is None else float(resolution)
    from .hierarchy import design_lmi

    lmi = lmi or design_lmi(system, condition, gain_bound=gain_bound, scaling=scaling)
    min_width = 2.0 * overlap + res

    def solve(a: float, b: float):
        return lmi.solve(jacobian_bounds(system, make_region(system, k, a, b)), min_decay)

    spans: list[tuple[float, float]] = []
    a = float(lo)
    while True:
        if solve(a, hi).feasible:
            spans.append((a, float(hi)))
            break
        b_ok = min(a + min_width, hi)
        first = solve(a, b_ok)
        if not first.feasible:
            _growth_failure(system, lmi, k, a, b_ok, min_decay, first, condition)
        b_bad = float(hi)
        while b_bad - b_ok > res:
            mid = 0.5 * (b_ok + b_bad)
            if solve(a, mid).feasible:
                b_ok = mid
            else:
                b_bad = mid
        spans.append((a, b_ok))
        a = b_ok - 2.0 * overlap
    return [make_region(system, k, s0, s1, i) for i, (s0, s1) in enumerate(spans)]


def _growth_failure(system, lmi, k: int, a: float, b: float, min_decay: float, sol, condition: str):
    """Raise the error of a region growth that found no gain even on ``[a, b]``, with what is proven.

    The certificate covers every gain only without a gain bound, so under a bound the same
    condition is re-solved without it: infeasible there (with a verified certificate) is proven for
    every gain, feasible there means the bound is what fails.  Undetectable points of ``[a, b]``
    (:mod:`.impossibility`) are named: they rule out every gain on any region containing them.
    """
    from .farkas import verified_farkas as _farkas
    from .hierarchy import _certificate, design_lmi
    from .impossibility import undetectable_points

    name = system.state_names[k]
    problem = f"region growth from {name} = {a:.6g}"
    where = f"[{a:.6g}, {b:.6g}]"
    points = undetectable_points(system, k, a, b)
    proof = (" " + points[0].claim) if points else ""
    undecided = f"{problem} ({condition} condition on {where})"
    cert, missing = _certificate(lmi, sol)
    if cert is None:
        # the condition's own certificates did not verify: the Farkas ray of the problem as posed
        cert = _farkas(lmi, f"the {condition} condition on {where} at decay rate {min_decay:g}")
    if cert is None:
        raise SolverError(undecided, SOLVER, sol.status,
                          f"no gain was confirmed and no certificate of infeasibility verified ({missing}); lower the "
                          f"minimum decay or the resolution, or rescale the model.{proof}")
    if lmi.gain_bound is None:
        raise InfeasibleError(problem, cert, f"no gain with decay rate {min_decay:g} satisfies the {condition} condition "
                              f"even on {where}." + proof)
    free = design_lmi(system, condition, gain_bound=None, scaling=lmi.d)
    fsol = free.solve(sol.bounds, min_decay)
    if fsol.feasible:
        raise InfeasibleError(problem, cert, f"no gain with decay rate {min_decay:g} and ||L||_2 <= {lmi.gain_bound:.4g} "
                              f"satisfies the {condition} condition on {where} (certificate: {type(cert).__name__}), but "
                              f"without the bound it is feasible there (||L||_2 = {fsol.gain_norm:.4g}): raise the gain "
                              f"bound or lower the minimum decay.{proof}")
    fcert, fmissing = _certificate(free, fsol)
    if fcert is None:
        fcert = _farkas(free, f"the {condition} condition on {where} at decay rate {min_decay:g} without a gain bound")
    if fcert is None:  # proven under the bound only
        raise InfeasibleError(problem, cert, f"no gain with decay rate {min_decay:g} and ||L||_2 <= {lmi.gain_bound:.4g} "
                              f"satisfies the {condition} condition on {where}; without the bound the solver found no "
                              f"gain either but no certificate verified ({fmissing}).{proof}")
    raise InfeasibleError(problem, fcert, f"no gain with decay rate {min_decay:g} satisfies the {condition} condition on "
                          f"{where}, whatever the gain bound." + proof)


_log = logging.getLogger(__name__)


@with_verbose
def synthesize_switched(
    system: ScalarNonlinearSystem,
    regions: Sequence[SchedulingRegion],
    *,
    gain_bound: float | None = None,
    decay_fraction: float = 0.5,
    sigma_cap: float = SIGMA_CAP,
    scaling: np.ndarray | None = None,
    max_rate: float | None = None,
    overlap: float | None = None,
    dwell: bool = True,
    accept_unenforced_dwell: bool = False,
    condition: str = "paper",
    min_decay: float | None = None,
    verbose: bool | int = False,
) -> SwitchedDesign:
    """Gains per region and the joint dwell time (paper 004, Section 5, Theorem 6).

    Parameters
    ----------
    system : ScalarNonlinearSystem
    regions : sequence of SchedulingRegion
        Regions of one coordinate (e.g. from :func:`.schedule.regions_from_switch_points` or
        :func:`grow_regions`).
    gain_bound : float, optional
        ``||L_i||_2 <= gain_bound`` (noise sensitivity); without it ``sigma_max`` is only limited by
        ``sigma_cap`` and the gains grow without bound as the rate does.
    decay_fraction : float
        Design rate ``sigma_i = decay_fraction * sigma_max_i`` (in ``(0, 1]``): a margin below the
        largest rate leaves room for the joint dwell-time constraints.
    sigma_cap : float
        Upper end of the decay-rate search.
    scaling : (n,) array, optional
        State scaling of the LMIs (default: the box half-widths).
    max_rate : float, optional
        Maximum rate of the scheduling variable (model units/s) for the hysteresis of Fig. 1.
    overlap : float, optional
        The hysteresis ``epsilon`` the regions were built with (for the dwell-time guarantee).
    dwell : bool
        Run the joint dwell-time search (else ``tau`` is the fixed-``P`` value).
    accept_unenforced_dwell : bool
        Return a design whose hysteresis does not enforce ``tau`` at ``max_rate`` (with a
        :class:`DwellTimeWarning`) instead of raising :class:`DwellTimeError`.
    condition : {"paper", "per_function", "polytopic"}
        The region condition (:mod:`.hierarchy`), used for the decay rates and the joint dwell LMI.
    min_decay : float, optional
        The rate the regions were grown for: the decay search tries it, so ``sigma_max`` is not
        reported below it by the bisection's tolerance.
    verbose : bool or int, default False
        Log the progress (and every LMI solve at DEBUG) to standard error: ``True`` at INFO, or a
        logging level (:func:`hybobs_opt._logging.verbose_logging`).

    Returns
    -------
    SwitchedDesign
        The gain and Lyapunov matrix of each region, the switching pairs, the dwell time ``tau``
        and whether the hysteresis enforces it.

    Raises
    ------
    InfeasibleError
        A region admits no constant gain (carries the certificate).
    DwellTimeError
        The overlap does not enforce the dwell time at ``max_rate`` and the caller did not accept it.

    See Also
    --------
    regions_from_switch_points : Regions around given switching points.
    grow_regions : Regions grown from the LMI.
    design_switched : Settings, regions and gains in one call.
    SwitchedGainObserver : Runs the design.

    Examples
    --------
    The vehicle of paper 004 with the two regions of eqs. (61)-(62):

    >>> import math
    >>> import hybobs_opt as hy
    >>> vehicle = hy.get_example("vehicle_tracking").build()
    >>> from hybobs_opt.lmi import synthesize_switched, regions_from_switch_points
    >>> regions = regions_from_switch_points(vehicle, "psi", 0.0, math.radians(140),
    ...                                      [math.radians(70)], math.radians(10))
    >>> design = synthesize_switched(vehicle, regions)
    >>> [g.L.shape for g in design.regions]
    [(4, 2), (4, 2)]
    >>> design.pairs, bool(design.tau > 0)
    ([(0, 1), (1, 0)], True)
    """
    from .hierarchy import design_lmi, verified_rate

    t0 = time.perf_counter()
    calls0 = COUNTERS.calls
    undecided0, rescued0, none0 = COUNTERS.primary_undecided, dict(COUNTERS.rescued), COUNTERS.undecided
    statuses0 = dict(COUNTERS.statuses)
    if not regions:
        raise ModelError("regions", "at least one region", "none")
    k = regions[0].coordinate
    if any(r.coordinate != k for r in regions):
        raise ModelError("regions", "regions of one scheduling coordinate", "regions of several coordinates")
    if not (0 < decay_fraction <= 1):
        raise ModelError("decay_fraction", "a number in (0, 1]", repr(decay_fraction))
    regions = [SchedulingRegion(r.coordinate, r.name, r.lo, r.hi, i) for i, r in enumerate(regions)]
    lmi = design_lmi(system, condition, gain_bound=gain_bound, scaling=scaling)
    per = []
    guess = None
    for reg in regions:
        b = jacobian_bounds(system, reg)
        dr = lmi.max_decay(b, sigma_cap, guess=guess, known=min_decay)
        if not dr.solution.feasible:  # the polytopic search returns the failed zero-rate solve
            cert = lmi.certify(dr.solution) if lmi.gain_bound is None else None
            if cert is None or not cert.verify():
                from .farkas import verified_farkas

                cert = verified_farkas(lmi, f"the polytopic condition on {reg.name} at decay rate 0")
            if cert is None:
                raise SolverError(f"polytopic condition on {reg.name} in [{reg.lo:.6g}, {reg.hi:.6g}]", SOLVER,
                                  dr.solution.status, "no gain was found and no certificate of infeasibility verified: "
                                  "rescale the model or split the region")
            raise InfeasibleError(f"polytopic condition on {reg.name} in [{reg.lo:.6g}, {reg.hi:.6g}]", cert,
                                  "no constant gain with a quadratic Lyapunov function on this region"
                                  + ("" if lmi.gain_bound is None else f" within ||L||_2 <= {lmi.gain_bound:.4g}"))
        guess = dr.sigma_max if dr.sigma_max > 0 else None
        _log.info("switched design: region %s in [%.6g, %.6g], largest decay rate %.4g (%d LMI solves so far)", reg.name,
                  reg.lo, reg.hi, dr.sigma_max, COUNTERS.calls - calls0)
        # the solution at sigma_max also satisfies the LMI at the smaller design rate
        per.append((reg, b, dr, decay_fraction * dr.sigma_max, dr.solution))
    pairs = adjacent_pairs(regions)
    sigmas = [p[3] for p in per]
    P_scaled = [p[4].P_scaled for p in per]
    tau_fixed = dwell_time_fixed(P_scaled, sigmas, pairs)
    dwell_solves = 0
    if dwell and len(regions) > 1:
        search = DwellTimeLMI.compiled(system, len(regions), pairs, gain_bound=gain_bound, scaling=lmi.d,
                                       condition=condition)
        res = search.set_regions([p[1] for p in per], sigmas).search(tau_fixed, tau_fixed=tau_fixed)
        tau, Ps, Ls, mults, eigs = res.tau, res.P, res.L, res.multipliers, res.lmi_max_eig
        dwell_solves, min_pair = res.solves, res.min_pair_eig
    else:
        tau = tau_fixed
        Ps = [p[4].P_scaled / lmi.d[:, None] / lmi.d[None, :] for p in per]
        Ls = [p[4].L for p in per]
        mults = [getattr(p[4], "multiplier", None) for p in per]
        eigs = [p[4].lmi_max_eig for p in per]
        min_pair = float("nan")
    gains = tuple(RegionGain(reg, L, P, sigma, dr.sigma_max, dr.capped, float("nan") if m is None else float(np.min(m)),
                             float(e), b,
                             verified_rate(system, b, P, L), dr.log)
                  for (reg, b, dr, sigma, _), L, P, m, e in zip(per, Ls, Ps, mults, eigs))
    eps_req = dwell_g = None
    if max_rate is not None:
        eps_req = float(hysteresis_for_dwell(tau, max_rate))
        if overlap is not None:
            dwell_g = float(dwell_for_hysteresis(overlap, max_rate, regions))
    statuses = {st: n - statuses0.get(st, 0) for st, n in COUNTERS.statuses.items() if n - statuses0.get(st, 0)}
    counts = {"statuses": statuses, "clarabel_undecided": COUNTERS.primary_undecided - undecided0,
              "rescued_by": {s_: n - rescued0.get(s_, 0) for s_, n in COUNTERS.rescued.items() if n - rescued0.get(s_, 0)},
              "undecided": COUNTERS.undecided - none0}
    design = SwitchedDesign(system, k, gains, pairs, float(tau), float(tau_fixed), overlap,
                            None if max_rate is None else float(max_rate), eps_req, dwell_g, gain_bound,
                            COUNTERS.calls - calls0, time.perf_counter() - t0, dwell_solves, min_pair, counts,
                            bool(accept_unenforced_dwell))
    _log.info("switched design: %d regions, dwell time %.4g s (fixed-P %.4g s), %d LMI solves, %.3g s", len(regions),
              design.tau, design.tau_fixed, design.solves,
              time.perf_counter() - t0)
    if design.dwell_enforced is False and not accept_unenforced_dwell:
        raise DwellTimeError(design)
    for text in design.warnings:
        # 3: the caller of the verbose wrapper (hybobs_opt._logging.with_verbose)
        warnings.warn(text, DwellTimeWarning, stacklevel=3)
    return design
